"""``vesicle neutral-bq``: the neutral curve of a viscous membrane in the (Bq, lambda) plane."""

from __future__ import annotations

import click

from vesicle.bifurcation.neutral_bq import BqCurveInterrupted, neutral_curve_bq
from vesicle.bifurcation.neutral_codim2 import curve_memo
from vesicle.cli.base import command_line, fail, interruptible, main
from vesicle.cli.options import (
    config_option,
    discretisation_options,
    make_discretisation,
    make_physics,
    physics_options,
    task_option,
)
from vesicle.cli.steady import (
    _configure,
    _echo_progress,
    _emit_json,
    check_codim2_out,
    memo_folder,
    write_partial,
)
from vesicle.io.memo import MemoMismatch
from vesicle.model.settings import StabilitySettings
from vesicle.ranges import parse_range
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NewtonError


@main.command("neutral-bq")
@physics_options(("v", "chi", "flow"))
@click.option("--bq", "bq_text", default="0:10:1", show_default=True,
              help="The Boussinesq numbers to report: START:STOP[:STEP] or a comma list "
              "(>= 0); the curve is continued from the first to the last.")  # fmt: skip
@click.option("--lam-at", "lam_at", default=None,
              help="Viscosity ratios (comma list) at which to solve for the critical Bq, "
              "e.g. 1 [default: none].")  # fmt: skip
@click.option("--lam-min", type=float, default=0.05, show_default=True,
              help="The curve is followed down to this lambda.")
@click.option("--lam0", type=float, default=None,
              help="Where the seed's search for lambda_c at the first Bq starts.")
@discretisation_options()
@task_option("form")
@task_option("orientation")
@task_option("modes")
@task_option("jacobian")
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="Write the curve as JSON to this file; while the curve is traced its "
              "evaluations are kept beside it (curve.json -> curve.codim2/) for --resume.")
@click.option("--resume", is_flag=True,
              help="Continue the interrupted curve of --out: its evaluations kept in "
              "curve.codim2/ are replayed, and it goes on from where it stopped.")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing --out file and the evaluations kept beside it.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
@interruptible(lambda p: f"what was found is in {p['out']} (complete: false), its evaluations "
               f"in {memo_folder(p['out'])}: continue with the same command and --resume"
               if p.get("out")
               else "nothing was kept (give --out to keep what an interrupted curve found)")
def neutral_bq_command(ctx, bq_text, lam_at, lam_min, lam0, form, orientation, modes,
                       jacobian, out, resume, overwrite, as_json, config_path,
                       **options) -> None:  # fmt: skip
    """Critical viscosity ratio against the membrane's Boussinesq number, lambda_c(Bq), at
    fixed v and chi by two-parameter continuation in (Bq, lambda), and the critical Bq at
    the viscosity ratios of --lam-at (membrane viscosity: docs/reference/membrane-viscosity.md).
    """
    try:
        bqs = parse_range(bq_text, "step", name="--bq")
        lams = parse_range(lam_at, "linear", name="--lam-at", positive=True) if lam_at else []
    except ValueError as err:
        fail(str(err))
    if any(b < 0 for b in bqs):
        fail(f"--bq values must be >= 0, got {bq_text!r}")
    if not options["chi"] > 0:
        fail(f"--chi must be positive, got {options['chi']} (a reversed shear has the same "
             f"curve: give |chi|)")  # fmt: skip
    if not (lam_min > 0):
        fail(f"--lam-min must be positive, got {lam_min}")
    if lam0 is not None and not (lam0 > 0):
        fail(f"--lam0 must be positive, got {lam0}")
    check_codim2_out(out, resume, overwrite)
    memo = None
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        analysis = StabilitySettings(orientation, modes, jacobian)
        if out is not None:
            memo = curve_memo(memo_folder(out), physics, disc, analysis, form, ("lam", "bq"))
            if len(memo):
                click.echo(f"resuming: replaying the {len(memo)} evaluations kept in "
                           f"{memo.folder}", err=True)  # fmt: skip
        curve = neutral_curve_bq(physics, bqs, disc, lam_at=lams, lam0=lam0, analysis=analysis,
                                 form=form, lam_range=(lam_min, 100.0),
                                 progress=_echo_progress, memo=memo)  # fmt: skip
    except BqCurveInterrupted as err:  # what was found is kept, then the interruption goes on
        write_partial(ctx, out, err.partial, physics, disc, ("lam", "bq"))
        raise
    except MemoMismatch as err:
        fail(f"{err}: --overwrite starts the curve afresh")
    except (ValueError, TypeError, NewtonError, SolverError, RuntimeError, OSError) as err:
        fail(str(err) + ("" if memo is None else
                         f" (its evaluations are kept in {memo.folder}; --resume replays them)"))
    result = {**curve.to_dict(), "command": command_line(ctx)}
    if memo is not None:
        result["replayed"] = memo.hits
    if curve.failed:  # what was found is written; the command still fails
        _emit_json(result, out, as_json)
        kept = ("" if memo is None else
                f" (its evaluations stay in {memo.folder}: --resume replays them)")
        fail("; ".join(f["error"] for f in curve.failed) + kept)
    written = _emit_json(result, out, as_json)
    if memo is not None:  # the curve is in --out: its evaluations are no longer needed
        memo.clear()
    if written:
        return
    for p in result["points"]:
        if p["lambda_c"] is None:
            click.echo(f"Bq={p['bq']:<8.4g} {p['note']}")
            continue
        note = "" if p["located"] else " (estimate: not solved to tolerance)"
        if p["other_unstable"]:
            note += " (another eigenvalue unstable: not a stability boundary)"
        click.echo(f"Bq={p['bq']:<8.4g} lambda_c={p['lambda_c']:<10.6g} {p['bifurcation']:<12} "
                   f"omega_R={p['omega_R']:.4g}{note}")  # fmt: skip
    for q in result["critical_bq"]:
        how = "located" if q["located"] else "NOT located (estimate)"
        click.echo(f"critical Bq at lambda = {q['lam']:g}: {q['bq']:.6g} ({q['bifurcation']}, "
                   f"{how}, residual {q['residual']:.2g})")  # fmt: skip
    for q in result["special_points"]:
        how = "located" if q["located"] else "not located"
        click.echo(f"{q['kind']} at Bq = {q['bq']:.6g}, lambda = {q['lam']:.6g} ({how})")
