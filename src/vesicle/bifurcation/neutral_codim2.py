"""Neutral curves ``lambda_c(chi)`` by two-parameter continuation (issue 40, SPEC §16).

What is computed
----------------
The neutral curve at fixed ``v`` is the upper edge (in ``lambda``) of the region where a
stable steady tank-treading state exists: at each ``chi`` the largest ``lambda`` at which a
steady state loses stability as ``lambda`` grows (the in-plane branch; the vorticity branch is
stable *above* its curve, and there the smallest ``lambda`` counts).  The candidates are the
points of the fold and Hopf curves of the steady equations (:mod:`.steady_codim2`) where no
eigenvalue other than the critical one(s) is on or over the axis.  On an S-shaped branch (v =
0.95 near chi = 0.25) the lower sheet's fold and the upper sheet's Hopf point are both
candidates: tank-treading goes on past the fold on the upper sheet up to its Hopf point when
that lies higher, and the curve changes type where the two meet (the *type change*, located
by Brent's method on the difference of the two points solved at the same ``chi``).

How
---
1. **A seed** at the requested ``chi`` nearest 1 (the largest for the vorticity branch): the
   branch from low ``lambda`` stepped to its first loss of stability (:func:`_first_loss`,
   steps of 8-30 % placed by the growth rate's extrapolation), and the Hopf (or fold) point
   solved for there on its augmented system.  Finer than N = 4 on 16x32 the stepping runs at
   that coarse resolution only, its state is continued to the full one and the point solved
   for there (:func:`_coarse_first_loss`).  Where that fails, and first on the vorticity
   branch, the bracketing search :func:`vesicle.bifurcation.critical.critical_lambda` gives a
   stable state just below ``lambda_c`` (at the coarse resolution first:
   :func:`_coarse_seed`) from which the point is solved for.  (The search first: at v = 0.85,
   N = 4 it spent 151 s failing next to the fold at chi = 1 before the stepping found it.)
2. **Its curve continued** both ways in ``chi`` by pseudo-arclength
   (:func:`vesicle.bifurcation.codim2.hopf_curve` / ``fold_curve``), with its Bogdanov–Takens
   and cusp points located on the way; from a BT point with no other unstable eigenvalue the
   other curve is continued too (the switch at BT).
3. **Coverage**: a requested ``chi`` with no candidate yet (below a BT point where the Hopf
   curve ends) gets a new seed by :func:`_first_loss` there (stepped at N = 4 on 16x32 first
   at finer resolutions: :func:`_coarse_first_loss`), and its curve is continued (at
   v = 0.95: the lower sheet's fold curve, up to its cusp).
4. **The type change** where the winning candidate changes kind, located on the augmented
   systems (:func:`.steady_codim2.locate_type_change`), or at a BT point where the curves
   meet there.
5. **Each requested chi solved** on its winning curve at that ``chi``: the curves land on the
   requested values of ``chi`` (a step that would pass one is shortened onto it and corrected
   with ``chi`` held), so a reported point is normally a curve point; otherwise Newton on the
   augmented system from the nearest curve point.  ``located`` means that system converged to
   ``settings.ftol``; its residual is reported.

Every reported point carries ``located``, ``residual`` and ``other_unstable``; a point that did
not converge is reported as an estimate (``located = False``, the curve's interpolated value)
and never compared with the paper.
"""

from __future__ import annotations

import itertools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from vesicle.bifurcation import codim2
from vesicle.bifurcation.branch import reach
from vesicle.bifurcation.critical import (
    _coarse_discretisation,
    critical_lambda,
    vorticity_start_lambda,
)
from vesicle.bifurcation.neutral import NeutralCurve, NeutralPoint, curve_inputs
from vesicle.bifurcation.steady_codim2 import SteadyEquations, locate_type_change
from vesicle.geometry.diagnostics import diagnose
from vesicle.geometry.surface import Shape, ShapeError
from vesicle.io.memo import EvaluationMemo
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import (
    CriticalSearch,
    StabilitySettings,
    legacy_settings,
    refuse_unknown,
)
from vesicle.model.theory import misbah_critical_lambda
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NewtonError, steady_tank_treading
from vesicle.steady.stability import stability

__all__ = ["DEFAULT_SETTINGS", "CurveInterrupted", "curve_memo", "lam_box",
           "neutral_curve_codim2"]

log = logging.getLogger(__name__)

_FAILURES = (NewtonError, ShapeError, SolverError)

#: The continuation's settings for the vesicle: residual to 1e-8 (the solves' own accuracy is
#: about 1e-9) and forward differences with a 1e-5 step for the Newton matrices' second
#: derivatives (the Jacobian carries noise of about 1e-9: a sqrt(eps) step would amplify it to
#: 7 %; measured at N = 4 on 16x32, chi = 3.162: the same Hopf point to 5e-8 in lambda as with
#: central differences, 11 Jacobians instead of 17); the step grows after correctors of up to 3
#: iterations (linear convergence at that rate); a cusp is located to 1e-7 in arclength (the
#: default 1e-11 took 15 Brent evaluations, 100 s at N = 4, for digits nothing uses); a
#: corrector not converged after 3 iterations goes on with central differences (next to a cusp
#: the forward ones stalled at residuals of 1e-3); a corrector gives up after 5 iterations (it
#: converges in 2-4 where it converges at all: next to the cusp of the S at v = 0.95 failures
#: of 8 iterations cost most of the fold curve), and after 2 if its residual is not below its
#: start's by then (those never recovered); the first step is 0.3 (0.1 ramped up over three
#: points of every curve), and a requested chi up to 1.5 steps ahead is landed on directly
#: (a refused step is still halved down to 1e-5: a run at v = 0.85 with 1e-3 reported no
#: cusp where the earlier settings had located one); fold curves are watched for a smooth
#: turn of chi (at v = 0.85, N = 4, the lower fold curve turned back at chi about 0.126 with
#: no cusp found: the left end of the folds' range, where the stable region closes).
DEFAULT_SETTINGS = codim2.Settings(ftol=1e-8, step_tol=1e-6, forward_step=1e-5, ds=0.3,
                                   ds_max=0.6, target_iterations=3, locate_tol=1e-7,
                                   central_after=3, max_iter=5, stall_after=2,
                                   land_ahead=1.5, monitor_turn=True)  # fmt: skip

#: Relative step in lambda of the search for the first loss of stability (:func:`_first_loss`).
LOSS_STEP = 1.08

#: Where the first-loss search starts again when the state at its first lambda is unstable
#: (:func:`_first_loss`).
LOW_START = 1.0

#: Largest relative step in lambda of that search, where the growth rate's extrapolation
#: puts the crossing far ahead (:func:`_loss_step`; at v = 0.85, N = 4, chi = 1 the 8 % steps
#: took 22 states from lambda = 0.77 to the fold at 4.07).
LOSS_STEP_MAX = 1.3

#: A step of the first-loss search whose shape moves this many times faster (per unit of
#: lambda) than the last step's is taken for a jump to another sheet and halved.  Approaching
#: a fold the rate grows like (lam_f - lam)^(-1/2): by under 2 between 8 % steps until the
#: last one.
JUMP = 4.0

#: A curve is given up after this many points in a row with another unstable eigenvalue
#: (it is not the stability boundary there; the points found are kept and reported); a curve
#: started from a BT point after its first point if that one has (the BT normal form: the
#: half of the curve where the pair's other eigenvalue is unstable stays so).
OFF_BOUNDARY = 3

#: A fold curve is given up once its chi has turned back by this much in log chi (its
#: cusp passed: the points found are kept).
TURNED_BACK = 0.05

#: A fold curve past the type change (a Hopf curve found lies beyond it in lambda: it is no
#: longer the stability boundary) goes on only to locate its cusp, for at most this many
#: points, and is given up once more than ``CUSP_REFUSALS`` steps in a row are refused (at
#: N = 8 the fold curve next to the cusp crept for 4-7 min of refused steps without passing it:
#: v = 0.95 and 0.90, fourth session; at N = 4 v = 0.90 reached its cusp after a point with
#: refused steps).
CUSP_POINTS = 4
CUSP_REFUSALS = 2

