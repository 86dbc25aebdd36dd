"""Steady TT + stability (``vesicle tt --stability``), v = 0.95, lam = 8, chi = 10.

Paths timed in the same run, on the same inputs:

- ``reference``: finite-difference Jacobians (forward in Newton, central at the solution), a fresh
  one every Newton step (``jacobian="differences", updates="none"``): the method before issue 12;
- ``broyden``: the same Jacobians reused with Broyden updates (``jacobian="differences"``);
- ``broyden_2_workers``: that, with the columns on 2 processes;
- ``linearised_nested``: the solve differentiated (:mod:`vesicle.solve.linearisation`), every solve
by
  the nested GMRES (the default before the preconditioned solves);
- ``linearised``: the default (that, with the solves after a Jacobian preconditioned by its
  factorised system, :func:`vesicle.solve.factorised.preconditioned_solve`).

Cases: N = 4 on 16x32 and N = 6 on 24x48; ``VESICLE_BENCH_FULL=1`` adds the paper's N = 8 on
32x64 (about 13 min) and, there, one continuation step (lam 7 -> 7.3 at chi = 1, with its stability)
and ``critical_lambda(v=0.95, chi=1)`` from its default start, each by the method before and the
default (constraint correction; coarse-to-fine search).  Reported: wall times, ratios
against the reference, GMRES solves, Jacobians formed, the time inside the linearised Jacobians
(split into factorisation, layer-potential derivatives, local differences and the batched
solve) and the relative difference of omega from the reference.
"""

from __future__ import annotations

import os
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import vesicle as vs
import vesicle.steady.problem as problem_module
from vesicle.bifurcation.branch import reach

PATHS = {
    "reference": dict(jacobian="differences", updates="none", constraints="first-order"),
    "linearised_nested": dict(jacobian="linearised", updates="broyden", preconditioned=False),
    "broyden": dict(jacobian="differences", updates="broyden"),
    "broyden_2_workers": dict(jacobian="differences", updates="broyden"),
    "linearised": dict(jacobian="linearised", updates="broyden"),
}


class _JacobianClock:
    """Sums the pieces of every linearised Jacobian formed while it is installed."""

    def __init__(self):
        self.seconds = defaultdict(float)
        self.count = 0
        self._original = problem_module.linearised_jacobian

    def __enter__(self):
        def timed(*args, **kwargs):
            out = self._original(*args, **kwargs)
            self.count += 1
            for k, v in out.seconds.items():
                self.seconds[k] += v
            return out

        problem_module.linearised_jacobian = timed
        return self

    def __exit__(self, *exc):
        problem_module.linearised_jacobian = self._original


def _time(path: str, degree: int, grid: int):
    p = vs.Physics(v=0.95, lam=8.0, chi=10.0)
    d = vs.Discretisation(grid, degree)
    pool = ProcessPoolExecutor(2) if path.endswith("2_workers") else None
    with _JacobianClock() as clock:
        t0 = time.perf_counter()
        r = vs.steady_tank_treading(p, d, executor=pool, **PATHS[path])
        w = vs.stability(r).most_unstable
        seconds = time.perf_counter() - t0
    if pool is not None:
        pool.shutdown()
    return seconds, np.array(w), r, clock


def _continuation_and_critical(disc) -> dict:
    """Target 2 of issue 12 (N = 8, 32x64): one continuation step lam 7 -> 7.3 at chi = 1 with
    its stability, from the converged lam = 7 state (not timed), by the method before (no
    constraint correction, nested GMRES solves) and the default; and lambda_c at chi = 1 from
    the default start by the bracketing from the leading-order estimate (``coarse=None``, the
    search before) and the default coarse-to-fine search; on the same inputs in the same run."""
    out = {}
    start = reach(vs.Physics(v=0.95, lam=7.0, chi=1.0), disc)
    before = {"constraints": "first-order", "preconditioned": False}
    for name, options in (("before", before), ("default", {})):
        t0 = time.perf_counter()
        step = vs.steady_tank_treading(start.physics.replace(lam=7.3), disc, initial=start,
                                       **options)  # fmt: skip
        w = vs.stability(step).most_unstable
        seconds = time.perf_counter() - t0
        out[f"continuation_step_{name}"] = {
            "seconds": seconds, "solves": step.solves, "jacobians": step.jacobians,
            "omega": list(w),
        }  # fmt: skip
        print(f"  continuation step lam 7 -> 7.3 (chi = 1), {name}: {seconds:.1f} s "
              f"({step.solves} solves, {step.jacobians} Newton Jacobians), omega "
              f"({w[0]:.8f}, {w[1]:.8f})")  # fmt: skip
    for name, coarse in (("before", None), ("default", "auto")):
        t0 = time.perf_counter()
        c = vs.critical_lambda(
            vs.Physics(v=0.95, chi=1.0), disc, search=vs.CriticalSearch(coarse=coarse)
        )
        seconds = time.perf_counter() - t0
        coarse_evaluations = len(c.coarse.history) if c.coarse else 0
        out[f"critical_{name}"] = {"seconds": seconds, "lambda_c": c.lambda_c,
                                   "evaluations": len(c.history),
                                   "coarse_evaluations": coarse_evaluations}  # fmt: skip
        print(f"  critical_lambda(v=0.95, chi=1), {name}: {seconds:.1f} s, lambda_c = "
              f"{c.lambda_c:.5f} ({len(c.history)} evaluations at N = 8, {coarse_evaluations} "
              "coarse)")  # fmt: skip
    for key in ("continuation_step", "critical"):
        before, new = out[f"{key}_before"]["seconds"], out[f"{key}_default"]["seconds"]
        out[f"{key}_ratio"] = before / new
        print(f"  {key}: {before / new:.2f}x")
    return out


def run() -> dict:
    full = bool(os.environ.get("VESICLE_BENCH_FULL"))
    cases = [(4, 16), (6, 24)] + ([(8, 32)] if full else [])
    results = {}
    for degree, grid in cases:
        key = f"N={degree} {grid}x{2 * grid}"
        row, timed = {}, {}
        for path in PATHS:
            timed[path] = _time(path, degree, grid)
        ref_s, w_ref, _, _ = timed["reference"]
        for path, (s, w, r, clock) in timed.items():
            row[path] = {
                "seconds": s, "ratio": ref_s / s, "solves": r.solves, "jacobians": r.jacobians,
                "omega": w.tolist(),
                "omega_relative_difference": float(np.max(np.abs(w - w_ref)) / np.abs(w_ref).max()),
                "linearised_jacobians": clock.count, "linearised_seconds": dict(clock.seconds),
            }  # fmt: skip
            pieces = ", ".join(f"{k} {v:.1f} s" for k, v in clock.seconds.items())
            print(
                f"  {key} {path}: {s:.1f} s ({ref_s / s:.2f}x), {r.solves} solves, "
                f"{r.jacobians} Newton Jacobians, omega ({w[0]:.6f}, {w[1]:.6e}), difference "
                f"{row[path]['omega_relative_difference']:.1e}"
                + (f"; {clock.count} linearised Jacobians: {pieces}" if clock.count else "")
            )
        if degree == 8:
            row.update(_continuation_and_critical(timed["linearised"][2].discretisation))
        results[key] = row
    return results
