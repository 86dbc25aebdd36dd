"""Parameter sweeps on Dask with a crash-proof results store (issue 13, part 3).

A sweep is a task (:data:`TASKS`) evaluated at every point of a parameter grid.  Its config is a
TOML file::

    [sweep]
    task = "tt"            # tt | stability | critical | branch | neutral | run
    out = "s.h5"           # the results store (relative to the config file's folder)
    points = "product"     # the Cartesian product of [grid] (default), or "list": the i-th
                           #   values of every [grid] list together
    [grid]                 # lists (or single values) of v, lam, chi
    v = [0.95]
    lam = [1.0, 2.0, 4.0, 8.0]
    chi = [1.0]
    [physics]              # fixed physics (flow, or a v/lam/chi not swept)
    [discretisation]       # as for every command
    degree = 8
    grid = 32
    [solver]               # velocity-solve tolerances of "run" points
    [run]                  # the run settings of "run" points (t_end, save_every, ...)
    [task]                 # task options: modes ("symmetric" | "general") for stability,
                           #   jacobian, max_iterations, xtol, coarse (true: locate at
                           #   N = 4 first, the default) for critical; for branch:
                           #   parameter ("lam" | "chi" | "v", not in [grid]) and values
                           #   ("1:9", "1:9:0.5" or a list), past_fold, xtol; for neutral:
                           #   chi ("0.1:10" with points, or a list), continuation
                           #   ("codim2", the default, as `vesicle neutral`, with form and
                           #   cusps; or
                           #   "trace": the tracer, with xtol, type_tol and checkpoints),
                           #   locate_type_change; orientation ("flow" | "vorticity": the
                           #   TT branch) for tt, stability (general modes by default on the
                           #   vorticity branch), critical and neutral

A ``branch`` point is a whole branch at the fixed values of its grid point (e.g. one per v and
chi, continued in lam), a ``neutral`` point a whole neutral curve at its v: sweeps of these run
whole branches or curves side by side on the workers.  A neutral curve by two-parameter
continuation (``continuation = "codim2"``, the default, as ``vesicle neutral``) is stored when
complete; one by the tracer (``"trace"``) keeps its points and their states as they are found
in ``STORE_curves/`` (:class:`vesicle.bifurcation.checkpoint.Checkpoint`), and one cut short
goes on from them when it is tried again.  (A neutral sweep begun before ``continuation``
existed traced its curves: add ``continuation = "trace"`` to its ``[task]`` to finish it the
same way.)

Every point is keyed by its parameters (:attr:`vesicle.Physics.key`).  Results come back to the
process that runs the sweep and are written, one completed point at a time, to the store by an
atomic rewrite (:func:`vesicle.io.files.write_atomically`): a crash, Ctrl-C, SIGKILL or a full disk
loses at most the points in flight, and a rerun skips every point already done (failed ones are
tried again).  A point that raises is recorded with its error and does not stop the others; a
worker that dies mid-point has its point rescheduled by Dask (up to its ``allowed-failures``,
then the point is recorded as failed).  The store holds the config it was made with; a rerun with
a different task, discretisation or fixed parameters is refused (start a new store).
"""

from __future__ import annotations

import difflib
import itertools
import json
import logging
import os
import time
import tomllib
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import h5py
import numpy as np

from vesicle.bifurcation.branch import PARAMETERS, branch, reach
from vesicle.bifurcation.checkpoint import Checkpoint
from vesicle.bifurcation.critical import critical_lambda, critical_summary
from vesicle.bifurcation.neutral import neutral_curve
from vesicle.bifurcation.neutral_codim2 import neutral_curve_codim2
from vesicle.bifurcation.steady_codim2 import FORMS
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import load_parameters, simulate
from vesicle.geometry.diagnostics import diagnose, summarize
from vesicle.io.files import open_file, plain, read_run, stamp, stamped, write_atomically
from vesicle.model.parameters import Discretisation, Physics, stable_key
from vesicle.parallel import close_cluster, local_cluster
from vesicle.ranges import parse_range
from vesicle.solve.ellipsoid import equivalent_ellipsoid, flow_stress, stress_map
from vesicle.steady.files import steady_summary
from vesicle.steady.newton import ORIENTATIONS
from vesicle.steady.stability import default_modes, stability
from vesicle.workflows.config import SECTIONS, ConfigError, solver_from

