"""Fold and Hopf curves and their codim-2 points on normal forms with exact answers (issue 40).

Every problem is a normal form ``f`` seen through a fixed random orthogonal change of
coordinates, ``G(u, p) = Q f(Q^T u, p)`` (block-diagonal ``Q`` for the DAE so that ``B`` keeps
its form), with stable components coupled to it, so that the Jacobians are dense while the
curves stay known exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vesicle.bifurcation import codim2
from vesicle.bifurcation.codim2 import (
    Curve,
    Problem,
    Settings,
    fd_jacobian_action_derivative,
    fd_parameter_derivative,
    finite_eigenvalues,
    fold_curve,
    hopf_curve,
    locate_bt,
    locate_fold,
    locate_hopf,
)

EXACT = 1e-8
BOX = [[-5.0, 5.0], [-1.05, 0.6]]


def _orthogonal(n: int, seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((n, n)))
    return q * np.sign(np.diag(r))


class Mixed(Problem):
    """``G(u, p) = Q f(Q^T u, p)``; subclasses give ``f`` and its Jacobian ``jac``."""

    n = 3

    def __init__(self, seed: int, mixed: int | None = None):
        m = self.n if mixed is None else mixed
        self.Q = np.eye(self.n)
        self.Q[:m, :m] = _orthogonal(m, seed)

    def to_u(self, x):
        return self.Q @ np.asarray(x, dtype=float)

    def to_x(self, u):
        return self.Q.T @ np.asarray(u)

    def xs(self, curve: Curve) -> np.ndarray:
        return curve.x @ self.Q

    def residual(self, u, p):
        return self.Q @ self.f(self.to_x(u), p)

    def jacobian(self, u, p):
        return self.Q @ self.jac(self.to_x(u), p) @ self.Q.T


class SaddleNode(Mixed):
    """Reduced to ``p0 - shift(p1) + (1 + sin(p1)/2) x0^2 + 0.15 x0^3``: fold curve ``x = 0,
    p0 = shift(p1)``, with ``shift = 0`` (the saddle-node normal form's ``p0 = 0``)."""

    def __init__(self, seed=3):
        super().__init__(seed)

    def shift(self, p1):
        return 0.0 * p1

    def f(self, x, p):
        c = 1 + 0.5 * np.sin(p[1])
        return np.array(
            [
                p[0] - self.shift(p[1]) + c * x[0] ** 2 + 0.3 * x[0] * x[1],
                -x[1] + 0.5 * x[0] ** 2,
                -2 * x[2] + x[0] * x[1] + p[1] * x[1],
            ]
        )

    def jac(self, x, p):
        c = 1 + 0.5 * np.sin(p[1])
        return np.array(
            [
                [2 * c * x[0] + 0.3 * x[1], 0.3 * x[0], 0],
                [x[0], -1, 0],
                [x[1], x[0] + p[1], -2.0],
            ]
        )


class HookedSaddleNode(SaddleNode):
    """With ``shift = 0.3 sin(p1)`` (a curved fold line) and analytic ``F_p``, ``F_xz(q, d)``."""

    def shift(self, p1):
        return 0.3 * np.sin(p1)

    def parameter_derivative(self, u, p):
        x = self.to_x(u)
        fp1 = 0.5 * np.cos(p[1]) * x[0] ** 2 - 0.3 * np.cos(p[1])
        fp = np.array([[1.0, fp1], [0, 0], [0, x[1]]])
        return self.Q @ fp

    def jacobian_action_derivative(self, u, p, q, direction):
        n = self.n
        dx, dp = self.to_x(direction[:n]), direction[n:]
        x = self.to_x(u)
        c, dc = 1 + 0.5 * np.sin(p[1]), 0.5 * np.cos(p[1]) * dp[1]
        dJ = np.array(
            [
                [2 * c * dx[0] + 2 * dc * x[0] + 0.3 * dx[1], 0.3 * dx[0], 0],
                [dx[0], 0, 0],
                [dx[1], dx[0] + dp[1], 0],
            ]
        )
        return self.Q @ dJ @ self.Q.T @ q


class Cusp(Mixed):
    """``p0 + p1 x0 - x0^3`` driving stable ``x1, x2``: fold curve ``p1 = 3 x0^2,
    p0 = -2 x0^3``, i.e. ``p0 = -+2 (p1/3)^(3/2)``, cusp at the origin."""

    def __init__(self, seed=2):
        super().__init__(seed)

    def f(self, x, p):
        return np.array(
            [
                p[0] + p[1] * x[0] - x[0] ** 3,
                -x[1] + x[0] ** 2 * p[1],
                -3 * x[2] + x[0] * x[1] + np.sin(x[0]),
            ]
        )

    def jac(self, x, p):
        return np.array(
            [
                [p[1] - 3 * x[0] ** 2, 0, 0],
                [2 * x[0] * p[1], -1, 0],
                [x[1] + np.cos(x[0]), x[0], -3.0],
            ]
        )


class Turn(Mixed):
    """``p0 + p1^2 + x0^2`` driving stable ``x1, x2``: fold curve ``x0 = 0, p0 = -p1^2``, a
    smooth curve whose ``p0`` has its maximum at the origin: a turn, not a cusp (the cusp
    coefficient is 1 all along)."""

    def __init__(self, seed=5):
        super().__init__(seed)

    def f(self, x, p):
        return np.array(
            [
                p[0] + p[1] ** 2 + x[0] ** 2,
                -x[1] + x[0] * p[1],
                -2 * x[2] + x[0] * x[1],
            ]
        )

    def jac(self, x, p):
        return np.array(
            [
                [2 * x[0], 0, 0],
                [p[1], -1, 0],
                [x[1], x[0], -2.0],
            ]
        )


class BogdanovTakens(Mixed):
    """``x0' = x1, x1' = b0 + b1 x0 + x0^2 + s x0 x1 + e b1^2 x1`` and a stable ``x2``.

    Fold curve ``b0 = b1^2 / 4`` (``x0 = -b1/2``, other eigenvalue ``s x0 + e b1^2``); BT at
    the origin; for ``e = 0`` the Hopf curve is ``b0 = 0, b1 < 0`` with ``omega^2 = -b1``.
    """

    def __init__(self, s=-1.0, seed=1, e=0.0):
        super().__init__(seed)
        self.s, self.e = s, e

    def f(self, x, p):
        return np.array(
            [
                x[1],
                p[0] + p[1] * x[0] + x[0] ** 2 + self.s * x[0] * x[1] + self.e * p[1] ** 2 * x[1],
                -x[2] + x[0] * x[1] + x[0] ** 2,
            ]
        )

    def jac(self, x, p):
        s, e = self.s, self.e
        return np.array(
            [
                [0, 1, 0],
                [p[1] + 2 * x[0] + s * x[1], s * x[0] + e * p[1] ** 2, 0],
                [x[1] + 2 * x[0], x[0], -1.0],
            ]
        )


class ConstrainedBogdanovTakens(Mixed):
    """The BT normal form as an index-2 DAE: states ``x0..x3``, a multiplier ``x4``.

    ``c = x3 - x0^2/2 - x2/5 = 0`` is the constraint row (``B = diag(1, 1, 1, 1, 0)``), ``x4``
    enters ``x3'`` as a Lagrange multiplier, and ``c`` couples into the other rows (a
    coupling that vanishes on the constraint): the finite spectrum and the curves are those of
    :class:`BogdanovTakens`; ``x3 = 0.7 x0^2``, ``x4 = x3 - 0.4 x0`` on equilibria.
    """

    n = 5
    mass = np.diag([1.0, 1.0, 1.0, 1.0, 0.0])

    def __init__(self, s=-1.0, seed=5):
        super().__init__(seed, mixed=4)
        self.s = s

    def f(self, x, p):
        c = x[3] - 0.5 * x[0] ** 2 - 0.2 * x[2]
        return np.array(
            [
                x[1] + 0.3 * c,
                p[0] + p[1] * x[0] + x[0] ** 2 + self.s * x[0] * x[1] - 0.7 * c,
                -x[2] + x[0] * x[1] + x[0] ** 2 + 0.5 * c,
                -x[3] + 0.4 * x[0] + x[4],
                c,
            ]
        )

    def jac(self, x, p):
        s = self.s
        cx = np.array([-x[0], 0, -0.2, 1, 0])
        J = np.array(
            [
                [0, 1, 0, 0, 0],
                [p[1] + 2 * x[0] + s * x[1], s * x[0], 0, 0, 0],
                [x[1] + 2 * x[0], x[0], -1, 0, 0],
                [0.4, 0, 0, -1, 1],
                [0, 0, 0, 0, 0],
            ],
            dtype=float,
        )
        J[0] += 0.3 * cx
        J[1] -= 0.7 * cx
        J[2] += 0.5 * cx
        J[4] = cx
        return J


class HopfNormalForm(Mixed):
    """``z' = (p0 + i w(p1)) z - |z|^2 z`` about the centre ``(sin(p1)/2, 0)``, a stable
    ``x2`` and a second pair ``x3 + i x4`` with real part ``re(p1)`` and frequency 2.

    Hopf curve ``p0 = 0`` with ``omega = w(p1) = 1 + p1^2/5``.  ``spurious``: ``re = p1 - 1``,
    so the second pair is unstable exactly where ``p1 > 1``; otherwise ``re = -1``.
    """

    n = 5

    def __init__(self, spurious=False, seed=4):
        super().__init__(seed)
        self.spurious = spurious

    @staticmethod
    def w(p1):
        return 1 + 0.2 * p1**2

    @staticmethod
    def centre(p1):
        return 0.5 * np.sin(p1)

    def re(self, p1):
        return p1 - 1 if self.spurious else -1.0

    def f(self, x, p):
        U, V = x[0] - self.centre(p[1]), x[1]
        r2, w, a = U * U + V * V, self.w(p[1]), self.re(p[1])
        return np.array(
            [
                p[0] * U - w * V - r2 * U,
                w * U + p[0] * V - r2 * V,
                -x[2] + U * U + x[3] * V,
                a * x[3] - 2 * x[4] + U * V,
                2 * x[3] + a * x[4],
            ]
        )

    def jac(self, x, p):
        U, V = x[0] - self.centre(p[1]), x[1]
        r2, w, a = U * U + V * V, self.w(p[1]), self.re(p[1])
        return np.array(
            [
                [p[0] - r2 - 2 * U * U, -w - 2 * U * V, 0, 0, 0],
                [w - 2 * U * V, p[0] - r2 - 2 * V * V, 0, 0, 0],
                [2 * U, x[3], -1, V, 0],
                [V, U, 0, a, -2],
                [0, 0, 0, 2, a],
            ]
        )


def _fold_at(problem, b1=-1.0):
    """A fold point of the BT problems, from a perturbed point of the branch in ``b0``."""
    x0 = [0.45, 0.02, 0.2, 0.1, 0.0][: problem.n]
    point = locate_fold(problem, problem.to_u(x0), [0.27, b1], free=0)
    assert point.converged
    return point


def _hopf_at(problem, b1=-1.0):
    point = locate_hopf(problem, problem.to_u([0.01, 0.01, 0, 0, 0][: problem.n]), [0.01, b1])
    assert point.converged
    return point


def _check_bt_fold(problem, curve):
    x, p = problem.xs(curve), curve.p
    assert np.all(np.abs(p[:, 0] - p[:, 1] ** 2 / 4) < EXACT)
    assert np.all(np.abs(x[:, 0] + p[:, 1] / 2) < EXACT)
    assert np.all(np.abs(x[:, 1]) < EXACT)


def _check_bt_hopf(problem, curve):
    x, p = problem.xs(curve), curve.p
    assert np.all(np.abs(p[:, 0]) < EXACT)
    assert np.all(np.abs(x[:, :2]) < EXACT)
    assert np.all(np.abs(curve.omega**2 + p[:, 1]) < EXACT)
    assert np.all(curve.omega[1:] > 0)


def _check_bt_point(problem, special):
    assert special.kind == "bt" and special.located
    assert special.residual < 1e-10 and abs(special.test) < 1e-10
    assert np.all(np.abs(special.point.p) < EXACT)
    assert np.all(np.abs(problem.to_x(special.point.x)) < EXACT)


# ---------------------------------------------------------------------------------------------


class Smooth(Problem):
    """Non-polynomial, written with complex-safe functions for complex-step references."""

    def residual(self, x, p):
        return np.array(
            [
                np.sin(x[0] * x[1]) + p[0] * np.exp(x[2]),
                np.cos(x[0]) * x[2] ** 2 + p[1] * x[1] + p[0] * p[1] ** 2,
                np.exp(0.3 * x[0] * x[2]) - p[1] * x[0] ** 3,
            ]
        )

    def jacobian(self, x, p):
        e = np.exp(0.3 * x[0] * x[2])
        return np.array(
            [
                [x[1] * np.cos(x[0] * x[1]), x[0] * np.cos(x[0] * x[1]), p[0] * np.exp(x[2])],
                [-np.sin(x[0]) * x[2] ** 2, p[1] + 0 * x[0], 2 * np.cos(x[0]) * x[2]],
                [0.3 * x[2] * e - 3 * p[1] * x[0] ** 2, 0 * x[0], 0.3 * x[0] * e],
            ]
        )


def test_default_differences_match_complex_step():
    """The central-difference defaults agree with complex-step derivatives to 1e-9."""
    problem = Smooth()
    x, p = np.array([0.7, -1.1, 0.4]), np.array([1.3, -0.6])
    h = 1e-30
    ref_p = np.column_stack([problem.residual(x, p + 1j * h * e).imag / h for e in np.eye(2)])
    got_p = fd_parameter_derivative(problem.residual, x, p)
    assert np.max(np.abs(got_p - ref_p)) < 1e-9 * np.max(np.abs(ref_p))
    rng = np.random.default_rng(0)
    q = rng.standard_normal((3, 2))
    d = rng.standard_normal(5)
    ref = problem.jacobian(x + 1j * h * d[:3], p + 1j * h * d[3:]).imag / h @ q
    got = fd_jacobian_action_derivative(problem.jacobian, x, p, q, d)
    assert np.max(np.abs(got - ref)) < 1e-9 * np.max(np.abs(ref))
    assert np.array_equal(problem.jacobian_action_derivative(x, p, q, d), got)


def test_saddle_node_fold_curve_is_the_line_p0_zero():
    problem = SaddleNode()
    start = locate_fold(problem, problem.to_u([0.05, 0.0, 0.0]), [0.01, 0.0], free=0)
    assert start.converged and start.kind == "fold"
    curve = fold_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 3]])
    assert curve.end == "bounds" and curve.p[-1, 1] > 3
    assert np.all(np.abs(curve.p[:, 0]) < EXACT)
    assert np.all(np.abs(curve.x) < EXACT)
    assert np.all(np.diff(curve.p[:, 1]) > 0)
    assert not curve.special
    for point in curve.points:
        assert point.converged and point.residual < 1e-10
        assert abs(point.tests["g"]) < 1e-10
        assert not point.other_unstable
        # spectrum at the fold: 0, -1, -2
        assert np.allclose(np.sort(point.eigenvalues.real), [-2, -1, 0], atol=1e-8)


