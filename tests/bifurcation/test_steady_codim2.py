"""The steady equations as a two-parameter problem (vesicle.bifurcation.steady_codim2).

Independent references: the Jacobian against central differences of the residual (the residual
is the Newton residual of vesicle.steady, the Jacobian the linearised one with the constraint
blocks), and the pencil's finite eigenvalues against vesicle.steady.stability, which computes
the growth rates another way (an orthogonal projection onto the constraints' tangent space, not
a singular mass matrix).  N = 2 on 8x16 (seconds)."""

import math

import numpy as np
import pytest

import vesicle as vs
from vesicle.bifurcation import codim2
from vesicle.bifurcation.steady_codim2 import SteadyEquations, locate_type_change
from vesicle.steady.stability import stability

TINY = vs.Discretisation(grid=8, degree=2)


@pytest.fixture(scope="module")
def state():
    return vs.steady_tank_treading(vs.Physics(v=0.95, lam=3.0, chi=1.5), TINY)


@pytest.mark.parametrize("form", ["curvature", "spec"])
def test_the_pencil_is_the_stability_analysis(state, form):
    eq = SteadyEquations(state.physics, TINY, form=form)
    x, p = eq.state(state)
    assert np.max(np.abs(eq.residual(x, p))) < 1e-7  # a converged state solves G = 0
    J = eq.jacobian(x, p)
    finite = codim2.finite_eigenvalues(J, eq.mass)
    reference = stability(state, curvature=(form == "curvature")).omega  # (omega_R, omega_I)
    growth = np.sort(finite.real)[::-1]
    expected = np.sort(reference[:, 1])[::-1]
    np.testing.assert_allclose(growth[: len(expected)], expected, atol=1e-7)


@pytest.mark.parametrize("form", ["curvature", "spec"])
def test_in_the_general_basis_the_spectrum_pencil_is_the_stability_analysis(state, form):
    """General modes: the spectrum pencil (translations held fixed) has exactly the growth
    rates of vesicle.steady.stability(modes="general"), which projects the translations out
    orthogonally; the plain pencil (J, B) has three more (the translations': at N = 8 on the
    vorticity branch some of them positive, which made every Hopf point look as if another
    eigenvalue were unstable)."""
    eq = SteadyEquations(state.physics, TINY, form=form, modes="general")
    x, p = eq.state(state)
    J = eq.jacobian(x, p)
    assert eq.translations.size == 3
    finite = codim2.finite_eigenvalues(*eq.spectrum_pencil(J))
    reference = stability(state, modes="general", curvature=(form == "curvature")).omega
    assert finite.size == len(reference)
    np.testing.assert_allclose(np.sort(finite.real)[::-1], np.sort(reference[:, 1])[::-1],
                               atol=1e-7)  # fmt: skip
    assert codim2.finite_eigenvalues(J, eq.mass).size == finite.size + 3
    # the symmetric basis has no translations: its pencil is (J, B) itself
    sym = SteadyEquations(state.physics, TINY, form=form)
    A, B = sym.spectrum_pencil(np.eye(sym.size + 2))
    assert A.shape == B.shape == (sym.size + 2, sym.size + 2)


def _jacobian_mismatch(grid: int) -> tuple[float, float]:
    """|J d - central difference of G along d|: the dynamic rows (relative) and the area row."""
    disc = vs.Discretisation(grid=grid, degree=2)
    steady = vs.steady_tank_treading(vs.Physics(v=0.95, lam=3.0, chi=1.5), disc)
    eq = SteadyEquations(steady.physics, disc, form="curvature")
    x, p = eq.state(steady)
    d = np.random.default_rng(3).standard_normal(x.size)
    d /= np.linalg.norm(d)
    h = 1e-5
    fd = (eq.residual(x + h * d, p) - eq.residual(x - h * d, p)) / (2 * h)
    exact = eq.jacobian(x, p) @ d
    err = np.abs(fd - exact)
    return float(err[:-2].max() / np.abs(exact[:-2]).max()), float(err[-2])


