"""Free-space Stokes kernels (SPEC §5), without the ``1/8 pi``: the one definition.

``G_ij = delta_ij / r + xh_i xh_j / r^3`` (Stokeslet) and ``T_ijk = -6 xh_i xh_j xh_k / r^5``
(stresslet), ``xh = x - x0``.  Vectors carry their Cartesian component on the leading axis.

Every use in the package comes from here: the pointwise applies (matrix-free layer potentials,
off-surface evaluation), the full tensors (tests) and the six symmetric components that the
NumPy reference assembly stores (:func:`stokeslet_pairs`, :func:`stresslet_factor`).  The fused
Numba kernels of :mod:`.fused` write the same formulas in compiled loops and are tested against
these.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "PAIRS",
    "inverse_distance",
    "stokeslet",
    "stokeslet_apply",
    "stokeslet_pairs",
    "stresslet",
    "stresslet_apply",
    "stresslet_factor",
    "stresslet_pairs",
]

#: The six stored components ``(a, b)``, ``a <= b``, of a symmetric 3x3 kernel, in their order.
PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("i...,i...->...", a, b)


def inverse_distance(xh: np.ndarray) -> np.ndarray:
    """``1 / |xh|``."""
    return 1.0 / np.sqrt(_dot(xh, xh))


def stokeslet_apply(xh: np.ndarray, f: np.ndarray, inv_r: np.ndarray | None = None) -> np.ndarray:
    """``G(xh) f`` pointwise: ``f / r + xh (xh . f) / r^3``."""
    inv_r = inverse_distance(xh) if inv_r is None else inv_r
    return f * inv_r + xh * (_dot(xh, f) * inv_r**3)


def stresslet_factor(xh: np.ndarray, n: np.ndarray, inv_r: np.ndarray | None = None) -> np.ndarray:
    """``-6 (xh . n) / r^5``, so that ``T_ijk n_k = factor * xh_i xh_j``."""
    inv_r = inverse_distance(xh) if inv_r is None else inv_r
    return -6.0 * _dot(xh, n) * inv_r**5


def stresslet_apply(
    xh: np.ndarray, n: np.ndarray, u: np.ndarray, inv_r: np.ndarray | None = None
) -> np.ndarray:
    """``u_i T_ijk n_k`` pointwise (the double-layer integrand, symmetric in i, j)."""
    return xh * (stresslet_factor(xh, n, inv_r) * _dot(xh, u))


def stokeslet(xh: np.ndarray) -> np.ndarray:
    """``G_ij(xh)`` as an array (3, 3, ...)."""
    inv_r = inverse_distance(xh)
    eye = np.eye(3).reshape(3, 3, *([1] * (xh.ndim - 1)))
    return eye * inv_r + np.einsum("i...,j...->ij...", xh, xh) * inv_r**3


def stresslet(xh: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``T_ijk(xh) n_k`` as an array (3, 3, ...)."""
    return np.einsum("i...,j...->ij...", xh, xh) * stresslet_factor(xh, n)


def stokeslet_pairs(xh: np.ndarray, weight: np.ndarray, inv_r: np.ndarray) -> np.ndarray:
    """``weight * G_ab`` for the six :data:`PAIRS`, stacked on axis 1: (Q, 6, K) for (3, Q, K)."""
    a_scale, diag = weight * inv_r**3, weight * inv_r
    out = np.empty((xh.shape[1], len(PAIRS), *xh.shape[2:]))
    for p, (a, b) in enumerate(PAIRS):
        out[:, p] = a_scale * (xh[a] * xh[b])
        if a == b:
            out[:, p] += diag
    return out


def stresslet_pairs(xh: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """``factor * xh_a xh_b`` for the six :data:`PAIRS`, (Q, 6, K)."""
    out = np.empty((xh.shape[1], len(PAIRS), *xh.shape[2:]))
    for p, (a, b) in enumerate(PAIRS):
        out[:, p] = factor * (xh[a] * xh[b])
    return out
