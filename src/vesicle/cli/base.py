"""The ``vesicle`` command group and shared helpers.

The CLI is the only layer that prints; library code logs through :mod:`logging`.
"""

from __future__ import annotations

import functools
import logging
import os
import shlex
import signal
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

import click

from vesicle._version import __version__
from vesicle.blas import one_blas_thread
from vesicle.io.files import stamped
from vesicle.parallel import keep_freed_memory
from vesicle.workflows.costs import command_help


def fail(message: str) -> None:
    """Stop with a clear one-line error (exit code 1)."""
    raise click.ClickException(message)


@click.group(
    context_settings={"help_option_names": ["-h", "--help"]},
    help=command_help(
        "Spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."
    ),
)
@click.version_option(__version__, prog_name="vesicle")
@click.option(
    "--verbose",
    count=True,
    help="More log output on stderr (--verbose: info, twice: debug). There is no -v: --v is "
    "the reduced volume of the commands.",
)
def main(verbose: int) -> None:
    """The ``vesicle`` command group. Its help (``help=`` above) is the one-line summary with
    the measured costs of :mod:`vesicle.workflows.costs`, the one table the README and docs
    quote."""
    configure_logging(logging.WARNING - 10 * min(verbose, 2))
    try:
        one_blas_thread()
    except ValueError as err:
        fail(str(err))
    keep_freed_memory()


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
    declared = {p.name: p for p in ctx.command.params}
    for name, value in ctx.params.items():
        if ctx.get_parameter_source(name) != click.core.ParameterSource.COMMANDLINE:
            continue
        param = declared.get(name)
        if isinstance(param, click.Argument):
            parts.append(shlex.quote(str(value)))
            continue
        # the option as it is spelled (``--chi`` for the parameter chi_text), not its name
        longs = [o for o in getattr(param, "opts", ()) if o.startswith("--")]
        option = longs[0] if longs else "--" + name.replace("_", "-")
        if isinstance(value, bool):
            off = [o for o in getattr(param, "secondary_opts", ()) if o.startswith("--")]
            if value or not off:
                parts.append(option if value or name.startswith("no_") else
                             f"--no-{option[2:]}")  # fmt: skip
            else:
                parts.append(off[0])
        else:
            parts.append(f"{option} {shlex.quote(str(value))}")
    return " ".join(parts)


def with_version(out: dict, **parameters) -> dict:
    """A ``--json`` object with ``vesicle_version`` and the given parameter objects' dicts."""
    return stamped(out, **parameters)


def check_output(
    path: str | os.PathLike,
    *,
    overwrite: bool = False,
    resume: bool | None = None,
    option: str = "--out",
) -> Path:
    """The one rule for every file a command writes, checked before any work.

    The folder must exist and take a new file (tried: a permission bit says nothing about
    ``/proc`` or a read-only mount).  An existing file is replaced only with ``--overwrite``;
    ``resume`` says whether the command can continue it instead (``None``: it cannot;
    ``False``: it can, with ``--resume``; ``True``: it is being resumed, so it must exist).
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        fail(f"cannot write {option} {path}: the folder {folder} does not exist")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".vesicle-probe-"):
            pass
    except OSError as err:
        fail(f"cannot write {option} {path}: the folder {folder} does not take new files "
             f"({err.strerror or err})")  # fmt: skip
    if resume:
        return path
    if path.exists() and not overwrite:
        how = ", continue it with --resume" if resume is False else ""
        fail(f"{path} exists; choose another {option}{how}, or replace it with --overwrite")
    return path


def _interrupt(*_) -> None:
    raise KeyboardInterrupt


def interruptible(kept: Callable[[dict], str]):
    """A command that Ctrl-C or SIGTERM ends with one line saying what was kept and how to go
    on (exit code 130), instead of click's bare "Aborted!".

    ``kept(params)`` builds that line from the command's parameters (read, say, the points of an
    ``--out`` file written as they were found).  Place it directly above the function."""

    def wrap(fn):
        @functools.wraps(fn)
        def run(*args, **params):
            main_thread = threading.current_thread() is threading.main_thread()
            previous = signal.signal(signal.SIGTERM, _interrupt) if main_thread else None
            try:
                return fn(*args, **params)
            except KeyboardInterrupt:
                try:
                    text = kept(params)
                except Exception as err:  # the message must not hide the interruption
                    text = f"(what was kept could not be read: {err})"
                click.echo(f"\ninterrupted: {text}", err=True)
                sys.exit(130)
            finally:
                if main_thread:
                    signal.signal(signal.SIGTERM, previous)

        return run

    return wrap


def check_scheduler(address: str | None, local: bool = False) -> None:
    """Refuse, before any work, a ``--scheduler`` that is not a Dask scheduler's address
    (``tcp://host:port``; Dask reads ``host:port`` as tcp): a client would otherwise only find
    out after the store or the output folder was written, and a half-made client can hang at
    exit.  ``local``: the command also takes ``local`` (a LocalCluster started here)."""
    if address is None or (local and address == "local"):
        return
    from distributed.comm.addressing import parse_address, parse_host_port  # with --scheduler

    try:
        _, location = parse_address(address)
        _, port = parse_host_port(location)
        if not 0 < port < 65536:
            raise ValueError(f"port {port} out of range")
    except ValueError as err:
        hint = "; for a LocalCluster started here give --workers" if address == "local" else ""
        fail(f"--scheduler must be a Dask scheduler address such as tcp://127.0.0.1:8786, got "
             f"{address!r} ({err}){hint}")  # fmt: skip
