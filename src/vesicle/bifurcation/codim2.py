"""Two-parameter continuation of fold and Hopf curves, with their codim-2 points (issue 40).

A generic core that knows nothing about vesicles.  The system is

.. math::  B \\dot x = F(x, p), \\qquad x \\in R^n,\\ p \\in R^2,

with a constant, possibly singular, mass matrix ``B`` (a DAE: the vesicle has
``x = (a, mu)`` and ``B = diag(I, 0)``).  Its equilibria are stable when every finite
eigenvalue ``s`` of the pencil ``J v = s B v`` (``J = F_x``) has a negative real part.

* a **fold** (saddle-node) point is an equilibrium with ``J`` singular;
* a **Hopf** point is an equilibrium with ``J - i omega B`` singular for some ``omega > 0``;
* a **Bogdanov-Takens** (BT) point is a double zero of the pencil with one eigenvector
  (``J q0 = 0``, ``J q1 = B q0``), where the fold curve ends the Hopf curve (``omega -> 0``);
* a **cusp** is a fold point where the fold normal-form coefficient
  ``a = 1/2 w^T F_xx(v, v)`` vanishes: the fold curve's projection on the parameter plane
  turns back there.

Fold and Hopf curves are continued in ``(x, p)`` (and ``omega``) by pseudo-arclength, defined
by minimally augmented systems (Govaerts 2000): ``F = 0`` plus one real (fold) or one complex
(Hopf) test function from a bordered linear system, so that the unknowns are only ``(x, p)``
or ``(x, p, omega)``.  Every Newton step is the full Newton step of the augmented system
(quadratic convergence up to the 1e-8 error of the differences that stand in for second
derivatives) yet asks the problem for second derivatives only along two or three directions
per iteration (see :func:`_newton_step`), which is what matters when one residual or Jacobian
costs a second.
The standard extended systems (the null vector ``q`` as unknowns) are implemented too
(``Settings(method="extended")``) for comparison; docs/reference/codim2.md gives the measurements.

Public API: :class:`Problem` (what a problem provides), :class:`Settings`,
:func:`locate_fold`, :func:`locate_hopf`, :func:`locate_bt` (from a point near one: the start
of every curve), :func:`fold_curve`, :func:`hopf_curve` (also from a BT point: the switch fold
-> Hopf), the frozen results :class:`CurvePoint`, :class:`SpecialPoint`, :class:`Curve`,
:class:`Evaluations`, and the helpers :func:`finite_eigenvalues`,
:func:`fd_parameter_derivative`, :func:`fd_jacobian_action_derivative`.
"""

from __future__ import annotations

import abc
import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq

__all__ = [
    "FD_STEP",
    "Curve",
    "CurvePoint",
    "Evaluations",
    "Problem",
    "Settings",
    "SpecialPoint",
    "fd_jacobian_action_derivative",
    "fd_parameter_derivative",
    "finite_eigenvalues",
    "fold_curve",
    "hopf_curve",
    "locate_bt",
    "locate_fold",
    "locate_hopf",
]

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


# ---------------------------------------------------------------------------------------------
# Settings and results
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Settings:
    """Tolerances and step control.

    Attributes
    ----------
    ds, ds_min, ds_max : float
        First, smallest and largest pseudo-arclength step, measured in ``(x, p)`` (and
        ``omega`` on Hopf curves) with unit weights.
    max_iter : int
        Newton iterations per corrector (twice this for the locating solves).
    ftol : float
        Converged when the largest residual (``|F|_inf`` and the test functions) is below
        this ...
    step_tol : float
        ... and the iterate's error, estimated from the last two Newton steps, below
        ``step_tol (1 + |u|_inf)``: the last step itself, or after two steps (with
        ``estimate_error``) ``theta / (1 - theta)`` times it, ``theta < 1`` the ratio of the
        last step to the one before (Deuflhard, *Newton Methods for Nonlinear Problems*,
        2004, Sec. 2.1: the error bound of a contraction with that rate; quadratic convergence
        makes it an overestimate).  It saves the last iteration, whose only purpose was to
        show a small step: a Jacobian and a Newton step per point.
    estimate_error : bool
        Whether the step ratio's error estimate may stand for the last step (above).
    max_angle : float
        Largest angle (rad) between consecutive secants; a larger turn is refused and the
        step halved (a guard against jumping to another curve).
    locate_tol : float
        Tolerance in arclength for locating a root of a test function along a curve (cusp).
    unstable_tol : float
        An eigenvalue other than the critical ones counts as unstable when its real part is
        ``>= -unstable_tol``.
    n_eigenvalues : int
        How many leading finite eigenvalues (largest real parts) each point keeps.
    finite_ratio : float
        An eigenvalue of the pencil is finite when ``|s| <= finite_ratio |J|_F / |B|_F``:
        the infinite eigenvalues of an index-2 DAE come out of QZ near ``1/sqrt(eps)`` times
        that scale (docs/reference/codim2.md).
    monitor_cusp : bool
        Evaluate the cusp coefficient at every fold point (one call of the Jacobian action
        derivative, two Jacobians by default); without it cusps are not detected.
    monitor_turn : bool
        Locate a smooth extremum of ``p[0]`` along a fold curve (a special point ``"turn"``):
        where two consecutive steps move ``p[0]`` opposite ways, the root of the ``p[0]``
        component of the curve's tangent (the kernel of its defining system's Jacobian, oriented
        along the curve) by Brent's method between the three points.  The tangent is that of
        whatever system defines the curve, so this holds for a curve defined by an approximate
        Jacobian too, where a test built on ``w^T F_p`` would not.  A cusp (where ``p[1]``
        turns) is not one.  Off by default: on the BT normal form the turn coincides with BT
        (its fold curve ``p0 = p1^2 / 4``).
    method : {"minaug", "extended"}
        The defining system of the curves: minimally augmented (the default) or the standard
        extended system with the null vector among the unknowns.
    newton_differences : {"forward", "central"}
        Differences for the derivatives in Newton matrices and tangents where the problem
        supplies no hook: forward (``F_p``: two residuals, a second derivative along one
        direction: one Jacobian, both reusing the base point's) or central (the
        :class:`Problem` defaults: four residuals, two Jacobians).  Test functions (the cusp
        coefficient) always use the central default or the hook.
    target_iterations : int
        The step grows by 1.5 after a corrector of at most this many Newton iterations and
        shrinks by 0.7 after one of ``target_iterations + 2`` or more (3 suits Newton whose
        second derivatives are differences with linear convergence).
    central_after : int
        With forward differences: after this many Newton iterations without convergence the
        rest of that solve uses central differences (0: never).  Next to a cusp the fold
        system's row along the null vector, ``2a``, tends to zero and the forward
        differences' error swamps it (measured on the vesicle: correctors stuck at residuals
        of 1e-3 for 8 iterations).
    forward_step : float, optional
        Relative step of those forward differences; default ``sqrt(eps)`` (1.5e-8), right for
        a problem evaluated to rounding.  A problem whose Jacobian carries noise ``delta``
        (iterative solves) wants about ``sqrt(delta)``: the derivative's error is then about
        ``sqrt(delta)`` relative, which only makes Newton's convergence linear at that rate
        (the converged point is defined by ``F`` and the test functions, not by these
        derivatives).
    stall_after : int
        Give up a corrector whose residual after this many iterations or more is not below
        the one it started from (0: never; then only ``max_iter`` and a 100-fold growth end
        it).  On the vesicle a corrector that increases its residual on its first iterations
        has not been seen to recover (v = 0.95, N = 4: 11 refused steps next to a cusp, each
        5 iterations); with 2 a refused step costs 2 iterations.
    land_ahead : float
        A landing value of ``p[0]`` (``landing=`` of the curves) at most ``land_ahead`` times
        the step ahead is landed on directly, without an intermediate point (1: only one
        the step passes; a failed landing falls back to the plain step).
    """

    ds: float = 0.05
    ds_min: float = 1e-5
    ds_max: float = 0.5
    max_iter: int = 8
    ftol: float = 1e-10
    step_tol: float = 1e-6
    estimate_error: bool = True
    max_angle: float = 0.4
    locate_tol: float = 1e-11
    unstable_tol: float = 0.0
    n_eigenvalues: int = 6
    finite_ratio: float = 1e4
    monitor_cusp: bool = True
    monitor_turn: bool = False
    method: str = "minaug"
    newton_differences: str = "forward"
    forward_step: float | None = None
    target_iterations: int = 2
    central_after: int = 0
    stall_after: int = 0
    land_ahead: float = 1.0

    def __post_init__(self):
        if not 0 < self.ds_min <= self.ds <= self.ds_max:
            raise ValueError(f"need 0 < ds_min <= ds <= ds_max, got {self}")
        if self.max_iter < 1 or self.n_eigenvalues < 0 or self.target_iterations < 1 or \
                self.central_after < 0 or self.stall_after < 0 or \
                not self.land_ahead >= 1.0:  # fmt: skip
            raise ValueError(
                "need max_iter >= 1, n_eigenvalues >= 0, target_iterations >= 1, "
                "central_after >= 0, stall_after >= 0 and land_ahead >= 1"
            )
        if not (self.ftol > 0 and self.step_tol > 0 and self.locate_tol > 0):
            raise ValueError("tolerances must be positive")
        if not 0 < self.max_angle < math.pi:
            raise ValueError("need 0 < max_angle < pi")
        if self.newton_differences not in ("forward", "central"):
            raise ValueError(
                "newton_differences must be 'forward' or 'central', "
                f"got {self.newton_differences!r}"
            )
        if self.forward_step is not None and not 0 < self.forward_step < 1:
            raise ValueError(f"forward_step must lie in (0, 1), got {self.forward_step}")
        if self.method not in ("minaug", "extended"):
            raise ValueError(f"method must be 'minaug' or 'extended', got {self.method!r}")


