"""Membrane mechanics on a shape: Helfrich bending and tension forces, energies (SPEC §4).

Forces are per unit area, pointing as the load the membrane exerts on the fluid jump
``[f]`` of the boundary integral equation; both are first variations of the energy
``W = int 2 kappa H^2 dA + int sigma dA``: ``delta W = int f . delta x dA``.

The membrane's viscous load (SPEC §17, docs/reference/membrane-viscosity.md) is the first
variation of its dissipation in the same sense: with the surface rate of strain
``D_s(u) = 1/2 (G P + (G P)^T)``, ``G = a^b (x) du/dxi^b`` (so ``P G = G``), the load
``f_eta = -2 Bq div_s D_s(u)`` satisfies ``int f_eta . w dA = int 2 Bq D_s(u) : D_s(w) dA`` for
every surface field ``w`` (integration by parts on the closed surface; ``D_s`` is tangential and
symmetric).  It is linear in ``u``; its sign is that of ``f_sigma = -div_s (sigma P)``.
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.sphere.transforms import transform

#: Relative size below which spectral coefficients of ``H`` are treated as rounding noise.
NOISE_FLOOR = 256.0 * np.finfo(float).eps

__all__ = [
    "NOISE_FLOOR",
    "bending_energy",
    "bending_force",
    "component_strain",
    "membrane_dissipation",
    "membrane_force",
    "rate_of_strain",
    "strain_divergence",
    "tension_energy",
    "tension_force",
    "viscous_force",
    "viscous_force_reference",
]


def bending_energy(shape: Shape, kappa: float = 1.0) -> float:
    """Helfrich energy ``int 2 kappa H^2 dA`` (a sphere gives ``8 pi kappa``)."""
    return shape.bending_energy(kappa)


def bending_force(shape: Shape, kappa: float = 1.0) -> np.ndarray:
    """``f_B = 2 kappa [2 H (H^2 - K) + Lap_s H] n``, shape (3, n_theta, n_phi).

    ``Lap_s H`` is computed spectrally from ``H`` on the shape's grid, so the grid must be
    much finer than the shape's degree (SPEC §2): the force's spectrum is wide.

    Notes
    -----
    The Laplace–Beltrami operator amplifies a degree-``l`` component by up to ``~l^4`` near the
    poles (second theta derivatives of high-degree, low-order harmonics), so the rounding noise of
    ``H`` (``~1e-16``) would reach ``~1e-11`` on a 32 x 64 grid.  Coefficients of ``H`` below
    ``NOISE_FLOOR`` times its largest coefficient carry only that noise and are dropped before
    differentiating; the force changes by less than the rounding of ``H`` itself.
    """
    H, K = shape.mean_curvature, shape.gaussian_curvature
    lap = shape.laplace_beltrami(H, noise_floor=NOISE_FLOOR)
    return 2.0 * kappa * (2.0 * H * (H * H - K) + lap) * shape.normal


def tension_force(shape: Shape, sigma: np.ndarray) -> np.ndarray:
    """``f_sigma = -2 H sigma n - grad_s sigma`` for a tension field ``sigma`` on the grid."""
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), shape.grid.shape)
    return -2.0 * shape.mean_curvature * sigma * shape.normal - shape.surface_gradient(sigma)


def tension_energy(shape: Shape, sigma: np.ndarray) -> float:
    """``int sigma dA`` with ``sigma`` attached to the material (grid) points."""
    return float(shape.integrate(np.broadcast_to(sigma, shape.grid.shape)))


def membrane_force(shape: Shape, sigma: np.ndarray, kappa: float = 1.0) -> np.ndarray:
    """Total membrane load ``[f] = f_B + f_sigma``."""
    return bending_force(shape, kappa) + tension_force(shape, sigma)


#: The six independent components of a symmetric 3x3 tensor, and each (i, j)'s index among them.
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
_INDEX = {**{p: k for k, p in enumerate(_PAIRS)}, **{p[::-1]: k for k, p in enumerate(_PAIRS)}}


def _projected_derivatives(shape: Shape, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``P du/dtheta`` and ``P du/dphi`` of velocities (..., 3, nt, np), spectrally."""
    T = transform(shape.grid.n_theta)
    dt, dp = T.gradient(T.analysis(u))
    n = shape.normal
    dt = dt - (dt * n).sum(axis=-3, keepdims=True) * n
    dp = dp - (dp * n).sum(axis=-3, keepdims=True) * n
    return dt, dp


def _strain_components(shape: Shape, u: np.ndarray) -> np.ndarray:
    """The six components :data:`_PAIRS` of ``D_s(u)``, (..., 6, nt, np):
    ``D_ij = 1/2 (a^b_i (P du/dxi^b)_j + a^b_j (P du/dxi^b)_i)``, since
    ``(G P)_ij = a^b_i (P du/dxi^b)_j``."""
    at, ap = shape.geometry.dual_tangents
    dt, dp = _projected_derivatives(shape, u)
    return np.stack([0.5 * (at[i] * dt[..., j, :, :] + ap[i] * dp[..., j, :, :]
                            + at[j] * dt[..., i, :, :] + ap[j] * dp[..., i, :, :])
                     for i, j in _PAIRS], axis=-3)  # fmt: skip


