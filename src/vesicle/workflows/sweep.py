"""Parameter sweeps on Dask with a crash-proof results store (issue 13, part 3).

A sweep is a task (:data:`vesicle.workflows.tasks.TASKS`) evaluated at every point of a
parameter grid.  Its config is a TOML file::

    [sweep]
    task = "tt"            # tt | stability | critical | branch | neutral | neutral_bq |
                           #   ellipsoid_map | run
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
    [task]                 # task options: the commands' options, by the same names
                           #   (vesicle.workflows.tasks.OPTIONS; which task takes which:
                           #   TASKS), e.g. modes, orientation, jacobian, xtol; for branch:
                           #   parameter ("lam" | "chi" | "v", not in [grid]) and values;
                           #   for neutral: chi ("0.1:10" with points, or a list) and
                           #   continuation ("codim2", the default, or "trace"); for
                           #   neutral_bq (grid v, chi): values (the Boussinesq numbers,
                           #   "0:10" or a list) and lam_at (lambdas of the critical Bq)

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

from vesicle.dynamics.integrators import RunParameters
from vesicle.io.files import open_file, plain, stamp, write_atomically
from vesicle.model.parameters import Discretisation, Physics, stable_key
from vesicle.parallel import close_cluster, forward_worker_logs, local_cluster
from vesicle.workflows.config import SECTIONS, ConfigError, solver_from
from vesicle.workflows.tasks import FOLDERS, GRID_KEYS, OPTIONS, TASKS, check_options

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
    _check_keys(path, "task", options, {k: OPTIONS[k].types for k in spec.options})
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
        if task in ("neutral", "neutral_bq"):  # each curve's checkpoint, beside the store
            settings["curves_dir"] = str(out_path.parent / f"{out_path.stem}_curves")
        check_options(task, options, grid, points)
    except (ValueError, TypeError) as err:
        raise ConfigError(f"{path}: {err}") from None
    if len({p.key for p in points}) != len(points):
        _fail(path, "[grid] repeats a point")
    out = Path(sweep["out"])
    if not out.is_absolute():
        out = path.parent / out
    return SweepConfig(path, task, out, points, disc, options, settings, text)


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
        client, cluster = Client(scheduler), None
    else:
        cluster = local_cluster(workers or max(1, os.cpu_count() or 1))
        client = Client(cluster)
    forward_worker_logs(client)  # with --verbose: each curve's and run's progress shows here
    return client, cluster


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


def reanalyse_runs(config: SweepConfig, store: SweepStore) -> int:
    """Compute the results of a ``run`` sweep's finished points again from their run files
    (:func:`vesicle.workflows.tasks.reanalysed_run`: no stepping), so that a figure drawn
    again shows this version's analysis of the trajectories already computed; each record
    changed gets ``reanalysed`` (the version and the time).  Points without a run file keep
    their stored result.  Writes the store once if anything changed; returns how many
    results changed."""
    from vesicle import __version__
    from vesicle.workflows.tasks import reanalysed_run

    if config.task != "run":
        return 0
    changed = 0
    for point in config.points:
        record = store.records.get(point.key)
        if not record or record.get("status") != "done":
            continue
        result = reanalysed_run(point, config.discretisation, config.options, config.settings)
        if result is None:
            continue
        result = plain(result, nonfinite_as_none=True)
        old = {k: v for k, v in (record.get("result") or {}).items() if k != "vesicle_version"}
        if {k: v for k, v in result.items() if k != "vesicle_version"} == old:
            continue
        store.records[point.key] = {**record, "result": result, "reanalysed": {
            "vesicle_version": __version__,
            "at": datetime.now(UTC).isoformat(timespec="seconds")}}  # fmt: skip
        changed += 1
    if changed:
        store.write()
        log.info("sweep %s: %d finished run(s) analysed again from their files", config.path,
                 changed)  # fmt: skip
    return changed


def runs_from_store(path: str | Path) -> list[dict]:
    """The finished points of a ``task = "run"`` sweep store as ``{"v", "chi", "lam",
    "regime", "period"}`` (points whose analysis found no regime are kept as "undetermined")."""
    store = SweepStore.read(path)
    if store.task != "run":
        raise ValueError(f"{path} is a {store.task!r} sweep; --runs takes a sweep of runs")
    return [{"v": r["v"], "chi": r["chi"], "lam": r["lam"],
             "regime": r.get("regime") or "undetermined", "period": r.get("period")}
            for r in store.rows() if r["status"] == "done"]  # fmt: skip
