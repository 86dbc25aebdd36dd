"""Branches of steady tank-treading states in one parameter, with their stability (SPEC §16).

:func:`branch` continues the steady TT state in ``lam``, ``chi`` or ``v`` through the values asked
for: a secant predictor from the last two points, the Newton corrector of
:func:`vesicle.steady.newton.steady_tank_treading` started from the neighbour's Jacobian (chord and
Broyden steps, one solve each), and step control (a failed step is halved, the values asked for
are still the ones reported).  Every point carries its stability analysis (SPEC §9).

Special points, where the leading eigenvalue crosses ``omega_I = 0`` between two points, are
located on the branch by the secant/Brent method on ``omega_I`` (each evaluation a corrector
solve from the nearest point and a stability analysis) to ``xtol``, with their type: ``"hopf"``
(a complex pair, ``omega_R != 0``: the branch continues, the TT state is unstable beyond) or
``"saddle-node"`` (a real eigenvalue).  Near a fold (SPEC §16) the branch turns back: the
corrector fails as the step is refined towards it; the tracer then stops there, says so, and
records a ``"fold"`` special point estimated from the square-root law
``omega_I^2 ~ (lam_fold - lam)`` of the real eigenvalue along the last points (``located`` is
then false: pseudo-arclength continuation past folds is the next step of issue 13).
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from vesicle.bifurcation.continuation import ArclengthPoint, arclength_step, tangent
from vesicle.geometry.diagnostics import diagnose
from vesicle.geometry.surface import ShapeError
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import (
    ContinuationSettings,
    NewtonSettings,
    StabilitySettings,
    legacy_settings,
    refuse_unknown,
)
from vesicle.ranges import parse_range
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import (
    NEWTON_TOLERANCES,
    NewtonError,
    SteadyResult,
    steady_result_at,
    steady_tank_treading,
)
from vesicle.steady.problem import SteadyProblem
from vesicle.steady.stability import StabilityResult, stability

__all__ = [
    "PARAMETERS",
    "Branch",
    "BranchPoint",
    "SpecialPoint",
    "approach_exponent",
    "branch",
    "reach",
]

log = logging.getLogger(__name__)

#: The parameters a branch may vary.
PARAMETERS = ("lam", "chi", "v", "bq")

#: The parameters whose steps and tolerances are absolute (the others' are relative): ``bq``
#: starts at 0.
ABSOLUTE = ("lam", "bq")

#: The reduced volume of the last easier start of :func:`reach` (for smaller v): Newton from the
#: tilted spheroid converges there at lam = chi = 1, and the state is continued in v.
EASY_V = 0.95

#: Leading eigenvalues stored per point.
LEADING = 6

#: Newton iterations of a corrector step before the step is halved. A diverging corrector stops
#: earlier on its own; a converging one may need more than 15 where Newton converges only linearly
#: (v = 0.85, chi = 1, N = 4: contraction 0.49 an iteration, see
#: docs/notes/continuation-measurements.md; at lam = 3.928 the residual fell from 1.8e-4 to 1.8e-8
#: in 15 iterations, and a fold was reported at 3.921 where the branch goes on past 3.94).
BRANCH_ITERATIONS = 25

#: A corrector result farther from the predictor than this multiple of the predictor step is
#: on another branch (a plain solve beyond a fold lands elsewhere, SPEC §16): the step is halved.
JUMP = 1.0

#: A failed step is not halved below this fraction of the branch's ``xtol``: natural
#: continuation then stops and the pseudo-arclength takes over (the fold lies within it).
MIN_STEP = 0.25

#: Failed correctors towards one value after which, next to a fold (the leading eigenvalue
#: real and its growth rate nearing zero over the last two points), the pseudo-arclength is
#: tried before halving on: natural steps creep up to a fold one failed corrector at a time
#: (v = 0.95, chi = 0.2154, N = 4: 54 of the point's 67 s went to 11 failed correctors between
#: lam = 7.471 and the fold at 7.4911, which the arclength then located in 2 s).
EARLY_FAILURES = 3

#: Arclength steps of that try, each this factor longer than the last: a branch that does not
#: fold before the failed value (next to the cusp, where the real eigenvalue nears zero
#: without crossing: v = 0.95, chi = 0.278, N = 4) costs a few steps, then natural
#: continuation goes on.
PROBE_STEPS, PROBE_GROWTH = 6, 1.5

#: |omega_R| below which the most unstable mode counts as real (saddle-node, not Hopf).
REAL_TOLERANCE = 1e-2


@dataclass(frozen=True, eq=False)
class BranchPoint:
    """One steady state of a branch with its stability."""

    physics: Physics
    steady: SteadyResult
    omega: np.ndarray  # (k, 2) leading (omega_R, omega_I), most unstable first
    requested: bool  # one of the values asked for (else a refinement step)
    #: :attr:`vesicle.steady.stability.StabilityResult.curvature_shift` of this state: how much the
    #: leading growth rate depends on the multipliers (large where the resolution is too low)
    curvature_shift: float = 0.0

    @property
    def n_unstable(self) -> int:
        """Unstable modes, a complex pair counted twice."""
        return int(np.sum(self.omega[:, 1] > 0))

    @property
    def oscillatory(self) -> bool:
        """Whether an unstable mode oscillates (a complex pair)."""
        unstable = self.omega[:, 1] > 0
        return bool(np.any(np.abs(self.omega[unstable, 0]) > REAL_TOLERANCE))

    @property
    def most_unstable(self) -> tuple[float, float]:
        return float(abs(self.omega[0, 0])), float(self.omega[0, 1])

    def to_dict(self) -> dict:
        r, p = self.steady, self.physics
        w_r, w_i = self.most_unstable
        return {
            "lam": p.lam, "chi": p.chi, "v": p.v, "bq": p.bq,
            "psi": r.psi, "D": r.D, "axes": r.axes.tolist(),
            "axis_directions": diagnose(r.shape).axes.tolist(),
            **r.stress.summary(),
            "bending": r.split["bending"].summary(), "flow": r.split["flow"].summary(),
            "omega_R": w_r, "omega_I": w_i,
            "eigenvalues": self.omega.tolist(),
            "n_unstable": self.n_unstable, "oscillatory": self.oscillatory,
            "curvature_shift": self.curvature_shift,
            "newton_iterations": r.newton_iterations, "solves": r.solves,
            "residual": r.residual, "requested": self.requested,
        }  # fmt: skip


@dataclass(frozen=True)
class SpecialPoint:
    """Where the branch loses (or gains) stability, or folds."""

    kind: str  # "hopf", "saddle-node" or "fold"
    parameter: str
    value: float
    omega_R: float
    located: bool  # to xtol on the branch (False: an estimate, see the module docstring)
    bracket: tuple[float, float]

    def to_dict(self) -> dict:
        return {
            "type": self.kind,
            self.parameter: self.value,
            "omega_R": self.omega_R,
            "located": self.located,
            "bracket": list(self.bracket),
        }


@dataclass(frozen=True, eq=False)
class Branch:
    """Points in the order continued, the special points found between them, and why the
    branch ended early (``None`` if it reached every value asked for)."""

    parameter: str
    points: list[BranchPoint]
    special_points: list[SpecialPoint]
    discretisation: Discretisation
    stopped: str | None = None
    seconds: float = 0.0
    #: where it ended early: (the last value reached, the first value no state was found at)
    stopped_between: tuple[float, float] | None = None

    def to_dict(self, all_points: bool = False) -> dict:
        """JSON-able: the points asked for (all with ``all_points``) and the special points."""
        pts = [p for p in self.points if all_points or p.requested]
        return {
            "parameter": self.parameter,
            "degree": self.discretisation.degree,
            "grid": self.discretisation.grid,
            "points": [p.to_dict() for p in pts],
            "special_points": [s.to_dict() for s in self.special_points],
            "stopped": self.stopped,
            "stopped_between": list(self.stopped_between) if self.stopped_between else None,
            "seconds": self.seconds,
        }


def approach_exponent(values, growth, critical: float | None = None) -> dict:
    """Fit ``|growth| = a |critical - value|^p`` (least squares in log-log).

    For the real eigenvalue of a branch approaching a saddle-node (fold) at ``critical``,
    ``p = 1/2`` (SPEC §16; the paper's Fig. 8).  With ``critical`` given, points at it and zero
    growth rates are left out and the fit is linear in log-log; with ``critical=None`` it is
    fitted too (three parameters, the values approaching it from below; at least three points),
    an estimate of the fold independent of its location on the branch.  Returns
    ``{"exponent", "coefficient", "critical", "points", "range"}``, the range being that of
    ``|critical - value|`` fitted.
    """
    values = np.asarray(values, dtype=float)
    y = np.abs(np.asarray(growth, dtype=float))
    if critical is None:
        from scipy.optimize import least_squares

        keep = (y > 0) & np.isfinite(values) & np.isfinite(y)
        x, y = values[keep], y[keep]
        if x.size < 3:
            raise ValueError("approach_exponent needs at least three points with a nonzero "
                             "growth rate to fit the critical value too")  # fmt: skip
        span = x.max() - x.min()

        def residual(q):
            a, xc, p = q
            return np.log(a) + p * np.log(np.maximum(xc - x, 1e-14)) - np.log(y)

        q0 = [y.max() / np.sqrt(span), x.max() + 0.1 * span, 0.5]
        r = least_squares(residual, q0, bounds=([1e-14, x.max() + 1e-12, 0.0],
                                                [np.inf, np.inf, 5.0]))  # fmt: skip
        a, xc, p = r.x
        d = xc - x
        return {"exponent": float(p), "coefficient": float(a), "critical": float(xc),
                "points": int(x.size), "range": [float(d.min()), float(d.max())]}  # fmt: skip
    x = np.abs(float(critical) - values)
    keep = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if keep.sum() < 2:
        raise ValueError("approach_exponent needs at least two points short of the critical "
                         "value with a nonzero growth rate")  # fmt: skip
    slope, intercept = np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)
    fitted = x[keep]
    return {
        "exponent": float(slope),
        "coefficient": float(np.exp(intercept)),
        "critical": float(critical),
        "points": int(keep.sum()),
        "range": [float(fitted.min()), float(fitted.max())],
    }


def _analyse(steady: SteadyResult, requested: bool, modes: str = "symmetric") -> BranchPoint:
    s: StabilityResult = stability(steady, modes=modes)
    return BranchPoint(steady.physics, steady, s.omega[:LEADING].copy(), requested,
                       float(s.curvature_shift))  # fmt: skip


class _Tracer:
    """The continuation's state: points so far and the corrector."""

    def __init__(
        self, physics, discretisation, parameter, executor, progress, max_halvings,
        analysis: StabilitySettings | None = None, min_step=0.0,
    ):  # fmt: skip
        self.physics, self.disc, self.parameter = physics, discretisation, parameter
        analysis = analysis if analysis is not None else StabilitySettings()
        self.analysis, self.jacobian, self.modes = analysis, analysis.jacobian, analysis.modes
        self.executor, self.progress = executor, progress
        self.max_halvings = max_halvings
        # the shortest step a failed one is halved to (absolute in lam, relative in chi, v)
        self.min_step = min_step
        self.points: list[BranchPoint] = []  # every state computed (starts, location steps)
        self.path: list[BranchPoint] = []  # the branch, in the order continued

    def at(self, value: float) -> Physics:
        return self.physics.replace(**{self.parameter: float(value)})

    def value(self, point: BranchPoint) -> float:
        return float(getattr(point.physics, self.parameter))

    def add(self, point: BranchPoint, on_path: bool = True) -> BranchPoint:
        self.points.append(point)
        if on_path:
            self.path.append(point)
        return point

    def correct(self, value: float, requested: bool = True, on_path: bool = True) -> BranchPoint:
        """A steady state at ``value`` from the nearest point (secant predictor), analysed."""
        start, guess = None, None
        if self.points:
            order = sorted(self.points, key=lambda p: abs(self.value(p) - value))
            start = order[0].steady
            if len(order) > 1:
                p0, p1 = order[1], order[0]
                v0, v1 = self.value(p0), self.value(p1)
                if v1 != v0:  # secant predictor in the basis coordinates
                    guess = p1.steady.a + (p1.steady.a - p0.steady.a) * (value - v1) / (v1 - v0)
                if on_path and abs(v1 - v0) > 2.0 * abs(value - v1):
                    # a halved step next to a fold: the secant over the long step before
                    # misses the branch's bend by more than the short step itself, so the
                    # jump guard refused a step on the same branch (v = 0.95, chi = 0.2,
                    # N = 8: from 7.0 and 7.5 to 7.53125, moved 3.83e-3 against 2.93e-3); the
                    # tangent at the nearest point errs by the step squared
                    tangent = self.tangent_guess(p1, value)
                    guess = tangent if tangent is not None else guess
            elif on_path:  # the first step from a lone start: the tangent predictor, so that
                # the jump guard works from the first step on
                guess = self.tangent_guess(order[0], value)
        steady = steady_tank_treading(
            self.at(value),
            self.disc,
            initial=start,
            guess=guess,
            newton=NewtonSettings(max_iterations=BRANCH_ITERATIONS),
            analysis=self._newton_analysis(start),
            executor=self.executor,
        )
        if guess is not None and on_path:
            predicted = float(np.linalg.norm(guess - start.a))
            moved = float(np.linalg.norm(steady.a - guess))
            if moved > JUMP * predicted:  # landed on another branch (past a fold, say)
                raise BranchJump(
                    f"the corrector at {self.parameter} = {value:.6g} moved {moved:.2e} from the "
                    f"predictor, more than the step itself ({predicted:.2e}): another branch"
                )
        point = self.add(_analyse(steady, requested, self.modes), on_path)
        w_r, w_i = point.most_unstable
        log.info(
            "%s = %.6g: psi %.4f, omega (%.4g, %.4g)", self.parameter, value, steady.psi, w_r, w_i
        )
        if self.progress is not None:
            self.progress({self.parameter: value, "psi": steady.psi, "omega_R": w_r,
                           "omega_I": w_i, "solves": steady.solves})  # fmt: skip
        return point

    def _newton_analysis(self, start: SteadyResult | None) -> StabilitySettings:
        """Newton's branch: that of the state it continues (as the loose form did)."""
        if start is None or start.orientation == self.analysis.orientation:
            return self.analysis
        return StabilitySettings(start.orientation, self.analysis.modes, self.jacobian)

    def tangent_guess(self, point: BranchPoint, value: float) -> np.ndarray | None:
        """The basis coordinates at ``value`` predicted along the branch's tangent at
        ``point`` (``dy/dp = -G_y^-1 G_p``, one solve for ``G_p``).

        Without it the first step from a start had no predictor, so no jump guard, and a step
        past a fold could land on another part of the branch unseen (v = 0.95, chi = 0.2449,
        N = 4 on 16x32: from the stable state at lam = 7.388, the 3 % step to 7.610 converged on
        the upper part of an S-shaped branch, past the fold at 7.510, and the crossing was
        located there; with this predictor Newton diverges at 7.610, and the corrector at 7.520
        lands 4.3 predictor steps away: refused).  ``None`` where the state has no Jacobian or
        ``G_y`` is singular (at a fold): the step is then taken without a predictor."""
        steady = point.steady
        if steady.jacobian is None:
            return None
        try:
            dy = -np.linalg.solve(_blocks(steady), _Arclength(self, point).G_p(steady))
        except (np.linalg.LinAlgError, NewtonError, ShapeError, SolverError) as err:
            log.info("no tangent predictor at %s = %.6g (%s)", self.parameter,
                     self.value(point), err)  # fmt: skip
            return None
        if not np.all(np.isfinite(dy)):
            return None
        return steady.a + dy[: steady.a.size] * (value - self.value(point))

    def near_fold(self) -> bool:
        """Whether the last two points lead with a real eigenvalue whose growth rate nears
        zero (a saddle-node fold ahead, SPEC §16)."""
        if len(self.path) < 2:
            return False
        (r0, g0), (r1, g1) = self.path[-2].most_unstable, self.path[-1].most_unstable
        return max(abs(r0), abs(r1)) <= REAL_TOLERANCE and abs(g1) < abs(g0)

    def step_to(self, value: float, early: bool = False) -> BranchPoint:
        """Reach ``value`` from the last point, halving failed steps and growing them back by
        at most 2 after each success (refinement points).  With ``early``, stop (``_Stop``
        with ``early = True``) after ``EARLY_FAILURES`` failed correctors next to a fold."""
        last = self.value(self.path[-1])
        target, halvings, failures = value, 0, 0
        while True:
            try:
                point = self.correct(target, requested=target == value)
            except (NewtonError, ShapeError, SolverError, BranchJump) as err:
                failures += 1
                if early and failures >= EARLY_FAILURES and self.near_fold():
                    raise _Stop(target, last, err, f"{failures} failed correctors next to a "
                                                   "fold", early=True) from err  # fmt: skip
                if halvings >= self.max_halvings:
                    raise _Stop(target, last, err, f"after {halvings} halvings") from err
                floor = self.min_step * (1.0 if self.parameter in ABSOLUTE else abs(last))
                if 0.5 * abs(target - last) < floor:  # the fold is within the tolerance:
                    # creeping on would cost a failed corrector per step (v = 0.95,
                    # chi = 0.2594, N = 8: steps of 1e-5 in lam, 4 min each)
                    raise _Stop(target, last, err, f"a shorter step would be below "
                                                   f"{floor:.2g}") from err  # fmt: skip
                halvings += 1
                target = last + 0.5 * (target - last)
                log.info("step failed (%s); trying %s = %.6g", err, self.parameter, target)
                continue
            if target == value:
                return point
            # after a halved step, grow back at most by 2 a step, not at once to the value
            # asked for: near a fold the secant predictor of a long step is long too, and a
            # corrector that converges (the second-order Newton does, where the first-order
            # one failed) may land on another state beyond the fold within the jump guard
            # (measured: chi = 0.2, N = 4, from lam = 7.48271 to 7.62918 past the fold at
            # 7.4833, reported as a Hopf point at 7.4845)
            step, last, halvings = target - last, target, 0
            target = value if abs(value - last) <= 2.0 * abs(step) else last + 2.0 * step


class BranchJump(RuntimeError):
    """A corrector that converged far from its predictor: onto another branch."""


class _Stop(Exception):
    def __init__(self, target: float, last: float, cause: Exception, why: str = "",
                 early: bool = False):  # fmt: skip
        super().__init__(str(cause))
        self.target, self.last, self.cause, self.why = target, last, cause, why
        self.early = early  # stopped to try the arclength, not for good


def branch(
    physics: Physics,
    discretisation: Discretisation | None = None,
    parameter: str = "lam",
    values: Sequence[float] | str | None = None,
    *,
    start: SteadyResult | None = None,
    continuation: ContinuationSettings | None = None,
    analysis: StabilitySettings | None = None,
    executor: Executor | None = None,
    progress: Callable[[dict], None] | None = None,
    **legacy,
) -> Branch:
    """Continue the steady TT state of ``physics`` in ``parameter`` through ``values``.

    Parameters
    ----------
    physics, discretisation : Physics, Discretisation
        The fixed parameters (``physics``' own value of ``parameter`` is not used).
    parameter : {"lam", "chi", "v", "bq"}
    values : sequence of float or str
        The values to report, in the order to continue (``"1:9"`` with ``continuation.step``,
        ``"1:9:0.5"`` or ``"1,2,4"`` also accepted).
    start : SteadyResult, optional
        A converged state to start from (else Newton from the default start at the first value).
    continuation : ContinuationSettings
        ``locate``: locate special points between neighbouring points to ``xtol`` (relative for
        ``v`` and ``chi``, absolute for ``lam``; see :class:`SpecialPoint`); ``max_halvings``:
        halvings of a failed step before natural continuation stops (at a fold, typically);
        ``arclength``: where natural continuation stops, follow the branch by pseudo-arclength
        from the last points to locate the fold (the tangent's ``parameter`` component changes
        sign there); ``past_fold``: arclength steps beyond the fold, on the unstable side.
    analysis : StabilitySettings
        ``modes``: the perturbations analysed at every point (:func:`stability`);
        ``orientation``: the TT branch of the first point when no ``start`` is given (default:
        ``start``'s); ``jacobian``: how Newton and stability form their Jacobians.
    executor, progress
        Jacobian columns' executor; a callable given each point's summary.

    The former keywords ``step``, ``locate``, ``xtol``, ``max_halvings``, ``arclength``,
    ``past_fold`` and ``modes``, ``orientation``, ``jacobian`` work for one release, with a
    :class:`~vesicle.model.settings.VesicleDeprecationWarning`.
    """
    settings = legacy_settings("branch", ContinuationSettings, continuation, legacy)
    settings = settings or ContinuationSettings()
    analysis = legacy_settings("branch", StabilitySettings, analysis, legacy)
    refuse_unknown("branch", legacy)
    if analysis is None:
        analysis = StabilitySettings(start.orientation if start is not None else "flow")
    step, xtol, past_fold = settings.step, settings.xtol, settings.past_fold
    if parameter not in PARAMETERS:
        raise ValueError(f"parameter must be one of {PARAMETERS}, got {parameter!r}")
    if isinstance(values, str):
        values = parse_range(values, "step", step=step, name=parameter)
    if values is None or len(values) == 0:
        raise ValueError("give the values of the branch parameter")
    values = [float(x) for x in values]
    for x in values:  # every value is a valid Physics, checked before any work
        physics.replace(**{parameter: x})
    disc = discretisation if discretisation is not None else Discretisation()
    t0 = time.perf_counter()
    tracer = _Tracer(physics, disc, parameter, executor, progress, settings.max_halvings,
                     analysis, MIN_STEP * xtol)  # fmt: skip
    stopped, stopped_between, fold, ends = None, None, None, None
    if start is None:  # the first value by Newton, or by continuation from an easier point
        start = reach(tracer.at(values[0]), disc, analysis=analysis, executor=executor,
                      progress=progress)  # fmt: skip
        requested = start.physics == tracer.at(values[0])
        tracer.add(_analyse(start, requested=requested, modes=analysis.modes))
        remaining = values if not requested else values[1:]
    else:
        tracer.add(_analyse(start, requested=False, modes=analysis.modes))
        remaining = values
    try:  # a stop at the first value too is a stop (a fold right after the start)
        for value in remaining:
            early = settings.arclength
            while True:
                try:
                    tracer.step_to(value, early=early)
                    break
                except _Stop as stop:
                    if not stop.early:
                        raise
                    ends = len(tracer.path)  # the natural path: special points on it only
                    fold = _try_fold(tracer, xtol, past_fold, limit=stop.target)
                    if fold is not None:
                        raise
                    early, ends = False, None  # no fold before the target: halve on
                    log.info("no fold before %s = %.6g: natural continuation goes on",
                             parameter, stop.target)  # fmt: skip
    except _Stop as stop:
        stopped_between = (float(stop.last), float(stop.target))
        stopped = (
            f"no steady state found beyond {parameter} = {stop.last:.6g} (towards "
            f"{stop.target:.6g}, {stop.why}): {stop.cause}"
        )
        log.warning("branch stopped: %s", stopped)
    specials = _special_points(tracer, settings.locate, xtol, ends)
    if stopped is not None and fold is None:  # a fold: located by arclength, else estimated
        if settings.arclength:
            try:
                fold = _follow_fold(tracer, xtol, past_fold)
            except (ValueError, NewtonError, ShapeError, SolverError, BranchJump) as err:
                # a step to an impossible parameter (lam < 0), a failed corrector: estimate
                log.warning("pseudo-arclength could not locate the fold: %s", err)
        if fold is None and len(tracer.path) >= 3:
            fold = _fold_estimate(tracer)
    if fold is not None:
        if fold.located:
            stopped = f"{stopped}; the branch folds at {parameter} = {fold.value:.6g}"
        specials.append(fold)
    return Branch(parameter, tracer.path, specials, disc, stopped, time.perf_counter() - t0,
                  stopped_between)


def _special_points(tracer: _Tracer, locate: bool, xtol: float, ends: int | None = None) -> list:
    """Where the leading omega_I changes sign between neighbours on the path (its first
    ``ends`` points: the natural continuation's, not the arclength's past a fold)."""
    found = []
    for p0, p1 in itertools.pairwise(list(tracer.path[:ends])):
        g0, g1 = p0.most_unstable[1], p1.most_unstable[1]
        if g0 * g1 <= 0 and g0 != g1:
            found.append(_locate(tracer, p0, p1, locate, xtol))
    return found


def _locate(tracer: _Tracer, p0: BranchPoint, p1: BranchPoint, locate: bool, xtol: float):
    x0, x1 = tracer.value(p0), tracer.value(p1)
    w_r = 0.5 * (p0.most_unstable[0] + p1.most_unstable[0])
    if locate:

        def growth(x):
            for p in tracer.points:  # Brent evaluates the bracket's ends first: reuse them
                if tracer.value(p) == x:
                    return p.most_unstable[1]
            return tracer.correct(x, requested=False, on_path=False).most_unstable[1]

        tol = xtol if tracer.parameter in ABSOLUTE else xtol * abs(x0)
        try:
            x = brentq(growth, min(x0, x1), max(x0, x1), xtol=tol)
        except (NewtonError, ShapeError, SolverError, BranchJump) as err:
            # next to a fold the corrector may fail between the two points: interpolate instead
            log.warning("could not locate the crossing between %.6g and %.6g: %s", x0, x1, err)
            locate = False
        else:
            nearest = min(tracer.points, key=lambda p: abs(tracer.value(p) - x))
            w_r = nearest.most_unstable[0]
    if not locate:
        g0, g1 = p0.most_unstable[1], p1.most_unstable[1]
        x = x0 - g0 * (x1 - x0) / (g1 - g0)
    kind = "hopf" if w_r > REAL_TOLERANCE else "saddle-node"
    return SpecialPoint(kind, tracer.parameter, float(x), float(w_r), locate, (x0, x1))


def _fold_estimate(tracer: _Tracer) -> SpecialPoint | None:
    """The fold from the square-root law of a real leading eigenvalue over the last points."""
    last = tracer.path[-3:]
    if any(p.most_unstable[0] > REAL_TOLERANCE for p in last):
        return None
    x = np.array([tracer.value(p) for p in last])
    g2 = np.array([p.most_unstable[1] ** 2 for p in last])
    slope, intercept = np.polyfit(x, g2, 1)
    if slope == 0:
        return None
    fold = -intercept / slope
    return SpecialPoint("fold", tracer.parameter, float(fold), 0.0, False, (x[-1], fold))


#: Largest difference of coefficients (relative to the largest) between the state continued
#: from an easier point and the one Newton found directly for the two to be the same state
#: (both solved to the Newton tolerance, 1e-8 in the residual).
SAME_STATE = 1e-5


def reach(
    physics: Physics,
    discretisation: Discretisation | None = None,
    *,
    legs: int = 4,
    newton: NewtonSettings | None = None,
    analysis: StabilitySettings | None = None,
    executor: Executor | None = None,
    progress: Callable[[dict], None] | None = None,
    verify_unstable: bool = False,
) -> SteadyResult:
    """The steady TT state at ``physics``: Newton from the default start, or, where that fails,
    continuation from an easier point, automatically.

    The easier points are ``chi = 1`` at the same ``v`` and ``lam``, then ``lam = 1, chi = 1``
    (Newton from the tilted spheroid converges there), and for ``v`` below :data:`EASY_V` also
    ``v = EASY_V, lam = 1, chi = 1``; the state is then continued in ``v``, ``lam`` and ``chi``
    to the target, ``legs`` geometric steps each (halved where a step fails).  A viscous
    membrane (``bq > 0``) starts from the inviscid one's: the same point at ``bq = 0`` first,
    then those easier points at ``bq = 0``, and the last leg continues in ``bq`` (``legs``
    equal steps): at v = 0.95, lam = 1, chi = 1, Bq = 5 (N = 4 on 16x32) Newton from the
    default start diverged.
    A state that Newton finds from the default start with an unstable mode may be another
    branch's (the saddle half of a fold, or a state Newton wandered to: at lam = 3.7, chi = 1,
    N = 4 it lands on psi = -0.60 with a growth rate 3.7; at lam = 2, chi = 0.2, N = 8 on one
    with a single unstable pair far below lambda_c): every unstable one is checked by
    continuation from an easier point, and the continued state replaces it; where the two are
    the same state (TT past its own loss of stability) the direct one is kept, its ``start``
    "direct, checked by continuation".  (``verify_unstable``, once the option that asked for
    this check, is now always on.)  An easier start is used only if it is stable, except the
    last, ``lam = 1, chi = 1``.
    Every detour is logged and reported to ``progress`` (``{"continuation": text}``); if the
    target cannot be reached the ``NewtonError`` says how far it got.  The result's ``start``
    says how it was reached (``"direct"``, ``"continued from ..."``); a state from the default
    start that looks like another branch's is returned only when no easier start works, and
    then flagged: ``start = "suspect: ..."`` (``result.suspect``), in the JSON and in files.
    ``newton``, ``analysis``: Newton's settings and the branch (``analysis.orientation``) and
    Jacobians of every solve (:func:`steady_tank_treading`).
    """
    disc = discretisation if discretisation is not None else Discretisation()
    analysis = analysis if analysis is not None else StabilitySettings()
    solve = {"newton": newton, "analysis": analysis, "executor": executor}
    direct = None
    try:
        direct = steady_tank_treading(physics, disc, progress=progress, **solve)
    except (NewtonError, ShapeError, SolverError) as err:
        first = err
    if analysis.orientation == "vorticity":
        # the vorticity-aligned branch: Newton from the spheroid along y slides onto the
        # in-plane branch at low lam (v = 0.90, chi = 2, lam = 4.28, N = 4) but converges at
        # lam = 8 and 16: start higher in lam and come down
        easier = [physics.replace(lam=2.0 * physics.lam), physics.replace(lam=4.0 * physics.lam)]
        if physics.v < EASY_V:
            easier.append(physics.replace(lam=4.0 * physics.lam, v=EASY_V))
    else:
        easier = [physics.replace(chi=1.0), physics.replace(chi=1.0, lam=1.0)]
        if physics.v < EASY_V:  # Newton from the spheroid fails at lam = chi = 1, v = 0.90 (N = 4)
            easier.append(physics.replace(chi=1.0, lam=1.0, v=EASY_V))
    if physics.bq > 0:  # a viscous membrane: the inviscid one's easier starts, then Bq
        easier = [e.replace(bq=0.0) for e in (physics, *easier)]
    easier = list(dict.fromkeys(e for e in easier if e != physics))
    if direct is not None:
        spectrum = stability(direct)
        w_r, w_i = spectrum.most_unstable
        unstable = int(np.sum(spectrum.omega[:, 1] > 0))
        # every unstable state is checked by continuation from an easier point, which reaches
        # it again where it is the TT state past its own loss of stability.  Newton from the
        # default start wanders: to the saddle half of a fold (a real mode), to a state with
        # several unstable modes (lam = 4, chi = 10, N = 4: psi = -0.338, 7 unstable modes,
        # the leading one (15.9, 9.6)), and to one with a single unstable pair far below
        # lambda_c (lam = 2, chi = 0.2, N = 8 on 32x64: psi = -0.490, axes 2.40, 2.06, 1.44,
        # omega = (0.025, +0.340), where the TT state is stable: lambda_c is about 7.6 there)
        if not w_i > 0:
            return direct
        # a real unstable mode: possibly the saddle half of a fold (SPEC §16); the state
        # continued from chi = 1 is the one on the branch that is stable below the fold
        kind = "a real unstable mode" if w_r <= REAL_TOLERANCE else f"{unstable} unstable modes"
        first = NewtonError(f"Newton from the default start found a state with {kind} "
                            f"(omega_I = {w_i:.3g})")  # fmt: skip
        flagged = dataclasses.replace(
            direct, start=f"suspect: Newton from the default start found a state with {kind} "
            f"(omega_I = {w_i:.3g}) and no easier start reached a stable state to continue from")
        if not easier:
            return flagged

    def say(text: str) -> None:
        log.warning("%s", text)
        if progress is not None:
            progress({"continuation": text})

    start = None
    for easy in easier:
        try:
            start = steady_tank_treading(easy, disc, **solve)
        except (NewtonError, ShapeError, SolverError):
            continue
        if easy is easier[-1] or stability(start).most_unstable[1] < 0:
            break
        log.info("the easier start at lam = %g, chi = %g is unstable (Newton may have wandered "
                 "to another branch): not used", easy.lam, easy.chi)  # fmt: skip
        start = None
    if start is None:
        if direct is not None:
            say(f"{first}; no easier start worked: the state is flagged as suspect")
            return flagged
        tried = ", ".join(f"(v = {e.v:g}, lam = {e.lam:g}, chi = {e.chi:g})" for e in easier)
        raise NewtonError(
            f"no steady TT state at lam = {physics.lam:g}, chi = {physics.chi:g}: Newton from the "
            f"default start failed ({first}), and so did the easier starts {tried}"
        )
    moved = f"v = {start.physics.v:g}, " if start.physics.v != physics.v else ""
    origin = f"continued from {moved}lam = {start.lam:g}, chi = {start.chi:g}"
    say(f"{first} at lam = {physics.lam:g}, chi = {physics.chi:g}; {origin}")
    for name in ("v", "lam", "chi", "bq"):
        here, there = getattr(start.physics, name), getattr(physics, name)
        if here == there:
            continue
        if name == "bq":  # from the inviscid membrane: equal steps
            values = list(here + (there - here) * np.arange(1, legs + 1) / legs)
        else:
            values = list(here * (there / here) ** (np.arange(1, legs + 1) / legs))
        values[-1] = there
        leg = branch(start.physics, disc, name, values, start=start,
                     continuation=ContinuationSettings(locate=False),
                     analysis=StabilitySettings(start.orientation, "symmetric", analysis.jacobian),
                     executor=executor)  # fmt: skip
        if leg.stopped:
            if direct is not None:
                say(f"continuation towards {name} = {there:g} stopped; keeping the state Newton "
                    "found from the default start, flagged as suspect")  # fmt: skip
                return flagged
            raise NewtonError(f"continuation towards {name} = {there:g} stopped: {leg.stopped}")
        start = leg.points[-1].steady
        say(f"continued in {name} to {there:g}")
    if direct is not None and start.a.shape == direct.a.shape and (
            np.max(np.abs(start.a - direct.a)) <= SAME_STATE * max(1.0, np.max(np.abs(direct.a)))):
        # the continued state is the direct one: TT past its own loss of stability
        say("the continued state is the one Newton found from the default start: kept")
        return dataclasses.replace(direct, start="direct, checked by continuation")
    return dataclasses.replace(start, start=origin)


def _blocks(steady: SteadyResult) -> np.ndarray:
    """``G_y`` of the steady equations in ``y = (a, mu)`` at a converged state (SPEC §8):
    ``[[M - mu . H, -g^T], [g, 0]]`` with the state's Jacobian ``M``, the exact gradients ``g``
    and the constraints' Hessians ``H`` (the multipliers' curvature, as in Newton)."""
    M, g = steady.jacobian, steady.gradients
    H = steady.problem.constraint_hessians(steady.a)
    n = M.shape[0]
    J = np.zeros((n + 2, n + 2))
    J[:n, :n] = M - np.einsum("k,kij->ij", np.asarray(steady.multipliers), H)
    J[:n, n:], J[n:, :n] = -g.T, g
    return J


def _state(point: BranchPoint, parameter: str) -> np.ndarray:
    r = point.steady
    return np.concatenate([r.a, r.multipliers, [getattr(r.physics, parameter)]])


class _Arclength:
    """The steady equations as ``G(y, p)`` for :mod:`vesicle.bifurcation.continuation`."""

    def __init__(self, tracer: _Tracer, last: BranchPoint):
        self.tracer, self.last, self.sigma = tracer, last.steady, None

    def problem(self, p: float) -> SteadyProblem:
        return SteadyProblem(
            self.tracer.at(p), self.tracer.disc, NEWTON_TOLERANCES,
            jacobian_method=self.tracer.jacobian,
        )  # fmt: skip

    def residual(self, y: np.ndarray, p: float):
        P = self.problem(p)
        a, mu = y[:-2], y[-2:]
        shape = P.shape(a)
        rate, flow = P.adot(a, self.sigma)
        self.sigma = flow.sigma
        G, size = P.residual(shape, rate, mu, P.gradients(shape))
        return G, size, (a, mu)

    def G_p(self, steady: SteadyResult) -> np.ndarray:
        """``dG/dp`` at a converged state by a forward difference (one solve; ``G = 0`` there
        to the Newton tolerance, 1e-4 of the difference)."""
        p = float(getattr(steady.physics, self.tracer.parameter))
        dp = 1e-4 * max(1.0, abs(p))
        if self.tracer.parameter == "v" and p + dp > 1.0:
            dp = -dp
        y = np.concatenate([steady.a, steady.multipliers])
        return self.residual(y, p + dp)[0] / dp

    def jacobian(self, z: np.ndarray, data):
        """At a converged arclength point: its steady result (no Newton: at fixed parameters it
        is singular at the fold), analysed, with the blocks for the next step."""
        a, mu = data
        steady = steady_result_at(self.problem(float(z[-1])), a, mu, self.tracer.executor)
        self.last = steady
        return (_blocks(steady), self.G_p(steady),
                _analyse(steady, requested=False, modes=self.tracer.modes))  # fmt: skip


def _try_fold(tracer: _Tracer, xtol: float, past_fold: int, limit: float):
    """:func:`_follow_fold` before the natural continuation gives up: the fold if the branch
    turns back before ``limit`` (the value the last step failed to reach), else ``None`` with
    the tracer as it was."""
    try:
        return _follow_fold(tracer, xtol, past_fold, limit=limit)
    except (ValueError, NewtonError, ShapeError, SolverError, BranchJump) as err:
        log.info("pseudo-arclength next to the fold stopped: %s", err)
        return None


def _follow_fold(
    tracer: _Tracer, xtol: float, past_fold: int, limit: float | None = None
) -> SpecialPoint | None:
    """From the last two points, pseudo-arclength until the tangent's parameter component
    changes sign; the fold located by the secant method on that component (see module doc).
    With ``limit``, give up (``None``, nothing added to the tracer) once the arclength passes
    ``limit`` without a fold."""
    path = tracer.path
    if len(path) < 2 or path[-1].most_unstable[0] > REAL_TOLERANCE:
        return None  # a complex leading pair: not a saddle-node fold
    name = tracer.parameter
    A = _Arclength(tracer, path[-1])
    z0, z1 = _state(path[-2], name), _state(path[-1], name)
    G_y, G_p = _blocks(path[-1].steady), A.G_p(path[-1].steady)
    ds = 0.5 * float(np.linalg.norm(z1 - z0))
    point = ArclengthPoint(z1, tangent(G_y, G_p, previous=z1 - z0), G_y, G_p, ds, path[-1])
    log.info("natural continuation stopped: pseudo-arclength from %s = %.6g", name, z1[-1])
    ahead = np.sign(z1[-1] - z0[-1])
    taken = []  # added to the tracer once the fold is found (or, without limit, at the end)
    step, turned = ds, False
    try:
        for _ in range(16 if limit is None else PROBE_STEPS):
            nxt = arclength_step(A.residual, A.jacobian, point, step, 1e-8, ds / 64)
            taken.append(nxt.data)
            turned = np.sign(nxt.tangent[-1]) != np.sign(point.tangent[-1])
            if turned or (limit is not None and ahead * (nxt.z[-1] - limit) > 0):
                break  # the fold, or past the value the natural step failed at without one
            point = nxt
            if limit is not None:  # a probe: longer steps towards the limit
                step = PROBE_GROWTH * abs(nxt.ds)
    except (RuntimeError, NewtonError, ShapeError, SolverError) as err:
        log.warning("pseudo-arclength stopped: %s", err)
    if turned or limit is None:
        for data in taken:
            tracer.add(data)
    if not turned:
        return None
    fold, located = _locate_fold(A, point, nxt, xtol)
    beyond = nxt
    for _ in range(past_fold):  # the unstable side, if asked
        beyond = arclength_step(A.residual, A.jacobian, beyond, ds, 1e-8, ds / 64)
        tracer.add(beyond.data)
    return SpecialPoint("saddle-node", name, fold, 0.0, located, (point.z[-1], nxt.z[-1]))


def _locate_fold(
    A: _Arclength, before: ArclengthPoint, after: ArclengthPoint, xtol: float
) -> tuple[float, bool]:
    """Secant in the arclength ``s`` from ``before`` on the tangent's parameter component: the
    fold's parameter and whether the secant converged to ``xtol`` (else the last iterate, an
    estimate).  Each iterate's arclength is the step the corrector took (it may halve the one
    asked for); a corrector that fails ends the search with the estimate, not the branch."""
    s0, f0 = 0.0, before.tangent[-1]
    s1, f1 = after.ds, after.tangent[-1]
    p_fold = 0.5 * (before.z[-1] + after.z[-1])
    for _ in range(12):
        s2 = s1 - f1 * (s1 - s0) / (f1 - f0) if f1 != f0 else 0.5 * (s0 + s1)
        try:
            q = arclength_step(A.residual, A.jacobian, before, s2, 1e-8, abs(s2) / 64)
        except (RuntimeError, NewtonError, ShapeError, SolverError) as err:
            log.info("locating the fold: the corrector failed (%s); the fold is an estimate", err)
            return p_fold, False
        A.tracer.add(q.data, on_path=False)
        previous, p_fold = p_fold, float(q.z[-1])
        s0, f0, s1, f1 = s1, f1, q.ds, q.tangent[-1]
        if abs(p_fold - previous) < xtol * (1.0 if A.tracer.parameter == "lam" else abs(p_fold)):
            return p_fold, True
    return p_fold, False
