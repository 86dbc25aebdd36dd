"""The neutral curve of a viscous membrane in the ``(Bq, lambda)`` plane at fixed ``chi`` (issue
42): ``lambda_c(Bq)`` by two-parameter continuation, and the critical Boussinesq number at given
viscosity ratios.

What is computed
----------------
The steady equations of :mod:`.steady_codim2` continued in ``p = (Bq, lambda)``
(``SteadyEquations(plane=("bq", "lam"))``; the parameter derivative in ``Bq`` is the system
differentiated in it, :meth:`~vesicle.steady.problem.SteadyProblem.parameter_rates`).

1. **The seed** at the first requested ``Bq`` (normally 0): the bracketing search
   :func:`vesicle.bifurcation.critical.critical_lambda` (at N = 4 on 16x32 first when the
   resolution is finer) gives a stable state just below ``lambda_c``, and the Hopf (or fold)
   point is solved for from it on its augmented system with ``Bq`` held.
2. **The curve continued** in ``Bq`` by pseudo-arclength (:func:`codim2.hopf_curve` /
   ``fold_curve``), landing on each requested ``Bq`` (a point there is corrected with ``Bq``
   held); at a located Bogdanov–Takens point the other curve is continued on from it (at most
   :data:`SWITCHES` times).  The box ends it; with ``lam_at`` it goes on past the last requested
   ``Bq`` (up to :data:`FAR_BQ`) until it is below the lowest of those lambdas.
3. **The critical Bq at each requested lambda** (``lam_at``): where the curve crosses that
   ``lambda``, the point solved for on its augmented system with ``lambda`` held and ``Bq``
   free, from the curve's points either side.

Every point carries ``located`` (its augmented system converged to ``settings.ftol`` in the
path that produced it), ``residual`` and ``other_unstable`` (another eigenvalue on or over the
axis: then it is not where tank-treading loses stability).  A requested ``Bq`` the curve did
not land on is reported as an estimate (``located = False``, interpolated between its
neighbours); a requested ``lambda`` the curve does not cross is listed in ``failed``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from vesicle.bifurcation import codim2
from vesicle.bifurcation.critical import critical_lambda
from vesicle.bifurcation.neutral_codim2 import DEFAULT_SETTINGS, lam_box
from vesicle.bifurcation.steady_codim2 import BQ_ROUNDING, FORMS, SteadyEquations
from vesicle.geometry.surface import ShapeError
from vesicle.io.files import stamped
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import CriticalSearch, StabilitySettings
from vesicle.model.theory import misbah_critical_lambda
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NewtonError

__all__ = ["BqCurve", "BqCurveInterrupted", "neutral_curve_bq"]

log = logging.getLogger(__name__)

#: The continuation's settings: the neutral curves' (:data:`.neutral_codim2.DEFAULT_SETTINGS`)
#: with arclength steps up to 2 instead of 0.6: lambda_c(Bq) is nearly straight.  Measured at
#: v = 0.95, chi = 1, N = 4 on 16x32, Bq 0 to 7.8: 10 curve points instead of 21, 103 s
#: instead of 123 s with the seed's search, the same lambda_c at Bq = 0, 1, 2, 5 to 1e-6.
SETTINGS = dataclasses.replace(DEFAULT_SETTINGS, ds_max=2.0)

#: Switches between the Hopf and the fold curve at BT points along one trace.
SWITCHES = 3

#: With ``lam_at``, the curve goes on past the last requested Bq (up to this Bq) until it is
#: below the lowest of those lambdas.
FAR_BQ = 50.0

_FAILURES = (NewtonError, ShapeError, SolverError, RuntimeError, ValueError,
             np.linalg.LinAlgError)  # fmt: skip


def _kind_name(kind: str) -> str:
    return "saddle-node" if kind in ("fold", "bt") else "hopf"


def _bq(value: float) -> float:
    """A Boussinesq number of a point; rounding below 0 (:data:`BQ_ROUNDING`) read as 0."""
    return 0.0 if -BQ_ROUNDING <= value < 0.0 else float(value)


def _point_dict(q: codim2.CurvePoint, located: bool | None = None) -> dict:
    return {"bq": _bq(q.p[0]), "lambda_c": float(q.p[1]), "bifurcation": _kind_name(q.kind),
            "omega_R": float(q.omega) if q.kind == "hopf" else 0.0,
            "located": bool(q.converged if located is None else located),
            "residual": float(q.residual), "other_unstable": bool(q.other_unstable)}  # fmt: skip


class BqCurveInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM, which the command line turns into one) during
    :func:`neutral_curve_bq`; ``partial`` is what was found: ``{"complete": False,
    "interrupted": True, "seed", "curves" (each ``{"kind", "end", "points"}``, the one under way
    with ``end = "interrupted"``), "special_points", "failed"}`` (no ``"points"``: nothing is
    picked from an unfinished curve)."""

    def __init__(self, partial: dict):
        super().__init__("the curve in (Bq, lambda) was interrupted")
        self.partial = partial


