"""Linear stability of steady tank-treading and the critical viscosity ratio (SPEC §9).

Admissible perturbations keep A and V: they lie orthogonal to ``z_1, z_2``, the Gram–Schmidt
orthonormalisation of ``dA/da``, ``dV/da``.  With ``Q = I - z_1 z_1^T - z_2 z_2^T`` the
eigenvalues ``mu`` of ``Q^T M Q`` other than the trivial zeros are the growth exponents
``-i omega`` of modes ``e^{-i omega t}``: ``omega_R = -Im mu``, ``omega_I = Re mu``
(``omega_I > 0`` unstable).  For ``modes="general"`` the full basis (2.1) is used (all degrees,
cosine and sine parts) and the three translations (degree 1) are excluded as well: a translated
vesicle drifts with the shear, a neutral mode the re-centring of the simulations removes.
"""

from __future__ import annotations

import logging
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .parameters import Discretisation, Physics
from .sphere.bases import FullBasis
from .steady import NewtonError, SteadyResult, steady_tank_treading
from .theory import misbah_critical_lambda

__all__ = ["CriticalResult", "FullBasis", "StabilityResult", "critical_lambda", "stability"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class StabilityResult:
    """Eigen-analysis of a steady state: ``omega`` sorted by ``omega_I`` (most unstable first)."""

    omega: np.ndarray  # (k, 2): (omega_R, omega_I)
    modes: np.ndarray  # (k, N+1, N+1) complex coefficient perturbations (real part is the mode)
    basis: str

    @property
    def most_unstable(self) -> tuple[float, float]:
        """``(omega_R, omega_I)`` of the mode with the largest growth rate (``omega_R >= 0``)."""
        w_r, w_i = self.omega[0]
        return float(abs(w_r)), float(w_i)


def stability(
    result: SteadyResult, modes: str = "symmetric", executor: Executor | None = None
) -> StabilityResult:
    """Growth exponents of perturbations of a steady tank-treading state (SPEC §9)."""
    if modes == "symmetric":
        basis, M = result.basis, result.jacobian
        if M is None:
            raise ValueError("the steady result carries no Jacobian (Newton did not converge)")
        g = result.gradients
        extra = np.zeros((0, basis.size))
    elif modes == "general":
        problem = result.problem.replace(modes="general")
        basis = problem.basis
        a0 = problem.coefficients_of(result.shape)
        M, _ = problem.jacobian(a0, central=True, executor=executor)
        g = problem.gradients(result.shape)
        extra = np.eye(basis.size)[basis.l == 1]  # translations
    else:
        raise ValueError("modes must be 'symmetric' or 'general'")
    Z, _ = np.linalg.qr(np.concatenate([g, extra]).T)
    Q = np.eye(basis.size) - Z @ Z.T
    mu, vec = np.linalg.eig(Q.T @ M @ Q)
    # drop the trivial zeros: eigenvectors in the constrained span (killed by Q)
    inside = np.linalg.norm(Q @ vec, axis=0)
    keep = np.argsort(inside)[Z.shape[1] :]
    mu, vec = mu[keep], vec[:, keep]
    omega = np.stack([-mu.imag, mu.real], axis=1)
    order = np.lexsort((-np.abs(omega[:, 0]), -omega[:, 1]))
    omega, vec = omega[order], vec[:, order]
    shapes = np.stack(
        [basis.to_coefficients(v.real) + 1j * basis.to_coefficients(v.imag) for v in vec.T]
    )
    log.info("most unstable %s mode: omega = (%.4g, %.4g)", modes, *omega[0])
    return StabilityResult(omega, shapes, modes)


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
    """
    physics, discretisation = _critical_objects(physics, discretisation, degree, grid, v, chi)
    history: list[tuple[float, float, float]] = []
    solutions: dict[float, SteadyResult] = {}

    def growth(lam: float) -> float:
        for done, _, w_i in history:  # Brent re-evaluates the bracket's ends: reuse them
            if done == lam:
                return w_i
        start = None
        if solutions:
            nearest = min(solutions, key=lambda x: abs(np.log(x / lam)))
            start = solutions[nearest]
        try:
            steady = steady_tank_treading(
                physics.replace(lam=lam),
                discretisation,
                initial=start,
                executor=executor,
                progress=progress,
                max_iterations=max_iterations,
                jacobian=jacobian,
            )
        except NewtonError as err:
            raise NewtonError(f"no steady TT state at lam = {lam:g}: {err}") from err
        solutions[lam] = steady
        w_r, w_i = stability(steady).most_unstable
        history.append((lam, w_r, w_i))
        log.info("lam = %.5g: omega = (%.4g, %.4g)", lam, w_r, w_i)
        if progress is not None:
            progress({"lam": lam, "omega_R": w_r, "omega_I": w_i})
        return w_i

    lam = lam0 if lam0 is not None else max(1.0, misbah_critical_lambda(physics.v))
    lo, hi = _bracket(growth, lam, step, factor)
    lam_c = brentq(growth, lo, hi, xtol=xtol)
    nearest = min(history, key=lambda h: abs(h[0] - lam_c))
    kind = "hopf" if nearest[1] > 1e-2 else "saddle-node"
    return CriticalResult(float(lam_c), kind, float(nearest[1]), tuple(history))
