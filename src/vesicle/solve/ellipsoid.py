"""The flow-resistance stress of an "equivalent ellipsoid" (SPEC §11; the paper's Fig. 17–21).

The equivalent ellipsoid of a vesicle has the vesicle's principal axis lengths and directions; its
stress ``S^V`` is that of the rigidly shaped, surface-incompressible ellipsoid in the flow alone
(no bending load): the velocity-tension solve with the right-hand side ``u_inf`` only.  It does
not depend on ``chi`` (the stress is normalised by it) and depends on ``lam`` only through the
solve, so the layer potentials of one ellipsoid orientation serve every ``lam``
(:func:`flow_stress`); :func:`stress_map` turns the ellipsoid about the vorticity axis over a
range of inclinations ``psi`` and solves each orientation for every ``lam`` (Fig. 18, 19, 21).
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances
from vesicle.model.rheology import ParticleStress
from vesicle.solve.solver import SolverError, VelocityTensionSolver
from vesicle.stokes import LayerPotentials

__all__ = ["equivalent_ellipsoid", "flow_stress", "stress_map"]


def _rotation_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def equivalent_ellipsoid(
    lengths, directions, grid: int = 32, degree: int | None = None, turn: float = 0.0
) -> Shape:
    """The ellipsoid of full axis ``lengths`` (3,) along the unit ``directions`` (rows, 3x3),
    turned by ``turn`` about the vorticity axis y (positive: the x axis towards +z, so that the
    inclination psi grows by ``turn``)."""
    lengths = np.asarray(lengths, dtype=float)
    Q = np.asarray(directions, dtype=float).T  # columns: the body axes in the lab frame
    if lengths.shape != (3,) or Q.shape != (3, 3):
        raise ValueError("give three axis lengths and a 3x3 matrix of axis directions")
    u, _, vt = np.linalg.svd(Q)  # the nearest rotation (the directions are unit, orthogonal)
    Q = u @ vt
    if np.linalg.det(Q) < 0:
        Q[:, 2] = -Q[:, 2]
    Q = _rotation_y(-turn) @ Q  # R_y(-t) e_x = (cos t, 0, sin t): psi increases by t
    a, b, c = lengths / 2.0
    return Shape.ellipsoid(a, b, c, grid=grid, degree=degree, rotation=Q)


def flow_stress(
    shape: Shape,
    lams,
    discretisation: Discretisation | None = None,
    tolerances: SolverTolerances | str = "steady",
    bq: float = 0.0,
) -> list[ParticleStress]:
    """``S^V`` of ``shape`` (fixed) in shear of unit rate for each viscosity ratio of ``lams``
    (membrane Boussinesq number ``bq``), on one assembly of the layer potentials."""
    # the layer-potential options (the degree is the shape's own: no bending force is formed)
    disc = discretisation or Discretisation(shape.grid.n_theta, shape.grid.n_theta // 2)
    tolerances = SolverTolerances.parse(tolerances)
    operators = LayerPotentials(shape, n_rot=disc.n_rot, backend=disc.backend,
                                method=disc.method, workers=disc.workers,
                                kernels=("single", "double"))  # fmt: skip
    out = []
    for lam in lams:
        solver = VelocityTensionSolver(shape, Physics(lam=float(lam), chi=1.0, bq=bq),
                                       tolerances, operators, None, disc)  # fmt: skip
        result = solver.solve(None, bending=False, flow=True)
        if not result.converged:
            raise SolverError(f"the flow-only solve of the ellipsoid did not converge at "
                              f"lam = {lam:g}", result)  # fmt: skip
        out.append(result.stress)
    return out


def stress_map(lengths, directions, psi0: float, psis, lams, grid: int = 32,
               discretisation: Discretisation | None = None, bq: float = 0.0) -> dict:  # fmt: skip
    """``S_xz``, ``N1``, ``N2`` (each (len(psis), len(lams))) of the equivalent ellipsoid of
    ``lengths``/``directions`` (inclination ``psi0``) turned to each inclination of ``psis``."""
    psis, lams = np.asarray(psis, dtype=float), np.asarray(lams, dtype=float)
    maps = {k: np.empty((psis.size, lams.size)) for k in ("S_xz", "N1", "N2")}
    for i, psi in enumerate(psis):
        shape = equivalent_ellipsoid(lengths, directions, grid, turn=psi - psi0)
        for j, s in enumerate(flow_stress(shape, lams, discretisation, bq=bq)):
            for k in maps:
                maps[k][i, j] = getattr(s, k)
    return {"psi": psis, "lam": lams, **maps}