def test_cusp_is_gone_around_and_located():
    problem = Cusp()
    start = locate_fold(problem, problem.to_u([-0.98, 2.7, 0.1]), [2.0, 3.0], free=0)
    assert start.converged
    assert np.allclose(problem.to_x(start.x)[0], -1.0, atol=EXACT)
    curve = fold_curve(problem, start, direction=(0, -1), bounds=[[-5, 5], [-1, 3.05]])
    x, p = problem.xs(curve), curve.p
    assert np.all(np.abs(p[:, 0] + 2 * x[:, 0] ** 3) < EXACT)
    assert np.all(np.abs(p[:, 1] - 3 * x[:, 0] ** 2) < EXACT)
    assert np.all(np.abs(np.abs(p[:, 0]) - 2 * (np.maximum(p[:, 1], 0) / 3) ** 1.5) < EXACT)
    # p1 turns: down to the cusp, up again on the other sheet (x0 > 0, p0 < 0)
    turn = int(np.argmin(p[:, 1]))
    assert 0 < turn < len(p) - 1 and p[turn, 1] < 0.05 and p[-1, 1] > 3.0
    assert np.all(x[:turn, 0] < 0) and np.all(x[turn + 1 :, 0] > 0)
    assert curve.end == "bounds"
    [cusp] = curve.special
    assert cusp.kind == "cusp" and cusp.located
    assert np.all(np.abs(cusp.point.p) < EXACT)
    assert np.all(np.abs(problem.to_x(cusp.point.x)) < EXACT)
    assert abs(cusp.test) < 1e-10 and cusp.residual < 1e-10
    assert np.sign(curve.points[0].tests["cusp"]) != np.sign(curve.points[-1].tests["cusp"])