__all__ = [
    "TASKS",
    "SweepConfig",
    "SweepStore",
    "is_sweep_store",
    "load",
    "read_sweep_config",
    "run_sweep",
    "run_sweeps",
    "runs_from_store",
    "task_key",
]

log = logging.getLogger(__name__)

FORMAT = "vesicle-sweep"
FORMAT_VERSION = 1

#: Parameters a grid may sweep.
GRID_KEYS = ("v", "lam", "chi")


# ------------------------------------------------------------------------ tasks
def _tt(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    return steady_summary(reach(physics, disc, **_newton(options)))


def _newton(options: dict) -> dict:
    """The Newton options of a steady-state task (the branch: ``orientation``)."""
    return {k: options[k] for k in ("jacobian", "max_iterations", "orientation") if k in options}


def _default_modes(options: dict) -> str:
    """The vorticity-aligned branch loses stability to modes breaking the x-z symmetry."""
    return default_modes(options.get("orientation", "flow"))


def _stability(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    r = reach(physics, disc, **_newton(options))
    return steady_summary(r, stability(r, modes=options.get("modes", _default_modes(options))))


def _critical(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    keys = ("jacobian", "max_iterations", "xtol", "lam0", "orientation")
    coarse = "auto" if options.get("coarse", True) else None
    c = critical_lambda(physics, disc, modes=options.get("modes", _default_modes(options)),
                        coarse=coarse, **{k: options[k] for k in keys if k in options})  # fmt: skip
    return critical_summary(c, physics, disc)


def _branch_values(options: dict) -> list[float]:
    return parse_range(options["values"], "step", name="[task] values")


def _branch(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    name = options["parameter"]
    values = _branch_values(options)
    start = physics.replace(**{name: values[0]})
    keys = ("jacobian", "xtol", "past_fold")
    b = branch(start, disc, name, values, **{k: options[k] for k in keys if k in options})
    fixed = {k: x for k, x in physics.to_dict().items() if k != name}
    result = b.to_dict()
    if options.get("ellipsoid"):  # S^V of each point's equivalent ellipsoid (SPEC §11)
        for p in result["points"]:
            shape = equivalent_ellipsoid(p["axes"], p["axis_directions"], disc.grid)
            p["ellipsoid"] = flow_stress(shape, [p["lam"]])[0].summary()
    return stamped({"physics": fixed, "discretisation": disc.to_dict(),
            **{k: physics.to_dict()[k] for k in GRID_KEYS if k != name}, **result})  # fmt: skip


#: settings that name folders of the points' files (not part of what a store's points share)
FOLDERS = ("runs_dir", "curves_dir")

def _neutral_chi(options: dict) -> list[float]:
    return parse_range(options.get("chi", "0.1:10"), "log", points=options.get("points"),
                       name="[task] chi", positive=True)


def _neutral(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    if options.get("continuation", "codim2") == "codim2":
        keys = ("jacobian", "locate_type_change", "orientation", "modes", "form", "cusps")
        c = neutral_curve_codim2(physics, _neutral_chi(options), disc,
                                 **{k: options[k] for k in keys if k in options})  # fmt: skip
        return c.to_dict()  # written when complete (no checkpoint: see the module notes)
    keys = ("jacobian", "xtol", "type_tol", "locate_type_change", "orientation", "modes")
    kwargs = {k: options[k] for k in keys if k in options}
    known, keep = [], None
    if settings.get("curves_dir"):  # the curve's points and states as they are found: a curve
        # cut short by a crash, Ctrl-C or a lost worker goes on from them when tried again
        keep = Checkpoint(Path(settings["curves_dir"]) / f"{physics.key}.json", physics, disc,
                          orientation=kwargs.get("orientation", "flow"),
                          modes=kwargs.get("modes"), xtol=kwargs.get("xtol", 1e-3),
                          jacobian=kwargs.get("jacobian", "linearised"))  # fmt: skip
        keep.out.parent.mkdir(parents=True, exist_ok=True)
        try:
            known = keep.resume()
        except ValueError as err:
            log.warning("neutral curve %s: its checkpoint is not usable (%s): traced again",
                        physics.key, err)  # fmt: skip
        if known:
            log.info("neutral curve %s: %d points from its checkpoint", physics.key, len(known))
    c = neutral_curve(physics, _neutral_chi(options), disc, known=known, checkpoint=keep,
                      **kwargs)  # fmt: skip
    return c.to_dict()  # a curve that stopped has "failed" entries: see run_point


def _values(spec, points: int, name: str) -> list[float]:
    """``ellipsoid_map``'s ``psi``/``lams``: a list, or ``LOW:HIGH`` with ``points`` values."""
    if isinstance(spec, list):
        return parse_range(spec, "linear", name=name)
    return parse_range(spec, "linear", points=points, name=name)


def _ellipsoid_map(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    """S^V of the TT state's equivalent ellipsoid turned over ``psi`` for every ``lams``."""
    state = reach(physics, disc, **{k: options[k] for k in ("jacobian",) if k in options})
    d = diagnose(state.shape)
    psis = _values(options.get("psi", "-0.6:0.8"), int(options.get("points", 15)), "[task] psi")
    lams = _values(options.get("lams", "1:12"), int(options.get("points", 15)), "[task] lams")
    m = stress_map(d.lengths, d.axes, state.psi, psis, lams, disc.grid)
    return stamped({"physics": physics.to_dict(),
            "discretisation": disc.to_dict(), "v": physics.v, "lam": physics.lam,
            "chi": physics.chi, "state": {"psi": state.psi, "axes": d.lengths.tolist(),
                                          "axis_directions": d.axes.tolist()},
            "map_psi": m["psi"].tolist(), "map_lam": m["lam"].tolist(),
            **{k: np.asarray(m[k]).tolist() for k in ("S_xz", "N1", "N2")}})  # fmt: skip


def _run(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    params = RunParameters(physics, disc, settings.get("solver"), **settings.get("run", {}))
    path, resume = None, None
    if settings.get("runs_dir"):  # each point's run file, checkpointed: a point cut short by a
        # crash, Ctrl-C or a lost worker resumes from its last checkpoint when tried again
        path = Path(settings["runs_dir"]) / f"{physics.key}.h5"
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists():
            try:
                previous = read_run(path)
            except (OSError, ValueError, KeyError) as err:
                log.warning("run file %s unreadable (%s): the point starts again", path, err)
                path.unlink()
            else:
                # the stop criteria only decide when to stop: a run to an earlier stop is the
                # beginning of the same trajectory, and continues exactly from its checkpoint
                stops = {k: getattr(params, k) for k in ("t_end", "periods", "steady_tol")}
                same = load_parameters(previous).replace(**stops) == params
                if previous.checkpoint is not None and same:
                    resume = previous
                    log.info("point %s resumes its run from t = %.4g", physics.key,
                             float(previous.checkpoint["t"]))  # fmt: skip
                else:
                    path.unlink()
    run = simulate(params, out=path, resume=resume)
    return stamped({"physics": physics.to_dict(),
            "discretisation": disc.to_dict(), "v": physics.v, "lam": physics.lam,
            "chi": physics.chi, **summarize(run)})  # fmt: skip


@dataclass(frozen=True)
class Task:
    """A sweep task: the function of one point and what it sweeps and accepts."""

    function: Callable[[Physics, Discretisation, dict, dict], dict]
    swept: tuple[str, ...]  # the [grid] keys it takes
    options: tuple[str, ...]  # the [task] keys it takes
    #: why a result falls short of what the point asked for (None: it reached all of it); such
    #: a point is recorded as failed, with what it found, and a rerun tries it again
    incomplete: Callable[[dict], str | None] = lambda result: None


def _branch_incomplete(result: dict) -> str | None:
    """A branch that stopped before its last value (a fold, a failed step) is not done."""
    if not result.get("stopped"):
        return None
    return f"the branch stopped before its last value: {result['stopped']}"


def _neutral_incomplete(result: dict) -> str | None:
    """A neutral curve with points it could not trace is not done."""
    if not result.get("failed"):
        return None
    where = [f"before chi = {f['chi']:.4g}: {f['error']}" for f in result["failed"]]
    return "the curve stopped: " + "; ".join(where)


#: The tasks, by name; each point's result has the keys of the command's own --json output.
TASKS = {
    "tt": Task(_tt, GRID_KEYS, ("jacobian", "max_iterations", "orientation")),
    "stability": Task(
        _stability, GRID_KEYS, ("jacobian", "max_iterations", "modes", "orientation")
    ),
    "critical": Task(
        _critical, ("v", "chi"),
        ("jacobian", "max_iterations", "xtol", "lam0", "orientation", "coarse"),
    ),
    "branch": Task(
        _branch, GRID_KEYS, ("parameter", "values", "jacobian", "xtol", "past_fold", "ellipsoid"),
        _branch_incomplete,
    ),
    "neutral": Task(
        _neutral,
        ("v",),
        ("chi", "points", "jacobian", "xtol", "type_tol", "locate_type_change", "orientation",
         "modes", "continuation", "form", "cusps"),
        _neutral_incomplete,
    ),
    "ellipsoid_map": Task(_ellipsoid_map, GRID_KEYS, ("psi", "lams", "points", "jacobian")),
    "run": Task(_run, GRID_KEYS, ()),
}

_TASK_TYPES = {"jacobian": (str,), "max_iterations": (int,), "modes": (str,),
               "xtol": (int, float), "lam0": (int, float), "parameter": (str,),
               "values": (str, list), "past_fold": (int,), "chi": (str, list),
               "points": (int,), "type_tol": (int, float),
               "locate_type_change": (bool,), "ellipsoid": (bool,), "psi": (str, list),
               "lams": (str, list), "orientation": (str,), "coarse": (bool,),
               "continuation": (str,), "form": (str,), "cusps": (bool,)}  # fmt: skip
_SWEEP_KEYS = {"task": (str,), "out": (str,), "points": (str,)}


# ----------------------------------------------------------------------- config
@dataclass(frozen=True)
class SweepConfig:
    """A checked sweep configuration (see the module docstring)."""

    path: Path
    task: str
    out: Path
    points: tuple[Physics, ...]
    discretisation: Discretisation
    options: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)  # "solver" (object), "run" (table)
    text: str = ""  # the file as given: stored with the results

    def plain_settings(self, runs_dir: bool = True) -> dict:
        """The settings as plain data (the solver object as its dict); ``runs_dir=False``
        leaves out the folders of the points' files (runs, neutral-curve checkpoints)."""
        return {k: (v.to_dict() if hasattr(v, "to_dict") else v)
                for k, v in self.settings.items() if runs_dir or k not in FOLDERS}  # fmt: skip

    def fingerprint(self) -> str:
        """What every point of one store must share (task, discretisation, options, settings,
        fixed physics)."""
        settings = self.plain_settings(runs_dir=False)
        fixed = self.points[0].to_dict() if self.points else {}
        for key in TASKS[self.task].swept:
            fixed.pop(key, None)
        return json.dumps({"task": self.task, "discretisation": self.discretisation.to_dict(),
                           "options": self.options, "settings": settings, "fixed": fixed},
                          sort_keys=True, default=str)  # fmt: skip


def _fail(path: Path, message: str):
    raise ConfigError(f"{path}: {message}")


def _check_keys(path: Path, section: str, table: dict, allowed: dict) -> None:
    if not isinstance(table, dict):
        _fail(path, f"[{section}] must be a table, got {table!r}")
    for key, value in table.items():
        if key not in allowed:
            hint = difflib.get_close_matches(key, list(allowed), n=1)
            _fail(path, f"unknown key {key!r} in [{section}]"
                  + (f" (did you mean {hint[0]!r}?)" if hint else
                     f"; expected one of {', '.join(sorted(allowed))}"))  # fmt: skip
        expected = allowed[key]
        if not isinstance(value, expected) or (isinstance(value, bool) and bool not in expected):
            names = " or ".join(sorted({t.__name__ for t in expected}))
            _fail(path, f"[{section}] {key} must be {names}, got {value!r}")


def _grid_values(path: Path, key: str, value) -> list[float]:
    values = value if isinstance(value, list) else [value]
    if not values:
        _fail(path, f"[grid] {key} is an empty list")
    for x in values:
        if isinstance(x, bool) or not isinstance(x, int | float):
            _fail(path, f"[grid] {key} must hold numbers, got {x!r}")
    return [float(x) for x in values]


def read_sweep_config(path: str | os.PathLike) -> SweepConfig:
    """Read and check a sweep config; every point's parameters are validated here, before any
    work, and errors name the file and the key."""
    path = Path(path)
    try:
        text = path.read_text()
        data = tomllib.loads(text)
    except FileNotFoundError:
        raise ConfigError(f"no sweep configuration at {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path} is not valid TOML: {err}") from None
    # [study]: a study's description and figure (vesicle.workflows.study); the engine only keeps it
    tables = ("sweep", "grid", "physics", "discretisation", "solver", "run", "task", "study")
    for section in data:
        if section not in tables:
            hint = difflib.get_close_matches(section, tables, n=1)
            _fail(path, f"unknown table [{section}]" + (f" (did you mean [{hint[0]}]?)" if hint
                  else ""))  # fmt: skip
    if not isinstance(data.get("study", {}), dict):
        _fail(path, "[study] must be a table")
    sweep = data.get("sweep")
    if not isinstance(sweep, dict) or "task" not in sweep or "out" not in sweep:
        _fail(path, "needs a [sweep] table with task and out")
    _check_keys(path, "sweep", sweep, _SWEEP_KEYS)
    task = sweep["task"]
    if task not in TASKS:
        _fail(path, f"[sweep] task must be one of {', '.join(TASKS)}, got {task!r}")
    spec = TASKS[task]
    grid = data.get("grid", {})
    _check_keys(path, "grid", grid, {k: (list, int, float) for k in spec.swept})
    if not grid:
        _fail(path, f"[grid] must give at least one of {', '.join(spec.swept)}")
    for section in ("physics", "discretisation", "solver", "run"):
        _check_keys(path, section, data.get(section, {}), SECTIONS[section])
    if task != "run" and ("run" in data or "solver" in data):
        _fail(path, f'[run] and [solver] are for task = "run", not {task!r}')
    options = data.get("task", {})
    _check_keys(path, "task", options, {k: _TASK_TYPES[k] for k in spec.options})
    fixed = data.get("physics", {})
    both = sorted(set(fixed) & set(grid))
    if both:
        _fail(path, f"{', '.join(both)} given in both [grid] and [physics]")
    values = {k: _grid_values(path, k, v) for k, v in grid.items()}
    mode = sweep.get("points", "product")
    if mode == "product":
        combos = [dict(zip(values, c, strict=True)) for c in itertools.product(*values.values())]
    elif mode == "list":
        lengths = {len(v) for v in values.values()}
        if len(lengths) != 1:
            _fail(path, f'[sweep] points = "list" needs [grid] lists of one length, got '
                  f"{ {k: len(v) for k, v in values.items()} }")  # fmt: skip
        combos = [dict(zip(values, c, strict=True)) for c in zip(*values.values(), strict=True)]
    else:
        _fail(path, f'[sweep] points must be "product" or "list", got {mode!r}')
    try:
        points = tuple(Physics(**{**fixed, **c}) for c in combos)
        disc = Discretisation(**data.get("discretisation", {}))
        settings = {}
        out_path = Path(sweep["out"])
        out_path = out_path if out_path.is_absolute() else path.parent / out_path
        if task == "run":
            settings = {"solver": solver_from(data.get("solver", {})), "run": data.get("run", {})}
            RunParameters(points[0], disc, settings["solver"], **settings["run"])
            # the run files of the points, beside the store (vesicle plot / analyze read them)
            settings["runs_dir"] = str(out_path.parent / f"{out_path.stem}_runs")
        if task == "neutral":  # each curve's checkpoint (points and states), beside the store
            settings["curves_dir"] = str(out_path.parent / f"{out_path.stem}_curves")
        if "orientation" in options and options["orientation"] not in ORIENTATIONS:
            raise ValueError(f"[task] orientation must be one of {', '.join(ORIENTATIONS)}, "
                             f"got {options['orientation']!r}")  # fmt: skip
        if "modes" in options and options["modes"] not in ("symmetric", "general"):
            raise ValueError(f"[task] modes must be 'symmetric' or 'general', got "
                             f"{options['modes']!r}")  # fmt: skip
        _check_task_numbers(options)
        _check_task(task, options, grid, points)
    except (ValueError, TypeError) as err:
        raise ConfigError(f"{path}: {err}") from None
    if len({p.key for p in points}) != len(points):
        _fail(path, "[grid] repeats a point")
    out = Path(sweep["out"])
    if not out.is_absolute():
        out = path.parent / out
    return SweepConfig(path, task, out, points, disc, options, settings, text)


def _check_task_numbers(options: dict) -> None:
    """The [task] numbers, as the commands' options take them (raises ValueError naming the
    key): tolerances and ``lam0`` positive and finite, ``max_iterations`` at least 1,
    ``past_fold`` not negative, ``points`` (of a range) at least 2."""
    for key in ("xtol", "type_tol", "lam0"):
        if key in options and not (np.isfinite(options[key]) and options[key] > 0):
            raise ValueError(f"[task] {key} must be a positive number, got {options[key]!r}")
    for key, least in (("max_iterations", 1), ("past_fold", 0), ("points", 2)):
        if key in options and options[key] < least:
            raise ValueError(f"[task] {key} must be at least {least}, got {options[key]!r}")


def _check_task(task: str, options: dict, grid: dict, points) -> None:
    """The branch and neutral tasks' own options (raises ValueError naming the key)."""
    if task == "branch":
        name = options.get("parameter")
        if name not in PARAMETERS:
            raise ValueError(f"[task] parameter must be one of {', '.join(PARAMETERS)} for "
                             f"task = 'branch', got {name!r}")  # fmt: skip
        if name in grid:
            raise ValueError(f"[task] parameter {name!r} is continued along each branch: it "
                             f"cannot also be in [grid]")  # fmt: skip
        if "values" not in options:
            raise ValueError("[task] values (e.g. \"1:9\" or [1, 2, 4]) are needed for "
                             "task = 'branch'")  # fmt: skip
        values = _branch_values(options)
        for p in points:
            for x in values:
                p.replace(**{name: x})
    if task == "ellipsoid_map":
        for key in ("psi", "lams"):
            if key in options:
                values = _values(options[key], options.get("points", 15), f"[task] {key}")
                if key == "lams" and any(not (x > 0) for x in values):
                    raise ValueError(f"[task] lams must be positive, got {options[key]!r}")
    if task == "neutral":
        if "points" in options and not (isinstance(options.get("chi"), str) and
                                        options["points"] >= 2):  # fmt: skip
            raise ValueError("[task] points goes with a chi range \"LOW:HIGH\" and must be "
                             "at least 2")  # fmt: skip
        _neutral_chi(options)
        how = options.get("continuation", "codim2")
        if how not in ("codim2", "trace"):
            raise ValueError(f"[task] continuation must be 'codim2' or 'trace', got {how!r}")
        if how == "codim2":
            for key in ("xtol", "type_tol"):
                if key in options:
                    raise ValueError(f"[task] {key} applies to continuation = 'trace' only "
                                     "(the two-parameter continuation solves each point to "
                                     "its own tolerance)")  # fmt: skip
            if options.get("form", "spec") not in FORMS:
                raise ValueError(f"[task] form must be one of {FORMS}, got {options['form']!r}")
        else:
            for key in ("form", "cusps"):
                if key in options:
                    raise ValueError(f"[task] {key} applies to continuation = 'codim2' only")
    if "jacobian" in options and options["jacobian"] not in ("linearised", "differences"):
        raise ValueError(f"[task] jacobian must be 'linearised' or 'differences', got "
                         f"{options['jacobian']!r}")  # fmt: skip


# ------------------------------------------------------------------------ store
@dataclass
class SweepStore:
    """The results of a sweep: one record per point key (status, parameters, result, error)."""

    path: Path
    fingerprint: str
    config_text: str
    task: str
    records: dict[str, dict] = field(default_factory=dict)
    attributes: dict = field(default_factory=dict)

    @classmethod
    def open(cls, config: SweepConfig) -> SweepStore:
        """The store of ``config``: read if it exists (and was made by the same config),
        else empty."""
        fingerprint = config.fingerprint()
        if not config.out.exists():
            return cls(config.out, fingerprint, config.text, config.task)
        store = cls.read(config.out)
        if store.fingerprint != fingerprint:
            raise ConfigError(
                f"{config.out} holds a sweep made with another task, discretisation, fixed "
                f"parameters or options than {config.path}; give a new [sweep] out (vesicle "
                f"study: another --out)"
            )
        store.config_text = config.text
        return store

    @classmethod
    def read(cls, path: str | os.PathLike) -> SweepStore:
        path = Path(path)
        with open_file(path, FORMAT, "sweep store") as f:
            records = {}
            for key, group in f["points"].items():
                records[key] = {k: json.loads(v) for k, v in group.attrs.items()}
            store = cls(path, str(f.attrs["fingerprint"]), str(f.attrs["config"]),
                        str(f.attrs["task"]), records,
                        {k: str(v) for k, v in f.attrs.items()})  # fmt: skip
        if store.attributes.get("checksum") != store._checksum():
            raise ValueError(f"{path} is corrupted: its records do not match their checksum")
        return store

    def _checksum(self) -> str:
        import hashlib

        return hashlib.sha256(json.dumps(self.records, sort_keys=True).encode()).hexdigest()

    def record(self, key: str, entry: dict) -> None:
        """Add one point's record and rewrite the store atomically."""
        self.records[key] = entry
        self.write()

    def write(self) -> Path:
        def fill(f: h5py.File) -> None:
            kept = {k: self.attributes[k] for k in ("created",) if k in self.attributes}
            self.attributes["created"] = stamp(f, FORMAT, FORMAT_VERSION, kept, self._checksum())
            f.attrs["fingerprint"] = self.fingerprint
            f.attrs["config"] = self.config_text
            f.attrs["task"] = self.task
            points = f.create_group("points")
            for key, entry in self.records.items():
                group = points.create_group(key)
                for name, value in entry.items():
                    group.attrs[name] = json.dumps(value)

        size = sum(len(json.dumps(e)) for e in self.records.values())
        return write_atomically(self.path, fill, size)

    def status(self, config: SweepConfig | None = None) -> dict:
        """``{"done", "failed"}`` of the records, and ``"pending"`` (points of ``config``
        without a record) when the config is given (then only its points are counted)."""
        if config is None:
            states = [r["status"] for r in self.records.values()]
            return {"done": states.count("done"), "failed": states.count("failed")}
        states = [self.records.get(p.key, {}).get("status") for p in config.points]
        return {"done": states.count("done"), "failed": states.count("failed"),
                "pending": states.count(None)}  # fmt: skip

    def rows(self) -> list[dict]:
        """One row per point: its parameters, status, error, seconds and result keys."""
        rows = []
        for key, r in self.records.items():
            row = {"key": key, **{k: r["physics"][k] for k in GRID_KEYS if k in r["physics"]},
                   "status": r["status"], "seconds": r.get("seconds"),
                   "error": r.get("error")}  # fmt: skip
            row.update({k: v for k, v in (r.get("result") or {}).items() if k not in row})
            rows.append(row)
        return sorted(rows, key=lambda row: tuple(row.get(k, 0.0) for k in GRID_KEYS))


def is_sweep_store(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a sweep store (an HDF5 file of this format)."""
    try:
        with h5py.File(path, "r") as f:
            return str(f.attrs.get("format", "")) == FORMAT
    except (OSError, ValueError):
        return False


def load(path: str | os.PathLike):
    """A sweep store as a :class:`pandas.DataFrame`: one row per point, its parameters, status
    and the scalar results (lists and tables of a point stay in :meth:`SweepStore.rows`)."""
    import pandas as pd  # costs ~0.3 s at start-up: only here

    rows = SweepStore.read(path).rows()
    scalar = [{k: v for k, v in r.items() if not isinstance(v, list | dict)} for r in rows]
    return pd.DataFrame(scalar)


# ------------------------------------------------------------------------- run
def run_point(task: str, physics: dict, disc: dict, options: dict, settings: dict) -> dict:
    """One point, in a worker: the task's result, or its error (never raises)."""
    start = time.perf_counter()
    try:
        result = TASKS[task].function(
            Physics.from_dict(physics), Discretisation.from_dict(disc), options, settings
        )
        entry = {"status": "done", "result": plain(result, nonfinite_as_none=True)}
        short = TASKS[task].incomplete(result)
        if short is not None:  # what it found is kept; the point counts as failed (a rerun
            # tries it again)
            entry.update(status="failed", error=short)
    except Exception as err:
        entry = {"status": "failed", "error": f"{type(err).__name__}: {err}",
                 "traceback": traceback.format_exc(limit=6)}  # fmt: skip
    entry.update(
        physics=physics,
        seconds=time.perf_counter() - start,
        pid=os.getpid(),
        finished=datetime.now(UTC).isoformat(timespec="seconds"),
    )
    return entry


def _client(workers: int | None, scheduler: str | None) -> tuple:
    """A Dask client: a LocalCluster of ``workers`` one-thread processes (default: the cores),
    or the scheduler at ``scheduler``."""
    from distributed import Client  # ~1 s to import: only here

    if scheduler is not None:
        return Client(scheduler), None
    n = workers or max(1, os.cpu_count() or 1)
    cluster = local_cluster(n)
    return Client(cluster), cluster


def task_key(config: SweepConfig, point: Physics) -> str:
    """The Dask key of ``point`` of ``config``: a hash of everything that defines its work
    (task, parameters, resolution, options, settings; a run's file folder among them), the
    same for the same work in any sweep, different when anything differs."""
    work = {"task": config.task, "point": point.to_dict(),
            "discretisation": config.discretisation.to_dict(), "options": config.options,
            "settings": config.plain_settings()}  # fmt: skip
    return "vesicle-point-" + stable_key(json.loads(json.dumps(work, default=str)), 20)


def run_sweep(
    config: SweepConfig,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[dict], None] | None = None,
    priority: int = 0,
) -> SweepStore:
    """Evaluate every point of ``config`` not yet done, on Dask, recording each as it completes.

    ``progress`` is called after every completed point with ``{"key", "status", "done",
    "total", "seconds"}``.  ``priority``: Dask's task priority (higher first), for sweeps that
    share one scheduler.  Returns the store; raises only for the sweep itself (a bad config,
    an unwritable store), never for a point.

    A point's Dask key is :func:`task_key`: sweeps sharing a scheduler compute an identical
    point once and never mix up two that differ only in their options.
    """
    return run_sweeps([config], workers, scheduler, progress, priority)[0]


def run_sweeps(
    configs: list[SweepConfig],
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[dict], None] | None = None,
    priority: int = 0,
) -> list[SweepStore]:
    """:func:`run_sweep` for several sweeps at once: their points side by side on one client
    (one cluster), each recorded in its own store as it completes.  Returns the stores."""
    from distributed import as_completed

    stores = [SweepStore.open(config) for config in configs]
    todo = []  # (config index, point)
    for i, (config, store) in enumerate(zip(configs, stores, strict=True)):
        points = [p for p in config.points
                  if store.records.get(p.key, {}).get("status") != "done"]  # fmt: skip
        log.info("sweep %s: %d points, %d to do", config.path, len(config.points), len(points))
        todo += [(i, p) for p in points]
    if not todo:
        return stores
    for i in sorted({i for i, _ in todo}):
        stores[i].write()  # the store exists (and is writable) before any work
    client, cluster = _client(workers, scheduler)
    futures = {}
    try:
        for i, p in todo:
            config = configs[i]
            future = client.submit(run_point, config.task, p.to_dict(),
                                   config.discretisation.to_dict(), config.options,
                                   config.settings, key=task_key(config, p),
                                   priority=priority, pure=False)  # fmt: skip
            futures[future] = (i, p)
        for future in as_completed(futures):
            i, p = futures[future]
            try:
                entry = future.result()
            except Exception as err:
                entry = {"status": "failed", "error": f"{type(err).__name__}: {err}",
                         "physics": p.to_dict()}  # fmt: skip
            stores[i].record(p.key, entry)
            if progress is not None:
                progress({"key": p.key, "status": entry["status"],
                          **stores[i].status(configs[i]), "total": len(configs[i].points),
                          "seconds": entry.get("seconds"), "sweep": str(configs[i].path)})
    finally:
        # cancel only what is still pending (Ctrl-C, an error): cancelling finished futures
        # sends the scheduler messages that it answers after the client has closed
        for future in futures:
            if not future.done():
                future.cancel()
        client.close()
        if cluster is not None:
            close_cluster(cluster)
    return stores


def runs_from_store(path: str | Path) -> list[dict]:
    """The finished points of a ``task = "run"`` sweep store as ``{"v", "chi", "lam",
    "regime", "period"}`` (points whose analysis found no regime are kept as "undetermined")."""
    store = SweepStore.read(path)
    if store.task != "run":
        raise ValueError(f"{path} is a {store.task!r} sweep; --runs takes a sweep of runs")
    return [{"v": r["v"], "chi": r["chi"], "lam": r["lam"],
             "regime": r.get("regime") or "undetermined", "period": r.get("period")}
            for r in store.rows() if r["status"] == "done"]  # fmt: skip
