"""``vesicle run``, ``analyze``, ``plot`` and ``export``: the time-dependent main job."""

from __future__ import annotations

import csv
import json
import signal
import sys
import time
from pathlib import Path

import click
from tqdm import tqdm

from vesicle.cli.base import check_output, command_line, fail, main, with_version
from vesicle.cli.options import (
    apply_config,
    config_option,
    discretisation_options,
    make_discretisation,
    make_physics,
    physics_options,
)
from vesicle.dynamics.integrators import (
    INTEGRATORS,
    RUN_DEFAULTS,
    VISCOUS_SOLVES,
    RunParameters,
)
from vesicle.dynamics.simulation import SimulationError, load_parameters, simulate
from vesicle.geometry.diagnostics import summarize
from vesicle.geometry.surface import ShapeError
from vesicle.io.files import SERIES, RunData, read_run, write_text_atomically
from vesicle.io.vtk import export_vtk
from vesicle.model.parameters import SolverTolerances
from vesicle.plots.branch import is_branch_file, plot_branch
from vesicle.plots.phase import is_neutral_file, plot_neutral
from vesicle.plots.runs import plot_run
from vesicle.plots.steady import plot_steady
from vesicle.solve.solver import SolverError
from vesicle.steady.files import is_steady_file, read_steady
from vesicle.steady.newton import NewtonError, steady_tank_treading
from vesicle.workflows.config import read_config, solver_from, to_toml
from vesicle.workflows.study import plot_study, study_of_store
from vesicle.workflows.sweep import SweepStore, is_sweep_store, runs_from_store


def _default(name: str):
    """The library's default of a run setting (one source for CLI and API)."""
    return RUN_DEFAULTS[name]


#: The first columns of ``analyze --csv``, in the order of earlier versions (a public interface)
_CSV_FIRST = ("t", "psi", "D", "L1", "L2", "L3", "bending_energy", "area", "volume", "S_xz",
              "N1", "N2", "dt", "outer_iterations", "inner_iterations")  # fmt: skip

#: The CSV columns: those, then every other scalar series of :data:`vesicle.io.files.SERIES`.
CSV_COLUMNS = _CSV_FIRST + tuple(
    name for name, (shape, *_) in SERIES.items() if shape == () and name not in _CSV_FIRST
)


def _load(path: str) -> RunData:
    try:
        return read_run(path)
    except (FileNotFoundError, ValueError) as err:
        fail(str(err))


def _start_shape(init: str, physics, discretisation):
    """``spheroid``, ``tt`` (the steady tank-treading shape by Newton), a steady-state file of
    ``vesicle tt --out`` (its shape, no Newton) or ``FILE[:INDEX]`` of a run file."""
    if init == "spheroid":
        return None
    if init == "tt":
        try:
            return steady_tank_treading(physics, discretisation).shape
        except (ValueError, NewtonError) as err:
            fail(f"--init tt: {err}")
    path, _, index = init.partition(":")
    if not Path(path).exists():
        fail(f"--init must be 'spheroid', 'tt', a steady-state file or FILE[:INDEX] of a run "
             f"file; {path!r} does not exist")  # fmt: skip
    if is_steady_file(path):
        return _steady_start(path, physics, discretisation)
    run = _load(path)
    try:
        return run.shape(int(index) if index else -1)
    except (ValueError, IndexError):
        fail(f"no saved step {index!r} in {path} ({run.n_saved} saved)")


def _steady_start(path: str, physics, discretisation):
    """The shape of a steady-state file, checked against the run it starts."""
    try:
        steady = read_steady(path)
    except ValueError as err:
        fail(str(err))
    if steady.physics.v != physics.v:
        fail(f"--init {path}: its state has v = {steady.physics.v:g}, the run asks for "
             f"v = {physics.v:g}")  # fmt: skip
    if steady.discretisation.degree != discretisation.degree:
        fail(
            f"--init {path}: its state has degree {steady.discretisation.degree}, the run "
            f"asks for {discretisation.degree} (give --degree {steady.discretisation.degree})"
        )
    return steady.shape.with_grid(discretisation.grid)


