"""Single- and double-layer Stokes potentials on a shape's grid (SPEC §5, §15).

``N[psi](x0) = int G(x - x0) psi(x) dA`` and the principal-value
``K[psi](x0) = int psi_i T_ijk(x - x0) n_k dA``, normalised without ``1/8 pi``.

Two strategies share one definition (the rotated-grid quadrature of :mod:`.quadrature`):

``"matrix-free"``
    the geometry is rotated once per shape; each apply rotates the density to every target.
``"assembled"``
    each operator is assembled once per shape as a dense matrix from the density's
    spherical-harmonic coefficients to the grid values (the adjoint of the rotation chain applied
    to the weighted kernels); each apply is a transform and one matrix-vector product.

The double layer uses singularity subtraction, ``K[u](x0) = int T n (u - u(x0)) dA - 4 pi u(x0)``,
which relies on ``K[c] = -4 pi c`` on closed surfaces; the raw quadrature of that identity is
available as :meth:`LayerPotentials.double_layer_of_constant` for tests.
"""

from __future__ import annotations

import logging
import time
from concurrent.futures import ThreadPoolExecutor
from functools import cached_property

import numpy as np
from scipy.sparse.linalg import LinearOperator

from vesicle.blas import blas_threads
from vesicle.geometry.surface import Shape
from vesicle.parallel import grid_threads
from vesicle.sphere.transforms import transform
from vesicle.stokes.backends import get_backend
from vesicle.stokes.fused import ring_shape_difference
from vesicle.stokes.kernels import stokeslet_apply, stresslet_apply
from vesicle.stokes.quadrature import RingGeometry, SingularQuadrature, singular_quadrature

__all__ = [
    "METHODS",
    "LayerPotentials",
    "double_layer",
    "shape_derivatives_reference",
    "single_layer",
]

log = logging.getLogger(__name__)

METHODS = ("assembled", "matrix-free")

#: Relative radius step of :meth:`LayerPotentials.shape_derivatives` (central differences).
SHAPE_STEP = 1e-5

#: The two layer potentials, in assembly order.
KERNELS = ("single", "double")


