"""Lockstep GMRES (:mod:`vesicle.solve.krylov`) against dense LU solves (the independent
answer) and against SciPy's GMRES one right-hand side at a time (the reference path)."""

import numpy as np
import pytest

import vesicle as vs
from vesicle.geometry.surface import Shape
from vesicle.solve.factorised import CoupledBlocks, FactorisedSystem, _preconditioned
from vesicle.solve.krylov import batched_gmres
from vesicle.solve.solver import VelocityTensionSolver


def _matrix(n, seed):
    """Nonsymmetric, well conditioned: identity plus a random matrix of norm about 0.5."""
    rng = np.random.default_rng(seed)
    return np.eye(n) + 0.5 * rng.standard_normal((n, n)) / np.sqrt(n)


def test_batched_gmres_solves_each_right_hand_side():
    """Five right-hand sides (one zero) of a 60 x 60 system: each equals LU's solution to
    the tolerance's order; the zero one is exactly zero after no iterations."""
    A = _matrix(60, 1)
    b = np.random.default_rng(2).standard_normal((5, 60))
    b[3] = 0.0
    out = batched_gmres(lambda X: X @ A.T, b, rtol=1e-12, max_iterations=60)
    exact = np.linalg.solve(A, b.T).T
    assert out.converged.all()
    assert np.abs(out.x - exact).max() < 1e-10 * np.abs(exact).max()
    assert out.iterations[3] == 0 and np.all(out.x[3] == 0.0)
    assert np.all(out.residuals[[0, 1, 2, 4]] <= 1e-12)


def test_an_eigenvector_converges_in_one_iteration():
    """A right-hand side along an eigenvector spans an invariant Krylov space of dimension 1
    (the breakdown GMRES exploits): solved exactly in one iteration, beside a generic one."""
    rng = np.random.default_rng(3)
    Q = np.linalg.qr(rng.standard_normal((20, 20)))[0]
    d = np.linspace(1.0, 3.0, 20)
    A = Q @ np.diag(d) @ Q.T
    b = np.stack([Q[:, 4], rng.standard_normal(20)])
    out = batched_gmres(lambda X: X @ A.T, b, rtol=1e-12, max_iterations=40)
    assert out.iterations[0] == 1
    assert np.abs(out.x[0] - Q[:, 4] / d[4]).max() < 1e-14
    assert out.converged.all() and out.iterations[1] > 1


def test_too_few_iterations_are_reported_not_hidden():
    """Three iterations on a system that needs about 20: no right-hand side is converged,
    and the residual estimates say by how much."""
    A = _matrix(80, 4)
    b = np.random.default_rng(5).standard_normal((3, 80))
    out = batched_gmres(lambda X: X @ A.T, b, rtol=1e-12, max_iterations=3)
    assert not out.converged.any() and np.all(out.residuals > 1e-6)
    with pytest.raises(ValueError, match="max_iterations"):
        batched_gmres(lambda X: X, b, rtol=1e-12, max_iterations=0)


@pytest.mark.parametrize("lam", [5.0, 1.0])
def test_the_batched_preconditioned_solve_equals_scipys_one_at_a_time(lam):
    """Six right-hand sides of a perturbed shape, preconditioned by a nearby shape's
    factorised system at another lam: the lockstep solve and SciPy's GMRES per right-hand side
    (the reference) take the same iterations and agree to rounding (the same Krylov spaces)."""
    shape = Shape.spheroid(0.9, 12, 4).perturbed(0.03, seed=2, degree=4)
    physics = vs.Physics(v=0.9, lam=lam, chi=3.0)
    system = FactorisedSystem(VelocityTensionSolver(shape, physics.replace(lam=lam * 1.05)))
    moved = VelocityTensionSolver(shape.perturbed(3e-3, seed=5, degree=4), physics)
    blocks = CoupledBlocks(moved)
    b = np.random.default_rng(6).standard_normal((6, 3, *shape.grid.shape))
    r = np.random.default_rng(7).standard_normal((6, blocks.tension_basis.size))
    u1, c1, n1, f1 = _preconditioned(blocks, system, b, r, 1e-11, 60, batched=True)
    u0, c0, n0, f0 = _preconditioned(blocks, system, b, r, 1e-11, 60, batched=False)
    assert all(f1) and all(f0)
    assert [c.count for c in n1] == [c.count for c in n0]
    assert np.abs(u1 - u0).max() < 1e-12 * np.abs(u0).max()
    assert np.abs(c1 - c0).max() < 1e-12 * np.abs(c0).max()
