"""Layer potentials: sphere eigenvalues, identities, reference, invariance (SPEC §5, §15)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import vesicle as vs
from vesicle.sphere.transforms import evaluate, transform
from vesicle.stokes import LayerPotentials
from vesicle.stokes.reference import layer_potential_reference


def vector_harmonics(grid, degree, order):
    """``V, W, X`` built from the real part of ``Pbar_nm e^{i m phi}`` on the unit sphere."""
    n = grid.n_theta
    c = np.zeros((n, n), complex)
    c[degree, order] = 1.0
    d = transform(n).derivatives(c)
    e_r, e_t, e_p = grid.unit_vectors
    grad = d.t * e_t + d.p / np.sin(grid.theta)[:, None] * e_p
    return {
        "V": grad - (degree + 1) * d.f * e_r,
        "W": grad + degree * d.f * e_r,
        "X": np.cross(e_r, grad, axis=0),
    }


def sphere_eigenvalues(n):
    """``(N/8pi, K/8pi)`` eigenvalues of SPEC §15."""
    return {
        "V": (n / ((2 * n + 1) * (2 * n + 3)), 3 / (2 * (2 * n + 1) * (2 * n + 3))),
        "W": ((n + 1) / ((2 * n - 1) * (2 * n + 1)), -3 / (2 * (2 * n - 1) * (2 * n + 1))),
        "X": (1 / (2 * n + 1), -3 / (2 * (2 * n + 1))),
    }


@pytest.fixture(scope="module")
def sphere32():
    return LayerPotentials(vs.Shape.sphere(grid=32), method="assembled")


@pytest.mark.parametrize("degree", range(1, 11))
def test_sphere_eigenvalues(sphere32, degree):
    grid = sphere32.shape.grid
    for order in sorted({0, 1, degree // 2, degree}):
        fields = vector_harmonics(grid, degree, order)
        for name, (n_eig, k_eig) in sphere_eigenvalues(degree).items():
            F = fields[name]
            err_n = np.abs(sphere32.single_layer(F) / (8 * np.pi) - n_eig * F).max()
            err_k = np.abs(sphere32.double_layer(F) / (8 * np.pi) - k_eig * F).max()
            assert err_n <= 1e-10 and err_k <= 1e-10, (name, order, err_n, err_k)


def test_constant_and_normal_identities_on_sphere(sphere32):
    s = sphere32.shape
    c = np.array([0.3, -1.0, 2.0])
    const = np.broadcast_to(c[:, None, None], (3, *s.grid.shape))
    np.testing.assert_allclose(sphere32.single_layer(const), 16 * np.pi / 3 * const, atol=1e-11)
    np.testing.assert_allclose(sphere32.double_layer(s.normal), 4 * np.pi * s.normal, atol=1e-11)
    assert np.abs(sphere32.single_layer(s.normal)).max() < 1e-11


@pytest.mark.parametrize("method", ["assembled", "matrix-free"])
@pytest.mark.parametrize("kind", ["single", "double"])
def test_fast_paths_match_reference(method, kind):
    s = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=12, degree=8).perturbed(0.05, seed=2)
    rng = np.random.default_rng(0)
    f = transform(12).filter(rng.standard_normal((3, 12, 24)), 9)
    targets = [(0, 0), (3, 5), (6, 17), (11, 23), (5, 12)]
    fast = getattr(LayerPotentials(s, method=method), f"{kind}_layer")(f)
    ref = layer_potential_reference(s, f, kind, targets)
    got = np.array([fast[:, i, k] for i, k in targets]).T
    np.testing.assert_allclose(got, ref, atol=1e-12 * np.abs(ref).max())


def identity_errors(shape, n_rot=None):
    """Quadrature errors of K[c] = -4 pi c and N[n] = 0 (geometry exact at the rotated nodes)."""
    lp = LayerPotentials(shape, n_rot=n_rot, method="matrix-free")
    c = np.array([1.0, -0.5, 0.25])
    k_err = np.abs(lp.double_layer_of_constant(c) + 4 * np.pi * c[:, None, None]).max()
    n_err = np.abs(lp.single_layer_of_normal()).max()
    return k_err, n_err


def test_grid_sampled_normal_is_limited_by_its_representation():
    """N[n] with n sampled on the grid: error = interpolation error of n, falling with the grid."""
    errs = [
        np.abs(vs.single_layer(s, s.normal)).max()
        for s in (SHAPES["ellipsoid"](n) for n in (24, 32))
    ]
    assert errs[1] < 0.1 * errs[0] and errs[1] < 1e-7, errs


SHAPES = {
    "ellipsoid": lambda n: vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=n),
    "perturbed": lambda n: (
        vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=32, degree=8).perturbed(0.05, seed=4).with_grid(n)
    ),
}


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_identities_converge_spectrally(name):
    errors = {n: identity_errors(SHAPES[name](n)) for n in (12, 16, 24, 32)}
    for j in range(2):
        e = [errors[n][j] for n in (12, 16, 24, 32)]
        assert e[3] <= 1e-8, e  # K[c] = -4 pi c and N[n] = 0 at 32 x 64
        assert e[2] < 0.1 * e[0], e  # geometric decay with grid size


def test_rotated_grid_size_converges():
    shape = SHAPES["perturbed"](24)
    errs = [identity_errors(shape, n_rot)[0] for n_rot in (12, 18, 24, 32)]
    assert errs[-1] < 1e-3 * errs[0] and errs[-1] < 1e-7, errs


@pytest.mark.parametrize(("n", "tol"), [(16, 1e-4), (32, 1e-8)])
def test_independent_of_parameterisation(n, tol):
    """Rotate the shape in space; the same physical density gives the rotated velocity.

    The comparison interpolates one result spectrally, so it is limited by the grid's resolution
    of the velocity field; the tolerance tightens with the grid.
    """
    s = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=32, degree=6).perturbed(0.03, seed=1).with_grid(n)
    R = Rotation.random(random_state=5).as_matrix()
    s2 = s.rotated(R)

    def density(x):  # a smooth physical field: f(x) = A x + b x_0^2
        A = np.array([[0.2, 1.0, 0.0], [-0.3, 0.1, 0.5], [0.4, 0.0, -0.3]])
        return (
            np.einsum("ij,j...->i...", A, x) + np.array([1.0, 0.0, -1.0])[:, None, None] * x[0] ** 2
        )

    u1 = LayerPotentials(s).single_layer(density(s.x))
    # s2's density at x' is R f(R^T x')
    x_back = np.einsum("ji,j...->i...", R, s2.x)
    f2 = np.einsum("ij,j...->i...", R, density(x_back))
    u2 = LayerPotentials(s2).single_layer(f2)
    # compare at the same physical points: s2's nodes pulled back to s's parameter sphere
    d_back = np.einsum("ji,j...->i...", R, s2.grid.unit_vectors[0])
    th = np.arctan2(np.hypot(d_back[0], d_back[1]), d_back[2])
    ph = np.arctan2(d_back[1], d_back[0])
    u1_at = evaluate(transform(n).analysis(u1), th, ph)
    np.testing.assert_allclose(
        u2, np.einsum("ij,j...->i...", R, u1_at), atol=tol * np.abs(u2).max()
    )


def test_linear_operators_and_bad_input():
    lp = LayerPotentials(vs.Shape.sphere(grid=8), method="matrix-free")
    op = lp.single_operator()
    v = np.random.default_rng(1).standard_normal(op.shape[1])
    np.testing.assert_allclose(op @ v, lp.single_layer(v.reshape(3, 8, 16)).ravel())
    with pytest.raises(ValueError, match="density must have shape"):
        lp.double_layer(np.zeros((3, 8, 8)))
    with pytest.raises(ValueError, match="method"):
        LayerPotentials(vs.Shape.sphere(grid=8), method="fmm")
    with pytest.raises(ValueError, match="kernels"):
        LayerPotentials(vs.Shape.sphere(grid=8), kernels=("triple",))


@pytest.mark.parametrize("kernels", [("single", "double"), ("single",), ("double",)])
def test_fused_kernel_matches_numpy_reference(kernels):
    """The compiled assembly kernel builds the NumPy reference's matrices to rounding."""
    shape = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=12, degree=8).perturbed(0.05, seed=3)
    fast = LayerPotentials(shape, kernels=kernels, backend="numba")
    ref = LayerPotentials(shape, kernels=kernels, backend="numpy")
    for kind in kernels:
        a, b = fast._matrix(kind), ref._matrix(kind)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * np.abs(b).max())
    if "double" in kernels:
        d_fast, d_ref = fast.double_matrix[1], ref.double_matrix[1]
        np.testing.assert_allclose(d_fast, d_ref, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="backend"):
        LayerPotentials(shape, backend="fortran")