class LayerPotentials:
    """Layer potentials of one shape, built once and applied many times.

    Parameters
    ----------
    shape : Shape
        The surface; densities live on its grid.
    n_rot : int, optional
        ``theta'`` nodes of the rotated grid (``2 n_rot`` in ``phi'``); default ``n_theta``.
    method : {"assembled", "matrix-free"}
        See the module docstring; "assembled" is faster beyond a few applies per shape.
    workers : int, optional
        Threads over latitude rings (BLAS is held to one thread inside); default
        :func:`vesicle.parallel.grid_threads` (no environment is read here: a
        :class:`~vesicle.model.parameters.Discretisation` resolves ``VESICLE_THREADS``).
    kernels : tuple of {"single", "double"}
        The operators the caller will apply: "assembled" builds them together, in one pass over
        the rings, on first need (an operator not listed is still available; it is then built
        on its own).  The velocity solve at ``lam = 1`` needs only the single layer.
    backend : str
        A name of :data:`vesicle.stokes.backends.BACKENDS`: ``"numba"``, the fused compiled
        kernels of :mod:`.fused` (default), or ``"numpy"``, the reference, which is slower and
        builds the same matrices to rounding.
    """

    def __init__(
        self,
        shape: Shape,
        n_rot: int | None = None,
        method: str = "assembled",
        workers: int | None = None,
        kernels: tuple[str, ...] = KERNELS,
        backend: str = "numba",
    ):
        self._assemble_rows = get_backend(backend)
        self.backend = backend
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        if not kernels or any(k not in KERNELS for k in kernels):
            raise ValueError(f"kernels must be a non-empty subset of {KERNELS}, got {kernels!r}")
        self.kernels = tuple(kernels)
        self._assembled: dict[str, np.ndarray] = {}
        self.shape = shape
        self.method = method
        self.quad: SingularQuadrature = singular_quadrature(shape.grid.n_theta, n_rot)
        self.workers = grid_threads(shape.grid.n_theta) if workers is None else int(workers)
        self.timings: dict[str, float] = {}
        self._tri = self.quad.packed

    # ------------------------------------------------------------ utilities
    def _map_rings(self, fn) -> list:
        rings = range(self.shape.grid.n_theta)
        with blas_threads(1):
            if self.workers == 1:
                return [fn(i) for i in rings]
            with ThreadPoolExecutor(self.workers) as pool:
                return list(pool.map(fn, rings))

    def _timed(self, key: str, fn):
        t = time.perf_counter()
        out = fn()
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t
        return out

    def _coefficients(self, density: np.ndarray) -> np.ndarray:
        density = np.asarray(density, dtype=float)
        if density.shape != (3, *self.shape.grid.shape):
            raise ValueError(
                f"density must have shape (3, {self.shape.grid.n_theta}, {self.shape.grid.n_phi}),"
                f" got {density.shape}"
            )
        return transform(self.shape.grid.n_theta).analysis(density)

    # ------------------------------------------------------------- geometry
    def ring_geometry(self, i: int) -> RingGeometry:
        """The shape seen from the rotated grids of ring ``i``'s targets (stored if cached)."""
        if "rings" in self.__dict__:
            return self.rings[i]
        return self.quad.ring_geometry(i, self.shape.coefficients, self.shape.x[:, i, :])

    @cached_property
    def rings(self) -> list[RingGeometry]:
        """Rotated geometry of every ring, kept for repeated matrix-free applies."""
        x, c = self.shape.x, self.shape.coefficients
        rings = self._timed(
            "geometry", lambda: self._map_rings(lambda i: self.quad.ring_geometry(i, c, x[:, i]))
        )
        log.debug("rotated geometry for %d rings in %.3f s", len(rings), self.timings["geometry"])
        return rings

    # --------------------------------------------------------- matrix-free
    def _single_ring(self, i: int, cf: np.ndarray) -> np.ndarray:
        g = self.rings[i]
        f = self.quad.values(i, cf).transpose(1, 0, 2)  # (3, Q, K)
        return stokeslet_apply(g.xh, f * g.weight, g.inv_r).sum(axis=1)

    def _double_ring(self, i: int, cu: np.ndarray, u0: np.ndarray) -> np.ndarray:
        g = self.rings[i]
        du = self.quad.values(i, cu).transpose(1, 0, 2) - u0[:, None, :]
        return stresslet_apply(g.xh, g.normal_weighted, du, g.inv_r).sum(axis=1) - 4.0 * np.pi * u0

    # ----------------------------------------------------------- assembly
    def _assemble_ring(self, i: int, kinds: tuple[str, ...], out: dict[str, np.ndarray]) -> None:
        """Rows of ring ``i`` of the operators ``kinds``, written into the preallocated ``out``
        by the chosen backend (:mod:`.backends`)."""
        self._assemble_rows(self.quad, self.shape, i, kinds, out)

    def _matrix(self, kind: str) -> np.ndarray:
        """The assembled ``kind`` operator; on first need, every kernel of ``self.kernels`` not
        yet assembled is built in the same pass over the rings (their geometry is shared)."""
        if kind not in self._assembled:
            wanted = (kind, *self.kernels)
            self._assemble(tuple(k for k in KERNELS if k in wanted and k not in self._assembled))
        return self._assembled[kind]

    def _assemble(self, kinds: tuple[str, ...]) -> None:
        nt, nphi = self.shape.grid.shape
        ntri = self._tri[0].size
        # Stored transposed, (columns, rows), so that each ring writes contiguous target runs;
        # the apply multiplies by the transpose (BLAS reads it as a row-major matrix).
        out = {kind: np.empty((3, 2, ntri, 3, nt, nphi)) for kind in kinds}
        if "double" in kinds:
            out["double_diagonal"] = np.empty((nt, nphi, 3, 3))
        before = self.timings.get("assembly", 0.0)
        self._timed(
            "assembly", lambda: self._map_rings(lambda i: self._assemble_ring(i, kinds, out))
        )
        log.debug(
            "assembled %s layer (%d x %d each) in %.3f s",
            " and ".join(kinds),
            3 * nt * nphi,
            6 * ntri,
            self.timings["assembly"] - before,
        )
        for kind in kinds:
            out[kind] = out[kind].reshape(6 * ntri, 3 * nt * nphi).T
        self._assembled.update(out)

    @property
    def single_matrix(self) -> np.ndarray:
        """Dense single layer: real coefficient vector (see :meth:`coefficient_vector`) -> grid."""
        return self._matrix("single")

    @property
    def double_matrix(self) -> tuple[np.ndarray, np.ndarray]:
        """Dense double layer: the coefficient-space matrix and the (nt, np, 3, 3) diagonal."""
        return self._matrix("double"), self._assembled["double_diagonal"]

    def coefficient_vector(self, density: np.ndarray) -> np.ndarray:
        """``[Re c_j, Im c_j]`` of the lower-triangular coefficients of each component ``j``."""
        c = self._coefficients(density)[:, self._tri[0], self._tri[1]]
        return np.stack([c.real, c.imag], axis=1).ravel()

    # -------------------------------------------------------------- applies
    def single_layer(self, f: np.ndarray) -> np.ndarray:
        """``N[f]`` at every grid point, shape (3, n_theta, n_phi)."""
        grid_shape = (3, *self.shape.grid.shape)
        if self.method == "assembled":
            vec = self.coefficient_vector(f)
            return self._timed("apply_single", lambda: self.single_matrix @ vec).reshape(grid_shape)
        cf = self._coefficients(f)
        out = self._timed(
            "apply_single", lambda: self._map_rings(lambda i: self._single_ring(i, cf))
        )
        return np.stack(out, axis=1)

    def double_layer(self, u: np.ndarray) -> np.ndarray:
        """Principal-value ``K[u]`` at every grid point, shape (3, n_theta, n_phi)."""
        u = np.asarray(u, dtype=float)
        grid_shape = (3, *self.shape.grid.shape)
        if self.method == "assembled":
            vec = self.coefficient_vector(u)
            A, diag = self.double_matrix

            def apply():
                return (A @ vec).reshape(grid_shape) + np.einsum("ikab,bik->aik", diag, u)

            return self._timed("apply_double", apply)
        cu = self._coefficients(u)
        out = self._timed(
            "apply_double", lambda: self._map_rings(lambda i: self._double_ring(i, cu, u[:, i, :]))
        )
        return np.stack(out, axis=1)

    def double_layer_of_constant(self, c: np.ndarray) -> np.ndarray:
        """Raw (unsubtracted) quadrature of ``K[c]`` for a constant ``c``; exact: ``-4 pi c``."""
        c = np.asarray(c, dtype=float)

        def ring(i):
            g = self.ring_geometry(i)
            return stresslet_apply(g.xh, g.normal_weighted, c[:, None, None], g.inv_r).sum(1)

        return np.stack(self._map_rings(ring), axis=1)

    def single_layer_of_normal(self) -> np.ndarray:
        """``N[n]`` with the normal taken exactly at the rotated nodes; exact value 0.

        Unlike ``single_layer(shape.normal)`` this does not interpolate a grid-sampled normal, so
        it measures the quadrature alone.
        """

        def ring(i):
            g = self.ring_geometry(i)
            return stokeslet_apply(g.xh, g.normal_weighted, g.inv_r).sum(axis=1)  # w J n

        return np.stack(self._map_rings(ring), axis=1)

    # ------------------------------------------------------ shape derivatives
    def shape_derivatives(
        self,
        directions: np.ndarray,
        f: np.ndarray | None = None,
        u: np.ndarray | None = None,
        step: float = SHAPE_STEP,
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Derivatives of ``N[f]`` and ``K[u]`` when the radius moves along ``directions``, the
        densities held fixed at their grid values.

        Central differences of step ``step`` of the rotated-grid quadrature itself, pair by pair
        in one fused pass over the rings (the densities are rotated once for all directions; the
        directions' rotated values are batched), so they carry no solver tolerance: the error is
        ``O(step^2)`` plus rounding over ``step`` (about 1e-9 relative at the default).
        The reference is :func:`shape_derivatives_reference` (perturbed shapes, matrix-free).

        Parameters
        ----------
        directions : (J, N+1, N+1) complex
            Radius coefficients of each direction (a real field's, degree <= the grid's).
        f, u : (3, n_theta, n_phi), optional
            Single- and double-layer densities (one of them at least).

        Returns
        -------
        dN, dK : (J, 3, n_theta, n_phi) or None
        """
        if f is None and u is None:
            raise ValueError("give a single-layer density f, a double-layer density u, or both")
        directions = np.asarray(directions, dtype=np.complex128)
        if directions.ndim != 3 or directions.shape[1] != directions.shape[2]:
            raise ValueError(f"directions must be (J, N+1, N+1), got {directions.shape}")
        degree = directions.shape[-1] - 1
        grid, quad = self.shape.grid, self.quad
        moved = transform(grid.n_theta, degree).synthesis(directions)  # (J, nt, np)
        dx0 = moved[:, None] * grid.unit_vectors[0][None]  # (J, 3, nt, np)
        cf = None if f is None else self._coefficients(f)
        cu = None if u is None else self._coefficients(u)
        coefficients, x = self.shape.coefficients, self.shape.x
        n_dir = directions.shape[0]

        order = quad.theta_major  # the node order of synthesize_by_field
        frame = [quad.ring_frame(i)[:, :, order] for i in range(grid.n_theta)]
        inv_sin, weights = quad.inv_sin_rot[order], quad.weights_rot[order]

        def ring(i):
            base = tuple(a[order].T for a in quad.ring_radius(i, coefficients))  # (K, Q)
            cp = quad.phase(directions, slice(None))
            rows = quad.synthesize_by_field(quad.rotate(i, cp, degree))
            rows = tuple(a.reshape(n_dir, -1, quad.n_nodes) for a in rows)  # (J, K, Q)

            def density(c):  # (K, 3, Q)
                return None if c is None else quad.values(i, c)[order].transpose(2, 1, 0)

            return ring_shape_difference(
                base, rows, frame[i], inv_sin, weights, grid.phi, x[:, i], dx0[:, :, i],
                density(cf), density(cu), None if u is None else u[:, i], step,
            )  # fmt: skip

        out = self._timed("shape_derivatives", lambda: self._map_rings(ring))
        scale = 1.0 / (2.0 * step)
        dN = None if f is None else np.stack([o[0] for o in out], axis=2) * scale
        dK = None if u is None else np.stack([o[1] for o in out], axis=2) * scale
        return dN, dK

    # ------------------------------------------------------ linear operators
    def _operator(self, apply) -> LinearOperator:
        n = 3 * self.shape.grid.n_theta * self.shape.grid.n_phi
        shape = (3, *self.shape.grid.shape)
        return LinearOperator(
            (n, n), matvec=lambda v: apply(v.reshape(shape)).ravel(), dtype=np.float64
        )

    def single_operator(self) -> LinearOperator:
        """``N`` as a :class:`scipy.sparse.linalg.LinearOperator` on flattened (3, nt, np)."""
        return self._operator(self.single_layer)

    def double_operator(self) -> LinearOperator:
        """``K`` as a :class:`scipy.sparse.linalg.LinearOperator` on flattened fields."""
        return self._operator(self.double_layer)


def single_layer(shape: Shape, f: np.ndarray, **options) -> np.ndarray:
    """``N[f]`` on the shape's grid (no ``1/8 pi``); ``options`` go to :class:`LayerPotentials`."""
    options.setdefault("method", "matrix-free")  # one apply: no assembly
    return LayerPotentials(shape, **options).single_layer(f)


def double_layer(shape: Shape, u: np.ndarray, **options) -> np.ndarray:
    """Principal-value ``K[u]`` on the shape's grid (no ``1/8 pi``)."""
    options.setdefault("method", "matrix-free")
    return LayerPotentials(shape, **options).double_layer(u)


def shape_derivatives_reference(
    shape: Shape,
    directions: np.ndarray,
    f: np.ndarray | None = None,
    u: np.ndarray | None = None,
    step: float = SHAPE_STEP,
    n_rot: int | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The reference of :meth:`LayerPotentials.shape_derivatives`: the matrix-free NumPy layer
    potentials of the shapes ``r +- step d`` applied to the same densities, differenced."""
    dN, dK = [], []
    for d in np.asarray(directions, dtype=np.complex128):
        pair = [
            LayerPotentials(Shape(shape.coefficients + s * step * d, shape.grid), n_rot,
                            method="matrix-free")
            for s in (1.0, -1.0)
        ]  # fmt: skip
        if f is not None:
            dN.append((pair[0].single_layer(f) - pair[1].single_layer(f)) / (2.0 * step))
        if u is not None:
            dK.append((pair[0].double_layer(u) - pair[1].double_layer(u)) / (2.0 * step))
    return (np.array(dN) if f is not None else None), (np.array(dK) if u is not None else None)
