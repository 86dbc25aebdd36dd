"""``vesicle tt`` and ``vesicle critical``: steady tank-treading, its stability, lambda_c."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import click

from ..branch import branch, parse_values, reach
from ..config import read_config
from ..parallel import executor
from ..parameters import Physics
from ..problem import JACOBIANS
from ..solver import SolverError
from ..stability import critical_lambda, stability
from ..steady import UPDATES, NewtonError
from .base import fail, main
from .options import (
    apply_config,
    config_option,
    discretisation_options,
    make_discretisation,
    make_physics,
    physics_options,
)


def _executor(workers: int, scheduler: str | None):
    if workers < 1:
        fail("--workers must be at least 1")
    return executor(workers, scheduler)


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


_MAX_ITERATIONS = click.option(
    "--max-iterations",
    type=int,
    default=None,
    help="Newton iterations per steady state before giving up [default: 30; 12 with "
    "--updates none].",
)
_UPDATES = click.option(
    "--updates",
    type=click.Choice(UPDATES),
    default="broyden",
    show_default=True,
    help="Newton's Jacobian: reused with Broyden updates, or fresh at every step (reference).",
)


_JACOBIAN = click.option(
    "--jacobian",
    type=click.Choice(JACOBIANS),
    default="linearised",
    show_default=True,
    help="How Newton and stability form Jacobians: the solve differentiated (no solves per "
    "column), or finite differences of perturbed solves (the reference; --workers/--scheduler "
    "run their columns).",
)


@main.command()
@physics_options()
@discretisation_options()
@click.option("--stability", "with_stability", is_flag=True, help="Eigenvalues of the state.")
@click.option(
    "--modes", type=click.Choice(["symmetric", "general"]), default="symmetric", show_default=True
)
@_MAX_ITERATIONS
@_UPDATES
@_JACOBIAN
@click.option(
    "--workers", type=int, default=1, show_default=True, help="Processes for the Jacobian columns."
)
@_SCHEDULER
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
def tt(
    ctx, with_stability, modes, max_iterations, updates, jacobian, workers, scheduler, as_json,
    config_path, **options,
) -> None:  # fmt: skip
    """Steady tank-treading shape by Newton (and its linear stability)."""
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        with _executor(workers, scheduler) as pool:
            r = reach(
                physics,
                disc,
                executor=pool,
                progress=_echo_progress,
                max_iterations=max_iterations,
                updates=updates,
                jacobian=jacobian,
            )
            s = stability(r, modes=modes, executor=pool) if with_stability else None
    except (ValueError, TypeError, NewtonError, SolverError, OSError) as err:
        fail(str(err))
    out = {
        "v": physics.v,
        "lam": physics.lam,
        "chi": physics.chi,
        "flow_type": physics.flow.name,
        "degree": disc.degree,
        "grid": disc.grid,
        "physics": physics.to_dict(),
        "discretisation": disc.to_dict(),
        "psi": r.psi,
        "D": r.D,
        "axes": r.axes.tolist(),
        **r.stress.summary(),
        "bending": r.split["bending"].summary(),
        "flow": r.split["flow"].summary(),
        "newton_iterations": r.newton_iterations,
        "jacobians": r.jacobians,
        "updates": updates,
        "jacobian": jacobian,
        "residual": r.residual,
        "residual_history": list(r.residual_history),
        "multipliers": list(r.multipliers),
        "solves": r.solves,
        "seconds": r.seconds,
    }
    if s is not None:
        w_r, w_i = s.most_unstable
        out.update(
            {"modes": modes, "omega_R": w_r, "omega_I": w_i, "eigenvalues": s.omega.tolist()}
        )
    _print(out, as_json)


@main.command()
@physics_options(("v", "chi", "flow"))
@discretisation_options()
@click.option("--lam0", type=float, default=None, help="First lambda to try.")
@click.option(
    "--step",
    type=float,
    default=0.05,
    show_default=True,
    help="Relative move of lambda from --lam0 to the second evaluation; secant steps follow.",
)
@click.option("--xtol", type=float, default=1e-3, show_default=True, help="Tolerance on lambda_c.")
@_MAX_ITERATIONS
@_JACOBIAN
@click.option("--workers", type=int, default=1, show_default=True)
@_SCHEDULER
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@config_option
@click.pass_context
def critical(
    ctx, lam0, step, xtol, max_iterations, jacobian, workers, scheduler, as_json, config_path,
    **options,
) -> None:  # fmt: skip
    """Critical viscosity ratio where steady tank-treading loses stability."""
    try:
        _configure(ctx, options, config_path)
        physics, disc = make_physics(options), make_discretisation(options)
        with _executor(workers, scheduler) as pool:
            c = critical_lambda(
                physics,
                disc,
                lam0=lam0,
                step=step,
                xtol=xtol,
                executor=pool,
                progress=_echo_progress,
                max_iterations=max_iterations,
                jacobian=jacobian,
            )
    except (ValueError, TypeError, NewtonError, SolverError, RuntimeError, OSError) as err:
        fail(str(err))
    _print(
        {
            "v": physics.v,
            "chi": physics.chi,
            "degree": disc.degree,
            "grid": disc.grid,
            "physics": {k: x for k, x in physics.to_dict().items() if k != "lam"},
            "discretisation": disc.to_dict(),
            "lambda_c": c.lambda_c,
            "bifurcation": c.bifurcation,
            "omega_R": c.omega_R,
            "jacobian": jacobian,
            "history": [list(h) for h in c.history],
        },
        as_json,
    )


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
            "give exactly one of --lam, --chi, --v as a range (START:STOP[:STEP]) or a comma "
            f"list; got {'none' if not varied else ', '.join('--' + k for k in varied)}"
        )
    name = varied[0]
    try:
        values = parse_values(texts[name], step)
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
    "--chi", default=str(Physics().chi), show_default=True, help="Shear rate (or a range/list)."
)
@physics_options(("flow",))
@click.option("--step", type=float, default=None, help="Step of a START:STOP range [default: 1].")
@discretisation_options()
@click.option(
    "--xtol",
    type=float,
    default=1e-3,
    show_default=True,
    help="Tolerance of the special points (absolute in lam, relative in chi and v).",
)
@click.option(
    "--locate/--no-locate",
    default=True,
    show_default=True,
    help="Locate stability changes between points.",
)
@click.option(
    "--arclength/--no-arclength",
    default=True,
    show_default=True,
    help="Where natural continuation stops, follow the branch by pseudo-arclength to locate "
    "the fold.",
)
@click.option(
    "--past-fold",
    type=int,
    default=0,
    show_default=True,
    help="Arclength steps beyond a fold, on the unstable side.",
)
@_JACOBIAN
@click.option("--workers", type=int, default=1, show_default=True)
@_SCHEDULER
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the branch as JSON to this file.",
)
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def branch_command(v, lam, chi, step, xtol, locate, arclength, past_fold, jacobian, workers,
                   scheduler, out, as_json, **options) -> None:  # fmt: skip
    """Continue steady tank-treading in lam, chi or v, with its stability and special points."""
    name, values, fixed = _branch_parameters({"v": v, "lam": lam, "chi": chi}, step)
    try:
        physics = make_physics(options, **{**fixed, name: values[0]})
        disc = make_discretisation(options)
        for x in values:
            physics.replace(**{name: x})
        if out is not None:
            _writable(Path(out))
        with _executor(workers, scheduler) as pool:
            b = branch(physics, disc, name, values, locate=locate, xtol=xtol, executor=pool,
                       arclength=arclength, past_fold=past_fold, jacobian=jacobian,
                       progress=_echo_progress)  # fmt: skip
    except (ValueError, TypeError, NewtonError, SolverError, OSError) as err:
        fail(str(err))
    result = b.to_dict()
    if out is not None:
        tmp = Path(str(out) + ".tmp")
        tmp.write_text(json.dumps(result, indent=1))
        tmp.replace(out)
    if as_json:
        click.echo(json.dumps(result))
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


def _writable(path: Path) -> None:
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        fail(f"cannot write {path}: the folder {folder} does not exist or is not writable")
