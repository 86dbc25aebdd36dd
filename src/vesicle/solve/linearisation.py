"""The steady problem's Jacobian ``M = d adot / d a`` by linearising the velocity-tension solve.

The finite-difference Jacobian (:func:`vesicle.steady.problem.finite_difference_jacobian`) solves
the whole boundary-integral system once (forward) or twice (central) per column, on a perturbed
shape, to a tolerance tight enough that the difference of two solutions is clean.  Here the
solution ``(u, t)`` of the base shape is differentiated instead.  Writing the system as

    G(x; u, t) = A_uu(x) u + N(x)[f_B(x) + f_sigma(x, t)] / 8 pi - u_inf(x) = 0,

(``A_uu(x) u`` holds the membrane's viscous load ``N(x)[f_eta(x, u)]/8 pi`` where ``Bq > 0``:
its shape derivative at fixed ``u`` is taken with the other local loads),
    C(x; u)    = band(div_x u) = 0,

a change ``delta x`` of the radius along the basis function ``phi_j`` moves the solution by
``A(x) [du; dt] = -[dG/dx; dC/dx] delta x``, and

    d adot / d a_j = P [d rate/dx (u) delta x + rate(x, du)].

The pieces:

- ``dN/dx [f]`` and ``dK/dx [u]`` at fixed densities: central differences of the quadrature
  itself (:meth:`~vesicle.stokes.LayerPotentials.shape_derivatives`), all directions in one
  fused pass;
- the local operators (bending and tension forces, surface divergence, the background flow, the
  rate of change of the radius): central differences of cheap grid computations, step
  ``LOCAL_STEP``;
- one :class:`~vesicle.solve.factorised.FactorisedSystem` of the base shape solves all columns.

Nothing is iterated to a tolerance, so there is no cancellation against solver error; what is
left is ``O(step^2)`` truncation and rounding over the steps (about 1e-9 relative; tests compare
with the finite-difference Jacobian and with a convergence in the steps).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.model.kinematics import rate_of_change
from vesicle.model.membrane import bending_force, tension_force
from vesicle.solve.factorised import (
    CoupledBlocks,
    FactorisedSystem,
    preconditioned_system_solve,
)
from vesicle.solve.solver import VelocityTensionSolver
from vesicle.sphere.bases import RealBasis

__all__ = ["LOCAL_STEP", "Linearisation", "linearised_action", "linearised_jacobian"]

log = logging.getLogger(__name__)

#: Relative radius step of the central differences of the local operators.
LOCAL_STEP = 1e-5


@dataclass(frozen=True, eq=False)
class Linearisation:
    """The linearised Jacobian and what it cost."""

    jacobian: np.ndarray  # M = d adot / d a, (size, size)
    seconds: dict  # {"factorise", "layer_potentials", "local", "solve"}
    u: np.ndarray  # the base velocity (exact solution of the discrete system)
    sigma: np.ndarray  # the base tension


def _local_terms(shape: Shape, u, t, flow, chi, degree, basis: RealBasis, formulation):
    """Force, divergence, background flow and rate of change of ``shape`` at fixed (u, t)
    (the force with the membrane's viscous load of ``u`` where ``Bq > 0``)."""
    f = bending_force(shape) + tension_force(shape, t)
    if formulation.viscous:
        f = f + formulation.viscous_load(shape, u)
    div = shape.surface_divergence(u)
    u_inf = flow.velocity(shape.x, chi) if flow is not None else np.zeros_like(u)
    rate = basis.from_coefficients(rate_of_change(shape, u, degree))
    return f, div, u_inf, rate


def linearised_jacobian(
    solver: VelocityTensionSolver,
    basis: RealBasis,
    step: float = LOCAL_STEP,
    system: FactorisedSystem | None = None,
) -> Linearisation:
    """``M = d adot / d a`` at ``solver.shape`` for the radius basis ``basis``.

    Parameters
    ----------
    solver : VelocityTensionSolver
        Of the base shape (its layer potentials are assembled here if they are not yet).
    basis : RealBasis
        The unknowns' basis (its degree is the shape's).
    step : float
        Central-difference step of the local operators, relative to ``max(1, |a_00|)``.
    system : FactorisedSystem, optional
        The base shape's factorised system, if already built.
    """
    times = {}
    system = system or FactorisedSystem(solver)
    times["factorise"] = system.seconds  # also when it was built by the caller
    u, t = system.solve(solver.rhs())  # exact base solution
    M = _columns(solver, system, basis, np.eye(basis.size), u, t, step, times,
                 lambda b_u, r: system.solve(b_u, r)[0])  # fmt: skip
    log.info(
        "linearised Jacobian (%d columns): %s",
        basis.size,
        ", ".join(f"{k} {v:.2f} s" for k, v in times.items()),
    )
    return Linearisation(jacobian=M.T, seconds=times, u=u, sigma=t)


def _columns(solver, blocks, basis, vectors, u, t, step, times, solve) -> np.ndarray:
    """``M v`` (as rows) for the rows ``v`` of ``vectors`` (basis coordinates), at the solution
    ``(u, t)`` of ``solver``'s shape (``blocks`` its :class:`CoupledBlocks`); ``solve(b_u, r)``
    returns the velocities of ``A [u; t] = [b_u; r]`` for a batch (B, 3, nt, np), (B, P)."""
    shape, params = solver.shape, solver.params
    flow = params.flow if params.driven else None
    degree = basis.degree
    if degree != shape.degree:
        raise ValueError(
            f"the basis has degree {degree}, the shape {shape.degree}: they must match"
        )
    directions = np.stack([basis.to_coefficients(e) for e in vectors])
    h = step * max(1.0, abs(float(shape.coefficients[0, 0].real)))

    clock = time.perf_counter()
    plus, minus = [], []
    for d in directions:
        for sign, out in ((1.0, plus), (-1.0, minus)):
            moved = Shape(shape.coefficients + sign * h * d, shape.grid)
            out.append(_local_terms(moved, u, t, flow, params.chi, degree, basis,
                                    solver.formulation))
    df, ddiv, du_inf, drate = (
        (np.array([p[i] for p in plus]) - np.array([m[i] for m in minus])) / (2.0 * h)
        for i in range(4)
    )
    times["local"] = time.perf_counter() - clock

    clock = time.perf_counter()
    f0 = bending_force(shape) + tension_force(shape, t)
    if solver.formulation.viscous:
        f0 = f0 + solver.formulation.viscous_load(shape, u)
    double = u if params.lam != 1.0 else None
    dN, dK = solver.lp.shape_derivatives(directions, f0, double)
    times["layer_potentials"] = time.perf_counter() - clock

    clock = time.perf_counter()
    dG = solver.formulation.shape_derivative(dN + blocks.single_layer(df), du_inf, dK)
    du = solve(-dG, -blocks.project(ddiv))
    M = drate + np.array([basis.from_coefficients(rate_of_change(shape, v, degree)) for v in du])
    times["solve"] = time.perf_counter() - clock
    return M


def linearised_action(
    solver: VelocityTensionSolver,
    basis: RealBasis,
    vectors: np.ndarray,
    preconditioner: FactorisedSystem,
    step: float = LOCAL_STEP,
    rtol: float = 1e-11,
    max_iterations: int = 60,
    iterations: list | None = None,
) -> np.ndarray:
    """``M v`` for a few vectors ``v`` (columns of ``vectors``, (size, k)) at ``solver.shape``,
    without factorising it: the base solve and the ``k`` linearised solves by GMRES
    preconditioned with ``preconditioner``, the factorised system of a nearby shape
    (:func:`~vesicle.solve.factorised.preconditioned_system_solve`).

    The same linearisation as :func:`linearised_jacobian` (same local steps, same shape
    derivatives of the layer potentials), so ``linearised_action(...) - J @ v`` of a Jacobian
    ``J`` at a nearby shape is a clean difference (GMRES to ``rtol``, not a factorisation).
    At N = 8 on 32x64 with two vectors it costs the layer potentials' assembly and three
    GMRES solves instead of a factorisation and 25 shape derivatives.  Raises
    :class:`~vesicle.solve.solver.SolverError` when a solve misses ``rtol`` in
    ``max_iterations``; ``iterations`` (a list), if given, receives each solve's count.
    With ``vectors`` the identity it is the whole Jacobian without a factorisation (the
    columns solved in one batch: :mod:`vesicle.solve.krylov`).
    """
    vectors = np.asarray(vectors, float)
    if vectors.ndim != 2 or vectors.shape[0] != basis.size:
        raise ValueError(f"vectors must have shape ({basis.size}, k), got {vectors.shape}")
    times: dict = {}
    blocks = CoupledBlocks(solver)

    def solve(b_u, r):
        return preconditioned_system_solve(blocks, preconditioner, b_u, r, rtol=rtol,
                                           max_iterations=max_iterations,
                                           iterations=iterations)[0]  # fmt: skip

    b = solver.rhs()
    u, coef = preconditioned_system_solve(blocks, preconditioner, b[None], None, rtol=rtol,
                                          max_iterations=max_iterations,
                                          iterations=iterations)  # fmt: skip
    u, t = u[0], blocks.tension(coef[0])
    return _columns(solver, blocks, basis, vectors.T, u, t, step, times, solve).T