def test_a_smooth_turn_of_p0_is_located_and_a_cusp_is_not_taken_for_one():
    """The fold curve ``p0 = -p1^2`` (exact) through its maximum in ``p0`` at the origin: one
    special point ``turn``, located there (``p0`` to 1e-8), where the curve's unit tangent has
    no ``p0`` component (its test); no cusp (the cusp coefficient is 1 all along).  Along the cusp
    normal form's fold curve ``p0 = -2 x0^3`` is monotone while ``p1`` turns: only the cusp is
    reported."""
    problem = Turn()
    start = locate_fold(problem, problem.to_u([0.0, 0.0, 0.0]) + 0.01, [-1.0, 1.0], free=0)
    assert start.converged
    curve = fold_curve(problem, start, direction=(0, -1), bounds=[[-5, 5], [-1.2, 1.5]],
                       settings=Settings(monitor_turn=True))  # fmt: skip
    x, p = problem.xs(curve), curve.p
    assert np.all(np.abs(p[:, 0] + p[:, 1] ** 2) < EXACT) and np.all(np.abs(x) < EXACT)
    assert curve.end == "bounds" and p[-1, 1] < -1.0
    [turn] = curve.special
    assert turn.kind == "turn" and turn.located
    # located to 1e-4 in arclength (codim2.curves._TURN_XTOL): p0, stationary there, to its square
    assert abs(turn.point.p[0]) < EXACT and abs(turn.point.p[1]) < 1e-4
    assert abs(turn.test) < 1e-4 and turn.residual < 1e-4
    assert all(abs(q.tests["cusp"]) > 0.1 for q in curve.points)
    assert not fold_curve(problem, start, direction=(0, -1), bounds=[[-5, 5], [-1.2, 1.5]]).special
    problem = Cusp()
    start = locate_fold(problem, problem.to_u([-0.98, 2.7, 0.1]), [2.0, 3.0], free=0)
    curve = fold_curve(problem, start, direction=(0, -1), bounds=[[-5, 5], [-1, 3.05]],
                       settings=Settings(monitor_turn=True))  # fmt: skip
    assert [sp.kind for sp in curve.special] == ["cusp"]


