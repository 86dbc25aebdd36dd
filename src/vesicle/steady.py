"""Steady tank-treading shapes by Newton–Raphson (SPEC §8).

The steady TT shape is symmetric under inversion through the origin and under ``y -> -y``, so
``r = sum_{l even <= N} sum_{m=0..l} a_lm Pbar_lm(cos theta) cos(m phi)`` with real ``a_lm``
(:class:`SymmetricBasis`).  With ``adot(a)`` the projection of the filtered ``dr/dt`` onto that
basis, the steady state solves

    adot(a) - lambda_A dA/da - lambda_V dV/da = 0,   A(a) = 4 pi,   V(a) = 4 pi v / 3,

the two multipliers absorbing the discrete dynamics' small failure to conserve A and V exactly.
The Jacobian block ``M = d adot / d a`` is formed by forward differences, one velocity solve per
column, through any :class:`concurrent.futures.Executor` (serial by default).
"""

from __future__ import annotations

import logging
import time
from concurrent.futures import Executor
from dataclasses import dataclass, field

import numpy as np

from .analysis import diagnose
from .dynamics import rate_of_change
from .rheology import ParticleStress
from .solver import SolverTolerances, solve_flow
from .sphere.rotation import rotation_matrix
from .sphere.transforms import transform
from .surface import Shape, ShapeError, spheroid_axes
from .theory import misbah_tt_inclination

__all__ = [
    "FullBasis",
    "NewtonError",
    "RealBasis",
    "SteadyResult",
    "SymmetricBasis",
    "steady_tank_treading",
]

log = logging.getLogger(__name__)


class NewtonError(RuntimeError):
    """Newton did not converge; the last iterate is attached."""

    def __init__(self, message: str, result: SteadyResult | None = None):
        super().__init__(message)
        self.result = result


class RealBasis:
    """Real coefficients of ``Pbar_lm cos(m phi)`` (part 0) and ``Pbar_lm sin(m phi)`` (part 1).

    In the complex convention of :mod:`vesicle.sphere`, a cosine coefficient is ``w_m Re r_lm``
    and a sine coefficient ``-w_m Im r_lm`` (``w_0 = 1``, ``w_m = 2``).
    """

    def __init__(self, degree: int, index: list[tuple[int, int, int]]):
        self.degree = degree
        self.index = index
        self.l = np.array([i[0] for i in index])
        self.m = np.array([i[1] for i in index])
        self.part = np.array([i[2] for i in index])
        self.weight = np.where(self.m == 0, 1.0, 2.0)

    @property
    def size(self) -> int:
        return len(self.index)

    def to_coefficients(self, a: np.ndarray) -> np.ndarray:
        c = np.zeros((self.degree + 1, self.degree + 1), dtype=complex)
        a = np.asarray(a, float) / self.weight
        cos, sin = self.part == 0, self.part == 1
        c[self.l[cos], self.m[cos]] += a[cos]
        c[self.l[sin], self.m[sin]] -= 1j * a[sin]
        return c

    def from_coefficients(self, c: np.ndarray) -> np.ndarray:
        """Project coefficients (any symmetry) onto the basis."""
        c = np.asarray(c)[self.l, self.m]
        return self.weight * np.where(self.part == 0, c.real, -c.imag)

    def functions(self, grid) -> np.ndarray:
        """The basis functions on a grid, (size, n_theta, n_phi)."""
        T = transform(grid.n_theta, self.degree)
        return T.synthesis(np.stack([self.to_coefficients(e) for e in np.eye(self.size)]))


class SymmetricBasis(RealBasis):
    """``a_lm`` (l even, 0 <= m <= l) of ``Pbar_lm cos(m phi)``: shapes symmetric under inversion
    through the origin and ``y -> -y`` (SPEC §8)."""

    def __init__(self, degree: int):
        if degree < 2:
            raise ValueError(f"the symmetric basis needs degree >= 2, got {degree}")
        super().__init__(degree, [(l, m, 0) for l in range(0, degree + 1, 2) for m in range(l + 1)])


