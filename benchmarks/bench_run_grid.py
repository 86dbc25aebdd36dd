"""The full report's time-dependent runs at N = 8 on 16x32 (``paper.RUNS_FULL`` since
2026-12-07) against 24x48, the grid they used before (the reference: ``--grid 24``).

The run is fig11's TR point (v = 0.95, lam = 10.5, chi = 8) with the report's run settings
(ROS34PW2, rtol 1e-3, saved every 0.05), stopped once 4 psi periods have settled (t = 6.75),
one command-line process per grid, one thread.  Reported per grid: wall time, the process's
user + system CPU seconds (``getrusage``), the solves, and what the report's items take from
such a run: the psi period and the period means of S_xz, N1, N2.  Then the CPU ratio
24x48 / 16x32 and the differences.  ``VESICLE_BENCH_FULL=1`` adds 32x64 (the paper's grid).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: fig11's TR point with the report's run settings (docs/notes/dynamics-measurements.md)
ARGS = ["run", "--v", "0.95", "--chi", "8", "--lam", "10.5", "--degree", "8", "--t-end", "30",
        "--save-every", "0.05", "--integrator", "ros34pw2", "--rtol", "1e-3", "--periods", "4",
        "--no-fields", "--threads", "1"]  # fmt: skip


def _one(grid: int, folder: Path) -> dict:
    from vesicle.geometry.diagnostics import summarize
    from vesicle.io.files import read_run

    out = folder / f"tr_{grid}.h5"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "vesicle", *ARGS, "--grid", str(grid), "--out",
                    str(out)], env=env, check=True, capture_output=True)  # fmt: skip
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    s = summarize(read_run(out))
    return {"grid": grid, "wall_s": time.perf_counter() - t0,
            "cpu_s": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime,
            "solves": s["solves"], "period": s["period"], **s["mean"]}  # fmt: skip


def run() -> dict:
    grids = [16, 24] + ([32] if os.environ.get("VESICLE_BENCH_FULL") else [])
    with tempfile.TemporaryDirectory() as tmp:
        rows = [_one(g, Path(tmp)) for g in grids]
    for r in rows:
        print(f"  {r['grid']}x{2 * r['grid']}: wall {r['wall_s']:6.1f} s  cpu {r['cpu_s']:6.1f} s"
              f"  solves {r['solves']}  period {r['period']:.9f}  S_xz {r['S_xz']:.8f}"
              f"  N1 {r['N1']:.4e}  N2 {r['N2']:.4e}")  # fmt: skip
    new, ref = rows[0], rows[1]
    out = {"rows": rows, "cpu_ratio_24_over_16": ref["cpu_s"] / new["cpu_s"],
           "period_relative_difference": new["period"] / ref["period"] - 1.0,
           "S_xz_relative_difference": new["S_xz"] / ref["S_xz"] - 1.0,
           "N1_difference": new["N1"] - ref["N1"],
           "N2_difference": new["N2"] - ref["N2"]}  # fmt: skip
    print(f"  CPU 24x48 / 16x32: {out['cpu_ratio_24_over_16']:.2f}x;  16x32 - 24x48: period "
          f"{out['period_relative_difference']:+.1e} rel, "
          f"S_xz {out['S_xz_relative_difference']:+.1e} rel, "
          f"N1 {out['N1_difference']:+.1e}, N2 {out['N2_difference']:+.1e}")  # fmt: skip
    return out
