"""The velocity-tension system of one shape, factorised once and solved for many right-hand sides.

:class:`~vesicle.solve.solver.VelocityTensionSolver` solves SPEC §6 by nested GMRES, which suits one
right-hand side.  The linearised Jacobian of the steady problem (:mod:`vesicle.solve.linearisation`)
needs the same system for one right-hand side per Jacobian column; this module builds its exact
inverse from the assembled layer potentials instead, so each extra right-hand side costs a few
matrix products.

Notes
-----
With the double layer assembled as ``K u = K_c A u + D u`` (``A`` the analysis to the real
coefficient vector, ``K_c`` its dense matrix, ``D`` the 3x3 diagonal of the singularity
subtraction), ``A_uu = M - c K_c A`` with ``M = alpha I - c D`` block diagonal, ``alpha =
(1 + lam)/2`` and ``c = (1 - lam)/(8 pi)``.  Woodbury's identity gives

    A_uu^-1 = M^-1 + c M^-1 K_c C^-1 A M^-1,      C = I - c A M^-1 K_c,

so only ``C`` (the size of the coefficient vector) is factorised.  The tension is expanded in the
real spherical harmonics of degree <= the solver's band (the unknowns GMRES works on), and the
constraint ``band(div_s u) = r`` is imposed on the same coefficients: with ``Z = A_uu^-1 A_us``
the Schur complement ``Sigma = P div Z`` is a small dense matrix.  The solution is exact to
rounding (no tolerance); tests hold it to the GMRES solve.
"""

from __future__ import annotations

import functools
import logging
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.linalg
from numba import njit
from scipy.sparse.linalg import LinearOperator, gmres

from vesicle.blas import blas_threads
from vesicle.model.membrane import component_strain, strain_divergence, viscous_force
from vesicle.solve.krylov import batched_gmres
from vesicle.solve.solver import FlowResult, SolverError, VelocityTensionSolver, _Counter
from vesicle.sphere.bases import FullBasis
from vesicle.sphere.transforms import transform

__all__ = [
    "CoupledBlocks",
    "FactorisedSystem",
    "block_apply_reference",
    "preconditioned_solve",
    "preconditioned_system_solve",
]

log = logging.getLogger(__name__)


@njit(cache=True, nogil=True)
def _block_apply(m, u, out):
    """``out[b, :, p] = m[:, :, p] @ u[b, :, p]``: a 3x3 block per grid point."""
    for b in range(u.shape[0]):
        for p in range(u.shape[2]):
            u0, u1, u2 = u[b, 0, p], u[b, 1, p], u[b, 2, p]
            for a in range(3):
                out[b, a, p] = m[a, 0, p] * u0 + m[a, 1, p] * u1 + m[a, 2, p] * u2


