"""classify_orbit: the classes of three-dimensional long-axis orbits (SPEC §13), on synthetic
trajectories whose class is known by construction."""

import numpy as np
import pytest

from vesicle.geometry.diagnostics import classify_orbit


def _frames(long_axis: np.ndarray) -> np.ndarray:
    """Orthonormal frames (t, 3, 3) whose first row is the given (normalised) long axis."""
    a = long_axis / np.linalg.norm(long_axis, axis=1)[:, None]
    helper = np.where(np.abs(a[:, [1]]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    b = np.cross(a, helper)
    b /= np.linalg.norm(b, axis=1)[:, None]
    return np.stack([a, b, np.cross(a, b)], axis=1)


T = np.linspace(0.0, 40.0, 2001)


def test_precession_about_the_vorticity_axis():
    """The long axis on a cone of half-angle 0.6 rad about y, one revolution per 5 time units;
    the sign flips of an eigenvector solver are undone first (every other row negated)."""
    cone = np.stack([np.sin(0.6) * np.cos(2 * np.pi * T / 5), np.full_like(T, np.cos(0.6)),
                     np.sin(0.6) * np.sin(2 * np.pi * T / 5)], axis=1)  # fmt: skip
    frames = _frames(cone)
    frames[::2] *= -1.0
    o = classify_orbit(T, frames)
    assert o.name == "precession" and o.period == pytest.approx(5.0, rel=1e-3)


def test_figure_8_about_x():
    """a = (1, 0.3 sin(w t / 2), 0.3 sin(w t)): a_y at half the frequency of a_z."""
    w = 2 * np.pi / 3.0
    a = np.stack([np.ones_like(T), 0.3 * np.sin(0.5 * w * T), 0.3 * np.sin(w * T)], axis=1)
    o = classify_orbit(T, _frames(a))
    assert o.name == "figure-8" and o.period == pytest.approx(6.0, rel=1e-2)


def test_vorticity_tt_and_in_plane():
    still = np.tile([[0.01, 1.0, 0.0]], (T.size, 1))
    assert classify_orbit(T, _frames(still)).name == "vorticity-TT"
    flat = np.stack([np.cos(0.3 * T), np.zeros_like(T), np.sin(0.3 * T)], axis=1)
    assert classify_orbit(T, _frames(flat)).name == "in-plane"
    assert classify_orbit(T[:3], _frames(flat[:3])).name == "undetermined"


def _tumbling_tilted(t: np.ndarray, period: float, tilt: np.ndarray):
    """A frame tumbling in the x-z plane (half-turn period ``period``) and turned out of it by
    the angle ``tilt(t)`` about its short axis: then the long axis's elevation above the plane,
    the out-of-plane angle, is ``tilt`` exactly.
    Returns (psi wrapped to (-pi/2, pi/2], frames (t, 3, 3))."""
    phi = 0.3 - np.pi * t / period  # angle of the long axis from x in the x-z plane
    c, s = np.cos(tilt), np.sin(tilt)
    long_in = np.stack([np.cos(phi), np.zeros_like(t), np.sin(phi)], axis=1)
    y = np.tile([0.0, 1.0, 0.0], (t.size, 1))
    short = np.cross(long_in, y)
    frames = np.stack([c[:, None] * long_in + s[:, None] * y,
                       -s[:, None] * long_in + c[:, None] * y, short], axis=1)  # fmt: skip
    psi = np.arctan(np.tan(phi))  # the x-z inclination, wrapped
    return psi, frames


def test_tilt_growth_of_a_tumbling_orbit():
    """Expected numbers by construction: the angle is 1e-3 exp(sigma t) times a factor that
    repeats every half turn, so sampling once per half turn sees sigma exactly (a straight line
    through every saved step would not: the factor swings by +-50 % within each turn)."""
    from vesicle.geometry.diagnostics import out_of_plane_angle, tilt_growth

    t = np.linspace(0.0, 30.0, 6001)
    period, sigma = 3.0, -0.05
    tilt = 1e-3 * np.exp(sigma * t) * (1.0 + 0.5 * np.sin(2 * np.pi * t / period + 0.4))
    psi, frames = _tumbling_tilted(t, period, tilt)
    frames[1::2, 1] *= -1.0  # eigenvector signs are arbitrary
    assert out_of_plane_angle(frames) == pytest.approx(tilt, rel=1e-9, abs=1e-15)
    g = tilt_growth(t, psi, frames)
    # phi passes -pi/2 - k pi at t = (0.3 + pi/2 + k pi) period / pi: 1.786, 4.786, ..., 28.786
    assert g.times == pytest.approx((0.3 + np.pi / 2) * period / np.pi + period * np.arange(10))
    assert g.rate == pytest.approx(sigma, rel=1e-4)
    assert g.per_half_turn == pytest.approx(np.exp(sigma * period), rel=1e-4)
    assert "decays" in g.detail
    grow = tilt_growth(t, psi, _tumbling_tilted(t, period, 1e-3 * np.exp(0.02 * t))[1])
    assert grow.rate == pytest.approx(0.02, rel=1e-4) and "grows" in grow.detail


def test_tilt_growth_in_the_plane_and_without_tumbling():
    from vesicle.geometry.diagnostics import tilt_growth

    t = np.linspace(0.0, 30.0, 3001)
    psi, frames = _tumbling_tilted(t, 3.0, np.zeros_like(t))
    flat = tilt_growth(t, psi, frames)
    assert flat.rate is None and "in the plane" in flat.detail
    # no tumbling (psi steady): a line through the last half of the saved steps
    still = np.full_like(t, 0.3)
    frames = np.stack([_tumbling_tilted(t[:1], 3.0, np.array([1e-2 * np.exp(-0.1 * x)]))[1][0]
                       for x in t])  # fmt: skip
    g = tilt_growth(t, still, frames)
    assert g.per_half_turn is None and g.rate == pytest.approx(-0.1, rel=1e-6)
    assert "last half" in g.detail
    one = tilt_growth(t[:1], still[:1], frames[:1])
    assert one.rate is None and "too few" in one.detail


def test_tilt_growth_says_when_the_angle_is_not_small():
    """A precession at 0.6 rad from y (elevation pi/2 - 0.6) is an orbit, not a small tilt."""
    from vesicle.geometry.diagnostics import tilt_growth

    cone = np.stack([np.sin(0.6) * np.cos(2 * np.pi * T / 5), np.full_like(T, np.cos(0.6)),
                     np.sin(0.6) * np.sin(2 * np.pi * T / 5)], axis=1)  # fmt: skip
    g = tilt_growth(T, np.zeros_like(T), _frames(cone))
    assert not g.small and "not a small tilt" in g.detail
    assert g.angles == pytest.approx(np.pi / 2 - 0.6, rel=1e-9)


def _cone(t: np.ndarray, half_angle, period) -> np.ndarray:
    """The long axis on a cone about y of the given half-angle (a number or an array over t),
    turning about y with ``period``."""
    phase = 2 * np.pi * t / period
    half_angle = np.broadcast_to(half_angle, t.shape)
    return np.stack([np.sin(half_angle) * np.cos(phase), np.cos(half_angle),
                     np.sin(half_angle) * np.sin(phase)], axis=1)  # fmt: skip


def test_settled_orbit_stops_a_settled_precession_only():
    """settled_orbit: two windows of 2 periods (10 time units each) at the end of the run must
    agree in period and size within 2 %.  By construction: a constant cone has settled; a cone
    shrinking as 0.6 + 0.3 exp(-t / 20) has window means 0.6 + 0.3 * (mean of exp over [20, 30]
    and [30, 40]) = 0.686 and 0.652, 5 % apart, so it has not; a run of 15 holds no two windows
    of 10."""
    from vesicle.geometry.diagnostics import settled_orbit

    settled = settled_orbit(T, _frames(_cone(T, 0.6, 5.0)), 2)
    assert settled is not None and settled.name == "precession"
    assert settled.period == pytest.approx(5.0, rel=1e-3)
    assert "settled" in settled.detail
    shrinking = _cone(T, 0.6 + 0.3 * np.exp(-T / 20.0), 5.0)
    assert classify_orbit(T, _frames(shrinking)).name == "precession"  # a class, but moving
    assert settled_orbit(T, _frames(shrinking), 2) is None
    short = T <= 15.0
    assert settled_orbit(T[short], _frames(_cone(T[short], 0.6, 5.0)), 2) is None
    with pytest.raises(ValueError, match="at least 2"):
        settled_orbit(T, _frames(_cone(T, 0.6, 5.0)), 1)


def test_settled_orbit_sees_a_drifting_period_and_other_classes():
    """A precession whose period lengthens from 5 to 6 over the run (the phase integral of
    1 / P(t) with P linear in t) has windows' periods about 5.6 and 5.9 (5 % apart): not settled.
    A figure-8 with constant amplitude has settled; a vorticity-TT state and an in-plane
    tumbling are not judged (steady_tol and settled_periods stop those)."""
    from vesicle.geometry.diagnostics import settled_orbit

    rate = 1.0 / (5.0 + T / 40.0)  # revolutions per time unit, P from 5 to 6
    phase = 2 * np.pi * np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1])
                                                         * np.diff(T))])  # fmt: skip
    drifting = np.stack([np.sin(0.6) * np.cos(phase), np.full_like(T, np.cos(0.6)),
                         np.sin(0.6) * np.sin(phase)], axis=1)  # fmt: skip
    assert classify_orbit(T, _frames(drifting)).name == "precession"
    assert settled_orbit(T, _frames(drifting), 2) is None
    w = 2 * np.pi / 3.0
    eight = np.stack([np.ones_like(T), 0.3 * np.sin(0.5 * w * T), 0.3 * np.sin(w * T)], axis=1)
    settled = settled_orbit(T, _frames(eight), 2)
    assert settled is not None and settled.name == "figure-8"
    still = np.tile([[0.01, 1.0, 0.0]], (T.size, 1))
    flat = np.stack([np.cos(0.3 * T), np.zeros_like(T), np.sin(0.3 * T)], axis=1)
    assert settled_orbit(T, _frames(still), 2) is None
    assert settled_orbit(T, _frames(flat), 2) is None


def test_a_run_stops_on_its_settled_orbit():
    """The time stepping's stop criterion (``orbits``) on a run's saved series: "orbit" once
    the precession has settled, "" while it has not or when the criterion is off."""
    from types import SimpleNamespace

    from vesicle.dynamics.integrators import RunParameters
    from vesicle.dynamics.simulation import _should_stop
    from vesicle.model.parameters import Discretisation, Physics

    def run(axis):
        return SimpleNamespace(n_saved=T.size - 1, series={"t": T, "axes": _frames(axis),
                                                           "psi": np.zeros_like(T)})  # fmt: skip

    on = RunParameters(Physics(), Discretisation(), steady_tol=0.0, orbits=2)
    off = on.replace(orbits=0)
    assert _should_stop(on, run(_cone(T, 0.6, 5.0)), None) == "orbit"
    assert _should_stop(on, run(_cone(T, 0.6 + 0.3 * np.exp(-T / 20.0), 5.0)), None) == ""
    assert _should_stop(off, run(_cone(T, 0.6, 5.0)), None) == ""
    with pytest.raises(ValueError, match="orbits must be 0"):
        on.replace(orbits=1)
