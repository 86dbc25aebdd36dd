"""``vesicle paper``: the seed paper's tables and figures as a report (:mod:`vesicle.paper`)."""

from __future__ import annotations

import click

from ..paper import ITEMS, build_report
from .base import fail, main


@main.command("paper")
@click.option("--quick", is_flag=True,
              help="Reduced resolution (N = 4 on 12x24, fewer points, shorter runs).")
@click.option("--out", "outdir", type=click.Path(file_okay=False), default="paper",
              show_default=True, help="Folder of the report and its data.")  # fmt: skip
@click.option("--only", default=None, metavar="ITEM,...",
              help="Compute only these items (table1, fig2, fig4, ...; see --list).")  # fmt: skip
@click.option("--list", "show_list", is_flag=True, help="List the items and exit.")
@click.option("--redo", is_flag=True, help="Recompute items already done in --out.")
@click.option("--workers", type=int, default=None,
              help="Processes of the LocalCluster of the sweeps [default: the cores].")  # fmt: skip
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the sweeps on this Dask scheduler instead.")  # fmt: skip
def paper_command(quick, outdir, only, show_list, redo, workers, scheduler) -> None:
    """Regenerate the paper's tables and figures into --out/index.html (static, offline).

    Every item is computed through the sweep engine and the studies (resumable: a second call
    only redraws), with its figures, data (CSV), parameters, wall time and, where the paper
    states a value, that value beside ours. Items the package cannot compute yet are listed as
    missing. The full report at the paper's resolution costs hours on a 2-core machine; --quick
    is meant to finish in about half an hour.
    """
    if show_list:
        for item in ITEMS:
            state = "" if item.compute is not None else f"  [missing: {item.missing}]"
            click.echo(f"{item.key:<7} {item.title:<20} {item.what}{state}")
        return
    if workers is not None and workers < 1:
        fail("--workers must be at least 1")
    if workers is not None and scheduler is not None:
        fail("give --workers (a LocalCluster) or --scheduler, not both")
    keys = [k.strip() for k in only.split(",") if k.strip()] if only else None
    if not quick:
        click.echo("the full report (N = 8 on 32x64) takes hours on a 2-core machine; "
                   "--quick for the reduced one", err=True)  # fmt: skip
    try:
        page = build_report(outdir, quick=quick, only=keys, redo=redo,
                            options={"workers": workers, "scheduler": scheduler},
                            progress=lambda text: click.echo(text, err=True))  # fmt: skip
    except KeyboardInterrupt:
        fail(f"interrupted: the items done are kept in {outdir}; run the same command again")
    except (ValueError, OSError) as err:
        fail(str(err))
    click.echo(str(page))