class _Bar:
    """Progress of a run: a tqdm bar on a terminal; on anything else (a log file, a batch
    system) a plain line every tenth of the run or every ``PLAIN_EVERY`` seconds."""

    PLAIN_EVERY = 60.0

    def __init__(self, t0: float, t_end: float, enabled: bool):
        terminal = sys.stderr.isatty()
        self.plain = enabled and not terminal
        self.bar = tqdm(
            total=t_end,
            initial=t0,
            unit="t",
            disable=not (enabled and terminal),
            file=sys.stderr,
            bar_format="{l_bar}{bar}| t={n:.4f}/{total:g} [{elapsed}<{remaining}] {postfix}",
        )
        self.t, self.t0, self.t_end = t0, t0, t_end
        self.next_mark = t0 + 0.1 * (t_end - t0)
        self.last_line = time.monotonic()

    def __call__(self, info: dict) -> None:
        self.bar.update(info["t"] - self.t)
        self.t = info["t"]
        text = (f"dt={info['dt']:.1e} psi={info['psi']:+.4f} GMRES {info['outer']}/"
                f"{info['inner']} rejected={info['rejected']}")  # fmt: skip
        self.bar.set_postfix_str(text, refresh=False)
        now = time.monotonic()
        if self.plain and (self.t >= self.next_mark or now - self.last_line >= self.PLAIN_EVERY):
            click.echo(f"t={self.t:.4f}/{self.t_end:g} steps={info['steps']} {text}", err=True)
            self.last_line = now
            while self.next_mark <= self.t:
                self.next_mark += 0.1 * (self.t_end - self.t0)


def _sigterm(*_) -> None:
    raise KeyboardInterrupt


#: Options that ``--resume`` may be given with (everything else is the stored run's).
_RESUME_OPTIONS = {"resume", "t_end", "plot", "progress", "overwrite", "write_config", "as_json"}


def _refuse_changes_on_resume(ctx: click.Context, path: str) -> None:
    """A resumed run continues as it was set up: refuse options that would silently not apply."""
    given = [
        name
        for name in ctx.params
        if name not in _RESUME_OPTIONS
        and ctx.get_parameter_source(name) == click.core.ParameterSource.COMMANDLINE
    ]
    if given:
        names = ", ".join("--" + n.replace("_", "-") for n in given)
        fail(
            f"--resume continues {path} with its stored parameters; {names} cannot be changed "
            f"(only --t-end). To change them, start a new run from its last state: "
            f"vesicle run --init {path} --out NEW.h5 ..."
        )


#: Run options that the [run] table covers (option name -> key).
_RUN_KEYS = {name: ("run", name) for name in RUN_DEFAULTS}


def _run_parameters(ctx: click.Context, options: dict, config_path: str | None):
    """RunParameters from the options, the config file (options given win) and the defaults."""
    options = dict(options)
    options.pop("out", None)
    options["drift_control"] = not options.pop("no_drift_control")
    rest, solver = {}, None
    if config_path is not None:
        config = read_config(config_path)
        rest = apply_config(ctx, options, config, _RUN_KEYS)
        if ctx.get_parameter_source("no_drift_control") == click.core.ParameterSource.COMMANDLINE:
            rest.pop(("run", "drift_control"), None)
        elif "drift_control" in config.get("run", {}):
            options["drift_control"] = config["run"]["drift_control"]
        given = ctx.get_parameter_source("tolerances") == click.core.ParameterSource.COMMANDLINE
        if not given and config.get("solver"):
            solver = solver_from(config["solver"])
            options.pop("tolerances")
    physics, discretisation = make_physics(options), make_discretisation(options)
    extra = {key: value for (section, key), value in rest.items() if section == "run"}
    if solver is not None:
        options["solver"] = solver
    return RunParameters(physics, discretisation, **{**options, **extra})


def _write_config(ctx, options, config_path, path: Path, overwrite: bool) -> None:
    try:
        params = _run_parameters(ctx, options, config_path)
    except (ValueError, TypeError) as err:
        fail(str(err))
    check_output(path, overwrite=overwrite, option="--write-config")
    write_text_atomically(path, to_toml(params))
    click.echo(f"wrote {path}", err=True)


