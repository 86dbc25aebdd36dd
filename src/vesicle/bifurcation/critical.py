"""The critical viscosity ratio lambda_c(v, chi) by a bracketing root search (SPEC §9).

The reference for the neutral-curve tracer (:mod:`vesicle.bifurcation.neutral`): at fixed ``(v,
chi)`` the
largest growth rate ``omega_I(lam)`` of the steady tank-treading state is bracketed and its root
found by Brent's method, each evaluation a Newton solve from the nearest solution found so far.
The first evaluation starts as ``vesicle tt`` does (:func:`vesicle.bifurcation.branch.reach`):
Newton from
the default start, or continuation from an easier point where that fails or lands on a state
with a real unstable mode (another branch).
"""

from __future__ import annotations

import dataclasses
import logging
from concurrent.futures import Executor
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from vesicle.bifurcation.branch import branch, reach
from vesicle.geometry.surface import ShapeError
from vesicle.io.files import stamped
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import (
    ContinuationSettings,
    CriticalSearch,
    NewtonSettings,
    StabilitySettings,
    legacy_settings,
    refuse_unknown,
    warn_loose,
)
from vesicle.model.theory import misbah_critical_lambda
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NewtonError, SteadyResult, steady_tank_treading
from vesicle.steady.stability import stability

#: Largest relative change of lam reached by one Newton solve from the nearest solution; farther
#: steps go by a branch (continuation with step halving and a jump guard).
JUMP_RATIO = 0.05

#: What a search may fail with (then the search without the coarse start is tried).
_FAILURES = (NewtonError, ShapeError, SolverError, np.linalg.LinAlgError)

#: The coarse resolution of ``coarse="auto"``: N = 4 on 16 x 32. There lambda_c lies 1-3 % (v =
#: 0.95) and 6-8 % (v = 0.90) below N = 8's on 32 x 64 (docs/notes/continuation-measurements.md),
#: against a factor 2.3 for the leading-order estimate at v = 0.95, chi = 1.
COARSE = {"grid": 16, "degree": 4}

#: Tolerance on the coarse lambda_c (it only places the first evaluations).
COARSE_XTOL = 1e-2

#: Relative step from the coarse lambda_c to the second evaluation at full resolution.
COARSE_STEP = 0.02

#: Largest change of psi (rad) from the coarse critical state to the state Newton continues it
#: to at full resolution; farther, Newton is taken to have left the branch.
COARSE_PSI = 0.15

__all__ = ["CriticalResult", "critical_lambda", "critical_summary"]

log = logging.getLogger(__name__)


def _bracket(f, x0: float, step: float, factor: float, moves: int = 12) -> tuple[float, float]:
    """Two neighbouring points where ``f`` (increasing through its root, as the growth rate in
    lambda) changes sign: ``x0``, ``x0`` moved by the relative ``step`` towards the root, then
    secant steps in ``log x`` pushed 20 % past the predicted root and capped at ``factor``."""
    if not step > 0 or not factor > 1:
        raise ValueError(f"need step > 0 and factor > 1, got step={step}, factor={factor}")
    points = [(x0, f(x0))]
    x = x0 * (1.0 + step) if points[0][1] < 0 else x0 / (1.0 + step)
    points.append((x, f(x)))
    for _ in range(moves):
        (x0, f0), (x1, f1) = points[-2:]
        if f0 * f1 <= 0:
            break
        direction = 1.0 if f1 < 0 else -1.0  # below the root: go up
        u0, u1 = np.log(x0), np.log(x1)
        move = -1.2 * f1 * (u1 - u0) / (f1 - f0) if f1 != f0 else np.inf
        if not move * direction > 0:  # the secant points away from the root
            move = direction * np.log(factor)
        move = direction * min(abs(move), np.log(factor))
        x = float(np.exp(u1 + move))
        points.append((x, f(x)))
    (x0, f0), (x1, f1) = points[-2:]
    if f0 * f1 > 0:
        raise RuntimeError(
            "could not bracket lambda_c: max omega_I did not change sign at lam = "
            + ", ".join(f"{p[0]:.4g}" for p in points)
        )
    return min(x0, x1), max(x0, x1)