def _frozen(a: Any) -> np.ndarray:
    out = np.array(a, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class CurvePoint:
    """One converged (or not) point of a fold or Hopf curve, or a BT point.

    Attributes
    ----------
    kind : {"fold", "hopf", "bt"}
    x : ndarray (n,)
        The state.
    p : ndarray (2,)
        The parameters.
    omega : float
        The Hopf frequency (0 on fold curves and at BT points).
    residual : float
        Largest residual of the defining system at the point (``|F|_inf``, test functions).
    converged : bool
    iterations : int
        Newton iterations of its corrector.
    tests : Mapping[str, float]
        Test functions: fold ``g`` (the bordered test function, 0 on the curve), ``bt``
        (``w^T B v / |w||v|``), ``cusp`` (``1/2 w^T F_xx(v, v) / |w||v|^2``, NaN when not
        monitored); Hopf ``g_re``, ``g_im``, ``omega``; BT ``g``, ``bt``, ``cusp``.
    eigenvalues : ndarray
        The leading finite eigenvalues of the pencil ``(J, B)``, largest real part first.
    other_unstable : bool
        Whether an eigenvalue other than the critical one(s) (the zero of a fold, the pair
        ``+-i omega`` of a Hopf point, the double zero of BT) has real part ``>= 0``: then
        the curve is not a stability boundary there.
    v, w : ndarray (n,)
        Right and left null vectors of ``J`` (fold, BT) or of ``J - i omega B`` (Hopf,
        complex), unit length.
    evaluations : Evaluations
        Calls made to reach this point since the previous one (failed tries included).
    refused : int
        Steps of the continuation refused (and halved) since the previous point.
    """

    kind: str
    x: np.ndarray
    p: np.ndarray
    omega: float
    residual: float
    converged: bool
    iterations: int
    tests: Mapping[str, float]
    eigenvalues: np.ndarray
    other_unstable: bool
    v: np.ndarray
    w: np.ndarray
    evaluations: Evaluations = field(default_factory=Evaluations)
    refused: int = 0


@dataclass(frozen=True, eq=False)
class SpecialPoint:
    """A codim-2 point (or the end of a curve) found along a curve.

    Attributes
    ----------
    kind : {"bt", "cusp", "turn", "hopf_end"}
        ``"turn"`` is a fold curve's smooth extremum in ``p[0]`` (:class:`Settings`,
        ``monitor_turn``); ``"hopf_end"`` is the end of a Hopf curve
        (omega -> 0) that could not be located as a BT point.
    point : CurvePoint
        The located point (kind ``"bt"`` for BT, ``"fold"`` for a cusp or turn); for an
        unlocated one, the nearest curve point.
    located : bool
        Whether the defining system was solved to tolerance.
    residual : float
        Largest residual of the defining system at ``point``, test function included
        (BT: ``F``, ``g``, ``w^T B v``; cusp: ``F``, ``g``, ``a``; turn: ``F``, ``g`` and
        the tangent's ``p[0]`` component).
    test : float
        The test function at ``point`` (BT: ``w^T B v / |w||v|``; cusp: ``a``; turn: the unit
        tangent's ``p[0]`` component).
    index : int
        The special point lies between ``points[index]`` and ``points[index + 1]`` of its
        curve (the last point for a curve's end).
    iterations : int
        Newton iterations (BT) or root-finder evaluations (cusp) of the location.
    evaluations : Evaluations
        Calls made by the location.
    """

    kind: str
    point: CurvePoint
    located: bool
    residual: float
    test: float
    index: int
    iterations: int
    evaluations: Evaluations = field(default_factory=Evaluations)


@dataclass(frozen=True, eq=False)
class Curve:
    """A continued fold or Hopf curve.

    Attributes
    ----------
    kind : {"fold", "hopf"}
    method : {"minaug", "extended"}
    points : tuple of CurvePoint
        In the order of continuation, the start first.
    special : tuple of SpecialPoint
        Codim-2 points in the order found.
    end : str
        Why the continuation stopped: ``"max_points"``, ``"bounds"`` (a point left the
        parameter box; it is the last point), ``"stopped"`` (the caller's ``stop``),
        ``"bt"`` (a Hopf curve reached omega = 0 at a located BT point), ``"hopf_end"`` (the
        same, unlocated), ``"step_too_small"``.
    evaluations : Evaluations
        All calls made, start tangent and locations included.
    """

    kind: str
    method: str
    points: tuple[CurvePoint, ...]
    special: tuple[SpecialPoint, ...]
    end: str
    evaluations: Evaluations

    @property
    def x(self) -> np.ndarray:
        """States, shape (len(points), n)."""
        return np.array([pt.x for pt in self.points])

    @property
    def p(self) -> np.ndarray:
        """Parameters, shape (len(points), 2)."""
        return np.array([pt.p for pt in self.points])

    @property
    def omega(self) -> np.ndarray:
        """Frequencies, shape (len(points),)."""
        return np.array([pt.omega for pt in self.points])

    @property
    def iterations(self) -> np.ndarray:
        """Newton iterations per point."""
        return np.array([pt.iterations for pt in self.points])


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


# ---------------------------------------------------------------------------------------------
# Points: monitors (test functions, spectrum)
# ---------------------------------------------------------------------------------------------


def _spectrum(J, ev, kind: str, omega: float, s: Settings):
    """Leading finite eigenvalues and whether a non-critical one has ``Re >= -unstable_tol``."""
    eig = finite_eigenvalues(*ev.spectrum_pencil(J), s.finite_ratio)
    rest = list(eig)
    targets = {"fold": [0.0], "bt": [0.0, 0.0], "hopf": [1j * omega, -1j * omega]}[kind]
    for target in targets:
        if rest:
            rest.pop(int(np.argmin(np.abs(np.array(rest) - target))))
    other = bool(any(z.real >= -s.unstable_tol for z in rest))
    order = np.argsort(-eig.real, kind="stable")
    return eig[order][: s.n_eigenvalues], other


def _admissible_target(ev, J, s: Settings, target: float | None) -> complex:
    """The eigenvalue the borders start from: of the problem's spectrum pencil where it has
    one (so that a neutral symmetry mode, absent from that pencil, is not taken for the
    critical one), nearest ``target`` (``None``: the complex one nearest the imaginary axis);
    without such a pencil, ``target`` itself."""
    if not ev.own_pencil:
        return target
    admissible = finite_eigenvalues(*ev.spectrum_pencil(J), s.finite_ratio)
    if target is None:
        upper = admissible[admissible.imag > 1e-8 * max(1.0, float(np.max(np.abs(admissible))))]
        if upper.size == 0:
            raise ValueError("the pencil has no complex eigenvalue: not near a Hopf point")
        return complex(upper[int(np.argmin(np.abs(upper.real)))])
    if admissible.size == 0:
        raise ValueError("the spectrum pencil has no finite eigenvalue")
    return complex(admissible[int(np.argmin(np.abs(admissible - target)))])


def _fold_tests(ev, J, u, b, c, s: Settings, cusp: bool):
    """``g``, ``bt``, ``cusp`` from the real bordered system; returns tests, v, w."""
    n = ev.n
    v, g, w, _ = _bordered(J, b, c)
    nv, nw = np.linalg.norm(v), np.linalg.norm(w)
    tests = {"g": float(g), "bt": float(w @ (ev.B @ v)) / (nv * nw), "cusp": math.nan}
    if cusp:
        Fxx = ev.action(u[:n], u[n : n + 2], v, np.concatenate([v, np.zeros(2)]))
        tests["cusp"] = 0.5 * float(w @ Fxx) / (nw * nv * nv)
    return tests, v / nv, w / nw


def _point(ev, kind, u, solved: _Solved, b, c, s: Settings, since: Evaluations) -> CurvePoint:
    """A :class:`CurvePoint` from a solved state and the borders of its system; its
    evaluations are those made since ``since``, its own monitors included."""
    n = ev.n
    J = solved.J
    omega = float(u[-1]) if kind == "hopf" else 0.0
    if not solved.converged and (J is None or not np.all(np.isfinite(J))):
        # a failed solve whose last iterate cannot be analysed: reported, not raised
        dtype = complex if kind == "hopf" else float
        return CurvePoint(kind=kind, x=_frozen(u[:n]), p=_frozen(u[n : n + 2]), omega=omega,
                          residual=float(solved.residual), converged=False,
                          iterations=int(solved.iterations), tests=MappingProxyType({}),
                          eigenvalues=_frozen(np.zeros(0, complex)), other_unstable=False,
                          v=_frozen(np.zeros(n, dtype)), w=_frozen(np.zeros(n, dtype)),
                          evaluations=ev.evaluations() - since)  # fmt: skip
    try:
        return _analysed(ev, kind, u, solved, b, c, s, since, J, omega)
    except np.linalg.LinAlgError:
        if solved.converged:
            raise
        return _point(ev, kind, u, _Solved(u, False, solved.iterations, solved.residual,
                                           None, None), b, c, s, since)  # fmt: skip


def _analysed(ev, kind, u, solved, b, c, s, since, J, omega) -> CurvePoint:
    """:func:`_point` of a state whose Jacobian is finite: monitors and spectrum."""
    n = ev.n
    if kind == "hopf":
        v, g, w, _ = _bordered(J - 1j * omega * ev.B, b, c)
        tests = {"g_re": float(g.real), "g_im": float(g.imag), "omega": omega}
        v, w = _unit(v), _unit(w)
    else:
        tests, v, w = _fold_tests(ev, J, u, b, c, s, s.monitor_cusp)
    eig, other = _spectrum(J, ev, kind, omega, s)
    return CurvePoint(
        kind=kind,
        x=_frozen(u[:n]),
        p=_frozen(u[n : n + 2]),
        omega=omega,
        residual=float(solved.residual),
        converged=bool(solved.converged),
        iterations=int(solved.iterations),
        tests=MappingProxyType(tests),
        eigenvalues=_frozen(eig),
        other_unstable=other,
        v=_frozen(v),
        w=_frozen(w),
        evaluations=ev.evaluations() - since,
    )


# ---------------------------------------------------------------------------------------------
# Starting points and BT points
# ---------------------------------------------------------------------------------------------


def _prepare(problem, x, p, s: Settings) -> tuple[_Evaluator, np.ndarray, np.ndarray]:
    x = np.array(x, dtype=float).ravel()
    p = np.array(p, dtype=float).ravel()
    if p.size != 2:
        raise ValueError(f"p must have two components, got {p.size}")
    if x.size < 1 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(p))):
        raise ValueError("x and p must be finite and x non-empty")
    return _Evaluator(problem, x.size, s.newton_differences, s.forward_step), x, p


