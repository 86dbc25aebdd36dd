"""``vesicle sweep CONFIG.toml``: a task over a parameter grid on Dask
(:mod:`vesicle.workflows.sweep`)."""

from __future__ import annotations

import csv
import json
import sys

import click

from vesicle.cli.base import check_scheduler, fail, interruptible, main
from vesicle.workflows.config import ConfigError
from vesicle.workflows.sweep import SweepStore, read_sweep_config, run_sweep


def _progress_printer():
    """A tqdm bar on a terminal; one plain line per completed point otherwise."""
    from tqdm import tqdm

    bar = None

    def show(info: dict) -> None:
        nonlocal bar
        if sys.stderr.isatty():
            if bar is None:
                bar = tqdm(total=info["total"], unit="point", file=sys.stderr,
                           initial=info["done"] + info["failed"] - 1)  # fmt: skip
            bar.update(1)
            bar.set_postfix_str(f"failed={info['failed']}", refresh=False)
            return
        seconds = info.get("seconds")
        took = f" in {seconds:.1f} s" if seconds is not None else ""
        click.echo(f"point {info['key']} {info['status']}{took}: {info['done']} done, "
                   f"{info['failed']} failed, {info['pending']} pending of {info['total']}",
                   err=True)  # fmt: skip

    def close() -> None:
        if bar is not None:
            bar.close()

    return show, close


@main.command("sweep")
@click.argument("config_path", metavar="CONFIG.toml", type=click.Path(dir_okay=False))
@click.option(
    "--workers",
    type=int,
    default=None,
    help="Processes of the LocalCluster started here [default: the cores].",
)
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on this Dask scheduler (tcp://host:port, e.g. from dask-jobqueue) "
              "instead of a LocalCluster.")  # fmt: skip
@click.option("--status", "show_status", is_flag=True, help="Report done / failed / pending.")
@click.option("--table", "show_table", is_flag=True, help="Print the results, one row per point.")
@click.option("--json", "as_json", is_flag=True, help="--status or --table as JSON.")
@click.option("--csv", "as_csv", is_flag=True, help="--table as CSV.")
@interruptible(lambda p: "the points done are kept in the sweep's store; run the same "
               "command again to continue")
def sweep_command(config_path, workers, scheduler, show_status, show_table, as_json,
                  as_csv) -> None:  # fmt: skip
    """Run a task (tt, stability, critical, branch, neutral, neutral_bq, ellipsoid_map, run)
    over the points of CONFIG.toml, resumably.

    Every completed point is written to the store ([sweep] out) at once; a rerun skips the
    points done. --status and --table read the store and compute nothing.
    """
    if workers is not None and workers < 1:
        fail("--workers must be at least 1")
    if workers is not None and scheduler is not None:
        fail("give --workers (a LocalCluster) or --scheduler, not both")
    if as_csv and not show_table:
        fail("--csv goes with --table")
    check_scheduler(scheduler)
    try:
        config = read_sweep_config(config_path)
        store = SweepStore.open(config)
    except (ConfigError, ValueError) as err:
        fail(str(err))
    if show_status or show_table:
        _report(store, config, show_status, show_table, as_json, as_csv)
        return
    show, close = _progress_printer()
    try:
        store = run_sweep(config, workers=workers, scheduler=scheduler, progress=show)
    except KeyboardInterrupt:
        close()
        status = SweepStore.open(config).status(config)
        fail(f"interrupted: {status['done']} points done and kept in {config.out}; run the same "
             "command again to continue")  # fmt: skip
    except (ConfigError, ValueError, OSError) as err:
        fail(str(err))
    close()
    status = store.status(config)
    click.echo(json.dumps(status) if as_json else
               f"{config.out}: {status['done']} done, {status['failed']} failed, "
               f"{status['pending']} pending")  # fmt: skip


def _report(store: SweepStore, config, show_status, show_table, as_json, as_csv) -> None:
    if show_status:
        status = store.status(config)
        click.echo(json.dumps(status) if as_json else
                   f"done {status['done']}, failed {status['failed']}, "
                   f"pending {status['pending']}")  # fmt: skip
    if not show_table:
        return
    rows = store.rows()
    if as_json:
        click.echo(json.dumps({"rows": rows}))
        return
    scalar = [{k: v for k, v in r.items() if not isinstance(v, list | dict)} for r in rows]
    columns = list(dict.fromkeys(k for r in scalar for k in r))
    if as_csv:
        writer = csv.DictWriter(sys.stdout, fieldnames=columns)
        writer.writeheader()
        writer.writerows(scalar)
        return
    shown = [c for c in columns if c not in ("key", "traceback", "error", "physics")][:9]
    click.echo("  ".join(f"{c:>12}" for c in shown))
    for r in scalar:
        click.echo("  ".join(f"{_cell(r.get(c)):>12}" for c in shown))
        if r.get("error"):
            click.echo(f"{'':>12}  error: {r['error']}")


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return "" if value is None else str(value)
