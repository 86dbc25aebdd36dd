"""Command-line interface: ``vesicle <command>`` (see ``vesicle --help``)."""

from vesicle.cli import geometry, membrane, paper, runs, steady, study, sweep  # noqa: F401  (register the commands)
from vesicle.cli.base import main

__all__ = ["main"]
