"""Eigenvalues on the unit sphere derived from SPEC §15: the Schur complement's symbol (the
solver's preconditioner) and the linear relaxation rates of shape modes (the ROS2 integrator's
approximate Jacobian).  Exact results, used by the solver and the integrator and tested against
the operators."""

from __future__ import annotations

import numpy as np

__all__ = ["schur_symbol", "sphere_relaxation_rates"]


def _sphere_mobilities(lmax: int, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degrees ``l`` and the eigenvalues of ``A_uu^-1 N / (8 pi)`` on ``W_l`` and ``V_l`` of the
    unit sphere (SPEC §15); entries with no such field (``W_0``) are 0."""
    l = np.arange(lmax + 1, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_w = np.where(l > 0, (l + 1) / ((2 * l - 1) * (2 * l + 1)), 0.0)
        n_v = l / ((2 * l + 1) * (2 * l + 3))
        k_w = -3.0 / (2 * (2 * l - 1) * (2 * l + 1))
        k_v = 3.0 / (2 * (2 * l + 1) * (2 * l + 3))
        a_w = 0.5 * (1 + lam) - (1 - lam) * k_w
        a_v = 0.5 * (1 + lam) - (1 - lam) * k_v
        m_w = np.where(l > 0, n_w / a_w, 0.0)
    return l, m_w, n_v / a_v


def schur_symbol(lmax: int, lam: float) -> np.ndarray:
    """Eigenvalues ``s_l`` of the Schur complement ``A_su A_uu^-1 A_us`` on the unit sphere.

    A tension ``Y_l`` gives ``f_sigma = -(alpha W_l + beta V_l)`` with ``alpha = (l-1)/(2l+1)``,
    ``beta = (l+2)/(2l+1)``; ``N``, ``K`` act on ``W_l``, ``V_l`` by the eigenvalues of SPEC §15 and
    ``div_s W_l = -l(l-1) Y_l``, ``div_s V_l = -(l+1)(l+2) Y_l``.  ``s_0 = 0`` (uniform tension is
    pressure) and ``s_l ~ l / (2 (1 + lam))`` for large ``l``: an operator of order one, which is
    why the Schur GMRES is preconditioned by ``1/s_l``.
    """
    l, m_w, m_v = _sphere_mobilities(lmax, lam)
    s = ((l - 1) * m_w * l * (l - 1) + (l + 2) * m_v * (l + 1) * (l + 2)) / (2 * l + 1)
    s[0] = 0.0
    return s


def sphere_relaxation_rates(lmax: int, lam: float, sigma: float = 0.0) -> np.ndarray:
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
    l, m_w, m_v = _sphere_mobilities(lmax, lam)
    a, b = l * (l - 1), (l + 1) * (l + 2)
    F = (l - 1) * (l + 2) * (l * (l + 1) + sigma)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = F * (m_w * a - m_v * b) / (m_w * a * (l - 1) + m_v * b * (l + 2))
        u_n = (-m_w * l * (F - tau * (l - 1)) - m_v * (l + 1) * (F + tau * (l + 2))) / (2 * l + 1)
    gamma = -u_n
    gamma[: min(2, lmax + 1)] = 0.0
    return gamma
