"""Spherical-harmonic toolkit: transforms, derivatives, rotations against references."""

import ducc0
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vesicle.sphere.grid import SphereGrid
from vesicle.sphere.legendre import legendre_reference, legendre_table
from vesicle.sphere.rotation import (
    euler_zyz,
    rotate_coefficients,
    rotated_angles,
    rotation_matrix,
    y_rotation,
)
from vesicle.sphere.transforms import (
    SHTransform,
    analysis_reference,
    evaluate,
    mode_energy,
    synthesis_reference,
    transform,
)


def random_coefficients(rng, lmax, batch=()):
    c = rng.standard_normal((*batch, lmax + 1, lmax + 1)) + 1j * rng.standard_normal(
        (*batch, lmax + 1, lmax + 1)
    )
    c = np.tril(c)
    c[..., 0] = c[..., 0].real
    return c


def test_grid_quadrature_integrates_polynomials_exactly():
    g = SphereGrid(10)
    assert g.shape == (10, 20)
    assert g.weights.sum() == pytest.approx(4 * np.pi, rel=1e-14)
    th, ph = g.meshgrid()
    x, z = np.sin(th) * np.cos(ph), np.cos(th)
    # int x^2 z^4 dOmega = 4 pi * 3 / 105 (degree 6 <= 2 n_theta - 1)
    assert np.sum(g.weights * x**2 * z**4) == pytest.approx(4 * np.pi / 35, rel=1e-14)


@pytest.mark.parametrize("bad", [0, 1, -3, 2.5, True, "8"])
def test_grid_rejects_bad_sizes(bad):
    with pytest.raises(ValueError, match="n_theta"):
        SphereGrid(bad)


def test_legendre_table_matches_scipy():
    theta = np.linspace(0.05, np.pi - 0.05, 17)
    (P,) = legendre_table(12, theta)
    for l in range(13):
        for m in range(l + 1):
            np.testing.assert_allclose(P[:, m, l], legendre_reference(l, m, theta), atol=1e-13)
    # normalisation int_{-1}^{1} Pbar^2 dx = 1
    x, w = np.polynomial.legendre.leggauss(20)
    (P,) = legendre_table(12, np.arccos(x))
    np.testing.assert_allclose(
        np.einsum("i,iml,iml->ml", w, P, P)[np.tril_indices(13)[::-1]], 1.0, atol=1e-13
    )


def test_transform_matches_reference_and_round_trips():
    rng = np.random.default_rng(0)
    g = SphereGrid(12)
    T = transform(12)
    c = random_coefficients(rng, 11)
    f = T.synthesis(c)
    np.testing.assert_allclose(f, synthesis_reference(g, c), atol=1e-12)
    np.testing.assert_allclose(T.analysis(f), c, atol=1e-13)
    np.testing.assert_allclose(analysis_reference(g, f, 11), c, atol=1e-13)


def test_batched_transform_equals_per_field_loop():
    rng = np.random.default_rng(1)
    T = transform(16, 10)
    c = random_coefficients(rng, 10, batch=(3, 4))
    f = T.synthesis(c)
    assert f.shape == (3, 4, 16, 32)
    for i in range(3):
        for j in range(4):
            np.testing.assert_allclose(f[i, j], T.synthesis(c[i, j]), atol=1e-13)
    np.testing.assert_allclose(T.analysis(f), c, atol=1e-13)


def test_transform_rejects_degree_beyond_grid():
    with pytest.raises(ValueError, match="n_theta >= 13"):
        SHTransform(SphereGrid(8), 12)


def polynomial_and_derivatives(th, ph):
    """f = x^2 y z + z^3 - x y on the unit sphere (degree 4) and its exact derivatives."""
    st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    # by hand: A = st^3 ct, B = cp^2 sp, C = ct^3, D = st^2, E = cp sp
    A, At = st**3 * ct, 3 * st**2 * ct**2 - st**4
    Att = 6 * st * ct**3 - 6 * st**3 * ct - 4 * st**3 * ct
    B, Bp = cp**2 * sp, -2 * cp * sp**2 + cp**3
    Bpp = 2 * sp**3 - 4 * cp**2 * sp - 3 * cp**2 * sp
    C, Ct, Ctt = ct**3, -3 * ct**2 * st, 6 * ct * st**2 - 3 * ct**3
    D, Dt, Dtt = st**2, 2 * st * ct, 2 * ct**2 - 2 * st**2
    E, Ep, Epp = cp * sp, cp**2 - sp**2, -4 * cp * sp
    return {
        "f": A * B + C - D * E,
        "t": At * B + Ct - Dt * E,
        "p": A * Bp - D * Ep,
        "tt": Att * B + Ctt - Dtt * E,
        "tp": At * Bp - Dt * Ep,
        "pp": A * Bpp - D * Epp,
    }


@pytest.mark.parametrize("n", [8, 16, 32])
def test_spectral_derivatives_exact_for_band_limited_fields(n):
    g = SphereGrid(n)
    exact = polynomial_and_derivatives(*g.meshgrid())
    T = transform(n)
    d = T.derivatives(T.analysis(exact["f"]))
    for key, value in exact.items():
        np.testing.assert_allclose(getattr(d, key), value, atol=5e-13 * n, err_msg=key)


