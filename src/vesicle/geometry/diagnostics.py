"""Shape diagnostics and regime analysis (SPEC §10).

Principal axes are the eigenvectors of the surface inertia tensor about the volume centroid; the
length of an axis is the sum of the radii from the centroid along its + and - directions (rays
intersected with the surface).  The inclination ``psi`` is the angle from x to the longer of the
two principal axes that lie closest to the x-z plane, in (-pi/2, pi/2]; ``D = (L1-L2)/(L1+L2)``.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from vesicle.geometry.surface import Shape, ShapeError
from vesicle.sphere.transforms import evaluate, mode_energy, transform

__all__ = [
    "DampedOscillation",
    "Regime",
    "ShapeDiagnostics",
    "TiltGrowth",
    "classify_orbit",
    "classify_regime",
    "continuous_axes",
    "diagnose",
    "fit_damped_oscillation",
    "local_minima",
    "out_of_plane_angle",
    "ray_radius",
    "recentered",
    "settled_orbit",
    "settled_periods",
    "summarize",
    "tilt_growth",
    "unresolved_change",
]

log = logging.getLogger(__name__)


def _unit_angles(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = d / np.linalg.norm(d, axis=0)
    return np.arctan2(np.hypot(d[0], d[1]), d[2]), np.arctan2(d[1], d[0])


#: Largest miss, relative to the radius, that :func:`ray_radius` accepts.
RAY_TOLERANCE = 1e-10


def ray_radius(
    shape: Shape, origin: np.ndarray, directions: np.ndarray, iterations: int = 30
) -> np.ndarray:
    """Distance from ``origin`` to the surface along unit ``directions`` (3, ...).

    Solves ``|o + s d| = r(direction of o + s d)`` by the secant method, started from the radius
    along ``d``; the origin must be inside the (star-shaped) surface.  Raises
    :class:`~vesicle.geometry.surface.ShapeError` if the secant steps do not meet the surface to
    :data:`RAY_TOLERANCE`.
    """
    o = np.asarray(origin, float).reshape(3, *([1] * (directions.ndim - 1)))
    c = shape.coefficients

    def g(s):
        p = o + s * directions
        th, ph = _unit_angles(p)
        return np.linalg.norm(p, axis=0) - evaluate(c, th, ph)

    s0 = evaluate(c, *_unit_angles(directions)) - np.sum(o * directions, axis=0)
    s1 = s0 * 1.001
    g0, g1 = g(s0), g(s1)
    for _ in range(iterations):
        denom = np.where(g1 != g0, g1 - g0, 1.0)
        s2 = np.where(g1 != g0, s1 - g1 * (s1 - s0) / denom, s1)
        s0, g0, s1 = s1, g1, s2
        g1 = g(s1)
        if np.max(np.abs(g1)) < 1e-14 * np.max(s1):
            break
    miss = np.max(np.abs(g1)) if np.all(np.isfinite(g1)) else np.inf
    if not miss <= RAY_TOLERANCE * np.max(np.abs(s1)):
        raise ShapeError(
            f"rays from {np.ravel(o).tolist()} did not meet the surface after {iterations} secant "
            f"steps (miss {miss:.1e}): the origin is outside, or the surface is not star-shaped "
            "from it"
        )
    return s1


def recentered(shape: Shape, origin: np.ndarray | None = None) -> Shape:
    """The same surface with its radius measured from ``origin`` (default: the volume centroid)."""
    origin = shape.centroid if origin is None else np.asarray(origin, float)
    e_r = shape.grid.unit_vectors[0]
    radius = ray_radius(shape, origin, e_r)
    c = transform(shape.grid.n_theta, shape.degree).analysis(radius)
    return Shape(c, shape.grid)


@dataclass(frozen=True)
class ShapeDiagnostics:
    """Geometry summary of one shape."""

    axes: np.ndarray  # (3, 3): row k = unit vector of axis k, lengths descending
    lengths: np.ndarray  # (3,) full lengths, descending
    psi: float
    D: float
    area: float
    volume: float
    reduced_volume: float
    bending_energy: float
    centroid: np.ndarray
    spectrum: np.ndarray


def diagnose(shape: Shape) -> ShapeDiagnostics:
    """Principal axes, inclination, deformation, area, volume, energy and spectrum of a shape."""
    c = shape.centroid
    _, vecs = np.linalg.eigh(shape.inertia_tensor(c))
    dirs = np.concatenate([vecs, -vecs], axis=1)  # (3, 6)
    radii = ray_radius(shape, c, dirs)
    lengths = radii[:3] + radii[3:]
    order = np.argsort(lengths)[::-1]
    axes, lengths = vecs[:, order].T.copy(), lengths[order]
    # orient each axis with a non-negative x component (then z) for a continuous psi
    for k in range(3):
        lead = axes[k, 0] if abs(axes[k, 0]) > 1e-12 else axes[k, 2]
        if lead < 0:
            axes[k] = -axes[k]
    in_plane = np.argsort(np.abs(axes[:, 1]))[:2]  # the two axes closest to the x-z plane
    i1, i2 = sorted(in_plane, key=lambda k: -lengths[k])
    a = axes[i1]
    psi = float(np.arctan2(a[2], a[0]))
    if psi <= -np.pi / 2:
        psi += np.pi
    elif psi > np.pi / 2:
        psi -= np.pi
    L1, L2 = lengths[i1], lengths[i2]
    return ShapeDiagnostics(
        axes=axes,
        lengths=lengths,
        psi=psi,
        D=float((L1 - L2) / (L1 + L2)),
        area=shape.area,
        volume=shape.volume,
        reduced_volume=shape.reduced_volume,
        bending_energy=shape.bending_energy(),
        centroid=c,
        spectrum=mode_energy(shape.coefficients),
    )


def local_minima(y: np.ndarray) -> np.ndarray:
    """Indices of the interior local minima of a series (the first of a flat pair)."""
    y = np.asarray(y, float)
    return np.nonzero((y[1:-1] < y[:-2]) & (y[1:-1] <= y[2:]))[0] + 1


def refined_minima(t: np.ndarray, y: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Times of the minima at ``indices`` of the series ``y(t)``: the minimum of the polynomial
    through the sample and its neighbours (two on each side where there are, else one: a
    quartic or a parabola), by Newton's method from the parabola's vertex.  For a smooth series
    the error falls as a high power of the spacing, against half the spacing for the sample
    time itself."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    out = []
    for i in np.asarray(indices, int):
        if i <= 0 or i >= t.size - 1:
            out.append(float(t[i]))
            continue
        width = 2 if 2 <= i <= t.size - 3 else 1
        ts, ys = t[i - width : i + width + 1], y[i - width : i + width + 1]
        scale = ts[-1] - ts[0]
        x = (ts - t[i]) / scale  # well conditioned
        c = np.polynomial.polynomial.polyfit(x, ys, 2 * width)
        d1, d2 = np.polynomial.polynomial.polyder(c), np.polynomial.polynomial.polyder(c, 2)
        p = np.polynomial.polynomial.polyfit(x[width - 1 : width + 2], ys[width - 1 : width + 2], 2)
        xm = -p[1] / (2.0 * p[2]) if p[2] > 0 else 0.0
        lo, hi = x[width - 1], x[width + 1]
        for _ in range(8):
            curvature = np.polynomial.polynomial.polyval(xm, d2)
            if curvature <= 0:
                break
            step = np.polynomial.polynomial.polyval(xm, d1) / curvature
            xm = float(np.clip(xm - step, lo, hi))
            if abs(step) < 1e-14:
                break
        out.append(float(t[i] + xm * scale))
    return np.array(out)


def half_turn_times(t: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Times at which a tumbling psi (wrapped to (-pi/2, pi/2]) passes -pi/2 (mod pi): where
    the unwrapped series crosses one of the levels -pi/2 + k pi, by linear interpolation
    between the two samples around each crossing.

    Every crossing counts, not only the samples' jumps of more than 0.75 pi that make a run
    TU (:func:`classify_regime`): a flip shorter than one save interval can show as a smaller
    jump, and a passage missed that way doubled one of the intervals whose mean is the period
    (v = 0.95, chi = 0.2, lam = 8, N = 8 saved every 2.0: one interval 253.36 among five of
    126.5-127.1, and the period read 152.17).  The unwrapping assumes that psi moves by less
    than pi/2 between saves (:func:`unresolved_change` says where it may not)."""
    t = np.asarray(t, float)
    unwrapped = 0.5 * np.unwrap(2.0 * np.asarray(psi, float))
    turn = np.floor((unwrapped + 0.5 * np.pi) / np.pi)  # which half turn each sample is in
    out = []
    for j in np.nonzero(np.diff(turn))[0]:
        a, b = unwrapped[j], unwrapped[j + 1]
        ks = np.arange(min(turn[j], turn[j + 1]) + 1, max(turn[j], turn[j + 1]) + 1)
        for k in ks if b > a else ks[::-1]:
            f = (-0.5 * np.pi + np.pi * k - a) / (b - a)
            out.append(t[j] + float(np.clip(f, 0.0, 1.0)) * (t[j + 1] - t[j]))
    return np.array(out)


