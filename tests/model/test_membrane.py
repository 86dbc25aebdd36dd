"""Membrane forces: first-variation identities and force/torque balance (SPEC §4)."""

import numpy as np
import pytest

import vesicle as vs
from vesicle.model.membrane import bending_energy, bending_force, tension_energy, tension_force
from vesicle.sphere.transforms import transform


def richardson_derivative(energy, coefficients, h, grid, eps=1e-4):
    def fd(e):
        return (
            energy(vs.Shape(coefficients + e * h, grid))
            - energy(vs.Shape(coefficients - e * h, grid))
        ) / (2 * e)

    return (4 * fd(eps / 2) - fd(eps)) / 3


@pytest.fixture(scope="module")
def perturbed():
    base = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=32, degree=8).perturbed(0.04, seed=1)
    rng = np.random.default_rng(5)
    h = rng.standard_normal((9, 9)) + 1j * rng.standard_normal((9, 9))
    h = np.tril(h) * 0.05
    h[:, 0] = h[:, 0].real
    return base, h


def normal_variation(shape, force, h):
    """int f . (h e_r) dA."""
    hg = transform(shape.grid.n_theta, 8).synthesis(h)
    e_r = shape.grid.unit_vectors[0]
    return shape.integrate(np.einsum("i...,i...->...", force, hg * e_r))


@pytest.mark.parametrize("n", [32, 48])
def test_bending_force_is_first_variation(perturbed, n):
    base, h = perturbed
    s = base.with_grid(n)
    predicted = normal_variation(s, bending_force(s), h)
    fd = richardson_derivative(bending_energy, s.coefficients, h, n)
    assert abs(fd / predicted - 1) <= 1e-6


def test_tension_force_is_first_variation(perturbed):
    base, h = perturbed
    th, ph = base.grid.meshgrid()
    sigma = (
        1.0
        + 0.3 * np.cos(th)
        + 0.2 * np.sin(th) ** 2 * np.sin(2 * ph)
        - 0.1 * np.sin(th) * np.cos(ph)
    )

    def energy(s):
        return tension_energy(s, sigma)

    predicted = normal_variation(base, tension_force(base, sigma), h)
    fd = richardson_derivative(energy, base.coefficients, h, 32)
    assert abs(fd / predicted - 1) <= 1e-6


def test_wrong_sign_would_fail_first_variation(perturbed):
    """The check has teeth: flipping the Laplacian term breaks it by orders of magnitude."""
    base, h = perturbed
    H, K = base.mean_curvature, base.gaussian_curvature
    wrong = 2 * (2 * H * (H * H - K) - base.laplace_beltrami(H)) * base.normal
    fd = richardson_derivative(bending_energy, base.coefficients, h, 32)
    assert abs(fd / normal_variation(base, wrong, h) - 1) > 1e-2


@pytest.mark.parametrize(
    ("shape", "tol"),
    [
        (vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=32, degree=8), 1e-10),
        (vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=48, degree=8).perturbed(0.04, seed=1), 1e-10),
    ],
)
def test_bending_force_is_force_and_torque_free(shape, tol):
    f = bending_force(shape)
    scale = shape.integrate(np.linalg.norm(f, axis=0))
    assert np.abs(shape.integrate(f)).max() <= tol * max(scale, 1)
    torque = shape.integrate(np.cross(shape.x, f, axis=0))
    assert np.abs(torque).max() <= tol * max(scale, 1)


def test_aliasing_decreases_with_grid(perturbed):
    base, _ = perturbed
    net = [
        np.abs(base.with_grid(n).integrate(bending_force(base.with_grid(n)))).max()
        for n in (24, 32, 48)
    ]
    assert net[1] < 1e-2 * net[0] and net[2] < 1e-2 * net[1]


def test_uniform_tension_on_sphere_is_pressure():
    s = vs.Shape.sphere(2.0, grid=16)
    f = tension_force(s, 3.0)
    np.testing.assert_allclose(f, 2 * 3.0 / 2.0 * s.normal, atol=1e-13)  # -2 H sigma n, H = -1/2
