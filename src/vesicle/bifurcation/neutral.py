"""Neutral curves ``lambda_c(chi)`` at fixed ``v``: loss of stability continued in chi (SPEC §16).

The curve is a fold (saddle-node) curve at low shear and a Hopf curve at high shear.  The tracer
starts where the bracketing search of :func:`vesicle.steady.stability.critical_lambda` is reliable
(the
requested ``chi`` closest to 1, a Hopf point) and continues the critical point from there in both
directions.  Each new ``chi``:

1. predicts ``lambda_c`` from the last two points (linear in ``log chi``, ``log lambda``);
2. moves the previous critical neighbourhood's stable state to the new ``chi`` at
   ``lambda_start`` = the prediction lowered by ``margin`` (Newton from that state and its
   Jacobian; a branch in ``chi`` with step halving where one jump is too far), lowering
   ``lambda_start`` further while the state found is not stable;
3. follows the branch in ``lambda`` from there (:func:`vesicle.bifurcation.branch.branch`:
corrector from the
   neighbour, stability at every point) until its leading eigenvalue crosses: a Hopf or
   saddle-node crossing located by Brent's method, or the fold where the branch turns back,
   located by pseudo-arclength, to ``xtol``.

No new ``chi`` starts from a fresh bracket.  Where the type changes between neighbours (the
complex pair of the Hopf curve becomes two real eigenvalues, SPEC §16), the change is located by
bisection in ``log chi`` to ``type_tol``.  The ``chi`` values asked for are the ones reported;
the bisection points are reported separately.
"""

from __future__ import annotations

import itertools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from vesicle.bifurcation.branch import REAL_TOLERANCE, BranchPoint, SpecialPoint, branch, reach
from vesicle.bifurcation.critical import critical_lambda, vorticity_start_lambda
from vesicle.geometry.surface import ShapeError
from vesicle.io.files import stamped
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import (
    ContinuationSettings,
    CriticalSearch,
    StabilitySettings,
    legacy_settings,
    refuse_unknown,
)
from vesicle.model.theory import misbah_critical_lambda
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NewtonError, SteadyResult, steady_tank_treading
from vesicle.steady.stability import stability

__all__ = ["NeutralCurve", "NeutralPoint", "neutral_curve"]

log = logging.getLogger(__name__)

_FAILURES = (NewtonError, ShapeError, SolverError)

#: How many points further back along the curve a new chi may start from where its
#: neighbour's state reaches no stable state (:meth:`_Tracer.stable_start`).
FALLBACKS = 2

#: Largest ratio between neighbouring chi of the trace (intermediate points are added).
CHI_RATIO = 1.5

#: How far past a fold or real crossing (in units of ``xtol``, its own tolerance) tank-treading
#: must go on, stable or unstable only within the resolution (:meth:`_Tracer.past_fold`).
PAST_FOLD = 3.0


@dataclass(frozen=True)
class NeutralPoint:
    """``lambda_c`` at one ``chi`` with the type of the bifurcation."""

    chi: float
    lambda_c: float
    bifurcation: str  # "hopf" or "saddle-node"
    omega_R: float
    psi: float  # of the stable state nearest below lambda_c (codim2: of the critical state)
    D: float
    located: bool
    seconds: float
    #: where lambda_c lies when it is not located to xtol (a fold estimated from the last state
    #: reached and the first lam where none was found); ``None`` when located
    bracket: tuple[float, float] | None = None
    #: a stable state on the branch at least half a margin below lambda_c where there is one
    #: (else the nearest below): where the next chi starts, and the state `--states` writes
    start: SteadyResult | None = field(default=None, repr=False, compare=False)
    #: the stable state's ``curvature_shift`` (:mod:`vesicle.steady.stability`): where it is above
    #: 1e-2 the resolution is too low for the multipliers to be negligible
    curvature_shift: float = 0.0
    #: where the branch from low lam loses stability at a fold (or real crossing) at this lam
    #: and tank-treading goes on past it (on the upper part of an S-shaped branch, or past a
    #: window of unresolved real growth): ``lambda_c`` is the loss of stability further up
    #: (see :meth:`_Tracer.past_fold`)
    lower_fold: float | None = None
    #: whether that fold was located (to xtol on its branch) or is an estimate
    lower_fold_located: bool = False
    #: the largest residual of the augmented system the point was solved on (two-parameter
    #: continuation, ``method = "codim2"``); ``None`` for the one-parameter tracer
    residual: float | None = None
    #: whether an eigenvalue other than the critical one(s) is on or over the axis at the
    #: point (then it is not on the stability boundary); ``None`` where not checked
    other_unstable: bool | None = None

    def to_dict(self) -> dict:
        return {"chi": self.chi, "lambda_c": self.lambda_c, "bifurcation": self.bifurcation,
                "omega_R": self.omega_R, "psi": self.psi, "D": self.D,
                "located": self.located, "seconds": self.seconds,
                "curvature_shift": (self.curvature_shift if math.isfinite(self.curvature_shift)
                                    else None),
                **({"bracket": list(self.bracket)} if self.bracket else {}),
                **({} if self.lower_fold is None else
                   {"lower_fold": self.lower_fold,
                    "lower_fold_located": self.lower_fold_located}),
                **({} if self.residual is None else
                   {"residual": self.residual if math.isfinite(self.residual) else None}),
                **({} if self.other_unstable is None else
                   {"other_unstable": self.other_unstable})}  # fmt: skip

    @classmethod
    def from_dict(cls, d: dict, start: SteadyResult | None = None) -> NeutralPoint:
        """The point of :meth:`to_dict` (an ``--out`` file's entry), with its start state."""
        bracket = d.get("bracket")
        return cls(float(d["chi"]), float(d["lambda_c"]), str(d["bifurcation"]),
                   float(d["omega_R"]), float(d["psi"]), float(d["D"]),
                   bool(d.get("located", False)), float(d.get("seconds", 0.0)),
                   tuple(map(float, bracket)) if bracket else None, start,
                   float(d.get("curvature_shift") if d.get("curvature_shift") is not None
                         else (math.nan if "curvature_shift" in d else 0.0)),
                   None if d.get("lower_fold") is None else float(d["lower_fold"]),
                   bool(d.get("lower_fold_located", False)),
                   math.inf if "residual" in d and d["residual"] is None else
                   None if d.get("residual") is None else float(d["residual"]),
                   None if d.get("other_unstable") is None
                   else bool(d["other_unstable"]))  # fmt: skip