def _fixing_row(n: int, size: int, free: int, p: np.ndarray):
    if free not in (0, 1):
        raise ValueError(f"free must be 0 or 1, got {free}")
    row = np.zeros((1, size))
    row[0, n + 1 - free] = 1.0
    return row, np.array([p[1 - free]])


def locate_fold(
    problem: Any,
    x: Sequence[float] | np.ndarray,
    p: Sequence[float] | np.ndarray,
    *,
    free: int = 0,
    v: np.ndarray | None = None,
    w: np.ndarray | None = None,
    settings: Settings | None = None,
) -> CurvePoint:
    """Converge a point near a fold of a one-parameter branch onto the fold curve.

    Parameters
    ----------
    problem : Problem
    x, p : array_like
        A point on (or near) the branch in ``p[free]`` near its fold, e.g. the tracer's.
    free : {0, 1}
        The parameter the branch moves; the other one is held at its value.
    v, w : ndarray, optional
        Guesses of the right and left null vectors; by default the eigenvectors of the
        finite eigenvalue of the pencil nearest zero.
    settings : Settings, optional

    Returns
    -------
    CurvePoint
        Of kind ``"fold"``; check ``converged``.

    Notes
    -----
    Newton on ``F(x, p) = 0, g(x, p) = 0, p[1 - free] = const`` (``n + 2`` equations and
    unknowns), ``g`` the bordered test function of :func:`fold_curve`.
    """
    s = settings or Settings()
    ev, x, p = _prepare(problem, x, p, s)
    if v is None or w is None:
        J = ev.jacobian(x, p)
        eig, vl, vr = _pencil_vectors(J, ev.B, s.finite_ratio)
        if eig.size == 0:
            raise ValueError("the pencil has no finite eigenvalue")
        i = int(np.argmin(np.abs(eig - _admissible_target(ev, J, s, 0.0))))
        v = _realify(vr[:, i]) if v is None else v
        w = _realify(vl[:, i]) if w is None else w
    b, c = _unit(np.asarray(w, float)), _unit(np.asarray(v, float))
    n = ev.n
    u = np.concatenate([x, p])
    row, target = _fixing_row(n, u.size, free, p)
    solved = _newton(ev, _MinAugFold(n, ev.B, b, c), u, row, target, s, 2 * s.max_iter)
    if not solved.converged:
        log.warning("locate_fold: Newton did not converge (residual %.3g)", solved.residual)
    return _point(ev, "fold", solved.u, solved, b, c, s, Evaluations())


