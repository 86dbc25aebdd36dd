"""BLAS thread limits that do not rescan the process's libraries at every call.

``threadpoolctl.threadpool_limits`` builds a new ``ThreadpoolController`` each time, which reads
``/proc/self/maps`` and inspects every loaded library: in a sweep worker that was 6 % of a
branch point's samples (py-spy, 2026-12-03), as the assembly and the solves set limits
thousands of times.  One controller per process serves every call; it is made at the first
call, after NumPy and SciPy have loaded their BLAS.
"""

from __future__ import annotations

from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads"]


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def blas_threads(limit: int):
    """A context manager: the BLAS libraries limited to ``limit`` threads inside it."""
    return _controller().limit(limits=int(limit), user_api="blas")
