"""Shape geometry against exact answers, with spectral convergence (SPEC §2-3)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import vesicle as vs
from vesicle.geometry.surface import ShapeError, ellipsoid_area, ellipsoid_curvatures, spheroid_axes

AXES = (1.3, 0.9, 0.8)
EXACT_VOLUME = 4 * np.pi * np.prod(AXES) / 3


def ellipsoid_errors(n):
    s = vs.Shape.ellipsoid(*AXES, grid=n)
    H, K = ellipsoid_curvatures(AXES, s.x)
    return {
        "H": np.abs(s.mean_curvature - H).max(),
        "K": np.abs(s.gaussian_curvature - K).max(),
        "area": abs(s.area / ellipsoid_area(*AXES) - 1),
        "volume": abs(s.volume / EXACT_VOLUME - 1),
    }


def test_public_api_shapes():
    s = vs.Shape.ellipsoid(*AXES, grid=32)
    assert s.x.shape == s.normal.shape == (3, 32, 64)
    assert s.degree == 31
    assert s.bending_energy() > 8 * np.pi
    assert 0 < s.reduced_volume < 1
    s2 = vs.Shape.sphere(grid=32)
    assert s2.reduced_volume == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("R", [1.0, 2.5])
def test_sphere_exact(R):
    s = vs.Shape.sphere(R, grid=32)
    np.testing.assert_allclose(s.mean_curvature, -1 / R, atol=1e-12)
    np.testing.assert_allclose(s.gaussian_curvature, 1 / R**2, atol=1e-12)
    np.testing.assert_allclose(s.normal, s.grid.unit_vectors[0], atol=1e-14)
    assert np.abs(vs.bending_force(s)).max() <= 1e-12
    assert s.bending_energy() == pytest.approx(8 * np.pi, abs=1e-12)
    assert s.area == pytest.approx(4 * np.pi * R**2, rel=1e-14)
    assert s.volume == pytest.approx(4 * np.pi * R**3 / 3, rel=1e-14)
    assert s.excess_area == pytest.approx(0.0, abs=1e-13)


def test_ellipsoid_converges_spectrally():
    errors = {n: ellipsoid_errors(n) for n in (16, 24, 32, 48)}
    for key in ("H", "K", "area"):
        e = [errors[n][key] for n in (16, 24, 32)]
        assert e[1] < 1e-2 * e[0] and e[2] < 1e-2 * e[1], (key, e)  # geometric decay
    assert errors[32]["area"] <= 1e-8 and errors[32]["volume"] <= 1e-8
    assert errors[32]["H"] <= 1e-7 and errors[32]["K"] <= 1e-7
    assert errors[48]["H"] <= 1e-9 and errors[48]["K"] <= 1e-8


def test_ellipsoid_bending_energy_converges():
    energies = {n: vs.Shape.ellipsoid(*AXES, grid=n).bending_energy() for n in (32, 48, 64)}
    ref = energies[64]
    assert abs(energies[32] - ref) / ref <= 1e-6
    assert abs(energies[48] - ref) / ref <= 1e-9


def test_gauss_bonnet_on_perturbed_shape():
    s = vs.Shape.ellipsoid(*AXES, grid=32, degree=8).perturbed(0.05, seed=3)
    assert s.integrate(s.gaussian_curvature) == pytest.approx(4 * np.pi, rel=1e-9)


def test_rotated_ellipsoid_matches_rotated_shape():
    R = Rotation.random(random_state=2).as_matrix()
    a = vs.Shape.ellipsoid(*AXES, grid=32, degree=12, rotation=R)
    b = vs.Shape.ellipsoid(*AXES, grid=32, degree=12).rotated(R)
    np.testing.assert_allclose(a.coefficients, b.coefficients, atol=1e-12)
    assert a.area == pytest.approx(b.area, rel=1e-12)
    evals = np.linalg.eigvalsh(a.inertia_tensor())
    np.testing.assert_allclose(evals, np.linalg.eigvalsh(b.inertia_tensor()), rtol=1e-10)


def test_centroid_and_inertia():
    s = vs.Shape.sphere(grid=16)
    shifted = vs.Shape.from_radius(
        lambda t, p: np.cos(t) * 0.1 + np.sqrt(1 - 0.01 * np.sin(t) ** 2), grid=32
    )  # unit sphere centred at (0, 0, 0.1)
    np.testing.assert_allclose(shifted.centroid, [0, 0, 0.1], atol=1e-10)
    np.testing.assert_allclose(s.inertia_tensor(), np.eye(3) * 8 * np.pi / 3, atol=1e-12)


@pytest.mark.parametrize(("v", "tol"), [(0.7, 1e-4), (0.8, 1e-6), (0.95, 1e-9), (1.0, 1e-14)])
def test_spheroid_of_reduced_volume(v, tol):
    s = vs.Shape.spheroid(v, grid=32)
    assert s.area == pytest.approx(4 * np.pi, rel=1e-13)
    assert s.reduced_volume == pytest.approx(v, rel=tol)
    assert vs.Shape.spheroid(v, grid=48).reduced_volume == pytest.approx(v, rel=tol * 1e-2)
    a, b = spheroid_axes(v)
    assert a >= b
    I = np.diag(s.inertia_tensor())
    assert I[0] <= I[1] + 1e-12  # long axis along x


def test_perturbation_is_reproducible():
    base = vs.Shape.spheroid(0.9, grid=24, degree=8)
    p1, p2 = base.perturbed(0.05, seed=7), base.perturbed(0.05, seed=7)
    np.testing.assert_array_equal(p1.coefficients, p2.coefficients)
    assert not np.allclose(p1.coefficients, base.perturbed(0.05, seed=8).coefficients)
    dr = np.abs(p1.radius - base.radius).max()
    assert dr == pytest.approx(0.05 * abs(base.coefficients[0, 0]) / np.sqrt(2), rel=1e-12)


def test_laplace_beltrami_of_coordinates_gives_mean_curvature_normal():
    # Lap_s x = 2 H n on any surface
    s = vs.Shape.ellipsoid(*AXES, grid=48, degree=24).perturbed(0.03, seed=1)
    lap = np.array([s.laplace_beltrami(s.x[i]) for i in range(3)])
    np.testing.assert_allclose(lap, 2 * s.mean_curvature * s.normal, atol=1e-7)
    # div_s of the identity map is 2
    np.testing.assert_allclose(s.surface_divergence(s.x), 2.0, atol=1e-9)


# ----------------------------------------------------------------- bad input
def test_degree_the_grid_cannot_resolve():
    with pytest.raises(ShapeError, match="too high"):
        vs.Shape.ellipsoid(*AXES, grid=8, degree=8)
    with pytest.raises(ShapeError, match="too high"):
        vs.Shape(np.zeros((20, 20)), grid=16)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf, "x"])
def test_bad_semi_axes(bad):
    with pytest.raises(ShapeError, match=r"positive|number"):
        vs.Shape.ellipsoid(1.0, bad, 1.0, grid=16)


def test_non_positive_radius_refused():
    c = np.zeros((3, 3), complex)
    c[0, 0] = np.sqrt(2) * 0.3
    c[1, 0] = 1.0  # r = 0.3 + sqrt(3/2) cos(theta) goes negative
    with pytest.raises(ShapeError, match="non-positive"):
        vs.Shape.from_coefficients(c, grid=16)


@given(st.floats(allow_nan=True, allow_infinity=True).filter(lambda v: not 0 < v <= 1))
def test_reduced_volume_outside_range_refused(v):
    with pytest.raises(ShapeError, match="reduced volume"):
        vs.Shape.spheroid(v, grid=8)


@given(st.lists(st.floats(allow_nan=True), min_size=4, max_size=4))
def test_random_coefficients_are_accepted_or_refused_clearly(vals):
    c = np.zeros((2, 2), complex)
    c[0, 0], c[1, 0], c[1, 1] = vals[0], vals[1], vals[2] + 1j * vals[3]
    try:
        s = vs.Shape.from_coefficients(c, grid=8)
    except ShapeError:
        return
    assert s.radius.min() > 0 and np.isfinite(s.area)
