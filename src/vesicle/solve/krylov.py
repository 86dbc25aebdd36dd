"""GMRES for a batch of right-hand sides in lockstep.

Each right-hand side has its own Krylov space, but the operator is applied to the whole
batch at once: where the operator is a few dense matrices (the assembled layer potentials,
each larger than the caches), one product with a block of vectors reads each matrix once
instead of once per vector.  The reference is SciPy's ``gmres`` called once per right-hand
side (:func:`vesicle.solve.factorised.preconditioned_system_solve` with ``batched=False``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["BatchedGmres", "batched_gmres"]


@dataclass(frozen=True)
class BatchedGmres:
    """Solutions ``x`` (B, n), each right-hand side's iterations and whether it converged,
    and the relative residual estimates (GMRES's own, from the Hessenberg system)."""

    x: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    residuals: np.ndarray


def batched_gmres(
    op: Callable[[np.ndarray], np.ndarray],
    b: np.ndarray,
    rtol: float,
    max_iterations: int,
) -> BatchedGmres:
    """``op x = b`` for each row of ``b`` (B, n) by unrestarted GMRES from ``x = 0``.

    ``op`` maps (k, n) to (k, n), applied to the rows still iterating (a right-hand side leaves
    the batch once its residual estimate is below ``rtol`` times its norm).  The Arnoldi
    vectors are orthogonalised by classical Gram-Schmidt twice (one matrix product per pass for
    the whole batch), the least-squares problems updated by Givens rotations, as in the textbook
    algorithm (Saad, *Iterative Methods for Sparse Linear Systems*, 2nd ed., Alg. 6.9).
    """
    b = np.asarray(b, dtype=float)
    if b.ndim != 2:
        raise ValueError(f"b must be (B, n), got shape {b.shape}")
    if max_iterations < 1:
        raise ValueError("max_iterations must be at least 1")
    B, n = b.shape
    m = max_iterations
    beta = np.linalg.norm(b, axis=1)
    V = np.zeros((B, m + 1, n))
    H = np.zeros((B, m + 1, m))
    cs, sn = np.zeros((B, m)), np.zeros((B, m))
    g = np.zeros((B, m + 1))
    g[:, 0] = beta
    size = np.zeros(B, dtype=int)  # Krylov dimension used by each right-hand side
    residual = np.where(beta > 0, 1.0, 0.0)
    active = beta > 0
    V[active, 0] = b[active] / beta[active, None]
    for k in range(m):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        w = np.asarray(op(V[idx, k]), dtype=float)
        if w.shape != (idx.size, n):
            raise ValueError(f"op returned shape {w.shape}, expected {(idx.size, n)}")
        basis = V[idx, : k + 1]  # (a, k+1, n)
        h = np.einsum("ajn,an->aj", basis, w)
        w = w - np.einsum("aj,ajn->an", h, basis)
        h2 = np.einsum("ajn,an->aj", basis, w)  # the second pass (CGS2)
        w = w - np.einsum("aj,ajn->an", h2, basis)
        h = h + h2
        hn = np.linalg.norm(w, axis=1)
        col = np.zeros((idx.size, k + 2))
        col[:, : k + 1] = h
        col[:, k + 1] = hn
        for i in range(k):  # the earlier rotations on the new column
            c, s = cs[idx, i], sn[idx, i]
            top = c * col[:, i] + s * col[:, i + 1]
            col[:, i + 1] = -s * col[:, i] + c * col[:, i + 1]
            col[:, i] = top
        r = np.hypot(col[:, k], col[:, k + 1])
        safe = np.where(r > 0, r, 1.0)
        c, s = np.where(r > 0, col[:, k] / safe, 1.0), np.where(r > 0, col[:, k + 1] / safe, 0.0)
        cs[idx, k], sn[idx, k] = c, s
        col[:, k], col[:, k + 1] = r, 0.0
        H[idx, : k + 2, k] = col
        gk = g[idx, k]
        g[idx, k + 1] = -s * gk
        g[idx, k] = c * gk
        size[idx] = k + 1
        residual[idx] = np.abs(g[idx, k + 1]) / beta[idx]
        ok = hn > 0
        V[idx[ok], k + 1] = w[ok] / hn[ok, None]
        # done: converged, or an exact Krylov space (breakdown: the residual is then zero)
        active[idx] = (residual[idx] > rtol) & ok
    x = np.zeros((B, n))
    for j in np.flatnonzero(size > 0):
        k = size[j]
        R = np.triu(H[j, :k, :k])
        if np.any(np.diag(R) == 0.0):  # a singular operator on this Krylov space
            residual[j] = np.inf
            continue
        y = np.linalg.solve(R, g[j, :k])  # small upper-triangular system
        x[j] = y @ V[j, :k]
    return BatchedGmres(x=x, iterations=size, converged=residual <= rtol, residuals=residual)