def _critical_objects(physics, discretisation, legacy: dict) -> tuple[Physics, Discretisation]:
    """The parameter objects of either call form of :func:`critical_lambda` (the former loose
    ``v, chi, degree=, grid=`` are taken out of ``legacy``, with a deprecation warning)."""
    loose = {k: legacy.pop(k) for k in ("v", "chi", "degree", "grid") if k in legacy}
    loose = {k: x for k, x in loose.items() if x is not None}
    sizes = {k: loose[k] for k in ("grid", "degree") if k in loose}
    if isinstance(physics, Physics):
        if "v" in loose or "chi" in loose:
            raise ValueError("give the physics as a Physics object or as v, chi, not both")
        if discretisation is not None and sizes:
            raise ValueError("give degree and grid in the Discretisation, not as keywords")
    else:
        v = physics if physics is not None else loose.get("v")
        chi = discretisation if discretisation is not None else loose.get("chi")
        if v is None or chi is None:
            raise TypeError("critical_lambda needs Physics (and Discretisation), or v and chi")
        physics, discretisation = Physics(v=v, chi=chi), None
        loose = {"v": v, "chi": chi, **loose}
    if loose:
        warn_loose("critical_lambda", loose)
    if discretisation is None:
        discretisation = Discretisation(**sizes)
    return physics, discretisation


@dataclass(frozen=True)
class CriticalResult:
    """``lambda_c`` where the largest ``omega_I`` crosses zero, and the bifurcation type."""

    lambda_c: float
    bifurcation: str  # "saddle-node" (real crossing) or "hopf" (complex pair)
    omega_R: float
    history: tuple[tuple[float, float, float], ...]  # (lam, omega_R, omega_I) evaluated
    #: the first search at a coarse resolution this one started from (``coarse`` option)
    coarse: CriticalResult | None = None
    #: the steady states evaluated, in the order of ``history`` (starts for what follows: the
    #: neutral-curve tracer continues from the stable one nearest lambda_c)
    states: tuple[SteadyResult, ...] = field(default=(), repr=False, compare=False)


def vorticity_start_lambda(v: float) -> float:
    """Where a search on the vorticity-aligned branch starts by default: four times the
    leading-order in-plane lambda_c (:func:`vesicle.model.theory.misbah_critical_lambda`), at least
    4. That branch's lambda_c lies well above the in-plane one (the paper's Fig. 22; 14.4 at v =
    0.95, chi = 4, N = 8), and below about twice the leading-order value Newton from the spheroid
    along y slides onto the in-plane branch (v = 0.90, chi = 1 and 2, lam = 4.28, N = 4) while at
    lam = 8 and 16 it converges on the vorticity branch."""
    return 4.0 * max(1.0, misbah_critical_lambda(v))


def _default_start(physics: Physics) -> float:
    """The first lambda of a search: the leading-order in-plane lambda_c, at least 1; with a
    viscous membrane that estimate less ``(16/23) Bq`` (the leading-order theories' effective
    viscosity ratio ``lam + (16/23) Bq``, :func:`vesicle.model.theory.effective_viscosity_ratio`),
    at least 0.5."""
    estimate = misbah_critical_lambda(physics.v)
    if physics.bq == 0.0:
        return max(1.0, estimate)
    return max(0.5, estimate - 16.0 * physics.bq / 23.0)


