"""Steady tank-treading shapes by Newton–Raphson (SPEC §8), in any steady linear flow.

The steady TT shape is symmetric under inversion through the origin and under ``y -> -y``, so
``r = sum_{l even <= N} sum_{m=0..l} a_lm Pbar_lm(cos theta) cos(m phi)`` with real ``a_lm``
(:class:`~vesicle.sphere.bases.SymmetricBasis`).  With ``adot(a)`` the projection of the filtered
``dr/dt`` onto that basis, the steady state solves

    adot(a) - lambda_A dA/da - lambda_V dV/da = 0,   A(a) = 4 pi,   V(a) = 4 pi v / 3,

the two multipliers absorbing the discrete dynamics' small failure to conserve A and V exactly.
The equations are those of a :class:`~vesicle.steady.problem.SteadyProblem`; its Jacobian ``M = d
adot / d a`` is formed by forward differences, one velocity solve per column, through any
:class:`concurrent.futures.Executor` (serial by default).  The symmetric basis needs a flow that
is itself symmetric under ``y -> -y`` (simple shear, planar extension in the x-z plane, ...).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from vesicle.geometry.diagnostics import diagnose
from vesicle.geometry.surface import Shape, ShapeError, spheroid_axes
from vesicle.model.flows import LinearFlow
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.rheology import ParticleStress
from vesicle.model.settings import (
    NEWTON_SOLVER,
    ORIENTATIONS,
    UPDATES,
    NewtonSettings,
    StabilitySettings,
    legacy_settings,
    refuse_unknown,
    warn_loose,
)
from vesicle.model.theory import effective_viscosity_ratio, misbah_tt_inclination
from vesicle.solve.solver import SolverError
from vesicle.sphere.bases import FullBasis, RealBasis, SymmetricBasis
from vesicle.sphere.rotation import rotation_matrix
from vesicle.steady.problem import SteadyProblem

__all__ = [
    "ORIENTATIONS",
    "FullBasis",
    "NewtonError",
    "RealBasis",
    "SteadyResult",
    "SymmetricBasis",
    "initial_guess",
    "steady_result_at",
    "steady_tank_treading",
]

log = logging.getLogger(__name__)

#: Newton gives up once the residual exceeds this multiple of the first one (it diverges; a
#: start closer by continuation is needed, which is cheaper than iterating on).
DIVERGED = 1e3

#: Largest size, relative to the Newton step, of the second-order constraint correction that
#: is applied (``project``).  In Newton's basin it is second order in the step (measured, N = 4,
#: 16 x 32: 0.06 at the first chord step of a branch step lam 8 -> 8.3, chi = 10, falling to
#: 1e-3 at the next); from far away (lam 8 -> 6.5) it was 0.2-7.6 and, applied, made Newton
#: diverge.
CORRECTION_RATIO = 0.25

#: Tolerances of each velocity solve in Newton and stability: tighter than SPEC's 1e-6/1e-7 so
#: that the finite-difference Jacobian is clean (``NewtonSettings().solver``).
NEWTON_TOLERANCES = NEWTON_SOLVER


class NewtonError(RuntimeError):
    """Newton did not converge; the last iterate is attached."""

    def __init__(self, message: str, result: SteadyResult | None = None):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True, eq=False)
class SteadyResult:
    """A steady tank-treading state and the Newton history that found it."""

    a: np.ndarray
    multipliers: tuple[float, float]
    shape: Shape
    problem: SteadyProblem
    residual_history: tuple[float, ...]
    converged: bool
    jacobian: np.ndarray | None  # M = d adot / d a at the solution (basis coordinates)
    gradients: np.ndarray  # (2, size): dA/da, dV/da
    psi: float
    D: float
    axes: np.ndarray  # full lengths, descending
    stress: ParticleStress
    #: ``S = S^B + S^V`` by right-hand side ("bending", "flow"); with a viscous membrane also
    #: "membrane_viscous", the moment of its viscous load (a part of ``S``, in both)
    split: dict[str, ParticleStress]
    seconds: float
    solves: int
    jacobians: int = 0  # Newton Jacobians formed by differences (the stability one not counted)
    #: How the state was reached (its provenance, in the JSON and files): "direct" (Newton from
    #: the default start), "initial" (Newton from a given state or shape), "continued from ..."
    #: (:func:`vesicle.bifurcation.branch.reach`'s detour) or "suspect: ..." (a state Newton found
    #: from the default start that looks like another branch's, kept because no easier start worked)
    start: str = "direct"

    @property
    def suspect(self) -> bool:
        """Whether the state is one its start strategy flagged as possibly another branch's."""
        return self.start.startswith("suspect")

    @property
    def physics(self) -> Physics:
        return self.problem.physics

    @property
    def discretisation(self) -> Discretisation:
        return self.problem.discretisation

    @property
    def basis(self) -> RealBasis:
        return self.problem.basis

    v = property(lambda self: self.physics.v)
    lam = property(lambda self: self.physics.lam)
    chi = property(lambda self: self.physics.chi)

    @property
    def params(self) -> dict:
        """The discretisation and solve tolerances as plain values (for output files)."""
        tol = self.problem.tolerances
        return {
            "degree": self.discretisation.degree,
            "grid": self.discretisation.grid,
            "solver_tolerances": [tol.schur, tol.inner],
        }

    @property
    def newton_iterations(self) -> int:
        return len(self.residual_history) - 1

    @property
    def long_axis(self) -> np.ndarray:
        """Unit vector of the longest principal axis (sign: x, else z, component >= 0)."""
        return diagnose(self.shape).axes[0]

    @property
    def orientation(self) -> str:
        """The branch the state lies on: "vorticity" if its long axis is along y, else "flow"
        (in the y -> -y symmetric basis it is either exactly along y or in the x-z plane)."""
        return "vorticity" if abs(self.long_axis[1]) > 0.5 else "flow"

    @property
    def residual(self) -> float:
        return self.residual_history[-1]