class Walled(SaddleNode):
    """The saddle-node whose residual cannot be evaluated above ``p1 = 1`` (NaN): every step
    past it is refused."""

    def residual(self, u, p):
        return np.full(self.n, np.nan) if p[1] > 1.0 else super().residual(u, p)


def test_a_curve_is_given_up_when_its_caller_says_so_after_refused_steps():
    """``give_up(k)`` is asked after each refused step with the count since the last point:
    True ends the curve there (``end == "given_up"``), before the step would shrink to
    ``ds_min``; without it the same curve halves its step down to ``ds_min``."""
    problem = Walled()
    start = locate_fold(problem, problem.to_u([0.05, 0.0, 0.0]), [0.01, 0.0], free=0)
    asked = []

    def give_up(k):
        asked.append(k)
        return k >= 2

    curve = fold_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 3]],
                       give_up=give_up)  # fmt: skip
    assert curve.end == "given_up" and asked[-2:] == [1, 2] and asked.count(2) == 1
    assert curve.p[-1, 1] <= 1.0 and np.all(np.abs(curve.p[:, 0]) < EXACT)
    plain = fold_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 3]])
    assert plain.end == "step_too_small" and len(plain.points) > len(curve.points)


def test_a_curve_lands_on_the_values_of_p0_asked_for():
    """The cusp's fold curve ``p0 = -2 x0^3, p1 = 3 x0^2`` with landing values of p0 on both
    sheets: each is a point of the curve with p0 exactly that value (held by its corrector)
    and p1 = 3 (|p0|/2)^(2/3), the exact curve, to the Newton tolerance."""
    problem = Cusp()
    start = locate_fold(problem, problem.to_u([-0.98, 2.7, 0.1]), [2.0, 3.0], free=0)
    landing = [1.5, 0.7, 0.2, -0.5, -1.7]
    curve = fold_curve(problem, start, direction=(0, -1), bounds=[[-5, 5], [-1, 3.05]],
                       landing=landing)  # fmt: skip
    p = curve.p
    for value in landing:
        hit = [q for q in p if q[0] == value]
        assert len(hit) == 1, (value, p[:, 0])
        assert hit[0][1] == pytest.approx(3 * (abs(value) / 2) ** (2 / 3), abs=EXACT)
    assert all(q.converged for q in curve.points) and curve.end == "bounds"


