"""``vesicle tt`` and ``vesicle critical``: steady tank-treading, its stability, lambda_c."""

from __future__ import annotations

import json
import math
import os
import shutil
import sys
from pathlib import Path

import click

from vesicle.bifurcation.branch import branch
from vesicle.bifurcation.checkpoint import Checkpoint, states_folder
from vesicle.bifurcation.neutral import neutral_curve
from vesicle.bifurcation.neutral_codim2 import (
    CurveInterrupted,
    curve_memo,
    neutral_curve_codim2,
)
from vesicle.cli.base import (
    check_output,
    check_scheduler,
    command_line,
    fail,
    interruptible,
    main,
    with_version,
)
from vesicle.cli.options import (
    apply_config,
    config_option,
    discretisation_options,
    make_discretisation,
    make_physics,
    physics_options,
    task_option,
)
from vesicle.io.files import stamped, write_text_atomically
from vesicle.io.memo import MemoMismatch
from vesicle.model.parameters import Physics
from vesicle.model.settings import (
    ContinuationSettings,
    Execution,
    StabilitySettings,
)
from vesicle.ranges import parse_range
from vesicle.solve.solver import SolverError
from vesicle.steady.files import write_steady
from vesicle.steady.newton import NewtonError
from vesicle.steady.stability import stability
from vesicle.workflows import tasks
from vesicle.workflows.config import read_config


def _executor(workers: int, scheduler: str | None):
    """The Jacobian columns' executor of ``--workers``/``--scheduler`` (:class:`Execution`)."""
    try:
        execution = Execution(workers=workers, scheduler=scheduler)
    except ValueError as err:
        fail(str(err).replace("Execution.workers", "--workers"))
    check_scheduler(scheduler, local=True)
    return execution.executor()


_SCHEDULER = click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Run the Jacobian columns on Dask: 'local' (a LocalCluster of --workers processes) "
    "or a scheduler address (tcp://host:port).",
)


def _echo_progress(info: dict) -> None:
    click.echo(
        " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in info.items()),
        err=True,
    )


_MAX_ITERATIONS = task_option("max_iterations")
_UPDATES = task_option("updates")


_WORKERS = click.option(
    "--workers",
    type=int,
    default=1,
    show_default=True,
    help="Processes for finite-difference Jacobian columns (--jacobian differences).",
)
_STATES = click.option(
    "--states",
    type=click.Path(file_okay=False),
    default=None,
    help="Also write each point's steady state (shape, multipliers, Jacobian, all eigenvalues "
    "and modes) as a steady-state file in this folder (vesicle plot / run --init read them).",
)
_ORIENTATION = task_option("orientation")
_STABILITY_MODES = task_option("modes")
_JACOBIAN = task_option("jacobian")


@main.command()
@physics_options()
@discretisation_options(("grid", "degree", "n_rot", "backend", "method", "threads", "multipliers"))
@click.option("--stability", "with_stability", is_flag=True, help="Eigenvalues of the state.")
@_STABILITY_MODES
@_ORIENTATION
@_MAX_ITERATIONS
@_UPDATES
@_JACOBIAN
@_WORKERS
@_SCHEDULER
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the state, its Jacobian and (with --stability) all eigenvalues and modes to this "
    "HDF5 file (vesicle run --init FILE starts from it; vesicle plot FILE draws the spectrum).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
def tt(
    ctx, with_stability, modes, orientation, max_iterations, updates, jacobian, workers,
    scheduler, out, overwrite, as_json, config_path, **options,
) -> None:  # fmt: skip
    """Steady tank-treading shape by Newton (and its linear stability)."""
    if out is not None:
        check_output(out, overwrite=overwrite)
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        task = {"modes": modes, "orientation": orientation, "max_iterations": max_iterations,
                "updates": updates, "jacobian": jacobian}  # fmt: skip
        with _executor(workers, scheduler) as pool:
            r, s = tasks.steady_state(physics, disc, task, with_stability, pool, _echo_progress)
        if out is not None:
            write_steady(out, r, s, attributes={"command": command_line(ctx)})
    except (ValueError, TypeError, NewtonError, SolverError, OSError) as err:
        fail(str(err))
    _print(tasks.steady_json(r, s, task), as_json)