#: Largest change of psi between consecutive saves, after taking out the half turns (psi is
#: wrapped to (-pi/2, pi/2]), beyond which the saves do not resolve the motion
#: (:func:`unresolved_change`).  A resolved TR or TU moves psi by a few hundredths of a radian
#: between saves.
UNRESOLVED_CHANGE = 0.25 * np.pi


def unresolved_change(psi: np.ndarray) -> float:
    """Largest change of ``psi`` between consecutive samples, each taken modulo a half turn
    (into [-pi/2, pi/2)): 0.03 where the saves resolve the motion, up to pi/2 where they do
    not.  A flip shorter than one save interval shows as a jump that is neither small nor a
    half turn: v = 0.95, chi = 0.2, lam = 7.7, N = 8 saved every 2.0 jumps by 1.65-2.03 rad,
    which :func:`classify_regime`'s 0.75 pi does not count as a half turn (its D falls to
    0.01-0.03 in the flip; docs/notes/dynamics-measurements.md)."""
    d = np.diff(np.asarray(psi, float))
    if d.size == 0:
        return 0.0
    return float(np.max(np.abs((d + 0.5 * np.pi) % np.pi - 0.5 * np.pi)))


def _with_resolution(regime: Regime, psi: np.ndarray) -> Regime:
    """``regime`` with a warning in its detail where the saves do not resolve psi's motion."""
    change = unresolved_change(psi)
    if change <= UNRESOLVED_CHANGE:
        return regime
    detail = (f"{regime.detail}; psi moves by up to {change:.2f} rad between saves (half "
              "turns taken out): the saves do not resolve that motion, so the regime is not "
              "decided by them (save more often)")  # fmt: skip
    return Regime(regime.name, regime.period, regime.minima, detail)


