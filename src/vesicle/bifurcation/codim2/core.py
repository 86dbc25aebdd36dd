"""The problem interface, its evaluations and the finite differences that stand in for
second derivatives (the constants of the method are here too).

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import abc
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

_EPS = float(np.finfo(float).eps)

#: Relative step of the default central differences, ``eps**(1/3)`` (about 6.1e-6): it
#: balances the truncation error ``h**2 |F'''| / 6`` against the rounding ``eps |F| / h``;
#: measured 2e-11 relative (median, 3e-10 at worst) on an O(1) problem (docs/reference/codim2.md).
FD_STEP = _EPS ** (1.0 / 3.0)

#: Relative step of the forward differences of the Newton matrices, ``sqrt(eps)`` (1.5e-8):
#: their error (about 1e-8 relative) only slows Newton's quadratic convergence by that factor,
#: while the converged point is defined by ``F`` and the test functions alone.
_FORWARD_STEP = math.sqrt(_EPS)

#: Kernel directions of the linear part of a Newton system whose state components are below
#: this (relative) size are taken to have none: no second derivative is asked along them.
_KERNEL_TOL = 1e-8

#: Newton is given up once its residual exceeds this multiple of the smallest one it had
#: (from the second step on): divergence, which would otherwise cost ``max_iter`` steps.
_DIVERGED = 100.0

#: How many times the end of a Hopf curve (omega -> 0) is tried as a BT point; after that
#: the curve goes on towards omega = 0 (halving its steps) without trying.
_BT_TRIES = 6

#: A corrected Hopf point whose omega fell below this fraction of the last point's is refused
#: as if omega had crossed zero (omega = 0 makes the Hopf system degenerate: the fold curve
#: solves it too).
#: Arclength tolerance of a turn's location (:meth:`_Tracer.locate_turn`): ``p[0]`` is
#: stationary there, so its value is off by the square of that (the vesicle at N = 4: 41 s with
#: ``locate_tol = 1e-7``).
_TURN_XTOL = 1e-4

_OMEGA_FLOOR = 1e-6


# ---------------------------------------------------------------------------------------------
# The problem
# ---------------------------------------------------------------------------------------------


def fd_parameter_derivative(
    residual: Callable[[np.ndarray, np.ndarray], np.ndarray], x: np.ndarray, p: np.ndarray
) -> np.ndarray:
    """``F_p`` by central differences: four residual evaluations for two parameters.

    Parameters
    ----------
    residual : callable
        ``residual(x, p) -> ndarray(n)``.
    x, p : ndarray
        The state and the parameters.

    Returns
    -------
    ndarray, shape (n, len(p))

    Notes
    -----
    .. math:: F_{p_j} \\approx [F(x, p + h_j e_j) - F(x, p - h_j e_j)] / (2 h_j),
              \\qquad h_j = \\varepsilon^{1/3} \\max(1, |p_j|),

    divided by the representable difference of the two parameter values.
    """
    x = np.array(x, dtype=float)
    p = np.array(p, dtype=float)
    columns = []
    for j in range(p.size):
        h = FD_STEP * max(1.0, abs(p[j]))
        plus, minus = p.copy(), p.copy()
        plus[j] += h
        minus[j] -= h
        difference = np.asarray(residual(x, plus), float) - np.asarray(residual(x, minus), float)
        columns.append(difference / (plus[j] - minus[j]))
    return np.column_stack(columns)


def fd_jacobian_action_derivative(
    jacobian: Callable[[np.ndarray, np.ndarray], np.ndarray],
    x: np.ndarray,
    p: np.ndarray,
    q: np.ndarray,
    direction: np.ndarray,
) -> np.ndarray:
    """``d/dt [J(x + t dx, p + t dp) q]`` at ``t = 0`` by central differences of ``J``.

    Two Jacobian evaluations, whatever the number of columns of ``q``.

    Parameters
    ----------
    jacobian : callable
        ``jacobian(x, p) -> ndarray(n, n)``.
    x, p : ndarray
        The point.
    q : ndarray, shape (n,) or (n, k)
        The vector(s) the derivative of ``J`` acts on (real or complex).
    direction : ndarray, shape (n + 2,) or (n,)
        ``(dx, dp)``; a length-``n`` direction means ``dp = 0``.

    Returns
    -------
    ndarray, the shape of ``q``

    Notes
    -----
    .. math:: F_{xz}(q, d) \\approx [J(z + h d) - J(z - h d)]\\, q / (2h), \\qquad
              h = \\varepsilon^{1/3} \\max(1, |x|_\\infty, |p|_\\infty) / |d|_\\infty .

    The error is ``h**2 |F_xxxx| / 6`` plus ``eps |J| / h``: 1e-11 to 1e-10 relative on the
    smooth test problems (docs/reference/codim2.md).
    """
    x = np.asarray(x, dtype=float)
    p = np.asarray(p, dtype=float)
    d = np.asarray(direction, dtype=float)
    n = x.size
    if d.size == n:
        d = np.concatenate([d, np.zeros(p.size)])
    dx, dp = d[:n], d[n:]
    size = float(np.max(np.abs(d))) if d.size else 0.0
    q = np.asarray(q)
    if size == 0.0:
        return np.zeros(q.shape, dtype=np.result_type(q, float))
    h = FD_STEP * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(p)))) / size
    plus = np.asarray(jacobian(x + h * dx, p + h * dp), float)
    minus = np.asarray(jacobian(x - h * dx, p - h * dp), float)
    return (plus - minus) @ q / (2.0 * h)


class Problem(abc.ABC):
    """A parameter-dependent system ``B dx/dt = F(x, p)`` with ``p`` of length 2.

    Subclass and implement :meth:`residual` and :meth:`jacobian`; override the others where
    something cheaper or more accurate than the defaults exists.  Any object with the same
    methods (duck typing) is accepted as well.

    Attributes
    ----------
    mass : ndarray (n, n) or None
        The constant mass matrix ``B``; ``None`` (the default) means the identity.  A singular
        ``B`` (algebraic rows, e.g. ``diag(I_m, 0)``) is allowed: only the finite eigenvalues
        of the pencil ``(J, B)`` count.

    Notes
    -----
    Cost is counted in calls (:class:`Evaluations`).  The defaults cost four residual
    evaluations (:meth:`parameter_derivative`) and two Jacobian evaluations
    (:meth:`jacobian_action_derivative`) per call.
    """

    mass: np.ndarray | None = None

    @abc.abstractmethod
    def residual(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``F(x, p)``, shape (n,)."""

    @abc.abstractmethod
    def jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``J = F_x(x, p)``, dense, shape (n, n): the matrix whose singularity (or that of
        ``J - i omega B``) defines the fold (Hopf) curves and whose pencil gives the
        stability.  A problem whose stability operator is *not* the derivative of ``F`` (the
        vesicle's SPEC §9 operator) returns that operator here and the derivative from
        :meth:`state_jacobian`."""

    # Optional: ``state_jacobian(x, p) -> ndarray (n, n)``, the exact ``F_x`` where it differs
    # from :meth:`jacobian`; Newton's rows of ``F`` (and the curves' tangents) use it, so that
    # they converge quadratically.  Not defined here: a problem without it has ``F_x = J``.
    #
    # Optional: ``newton_action_derivative(x, p, q, direction, J) -> like q``, a cheaper
    # approximation of :meth:`jacobian_action_derivative` used only inside Newton matrices and
    # tangents (where its error slows the convergence but does not move the solution); ``J``
    # is :meth:`jacobian` at ``(x, p)`` when the caller has it, else ``None``.  The test functions
    # (cusp coefficient, BT) keep the accurate derivative.  A problem with a false attribute
    # ``newton_actions`` is treated as not having the hook (its reference path); likewise one
    # with a false ``exact_parameter_derivative`` for :meth:`parameter_derivative`.
    #
    # Optional: ``spectrum_pencil(J) -> (A, B)``, the pencil whose finite eigenvalues are the
    # growth rates that the spectrum check (``other_unstable``) and the reported eigenvalues
    # use, where it is not ``(J, mass)``: a problem with neutral modes of a symmetry that the
    # dynamics removes (the vesicle's translations in the general basis) holds them fixed by
    # extra algebraic rows there.  The defining systems keep ``J`` and ``mass``.

    def parameter_derivative(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``F_p(x, p)``, shape (n, 2); default :func:`fd_parameter_derivative`."""
        return fd_parameter_derivative(self.residual, x, p)

    def jacobian_action_derivative(
        self, x: np.ndarray, p: np.ndarray, q: np.ndarray, direction: np.ndarray
    ) -> np.ndarray:
        """``d/dt [J(x + t dx, p + t dp) q]``, with ``direction = (dx, dp)`` of length n + 2.

        ``q`` is (n,) or (n, k); the result has its shape.  In terms of second derivatives
        this is ``F_xx(q, dx) + F_xp(q, dp)``.  Default: :func:`fd_jacobian_action_derivative`.
        """
        return fd_jacobian_action_derivative(self.jacobian, x, p, q, direction)


def _overrides(problem: Any, name: str) -> bool:
    """Whether ``problem`` brings its own ``name`` (not :class:`Problem`'s default)."""
    own = getattr(type(problem), name, None)
    return own is not None and own is not getattr(Problem, name)


@dataclass(frozen=True)
class Evaluations:
    """Calls made to the problem.

    ``residual`` and ``jacobian`` include those made by the default finite-difference
    hooks; ``parameter_derivative`` and ``action`` count calls of hooks the problem supplies
    itself (zero when it uses the defaults).
    """

    residual: int = 0
    jacobian: int = 0
    parameter_derivative: int = 0
    action: int = 0

    @property
    def total(self) -> int:
        """All calls together (each is roughly one residual-sized cost in the vesicle)."""
        return self.residual + self.jacobian + self.parameter_derivative + self.action

    def __add__(self, other: Evaluations) -> Evaluations:
        return Evaluations(
            self.residual + other.residual,
            self.jacobian + other.jacobian,
            self.parameter_derivative + other.parameter_derivative,
            self.action + other.action,
        )

    def __sub__(self, other: Evaluations) -> Evaluations:
        return Evaluations(
            self.residual - other.residual,
            self.jacobian - other.jacobian,
            self.parameter_derivative - other.parameter_derivative,
            self.action - other.action,
        )


class _Evaluator:
    """The problem behind a counter, with the defaults routed through the counted calls."""

    def __init__(
        self, problem: Any, n: int, differences: str = "forward", forward_step: float | None = None
    ):
        for name in ("residual", "jacobian"):
            if not callable(getattr(problem, name, None)):
                raise TypeError(f"the problem has no {name}(x, p) method")
        self.problem = problem
        self.n = n
        self.own_parameter_derivative = _overrides(problem, "parameter_derivative") and \
            bool(getattr(problem, "exact_parameter_derivative", True))  # fmt: skip
        self.own_action = _overrides(problem, "jacobian_action_derivative")
        mass = getattr(problem, "mass", None)
        if callable(mass):
            mass = mass()
        if mass is None:
            self.B = np.eye(n)
        else:
            self.B = np.array(mass, dtype=float)
            if self.B.shape != (n, n):
                raise ValueError(f"mass has shape {self.B.shape}, expected {(n, n)}")
        self.identity_mass = bool(np.array_equal(self.B, np.eye(n)))
        self.counts = [0, 0, 0, 0]
        self.own_state_jacobian = callable(getattr(problem, "state_jacobian", None))
        self.own_newton_action = callable(getattr(problem, "newton_action_derivative", None)) \
            and bool(getattr(problem, "newton_actions", True))  # fmt: skip
        self.differences = differences
        self.forward_step = _FORWARD_STEP if forward_step is None else float(forward_step)
        self.base: tuple = (None, None, None, None)
        self.own_pencil = callable(getattr(problem, "spectrum_pencil", None))

    def spectrum_pencil(self, J: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The pencil of the spectrum check: the problem's, else ``(J, B)`` (``B`` ``None``
        for the identity)."""
        if not self.own_pencil:
            return J, None if self.identity_mass else self.B
        A, B = self.problem.spectrum_pencil(np.asarray(J, float))
        A, B = np.asarray(A, float), np.asarray(B, float)
        if A.shape != B.shape or A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] < self.n:
            raise ValueError(f"spectrum_pencil gave shapes {A.shape} and {B.shape}: expected "
                             f"two square matrices of the same size, at least {self.n}")
        return A, B

    def evaluations(self) -> Evaluations:
        return Evaluations(*self.counts)

    def residual(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        self.counts[0] += 1
        r = np.asarray(self.problem.residual(np.array(x, float), np.array(p, float)), float)
        if r.shape != (self.n,):
            raise ValueError(f"residual has shape {r.shape}, expected {(self.n,)}")
        return r

    def jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        self.counts[1] += 1
        J = np.asarray(self.problem.jacobian(np.array(x, float), np.array(p, float)), float)
        if J.shape != (self.n, self.n):
            raise ValueError(f"jacobian has shape {J.shape}, expected {(self.n, self.n)}")
        return J

    def state_jacobian(self, x: np.ndarray, p: np.ndarray, J: np.ndarray) -> np.ndarray:
        """``F_x`` for the rows of ``F`` in a Newton matrix: the problem's
        ``state_jacobian`` where it has one (``J`` of the same point otherwise)."""
        if not self.own_state_jacobian:
            return J
        Jf = np.asarray(self.problem.state_jacobian(np.array(x, float), np.array(p, float)),
                        float)  # fmt: skip
        if Jf.shape != (self.n, self.n):
            raise ValueError(f"state_jacobian has shape {Jf.shape}, expected {(self.n, self.n)}")
        return Jf

    def parameter_derivative(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        if self.own_parameter_derivative:
            self.counts[2] += 1
            Fp = self.problem.parameter_derivative(np.array(x, float), np.array(p, float))
            Fp = np.asarray(Fp, float)
        else:
            Fp = fd_parameter_derivative(self.residual, x, p)
        if Fp.shape != (self.n, 2):
            raise ValueError(f"parameter_derivative has shape {Fp.shape}, expected {(self.n, 2)}")
        return Fp

    def set_base(self, x: np.ndarray, p: np.ndarray, F: np.ndarray | None, J: np.ndarray):
        """The point of the Newton step under way, with its residual and Jacobian."""
        self.base = (np.array(x, float), np.array(p, float), F, J)

    def step_parameter_derivative(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``F_p`` for a Newton matrix: the problem's hook, else central or forward
        differences (forward: two residuals, reusing ``F`` at the base point)."""
        if self.own_parameter_derivative or self.differences == "central":
            return self.parameter_derivative(x, p)
        bx, bp, F, _ = self.base
        if F is None or not (np.array_equal(bx, x) and np.array_equal(bp, p)):
            return self.parameter_derivative(x, p)
        columns = []
        for j in range(2):
            plus = np.array(p, float)
            plus[j] += self.forward_step * max(1.0, abs(p[j]))
            columns.append((self.residual(x, plus) - F) / (plus[j] - p[j]))
        return np.column_stack(columns)

    def step_action(self, x: np.ndarray, p: np.ndarray, q: np.ndarray, direction: np.ndarray):
        """``F_xz(q, direction)`` for a Newton matrix: the problem's hook, else central or
        forward differences of ``J`` (forward: one Jacobian, reusing ``J`` at the base);
        the problem's ``newton_action_derivative`` before all of them where it has one, except
        once a corrector has turned to central differences (``Settings.central_after``) and
        the problem has its own accurate ``jacobian_action_derivative``: then that one (next
        to a cusp Newton stalls on the approximate derivative)."""
        if self.own_newton_action and not (self.differences == "central" and self.own_action):
            self.counts[3] += 1
            bx, bp, _, J = self.base
            same = bx is not None and np.array_equal(bx, x) and np.array_equal(bp, p)
            r = self.problem.newton_action_derivative(
                np.array(x, float),
                np.array(p, float),
                np.array(q),
                np.array(direction, float),
                J if same else None,
            )
            r = np.asarray(r)
            if r.shape != np.shape(q):
                raise ValueError(
                    f"newton_action_derivative has shape {r.shape}, expected {np.shape(q)}"
                )
            return r
        if self.own_action or self.differences == "central":
            return self.action(x, p, q, direction)
        bx, bp, _, J = self.base
        if not (np.array_equal(bx, x) and np.array_equal(bp, p)):
            return self.action(x, p, q, direction)
        d = np.asarray(direction, dtype=float)
        n = self.n
        size = float(np.max(np.abs(d)))
        if size == 0.0:
            return np.zeros(np.shape(q))
        h = self.forward_step * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(p)))) / size
        return (self.jacobian(x + h * d[:n], p + h * d[n:]) - J) @ q / h

    def action(self, x: np.ndarray, p: np.ndarray, q: np.ndarray, direction: np.ndarray):
        """``F_xz(q, direction)``; ``q`` real (n,) or (n, k)."""
        if self.own_action:
            self.counts[3] += 1
            r = self.problem.jacobian_action_derivative(
                np.array(x, float), np.array(p, float), np.array(q), np.array(direction, float)
            )
            r = np.asarray(r)
            if r.shape != np.shape(q):
                raise ValueError(
                    f"jacobian_action_derivative has shape {r.shape}, expected {np.shape(q)}"
                )
            return r
        return fd_jacobian_action_derivative(self.jacobian, x, p, q, direction)