def locate_hopf(
    problem: Any,
    x: Sequence[float] | np.ndarray,
    p: Sequence[float] | np.ndarray,
    *,
    free: int = 0,
    omega: float | None = None,
    v: np.ndarray | None = None,
    w: np.ndarray | None = None,
    settings: Settings | None = None,
) -> CurvePoint:
    """Converge a point near a Hopf point of a one-parameter branch onto the Hopf curve.

    Parameters
    ----------
    problem : Problem
    x, p : array_like
        A point on (or near) the branch in ``p[free]`` near its Hopf point.
    free : {0, 1}
        The parameter the branch moves; the other one is held.
    omega : float, optional
        Guess of the frequency; by default the imaginary part of the finite eigenvalue with
        positive imaginary part nearest the imaginary axis (nearest ``i omega`` if given).
    v, w : ndarray (complex), optional
        Guesses of the right and left eigenvectors for ``+i omega``.
    settings : Settings, optional

    Returns
    -------
    CurvePoint
        Of kind ``"hopf"``; check ``converged``.

    Notes
    -----
    Newton on ``F = 0, Re g = Im g = 0, p[1 - free] = const`` in ``(x, p, omega)``, ``g`` the
    complex bordered test function of :func:`hopf_curve`.
    """
    s = settings or Settings()
    ev, x, p = _prepare(problem, x, p, s)
    if v is None or w is None or omega is None:
        J = ev.jacobian(x, p)
        eig, vl, vr = _pencil_vectors(J, ev.B, s.finite_ratio)
        upper = np.flatnonzero(eig.imag > 1e-8 * max(1.0, float(np.max(np.abs(eig)))))
        if upper.size == 0:
            raise ValueError("the pencil has no complex eigenvalue: not near a Hopf point")
        if omega is None:  # the pair nearest the axis (among the admissible modes)
            distance = (np.abs(eig[upper] - _admissible_target(ev, J, s, None)) if ev.own_pencil
                        else np.abs(eig[upper].real))  # fmt: skip
            i = upper[int(np.argmin(distance))]
            omega = float(eig[i].imag)
        else:
            i = upper[int(np.argmin(np.abs(eig[upper] - 1j * omega)))]
        v = vr[:, i] if v is None else v
        w = vl[:, i] if w is None else w
    if not omega > 0:
        raise ValueError(f"omega must be positive, got {omega}")
    b, c = _unit(np.asarray(w, complex)), _unit(np.asarray(v, complex))
    n = ev.n
    u = np.concatenate([x, p, [omega]])
    row, target = _fixing_row(n, u.size, free, p)
    solved = _newton(ev, _MinAugHopf(n, ev.B, b, c), u, row, target, s, 2 * s.max_iter)
    if not solved.converged:
        log.warning("locate_hopf: Newton did not converge (residual %.3g)", solved.residual)
    return _point(ev, "hopf", solved.u, solved, b, c, s, Evaluations())