@main.command()
@physics_options()
@click.option("--t-end", type=float, default=_default("t_end"), show_default=True,
              help="End time, in units of mu_out a^3 / kappa (SPEC §1).")
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default="run.h5",
    show_default=True,
    help="The run file (HDF5: series, shapes, fields, checkpoint; vesicle.open_run reads it).",
)
@discretisation_options()
@click.option(
    "--init",
    default="spheroid",
    show_default=True,
    help="'spheroid' (of --v, long axis x); 'tt' (the steady tank-treading shape, by Newton); "
    "a steady-state file of 'vesicle tt --out' (its shape, no Newton); or FILE[:INDEX] (a "
    "saved step of a run).",
)
@click.option(
    "--tilt",
    type=float,
    default=_default("tilt"),
    help="Tilt (degrees) about the shorter in-plane principal axis, for out-of-plane starts.",
)
@click.option(
    "--perturb", type=float, default=_default("perturb"), help="Random perturbation amplitude."
)
@click.option("--seed", type=int, default=_default("seed"), help="Seed of the perturbation.")
@click.option(
    "--save-every",
    type=float,
    default=_default("save_every"),
    show_default=True,
    help="Time between saved steps (units of --t-end).",
)
@click.option(
    "--rtol",
    type=float,
    default=_default("rtol"),
    show_default=True,
    help="Local error per step, relative to the mean radius.",
)
@click.option(
    "--dt-max", type=float, default=_default("dt_max"), show_default=True,
    help="Largest time step (units of --t-end)."
)
@click.option(
    "--integrator",
    type=click.Choice(INTEGRATORS),
    default=_default("integrator"),
    show_default=True,
    help="ros2: linearly implicit in the bending stiffness (2 solves per step); "
    "bs3, heun: explicit (3 and 2 solves per step, step limited by bending stiffness).",
)
@click.option(
    "--viscous-solve",
    type=click.Choice(VISCOUS_SOLVES),
    default=_default("viscous_solve"),
    show_default=True,
    help="With --bq > 0: each solve by GMRES preconditioned with a kept factorised system "
    "(refreshed when it needs more than 8 iterations), or by the nested GMRES (the reference: "
    "slower with a viscous membrane).",
)
@click.option(
    "--steady-tol",
    type=float,
    default=_default("steady_tol"),
    show_default=True,
    help="Stop once max |dr/dt| falls below this: a settled tank-treading state (0: never).",
)
@click.option(
    "--periods",
    type=int,
    default=_default("periods"),
    help="Stop after this many settled psi periods (the last ones agreeing in length, and in "
    "TR in swing, to 2 %: the start-up transient is not counted; at least 2).",
)
@click.option(
    "--orbits",
    type=int,
    default=_default("orbits"),
    help="Out-of-plane runs (--tilt): stop once the long axis's precession or figure-8 has run "
    "this many of its periods twice over, the two windows agreeing in period and size to 2 % "
    "(0: never; at least 2).",
)
@click.option(
    "--split-stress",
    is_flag=True,
    help="Also store the bending and flow parts of the stress at saved steps (2 more solves each).",
)
@click.option(
    "--fields/--no-fields",
    "save_fields",
    default=_default("save_fields"),
    show_default=True,
    help="Store the tension and the membrane velocity on the grid at saved steps (64 kB per "
    "step at 32x64; --no-fields for very long runs).",
)
@click.option(
    "--checkpoint-every",
    type=float,
    default=_default("checkpoint_every"),
    show_default=True,
    help="Wall seconds between checkpoints.",
)
@click.option(
    "--tolerances",
    type=click.Choice(SolverTolerances.PRESETS),
    default="time-dependent",
    show_default=True,
    help="Velocity-solve tolerances (SPEC §6): 1e-3/1e-4, or the tight 1e-6/1e-7.",
)
@click.option("--no-drift-control", is_flag=True, help="Do not restore area and volume.")
@click.option(
    "--drift-tol",
    type=float,
    default=_default("drift_tol"),
    show_default=True,
    help="Relative area/volume drift at which both are restored.",
)
@click.option(
    "--resume",
    type=click.Path(exists=True, dir_okay=False),
    help="Continue the run in this file from its checkpoint (to --t-end if given).",
)
@click.option(
    "--plot/--no-plot",
    default=True,
    show_default=True,
    help="Write the figures next to the output file at the end.",
)
@click.option(
    "--progress/--no-progress",
    default=True,
    show_default=True,
    help="A progress bar on a terminal (periodic plain lines when stderr is not one).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
@click.option(
    "--json", "as_json", is_flag=True, help="The run's summary (vesicle analyze --json) on stdout."
)
@config_option
@click.option(
    "--write-config",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the run's parameters (defaults, the file's and the options given) as a "
    "commented TOML file, and stop.",
)
@click.pass_context
def run(
    ctx, resume, plot, progress, overwrite, as_json, config_path, write_config, **options
) -> None:
    """Time-dependent simulation of a vesicle in shear (writes an HDF5 run file)."""
    signal.signal(signal.SIGTERM, _sigterm)
    if write_config is not None:
        _write_config(ctx, options, config_path, Path(write_config), overwrite)
        return
    try:
        if resume:
            _refuse_changes_on_resume(ctx, resume)
            data = _load(resume)
            params = load_parameters(data)
            if ctx.get_parameter_source("t_end") != click.core.ParameterSource.DEFAULT:
                params = params.replace(t_end=options["t_end"])
            reached = float(data.checkpoint["t"]) if data.checkpoint else 0.0
            if params.t_end <= reached:
                fail(f"{resume} is already at t = {reached:g}: give --t-end beyond it to go on")
            out, start = resume, None
            check_output(out, resume=True)
        else:
            data, out = None, options.pop("out")
            check_output(out, overwrite=overwrite, resume=False)
            params = _run_parameters(ctx, options, config_path)
            start = _start_shape(params.init, params.physics, params.discretisation)
    except (ValueError, TypeError, ShapeError) as err:
        fail(str(err))
    t0 = float(data.checkpoint["t"]) if data is not None and data.checkpoint else 0.0
    command = command_line(ctx)
    if data is not None:
        data.attributes["resumed_by"] = command
    bar = _Bar(t0, params.t_end, progress)
    try:
        result = simulate(params, out=out, progress=bar, start=start, resume=data,
                          attributes={"command": command} if data is None else None)  # fmt: skip
    except KeyboardInterrupt:
        bar.bar.close()
        click.echo(f"interrupted; {_kept(out)}", err=True)
        sys.exit(130)
    except (SimulationError, SolverError, ShapeError) as err:
        bar.bar.close()
        fail(f"{err} ({_kept(out)})")
    except OSError as err:  # a full disk, a vanished folder: the last written file is intact
        bar.bar.close()
        kept = f"{out} keeps the last checkpoint written" if Path(out).exists() else "no file"
        fail(
            f"could not write {out}: {err.strerror or err}; {kept} "
            f"(resume with: vesicle run --resume {out} once the cause is fixed)"
        )
    bar.bar.close()
    summary = summarize(result)
    click.echo(
        f"wrote {out}: t = {summary['t_final']:g}, regime {summary['regime']}, "
        f"psi = {summary['final']['psi']:.4f}, D = {summary['final']['D']:.4f}",
        err=True,
    )
    if plot:
        try:
            figures = plot_run(result, Path(out).with_suffix(""), prefix="")
        except OSError as err:
            fail(f"the run is complete in {out}, but its figures could not be written: {err}")
        click.echo(f"figures in {Path(out).with_suffix('')}/ ({len(figures)} files)", err=True)
    if as_json:
        click.echo(json.dumps(with_version({"file": str(out), **summary})))