@main.command()
@physics_options(("v", "chi", "flow", "bq"))
@discretisation_options()
@task_option("lam0")
@task_option("step")
@task_option("xtol", help="Tolerance on lambda_c.")
@task_option("coarse")
@_ORIENTATION
@_STABILITY_MODES
@_MAX_ITERATIONS
@_JACOBIAN
@_WORKERS
@_SCHEDULER
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
def critical(
    ctx, lam0, step, xtol, coarse, orientation, modes, max_iterations, jacobian, workers, scheduler,
    as_json, config_path, **options,
) -> None:  # fmt: skip
    """Critical viscosity ratio where steady tank-treading loses stability."""
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        task = {"lam0": lam0, "step": step, "xtol": xtol, "coarse": coarse,
                "orientation": orientation, "modes": modes, "max_iterations": max_iterations,
                "jacobian": jacobian}  # fmt: skip
        with _executor(workers, scheduler) as pool:
            c = tasks.critical(physics, disc, task, pool, _echo_progress)
    except (ValueError, TypeError, NewtonError, SolverError, RuntimeError, OSError) as err:
        fail(str(err))
    _print(tasks.critical_json(c, physics, disc, task), as_json)


def _print(out: dict, as_json: bool) -> None:
    if as_json:
        click.echo(json.dumps(out))
        return
    for key, value in out.items():
        if key not in ("eigenvalues", "residual_history", "history"):
            click.echo(f"{key:<18} {value}")
    sys.stdout.flush()


def _configure(ctx: click.Context, options: dict, config_path: str | None) -> None:
    """Options from a [physics] / [discretisation] config (explicit options win)."""
    if config_path is None:
        return
    config = read_config(config_path, sections=("physics", "discretisation"))
    rest = apply_config(ctx, options, config)
    if rest:  # keys this command has no option for (lam for critical, say)
        keys = ", ".join(f"[{s}] {k}" for s, k in rest)
        raise ValueError(f"{config_path}: {ctx.info_name} does not use {keys}")


def _branch_parameters(texts: dict[str, str], step: float | None):
    """The one varied parameter (a range or list) and the fixed ones (numbers)."""
    varied = [k for k, t in texts.items() if any(c in str(t) for c in ":,")]
    if len(varied) != 1:
        fail(
            "give exactly one of --lam, --chi, --v, --bq as a range (START:STOP[:STEP]) or a comma "
            f"list; got {'none' if not varied else ', '.join('--' + k for k in varied)}"
        )
    name = varied[0]
    try:
        values = parse_range(texts[name], "step", step=step, name=f"--{name}")
        fixed = {k: float(t) for k, t in texts.items() if k != name}
    except ValueError as err:
        fail(str(err))
    return name, values, fixed


@main.command("branch")
@click.option(
    "--v",
    "v",
    default=str(Physics().v),
    show_default=True,
    help="Reduced volume (or a range/list to vary it).",
)
@click.option(
    "--lam",
    default=str(Physics().lam),
    show_default=True,
    help="Viscosity ratio (or a range/list, e.g. 1:9 or 1,2,4,8).",
)
@click.option(
    "--chi", default=str(Physics().chi), show_default=True,
    help="Dimensionless shear rate (or a range/list)."
)
@click.option(
    "--bq", default=str(Physics().bq), show_default=True,
    help="Boussinesq number of the membrane's viscosity, >= 0 (or a range/list)."
)
@physics_options(("flow",))
@click.option("--step", type=float, default=None,
              help="Step size of a START:STOP range, which may run down (8:7) [default: 1].")