def _bt(ev, z, b, c, s: Settings, index: int = 0) -> SpecialPoint:
    """Newton on the BT system from ``z``; a :class:`SpecialPoint` of kind ``"bt"``."""
    start = ev.evaluations()
    system = _BogdanovTakens(ev.n, ev.B, b, c)
    solved = _newton(ev, system, z, np.zeros((0, z.size)), np.zeros(0), s, 2 * s.max_iter)
    if solved.J is None:
        raise np.linalg.LinAlgError("BT location failed before its first evaluation")
    point = _point(ev, "bt", solved.u, solved, b, c, s, start)
    log.info(
        "BT %s at p = %s (residual %.2g)",
        "located" if solved.converged else "NOT located",
        np.array2string(point.p, precision=8),
        solved.residual,
    )
    return SpecialPoint(
        kind="bt",
        point=point,
        located=solved.converged,
        residual=solved.residual,
        test=point.tests.get("bt", math.nan),  # a failed solve carries no tests
        index=index,
        iterations=solved.iterations,
        evaluations=ev.evaluations() - start,
    )


def locate_bt(
    problem: Any,
    x: Sequence[float] | np.ndarray,
    p: Sequence[float] | np.ndarray,
    *,
    v: np.ndarray | None = None,
    w: np.ndarray | None = None,
    settings: Settings | None = None,
) -> SpecialPoint:
    """Locate a Bogdanov-Takens point from a point near it.

    Parameters
    ----------
    problem : Problem
    x, p : array_like
        A point near the BT point (e.g. where the tracer's critical eigenvalues change from a
        complex pair to two real ones).
    v, w : ndarray, optional
        Guesses of the right and left null vectors; by default those of the finite
        eigenvalue nearest zero (made real).
    settings : Settings, optional

    Returns
    -------
    SpecialPoint
        Of kind ``"bt"``; ``point.v``, ``point.w`` are ``q0`` and the left null vector.

    Notes
    -----
    Newton on ``F = 0, g = 0, psi = w^T B v = 0`` in ``(x, p)`` (``n + 2`` equations and
    unknowns, regular at a nondegenerate BT point), ``v, w`` from the fold's bordered
    systems.
    """
    s = settings or Settings()
    ev, x, p = _prepare(problem, x, p, s)
    if v is None or w is None:
        J = ev.jacobian(x, p)
        eig, vl, vr = _pencil_vectors(J, ev.B, s.finite_ratio)
        if eig.size == 0:
            raise ValueError("the pencil has no finite eigenvalue")
        i = int(np.argmin(np.abs(eig - _admissible_target(ev, J, s, 0.0))))
        v = _realify(vr[:, i]) if v is None else v
        w = _realify(vl[:, i]) if w is None else w
    b, c = _unit(np.asarray(w, float)), _unit(np.asarray(v, float))
    return _bt(ev, np.concatenate([x, p]), b, c, s)


# ---------------------------------------------------------------------------------------------
# Continuation
# ---------------------------------------------------------------------------------------------


