"""Command-line interface: ``vesicle <command>`` (see ``vesicle --help``)."""

from . import geometry, runs, steady, sweep  # noqa: F401  (register the commands)
from .base import main

__all__ = ["main"]