def test_the_jacobian_is_the_derivative_of_the_residual():
    """The linearised Jacobian and the constraint gradients are derivatives of the continuous
    equations: they match differences of the discrete residual up to the grid's aliasing
    error, which falls fast with the grid (measured: dynamic rows 1.1e-5, 2.3e-7, 5e-9 to 7e-7
    and the area row 1.1e-3, 1.4e-5, 1.8e-7 on 8x16, 12x24, 16x32 at N = 2; on 16x32 the
    dynamic rows' difference is at the level of the solves' tolerance divided by the step)."""
    coarse, fine = _jacobian_mismatch(8), _jacobian_mismatch(16)
    assert fine[0] < 2e-6 and fine[1] < 1e-6
    assert coarse[1] > 100 * fine[1]


@pytest.mark.parametrize("form", ["curvature", "spec"])
def test_newtons_action_derivative_is_the_difference_of_whole_jacobians(state, form):
    """The Jacobian-vector products of the linearisation at the moved point (the fast path
    of Newton's matrices) against central differences of whole Jacobians (the core's
    reference), along a direction in (x, p) and along lambda alone: measured 8e-4 and 1e-4
    relative at N = 4 on 16x32 (a forward difference of step 1e-5 against a central one of
    6e-6); here within 1e-2, which is what Newton's rate needs."""
    eq = SteadyEquations(state.physics, TINY, form=form)
    x, p = eq.state(state)
    rng = np.random.default_rng(7)
    q = rng.standard_normal((x.size, 2))
    for d in (np.concatenate([0.1 * rng.standard_normal(x.size), [0.3, -0.5]]),
              np.concatenate([np.zeros(x.size), [0.0, 1.0]])):  # fmt: skip
        reference = codim2.fd_jacobian_action_derivative(eq.jacobian, x, p, q, d)
        J = eq.jacobian(x, p)
        fast = eq.newton_action_derivative(x, p, q, d, J)
        assert np.abs(fast - reference).max() < 1e-2 * np.abs(reference).max()
    reference_path = SteadyEquations(state.physics, TINY, form=form, actions="jacobians")
    assert not reference_path.newton_actions
    with pytest.raises(ValueError, match="actions"):
        SteadyEquations(state.physics, TINY, actions="other")


@pytest.mark.parametrize("lam", [3.0, 1.0])
def test_the_exact_parameter_derivative_is_the_limit_of_residual_differences(state, lam):
    """``G_p`` from the parameter-differentiated solves against central differences of
    residuals (step eps^(1/3), the core's reference), at a point off the steady state (a
    moved shape and multipliers), with and without a double layer (lam = 1): equal to the
    differences' O(h^2) and the solves' 1e-10 over h (measured 2e-10 relative at N = 2 and
    N = 4; held to 1e-8)."""
    eq = SteadyEquations(state.physics.replace(lam=lam), TINY)
    x, p = eq.state(state)
    p[1] = lam
    x = x + 1e-3 * np.random.default_rng(8).standard_normal(x.size)
    eq.jacobian(x, p)  # the Newton loop's order: a Jacobian (a factorisation) at the point first
    exact = eq.parameter_derivative(x, p)
    reference = codim2.fd_parameter_derivative(eq.residual, x, p)
    assert np.all(exact[-2:] == 0.0)
    assert np.abs(exact - reference).max() < 1e-8 * np.abs(reference).max()
    fresh = SteadyEquations(state.physics.replace(lam=lam), TINY)  # no factorisation kept
    assert np.abs(fresh.parameter_derivative(x, p) - exact).max() < 1e-8 * np.abs(exact).max()
    assert not SteadyEquations(state.physics, TINY, parameter_derivatives="differences") \
        .exact_parameter_derivative  # fmt: skip
    with pytest.raises(ValueError, match="parameter_derivatives"):
        SteadyEquations(state.physics, TINY, parameter_derivatives="other")


