"""Wall time of steady tank-treading + stability (vesicle tt --stability), serial vs 2 workers."""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor

from vesicle.stability import stability
from vesicle.steady import steady_tank_treading


def _time(executor, degree: int, grid: int) -> tuple[float, tuple[float, float], int]:
    t0 = time.perf_counter()
    r = steady_tank_treading(0.95, 8.0, 10.0, degree=degree, grid=grid, executor=executor)
    w = stability(r).most_unstable
    return time.perf_counter() - t0, w, r.solves


def run() -> dict:
    results = {}
    for degree, grid in ((4, 16), (8, 24)):
        serial, w, solves = _time(None, degree, grid)
        with ProcessPoolExecutor(2) as pool:
            parallel, w2, _ = _time(pool, degree, grid)
        key = f"N={degree} {grid}x{2 * grid}"
        results[key] = {
            "serial_s": serial,
            "two_workers_s": parallel,
            "solves": solves,
            "omega": w,
            "identical": w == w2,
        }
        print(
            f"  {key}: serial {serial:.1f} s, 2 workers {parallel:.1f} s "
            f"({serial / parallel:.2f}x), {solves} velocity solves, omega = "
            f"({w[0]:.4f}, {w[1]:.4e}), serial == parallel: {w == w2}"
        )
    return results