def test_filter_and_mode_energy():
    rng = np.random.default_rng(2)
    T = transform(16)
    c = random_coefficients(rng, 15)
    low = T.filter(T.synthesis(c), degree=5)
    c_low = T.analysis(low)
    np.testing.assert_allclose(c_low[:6, :6], c[:6, :6], atol=1e-13)
    assert np.abs(c_low[6:]).max() < 1e-13
    E = mode_energy(c)
    assert E[3] == pytest.approx(abs(c[3, 0]) ** 2 + 2 * np.sum(abs(c[3, 1:4]) ** 2))
    # Parseval with the SPEC normalisation: int f^2 dOmega = 2 pi sum_l E_l
    g = SphereGrid(16)
    assert np.sum(g.weights * T.synthesis(c) ** 2) == pytest.approx(2 * np.pi * E.sum(), rel=1e-12)


def test_evaluate_at_arbitrary_points():
    rng = np.random.default_rng(3)
    c = random_coefficients(rng, 9)
    g = SphereGrid(10)
    np.testing.assert_allclose(
        evaluate(c, *g.meshgrid()), transform(10, 9).synthesis(c), atol=1e-12
    )


def test_euler_angles_round_trip():
    for seed in range(5):
        R = Rotation.random(random_state=seed).as_matrix()
        a, b, c = euler_zyz(R)
        R2 = rotation_matrix("z", a) @ rotation_matrix("y", b) @ rotation_matrix("z", c)
        np.testing.assert_allclose(R2, R, atol=1e-12)
    for R in (np.eye(3), rotation_matrix("y", np.pi) @ rotation_matrix("z", 0.3)):
        a, b, c = euler_zyz(R)
        R2 = rotation_matrix("z", a) @ rotation_matrix("y", b) @ rotation_matrix("z", c)
        np.testing.assert_allclose(R2, R, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wigner_rotation_equals_direct_evaluation(seed):
    rng = np.random.default_rng(seed)
    L = 24
    c = random_coefficients(rng, L) / (1.0 + np.arange(L + 1))[:, None]
    R = Rotation.random(random_state=seed).as_matrix()
    c_rot = rotate_coefficients(c, R)
    th, ph = rng.uniform(0, np.pi, 200), rng.uniform(0, 2 * np.pi, 200)
    direct = evaluate(c, *rotated_angles(R, th, ph))
    scale = np.abs(direct).max()
    np.testing.assert_allclose(evaluate(c_rot, th, ph), direct, atol=1e-12 * scale)


def _healpy_order(c):
    L = c.shape[0] - 1
    return np.array(
        [np.sqrt(2 * np.pi) * (-1) ** m * c[l, m] for m in range(L + 1) for l in range(m, L + 1)]
    )


def test_wigner_rotation_agrees_with_ducc0():
    """An independent implementation: ducc0.sht.rotate_alm in the healpy convention."""
    rng = np.random.default_rng(4)
    L = 16
    c = random_coefficients(rng, L)
    R = Rotation.random(random_state=9).as_matrix()
    a, b, g = euler_zyz(R)
    # ducc0 rotates the field actively by Rz(phi) Ry(theta) Rz(psi); our pull-back by
    # R = Rz(a) Ry(b) Rz(g) is the active rotation by R^-1 = Rz(-g) Ry(-b) Rz(-a).
    ref = ducc0.sht.rotate_alm(_healpy_order(c), L, -a, -b, -g)
    np.testing.assert_allclose(_healpy_order(rotate_coefficients(c, R)), ref, atol=1e-12)


def test_y_rotation_is_orthogonal_and_composes():
    L = 10
    D1, D2, D3 = y_rotation(0.3, L), y_rotation(0.5, L), y_rotation(0.8, L)
    rng = np.random.default_rng(5)
    c = random_coefficients(rng, L)
    np.testing.assert_allclose(D2.apply(D1.apply(c)), D3.apply(c), atol=1e-13)
    # rotations preserve the modal energy
    np.testing.assert_allclose(mode_energy(D1.apply(c)), mode_energy(c), rtol=1e-12)


def test_rotate_coefficients_rejects_non_rotations():
    with pytest.raises(ValueError, match="rotation"):
        rotate_coefficients(np.zeros((3, 3), complex), np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="rotation"):
        rotate_coefficients(np.zeros((3, 3), complex), np.ones((3, 3)))


@pytest.mark.parametrize("lmax", [6, 23])
def test_fast_y_rotation_equals_quadrature_reference(lmax):
    from vesicle.sphere.rotation import y_rotation_quadrature

    for beta in (0.2, 1.3, 2.8, -0.9):
        fast, ref = y_rotation(beta, lmax), y_rotation_quadrature(beta, lmax)
        np.testing.assert_allclose(fast.plus, ref.plus, atol=1e-13)
        np.testing.assert_allclose(fast.minus, ref.minus, atol=1e-13)