@dataclass(frozen=True)
class Regime:
    """Result of :func:`classify_regime`."""

    name: str  # "TT", "TR", "TU", "out-of-plane", "undetermined"
    period: float | None
    minima: np.ndarray  # times of the psi minima (TR) or of the half-turn jumps (TU)
    detail: str


def classify_regime(
    t: np.ndarray,
    psi: np.ndarray,
    axes: np.ndarray | None = None,
    tail: float = 0.5,
    steady_tol: float = 1e-3,
) -> Regime:
    """Classify a run from its inclination series (SPEC §10): see :func:`_classify`.  Where psi
    moves between two saves by more than :data:`UNRESOLVED_CHANGE` besides its half turns, the
    label stands and its detail says that the saves do not resolve the motion (a run at
    v = 0.95, chi = 0.2, lam = 7.55, N = 8 saved every 2.0 flips every 348 and read "TT,
    damped": the swings it compares are the flips, caught at other phases)."""
    regime = _classify(t, psi, axes, tail, steady_tol)
    if regime.name in ("TT", "TR", "TU"):
        t = np.asarray(t, float)
        last = t >= t[0] + (1 - tail) * (t[-1] - t[0])
        return _with_resolution(regime, np.asarray(psi, float)[last])
    return regime


def _classify(t, psi, axes, tail, steady_tol) -> Regime:
    """Classify a run from its inclination series (SPEC §10).

    TU when psi jumps by about pi (it runs through +-pi/2); out-of-plane when the longest axis
    leaves the x-z plane (|y component| > 0.1 over the last part); TT when psi varies by less
    than ``steady_tol`` over the last ``tail`` fraction of the run; TR when psi oscillates there
    with at least two minima and does not decay (its amplitude falling by less than 20 % over the
    tail, read from the swings between consecutive minima where the tail holds two or more, else
    from a fitted damped sinusoid; a damped oscillation is a TT approach).  The period is the
    mean time between consecutive minima of psi (TR, each refined by :func:`refined_minima`) or
    between the passages of psi through -pi/2 (TU, so a half turn; interpolated between the
    samples around each jump): accurate well below the save interval.
    """
    t, psi = np.asarray(t, float), np.asarray(psi, float)
    if t.size < 5:
        return Regime("undetermined", None, np.array([]), "fewer than 5 saved steps")
    last = t >= t[0] + (1 - tail) * (t[-1] - t[0])
    jumps = np.nonzero(np.abs(np.diff(psi)) > 0.75 * np.pi)[0]
    if axes is not None and np.median(np.abs(np.asarray(axes)[last, 0, 1])) > 0.1:
        return Regime("out-of-plane", None, np.array([]), "longest axis out of the x-z plane")
    if jumps.size:
        times = half_turn_times(t, psi)
        period = float(np.mean(np.diff(times))) if times.size > 1 else None
        detail = f"{jumps.size} half-turn jumps of psi"
        if times.size > jumps.size:  # passages whose flip fell between two saves
            detail = (f"{times.size} half turns of psi, {jumps.size} of them seen as jumps of "
                      "more than 0.75 pi")  # fmt: skip
        return Regime("TU", period, times, detail)
    p = psi[last]
    minima = local_minima(p)
    spread = float(np.ptp(p))
    if spread < steady_tol:
        return Regime("TT", None, np.array([]), f"psi steady to {spread:.1e} over the tail")
    if minima.size >= 2:
        # a decaying oscillation that settles is TT; a sustained one is TR: damped when the
        # amplitude falls by 20 % or more over the tail.  Its rate is read from the swings
        # (psi's range between consecutive minima) where the tail holds two or more, else from
        # a fitted damped sinusoid.  The swings come first: a TR swing of +-0.47 rad is far from
        # a sinusoid (v = 0.95, lam = 10.5, chi = 8, N = 8 on 24x48: swings 0.9471, 0.9483,
        # sustained, while the sinusoid's fit, off by 0.17 rms of its 0.50 amplitude, read a
        # decay x0.75 and called it TT)
        tl = t[last]
        tm = refined_minima(tl, p, minima)
        period = float(np.mean(np.diff(tm)))
        swings = [(0.5 * (a + b), float(np.ptp(p[(tl >= a) & (tl <= b)])))
                  for a, b in pairwise(tm)]  # fmt: skip
        try:
            if len(swings) >= 2 and swings[0][1] > 0:
                (t0, a0), (t1, a1) = swings[0], swings[-1]
                rate = np.log(a1 / a0) / (t1 - t0)  # per unit time, as a fit's omega_I
                decay = float(np.exp(rate * (tl[-1] - tl[0])))
            else:
                fit = fit_damped_oscillation(tl, p, t_min=tl[0])
                decay = float(np.exp(fit.omega_I * (tl[-1] - tl[0])))
        except ValueError:  # too few periods to fit: compare the first and last swings
            amp = [np.ptp(p[(tl >= a) & (tl <= b)]) for a, b in pairwise(tm)]
            where = "the tail"
            if len(amp) < 2 or amp[0] <= 0:  # of the whole run, then: a run stopped once its
                every = refined_minima(t, psi, local_minima(psi))  # periods settled may have
                amp = [np.ptp(psi[(t >= a) & (t <= b)]) for a, b in pairwise(every)]  # one
                where = "the run"  # swing in its last half
            if len(amp) < 2 or amp[0] <= 0:
                detail = "oscillation of psi, too few periods to tell damped from sustained"
                return Regime("undetermined", period, tm, detail + "; run longer")
            decay = amp[-1] / amp[0]
            if decay >= 0.8:
                detail = f"sustained oscillation of psi (x{decay:.2f} over {where})"
                return Regime("TR", period, tm, detail)
        if decay < 0.8:
            return Regime(
                "TT", period, tm, f"damped oscillation of psi (x{decay:.2f} over the tail)"
            )
        detail = f"sustained oscillation of psi (x{decay:.2f} over the tail)"
        return Regime("TR", period, tm, detail)
    return Regime("undetermined", None, np.array([]), "psi still drifting; run longer")


