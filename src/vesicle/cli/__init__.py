"""Command-line interface: ``vesicle <command>`` (see ``vesicle --help``)."""

from . import geometry, paper, runs, steady, study, sweep  # noqa: F401  (register the commands)
from .base import main

__all__ = ["main"]