def _kept(out: str) -> str:
    """What a run that stopped early left, and how to go on."""
    if Path(out).exists():
        return (f"checkpoint in {out}, which holds everything up to there (resume with: "
                f"vesicle run --resume {out})")  # fmt: skip
    return f"it stopped before its first checkpoint: nothing was written to {out}"


@main.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@click.option("--csv", "as_csv", is_flag=True, help="The time series as CSV on stdout.")
def analyze(file, as_json, as_csv) -> None:
    """Regime, period, final shape, mean stress and drift of a run file."""
    data = _load(file)
    if data.n_saved == 0:
        fail(f"{file} has no saved steps")
    if as_csv:
        writer = csv.writer(sys.stdout)
        writer.writerow(CSV_COLUMNS)
        s = data.series
        for i in range(data.n_saved):
            row = {k: s[k][i] for k in s if s[k].ndim == 1}
            row.update({"L1": s["L"][i, 0], "L2": s["L"][i, 1], "L3": s["L"][i, 2]})
            writer.writerow([f"{float(row[c]):.12g}" for c in CSV_COLUMNS])
        return
    summary = summarize(data)
    if as_json:
        made_by = {"file_vesicle_version": str(data.attributes.get("vesicle_version", "?"))}
        click.echo(json.dumps(with_version({**made_by, **summary})))
        return
    for key, value in summary.items():
        if key != "parameters":
            click.echo(f"{key:<15} {value}")


