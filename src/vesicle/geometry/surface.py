"""A closed star-shaped surface given by a spherical-harmonic radius, and its geometry (SPEC §2-3).

``x(theta, phi) = r(theta, phi) e_r`` with ``r`` a series of degree ``N`` (the shape's
*degree*), sampled on a Gauss–Legendre x uniform grid (the shape's *grid*).  All geometric
quantities are computed on that grid, with derivatives taken spectrally.

Conventions (tensor notation, ``xi^1 = theta``, ``xi^2 = phi``): outward normal
``n = a_1 x a_2 / |a_1 x a_2|``, curvature tensor ``b_ab = x_ab . n``, mean curvature
``H = g^ab b_ab / 2`` and Gaussian curvature ``K = det b / det g``; a sphere of radius ``R`` has
``H = -1/R`` and ``K = 1/R^2``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipeinc, ellipkinc

from vesicle.sphere.grid import SphereGrid, spherical_basis
from vesicle.sphere.rotation import rotate_coefficients
from vesicle.sphere.transforms import Derivatives, evaluate, mode_energy, resize, transform

__all__ = ["Geometry", "Shape", "ShapeError"]

#: Radii accepted (units of the vesicle size): squares and products of curvatures must stay finite.
RADIUS_RANGE = (1e-30, 1e30)


class ShapeError(ValueError):
    """A shape the radial representation cannot hold, or inconsistent shape input."""


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("i...,i...->...", a, b)


@dataclass(frozen=True, eq=False)
class Geometry:
    """Differential geometry of a shape on its grid; vectors have a leading axis of length 3."""

    x: np.ndarray
    tangents: tuple[np.ndarray, np.ndarray]  # a_theta, a_phi
    second: tuple[np.ndarray, np.ndarray, np.ndarray]  # x_tt, x_tp, x_pp
    normal: np.ndarray
    sqrt_g: np.ndarray
    metric: np.ndarray  # (2, 2, n_theta, n_phi): g_ab
    inverse_metric: np.ndarray  # g^ab
    curvature_tensor: np.ndarray  # b_ab
    mean_curvature: np.ndarray
    gaussian_curvature: np.ndarray
    area_element: np.ndarray  # J = sqrt(g)/sin(theta): dA = J dOmega

    @cached_property
    def dual_tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Contravariant tangents ``a^b = g^ab a_a``."""
        gi = self.inverse_metric
        at, ap = self.tangents
        return gi[0, 0] * at + gi[0, 1] * ap, gi[1, 0] * at + gi[1, 1] * ap

    @cached_property
    def christoffel(self) -> np.ndarray:
        """``Gamma^c_ab = a^c . x_ab`` as an array (c, a, b, n_theta, n_phi)."""
        xtt, xtp, xpp = self.second
        xab = [[xtt, xtp], [xtp, xpp]]
        return np.array(
            [
                [[_dot(dual, xab[a][b]) for b in range(2)] for a in range(2)]
                for dual in self.dual_tangents
            ]
        )