def test_landing_ahead_lands_on_the_same_values_with_fewer_points():
    """``land_ahead = 1.5`` lands on a value up to 1.5 steps ahead directly: the same exact
    points (p1 = 3 (|p0|/2)^(2/3)) and fewer corrected points in all than with 1 (the
    intermediate points before each landing are skipped)."""
    problem = Cusp()
    start = locate_fold(problem, problem.to_u([-0.98, 2.7, 0.1]), [2.0, 3.0], free=0)
    landing = list(np.linspace(1.9, 0.1, 12))
    curves = {}
    for ahead in (1.0, 1.5):
        s = Settings(ds=0.3, ds_max=0.3, land_ahead=ahead)
        curves[ahead] = fold_curve(problem, start, direction=(0, -1),
                                   bounds=[[0.05, 5], [-1, 3.05]], landing=landing,
                                   settings=s)  # fmt: skip
        for value in landing:
            [hit] = [q for q in curves[ahead].p if q[0] == value]
            assert hit[1] == pytest.approx(3 * (abs(value) / 2) ** (2 / 3), abs=EXACT)
    assert len(curves[1.5].points) < len(curves[1.0].points)
    with pytest.raises(ValueError, match="land_ahead"):
        Settings(land_ahead=0.5)
    with pytest.raises(ValueError, match="stall_after"):
        Settings(stall_after=-1)