#: Relative spread of the trailing periods (and of their psi swings, TR) within which a run's
#: oscillation counts as settled on its limit cycle (:func:`settled_periods`).
SETTLE_TOL = 0.02


#: The smallest swing of psi over a TR period that counts as one (rad): the psi spread below
#: which :func:`classify_regime` calls a run TT.  Without it a TT run's drift-control sawtooth
#: (corrections every 1.0, swings of 1e-7 at N = 4, lam = 7.50, chi = 0.2) counted as periods.
MIN_SWING = 1e-3


def settled_periods(t: np.ndarray, psi: np.ndarray, tol: float = SETTLE_TOL) -> int:
    """How many of the last whole periods of psi (TR: between refined minima; TU: half turns)
    agree with each other: each period's length, and in TR the swing of psi over it, within
    ``tol`` of the mean of those periods.  A start-up transient (a TR oscillation still growing
    from a TT-like start, a tumbling that is still speeding up) is not counted, so a run stopped
    after ``n`` settled periods has ``n`` periods on its limit cycle to average over.  The count
    is 0 or at least 2: a single period has nothing to agree with."""
    t, psi = np.asarray(t, float), np.asarray(psi, float)
    if t.size < 5:
        return 0
    if np.any(np.abs(np.diff(psi)) > 0.75 * np.pi):
        marks = half_turn_times(t, psi)
        swings = None
    else:
        minima = local_minima(psi)
        marks = refined_minima(t, psi, minima)
        swings = [np.ptp(psi[(t >= a) & (t <= b)]) for a, b in pairwise(marks)]
    lengths = np.diff(marks)
    count = 0
    for k in range(2, lengths.size + 1):  # the last k periods (one alone proves nothing)
        tail = lengths[-k:]
        ok = np.ptp(tail) <= tol * np.mean(tail)
        if ok and swings is not None:
            sw = np.asarray(swings[-k:])
            ok = np.min(sw) > MIN_SWING and np.ptp(sw) <= tol * np.mean(sw)
        if not ok:
            break
        count = k
    return count


@dataclass(frozen=True)
class Orbit:
    """Result of :func:`classify_orbit`: the class of a three-dimensional orbit of the long axis."""

    name: str  # "in-plane", "vorticity-TT", "precession", "figure-8", "undetermined"
    period: float | None  # of the long axis's motion (one revolution or one loop)
    detail: str


