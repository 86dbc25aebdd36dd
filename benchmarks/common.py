"""Timing helpers shared by the benchmarks."""

from __future__ import annotations

import time

import numpy as np


def best_time(fn, repeat: int = 5, number: int = 1) -> float:
    """Best wall time of ``number`` calls, over ``repeat`` tries (seconds per call)."""
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t) / number)
    return best


def dgemm_rate(n: int = 1024) -> float:
    """This machine's DGEMM rate in FLOP/s (square n x n, BLAS as configured)."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((n, n)), rng.standard_normal((n, n))
    return 2.0 * n**3 / best_time(lambda: a @ b, repeat=3)
