"""Executors for independent evaluations (Jacobian columns now, sweep points later).

Library functions take any :class:`concurrent.futures.Executor` (``executor=``) and map
module-level functions over it, so results do not depend on where they ran.  :func:`executor`
makes one from command-line choices:

- ``workers = 1`` and no scheduler: ``None`` (serial);
- ``workers > 1``: a local process pool;
- ``scheduler = "local"``: a Dask ``LocalCluster`` of ``workers`` processes with one thread each
  (BLAS stays on one thread per process), started here and closed on exit;
- ``scheduler = "tcp://host:port"``: an existing Dask scheduler (e.g. one started by
  dask-jobqueue on SLURM/PBS, see docs/architecture.md); ``workers`` is then the cluster's
  business.

A Dask client's executor is a ``concurrent.futures.Executor``; the code path is the same on a
laptop and on a cluster.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager

__all__ = [
    "ONE_THREAD_GRID",
    "close_cluster",
    "executor",
    "forward_worker_logs",
    "grid_threads",
    "keep_freed_memory",
    "keeping_memory",
    "local_cluster",
    "threads_from_environment",
]

log = logging.getLogger(__name__)


#: Grids with at most this many latitudes get one assembly thread by default (:func:`grid_threads`).
ONE_THREAD_GRID = 16


def threads_from_environment() -> int | None:
    """``VESICLE_THREADS`` (assembly threads per process), or ``None`` when unset: the one place
    the package reads it.  The sweep engine's workers have it set to 1 (a process per core,
    :func:`local_cluster`); set it on your own cluster's workers for the same.  It is read when a
    :class:`~vesicle.model.parameters.Discretisation` without ``workers`` gives the layer
    potentials their options (:meth:`~vesicle.model.parameters.Discretisation.assembly_threads`),
    in the process that assembles."""
    text = os.environ.get("VESICLE_THREADS", "").strip()
    if not text:
        return None
    try:
        return max(1, int(text))
    except ValueError:
        raise ValueError(f"VESICLE_THREADS must be a whole number, got {text!r}") from None


def grid_threads(n_theta: int | None = None) -> int:
    """The default assembly threads of a grid: one on grids of at most :data:`ONE_THREAD_GRID`
    latitudes, the cores (at most 2) on finer ones.

    Measured on this 2-core machine, alone (docs/reference/performance.md): ``vesicle neutral
    --v 0.98 --degree 4 --grid 16`` (13 chi) 36 s on one thread against 80 s on two, where a
    single ``vesicle tt --stability`` at the same resolution takes 2.5 s either way; at N = 6
    on 24x48 that state takes 6.0 s on two threads against 7.1 s on one, at N = 8 on 32x64
    17 s against 24 s, and a short N = 8 neutral curve 85 s against 93 s."""
    if n_theta is not None and n_theta <= ONE_THREAD_GRID:
        return 1
    return max(1, min(2, os.cpu_count() or 1))


def local_cluster(workers: int):
    """A Dask ``LocalCluster`` of ``workers`` one-thread processes, each assembling its layer
    potentials on one thread (``VESICLE_THREADS=1`` in their environment unless this process
    sets it): a process per core.  Two ring threads in each of two workers on two cores made
    every sweep point about 2x slower (measured 2026-12-03: 30 s against 14.4 s a branch of the
    quick ``stress-split``; ``python benchmarks/run.py dask``)."""
    import dask
    from distributed import LocalCluster  # ~1 s to import: only here

    env = {"VESICLE_THREADS": os.environ.get("VESICLE_THREADS", "1")}
    spawn = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    if keeping_memory():  # glibc reads these at a process's start (keep_freed_memory)
        spawn.update(KEEP_MEMORY_ENVIRON)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": spawn}):
        return LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                            dashboard_address=None, env=env)  # fmt: skip


def close_cluster(cluster) -> None:
    """Close a cluster of :func:`local_cluster` without the nannies' warnings: at the end of a
    command its workers may still be finishing a cancelled task (Python cannot interrupt a
    running function), and a nanny then warns "Worker process still alive ..., killing" before
    it does what closing asks.  That is the intended end, not news for the user."""
    nanny = logging.getLogger("distributed.nanny")
    level = nanny.level
    nanny.setLevel(logging.ERROR)
    try:
        cluster.close()
    finally:
        nanny.setLevel(level)


#: glibc ``mallopt`` parameters (malloc.h) and the values :func:`keep_freed_memory` gives them:
#: no ``mmap`` for large blocks, the heap trimmed only above 2 GiB - 1 free at its top (the
#: most ``mallopt`` takes), one arena for all threads (a thread's own arena maps its large
#: blocks whatever the other two say).
KEEP_MEMORY = {"M_MMAP_MAX": (-4, 0), "M_TRIM_THRESHOLD": (-1, 2**31 - 1), "M_ARENA_MAX": (-8, 1)}
#: The same as glibc's environment variables, which take effect from a process's start: what a
#: :func:`local_cluster`'s nannies set before they start their workers.
KEEP_MEMORY_ENVIRON = {"MALLOC_MMAP_MAX_": "0", "MALLOC_TRIM_THRESHOLD_": str(2**31 - 1),
                       "MALLOC_ARENA_MAX": "1"}  # fmt: skip


def keeping_memory() -> bool:
    """Whether the package sets the allocator to keep freed memory (:func:`keep_freed_memory`):
    unless ``VESICLE_KEEP_MEMORY=0``."""
    return os.environ.get("VESICLE_KEEP_MEMORY", "1").strip() != "0"


def keep_freed_memory() -> bool:
    """Let this process's C allocator (glibc's malloc) keep the memory it frees for the next
    allocations, instead of handing it back to the system (:data:`KEEP_MEMORY`).

    Every new page the system gives a process is zeroed first.  A steady state at N = 8 on
    32x64 allocates and frees its large arrays (operators of hundreds of MB) many times over,
    and on this machine the zeroing took as long as the arithmetic: ``vesicle tt --stability``
    at N = 8 on 32x64 spent 19-27 s in the kernel beside 29 s of its own, most of it clearing
    pages (``perf``), and on a Dask worker, whose nanny has glibc hand back any 64 kB it can
    (``MALLOC_TRIM_THRESHOLD_=65536``), 28-35 s in 3.3-3.5 million page faults; kept, 0.6 s
    from its second state on (docs/reference/performance.md, *Memory the allocator keeps*).
    A process then keeps its peak memory until it ends, and the peak grows a little (that
    state: 2.03 against 1.98 GB).

    It applies to allocations made after the call, in threads that have not allocated yet
    (one arena): the command line calls it first thing.  A Dask worker has its threads
    running before any code of ours, and called there it changed nothing (measured); so
    :func:`local_cluster`'s workers get it from their start instead
    (:data:`KEEP_MEMORY_ENVIRON` in their nannies' ``pre-spawn-environ``), and a cluster of
    your own gets it the same way (docs/howto/sweeps.md, *On a cluster*).
    ``VESICLE_KEEP_MEMORY=0`` leaves the allocator as it is (the reference).  Elsewhere than
    on glibc, nothing changes.  Whether it applied."""
    if not keeping_memory():
        return False
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c")).mallopt
    except (OSError, AttributeError, TypeError):  # not glibc (macOS, musl, Windows)
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return all([bool(mallopt(param, value)) for param, value in KEEP_MEMORY.values()])


def _log_level(name: str, level: int) -> None:
    """On a worker: ``name``'s logger at ``level`` (its records then reach the forwarding)."""
    logging.getLogger(name).setLevel(level)


#: Whether :func:`forward_worker_logs` forwards in this process (see
#: :func:`set_worker_log_forwarding`).
_FORWARDING = {"enabled": True}


def set_worker_log_forwarding(enabled: bool) -> None:
    """Whether this process's clients forward the workers' records (:func:`forward_worker_logs`).

    Every client that forwards receives every worker's records: the scheduler sends them to all
    its subscribers.  A process that shares a cluster with others that drive their own work
    (the items of the concurrent ``vesicle paper``) turns it off, and the process that owns the
    cluster forwards once for all; else each record showed once per item, named by each."""
    _FORWARDING["enabled"] = bool(enabled)


def forward_worker_logs(client, name: str = "vesicle") -> bool:
    """With ``name``'s logger at INFO or below in this process (``vesicle --verbose``), the
    workers' records of it at that level are sent here and logged as this process's are: the
    progress of a neutral curve or a run on a worker (each curve point, each search step) shows
    on the command's stderr.  At the default level nothing changes (a worker's warnings reach
    its stderr, which a LocalCluster's workers share with the command), nor where this process
    has turned forwarding off (:func:`set_worker_log_forwarding`).  Workers that join later
    keep their default level.  Whether it forwards."""
    level = logging.getLogger(name).getEffectiveLevel()
    if level > logging.INFO or not _FORWARDING["enabled"]:
        return False
    try:
        client.run(_log_level, name, level)
        client.forward_logging(name, level=level)
    except Exception as err:  # an old distributed, or a worker gone: the work goes on
        log.info("the workers' log records stay on the workers (%s)", err)
        return False
    return True


@contextmanager
def executor(workers: int = 1, scheduler: str | None = None) -> Iterator[Executor | None]:
    """An executor for ``workers`` local processes or a Dask ``scheduler`` (see module doc)."""
    if int(workers) < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if scheduler is None:
        if workers == 1:
            yield None
            return
        with ProcessPoolExecutor(int(workers)) as pool:
            yield pool
        return
    # distributed is imported only when asked for: it costs ~1 s at start-up
    from distributed import Client

    if scheduler == "local":
        cluster = local_cluster(int(workers))
        log.info("started a Dask LocalCluster of %d workers", workers)
        try:
            with Client(cluster) as client:
                forward_worker_logs(client)
                yield client.get_executor()
        finally:
            close_cluster(cluster)
        return
    with Client(scheduler) as client:
        log.info("connected to the Dask scheduler at %s", scheduler)
        forward_worker_logs(client)
        yield client.get_executor()
