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
    "membrane_dissipation",
    "membrane_force",
    "rate_of_strain",
    "tension_energy",
    "tension_force",
    "viscous_force",
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


def rate_of_strain(shape: Shape, u: np.ndarray) -> np.ndarray:
    """The surface rate of strain ``D_s(u)`` of membrane velocities ``u`` (..., 3, nt, np),
    as (..., 3, 3, nt, np): ``1/2 (G P + (G P)^T)`` with ``G_ij = a^b_i du_j/dxi^b`` and
    ``P = I - n n``.  For ``u = u_t + u_n n`` it holds the ``u_n b`` term (from ``dn/dxi``);
    its trace is ``div_s u``; a rigid motion gives zero (to rounding)."""
    T = transform(shape.grid.n_theta)
    dt, dp = T.gradient(T.analysis(u))  # (..., 3, nt, np): du_j/dtheta, du_j/dphi
    at, ap = shape.geometry.dual_tangents
    n = shape.normal
    G = at[:, None] * dt[..., None, :, :, :] + ap[:, None] * dp[..., None, :, :, :]
    Gn = np.einsum("...ijtp,jtp->...itp", G, n)
    GP = G - Gn[..., :, None, :, :] * n[None]
    return 0.5 * (GP + np.swapaxes(GP, -4, -3))


def _tensor_divergence(shape: Shape, D: np.ndarray) -> np.ndarray:
    """``(div_s D)_j = a^b_i dD_ij/dxi^b`` of tensor fields (..., 3, 3, nt, np)."""
    T = transform(shape.grid.n_theta)
    dt, dp = T.gradient(T.analysis(D))
    at, ap = shape.geometry.dual_tangents
    return np.einsum("itp,...ijtp->...jtp", at, dt) + np.einsum("itp,...ijtp->...jtp", ap, dp)


def viscous_force(shape: Shape, u: np.ndarray, bq: float = 1.0) -> np.ndarray:
    """The membrane's viscous load ``f_eta = -2 Bq div_s D_s(u)`` for velocities ``u``
    (..., 3, nt, np) (module notes; SPEC §17).  On a unit sphere a tangential divergence-free
    field of degree ``l`` gives ``Bq (l - 1)(l + 2) u``."""
    return (-2.0 * bq) * _tensor_divergence(shape, rate_of_strain(shape, u))


def membrane_dissipation(shape: Shape, u: np.ndarray, bq: float = 1.0) -> float:
    """``int 2 Bq D_s(u) : D_s(u) dA``, the power the membrane's viscosity dissipates."""
    D = rate_of_strain(shape, u)
    return float(2.0 * bq * shape.integrate(np.einsum("ijtp,ijtp->tp", D, D)))
