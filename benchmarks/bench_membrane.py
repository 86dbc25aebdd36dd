"""The cost of a viscous membrane (issue 42) at N = 8 on 32x64, as ratios measured in this run.

- Time stepping, v = 0.95, lam = 8, chi = 1, from the spheroid to t = 0.3 (the same number of
  steps each way): Bq = 0 (nested GMRES, the inviscid runs' solve), Bq = 1 with the solves
  preconditioned by a kept factorised system (the default) and Bq = 1 with the nested GMRES
  (``viscous_solve = "nested"``, the reference).  Seconds per solve and their ratios.
- One Newton iteration's work (the solve and the linearised Jacobian: a factorisation and its
  solves) at the start shape of v = 0.95, lam = 8, chi = 10, at Bq = 0 and 1.
"""

from __future__ import annotations

import time

import vesicle as vs
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.steady.newton import NEWTON_TOLERANCES, initial_guess
from vesicle.steady.problem import SteadyProblem

DISC = vs.Discretisation(grid=32, degree=8)


def _run(bq: float, how: str) -> tuple[float, int]:
    params = RunParameters(vs.Physics(v=0.95, lam=8.0, chi=1.0, bq=bq), DISC, t_end=0.3,
                           dt0=0.05, dt_max=0.05, save_fields=False, viscous_solve=how)
    t0 = time.perf_counter()
    run = simulate(params)
    return time.perf_counter() - t0, int(run.checkpoint["solves"])


def _newton_step(bq: float) -> float:
    """A Newton iteration's work at one shape: the solve (``adot``) and the linearised
    Jacobian.  With Bq > 0 the first solve of a shape is by factorisation and the Jacobian
    reuses that system, so the two are timed together."""
    physics = vs.Physics(v=0.95, lam=8.0, chi=10.0, bq=bq)
    problem = SteadyProblem(physics, DISC, NEWTON_TOLERANCES)
    a = initial_guess(physics, DISC)
    t0 = time.perf_counter()
    problem.adot(a)
    problem.jacobian(a)
    return time.perf_counter() - t0


def run() -> dict:
    _run(0.0, "factorised")  # compile and load the kernels once
    rows = {}
    for name, bq, how in (("Bq = 0", 0.0, "factorised"), ("Bq = 1, factorised", 1.0, "factorised"),
                          ("Bq = 1, nested (reference)", 1.0, "nested")):  # fmt: skip
        seconds, solves = _run(bq, how)
        rows[name] = {"seconds": seconds, "solves": solves, "per_solve": seconds / solves}
    base = rows["Bq = 0"]["per_solve"]
    for name, r in rows.items():
        r["ratio_to_bq0"] = r["per_solve"] / base
        print(f"  time stepping {name:28s}: {r['seconds']:6.1f} s, {r['solves']} solves, "
              f"{r['per_solve']:.2f} s per solve, {r['ratio_to_bq0']:.2f} x Bq = 0")
    jac = {bq: _newton_step(bq) for bq in (0.0, 1.0)}
    rows["newton_iteration"] = {"bq0_s": jac[0.0], "bq1_s": jac[1.0],
                                "ratio": jac[1.0] / jac[0.0]}  # fmt: skip
    print(f"  a Newton iteration (solve and Jacobian): Bq = 0 {jac[0.0]:.1f} s, Bq = 1 "
          f"{jac[1.0]:.1f} s, {jac[1.0] / jac[0.0]:.2f} x")
    return rows