@pytest.mark.parametrize("s", [-1.0, 1.0])
def test_bogdanov_takens_fold_curve_then_switch_to_hopf(s):
    problem = BogdanovTakens(s)
    curve = fold_curve(problem, _fold_at(problem), direction=(0, 1), bounds=BOX)
    _check_bt_fold(problem, curve)
    assert curve.end == "bounds" and curve.p[0, 1] < -0.99 and curve.p[-1, 1] > 0.6
    [bt] = curve.special
    _check_bt_point(problem, bt)
    assert curve.p[bt.index, 1] < 0 < curve.p[bt.index + 1, 1]
    # the other eigenvalue at the fold is s x0 = -s b1 / 2: unstable on one side of BT
    for point in curve.points:
        if abs(point.p[1]) > 1e-6:
            assert point.other_unstable == (-s * point.p[1] > 0)
    hopf = hopf_curve(problem, bt, bounds=BOX)
    assert hopf.kind == "hopf" and hopf.end == "bounds" and hopf.p[-1, 1] < -1.05
    assert hopf.omega[0] == 0 and hopf.points[0].kind == "hopf"
    _check_bt_hopf(problem, hopf)
    assert not any(point.other_unstable for point in hopf.points[1:])


def test_hopf_curve_ends_at_bt_and_fold_curve_starts_there():
    problem = BogdanovTakens(-1.0)
    start = _hopf_at(problem)
    assert abs(start.omega - 1) < EXACT and abs(start.p[0]) < EXACT
    hopf = hopf_curve(problem, start, direction=(0, 1))
    assert hopf.end == "bt"
    _check_bt_hopf(problem, hopf)
    assert hopf.omega[-1] < 0.3
    [bt] = hopf.special
    _check_bt_point(problem, bt)
    for direction in ((0, 1), (0, -1)):
        fold = fold_curve(problem, bt, direction=direction, bounds=[[-5, 5], [-1, 1]])
        _check_bt_fold(problem, fold)
        assert not fold.special  # the BT it starts from is not found again
        assert np.sign(fold.p[-1, 1]) == direction[1]


def test_hopf_end_not_even_in_omega_squared():
    """With ``e = 1/2, s = 1`` the Hopf curve is ``x0 = -b1^2/2, b0 = b1^3/2 - b1^4/4``,
    ``omega^2 = -b1 + b1^2``: the extrapolation to omega = 0 is inexact and the BT point is
    reached by Newton on its system."""
    problem = BogdanovTakens(s=1.0, e=0.5)
    start = locate_hopf(problem, problem.to_u([-0.45, 0.01, 0.0]), [0.5, -1.0])
    curve = hopf_curve(problem, start, direction=(0, 1))
    x, p = problem.xs(curve), curve.p
    b1 = p[:, 1]
    assert np.all(np.abs(x[:, 0] + b1**2 / 2) < EXACT)
    assert np.all(np.abs(p[:, 0] - (b1**3 / 2 - b1**4 / 4)) < EXACT)
    assert np.all(np.abs(curve.omega**2 - (-b1 + b1**2)) < EXACT)
    assert curve.end == "bt"
    [bt] = curve.special
    _check_bt_point(problem, bt)
    assert bt.iterations >= 1


def test_locate_bt_directly():
    problem = BogdanovTakens(1.0)
    bt = locate_bt(problem, problem.to_u([0.03, 0.02, 0.0]), [0.01, -0.05])
    _check_bt_point(problem, bt)
    assert np.allclose(np.abs(bt.point.eigenvalues[:2]), 0, atol=1e-6)


def test_hopf_normal_form_frequency_and_centre():
    problem = HopfNormalForm()
    start = locate_hopf(problem, problem.to_u([0.01, 0.02, 0, 0, 0]), [0.02, -0.5], free=0)
    assert start.converged and abs(start.omega - problem.w(-0.5)) < EXACT
    curve = hopf_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 2.5]])
    x, p = problem.xs(curve), curve.p
    assert curve.end == "bounds" and p[-1, 1] > 2.5
    assert np.all(np.abs(p[:, 0]) < EXACT)
    assert np.all(np.abs(curve.omega - problem.w(p[:, 1])) < EXACT)
    assert np.all(np.abs(x[:, 0] - problem.centre(p[:, 1])) < EXACT)
    assert np.all(np.abs(x[:, 1:]) < EXACT)
    for point in curve.points:
        assert abs(point.tests["g_re"]) < 1e-10 and abs(point.tests["g_im"]) < 1e-10
        assert not point.other_unstable
        assert np.min(np.abs(point.eigenvalues - 1j * point.omega)) < 1e-8