@main.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--out",
    "outdir",
    type=click.Path(file_okay=False),
    help="Folder for the PNG files (default: FILE without its suffix).",
)
@click.option(
    "--with",
    "others",
    multiple=True,
    type=click.Path(exists=True, dir_okay=False),
    help="Further neutral-curve files drawn on the same phase diagram (repeatable).",
)
@click.option(
    "--runs",
    "runs_store",
    multiple=True,
    type=click.Path(exists=True, dir_okay=False),
    help='A sweep store of time-dependent runs (task = "run") whose regimes (TT/TR/TU) are '
    "overlaid on the phase diagrams (repeatable).",
)
def plot(file, outdir, others, runs_store) -> None:
    """PNG figures of a run (psi(t), D(t), S(t), D-psi orbit, shape projections, axes), of a
    steady-state file of ``vesicle tt --out`` (spectrum_eigenvalues, spectrum_El,
    eigenmode_1, eigenmode_2), of a branch of ``vesicle branch --out`` (branch_shape,
    branch_omega) or of neutral curves of ``vesicle neutral --out`` (phase_diagram,
    phase_SLambda; with --runs, the regimes of a sweep of runs on both)."""
    folder = outdir or Path(file).with_suffix("")
    kind, draw = next((k, d) for k, (is_kind, d) in FILE_KINDS.items() if is_kind(file))
    if (others or runs_store) and kind not in ("sweep store", "neutral curve"):
        fail("--with and --runs go with a neutral-curve file")
    try:
        paths = draw(file, folder, others, runs_store)
    except ValueError as err:
        fail(str(err))
    except OSError as err:
        fail(f"cannot write the figures: {err}")
    for p in paths or []:
        click.echo(str(p))


def _draw_neutral(file, folder, others, runs_store):
    _plot_curves([json.loads(Path(file).read_text())], folder, others, runs_store)


def _draw_branch(file, folder, others, runs_store):
    return plot_branch(json.loads(Path(file).read_text()), folder)


def _draw_steady(file, folder, others, runs_store):
    return plot_steady(read_steady(file), folder)


def _draw_run(file, folder, others, runs_store):
    return plot_run(_load(file), folder)


def _draw_sweep(file, folder, others, runs_store):
    _plot_sweep(file, folder, others, runs_store)


#: The kinds of file ``vesicle plot`` draws, in the order they are recognised: name ->
#: (detector, drawer).  A run file is the last resort (its reader says what is wrong with a
#: file that is none of them).  A new kind of output is one entry here.
FILE_KINDS = {
    "sweep store": (is_sweep_store, _draw_sweep),
    "neutral curve": (is_neutral_file, _draw_neutral),
    "branch": (is_branch_file, _draw_branch),
    "steady state": (is_steady_file, _draw_steady),
    "run": (lambda file: True, _draw_run),
}