def _initial_angle(physics: Physics) -> float:
    """The start's inclination: Misbah's leading-order TT angle in shear (0.1 rad beyond its
    range), else the extensional axis of the rate of strain in the x-z plane."""
    flow = physics.flow
    sign = 1.0 if physics.chi >= 0 else -1.0
    if np.array_equal(flow.matrix, LinearFlow.shear().matrix):
        psi = misbah_tt_inclination(physics.v, effective_viscosity_ratio(physics.lam, physics.bq))
        return sign * (0.1 if not np.isfinite(psi) else psi)
    E = sign * flow.rate_of_strain[np.ix_([0, 2], [0, 2])]
    w, vec = np.linalg.eigh(E)
    x, z = vec[:, int(np.argmax(w))]
    return float(np.arctan(z / x)) if x != 0 else 0.5 * np.pi


def initial_guess(
    physics: Physics,
    discretisation: Discretisation,
    psi: float | None = None,
    orientation: str = "flow",
) -> np.ndarray:
    """The spheroid of ``v`` tilted to ``psi`` (default :func:`_initial_angle`) in the x-z plane,
    or with its long axis along the vorticity axis y (``orientation="vorticity"``), as
    symmetric coefficients."""
    if orientation not in ORIENTATIONS:
        raise ValueError(f"orientation must be one of {ORIENTATIONS}, got {orientation!r}")
    psi = _initial_angle(physics) if psi is None else psi
    a_ax, b_ax = spheroid_axes(physics.v)
    rotation = rotation_matrix("y", -psi)
    if orientation == "vorticity":  # body x (the long axis) -> lab y
        rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    shape = Shape.ellipsoid(
        a_ax,
        b_ax,
        b_ax,
        grid=discretisation.grid,
        degree=discretisation.degree,
        rotation=rotation,
    ).scaled_to_area()
    return SymmetricBasis(discretisation.degree).from_coefficients(shape.coefficients)


def _objects(physics, discretisation, loose: tuple, legacy: dict) -> tuple[Physics, Discretisation]:
    """The parameter objects of either call form: objects, or the former loose scalars
    ``v, lam, chi, degree=, grid=`` (taken out of ``legacy``, with a deprecation warning)."""
    scalars = {k: legacy.pop(k) for k in ("v", "lam", "chi", "degree", "grid") if k in legacy}
    scalars.update(zip(("chi", "degree", "grid"), loose, strict=False))
    if len(loose) > 3:
        raise TypeError("steady_tank_treading takes at most 5 positional arguments, "
                        f"got {2 + len(loose)}")  # fmt: skip
    scalars = _given(**scalars)
    if isinstance(physics, Physics):
        if any(k in scalars for k in ("chi", "v", "lam")):
            raise ValueError("give the physics as a Physics object or as v, lam, chi, not both")
        if discretisation is not None and not isinstance(discretisation, Discretisation):
            raise TypeError("with a Physics, the second argument must be a Discretisation")
        if discretisation is not None and ("degree" in scalars or "grid" in scalars):
            raise ValueError("give degree and grid in the Discretisation, not as keywords")
        if scalars:
            warn_loose("steady_tank_treading", scalars)
        return physics, discretisation or Discretisation(**scalars)
    v = physics if physics is not None else scalars.pop("v", None)
    lam = discretisation if discretisation is not None else scalars.pop("lam", None)
    chi = scalars.pop("chi", None)
    if v is None or lam is None or chi is None:
        raise TypeError("steady_tank_treading needs Physics (and Discretisation), or v, lam, chi")
    warn_loose("steady_tank_treading", {"v": v, "lam": lam, "chi": chi, **scalars})
    return Physics(v=v, lam=lam, chi=chi), Discretisation(**scalars)


