"""Command-line options of the parameter objects: one default per parameter, read from the
objects themselves (:class:`~vesicle.model.parameters.Physics`, :class:`~vesicle.model.parameters.
Discretisation`, :data:`vesicle.dynamics.integrators.RUN_DEFAULTS`), and the objects built from
them; and the options of the tasks (:data:`vesicle.workflows.tasks.OPTIONS`), declared once for the
commands and the sweeps (:func:`task_option`)."""

from __future__ import annotations

import click

from vesicle.model.flows import FLOWS
from vesicle.model.parameters import METHODS, MULTIPLIERS, Discretisation, Physics
from vesicle.stokes.backends import BACKENDS
from vesicle.workflows.tasks import OPTIONS

__all__ = [
    "discretisation_options",
    "make_discretisation",
    "make_physics",
    "physics_options",
    "task_option",
]

_P = Physics()
_D = Discretisation()


def _apply(decorators):
    def wrap(fn):
        for d in reversed(decorators):
            fn = d(fn)
        return fn

    return wrap


def physics_options(names=("v", "lam", "chi", "flow", "bq")):
    """``--v --lam --chi --flow --bq`` with the defaults of :class:`Physics`."""
    table = {
        "v": click.option("--v", "v", type=float, default=_P.v, show_default=True,
                          help="Reduced volume, in (0, 1]."),
        "lam": click.option("--lam", type=float, default=_P.lam, show_default=True,
                            help="Viscosity ratio mu_in / mu_out."),
        "chi": click.option("--chi", type=float, default=_P.chi, show_default=True,
                            help="Dimensionless shear rate (strain rate of other flows)."),
        "flow": click.option("--flow", type=click.Choice(sorted(FLOWS)), default=_P.flow.name,
                             show_default=True, help="Background linear flow."),
        "bq": click.option("--bq", type=float, default=_P.bq, show_default=True,
                           help="Boussinesq number eta_m / (mu_out a) of the membrane's surface "
                           "viscosity, >= 0 (0: the paper's inviscid membrane)."),
    }  # fmt: skip
    return _apply([table[n] for n in names])


def discretisation_options(names=("grid", "degree", "n_rot", "backend", "method", "threads")):
    """``--grid --degree --n-rot --backend --method --threads`` with the defaults of
    :class:`Discretisation`."""
    table = {
        "grid": click.option("--grid", type=int, default=_D.grid, show_default=True,
                             help="n_theta of the grid (n_phi = 2 n_theta)."),
        "degree": click.option("--degree", type=int, default=_D.degree, show_default=True,
                               help="Shape degree N."),
        "n_rot": click.option("--n-rot", type=int, default=None,
                              help="theta' nodes of the rotated quadrature grid [default: grid]."),
        "backend": click.option("--backend", type=click.Choice(tuple(BACKENDS)),
                                default=_D.backend, show_default=True,
                                help="Layer-potential assembly kernels (numpy: the reference)."),
        "method": click.option("--method", type=click.Choice(METHODS), default=_D.method,
                               show_default=True, help="Layer potentials assembled or not."),
        "multipliers": click.option(
            "--multipliers", type=click.Choice(MULTIPLIERS), default=_D.multipliers,
            show_default=True,
            help="Along which directions the steady equations' area and volume multipliers "
                 "act: the gradients in the basis coordinates (SPEC §8) or the L2 gradients "
                 "(l2: those of the time stepping's drift control, whose fixed points the "
                 "states then are)."),
        "threads": click.option("--threads", type=int, default=None,
                                help="Threads over latitude rings in assembly [default: 1 on grids "
                                "of 16 latitudes or fewer, else <= 2]."),
    }  # fmt: skip
    return _apply([table[n] for n in names])


def task_option(key: str, name: str | None = None, **changes):
    """The command-line option of the task option ``key`` (:data:`OPTIONS`): its spelling,
    type, choices, default and help, as a sweep's ``[task]`` table takes it.  ``name``: the
    Python parameter where it differs from the key; ``changes``: click keywords overriding
    those (a command-specific help, say)."""
    o = OPTIONS[key]
    if not o.cli:
        raise ValueError(f"{key} is a sweep-only option")
    flag = o.flag or "--" + key.replace("_", "-")
    if bool in o.types:
        if "/" in flag:  # --coarse/--no-coarse
            kwargs = {"default": o.default, "show_default": True}
        else:  # --cusps; --no-type-change sets the key to false
            kwargs = {"is_flag": True}
            name = name or flag[2:].replace("-", "_")
    elif o.choices is not None:
        kwargs = {"type": click.Choice(list(o.choices)), "default": o.default}
    elif int in o.types and float not in o.types:
        kwargs = {"type": int, "default": o.default}
    elif float in o.types:
        kwargs = {"type": float, "default": o.default}
    else:
        kwargs = {"type": str, "default": o.default}
    if o.default is not None and "is_flag" not in kwargs:
        kwargs["show_default"] = True
    kwargs = {"help": o.help, **kwargs, **changes}
    return click.option(flag, name or key, **kwargs)


def make_physics(options: dict, **overrides) -> Physics:
    """The :class:`Physics` of the parsed options (popped from ``options``)."""
    values = {k: options.pop(k) for k in ("v", "lam", "chi", "flow", "bq") if k in options}
    return Physics(**{**values, **overrides})


def make_discretisation(options: dict) -> Discretisation:
    """The :class:`Discretisation` of the parsed options (popped from ``options``)."""
    values = {k: options.pop(k) for k in ("grid", "degree", "n_rot", "backend", "method",
                                          "multipliers") if k in options}  # fmt: skip
    if "threads" in options:
        values["workers"] = options.pop("threads")
    return Discretisation(**values)


#: Command-line option -> (config table, key) for the options the tables cover.
CONFIG_KEYS = {
    "v": ("physics", "v"), "lam": ("physics", "lam"), "chi": ("physics", "chi"),
    "flow": ("physics", "flow"), "bq": ("physics", "bq"), "grid": ("discretisation", "grid"),
    "degree": ("discretisation", "degree"), "n_rot": ("discretisation", "n_rot"),
    "backend": ("discretisation", "backend"), "method": ("discretisation", "method"),
    "threads": ("discretisation", "workers"), "tolerances": ("solver", "preset"),
    "multipliers": ("discretisation", "multipliers"),
}  # fmt: skip


def config_option(fn):
    """``--config FILE.toml``: the tables of :mod:`vesicle.workflows.config`; explicit options
    win."""
    return click.option(
        "--config",
        "config_path",
        type=click.Path(dir_okay=False),
        default=None,
        help="TOML file with [physics], [discretisation], [solver] (and [run]) tables; "
        "options given on the command line override it.",
    )(fn)


def apply_config(ctx: click.Context, options: dict, config: dict, extra: dict | None = None):
    """Fill ``options`` from ``config`` where the command line did not give them; returns the
    config's keys that no option covers (e.g. run settings without an option)."""
    keys = {**CONFIG_KEYS, **(extra or {})}
    covered = set()
    for name, (section, key) in keys.items():
        if name not in options:
            continue
        covered.add((section, key))
        given = ctx.get_parameter_source(name) == click.core.ParameterSource.COMMANDLINE
        if not given and key in config.get(section, {}):
            options[name] = config[section][key]
    return {
        (section, key): value
        for section, table in config.items()
        for key, value in table.items()
        if (section, key) not in covered
    }