def _plot_curves(curves: list[dict], folder, others, runs_store) -> None:
    """The phase diagrams of ``curves`` and the neutral-curve files ``others``, with the runs
    of a sweep store."""
    bad = [f for f in others if not is_neutral_file(f)]
    if bad:
        fail(f"--with takes neutral-curve files; {bad[0]} is not one")
    try:
        runs = [r for store in runs_store for r in runs_from_store(store)] or None
    except (OSError, ValueError, KeyError) as err:
        fail(f"--runs: {err}")
    curves = curves + [json.loads(Path(f).read_text()) for f in others]
    if not curves and not runs:
        fail("nothing to draw: no neutral curve and no classified run")
    try:
        paths = plot_neutral(curves, folder, runs=runs)
    except OSError as err:
        fail(f"cannot write the figures: {err}")
    for p in paths:
        click.echo(str(p))


def _plot_sweep(file, folder, others, runs_store) -> None:
    """A sweep store: its neutral curves (task neutral) or its classified runs (task run) on
    the phase diagrams, or each branch's figures in a subfolder (task branch)."""
    try:
        store = SweepStore.read(file)
    except (OSError, ValueError, KeyError) as err:
        fail(f"cannot read {file}: {err}")
    results = [(key, r["result"]) for key, r in store.records.items() if r.get("result")]
    study = study_of_store(store)
    if study is not None:  # a study's store (vesicle study): its own figure and table
        if others or runs_store:
            fail("--with and --runs go with neutral curves, not a study's store")
        try:
            paths = plot_study(store, study, folder)
        except OSError as err:
            fail(f"cannot write the figures: {err}")
        for p in paths:
            click.echo(str(p))
        return
    if store.task == "neutral":
        _plot_curves([r for _, r in results if r.get("points")], folder, others, runs_store)
    elif store.task == "run":
        if runs_store:
            fail("--runs goes with a neutral-curve file; this store is itself a sweep of runs")
        _plot_curves([], folder, others, (file,))
    elif store.task == "branch":
        if others or runs_store:
            fail("--with and --runs go with neutral curves")
        for key, r in results:
            try:
                paths = plot_branch(r, Path(folder) / key)
            except OSError as err:
                fail(f"cannot write the figures: {err}")
            for p in paths:
                click.echo(str(p))
    else:
        fail(f"vesicle plot draws sweeps of neutral curves, branches and runs; this one is "
             f"{store.task!r} (vesicle sweep CONFIG --table gives its rows)")  # fmt: skip


@main.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--vtk",
    "vtk_dir",
    type=click.Path(file_okay=False),
    required=True,
    help="Folder for the VTK time series (surface_*.vtp and surface.pvd).",
)
@click.option("--every", type=int, default=1, show_default=True, help="Export every k-th step.")
@click.option(
    "--ascii",
    "ascii_",
    is_flag=True,
    help="Write the arrays as text (default: binary, ~4x smaller).",
)
def export(file, vtk_dir, every, ascii_) -> None:
    """The surface at saved steps as a VTK time series for ParaView (point data: curvature,
    normal, radius and, when the run kept its fields, tension and velocity)."""
    data = _load(file)
    try:
        paths = export_vtk(data, vtk_dir, every=every, encoding="ascii" if ascii_ else "binary")
    except ValueError as err:
        fail(str(err))
    except OSError as err:
        fail(f"cannot write the VTK files: {err}")
    click.echo(f"wrote {len(paths) - 1} surfaces and {paths[-1]}")


@main.command("config")
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="Write the TOML here instead of stdout.")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file.")
def config_command(file, out, overwrite) -> None:
    """A run file's parameters as a TOML configuration (repeat it with vesicle run --config)."""
    data = _load(file)
    try:
        text = to_toml(load_parameters(data), title=f"parameters of {file}")
    except (ValueError, TypeError) as err:
        fail(f"cannot read the parameters of {file}: {err}")
    if out is None:
        click.echo(text, nl=False)
        return
    check_output(out, overwrite=overwrite)
    write_text_atomically(out, text)
    click.echo(f"wrote {out}", err=True)
