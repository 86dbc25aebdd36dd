"""Layer-potential assembly backends behind one registry (see :mod:`.registry`)."""

from vesicle.stokes.backends import numba_backend, numpy_backend  # noqa: F401  (register the backends)
from vesicle.stokes.backends.registry import BACKENDS, get_backend, register_backend

__all__ = ["BACKENDS", "get_backend", "register_backend"]
