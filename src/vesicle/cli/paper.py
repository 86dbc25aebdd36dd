"""``vesicle paper``: the seed paper's tables and figures as a report
(:mod:`vesicle.workflows.paper`)."""

from __future__ import annotations

import click

from vesicle.cli.base import check_scheduler, fail, interruptible, main
from vesicle.workflows.costs import COSTS
from vesicle.workflows.paper import ITEMS, build_report


@main.command("paper")
@click.option("--quick", is_flag=True,
              help="Reduced resolution (N = 4 on 12x24, fewer points, shorter runs): about "
                   f"{COSTS['paper_quick'].figure} on 2 cores (measured "
                   f"{COSTS['paper_quick'].measured}).")  # fmt: skip
@click.option("--out", "outdir", type=click.Path(file_okay=False), default="paper",
              show_default=True, help="Folder of the report and its data.")  # fmt: skip
@click.option("--only", default=None, metavar="ITEM,...",
              help="Compute only these items (table1, fig2, fig4, ...; see --list).")  # fmt: skip
@click.option("--list", "show_list", is_flag=True, help="List the items and exit.")
@click.option("--redo", is_flag=True,
              help="Recompute items already done in --out (failed ones are always retried).")
@click.option("--redraw", is_flag=True,
              help="Draw the items done in --out again from their stored data (figures, "
                   "tables, comparisons); computes nothing for them.")  # fmt: skip
@click.option("--workers", type=int, default=None,
              help="Processes of the LocalCluster of the sweeps [default: the cores].")  # fmt: skip
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the sweeps on this Dask scheduler instead.")  # fmt: skip
@interruptible(lambda p: f"the items done are kept in {p['outdir']}; run the same command "
               "again")
def paper_command(quick, outdir, only, show_list, redo, redraw, workers, scheduler) -> None:
    """Regenerate the paper's tables and figures into --out/index.html (static, offline).

    Every item is computed through the sweep engine and the studies (resumable: a second call
    only redraws), with its figures, data (CSV), parameters, wall time and, where the paper
    states a value, that value beside ours. Items the package cannot compute yet are listed as
    missing. The full report at the paper's resolution costs hours on a 2-core machine; --quick
    is the reduced one (its measured cost below).
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
    check_scheduler(scheduler)
    keys = _only_items(only)
    if not quick:
        click.echo("the full report (N = 8 on 32x64) takes hours on a 2-core machine; "
                   "--quick for the reduced one", err=True)  # fmt: skip
    try:
        page = build_report(outdir, quick=quick, only=keys, redo=redo, redraw=redraw,
                            options={"workers": workers, "scheduler": scheduler},
                            progress=lambda text: click.echo(text, err=True))  # fmt: skip
    except KeyboardInterrupt:
        fail(f"interrupted: the items done are kept in {outdir}; run the same command again")
    except (ValueError, OSError) as err:
        fail(str(err))
    click.echo(str(page))


def _only_items(only: str | None) -> list[str] | None:
    """The items of ``--only`` (None: all), each checked against the report's before any work
    (an empty list, such as ``--only ,``, would otherwise mean every item)."""
    if only is None:
        return None
    keys = [k.strip() for k in only.split(",") if k.strip()]
    known = [item.key for item in ITEMS]
    if not keys:
        fail(f"--only needs item names, got {only!r}; the items are {', '.join(known)}")
    unknown = [k for k in keys if k not in known]
    if unknown:
        fail(f"--only: unknown item(s) {', '.join(unknown)}; the items are {', '.join(known)} "
             "(vesicle paper --list)")  # fmt: skip
    return keys


@main.command("validation")
@click.option("--full", "full_dir", type=click.Path(file_okay=False, exists=True), required=True,
              help="The full report's folder (vesicle paper --out DIR).")
@click.option("--quick", "quick_dir", type=click.Path(file_okay=False, exists=True),
              default=None, help="A quick report's folder, whose values go beside the full's.")
@click.option("--page", type=click.Path(dir_okay=False), default="docs/validation.md",
              show_default=True,
              help="The page whose generated section is replaced (appended if it has none).")
@click.option("--data", type=click.Path(file_okay=False), default="docs/validation",
              show_default=True, help="Folder for report.csv and report.json.")
@click.option("--package", "package", type=click.Path(file_okay=False), default=None,
              help="Also store the full report's values as the package's data here "
              "(src/vesicle/workflows/data: the quick report shows them beside its own).")
def validation_command(full_dir, quick_dir, page, data, package) -> None:
    """The validation page's table of the report's comparisons, from a full report (and a
    quick one): nothing is computed, every number is a report's."""
    from vesicle.workflows.validation import write_validation

    try:
        table = write_validation(full_dir, quick_dir, page, data, package)
    except (ValueError, OSError) as err:
        fail(str(err))
    compared = sum(1 for r in table if r["full_compared"])
    click.echo(f"{len(table)} comparisons ({compared} compared at the full resolution) written "
               f"to {page} and {data}/report.csv, report.json")  # fmt: skip