#: A seed solved for from the coarse lambda_c (:func:`_coarse_seed`) is kept only within
#: this relative distance of it (N = 4's lambda_c lies 1-8 % below N = 8's).
COARSE_SEED_GAP = 0.15

#: A point this close in log chi to the outermost requested chi has landed on it (a landing
#: solve holds log chi exactly).
_EDGE = 1e-12

#: A requested chi this close (relative) to a curve's end counts as covered by it.
_COVER = 1e-9


@dataclass
class _Curve:
    """One continued curve with its converged points ordered as traced."""

    kind: str  # "hopf" or "fold"
    curve: codim2.Curve

    def points(self) -> list[codim2.CurvePoint]:
        """Its points, and the located BT point where it ends at one (a Hopf curve's last
        step goes from omega about 0.1 straight to BT: the BT point is its end)."""
        pts = list(self.curve.points)
        bt = [sp for sp in self.curve.special if sp.kind == "bt" and sp.located]
        if self.curve.end == "bt" and bt:
            pts.append(bt[-1].point)
        return pts

    def before_turn(self) -> list[codim2.CurvePoint]:
        """Its points up to where its chi turns back (a fold curve past its cusp runs on the
        S's other fold): the starts of the solves at fixed chi."""
        pts = self.points()
        if self.kind != "fold" or len(pts) < 2:
            return pts
        way = 1.0 if pts[1].p[0] >= pts[0].p[0] else -1.0
        out = [pts[0]]
        for q in pts[1:]:
            if way * (q.p[0] - out[-1].p[0]) < 0:
                break
            out.append(q)
        return out

    def segments(self):
        """Consecutive pairs of converged points with no other unstable eigenvalue."""
        for a, b in itertools.pairwise(self.points()):
            if a.converged and b.converged and not (a.other_unstable or b.other_unstable):
                yield a, b


@dataclass
class _Candidate:
    kind: str
    lam: float
    near: codim2.CurvePoint
    curve: _Curve


def _candidates(curves: Sequence[_Curve], chi: float) -> list[_Candidate]:
    """Each curve's crossings of ``log chi`` (linear between its points)."""
    t = math.log(chi)
    out = []
    for c in curves:
        for a, b in c.segments():
            lo, hi = sorted((a.p[0], b.p[0]))
            if lo - _COVER <= t <= hi + _COVER:
                s = 0.0 if hi == lo else (t - a.p[0]) / (b.p[0] - a.p[0])
                lam = float(a.p[1] + s * (b.p[1] - a.p[1]))
                near = a if s < 0.5 else b
                if near.kind != c.kind:  # a BT end: Newton starts from the curve's own point
                    near = b if near is a else a
                out.append(_Candidate(c.kind, lam, near, c))
        if c.curve.points and c.curve.points[0].converged:  # a curve of one point (its start)
            q = c.curve.points[0]
            if len(c.curve.points) == 1 and abs(q.p[0] - t) <= _COVER and not q.other_unstable:
                out.append(_Candidate(c.kind, float(q.p[1]), q, c))
    return out


def _winner(curves: Sequence[_Curve], chi: float, side: int) -> _Candidate | None:
    cands = _candidates(curves, chi)
    return max(cands, key=lambda c: side * c.lam) if cands else None


@dataclass
class _Context:
    physics: Physics
    disc: Discretisation
    eq: SteadyEquations
    analysis: StabilitySettings
    settings: codim2.Settings
    side: int
    bounds: list
    max_points: int
    say: Callable[[dict], None]
    landing: list[float] = field(default_factory=list)  # log chi of the requested points
    curves: list[_Curve] = field(default_factory=list)
    special: list[codim2.SpecialPoint] = field(default_factory=list)
    visited_bt: set = field(default_factory=set)
    #: the equations of the curves' points (``eq`` itself, except in a coarse search)
    curves_eq: SteadyEquations | None = None
    #: fold curves past the type change go on to their cusps however long that takes
    cusps: bool = False
    #: the last stable steady state of each first-loss search, as (chi, lam, discretisation,
    #: shape): the starts of later searches (shapes only: a state keeps its problem's operators)
    stable: list = field(default_factory=list)
    #: the points of the curve under way (what an interruption keeps of it)
    current: list = field(default_factory=list)

    def at(self, chi: float, lam: float) -> Physics:
        return self.physics.replace(chi=float(chi), lam=float(lam))


def _locate(ctx: _Context, kind: str, x, p, free: int = 1, near: codim2.CurvePoint | None = None):
    """Newton on the fold or Hopf system from ``(x, p)`` with ``p[1 - free]`` held."""
    s = ctx.settings
    if kind == "fold":
        v = w = None
        if near is not None and near.kind in ("fold", "bt"):
            v, w = near.v, near.w
        return codim2.locate_fold(ctx.eq, x, p, free=free, v=v, w=w, settings=s)
    omega = near.omega if near is not None and near.kind == "hopf" else None
    v = w = None
    if near is not None and near.kind == "hopf":
        v, w = near.v, near.w
    return codim2.locate_hopf(ctx.eq, x, p, free=free, omega=omega, v=v, w=w, settings=s)


def _leading(state, modes: str) -> tuple[float, float]:
    """(growth, frequency) of the most unstable mode of a steady state."""
    om = stability(state, modes=modes).omega  # rows (omega_R, omega_I)
    i = int(np.argmax(om[:, 1]))
    return float(om[i, 1]), float(abs(om[i, 0]))


