"""Eigenvalues on the unit sphere derived from SPEC §15: the Schur complement's symbol (the
solver's preconditioner) and the linear relaxation rates of shape modes (the ROS2 integrator's
approximate Jacobian).  Exact results, used by the solver and the integrator and tested against
the operators."""

from __future__ import annotations

import numpy as np

__all__ = ["schur_symbol", "sphere_mobility", "sphere_relaxation_rates", "viscous_symbol"]


def _layer_eigenvalues(lmax: int) -> tuple[np.ndarray, ...]:
    """Degrees ``l`` and SPEC §15's eigenvalues of ``N / (8 pi)`` and ``K / (8 pi)`` on ``W_l``
    and ``V_l`` of the unit sphere: ``l, n_w, n_v, k_w, k_v`` (``n_w = 0`` where ``W_0`` does not
    exist)."""
    l = np.arange(lmax + 1, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_w = np.where(l > 0, (l + 1) / ((2 * l - 1) * (2 * l + 1)), 0.0)
        n_v = l / ((2 * l + 1) * (2 * l + 3))
        k_w = -3.0 / (2 * (2 * l - 1) * (2 * l + 1))
        k_v = 3.0 / (2 * (2 * l + 1) * (2 * l + 3))
    return l, n_w, n_v, k_w, k_v


def _sphere_mobilities(lmax: int, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degrees ``l`` and the eigenvalues of ``A_uu^-1 N / (8 pi)`` on ``W_l`` and ``V_l`` of the
    unit sphere (SPEC §15); entries with no such field (``W_0``) are 0."""
    l, n_w, n_v, k_w, k_v = _layer_eigenvalues(lmax)
    with np.errstate(divide="ignore", invalid="ignore"):
        a_w = 0.5 * (1 + lam) - (1 - lam) * k_w
        a_v = 0.5 * (1 + lam) - (1 - lam) * k_v
        m_w = np.where(l > 0, n_w / a_w, 0.0)
    return l, m_w, n_v / a_v


def viscous_symbol(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """The membrane's viscous load ``V u = -2 div_s D_s(u)`` (SPEC §17) on the unit sphere:
    the 2x2 blocks ``E_l`` (lmax+1, 2, 2) acting on the coordinates of ``(W_l, V_l)`` and the
    eigenvalue on ``X_l``.

    With ``u = a Y n + b grad_s Y`` (``L = l(l+1)``), ``D_s = D_t(b grad_s Y) + a Y P`` and
    ``div_s (2 D_s) = 2 [a - (L - 1) b] grad_s Y + 2 [L b - 2 a] Y n``
    (docs/reference/membrane-viscosity.md), so ``V u = 2[(L-1) b - a] grad_s Y + 2[2 a - L b] Y n``.
    ``W_l`` is ``(a, b) = (l, 1)``, ``V_l`` is ``(-(l+1), 1)``; in their coordinates

        E_l = 2/(2l+1) [[(l-1)(l^2+l+1),  (l-1)(l+1)(l+2)],
                        [l(l-1)(l+2),     (l+2)(l^2+l+1) ]],

    and ``V X_l = (l-1)(l+2) X_l``.  A divergence-free field (``l W_l - ... ``: ``a = L b / 2``)
    gives ``V u = (l-1)(l+2) b grad_s Y``: tangential, the factor ``(l-1)(l+2)`` of the
    quasi-spherical theories; ``l = 1`` (rigid motions) gives zero.
    """
    l = np.arange(lmax + 1, dtype=float)
    q = l * l + l + 1
    E = np.empty((lmax + 1, 2, 2))
    E[:, 0, 0] = (l - 1) * q
    E[:, 0, 1] = (l - 1) * (l + 1) * (l + 2)
    E[:, 1, 0] = l * (l - 1) * (l + 2)
    E[:, 1, 1] = (l + 2) * q
    E *= (2.0 / (2 * l + 1))[:, None, None]
    return E, (l - 1) * (l + 2)


def sphere_operator_blocks(lmax: int, lam: float, bq: float) -> np.ndarray:
    """``A_uu = alpha - c K + Bq N V / (8 pi)`` on the unit sphere: its 2x2 blocks on the
    coordinates of ``(W_l, V_l)``, (lmax+1, 2, 2) (SPEC §15, §17).  ``W_0`` does not exist:
    its entries are placeholders."""
    _, n_w, n_v, k_w, k_v = _layer_eigenvalues(lmax)
    E, _ = viscous_symbol(lmax)
    A = np.zeros((lmax + 1, 2, 2))
    A[:, 0, 0] = 0.5 * (1 + lam) - (1 - lam) * k_w
    A[:, 1, 1] = 0.5 * (1 + lam) - (1 - lam) * k_v
    A += bq * np.stack([n_w, n_v], axis=1)[:, :, None] * E
    return A


def sphere_mobility(lmax: int, lam: float, bq: float = 0.0) -> np.ndarray:
    """``A_uu^-1 N / (8 pi)`` on the unit sphere in the coordinates of ``(W_l, V_l)``:
    (lmax+1, 2, 2), with ``A_uu = alpha - c K + Bq N V / (8 pi)`` (SPEC §15, §17).  Diagonal
    at ``Bq = 0`` (``_sphere_mobilities``); ``W_0`` does not exist (its row and column are 0)."""
    _, m_w, m_v = _sphere_mobilities(lmax, lam)
    out = np.zeros((lmax + 1, 2, 2))
    out[:, 0, 0], out[:, 1, 1] = m_w, m_v
    if bq == 0.0:
        return out
    A = sphere_operator_blocks(lmax, lam, bq)
    _, n_w, n_v, _, _ = _layer_eigenvalues(lmax)
    n = np.zeros((lmax + 1, 2, 2))
    n[:, 0, 0], n[:, 1, 1] = n_w, n_v
    A[0] = np.diag([1.0, A[0, 1, 1]])  # no W_0: keep the block invertible, then zero it
    out = np.linalg.solve(A, n)
    out[0, 0, :] = out[0, :, 0] = 0.0
    return out


def schur_symbol(lmax: int, lam: float, bq: float = 0.0) -> np.ndarray:
    """Eigenvalues ``s_l`` of the Schur complement ``A_su A_uu^-1 A_us`` on the unit sphere.

    A tension ``Y_l`` gives ``f_sigma = -(alpha W_l + beta V_l)`` with ``alpha = (l-1)/(2l+1)``,
    ``beta = (l+2)/(2l+1)``; ``N``, ``K`` act on ``W_l``, ``V_l`` by the eigenvalues of SPEC §15 and
    ``div_s W_l = -l(l-1) Y_l``, ``div_s V_l = -(l+1)(l+2) Y_l``.  ``s_0 = 0`` (uniform tension is
    pressure) and ``s_l ~ l / (2 (1 + lam))`` for large ``l``: an operator of order one, which is
    why the Schur GMRES is preconditioned by ``1/s_l``.
    """
    if bq != 0.0:  # the same with the 2x2 mobility blocks of a viscous membrane
        l = np.arange(lmax + 1, dtype=float)
        d = np.stack([l * (l - 1), (l + 1) * (l + 2)], axis=1)
        c = np.stack([l - 1, l + 2], axis=1) / (2 * l + 1)[:, None]
        s = np.einsum("li,lij,lj->l", d, sphere_mobility(lmax, lam, bq), c)
        s[0] = 0.0
        return s
    l, m_w, m_v = _sphere_mobilities(lmax, lam)
    s = ((l - 1) * m_w * l * (l - 1) + (l + 2) * m_v * (l + 1) * (l + 2)) / (2 * l + 1)
    s[0] = 0.0
    return s


def sphere_relaxation_rates(
    lmax: int, lam: float, sigma: float = 0.0, bq: float = 0.0
) -> np.ndarray:
    """Linear relaxation rates ``Gamma_l`` of shape modes of the unit sphere (bending ``kappa =
    1``, uniform tension ``sigma``): ``dr_lm/dt = -Gamma_l r_lm`` for ``r = 1 + eps Y_lm``.

    Derived from SPEC §15: the linearised load is ``F Y n`` with
    ``F = (l-1)(l+2)[l(l+1) + sigma]`` (bending ``L(L-2)``, tension ``-2 H sigma n`` with
    ``H = -1 + (L-2) eps Y / 2``, ``L = l(l+1)``); ``Y n = (W_l - V_l)/(2l+1)``; the tension
    perturbation ``tau Y`` is fixed by ``div_s u = 0``; ``Gamma_l = -u . n``.  ``Gamma_0 =
    Gamma_1 = 0`` (volume, translation).  For large ``l``, ``Gamma_l ~ l^3 / (2 (1 + lam))``:
    the bending stiffness that limits explicit time steps.  Used as the approximate Jacobian of
    the linearly implicit integrator (``vesicle.dynamics.integrators``); a negative ``sigma`` can
    make low modes grow (``Gamma_l < 0``), which is physical (buckling).
    """
    if bq != 0.0:
        return _viscous_relaxation_rates(lmax, lam, sigma, bq)
    l, m_w, m_v = _sphere_mobilities(lmax, lam)
    a, b = l * (l - 1), (l + 1) * (l + 2)
    F = (l - 1) * (l + 2) * (l * (l + 1) + sigma)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = F * (m_w * a - m_v * b) / (m_w * a * (l - 1) + m_v * b * (l + 2))
        u_n = (-m_w * l * (F - tau * (l - 1)) - m_v * (l + 1) * (F + tau * (l + 2))) / (2 * l + 1)
    gamma = -u_n
    gamma[: min(2, lmax + 1)] = 0.0
    return gamma


def _viscous_relaxation_rates(lmax: int, lam: float, sigma: float, bq: float) -> np.ndarray:
    """:func:`sphere_relaxation_rates` with a viscous membrane: the same load ``F Y n`` and
    tension ``tau Y``, the velocity ``u = -Mob f`` with the 2x2 mobility blocks of
    :func:`sphere_mobility`, ``tau`` fixed by ``div_s u = 0``, ``Gamma_l = -u . n``."""
    l = np.arange(lmax + 1, dtype=float)
    mob = sphere_mobility(lmax, lam, bq)
    F = (l - 1) * (l + 2) * (l * (l + 1) + sigma)
    load = np.stack([F, -F], axis=1) / (2 * l + 1)[:, None]  # F Y n = F (W - V)/(2l+1)
    tension = -np.stack([l - 1, l + 2], axis=1) / (2 * l + 1)[:, None]  # f_sigma of Y
    div = -np.stack([l * (l - 1), (l + 1) * (l + 2)], axis=1)  # div_s of W_l, V_l
    u_load = -np.einsum("lij,lj->li", mob, load)
    u_tension = -np.einsum("lij,lj->li", mob, tension)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = -np.einsum("li,li->l", div, u_load) / np.einsum("li,li->l", div, u_tension)
    u = u_load + tau[:, None] * u_tension
    normal = np.stack([l, -(l + 1)], axis=1)  # n . W_l = l Y, n . V_l = -(l+1) Y
    gamma = -np.einsum("li,li->l", normal, u)
    gamma[: min(2, lmax + 1)] = 0.0
    return gamma
