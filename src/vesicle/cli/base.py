"""The ``vesicle`` command group and shared helpers.

The CLI is the only layer that prints; library code logs through :mod:`logging`.
"""

from __future__ import annotations

import logging
import shlex
import sys

import click

from .. import __version__


def fail(message: str) -> None:
    """Stop with a clear one-line error (exit code 1)."""
    raise click.ClickException(message)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vesicle")
@click.option(
    "--verbose",
    count=True,
    help="More log output on stderr (--verbose: info, twice: debug). There is no -v: --v is "
    "the reduced volume of the commands.",
)
def main(verbose: int) -> None:
    """Spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow.

    Costs at the default resolution (N = 8 on 32 x 64) on a 2-core machine: `tt --stability`
    about 33 s, `critical` about 5 min, `run` about 3 s per time step near lambda = 8 (260 s
    per unit of time; 155 s at lambda = 1); `neutral` at N = 4 on 16 x 32 about 2.5 min for
    chi = 0.2, 1, 3.
    """
    configure_logging(logging.WARNING - 10 * min(verbose, 2))


def configure_logging(level: int) -> logging.Handler | None:
    """Log records of ``level`` and above to stderr, whichever logger they come from.

    The level is set on the handler too: records that other libraries' loggers emit below it
    (Dask's scheduler and nanny log at info level by default) propagate to the root's handler
    past the root logger's own level, and would otherwise reach the terminal."""
    root = logging.getLogger()
    if root.handlers:  # configured already (an embedding program, a test runner): keep it
        return None
    logging.basicConfig(
        level=level, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s"
    )
    handler = root.handlers[-1]
    handler.setLevel(level)
    return handler


def command_line(ctx: click.Context) -> str:
    """The command as given: its path and the options set on the command line."""
    parts = [ctx.command_path]
    for name, value in ctx.params.items():
        if ctx.get_parameter_source(name) != click.core.ParameterSource.COMMANDLINE:
            continue
        option = "--" + name.replace("_", "-")
        if isinstance(value, bool):
            parts.append(option if value or name.startswith("no_") else f"--no-{option[2:]}")
        else:
            parts.append(f"{option} {shlex.quote(str(value))}")
    return " ".join(parts)


def with_version(out: dict, **parameters) -> dict:
    """A ``--json`` object with ``vesicle_version`` and the given parameter objects' dicts."""
    extra = {k: (v.to_dict() if hasattr(v, "to_dict") else v) for k, v in parameters.items()}
    return {"vesicle_version": __version__, **extra, **out}
