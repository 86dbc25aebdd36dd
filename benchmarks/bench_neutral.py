"""Neutral curve: the traced critical point against a fresh bracketing search at each chi.

Same run, same inputs (v = 0.95, BLAS one thread): ``vs.neutral_curve`` through
chi = 1, 1.468, 2.154, 3.162 (the seed at chi = 1 is itself found by bracketing), then
``vs.critical_lambda`` from its default start at each chi after the seed.  Reported per chi:
both lambda_c, their difference (each is located to xtol = 1e-3), and the wall time of one traced
point against one bracketing search.  N = 4 on 16x32 by default; ``VESICLE_BENCH_FULL=1`` adds
N = 6 on 24x48.
"""

from __future__ import annotations

import os
import time

import vesicle as vs

CHI = [1.0, 1.468, 2.154, 3.162]


def _case(degree: int, grid: int) -> list[dict]:
    disc = vs.Discretisation(grid, degree)
    curve = vs.neutral_curve(0.95, CHI, disc, locate_type_change=False)
    rows = []
    for p in curve.points[1:]:
        t0 = time.perf_counter()
        c = vs.critical_lambda(vs.Physics(v=0.95, chi=p.chi), disc)
        seconds = time.perf_counter() - t0
        row = {"degree": degree, "grid": grid, "chi": p.chi,
               "traced_lambda_c": p.lambda_c, "traced_s": p.seconds,
               "bracketing_lambda_c": c.lambda_c, "bracketing_s": seconds,
               "bracketing_evaluations": len(c.history),
               "difference": p.lambda_c - c.lambda_c}  # fmt: skip
        print(f"  N={degree} {grid}x{2 * grid} chi={p.chi:<6g} traced {p.lambda_c:.5f} "
              f"({p.seconds:5.1f} s)  bracketing {c.lambda_c:.5f} ({seconds:5.1f} s, "
              f"{len(c.history)} evaluations)  difference {row['difference']:+.1e}  "
              f"cost ratio {seconds / p.seconds:.2f}x")  # fmt: skip
        rows.append(row)
    return rows


def run() -> dict:
    cases = [(4, 16)] + ([(6, 24)] if os.environ.get("VESICLE_BENCH_FULL") else [])
    return {"points": [row for d, g in cases for row in _case(d, g)]}
