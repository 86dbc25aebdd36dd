"""The NumPy reference backend: rotated geometry, then the kernels of :mod:`..kernels`."""

from __future__ import annotations

import numpy as np

from vesicle.stokes.backends.registry import register_backend
from vesicle.stokes.kernels import PAIRS, stokeslet_pairs, stresslet_factor, stresslet_pairs

__all__ = ["assemble_ring_numpy", "ring_components_numpy"]


def ring_components_numpy(quad, shape, i: int, kinds: tuple[str, ...]):
    """Kernel components of ``kinds`` at ring ``i``'s rotated nodes, (Q, 6 per kind, K), and the
    double layer's subtraction diagonal ``-sum_q T n w J`` (K, 3, 3) if requested."""
    g = quad.ring_geometry(i, shape.coefficients, shape.x[:, i])
    inv_r = g.inv_r
    parts = []
    subtraction = None
    for kind in kinds:
        if kind == "single":
            parts.append(stokeslet_pairs(g.xh, g.weight, inv_r))
        else:
            factor = stresslet_factor(g.xh, g.normal_weighted, inv_r)
            parts.append(stresslet_pairs(g.xh, factor))
            subtraction = -np.einsum("qk,iqk,jqk->kij", factor, g.xh, g.xh)
    return np.concatenate(parts, axis=1), subtraction


@register_backend("numpy")
def assemble_ring_numpy(quad, shape, i: int, kinds: tuple[str, ...], out: dict) -> None:
    """Rows of ring ``i`` (see :mod:`.registry`) by NumPy products and the BLAS pull-back."""
    comps, subtraction = ring_components_numpy(quad, shape, i, kinds)
    rows = quad.pull_back(i, comps)  # (2, ntri, 6 per kind, K)
    for k, kind in enumerate(kinds):
        block = out[kind][:, :, :, :, i]  # (3 [density], 2, ntri, 3 [out], K)
        for p, (a, b) in enumerate(PAIRS):
            block[b, :, :, a] = rows[:, :, p + k * len(PAIRS)]
            block[a, :, :, b] = rows[:, :, p + k * len(PAIRS)]
    if subtraction is not None:
        out["double_diagonal"][i] = subtraction - 4.0 * np.pi * np.eye(3)