class FullBasis(RealBasis):
    """The full real basis (2.1): all degrees, cosine and sine parts."""

    def __init__(self, degree: int):
        cos = [(l, m, 0) for l in range(degree + 1) for m in range(l + 1)]
        sin = [(l, m, 1) for l in range(degree + 1) for m in range(1, l + 1)]
        super().__init__(degree, cos + sin)


@dataclass(frozen=True, eq=False)
class SteadyResult:
    """A steady tank-treading state and the Newton history that found it."""

    a: np.ndarray
    multipliers: tuple[float, float]
    shape: Shape
    basis: RealBasis
    residual_history: tuple[float, ...]
    converged: bool
    jacobian: np.ndarray  # M = d adot / d a at the solution (basis coordinates)
    gradients: np.ndarray  # (2, size): dA/da, dV/da
    psi: float
    D: float
    axes: np.ndarray  # full lengths, descending
    stress: ParticleStress
    split: dict[str, ParticleStress]
    v: float
    lam: float
    chi: float
    seconds: float
    solves: int
    params: dict = field(default_factory=dict)

    @property
    def newton_iterations(self) -> int:
        return len(self.residual_history) - 1

    @property
    def residual(self) -> float:
        return self.residual_history[-1]


def _gradients(shape: Shape, basis: RealBasis, phi: np.ndarray) -> np.ndarray:
    """``dA/da`` and ``dV/da``: ``delta A = int -2H (n.e_r) delta r dA``, ``delta V = int (n.e_r)
    delta r dA``, integrated against each basis function."""
    ner = np.einsum("i...,i...->...", shape.normal, shape.grid.unit_vectors[0])
    gA = shape.integrate(-2.0 * shape.mean_curvature * ner * phi)
    gV = shape.integrate(ner * phi)
    return np.array([gA, gV])


class _Problem:
    """The steady-state equations for one parameter point."""

    def __init__(self, v, lam, chi, degree, grid, tolerances, executor):
        self.v, self.lam, self.chi = v, lam, chi
        self.grid = grid
        self.basis = SymmetricBasis(degree)
        self.tol = tolerances
        self.executor = executor
        self.phi = self.basis.functions(Shape.sphere(grid=grid).grid)
        self.solves = 0
        self.area0, self.volume0 = 4.0 * np.pi, 4.0 * np.pi * v / 3.0

    def shape(self, a: np.ndarray) -> Shape:
        return Shape(self.basis.to_coefficients(a), self.grid)

    def adot(self, a: np.ndarray, sigma0=None):
        shape = self.shape(a)
        flow = solve_flow(shape, lam=self.lam, chi=self.chi, tolerances=self.tol, sigma0=sigma0)
        self.solves += 1
        rate = rate_of_change(shape, flow.u, self.basis.degree)
        return self.basis.from_coefficients(rate), flow

    def jacobian(
        self, a: np.ndarray, base: np.ndarray, sigma0, central: bool = False
    ) -> np.ndarray:
        """``d adot / d a`` by differences of step ``1e-4``: forward (one solve per column) for
        Newton, central (two) for the stability analysis, where the forward difference's O(h)
        bias shifts the small growth rates (1.5 % of omega_I at N = 4, against 0.02 %)."""
        h = 1e-4 * max(1.0, abs(a[0]))
        steps = [h * e for e in np.eye(a.size)]
        points = [a + d for d in steps] + ([a - d for d in steps] if central else [])
        if self.executor is None:
            values = [_adot_column(self._spec(), c, sigma0) for c in points]
        else:
            values = list(
                self.executor.map(
                    _adot_column, [self._spec()] * len(points), points, [sigma0] * len(points)
                )
            )
        self.solves += len(points)
        values = np.array(values).T
        if central:
            return (values[:, : a.size] - values[:, a.size :]) / (2.0 * h)
        return (values - base[:, None]) / h

    def _spec(self) -> tuple:
        return (self.lam, self.chi, type(self.basis), self.basis.degree, self.grid, self.tol)


def _adot_column(spec: tuple, a: np.ndarray, sigma0=None) -> np.ndarray:
    """``adot`` at coefficients ``a`` of a basis, one Jacobian column (module level so process
    pools can pickle it); ``spec = (lam, chi, basis class, degree, grid, tolerances)``."""
    lam, chi, basis_cls, degree, grid, tol = spec
    basis = basis_cls(degree)
    shape = Shape(basis.to_coefficients(a), grid)
    flow = solve_flow(shape, lam=lam, chi=chi, tolerances=tol, sigma0=sigma0)
    return basis.from_coefficients(rate_of_change(shape, flow.u, degree))


