"""The linearised Jacobian (issue 12): each fast piece held to its reference, and the whole held
to finite differences of complete solves (an independent computation of the same derivative)."""

import numpy as np
import pytest

import vesicle as vs
from vesicle.geometry.surface import Shape
from vesicle.model.membrane import bending_force
from vesicle.model.parameters import SolverTolerances
from vesicle.solve.factorised import (
    FactorisedSystem,
    _block_apply,
    block_apply_reference,
    preconditioned_solve,
    preconditioned_system_solve,
)
from vesicle.solve.linearisation import linearised_action, linearised_jacobian
from vesicle.solve.solver import VelocityTensionSolver
from vesicle.sphere.bases import basis
from vesicle.steady.newton import initial_guess
from vesicle.steady.problem import SteadyProblem, finite_difference_jacobian
from vesicle.stokes.operators import LayerPotentials, shape_derivatives_reference

TIGHT = SolverTolerances(schur=1e-12, inner=1e-13, max_outer=400, max_inner=400)


@pytest.fixture(scope="module")
def shape():
    """No symmetry: a perturbed spheroid, N = 4 on 12 x 24."""
    return Shape.spheroid(0.9, 12, 4).perturbed(0.03, seed=2, degree=4)


def test_fused_shape_derivatives_match_the_perturbed_shapes(shape):
    """The fused pass against the matrix-free NumPy layer potentials of the shapes r +- h d
    (the reference: the same quadrature, evaluated separately on each moved shape)."""
    B = basis("general", 4)
    dirs = np.stack([B.to_coefficients(e) for e in np.eye(B.size)[[0, 3, 7, 12, 20]]])
    rng = np.random.default_rng(0)
    f, u = rng.standard_normal((2, 3, *shape.grid.shape))
    dN, dK = LayerPotentials(shape).shape_derivatives(dirs, f, u)
    rN, rK = shape_derivatives_reference(shape, dirs, f, u)
    # both are differences of step 1e-5: they agree to the rounding of the differences
    assert np.abs(dN - rN).max() < 1e-8 * np.abs(rN).max()
    assert np.abs(dK - rK).max() < 1e-7 * np.abs(rK).max()  # rough density: more rounding
    only_single, none = LayerPotentials(shape).shape_derivatives(dirs, f=f)
    assert none is None and np.array_equal(only_single, dN)


def test_shape_derivatives_converge_like_central_differences():
    """Steps 1e-3, 1e-4 against 1e-5: the error falls 100x per decade (O(h^2)), so the
    default step's own error is about 1e-8 of the derivative."""
    s = Shape.spheroid(0.9, 16, 6)
    B = basis("symmetric", 6)
    dirs = np.stack([B.to_coefficients(e) for e in np.eye(B.size)])
    f, u = bending_force(s), s.x * np.array([1.0, 0.3, -0.2])[:, None, None]
    lp = LayerPotentials(s)
    ref = lp.shape_derivatives(dirs, f, u)
    errors = []
    for h in (1e-3, 1e-4):
        d = lp.shape_derivatives(dirs, f, u, step=h)
        errors.append([np.abs(d[i] - ref[i]).max() / np.abs(ref[i]).max() for i in (0, 1)])
    errors = np.array(errors)
    assert np.all(errors[1] < 2e-6)
    np.testing.assert_allclose(errors[0] / errors[1], 100.0, rtol=0.05)


@pytest.mark.parametrize("lam", [5.0, 1.0])
def test_factorised_solve_matches_gmres(shape, lam):
    """The exact (Woodbury + Schur) solve against nested GMRES at 1e-12 / 1e-13."""
    solver = VelocityTensionSolver(shape, vs.Physics(v=0.9, lam=lam, chi=3.0), TIGHT)
    gmres = solver.solve()
    system = FactorisedSystem(solver)
    u, sigma = system.solve(solver.rhs())
    assert np.abs(u - gmres.u).max() < 1e-10 * np.abs(gmres.u).max()
    assert np.abs(sigma - gmres.sigma).max() < 1e-10 * np.abs(gmres.sigma).max()
    exact = system.flow_result()
    assert exact.converged and exact.constraint_residual < 1e-10
    np.testing.assert_allclose(exact.stress.S, gmres.stress.S, rtol=1e-9, atol=1e-9)