class _Tracer:
    """Pseudo-arclength continuation of one curve with its special points."""

    def __init__(self, ev, form: _Formulation, s: Settings, bounds, max_points, progress,
                 stop=None, landing=None, give_up=None):  # fmt: skip
        self.ev, self.form, self.s = ev, form, s
        self.bounds = None if bounds is None else np.asarray(bounds, dtype=float)
        if self.bounds is not None and self.bounds.shape != (2, 2):
            raise ValueError("bounds must be [[p0_min, p0_max], [p1_min, p1_max]]")
        if max_points < 2:
            raise ValueError("max_points must be at least 2")
        self.max_points = max_points
        self.progress = progress
        self.stop = stop
        self.give_up = give_up
        self.landing = sorted({float(x) for x in landing}) if landing is not None else []
        self.skip_first: set[str] = set()
        self.points: list[CurvePoint] = []
        self.states: list[np.ndarray] = []
        self.special: list[SpecialPoint] = []

    # -- the corrector -------------------------------------------------------------------------

    def arc_row(self, t: np.ndarray) -> np.ndarray:
        """The constraint row: ``t`` on the arclength components; on a Hopf curve whose
        secant moves mostly in ``(x, p)``, its ``(x, p)`` part only (then the Newton step needs
        one Jacobian action derivative fewer)."""
        form = self.form
        row = np.where(form.geom, t, 0.0)
        if form.kind == "hopf":
            tz = row[: form.nz]
            if tz @ tz >= 0.5 * (row @ row):
                row = np.zeros_like(row)
                row[: form.nz] = tz
        return row / np.linalg.norm(row)

    def correct(self, u_guess, u_from, t, sigma) -> _Solved:
        """The curve point on the hyperplane ``row (u - u_from) = sigma``."""
        row = self.arc_row(t)
        target = row @ u_from + sigma
        return _newton(self.ev, self.form.system(), u_guess, row, [target], self.s)

    def make_point(self, u, solved, since: Evaluations) -> CurvePoint:
        form = self.form
        return _point(self.ev, form.kind, u, solved, form.b, form.c, self.s, since)

    # -- the loop ------------------------------------------------------------------------------

    def run(self, start: CurvePoint, u: np.ndarray, t: np.ndarray) -> Curve:
        """Continue from ``start`` (state ``u``) along the tangent ``t``."""
        ev, form, s = self.ev, self.form, self.s
        begin = mark = ev.evaluations()
        self.points.append(start)
        self.states.append(u)
        t = t / np.linalg.norm(t[form.geom])
        ds, end, bt_tries = s.ds, "max_points", 0
        refusals = 0  # steps refused since the last point
        done: set[float] = set()  # landing values reached (or given up on)
        while len(self.points) < self.max_points:
            u_pred = u + ds * t
            reach = s.land_ahead * ds
            land, step = self.landing_value(u, u + reach * t, done), ds
            if land is not None:
                u_pred = u + reach * t
            if land is None:
                solved = self.correct(u_pred, u, t, ds * (self.arc_row(t) @ t))
            else:  # a shorter step onto p[0] = land, corrected there with p[0] held
                n0 = ev.n
                step = reach * (land - u[n0]) / (u_pred[n0] - u[n0])
                u_pred = u + step * t
                row = np.zeros(u.size)
                row[n0] = 1.0
                solved = _newton(ev, form.system(), u_pred, row, [land], s)
            refused, length = self.refusal(solved, u, u_pred, t, step)
            if land is not None:
                done.add(land)
                if refused is not None:  # the landing failed: the arclength step instead
                    refusals += 1
                    if self.give_up is not None and self.give_up(refusals):
                        end = "given_up"
                        break
                    log.debug("%s curve: landing on p0 = %.6g refused: %s", form.kind, land,
                              refused)  # fmt: skip
                    continue
            # omega = 0 (to rounding) is not a Hopf point: there the complex border condition
            # loses a row and the fold curve solves the system too (a corrector can land on it)
            if refused is None and form.kind == "hopf" and \
                    form.omega(solved.u) <= _OMEGA_FLOOR * form.omega(u):  # fmt: skip
                if bt_tries < _BT_TRIES and self.hopf_end(u):
                    end = "bt"
                    break
                bt_tries += 1
                refused = "omega <= 0"
            if refused is not None:
                log.debug("%s curve: step %.3g refused: %s", form.kind, ds, refused)
                refusals += 1
                if self.give_up is not None and self.give_up(refusals):
                    end = "given_up"
                    break
                ds *= 0.5
                if ds < s.ds_min:
                    end = "step_too_small"
                    if refused == "omega <= 0":
                        end = "hopf_end"
                        self.special.append(
                            SpecialPoint(
                                "hopf_end",
                                self.points[-1],
                                False,
                                math.nan,
                                form.omega(u),
                                len(self.points) - 1,
                                0,
                            )
                        )
                    break
                continue
            point = replace(self.make_point(solved.u, solved, mark), refused=refusals)
            refusals = 0
            if form.kind == "fold":
                self.fold_special(u, solved.u, point)
            self.points.append(point)
            self.states.append(solved.u)
            form.accept(solved.u, point)
            mark = ev.evaluations()
            if self.progress is not None:
                self.progress(point)
            log.debug(
                "%s point %d: p = %s, omega = %.6g, %d iterations",
                form.kind,
                len(self.points) - 1,
                point.p,
                point.omega,
                point.iterations,
            )
            t = (solved.u - u) / length
            u = solved.u
            if solved.iterations <= s.target_iterations:
                ds = min(s.ds_max, 1.5 * ds)
            elif solved.iterations >= s.target_iterations + 2:
                ds = max(s.ds_min, 0.7 * ds)
            if self.bounds is not None and np.any(
                (point.p < self.bounds[:, 0]) | (point.p > self.bounds[:, 1])
            ):
                end = "bounds"
                break
            if self.stop is not None and self.stop(point, tuple(self.special)):
                end = "stopped"
                break
            if form.kind == "hopf" and t[-1] < 0 and form.omega(u) + ds * t[-1] <= 0.0:
                # the next step would cross omega = 0: the curve ends at a BT point
                if bt_tries < _BT_TRIES and self.hopf_end(u):
                    end = "bt"
                    break
                bt_tries += 1
                ds = max(s.ds_min, min(ds, 0.5 * form.omega(u) / -t[-1]))
        log.info(
            "%s curve: %d points, end %s, special %s",
            form.kind,
            len(self.points),
            end,
            [sp.kind for sp in self.special],
        )
        return Curve(
            kind=form.kind,
            method=form.method,
            points=tuple(self.points),
            special=tuple(self.special),
            end=end,
            evaluations=ev.evaluations() - begin,
        )

    def landing_value(self, u, u_pred, done: set[float]) -> float | None:
        """The first landing value of ``p[0]`` strictly past ``u`` and up to the prediction."""
        a, b = u[self.ev.n], u_pred[self.ev.n]
        hits = [x for x in self.landing if x not in done and
                min(a, b) < x <= max(a, b) and abs(x - a) > 1e-12]  # fmt: skip
        return min(hits, key=lambda x: abs(x - a)) if hits else None

    def refusal(self, solved: _Solved, u, u_pred, t, ds) -> tuple[str | None, float]:
        """Why a corrected point is refused (None: accepted), and the step's length."""
        form, s = self.form, self.s
        if not solved.converged:
            return f"Newton ({solved.iterations} iterations, residual {solved.residual:.2g})", 0.0
        step = np.where(form.geom, solved.u - u, 0.0)
        length = float(np.linalg.norm(step))
        miss = float(np.linalg.norm(np.where(form.geom, solved.u - u_pred, 0.0)))
        if length == 0.0 or miss > ds:
            return f"jump ({miss:.3g} from the prediction, step {ds:.3g})", length
        if step @ t < math.cos(s.max_angle) * length * np.linalg.norm(t[form.geom]):
            return "angle", length
        return None, length

    # -- special points ------------------------------------------------------------------------

    def fold_special(self, u_a, u_b, point_b: CurvePoint) -> None:
        """BT and cusp between the last point and ``point_b`` (same borders: same signs)."""
        a = self.points[-1]
        skip = self.skip_first if len(self.points) == 1 else set()
        found = []
        if "bt" not in skip and a.tests["bt"] * point_b.tests["bt"] < 0:
            theta = a.tests["bt"] / (a.tests["bt"] - point_b.tests["bt"])
            found.append((theta, "bt"))
        ca, cb = a.tests["cusp"], point_b.tests["cusp"]
        if "cusp" not in skip and np.isfinite(ca) and np.isfinite(cb) and ca * cb < 0:
            found.append((ca / (ca - cb), "cusp"))
        n0 = self.ev.n
        if self.s.monitor_turn and len(self.states) >= 2 and not found:
            before, last = u_a[n0] - self.states[-2][n0], u_b[n0] - u_a[n0]
            if before * last < 0:  # p[0] turned within the last two steps
                sp = self.locate_turn(self.states[-2], u_b, len(self.points) - 2)
                if sp is not None:
                    self.special.append(sp)
        for theta, kind in sorted(found):
            index = len(self.points) - 1
            if kind == "bt":
                z = (1 - theta) * u_a[: self.form.nz] + theta * u_b[: self.form.nz]
                try:
                    sp = _bt(self.ev, z, self.form.b, self.form.c, self.s, index)
                except np.linalg.LinAlgError:
                    log.warning("BT between fold points %d and %d not located", index, index + 1)
                    continue
            else:
                sp = self.locate_cusp(u_a, u_b, ca, cb, index)
            self.special.append(sp)

    def locate_cusp(self, u_a, u_b, fa, fb, index) -> SpecialPoint:
        """The root of the cusp coefficient along the chord from ``u_a`` to ``u_b``."""
        ev, s, form = self.ev, self.s, self.form

        def cusp(solved: _Solved, t: np.ndarray) -> float:
            tests, _, _ = _fold_tests(ev, solved.J, solved.u, form.b, form.c, s, True)
            return tests["cusp"]

        return self._root_along(u_a, u_b, fa, fb, index, "cusp", cusp)

    def locate_turn(self, u_a, u_b, index) -> SpecialPoint | None:
        """The extremum of ``p[0]`` between ``u_a`` and ``u_b`` (two steps of the curve): the
        root of the ``p[0]`` component of the tangent, oriented along the chord."""
        ev, form = self.ev, self.form
        n0 = ev.n
        chord = np.where(form.geom, u_b - u_a, 0.0)

        def slope(solved: _Solved, t: np.ndarray) -> float:
            k = _tangent(ev, form.system(), solved.u)
            k = k if k @ chord >= 0 else -k
            return float(k[n0] / np.linalg.norm(k[form.geom]))

        try:
            fa = slope(_Solved(u_a, True, 0, 0.0, None, None), chord)
            fb = slope(_Solved(u_b, True, 0, 0.0, None, None), chord)
        except np.linalg.LinAlgError as error:
            log.warning("turn near point %d not located: %s", index + 1, error)
            return None
        if not fa * fb < 0:
            log.info("p[0] turned near point %d, but the tangents at the ends agree", index + 1)
            return None
        return self._root_along(u_a, u_b, fa, fb, index, "turn", slope,
                                max(self.s.locate_tol, _TURN_XTOL))  # fmt: skip

    def _root_along(self, u_a, u_b, fa, fb, index, kind, evaluate,
                    xtol: float | None = None) -> SpecialPoint:  # fmt: skip
        """The root of ``evaluate(solved, t)`` along the chord from ``u_a`` to ``u_b`` (Brent),
        its values ``fa``, ``fb`` at the ends.

        Each evaluation is a corrector on the hyperplane at arclength ``sigma`` along the
        chord, from the linear interpolation, with the borders of the last point.
        """
        ev, s = self.ev, self.s
        start = ev.evaluations()
        chord = np.where(self.form.geom, u_b - u_a, 0.0)
        length = float(np.linalg.norm(chord))
        t = (u_b - u_a) / length
        cache: dict[float, tuple[_Solved, float]] = {}

        def value(sigma: float) -> float:
            if sigma == 0.0:
                return fa
            if sigma == length:
                return fb
            guess = u_a + (sigma / length) * (u_b - u_a)
            solved = self.correct(guess, u_a, t, sigma)
            if not solved.converged:
                raise np.linalg.LinAlgError(f"corrector failed while locating a {kind}")
            cache[sigma] = (solved, evaluate(solved, t))
            return cache[sigma][1]

        located, calls = False, 0
        try:
            root, info = brentq(value, 0.0, length, xtol=s.locate_tol if xtol is None else xtol,
                                rtol=4 * _EPS, full_output=True)  # fmt: skip
            if root not in cache:
                value(root)
            located, calls = bool(info.converged), info.function_calls
            solved, test = cache[root]
        except (np.linalg.LinAlgError, ValueError, RuntimeError) as error:
            log.warning(
                "%s between fold points %d and %d not located: %s", kind, index, index + 1, error
            )
            solved = _Solved(u_a, False, 0, math.nan, None, None)
            test = fa
        if solved.J is None:
            point = self.points[-1]
            residual = math.nan
        else:
            point = self.make_point(solved.u, solved, start)
            residual = max(solved.residual, abs(test))
        log.info("%s %s at p = %s", kind, "located" if located else "NOT located", point.p)
        return SpecialPoint(
            kind=kind,
            point=point,
            located=located and solved.converged,
            residual=residual,
            test=test,
            index=index,
            iterations=calls,
            evaluations=ev.evaluations() - start,
        )

    def hopf_end(self, u: np.ndarray) -> bool:
        """Try to locate the BT point where the Hopf curve reaches omega = 0.

        Near BT the Hopf curve is even in omega (``z = z_BT + O(omega^2)``): the start is the
        extrapolation to ``omega = 0`` in ``omega^2`` from the last two points, the borders
        the real parts (after a phase rotation) of the last point's eigenvectors.
        """
        form = self.form
        nz = form.nz
        zb, ob = u[:nz], form.omega(u)
        z0 = zb
        if len(self.states) >= 2:
            za, oa = self.states[-2][:nz], form.omega(self.states[-2])
            if oa > 0 and abs(oa * oa - ob * ob) > 1e-12:
                z0 = (oa * oa * zb - ob * ob * za) / (oa * oa - ob * ob)
        last = self.points[-1]
        try:
            sp = _bt(self.ev, z0, _realify(last.w), _realify(last.v), self.s, len(self.points) - 1)
        except np.linalg.LinAlgError:
            return False
        distance = float(np.linalg.norm(np.concatenate([sp.point.x, sp.point.p]) - zb))
        if not sp.located or distance > 4.0 * float(np.linalg.norm(z0 - zb)) + 2.0 * ob:
            log.info("Hopf curve: omega -> 0 but no BT point near omega = %.3g", ob)
            return False
        self.special.append(sp)
        return True


