"""The settings of the method and its frozen results: curve points, special points, curves.

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vesicle.bifurcation.codim2.core import Evaluations

log = logging.getLogger(__name__)

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


