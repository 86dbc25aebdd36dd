"""Steady TT + stability (vesicle tt --stability): Newton with Broyden updates against the
reference (a fresh Jacobian every Newton step), serial, and the new path with 2 workers.

Cases: N = 4 on 16x32 and N = 6 on 24x48; set VESICLE_BENCH_FULL=1 to add the paper's N = 8 on
32x64 (about 15 min).  Reported: wall times, their ratio (same run, same inputs), solves,
Jacobians formed, and the relative difference of omega between the two paths.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import vesicle as vs


def _time(updates: str, executor, degree: int, grid: int):
    t0 = time.perf_counter()
    p = vs.Physics(v=0.95, lam=8.0, chi=10.0)
    r = vs.steady_tank_treading(p, vs.Discretisation(grid, degree), executor=executor,
                                updates=updates)  # fmt: skip
    w = vs.stability(r).most_unstable
    return time.perf_counter() - t0, np.array(w), r


def run() -> dict:
    cases = [(4, 16), (6, 24)] + ([(8, 32)] if os.environ.get("VESICLE_BENCH_FULL") else [])
    results = {}
    for degree, grid in cases:
        ref_s, w_ref, ref = _time("none", None, degree, grid)
        new_s, w_new, new = _time("broyden", None, degree, grid)
        with ProcessPoolExecutor(2) as pool:
            par_s, w_par, _ = _time("broyden", pool, degree, grid)
        key = f"N={degree} {grid}x{2 * grid}"
        diff = float(np.max(np.abs(w_new - w_ref) / np.abs(w_ref)))
        results[key] = {
            "reference_s": ref_s, "broyden_s": new_s, "broyden_2_workers_s": par_s,
            "reference_solves": ref.solves, "broyden_solves": new.solves,
            "reference_jacobians": ref.jacobians, "broyden_jacobians": new.jacobians,
            "omega_reference": w_ref.tolist(), "omega_broyden": w_new.tolist(),
            "omega_relative_difference": diff, "parallel_identical": bool(np.all(w_par == w_new)),
        }  # fmt: skip
        print(
            f"  {key}: reference {ref_s:.1f} s ({ref.solves} solves, {ref.jacobians} Jacobians),"
            f" Broyden {new_s:.1f} s ({new.solves} solves, {new.jacobians} Jacobians): "
            f"{ref_s / new_s:.2f}x; 2 workers {par_s:.1f} s ({ref_s / par_s:.2f}x); "
            f"omega ({w_new[0]:.5f}, {w_new[1]:.5e}), relative difference {diff:.1e}"
        )
    return results