def _orient(t: np.ndarray, n: int, direction) -> np.ndarray:
    d = np.asarray(direction, dtype=float).ravel()
    if d.size != 2:
        raise ValueError("direction must be a vector in the parameter plane")
    dot = float(t[n : n + 2] @ d)
    if abs(dot) <= 1e-10 * np.linalg.norm(d) * max(float(np.linalg.norm(t)), 1e-300):
        raise ValueError(
            "the curve's tangent is normal to `direction` in the parameter plane; pick another"
        )
    return t if dot > 0 else -t


def _start_point(start: CurvePoint | SpecialPoint) -> CurvePoint:
    point = start.point if isinstance(start, SpecialPoint) else start
    if not isinstance(point, CurvePoint):
        raise TypeError("start must be a CurvePoint or a SpecialPoint")
    if not point.converged:
        raise ValueError("the start point is not converged")
    return point


def fold_curve(
    problem: Any,
    start: CurvePoint | SpecialPoint,
    *,
    direction: Sequence[float] = (1.0, 0.0),
    bounds: Sequence[Sequence[float]] | np.ndarray | None = None,
    max_points: int = 200,
    settings: Settings | None = None,
    progress: Callable[[CurvePoint], None] | None = None,
    stop: Callable[[CurvePoint, tuple[SpecialPoint, ...]], bool] | None = None,
    landing: Sequence[float] | None = None,
    give_up: Callable[[int], bool] | None = None,
) -> Curve:
    """Continue a fold (saddle-node) curve in the parameter plane.

    Parameters
    ----------
    problem : Problem
    start : CurvePoint or SpecialPoint
        A fold point from :func:`locate_fold`, or a BT point (:func:`locate_bt`, or found on a
        Hopf curve).
    direction : (2,) array_like
        The first step goes the way its parameter change has a positive component along
        ``direction``.
    bounds : (2, 2) array_like, optional
        ``[[p0_min, p0_max], [p1_min, p1_max]]``: stop at the first point outside.
    max_points : int
        Points of the curve, the start included.
    settings : Settings, optional
    progress : callable, optional
        Called with each new :class:`CurvePoint`.
    stop : callable, optional
        ``stop(point, special)`` after each new point with the special points found so far:
        True ends the curve there (``end == "stopped"``).
    landing : sequence of float, optional
        Values of ``p[0]`` the curve is to have points at exactly: a step that would pass one
        is shortened onto it and corrected with ``p[0]`` held there (where that corrector
        fails, the ordinary step is taken and the value skipped).
    give_up : callable, optional
        ``give_up(k)`` after each refused step, ``k`` the steps refused since the last point:
        True ends the curve there (``end == "given_up"``).

    Returns
    -------
    Curve
        With BT points and cusps located on the way.

    Notes
    -----
    Unknowns ``z = (x, p)``; equations (minimally augmented system, Govaerts 2000)

    .. math::
        F(x, p) = 0, \\qquad g(x, p) = 0, \\qquad
        \\begin{pmatrix} J & b \\\\ c^T & 0 \\end{pmatrix}
        \\begin{pmatrix} v \\\\ g \\end{pmatrix} = \\begin{pmatrix} 0 \\\\ 1 \\end{pmatrix},

    with the adjoint ``J^T w + c g = 0, b^T w = 1`` and ``g_z d = -w^T J_z(d) v``; ``b, c``
    are the unit left and right null vectors of the previous point.  Pseudo-arclength:
    ``t^T (z - z_k) = ds`` with ``t`` the secant (at the start the tangent).  Tests at every
    point: ``bt = w^T B v / |w||v|`` (BT where it changes sign; located by Newton on
    ``F = 0, g = 0, w^T B v = 0``) and ``cusp = 1/2 w^T F_xx(v, v) / |w||v|^2`` (located by
    Brent in arclength along the chord).
    """
    s = settings or Settings()
    point = _start_point(start)
    if point.kind not in ("fold", "bt"):
        raise ValueError(f"a fold curve starts from a fold or BT point, not {point.kind!r}")
    ev = _Evaluator(problem, point.x.size, s.newton_differences, s.forward_step)
    form = _Formulation("fold", s.method, ev.n, ev.B)
    form.set_vectors(point.v, point.w)
    u = form.state(point)
    t = _orient(_tangent(ev, form.system(), u), ev.n, direction)
    first = (
        _point(
            ev,
            "fold",
            u,
            _Solved(u, True, point.iterations, point.residual, ev.jacobian(point.x, point.p), None),
            form.b,
            form.c,
            s,
            Evaluations(),
        )
        if point.kind == "bt"
        else point
    )
    tracer = _Tracer(ev, form, s, bounds, max_points, progress, stop, landing, give_up)
    if point.kind == "bt":
        tracer.skip_first.add("bt")
    return tracer.run(first, u, t)