@dataclass
class BqCurve:
    """What :func:`neutral_curve_bq` found (``to_dict`` is ``vesicle neutral-bq``'s JSON)."""

    physics: Physics
    discretisation: Discretisation
    form: str
    points: list[dict]  # at the requested Bq
    critical_bq: list[dict]  # at the requested lambda
    curves: list[dict]  # every continued curve: kind, end, its points
    special: list[dict]  # BT points and cusps
    failed: list[dict]
    seconds: float
    ftol: float
    seed: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        fixed = {k: x for k, x in self.physics.to_dict().items() if k not in ("lam", "bq")}
        return stamped({
            "method": "codim2", "plane": ["bq", "lam"], "form": self.form,
            "v": self.physics.v, "chi": self.physics.chi,
            "degree": self.discretisation.degree, "grid": self.discretisation.grid,
            "physics": fixed, "discretisation": self.discretisation.to_dict(),
            "ftol": self.ftol, "seed": self.seed, "points": self.points,
            "critical_bq": self.critical_bq, "special_points": self.special,
            "curves": self.curves, "failed": self.failed, "seconds": self.seconds,
            "leading_order": {
                "lambda_c_bq0": misbah_critical_lambda(self.physics.v),
                "slope": -16.0 / 23.0,
                "note": "the small-deformation theory's effective viscosity ratio lambda + "
                        "16 Bq/23: lambda_c(Bq) = lambda_c(0) - 16 Bq/23 as v -> 1 "
                        "(lambda_c_bq0: its own lambda_c,LO(v))"},
        })  # fmt: skip


def _seed(eq: SteadyEquations, physics: Physics, disc: Discretisation,
          analysis: StabilitySettings, settings: codim2.Settings,
          lam0: float | None) -> codim2.CurvePoint:  # fmt: skip
    """The critical point at ``physics.bq`` from the bracketing search's stable state nearest
    ``lambda_c``."""
    search = CriticalSearch(lam0=lam0, coarse="auto" if lam0 is None else None)
    c = critical_lambda(physics, disc, search=search, analysis=analysis)
    stable = [(lam, s) for (lam, _, w_i), s in zip(c.history, c.states, strict=True) if w_i < 0]
    if not stable:
        raise NewtonError(f"the bracketing search at Bq = {physics.bq:g} kept no stable state")
    _, state = min(stable, key=lambda q: abs(q[0] - c.lambda_c))
    x, _ = eq.state(state)
    p = np.array([physics.bq, c.lambda_c])
    if c.omega_R > 1e-6:
        return codim2.locate_hopf(eq, x, p, free=1, omega=c.omega_R, settings=settings)
    return codim2.locate_fold(eq, x, p, free=1, settings=settings)


def _continue(eq, start, kind: str, bounds, landing, max_points, settings, say,
              stop=None) -> codim2.Curve:  # fmt: skip
    def progress(q: codim2.CurvePoint) -> None:
        say({"curve": kind, **_point_dict(q)})

    run = codim2.hopf_curve if kind == "hopf" else codim2.fold_curve
    return run(eq, start, direction=(1.0, 0.0), bounds=bounds, max_points=max_points,
               settings=settings, progress=progress, landing=landing, stop=stop)  # fmt: skip


def _at_bq(curves: Sequence[codim2.Curve], bq: float) -> dict | None:
    """The curve point at ``bq`` (a landing), else the estimate interpolated between the two
    points either side (``located = False``)."""
    points = [q for c in curves for q in c.points]
    exact = [q for q in points if _bq(q.p[0]) == bq]
    if exact:
        q = min(exact, key=lambda q: q.residual)
        return _point_dict(q)
    for c in curves:
        for a, b in zip(c.points[:-1], c.points[1:], strict=True):
            if (a.p[0] - bq) * (b.p[0] - bq) < 0:
                s = (bq - a.p[0]) / (b.p[0] - a.p[0])
                d = _point_dict(a if s < 0.5 else b, located=False)
                d.update(bq=float(bq), lambda_c=float(a.p[1] + s * (b.p[1] - a.p[1])),
                         residual=float("nan"), estimate="interpolated between curve points")
                return d
    return None


def _below_floor(curves: Sequence[codim2.Curve], lo: float) -> float | None:
    """The ``Bq`` at which the last curve left the box below ``lambda = lo`` (its last point,
    out of the box), else None."""
    if not curves or curves[-1].end != "bounds":
        return None
    last = curves[-1].points[-1]
    return float(last.p[0]) if last.p[1] < lo else None