def continuous_axes(axes: np.ndarray) -> np.ndarray:
    """Principal-axis vectors (t, 3, 3) with signs flipped so that each varies continuously."""
    out = np.array(axes, dtype=float)
    for i in range(1, out.shape[0]):
        dots = np.einsum("kj,kj->k", out[i], out[i - 1])
        out[i, dots < 0] *= -1.0
    return out


def _crossing_period(t: np.ndarray, x: np.ndarray) -> float | None:
    """Mean time between upward zero crossings of ``x`` (None with fewer than two)."""
    up = np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]
    if up.size < 2:
        return None
    times = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    return float(np.mean(np.diff(times)))


def classify_orbit(t: np.ndarray, axes: np.ndarray, tail: float = 0.5) -> Orbit:
    """Classify the motion of the long axis ``a(t)`` (the first of ``axes``, (t, 3, 3)) over the
    last ``tail`` of a run that left the shear plane (SPEC §13; the paper's Fig. 23, 24).

    - ``in-plane``: ``|a_y| < 0.05`` throughout (back in the shear plane: classify psi instead);
    - ``vorticity-TT``: ``|a_y| > 0.9`` and ``a`` nearly fixed (moves by less than 0.05);
    - ``precession``: the long axis circles the vorticity axis: its azimuth about y,
      ``atan2(a_z, a_x)``, turns through at least one full revolution while the angle from y
      stays within 0.3 rad of its mean; period = time per revolution;
    - ``figure-8``: the long axis stays on one side (``a_x`` keeps its sign, no revolution about
      y) while ``a_y`` and ``a_z`` both oscillate through zero, ``a_y`` at half the frequency of
      ``a_z`` (a figure-8 about x); period = that of ``a_y``;
    - otherwise ``undetermined`` (run longer).
    """
    t = np.asarray(t, float)
    if t.size < 5:
        return Orbit("undetermined", None, "fewer than 5 saved steps")
    a = continuous_axes(axes)[:, 0]
    last = t >= t[0] + (1.0 - tail) * (t[-1] - t[0])
    t, a = t[last], a[last]
    ay = np.abs(a[:, 1])
    if np.max(ay) < 0.05:
        return Orbit("in-plane", None, f"|a_y| <= {np.max(ay):.2g} over the tail")
    if np.min(ay) > 0.9 and np.max(np.ptp(a, axis=0)) < 0.05:
        return Orbit(
            "vorticity-TT", None, f"long axis along y, moving by {np.ptp(a, axis=0).max():.2g}"
        )
    azimuth = np.unwrap(np.arctan2(a[:, 2], a[:, 0]))
    turns = abs(azimuth[-1] - azimuth[0]) / (2.0 * np.pi)
    polar = np.arccos(np.clip(ay, 0.0, 1.0))
    if turns >= 1.0 and np.ptp(polar) < 0.6:
        period = float((t[-1] - t[0]) / turns)
        return Orbit("precession", period, f"{turns:.1f} revolutions about y, angle from y "
                     f"{np.mean(polar):.2f} +- {0.5 * np.ptp(polar):.2f} rad")  # fmt: skip
    x_side = np.all(a[:, 0] > 0) or np.all(a[:, 0] < 0)
    py, pz = _crossing_period(t, a[:, 1]), _crossing_period(t, a[:, 2])
    if x_side and py is not None and pz is not None and 1.5 < py / pz < 2.5:
        return Orbit("figure-8", py, f"a_y period {py:.3g}, a_z period {pz:.3g}")
    return Orbit("undetermined", None, f"{turns:.2f} revolutions about y; a_y, a_z periods "
                 f"{py}, {pz}: run longer")  # fmt: skip


#: How closely the last two windows of an orbit must agree (its period, and its size: the mean
#: angle of the long axis from y in a precession, the swing of ``a_y`` in a figure-8) for
#: :func:`settled_orbit` to call it settled: the same 2 % as :data:`SETTLE_TOL` for psi.
ORBIT_TOL = SETTLE_TOL

#: The orbit classes that :func:`settled_orbit` judges: the periodic ones out of the plane (an
#: in-plane orbit is judged by psi, :func:`settled_periods`; a vorticity-TT state is a steady
#: shape, which ``steady_tol`` stops).
PERIODIC_ORBITS = ("precession", "figure-8")


def _orbit_size(name: str, a: np.ndarray) -> float:
    """The size of an orbit of the long axis ``a`` (t, 3): a precession's mean angle from y, a
    figure-8's swing of ``a_y``."""
    if name == "precession":
        return float(np.mean(np.arccos(np.clip(np.abs(a[:, 1]), 0.0, 1.0))))
    return float(np.ptp(a[:, 1]))


