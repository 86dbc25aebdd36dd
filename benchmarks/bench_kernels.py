"""The dominant kernels against this machine's one-thread DGEMM rate, measured in the same run.

Issue 12's target 4. Which kernels dominate (docs/notes/steady-measurements.md,
docs/notes/dynamics-measurements.md): in time stepping the layer-potential assembly (its BLAS core
is the pull-back: a phi' DFT product, then Legendre and Wigner products per ring) and GMRES; in the
steady solve with its stability, the factorisation of the velocity-tension system
(``vesicle.solve.factorised``: the batched spherical-harmonic analysis of ``M^-1 K_c``'s columns
and the LU factorisation of ``C``).

Each kernel reports its wall time, the floating-point operations it does (counted from the
shapes of its products; the FFT's are not counted) and that count over the time as a fraction of
DGEMM (1024^3, one thread). A GMRES iteration's dense matrix-vector product is bound by memory
bandwidth, not flops; it is reported in GB/s of matrix read instead. BLAS runs on one thread
throughout (the assembly's two ring threads are not used here, so the rates are per core).

Cases: 32x64 (the paper's grid) and 48x96, a perturbed spheroid v = 0.95, N = 8, lam = 8.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

import vesicle as vs
from bench_layer_potentials import _pull_back_rate
from vesicle.solve.factorised import FactorisedSystem
from vesicle.solve.solver import VelocityTensionSolver
from vesicle.sphere.transforms import transform
from vesicle.stokes import singular_quadrature

from common import best_time, dgemm_rate


def _lu(n: int) -> tuple[float, float]:
    """LU with partial pivoting of a dense n x n matrix (as the factorisation's ``C``)."""
    a = np.random.default_rng(0).standard_normal((n, n)) + n * np.eye(n)
    t = best_time(lambda: scipy.linalg.lu_factor(a, check_finite=False), repeat=2)
    return t, (2.0 / 3.0) * n**3 / t


def _analysis(n: int, fields: int) -> tuple[float, float]:
    """The batched spherical-harmonic analysis of ``fields`` grid fields (FFT in phi, then the
    Legendre product per order m: real and imaginary parts of (l x theta) @ (theta x fields))."""
    T = transform(n)
    f = np.random.default_rng(0).standard_normal((fields, n, 2 * n))
    t = best_time(lambda: T.analysis(f), repeat=2)
    M = T.lmax + 1
    return t, 2.0 * 2.0 * M * M * n * fields / t


def _matvec(lp) -> tuple[float, float]:
    """One GMRES matrix-vector product with the assembled single layer: GB/s of matrix read."""
    A = lp.single_matrix
    x = np.random.default_rng(0).standard_normal(A.shape[1])
    t = best_time(lambda: A @ x, repeat=5, number=5)
    return t, A.nbytes / t


def _case(n: int, gemm: float) -> dict:
    shape = vs.Shape.spheroid(0.95, grid=n, degree=8).perturbed(0.02, seed=1)
    physics = vs.Physics(v=0.95, lam=8.0, chi=10.0)
    d = vs.Discretisation(grid=n, degree=8, workers=1)
    with threadpool_limits(limits=1, user_api="blas"):
        solver = VelocityTensionSolver(shape, physics, discretisation=d)
        t0 = time.perf_counter()
        _ = solver.lp.single_matrix, solver.lp.double_matrix
        build = time.perf_counter() - t0
        t0 = time.perf_counter()
        system = FactorisedSystem(solver)
        factorise = time.perf_counter() - t0
        size = system._lu[0].shape[0]
        rows = {"assembly_s": build, "factorisation_s": factorise, "C_size": size}
        t_pb, r_pb = _pull_back_rate(n)
        rows["pull_back"] = {"ring_s": t_pb, "rings": n, "GFLOPs": r_pb / 1e9,
                             "of_dgemm": r_pb / gemm}  # fmt: skip
        t_an, r_an = _analysis(n, 3 * size)
        rows["analysis"] = {"s": t_an, "fields": 3 * size, "GFLOPs": r_an / 1e9,
                            "of_dgemm": r_an / gemm}  # fmt: skip
        t_lu, r_lu = _lu(size)
        rows["lu"] = {"s": t_lu, "n": size, "GFLOPs": r_lu / 1e9, "of_dgemm": r_lu / gemm}
        t_mv, bw = _matvec(solver.lp)
        rows["matvec"] = {"s": t_mv, "GBs": bw / 1e9}
    return rows


def run() -> dict:
    _ = singular_quadrature(16).wigner  # compile the kernels outside the timings
    gemm = dgemm_rate()
    print(f"  DGEMM rate (1 thread): {gemm / 1e9:.1f} GFLOP/s")
    results = {"dgemm_flops": gemm}
    for n in (32, 48):
        row = _case(n, gemm)
        pb, an, lu, mv = row["pull_back"], row["analysis"], row["lu"], row["matvec"]
        print(
            f"  {n}x{2 * n}: assembly (N and K, 1 thread) {row['assembly_s']:.2f} s, of which "
            f"pull-back {pb['ring_s'] * pb['rings']:.2f} s at {pb['GFLOPs']:.1f} GFLOP/s "
            f"({pb['of_dgemm']:.0%} of DGEMM); factorisation {row['factorisation_s']:.2f} s: "
            f"analysis of {an['fields']} fields {an['s']:.2f} s at {an['GFLOPs']:.1f} GFLOP/s "
            f"({an['of_dgemm']:.0%}), LU of {lu['n']}^2 {lu['s']:.2f} s at {lu['GFLOPs']:.1f} "
            f"GFLOP/s ({lu['of_dgemm']:.0%}); GMRES matvec (single layer) {1e3 * mv['s']:.1f} ms "
            f"at {mv['GBs']:.1f} GB/s",
            flush=True,
        )
        results[f"{n}x{2 * n}"] = row
    return results
