"""classify_orbit: the classes of three-dimensional long-axis orbits (SPEC §13), on synthetic
trajectories whose class is known by construction."""

import numpy as np
import pytest

from vesicle.analysis import classify_orbit


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
