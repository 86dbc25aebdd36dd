"""Membrane velocity and tension for a given shape (SPEC §6), and the particle stress (§11).

The boundary integral equation with the surface-incompressibility constraint,

    [ A_uu  A_us ] [ u     ]   [ b_u ]     A_uu u = (1+lam)/2 u - (1-lam)/(8 pi) K u
    [ A_su  0    ] [ sigma ] = [ 0   ]              + Bq N[V u] / (8 pi)   (membrane viscosity)
                                           A_us s = N f_sigma(s) / (8 pi)
                                           A_su u = div_s u,  b_u = u_inf - N f_B / (8 pi)

(:mod:`vesicle.model.formulation`; ``V u = -2 div_s D_s(u)``, zero at ``Bq = 0``)

is solved through its Schur complement with matrix-free GMRES: ``A_uu u* = b_u``;
``(A_su A_uu^-1 A_us) sigma = A_su u*``; ``A_uu u = b_u - A_us sigma``.

GMRES works in the surface L2 inner product: unknowns are scaled by ``sqrt(w J)`` (quadrature
weight times area element), so its relative residuals are relative L2 norms over the membrane.
For an exact sphere a uniform tension is indistinguishable from pressure; that one null mode of
the Schur complement is deflated and the tension returned with zero area-weighted mean.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from scipy.sparse.linalg import LinearOperator, gmres

from vesicle.geometry.surface import Shape
from vesicle.model.flows import LinearFlow
from vesicle.model.formulation import Formulation
from vesicle.model.membrane import bending_force, tension_force
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances
from vesicle.model.rheology import ParticleStress, particle_stress
from vesicle.sphere.transforms import transform
from vesicle.stokes import LayerPotentials
from vesicle.stokes.spectra import schur_symbol

__all__ = [
    "FlowResult",
    "SolverError",
    "SolverTolerances",
    "VelocityTensionSolver",
    "solve_flow",
    "with_split",
]

log = logging.getLogger(__name__)

#: ``|v - 1|`` below which a shape is treated as an exact sphere (uniform-tension gauge).
SPHERE_TOLERANCE = 1e-10


class SolverError(RuntimeError):
    """GMRES did not reach the requested tolerance; the partial result is attached."""

    def __init__(self, message: str, result: FlowResult | None = None):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True, eq=False)
class FlowResult:
    """Velocity and tension of one shape, with the solver's account of itself."""

    u: np.ndarray  # (3, n_theta, n_phi)
    sigma: np.ndarray  # (n_theta, n_phi)
    div_residual: float  # RMS of div_s u over the surface
    div_residual_relative: float  # ||div_s u|| / ||div_s u*||, all degrees
    constraint_residual: float  # the same for the imposed band (what GMRES drives to its tolerance)
    outer_iterations: int
    inner_iterations: int
    inner_per_solve: tuple[int, ...]
    residual_history: tuple[float, ...]
    converged: bool
    seconds: float
    stress: ParticleStress
    params: Physics
    tolerances: SolverTolerances
    split: dict[str, ParticleStress] | None = None
    load: np.ndarray | None = None  # the membrane load [f] (3, n_theta, n_phi) of the stress
    #: the part of ``stress`` from the membrane's viscous load ``f_eta`` (its moment ``int f_eta x
    #: dA / V``), ``None`` at ``Bq = 0``: a part of ``S``, contained in ``S^B`` and ``S^V`` alike
    viscous: ParticleStress | None = None

    @property
    def S(self) -> np.ndarray:
        return self.stress.S

    @property
    def S_xz(self) -> float:
        return self.stress.S_xz

    @property
    def N1(self) -> float:
        return self.stress.N1

    @property
    def N2(self) -> float:
        return self.stress.N2

    @property
    def iterations(self) -> dict[str, int]:
        return {"outer": self.outer_iterations, "inner": self.inner_iterations}


