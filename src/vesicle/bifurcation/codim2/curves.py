"""Fold and Hopf curves by pseudo-arclength, with their special points along the way.

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.optimize import brentq

from vesicle.bifurcation.codim2.core import (
    _BT_TRIES,
    _EPS,
    _OMEGA_FLOOR,
    _TURN_XTOL,
    Evaluations,
    _Evaluator,
)
from vesicle.bifurcation.codim2.linalg import _realify
from vesicle.bifurcation.codim2.locate import (
    _bt,
    _fold_tests,
    _point,
)
from vesicle.bifurcation.codim2.results import (
    Curve,
    CurvePoint,
    Settings,
    SpecialPoint,
)
from vesicle.bifurcation.codim2.systems import (
    _Formulation,
    _newton,
    _Solved,
    _tangent,
)

log = logging.getLogger(__name__)

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
