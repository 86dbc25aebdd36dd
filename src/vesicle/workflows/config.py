"""TOML configuration files for runs and steady-state commands (issue 18, part 1).

A file has up to four tables that map onto the parameter objects::

    [physics]          # vesicle.Physics: v, lam, chi, flow
    [discretisation]   # vesicle.Discretisation: grid, degree, n_rot, backend, method, workers
    [solver]           # vesicle.SolverTolerances: preset ("time-dependent" | "steady") or
                       #   schur, inner, max_outer, max_inner, restart
    [run]              # the run settings of vesicle.dynamics.integrators.RUN_DEFAULTS (vesicle run
    only)

:func:`read_config` refuses, before any work, unknown tables and keys (naming the key, the file
and the closest known key), values of the wrong type and values the objects refuse.
Command-line options given explicitly override the file (:func:`merge`); :func:`to_toml` writes
a commented file from :class:`~vesicle.dynamics.integrators.RunParameters` (the defaults as a
template, or a run file's parameters to repeat the run).
"""

from __future__ import annotations

import difflib
import json
import tomllib
from pathlib import Path

import numpy as np

from vesicle.dynamics.integrators import RUN_DEFAULTS, RunParameters
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances

__all__ = ["SECTIONS", "ConfigError", "merge", "read_config", "to_toml", "toml_text", "toml_value"]

_NUMBER = (int, float)

#: Keys of each table and the types they take (``None``: also allowed to be absent/null).
SECTIONS: dict[str, dict[str, tuple]] = {
    "physics": {"v": _NUMBER, "lam": _NUMBER, "chi": _NUMBER, "flow": (str, list)},
    "discretisation": {"grid": (int,), "degree": (int,), "n_rot": (int,), "backend": (str,),
                       "method": (str,), "workers": (int,), "multipliers": (str,)},
    "solver": {"preset": (str,), "schur": _NUMBER, "inner": _NUMBER, "max_outer": (int,),
               "max_inner": (int,), "restart": (int,)},
    "run": {name: (bool,) if isinstance(d, bool) else (str,) if isinstance(d, str)
            else (int,) if isinstance(d, int) else _NUMBER for name, d in RUN_DEFAULTS.items()},
}  # fmt: skip

_DESCRIPTIONS = {
    "v": "reduced volume, in (0, 1]",
    "lam": "viscosity ratio mu_in / mu_out",
    "chi": "dimensionless shear rate",
    "flow": '"shear", "planar-extension", "rotation", "none" or a traceless 3x3 gradient',
    "grid": "n_theta Gauss-Legendre rings (n_phi = 2 n_theta); >= 2 degree",
    "degree": "shape degree N",
    "n_rot": "rotated-grid theta' nodes (default: grid)",
    "backend": "layer-potential kernels: numba or numpy (the reference)",
    "method": "assembled or matrix-free",
    "workers": "threads over latitude rings (default: <= 2)",
    "multipliers": '"coefficients" (SPEC §8) or "l2" (the time stepping\'s drift-control '
                   "directions): along which the steady equations' A and V multipliers act",
    "preset": '"time-dependent" (1e-3/1e-4) or "steady" (1e-6/1e-7), or give schur, inner',
    "schur": "relative tolerance of the outer (Schur-complement) GMRES, in (0, 1)",
    "inner": "relative tolerance of the inner (A_uu) GMRES, in (0, 1)",
    "max_outer": "outer GMRES iterations at most",
    "max_inner": "inner GMRES iterations at most",
    "restart": "GMRES restart length",
    "t_end": "end time, in units of mu_out a^3 / kappa",
    "save_every": "time between saved steps (same units as t_end)",
    "init": '"spheroid", "tt", a steady-state file or FILE[:INDEX] of a run file',
    "tilt": "tilt of the start out of the shear plane, degrees",
    "perturb": "random perturbation of the start: its largest radius change over the mean radius",
    "seed": "seed of the random perturbation",
    "integrator": "ros2, a Rosenbrock-W method (ros34pw2, ...) or an explicit pair (bs3, heun)",
    "viscous_solve": 'Bq > 0: "factorised" (GMRES preconditioned by a kept factorised system) '
                     'or "nested" (the reference)',
    "rtol": "local error per step relative to the mean radius, in (0, 1)",
    "dt0": "first time step (units of t_end)",
    "dt_min": "smallest time step before the run stops (units of t_end)",
    "dt_max": "largest time step (units of t_end)",
    "drift_control": "restore area and volume when they drift",
    "drift_tol": "relative area/volume drift at which both are restored",
    "recenter_threshold": "centroid drift (units of a) at which the shape is re-centred",
    "steady_tol": "stop once max |dr/dt| falls below this (0: never)",
    "periods": "stop after this many settled psi periods (0: never; else at least 2)",
    "orbits": "stop once the out-of-plane orbit has run this many periods twice over, alike "
              "(0: never; else at least 2)",
    "split_stress": "also store the bending and flow parts of the stress at saved steps",
    "save_fields": "store the tension and membrane velocity on the grid at saved steps",
    "checkpoint_every": "wall-clock seconds between checkpoints",
}


class ConfigError(ValueError):
    """A configuration file that cannot be used, with the file and key in the message."""


def _fail(path: Path, message: str) -> None:
    raise ConfigError(f"{path}: {message}")