def test_factorised_solve_satisfies_the_original_equations(shape):
    """With a constraint right-hand side: the solution put back into the operators of the
    GMRES solver (A_uu, A_us, the band-limited divergence), not into the factorised pieces."""
    solver = VelocityTensionSolver(shape, vs.Physics(v=0.9, lam=3.0, chi=2.0), TIGHT)
    system = FactorisedSystem(solver)
    rng = np.random.default_rng(1)
    b = rng.standard_normal((2, 3, *shape.grid.shape))
    r = rng.standard_normal((2, system.tension_basis.size))
    u, t = system.solve(b, r)
    for k in range(2):
        momentum = solver.A_uu(u[k]) + solver.A_us(t[k]) - b[k]
        assert np.abs(momentum).max() < 1e-11 * np.abs(b[k]).max()
        np.testing.assert_allclose(system.project(solver.A_su(u[k])[None])[0], r[k], atol=1e-10)
        assert np.abs(t[k] - solver._band(t[k])).max() < 1e-12 * np.abs(t[k]).max()


@pytest.mark.parametrize("lam, other_lam, size", [(5.0, 5.0, 1e-3), (5.0, 5.3, 1e-2),
                                                   (1.0, 1.0, 1e-2)])  # fmt: skip
def test_preconditioned_solve_matches_gmres(shape, lam, other_lam, size):
    """A shape moved by ``size`` (and lam by 6 %) from a factorised one, solved by GMRES
    preconditioned with that system, against the nested GMRES at 1e-12 / 1e-13 (the reference):
    the velocity and tension agree to the solve's 1e-10, in a few iterations (the
    preconditioned operator is I + O(size))."""
    moved = shape.perturbed(size, seed=5, degree=4)
    physics = vs.Physics(v=0.9, lam=lam, chi=3.0)
    system = FactorisedSystem(VelocityTensionSolver(shape, physics.replace(lam=other_lam)))
    solver = VelocityTensionSolver(moved, physics, TIGHT)
    reference = solver.solve()
    r = preconditioned_solve(solver, system, rtol=1e-11)
    assert r.converged and r.outer_iterations <= 12 and r.inner_iterations == 0
    assert np.abs(r.u - reference.u).max() < 1e-9 * np.abs(reference.u).max()
    assert np.abs(r.sigma - reference.sigma).max() < 1e-9 * np.abs(reference.sigma).max()
    np.testing.assert_allclose(r.stress.S, reference.stress.S, rtol=1e-8, atol=1e-8)
    assert r.constraint_residual < 1e-9


def test_linearised_action_is_the_linearised_jacobian_times_the_vectors(jacobians):
    """``M V`` from the linearisation along three vectors only, its solves by GMRES
    preconditioned with a nearby shape's factorised system (another lam too), against the
    whole linearised Jacobian of the same shape (a factorisation: the independent solve) times
    ``V``: equal to the GMRES tolerance (1e-11), not to a difference step."""
    lin, _, P, a = jacobians
    p = P.physics
    solver = VelocityTensionSolver(P.shape(a), p, discretisation=P.discretisation)
    near = P.shape(a + 1e-3 * np.random.default_rng(4).standard_normal(a.size))
    system = FactorisedSystem(VelocityTensionSolver(near, p.replace(lam=5.2)))
    V = np.random.default_rng(5).standard_normal((a.size, 3))
    MV = linearised_action(solver, P.basis, V, system, rtol=1e-12)
    assert np.abs(MV - lin @ V).max() < 1e-8 * np.abs(lin @ V).max()
    with pytest.raises(ValueError, match="vectors"):
        linearised_action(solver, P.basis, V[:-1], system)


def test_the_preconditioned_system_solve_reports_a_missed_tolerance(shape):
    """A preconditioner from a far shape and one GMRES iteration: an error, not a result."""
    physics = vs.Physics(v=0.9, lam=5.0, chi=3.0)
    far = Shape.spheroid(0.6, 12, 4)
    system = FactorisedSystem(VelocityTensionSolver(far, physics))
    solver = VelocityTensionSolver(shape, physics)
    from vesicle.solve.factorised import CoupledBlocks
    from vesicle.solve.solver import SolverError

    with pytest.raises(SolverError, match="missed"):
        preconditioned_system_solve(CoupledBlocks(solver), system, solver.rhs()[None],
                                    rtol=1e-12, max_iterations=1)  # fmt: skip


