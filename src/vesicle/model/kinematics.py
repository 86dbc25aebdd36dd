"""Shape kinematics shared by the time-dependent and the steady drivers (SPEC §7, §8).

- :func:`rate_of_change`: the filtered ``dr/dt`` of (2.18)-(2.19) for a membrane velocity;
- :func:`area_volume_variations`: the first variations of area and volume with respect to the
  radius, ``delta A = int -2H (n . e_r) delta r dA``, ``delta V = int (n . e_r) delta r dA``;
- :func:`constraint_gradients`: those variations integrated against basis functions (the
  Lagrange-multiplier columns of Newton and the constraint directions of stability).
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.sphere.transforms import transform

__all__ = ["area_volume_variations", "constraint_gradients", "rate_of_change"]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("i...,i...->...", a, b)


def rate_of_change(shape: Shape, u: np.ndarray, degree: int) -> np.ndarray:
    """Coefficients of ``dr/dt`` (2.18)-(2.19) at fixed grid directions, filtered to ``degree``:
    ``Dr/Dt - r_theta Dtheta/Dt - r_phi Dphi/Dt`` with ``Dr/Dt = e_r . u``,
    ``Dtheta/Dt = e_theta . u / r``, ``Dphi/Dt = e_phi . u / (r sin theta)``."""
    e_r, e_t, e_p = shape.grid.unit_vectors
    d = shape.radius_derivatives
    st = np.sin(shape.grid.theta)[:, None]
    r = d.f
    drdt = _dot(e_r, u) - d.t * _dot(e_t, u) / r - d.p * _dot(e_p, u) / (r * st)
    return transform(shape.grid.n_theta, degree).analysis(drdt)


def area_volume_variations(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """``-2 H (n . e_r)`` and ``n . e_r`` on the grid: ``delta A`` and ``delta V`` per unit
    ``delta r`` per unit area."""
    ner = _dot(shape.normal, shape.grid.unit_vectors[0])
    return -2.0 * shape.mean_curvature * ner, ner


def constraint_gradients(shape: Shape, functions: np.ndarray) -> np.ndarray:
    """``dA/da`` and ``dV/da`` (2, size) for ``r`` perturbed by ``sum_k a_k functions[k]``."""
    var_a, var_v = area_volume_variations(shape)
    return np.array([shape.integrate(var_a * functions), shape.integrate(var_v * functions)])
