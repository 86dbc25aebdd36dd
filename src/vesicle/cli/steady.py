"""``vesicle tt`` and ``vesicle critical``: steady tank-treading, its stability, lambda_c."""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext

import click

from ..stability import critical_lambda, stability
from ..steady import NewtonError, steady_tank_treading
from .base import fail, main


def _executor(workers: int):
    if workers < 1:
        fail("--workers must be at least 1")
    return nullcontext(None) if workers == 1 else ProcessPoolExecutor(workers)


def _echo_progress(info: dict) -> None:
    click.echo(
        " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in info.items()),
        err=True,
    )


@main.command()
@click.option("--v", "v", type=float, default=0.95, show_default=True, help="Reduced volume.")
@click.option("--lam", type=float, default=8.0, show_default=True, help="Viscosity ratio.")
@click.option("--chi", type=float, default=10.0, show_default=True, help="Shear rate.")
@click.option("--degree", type=int, default=8, show_default=True, help="Shape degree N.")
@click.option("--grid", type=int, default=32, show_default=True, help="n_theta of the grid.")
@click.option("--stability", "with_stability", is_flag=True, help="Eigenvalues of the state.")
@click.option(
    "--modes", type=click.Choice(["symmetric", "general"]), default="symmetric", show_default=True
)
@click.option(
    "--workers", type=int, default=1, show_default=True, help="Processes for the Jacobian columns."
)
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def tt(v, lam, chi, degree, grid, with_stability, modes, workers, as_json) -> None:
    """Steady tank-treading shape by Newton (and its linear stability)."""
    try:
        with _executor(workers) as pool:
            r = steady_tank_treading(
                v, lam, chi, degree=degree, grid=grid, executor=pool, progress=_echo_progress
            )
            s = stability(r, modes=modes, executor=pool) if with_stability else None
    except (ValueError, NewtonError) as err:
        fail(str(err))
    out = {
        "v": v,
        "lam": lam,
        "chi": chi,
        "degree": degree,
        "grid": grid,
        "psi": r.psi,
        "D": r.D,
        "axes": r.axes.tolist(),
        **r.stress.summary(),
        "bending": r.split["bending"].summary(),
        "flow": r.split["flow"].summary(),
        "newton_iterations": r.newton_iterations,
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
@click.option("--v", "v", type=float, default=0.95, show_default=True, help="Reduced volume.")
@click.option("--chi", type=float, default=1.0, show_default=True, help="Shear rate.")
@click.option("--degree", type=int, default=8, show_default=True, help="Shape degree N.")
@click.option("--grid", type=int, default=32, show_default=True, help="n_theta of the grid.")
@click.option("--lam0", type=float, default=None, help="First lambda to try.")
@click.option(
    "--step",
    type=float,
    default=0.05,
    show_default=True,
    help="Relative move of lambda from --lam0 to the second evaluation; secant steps follow.",
)
@click.option("--xtol", type=float, default=1e-3, show_default=True, help="Tolerance on lambda_c.")
@click.option("--workers", type=int, default=1, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def critical(v, chi, degree, grid, lam0, step, xtol, workers, as_json) -> None:
    """Critical viscosity ratio where steady tank-treading loses stability."""
    try:
        with _executor(workers) as pool:
            c = critical_lambda(
                v,
                chi,
                degree=degree,
                grid=grid,
                lam0=lam0,
                step=step,
                xtol=xtol,
                executor=pool,
                progress=_echo_progress,
            )
    except (ValueError, NewtonError, RuntimeError) as err:
        fail(str(err))
    _print(
        {
            "v": v,
            "chi": chi,
            "degree": degree,
            "grid": grid,
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
