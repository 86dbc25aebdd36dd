"""The pseudo-arclength core on model folds with known answers (SPEC §16)."""

from __future__ import annotations

import numpy as np
import pytest

from vesicle.bifurcation.continuation import ArclengthPoint, arclength_step, corrector, tangent


def _circle(y, p):  # G = y0^2 + y1^2/4 + p^2 - 1: folds in p at p = +-1 (y = 0)
    G = np.array([y[0] ** 2 + 0.25 * y[1] ** 2 + p**2 - 1.0, y[1] - 0.5 * y[0] * p])
    return G, float(np.max(np.abs(G))), None


def _jacobian(z, _data):
    y0, y1, p = z
    G_y = np.array([[2 * y0, 0.5 * y1], [-0.5 * p, 1.0]])
    G_p = np.array([2 * p, -0.5 * y0])
    return G_y, G_p, None


def test_tangent_is_the_null_direction_and_keeps_its_orientation():
    G_y, G_p = np.array([[1.2]]), np.array([1.6])
    t = tangent(G_y, G_p, previous=np.array([-1.0, 1.0]))
    np.testing.assert_allclose(t, [-0.8, 0.6], atol=1e-14)
    np.testing.assert_allclose(tangent(G_y, G_p, previous=-t), [0.8, -0.6], atol=1e-14)


def test_corrector_lands_on_the_branch_from_a_predictor():
    z0 = np.array([0.6, 0.0, 0.8])
    z0[1] = 0.5 * z0[0] * z0[2] / (1.0)  # y1 from the second equation (approximately)
    G_y, G_p, _ = _jacobian(z0, None)
    t = tangent(G_y, G_p)
    c = corrector(_circle, G_y, G_p, z0 + 0.05 * t, t, tolerance=1e-12)
    assert c.converged and np.max(np.abs(_circle(c.z[:-1], c.z[-1])[0])) < 1e-12


def test_arclength_passes_the_fold_and_finds_it():
    """Along the closed curve from p = 0 upwards: p rises to its maximum 1 (the fold, where
    G_y is singular and natural continuation in p must fail) and falls again; the tangent's
    p component changes sign there, and a secant on it locates p = 1 to 1e-8."""
    y = np.array([1.0, 0.0])
    G_y, G_p, _ = _jacobian(np.append(y, 0.0), None)
    t = tangent(G_y, G_p, previous=np.array([0.0, 0.0, 1.0]))
    point = ArclengthPoint(np.append(y, 0.0), t, G_y, G_p, 0.2, None)
    points = [point]
    for _ in range(12):
        point = arclength_step(_circle, _jacobian, point, 0.2, 1e-12, 1e-6)
        points.append(point)
    p = np.array([q.z[-1] for q in points])
    t_p = np.array([q.tangent[-1] for q in points])
    k = int(np.flatnonzero(np.diff(np.sign(t_p)))[0])  # the fold lies between k and k + 1
    assert p[k + 1] < 1.0 and p.max() < 1.0 + 1e-12 and p[-1] < p[k]  # turned back

    def tp_at(s):  # the branch point at arclength s from point k
        q = arclength_step(_circle, _jacobian, points[k], s, 1e-13, 1e-9)
        return q.tangent[-1], q.z[-1]

    s0, s1 = 0.0, points[k + 1].ds
    f0, f1 = points[k].tangent[-1], points[k + 1].tangent[-1]
    for _ in range(30):
        s2 = s1 - f1 * (s1 - s0) / (f1 - f0)
        f2, p_fold = tp_at(s2)
        s0, f0, s1, f1 = s1, f1, s2, f2
        if abs(f2) < 1e-12:
            break
    assert p_fold == pytest.approx(1.0, abs=1e-8)


def test_corrector_reports_failure_instead_of_accepting_it():
    G_y, G_p, _ = _jacobian(np.array([1.0, 0.0, 0.0]), None)
    t = tangent(G_y, G_p)
    c = corrector(_circle, G_y, G_p, np.array([5.0, 5.0, 5.0]), t, 1e-12, max_iterations=3)
    assert not c.converged