@discretisation_options(("grid", "degree", "n_rot", "backend", "method", "threads", "multipliers"))
@task_option("xtol",
             help="Tolerance of the special points (absolute in lam, relative in chi and v).")
@task_option("locate")
@task_option("arclength")
@task_option("past_fold")
@_ORIENTATION
@_STABILITY_MODES
@_JACOBIAN
@_WORKERS
@_SCHEDULER
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the branch as JSON to this file.",
)
@_STATES
@click.option("--overwrite", is_flag=True,
              help="Replace an existing --out file and --states files.")  # fmt: skip
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
@interruptible(lambda p: "nothing was written: a branch is written when it ends (its points "
               "were echoed above); run the command again to trace it")  # fmt: skip
def branch_command(ctx, v, lam, chi, bq, step, xtol, locate, arclength, past_fold, orientation,
                   modes, jacobian, workers, scheduler, out, states, overwrite, as_json,
                   config_path, **options) -> None:  # fmt: skip
    """Continue steady tank-treading in lam, chi, v or bq, with its stability and special points.

    With --config, the file's [physics] gives the values of --v/--lam/--chi/--bq not given on
    the command line (a range or list as a string, e.g. lam = "1:9") and [discretisation] the
    resolution."""
    texts = {"v": v, "lam": lam, "chi": chi, "bq": bq}
    if config_path is not None:
        try:
            config = read_config(config_path, sections=("physics", "discretisation"),
                                 ranges=("v", "lam", "chi", "bq"))  # fmt: skip
        except ValueError as err:
            fail(str(err))
        for key in texts:
            given = ctx.get_parameter_source(key) == click.core.ParameterSource.COMMANDLINE
            if not given and key in config.get("physics", {}):
                texts[key] = str(config["physics"][key])
        config["physics"] = {k: x for k, x in config.get("physics", {}).items() if k not in texts}
        apply_config(ctx, options, config)
    name, values, fixed = _branch_parameters(texts, step)
    try:
        physics = make_physics(options, **{**fixed, name: values[0]})
        disc = make_discretisation(options)
        for x in values:
            physics.replace(**{name: x})
        if out is not None:
            check_output(out, overwrite=overwrite)
        if states is not None:
            _check_states(states, [f"{name}_{x:.6g}.h5" for x in values], overwrite)
        with _executor(workers, scheduler) as pool:
            settings = ContinuationSettings(locate=locate, xtol=xtol, arclength=arclength,
                                            past_fold=past_fold)  # fmt: skip
            b = branch(physics, disc, name, values, continuation=settings,
                       analysis=StabilitySettings(orientation, modes, jacobian), executor=pool,
                       progress=_echo_progress)  # fmt: skip
    except (ValueError, TypeError, NewtonError, SolverError, OSError) as err:
        fail(str(err))
    fixed = {k: x for k, x in physics.to_dict().items() if k != name}
    result = with_version(b.to_dict(), physics=fixed, discretisation=disc)
    if states is not None:
        _write_states(ctx, states, [(f"{name}_{getattr(p.physics, name):.6g}", p.steady)
                                    for p in b.points if p.requested])  # fmt: skip
    if _emit_json(result, out, as_json):
        return
    for p in result["points"]:
        click.echo(
            f"{name}={p[name]:<10.6g} psi={p['psi']:+.5f} D={p['D']:.5f} S_xz={p['S_xz']:.5f} "
            f"omega=({p['omega_R']:.5g}, {p['omega_I']:+.5g}) unstable={p['n_unstable']}"
        )
    for s in result["special_points"]:
        click.echo(f"special point: {s['type']} at {name} = {s[name]:.6g}, omega_R = "
                   f"{s['omega_R']:.4g} ({'located' if s['located'] else 'estimate'})")  # fmt: skip
    if b.stopped:
        click.echo(f"stopped: {b.stopped}", err=True)