def _check_type(path: Path, section: str, key: str, value) -> None:
    expected = SECTIONS[section][key]
    ok = isinstance(value, expected) and not (isinstance(value, bool) and bool not in expected)
    if not ok:
        names = " or ".join(sorted({t.__name__ for t in expected}))
        _fail(path, f"[{section}] {key} must be {names}, got {value!r}")


def read_config(
    path: str | Path, sections: tuple[str, ...] = tuple(SECTIONS), ranges: tuple[str, ...] = ()
) -> dict:
    """The tables of a TOML file, checked (see the module docstring); ``sections`` are the
    tables the caller accepts; the ``[physics]`` keys in ``ranges`` may also be a range or list
    as a string (``lam = "1:9"``, ``chi = "0.2,1,6"``: ``vesicle branch``)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"no configuration file at {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path} is not valid TOML: {err}") from None
    for section, table in data.items():
        if section not in sections:
            hint = difflib.get_close_matches(section, sections, n=1)
            _fail(path, f"unknown table [{section}]" + (f" (did you mean [{hint[0]}]?)" if hint
                  else f"; expected {', '.join(f'[{s}]' for s in sections)}"))  # fmt: skip
        if not isinstance(table, dict):
            _fail(path, f"{section} must be a table [{section}], got {table!r}")
        for key, value in table.items():
            if key not in SECTIONS[section]:
                hint = difflib.get_close_matches(key, SECTIONS[section], n=1)
                _fail(path, f"unknown key {key!r} in [{section}]"
                      + (f" (did you mean {hint[0]!r}?)" if hint else ""))  # fmt: skip
            if section == "physics" and key in ranges and isinstance(value, str):
                _check_range(path, key, value)
                continue
            _check_type(path, section, key, value)
    numbers = {**data, "physics": {k: v for k, v in data.get("physics", {}).items()
                                   if not (k in ranges and isinstance(v, str))}}  # fmt: skip
    _validate(path, numbers)
    return data


def _check_range(path: Path, key: str, text: str) -> None:
    """A range or list value: numbers separated by ':' (START:STOP[:STEP]) or ','."""
    try:
        values = [float(x) for x in text.replace(":", ",").split(",")]
    except ValueError:
        values = []
    if not values or not all(np.isfinite(values)):
        _fail(path, f"[physics] {key} must be a number or a range/list such as \"1:9\" or "
              f"\"1,2,4\", got {text!r}")  # fmt: skip


def _validate(path: Path, data: dict) -> None:
    """Build the objects once, so that bad values are refused here, naming the file."""
    try:
        Physics(**data.get("physics", {}))
        Discretisation(**data.get("discretisation", {}))
        solver_from(data.get("solver", {}))
        if "run" in data:
            RunParameters(**data["run"])
    except (ValueError, TypeError) as err:
        raise ConfigError(f"{path}: {err}") from None


def solver_from(table: dict) -> SolverTolerances | None:
    """The solver tolerances of a ``[solver]`` table (``None`` if empty)."""
    if not table:
        return None
    table = dict(table)
    base = SolverTolerances.parse(table.pop("preset", "time-dependent"))
    return base.replace(**table)


def merge(config: dict, section: str, key: str, value, given: bool):
    """The command line's ``value`` if it was ``given``, else the file's (else ``value``)."""
    if given:
        return value
    return config.get(section, {}).get(key, value)


def toml_value(value) -> str:
    """One TOML value: booleans, strings (JSON escapes are TOML's), numbers, lists and inline
    tables of those."""
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, int | float | np.number):
        return repr(float(value)) if isinstance(value, float | np.floating) else str(int(value))
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML value for {type(value).__name__} {value!r}")


def toml_text(tables: dict[str, dict], header: tuple[str, ...] = (),
              notes: dict[str, str] | None = None) -> str:  # fmt: skip
    """A TOML document of ``{table: {key: value}}``, with ``header`` comment lines first and a
    comment after each key that ``notes`` describes; ``tomllib`` reads it back to equal values
    (the one TOML writer of the package: run configs, study and report sweep configs)."""
    lines = [f"# {line}" for line in header]
    if lines:
        lines.append("")
    for section, table in tables.items():
        lines.append(f"[{section}]")
        for key, value in table.items():
            note = (notes or {}).get(key)
            lines.append(f"{key} = {toml_value(value)}" + (f"  # {note}" if note else ""))
        lines.append("")
    return "\n".join(lines)


def to_toml(params: RunParameters, title: str = "vesicle run configuration") -> str:
    """A commented TOML file of ``params`` that :func:`read_config` reads back to equal
    parameters (``vesicle run --config``)."""
    p, d, s = params.physics, params.discretisation, params.solver
    flow = p.flow.name if p.flow.name in ("shear", "planar-extension", "rotation", "none") else (
        [list(r) for r in p.flow.gradient])  # fmt: skip
    tables = {
        "physics": {"v": p.v, "lam": p.lam, "chi": p.chi, "flow": flow},
        "discretisation": {
            k: x for k, x in d.to_dict().items() if x is not None  # the default multipliers
        },  # are left out (Discretisation.to_dict)
        "solver": {
            k: getattr(s, k) for k in ("schur", "inner", "max_outer", "max_inner", "restart")
        },
        "run": {k: getattr(params, k) for k in RUN_DEFAULTS},
    }
    return toml_text(tables, (title, "Every key is optional; the command line overrides the file."),
                     _DESCRIPTIONS)
