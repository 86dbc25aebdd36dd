"""Command-line interface: ``vesicle <command>``.

The CLI is the only layer that prints; library code logs through :mod:`logging`.
"""

from __future__ import annotations

import json
import logging
import sys

import click
import numpy as np

from . import __version__
from .surface import Shape, ShapeError


def _fail(message: str) -> None:
    raise click.ClickException(message)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vesicle")
@click.option("-v", "--verbose", count=True, help="More log output on stderr (-v info, -vv debug).")
def main(verbose: int) -> None:
    """Spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(
        level=level, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s"
    )


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
        click.echo(json.dumps(summary))
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


if __name__ == "__main__":  # pragma: no cover
    main()
