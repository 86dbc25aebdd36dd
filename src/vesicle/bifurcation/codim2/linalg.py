"""Finite eigenvalues of the pencil and the bordered systems behind the test functions.

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla

log = logging.getLogger(__name__)

# ---------------------------------------------------------------------------------------------
# Linear algebra
# ---------------------------------------------------------------------------------------------


def finite_eigenvalues(
    J: np.ndarray, B: np.ndarray | None = None, finite_ratio: float = 1e4
) -> np.ndarray:
    """The finite eigenvalues ``s`` of the pencil ``J v = s B v``.

    Parameters
    ----------
    J, B : ndarray (n, n)
        ``B = None`` or the identity gives the eigenvalues of ``J``.
    finite_ratio : float
        Eigenvalues with ``|s| > finite_ratio |J|_F / |B|_F`` are taken to be infinite.

    Notes
    -----
    QZ (``scipy.linalg.eigvals`` in homogeneous form ``(alpha, beta)``).  The infinite
    eigenvalues of a singular ``B`` come out with ``beta`` at rounding level; for an index-2
    DAE (a Lagrange multiplier) they are defective and come out at ``|s| ~ |J| / sqrt(eps)``,
    far above the bound.
    """
    J = np.asarray(J, dtype=float)
    if B is None or np.array_equal(B, np.eye(J.shape[0])):
        return np.linalg.eigvals(J)
    alpha, beta = sla.eigvals(J, B, homogeneous_eigvals=True, check_finite=False)
    bound = finite_ratio * np.linalg.norm(J) / max(np.linalg.norm(B), 1e-300)
    finite = np.abs(alpha) <= bound * np.abs(beta)
    return alpha[finite] / beta[finite]


def _pencil_vectors(J: np.ndarray, B: np.ndarray, finite_ratio: float):
    """Finite eigenvalues with left and right eigenvectors (``w^H J = s w^H B``)."""
    (alpha, beta), vl, vr = sla.eig(
        J, B, left=True, right=True, homogeneous_eigvals=True, check_finite=False
    )
    bound = finite_ratio * np.linalg.norm(J) / max(np.linalg.norm(B), 1e-300)
    finite = np.abs(alpha) <= bound * np.abs(beta)
    return alpha[finite] / beta[finite], vl[:, finite], vr[:, finite]


def _realify(v: np.ndarray) -> np.ndarray:
    """The real vector closest in direction to ``v`` up to a complex phase."""
    v = np.asarray(v, dtype=complex)
    s = np.sum(v * v)
    theta = 0.5 * np.angle(s) if abs(s) > 0 else 0.0
    r = (v * np.exp(-1j * theta)).real
    return r / np.linalg.norm(r)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _bordered(A: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Solve ``[[A, b], [c^H, 0]] [v; g] = [0; 1]`` and its adjoint.

    Returns ``v, g, w, lu`` with ``A v + b g = 0, c^H v = 1`` and
    ``A^H w + c conj(g) = 0, b^H w = 1``; ``lu`` factors the bordered matrix ``M``.
    """
    n = A.shape[0]
    dtype = np.result_type(A, b, c)
    M = np.zeros((n + 1, n + 1), dtype=dtype)
    M[:n, :n] = A
    M[:n, n] = b
    M[n, :n] = np.conj(c)
    lu = sla.lu_factor(M, check_finite=False)
    e = np.zeros(n + 1, dtype=dtype)
    e[n] = 1.0
    V = sla.lu_solve(lu, e, check_finite=False)
    W = sla.lu_solve(lu, e, trans=2, check_finite=False)
    if not (np.all(np.isfinite(V)) and np.all(np.isfinite(W))):
        raise np.linalg.LinAlgError("singular bordered matrix")
    return V[:n], V[n], W[:n], lu


