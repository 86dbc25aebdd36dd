"""``vesicle shape`` and ``vesicle solve``: geometry and one velocity-tension solve."""

from __future__ import annotations

import json

import click
import numpy as np

from vesicle.cli.base import fail as _fail
from vesicle.cli.base import main, with_version
from vesicle.cli.options import discretisation_options, physics_options
from vesicle.geometry.surface import Shape, ShapeError
from vesicle.model.formulation import Formulation
from vesicle.model.parameters import Physics
from vesicle.solve.solver import SolverError, default_tension_degree, solve_flow
from vesicle.sphere.rotation import rotation_matrix
from vesicle.stokes import LayerPotentials


def shape_summary(s: Shape) -> dict:
    """Geometric summary of a shape, as plain JSON-able values."""
    evals = np.linalg.eigvalsh(s.inertia_tensor())
    return {
        "area": s.area,
        "volume": s.volume,
        "reduced_volume": s.reduced_volume,
        "excess_area": s.excess_area,
        "bending_energy": s.bending_energy(),
        "centroid": s.centroid.tolist(),
        "inertia_eigenvalues": evals.tolist(),
        "grid": [s.grid.n_theta, s.grid.n_phi],
        "degree": s.degree,
    }


#: The smallest grid and (for a shape other than the sphere) degree: those of
#: :class:`vesicle.Discretisation`; a degree below 2 holds only the sphere (a "spheroid" of
#: v = 0.9 at degree 1 is the unit sphere, v = 1).
MIN_GRID, MIN_DEGREE = 4, 2


def _check_resolution(grid: int, degree: int | None, sphere: bool = False) -> None:
    """Refuse, before any work, a grid or degree too small for the shape asked for."""
    if grid < MIN_GRID:
        _fail(f"--grid must be at least {MIN_GRID} (n_theta; n_phi = 2 n_theta), got {grid}")
    if degree is not None and degree < (0 if sphere else MIN_DEGREE):
        _fail(f"--degree must be at least {MIN_DEGREE} (a lower degree holds only the sphere), "
              f"got {degree}")  # fmt: skip


