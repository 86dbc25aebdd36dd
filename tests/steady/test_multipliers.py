"""The directions of the steady equations' area and volume multipliers (issue 41: the fold of the
steady solver against the time stepping's own end of the TT branch).

``Discretisation(multipliers="l2")`` makes the multipliers act along the L2 gradients of A and V,
the directions of the time stepping's drift control; the default acts along the gradients in the
basis coordinates (SPEC §8).  The expected values here are not this code's steady solver: they
are the drift control's own directions (:func:`vesicle.dynamics.integrators.restore_area_volume`'s
formula, evaluated here), the identity ``W^-1 g`` that relates the two, and the orthogonal
projection of SPEC §9 that the weighed pencil must reduce to when the weights are one.
"""

import numpy as np
import pytest

import vesicle as vs
from vesicle.bifurcation.branch import reach
from vesicle.model.kinematics import area_volume_variations
from vesicle.sphere.transforms import transform
from vesicle.steady.stability import _weighed_spectrum, stability

PHYSICS = vs.Physics(v=0.95, lam=1.0, chi=1.0)  # Newton converges from the default start


def _drift_control_directions(result) -> np.ndarray:
    """The time stepping's drift-control directions at the state's shape, in its basis: the L2
    gradients ``var_A J``, ``var_V J`` projected to the degree (restore_area_volume)."""
    shape, basis = result.shape, result.problem.basis
    T = transform(shape.grid.n_theta, basis.degree)
    return np.array([basis.from_coefficients(T.analysis(v * shape.area_element))
                     for v in area_volume_variations(shape)])  # fmt: skip


def _fixed_point_residual(result) -> float:
    """How far the state is from a fixed point of the drift-controlled dynamics: the part of
    its rate outside the drift control's directions, relative to the rate."""
    P = result.problem
    rate = P.adot(result.a)[0]
    if P.rate_weights is not None:
        rate = rate / P.rate_weights
    D = _drift_control_directions(result)
    mu, *_ = np.linalg.lstsq(D.T, rate, rcond=None)
    return float(np.linalg.norm(rate - D.T @ mu) / np.linalg.norm(rate))


@pytest.fixture(scope="module")
def states():
    return {m: reach(PHYSICS, vs.Discretisation(12, 4, multipliers=m))
            for m in ("coefficients", "l2")}  # fmt: skip


def test_the_option_is_validated_and_the_default_keeps_every_key():
    d = vs.Discretisation(16, 4)
    assert "multipliers" not in d.to_dict()  # the keys of results computed before it existed
    l2 = vs.Discretisation(16, 4, multipliers="l2")
    assert l2.to_dict()["multipliers"] == "l2" and l2.key != d.key
    assert vs.Discretisation.from_dict(l2.to_dict()) == l2
    with pytest.raises(ValueError, match="multipliers must be one of"):
        vs.Discretisation(16, 4, multipliers="L2")


def test_weighed_gradients_are_the_drift_controls_directions(states):
    r = states["l2"]
    W = r.problem.rate_weights
    g = r.problem.gradients(r.shape)
    D = _drift_control_directions(r)
    assert np.abs(g / W - D).max() < 1e-12 * np.abs(D).max()
    assert states["coefficients"].problem.rate_weights is None


def test_only_the_l2_state_is_a_fixed_point_of_the_time_stepping(states):
    """Both states solve their own equations to Newton's tolerance; only the "l2" one is a
    fixed point of the time stepping (its rate lies in the drift control's directions: the
    solves' 1e-8 bound the residual), the default misses by the multipliers' share of the rate
    (at N = 4 on 12x24, lam = 7.47, chi = 0.2 the same check gave 2.2e-8 against 0.28)."""
    for r in states.values():
        assert r.converged and r.residual < 1e-8
    assert _fixed_point_residual(states["l2"]) < 1e-6
    assert _fixed_point_residual(states["coefficients"]) > 1e-3
    # the two discretisations of the constraints differ by the multipliers' size, not more
    psi = {m: r.psi for m, r in states.items()}
    assert 0 < abs(psi["l2"] - psi["coefficients"]) < 1e-2


def test_weighed_pencil_reduces_to_the_projected_operator_with_unit_weights():
    rng = np.random.default_rng(3)
    n, c = 12, 2
    A, C = rng.standard_normal((n, n)), rng.standard_normal((c, n))
    mu, _ = _weighed_spectrum(A, C, np.ones(n))
    Z, _ = np.linalg.qr(C.T)
    Q = np.eye(n) - Z @ Z.T
    ref = np.linalg.eigvals(Q @ A @ Q)
    ref = ref[np.argsort(np.abs(ref))][c:]  # the c trivial zeros dropped
    assert mu.size == n - c
    gap = np.abs(mu[:, None] - ref[None, :])  # the same set (conjugates in any order)
    assert gap.min(axis=1).max() < 1e-10 and gap.min(axis=0).max() < 1e-10


def test_l2_growth_rates_are_those_of_the_drift_controlled_dynamics(states):
    """The leading growth rates of the "l2" state against a finite-difference linearisation of
    the drift-controlled dynamics themselves: ``da/dt = adot(a)`` followed by the drift control
    (the L2 projection onto A, V), differenced at the state along each constrained direction."""
    r = states["l2"]
    s = stability(r, curvature=True)
    P = r.problem
    W = P.rate_weights
    M = r.jacobian / W[:, None]  # d adot / d a, unweighed
    g = P.gradients(r.shape)
    H = P.constraint_hessians(r.a)
    D = g / W[None, :]
    # the linearised drift-controlled dynamics on the constraints' tangent space: the rate's
    # part along D removed by the oblique projection that keeps g . da = 0
    proj = np.eye(D.shape[1]) - D.T @ np.linalg.solve(g @ D.T, g)
    L = proj @ (M - np.einsum("k,kij->ij", np.asarray(r.multipliers), H) / W[:, None])
    Z, _ = np.linalg.qr(g.T)
    basis = np.linalg.svd(np.eye(D.shape[1]) - Z @ Z.T)[0][:, : D.shape[1] - 2]
    # L maps the tangent space into itself up to O(multipliers); its spectrum there
    ref = np.linalg.eigvals(np.linalg.pinv(basis) @ L @ basis)
    lead = ref[np.argmax(ref.real)]
    assert abs(s.omega[0, 1] - lead.real) < 1e-6 * max(1.0, abs(lead.real)) + 1e-8