def critical_lambda(
    physics: Physics | float,
    discretisation: Discretisation | float | None = None,
    *,
    search: CriticalSearch | None = None,
    newton: NewtonSettings | None = None,
    analysis: StabilitySettings | None = None,
    executor: Executor | None = None,
    progress=None,
    **legacy,
) -> CriticalResult:
    """Bracketing root search for ``lambda_c(v, chi)`` with continuation of the steady shape.

    Called as ``critical_lambda(physics, discretisation)`` (``physics.lam`` is not used: it is
    what is sought); the former ``critical_lambda(v, chi, degree=8, grid=32)`` still works for
    one release, with a :class:`~vesicle.model.settings.VesicleDeprecationWarning`, as do the
    former keywords of the settings objects (``lam0``, ``step``, ``factor``, ``xtol``,
    ``coarse``: :class:`CriticalSearch`; ``max_iterations``: :class:`NewtonSettings`;
    ``jacobian``, ``modes``, ``orientation``: :class:`StabilitySettings`).

    ``search`` (:class:`CriticalSearch`): starts at ``lam0`` (default: the leading-order
    estimate, at least 1) and at ``lam0`` moved by the relative ``step`` towards the crossing
    (up when stable); then secant steps in ``log lam``, pushed 20 % past the predicted root and
    limited to a factor ``factor``, until ``max omega_I`` changes sign; then Brent's method to
    ``xtol``.  Each evaluation starts Newton (at most ``newton.max_iterations``) from the
    nearest solution found so far, with chord iterations on its Jacobian
    (:func:`steady_tank_treading`), so a nearby evaluation costs little more than the stability
    Jacobian itself.

    ``coarse``: a first search at a coarse resolution (``"auto"``: :data:`COARSE`, N = 4 on
    16 x 32, when ``discretisation`` is finer, ``lam0`` is not given and the branch is the
    in-plane one with symmetric modes; a :class:`Discretisation`; or ``None``).  Its
    ``lambda_c`` is then the first evaluation here, with the relative step :data:`COARSE_STEP`
    (instead of ``step``), and its critical state the start of that evaluation's Newton
    (continuation in resolution), so the search at full resolution skips the far bracketing
    moves from the leading-order estimate and the detours of the default start.  A coarse
    search that fails, a state that does not match its coarse start (another branch), or a
    search from there that fails fall back to the search without it (logged).  Progress
    records of the coarse search carry ``"level": "coarse"``.

    ``analysis.modes`` are the perturbations whose growth is bracketed (``"general"`` for the
    out-of-plane branch, which loses stability to perturbations that break the x-z symmetry);
    ``analysis.orientation`` the TT branch of the first evaluation (later ones continue from
    it); ``newton.max_iterations`` limits each evaluation's Newton.
    """
    physics, discretisation = _critical_objects(physics, discretisation, legacy)
    search = legacy_settings("critical_lambda", CriticalSearch, search, legacy) or CriticalSearch()
    newton = legacy_settings("critical_lambda", NewtonSettings, newton, legacy)
    analysis = legacy_settings("critical_lambda", StabilitySettings, analysis, legacy)
    refuse_unknown("critical_lambda", legacy)
    analysis = analysis if analysis is not None else StabilitySettings()
    lam0, step, xtol = search.lam0, search.step, search.xtol
    options = {"factor": search.factor, "executor": executor, "progress": progress,
               "newton": newton, "analysis": analysis}  # fmt: skip
    coarse_disc = _coarse_discretisation(discretisation, search.coarse, lam0, analysis)
    given = {"lam0": lam0, "step": step}  # the search without the coarse start
    first, coarse_result = None, None
    if coarse_disc is not None:
        coarse_options = dict(options)
        if progress is not None:  # the coarse evaluations, told apart from the others
            coarse_options["progress"] = lambda info: progress({"level": "coarse", **info})
        try:
            coarse_result, states = _search(physics, coarse_disc, lam0, step,
                                            max(xtol, COARSE_XTOL), None,
                                            **coarse_options)  # fmt: skip
        except (*_FAILURES, RuntimeError) as err:
            log.warning("the coarse search (N = %d on %d x %d) failed (%s): searching from the "
                        "default start", coarse_disc.degree, coarse_disc.grid,
                        2 * coarse_disc.grid, err)  # fmt: skip
        else:
            lam0, step = coarse_result.lambda_c, COARSE_STEP
            first = states[min(states, key=lambda x: abs(x - lam0))]
            log.info("coarse lambda_c = %.5g (N = %d on %d x %d): the search starts there",
                     lam0, coarse_disc.degree, coarse_disc.grid, 2 * coarse_disc.grid)  # fmt: skip
            if progress is not None:
                progress({"coarse": f"lambda_c = {lam0:.5g} at N = {coarse_disc.degree} on "
                                    f"{coarse_disc.grid}x{2 * coarse_disc.grid}"})  # fmt: skip
    if coarse_result is None:
        return _search(physics, discretisation, lam0, step, xtol, None, **options)[0]
    try:
        result, _ = _search(physics, discretisation, lam0, step, xtol, first, **options)
    except (*_FAILURES, RuntimeError) as err:  # as without the coarse search
        log.warning("the search from the coarse lambda_c = %.5g failed (%s): searching from the "
                    "default start", lam0, err)  # fmt: skip
        return _search(physics, discretisation, given["lam0"], given["step"], xtol, None,
                       **options)[0]  # fmt: skip
    return dataclasses.replace(result, coarse=coarse_result)


def _coarse_discretisation(disc, coarse, lam0, analysis) -> Discretisation | None:
    if coarse is None or isinstance(coarse, Discretisation):
        return coarse
    finer = disc.degree > COARSE["degree"] and disc.grid > COARSE["grid"]
    in_plane = analysis.orientation == "flow" and analysis.modes == "symmetric"
    if lam0 is not None or not finer or not in_plane:
        return None
    return disc.replace(n_rot=None, **COARSE)