@main.command()
@click.option("--ellipsoid", nargs=3, type=float, metavar="A B C", help="Semi-axes along x, y, z.")
@click.option(
    "--spheroid",
    "v",
    type=float,
    metavar="V",
    help="Prolate spheroid of reduced volume V and area 4 pi.",
)
@click.option(
    "--grid", type=int, default=32, show_default=True, help="n_theta (n_phi = 2 n_theta)."
)
@click.option(
    "--degree",
    type=int,
    default=None,
    help="Degree N of the radius series (default: the highest the grid holds).",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
def shape(ellipsoid, v, grid, degree, as_json) -> None:
    """Geometry of a shape: area, volume, reduced volume, excess area, bending energy."""
    if (ellipsoid is None) == (v is None):
        _fail("give exactly one of --ellipsoid A B C or --spheroid V")
    _check_resolution(grid, degree)
    try:
        s = (
            Shape.ellipsoid(*ellipsoid, grid=grid, degree=degree)
            if ellipsoid
            else Shape.spheroid(v, grid=grid, degree=degree)
        )
    except ShapeError as err:
        _fail(str(err))
    summary = shape_summary(s)
    if as_json:
        click.echo(json.dumps(with_version(summary, grid=grid, degree=s.degree)))
        return
    rows = [
        ("grid", f"{grid} x {2 * grid}"),
        ("degree N", str(s.degree)),
        ("area", f"{s.area:.12g}"),
        ("volume", f"{s.volume:.12g}"),
        ("reduced volume v", f"{s.reduced_volume:.12g}"),
        ("excess area Delta", f"{s.excess_area:.12g}"),
        ("bending energy (kappa=1)", f"{summary['bending_energy']:.12g}"),
        ("bending energy / 8 pi", f"{summary['bending_energy'] / (8 * np.pi):.12g}"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, val in rows:
        click.echo(f"{k:<{width}}  {val}")


def parse_shape(spec: str, grid: int, degree: int | None, tilt_degrees: float) -> Shape:
    """``sphere``, ``ellipsoid:A,B,C`` or ``spheroid:V``, tilted by ``tilt`` in the x-z plane."""
    kind, _, args = spec.partition(":")
    try:
        values = [float(a) for a in args.split(",")] if args else []
    except ValueError:
        raise ShapeError(f"cannot read the numbers in shape {spec!r}") from None
    if kind == "sphere" and not values:
        shape = Shape.sphere(grid=grid, degree=degree or 0)
    elif kind == "ellipsoid" and len(values) == 3:
        shape = Shape.ellipsoid(*values, grid=grid, degree=degree)
    elif kind == "spheroid" and len(values) == 1:
        shape = Shape.spheroid(values[0], grid=grid, degree=degree)
    else:
        raise ShapeError(f"unknown shape {spec!r}: use sphere, ellipsoid:A,B,C or spheroid:V")
    if tilt_degrees:
        # long axis from x towards +z by the tilt: an active rotation about y by -tilt
        shape = shape.rotated(rotation_matrix("y", -np.radians(tilt_degrees)))
    return shape


@main.command()
@click.option(
    "--shape",
    "shape_spec",
    default="spheroid:0.95",
    show_default=True,
    help="sphere, ellipsoid:A,B,C (semi-axes along x,y,z) or spheroid:V.",
)
@click.option(
    "--tilt",
    type=float,
    default=0.0,
    show_default=True,
    help="Rotate the shape in the x-z plane: long axis from x towards z, degrees.",
)
@physics_options(("lam", "chi", "flow", "bq"))
@discretisation_options(("n_rot", "backend", "method", "threads"))
@click.option(
    "--grid", type=int, default=32, show_default=True, help="n_theta (n_phi = 2 n_theta)."
)
@click.option("--degree", type=int, default=None, help="Degree N of the shape (default: grid's).")
@click.option("--steady", is_flag=True, help="Tight tolerances (1e-6/1e-7) instead of 1e-3/1e-4.")
@click.option("--split", is_flag=True, help="Also report the bending and flow parts of S.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
def solve(shape_spec, tilt, grid, degree, steady, split, as_json, **options) -> None:
    """Membrane velocity, tension and particle stress of a fixed shape."""
    _check_resolution(grid, degree, sphere=shape_spec == "sphere")
    if not np.isfinite(tilt):
        _fail(f"--tilt must be a finite angle in degrees, got {tilt}")
    if options["n_rot"] is not None and options["n_rot"] < 2:
        _fail(f"--n-rot must be at least 2, got {options['n_rot']}")
    if options["threads"] is not None and options["threads"] < 1:
        _fail(f"--threads must be at least 1, got {options['threads']}")
    try:
        s = parse_shape(shape_spec, grid, degree, tilt)
        lam, chi, flow = options.pop("lam"), options.pop("chi"), options.pop("flow")
        physics = Physics(v=min(1.0, s.reduced_volume), lam=lam, chi=chi, flow=flow,
                          bq=options.pop("bq"))  # fmt: skip
        layer_options = {k: options[k] for k in ("n_rot", "backend", "method")}
        layer_options["kernels"] = Formulation.of(physics).kernels
        result = solve_flow(
            s,
            physics,
            split=split,
            tolerances="steady" if steady else "time-dependent",
            operators=LayerPotentials(s, workers=options["threads"], **layer_options),
        )
    except (ShapeError, ValueError, SolverError) as err:
        _fail(str(err))
    out = {
        "shape": shape_spec,
        "tilt_degrees": tilt,
        "lam": lam,
        "chi": chi,
        "flow_type": flow,
        "grid": [s.grid.n_theta, s.grid.n_phi],
        "degree": s.degree,
        "reduced_volume": s.reduced_volume,
        **result.stress.summary(),
        "iterations": result.iterations,
        "inner_per_solve": list(result.inner_per_solve),
        "div_residual": result.div_residual,
        "div_residual_relative": result.div_residual_relative,
        "constraint_residual": result.constraint_residual,
        "tension_degree": default_tension_degree(s.grid.n_theta),
        "converged": result.converged,
        "seconds": result.seconds,
    }
    if split and result.split:
        out.update({k: v.summary() for k, v in result.split.items()})
    if result.viscous is not None:  # the membrane's viscous stress, a part of S
        out["membrane_viscous"] = result.viscous.summary()
    if as_json:
        click.echo(json.dumps(with_version(out, physics=physics)))
        return
    for key, value in out.items():
        click.echo(f"{key:<22} {value}")