def test_the_accurate_action_derivative_is_the_difference_of_whole_jacobians(state):
    """The test functions' ``F_xz(q, d)`` (the cusp coefficient's): central differences of
    the linearisation along ``q`` only, against central differences of whole Jacobians (the
    core's default, an independent way through the factorised solves), along a direction in
    (x, p): equal to 1e-8 relative at N = 2 and N = 4 (held to 1e-6); the reference path
    (``actions="jacobians"``) is the whole Jacobians' differences exactly."""
    eq = SteadyEquations(state.physics, TINY, form="spec")
    x, p = eq.state(state)
    rng = np.random.default_rng(11)
    q = rng.standard_normal(x.size)
    d = np.concatenate([0.1 * rng.standard_normal(x.size), [0.3, -0.5]])
    eq.jacobian(x, p)  # a factorised system kept nearby (the continuation always has one)
    fast = eq.jacobian_action_derivative(x, p, q, d)
    reference = codim2.fd_jacobian_action_derivative(eq.jacobian, x, p, q, d)
    assert np.abs(fast - reference).max() < 1e-6 * np.abs(reference).max()  # measured 1e-8
    slow = SteadyEquations(state.physics, TINY, form="spec", actions="jacobians")
    np.testing.assert_array_equal(
        slow.jacobian_action_derivative(x, p, q, d),
        codim2.fd_jacobian_action_derivative(slow.jacobian, x, p, q, d),
    )


def test_a_points_jacobian_is_computed_once(state, monkeypatch):
    """The Jacobian asked for again at the same (x, p) (a reported point's) comes from the
    kept ones: equal, a copy (changing it changes nothing kept), no second linearisation."""
    from vesicle.steady.problem import SteadyProblem

    eq = SteadyEquations(state.physics, TINY)
    x, p = eq.state(state)
    J = eq.jacobian(x, p)
    calls = []
    original = SteadyProblem.jacobian
    monkeypatch.setattr(
        SteadyProblem, "jacobian", lambda self, *a, **k: calls.append(1) or original(self, *a, **k)
    )
    again = eq.jacobian(x, p)
    assert calls == [] and np.array_equal(again, J) and again is not J
    again[0, 0] += 1.0
    assert np.array_equal(eq.jacobian(x, p), J)
    eq.jacobian(x + 1e-6, p)
    assert calls == [1]


def test_the_parameters_are_log_chi_and_lambda(state):
    eq = SteadyEquations(state.physics, TINY)
    _, p = eq.state(state)
    assert p[0] == pytest.approx(math.log(1.5)) and p[1] == 3.0
    assert eq.physics_at(p) == state.physics
    with pytest.raises(ValueError, match="form"):
        SteadyEquations(state.physics, TINY, form="other")


def test_a_hopf_point_located_on_the_augmented_system_is_the_bracketed_lambda_c():
    """v = 0.95, chi = 3.162, N = 4 on 16x32: the Hopf point solved for on the minimally
    augmented system (SPEC 9's operator) against lambda_c by Brent's method on the leading
    growth rate of vesicle.steady.stability (vesicle.bifurcation.critical, xtol 1e-3: 8.59004,
    docs/notes/continuation-measurements.md; the one-parameter tracer gave 8.59007).  Measured:
    8.590038, located in 3 Newton iterations."""
    disc = vs.Discretisation(grid=16, degree=4)
    physics = vs.Physics(v=0.95, lam=8.57, chi=3.162)
    eq = SteadyEquations(physics, disc, form="spec")
    x, p = eq.state(vs.steady_tank_treading(physics, disc))
    settings = codim2.Settings(ftol=1e-8, step_tol=1e-6, newton_differences="central")
    point = codim2.locate_hopf(eq, x, p, free=1, settings=settings)
    assert point.converged and point.residual < 1e-8
    assert point.p[1] == pytest.approx(8.59004, abs=1e-3)
    assert math.exp(point.p[0]) == pytest.approx(3.162, rel=1e-12)  # chi held
    assert point.omega > 0.5 and not point.other_unstable


@pytest.fixture(scope="module")
def sheets_near_the_type_change():
    """v = 0.95, N = 4 on 16x32: the lower sheet's fold at chi = 0.26 and the upper sheet's
    Hopf point at 0.27, located with the neutral curve's settings (shared by the two tests of
    the type change: 40 s of setup)."""
    from vesicle.bifurcation.neutral_codim2 import DEFAULT_SETTINGS

    disc = vs.Discretisation(grid=16, degree=4)
    settings = DEFAULT_SETTINGS
    low = (
        vs.branch(
            vs.Physics(v=0.95, lam=7.0, chi=0.26),
            disc,
            "lam",
            [7.0, 7.3, 7.45, 7.5],
            continuation=vs.ContinuationSettings(locate=False, arclength=False),
        )
        .points[-1]
        .steady
    )
    up = vs.steady_tank_treading(vs.Physics(v=0.95, lam=7.59, chi=0.27), disc)
    eq = SteadyEquations(low.physics, disc, form="spec")
    fold = codim2.locate_fold(eq, *eq.state(low), free=1, settings=settings)
    hopf = codim2.locate_hopf(eq, *eq.state(up), free=1, settings=settings)
    return eq, fold, hopf, settings