def rate_of_strain(shape: Shape, u: np.ndarray) -> np.ndarray:
    """The surface rate of strain ``D_s(u)`` of membrane velocities ``u`` (..., 3, nt, np),
    as (..., 3, 3, nt, np): ``1/2 (G P + (G P)^T)`` with ``G_ij = a^b_i du_j/dxi^b`` and
    ``P = I - n n``.  For ``u = u_t + u_n n`` it holds the ``u_n b`` term (from ``dn/dxi``);
    its trace is ``div_s u``; a rigid motion gives zero (to rounding)."""
    D = _strain_components(shape, u)
    return np.stack([np.stack([D[..., _INDEX[i, j], :, :] for j in range(3)], axis=-3)
                     for i in range(3)], axis=-4)  # fmt: skip


def component_strain(shape: Shape) -> np.ndarray:
    """``S`` (2, 3, 6, nt, np) with ``D_s(Y e_k) = S[0, k] dY/dtheta + S[1, k] dY/dphi`` (the six
    components :data:`_PAIRS`) for any scalar field ``Y``: ``S[b, k]_ij = 1/2 (a^b_i P_jk +
    a^b_j P_ik)``.  The viscous operator's matrix (:mod:`vesicle.solve.factorised`) is built from
    it without transforming each unit field's velocity."""
    at, ap = shape.geometry.dual_tangents
    n = shape.normal
    P = np.eye(3)[:, :, None, None] - n[:, None] * n[None, :]
    return np.array([[[0.5 * (a[i] * P[j, k] + a[j] * P[i, k]) for i, j in _PAIRS]
                      for k in range(3)] for a in (at, ap)])  # fmt: skip


def strain_divergence(shape: Shape, D: np.ndarray) -> np.ndarray:
    """``-2 div_s D`` of symmetric tensors given by their six components (..., 6, nt, np):
    ``(div_s D)_j = a^b_i dD_ij/dxi^b``, the components analysed and differentiated once."""
    T = transform(shape.grid.n_theta)
    at, ap = shape.geometry.dual_tangents
    Dt, Dp = T.gradient(T.analysis(D))
    div = np.stack([sum(at[i] * Dt[..., _INDEX[i, j], :, :] + ap[i] * Dp[..., _INDEX[i, j], :, :]
                        for i in range(3)) for j in range(3)], axis=-3)  # fmt: skip
    return -2.0 * div


def viscous_force(shape: Shape, u: np.ndarray, bq: float = 1.0) -> np.ndarray:
    """The membrane's viscous load ``f_eta = -2 Bq div_s D_s(u)`` for velocities ``u``
    (..., 3, nt, np) (module notes; SPEC §17), with ``(div_s D)_j = a^b_i dD_ij/dxi^b``: the six
    components of ``D_s`` analysed and differentiated once.  On a unit sphere a tangential
    divergence-free field of degree ``l`` gives ``Bq (l - 1)(l + 2) u``.
    :func:`viscous_force_reference` is the same with the whole tensor and ``einsum``."""
    return bq * strain_divergence(shape, _strain_components(shape, u))


def viscous_force_reference(shape: Shape, u: np.ndarray, bq: float = 1.0) -> np.ndarray:
    """:func:`viscous_force` written plainly: ``G``, ``G P``, the full ``D_s`` and its
    divergence by ``einsum`` over all nine components (three times slower)."""
    T = transform(shape.grid.n_theta)
    dt, dp = T.gradient(T.analysis(u))
    at, ap = shape.geometry.dual_tangents
    n = shape.normal
    G = at[:, None] * dt[..., None, :, :, :] + ap[:, None] * dp[..., None, :, :, :]
    Gn = np.einsum("...ijtp,jtp->...itp", G, n)
    GP = G - Gn[..., :, None, :, :] * n[None]
    D = 0.5 * (GP + np.swapaxes(GP, -4, -3))
    Dt, Dp = T.gradient(T.analysis(D))
    div = np.einsum("itp,...ijtp->...jtp", at, Dt) + np.einsum("itp,...ijtp->...jtp", ap, Dp)
    return (-2.0 * bq) * div


def membrane_dissipation(shape: Shape, u: np.ndarray, bq: float = 1.0) -> float:
    """``int 2 Bq D_s(u) : D_s(u) dA``, the power the membrane's viscosity dissipates."""
    D = _strain_components(shape, u)
    weights = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])  # off-diagonal pairs count twice
    return float(2.0 * bq * shape.integrate(np.einsum("k,ktp,ktp->tp", weights, D, D)))
