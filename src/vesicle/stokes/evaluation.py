"""Layer potentials at points off the surface (flow fields for figures and diagnostics).

The smooth quadrature of the grid (Gauss–Legendre x trapezoid, weights ``w J``) is spectrally
accurate for targets well away from the surface; near it the kernel's peak is under-resolved and
the error grows like ``exp(-c d / h)`` with ``d`` the distance and ``h`` the grid spacing.
``upsample`` interpolates density and shape spectrally onto a finer grid first, which moves the
accuracy boundary proportionally closer.  Measured on a unit sphere at 32 x 64 (see
``docs/reference/layer-potentials.md``).
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.sphere.transforms import resize, transform
from vesicle.stokes.kernels import stokeslet_apply, stresslet_apply

__all__ = ["evaluate_double_layer", "evaluate_single_layer"]

_CHUNK = 256  # targets per batch: bounds the (3, chunk, n_theta * n_phi) temporaries


def _upsampled(shape: Shape, density: np.ndarray, factor: float) -> tuple[Shape, np.ndarray]:
    density = np.asarray(density, dtype=float)
    if density.shape != (3, *shape.grid.shape):
        raise ValueError(f"density must have shape (3, {shape.grid.n_theta}, {shape.grid.n_phi})")
    if factor == 1:
        return shape, density
    n_up = int(np.ceil(factor * shape.grid.n_theta))
    c = transform(shape.grid.n_theta).analysis(density)
    fine = shape.with_grid(n_up)
    return fine, transform(n_up).synthesis(resize(c, n_up - 1))


def _points(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim < 1 or p.shape[0] != 3 or not np.all(np.isfinite(p)):
        raise ValueError("points must be a finite array of shape (3, ...)")
    return p.reshape(3, -1)


def _evaluate(shape, density, points, upsample, integrand) -> np.ndarray:
    shape, density = _upsampled(shape, density, upsample)
    p = _points(points)
    wj = (shape.grid.weights * shape.area_element).ravel()
    x = shape.x.reshape(3, -1)
    n = shape.normal.reshape(3, -1)
    psi = density.reshape(3, -1)
    out = np.empty((3, p.shape[1]))
    for start in range(0, p.shape[1], _CHUNK):
        x0 = p[:, start : start + _CHUNK]
        xh = x[:, None, :] - x0[:, :, None]
        out[:, start : start + _CHUNK] = np.sum(
            integrand(xh, n[:, None], psi[:, None]) * wj, axis=-1
        )
    return out.reshape(np.shape(points))


def evaluate_single_layer(
    shape: Shape, f: np.ndarray, points: np.ndarray, upsample: float = 2
) -> np.ndarray:
    """``N[f](x0) = int G(x - x0) f dA`` at off-surface ``points`` (3, ...), no ``1/8 pi``."""
    return _evaluate(shape, f, points, upsample, lambda xh, n, f: stokeslet_apply(xh, f))


def evaluate_double_layer(
    shape: Shape, u: np.ndarray, points: np.ndarray, upsample: float = 2
) -> np.ndarray:
    """``K[u](x0) = int u_i T_ijk n_k dA`` at off-surface ``points`` (3, ...), no ``1/8 pi``.

    For a constant ``u = c`` this is ``-8 pi c`` inside the surface and ``0`` outside.
    """
    return _evaluate(shape, u, points, upsample, stresslet_apply)