def test_assembling_one_kernel_at_a_time_gives_the_same_operators():
    """lam = 1 needs only the single layer; the double layer, if asked for later, is built alone."""
    shape = vs.Shape.ellipsoid(1.2, 0.9, 0.8, grid=10)
    both = LayerPotentials(shape)
    one = LayerPotentials(shape, kernels=("single",))
    f = np.random.default_rng(2).standard_normal((3, 10, 20))
    np.testing.assert_array_equal(one.single_layer(f), both.single_layer(f))
    assert "double" not in one._assembled and "double" in both._assembled
    np.testing.assert_array_equal(one.double_layer(f), both.double_layer(f))


def test_public_functions():
    s = vs.Shape.sphere(grid=12)
    c = np.broadcast_to(np.array([1.0, 2.0, 3.0])[:, None, None], (3, 12, 24))
    np.testing.assert_allclose(vs.single_layer(s, c), 16 * np.pi / 3 * c, atol=1e-10)
    np.testing.assert_allclose(vs.double_layer(s, c), -4 * np.pi * c, atol=1e-12)


def test_off_surface_evaluation_jump_relations_and_accuracy():
    from vesicle.stokes.evaluation import evaluate_double_layer, evaluate_single_layer

    s = vs.Shape.sphere(grid=32)
    c = np.array([1.0, 2.0, 3.0])
    const = np.broadcast_to(c[:, None, None], (3, *s.grid.shape))
    dirs = np.random.default_rng(0).standard_normal((3, 40))
    dirs /= np.linalg.norm(dirs, axis=0)
    outside = evaluate_double_layer(s, const, 1.3 * dirs)
    inside = evaluate_double_layer(s, const, 0.7 * dirs)
    assert np.abs(outside).max() < 1e-9
    assert np.abs(inside + 8 * np.pi * c[:, None]).max() < 1e-9
    assert np.abs(evaluate_single_layer(s, s.normal, 1.3 * dirs)).max() < 1e-9
    # near the surface the smooth rule degrades; upsampling recovers it
    near = [
        np.abs(evaluate_double_layer(s, const, 1.1 * dirs, upsample=u)).max() for u in (1, 2, 4)
    ]
    assert near[2] < 1e-6 < near[0] and near[1] < near[0]
    # uniform density on the unit sphere: exactly 4 pi (G + Lap G / 6) c outside
    x = np.array([[3.0], [-1.0], [2.0]])
    r = np.linalg.norm(x)
    G = np.eye(3) / r + x @ x.T / r**3
    lap_G = 2 * np.eye(3) / r**3 - 6 * x @ x.T / r**5
    exact = 4 * np.pi * (G + lap_G / 6) @ c
    np.testing.assert_allclose(evaluate_single_layer(s, const, x)[:, 0], exact, rtol=1e-12)