def _first_loss(ctx: _Context, chi: float, lam0: float, start=None) -> codim2.CurvePoint:
    """The first loss of stability of the branch from a stable state at ``lam0`` (``start``,
    or one from a kept state or the default start: :func:`_curve_start`), stepping ``lambda``
    by :data:`LOSS_STEP` to :data:`LOSS_STEP_MAX` (down for the vorticity branch), solved for
    on its augmented system: a Hopf point where the leading eigenvalue crossing is complex, a
    fold where it is real or where Newton finds no state one step further (halving the step
    four times first).  Raises ``NewtonError`` where no loss is found in the parameter box."""
    side, lo, hi = ctx.side, ctx.bounds[1][0], ctx.bounds[1][1]
    state = start if start is not None else _curve_start(ctx, chi, lam0)
    if state is None:
        state = reach(ctx.at(chi, lam0), ctx.disc, analysis=ctx.analysis)  # fmt: skip
    growth, freq = _leading(state, ctx.analysis.modes)
    if growth >= 0 and side > 0 and lam0 > LOW_START and lo <= LOW_START:
        # unstable there: the branch from low lambda is the one asked for, and the state
        # reached may lie on another (v = 0.90, N = 4, chi = 0.1: a state with a complex
        # unstable pair at 4.53, continued down to 0.5 without a stable state, while the
        # branch from lambda = 1 is stable up to its fold at 5.35)
        try:
            low = _curve_start(ctx, chi, LOW_START) or reach(
                ctx.at(chi, LOW_START), ctx.disc, analysis=ctx.analysis)  # fmt: skip
            state = low
            growth, freq = _leading(state, ctx.analysis.modes)
        except _FAILURES as err:
            log.info("chi = %.4g: no state at lambda = %g (%s)", chi, LOW_START, err)
    while growth >= 0:  # start lower (higher for the vorticity branch) until stable
        lam = state.lam * LOSS_STEP ** (-2 * side)
        if not lo <= lam <= hi:
            raise NewtonError(f"no stable steady state at chi = {chi:.4g} for lam in "
                              f"[{lo:g}, {hi:g}]")  # fmt: skip
        try:  # the same branch, continued from the last state (one Newton solve)
            state = steady_tank_treading(ctx.at(chi, lam), ctx.disc, initial=state,
                                         analysis=ctx.analysis)  # fmt: skip
        except _FAILURES:  # (a fold on the way down): reached afresh, as the first state was
            state = reach(ctx.at(chi, lam), ctx.disc, analysis=ctx.analysis)  # fmt: skip
        growth, freq = _leading(state, ctx.analysis.modes)
    last: tuple[float, float] | None = None  # the previous state's (lam, growth)
    last_rate: float | None = None  # |da / dlam| of the last step
    while True:
        step = _loss_step(state.lam, growth, freq, last, side)
        fold = _fold_ahead(ctx, chi, state, growth, freq, last, step)
        if fold is not None:
            _keep_stable(ctx, state)
            return fold
        last = (state.lam, growth)
        lam, halvings, nxt = state.lam * step, 0, None
        if not lo <= lam <= hi:
            raise NewtonError(f"no loss of stability at chi = {chi:.4g} for lam up to "
                              f"{state.lam:.4g} (the box ends at {hi if side > 0 else lo:g})")
        while nxt is None:
            try:
                along = ctx.analysis.replace(orientation=state.orientation)
                nxt = steady_tank_treading(ctx.at(chi, lam), ctx.disc, initial=state,
                                           analysis=along)  # fmt: skip
                rate = float(np.linalg.norm(nxt.a - state.a)) / abs(lam - state.lam)
                if last_rate is not None and rate > JUMP * last_rate:
                    # the shape moved far more than the last step's rate says: Newton went
                    # over a fold onto another sheet (an S narrower than the step)
                    raise NewtonError(f"jump at lam = {lam:.6g} (shape rate {rate:.3g} "
                                      f"against {last_rate:.3g})")  # fmt: skip
            except _FAILURES:
                nxt = None
                halvings += 1
                if halvings > 4:  # a fold between state.lam and lam
                    _keep_stable(ctx, state)
                    ctx.say({"chi": chi, "first_loss": "fold beyond", "lam": state.lam})
                    x, p = ctx.eq.state(state)
                    return _locate(ctx, "fold", x, p)
                lam = state.lam * step ** (0.5**halvings)
        last_rate = rate
        g2, f2 = _leading(nxt, ctx.analysis.modes)
        if g2 >= 0:
            _keep_stable(ctx, state)
        ctx.say({"chi": chi, "lam": nxt.lam, "growth": g2})
        if g2 >= 0:
            # the crossing between the two states, linear in the growth rate
            lam_c = state.lam + (nxt.lam - state.lam) * (-growth) / (g2 - growth)
            # the kind of the eigenvalue that crossed (a real pair may merge into a complex
            # one before it crosses, next to a cusp)
            p = np.array([math.log(chi), lam_c])
            if f2 > 1e-6:  # from the unstable state, whose leading pair is the one that crossed
                x, _ = ctx.eq.state(nxt)
                return codim2.locate_hopf(ctx.eq, x, p, free=1, omega=f2, settings=ctx.settings)
            x, _ = ctx.eq.state(state)
            return _locate(ctx, "fold", x, p)
        state, growth, freq = nxt, g2, f2


#: Stable states kept for later searches (:func:`_keep_stable`).
KEPT_STABLE = 16


def _keep_stable(ctx: _Context, state) -> None:
    """Keep the shape of a stable state for the starts of later searches."""
    ctx.stable.append((state.physics.chi, state.lam, ctx.disc, state.shape))
    del ctx.stable[:-KEPT_STABLE]


def _curve_start(ctx: _Context, chi: float, lam0: float):
    """The steady state at ``(chi, lam0)`` by Newton from the nearest stable state of the
    searches so far (in ``log chi`` and ``log lambda``, at this resolution), else from the shape
    of the nearest curve point in ``chi``, if that converges to a stable state; else None (then
    :func:`~vesicle.bifurcation.branch.reach` from the default start: at v = 0.85, N = 4,
    chi = 1.47 that took 60 s of continuation legs from v = 0.95)."""
    starts = []
    mine = [(c, lam, shape) for c, lam, disc, shape in ctx.stable if disc == ctx.disc]
    if mine:
        starts.append(min(mine, key=lambda k: abs(math.log(k[0] / chi))
                          + abs(math.log(k[1] / lam0)))[2])  # fmt: skip
    pts = [q for c in ctx.curves for q in c.curve.points if q.converged]
    if pts:
        q = min(pts, key=lambda q: abs(q.p[0] - math.log(chi)))
        try:
            starts.append((ctx.curves_eq or ctx.eq).problem_at(q.p).shape(np.asarray(q.x[:-2])))
        except ShapeError:
            pass
    for start in starts:
        try:
            state = steady_tank_treading(ctx.at(chi, lam0), ctx.disc, initial=start,
                                         analysis=ctx.analysis)  # fmt: skip
        except _FAILURES as err:
            log.info("chi = %.4g: no state from a nearby one (%s)", chi, err)
            continue
        growth, _ = _leading(state, ctx.analysis.modes)
        if growth < 0:
            return state
    return None


def _loss_step(lam: float, growth: float, freq: float, last: tuple[float, float] | None,
               side: int) -> float:  # fmt: skip
    """The factor of the next lambda of :func:`_first_loss`: :data:`LOSS_STEP` (its inverse
    on the vorticity side), longer (up to :data:`LOSS_STEP_MAX`) where the growth rate
    extrapolated from the last two states stays below zero for twice the step: linearly, and
    for a real leading eigenvalue also its square linearly (the square-root law of a fold, which
    reaches zero sooner).  Halfway to the nearest predicted crossing."""
    if last is None or not growth < 0:
        return LOSS_STEP**side
    lam1, g1 = last
    if lam1 == lam or not g1 < growth:  # not rising towards the crossing
        return LOSS_STEP**side
    crossings = [lam - growth * (lam - lam1) / (growth - g1)]
    if freq <= 1e-6:
        crossings.append(lam + growth**2 * (lam - lam1) / (g1**2 - growth**2))
    ahead = min(side * (c - lam) for c in crossings)  # how far, along the way the steps go
    factor = 1.0 + 0.5 * ahead / lam
    factor = min(max(factor, LOSS_STEP), LOSS_STEP_MAX)
    return factor**side


def _loss(ctx: _Context, chi: float, lam0: float) -> codim2.CurvePoint:
    """:func:`_first_loss`, found at the coarse resolution first where that works
    (:func:`_coarse_first_loss`)."""
    point = _coarse_first_loss(ctx, chi, lam0)
    return point if point is not None else _first_loss(ctx, chi, lam0)


def _coarse_first_loss(ctx: _Context, chi: float, lam0: float) -> codim2.CurvePoint | None:
    """The first loss of stability at ``chi`` stepped for at N = 4 on 16x32 (finer
    resolutions only), then solved for at this one from there (:func:`_refined`).  ``None``
    where that fails: then :func:`_first_loss` steps at full resolution (at v = 0.90, N = 8,
    chi = 0.1: about 5 min, most of it reaching a first state from the default start)."""
    coarse = _coarse_discretisation(ctx.disc, "auto", None, ctx.analysis)
    if coarse is None:
        return None
    try:
        ceq = SteadyEquations(ctx.physics.replace(chi=chi, lam=lam0), coarse,
                              modes=ctx.analysis.modes, jacobian=ctx.analysis.jacobian,
                              form=ctx.eq.form)  # fmt: skip
        q = _first_loss(replace(ctx, disc=coarse, eq=ceq,
                                say=lambda d: ctx.say({"coarse": d})), chi, lam0)  # fmt: skip
        if not q.converged:
            return None
        shape = ceq.problem_at(q.p).shape(q.x[:-2])
    except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
        log.info("coarse first loss at chi = %.4g: %s", chi, err)
        return None
    lam = float(q.p[1])
    point = _refined(ctx, chi, shape, lam, lam, q.omega if q.kind == "hopf" else None,
                     "coarse first loss")  # fmt: skip
    if point is not None:
        ctx.say({"chi": chi, "first_loss": point.kind, "from_coarse": lam,
                 "lam": float(point.p[1])})  # fmt: skip
    return point