def settled_orbit(t: np.ndarray, axes: np.ndarray, periods: int,
                  tol: float = ORBIT_TOL) -> Orbit | None:
    """The orbit of the long axis once it has settled, else None.

    Settled: the class over the last half of the run (:func:`classify_orbit`'s default, what a
    report states) is periodic (:data:`PERIODIC_ORBITS`) with period ``P``, and the last two
    windows of ``periods * P`` each (``periods`` >= 2: a figure-8 needs two crossings of
    ``a_y`` in a window) are of that class, their periods within ``tol`` of their mean, and so
    are their sizes (:func:`_orbit_size`).  A transient that drifts from one orbit to another
    changes period or size between the windows; one that has not left the start has no class.
    """
    if periods < 2:
        raise ValueError(f"periods must be at least 2, got {periods}")
    t = np.asarray(t, float)
    whole = classify_orbit(t, axes)
    if whole.name not in PERIODIC_ORBITS or not whole.period:
        return None
    window = periods * whole.period
    if t[-1] - t[0] < 2.0 * window:
        return None
    a = continuous_axes(axes)[:, 0]
    found = []
    for start, end in ((t[-1] - 2.0 * window, t[-1] - window), (t[-1] - window, t[-1] + 1.0)):
        inside = (t >= start) & (t <= end)
        if np.count_nonzero(inside) < 5:
            return None
        orbit = classify_orbit(t[inside], np.asarray(axes)[inside], tail=1.0)
        if orbit.name != whole.name or not orbit.period:
            return None
        found.append((orbit.period, _orbit_size(whole.name, a[inside])))
    (p1, s1), (p2, s2) = found
    if abs(p1 - p2) > tol * 0.5 * (p1 + p2) or abs(s1 - s2) > tol * 0.5 * (s1 + s2):
        return None
    return Orbit(whole.name, whole.period,
                 f"{whole.detail}; settled: the last two windows of {periods} periods agree "
                 f"(periods {p1:.4g}, {p2:.4g}; sizes {s1:.3g}, {s2:.3g}) within {tol:g}")


def out_of_plane_angle(axes: np.ndarray) -> np.ndarray:
    """Elevation (rad) of the long axis above the shear (x-z) plane at each saved step (``axes``:
    (t, 3, 3), the axis vectors in rows, the longest first): zero for a shape symmetric about the
    plane with its long axis in it (in-plane TT, TR, TU), the tilt of a start turned out of it
    about its short in-plane axis (SPEC §13), pi/2 on the vorticity-aligned branch.  The long
    axis, not the others: a nearly prolate vesicle's two shorter axes are ill-defined and spin
    about the long one while it tumbles.  ``atan2``, so that angles of 1e-8 are still right."""
    a = np.asarray(axes, dtype=float)[..., 0, :]
    return np.arctan2(np.abs(a[..., 1]), np.hypot(a[..., 0], a[..., 2]))


@dataclass(frozen=True)
class TiltGrowth:
    """Result of :func:`tilt_growth`: how the out-of-plane angle of a run grows or decays."""

    times: np.ndarray  # where the angle was sampled
    angles: np.ndarray  # the out-of-plane angle there (rad)
    rate: float | None  # d ln(angle) / dt, a least-squares line through ln(angles)
    per_half_turn: float | None  # exp(rate * the mean half-turn period): the factor per TU
    detail: str

    @property
    def small(self) -> bool:
        """Whether every sampled angle is below 0.2 rad, where a growth rate means something (a
        linear perturbation of an orbit in the plane) rather than a large orbit's swing."""
        return bool(self.angles.size) and float(np.max(self.angles)) < 0.2


def tilt_growth(t: np.ndarray, psi: np.ndarray, axes: np.ndarray) -> TiltGrowth:
    """Growth or decay of the out-of-plane angle (:func:`out_of_plane_angle`: the long axis's
    elevation above the shear plane) of a run started with a small tilt (SPEC §13: is the
    in-plane tumbling orbit stable against tilt?).

    In TU the angle is sampled once per half turn at the same phase (psi through -pi/2,
    :func:`half_turn_times`; the in-plane orbit repeats every half turn, so the samples see its
    Floquet growth, not the swing within a turn) and ``ln angle`` is fitted by a straight line in
    t: ``rate`` per unit time, ``per_half_turn`` the factor per half turn.  At least three half
    turns are needed; with fewer, or without tumbling, the line is fitted through every saved
    step of the last half and ``per_half_turn`` is None.  A run that never leaves the plane (angle
    below 1e-12 anywhere in the fitted samples), or with fewer than two samples, has ``rate``
    None, and ``detail`` says which.
    """
    t, psi = np.asarray(t, float), np.asarray(psi, float)
    angle = out_of_plane_angle(axes)
    times = half_turn_times(t, psi) if t.size >= 2 else np.array([])
    if times.size >= 3:
        samples = np.interp(times, t, angle)
        half = float(np.mean(np.diff(times)))
        how = f"sampled at {times.size} half turns (period {half:.4g})"
    else:
        last = t >= t[0] + 0.5 * (t[-1] - t[0]) if t.size else np.array([], bool)
        times, samples, half = t[last], angle[last], None
        how = f"fitted over the last half ({times.size} saved steps; fewer than 3 half turns)"
    if times.size < 2:
        return TiltGrowth(times, samples, None, None, how + ": too few to fit")
    if np.min(samples) < 1e-12:
        return TiltGrowth(times, samples, None, None, how + "; the angle is zero: in the plane")
    rate = float(np.polyfit(times - times[0], np.log(samples), 1)[0])
    factor = float(np.exp(rate * half)) if half is not None else None
    verdict = "grows" if rate > 0 else "decays"
    detail = f"the out-of-plane angle {verdict} at {rate:.3g} per unit time; {how}"
    if factor is not None:
        detail += f", x{factor:.4g} per half turn"
    growth = TiltGrowth(times, samples, rate, factor, detail)
    if not growth.small:
        growth = TiltGrowth(times, samples, rate, factor, detail + "; the angle reaches "
                            f"{np.max(samples):.2g} rad: not a small tilt")  # fmt: skip
    return growth