def test_the_type_change_is_located_where_the_fold_meets_the_upper_sheets_hopf_curve(
    sheets_near_the_type_change,
):
    """v = 0.95, N = 4 on 16x32 with the neutral curve's settings: the lower sheet's fold and
    the upper sheet's Hopf point solved for at each chi, and the chi where their lambdas meet.
    Fails if the type change is not located or moves out of the independent references: the
    one-parameter tracer bracketed the change in [0.2544, 0.2577] with lambda_c about 7.520
    and omega_R 0.058 at its Hopf end (docs/notes/continuation-measurements.md); SPEC 14: near
    0.25.  Measured: 0.256642, 7.519719, omega_R 0.05720 (also with central differences)."""
    eq, fold, hopf, settings = sheets_near_the_type_change
    seen = []
    change = locate_type_change(eq, fold, hopf, (0.25, 0.265), settings=settings,
                                progress=lambda d: seen.append(d["chi"]))  # fmt: skip
    assert len(seen) == len(set(seen))  # no chi solved twice (Brent's first calls: the ends)
    assert change.located and not change.fold.other_unstable and not change.hopf.other_unstable
    assert 0.2544 <= change.chi <= 0.2577
    assert change.lambda_c == pytest.approx(7.520, abs=5e-3)
    assert change.omega_R == pytest.approx(0.058, abs=3e-3)


def test_the_type_changes_secant_iterations_find_brents_crossing_in_fewer_solves(
    sheets_near_the_type_change,
):
    """The same crossing as above (v = 0.95, N = 4 on 16x32) by the secant iterations from a
    start off the root (0.26: where the curves' own points put it is within about 0.005):
    the same chi to xtol (Brent's 0.256642, measured with the reference path in the test
    above, and independently inside the tracer's bracket [0.2544, 0.2577]), in fewer gap
    evaluations than Brent's seven."""
    eq, fold, hopf, settings = sheets_near_the_type_change
    seen = []
    change = locate_type_change(eq, fold, hopf, (0.25, 0.265), settings=settings, guess=0.26,
                                progress=lambda d: seen.append(d["chi"]))  # fmt: skip
    assert change.located and abs(change.gap) < 1e-4
    assert 0.2544 <= change.chi <= 0.2577
    assert change.chi == pytest.approx(0.256642, abs=2e-6)
    assert len(seen) == len(set(seen)) and len(seen) <= 5
    with pytest.raises(ValueError, match="method"):
        locate_type_change(eq, fold, hopf, (0.25, 0.265), method="newton")


def test_parameters_no_physics_has_give_nan_not_an_error(state):
    """A corrector's iterate at lambda <= 0 (v = 0.85, N = 8: lambda = -27.7 raised from
    Physics and ended a whole fold curve) gives NaN residuals and Jacobians, which the
    continuation refuses like an unrepresentable shape, and the parameter derivative too."""
    eq = SteadyEquations(state.physics, TINY)
    x, p = eq.state(state)
    bad = np.array([p[0], -27.7])
    assert np.all(np.isnan(eq.residual(x, bad)))
    assert np.all(np.isnan(eq.jacobian(x, bad)))
    assert np.all(np.isnan(eq.parameter_derivative(x, bad)))
    assert np.all(np.isfinite(eq.residual(x, p)))