def _write_states(ctx, folder: str, named: list) -> None:
    """One steady-state file per ``(name, SteadyResult)`` in ``folder`` (created)."""
    path = Path(folder)
    try:
        path.mkdir(parents=True, exist_ok=True)
        for name, steady in named:
            write_steady(path / f"{name}.h5", steady, stability(steady),
                         attributes={"command": command_line(ctx)})  # fmt: skip
    except OSError as err:
        fail(f"cannot write the states to {folder}: {err}")


def _check_states(folder: str, names: list[str], overwrite: bool) -> None:
    """A --states folder's files are replaced only with --overwrite (checked before work)."""
    path = Path(folder)
    there = [n for n in names if (path / n).exists()]
    existing = path
    while not existing.exists():  # the folder is made at the end: try the nearest that exists
        existing = existing.parent
    if there and not overwrite:
        fail(f"--states {folder} already holds {', '.join(there[:3])}"
             f"{' ...' if len(there) > 3 else ''}; choose another folder, or replace them with "
             "--overwrite")  # fmt: skip
    if path.exists() and not path.is_dir():
        fail(f"--states {folder} is a file, not a folder")
    check_output(existing / ".vesicle-probe", option="--states")


def write_partial(ctx, out: str | None, partial: dict, physics: Physics, disc,
                  continued: tuple[str, ...]) -> None:  # fmt: skip
    """An interrupted curve's ``partial`` written to ``out`` (if given), stamped with the
    command, the version, the physics without the ``continued`` parameters and the
    discretisation."""
    if out is None:
        return
    fixed = {k: x for k, x in physics.to_dict().items() if k not in continued}
    write_text_atomically(out, json.dumps(
        stamped({**partial, "command": command_line(ctx)}, physics=fixed, discretisation=disc),
        indent=1))  # fmt: skip


def _emit_json(result: dict, out: str | None, as_json: bool) -> bool:
    """Write ``result`` to ``out`` (atomically) and print it with ``--json``; returns whether
    it was printed (then nothing else is)."""
    if out is not None:
        write_text_atomically(out, json.dumps(result, indent=1))
    if as_json:
        click.echo(json.dumps(result))
    return as_json


def _clear_states(folder: Path, resume: bool, overwrite: bool) -> None:
    """A neutral curve's checkpoint folder: kept with --resume, emptied of its states with
    --overwrite, refused otherwise if it holds states (a new curve would mix with them)."""
    held = sorted(folder.glob("chi_*.h5")) if folder.is_dir() else []
    if resume or not held:
        return
    if not overwrite:
        fail(f"the checkpoint folder {folder} holds {len(held)} states of an earlier curve; "
             "continue that curve with --resume, or replace it with --overwrite")  # fmt: skip
    for path in held:
        path.unlink()


def memo_folder(out: str | os.PathLike) -> Path:
    """Where a codim2 curve written to ``out`` keeps its evaluations while it is traced
    (``curve.json`` -> ``curve.codim2/``)."""
    return states_folder(out, ".codim2")


def _check_codim2_resume(out: str) -> None:
    """--resume of a codim2 curve: refused where ``out`` holds a complete curve (nothing to
    resume); said where there is nothing kept (the curve is computed from the start)."""
    folder = memo_folder(out)
    if folder.exists():
        return
    try:
        data = json.loads(Path(out).read_text()) if Path(out).exists() else None
    except (OSError, ValueError):
        data = None
    if data is not None and data.get("points") is not None and not data.get("interrupted"):
        fail(f"--resume: {out} holds a complete curve and no evaluations are kept "
             f"({folder}): nothing to resume (--overwrite computes it again)")  # fmt: skip
    click.echo(f"nothing to resume ({folder} does not exist): computing the curve from the "
               "start", err=True)  # fmt: skip