@pytest.mark.parametrize("name", ["fold", "hopf", "bt"])
def test_newton_rows_of_the_test_functions_match_differences(name):
    """``E_z d`` of the bordered test functions (one Jacobian action derivative per
    direction) against central differences of ``E`` itself, borders fixed, on the DAE."""
    problem = ConstrainedBogdanovTakens()
    rng = np.random.default_rng(3)
    n = problem.n
    x, p = problem.to_u([0.3, 0.1, 0.2, 0.1, -0.1]), np.array([0.05, -0.4])
    b, c = rng.standard_normal(n), rng.standard_normal(n)
    if name == "hopf":
        b = b + 1j * rng.standard_normal(n)
        system = codim2.systems._MinAugHopf(n, problem.mass, b, c + 0j)
        u = np.concatenate([x, p, [0.7]])
    else:
        cls = codim2.systems._MinAugFold if name == "fold" else codim2.systems._BogdanovTakens
        system = cls(n, problem.mass, b, c)
        u = np.concatenate([x, p])
    ev = codim2.core._Evaluator(problem, n, "central")
    _, _, ctx = system.evaluate(u, problem.jacobian(x, p))
    for d in rng.standard_normal((3, n + 2)):
        h = 1e-6
        plus, minus = u.copy(), u.copy()
        plus[: n + 2] += h * d
        minus[: n + 2] -= h * d
        e_plus = system.evaluate(plus, problem.jacobian(plus[:n], plus[n : n + 2]))[0]
        e_minus = system.evaluate(minus, problem.jacobian(minus[:n], minus[n : n + 2]))[0]
        reference = (e_plus - e_minus) / (2 * h)
        got = system.derivative(ev, u, ctx, d)
        assert np.max(np.abs(got - reference)) < 1e-7 * max(1.0, np.max(np.abs(reference)))


class FrequencyDip(HopfNormalForm):
    """Hopf curve ``p0 = 0`` whose frequency ``0.005 + p1^2`` nearly reaches zero: no BT."""

    @staticmethod
    def w(p1):
        return 0.005 + p1**2


def test_hopf_curve_through_a_frequency_dip_goes_on():
    problem = FrequencyDip()
    start = locate_hopf(problem, problem.to_u([problem.centre(-1.0), 0.01, 0, 0, 0]), [0.01, -1])
    curve = hopf_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-2, 1]])
    assert curve.end == "bounds" and not curve.special
    assert np.min(curve.omega) < 0.01
    assert np.all(np.abs(curve.p[:, 0]) < EXACT)
    assert np.all(np.abs(curve.omega - problem.w(curve.p[:, 1])) < EXACT)


def test_spurious_unstable_eigenvalue_is_flagged():
    problem = HopfNormalForm(spurious=True)
    start = locate_hopf(problem, problem.to_u([0.01, 0.02, 0, 0, 0]), [0.02, -0.5], free=0)
    curve = hopf_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 2.5]])
    assert np.all(np.abs(curve.p[:, 0]) < EXACT)
    flags = np.array([point.other_unstable for point in curve.points])
    p1 = curve.p[:, 1]
    assert flags.any() and not flags.all()
    assert np.array_equal(flags[np.abs(p1 - 1) > 1e-6], (p1 > 1)[np.abs(p1 - 1) > 1e-6])
    # the second pair's real part is p1 - 1: flagged from Re = 0 on, not from some margin
    for p1, unstable in ((1 - 1e-7, False), (1 + 1e-7, True)):
        point = locate_hopf(
            problem, problem.to_u([problem.centre(p1), 0, 0, 0, 0]), [0, p1], omega=1.2
        )
        assert point.converged and abs(point.omega - problem.w(p1)) < EXACT
        assert point.other_unstable == unstable


