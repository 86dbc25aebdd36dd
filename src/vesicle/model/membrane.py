"""Membrane mechanics on a shape: Helfrich bending and tension forces, energies (SPEC §4).

Forces are per unit area, pointing as the load the membrane exerts on the fluid jump
``[f]`` of the boundary integral equation; both are first variations of the energy
``W = int 2 kappa H^2 dA + int sigma dA``: ``delta W = int f . delta x dA``.
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape

#: Relative size below which spectral coefficients of ``H`` are treated as rounding noise.
NOISE_FLOOR = 256.0 * np.finfo(float).eps

__all__ = [
    "NOISE_FLOOR",
    "bending_energy",
    "bending_force",
    "membrane_force",
    "tension_energy",
    "tension_force",
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
