"""Time stepping: time per step and per unit simulated time (lam = 1 and 8), and where it goes."""

from __future__ import annotations

import cProfile
import pstats
import time

import numpy as np

import vesicle as vs
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.stokes import singular_quadrature

#: Where the time goes: (label, module path suffix, function name) of cumulative profile entries.
PARTS = (
    ("layer-potential assembly", "stokes/operators.py", "_assemble"),
    ("GMRES (applies, constraints)", "_isolve/iterative.py", "gmres"),
    ("bending force", "membrane.py", "bending_force"),
    ("diagnostics of saved steps", "analysis.py", "diagnose"),
    ("drift control and re-centring", "dynamics.py", "post_step"),
)


def _case(grid: int, lam: float, integrator: str, t_end: float) -> dict:
    params = RunParameters(
        vs.Physics(v=0.95, lam=lam, chi=1.0),
        vs.Discretisation(grid=grid, degree=8),
        t_end=t_end,
        save_every=t_end / 4,
        checkpoint_every=1e9,
        integrator=integrator,
    )
    _ = singular_quadrature(grid).wigner
    steps: list[dict] = []
    profile = cProfile.Profile()
    t0 = time.perf_counter()
    profile.enable()
    run = simulate(params, progress=steps.append)
    profile.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(profile).stats
    parts = {}
    for label, path, name in PARTS:
        parts[label] = (
            sum(v[3] for (file, _, fn), v in stats.items() if fn == name and file.endswith(path))
            / wall
        )
    ck = run.checkpoint
    return {
        "wall_s": wall,
        "steps": ck["steps"],
        "rejected": ck["rejected"],
        "solves": ck["solves"],
        "per_step_s": wall / max(ck["steps"], 1),
        "per_solve_s": wall / ck["solves"],
        "per_unit_time_s": wall / t_end,
        "mean_dt": t_end / max(ck["steps"], 1),
        "mean_outer": float(np.mean([s["outer"] for s in steps])),
        "mean_inner": float(np.mean([s["inner"] for s in steps])),
        "fractions": parts,
    }


def run() -> dict:
    """v = 0.95 spheroid, chi = 1, N = 8, to t = 0.2 from dt0 = 1e-3 (the start-up transient,
    where accuracy rather than bending stiffness limits the step)."""
    results = {}
    for grid in (24, 32):
        for lam in (1.0, 8.0):
            for integrator in ("ros2", "bs3"):
                row = _case(grid, lam, integrator, t_end=0.2)
                results[f"{grid}x{2 * grid} lam={lam:g} {integrator}"] = row
                print(
                    f"  {grid}x{2 * grid} N=8 lam={lam:g} {integrator}: "
                    f"{row['per_step_s']:.2f} s/step ({row['steps']} steps, {row['rejected']} "
                    f"rejected, mean dt {row['mean_dt']:.3g}, {row['solves']} solves), "
                    f"{row['per_solve_s']:.2f} s per solve, "
                    f"{row['per_unit_time_s']:.0f} s per unit of simulated time"
                )
                print(
                    "    " + ", ".join(f"{k} {100 * v:.0f} %" for k, v in row["fractions"].items())
                )
    return results