def _refined(ctx: _Context, chi: float, initial, lam_state: float, lam_c: float,
             omega: float | None, what: str) -> codim2.CurvePoint | None:  # fmt: skip
    """The critical point at ``chi`` at full resolution from a coarse one: the steady state
    at ``lam_state`` by Newton from ``initial`` (a coarser state or shape), then the Hopf
    (``omega`` given) or fold point solved for from it with ``lam_c`` as its start.  Where
    that solve fails or its point lies more than :data:`COARSE_SEED_GAP` from ``lam_c``, the
    branch is stepped from that state to its first loss at full resolution
    (:func:`_first_loss`: at v = 0.90, N = 8, chi = 1 the Hopf point lies 6.5 % above N = 4's
    and its solve from there failed).  ``None`` where all that fails, or where the point has
    another unstable eigenvalue (logged, with ``what``)."""
    try:
        state = steady_tank_treading(ctx.at(chi, lam_state), ctx.disc, initial=initial,
                                     analysis=ctx.analysis)  # fmt: skip
    except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
        log.info("%s at chi = %.4g: %s", what, chi, err)
        return None
    point = None
    try:
        x, _ = ctx.eq.state(state)
        p = np.array([math.log(chi), lam_c])
        if omega is not None:
            point = codim2.locate_hopf(ctx.eq, x, p, free=1, omega=omega, settings=ctx.settings)
        else:
            point = codim2.locate_fold(ctx.eq, x, p, free=1, settings=ctx.settings)
    except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
        log.info("%s at chi = %.4g: %s", what, chi, err)
    if point is None or not point.converged or \
            abs(point.p[1] - lam_c) > COARSE_SEED_GAP * lam_c:  # fmt: skip
        log.info("%s at chi = %.4g: not solved for from the coarse lambda %.5g; stepping from "
                 "the state at %.5g", what, chi, lam_c, lam_state)  # fmt: skip
        try:
            point = _first_loss(ctx, chi, lam_state, start=state)
        except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
            log.info("%s at chi = %.4g: %s", what, chi, err)
            return None
    if not point.converged or point.other_unstable:
        log.info("%s at chi = %.4g refused (converged %s, lam %.5g against the coarse %.5g, "
                 "other unstable %s)", what, chi, point.converged, point.p[1], lam_c,
                 point.other_unstable)  # fmt: skip
        return None
    return point


def _fold_ahead(ctx, chi, state, growth, freq, last, ratio) -> codim2.CurvePoint | None:
    """The fold solved for directly when the leading eigenvalue is real and its square,
    extrapolated linearly in lambda from the last two states (the square-root law of a fold),
    reaches zero within the next step; ``None`` otherwise or where that solve does not
    converge beyond ``state`` (then the stepping goes on)."""
    if last is None or freq > 1e-6 or not growth < 0 or not last[1] < growth:
        return None
    (lam1, g1), lam2 = last, state.lam
    lam_f = lam2 + growth**2 * (lam2 - lam1) / (g1**2 - growth**2)
    if not (lam_f - lam2) * (lam2 * ratio - lam_f) > 0:  # not within the next step
        return None
    x, _ = ctx.eq.state(state)
    try:  # a speculative solve: a few iterations only (a fold in reach converges in 3-4)
        point = codim2.locate_fold(ctx.eq, x, np.array([math.log(chi), lam_f]), free=1,
                                   settings=replace(ctx.settings, max_iter=3))  # fmt: skip
    except (np.linalg.LinAlgError, ValueError):
        return None
    if point.converged and (point.p[1] - lam2) * (ratio - 1.0) > 0:
        ctx.say({"chi": chi, "first_loss": "fold", "predicted": lam_f, "lam": float(point.p[1])})
        return point
    return None


def _coarse_seed(ctx: _Context, chi: float) -> codim2.CurvePoint | None:
    """The seed from the coarse search alone (finer resolutions than ``critical.COARSE``):
    lambda_c at N = 4 on 16x32, then the point solved for at this resolution from the coarse
    search's stable state nearest it (:func:`_refined`).  ``None`` where that fails (then the
    full-resolution search seeds).  Saves that search's bracketing and Brent evaluations at
    full resolution (at v = 0.90, N = 8: 325 s)."""
    coarse = _coarse_discretisation(ctx.disc, "auto", None, ctx.analysis)
    if coarse is None:
        return None
    try:
        c = critical_lambda(ctx.at(chi, 1.0), coarse, search=CriticalSearch(coarse=None),
                            analysis=ctx.analysis)  # fmt: skip
    except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
        log.info("coarse seed at chi = %.4g: %s", chi, err)
        return None
    stable = [(lam, s) for (lam, _, w_i), s in zip(c.history, c.states, strict=True)
              if w_i < 0]  # fmt: skip
    if not stable:
        return None
    _, start = min(stable, key=lambda q: abs(q[0] - c.lambda_c))
    point = _refined(ctx, chi, start, start.physics.lam, c.lambda_c,
                     c.omega_R if c.omega_R > 1e-6 else None, "coarse seed")  # fmt: skip
    if point is not None:
        ctx.say({"seed_from": f"lambda_c = {c.lambda_c:.5g} at N = {coarse.degree} on "
                              f"{coarse.grid}x{2 * coarse.grid}"})  # fmt: skip
    return point


def _seed(ctx: _Context, chi: float) -> codim2.CurvePoint:
    """The first critical point of the trace, at ``chi`` (see the module docstring): on the
    in-plane branch the first loss of stability from low lambda (:func:`_loss`), else (and on
    the vorticity branch first) the bracketing search."""
    if ctx.side > 0:
        try:
            point = _loss(ctx, chi, _start_lambda(ctx, chi))
            if point.converged and not point.other_unstable:
                return point
        except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
            log.info("neutral curve seed at chi = %.4g by the first loss: %s", chi, err)
    point = _coarse_seed(ctx, chi)
    if point is not None:
        return point
    try:
        c = critical_lambda(ctx.at(chi, 1.0), ctx.disc, analysis=ctx.analysis)  # fmt: skip
        stable = [(lam, s) for (lam, _, w_i), s in zip(c.history, c.states, strict=True)
                  if w_i < 0]  # fmt: skip
        if not stable:
            raise NewtonError("the bracketing search kept no stable state")
        _, state = min(stable, key=lambda q: abs(q[0] - c.lambda_c))
        x, _ = ctx.eq.state(state)
        kind = "hopf" if c.omega_R > 1e-6 else "fold"
        point = _locate(ctx, kind, x, np.array([math.log(chi), c.lambda_c]))
        if point.converged:
            return point
        log.warning("neutral curve seed at chi = %.4g: the %s point did not converge from the "
                    "bracket; stepping the branch instead", chi, kind)  # fmt: skip
    except (*_FAILURES, RuntimeError, ValueError) as err:
        log.warning("neutral curve seed at chi = %.4g: %s; stepping the branch instead", chi, err)
    return _first_loss(ctx, chi, _start_lambda(ctx, chi))


#: The scalar fields of a critical point kept by :func:`_kept` (its arrays are x, p,
#: eigenvalues, v, w).
_POINT_META = ("kind", "omega", "residual", "converged", "iterations", "tests",
               "other_unstable", "refused")  # fmt: skip


