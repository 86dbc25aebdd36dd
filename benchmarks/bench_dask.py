"""Dask: finite-difference Jacobian columns and sweep points on a LocalCluster of 1 and 2 workers.

Same inputs, same run: the serial path, then a ``LocalCluster`` (one-thread worker processes) of
1 and 2 workers through the same code (``vesicle.parallel.executor``, ``vesicle.workflows.sweep``).
 The workers assemble on one ring thread each (``VESICLE_THREADS=1``, set by
``vesicle.parallel.local_cluster``); "2 ring threads each" is the reference it replaced.
Reported: wall times and the speed-up over serial (the cluster's start-up is included for the
sweep, as a user pays it; not for the Jacobian, timed twice on a running cluster: the first
Jacobian meets cold worker processes, the second the warm ones a Newton iteration meets).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

import vesicle as vs
from vesicle.parallel import executor
from vesicle.steady.newton import NEWTON_TOLERANCES, initial_guess
from vesicle.workflows.sweep import TASKS, read_sweep_config, run_sweep

#: Points whose default start converges directly (at lam = 3.5 and 4, chi = 1 on 16x32, Newton
#: diverges or lands on a state with a real unstable mode and `reach` continues from lam = 1:
#: such a point costs as much as the others together and would set the parallel time alone).
LAMS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)

SWEEP = """[sweep]
task = "stability"
out = "s.h5"
[grid]
v = [0.95]
lam = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
chi = [1.0]
[discretisation]
degree = 4
grid = 16
"""


def _jacobian(
    workers: int | None, degree=6, grid=24, threads: int | None = None
) -> tuple[float, np.ndarray]:
    """``threads``: ring threads of each column's assembly (default: the Discretisation's, <= 2,
    which already keeps both cores busy in the serial path)."""
    p = vs.Physics(v=0.95, lam=8.0, chi=10.0)
    d = vs.Discretisation(grid, degree) if threads is None else vs.Discretisation(
        grid, degree, workers=threads)  # fmt: skip
    P = vs.SteadyProblem(p, d, NEWTON_TOLERANCES, jacobian_method="differences")
    a = initial_guess(p, d)
    base, flow = P.adot(a)
    if workers is None:
        t0 = time.perf_counter()
        M, _ = P.jacobian(a, base, flow.sigma)
        return time.perf_counter() - t0, M
    with executor(workers, "local") as pool:
        times = []
        for _ in range(2):  # cold workers (imports, compiled-kernel caches, tables), then warm
            t0 = time.perf_counter()
            M, _ = P.jacobian(a, base, flow.sigma, executor=pool)
            times.append(time.perf_counter() - t0)
        return times, M


def _sweep(workers: int, threads: int | None = None) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_text(SWEEP + ("" if threads is None else f"workers = {threads}\n"))
        t0 = time.perf_counter()
        store = run_sweep(read_sweep_config(path), workers=workers)
        seconds = time.perf_counter() - t0
        assert store.status()["done"] == len(LAMS)
    return seconds


def _sweep_serial() -> float:
    """The same points through the same task function, one after the other in this process
    (the sweep's own work: ``reach`` with its checks, the stability analysis), no store."""
    function = TASKS["stability"].function
    t0 = time.perf_counter()
    for lam in LAMS:
        function(vs.Physics(v=0.95, lam=lam, chi=1.0), vs.Discretisation(16, 4), {}, {})
    return time.perf_counter() - t0


def run() -> dict:
    out = {}
    serial, M0 = _jacobian(None)
    out["jacobian_serial_s"] = serial
    for workers, threads in ((1, None), (2, None), (2, 2)):
        (cold, warm), M = _jacobian(workers, threads=threads)
        name = f"{workers}" + ("" if threads is None else f"_threads_{threads}")
        out[f"jacobian_dask_{name}_s"] = warm
        out[f"jacobian_dask_{name}_cold_s"] = cold
        out[f"jacobian_dask_{name}_identical"] = bool(np.array_equal(M, M0))
        label = f"{workers}" + ("" if threads is None else f" ({threads} ring thread each)")
        print(f"  FD Jacobian N=6 24x48 (25 columns): serial {serial:.1f} s, LocalCluster of "
              f"{label}: first {cold:.1f} s ({serial / cold:.2f}x; the workers start cold), "
              f"second {warm:.1f} s ({serial / warm:.2f}x), identical "
              f"{out[f'jacobian_dask_{name}_identical']}")  # fmt: skip
    serial = _sweep_serial()
    out["sweep_serial_s"] = serial
    for workers, threads in ((1, None), (2, None), (2, 2)):
        seconds = _sweep(workers, threads)
        name = f"{workers}" + ("" if threads is None else f"_threads_{threads}")
        out[f"sweep_dask_{name}_s"] = seconds
        label = f"{workers}" + ("" if threads is None else f" ({threads} ring thread each)")
        print(
            f"  stability sweep, {len(LAMS)} points N=4 16x32: serial {serial:.1f} s, "
            f"LocalCluster of {label} (start-up included): {seconds:.1f} s "
            f"({serial / seconds:.2f}x)"
        )
    return out
