"""A point's spectral analysis and the location of fold, Hopf and BT points from a nearby
state (the start of every curve).

Part of :mod:`vesicle.bifurcation.codim2` (see its docstring)."""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from vesicle.bifurcation.codim2.core import Evaluations, _Evaluator
from vesicle.bifurcation.codim2.linalg import (
    _bordered,
    _pencil_vectors,
    _realify,
    _unit,
    finite_eigenvalues,
)
from vesicle.bifurcation.codim2.results import (
    CurvePoint,
    Settings,
    SpecialPoint,
    _frozen,
)
from vesicle.bifurcation.codim2.systems import (
    _BogdanovTakens,
    _MinAugFold,
    _MinAugHopf,
    _newton,
    _Solved,
)

log = logging.getLogger(__name__)

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