def _kept(ctx: _Context, name: str, compute, chi: float, lam0: float | None = None):
    """``compute()``, a critical point found by a search (the seed, a first loss), looked up
    first in the curve's memo (``ctx.eq.memo``) and kept there when found: a resumed curve
    replays the searches' results as it replays the evaluations, instead of stepping their
    branches again (at v = 0.85, N = 8 they were half of a curve's first 40 min).  Keyed by
    ``name``, ``chi`` and ``lam0`` to 6 digits (the start lambda comes from the curve points so
    far, which a replay reproduces to about 1e-10).  A search that raises is not kept (run
    again on resume); a point that did not converge is kept and replayed as such.  A replayed
    point reports no evaluations (none were made).  The stable states the search kept for later
    starts (:func:`_keep_stable`) are kept with it and put back on replay, so that a later
    search starts where it would have: without them fig7's resumed v = 0.85 curve at N = 8 had
    no state near chi = 1.47 to start its next search from (Newton diverged from lambda = 1 at
    N = 4 and from the fold curve's shape at N = 8; 2026-12-07).  Records written before then
    have none, and replay as before."""
    memo = getattr(ctx.eq, "memo", None)
    if memo is None:
        return compute()
    inputs = (float(chi),) if lam0 is None else (float(chi), round(float(lam0), 6))
    found = memo.load_record(name, inputs)
    if found is not None:
        arrays, meta = found
        for i, entry in enumerate(meta.get("stable", [])):
            disc = Discretisation.from_dict(entry["discretisation"])
            shape = Shape(arrays[f"stable{i}"], int(entry["n_theta"]))
            ctx.stable.append((float(entry["chi"]), float(entry["lam"]), disc, shape))
        del ctx.stable[:-KEPT_STABLE]
        ctx.say({"chi": chi, "replayed": name, "lam": float(arrays["p"][1])})
        return codim2.CurvePoint(x=arrays["x"], p=arrays["p"], eigenvalues=arrays["eigenvalues"],
                                 v=arrays["v"], w=arrays["w"],
                                 **{k: meta[k] for k in _POINT_META})  # fmt: skip
    before = list(ctx.stable)  # held, so that no new entry can be mistaken for one of them
    point = compute()
    if point is not None:
        stable = [e for e in ctx.stable if not any(e is b for b in before)]
        memo.save_record(name, inputs,
                         {"x": point.x, "p": point.p, "eigenvalues": point.eigenvalues,
                          "v": point.v, "w": point.w,
                          **{f"stable{i}": e[3].coefficients for i, e in enumerate(stable)}},
                         {**{k: dict(point.tests) if k == "tests" else getattr(point, k)
                             for k in _POINT_META},
                          "stable": [{"chi": c, "lam": lam, "discretisation": d.to_dict(),
                                      "n_theta": shape.grid.n_theta}
                                     for c, lam, d, shape in stable]})  # fmt: skip
    return point


def _start_lambda(ctx: _Context, chi: float) -> float:
    """A lambda on the stable side of the curve at ``chi``: 0.9 times the nearest curve point's
    lambda (1.1 on the vorticity branch), else the leading-order estimate's half (the
    vorticity branch: :func:`vorticity_start_lambda`)."""
    pts = [q for c in ctx.curves for q in c.curve.points if q.converged]
    if pts:
        q = min(pts, key=lambda q: abs(q.p[0] - math.log(chi)))
        return float(q.p[1]) * (0.9 if ctx.side > 0 else 1.1)
    if ctx.side < 0:
        return vorticity_start_lambda(ctx.physics.v)
    return 0.5 * max(1.0, misbah_critical_lambda(ctx.physics.v))


def _continue(ctx: _Context, start: codim2.CurvePoint | codim2.SpecialPoint, kind: str,
              directions=((1.0, 0.0), (-1.0, 0.0))) -> None:  # fmt: skip
    """Continue a curve from ``start`` (both ways unless from a BT point), and from each BT
    point on it with no other unstable eigenvalue the other curve."""
    trace = codim2.hopf_curve if kind == "hopf" else codim2.fold_curve
    from_bt = isinstance(start, codim2.SpecialPoint)
    start_point = start.point if from_bt else start
    if from_bt:
        ctx.visited_bt.add(tuple(np.round(start.point.p, 6)))
    lowest, highest = (min(ctx.landing), max(ctx.landing)) if ctx.landing else (None, None)
    for d in directions[:1] if from_bt and kind == "hopf" else directions:
        p0 = float(start_point.p[0])
        if not from_bt and lowest is not None and \
                ((d[0] < 0 and p0 <= lowest + _EDGE) or (d[0] > 0 and p0 >= highest - _EDGE)):
            # seeded at the outermost requested chi: nothing to report that way (the seed
            # itself is a curve of one point)
            ctx.curves.append(_Curve(kind, codim2.Curve(kind, "minaug", (start_point,), (),
                                                        "edge", codim2.Evaluations())))
            continue
        ctx.say({"curve": kind, "direction": "up" if d[0] > 0 else "down"})

        # off-boundary points in a row; the start's log chi; the farthest reached (times the
        # way the curve goes, appended after its first step)
        run = [0, float(start_point.p[0]), 0.0]
        omegas = [float(start_point.omega)]  # the Hopf frequency along the curve
        beyond = [0]  # fold points past the type change

        def stop(point, special, kind=kind, run=run, omegas=omegas, beyond=beyond):
            # a curve that is not a stability boundary (another eigenvalue unstable on
            # OFF_BOUNDARY points in a row); a fold curve whose chi has turned back (past its
            # cusp: the S's other fold lies below the first, never the edge of the stable
            # region) by TURNED_BACK in log chi
            run[0] = run[0] + 1 if point.other_unstable else 0
            if run[0] >= OFF_BOUNDARY:
                return True
            if from_bt and len(run) == 3 and point.other_unstable:
                # the first point from a BT point: of the two halves of a curve through BT,
                # the one where the pair's other eigenvalue (the trace of the 2x2 block,
                # which changes sign at BT) is unstable is never the boundary
                return True
            if len(run) == 3:  # the first step sets the way the curve goes in chi
                run.append(1.0 if point.p[0] >= run[1] else -1.0)
                run[2] = run[3] * run[1]
            way = run[3]
            run[2] = max(run[2], way * point.p[0])  # the farthest reached that way
            # landed on the outermost requested chi: nothing beyond is reported, except a BT
            # point that a Hopf curve whose frequency falls is heading for (it is located on
            # the way to omega = 0, a little past the range's margin)
            closing = kind == "hopf" and point.omega < omegas[-1]
            omegas.append(point.omega)
            if not closing and lowest is not None and \
                    ((way > 0 and point.p[0] >= highest - _EDGE) or
                     (way < 0 and point.p[0] <= lowest + _EDGE)):  # fmt: skip
                return True
            if kind == "fold" and any(sp.kind == "cusp" and sp.located for sp in special):
                return True  # past its located cusp (as TURNED_BACK below, sooner)
            if kind == "fold" and not ctx.cusps and _hopf_beyond(ctx, point):
                beyond[0] += 1  # past the type change: on only for its cusp, while it is cheap
                if beyond[0] > CUSP_POINTS or point.refused > CUSP_REFUSALS:
                    return True
            return kind == "fold" and way * point.p[0] < run[2] - TURNED_BACK

        def give_up(refused, beyond=beyond):
            # past the type change, refused steps are not spent on the cusp (4-7 min at N = 8)
            return beyond[0] > 0 and refused > CUSP_REFUSALS

        curve = trace(ctx.eq, start, direction=d, bounds=ctx.bounds, max_points=ctx.max_points,
                      settings=ctx.settings, stop=stop, landing=ctx.landing, give_up=give_up,
                      progress=lambda q, kind=kind: _progress(ctx, kind, q))  # fmt: skip
        ctx.current = []
        ctx.curves.append(_Curve(kind, curve))
        log.info("%s curve: %d points, end %s", kind, len(curve.points), curve.end)
        for sp in curve.special:
            ctx.special.append(sp)
            key = tuple(np.round(sp.point.p, 6))
            if sp.kind == "bt" and sp.located and not sp.point.other_unstable and \
                    key not in ctx.visited_bt:  # fmt: skip
                ctx.visited_bt.add(key)  # each BT point switched at once (no cycles)
                other = "fold" if kind == "hopf" else "hopf"
                ctx.say({"switch": f"{kind} -> {other} at BT", "chi": math.exp(sp.point.p[0])})
                _continue(ctx, sp, other, directions=(d,))


