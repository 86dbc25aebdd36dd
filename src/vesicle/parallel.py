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
    from distributed import LocalCluster  # ~1 s to import: only here

    env = {"VESICLE_THREADS": os.environ.get("VESICLE_THREADS", "1")}
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


def _log_level(name: str, level: int) -> None:
    """On a worker: ``name``'s logger at ``level`` (its records then reach the forwarding)."""
    logging.getLogger(name).setLevel(level)


def forward_worker_logs(client, name: str = "vesicle") -> bool:
    """With ``name``'s logger at INFO or below in this process (``vesicle --verbose``), the
    workers' records of it at that level are sent here and logged as this process's are: the
    progress of a neutral curve or a run on a worker (each curve point, each search step) shows
    on the command's stderr.  At the default level nothing changes (a worker's warnings reach
    its stderr, which a LocalCluster's workers share with the command).  Workers that join
    later keep their default level.  Whether it forwards."""
    level = logging.getLogger(name).getEffectiveLevel()
    if level > logging.INFO:
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