def _clear_memo(folder: Path, resume: bool, overwrite: bool) -> None:
    """A codim2 curve's evaluations: replayed with --resume, removed with --overwrite, refused
    otherwise (checked before any work)."""
    if not folder.exists() or resume:
        return
    if not overwrite:
        fail(f"{folder} holds the evaluations of an interrupted curve: continue it with "
             "--resume, or start afresh with --overwrite")  # fmt: skip
    shutil.rmtree(folder, ignore_errors=True)


def check_codim2_out(out: str | None, resume: bool, overwrite: bool) -> None:
    """A codim2 curve's ``--out``, ``--resume`` and ``--overwrite``, before any work: the
    combinations refused, a complete curve not resumed, the kept evaluations replayed
    (``--resume``), removed (``--overwrite``) or refused (neither)."""
    if resume and out is None:
        fail("--resume continues the curve of an --out file: give --out")
    if resume and overwrite:
        fail("--resume continues the curve in --out, --overwrite replaces it: give one")
    if out is None:
        return
    if Path(out).suffix == ".codim2":
        fail("--out: a curve's file cannot end in .codim2 (the name of the folder of its "
             "evaluations)")  # fmt: skip
    if resume:
        _check_codim2_resume(out)
    # an interrupted curve's file (complete: false) is replaced when it resumes
    check_output(out, overwrite=overwrite or resume, resume=False)
    _clear_memo(memo_folder(out), resume, overwrite)


def _neutral_kept(out: str | None, states: str | None, method: str = "trace") -> str:
    """What an interrupted ``vesicle neutral`` kept, and how to go on."""
    if method == "codim2":
        try:
            data = json.loads(Path(out).read_text()) if out is not None else {}
        except (OSError, ValueError):
            data = {}
        if data.get("interrupted"):
            n = sum(len(c["points"]) for c in data.get("curves", []))
            return (f"the curves traced so far ({len(data.get('curves', []))}, {n} points; "
                    f"complete: false) are in {out}, their evaluations in {memo_folder(out)}: "
                    "continue with the same command and --resume")  # fmt: skip
        return ("nothing was kept" + ("" if out is None else f" in {out}") + ": give --out to "
                "keep the curves traced so far on an interruption (--continuation trace keeps "
                "each point as it is found and resumes)")
    if out is None and states is None:
        return "nothing was kept (give --out to keep each point as it is found)"
    if out is None:
        return f"the states found are in {states}"
    try:
        points = len(json.loads(Path(out).read_text()).get("points", []))
    except (OSError, ValueError):
        points = 0
    folder = states or states_folder(out)
    return (f"{points} point{'s' if points != 1 else ''} kept in {out} (states in {folder}); "
            "continue with the same command and --resume")  # fmt: skip


