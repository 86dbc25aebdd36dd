"""One velocity-tension solve at 32x64 (lam = 1 and 8): time, iterations, where the time goes."""

from __future__ import annotations

import time

import numpy as np

import vesicle as vs
from vesicle.solve.solver import solve_flow
from vesicle.sphere.rotation import rotation_matrix
from vesicle.stokes import LayerPotentials, singular_quadrature


def run() -> dict:
    shape = vs.Shape.spheroid(0.95, grid=32, degree=8).rotated(rotation_matrix("y", -0.5))
    # once per grid and process, not part of a solve: the Wigner tables, and loading (or
    # compiling) the fused kernels
    _ = singular_quadrature(32).wigner
    _ = LayerPotentials(vs.Shape.sphere(grid=32), kernels=("single",)).single_matrix
    results = {}
    for lam in (1.0, 8.0):
        kernels = ("single",) if lam == 1.0 else ("single", "double")  # as the solver does
        for preset in ("time-dependent", "steady"):
            t0 = time.perf_counter()
            lp = LayerPotentials(shape, kernels=kernels)
            _ = lp.single_matrix
            t_build = time.perf_counter() - t0
            cold = solve_flow(shape, lam=lam, chi=1.0, tolerances=preset, operators=lp)
            applies = dict(lp.timings)
            warm_shape = shape.perturbed(2e-3, seed=3)  # a next time step's shape
            warm = solve_flow(warm_shape, lam=lam, chi=1.0, tolerances=preset, sigma0=cold.sigma)
            t_total = t_build + cold.seconds
            t_apply = applies.get("apply_single", 0.0) + applies.get("apply_double", 0.0)
            row = {
                "total_s": t_total,
                "build_s": t_build,
                "applies_s": t_apply,
                "other_s": cold.seconds - t_apply,
                "outer": cold.outer_iterations,
                "inner": cold.inner_iterations,
                "inner_per_solve": list(cold.inner_per_solve),
                "warm_outer": warm.outer_iterations,
                "warm_inner_per_solve": list(warm.inner_per_solve),
                "warm_total_s": warm.seconds,
                "div_residual_relative": cold.div_residual_relative,
                "S_xz": cold.S_xz,
            }
            results[f"lam={lam:g} {preset}"] = row
            print(
                f"  lam={lam:g} {preset:14s}: {t_total:.2f} s = assembly {t_build:.2f} + "
                f"N/K applies {t_apply:.2f} + transforms/GMRES {row['other_s']:.2f}; outer "
                f"{cold.outer_iterations}, inner/solve {np.mean(cold.inner_per_solve):.1f}; "
                f"warm start (next step's shape): outer {warm.outer_iterations}, inner/solve "
                f"{np.mean(warm.inner_per_solve):.1f}, {warm.seconds:.2f} s with assembly"
            )
    return results