def initial_guess(
    v: float, lam: float, degree: int, grid: int, psi: float | None = None
) -> np.ndarray:
    """The spheroid of ``v`` tilted to ``psi`` (default: Misbah's leading-order TT angle, or
    0.1 rad beyond its range) in the x-z plane, as symmetric coefficients."""
    if psi is None:
        psi = misbah_tt_inclination(v, lam)
        psi = 0.1 if not np.isfinite(psi) else psi
    a_ax, b_ax = spheroid_axes(v)
    shape = Shape.ellipsoid(
        a_ax, b_ax, b_ax, grid=grid, degree=degree, rotation=rotation_matrix("y", -psi)
    ).scaled_to_area()
    return SymmetricBasis(degree).from_coefficients(shape.coefficients)


def steady_tank_treading(
    v: float,
    lam: float,
    chi: float,
    degree: int = 8,
    grid: int = 32,
    initial: np.ndarray | Shape | SteadyResult | None = None,
    tolerance: float = 1e-8,
    max_iterations: int = 12,
    solver_tolerances: SolverTolerances | None = None,
    executor: Executor | None = None,
    chord_contraction: float = 0.7,
    progress=None,
) -> SteadyResult:
    """Newton–Raphson for the steady tank-treading shape (SPEC §8).

    Parameters
    ----------
    v, lam, chi : float
        Reduced volume, viscosity ratio, shear rate.
    degree, grid : int
        Shape degree N and grid n_theta.
    initial : array of symmetric coefficients, Shape, SteadyResult, or None
        Start; default :func:`initial_guess`.  A :class:`SteadyResult` (a neighbouring solution,
        for continuation in lam, chi or v) also gives the multipliers and, at the same degree
        and grid, its Jacobian: Newton then starts with chord iterations on that Jacobian (one
        solve each instead of one per column) and forms a fresh one as soon as an iteration
        fails to reduce the residual by ``chord_contraction``.
    tolerance : float
        Converged when the residual's max-norm is below ``tolerance`` (relative to ``chi`` for
        the dynamic part).
    solver_tolerances : SolverTolerances
        Of each velocity solve; default 1e-8 (Schur) and 1e-9 (inner), tighter than SPEC's
        1e-6/1e-7 so that the finite-difference Jacobian is clean.
    executor : concurrent.futures.Executor, optional
        Runs the Jacobian columns (e.g. a ``ProcessPoolExecutor`` or a Dask client's executor).
    chord_contraction : float
        Largest residual ratio accepted from a chord iteration (see ``initial``).
    progress : callable, optional
        Called after every Newton iteration with ``{"iteration", "residual", "seconds"}``
        (``critical_lambda`` passes its own callback through, which also gets ``{"lam",
        "omega_R", "omega_I"}`` after each stability analysis).
    """
    if not (np.isfinite(v) and 0 < v <= 1) or not (np.isfinite(lam) and lam > 0):
        raise ValueError(f"need 0 < v <= 1 and lam > 0, got v={v}, lam={lam}")
    if not np.isfinite(chi) or chi == 0:
        raise ValueError("steady tank-treading needs a finite, non-zero shear rate chi")
    t0 = time.perf_counter()
    tol = solver_tolerances or SolverTolerances(1e-8, 1e-9)
    P = _Problem(float(v), float(lam), float(chi), degree, grid, tol, executor)
    mult = np.zeros(2)
    chord = None  # a neighbour's Jacobian, used until it stops paying
    if initial is None:
        a = initial_guess(v, lam, degree, grid)
    elif isinstance(initial, SteadyResult):
        a = P.basis.from_coefficients(initial.shape.with_degree(degree).coefficients)
        mult = np.array(initial.multipliers, float)
        same = initial.basis.degree == degree and initial.params.get("grid") == grid
        chord = initial.jacobian if same else None
    elif isinstance(initial, Shape):
        a = P.basis.from_coefficients(initial.with_degree(degree).coefficients)
    else:
        a = np.asarray(initial, float).copy()
    history: list[float] = []
    sigma = None
    converged = False
    previous = None  # the last iterate a step was taken from
    halved = 0  # Newton steps halved to stay representable
    step = np.zeros(a.size + 2)
    for it in range(max_iterations + 1):
        try:
            shape = P.shape(a)
            rate, flow = P.adot(a, sigma)
        except ShapeError as err:
            if previous is None:
                raise
            if it == max_iterations:  # report the last representable iterate
                a, mult, rate, sigma, g, G, flow = previous
                break
            if chord is not None:
                log.info("chord step left the representable shapes (%s): fresh Jacobian", err)
                chord = None
                a, mult, rate, sigma, g, G, flow = previous
            else:  # a Newton step too long for the radial representation: halve it
                log.info("Newton step left the representable shapes (%s): halved", err)
                halved += 1
                step = 0.5 * step
                a, mult = previous[0] + step[: a.size], previous[1] + step[a.size :]
                continue
        else:
            sigma = flow.sigma
            g = _gradients(shape, P.basis, P.phi)
            G = np.concatenate([rate - mult @ g, [shape.area - P.area0, shape.volume - P.volume0]])
            res = float(np.max(np.abs(G[:-2])) / abs(chi) + np.max(np.abs(G[-2:])))
            history.append(res)
            log.info("Newton %d: residual %.3e (%.1f s)", it, res, time.perf_counter() - t0)
            if progress is not None:
                progress({"iteration": it, "residual": res, "seconds": time.perf_counter() - t0})
            if res < tolerance:
                converged = True
                break
            if chord is not None and previous is not None:
                ratio = res / history[-2]
                if ratio > chord_contraction:
                    log.info("chord step contracted by %.2f only: fresh Jacobian", ratio)
                    chord = None
                    if ratio > 1.0:  # it made things worse: step from the last iterate instead
                        a, mult, rate, sigma, g, G, flow = previous
        if it == max_iterations:
            break
        previous = (a, mult, rate, sigma, g, G, flow)
        M = chord if chord is not None else P.jacobian(a, rate, sigma)
        step = _newton_step(M, g, G)
        a = a + step[: a.size]
        mult = mult + step[a.size :]
    # The Jacobian at the solution, by central differences, for the stability analysis.  The
    # Newton steps neglect the multipliers' curvature terms lambda_A d2A/da2: the multipliers
    # are at the level of the discrete drift.
    M = P.jacobian(a, rate, sigma, central=True) if converged else None
    result = _result(P, a, mult, history, converged, M, g, flow, t0)
    if not converged:
        raise NewtonError(
            f"Newton did not converge in {max_iterations} iterations ({halved} of them halved "
            f"steps that left the radial representation): residual history "
            f"{', '.join(f'{r:.1e}' for r in history)}; start closer (continuation in small "
            "steps) or from a short time-dependent run",
            result,
        )
    return result