def _neutral_codim2(ctx, chis, form, orientation, modes, jacobian, out, as_json, config_path,
                    options, type_change, cusps=False) -> None:  # fmt: skip
    """``vesicle neutral --continuation codim2``: the curve, then its points, type change, BT and
    cusp points printed (or the JSON)."""
    memo = None
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        analysis = StabilitySettings(orientation, modes, jacobian)
        if out is not None:
            memo = curve_memo(memo_folder(out), physics, disc, analysis, form)
            if len(memo):
                click.echo(f"resuming: replaying the {len(memo)} evaluations kept in "
                           f"{memo.folder}", err=True)  # fmt: skip
        curve = neutral_curve_codim2(physics, chis, disc, analysis=analysis, form=form,
                                     locate_type_change=type_change, cusps=cusps,
                                     progress=_echo_progress, memo=memo)  # fmt: skip
    except CurveInterrupted as err:  # what was found is kept, then the interruption goes on
        write_partial(ctx, out, err.partial, physics, disc, ("lam", "chi"))
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
        fail("; ".join(f"no point at chi = {f['chi']:.4g} ({f['error']})" if f["chi"] is not None
                       else f["error"] for f in curve.failed) + kept)  # fmt: skip
    written = _emit_json(result, out, as_json)
    if memo is not None:  # the curve is in --out: its evaluations are no longer needed
        memo.clear()
    if written:
        return
    for p in result["points"]:
        note = "" if p["located"] else " (estimate: not solved to tolerance)"
        if p.get("other_unstable"):
            note += " (another eigenvalue unstable: not a stability boundary)"
        if p.get("lower_fold") is not None:
            note += f" (past the lower sheet's fold at {p['lower_fold']:.6g})"
        click.echo(f"chi={p['chi']:<10.5g} lambda_c={p['lambda_c']:<10.6g} {p['bifurcation']:<12} "
                   f"omega_R={p['omega_R']:.4g}{note}")  # fmt: skip
    t = result["type_change"]
    if t:
        how = "located" if t.get("located") else "NOT located (estimate)"
        click.echo(f"type change at chi = {t['chi']:.6g} (lambda_c = {t['lambda_c']:.6g}, "
                   f"{how}): {t['below']} below, {t['above']} above")  # fmt: skip
    for key, name in (("bt_points", "Bogdanov-Takens"), ("cusp_points", "cusp"),
                      ("turn_points", "fold-curve turn (extremum of chi)")):  # fmt: skip
        for q in result.get(key, []):
            how = "located" if q["located"] else "not located"
            res = "" if q["residual"] is None else f", residual {q['residual']:.2g}"
            click.echo(f"{name} point at chi = {q['chi']:.6g}, lambda = {q['lambda']:.6g} "
                       f"({how}{res})")  # fmt: skip


def _chi_values(text: str, points: int | None) -> list[float]:
    """``--chi``: a list ``0.2,1,6``, or a range ``0.1:10`` with ``--points K`` (log-spaced)."""
    try:
        return parse_range(text, "log", points=points, name="--chi", positive=True)
    except ValueError as err:
        fail(str(err).replace("points", "--points"))


@main.command("neutral")
@physics_options(("v", "flow", "bq"))
@task_option("chi", "chi_text")
@task_option("points")
@discretisation_options()
@task_option("xtol", help="Absolute tolerance of each lambda_c.")
@task_option("type_tol")
@task_option("locate_type_change")
@task_option("cusps")
@task_option("continuation")
@task_option("form")
@_ORIENTATION
@_STABILITY_MODES
@_JACOBIAN
@_WORKERS
@_SCHEDULER
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="Write the curve as JSON to this file, point by point as they are found; "
              "each point's state goes to a checkpoint folder beside it (curve.json: "
              "curve.states/) unless --states names one.  codim2: the curve is written when "
              "complete, its evaluations kept in curve.codim2/ until then (--resume).")  # fmt: skip