def block_apply_reference(m: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The NumPy reference of the per-point 3x3 products (m: (3, 3, ...), u: (B, 3, ...))."""
    return np.einsum("ab...,zb...->za...", m, u)


class CoupledBlocks:
    """The blocks of ``A [u; t] = [b_u; r]`` of one shape, applied in batches, with the tension
    in band coordinates (the unknowns of :class:`FactorisedSystem`): what the factorisation
    and the preconditioned solve (:func:`preconditioned_solve`) share.

    Parameters
    ----------
    solver : VelocityTensionSolver
        The shape, physics, band and layer potentials (assembled on first use).
        Not for an exact sphere (its extra normal multiplier is not represented).
    """

    def __init__(self, solver: VelocityTensionSolver):
        if solver.is_sphere:
            raise ValueError(
                "the factorised system does not represent the exact sphere's extra multiplier; "
                "use the GMRES solver (VelocityTensionSolver) there"
            )
        self.solver = solver
        self.shape = shape = solver.shape
        self.lp = solver.lp
        self.workers = solver.lp.workers
        self.formulation = solver.formulation
        self.alpha, self.c = self.formulation.alpha, self.formulation.c
        self.tension_basis = FullBasis(solver.tension_degree)
        self._band_transform = transform(shape.grid.n_theta, solver.tension_degree)
        self._functions = self.tension_basis.functions(shape.grid)  # (P, nt, np)

    def apply(self, u: np.ndarray, coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``A [u; t]`` for one velocity (3, nt, np) and band coordinates ``coef`` (P,) of
        the tension: ``(A_uu u + A_us t, band(div_s u))``, the second in band coordinates."""
        t = np.tensordot(coef, self._functions, axes=(0, 0))
        top = self.solver.A_uu(u) + self.apply_us(t[None])[0]
        return top, self.constraint(u[None])[0]

    def apply_batch(self, u: np.ndarray, coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`apply` for a batch, ``u`` (B, 3, nt, np) and ``coef`` (B, P): each dense
        layer-potential matrix read once for the whole batch (the single-vector products are
        bound by memory traffic).  Needs the assembled layer potentials."""
        t = np.tensordot(coef, self._functions, axes=(1, 0))
        top = self.apply_us(t)
        if self.formulation.lam == 1.0:
            top += u
        else:
            A, diag = self.lp.double_matrix
            K = (self._coefficient_vectors(u) @ A.T).reshape(u.shape)
            K += np.einsum("ikab,zbik->zaik", diag, u)
            top += self.alpha * u - self.c * K
        if self.formulation.viscous:
            top += self.apply_viscous(u)
        return top, self.constraint(u)

    def apply_viscous(self, u: np.ndarray) -> np.ndarray:
        """The membrane-viscosity block ``Bq N[V u] / 8 pi`` on velocities (B, 3, nt, np)."""
        load = self._chunks(lambda v: self.formulation.viscous_load(self.shape, v), u)
        return self.formulation.traction_velocity(self.single_layer(load))

    def fields(self, vectors: np.ndarray) -> np.ndarray:
        """Grid fields (B, 3, nt, np) of real coefficient vectors (B, 6 T): the inverse of
        :meth:`_coefficient_vectors` on band-limited fields (the imaginary parts of ``m = 0``
        are not fields' coefficients and are dropped)."""
        tri = self.lp.quad.packed
        n = self.shape.grid.n_theta
        T = transform(n)
        parts = vectors.reshape(vectors.shape[0], 3, 2, -1)

        def synth(p):
            c = np.zeros((p.shape[0], 3, n, n), dtype=complex)
            c[..., tri[0], tri[1]] = p[:, :, 0] + 1j * p[:, :, 1]
            c[..., 0].imag = 0.0
            return T.synthesis(c)

        return self._chunks(synth, parts)

    def tension(self, coef: np.ndarray) -> np.ndarray:
        """The tension field (nt, np) of band coordinates ``coef`` (P,)."""
        return np.tensordot(coef, self._functions, axes=(0, 0))

    def _chunks(self, fn, x: np.ndarray) -> np.ndarray:
        """``fn`` over the batch of ``x`` in ``workers`` threads (transforms release the GIL)."""
        workers = min(self.workers, x.shape[0])
        if workers <= 1:
            return fn(x)
        parts = np.array_split(x, workers)
        with blas_threads(1), ThreadPoolExecutor(workers) as pool:
            return np.concatenate(list(pool.map(fn, parts)))

    def _coefficient_vectors(self, u: np.ndarray) -> np.ndarray:
        """Batched :meth:`LayerPotentials.coefficient_vector`: (B, 3, nt, np) -> (B, 6 T)."""
        tri = self.lp.quad.packed
        T = transform(self.shape.grid.n_theta)

        def vectors(v):
            c = T.analysis(v)[..., tri[0], tri[1]]
            return np.stack([c.real, c.imag], axis=-2).reshape(v.shape[0], -1)

        return self._chunks(vectors, u)

    def project(self, s: np.ndarray) -> np.ndarray:
        """Band coordinates (B, P) of scalar fields (B, nt, np) in the tension basis."""
        c = self._band_transform.analysis(s)
        b = self.tension_basis
        c = c[..., b.l, b.m]
        return b.weight * np.where(b.part == 0, c.real, -c.imag)

    def constraint(self, u: np.ndarray) -> np.ndarray:
        """``band(div_s u)`` in band coordinates, (B, P) for (B, 3, nt, np)."""
        T = transform(self.shape.grid.n_theta)
        dt, dp = T.gradient(T.analysis(u))
        at, ap = self.shape.geometry.dual_tangents
        div = sum(at[i] * dt[:, i] + ap[i] * dp[:, i] for i in range(3))
        return self.project(div)

    def tension_forces(self, t: np.ndarray) -> np.ndarray:
        """``f_sigma`` (B, 3, nt, np) of tensions (B, nt, np)."""
        shape = self.shape
        T = transform(shape.grid.n_theta)
        dt, dp = T.gradient(T.analysis(t))
        at, ap = shape.geometry.dual_tangents
        grad = at[None] * dt[:, None] + ap[None] * dp[:, None]
        return -2.0 * (shape.mean_curvature * t)[:, None] * shape.normal[None] - grad

    def single_layer(self, f: np.ndarray) -> np.ndarray:
        """``N[f]`` (no ``1/8 pi``) for densities (B, 3, nt, np), as one matrix product."""
        out = self._coefficient_vectors(f) @ self.lp.single_matrix.T
        return out.reshape(f.shape[0], 3, *self.shape.grid.shape)

    def apply_us(self, t: np.ndarray) -> np.ndarray:
        """``A_us`` on tensions (B, nt, np): ``N[f_sigma] / 8 pi``, (B, 3, nt, np)."""
        return self.formulation.traction_velocity(self.single_layer(self.tension_forces(t)))


class FactorisedSystem(CoupledBlocks):
    """``A [u; t] = [b_u; r]`` of one shape, factorised (see the module notes).

    Parameters
    ----------
    solver : VelocityTensionSolver
        The shape, physics, band and layer potentials (assembled here if they are not yet).
        Not for an exact sphere (its extra normal multiplier is not represented).
    """

    def __init__(self, solver: VelocityTensionSolver):
        start = time.perf_counter()
        super().__init__(solver)
        shape = self.shape
        with blas_threads(self.workers):
            if not self.formulation.identity_uu:
                self._factor_uu()
            self._factor_schur()
        self.seconds = time.perf_counter() - start
        size = 3 * shape.grid.n_theta * shape.grid.n_phi + self.tension_basis.size
        log.info(
            "factorised the %d x %d velocity-tension system in %.2f s", size, size, self.seconds
        )

    def _apply_minv(self, u: np.ndarray) -> np.ndarray:
        """``M^-1`` on (B, 3, nt, np)."""
        b = np.ascontiguousarray(u).reshape(u.shape[0], 3, -1)
        out = np.empty_like(b)
        _block_apply(self._minv, b, out)
        return out.reshape(u.shape)

    def _factor_uu(self) -> None:
        """``A_uu = M + L A`` with ``L = -c K_c + beta S_c Q`` (``beta = Bq / 8 pi``, ``S_c``
        the single layer's matrix, ``Q`` the viscous load ``V`` between coefficient vectors):
        Woodbury on the coefficient space, ``C = I + A M^-1 L`` (module notes)."""
        nt, nphi = self.shape.grid.shape
        eye = np.eye(3)
        if self.c != 0.0:
            Kc, diag = self.lp.double_matrix
            minv = np.linalg.inv(self.alpha * eye - self.c * diag)  # (nt, np, 3, 3)
        else:
            minv = np.broadcast_to(eye / self.alpha, (nt, nphi, 3, 3))
        self._minv = np.ascontiguousarray(minv.transpose(2, 3, 0, 1)).reshape(3, 3, -1)
        size = 6 * len(self.lp.quad.packed[0])
        C = np.eye(size)
        if self.c != 0.0:
            cols = np.ascontiguousarray(Kc.T).reshape(-1, 3, nt, nphi)  # (6T, 3, nt, np)
            self._minv_kc = self._apply_minv(cols)  # M^-1 K_c, by columns
            C -= self.c * self._coefficient_vectors(self._minv_kc).T
        if self.formulation.viscous:
            self._beta = self.formulation.traction_velocity(self.formulation.bq)
            self._q = self.viscous_matrix()  # (6T, 6T): V between coefficient vectors
            cols = np.ascontiguousarray(self.lp.single_matrix.T).reshape(-1, 3, nt, nphi)
            self._minv_sc = self._apply_minv(cols)  # M^-1 S_c, by columns
            C += self._beta * (self._coefficient_vectors(self._minv_sc).T @ self._q)
        self._lu = scipy.linalg.lu_factor(C, overwrite_a=True, check_finite=False)

    def viscous_matrix(self, reference: bool = False) -> np.ndarray:
        """``Q`` (6T, 6T): the viscous load ``V u = -2 div_s D_s(u)`` (``Bq = 1``) between real
        coefficient vectors, ``A V u = Q A u``.  A unit vector is one harmonic ``Y`` in one
        component ``k``, whose strain is ``S[0, k] dY/dtheta + S[1, k] dY/dphi``
        (:func:`~vesicle.model.membrane.component_strain`): the harmonics' derivatives are
        synthesised once for the three components.  ``reference``: ``V`` applied to the fields of
        the unit vectors (the same matrix; 7.9 s against 1.5 s at N = 8 on 32x64)."""
        size = 6 * len(self.lp.quad.packed[0])
        if reference:
            unit = self.fields(np.eye(size))
            load = self._chunks(lambda v: viscous_force(self.shape, v, 1.0), unit)
            return self._coefficient_vectors(load).T
        tri = self.lp.quad.packed
        n = self.shape.grid.n_theta
        T = transform(n)
        harmonics = len(tri[0])
        S = component_strain(self.shape)  # (2, 3, 6, nt, np)
        Q = np.zeros((size, size))
        for part in range(2):  # the real and imaginary parts of the coefficients
            c = np.zeros((harmonics, n, n), dtype=complex)
            c[np.arange(harmonics), tri[0], tri[1]] = 1.0 if part == 0 else 1.0j
            c[..., 0] = c[..., 0].real  # m = 0 has no imaginary part: a zero field
            dt, dp = T.gradient(c)  # (harmonics, nt, np)
            for k in range(3):
                def load(index, k=k, dt=dt, dp=dp):
                    D = S[0, k] * dt[index, None] + S[1, k] * dp[index, None]
                    return strain_divergence(self.shape, D)

                loads = self._chunks(load, np.arange(harmonics))  # (harmonics, 3, nt, np)
                first = k * 2 * harmonics + part * harmonics
                Q[:, first:first + harmonics] = self._coefficient_vectors(loads).T
        return Q

    def solve_uu(self, b: np.ndarray) -> np.ndarray:
        """``A_uu^-1 b`` for (B, 3, nt, np)."""
        if self.formulation.identity_uu:
            return b / self.alpha
        y = self._apply_minv(b)
        z = scipy.linalg.lu_solve(self._lu, self._coefficient_vectors(y).T, check_finite=False)
        if self.c != 0.0:
            y = y + self.c * np.tensordot(z.T, self._minv_kc, axes=(1, 0))
        if self.formulation.viscous:
            y = y - self._beta * np.tensordot((self._q @ z).T, self._minv_sc, axes=(1, 0))
        return y

    def _factor_schur(self) -> None:
        self._z = self.solve_uu(self.apply_us(self._functions))  # (P, 3, nt, np)
        schur = self.constraint(self._z).T  # (P, P): column j = P div Z e_j
        self._schur_matrix = schur
        self._schur = scipy.linalg.lu_factor(schur, check_finite=False)

    @functools.cached_property
    def schur_condition(self) -> float:
        """The 2-norm condition number of the tension Schur complement (a diagnostic, computed
        when asked: its SVD cost 10 % of each factorisation at N = 4 and 7 % at N = 8)."""
        return float(np.linalg.cond(self._schur_matrix))

    def solve(self, b_u: np.ndarray, r: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Velocities and tensions of ``A [u; t] = [b_u; r]``.

        Parameters
        ----------
        b_u : (B, 3, nt, np) or (3, nt, np)
        r : (B, P) or (P,), optional
            Right-hand side of the band constraint in band coordinates (default 0).

        Returns
        -------
        u : like ``b_u``
        t : (B, nt, np) or (nt, np), band-limited
        """
        single = b_u.ndim == 3
        u, coef = self.solve_coefficients(b_u[None] if single else b_u, r)
        t = np.tensordot(coef, self._functions, axes=(1, 0))
        return (u[0], t[0]) if single else (u, t)

    def solve_coefficients(
        self, b_u: np.ndarray, r: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`solve` with the tensions in band coordinates: ``u`` (B, 3, nt, np), (B, P)."""
        u_star = self.solve_uu(b_u)
        rhs = self.constraint(u_star)
        if r is not None:
            rhs = rhs - (np.atleast_2d(r))
        coef = scipy.linalg.lu_solve(self._schur, rhs.T, check_finite=False).T  # (B, P)
        return u_star - np.tensordot(coef, self._z, axes=(1, 0)), coef

    def flow_result(self, bending: bool = True, flow: bool = True) -> FlowResult:
        """The :class:`~vesicle.solve.solver.FlowResult` of the shape's own right-hand side (bending
        and/or background flow), solved exactly: no iterations; the residuals it reports are
        measured on the solution."""
        start = time.perf_counter()
        s = self.solver
        b = s.rhs(bending, flow)
        u, t = self.solve(b)
        rhs_t = s._constraints(self.solve_uu(b[None])[0])
        force = s._multiplier_force(t)
        seconds = time.perf_counter() - start
        return s._result(u, t, force, rhs_t, _Counter(), _Counter(), [], True, bending, seconds)


def preconditioned_system_solve(
    blocks: CoupledBlocks,
    system: FactorisedSystem,
    b_u: np.ndarray,
    r: np.ndarray | None = None,
    rtol: float = 1e-10,
    max_iterations: int = 60,
    batched: bool = True,
    iterations: list | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``A [u; t] = [b_u; r]`` of ``blocks``' shape for a batch of right-hand sides, each by
    GMRES right-preconditioned with the exact inverse of a nearby shape's ``system`` (see
    :func:`preconditioned_solve`, which is this for the shape's own right-hand side).

    All right-hand sides iterate in lockstep (``batched``, :mod:`vesicle.solve.krylov`: one
    product with each dense matrix per iteration for the whole batch) or, the reference, by
    SciPy's GMRES one after another.  Returns ``u`` (B, 3, nt, np) and the tensions' band
    coordinates (B, P).  Raises :class:`~vesicle.solve.solver.SolverError` if one of them misses
    ``rtol``."""
    u, coef, counts, converged = _preconditioned(blocks, system, b_u, r, rtol, max_iterations,
                                                 batched)  # fmt: skip
    if iterations is not None:  # each right-hand side's GMRES iterations, for the caller
        iterations.extend(c.count for c in counts)
    if not all(converged):
        raise SolverError(
            f"preconditioned GMRES missed rtol {rtol:.0e} in {max_iterations} iterations"
        )
    return u, coef


def _preconditioned(blocks, system, b_u, r, rtol, max_iterations, batched=True):
    """The preconditioned GMRES of :func:`preconditioned_system_solve`, with each solve's
    iteration count and whether it converged: all right-hand sides in lockstep
    (:func:`~vesicle.solve.krylov.batched_gmres`, ``batched``) or SciPy's GMRES one after
    another (the reference)."""
    solver = blocks.solver
    D = solver.scale
    grid = blocks.shape.grid.shape
    nu, nc = 3 * D.size, blocks.tension_basis.size
    if system.tension_basis.size != nc or system.shape.grid.shape != grid:
        raise ValueError("the preconditioner's system has another grid or tension band")
    b_u = np.asarray(b_u, float).reshape(-1, 3, *grid)
    r = np.zeros((b_u.shape[0], nc)) if r is None else np.atleast_2d(np.asarray(r, float))

    def matvec(y):  # A P^-1 y, in the scaled residual space
        u, coef = system.solve_coefficients((y[:nu].reshape(3, *grid) / D)[None], y[nu:])
        top, constraint = blocks.apply(u[0], coef[0])
        return np.concatenate([(top * D).ravel(), constraint])

    if batched:
        return _preconditioned_batch(blocks, system, b_u, r, rtol, max_iterations, D, nu)
    us, coefs, counts, flags = [], [], [], []
    with blas_threads(system.workers):
        for bu, rr in zip(b_u, r, strict=True):
            b = np.concatenate([(bu * D).ravel(), rr])
            counter = _Counter()
            y, info = gmres(LinearOperator((nu + nc, nu + nc), matvec=matvec, dtype=float), b,
                            rtol=rtol, atol=0.0, restart=max_iterations, maxiter=1,
                            callback=counter, callback_type="pr_norm")  # fmt: skip
            u, coef = system.solve_coefficients((y[:nu].reshape(3, *grid) / D)[None], y[nu:])
            us.append(u[0])
            coefs.append(coef[0])
            counts.append(counter)
            flags.append(info == 0)
    return np.array(us), np.array(coefs), counts, flags


def _preconditioned_batch(blocks, system, b_u, r, rtol, max_iterations, D, nu):
    """:func:`_preconditioned` for the whole batch at once (same scaled residual space)."""
    grid = blocks.shape.grid.shape

    def op(Y):  # A P^-1 Y for the rows of Y
        k = Y.shape[0]
        u, coef = system.solve_coefficients(Y[:, :nu].reshape(k, 3, *grid) / D, Y[:, nu:])
        top, constraint = blocks.apply_batch(u, coef)
        return np.concatenate([(top * D).reshape(k, -1), constraint], axis=1)

    rhs = np.concatenate([(b_u * D).reshape(b_u.shape[0], -1), r], axis=1)
    with blas_threads(system.workers):
        out = batched_gmres(op, rhs, rtol, max_iterations)
        u, coef = system.solve_coefficients(out.x[:, :nu].reshape(-1, 3, *grid) / D,
                                            out.x[:, nu:])  # fmt: skip
    counts = []
    for i in out.iterations:
        c = _Counter()
        c.count = int(i)
        counts.append(c)
    return u, coef, counts, [bool(f) for f in out.converged]


def preconditioned_solve(
    solver: VelocityTensionSolver,
    system: FactorisedSystem,
    rtol: float = 1e-10,
    max_iterations: int = 60,
) -> FlowResult:
    """The velocity-tension solve of ``solver``'s shape by GMRES on the whole system, right-
    preconditioned by the exact inverse of a nearby shape's ``system`` (same grid, band and
    kind of physics; ``lam`` may differ).

    Newton's iterates and a branch's neighbours differ from the shape of the last factorised
    system (a linearised Jacobian's) by a small step, so ``A P^-1 = I + O(step)`` and GMRES
    converges in a few iterations, each one product with the assembled layer potentials and
    one back-substitution, where the nested Schur-complement GMRES of
    :meth:`VelocityTensionSolver.solve` makes about 150 double-layer products at 1e-8/1e-9.

    The residual is measured with the velocity rows in the surface L2 norm (scaled by
    ``sqrt(w J)``, as the nested solver) and the constraint in band coordinates (orthonormal
    on the sphere); ``rtol`` is relative to the right-hand side.  Returns the
    :class:`~vesicle.solve.solver.FlowResult` (``outer_iterations`` = GMRES iterations, no inner
    ones); ``converged`` is false if GMRES missed ``rtol`` in ``max_iterations``.
    """
    t0 = time.perf_counter()
    blocks = CoupledBlocks(solver)
    b_u = solver.rhs()
    u, coef, counts, flags = _preconditioned(blocks, system, b_u[None], None, rtol,
                                             max_iterations)  # fmt: skip
    u, sigma = u[0], blocks.tension(coef[0])
    force = solver._multiplier_force(sigma)
    rhs_t = solver._constraints(system.solve_uu(b_u[None])[0])  # the scale of the residuals
    return solver._result(u, sigma, force, rhs_t, counts[0], _Counter(), [], flags[0], True,
                          time.perf_counter() - t0)  # fmt: skip