@dataclass(frozen=True)
class DampedOscillation:
    """``psi(t) = psi_inf + amplitude exp(omega_I t) cos(omega_R t + phase)``, fitted."""

    psi_inf: float
    amplitude: float
    omega_R: float
    omega_I: float
    phase: float
    rms_residual: float  # of the fit over the fitted window
    t_min: float

    @property
    def omega(self) -> tuple[float, float]:
        return self.omega_R, self.omega_I

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """The fitted ``psi(t)``."""
        t = np.asarray(t, float)
        return self.psi_inf + self.amplitude * np.exp(self.omega_I * t) * np.cos(
            self.omega_R * t + self.phase
        )


def fit_damped_oscillation(
    t: np.ndarray, psi: np.ndarray, t_min: float | None = None
) -> DampedOscillation:
    """Least-squares fit of a damped (or growing) oscillation to ``psi(t)`` for ``t >= t_min``.

    How a time-dependent run is compared with the linear stability of its steady state (SPEC
    §14): ``(omega_R, omega_I)`` of the fit against the most unstable eigenvalue.  The start
    values come from the series itself (the mean of its last part, the dominant frequency of its
    periodogram, the decay of its envelope); ``t_min`` (default: a fifth into the series) skips
    the start-up transient.  Raises ``ValueError`` when the window holds fewer than 1.5 periods
    or the fit does not converge.
    """
    from scipy.optimize import OptimizeWarning, curve_fit

    t, psi = np.asarray(t, float), np.asarray(psi, float)
    if t_min is None:
        t_min = t[0] + 0.2 * (t[-1] - t[0])
    keep = (t >= t_min) & np.isfinite(psi)
    tw, pw = t[keep], psi[keep]
    if tw.size < 16:
        raise ValueError(f"only {tw.size} saved steps after t = {t_min:g}; need at least 16")
    # start values: uniform resampling, periodogram peak, envelope decay
    tu = np.linspace(tw[0], tw[-1], tw.size)
    pu = np.interp(tu, tw, pw)
    mean = float(np.mean(pu[pu.size // 2 :]))
    spectrum = np.abs(np.fft.rfft((pu - mean) * np.hanning(pu.size)))
    freqs = np.fft.rfftfreq(pu.size, tu[1] - tu[0]) * 2.0 * np.pi
    k = int(np.argmax(spectrum[1:])) + 1
    omega_r = float(freqs[k])
    # the periodogram's bins are 2 pi / window wide, so this start value can be a bin low:
    # ask for 1.5 periods by it (two or more in fact, for the runs this is meant for)
    if omega_r * (tw[-1] - tw[0]) < 3.0 * np.pi:
        raise ValueError("the fitted window holds fewer than 1.5 periods; run longer")
    half = tw < tw[0] + 0.5 * (tw[-1] - tw[0])
    a0, a1 = np.ptp(pw[half]), np.ptp(pw[~half])
    span = 0.5 * (tw[-1] - tw[0])
    omega_i = float(np.log(max(a1, 1e-300) / max(a0, 1e-300)) / span) if a0 > 0 else 0.0

    def model(x, c, a, wi, wr, ph):
        return c + a * np.exp(wi * (x - tw[0])) * np.cos(wr * x + ph)

    best = None
    for phase in np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False):
        try:
            with warnings.catch_warnings():  # a singular covariance is no concern here
                warnings.simplefilter("ignore", OptimizeWarning)
                p, _ = curve_fit(
                    model, tw, pw, p0=[mean, 0.5 * a0, omega_i, omega_r, phase], maxfev=20000
                )
        except RuntimeError:
            continue
        rms = float(np.sqrt(np.mean((model(tw, *p) - pw) ** 2)))
        if best is None or rms < best[1]:
            best = (p, rms)
    if best is None:
        raise ValueError("the damped-oscillation fit did not converge")
    (c, a, wi, wr, ph), rms = best
    if wr < 0:  # cos is even: report omega_R > 0
        wr, ph = -wr, -ph
    if a < 0:
        a, ph = -a, ph + np.pi
    amplitude = float(a * np.exp(-wi * tw[0]))  # referred to t = 0
    return DampedOscillation(
        float(c), amplitude, float(wr), float(wi), float(np.mod(ph, 2 * np.pi)), rms, float(t_min)
    )


def summarize(run) -> dict:
    """Regime, period, final shape, stress averages and drift of a run (JSON-able).

    ``run`` is a :class:`vesicle.io.files.RunData` (anything with ``series``, ``checkpoint``,
    ``parameters`` and ``n_saved``).

    ``mean`` averages ``S_xz, N1, N2`` over whole periods (between the first and last psi
    minimum) when the run is periodic, else over the last quarter of the saved steps.
    ``drift`` is the relative change of area and volume from the first to the last saved step;
    ``corrections`` the total relative amounts the drift control removed.  ``oscillation``: when
    psi oscillates (a damped TT approach or TR), the fit of
    ``psi_inf + A exp(omega_I t) cos(omega_R t + phase)`` from the second psi minimum on
    (:func:`vesicle.geometry.diagnostics.fit_damped_oscillation`), else ``None``.
    ``out_of_plane``: the
    long axis's elevation above the shear plane at the first and last saved steps and its
    growth rate (:func:`vesicle.geometry.diagnostics.tilt_growth`; per half turn in TU).
    """
    s = run.series
    t = s["t"]
    regime = classify_regime(t, s["psi"], s["axes"])
    stopped = (run.checkpoint or {}).get("stopped", "")
    if stopped == "steady" and regime.name in ("undetermined", "TR"):  # it reached steady_tol
        regime = Regime("TT", regime.period, regime.minima,
                        "stopped at a steady state (max |dr/dt| below steady_tol); "
                        f"psi over the tail: {regime.detail}")  # fmt: skip
    if regime.minima.size >= 2:
        window = (t >= regime.minima[0]) & (t <= regime.minima[-1])
    else:
        window = t >= t[0] + 0.75 * (t[-1] - t[0])

    def mean(name):
        y, x = s[name][window], t[window]
        if np.all(np.isnan(y)):
            return None
        return float(np.trapezoid(y, x) / (x[-1] - x[0])) if x.size > 1 else float(y[-1])

    ck = run.checkpoint or {}
    corrections = ck.get("corrections", {})
    oscillation = None
    if regime.name in ("TT", "TR") and regime.minima.size >= 2:
        minima = local_minima(s["psi"])
        try:  # from the second minimum of the whole series: past the start-up transient
            t_min = float(t[minima[min(1, minima.size - 1)]])
            fit = fit_damped_oscillation(t, s["psi"], t_min=t_min)
            oscillation = {
                "omega_R": fit.omega_R,
                "omega_I": fit.omega_I,
                "psi_inf": fit.psi_inf,
                "amplitude": fit.amplitude,
                "rms_residual": fit.rms_residual,
                "t_min": fit.t_min,
            }
        except ValueError as err:
            log.info("no damped-oscillation fit: %s", err)
    tilt = tilt_growth(t, s["psi"], s["axes"])
    out_of_plane = {
        "angle_start": float(out_of_plane_angle(s["axes"][:1])[0]),
        "angle_end": float(out_of_plane_angle(s["axes"][-1:])[0]),
        "rate": tilt.rate,
        "per_half_turn": tilt.per_half_turn,
        "detail": tilt.detail,
    }
    orbit = None
    if regime.name == "out-of-plane":  # the class of the long axis's 3-D orbit (SPEC §13)
        o = classify_orbit(t, s["axes"])
        orbit = {"class": o.name, "period": o.period, "detail": o.detail}
    return {
        "regime": regime.name,
        "regime_detail": regime.detail,
        "stopped": stopped,
        "period": regime.period,
        "orbit": orbit,
        "out_of_plane": out_of_plane,
        "t_final": float(t[-1]),
        "saved_steps": run.n_saved,
        "steps": ck.get("steps"),
        "rejected_steps": ck.get("rejected"),
        "solves": ck.get("solves"),
        "final": {
            "psi": float(s["psi"][-1]),
            "D": float(s["D"][-1]),
            "axes": s["L"][-1].tolist(),
            "bending_energy": float(s["bending_energy"][-1]),
            "reduced_volume": float(s["reduced_volume"][-1]),
        },
        "mean": {k: mean(k) for k in ("S_xz", "N1", "N2")},
        "oscillation": oscillation,
        "drift": {
            "area": float(s["area"][-1] / s["area"][0] - 1.0),
            "volume": float(s["volume"][-1] / s["volume"][0] - 1.0),
        },
        "corrections": {
            "area": corrections.get("area"),
            "volume": corrections.get("volume"),
            "recentered": corrections.get("recentered"),
        },
        "parameters": run.parameters,
    }