def _newton_step(M: np.ndarray, g: np.ndarray, G: np.ndarray) -> np.ndarray:
    n = M.shape[0]
    J = np.zeros((n + 2, n + 2))
    J[:n, :n] = M
    J[:n, n:] = -g.T
    J[n:, :n] = g
    return np.linalg.solve(J, -G)


def _result(P, a, mult, history, converged, M, g, flow, t0) -> SteadyResult:
    shape = P.shape(a)
    d = diagnose(shape)
    split_flow = solve_flow(
        shape, lam=P.lam, chi=P.chi, tolerances=P.tol, split=True, sigma0=flow.sigma
    )
    P.solves += 3
    return SteadyResult(
        a=a,
        multipliers=(float(mult[0]), float(mult[1])),
        shape=shape,
        basis=P.basis,
        residual_history=tuple(history),
        converged=converged,
        jacobian=M,
        gradients=g,
        psi=d.psi,
        D=d.D,
        axes=d.lengths,
        stress=split_flow.stress,
        split=split_flow.split,
        v=P.v,
        lam=P.lam,
        chi=P.chi,
        seconds=time.perf_counter() - t0,
        solves=P.solves,
        params={
            "degree": P.basis.degree,
            "grid": P.grid,
            "solver_tolerances": [P.tol.schur, P.tol.inner],
        },
    )