@dataclass(frozen=True)
class NeutralCurve:
    """The traced curve, the located type change (or ``None``) and the cost."""

    physics: Physics  # v and flow (lam and chi are what is traced)
    discretisation: Discretisation
    points: list[NeutralPoint]
    type_change: dict | None
    bisection: list[NeutralPoint]
    seconds: float
    failed: list[dict] = field(default_factory=list)  # {"chi", "error"} where a direction stopped
    orientation: str = "flow"
    modes: str = "symmetric"
    xtol: float = 1e-3
    resumed: int = 0  # points taken from a checkpoint (``known``), not traced again
    #: "trace" (this module: one-parameter continuation at each chi) or "codim2" (two-parameter
    #: continuation of the fold and Hopf curves, :mod:`vesicle.bifurcation.neutral_codim2`)
    method: str = "trace"
    #: Bogdanov–Takens and cusp points found on the curves (codim2 only): chi, lambda,
    #: located, residual, the test function, other_unstable, the two smallest eigenvalues
    bt_points: list[dict] = field(default_factory=list)
    cusp_points: list[dict] = field(default_factory=list)
    #: where a fold curve's chi turns smoothly (an extremum of chi along it, not a cusp: the
    #: left or right end of the folds' range in chi), the same keys
    turn_points: list[dict] = field(default_factory=list)
    #: the Jacobian the codim2 curves are defined by (:data:`.steady_codim2.FORMS`)
    form: str = "spec"

    def to_dict(self) -> dict:
        extra = {} if self.method == "trace" else {
            "bt_points": list(self.bt_points), "cusp_points": list(self.cusp_points),
            "turn_points": list(self.turn_points), "form": self.form}  # fmt: skip
        return stamped({
            "method": self.method,
            **extra,
            "v": self.physics.v,
            "degree": self.discretisation.degree,
            "grid": self.discretisation.grid,
            "xtol": self.xtol,
            "resumed": self.resumed,
            "physics": {k: x for k, x in self.physics.to_dict().items() if k not in ("lam", "chi")},
            "discretisation": self.discretisation.to_dict(),
            "points": [p.to_dict() for p in self.points],
            "type_change": self.type_change,
            "bisection": [p.to_dict() for p in self.bisection],
            "failed": list(self.failed),
            "orientation": self.orientation,
            "modes": self.modes,
            "seconds": self.seconds,
        })


def _state_key(state: SteadyResult) -> tuple:
    """A state by its content (parameters, coordinates and multipliers, bit for bit): the key of
    the legs already tried from it."""
    return (state.physics.key, state.discretisation.grid, state.a.tobytes(),
            tuple(state.multipliers))  # fmt: skip