def _critical_bq(eq, curves: Sequence[codim2.Curve], lam: float, settings) -> list[dict]:
    """Each crossing of ``lambda = lam`` by the curves, solved for with ``lambda`` held."""
    out = []
    for c in curves:
        for a, b in zip(c.points[:-1], c.points[1:], strict=True):
            if not (a.p[1] - lam) * (b.p[1] - lam) <= 0 or a.p[1] == b.p[1]:
                continue
            s = (lam - a.p[1]) / (b.p[1] - a.p[1])
            near = a if s < 0.5 else b
            x = a.x + s * (b.x - a.x)
            p = np.array([a.p[0] + s * (b.p[0] - a.p[0]), lam])
            if c.kind == "hopf":
                q = codim2.locate_hopf(eq, x, p, free=0, omega=near.omega, v=near.v, w=near.w,
                                       settings=settings)  # fmt: skip
            else:
                q = codim2.locate_fold(eq, x, p, free=0, v=near.v, w=near.w, settings=settings)
            d = _point_dict(q)
            d["lam"] = d.pop("lambda_c")
            d["estimate_from_curve"] = float(p[0])
            if not q.converged:  # an unconverged iterate is no answer: the curve's estimate
                d.update(bq=float(p[0]), estimate="interpolated between curve points")
            out.append(d)
    return out


def neutral_curve_bq(
    physics: Physics,
    bq: Sequence[float],
    discretisation: Discretisation | None = None,
    *,
    lam_at: Sequence[float] = (),
    analysis: StabilitySettings | None = None,
    form: str = "spec",
    lam_range: tuple[float, float] = (0.05, 100.0),
    settings: codim2.Settings | None = None,
    max_points: int = 80,
    lam0: float | None = None,
    progress: Callable[[dict], None] | None = None,
    memo=None,
) -> BqCurve:
    """``lambda_c(Bq)`` at ``physics``' ``v``, ``chi`` and flow, through the requested ``bq``
    (ascending; the first is the seed's), and the critical ``Bq`` at each of ``lam_at``
    (module docstring).

    Parameters
    ----------
    physics : Physics
        Its ``v``, ``chi`` and flow (its ``lam`` and ``bq`` are not used).
    bq : sequence of float
        The Boussinesq numbers to report, ``>= 0``; the curve is continued from the first up to
        the last.
    lam_at : sequence of float
        Viscosity ratios at which to solve for the critical Bq.
    analysis : StabilitySettings
        The branch (``orientation``), modes and Jacobians.
    form : {"spec", "curvature"}
        The Jacobian the curves are defined by (:data:`.steady_codim2.FORMS`).
    lam_range : (float, float)
        The box in lambda the curves are kept in.
    settings : codim2.Settings, optional
        Default :data:`SETTINGS`.
    max_points : int
        Most points of each continued curve.
    lam0 : float, optional
        Where the seed's bracketing search starts (default: its own start, at N = 4 first).
    progress : callable, optional
        Given a summary dict of each curve point and located point.
    memo : EvaluationMemo, optional
        Where the evaluations are kept and looked up, as for
        :func:`~vesicle.bifurcation.neutral_codim2.neutral_curve_codim2` (``curve_memo(...,
        free=("lam", "bq"))``): a curve run again with it replays them.
    """
    bqs = sorted(float(b) for b in bq)
    if not bqs or any(not (math.isfinite(b) and b >= 0) for b in bqs):
        raise ValueError(f"bq must be finite values >= 0, got {list(bq)}")
    if not physics.chi > 0:
        raise ValueError(f"chi must be positive for a neutral curve in (Bq, lambda), got "
                         f"{physics.chi} (a reversed shear, chi < 0, has the same curve: give "
                         f"|chi|)")  # fmt: skip
    lams = [float(x) for x in lam_at]
    if any(not (math.isfinite(x) and x > 0) for x in lams):
        raise ValueError(f"lam_at must be positive, got {list(lam_at)}")
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}, got {form!r}")
    lo, hi = lam_box(lam_range)
    analysis = analysis if analysis is not None else StabilitySettings()
    disc = discretisation if discretisation is not None else Discretisation()
    settings = settings or SETTINGS
    t0 = time.perf_counter()

    under_way: list[dict] = []  # the points of the curve being continued
    seen: dict = {}

    def say(d: dict) -> None:
        log.info("%s", d)
        if "seed" in d:
            seen["seed"] = d["seed"]
        if "curve" in d:
            under_way.append({k: x for k, x in d.items() if k != "curve"})
        if progress is not None:
            progress(d)

    curves: list[codim2.Curve] = []
    special: list[dict] = []
    failed: list[dict] = []
    try:
        return _trace(physics, disc, bqs, lams, analysis, form, (lo, hi), settings, max_points,
                      lam0, say, under_way, curves, special, failed, t0, memo=memo)  # fmt: skip
    except KeyboardInterrupt as err:
        done = [{"kind": c.kind, "end": c.end, "points": [_point_dict(q) for q in c.points]}
                for c in curves]  # fmt: skip
        if under_way:
            done.append({"kind": "under way", "end": "interrupted", "points": list(under_way)})
        raise BqCurveInterrupted({
            "complete": False, "interrupted": True, "method": "codim2", "plane": ["bq", "lam"],
            "v": physics.v, "chi": physics.chi, "bq_requested": bqs, "lam_at": lams,
            "seed": seen.get("seed"), "curves": done, "special_points": special, "failed": failed,
            "seconds": time.perf_counter() - t0}) from err  # fmt: skip


