"""The ``vesicle`` command group and shared helpers.

The CLI is the only layer that prints; library code logs through :mod:`logging`.
"""

from __future__ import annotations

import logging
import sys

import click

from .. import __version__


def fail(message: str) -> None:
    """Stop with a clear one-line error (exit code 1)."""
    raise click.ClickException(message)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vesicle")
@click.option("-v", "--verbose", count=True, help="More log output on stderr (-v info, -vv debug).")
def main(verbose: int) -> None:
    """Spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(
        level=level, stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s"
    )