@pytest.mark.parametrize("n_theta, n_rot", [(16, 16), (16, 8), (24, 12), (32, 32)])
def test_pull_back_dft_product_matches_the_fft_reference(n_theta, n_rot):
    """The pull-back's phi' transform as one real DFT product (the default) against the FFT of
    every column (the reference path), including grids where the orders alias (n_rot = 8 at
    16x32: lmax + 1 = 16 > n_rot_phi / 2 + 1 = 9)."""
    from vesicle.stokes import singular_quadrature

    q = singular_quadrature(n_theta, n_rot)
    v = np.random.default_rng(n_rot).standard_normal((q.n_nodes, 6, 2 * n_theta))
    for i in (0, n_theta // 2):
        fast, ref = q.pull_back_unphased(i, v, "gemm"), q.pull_back_unphased(i, v, "fft")
        for a, b in zip(fast, ref, strict=True):
            assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(b))
    with pytest.raises(ValueError, match="gemm"):
        q.pull_back_unphased(0, v, "dft")


def test_assembly_in_threads_matches_one_thread():
    """Rings assembled in two threads (each with its own pull-back scratch arrays) give the
    one-thread operators exactly, and a later build on another grid in the same thread (scratch
    of another size) still matches the NumPy reference."""
    shape = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=12, degree=6).perturbed(0.05, seed=5)
    one = LayerPotentials(shape, workers=1)
    two = LayerPotentials(shape, workers=2)
    for kind in ("single", "double"):
        np.testing.assert_array_equal(two._matrix(kind), one._matrix(kind))
    other = vs.Shape.ellipsoid(1.2, 1.0, 0.8, grid=10, degree=6)
    fast, ref = LayerPotentials(other, workers=1), LayerPotentials(other, backend="numpy")
    b = ref._matrix("single")
    np.testing.assert_allclose(fast._matrix("single"), b, rtol=0, atol=1e-13 * np.abs(b).max())