def _trace(physics, disc, bqs, lams, analysis, form, lam_range, settings, max_points, lam0, say,
           under_way, curves, special, failed, t0, memo=None) -> BqCurve:  # fmt: skip
    """The work of :func:`neutral_curve_bq` (its lists filled as it goes, for an
    interruption)."""
    lo, hi = lam_range
    start = physics.replace(bq=bqs[0], lam=max(lo, 1.0))
    eq = SteadyEquations(start, disc, modes=analysis.modes, jacobian=analysis.jacobian,
                         form=form, plane=("bq", "lam"))  # fmt: skip
    eq.memo = memo
    seed = _seed(eq, start, disc, analysis, settings, lam0)
    if not seed.converged:
        raise NewtonError(f"the critical point at Bq = {bqs[0]:g} did not converge "
                          f"(residual {seed.residual:.2e})")  # fmt: skip
    say({"seed": _point_dict(seed)})
    margin = 1e-9 * max(1.0, bqs[-1])
    # with lam_at, on past the last Bq until the curve is below the lowest of them
    far = max(bqs[-1], FAR_BQ) if lams else bqs[-1]
    bounds = [[bqs[0] - margin, far + margin], [lo, hi]]

    def stop(q: codim2.CurvePoint, found) -> bool:
        return bool(lams) and q.p[0] >= bqs[-1] and q.p[1] < min(lams)

    start_point: codim2.CurvePoint | codim2.SpecialPoint = seed
    kind = seed.kind
    for _ in range(SWITCHES + 1):
        under_way.clear()
        try:
            curve = _continue(eq, start_point, kind, bounds, bqs, max_points, settings, say,
                              stop)  # fmt: skip
        except _FAILURES as err:
            failed.append({"bq": None, "error": f"the {kind} curve from Bq = "
                           f"{float(_start_p(start_point)[0]):g} stopped: {err}"})  # fmt: skip
            break
        curves.append(curve)
        under_way.clear()
        switch = None
        for s in curve.special:
            special.append({"kind": s.kind, "bq": float(s.point.p[0]),
                            "lam": float(s.point.p[1]), "located": bool(s.located),
                            "residual": float(s.residual), "on": curve.kind})  # fmt: skip
            if s.kind == "bt" and s.located and switch is None:
                switch = s
        if curve.end in ("bounds", "stopped") or switch is None:
            break
        kind = "fold" if curve.kind == "hopf" else "hopf"
        start_point = switch
        say({"switch": f"{curve.kind} -> {kind} at BT", "bq": float(switch.point.p[0]),
             "lam": float(switch.point.p[1])})  # fmt: skip
    points = []
    floor = _below_floor(curves, lo)
    for b in bqs:
        d = _at_bq(curves, b)
        if d is None and floor is not None and b > floor:
            # past where lambda_c fell below the box: no stable TT at lambda >= lam_range[0]
            d = {"bq": b, "lambda_c": None, "bifurcation": None, "located": False,
                 "below_lam_min": lo,
                 "note": f"lambda_c < {lo:g} here: the curve left the box at Bq = {floor:.6g}"}
        if d is None:
            failed.append({"bq": b, "error": "the curve does not reach this Bq"})
            continue
        points.append(d)
    critical = []
    for lam in lams:
        try:
            found = _critical_bq(eq, curves, lam, settings)
        except _FAILURES as err:
            failed.append({"lam": lam, "error": f"the critical Bq did not solve: {err}"})
            continue
        if not found:
            failed.append({"lam": lam, "error": "the curve does not cross this lambda"})
        for d in found:
            say({"critical_bq": d})
        critical.extend(found)
    curve_dicts = [{"kind": c.kind, "end": c.end, "points": [_point_dict(q) for q in c.points]}
                   for c in curves]  # fmt: skip
    return BqCurve(physics.replace(bq=bqs[0]), disc, form, points, critical, curve_dicts,
                   special, failed, time.perf_counter() - t0, settings.ftol,
                   seed=_point_dict(seed))  # fmt: skip


def _start_p(start) -> np.ndarray:
    return start.point.p if isinstance(start, codim2.SpecialPoint) else start.p