def _first_state(physics, disc, start, solve: dict) -> SteadyResult:
    """The first evaluation's state: continued from the coarse critical state ``start`` (the
    same parameters at a coarser resolution) when it converges to a state like it, else as
    ``vesicle tt`` starts (continuation where Newton cannot)."""
    if start is not None:
        try:
            steady = steady_tank_treading(physics, disc, initial=start, **solve)
        except _FAILURES as err:
            log.warning("Newton from the coarse critical state failed (%s): default start", err)
        else:
            turned = abs(steady.psi - start.psi)
            if turned <= COARSE_PSI:
                return steady
            log.warning("the state continued from the coarse one turned by %.3g rad (psi %.4g "
                        "against %.4g): another branch; default start", turned, steady.psi,
                        start.psi)  # fmt: skip
    state = reach(physics, disc, verify_unstable=True, **solve)
    if state.suspect:  # the search would start on another branch: refuse, say why
        raise NewtonError(
            f"no trustworthy first state at lam = {physics.lam:g}, chi = {physics.chi:g} for the "
            f"critical-lambda search ({state.start}); give --lam0 closer to a stable tank-"
            "treading state"
        )
    return state


def _search(
    physics, discretisation, lam0, step, xtol, first, *, factor, executor, progress,
    newton: NewtonSettings | None, analysis: StabilitySettings,
) -> tuple[CriticalResult, dict[float, SteadyResult]]:  # fmt: skip
    """The bracket and Brent's method at one resolution; the result and the states found."""
    history: list[tuple[float, float, float]] = []
    solutions: dict[float, SteadyResult] = {}

    def growth(lam: float) -> float:
        for done, _, w_i in history:  # Brent re-evaluates the bracket's ends: reuse them
            if done == lam:
                return w_i
        solve = {"executor": executor, "progress": progress, "newton": newton,
                 "analysis": analysis}  # fmt: skip
        try:
            if solutions:
                nearest = min(solutions, key=lambda x: abs(np.log(x / lam)))
                if abs(np.log(lam / nearest)) <= JUMP_RATIO:
                    steady = steady_tank_treading(physics.replace(lam=lam), discretisation,
                                                  initial=solutions[nearest], **solve)  # fmt: skip
                else:  # a far secant step: by a branch with step halving and its jump guard,
                    # so that it cannot land on another steady state (measured: chi = 3.162,
                    # N = 4, one Newton jump found lam_c = 6.627 on another branch, not 8.590)
                    leg = branch(solutions[nearest].physics, discretisation, "lam", [lam],
                                 start=solutions[nearest],
                                 continuation=ContinuationSettings(locate=False, arclength=False),
                                 analysis=analysis, executor=executor)  # fmt: skip
                    if leg.stopped:
                        raise NewtonError(leg.stopped)
                    steady = leg.points[-1].steady
            else:  # the first: from the coarse state, or as vesicle tt starts
                steady = _first_state(physics.replace(lam=lam), discretisation, first, solve)
        except NewtonError as err:
            raise NewtonError(f"no steady TT state at lam = {lam:g}: {err}") from err
        solutions[lam] = steady
        w_r, w_i = stability(steady, modes=analysis.modes).most_unstable
        history.append((lam, w_r, w_i))
        log.info("lam = %.5g: omega = (%.4g, %.4g)", lam, w_r, w_i)
        if progress is not None:
            progress({"lam": lam, "omega_R": w_r, "omega_I": w_i})
        return w_i

    lam = lam0 if lam0 is not None else _default_start(physics)
    if analysis.orientation == "vorticity":  # stable above lambda_c: bracket the decay rate
        if lam0 is None:
            lam = vorticity_start_lambda(physics.v)
        lo, hi = _bracket(lambda x: -growth(x), lam, step, factor)
    else:
        lo, hi = _bracket(growth, lam, step, factor)
    lam_c = brentq(growth, lo, hi, xtol=xtol)
    nearest = min(history, key=lambda h: abs(h[0] - lam_c))
    kind = "hopf" if nearest[1] > 1e-2 else "saddle-node"
    states = tuple(solutions[h[0]] for h in history)
    result = CriticalResult(float(lam_c), kind, float(nearest[1]), tuple(history), states=states)
    return result, solutions


def critical_summary(result: CriticalResult, physics: Physics, discretisation: Discretisation):
    """The JSON summary of a critical-lambda search (``vesicle critical --json``; a
    ``critical`` sweep's point), with the package version and the parameters."""
    return stamped({
        "v": physics.v,
        "chi": physics.chi,
        "degree": discretisation.degree,
        "grid": discretisation.grid,
        "physics": {k: x for k, x in physics.to_dict().items() if k != "lam"},
        "discretisation": discretisation.to_dict(),
        "lambda_c": result.lambda_c,
        "bifurcation": result.bifurcation,
        "omega_R": result.omega_R,
        "history": [list(h) for h in result.history],
        "coarse": None if result.coarse is None else {
            "lambda_c": result.coarse.lambda_c,
            "evaluations": len(result.coarse.history),
        },
    })
