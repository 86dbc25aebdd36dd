"""``vesicle study NAME``: the paper's parametric studies (:mod:`vesicle.workflows.study`)."""

from __future__ import annotations

import json

import click

from vesicle.cli.base import check_scheduler, fail, interruptible, main
from vesicle.cli.sweep import _progress_printer
from vesicle.workflows.config import ConfigError
from vesicle.workflows.study import list_studies, run_study


@main.command("study")
@click.argument("name", required=False)
@click.option("--list", "show_list", is_flag=True, help="List the shipped studies and their costs.")
@click.option("--quick", is_flag=True,
              help="Reduced resolution (the study's [quick] table: N = 4 on 12x24).")  # fmt: skip
@click.option("--degree", type=int, default=None,
              help="Shape degree N, replacing the study's (and --quick's).")  # fmt: skip
@click.option("--grid", type=int, default=None,
              help="n_theta of the grid (n_phi = 2 n_theta), replacing the study's (and "
                   "--quick's). A store of another resolution in --out is refused: give "
                   "another --out.")  # fmt: skip
@click.option("--out", "outdir", type=click.Path(file_okay=False), default="studies",
              show_default=True,
              help="Folder for the study's config, store, figure and table.")  # fmt: skip
@click.option("--workers", type=int, default=None,
              help="Processes of the LocalCluster started here [default: the cores].")  # fmt: skip
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on this Dask scheduler (tcp://host:port) instead.")  # fmt: skip
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@interruptible(lambda p: f"the points done are kept in {p['outdir']}; run the same command "
               "again to continue")
def study_command(name, show_list, quick, degree, grid, outdir, workers, scheduler,
                  as_json) -> None:  # fmt: skip
    """Run one of the paper's parametric studies (or a study TOML file) through the sweep
    engine, resumably, and draw its figure and table into --out.

    A second call computes only what is missing (and redraws). `vesicle study --list` shows
    the studies; each one's TOML (written into --out) is a sweep config with a [study] table.
    """
    if show_list or name is None:
        studies = list_studies()
        if as_json:
            click.echo(json.dumps(studies))
            return
        for key, s in studies.items():
            click.echo(f"{key:<18} {s.get('title', '')}")
            click.echo(f"{'':<18} cost: {s.get('cost', 'not measured')}")
        if name is None and not show_list:
            click.echo("\ngive a study NAME (or a TOML path) to run it", err=True)
        return
    if workers is not None and workers < 1:
        fail("--workers must be at least 1")
    if workers is not None and scheduler is not None:
        fail("give --workers (a LocalCluster) or --scheduler, not both")
    resolution = {k: v for k, v in (("degree", degree), ("grid", grid)) if v is not None}
    for key, value in resolution.items():
        if value < 1:
            fail(f"--{key} must be at least 1, got {value}")
    check_scheduler(scheduler)
    show, close = _progress_printer()
    try:
        result = run_study(name, outdir, quick=quick, workers=workers, scheduler=scheduler,
                           progress=show, resolution=resolution)  # fmt: skip
    except KeyboardInterrupt:
        close()
        fail(f"interrupted: the points done are kept in {outdir}; run the same command again "
             "to continue")  # fmt: skip
    except (ConfigError, ValueError, OSError) as err:
        fail(str(err))
    close()
    if as_json:
        click.echo(json.dumps(result))
        return
    status = result["status"]
    click.echo(f"{result['store']}: {status['done']} done, {status['failed']} failed")
    click.echo(f"figure {result['figure']}\ntable  {result['table']}")
