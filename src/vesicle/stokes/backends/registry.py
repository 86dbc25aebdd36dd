"""The registry of layer-potential assembly backends: the one dispatch point.

A backend computes the rows of the assembled operators for the targets of one latitude ring.
It is a callable

    assemble_ring(quad, shape, ring, kinds, out) -> None

with ``quad`` the :class:`~vesicle.stokes.quadrature.SingularQuadrature`, ``shape`` the
:class:`~vesicle.geometry.surface.Shape`, ``kinds`` a tuple of ``"single"`` / ``"double"`` and
``out`` the
preallocated transposed matrices ``out[kind]`` of shape (3 [density], 2 [Re, Im], T, 3 [output],
rings, K) and, with the double layer, ``out["double_diagonal"]`` (rings, K, 3, 3), the singularity
subtraction's diagonal ``-sum_q T n w J - 4 pi I``.

A new backend (a GPU array library, say) is one module that decorates its function with
:func:`register_backend` and a test that holds it to the ``"numpy"`` reference.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["BACKENDS", "get_backend", "register_backend"]

#: Backends by name, in registration order (the reference first).
BACKENDS: dict[str, Callable] = {}


def register_backend(name: str) -> Callable[[Callable], Callable]:
    """Register ``assemble_ring`` under ``name``."""

    def wrap(fn: Callable) -> Callable:
        if name in BACKENDS:
            raise ValueError(f"backend {name!r} is already registered")
        BACKENDS[name] = fn
        return fn

    return wrap


def get_backend(name: str) -> Callable:
    """The registered ``assemble_ring`` of ``name``, or a ``ValueError`` naming the choices."""
    try:
        return BACKENDS[name]
    except KeyError:
        raise ValueError(f"backend must be one of {tuple(BACKENDS)}, got {name!r}") from None
