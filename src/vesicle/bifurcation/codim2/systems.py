"""The defining systems (minimally augmented and extended fold, Hopf, BT) and their Newton
corrector.

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from vesicle.bifurcation.codim2.core import _DIVERGED, _KERNEL_TOL
from vesicle.bifurcation.codim2.linalg import _bordered, _unit
from vesicle.bifurcation.codim2.results import CurvePoint, Settings

log = logging.getLogger(__name__)

# ---------------------------------------------------------------------------------------------
# Defining systems: F = 0 plus m extra equations E(u) on u = (x, p, e), e the k extra unknowns
# ---------------------------------------------------------------------------------------------


class _System:
    """Extra equations ``E(u) = 0`` of an augmented system and what Newton needs of them.

    ``evaluate(u, J)`` returns ``E`` (m,), ``E_e`` (m, k) (their derivative with respect to
    the extra unknowns, known exactly) and a context; ``derivative(ev, u, ctx, d)`` returns
    ``E_z d`` for a direction ``d`` in ``z = (x, p)`` with ONE call of the Jacobian action
    derivative; ``linear_rows(u)`` returns normalisation rows ``R u = r`` of the system.
    """

    k = 0
    m = 1

    def __init__(self, n: int, B: np.ndarray):
        self.n = n
        self.B = B

    def linear_rows(self, size: int) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros((0, size)), np.zeros(0)


class _MinAugFold(_System):
    """``g(x, p) = 0`` from ``[[J, b], [c^T, 0]] [v; g] = [0; 1]``; ``g_z d = -w^T J_z(d) v``."""

    def __init__(self, n, B, b, c):
        super().__init__(n, B)
        self.b, self.c = b, c

    def evaluate(self, u, J):
        v, g, w, _ = _bordered(J, self.b, self.c)
        return np.array([g]), np.zeros((1, 0)), (v, w)

    def derivative(self, ev, u, ctx, d):
        v, w = ctx
        n = self.n
        return np.array([-(w @ ev.step_action(u[:n], u[n : n + 2], v, d))])


class _MinAugHopf(_System):
    """``g(x, p, omega) = 0`` (complex) from the bordered ``J - i omega B``; ``u = (x, p, omega)``.

    ``g_z d = -w^H J_z(d) v`` and ``g_omega = i w^H B v``.
    """

    k = 1
    m = 2

    def __init__(self, n, B, b, c):
        super().__init__(n, B)
        self.b, self.c = b, c

    def evaluate(self, u, J):
        omega = u[-1]
        v, g, w, _ = _bordered(J - 1j * omega * self.B, self.b, self.c)
        g_omega = 1j * (np.conj(w) @ (self.B @ v))
        return (
            np.array([g.real, g.imag]),
            np.array([[g_omega.real], [g_omega.imag]]),
            (v, w),
        )

    def derivative(self, ev, u, ctx, d):
        v, w = ctx
        n = self.n
        r = ev.step_action(u[:n], u[n : n + 2], np.column_stack([v.real, v.imag]), d)
        dg = -(np.conj(w) @ (r[:, 0] + 1j * r[:, 1]))
        return np.array([dg.real, dg.imag])


class _BogdanovTakens(_System):
    """``g = 0`` and ``psi = w^T B v = 0`` (the fold's null vectors B-orthogonal).

    Notes
    -----
    With ``V = [v; g]``, ``W = [w; g]``, ``Y = M^{-1} [B v; 0]``, ``Z = M^{-T} [B^T w; 0]``:
    ``psi_z d = -(w^T J_z(d) y + z^T J_z(d) v)`` (top parts ``y, z``), one call with
    ``q = [v, y]``.
    """

    m = 2

    def __init__(self, n, B, b, c):
        super().__init__(n, B)
        self.b, self.c = b, c

    def evaluate(self, u, J):
        v, g, w, lu = _bordered(J, self.b, self.c)
        Bv = self.B @ v
        y = sla.lu_solve(lu, np.append(Bv, 0.0), check_finite=False)[: self.n]
        z = sla.lu_solve(lu, np.append(self.B.T @ w, 0.0), trans=1, check_finite=False)
        return np.array([g, w @ Bv]), np.zeros((2, 0)), (v, w, y, z[: self.n])

    def derivative(self, ev, u, ctx, d):
        v, w, y, z = ctx
        n = self.n
        r = ev.step_action(u[:n], u[n : n + 2], np.column_stack([v, y]), d)
        return np.array([-(w @ r[:, 0]), -(w @ r[:, 1] + z @ r[:, 0])])


class _ExtendedFold(_System):
    """``J q = 0``, ``l^T q = 1`` with ``u = (x, p, q)``."""

    def __init__(self, n, B, l):
        super().__init__(n, B)
        self.l = l
        self.k = n
        self.m = n

    def linear_rows(self, size):
        row = np.zeros((1, size))
        row[0, self.n + 2 :] = self.l
        return row, np.ones(1)

    def evaluate(self, u, J):
        q = u[self.n + 2 :]
        return J @ q, J, q

    def derivative(self, ev, u, ctx, d):
        n = self.n
        return ev.step_action(u[:n], u[n : n + 2], ctx, d)


class _ExtendedHopf(_System):
    """``(J - i omega B) q = 0``, ``l^H q = 1`` with ``u = (x, p, Re q, Im q, omega)``."""

    def __init__(self, n, B, l):
        super().__init__(n, B)
        self.l = l
        self.k = 2 * n + 1
        self.m = 2 * n

    def linear_rows(self, size):
        n = self.n
        rows = np.zeros((2, size))
        lr, li = self.l.real, self.l.imag
        rows[0, n + 2 : 2 * n + 2] = lr
        rows[0, 2 * n + 2 : 3 * n + 2] = li
        rows[1, n + 2 : 2 * n + 2] = -li
        rows[1, 2 * n + 2 : 3 * n + 2] = lr
        return rows, np.array([1.0, 0.0])

    def evaluate(self, u, J):
        n, B = self.n, self.B
        qr, qi, omega = u[n + 2 : 2 * n + 2], u[2 * n + 2 : 3 * n + 2], u[-1]
        E = np.concatenate([J @ qr + omega * (B @ qi), J @ qi - omega * (B @ qr)])
        Ee = np.zeros((2 * n, 2 * n + 1))
        Ee[:n, :n], Ee[:n, n : 2 * n], Ee[:n, -1] = J, omega * B, B @ qi
        Ee[n:, :n], Ee[n:, n : 2 * n], Ee[n:, -1] = -omega * B, J, -(B @ qr)
        return E, Ee, np.column_stack([qr, qi])

    def derivative(self, ev, u, ctx, d):
        n = self.n
        r = ev.step_action(u[:n], u[n : n + 2], ctx, d)
        return np.concatenate([r[:, 0], r[:, 1]])


# ---------------------------------------------------------------------------------------------
# Newton
# ---------------------------------------------------------------------------------------------


def _known_block(J, Fp, rows, size):
    n = J.shape[0]
    A = np.zeros((n + rows.shape[0], size))
    A[:n, :n] = J
    A[:n, n : n + 2] = Fp
    A[n:] = rows
    return A


def _split_kernel(K: np.ndarray, nz: int) -> tuple[np.ndarray, int]:
    """Rotate the kernel basis ``K`` so that only its first ``r`` columns have a z-part."""
    if K.shape[1] == 0:
        return K, 0
    _, sigma, Qt = np.linalg.svd(K[:nz], full_matrices=True)
    r = int(np.sum(sigma > _KERNEL_TOL))
    K = K @ Qt.T
    K[:nz, r:] = 0.0
    return K, r


def _newton_step(ev, system, u, F, J, Fp, E, Ee, ctx, rows, rres):
    """The exact Newton step of ``F = 0, E = 0, rows u = target`` at ``u``.

    Notes
    -----
    The rows of ``F`` and of the linear constraints are known in full
    (``F_z = [J, F_p]``), those of ``E`` only through directional derivatives.  The known
    rows ``A du = -[F; rows u - target]`` give ``du = u0 + K c`` (``u0`` the least-norm
    solution, ``K`` a kernel basis from one SVD).  ``K`` is rotated so that only ``r`` of its
    columns move ``z = (x, p)``; then ``E_z`` is needed only along ``u0_z`` and those ``r``
    columns (``r + 1 = 2`` on fold and Hopf curves, 3 at a BT point), and ``c`` solves the
    square system ``[E_z K_z + E_e K_e] c = -E - E_z u0_z - E_e u0_e``.
    """
    n = J.shape[0]
    nz = n + 2
    A = _known_block(J, Fp, rows, u.size)
    rank = A.shape[0]
    U, S, Vt = np.linalg.svd(A, full_matrices=True)
    if not S[-1] > 1e-13 * S[0]:
        raise np.linalg.LinAlgError("rank-deficient [F_x, F_p]")
    u0 = Vt[:rank].T @ ((U.T @ -np.concatenate([F, rres])) / S)
    K, r = _split_kernel(Vt[rank:].T, nz)
    if K.shape[1] != system.m:
        raise np.linalg.LinAlgError("the augmented system is not square")
    R = Ee @ K[nz:]
    for i in range(r):
        R[:, i] += system.derivative(ev, u, ctx, K[:nz, i])
    rhs = -(E + Ee @ u0[nz:])
    if np.max(np.abs(u0[:nz])) > 1e-14 * (1.0 + np.max(np.abs(u[:nz]))):
        rhs -= system.derivative(ev, u, ctx, u0[:nz])
    c = np.linalg.solve(R, rhs)
    return u0 + K @ c


@dataclass
class _Solved:
    u: np.ndarray
    converged: bool
    iterations: int
    residual: float
    J: np.ndarray | None
    ctx: Any


def _newton(ev, system, u, rows, target, s: Settings, max_iter: int | None = None) -> _Solved:
    """Newton on ``F = 0, E = 0`` with the system's normalisation rows and ``rows u = target``;
    forward differences in the Newton matrix turn central after ``s.central_after``
    iterations without convergence (for this solve only)."""
    differences = ev.differences
    try:
        return _newton_iterations(ev, system, u, rows, target, s, max_iter)
    finally:
        ev.differences = differences


def _newton_iterations(ev, system, u, rows, target, s: Settings, max_iter) -> _Solved:
    n = ev.n
    max_iter = s.max_iter if max_iter is None else max_iter
    u = np.array(u, dtype=float)
    norm_rows, norm_target = system.linear_rows(u.size)
    rows = np.vstack([norm_rows, np.reshape(rows, (-1, u.size))])
    target = np.concatenate([norm_target, np.ravel(target)])
    last, iterations, J, ctx, residual, best = math.inf, 0, None, None, math.inf, math.inf
    before = math.inf  # the step before the last
    first = math.inf
    while True:
        x, p = u[:n], u[n : n + 2]
        try:
            F = ev.residual(x, p)
            J = ev.jacobian(x, p)
            E, Ee, ctx = system.evaluate(u, J)
        except (np.linalg.LinAlgError, FloatingPointError):
            return _Solved(u, False, iterations, math.inf, J, ctx)
        rres = rows @ u - target
        residual = max(np.max(np.abs(F)), np.max(np.abs(E)), np.max(np.abs(rres), initial=0.0))
        log.debug("newton %d: |F| %.3g, |E| %.3g", iterations, np.max(np.abs(F)),
                  np.max(np.abs(E)))  # fmt: skip
        if not np.isfinite(residual):
            return _Solved(u, False, iterations, math.inf, J, ctx)
        scale = 1.0 + float(np.max(np.abs(u)))
        small = iterations == 0 or _error(last, before, s) <= s.step_tol * scale
        if residual <= s.ftol and small:
            return _Solved(u, True, iterations, float(residual), J, ctx)
        best = min(best, residual)
        if iterations == 0:
            first = residual
        stalled = bool(s.stall_after) and iterations >= s.stall_after and residual >= first
        if iterations >= max_iter or stalled or (iterations >= 2 and residual > _DIVERGED * best):
            return _Solved(u, False, iterations, float(residual), J, ctx)
        if s.central_after and iterations >= s.central_after:
            ev.differences = "central"
        ev.set_base(x, p, F, J)
        Fp = ev.step_parameter_derivative(x, p)
        try:
            Jf = ev.state_jacobian(x, p, J)
            du = _newton_step(ev, system, u, F, Jf, Fp, E, Ee, ctx, rows, rres)
        except np.linalg.LinAlgError:
            return _Solved(u, False, iterations, float(residual), J, ctx)
        if not np.all(np.isfinite(du)):
            return _Solved(u, False, iterations, float(residual), J, ctx)
        u = u + du
        before, last = last, float(np.max(np.abs(du)))
        iterations += 1


def _error(last: float, before: float, s: Settings) -> float:
    """The estimated error of the iterate after a step of size ``last`` (max-norm) that
    followed one of size ``before`` (see :class:`Settings`, ``step_tol``)."""
    if not s.estimate_error or not math.isfinite(before) or before <= 0.0:
        return last
    theta = last / before
    return min(last, theta / (1.0 - theta) * last) if theta < 1.0 else last


def _tangent(ev, system, u) -> np.ndarray:
    """The kernel of the full Jacobian of ``F = 0, E = 0`` (and normalisation) at ``u``.

    Costs one Jacobian, one ``F_p`` and two Jacobian action derivatives (the kernel of
    ``F_z`` is two-dimensional).
    """
    n = ev.n
    nz = n + 2
    x, p = u[:n], u[n:nz]
    J = ev.jacobian(x, p)
    ev.set_base(x, p, None, J)
    Fp = ev.step_parameter_derivative(x, p)
    _, Ee, ctx = system.evaluate(u, J)
    rows, _ = system.linear_rows(u.size)
    A = _known_block(ev.state_jacobian(x, p, J), Fp, rows, u.size)
    _, _, Vt = np.linalg.svd(A, full_matrices=True)
    K, r = _split_kernel(Vt[A.shape[0] :].T, nz)
    R = Ee @ K[nz:]
    for i in range(r):
        R[:, i] += system.derivative(ev, u, ctx, K[:nz, i])
    _, _, Wt = np.linalg.svd(R, full_matrices=True)
    return K @ Wt[-1]


# ---------------------------------------------------------------------------------------------
# Formulations: the state vector of a curve and its defining system
# ---------------------------------------------------------------------------------------------


class _Formulation:
    """A curve's unknowns ``u`` and defining system, with the borders kept along it.

    fold/minaug ``u = (x, p)``; hopf/minaug ``(x, p, omega)``; fold/extended ``(x, p, q)``;
    hopf/extended ``(x, p, Re q, Im q, omega)``.  Arclength is measured on ``(x, p)`` and
    ``omega``.
    """

    def __init__(self, kind: str, method: str, n: int, B: np.ndarray):
        self.kind, self.method, self.n, self.B = kind, method, n, B
        self.nz = n + 2
        k = {"fold": {"minaug": 0, "extended": n}, "hopf": {"minaug": 1, "extended": 2 * n + 1}}
        self.size = self.nz + k[kind][method]
        self.geom = np.zeros(self.size, dtype=bool)
        self.geom[: self.nz] = True
        if kind == "hopf":
            self.geom[-1] = True
        self.b = self.c = self.l = None

    def set_vectors(self, v: np.ndarray, w: np.ndarray) -> None:
        dtype = complex if self.kind == "hopf" else float
        self.c = _unit(np.asarray(v, dtype=dtype))
        self.b = _unit(np.asarray(w, dtype=dtype))

    def system(self) -> _System:
        n, B = self.n, self.B
        if self.method == "minaug":
            cls = _MinAugFold if self.kind == "fold" else _MinAugHopf
            return cls(n, B, self.b, self.c)
        if self.kind == "fold":
            return _ExtendedFold(n, B, self.l)
        return _ExtendedHopf(n, B, self.l)

    def state(self, point: CurvePoint) -> np.ndarray:
        z = np.concatenate([point.x, point.p])
        if self.method == "minaug":
            return z if self.kind == "fold" else np.append(z, point.omega)
        q = np.asarray(point.v)
        self.l = q / np.vdot(q, q).real
        if self.kind == "fold":
            return np.concatenate([z, q.real])
        q = q.astype(complex)
        return np.concatenate([z, q.real, q.imag, [point.omega]])

    def omega(self, u: np.ndarray) -> float:
        return float(u[-1]) if self.kind == "hopf" else 0.0

    def accept(self, u: np.ndarray, point: CurvePoint) -> None:
        self.set_vectors(point.v, point.w)
        if self.method == "extended":
            n = self.n
            q = u[n + 2 :] if self.kind == "fold" else u[n + 2 : 2 * n + 2] + 1j * u[2 * n + 2 : -1]
            self.l = q / np.vdot(q, q).real