@pytest.mark.parametrize("s", [-1.0, 1.0])
def test_dae_with_singular_mass_matrix(s):
    problem = ConstrainedBogdanovTakens(s)
    start = _fold_at(problem)
    x = problem.to_x(start.x)
    assert np.allclose(x, [0.5, 0, 0.25, 0.175, -0.025], atol=EXACT)
    fold = fold_curve(problem, start, direction=(0, 1), bounds=BOX)
    _check_bt_fold(problem, fold)
    [bt] = fold.special
    _check_bt_point(problem, bt)
    for point in fold.points:
        assert point.eigenvalues.size == 3  # m - 2 k = 3 finite eigenvalues (k = 1 constraint)
        if abs(point.p[1]) > 1e-6:
            assert point.other_unstable == (-s * point.p[1] > 0)
    hopf = hopf_curve(problem, bt, bounds=BOX)
    assert hopf.end == "bounds"
    _check_bt_hopf(problem, hopf)
    back = hopf_curve(problem, _hopf_at(problem), direction=(0, 1))
    assert back.end == "bt"
    _check_bt_hopf(problem, back)
    _check_bt_point(problem, back.special[0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_finite_eigenvalues_of_a_transformed_dae(seed):
    """Infinite eigenvalues (index 2) are dropped even after a general ``T (J, B) S``."""
    problem = ConstrainedBogdanovTakens()
    u = problem.to_u([0.5, 0, 0.25, 0.175, -0.025])
    J, B = problem.jacobian(u, [0.25, -1]), problem.mass
    rng = np.random.default_rng(seed)
    T, S = rng.standard_normal((5, 5)), rng.standard_normal((5, 5))
    eig = finite_eigenvalues(T @ J @ S, T @ B @ S)
    assert np.allclose(np.sort(eig.real), [-1, -0.5, 0], atol=1e-8)


@pytest.mark.parametrize("kind", ["fold", "hopf"])
def test_extended_system_gives_the_same_curves(kind):
    problem = BogdanovTakens(-1.0)
    settings = Settings(method="extended")
    if kind == "fold":
        curve = fold_curve(
            problem, _fold_at(problem), direction=(0, 1), bounds=BOX, settings=settings
        )
        _check_bt_fold(problem, curve)
    else:
        curve = hopf_curve(problem, _hopf_at(problem), direction=(0, 1), settings=settings)
        _check_bt_hopf(problem, curve)
        assert curve.end == "bt"
    assert curve.method == "extended"
    _check_bt_point(problem, curve.special[0])


def test_cost_per_newton_iteration_with_supplied_hooks():
    """Per fold point with k Newton iterations: k + 1 residuals and Jacobians, k calls of
    F_p, at most 2 k Jacobian action derivatives (two directions per step, one where the
    residual of F is at rounding level) and one for the cusp coefficient; no hidden finite
    differences."""
    problem = HookedSaddleNode()
    start = locate_fold(problem, problem.to_u([0.05, 0.0, 0.0]), [0.01, 0.0])
    curve = fold_curve(problem, start, direction=(0, 1), bounds=[[-5, 5], [-1, 3]])
    assert np.all(np.abs(curve.p[:, 0] - 0.3 * np.sin(curve.p[:, 1])) < EXACT)
    assert np.all(np.abs(curve.x) < EXACT)
    assert min(point.iterations for point in curve.points[1:]) >= 1
    for point in curve.points[1:]:
        k, ev = point.iterations, point.evaluations
        assert (ev.residual, ev.jacobian, ev.parameter_derivative) == (k + 1, k + 1, k)
        assert k + 1 <= ev.action <= 2 * k + 1


def test_results_are_frozen_and_progress_is_called():
    problem = BogdanovTakens()
    seen = []
    curve = fold_curve(
        problem, _fold_at(problem), direction=(0, -1), max_points=4, progress=seen.append
    )
    assert curve.end == "max_points" and len(curve.points) == 4
    assert seen == list(curve.points[1:])
    point = curve.points[1]
    with pytest.raises(dataclasses.FrozenInstanceError):
        point.omega = 1.0
    with pytest.raises(ValueError):
        point.x[0] = 0.0
    with pytest.raises(TypeError):
        point.tests["g"] = 0.0
    assert curve.evaluations.total >= sum(pt.evaluations.total for pt in curve.points[1:])


def test_duck_typed_problem_with_defaults():
    """Any object with ``residual`` and ``jacobian`` (no :class:`Problem` base) works."""

    class Plain:
        def __init__(self):
            self.inner = BogdanovTakens(-1.0)

        def residual(self, x, p):
            return self.inner.residual(x, p)

        def jacobian(self, x, p):
            return self.inner.jacobian(x, p)

    problem = Plain()
    point = locate_fold(problem, problem.inner.to_u([0.45, 0.02, 0.2]), [0.27, -1.0])
    assert point.converged and abs(point.p[0] - 0.25) < EXACT
    assert point.evaluations.parameter_derivative == point.evaluations.action == 0


def test_bad_inputs_are_refused():
    problem = BogdanovTakens()
    with pytest.raises(ValueError, match="free"):
        locate_fold(problem, np.zeros(3), [0.0, -1.0], free=2)
    with pytest.raises(ValueError, match="two components"):
        locate_fold(problem, np.zeros(3), [0.0, -1.0, 2.0])
    fold = _fold_at(problem)
    with pytest.raises(ValueError, match="Hopf or BT"):
        hopf_curve(problem, fold)
    with pytest.raises(ValueError, match="normal"):
        fold_curve(problem, fold, direction=(1.0, -fold.p[1] / 2))  # normal to (b1/2, 1)
    unconverged = dataclasses.replace(fold, converged=False)
    with pytest.raises(ValueError, match="not converged"):
        fold_curve(problem, unconverged)
    with pytest.raises(ValueError):
        Settings(method="bogus")
