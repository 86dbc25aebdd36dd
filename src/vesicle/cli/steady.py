"""``vesicle tt`` and ``vesicle critical``: steady tank-treading, its stability, lambda_c."""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext

import click

from ..stability import critical_lambda, stability
from ..steady import UPDATES, NewtonError, steady_tank_treading
from .base import fail, main
from .options import discretisation_options, make_discretisation, make_physics, physics_options


def _executor(workers: int):
    if workers < 1:
        fail("--workers must be at least 1")
    return nullcontext(None) if workers == 1 else ProcessPoolExecutor(workers)


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


@main.command()
@physics_options()
@discretisation_options()
@click.option("--stability", "with_stability", is_flag=True, help="Eigenvalues of the state.")
@click.option(
    "--modes", type=click.Choice(["symmetric", "general"]), default="symmetric", show_default=True
)
@_MAX_ITERATIONS
@_UPDATES
@click.option(
    "--workers", type=int, default=1, show_default=True, help="Processes for the Jacobian columns."
)
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def tt(with_stability, modes, max_iterations, updates, workers, as_json, **options) -> None:
    """Steady tank-treading shape by Newton (and its linear stability)."""
    try:
        physics, disc = make_physics(options), make_discretisation(options)
        with _executor(workers) as pool:
            r = steady_tank_treading(
                physics,
                disc,
                executor=pool,
                progress=_echo_progress,
                max_iterations=max_iterations,
                updates=updates,
            )
            s = stability(r, modes=modes, executor=pool) if with_stability else None
    except (ValueError, TypeError, NewtonError) as err:
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
@click.option("--workers", type=int, default=1, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def critical(lam0, step, xtol, max_iterations, workers, as_json, **options) -> None:
    """Critical viscosity ratio where steady tank-treading loses stability."""
    try:
        physics, disc = make_physics(options), make_discretisation(options)
        with _executor(workers) as pool:
            c = critical_lambda(
                physics,
                disc,
                lam0=lam0,
                step=step,
                xtol=xtol,
                executor=pool,
                progress=_echo_progress,
                max_iterations=max_iterations,
            )
    except (ValueError, TypeError, NewtonError, RuntimeError) as err:
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
