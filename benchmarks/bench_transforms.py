"""Spherical-harmonic transform pair (analysis + synthesis), batched vs per-field loop."""

from __future__ import annotations

import numpy as np

from vesicle.sphere.transforms import transform

from common import best_time, dgemm_rate


def run() -> dict:
    gemm = dgemm_rate()
    print(f"  DGEMM rate (1 thread): {gemm / 1e9:.1f} GFLOP/s")
    rows = {}
    for n in (32, 64):
        T = transform(n)
        for nf in (1, 100):
            f = np.random.default_rng(0).standard_normal((nf, n, 2 * n))
            T.synthesis(T.analysis(f))
            t_batch = best_time(lambda: T.synthesis(T.analysis(f)), number=5)  # noqa: B023
            t_loop = best_time(lambda: [T.synthesis(T.analysis(x)) for x in f], number=1)  # noqa: B023
            # Legendre stage: 2 real GEMMs of (L+1)(L+1)n per m, 2 numbers per complex value
            flops = 2 * 2 * 2.0 * n * n * n * nf
            rows[f"{n}x{2 * n}, {nf} fields"] = {
                "batched_s": t_batch,
                "loop_s": t_loop,
                "loop_over_batched": t_loop / t_batch,
                "legendre_fraction_of_dgemm": flops / t_batch / gemm,
            }
            print(
                f"  {n}x{2 * n} {nf:4d} fields: batched {t_batch * 1e3:7.2f} ms, "
                f"per-field loop {t_loop * 1e3:7.2f} ms ({t_loop / t_batch:4.1f}x), "
                f"{flops / t_batch / gemm:5.1%} of DGEMM"
            )
    return {"dgemm_flops": gemm, "transforms": rows}