@click.option(
    "--states",
    type=click.Path(file_okay=False),
    default=None,
    help="Write each point's state (the stable state below lambda_c: shape, multipliers, "
    "Jacobian, eigenvalues) as a steady-state file in this folder as it is found (vesicle "
    "plot / run --init read them; --resume continues from them).",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Continue the curve in --out (interrupted, or with more chi): its points whose "
    "states are kept are taken as found, the rest traced from them (the same options needed). "
    "With --continuation codim2: the interrupted curve is run again, its evaluations kept in "
    "curve.codim2/ replayed, and goes on from where it stopped.",
)
@click.option("--overwrite", is_flag=True,
              help="Replace an existing --out curve and the states of its checkpoint folder.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
@interruptible(lambda p: _neutral_kept(p["out"], p["states"], p.get("continuation", "trace")))
def neutral_command(ctx, chi_text, points, xtol, type_tol, no_type_change, cusps, continuation,
                    form, orientation, modes, jacobian, workers, scheduler, out, states, resume,
                    overwrite, as_json, config_path, **options) -> None:  # fmt: skip
    """Neutral curve lambda_c(chi) at fixed v: the edge of stable tank-treading, with the
    bifurcation type along the curve and where it changes (fold at low chi, Hopf at high)."""
    chis = _chi_values(chi_text, points)
    for name, value in (("--xtol", xtol), ("--type-tol", type_tol)):  # refused whichever method
        if not (math.isfinite(value) and value > 0):
            fail(f"{name} must be a positive number, got {value}")
    if continuation == "codim2":
        if states is not None:
            fail("--states applies to --continuation trace (the codim2 curve is written to "
                 "--out when it is complete; its evaluations are kept beside it)")  # fmt: skip
        check_codim2_out(out, resume, overwrite)
        _neutral_codim2(ctx, chis, form, orientation, modes, jacobian, out, as_json,
                        config_path, options, not no_type_change, cusps)  # fmt: skip
        return
    if cusps:
        fail("--cusps applies to --continuation codim2")
    if resume and out is None:
        fail("--resume continues the curve of an --out file: give --out")
    if resume and overwrite:
        fail("--resume continues the curve in --out, --overwrite replaces it: give one")
    if out is not None:
        check_output(out, overwrite=overwrite, resume=resume)
    if out is not None or states is not None:
        folder = Path(states) if states is not None else states_folder(out)
        _clear_states(folder, resume, overwrite)
    found: list[dict] = []
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        keep, known = None, []
        if out is not None or states is not None:
            keep = Checkpoint(out, physics, disc, folder=states, orientation=orientation,
                              modes=modes, xtol=xtol, jacobian=jacobian,
                              extra={"command": command_line(ctx)})  # fmt: skip
        if resume:
            known = keep.resume()
            click.echo(f"resuming {out}: {len(known)} points with their states in "
                       f"{keep.folder}" if Path(out).exists() else
                       f"nothing to resume in {out} (no such file): tracing from the start",
                       err=True)  # fmt: skip
        found = [p.to_dict() for p in known]

        def progress(info: dict) -> None:  # each point echoed (kept by the checkpoint)
            _echo_progress(info)
            found.append(info)

        with _executor(workers, scheduler) as pool:
            curve = neutral_curve(physics, chis, disc, xtol=xtol, type_tol=type_tol,
                                  locate_type_change=not no_type_change,
                                  analysis=StabilitySettings(orientation, modes, jacobian),
                                  executor=pool, progress=progress, known=known,
                                  checkpoint=keep)  # fmt: skip
    except (ValueError, TypeError, NewtonError, SolverError, RuntimeError, OSError) as err:
        kept = f" (the points found are in {out}; --resume continues)" if out and found else ""
        fail(str(err) + kept)
    result = {**curve.to_dict(), "command": command_line(ctx)}
    if curve.failed:  # what was found is written; the command still fails
        _emit_json(result, out, as_json)
        kept = f" (the points found are in {out}; --resume continues)" if out else ""
        fail("the curve stopped: " + "; ".join(f"before chi = {f['chi']:.4g}: {f['error']}"
                                              for f in curve.failed) + kept)  # fmt: skip
    if _emit_json(result, out, as_json):
        return
    for p in result["points"]:
        estimate = ("" if p.get("located", True) else
                    " (estimate: lambda_c in [{:.6g}, {:.6g}])".format(*p["bracket"]))
        if p.get("lower_fold") is not None:  # tank-treading goes on past a real crossing
            estimate += f" (past the real crossing at {p['lower_fold']:.6g})"
        click.echo(f"chi={p['chi']:<10.5g} lambda_c={p['lambda_c']:<10.6g} {p['bifurcation']:<12} "
                   f"omega_R={p['omega_R']:.4g}{estimate}")  # fmt: skip
    if result["type_change"]:
        t = result["type_change"]
        click.echo(f"type change at chi = {t['chi']:.4g} (lambda_c = {t['lambda_c']:.5g}): "
                   f"{t['below']} below, {t['above']} above")  # fmt: skip