class _Tracer:
    def __init__(self, physics, disc, xtol, margin, progress, analysis: StabilitySettings,
                 executor, known=(), checkpoint=None):  # fmt: skip
        self.physics, self.disc, self.xtol, self.margin = physics, disc, xtol, margin
        # points already traced (a resumed curve), by their exact chi, and the callback given
        # each new point (with its start state) before ``progress``
        self.known = {p.chi: p for p in known}
        self.checkpoint = checkpoint
        self.resumed: set[float] = set()
        self.progress, self.analysis, self.modes = progress, analysis, analysis.modes
        # +1: TT stable below lambda_c (the in-plane branch); -1: stable above it (vorticity)
        self.side = -1 if analysis.orientation == "vorticity" else 1
        self.executor = executor
        self.options = {"analysis": analysis, "executor": executor}  # of branch, reach
        # branch legs of _to that failed, by (id of the start state, parameter, value), with
        # the state and the error: emptied at each new point
        self._failed_legs: dict[tuple, NewtonError] = {}

    def at(self, chi: float, lam: float) -> Physics:
        return self.physics.replace(chi=float(chi), lam=float(lam))

    def newton(self, physics: Physics, start: SteadyResult) -> SteadyResult:
        analysis = StabilitySettings(start.orientation, self.modes, self.analysis.jacobian)
        return steady_tank_treading(physics, self.disc, initial=start, analysis=analysis,
                                    executor=self.executor)  # fmt: skip

    def _to(
        self, start: SteadyResult, parameter: str, value: float, direct: bool = True
    ) -> SteadyResult:
        """``start`` moved in one parameter: Newton directly (unless not ``direct``), else a
        branch with step halving and its jump guard."""
        target = start.physics.replace(**{parameter: float(value)})
        if direct:
            try:
                return self.newton(target, start)
            except _FAILURES as err:
                log.info("direct move to %s = %.4g failed (%s): by a branch", parameter, value,
                         err)  # fmt: skip
        key = (_state_key(start), parameter, float(value))
        if key in self._failed_legs:  # the same leg from the same state: the branch is
            # deterministic, so it fails again (a move tried directly, then by branches)
            raise self._failed_legs[key]
        leg = branch(start.physics, self.disc, parameter, [value], start=start,
                     continuation=ContinuationSettings(locate=False, arclength=False),
                     **self.options)  # fmt: skip
        if leg.stopped:
            err = NewtonError(f"could not continue to {parameter} = {value:g}: {leg.stopped}")
            self._failed_legs[key] = err
            raise err
        return leg.points[-1].steady

    def move(
        self, start: SteadyResult, chi: float, lam: float, direct: bool = True
    ) -> SteadyResult:
        """A steady state at (chi, lam) from ``start``: first in lam at the start's chi (below
        the old critical point the branch exists), then in chi at that lam."""
        if start.lam != lam:
            start = self._to(start, "lam", lam, direct)
        return start if start.chi == chi else self._to(start, "chi", chi, direct)

    def stable_start(
        self, start: SteadyResult, chi: float, lam: float, fallbacks: Sequence[SteadyResult] = ()
    ) -> SteadyResult:
        """A stable state at ``chi`` at or below ``lam``: where there is none there (beyond a
        fold, or past the loss of stability) lam is lowered by twice the margin and the move
        repeated.  At each lam the move is tried from ``start`` first, then from each of
        ``fallbacks`` (the start states of points further back along the curve): next to the
        cusp the neighbour's state can lie on the upper part of an S-shaped branch, which
        folds going down in lam at its chi, while a state further from the cusp, where the
        branch is monotone, passes below the S (v = 0.95, chi = 0.27, N = 8 on 32x64: from the
        Hopf point 7.668 the branch stops at lam = 7.598 going down, and every lower lam
        failed from there, 2 h of correctors)."""
        starts = [start, *(f for f in fallbacks if f is not None)]
        for _ in range(8):
            for k, origin in enumerate(starts):
                for direct in (True, False):  # a direct Newton may land on another state
                    try:
                        state = self.move(origin, chi, lam, direct)
                    except _FAILURES as err:
                        log.info("chi = %.4g: no state reached at lam = %.4g from chi = %.4g "
                                 "(%s)", chi, lam, origin.chi, err)  # fmt: skip
                        continue
                    if stability(state, modes=self.modes).most_unstable[1] < 0:
                        if k:
                            log.warning("chi = %.4g: started from the state at chi = %.4g, "
                                        "lam = %.4g (none reached from the neighbour at chi "
                                        "= %.4g)", chi, origin.chi, origin.lam,
                                        start.chi)  # fmt: skip
                        return state
                    log.info("chi = %.4g: the state at lam = %.4g is not stable", chi, lam)
            lam *= 1.0 - 2.0 * self.margin * self.side
        raise NewtonError(f"no stable tank-treading state found at chi = {chi:g} "
                          f"{'down' if self.side > 0 else 'up'} to lam = {lam:g}")  # fmt: skip

    def crossing(self, state: SteadyResult, lam_pred: float) -> tuple:
        """Follow the branch up in lam from ``state``, in steps of ``margin`` (two at a time,
        so that the secant predictor and the jump guard of the branch work and a fold is met
        by step halving), until its stability changes."""
        lam, side = state.lam, self.side
        ratio = (1.0 + self.margin) ** side  # towards the loss of stability
        for _ in range(int(math.log(3.0) / math.log(1.0 + self.margin)) // 2 + 1):  # 3x lam
            values = [lam * ratio, lam * ratio**2]
            b = branch(state.physics, self.disc, "lam", values, start=state,
                       continuation=ContinuationSettings(xtol=self.xtol),
                       **self.options)  # fmt: skip
            crossings = [s for s in b.special_points if side * (s.value - lam) > 0]
            if crossings:
                return crossings[0], b
            if b.stopped:  # a fold the arclength could not locate (a complex pair leads there,
                # next to the type change): the last point reached, within the step halving
                last = max((p.physics.lam for p in b.points), key=lambda x: side * x)
                log.warning("chi = %.4g: the branch folds near lam = %.6g (not located: %s)",
                            state.chi, last, b.stopped)  # fmt: skip
                failed = b.stopped_between[1] if b.stopped_between else last
                # an estimate, reported with what was computed there: the leading eigenvalue
                # of the last point reached (a complex pair is not called a saddle-node)
                end = max(b.points, key=lambda p: side * p.physics.lam)
                w_r = float(end.most_unstable[0])
                kind = "hopf" if w_r > REAL_TOLERANCE else "fold"
                return SpecialPoint(kind, "lam", last, w_r if kind == "hopf" else 0.0, False,
                                    (last, failed)), b  # fmt: skip
            state, lam = b.points[-1].steady, values[-1]
        raise NewtonError(f"no loss of stability at chi = {state.chi:g} "
                          f"{'below' if side > 0 else 'above'} lam = {lam:g}")  # fmt: skip

    def point(
        self, start: SteadyResult, chi: float, lam_pred: float,
        fallbacks: Sequence[SteadyResult] = (),
    ) -> NeutralPoint:
        if chi in self.known:  # found before the curve was interrupted: its start state is
            # the one stored, bit for bit, so the trace goes on as it would have
            log.info("chi = %.4g: lambda_c = %.6g from the checkpoint", chi,
                     self.known[chi].lambda_c)  # fmt: skip
            self.resumed.add(chi)
            return self.known[chi]
        t0 = time.perf_counter()
        self._failed_legs.clear()
        state = self.stable_start(start, chi, lam_pred * (1.0 - self.side * self.margin),
                                  fallbacks)  # fmt: skip
        special, b = self.crossing(state, lam_pred)
        p = self._point(chi, special, b, state, t0)
        log.info("chi = %.4g: lambda_c = %.6g (%s, omega_R = %.4g)", chi, p.lambda_c,
                 p.bifurcation, p.omega_R)  # fmt: skip
        if self.checkpoint is not None:  # first: a point is listed only once its state is kept
            self.checkpoint(p)
        if self.progress is not None:
            self.progress(p.to_dict())
        return p

    def _point(self, chi: float, special: SpecialPoint, b, state: SteadyResult, t0: float,
               lower_fold: float | None = None,
               lower_fold_located: bool = False) -> NeutralPoint:  # fmt: skip
        """The point of the special point ``special`` of the branch ``b`` (followed from the
        stable ``state``), with the state the next chi starts from."""
        side = self.side
        stable_side = [p for p in b.points if side * (special.value - p.physics.lam) >= 0]
        below = [p for p in stable_side if p.most_unstable[1] < 0]
        nearest: BranchPoint = (max(below, key=lambda p: side * p.physics.lam) if below
                                else b.points[0])  # fmt: skip
        # the next chi starts from a state half a margin or more below lambda_c: at a fold the
        # branch's Jacobian in lam is singular, and a natural step from next to it diverges
        # (N = 4, chi = 0.215: from lam = 7.49025, 1e-4 below the fold, every step down failed)
        limit = special.value * (1.0 - 0.5 * self.margin * side)
        away = [(p.physics.lam, p.steady) for p in below if side * (limit - p.physics.lam) >= 0]
        if side * (limit - state.lam) >= 0:  # the stable state this chi started from
            away.append((state.lam, state))
        start_from = max(away, key=lambda c: side * c[0])[1] if away else nearest.steady
        kind = "hopf" if special.kind == "hopf" else "saddle-node"
        return NeutralPoint(float(chi), float(special.value), kind, float(special.omega_R),
                            float(nearest.steady.psi), float(nearest.steady.D),
                            bool(special.located), time.perf_counter() - t0,
                            None if special.located else tuple(map(float, special.bracket)),
                            start_from, nearest.curvature_shift, lower_fold,
                            lower_fold_located)  # fmt: skip

    def past_fold(self, fold: NeutralPoint, hopf: NeutralPoint) -> NeutralPoint | None:
        """Whether tank-treading goes on past the fold of ``fold`` (the branch from low lam
        loses stability there to a real eigenvalue) on another stable branch: the point of
        that branch's own loss of stability if it does, else ``None``.

        Next to the change of type the branch can be S-shaped (v = 0.90, chi = 0.6484, N = 4
        on 16x32, by pseudo-arclength: the branch from low lam folds at 5.4618; the part above
        it comes down to a second fold at 5.4565, stable from there to its Hopf point at
        5.4955).  Between the
        first fold and that Hopf point the only TT state nearby is the upper one, and it is
        stable: the vesicle tank-treads there, and lambda_c is the Hopf point.  Which part a
        trace lands on depends on where it starts, so both are looked at.  The upper part is
        reached from the Hopf neighbour ``hopf`` (larger chi) at its own lambda_c, which lies
        above the fold curve and above the cusp where the two folds meet (at fixed lam below
        the cusp a move in chi stays on the lower part), moved to ``fold.chi`` there, and
        followed down in lam to ``PAST_FOLD * xtol`` above the fold.  Where the state there
        is stable (or unstable only within the resolution, :func:`_goes_on`: past the cusp the
        branch is monotone and only a narrow window of weak real instability is left), the
        lowest crossing above it where the branch loses stability is the point (or, if none,
        the branch is followed up as in :meth:`point`)."""
        if self.side < 0 or fold.bifurcation == "hopf" or hopf.start is None:
            return None
        probe, top = fold.lambda_c + PAST_FOLD * self.xtol, hopf.lambda_c
        if top <= probe:
            return None
        t0 = time.perf_counter()
        try:
            high = self.move(hopf.start, fold.chi, top, direct=False)
            steps = max(1, math.ceil(math.log(top / probe) / math.log(1.0 + 0.5 * self.margin)))
            values = [top * (probe / top) ** (k / steps) for k in range(1, steps + 1)]
            values[-1] = probe
            down = branch(high.physics, self.disc, "lam", values, start=high,
                          continuation=ContinuationSettings(xtol=self.xtol, arclength=False),
                          **self.options)  # fmt: skip
        except _FAILURES as err:
            log.info("chi = %.4g: no other branch past the fold at %.6g (%s)", fold.chi,
                     fold.lambda_c, err)  # fmt: skip
            return None
        end = down.points[-1]
        if down.stopped or end.physics.lam != probe or not _goes_on(end):
            log.info("chi = %.4g: no stable state past the fold at %.6g%s", fold.chi,
                     fold.lambda_c, f" ({down.stopped})" if down.stopped else "")  # fmt: skip
            return None
        losses = [s for s in down.special_points if s.value > probe and _lost_upwards(down, s)]
        if losses:
            p = self._point(fold.chi, min(losses, key=lambda s: s.value), down, end.steady,
                            t0, fold.lambda_c, fold.located)  # fmt: skip
        else:  # stable from the fold up to the Hopf neighbour's lambda_c: follow it up
            special, up = self.crossing(high, top)
            p = self._point(fold.chi, special, up, high, t0, fold.lambda_c, fold.located)
        log.warning("chi = %.4g: past the real crossing at lam = %.6g the vesicle goes on "
                    "tank-treading (another part of the branch, stable, or the same part, "
                    "unstable only within the resolution) up to the %s point at lam = %.6g "
                    "(omega_R = %.4g): lambda_c is that point", fold.chi, fold.lambda_c,
                    p.bifurcation, p.lambda_c, p.omega_R)  # fmt: skip
        return p


def _goes_on(point: BranchPoint) -> bool:
    """Whether tank-treading goes on at ``point``: it is stable, or its one unstable mode is
    real and grows more slowly than the resolution can tell from zero (below the state's
    ``curvature_shift``: past the cusp where the two folds of an S-shaped branch meet, the
    branch runs on monotone in lam, and the real eigenvalue of SPEC 9's operator may still
    poke above zero in a narrow window, an artefact of the multipliers' curvature: v = 0.90,
    chi = 0.6813, N = 4 on 16x32: growth <= 0.0019 for lam in [5.4724, 5.4770], against a
    curvature shift of 0.0092, and stable from there to the Hopf point at 5.541)."""
    w_r, w_i = point.most_unstable
    return w_i < 0 or (point.n_unstable == 1 and w_r <= REAL_TOLERANCE
                       and w_i < abs(point.curvature_shift))  # fmt: skip


def _lost_upwards(b, special: SpecialPoint) -> bool:
    """Whether the branch ``b`` loses stability at ``special`` going up in lam (stable at the
    lower end of its bracket, unstable at the upper), not regains it (the upper end of such a
    window of real instability, :func:`_goes_on`)."""
    at = {p.physics.lam: p for p in b.points}
    lo, hi = (at.get(x) for x in sorted(special.bracket))
    return lo is not None and hi is not None and lo.most_unstable[1] < 0 <= hi.most_unstable[1]


def _predict(points: list[NeutralPoint], chi: float) -> float:
    """lambda_c at chi, linear in (log chi, log lambda) through the last two points."""
    if len(points) == 1:
        return points[0].lambda_c
    a, b = points[-2], points[-1]
    slope = math.log(b.lambda_c / a.lambda_c) / math.log(b.chi / a.chi)
    return b.lambda_c * (chi / b.chi) ** slope


def curve_inputs(physics: Physics | float, chi: Sequence[float]) -> tuple[Physics, list[float]]:
    """A neutral curve's ``physics`` (or ``v``) and ``chi`` values checked before any work: the
    physics of every chi valid, the chi positive (returned ascending, without repeats)."""
    if not isinstance(physics, Physics):
        physics = Physics(v=float(physics))
    chis = sorted({float(c) for c in chi})
    if not chis or chis[0] <= 0:
        raise ValueError(f"chi values must be positive, got {list(chi)}")
    for c in chis:
        physics.replace(chi=c)
    return physics, chis


def neutral_curve(
    physics: Physics | float,
    chi: Sequence[float],
    discretisation: Discretisation | None = None,
    *,
    xtol: float = 1e-3,
    margin: float = 0.03,
    type_tol: float = 0.02,
    locate_type_change: bool = True,
    analysis: StabilitySettings | None = None,
    executor=None,
    progress: Callable[[dict], None] | None = None,
    known: Sequence[NeutralPoint] = (),
    checkpoint: Callable[[NeutralPoint], None] | None = None,
    **legacy,
) -> NeutralCurve:
    """Trace ``lambda_c(chi)`` through the values ``chi`` (see the module docstring).

    Parameters
    ----------
    physics : Physics or float
        Its ``v`` and ``flow`` (or just ``v``).
    chi : sequence of float
        The shear rates to report (positive; any order; reported ascending).
    xtol : float
        Absolute tolerance of each lambda_c.
    margin : float
        Relative distance below the predicted lambda_c at which each chi is started.
    type_tol : float
        Relative width in chi to which a change of bifurcation type is located.
    analysis : StabilitySettings
        ``orientation``: the TT branch whose loss of stability is traced; ``modes``: the
        perturbations analysed (default by orientation: general on the vorticity branch, which
        loses stability to modes that break the x-z symmetry); ``jacobian``: as for
        :func:`vesicle.steady.newton.steady_tank_treading`.  The former keywords
        ``orientation``, ``modes``, ``jacobian`` work for one release, with a warning.
    executor
        Runs finite-difference Jacobian columns.
    progress : callable, optional
        Given each point's summary as it is found.
    known : sequence of NeutralPoint
        Points of an interrupted trace of the same curve (same v, resolution, orientation,
        modes and ``xtol``), each with its ``start`` state (:func:`vesicle.bifurcation.checkpoint.
        read_checkpoint`): wherever the trace (seed, intermediate chi, bisection) comes to one of
        their chi exactly, the point is taken instead of traced again.  Since each new chi
        starts from its neighbour's stored state, the resumed curve is the one an uninterrupted
        trace gives.
    checkpoint : callable, optional
        Given each newly traced :class:`NeutralPoint` (with its start state) before
        ``progress``: where a long trace keeps its states (:func:`vesicle.bifurcation.checkpoint.
        write_point_state`).
    """
    for name, value in (("xtol", xtol), ("type_tol", type_tol)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value}")
    analysis = legacy_settings("neutral_curve", StabilitySettings, analysis, legacy)
    refuse_unknown("neutral_curve", legacy)
    analysis = analysis if analysis is not None else StabilitySettings()
    orientation, modes = analysis.orientation, analysis.modes
    physics, chis = curve_inputs(physics, chi)
    disc = discretisation if discretisation is not None else Discretisation()
    t0 = time.perf_counter()
    tracer = _Tracer(physics, disc, float(xtol), float(margin), progress, analysis, executor,
                     known, checkpoint)  # fmt: skip
    # the seed: the chi nearest 1 first; where no critical point is found there, the next
    # nearest, and so on.  The vorticity branch is seeded from the largest chi down: its
    # lambda_c falls with chi and may not exist at low chi (v = 0.90, chi = 2, N = 4: unstable
    # at every lam up to 989), where each failed search costs a long bracket
    if orientation == "vorticity":
        candidates = sorted(range(len(chis)), key=lambda i: -chis[i])
    else:
        candidates = sorted(range(len(chis)), key=lambda i: abs(math.log(chis[i])))
    seed, seed_errors = None, {}
    resumed = [i for i in candidates if chis[i] in tracer.known]
    if resumed:  # a point found before the interruption seeds the curve
        candidates = [resumed[0]] + [i for i in candidates if i != resumed[0]]
    for first in candidates:
        try:
            if chis[first] in tracer.known:
                seed = tracer.point(None, chis[first], tracer.known[chis[first]].lambda_c)
                break
            seed = _seed(tracer, chis[first], xtol, modes, orientation)
            break
        except (*_FAILURES, RuntimeError, ValueError) as err:
            log.warning("neutral curve: no critical point to start from at chi = %.4g (%s); "
                        "trying the next chi", chis[first], err)  # fmt: skip
            seed_errors[chis[first]] = str(err)
    if seed is None:
        raise NewtonError("no critical point found at any chi: " + "; ".join(
            f"chi = {c:g}: {e}" for c, e in seed_errors.items()))  # fmt: skip
    traced, between, failed = {chis[first]: seed}, [], []
    for order in (chis[first + 1 :], chis[:first][::-1]):  # up, then down from the seed
        path = [seed]
        for x in order:
            steps = math.ceil(abs(math.log(x / path[-1].chi)) / math.log(CHI_RATIO) - 1e-9)
            try:
                for k in range(1, steps + 1):  # intermediate chi where the asked ones are far apart
                    here = path[-1].chi * (x / path[-1].chi) ** (1.0 / (steps - k + 1))
                    p = tracer.point(path[-1].start, x if k == steps else here,
                                     _predict(path, here),
                                     [q.start for q in path[::-1][1 : 1 + FALLBACKS]])  # fmt: skip
                    path.append(p)
                    if k < steps:
                        between.append(p)
            except _FAILURES as err:  # this direction ends here; the other one and the points
                # found are kept, and the failure is reported with the curve
                log.warning("neutral curve: stopped before chi = %.4g: %s", x, err)
                failed.append({"chi": x, "error": str(err)})
                break
            traced[x] = path[-1]
    stopped_at = {f["chi"] for f in failed} | set(traced)
    failed += [{"chi": c, "error": f"no critical point to start from: {e}"}
               for c, e in seed_errors.items() if c not in stopped_at]  # fmt: skip
    # fold points next to the Hopf part: where TT goes on past the fold on another branch,
    # lambda_c is that branch's loss of stability (an S-shaped branch, _Tracer.past_fold)
    upper = _past_folds(tracer, list(traced.values()) + between)
    traced = {x: upper.get(x, p) for x, p in traced.items()}
    between = [upper.get(p.chi, p) for p in between]
    points = [traced[x] for x in chis if x in traced]
    change, bisection = None, []
    if locate_type_change:
        change, bisection = _type_change(tracer, sorted(points + between, key=lambda p: p.chi),
                                         type_tol)  # fmt: skip
    return NeutralCurve(physics, disc, points, change, between + bisection,
                        time.perf_counter() - t0, failed, orientation, modes, float(xtol),
                        len(tracer.resumed))  # fmt: skip


def _seed(tracer: _Tracer, chi: float, xtol: float, modes: str, orientation: str) -> NeutralPoint:
    """The first critical point: bracketed by :func:`critical_lambda` (a Hopf or real crossing),
    then traced from just below it.  Where the loss of stability is a fold the bracket cannot
    see (its secant steps land past the fold, where Newton stalls: v = 0.85, chi = 1, N = 4,
    at lam = 4.05), the branch is followed instead from a stable state at low lam in 10 %
    steps to its special point, and the point traced from there."""
    side = tracer.side
    start = None
    try:
        c = critical_lambda(tracer.at(chi, 1.0), tracer.disc, search=CriticalSearch(xtol=xtol),
                            **tracer.options)  # fmt: skip
        lam_c = c.lambda_c
        # a stable state of the search (not a fresh start from the spheroid, which at N = 8
        # may need a detour by continuation from lam = 1), half a margin or more from lambda_c
        # as in _Tracer.point (next to a fold the branch's Jacobian is singular), nearest the
        # start of the trace
        limit, target = lam_c * (1 - 0.5 * side * tracer.margin), lam_c * (1 - side * tracer.margin)
        stable = [(lam, s) for (lam, _, w_i), s in zip(c.history, c.states, strict=True)
                  if w_i < 0 and side * (limit - lam) >= 0]  # fmt: skip
        if stable:
            start = min(stable, key=lambda x: abs(x[0] - target))[1]
    except (*_FAILURES, RuntimeError) as err:
        log.warning("neutral curve seed at chi = %.4g: the bracketing search failed (%s); "
                    "following the branch instead", chi, err)  # fmt: skip
        lam = (vorticity_start_lambda(tracer.physics.v) if side < 0
               else 0.5 * max(1.0, misbah_critical_lambda(tracer.physics.v)))  # fmt: skip
        state = reach(tracer.at(chi, lam), tracer.disc, **tracer.options)
        ratio = 1.1**side
        values = [lam * ratio**k for k in range(1, 26)]  # up to 10.8 x lam
        b = branch(state.physics, tracer.disc, "lam", values, start=state,
                   continuation=ContinuationSettings(xtol=0.05 * lam),
                   **tracer.options)  # fmt: skip
        if not b.special_points and not b.stopped:
            raise NewtonError(f"no loss of stability at chi = {chi:g} between lam = {lam:g} "
                              f"and {values[-1]:g}") from err  # fmt: skip
        lam_c = (b.special_points[0].value if b.special_points else
                 max((p.physics.lam for p in b.points), key=lambda x: side * x))  # fmt: skip
        limit = lam_c * (1 - side * tracer.margin)  # a stable state of this branch below it
        below = [p for p in b.points if side * (limit - p.physics.lam) >= 0
                 and p.most_unstable[1] < 0]  # fmt: skip
        start = max(below, key=lambda p: side * p.physics.lam).steady if below else state
    if start is None:
        start = reach(tracer.at(chi, lam_c * (1 - side * tracer.margin)), tracer.disc,
                      **tracer.options)  # fmt: skip
    return tracer.point(start, chi, lam_c)


def _past_folds(tracer: _Tracer, points: list[NeutralPoint]) -> dict[float, NeutralPoint]:
    """Fold points replaced by :meth:`_Tracer.past_fold`, by chi: from each fold point whose
    neighbour at larger chi is a Hopf point down in chi, while tank-treading goes on past
    the fold (each found point the Hopf neighbour of the next)."""
    points = sorted(points, key=lambda p: p.chi)
    replaced: dict[float, NeutralPoint] = {}
    for i in range(len(points) - 1, 0, -1):
        hopf = points[i]
        if hopf.bifurcation != "hopf" or points[i - 1].bifurcation == "hopf":
            continue
        for fold in points[i - 1 :: -1]:
            if fold.bifurcation == "hopf" or fold.chi in replaced:
                break
            p = tracer.past_fold(fold, hopf)
            if p is None:
                break
            replaced[fold.chi] = hopf = p
    return replaced


def _type_change(tracer: _Tracer, points: list[NeutralPoint], tol: float):
    """Bisection in log chi between the first neighbours of different type.  Each new chi
    starts from the fold side's state (the branch from low lam), and where that branch
    folds, the Hopf side's branch is looked at past the fold (:meth:`_Tracer.past_fold`):
    lambda_c is the larger of the two."""
    for a, b in itertools.pairwise(points):
        if a.bifurcation != b.bifurcation:
            break
    else:
        return None, []
    extra = []
    while b.chi / a.chi > 1.0 + tol:
        mid = math.sqrt(a.chi * b.chi)
        fold, hopf = (a, b) if b.bifurcation == "hopf" else (b, a)
        lam = a.lambda_c + (b.lambda_c - a.lambda_c) * math.log(mid / a.chi) / math.log(
            b.chi / a.chi)  # fmt: skip
        try:
            p = tracer.point(fold.start, mid, lam)
            if p.bifurcation != "hopf":
                p = tracer.past_fold(p, hopf) or p
        except (*_FAILURES, ValueError) as err:  # next to the type change the fold is hard
            log.warning("type change: no critical point at chi = %.4g (%s); bracket kept at "
                        "[%.4g, %.4g]", mid, err, a.chi, b.chi)  # fmt: skip
            break
        extra.append(p)
        if p.bifurcation == a.bifurcation:
            a = p
        else:
            b = p
    hopf = a if a.bifurcation == "hopf" else b
    return {"chi": math.sqrt(a.chi * b.chi), "lambda_c": 0.5 * (a.lambda_c + b.lambda_c),
            "bracket": [a.chi, b.chi], "located": b.chi / a.chi <= 1.0 + tol,
            "omega_R_at_hopf_end": hopf.omega_R, "below": a.bifurcation,
            "above": b.bifurcation}, extra  # fmt: skip