def default_tension_degree(n_theta: int) -> int:
    """Highest degree of the tension and of the imposed divergence: ``3 n_theta / 4``.

    On a non-spherical shape the top quarter of the grid's degrees cannot be constrained: the
    products of the tension gradient with the geometry alias there, and GMRES stagnates at the
    size of that aliasing (4e-4 relative at 32 x 64 for v = 0.95) if the full degree is imposed.
    The divergence left above the band decays spectrally with the grid (7.6e-3, 4.5e-4, 3.5e-6
    relative at 24, 32, 48 rings) and is reported as part of ``div_residual``.
    """
    return (3 * n_theta) // 4


class _Counter:
    def __init__(self) -> None:
        self.count = 0
        self.history: list[float] = []

    def __call__(self, residual: float) -> None:
        self.count += 1
        self.history.append(float(residual))


class VelocityTensionSolver:
    """The Schur-complement solve of SPEC §6 for one shape, reusable for several right-hand sides.

    Parameters
    ----------
    shape : Shape
    params : Physics
        Its ``lam``, ``chi`` and ``flow`` (``v`` is the shape's business).
    tolerances : SolverTolerances, optional
        Default: the time-dependent preset.
    operators : LayerPotentials, optional
        Prebuilt layer potentials of ``shape`` (default: assembled here, with the options of
        ``discretisation``).
    discretisation : Discretisation, optional
        Rotated-grid size, backend, method and threads of the layer potentials.
    """

    def __init__(
        self,
        shape: Shape,
        params: Physics,
        tolerances: SolverTolerances | None = None,
        operators: LayerPotentials | None = None,
        tension_degree: int | None = None,
        discretisation: Discretisation | None = None,
    ):
        self.shape = shape
        self.params = params
        self.tol = tolerances or SolverTolerances.time_dependent()
        self.formulation = Formulation.of(params)
        if operators is None:
            options = discretisation.operator_options() if discretisation is not None else {}
            operators = LayerPotentials(shape, kernels=self.formulation.kernels, **options)
        self.lp = operators
        self.scale = np.sqrt(shape.grid.weights * shape.area_element)
        self.is_sphere = abs(shape.reduced_volume - 1.0) < SPHERE_TOLERANCE
        self._bending = None
        symbol = schur_symbol(shape.grid.max_degree, params.lam, params.bq)
        symbol[0] = symbol[1]  # the uniform mode: any positive scale
        self._symbol = symbol
        self.tension_degree = (
            default_tension_degree(shape.grid.n_theta)
            if tension_degree is None
            else int(tension_degree)
        )
        if not 1 <= self.tension_degree <= shape.grid.max_degree:
            raise ValueError(f"tension_degree must lie in [1, {shape.grid.max_degree}]")

    # ---------------------------------------------------------------- blocks
    @property
    def bending_force(self) -> np.ndarray:
        if self._bending is None:
            self._bending = bending_force(self.shape)
        return self._bending

    def A_uu(self, u: np.ndarray) -> np.ndarray:
        return self.formulation.A_uu(u, self.lp.double_layer, self.lp.single_layer, self.shape)

    def A_us(self, sigma: np.ndarray) -> np.ndarray:
        return self.formulation.traction_velocity(
            self.lp.single_layer(tension_force(self.shape, sigma))
        )

    def A_su(self, u: np.ndarray) -> np.ndarray:
        return self.shape.surface_divergence(u)

    def rhs(self, bending: bool = True, flow: bool = True) -> np.ndarray:
        """``b_u`` with the bending and/or background-flow parts."""
        b = np.zeros((3, *self.shape.grid.shape))
        if flow and self.params.driven:
            b += self.params.flow.velocity(self.shape.x, self.params.chi)
        if bending:
            b -= self.formulation.traction_velocity(self.lp.single_layer(self.bending_force))
        return b

    # ---------------------------------------------------------------- solves
    def solve_uu(self, rhs: np.ndarray, counter: _Counter | None = None) -> tuple[np.ndarray, bool]:
        """``A_uu^{-1} rhs`` by GMRES (exact for ``lam = 1`` and ``Bq = 0``)."""
        if self.formulation.identity_uu:
            return rhs.copy(), True
        D = self.scale
        shape3 = rhs.shape
        op = LinearOperator(
            (rhs.size, rhs.size),
            dtype=float,
            matvec=lambda v: (self.A_uu(v.reshape(shape3) / D) * D).ravel(),
        )
        b = (rhs * D).ravel()
        x0 = b / self.formulation.alpha
        counter = counter if counter is not None else _Counter()
        start = counter.count
        cap = self.inner_cap
        restart = min(self.tol.restart, cap)
        x, info = gmres(
            op,
            b,
            x0=x0,
            rtol=self.tol.inner,
            atol=0.0,
            restart=restart,
            maxiter=-(-cap // restart),
            callback=counter,
            callback_type="pr_norm",
        )
        if info != 0:
            log.warning(
                "inner GMRES stopped after %d iterations without reaching %.1e",
                counter.count - start,
                self.tol.inner,
            )
        return x.reshape(shape3) / D, info == 0

    @property
    def inner_cap(self) -> int:
        """The inner solve's iteration limit: ``max_inner``, times ``sqrt(kappa)`` with a
        viscous membrane, ``kappa = 1 + Bq L / (1 + lam)`` the unit sphere's condition number of
        ``A_uu`` up to the grid's degree ``L`` (the viscous term grows like ``Bq l / 2``; GMRES
        needs about ``sqrt(kappa)`` times the iterations: measured 27, 75, 101 at Bq = 1, 8, 16
        on 16x32 at 1e-9)."""
        if not self.formulation.viscous:
            return self.tol.max_inner
        L = self.shape.grid.max_degree
        kappa = 1.0 + self.params.bq * L / (1.0 + self.params.lam)
        return int(np.ceil(self.tol.max_inner * np.sqrt(kappa)))

    # ------------------------------------------------ constraint multipliers
    # The multipliers t enforce the constraints c(u) = 0.  On any shape t = sigma (tension) and
    # c = div_s u.  An exact sphere cannot change shape at all (its area is minimal for its
    # volume: a normal velocity of degree >= 2 keeps div_s u = 0 at first order but raises the
    # area at second order); the tension's isotropic part, which diverges like Delta^(-1/2) as
    # v -> 1, then acts as a normal load q n with q of degree >= 2 enforcing u . n = 0 there.
    def _low_modes(self, f: np.ndarray) -> np.ndarray:
        """Projection of a scalar grid field onto degrees 0 and 1."""
        return self.shape.filter_field(f, 1)

    def _band(self, f: np.ndarray) -> np.ndarray:
        L = self.tension_degree
        return f if L >= self.shape.grid.max_degree else self.shape.filter_field(f, L)

    def _multiplier_force(self, t: np.ndarray) -> np.ndarray:
        if not self.is_sphere:
            return tension_force(self.shape, self._band(t))
        sigma, q = t
        q = q - self._low_modes(q)
        return tension_force(self.shape, sigma) + q * self.shape.normal

    def _constraints(self, u: np.ndarray) -> np.ndarray:
        div = self._band(self.A_su(u))
        if not self.is_sphere:
            return div
        un = np.einsum("i...,i...->...", u, self.shape.normal)
        return np.stack([div, un - self._low_modes(un)])

    def _precondition(self, t: np.ndarray, inverse: bool = False) -> np.ndarray:
        """Right preconditioner on scaled multipliers: ``1/s_l`` on the tension (``s_l`` if
        ``inverse``), identity on the sphere's normal load."""
        T = transform(self.shape.grid.n_theta)
        D = self.scale
        sigma = t[0] if self.is_sphere else t
        factor = self._symbol if inverse else 1.0 / self._symbol
        sigma = T.synthesis(T.analysis(sigma / D) * factor[:, None]) * D
        if not self.is_sphere:
            return sigma
        return np.stack([sigma, t[1]])

    def _deflate(self, t: np.ndarray, out: np.ndarray) -> None:
        """Make the sphere's null modes (uniform tension; q of degree <= 1) non-singular."""
        D = self.scale
        z = D / np.sqrt(np.sum(D * D))
        out[0] += z * np.sum(z * t[0])
        out[1] += self._low_modes(t[1] / D) * D

    def solve(
        self, sigma0: np.ndarray | None = None, bending: bool = True, flow: bool = True
    ) -> FlowResult:
        """Velocity and tension for the chosen right-hand side; ``sigma0`` warm-starts GMRES."""
        t0 = time.perf_counter()
        D = self.scale
        t_shape = (2, *self.shape.grid.shape) if self.is_sphere else self.shape.grid.shape
        inner = _Counter()
        per_solve: list[int] = []
        ok = [True]

        def inverse(rhs):
            before = inner.count
            u, good = self.solve_uu(rhs, inner)
            per_solve.append(inner.count - before)
            ok[0] &= good
            return u

        b_u = self.rhs(bending, flow)
        u_star = inverse(b_u)
        rhs_t = self._constraints(u_star)

        def schur(v):  # right-preconditioned: v -> S M v
            tv = self._precondition(v.reshape(t_shape))
            f = self._multiplier_force(tv / D)
            out = self._constraints(
                inverse(self.formulation.traction_velocity(self.lp.single_layer(f)))
            ) * D
            if self.is_sphere:
                self._deflate(tv, out)
            else:  # tension components above the band are not unknowns: identity on them
                out += tv - self._band(tv / D) * D
            return out.ravel()

        n = rhs_t.size
        outer = _Counter()
        b = (rhs_t * D).ravel()
        # rounding floor: the divergence of a velocity of size |u*| is computed to ~L eps |u*|/a
        floor = 1e3 * np.finfo(float).eps * self.shape.grid.max_degree * np.linalg.norm(u_star * D)
        x0 = None
        if sigma0 is not None:
            x0 = np.zeros(t_shape)
            if self.is_sphere:
                x0[0] = np.broadcast_to(sigma0, D.shape)
            else:
                x0[...] = np.broadcast_to(sigma0, D.shape)
            x0 = self._precondition(x0 * D, inverse=True).ravel()
        if np.linalg.norm(b) <= floor:
            y, info = np.zeros(n), 0
        else:
            restart = min(self.tol.restart, self.tol.max_outer)
            y, info = gmres(
                LinearOperator((n, n), matvec=schur, dtype=float),
                b,
                x0=x0,
                rtol=self.tol.schur,
                atol=floor,
                restart=restart,
                maxiter=-(-self.tol.max_outer // restart),
                callback=outer,
                callback_type="pr_norm",
            )
        t = self._precondition(y.reshape(t_shape)) / D
        if not self.is_sphere:
            t = self._band(t)
        force = self._multiplier_force(t)
        u = inverse(b_u - self.formulation.traction_velocity(self.lp.single_layer(force)))
        sigma = t[0] if self.is_sphere else t
        return self._result(
            u,
            sigma,
            force,
            rhs_t,
            outer,
            inner,
            per_solve,
            info == 0 and ok[0],
            bending,
            time.perf_counter() - t0,
        )

    def _result(
        self, u, sigma, force, rhs_t, outer, inner, per_solve, converged, bending, seconds
    ) -> FlowResult:
        div = self.A_su(u)
        norm = self.shape.integrate
        div_rms = float(np.sqrt(norm(div**2) / self.shape.area))
        rhs_div = rhs_t[0] if self.is_sphere else rhs_t
        initial = float(np.sqrt(norm(rhs_div**2) / self.shape.area))
        band = self._band(div)
        band_rms = float(np.sqrt(norm(band**2) / self.shape.area))
        if bending:
            force = force + self.bending_force
        viscous = None
        if self.formulation.viscous:  # the membrane's viscous load is part of [f]
            f_eta = self.formulation.viscous_load(self.shape, u)
            force = force + f_eta
            viscous = particle_stress(self.shape, f_eta, np.zeros_like(u), 1.0, self.params.chi)
        stress = particle_stress(self.shape, force, u, self.params.lam, self.params.chi)
        result = FlowResult(
            u=u,
            sigma=sigma,
            div_residual=div_rms,
            div_residual_relative=div_rms / initial if initial > 0 else 0.0,
            constraint_residual=band_rms / initial if initial > 0 else 0.0,
            outer_iterations=outer.count,
            inner_iterations=inner.count,
            inner_per_solve=tuple(per_solve),
            residual_history=tuple(outer.history),
            converged=bool(converged),
            seconds=seconds,
            stress=stress,
            params=self.params,
            tolerances=self.tol,
            load=force,
            viscous=viscous,
        )
        log.info(
            "solve: %d outer, %d inner iterations, div residual %.2e (rel %.2e), %.2f s%s",
            outer.count,
            inner.count,
            div_rms,
            result.div_residual_relative,
            seconds,
            "" if converged else " NOT CONVERGED",
        )
        return result


def solve_flow(
    shape: Shape,
    physics: Physics | None = None,
    *,
    lam: float | None = None,
    chi: float | None = None,
    flow: LinearFlow | str | None = None,
    tolerances: SolverTolerances | str = "time-dependent",
    discretisation: Discretisation | None = None,
    sigma0: np.ndarray | None = None,
    split: bool = False,
    operators: LayerPotentials | None = None,
    raise_on_failure: bool = True,
) -> FlowResult:
    """Membrane velocity, tension and particle stress of ``shape`` in a linear flow.

    Parameters
    ----------
    shape : Shape
    physics : Physics, optional
        Viscosity ratio, shear rate and background flow (its ``v`` is not used: the shape is
        given).  Or the keywords ``lam`` (default 1), ``chi`` (default 1) and ``flow`` (default
        ``"shear"``), not both.  ``chi = 0`` is relaxation at rest (the chi-normalised stress is
        then undefined and reported as ``nan``).
    tolerances : SolverTolerances or {"time-dependent", "steady"}
    discretisation : Discretisation, optional
        Layer-potential options (``n_rot``, ``backend``, ``method``, ``workers``); its grid and
        degree are the shape's business.
    sigma0 : array, optional
        Initial tension (warm start), e.g. the previous step's.
    split : bool
        Also solve with the bending and the flow right-hand sides alone: ``result.split`` holds
        ``{"bending": S^B, "flow": S^V}`` with ``S = S^B + S^V`` (SPEC §11).
    raise_on_failure : bool
        Raise :class:`SolverError` if GMRES misses a tolerance (else flag ``converged=False``).
    """
    physics = _physics(shape, physics, lam, chi, flow)
    tolerances = SolverTolerances.parse(tolerances)
    solver = VelocityTensionSolver(shape, physics, tolerances, operators, None, discretisation)
    result = solver.solve(sigma0)
    if split:
        parts = {
            "bending": solver.solve(None, bending=True, flow=False),
            "flow": solver.solve(None, bending=False, flow=True),
        }
        result = with_split(result, parts)
    if not result.converged and raise_on_failure:
        raise SolverError(
            f"velocity-tension solve did not converge: {result.outer_iterations} outer and "
            f"{result.inner_iterations} inner iterations, relative divergence residual "
            f"{result.div_residual_relative:.2e} (tolerances {tolerances})",
            result,
        )
    return result


def with_split(result: FlowResult, parts: dict[str, FlowResult]) -> FlowResult:
    """``result`` with the stresses of its bending and flow parts (``split=True``)."""
    converged = result.converged and all(p.converged for p in parts.values())
    return FlowResult(
        **{
            **result.__dict__,
            "converged": converged,
            "split": {k: p.stress for k, p in parts.items()},
        }
    )


def _physics(shape: Shape, physics, lam, chi, flow) -> Physics:
    """``physics``, or one made of the keywords with the shape's reduced volume."""
    keywords = {k: x for k, x in (("lam", lam), ("chi", chi), ("flow", flow)) if x is not None}
    if physics is not None:
        if keywords:
            raise ValueError(
                f"give the physics as a Physics object or as keywords, not both "
                f"(got Physics and {', '.join(keywords)})"
            )
        if not isinstance(physics, Physics):
            raise TypeError(f"physics must be a vesicle.Physics, got {type(physics).__name__}")
        return physics
    v = float(np.clip(shape.reduced_volume, np.finfo(float).tiny, 1.0))
    return Physics(v=v, **{"lam": 1.0, "chi": 1.0, "flow": "shear", **keywords})
