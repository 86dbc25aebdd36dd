"""Free-space Stokes kernels (SPEC §5), without the ``1/8 pi``.

``G_ij = delta_ij / r + xh_i xh_j / r^3`` (Stokeslet) and ``T_ijk = -6 xh_i xh_j xh_k / r^5``
(stresslet), ``xh = x - x0``.  Vectors carry their Cartesian component on the leading axis.
"""

from __future__ import annotations

import numpy as np

__all__ = ["stokeslet", "stokeslet_apply", "stresslet", "stresslet_apply"]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("i...,i...->...", a, b)


def stokeslet(xh: np.ndarray) -> np.ndarray:
    """``G_ij(xh)`` as an array (3, 3, ...)."""
    r2 = _dot(xh, xh)
    r = np.sqrt(r2)
    return np.eye(3).reshape(3, 3, *([1] * (xh.ndim - 1))) / r + np.einsum(
        "i...,j...->ij...", xh, xh
    ) / (r2 * r)


def stokeslet_apply(xh: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``G(xh) f`` pointwise: ``f / r + xh (xh . f) / r^3``."""
    r2 = _dot(xh, xh)
    r = np.sqrt(r2)
    return f / r + xh * (_dot(xh, f) / (r2 * r))


def stresslet(xh: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``T_ijk(xh) n_k`` as an array (3, 3, ...)."""
    r2 = _dot(xh, xh)
    return -6.0 * np.einsum("i...,j...->ij...", xh, xh) * (_dot(xh, n) / (r2 * r2 * np.sqrt(r2)))


def stresslet_apply(xh: np.ndarray, n: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``u_i T_ijk n_k`` pointwise (the double-layer integrand, symmetric in i, j)."""
    r2 = _dot(xh, xh)
    return -6.0 * xh * (_dot(xh, u) * _dot(xh, n) / (r2 * r2 * np.sqrt(r2)))