def hopf_curve(
    problem: Any,
    start: CurvePoint | SpecialPoint,
    *,
    direction: Sequence[float] = (1.0, 0.0),
    bounds: Sequence[Sequence[float]] | np.ndarray | None = None,
    max_points: int = 200,
    settings: Settings | None = None,
    progress: Callable[[CurvePoint], None] | None = None,
    stop: Callable[[CurvePoint, tuple[SpecialPoint, ...]], bool] | None = None,
    landing: Sequence[float] | None = None,
    give_up: Callable[[int], bool] | None = None,
) -> Curve:
    """Continue a Hopf curve in the parameter plane (``omega > 0`` along it).

    Parameters
    ----------
    problem : Problem
    start : CurvePoint or SpecialPoint
        A Hopf point from :func:`locate_hopf`, or a BT point (kind ``"bt"``, e.g. located on a
        fold curve): then the curve starts there with ``omega = 0`` and goes into
        ``omega > 0`` (the switch fold -> Hopf), and ``direction`` is not used.
    direction, bounds, max_points, settings, progress, stop, landing, give_up
        As for :func:`fold_curve`.

    Returns
    -------
    Curve
        Ending with ``end == "bt"`` and a located BT point where omega reaches zero.

    Notes
    -----
    Unknowns ``(x, p, omega)``; equations ``F = 0``, ``Re g = Im g = 0`` with

    .. math::
        \\begin{pmatrix} J - i\\omega B & b \\\\ c^H & 0 \\end{pmatrix}
        \\begin{pmatrix} v \\\\ g \\end{pmatrix} = \\begin{pmatrix} 0 \\\\ 1 \\end{pmatrix},
        \\qquad g_z d = -w^H J_z(d) v, \\quad g_\\omega = i w^H B v .

    The set ``{F = 0, g = 0}`` is symmetric in ``omega -> -omega`` and contains the fold curve
    at ``omega = 0``; BT is where they cross.  From BT the Hopf branch leaves along
    ``+omega`` (``z = z_BT + O(omega^2)``), which is the first predictor.  Approaching BT
    (``omega + ds d omega/ds <= 0``) the BT point is located by Newton on its own regular
    system from the extrapolation in ``omega^2``.
    """
    s = settings or Settings()
    point = _start_point(start)
    if point.kind not in ("hopf", "bt"):
        raise ValueError(f"a Hopf curve starts from a Hopf or BT point, not {point.kind!r}")
    ev = _Evaluator(problem, point.x.size, s.newton_differences, s.forward_step)
    form = _Formulation("hopf", s.method, ev.n, ev.B)
    form.set_vectors(point.v, point.w)
    u = form.state(point)
    if point.kind == "bt":
        t = np.zeros(u.size)
        t[-1] = 1.0
        solved = _Solved(
            u, True, point.iterations, point.residual, ev.jacobian(point.x, point.p), None
        )
        first = _point(ev, "hopf", u, solved, form.b, form.c, s, Evaluations())
    else:
        t = _orient(_tangent(ev, form.system(), u), ev.n, direction)
        first = point
    return _Tracer(ev, form, s, bounds, max_points, progress, stop, landing,
                   give_up).run(first, u, t)  # fmt: skip
