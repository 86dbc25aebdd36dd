"""One description of the steady problem (SPEC §8, §9, §16), shared by Newton, stability and
continuation.

A :class:`SteadyProblem` holds the physics, the discretisation, the solver tolerances and the
basis of the unknowns (``"symmetric"``: even degrees, cosines, SPEC §8; ``"general"``: the full
basis (2.1)).  It maps basis coefficients ``a`` to the shape, to ``adot(a)`` (the projection of
the filtered ``dr/dt`` onto the basis, one velocity-tension solve) and to the constraint
gradients, and forms ``M = d adot / d a`` by finite differences — the one Jacobian of the
package, serial or through any :class:`concurrent.futures.Executor` with identical results.

The object is small and picklable (its cached tables are rebuilt in a worker), so Jacobian
columns travel to process pools and Dask workers as ``(problem, a)``.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from concurrent.futures import Executor
from dataclasses import dataclass
from functools import cached_property, partial

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.model.formulation import EIGHT_PI, Formulation
from vesicle.model.kinematics import constraint_gradients, rate_of_change
from vesicle.model.membrane import viscous_force
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances
from vesicle.solve.factorised import (
    CoupledBlocks,
    FactorisedSystem,
    preconditioned_solve,
    preconditioned_system_solve,
)
from vesicle.solve.linearisation import linearised_action, linearised_jacobian
from vesicle.solve.solver import (
    SPHERE_TOLERANCE,
    FlowResult,
    SolverError,
    VelocityTensionSolver,
    solve_flow,
    with_split,
)
from vesicle.sphere.bases import RealBasis, basis
from vesicle.sphere.grid import SphereGrid
from vesicle.stokes import LayerPotentials

__all__ = ["JACOBIANS", "PARAMETER_RATES", "SteadyProblem", "finite_difference_jacobian"]

#: How :meth:`SteadyProblem.jacobian` forms ``M``: ``"linearised"`` (the solve differentiated,
#: :mod:`vesicle.solve.linearisation`; default) or ``"differences"`` (the reference: one or two
#: solves of perturbed shapes per column).
JACOBIANS = ("linearised", "differences")

#: The parameters :meth:`SteadyProblem.parameter_rates` differentiates in: ``log chi`` (named
#: ``"chi"``), ``lam`` and the Boussinesq number ``bq``.
PARAMETER_RATES = ("chi", "lam", "bq")

log = logging.getLogger(__name__)

#: Relative residual of a preconditioned solve (:meth:`SteadyProblem.solve`): below the nested
#: solver's 1e-8 (Schur) / 1e-9 (inner), so that Newton's residuals are as clean.
PRECONDITIONED_RTOL = 1e-10

#: A reused factorisation (``reuse_factorisation``) is given up for a new one when the
#: Jacobian's GMRES misses 1e-11 in this many iterations; at N = 8 on 32x64 a batch of 25
#: columns costs about 0.2 s an iteration against 2.2 s a factorisation.
REUSE_ITERATIONS = 10

#: ... and refreshed at the next Jacobian when one took more than this many.
REFRESH_ITERATIONS = 6

#: Reuse stops (for this problem and those that adopt its state) once a reused Jacobian took
#: longer than this fraction of the last factorised one (both measured, the layer potentials'
#: assembly excluded from both): at N = 4 on 16x32 a factorisation (0.18 s) is cheaper than
#: the batched GMRES, at N = 8 on 32x64 (2.2 s) it is not.
REUSE_COST = 0.9

#: Relative finite-difference step of the Jacobian (scaled by ``max(1, |a_00|)``).
JACOBIAN_STEP = 1e-4


class _Kept:
    """The layer potentials and the factorised system of the last shape a problem solved,
    each as ``(shape key, object)``: about 0.3 GB each at 32x64, so one shape at most; and a
    factorised system adopted from a problem at another parameter point, used only as a
    preconditioner (:meth:`SteadyProblem.adopt`)."""

    __slots__ = ("factorised_seconds", "operators", "preconditioner", "reuse_cost", "stale",
                 "system")

    def __init__(self) -> None:
        self.operators: tuple | None = None
        self.system: tuple | None = None
        self.preconditioner = None
        self.stale = False  # the kept system preconditions too slowly: factorise next time
        # seconds of the last Jacobian on a reused factorisation over those of the last
        # factorisation: reuse stops where it does not pay (small grids)
        self.reuse_cost: float | None = None
        self.factorised_seconds: float | None = None  # the last factorised Jacobian's


@dataclass(frozen=True)
class SteadyProblem:
    """The steady-state equations ``adot(a) - mu . grad(A, V) = 0``, ``A = 4 pi``,
    ``V = 4 pi v / 3`` for one parameter point.

    Parameters
    ----------
    physics, discretisation : Physics, Discretisation
    tolerances : SolverTolerances
        Of each velocity solve; Newton and stability use 1e-8 / 1e-9 (see
        :func:`vesicle.steady.newton.steady_tank_treading`).
    modes : {"symmetric", "general"}
        The basis of the unknowns.
    jacobian_method : {"linearised", "differences"}
        See :data:`JACOBIANS`.
    preconditioned : bool
        Solve shapes near that of the last linearised Jacobian by GMRES preconditioned with its
        factorised system (:func:`vesicle.solve.factorised.preconditioned_solve`; default), else by
        the nested Schur-complement GMRES (the method before).
    reuse_factorisation : bool
        A linearised Jacobian at a new shape without a new factorisation: its columns solved
        together by GMRES preconditioned with the kept (or adopted) factorised system of a
        nearby shape (:func:`vesicle.solve.linearisation.linearised_action` on the identity), to
        the same 1e-11 as the solves of Newton's action derivatives.  A factorisation instead
        where none is kept, where GMRES misses ``1e-11`` in :data:`REUSE_ITERATIONS`, and at the
        next Jacobian after one that took more than :data:`REFRESH_ITERATIONS` (the kept system
        has grown too far from the shapes).  Off by default (the factorised Jacobian, exact to
        rounding); the two-parameter continuation turns it on.
    """

    physics: Physics
    discretisation: Discretisation
    tolerances: SolverTolerances
    modes: str = "symmetric"
    jacobian_method: str = "linearised"
    preconditioned: bool = True
    reuse_factorisation: bool = False
    #: What is kept of the last shape solved (its layer potentials and factorised system): an
    #: explicit one-shape cache, not part of the problem's identity, dropped by :meth:`release`
    kept: _Kept = dataclasses.field(default_factory=lambda: _Kept(), init=False,
                                    compare=False, repr=False)  # fmt: skip

    def __post_init__(self) -> None:
        basis(self.modes, self.discretisation.degree)  # validates the name and the degree
        if self.jacobian_method not in JACOBIANS:
            raise ValueError(
                f"jacobian_method must be one of {JACOBIANS}, got {self.jacobian_method!r}"
            )

    def __getstate__(self) -> dict:  # the cached tables and operators are rebuilt where it lands
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init}

    def __setstate__(self, state: dict) -> None:
        for name, value in {**state, "kept": _Kept()}.items():
            object.__setattr__(self, name, value)

    def replace(self, **changes) -> SteadyProblem:
        return dataclasses.replace(self, **changes)

    def release(self) -> None:
        """Drop the layer potentials and factorised system kept for the last shape (about
        0.3 GB each at 32x64): a finished steady state keeps its problem, and a neutral curve
        keeps hundreds of states (at N = 8 on 32x64 the tracer grew to 22 GB and was killed
        before this was called when Newton returns)."""
        self.kept.operators = self.kept.system = self.kept.preconditioner = None

    def adopt(self, other: SteadyProblem) -> None:
        """Take over what ``other`` (same discretisation, another parameter point) keeps:
        its layer potentials where the kernels are the same (they depend on the shape and the
        kernels only, not on ``lam`` or ``chi``), and its factorised system as the
        preconditioner of this problem's solves (never as an exact inverse: ``lam`` may
        differ).  A two-parameter continuation moves ``(chi, lam)`` at every evaluation of its
        parameter derivatives; without this each such solve was a nested GMRES from scratch
        (1.5 s against 0.55 s at N = 8 on 32x64)."""
        if other is self or other.discretisation != self.discretisation:
            return
        ops = other.kept.operators
        if ops is not None and ops[1].kernels == Formulation.of(self.physics).kernels:
            self.kept.operators = ops
        system = other.kept.system[1] if other.kept.system is not None else \
            other.kept.preconditioner  # fmt: skip
        if system is not None:
            self.kept.preconditioner = system
            self.kept.stale = other.kept.stale
        self.kept.reuse_cost = other.kept.reuse_cost
        self.kept.factorised_seconds = other.kept.factorised_seconds

    # ----------------------------------------------------------------- basis
    @cached_property
    def basis(self) -> RealBasis:
        return basis(self.modes, self.discretisation.degree)

    @cached_property
    def functions(self) -> np.ndarray:
        """The basis functions on the grid, (size, n_theta, n_phi)."""
        return self.basis.functions(SphereGrid(self.discretisation.grid))

    @cached_property
    def rate_weights(self) -> np.ndarray | None:
        """The weights of the rates under ``Discretisation(multipliers="l2")``: each basis
        function's squared L2 norm on the unit sphere, ``W_k = int Y_k^2 dOmega``.

        Every rate (``adot``, ``M = d adot / d a``, ``d adot / d p``) is multiplied by ``W``,
        so the dynamic equations ``W adot - mu . g = 0`` read ``adot = mu . W^-1 g``: the
        multipliers act along ``W^-1 g``, the L2 gradients of A and V, which are the
        directions of the time stepping's drift control
        (:func:`vesicle.dynamics.integrators.restore_area_volume`), and the steady states are
        the time stepping's fixed points.  The Newton matrix ``[[W M - mu . H, -g^T], [g, 0]]``
        is singular where the branch turns, whatever ``W``; the growth rates are those of the
        pencil with the mass matrix ``diag(W, 0)`` (:func:`vesicle.steady.stability.stability`).
        ``None`` (nothing weighed, the default ``"coefficients"``): the multipliers act along
        the gradients in the basis coordinates (SPEC §8)."""
        if self.discretisation.multipliers == "coefficients":
            return None
        f = self.functions
        return np.einsum("kij,kij,ij->k", f, f, SphereGrid(self.discretisation.grid).weights)

    def _weighed(self, rates: np.ndarray) -> np.ndarray:
        """``rates`` (size,) or (size, k) multiplied by :attr:`rate_weights` (when there are)."""
        w = self.rate_weights
        if w is None:
            return rates
        return w * rates if rates.ndim == 1 else w[:, None] * rates

    @property
    def targets(self) -> tuple[float, float]:
        """The area and volume every steady state keeps: ``4 pi`` and ``4 pi v / 3``."""
        return 4.0 * np.pi, 4.0 * np.pi * self.physics.v / 3.0

    def coefficients_of(self, shape: Shape) -> np.ndarray:
        """Basis coordinates of a shape (projected; other symmetries are dropped)."""
        return self.basis.from_coefficients(shape.with_degree(self.basis.degree).coefficients)

    def shape(self, a: np.ndarray) -> Shape:
        return Shape(self.basis.to_coefficients(a), self.discretisation.grid)

    # ------------------------------------------------------------- equations
    def solve(self, shape: Shape, sigma0=None, split: bool = False) -> FlowResult:
        """The velocity-tension solve of ``shape`` with this problem's parameters.

        With ``split`` at the shape of the last linearised Jacobian (a steady state whose
        stability was just analysed) the three solves reuse its factorised system: exact, no
        iterations."""
        kept = self.kept.system
        if split and kept is not None and kept[0] == self._key(shape):
            system = kept[1]
            parts = {"bending": system.flow_result(True, False),
                     "flow": system.flow_result(False, True)}  # fmt: skip
            return with_split(system.flow_result(), parts)
        preconditioner = kept[1] if kept is not None else self.kept.preconditioner
        if not split and preconditioner is not None and self.preconditioned:
            result = self._preconditioned(shape, preconditioner)
            if result is not None:
                return result
        if self.physics.bq != 0.0:
            result = self._exact(shape, split)
            if result is not None:
                return result
        return solve_flow(
            shape,
            self.physics,
            tolerances=self.tolerances,
            discretisation=self.discretisation,
            sigma0=sigma0,
            split=split,
            operators=self._operators(shape),
        )

    def _solver(self, shape: Shape) -> VelocityTensionSolver:
        """The velocity-tension solver of ``shape`` on its kept layer potentials."""
        return VelocityTensionSolver(shape, self.physics, self.tolerances, self._operators(shape),
                                     discretisation=self.discretisation)  # fmt: skip

    def factorise(self, shape: Shape) -> FactorisedSystem:
        """The factorised velocity-tension system of ``shape`` (linearised Jacobians), kept as
        the preconditioner of the next solves (:meth:`solve`)."""
        system = FactorisedSystem(self._solver(shape))
        self.kept.system = (self._key(shape), system)
        return system

    def wants_preconditioner(self, shape: Shape) -> bool:
        """Whether solves of shapes near ``shape`` would be preconditioned but no system is
        kept yet (a continuation step's first iterate: the neighbour's system is gone)."""
        return (self.preconditioned and self.jacobian_method == "linearised"
                and self.kept.system is None
                and abs(shape.reduced_volume - 1.0) >= SPHERE_TOLERANCE)  # fmt: skip

    def _exact(self, shape: Shape, split: bool) -> FlowResult | None:
        """With a viscous membrane, the solve by factorisation instead of the nested GMRES:
        the inner solve's operator ``alpha + Bq N V / 8 pi`` is far from normal (its symmetric
        part is indefinite: -3.6 at Bq = 8, N = 4 on 16x32, while its eigenvalues lie in
        [1, 69]) and its GMRES stagnated on shapes of a continuation in Bq even with 1600
        iterations.  The factorised system is exact and is kept as the next solves'
        preconditioner.  ``None`` for an exact sphere (not representable there)."""
        solver = self._solver(shape)
        if solver.is_sphere:
            return None
        if self.jacobian_method == "linearised":
            system = self.factorise(shape)
        else:
            system = FactorisedSystem(solver)
        log.info("viscous membrane: solve by factorisation (%.2f s)", system.seconds)
        result = system.flow_result()
        if split:
            parts = {"bending": system.flow_result(True, False),
                     "flow": system.flow_result(False, True)}  # fmt: skip
            result = with_split(result, parts)
        return result

    def _preconditioned(self, shape: Shape, system: FactorisedSystem) -> FlowResult | None:
        """The solve of ``shape`` preconditioned by the kept ``system``, or ``None`` (logged)
        where GMRES misses its tolerance (a shape too far from the system's): the nested
        solve then takes over."""
        solver = self._solver(shape)
        if solver.is_sphere:
            return None
        result = preconditioned_solve(solver, system, rtol=PRECONDITIONED_RTOL)
        if not result.converged:
            log.info("preconditioned solve: %d iterations without reaching %.0e; nested GMRES",
                     result.outer_iterations, PRECONDITIONED_RTOL)  # fmt: skip
            return None
        return result

    @staticmethod
    def _key(shape: Shape) -> tuple:
        return (shape.grid.n_theta, shape.coefficients.tobytes())

    def _operators(self, shape: Shape):
        """The layer potentials of the last shape solved, kept for its linearised Jacobian
        (one shape: the assembled matrices are the size of the problem); ``None`` (built by
        the solve and dropped) for finite differences."""
        if self.jacobian_method != "linearised":
            return None
        key = self._key(shape)
        kept = self.kept.operators
        if kept is None or kept[0] != key:
            lp = LayerPotentials(shape, kernels=Formulation.of(self.physics).kernels,
                                 **self.discretisation.operator_options())  # fmt: skip
            kept = self.kept.operators = (key, lp)
        return kept[1]

    def jacobian_action(self, a: np.ndarray, vectors: np.ndarray) -> np.ndarray:
        """``M(a) V`` for a few columns ``V`` (size, k), by the linearisation along them only
        (:func:`vesicle.solve.linearisation.linearised_action`), its solves preconditioned by
        the kept (or adopted) factorised system of a nearby shape.  Raises ``ValueError``
        where none is kept (a linearised Jacobian near ``a`` comes first)."""
        if self.jacobian_method != "linearised":
            raise ValueError("jacobian_action needs jacobian_method='linearised'")
        kept = self.kept.system
        system = kept[1] if kept is not None else self.kept.preconditioner
        if system is None:
            raise ValueError("no factorised system kept near this shape: compute a Jacobian first")
        shape = self.shape(a)
        return self._weighed(linearised_action(self._solver(shape), self.basis, vectors, system))

    def parameter_rates(self, a: np.ndarray,
                        parameters: tuple[str, ...] = ("chi", "lam")) -> np.ndarray:  # fmt: skip
        """``d adot / d p`` at ``a``, (size, len(parameters)), for ``p`` among ``log chi``
        (named ``"chi"``), ``lam`` and ``bq``: the velocity-tension system differentiated in
        its parameters (no finite differences).

        The system ``A(lam, bq) [u; t] = [b(chi); 0]`` has ``b = chi u_inf^(1) - N[f_B]/(8 pi)``
        and ``A_uu = (1 + lam)/2 I - (1 - lam)/(8 pi) K + Bq N[V .]/(8 pi)`` (``V`` the
        membrane's viscous operator at unit Bq), so ``A [u_chi; t_chi] = [chi u_inf^(1); 0]``,
        ``A [u_lam; t_lam] = [-(u/2 + K[u]/(8 pi)); 0]`` and ``A [u_bq; t_bq] = [-N[V u]/(8 pi);
        0]``; each column is the rate of change of its velocity.  The solves are exact with the
        factorised system of this shape (kept by the last Jacobian at ``a``), else by GMRES
        preconditioned with the kept or adopted one (a factorisation where there is none).  At
        ``lam = 1`` the double layer, not otherwise needed, is assembled for ``K[u]``."""
        unknown = [q for q in parameters if q not in PARAMETER_RATES]
        if unknown:
            raise ValueError(f"parameter_rates: unknown parameters {unknown}; "
                             f"known: {PARAMETER_RATES}")  # fmt: skip
        if self.jacobian_method != "linearised":
            raise ValueError("parameter_rates needs jacobian_method='linearised'")
        shape = self.shape(a)
        solver = self._solver(shape)
        kept = self.kept.system
        if kept is not None and kept[0] == self._key(shape):
            exact = kept[1]

            def solve(b):
                return exact.solve_coefficients(b)[0]
        else:
            near = self.kept.preconditioner if kept is None else kept[1]
            if near is None:
                near = self.factorise(shape)
            blocks = CoupledBlocks(solver)

            def solve(b):
                return preconditioned_system_solve(blocks, near, b, rtol=PRECONDITIONED_RTOL)[0]

        u = solve(solver.rhs()[None])[0]
        params = self.physics
        rhs = []
        for q in parameters:
            if q == "chi":
                rhs.append(params.flow.velocity(shape.x, params.chi) if params.driven
                           else np.zeros_like(u))  # fmt: skip
            elif q == "lam":
                rhs.append(-(0.5 * u + solver.lp.double_layer(u) / EIGHT_PI))
            else:  # the membrane's viscous load at unit Bq
                rhs.append(-solver.lp.single_layer(viscous_force(shape, u, 1.0)) / EIGHT_PI)
        du = solve(np.stack(rhs))
        degree = self.basis.degree
        return self._weighed(np.stack([self.basis.from_coefficients(rate_of_change(shape, d,
                                                                                   degree))
                                       for d in du], axis=1))  # fmt: skip

    def adot(self, a: np.ndarray, sigma0=None) -> tuple[np.ndarray, FlowResult]:
        """``adot(a)`` and the solve it came from."""
        shape = self.shape(a)
        flow = self.solve(shape, sigma0)
        rate = rate_of_change(shape, flow.u, self.basis.degree)
        return self._weighed(self.basis.from_coefficients(rate)), flow

    def gradients(self, shape: Shape) -> np.ndarray:
        """``dA/da`` and ``dV/da`` at ``shape``, (2, size)."""
        return constraint_gradients(shape, self.functions)

    def project(
        self,
        a: np.ndarray,
        jacobian: np.ndarray | None = None,
        tolerance: float = 1e-13,
        max_iterations: int = 8,
        max_move: float = np.inf,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``a`` moved onto the constraints ``A = 4 pi``, ``V = 4 pi v / 3`` (geometry only).

        A Newton step meets the constraints to first order only: along a branch step of
        ``|da| = 0.02`` (N = 8, lam 7 -> 7.3, chi = 1) their quadratic error (6e-3 in ``A``)
        outweighed the dynamic residual, which the step had cut by 4, and Newton discarded a
        good Jacobian.  This is the second-order correction of constrained Newton (SQP):

        - with ``jacobian`` (``M``): the bordered step ``[[M, -g^T], [g, 0]] (da, dmu) =
          (0, -(A - A0, V - V0))``, the correction that leaves the linearised dynamic residual
          ``adot - mu . g`` unchanged when the multipliers move by ``dmu`` too (what the next
          Newton step would do for the constraints, without a solve);
        - without: the smallest move, along ``g^T`` (``dmu = 0``).

        Iterated with ``g`` at the corrected point until the misfit is below ``tolerance``
        relative (at most ``max_iterations``).  Returns the corrected coefficients and the
        multipliers' change.  Raises :class:`~vesicle.geometry.surface.ShapeError` (a shape not
        representable) and ``ValueError`` when the accumulated move exceeds ``max_move``.
        """
        a = np.asarray(a, float).copy()
        start = a.copy()
        dmu = np.zeros(2)
        targets = np.array(self.targets)
        n = a.size
        for _ in range(max_iterations):
            shape = self.shape(a)
            misfit = np.array([shape.area, shape.volume]) - targets
            if np.all(np.abs(misfit) <= tolerance * targets):
                break
            g = self.gradients(shape)
            if jacobian is None:
                a -= g.T @ np.linalg.solve(g @ g.T, misfit)
            else:
                J = np.zeros((n + 2, n + 2))
                J[:n, :n], J[:n, n:], J[n:, :n] = jacobian, -g.T, g
                step = np.linalg.solve(J, np.concatenate([np.zeros(n), -misfit]))
                a += step[:n]
                dmu += step[n:]
            moved = float(np.linalg.norm(a - start))
            if moved > max_move:
                raise ValueError(f"the constraint correction moved {moved:.2e} > {max_move:.2e}")
        return a, dmu

    def constraint_hessians(self, a: np.ndarray, step: float = 1e-5) -> np.ndarray:
        """``d^2 A / da^2`` and ``d^2 V / da^2`` (2, size, size) by central differences of the
        exact gradients (geometry only, ``2 size`` shapes; error O(step^2), about 1e-10).

        The residual ``adot - mu . g`` has the Jacobian ``M - mu . H``; Newton with ``M`` alone
        converges only linearly where ``|mu . H|`` is not small against ``M``'s smallest
        scales: at v = 0.85, chi = 1, lam = 3.9 (N = 4, 16 x 32) ``mu = (0.0056, -0.0137)``,
        ``|H_A| = 115``, ``|mu . H| = 0.51``, and the contraction was 0.49 per iteration; with
        the term, 2e-2, 4.4e-4, 5.8e-6, 3.4e-9 (measured, docs/reference/steady.md)."""
        a = np.asarray(a, float)
        n = a.size
        H = np.empty((2, n, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = step
            plus, minus = self.gradients(self.shape(a + e)), self.gradients(self.shape(a - e))
            H[:, :, j] = (plus - minus) / (2.0 * step)
        return 0.5 * (H + H.transpose(0, 2, 1))  # symmetric up to the differences' error

    def residual(
        self, shape: Shape, rate: np.ndarray, multipliers: np.ndarray, gradients: np.ndarray
    ) -> tuple[np.ndarray, float]:
        """The residual vector ``(adot - mu . g, A - A0, V - V0)`` and its size: the max-norm of
        the dynamic part relative to ``|chi|`` plus that of the constraints."""
        area0, volume0 = self.targets
        G = np.concatenate(
            [rate - multipliers @ gradients, [shape.area - area0, shape.volume - volume0]]
        )
        size = float(np.max(np.abs(G[:-2])) / abs(self.physics.chi) + np.max(np.abs(G[-2:])))
        return G, size

    # -------------------------------------------------------------- Jacobian
    def jacobian(
        self,
        a: np.ndarray,
        base: np.ndarray | None = None,
        sigma0=None,
        central: bool = False,
        executor: Executor | None = None,
    ) -> tuple[np.ndarray, int]:
        """``M = d adot / d a`` and the number of velocity solves it took.

        ``jacobian_method="linearised"`` (default): the solve of ``a``'s shape differentiated
        (:func:`vesicle.solve.linearisation.linearised_jacobian`), exact to about 1e-9 and no solves
        (one factorisation; ``base``, ``central`` and ``executor`` are not needed).  The exact
        sphere, whose system has an extra multiplier, falls back to central differences
        (logged).

        ``"differences"`` (the reference): step ``1e-4 max(1, |a_00|)``, forward (``base =
        adot(a)`` given, one solve per column) for Newton, central (two) for the stability
        analysis, where the forward difference's O(h) bias shifts the small growth rates
        (1.5 % of omega_I at N = 4, against 0.02 %).  The central difference's own O(h^2)
        error is about 1e-5 relative (measured against the linearised Jacobian and against
        differences of steps 3e-4, 1e-4, 3e-5).
        """
        if self.jacobian_method == "linearised":
            shape = self.shape(a)
            if abs(shape.reduced_volume - 1.0) >= SPHERE_TOLERANCE:
                reused = _reused(self, shape)
                if reused is not None:
                    return self._weighed(reused), 0
                _assembled(self._solver(shape))  # not timed: common to both ways
                start = time.perf_counter()
                kept = self.kept.system  # a viscous membrane's solve may have factorised it
                if kept is not None and kept[0] == self._key(shape):
                    system = kept[1]
                else:
                    system = self.factorise(shape)
                self.kept.stale = False
                M = linearised_jacobian(system.solver, self.basis, system=system).jacobian
                self.kept.factorised_seconds = time.perf_counter() - start
                return self._weighed(M), 0
            log.info("exact sphere: Jacobian by central differences")
            central = True
        h = JACOBIAN_STEP * max(1.0, abs(a[0]))
        column = partial(_adot_column, self, sigma0=sigma0)
        return finite_difference_jacobian(column, a, h, base, central, executor)


def _assembled(solver: VelocityTensionSolver) -> VelocityTensionSolver:
    """``solver`` with its layer potentials assembled (every kernel it uses)."""
    _ = solver.lp.single_matrix
    if solver.formulation.lam != 1.0:
        _ = solver.lp.double_matrix
    return solver


def _reused(problem: SteadyProblem, shape: Shape) -> np.ndarray | None:
    """The linearised Jacobian of ``shape`` by GMRES on the kept factorisation
    (:attr:`SteadyProblem.reuse_factorisation`), or ``None`` where a factorisation is due."""
    kept = problem.kept
    if not problem.reuse_factorisation or kept.stale:
        return None
    if kept.reuse_cost is not None and kept.reuse_cost > REUSE_COST:
        return None
    near = kept.system[1] if kept.system is not None else kept.preconditioner
    if near is None or (kept.system is not None and kept.system[0] == problem._key(shape)):
        return None  # nothing to reuse, or the shape's own system: factorised exactly anyway
    counts: list[int] = []
    solver = _assembled(problem._solver(shape))
    start = time.perf_counter()
    try:
        M = linearised_action(solver, problem.basis, np.eye(problem.basis.size), near,
                              max_iterations=REUSE_ITERATIONS, iterations=counts)  # fmt: skip
    except SolverError as err:
        log.info("Jacobian on the kept factorisation: %s; factorising", err)
        kept.stale = True
        return None
    seconds = time.perf_counter() - start
    kept.stale = max(counts) > REFRESH_ITERATIONS
    if kept.factorised_seconds is not None:  # against a factorised Jacobian's time
        kept.reuse_cost = seconds / kept.factorised_seconds
    log.info("Jacobian on the kept factorisation: %d GMRES iterations, %.2f s (%s times a "
             "factorised one)", max(counts), seconds, kept.reuse_cost)  # fmt: skip
    return M


def _adot_column(problem: SteadyProblem, a: np.ndarray, sigma0=None) -> np.ndarray:
    """``adot`` at ``a``: one Jacobian column (module level, so process pools can pickle it)."""
    return problem.adot(a, sigma0)[0]


def finite_difference_jacobian(
    f,
    x: np.ndarray,
    h: float,
    base: np.ndarray | None = None,
    central: bool = False,
    executor: Executor | None = None,
) -> tuple[np.ndarray, int]:
    """``df/dx`` by forward (needs ``base = f(x)``) or central differences of step ``h``, the
    evaluations mapped serially or through ``executor`` (same values, same order); returns the
    matrix and the number of evaluations."""
    if not central and base is None:
        raise ValueError("forward differences need base = f(x)")
    steps = [h * e for e in np.eye(x.size)]
    points = [x + d for d in steps] + ([x - d for d in steps] if central else [])
    if executor is None:
        values = [f(p) for p in points]
    else:
        values = list(executor.map(f, points))
    values = np.array(values).T
    if central:
        return (values[:, : x.size] - values[:, x.size :]) / (2.0 * h), len(points)
    return (values - base[:, None]) / h, len(points)