# --------------------------------------------------------------- the (Bq, lambda) plane
def test_the_bq_plane_has_bq_and_lambda_and_refuses_a_bad_plane(state):
    eq = SteadyEquations(state.physics.replace(bq=2.0), TINY, plane=("bq", "lam"))
    p = eq.coordinates(state.physics.replace(bq=2.0))
    assert list(p) == [2.0, 3.0]
    assert eq.physics_at(p) == state.physics.replace(bq=2.0)
    assert eq.physics_at([-1e-13, 3.0]).bq == 0.0  # rounding below 0 is 0
    x, _ = eq.state(state)
    assert np.all(np.isnan(eq.residual(x, np.array([-1e-3, 3.0]))))  # no physics at Bq < 0
    for bad in (("chi", "chi"), ("bq",), ("lam", "eta")):
        with pytest.raises(ValueError, match="plane"):
            SteadyEquations(state.physics, TINY, plane=bad)


@pytest.mark.parametrize("bq", [2.0, 0.0])
def test_the_parameter_derivative_in_bq_is_the_limit_of_residual_differences(state, bq):
    """``G_p`` in ``(Bq, lambda)`` (the system differentiated in Bq: right-hand side
    ``-N[V u]/(8 pi)``) against differences of residuals: central at Bq = 2 (O(h^2), measured
    6e-10 relative at N = 4), one-sided forward at Bq = 0 (no physics below it: O(h) with the
    core's step eps^(1/3), 6e-6; held to 1e-4).  At a moved point off the steady state."""
    physics = state.physics.replace(bq=bq)
    eq = SteadyEquations(physics, TINY, plane=("bq", "lam"))
    x, p = eq.state(state)
    p[0] = bq
    x = x + 1e-3 * np.random.default_rng(3).standard_normal(x.size)
    eq.jacobian(x, p)
    exact = eq.parameter_derivative(x, p)
    if bq > 0:
        reference = codim2.fd_parameter_derivative(eq.residual, x, p)
        tol = 1e-8
    else:
        h = codim2.FD_STEP * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(p))))
        base = eq.residual(x, p)
        reference = np.stack([(eq.residual(x, p + h * e) - base) / h for e in np.eye(2)], 1)
        tol = 1e-4
    assert np.all(exact[-2:] == 0.0)
    assert np.abs(exact - reference).max() < tol * np.abs(reference).max()
    assert np.abs(exact[:, 0]).max() > 1e-3 * np.abs(exact[:, 1]).max()  # Bq moves the state


def test_the_critical_bq_at_a_held_lambda_is_the_bracketed_lambda_c():
    """v = 0.95, chi = 3.162, N = 4 on 16x32.  ``vesicle critical --bq 1 --xtol 1e-5`` (Brent's
    method on the leading growth rate of vesicle.steady.stability at Bq = 1: lambda held,
    bracketed in lambda) gave lambda_c = 7.5502789, Hopf, omega_R = 1.30869.  Here lambda is
    held at that value and Bq is the free parameter of the Hopf system (its derivative in Bq
    from the parameter-differentiated solve): Bq_c = 1 to the bracket's 1e-5 in lambda over
    the slope |d lambda_c / d Bq| = 1.04 (measured 0.999999)."""
    disc = vs.Discretisation(grid=16, degree=4)
    physics = vs.Physics(v=0.95, lam=7.5502789, chi=3.162, bq=0.95)
    eq = SteadyEquations(physics, disc, form="spec", plane=("bq", "lam"))
    x, p = eq.state(vs.steady_tank_treading(physics, disc))
    settings = codim2.Settings(ftol=1e-8, step_tol=1e-6, newton_differences="central")
    point = codim2.locate_hopf(eq, x, p, free=0, settings=settings)
    assert point.converged and point.residual < 1e-8
    assert point.p[0] == pytest.approx(1.0, abs=3e-5)
    assert point.p[1] == 7.5502789  # lambda held
    assert point.omega == pytest.approx(1.30869, abs=1e-4) and not point.other_unstable
    # and at Bq = 0 held (Newton's differences one-sided there): the bracketed 8.59004 of
    # test_a_hopf_point_located_on_the_augmented_system_is_the_bracketed_lambda_c
    zero = SteadyEquations(physics.replace(bq=0.0, lam=8.57), disc, form="spec",
                           plane=("bq", "lam"))  # fmt: skip
    x, p = zero.state(vs.steady_tank_treading(physics.replace(bq=0.0, lam=8.57), disc))
    point = codim2.locate_hopf(zero, x, p, free=1, settings=settings)
    assert point.converged and abs(point.p[0]) <= 1e-12
    assert point.p[1] == pytest.approx(8.59004, abs=1e-3)