def _given(**values) -> dict:
    return {k: x for k, x in values.items() if x is not None}


def _check_problem(physics: Physics) -> None:
    if physics.chi == 0 or physics.flow.is_zero:
        raise ValueError("steady tank-treading needs a background flow (a finite, non-zero chi)")
    G = physics.flow.matrix
    P = np.diag([1.0, -1.0, 1.0])
    if not np.allclose(P @ G @ P, G):
        raise ValueError(
            "the steady solver's symmetric basis needs a flow symmetric under y -> -y (no "
            f"velocity-gradient entries coupling y with x or z); got {G.tolist()}"
        )


def steady_tank_treading(
    physics: Physics | float,
    discretisation: Discretisation | float | None = None,
    *loose: float,
    initial: np.ndarray | Shape | SteadyResult | None = None,
    guess: np.ndarray | None = None,
    newton: NewtonSettings | None = None,
    analysis: StabilitySettings | None = None,
    executor: Executor | None = None,
    progress=None,
    **legacy,
) -> SteadyResult:
    """Newton–Raphson for the steady tank-treading shape (SPEC §8).

    Parameters
    ----------
    physics, discretisation : Physics, Discretisation
        The parameter point and its resolution (default ``Discretisation()``: N = 8 on 32 x 64).
        The former form ``steady_tank_treading(v, lam, chi, degree=8, grid=32)`` gives the same
        result bit for bit, with a :class:`VesicleDeprecationWarning`.
    initial : array of symmetric coefficients, Shape, SteadyResult, or None
        Start; default :func:`initial_guess`.  A :class:`SteadyResult` (a neighbouring solution,
        for continuation in lam, chi or v) also gives the multipliers and, at the same degree
        and grid, its Jacobian: Newton then starts with chord iterations on that Jacobian (one
        solve each instead of one per column) and forms a fresh one as soon as an iteration
        fails to reduce the residual by ``newton.chord_contraction``.
    guess : array, optional
        Start coefficients (a predictor) that replace those of ``initial``, whose multipliers
        and Jacobian are still used (continuation along a branch).
    newton : NewtonSettings
        Tolerance (the residual's max-norm, relative to ``chi`` for the dynamic part), iteration
        limit (:class:`NewtonError` beyond it), Jacobian updates, constraint order,
        preconditioning and the velocity solves' tolerances; default ``NewtonSettings()``.

        - ``updates="broyden"`` (default): once a Newton step on a Jacobian formed by
          differences has contracted the residual by ``chord_contraction``, that Jacobian is
          reused for the following steps with good-Broyden rank-one updates (one solve per step)
          until a step contracts it by less; ``"none"``: the reference, a fresh Jacobian at
          every step once the chord steps on a neighbour's Jacobian stop paying.
        - ``constraints="second-order"`` (default): the Newton matrix includes the multipliers'
          curvature term ``-mu . d^2(A, V)/da^2``
          (:meth:`vesicle.steady.problem.SteadyProblem.constraint_hessians`), so Newton
          converges quadratically where the multipliers are not small (v = 0.85: linear with
          ratio 0.49 without it), and every iterate is moved back onto the area and volume
          constraints by the bordered step of the matrix it was found with
          (:meth:`vesicle.steady.problem.SteadyProblem.project`; no solve).
          ``"first-order"``: the method before.
        - ``preconditioned=True`` (default, linearised Jacobians): solve the iterates by GMRES
          preconditioned with the last Jacobian's factorised system; ``False``: the nested GMRES.
    analysis : StabilitySettings, optional
        ``orientation``: the branch sought, in-plane (``"flow"``: the start is the spheroid
        tilted in the shear plane) or along the vorticity axis (the start is the spheroid along
        y); a converged state on the other branch is refused with :class:`NewtonError`.
        ``jacobian``: ``"linearised"`` (the solve differentiated, no solves per column, exact to
        about 1e-9) or ``"differences"`` (the reference; the ``executor`` runs its columns).
        Default: the orientation of ``initial`` if it is a :class:`SteadyResult` (continuation
        stays on its branch), else ``"flow"``, and linearised Jacobians.
    executor : concurrent.futures.Executor, optional
        Runs the Jacobian columns (e.g. a ``ProcessPoolExecutor`` or a Dask client's executor).
    progress : callable, optional
        Called after every Newton iteration with ``{"lam", "chi", "iteration", "residual",
        "seconds"}``.

    The former keywords ``tolerance``, ``max_iterations``, ``solver_tolerances``, ``updates``,
    ``chord_contraction``, ``constraints``, ``preconditioned`` (now :class:`NewtonSettings`)
    and ``jacobian``, ``orientation`` (now :class:`StabilitySettings`) work for one release,
    with a :class:`VesicleDeprecationWarning`.
    """
    physics, discretisation = _objects(physics, discretisation, loose, legacy)
    newton = legacy_settings("steady_tank_treading", NewtonSettings, newton, legacy,
                             {"solver_tolerances": "solver"}) or NewtonSettings()  # fmt: skip
    analysis = legacy_settings("steady_tank_treading", StabilitySettings, analysis, legacy)
    refuse_unknown("steady_tank_treading", legacy)
    if analysis is None:
        analysis = StabilitySettings(
            orientation=initial.orientation if isinstance(initial, SteadyResult) else "flow")
    orientation = analysis.orientation
    initial_is_default = initial is None
    if initial is None and orientation != "flow":
        initial = initial_guess(physics, discretisation, orientation=orientation)
    _check_problem(physics)
    problem = SteadyProblem(physics, discretisation, newton.solver,
                            jacobian_method=analysis.jacobian,
                            preconditioned=newton.preconditioned)  # fmt: skip
    settings = newton
    newton = _Newton(problem, executor, settings.chord_contraction, progress, settings.updates,
                     settings.constraints == "second-order")  # fmt: skip
    newton.start(initial)
    if guess is not None:
        guess = np.asarray(guess, float)
        if guess.shape != newton.a.shape:
            raise ValueError(f"guess must have {newton.a.size} coefficients, got {guess.shape}")
        newton.a = guess.copy()
    converged = newton.iterate(settings.tolerance, settings.iterations)
    result = newton.result(converged)
    if not initial_is_default:
        result = dataclasses.replace(result, start="initial")
    if not converged:
        how = "diverged after" if newton.diverged else "did not converge in"
        raise NewtonError(
            f"Newton {how} {len(newton.history) - 1} iterations at lam = {physics.lam:g}, "
            f"chi = {physics.chi:g} ({_halvings(newton.halved)}): residual history "
            f"{', '.join(f'{r:.1e}' for r in newton.history)}; start closer (continuation in "
            "small steps), from a short time-dependent run, or allow more iterations",
            result,
        )
    if result.orientation != orientation:
        axis = ", ".join(f"{x:+.3f}" for x in result.long_axis)
        raise NewtonError(
            f"Newton converged on the {result.orientation!r} branch (long axis ({axis})) at "
            f"lam = {physics.lam:g}, chi = {physics.chi:g}, not the {orientation!r} one asked "
            "for: start closer to it (continuation from a state on it)",
            result,
        )
    return result