class Shape:
    """A closed surface ``x = r(theta, phi) e_r`` with ``r`` a degree-``N`` harmonic series.

    Parameters
    ----------
    coefficients : complex array (N+1, N+1)
        Radius coefficients ``r_lm`` indexed ``[l, m]`` (``m >= 0``), normalisation of SPEC §2.
    grid : int or SphereGrid
        ``n_theta`` of the Gauss–Legendre grid (``n_phi = 2 n_theta``); must exceed ``N``.

    Raises
    ------
    ShapeError
        Non-finite coefficients, a degree the grid cannot resolve, or a radius that is not
        positive everywhere (the radial representation cannot hold such a shape).
    """

    def __init__(self, coefficients: np.ndarray, grid: int | SphereGrid = 32):
        grid = grid if isinstance(grid, SphereGrid) else _make_grid(grid)
        c = np.array(coefficients, dtype=np.complex128)
        if c.ndim != 2 or c.shape[0] != c.shape[1] or c.shape[0] < 1:
            raise ShapeError(f"coefficients must be a square (N+1, N+1) array, got {c.shape}")
        if not np.all(np.isfinite(c)):
            raise ShapeError("radius coefficients contain NaN or infinity")
        degree = c.shape[0] - 1
        if degree > grid.max_degree:
            raise ShapeError(
                f"degree N = {degree} is too high for a grid of n_theta = {grid.n_theta}: "
                f"the grid resolves degree <= {grid.max_degree} (use n_theta >= {degree + 1})"
            )
        c = np.tril(c)
        c[:, 0] = c[:, 0].real
        c.setflags(write=False)
        self.coefficients = c
        self.grid = grid
        self._check_radius()

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_coefficients(cls, coefficients: np.ndarray, grid: int | SphereGrid = 32) -> Shape:
        """A shape from radius coefficients (SPEC §2 normalisation)."""
        return cls(coefficients, grid)

    @classmethod
    def from_radius(cls, radius, grid: int | SphereGrid = 32, degree: int | None = None) -> Shape:
        """Project a radius function ``radius(theta, phi)`` (or grid values) onto degree ``N``.

        ``degree`` defaults to the highest degree the grid holds.
        """
        grid = grid if isinstance(grid, SphereGrid) else _make_grid(grid)
        degree = grid.max_degree if degree is None else _check_degree(degree)
        values = radius(*grid.meshgrid()) if callable(radius) else np.asarray(radius, float)
        if values.shape != grid.shape:
            raise ShapeError(f"radius values must have the grid shape {grid.shape}")
        if not np.all(np.isfinite(values)):
            raise ShapeError("radius values contain NaN or infinity")
        if degree > grid.max_degree:
            raise ShapeError(
                f"degree N = {degree} is too high for a grid of n_theta = {grid.n_theta} "
                f"(use n_theta >= {degree + 1})"
            )
        return cls(transform(grid.n_theta, degree).analysis(values), grid)

    @classmethod
    def sphere(cls, radius: float = 1.0, grid: int | SphereGrid = 32, degree: int = 0) -> Shape:
        """A sphere of the given radius centred at the origin."""
        radius = _positive("radius", radius)
        c = np.zeros((degree + 1, degree + 1), dtype=complex)
        c[0, 0] = radius * np.sqrt(2.0)  # Pbar_00 = 1/sqrt(2)
        return cls(c, grid)

    @classmethod
    def ellipsoid(
        cls,
        a: float,
        b: float,
        c: float,
        grid: int | SphereGrid = 32,
        degree: int | None = None,
        rotation: np.ndarray | None = None,
    ) -> Shape:
        """An ellipsoid with semi-axes ``a, b, c`` along x, y, z, optionally rotated.

        ``rotation`` is a 3x3 matrix taking the body axes to the lab frame.
        """
        axes = np.array([_positive(n, v) for n, v in zip("abc", (a, b, c), strict=True)])
        Q = np.eye(3) if rotation is None else _rotation(rotation)
        return cls.from_radius(lambda t, p: _ellipsoid_radius(axes, Q, t, p), grid, degree)

    @classmethod
    def spheroid(cls, v: float, grid: int | SphereGrid = 32, degree: int | None = None) -> Shape:
        """The prolate spheroid (long axis along x) of reduced volume ``v`` and area ``4 pi``.

        The area is exactly ``4 pi`` on the discrete representation; the reduced volume is ``v``
        up to the representation error of the spheroid at this degree and grid.
        """
        a, b = spheroid_axes(v)
        return cls.ellipsoid(a, b, b, grid=grid, degree=degree).scaled_to_area()

    # --------------------------------------------------------------- variations
    @property
    def degree(self) -> int:
        return self.coefficients.shape[0] - 1

    def with_grid(self, grid: int | SphereGrid) -> Shape:
        """The same coefficients on another grid."""
        return Shape(self.coefficients, grid)

    def with_degree(self, degree: int) -> Shape:
        """Truncate (filter) or zero-pad the radius series to ``degree``."""
        return Shape(resize(self.coefficients, _check_degree(degree)), self.grid)

    def scaled(self, factor: float) -> Shape:
        return Shape(self.coefficients * _positive("factor", factor), self.grid)

    def scaled_to_area(self, area: float = 4.0 * np.pi) -> Shape:
        """Rescale so that the area is ``area`` (default ``4 pi``, the unit of length)."""
        return self.scaled(np.sqrt(_positive("area", area) / self.area))

    def perturbed(self, amplitude: float = 0.05, seed: int = 0, degree: int | None = None) -> Shape:
        """Add a reproducible random smooth perturbation of relative size ``amplitude``.

        Coefficients of degree ``1 <= l <= degree`` (default: this shape's degree, at least 2)
        are drawn from ``seed`` with a spectrum decaying like ``l^-2``, then scaled so the
        largest radius change on the grid is ``amplitude`` times the mean radius.
        """
        degree = max(self.degree, 2) if degree is None else _check_degree(degree)
        rng = np.random.default_rng(seed)
        d = rng.standard_normal((degree + 1, degree + 1)) + 1j * rng.standard_normal(
            (degree + 1, degree + 1)
        )
        d *= (1.0 + np.arange(degree + 1))[:, None] ** -2.0
        d = np.tril(d)
        d[0] = 0.0
        d[:, 0] = d[:, 0].real
        dr = transform(self.grid.n_theta, degree).synthesis(d)
        mean_r = abs(self.coefficients[0, 0]) / np.sqrt(2.0)
        d *= amplitude * mean_r / np.abs(dr).max()
        n = max(degree, self.degree)
        return Shape(resize(self.coefficients, n) + resize(d, n), self.grid)

    def rotated(self, R: np.ndarray) -> Shape:
        """The shape rotated in space by ``R`` (``x -> R x``)."""
        # The rotated surface has radius r(R^T y): an exact Wigner rotation of the coefficients.
        return Shape(rotate_coefficients(self.coefficients, _rotation(R).T), self.grid)

    def radius_at(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Evaluate the radius series at arbitrary angles."""
        return evaluate(self.coefficients, theta, phi)

    # ---------------------------------------------------------------- geometry
    @cached_property
    def radius(self) -> np.ndarray:
        return self.radius_derivatives.f

    @cached_property
    def radius_derivatives(self) -> Derivatives:
        """``r`` and its first and second theta/phi derivatives on the grid (exact, degree N)."""
        return transform(self.grid.n_theta, self.degree).derivatives(self.coefficients)

    @cached_property
    def geometry(self) -> Geometry:
        return compute_geometry(self.grid, self.radius_derivatives)

    @property
    def x(self) -> np.ndarray:
        """Positions on the grid, shape (3, n_theta, n_phi)."""
        return self.geometry.x

    @property
    def normal(self) -> np.ndarray:
        """Outward unit normal on the grid, shape (3, n_theta, n_phi)."""
        return self.geometry.normal

    @property
    def mean_curvature(self) -> np.ndarray:
        return self.geometry.mean_curvature

    @property
    def gaussian_curvature(self) -> np.ndarray:
        return self.geometry.gaussian_curvature

    @property
    def area_element(self) -> np.ndarray:
        """``J = sqrt(g) / sin(theta)``, so that ``dA = J dOmega``."""
        return self.geometry.area_element

    def integrate(self, f: np.ndarray) -> np.ndarray:
        """``int f dA`` over the surface for grid fields ``f`` (..., n_theta, n_phi)."""
        return np.sum(np.asarray(f) * (self.grid.weights * self.area_element), axis=(-2, -1))

    @cached_property
    def area(self) -> float:
        return float(self.integrate(np.ones(self.grid.shape)))

    @cached_property
    def volume(self) -> float:
        """``V = (1/3) int x . n dA``."""
        return float(self.integrate(_dot(self.x, self.normal)) / 3.0)

    @property
    def size(self) -> float:
        """``a = sqrt(A / 4 pi)``."""
        return float(np.sqrt(self.area / (4.0 * np.pi)))

    @property
    def reduced_volume(self) -> float:
        """``v = 3 V / (4 pi a^3)``."""
        return 3.0 * self.volume / (4.0 * np.pi * self.size**3)

    @property
    def excess_area(self) -> float:
        """``Delta = 4 pi (v^(-2/3) - 1)``."""
        return 4.0 * np.pi * (self.reduced_volume ** (-2.0 / 3.0) - 1.0)

    def bending_energy(self, kappa: float = 1.0) -> float:
        """Helfrich energy ``int 2 kappa H^2 dA`` (``8 pi kappa`` for a sphere)."""
        return float(2.0 * kappa * self.integrate(self.mean_curvature**2))

    @cached_property
    def centroid(self) -> np.ndarray:
        """Volume centroid ``x_c = (1/2V) int |x|^2 n dA``."""
        return self.integrate(_dot(self.x, self.x) * self.normal) / (2.0 * self.volume)

    def inertia_tensor(self, origin: np.ndarray | None = None) -> np.ndarray:
        """Surface inertia ``int (|x|^2 Id - x x^T) dA`` about ``origin`` (default: centroid)."""
        origin = self.centroid if origin is None else np.asarray(origin, float)
        y = self.x - origin[:, None, None]
        yy = np.einsum("i...,j...->ij...", y, y)
        return np.eye(3) * self.integrate(_dot(y, y)) - self.integrate(yy)

    def spectrum(self) -> np.ndarray:
        """Modal energy ``E_l(r)`` of the radius, ``l = 0..N`` (SPEC (3.5))."""
        return mode_energy(self.coefficients)

    # ---------------------------------------------------------- field calculus
    def field_derivatives(self, f: np.ndarray, noise_floor: float = 0.0) -> Derivatives:
        """Spectral derivatives of grid fields (..., n_theta, n_phi) at the grid's full degree.

        Coefficients smaller than ``noise_floor`` times the field's largest one are dropped
        (``0`` keeps all).
        """
        T = transform(self.grid.n_theta)
        c = T.analysis(f)
        if noise_floor > 0.0:
            big = np.abs(c).max(axis=(-2, -1), keepdims=True)
            c = np.where(np.abs(c) > noise_floor * big, c, 0.0)
        return T.derivatives(c)

    def filter_field(self, f: np.ndarray, degree: int) -> np.ndarray:
        """Project grid fields onto spherical harmonics of degree <= ``degree``."""
        return transform(self.grid.n_theta).filter(f, degree)

    def surface_gradient(self, s: np.ndarray) -> np.ndarray:
        """``grad_s s = g^ab (d_b s) a_a`` of a scalar grid field, shape (3, n_theta, n_phi)."""
        d = self.field_derivatives(s)
        at, ap = self.geometry.dual_tangents
        return at * d.t + ap * d.p

    def laplace_beltrami(self, s: np.ndarray, noise_floor: float = 0.0) -> np.ndarray:
        """``Lap_s s = g^ab (s_ab - Gamma^c_ab s_c)`` of a scalar grid field."""
        d = self.field_derivatives(s, noise_floor)
        gi, G = self.geometry.inverse_metric, self.geometry.christoffel
        grad = (d.t, d.p)
        hess = ((d.tt, d.tp), (d.tp, d.pp))
        out = np.zeros(self.grid.shape)
        for a in range(2):
            for b in range(2):
                out += gi[a, b] * (hess[a][b] - G[0, a, b] * grad[0] - G[1, a, b] * grad[1])
        return out

    def surface_divergence(self, u: np.ndarray) -> np.ndarray:
        """``div_s u = a^b . du/dxi^b`` of a vector grid field (3, n_theta, n_phi)."""
        d = self.field_derivatives(u)
        at, ap = self.geometry.dual_tangents
        return _dot(at, d.t) + _dot(ap, d.p)

    # -------------------------------------------------------------- validation
    def _check_radius(self) -> None:
        n_check = max(self.grid.n_theta, 2 * self.degree + 2)
        r = transform(n_check, self.degree).synthesis(self.coefficients)
        if not np.all(np.isfinite(r)) or r.max() > RADIUS_RANGE[1]:
            raise ShapeError(f"the radius exceeds {RADIUS_RANGE[1]:g}: not a usable shape")
        if r.min() <= 0.0:
            raise ShapeError(
                f"the radius goes non-positive (min {r.min():.3g}): the shape is not star-shaped "
                "about the origin, so the radial representation cannot hold it"
            )
        if r.min() < max(1e-3 * r.max(), RADIUS_RANGE[0]):
            raise ShapeError(
                f"the radius ranges over [{r.min():.3g}, {r.max():.3g}]: the shape nearly folds "
                "through the origin and the radial representation cannot resolve it"
            )

    def __repr__(self) -> str:
        return f"Shape(degree={self.degree}, grid={self.grid.n_theta}x{self.grid.n_phi})"


# ------------------------------------------------------------------- helpers
def compute_geometry(grid: SphereGrid, d: Derivatives) -> Geometry:
    """Geometry on the grid from the radius and its spectral derivatives."""
    e_r, e_t, e_p = grid.unit_vectors
    st = np.sin(grid.theta)[:, None]
    ct = np.cos(grid.theta)[:, None]
    r = d.f
    x = r * e_r
    xt = d.t * e_r + r * e_t
    xp = d.p * e_r + r * st * e_p
    xtt = (d.tt - r) * e_r + 2.0 * d.t * e_t
    xtp = d.tp * e_r + d.p * e_t + (d.t * st + r * ct) * e_p
    xpp = (d.pp - r * st * st) * e_r - r * st * ct * e_t + 2.0 * d.p * st * e_p
    cross = np.cross(xt, xp, axis=0)
    sqrt_g = np.sqrt(_dot(cross, cross))
    n = cross / sqrt_g
    g = np.array([[_dot(xt, xt), _dot(xt, xp)], [_dot(xt, xp), _dot(xp, xp)]])
    det = g[0, 0] * g[1, 1] - g[0, 1] ** 2
    gi = np.array([[g[1, 1], -g[0, 1]], [-g[0, 1], g[0, 0]]]) / det
    b = np.array([[_dot(xtt, n), _dot(xtp, n)], [_dot(xtp, n), _dot(xpp, n)]])
    H = 0.5 * np.einsum("ab...,ab...->...", gi, b)
    K = (b[0, 0] * b[1, 1] - b[0, 1] ** 2) / det
    return Geometry(
        x=x,
        tangents=(xt, xp),
        second=(xtt, xtp, xpp),
        normal=n,
        sqrt_g=sqrt_g,
        metric=g,
        inverse_metric=gi,
        curvature_tensor=b,
        mean_curvature=H,
        gaussian_curvature=K,
        area_element=sqrt_g / st,
    )


def spheroid_axes(v: float) -> tuple[float, float]:
    """Semi-axes ``(a, b)`` of the prolate spheroid with reduced volume ``v`` and area ``4 pi``."""
    v = _reduced_volume(v)
    if v == 1.0:
        return 1.0, 1.0

    def reduced(aspect: float) -> float:
        area, vol = _spheroid_area_volume(aspect, 1.0)
        return 3.0 * vol / (4.0 * np.pi * (area / (4.0 * np.pi)) ** 1.5) - v

    aspect = brentq(reduced, 1.0 + 1e-12, 1e3, xtol=1e-15, rtol=1e-15)
    area, _ = _spheroid_area_volume(aspect, 1.0)
    b = np.sqrt(4.0 * np.pi / area)
    return aspect * b, b


def _spheroid_area_volume(a: float, b: float) -> tuple[float, float]:
    """Area and volume of the prolate spheroid with semi-axes ``a >= b = c``."""
    if a == b:
        return 4.0 * np.pi * a * a, 4.0 * np.pi * a**3 / 3.0
    e = np.sqrt(1.0 - (b / a) ** 2)
    return 2.0 * np.pi * b * b * (1.0 + a / (b * e) * np.arcsin(e)), 4.0 * np.pi * a * b * b / 3.0


def ellipsoid_area(a: float, b: float, c: float) -> float:
    """Exact ellipsoid area from incomplete elliptic integrals (Legendre's formula)."""
    a, b, c = sorted((a, b, c), reverse=True)
    if np.isclose(a, c, rtol=0, atol=1e-15):
        return 4.0 * np.pi * a * a
    phi = np.arccos(c / a)
    m = (a * a * (b * b - c * c)) / (b * b * (a * a - c * c))
    s = np.sin(phi)
    return float(
        2.0 * np.pi * c * c
        + 2.0
        * np.pi
        * a
        * b
        / s
        * (ellipeinc(phi, m) * s * s + ellipkinc(phi, m) * np.cos(phi) ** 2)
    )


def ellipsoid_curvatures(axes, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact ``(H, K)`` of the axis-aligned ellipsoid at surface points ``x`` (3, ...)."""
    a2 = np.asarray(axes, float)[:, None] ** 2
    xf = x.reshape(3, -1)
    S = np.sum(xf**2 / a2**2, axis=0)
    p = np.prod(a2)
    K = 1.0 / (p * S**2)
    H = (np.sum(xf**2, axis=0) - a2.sum()) / (2.0 * p * S**1.5)
    return H.reshape(x.shape[1:]), K.reshape(x.shape[1:])


def _ellipsoid_radius(axes: np.ndarray, Q: np.ndarray, theta, phi) -> np.ndarray:
    d = np.einsum("ji,j...->i...", Q, spherical_basis(theta, phi)[0])  # body frame
    return 1.0 / np.sqrt(np.sum(d**2 / axes[:, None, None] ** 2, axis=0))


def _make_grid(n) -> SphereGrid:
    try:
        return SphereGrid(n)
    except ValueError as err:
        raise ShapeError(str(err)) from None


def _check_degree(degree) -> int:
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 0:
        raise ShapeError(f"degree must be a non-negative integer, got {degree!r}")
    return int(degree)


def _positive(name: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ShapeError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(value) or value <= 0.0:
        raise ShapeError(f"{name} must be positive and finite, got {value}")
    return value


def _reduced_volume(v) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ShapeError(f"reduced volume v must be a number, got {v!r}") from None
    if not np.isfinite(v) or not 0.0 < v <= 1.0:
        raise ShapeError(f"reduced volume v must lie in (0, 1], got {v}")
    return v


def _rotation(R) -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ShapeError("rotation must be a finite 3x3 matrix")
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-10) or np.linalg.det(R) < 0:
        raise ShapeError("rotation must be a proper orthogonal matrix (R R^T = I, det R = +1)")
    return R
