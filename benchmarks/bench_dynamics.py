"""Time stepping: time per step and per unit simulated time (lam = 1 and 8), and where it goes."""

from __future__ import annotations

import time

import numpy as np

from vesicle.dynamics import RunParameters
from vesicle.simulation import simulate
from vesicle.stokes import singular_quadrature


def _case(grid: int, lam: float, t_end: float) -> dict:
    params = RunParameters(
        v=0.95,
        lam=lam,
        chi=1.0,
        grid=grid,
        degree=8,
        t_end=t_end,
        save_every=t_end,
        checkpoint_every=1e9,
    )
    _ = singular_quadrature(grid).wigner
    steps: list[dict] = []
    t0 = time.perf_counter()
    run = simulate(params, progress=steps.append)
    wall = time.perf_counter() - t0
    ck = run.checkpoint
    evaluations = 3 * (ck["steps"] + ck["rejected"]) + 1 + ck["corrections"]["evaluations"]
    return {
        "wall_s": wall,
        "steps": ck["steps"],
        "rejected": ck["rejected"],
        "evaluations": evaluations,
        "per_step_s": wall / max(ck["steps"], 1),
        "per_evaluation_s": wall / evaluations,
        "per_unit_time_s": wall / t_end,
        "mean_dt": t_end / max(ck["steps"], 1),
        "mean_outer": float(np.mean([s["outer"] for s in steps])),
        "mean_inner": float(np.mean([s["inner"] for s in steps])),
    }


def run() -> dict:
    results = {}
    for grid in (24, 32):
        for lam in (1.0, 8.0):
            row = _case(grid, lam, t_end=0.2)
            results[f"{grid}x{2 * grid} lam={lam:g}"] = row
            print(
                f"  {grid}x{2 * grid} N=8 lam={lam:g}: {row['per_step_s']:.2f} s/step "
                f"({row['steps']} steps, {row['rejected']} rejected, mean dt "
                f"{row['mean_dt']:.3g}), {row['per_evaluation_s']:.2f} s per right-hand side "
                f"(one solve: layer-potential assembly + GMRES), "
                f"{row['per_unit_time_s']:.0f} s per unit of simulated time"
            )
    return results