def test_with_a_memo_a_fresh_problem_replays_the_evaluations_and_goes_on(state, tmp_path,
                                                                         monkeypatch):
    """The memo of an interrupted curve (vesicle.io.memo): a new problem with it gives the
    residual, Jacobian and parameter derivative kept (bit for bit, no linearisation), and the
    Newton action at a new direction (a lookup that misses, with no factorised system kept
    after the Jacobian was looked up) is computed, as the problem without a memo computes it
    (the same solves to 1e-11, differenced with step 1e-5: 1e-5 relative)."""
    from vesicle.bifurcation.neutral_codim2 import curve_memo
    from vesicle.steady.problem import SteadyProblem

    first = SteadyEquations(state.physics, TINY)
    first.memo = curve_memo(tmp_path / "m", state.physics, TINY, form="curvature")
    x, p = first.state(state)
    kept = (first.residual(x, p), first.jacobian(x, p), first.parameter_derivative(x, p))
    rng = np.random.default_rng(3)
    q = rng.standard_normal((x.size, 2))
    d = np.concatenate([0.1 * rng.standard_normal(x.size), [0.2, -0.4]])
    plain = SteadyEquations(state.physics, TINY)
    expected = plain.newton_action_derivative(x, p, q, d, plain.jacobian(x, p))

    again = SteadyEquations(state.physics, TINY)
    again.memo = curve_memo(tmp_path / "m", state.physics, TINY, form="curvature")
    original = SteadyProblem.jacobian
    calls = []
    monkeypatch.setattr(
        SteadyProblem, "jacobian", lambda self, *a, **k: calls.append(1) or original(self, *a, **k)
    )
    replayed = (again.residual(x, p), again.jacobian(x, p), again.parameter_derivative(x, p))
    assert calls == [] and again.memo.hits == 3
    assert all(np.array_equal(a, b) for a, b in zip(kept, replayed, strict=True))
    action = again.newton_action_derivative(x, p, q, d, replayed[1])
    assert np.all(np.isfinite(action)) and again.memo.misses == 1
    assert np.abs(action - expected).max() < 1e-5 * np.abs(expected).max()


def test_with_a_memo_a_failed_evaluation_is_replayed_as_the_same_failure(state, tmp_path,
                                                                         monkeypatch):
    """A Jacobian or Jacobian action that failed when computed is kept (as NaN) and fails
    again when a resumed curve meets the same point, without computing it again (the Jacobian
    is NaN, as the public ``jacobian`` reports a failure; the action raises)."""
    from vesicle.bifurcation.neutral_codim2 import curve_memo
    from vesicle.solve.solver import SolverError

    def fails(self, *args):
        raise SolverError("no convergence (a stand-in)")

    first = SteadyEquations(state.physics, TINY)
    first.memo = curve_memo(tmp_path / "m", state.physics, TINY)
    x, p = first.state(state)
    q = np.eye(x.size)[:, :2]
    monkeypatch.setattr(SteadyEquations, "_computed_jacobian", fails)
    monkeypatch.setattr(SteadyEquations, "_computed_times", fails)
    first = SteadyEquations(state.physics, TINY)  # nothing in memory
    first.memo = curve_memo(tmp_path / "m", state.physics, TINY)
    assert np.all(np.isnan(first.jacobian(x, p)))
    with pytest.raises(SolverError):
        first._times(x, p, q)
    assert len(first.memo) == 2  # both failures kept

    def computed(self, *args):
        pytest.fail("a failure kept was computed again")

    monkeypatch.setattr(SteadyEquations, "_computed_jacobian", computed)
    monkeypatch.setattr(SteadyEquations, "_computed_times", computed)
    again = SteadyEquations(state.physics, TINY)
    again.memo = curve_memo(tmp_path / "m", state.physics, TINY)
    with pytest.raises(SolverError, match="replayed"):
        again._jacobian(x, p)
    assert np.all(np.isnan(again.jacobian(x, p)))
    with pytest.raises(SolverError, match="replayed"):
        again._times(x, p, q)
    assert again.memo.hits == 3