def steady_result_at(
    problem: SteadyProblem,
    a: np.ndarray,
    multipliers: np.ndarray,
    executor: Executor | None = None,
) -> SteadyResult:
    """The :class:`SteadyResult` of a state already converged by other means (a
    pseudo-arclength corrector, where Newton at fixed parameters is singular, at a fold): one
    evaluation, the central-difference Jacobian and the split stress, no Newton step."""
    newton = _Newton(problem, executor, 0.7, None, "none")
    newton.a, newton.mult = np.asarray(a, float).copy(), np.asarray(multipliers, float).copy()
    newton.state, res = newton._evaluate(None)
    newton.history.append(res)
    return newton.result(converged=True)


class _Newton:
    """The Newton iteration's state: iterate, multipliers, history, the chord Jacobian."""

    def __init__(
        self,
        problem: SteadyProblem,
        executor,
        chord_contraction: float,
        progress,
        updates: str,
        second_order: bool = False,
    ):
        if updates not in UPDATES:
            raise ValueError(f"updates must be one of {UPDATES}, got {updates!r}")
        self.updates = updates
        self.second_order = second_order  # curvature term, constraint correction
        self.hessians = None  # d2(A, V)/da2 at the last fresh Jacobian (second order)
        self.chord = None  # a reused Jacobian (a neighbour's, or Broyden-updated)
        self.matrix = None  # the Newton matrix of the last step
        self.step_size = 0.0
        self.fresh = False  # whether the last step used a freshly differenced Jacobian
        self.candidate = None  # that Jacobian, until the step's contraction is known
        self.jacobians = 0  # Jacobians formed by differences
        self.P = problem
        self.executor = executor
        self.contraction = chord_contraction
        self.progress = progress
        self.t0 = time.perf_counter()
        self.solves = 0
        self.history: list[float] = []
        self.halved = 0  # Newton steps halved to stay representable
        self.diverged = False

    def start(self, initial) -> None:
        P = self.P
        self.mult = np.zeros(2)
        self.chord = None  # a neighbour's Jacobian, used until it stops paying
        if initial is None:
            self.a = initial_guess(P.physics, P.discretisation)
        elif isinstance(initial, SteadyResult):
            self.a = P.coefficients_of(initial.shape)
            self.mult = np.array(initial.multipliers, float)
            same = (
                initial.discretisation.degree == P.discretisation.degree
                and initial.discretisation.grid == P.discretisation.grid
            )
            self.chord = initial.jacobian if same else None
        elif isinstance(initial, Shape):
            self.a = P.coefficients_of(initial)
        else:
            self.a = np.asarray(initial, float).copy()

    def _evaluate(self, sigma):
        """Solve at the current iterate; returns its state tuple and residual size."""
        if self.second_order and self.matrix is not None and self.step_size > 0:
            # applied only where it is second order against the step (Newton's basin)
            try:
                limit = CORRECTION_RATIO * self.step_size
                self.a, dmu = self.P.project(self.a, self.matrix, max_move=limit)
                self.mult = self.mult + dmu
            except (ShapeError, ValueError, np.linalg.LinAlgError) as err:
                log.info("constraint correction not applied: %s", err)
        shape = self.P.shape(self.a)
        if self.chord is not None and self.P.wants_preconditioner(shape):
            # from a neighbour's Jacobian, several chord steps follow, one solve each: the
            # first iterate's system (about 1.5 solves) preconditions them (half a solve each)
            self.P.factorise(shape)
        rate, flow = self.P.adot(self.a, sigma)
        self.solves += 1
        g = self.P.gradients(shape)
        G, res = self.P.residual(shape, rate, self.mult, g)
        return (self.a, self.mult, rate, flow.sigma, g, G, flow), res

    def _report(self, it: int, res: float) -> None:
        seconds = time.perf_counter() - self.t0
        log.info("Newton %d: residual %.3e (%.1f s)", it, res, seconds)
        if self.progress is not None:
            p = self.P.physics
            self.progress(
                {"lam": p.lam, "chi": p.chi, "iteration": it, "residual": res, "seconds": seconds}
            )

    def iterate(self, tolerance: float, max_iterations: int) -> bool:
        previous = None  # the state a step was last taken from
        step = np.zeros(self.a.size + 2)
        sigma = None
        for it in range(max_iterations + 1):
            try:
                state, res = self._evaluate(sigma)
            except (ShapeError, SolverError) as err:  # an iterate too far: no shape, or no solve
                if previous is None:
                    raise
                if it == max_iterations:  # report the last representable iterate
                    self.state = previous
                    return False
                if not self.fresh:
                    log.info("step on a reused Jacobian left the representable shapes (%s): "
                             "fresh Jacobian", err)  # fmt: skip
                    self.chord, state = None, previous
                else:  # a Newton step too long for the radial representation: halve it
                    log.info("Newton step left the representable shapes (%s): halved", err)
                    self.halved += 1
                    step = 0.5 * step
                    self.step_size = float(np.linalg.norm(step[: self.a.size]))
                    self.a = previous[0] + step[: self.a.size]
                    self.mult = previous[1] + step[self.a.size :]
                    continue
            else:
                self.history.append(res)
                self._report(it, res)
                self.state = state
                if res < tolerance:
                    return True
                if res > DIVERGED * self.history[0] or not np.isfinite(res):
                    log.info("Newton diverges (residual %.1e from %.1e): giving up", res,
                             self.history[0])  # fmt: skip
                    self.diverged = True
                    return False
                if previous is not None and self.fresh:
                    self._adopt(self.history[-1] / self.history[-2])
                elif previous is not None:
                    state = self.state = self._check_chord(state, previous)
                if previous is not None and self.chord is not None and state is not previous:
                    self._broyden(previous, state)
            if it == max_iterations:
                return False
            previous = self.state = state
            step = self._step(state)
            self.a, self.mult, sigma = state[0] + step[:-2], state[1] + step[-2:], state[3]
            self.step_size = float(np.linalg.norm(step[:-2]))
        return False

    def _check_chord(self, state, previous):
        """After a step on a reused Jacobian: keep it while it contracts the residual by
        ``contraction``; else a fresh one (from the last state if the step made things worse)."""
        ratio = self.history[-1] / self.history[-2]
        if ratio <= self.contraction:
            return state
        log.info("step on a reused Jacobian contracted by %.2f only: fresh Jacobian", ratio)
        self.chord = None
        return previous if ratio > 1.0 else state

    def _adopt(self, ratio: float) -> None:
        """After a step on a fresh Jacobian: with Broyden updates, keep reusing it once such a
        step has contracted the residual by ``contraction`` (Newton's basin); farther out,
        Newton keeps forming fresh Jacobians, like the reference."""
        if self.updates == "broyden" and ratio <= self.contraction:
            self.chord = self.candidate
        self.candidate = None

    def _broyden(self, previous, state) -> None:
        """Good Broyden update of the reused Jacobian with the step just taken (SPEC §8's M
        only; the constraint gradients are exact at every iterate)."""
        if self.updates != "broyden":
            return
        da = state[0] - previous[0]
        dr = state[2] - previous[2]
        norm = float(da @ da)
        if norm > 0.0:
            self.chord = self.chord + np.outer(dr - self.chord @ da, da) / norm

    def _step(self, state) -> np.ndarray:
        a, _, rate, sigma, g, G, _ = state
        self.fresh = self.chord is None
        if self.fresh:
            M, n = self.P.jacobian(a, rate, sigma, executor=self.executor)
            self.solves += n
            self.jacobians += 1
            self.candidate = M  # reused with rank-one updates if this step contracts enough
        else:
            M = self.chord
        if self.second_order:  # the true Jacobian of adot - mu . g: M - mu . H
            if self.fresh or self.hessians is None:
                self.hessians = self.P.constraint_hessians(a)
            M = M - np.einsum("k,kij->ij", state[1], self.hessians)
        self.matrix = M
        return _newton_step(M, g, G)

    def result(self, converged: bool) -> SteadyResult:
        a, mult, rate, sigma, g, _, flow = self.state
        # The Jacobian at the solution, by central differences, for the stability analysis.
        # Newton steps neglect the multipliers' curvature terms lambda_A d2A/da2: the
        # multipliers are at the level of the discrete drift.
        M = None
        if converged:
            M, n = self.P.jacobian(a, rate, sigma, central=True, executor=self.executor)
            self.solves += n
        shape = self.P.shape(a)
        d = diagnose(shape)
        split_flow = self.P.solve(shape, flow.sigma, split=True)
        self.solves += 3
        self.P.release()  # the result keeps its problem, not the problem's operators
        return SteadyResult(
            a=a,
            multipliers=(float(mult[0]), float(mult[1])),
            shape=shape,
            problem=self.P,
            residual_history=tuple(self.history),
            converged=converged,
            jacobian=M,
            gradients=g,
            psi=d.psi,
            D=d.D,
            axes=d.lengths,
            stress=split_flow.stress,
            split={**split_flow.split, **({"membrane_viscous": split_flow.viscous}
                                          if split_flow.viscous is not None else {})},
            seconds=time.perf_counter() - self.t0,
            solves=self.solves,
            jacobians=self.jacobians,
        )


def _halvings(k: int) -> str:
    """The log's words for ``k`` Newton steps halved (each halving is one more pass, not one more
    iteration: the history counts only the steps evaluated)."""
    if k == 0:
        return "no step halved"
    return f"besides {k} step halving{'s' if k > 1 else ''} where a step left the radial " \
           "representation"


def _newton_step(M: np.ndarray, g: np.ndarray, G: np.ndarray) -> np.ndarray:
    n = M.shape[0]
    J = np.zeros((n + 2, n + 2))
    J[:n, :n] = M
    J[:n, n:] = -g.T
    J[n:, :n] = g
    return np.linalg.solve(J, -G)