def test_block_apply_matches_numpy():
    rng = np.random.default_rng(3)
    m, u = rng.standard_normal((3, 3, 50)), rng.standard_normal((4, 3, 50))
    out = np.empty_like(u)
    _block_apply(m, u, out)
    np.testing.assert_allclose(out, block_apply_reference(m, u), rtol=1e-14, atol=1e-14)


@pytest.fixture(scope="module")
def jacobians():
    """The linearised Jacobian and central differences of complete solves (1e-11 / 1e-12) at
    steps h and h/2, at the default start for v = 0.95, lam = 5, chi = 2 (N = 4, 12 x 24)."""
    p = vs.Physics(v=0.95, lam=5.0, chi=2.0)
    d = vs.Discretisation(grid=12, degree=4)
    tol = SolverTolerances(1e-11, 1e-12, 400, 400)
    P = SteadyProblem(p, d, tol, jacobian_method="differences")
    a = initial_guess(p, d)
    solver = VelocityTensionSolver(P.shape(a), p, tol, discretisation=d)
    lin = linearised_jacobian(solver, P.basis).jacobian
    fd = {}
    for h in (2e-4, 1e-4):
        column = lambda x: P.adot(x)[0]  # noqa: E731
        fd[h] = finite_difference_jacobian(column, a, h, central=True)[0]
    return lin, fd, P, a


def test_linearised_jacobian_is_the_limit_of_central_differences(jacobians):
    """Central differences carry an O(h^2) error: 2.6e-5 at h = 2e-4 and a quarter of it at
    1e-4 (measured); their Richardson extrapolation removes it and meets the linearised
    Jacobian at the level of the solver tolerance."""
    lin, fd, _, _ = jacobians
    scale = np.abs(lin).max()
    e_big = np.abs(fd[2e-4] - lin).max() / scale
    e_small = np.abs(fd[1e-4] - lin).max() / scale
    assert e_small < 2e-5
    assert e_big / e_small == pytest.approx(4.0, rel=0.1)  # the h^2 law, so lin is the limit
    richardson = (4.0 * fd[1e-4] - fd[2e-4]) / 3.0
    assert np.abs(richardson - lin).max() / scale < 3e-7


def test_linearised_jacobian_through_the_problem(jacobians):
    """SteadyProblem.jacobian dispatches: no solves counted, the same matrix."""
    lin, _, P, a = jacobians
    Pl = P.replace(jacobian_method="linearised", tolerances=SolverTolerances(1e-8, 1e-9))
    M, n = Pl.jacobian(a)
    assert n == 0
    np.testing.assert_allclose(M, lin, rtol=0, atol=1e-8 * np.abs(lin).max())
    with pytest.raises(ValueError, match="jacobian_method"):
        P.replace(jacobian_method="complex-step")


def test_steady_state_and_stability_agree_with_the_reference(table1_n4):
    """Newton + stability with linearised Jacobians against the reference (finite differences,
    no Broyden updates) at N = 4 on 16 x 32 (Table 1's parameters): omega to 1e-5 relative
    (measured 5e-7; the reference's own O(h^2) error is of that order); the states agree to
    what Newton's stopping rule leaves (residual < 1e-8: measured 1.1e-8 in the coefficients)."""
    new = table1_n4  # the default path at Table 1's parameters (tests/conftest.py)
    p, d = new.physics, new.discretisation
    ref = vs.steady_tank_treading(
        p,
        d,
        newton=vs.NewtonSettings(updates="none"),
        analysis=vs.StabilitySettings(jacobian="differences"),
    )
    np.testing.assert_allclose(new.a, ref.a, atol=1e-7)
    w_new = np.array(vs.stability(new).most_unstable)  # (|omega_R|, omega_I): pairs are +-
    w_ref = np.array(vs.stability(ref).most_unstable)
    assert np.abs(w_new - w_ref).max() < 1e-5 * np.abs(w_ref).max()
    # The split stress reused the factorised system of the final shape (exact solves) where the
    # reference iterated GMRES to 1e-8: the deviatoric parts agree to 1e-7 (measured 6e-8); the
    # isotropic part, a uniform-tension pressure that no rheological function sees, differs by
    # the tension's GMRES tolerance (measured 7e-7 on diagonals of 0.04).
    for part in ("bending", "flow"):
        dev = [S - np.trace(S) / 3.0 * np.eye(3) for S in (new.split[part].S, ref.split[part].S)]
        np.testing.assert_allclose(dev[0], dev[1], rtol=0, atol=1e-7)