def _turn_beyond(ctx: _Context, chi: float) -> codim2.SpecialPoint | None:
    """A located turn of a fold curve (an extremum of chi along it) with ``chi`` beyond it: its
    points on both sides lie on the other side of the turn in chi (a smallest chi above
    ``chi``, or a largest below)."""
    t = math.log(chi)
    for c in ctx.curves:
        for sp in c.curve.special:
            if sp.kind != "turn" or not sp.located:
                continue
            t0 = float(sp.point.p[0])
            near = [q.p[0] for q in c.curve.points[max(sp.index - 1, 0): sp.index + 3]]
            if near and all((q - t0) * (t0 - t) > 0 for q in near):
                return sp
    return None


def _hopf_beyond(ctx: _Context, point: codim2.CurvePoint) -> bool:
    """Whether a Hopf curve found so far lies beyond the fold ``point`` in lambda at its chi
    (above it on the in-plane side): the fold is not the stability boundary there."""
    t = float(point.p[0])
    for c in ctx.curves:
        if c.kind == "hopf":
            lam = _interpolated(c, t)
            if lam is not None and ctx.side * (lam - float(point.p[1])) > 0:
                return True
    return False


def _guarded_continue(ctx: _Context, start: codim2.CurvePoint, failed: list[dict]) -> None:
    """:func:`_continue`, with a failure recorded (the curves found so far are kept)."""
    try:
        _continue(ctx, start, start.kind)
    except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
        chi = math.exp(start.p[0])
        log.warning("the %s curve from chi = %.4g stopped: %s", start.kind, chi, err)
        failed.append({"chi": None, "error": f"the {start.kind} curve from chi = {chi:.6g} "
                                             f"stopped: {err}"})  # fmt: skip


def _progress(ctx: _Context, kind: str, q: codim2.CurvePoint) -> None:
    """A new point of the curve under way: kept for an interruption, then reported."""
    summary = _point_summary(kind, q)
    ctx.current.append(summary)
    ctx.say(summary)


class CurveInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM, which the command line turns into one) during
    :func:`neutral_curve_codim2`; ``partial`` is what was found (:func:`_partial`)."""

    def __init__(self, partial: dict):
        super().__init__("the neutral curve was interrupted")
        self.partial = partial


def _partial(ctx: _Context, chis: Sequence[float], failed: list[dict]) -> dict:
    """What an interrupted curve had found: every fold and Hopf curve traced so far (and the
    points of the one under way) with each point's ``converged`` and ``other_unstable``, and the
    special points located.  No neutral point is picked from them (that needs the type change
    and the rule of the module notes): ``complete`` is false.  The command run again with the
    same memo (``memo=``, ``vesicle neutral --resume``) replays its evaluations."""
    curves = [{"kind": c.kind, "end": c.curve.end,
               "points": [_point_summary(c.kind, q) for q in c.curve.points]}
              for c in ctx.curves]  # fmt: skip
    if ctx.current:
        curves.append({"kind": ctx.current[0]["curve"], "end": "interrupted",
                       "points": list(ctx.current)})  # fmt: skip
    return {"complete": False, "interrupted": True, "method": "codim2",
            "v": float(ctx.physics.v), "orientation": ctx.analysis.orientation,
            "modes": ctx.analysis.modes,
            "chi_requested": [float(c) for c in chis], "curves": curves,
            "bt_points": _special_dicts(ctx, "bt"), "cusp_points": _special_dicts(ctx, "cusp"),
            "turn_points": _special_dicts(ctx, "turn"), "failed": list(failed)}  # fmt: skip


def _point_summary(kind: str, q: codim2.CurvePoint) -> dict:
    return {"curve": kind, "chi": math.exp(q.p[0]), "lam": float(q.p[1]),
            "omega_R": float(q.omega), "converged": bool(q.converged),
            "other_unstable": bool(q.other_unstable)}  # fmt: skip


def _state_numbers(ctx: _Context, q: codim2.CurvePoint) -> tuple[float, float, float]:
    """psi and D of the critical state, and its curvature shift (the leading growth rate of
    the pencil with the multipliers' curvature minus SPEC §9's, at the critical eigenvalue)."""
    P = ctx.eq.problem_at(q.p)
    a, mu = q.x[:-2], q.x[-2:]
    try:
        d = diagnose(P.shape(a))
    except ShapeError as err:
        log.warning("chi = %.4g: no shape diagnostics (%s)", math.exp(q.p[0]), err)
        return math.nan, math.nan, math.nan
    shift = 0.0
    try:
        J = ctx.eq.jacobian(q.x, q.p).copy()  # the problem keeps the array it returns
        H = P.constraint_hessians(a)
        n = a.size
        Jc = J.copy()
        if ctx.eq.form == "spec":
            Jc[:n, :n] -= np.einsum("k,kij->ij", mu, H)
        else:
            J[:n, :n] += np.einsum("k,kij->ij", mu, H)
        s_spec = codim2.finite_eigenvalues(*ctx.eq.spectrum_pencil(J))
        s_curv = codim2.finite_eigenvalues(*ctx.eq.spectrum_pencil(Jc))
        target = 1j * q.omega
        shift = float(s_curv[np.argmin(np.abs(s_curv - target))].real
                      - s_spec[np.argmin(np.abs(s_spec - target))].real)  # fmt: skip
    except (np.linalg.LinAlgError, ValueError, ShapeError, SolverError) as err:  # reported
        log.warning("curvature shift at chi = %.4g not computed: %s", math.exp(q.p[0]), err)
        shift = math.nan
    return float(d.psi), float(d.D), shift


def _report(ctx: _Context, chi: float, cand: _Candidate, t0: float,
            lower: _Candidate | None) -> NeutralPoint:  # fmt: skip
    """The candidate solved for at exactly ``chi``: a located point, else the estimate."""
    q = cand.near
    p = np.array([math.log(chi), cand.lam])
    try:
        if q.converged and abs(q.p[0] - p[0]) <= 1e-12:  # the curve landed on this chi
            r = q
        else:
            r = _locate(ctx, cand.kind, q.x, p, near=q)
    except (*_FAILURES, np.linalg.LinAlgError, ValueError) as err:
        log.warning("chi = %.4g: the %s point was not solved for (%s)", chi, cand.kind, err)
        r = None
    if r is None or not r.converged:
        lam, located, residual, other, omega = cand.lam, False, (
            math.inf if r is None else float(r.residual)), bool(q.other_unstable), float(q.omega)
        numbers = _state_numbers(ctx, q)
    else:
        lam, located, residual, other, omega = (float(r.p[1]), True, float(r.residual),
                                                bool(r.other_unstable), float(r.omega))
        numbers = _state_numbers(ctx, r)
    lower_fold, lower_located = None, False
    if lower is not None:
        f = None
        try:
            f = lower.near if lower.near.converged and \
                abs(lower.near.p[0] - math.log(chi)) <= 1e-12 else \
                _locate(ctx, "fold", lower.near.x, np.array([math.log(chi), lower.lam]),
                        near=lower.near)  # fmt: skip
        except (*_FAILURES, np.linalg.LinAlgError, ValueError) as err:
            log.warning("chi = %.4g: the lower fold was not solved for (%s)", chi, err)
        lower_fold, lower_located = ((float(f.p[1]), True) if f is not None and f.converged
                                     else (lower.lam, False))  # fmt: skip
    psi, D, shift = numbers
    kind = "hopf" if cand.kind == "hopf" else "saddle-node"
    return NeutralPoint(float(chi), lam, kind, omega if kind == "hopf" else 0.0, psi, D, located,
                        time.perf_counter() - t0, None, None, shift, lower_fold, lower_located,
                        residual=residual, other_unstable=other)  # fmt: skip


def _extent(curve: _Curve) -> tuple[float, float]:
    """The range of log chi its candidate segments cover."""
    ts = [q.p[0] for seg in curve.segments() for q in seg]
    return (min(ts), max(ts)) if ts else (math.inf, -math.inf)


def _nearest(curve: _Curve, t: float) -> codim2.CurvePoint:
    """Its converged point of its own kind (not a BT end), before its chi turns back and with
    no other unstable eigenvalue, nearest ``log chi = t``."""
    pts = [q for q in curve.before_turn() if q.kind == curve.kind and q.converged
           and not q.other_unstable]  # fmt: skip
    return min(pts, key=lambda q: abs(q.p[0] - t))


def _interpolated(curve: _Curve, t: float) -> float | None:
    """``lambda`` of the curve's first candidate at ``log chi = t`` (:func:`_candidates`), or
    None."""
    cands = _candidates([curve], math.exp(t))
    return cands[0].lam if cands else None


def _crossing_estimate(fold: _Curve, hopf: _Curve, lo: float, hi: float):
    """Where the two curves' own points (joined linearly) cross inside ``log chi`` in
    ``[lo, hi]``: ``(chi, d gap / d chi)`` of the gap ``lambda_hopf - lambda_fold`` there (the
    start of :func:`.steady_codim2.locate_type_change`'s secant iterations), or
    ``(None, None)``."""
    ts = sorted({lo, hi, *(q.p[0] for c in (fold, hopf) for seg in c.segments() for q in seg
                           if lo < q.p[0] < hi)})  # fmt: skip
    gaps = []
    for t in ts:
        lf, lh = _interpolated(fold, t), _interpolated(hopf, t)
        gaps.append(None if lf is None or lh is None else lh - lf)
    for (t0, g0), (t1, g1) in itertools.pairwise(zip(ts, gaps, strict=True)):
        if g0 is None or g1 is None or g0 * g1 > 0 or g0 == g1:
            continue
        t = t0 + g0 * (t1 - t0) / (g0 - g1)
        chi = math.exp(t)
        return chi, (g1 - g0) / (t1 - t0) / chi
    return None, None


def _type_change(ctx: _Context, chis: Sequence[float]) -> tuple[dict | None, dict | None]:
    """Where the winning candidate changes kind along the curves' own points: the two curves
    that swap, then Brent's method on their difference over the range of chi both cover
    (each evaluation solves both points at that chi on their augmented systems, from the
    nearest point of their own curve, so that neither jumps to another sheet), or their BT
    point where they meet only there."""
    grid = sorted({float(math.exp(q.p[0])) for c in ctx.curves for q in c.curve.points
                   if q.converged} | set(chis))  # fmt: skip
    grid = [x for x in grid if chis[0] <= x <= chis[-1]]
    kinds = [(x, _winner(ctx.curves, x, ctx.side)) for x in grid]
    kinds = [(x, w) for x, w in kinds if w is not None]
    for (x0, w0), (x1, w1) in itertools.pairwise(kinds):
        if w0.kind == w1.kind:
            continue
        names = {"below": "hopf" if w0.kind == "hopf" else "saddle-node",
                 "above": "hopf" if w1.kind == "hopf" else "saddle-node"}  # fmt: skip
        fold, hopf = (w0, w1) if w0.kind == "fold" else (w1, w0)
        (f_lo, f_hi), (h_lo, h_hi) = _extent(fold.curve), _extent(hopf.curve)
        lo, hi = max(f_lo, h_lo), min(f_hi, h_hi)
        estimate = {"chi": math.sqrt(x0 * x1), "bracket": [x0, x1], "located": False,
                    "lambda_c": 0.5 * (w0.lam + w1.lam), "omega_R": float(hopf.near.omega),
                    **names}  # fmt: skip
        if hi - lo < 1e-6:  # the curves meet at one point only: their BT point
            bt = [sp for sp in ctx.special if sp.kind == "bt" and sp.located and
                  abs(sp.point.p[0] - lo) < 1e-5 and not sp.point.other_unstable]  # fmt: skip
            if bt:
                q = bt[0].point
                return {"chi": math.exp(q.p[0]), "lambda_c": float(q.p[1]), "omega_R": 0.0,
                        "located": True, "at": "bt", "residual": float(bt[0].residual),
                        **names}, None  # fmt: skip
            return {**estimate, "error": "the fold and Hopf curves do not overlap in chi"}, None
        # inside the overlap, away from its ends (a cusp at one: the fold at fixed chi is
        # singular there)
        margin = min(0.01, 0.1 * (hi - lo))
        a, b = math.exp(lo + 0.5 * margin), math.exp(hi - margin)
        # the gap is probed from the switch the curves' points show, outwards, before Brent
        probes = [math.exp(lo + f * (hi - lo)) for f in (0.25, 0.5, 0.75)]
        guess, slope = _crossing_estimate(fold.curve, hopf.curve, math.log(a), math.log(b))
        try:
            change = locate_type_change(
                ctx.eq, _nearest(fold.curve, math.log(a)), _nearest(hopf.curve, math.log(a)),
                (a, b), settings=ctx.settings, probes=probes, guess=guess, slope=slope,
                progress=lambda d: ctx.say({"type_change": d}),
                start=lambda kind, chi, f=fold.curve, h=hopf.curve: _nearest(
                    f if kind == "fold" else h, math.log(chi)))  # fmt: skip
        except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
            log.warning("type change between chi = %.4g and %.4g not located: %s", a, b, err)
            return {**estimate, "error": str(err)}, None
        d = change.to_dict()
        d.update({"bracket": [a, b], "at": "crossing", **names,
                  "other_unstable": bool(change.fold.other_unstable or
                                         change.hopf.other_unstable)})  # fmt: skip
        return d, None
    return None, None


def _finite(x: float) -> float | None:
    """A number for the JSON: ``None`` where it is not finite (JSON has no NaN or inf)."""
    x = float(x)
    return x if math.isfinite(x) else None


def _special_dicts(ctx: _Context, kind: str) -> list[dict]:
    out = []
    for sp in ctx.special:
        if sp.kind != kind:
            continue
        q = sp.point
        eig = np.asarray(q.eigenvalues)
        two = sorted(eig, key=abs)[:2] if eig.size else []
        out.append({"chi": math.exp(q.p[0]), "lambda": float(q.p[1]), "located": bool(sp.located),
                    "residual": _finite(sp.residual), "test": _finite(sp.test),
                    "other_unstable": bool(q.other_unstable),
                    "smallest_eigenvalues": [[float(z.real), float(z.imag)] for z in two]})
    return out


def lam_box(lam_range) -> tuple[float, float]:
    """``(low, high)`` of a curve's box in lambda, checked: ``0 < low < high``."""
    lo, hi = map(float, lam_range)
    if not 0 < lo < hi:
        raise ValueError(f"lam_range must be (low, high) with 0 < low < high, got {lam_range}")
    return lo, hi


def curve_memo(folder, physics: Physics, discretisation: Discretisation,
               analysis: StabilitySettings | None = None, form: str = "spec",
               free: tuple[str, str] = ("lam", "chi")) -> EvaluationMemo:  # fmt: skip
    """The memo of a curve's evaluations in ``folder`` (``neutral_curve_codim2(memo=...)``), for
    this physics but the curve's two parameters ``free`` (``("lam", "bq")`` for
    :func:`~vesicle.bifurcation.neutral_bq.neutral_curve_bq`), discretisation, analysis and
    form.  Raises
    :class:`~vesicle.io.memo.MemoMismatch` where ``folder`` holds another curve's."""
    from vesicle import __version__

    analysis = analysis if analysis is not None else StabilitySettings()
    held = {k: v for k, v in physics.to_dict().items() if k not in free}
    # the threads change no value (at most the last bits, then the lookups miss)
    disc = {k: v for k, v in discretisation.to_dict().items() if k != "workers"}
    return EvaluationMemo(folder, {"physics": held, "discretisation": disc,
                                   "orientation": analysis.orientation, "modes": analysis.modes,
                                   "jacobian": analysis.jacobian, "form": form,
                                   "vesicle_version": __version__})  # fmt: skip


def neutral_curve_codim2(
    physics: Physics | float,
    chi: Sequence[float],
    discretisation: Discretisation | None = None,
    *,
    analysis: StabilitySettings | None = None,
    form: str = "spec",
    lam_range: tuple[float, float] = (0.5, 100.0),
    settings: codim2.Settings | None = None,
    max_points: int = 80,
    locate_type_change: bool = True,
    cusps: bool = False,
    progress: Callable[[dict], None] | None = None,
    memo: EvaluationMemo | None = None,
    **legacy,
) -> NeutralCurve:
    """The neutral curve through the requested ``chi`` by two-parameter continuation (see the
    module docstring).

    Parameters
    ----------
    physics : Physics or float
        Its ``v`` and ``flow`` (or just ``v``).
    chi : sequence of float
        The shear rates to report (positive; reported ascending).
    analysis : StabilitySettings
        The branch, modes and Jacobians, as for :func:`vesicle.bifurcation.neutral.neutral_curve`
        (the former keywords ``orientation``, ``modes``, ``jacobian`` work for one release, with
        a warning).
    form : {"spec", "curvature"}
        The Jacobian the curves are defined by (:data:`.steady_codim2.FORMS`): SPEC §9's
        operator (the default: what ``vesicle critical`` and the tracer compute) or the Newton
        matrix with the multipliers' curvature.
    lam_range : (float, float)
        The box in lambda the curves are kept in.
    settings : codim2.Settings, optional
        Default :data:`DEFAULT_SETTINGS`.
    max_points : int
        Most points of each continued curve.
    locate_type_change : bool
        Solve for the change of type (False: ``type_change`` is None).
    cusps : bool
        Continue each fold curve past the type change to its cusp however many refused steps
        that takes (default: given up there after :data:`CUSP_POINTS` points or more than
        :data:`CUSP_REFUSALS` refused steps in a row; then the cusps of v = 0.95 and 0.90 are
        not reached even at N = 4).
    progress : callable, optional
        Given a summary dict of each step (curve points, searches, located points).
    memo : EvaluationMemo, optional
        Where the evaluations at the full resolution are kept and looked up (:func:`curve_memo`):
        a curve interrupted and run again with the same memo replays what it computed and goes
        on from where it stopped (the stepping searches, at N = 4 first, are computed again).

    Returns
    -------
    NeutralCurve
        ``method = "codim2"``, with ``bt_points``, ``cusp_points`` and ``turn_points``; each
        point with ``located``, ``residual`` and ``other_unstable``.
    """
    analysis = legacy_settings("neutral_curve_codim2", StabilitySettings, analysis, legacy)
    refuse_unknown("neutral_curve_codim2", legacy)
    analysis = analysis if analysis is not None else StabilitySettings()
    orientation, modes, jacobian = analysis.orientation, analysis.modes, analysis.jacobian
    physics, chis = curve_inputs(physics, chi)
    lo, hi = lam_box(lam_range)
    disc = discretisation if discretisation is not None else Discretisation()
    t0 = time.perf_counter()
    side = -1 if orientation == "vorticity" else 1
    seed_chi = max(chis) if side < 0 else min(chis, key=lambda c: abs(math.log(c)))
    eq = SteadyEquations(physics.replace(chi=seed_chi, lam=max(lo, 1.0)), disc, modes=modes,
                         jacobian=jacobian, form=form)  # fmt: skip
    eq.memo = memo
    margin = 0.02
    bounds = [[math.log(chis[0]) - margin, math.log(chis[-1]) + margin], [lo, hi]]

    def say(d: dict) -> None:
        log.info("%s", d)
        if progress is not None:
            progress(d)

    ctx = _Context(physics, disc, eq, analysis,
                   settings or DEFAULT_SETTINGS, side, bounds, max_points, say,
                   [math.log(c) for c in chis])  # fmt: skip
    ctx.curves_eq = eq
    ctx.cusps = bool(cusps)
    failed: list[dict] = []
    try:
        seed = _kept(ctx, "seed", lambda: _seed(ctx, seed_chi), seed_chi)
        if not seed.converged:
            raise NewtonError(f"the critical point at chi = {seed_chi:g} did not converge "
                              f"(residual {seed.residual:.2e})")  # fmt: skip
        say({"seed": _point_summary(seed.kind, seed)})
        _guarded_continue(ctx, seed, failed)
        tried: set[float] = {seed_chi}
        edge = chis[0] if side > 0 else chis[-1]
        for _ in range(4):
            # a new seed where requested chi are not covered yet, else at the low-chi edge (high
            # for the vorticity branch): the curves found so far may belong to another sheet
            # than the branch from low lambda there (v = 0.95 between the BT point and the type
            # change: the Hopf curve is the upper sheet's, the lower sheet folds first)
            missing = [c for c in chis if _winner(ctx.curves, c, side) is None and c not in tried]
            if missing:
                c = missing[0] if side > 0 else missing[-1]
            elif edge not in tried:
                c = edge
            else:
                break
            tried.add(c)
            turn = _turn_beyond(ctx, c)
            coarse = _coarse_discretisation(ctx.disc, "auto", None, ctx.analysis)
            try:
                if turn is not None and coarse is not None:  # past where the folds end: the
                    # search at the coarse resolution only (one that finds nothing steps the
                    # whole box)
                    lam0 = _start_lambda(ctx, c)
                    point = _kept(ctx, "coarse first loss",
                                  lambda: _coarse_first_loss(ctx, c, lam0), c, lam0)  # noqa: B023
                    if point is None:
                        raise NewtonError("the search at N = 4 on 16x32 found none")
                else:
                    lam0 = _start_lambda(ctx, c)
                    point = _kept(ctx, "first loss", lambda: _loss(ctx, c, lam0), c, lam0)  # noqa: B023
            except (*_FAILURES, RuntimeError, ValueError, np.linalg.LinAlgError) as err:
                note = "" if turn is None else (
                    f"; the fold curve turns back at chi = {math.exp(turn.point.p[0]):.6g}, "
                    f"lambda = {turn.point.p[1]:.6g} (located): no fold of it lies beyond")
                failed.append({"chi": c, "error": f"no critical point: {err}{note}"})
                log.warning("neutral curve: no critical point at chi = %.4g: %s%s", c, err, note)
                continue
            if not point.converged:
                failed.append({"chi": c, "error": f"the {point.kind} point did not converge "
                                                  f"(residual {point.residual:.2e})"})
                continue
            if any(k.kind == point.kind and abs(k.lam - point.p[1]) <= 1e-5 * max(1.0, k.lam)
                   for k in _candidates(ctx.curves, c)):  # fmt: skip
                say({"chi": c, "first_loss": f"on the {point.kind} curve already traced"})
                continue
            say({"seed": _point_summary(point.kind, point)})
            _guarded_continue(ctx, point, failed)
        change = _type_change(ctx, chis)[0] if locate_type_change else None
        points = []
        for c in chis:
            t1 = time.perf_counter()
            cand = _winner(ctx.curves, c, side)
            if cand is None:
                if not any(f["chi"] == c for f in failed):
                    failed.append({"chi": c, "error": "no fold or Hopf curve reaches this chi "
                                                      "without another unstable eigenvalue"})
                continue
            lower = None
            if cand.kind == "hopf":
                folds = [k for k in _candidates(ctx.curves, c) if k.kind == "fold"
                         and side * (cand.lam - k.lam) > 0]  # fmt: skip
                lower = max(folds, key=lambda k: side * k.lam) if folds else None
            point = _report(ctx, c, cand, t1, lower)
            points.append(point)
            say({"point": point.to_dict()})
        # a chi reported in the end is not a failure (an edge seed that failed where a curve
        # already reached); the failures of the curves themselves stay (chi = None)
        reported = {p.chi for p in points}
        failed = [f for f in failed if f["chi"] not in reported]
        return NeutralCurve(physics, disc, points, change, [], time.perf_counter() - t0, failed,
                            orientation, modes, ctx.settings.ftol, 0, method="codim2",
                            bt_points=_special_dicts(ctx, "bt"),
                            cusp_points=_special_dicts(ctx, "cusp"),
                            turn_points=_special_dicts(ctx, "turn"), form=form)  # fmt: skip
    except KeyboardInterrupt as err:  # Ctrl-C or SIGTERM: what was found goes with it
        raise CurveInterrupted(_partial(ctx, chis, failed)) from err
