"""BLAS thread limits that do not rescan the process's libraries at every call.

``threadpoolctl.threadpool_limits`` builds a new ``ThreadpoolController`` each time, which reads
``/proc/self/maps`` and inspects every loaded library: in a sweep worker that was 6 % of a
branch point's samples (py-spy, 2026-12-03), as the assembly and the solves set limits
thousands of times.  One controller per process serves every call; it is made at the first
call, after NumPy and SciPy have loaded their BLAS.
"""

from __future__ import annotations

import os
from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads", "one_blas_thread"]


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def blas_threads(limit: int):
    """A context manager: the BLAS libraries limited to ``limit`` threads inside it."""
    return _controller().limit(limits=int(limit), user_api="blas")


#: The process-wide limit set by :func:`one_blas_thread` (kept: dropping it would restore).
_PROCESS_LIMIT: list = []


def one_blas_thread() -> None:
    """BLAS on one thread for the rest of the process (``VESICLE_BLAS_THREADS`` overrides:
    a number, or ``default`` to leave the library's own, the reference), except inside
    :func:`blas_threads` blocks that ask for more (the factorisations and batched solves, with
    the assembly's thread count).  The command line calls it at start: the many small
    products and solves elsewhere (at N = 4 matrices of a few hundred rows; the
    continuation's SVDs and eigenvalues) ran slower on two OpenBLAS threads than on one
    (docs/reference/performance.md).  Dask workers get one thread from their nanny's
    environment (``OPENBLAS_NUM_THREADS=1``)."""
    setting = os.environ.get("VESICLE_BLAS_THREADS", "1").strip().lower()
    if setting == "default" or _PROCESS_LIMIT:
        return
    try:
        limit = int(setting)
    except ValueError:
        raise ValueError(f"VESICLE_BLAS_THREADS must be a whole number or 'default', got "
                         f"{setting!r}") from None  # fmt: skip
    if limit < 1:
        raise ValueError(f"VESICLE_BLAS_THREADS must be at least 1, got {limit}")
    _PROCESS_LIMIT.append(_controller().limit(limits=limit, user_api="blas"))
