"""The default backend: the fused compiled kernels of :mod:`..fused` (Numba)."""

from __future__ import annotations

import numpy as np

from vesicle.stokes.backends.registry import register_backend
from vesicle.stokes.fused import ring_components, scatter_rows
from vesicle.stokes.kernels import PAIRS

__all__ = ["assemble_ring_numba"]


@register_backend("numba")
def assemble_ring_numba(quad, shape, i: int, kinds: tuple[str, ...], out: dict) -> None:
    """Rows of ring ``i`` (see :mod:`.registry`): one fused pass for geometry and kernels, the
    BLAS pull-back, and a fused scatter that applies the z-phase."""
    r, rt, rp = quad.ring_radius(i, shape.coefficients)
    comps, subtraction = ring_components(
        r, rt, rp, quad.ring_frame(i), quad.inv_sin_rot, quad.weights_rot,
        shape.grid.phi, shape.x[:, i], kinds,
    )  # fmt: skip
    re, im = quad.pull_back_unphased(i, comps)
    cos, sin = quad.phase_parts
    for k, kind in enumerate(kinds):
        scatter_rows(re, im, cos, sin, out[kind], i, len(PAIRS) * k)
    if subtraction is not None:
        out["double_diagonal"][i] = subtraction - 4.0 * np.pi * np.eye(3)
