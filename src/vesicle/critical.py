"""The critical viscosity ratio lambda_c(v, chi) by a bracketing root search (SPEC §9).

The reference for the neutral-curve tracer (:mod:`vesicle.neutral`): at fixed ``(v, chi)`` the
largest growth rate ``omega_I(lam)`` of the steady tank-treading state is bracketed and its root
found by Brent's method, each evaluation a Newton solve from the nearest solution found so far.
The first evaluation starts as ``vesicle tt`` does (:func:`vesicle.branch.reach`): Newton from
the default start, or continuation from an easier point where that fails or lands on a state
with a real unstable mode (another branch).
"""

from __future__ import annotations

import logging
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from . import __version__
from .branch import branch, reach
from .parameters import Discretisation, Physics
from .stability import stability
from .steady import NewtonError, SteadyResult, steady_tank_treading
from .theory import misbah_critical_lambda

#: Largest relative change of lam reached by one Newton solve from the nearest solution; farther
#: steps go by a branch (continuation with step halving and a jump guard).
JUMP_RATIO = 0.05

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


def _critical_objects(physics, discretisation, degree, grid, v, chi):
    """The parameter objects of either call form of :func:`critical_lambda`."""
    sizes = {k: x for k, x in (("grid", grid), ("degree", degree)) if x is not None}
    if isinstance(physics, Physics):
        if v is not None or chi is not None:
            raise ValueError("give the physics as a Physics object or as v, chi, not both")
        return physics, discretisation if discretisation is not None else Discretisation(**sizes)
    v = physics if physics is not None else v
    chi = discretisation if discretisation is not None else chi
    if v is None or chi is None:
        raise TypeError("critical_lambda needs Physics (and Discretisation), or v and chi")
    return Physics(v=v, chi=chi), Discretisation(**sizes)


@dataclass(frozen=True)
class CriticalResult:
    """``lambda_c`` where the largest ``omega_I`` crosses zero, and the bifurcation type."""

    lambda_c: float
    bifurcation: str  # "saddle-node" (real crossing) or "hopf" (complex pair)
    omega_R: float
    history: tuple[tuple[float, float, float], ...]  # (lam, omega_R, omega_I) evaluated


def critical_lambda(
    physics: Physics | float | None = None,
    discretisation: Discretisation | float | None = None,
    degree: int | None = None,
    grid: int | None = None,
    lam0: float | None = None,
    step: float = 0.05,
    factor: float = 1.5,
    xtol: float = 1e-3,
    executor: Executor | None = None,
    progress=None,
    max_iterations: int | None = None,
    *,
    v: float | None = None,
    chi: float | None = None,
    jacobian: str = "linearised",
    modes: str = "symmetric",
    orientation: str = "flow",
) -> CriticalResult:
    """Bracketing root search for ``lambda_c(v, chi)`` with continuation of the steady shape.

    Called as ``critical_lambda(physics, discretisation)`` (``physics.lam`` is not used: it is
    what is sought) or as ``critical_lambda(v, chi, degree=8, grid=32)``.

    Starts at ``lam0`` (default: the leading-order estimate, at least 1) and at ``lam0`` moved
    by the relative ``step`` towards the crossing (up when stable); then secant steps in
    ``log lam``, pushed 20 % past the predicted root and limited to a factor ``factor``, until
    ``max omega_I`` changes sign; then Brent's method to ``xtol``.  Each evaluation starts
    Newton (at most ``max_iterations`` iterations) from the nearest solution found so far, with
    chord iterations on its Jacobian (:func:`steady_tank_treading`), so a nearby evaluation
    costs little more than the stability Jacobian itself.

    ``modes`` are the perturbations whose growth is bracketed (``"general"`` for the
    out-of-plane branch, which loses stability to perturbations that break the x-z symmetry);
    ``orientation`` the TT branch of the first evaluation (later ones continue from it).
    """
    physics, discretisation = _critical_objects(physics, discretisation, degree, grid, v, chi)
    history: list[tuple[float, float, float]] = []
    solutions: dict[float, SteadyResult] = {}

    def growth(lam: float) -> float:
        for done, _, w_i in history:  # Brent re-evaluates the bracket's ends: reuse them
            if done == lam:
                return w_i
        newton = {"executor": executor, "progress": progress, "max_iterations": max_iterations,
                  "jacobian": jacobian}  # fmt: skip
        try:
            if solutions:
                nearest = min(solutions, key=lambda x: abs(np.log(x / lam)))
                if abs(np.log(lam / nearest)) <= JUMP_RATIO:
                    steady = steady_tank_treading(physics.replace(lam=lam), discretisation,
                                                  initial=solutions[nearest], **newton)  # fmt: skip
                else:  # a far secant step: by a branch with step halving and its jump guard,
                    # so that it cannot land on another steady state (measured: chi = 3.162,
                    # N = 4, one Newton jump found lam_c = 6.627 on another branch, not 8.590)
                    leg = branch(solutions[nearest].physics, discretisation, "lam", [lam],
                                 start=solutions[nearest], locate=False, arclength=False,
                                 executor=executor, jacobian=jacobian, modes=modes)  # fmt: skip
                    if leg.stopped:
                        raise NewtonError(leg.stopped)
                    steady = leg.points[-1].steady
            else:  # the first: as vesicle tt starts (continuation where Newton cannot)
                steady = reach(physics.replace(lam=lam), discretisation, verify_unstable=True,
                               orientation=orientation, **newton)  # fmt: skip
        except NewtonError as err:
            raise NewtonError(f"no steady TT state at lam = {lam:g}: {err}") from err
        solutions[lam] = steady
        w_r, w_i = stability(steady, modes=modes).most_unstable
        history.append((lam, w_r, w_i))
        log.info("lam = %.5g: omega = (%.4g, %.4g)", lam, w_r, w_i)
        if progress is not None:
            progress({"lam": lam, "omega_R": w_r, "omega_I": w_i})
        return w_i

    lam = lam0 if lam0 is not None else max(1.0, misbah_critical_lambda(physics.v))
    if orientation == "vorticity":  # stable above its lambda_c: bracket the decay rate instead
        if lam0 is None:  # its lambda_c lies well above the in-plane one (the paper's Fig. 22)
            lam = 2.0 * lam
        lo, hi = _bracket(lambda x: -growth(x), lam, step, factor)
    else:
        lo, hi = _bracket(growth, lam, step, factor)
    lam_c = brentq(growth, lo, hi, xtol=xtol)
    nearest = min(history, key=lambda h: abs(h[0] - lam_c))
    kind = "hopf" if nearest[1] > 1e-2 else "saddle-node"
    return CriticalResult(float(lam_c), kind, float(nearest[1]), tuple(history))


def critical_summary(result: CriticalResult, physics: Physics, discretisation: Discretisation):
    """The JSON summary of a critical-lambda search (``vesicle critical --json``; a
    ``critical`` sweep's point), with the package version and the parameters."""
    return {
        "vesicle_version": __version__,
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
    }
