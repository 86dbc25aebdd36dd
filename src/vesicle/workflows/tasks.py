"""One registry of tasks: what each computation takes and gives, for the commands and the sweeps.

A task is a function of one parameter point (``Physics``, ``Discretisation``) and its options,
returning the JSON object that ``vesicle <command> --json`` prints and that a sweep's store
keeps for that point.  :data:`TASKS` lists them (``tt``, ``stability``, ``critical``,
``branch``, ``neutral``, ``ellipsoid_map``, ``run``) with the grid keys each sweeps and the
options it takes; :data:`OPTIONS` holds each option once: its ``[task]`` key (also its JSON key),
TOML types, default, allowed values, bounds, command-line spelling and help.  From them:

- a sweep's ``[task]`` table is checked (:func:`check_options`: unknown keys with the closest
  known one, types, choices, bounds, before any work);
- the commands' options are built (:func:`vesicle.cli.options.task_option`: same default,
  choices and help);
- the commands call the same task functions where they compute what a sweep point computes
  (``vesicle tt``, ``critical``), so the JSON keys are the same.

The settings objects (:mod:`vesicle.model.settings`) are made here from the options, in one
place per kind: :func:`analysis` (orientation, modes, Jacobians), :func:`solve` (Newton).
"""

from __future__ import annotations

import logging
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vesicle.bifurcation.branch import PARAMETERS, branch, reach
from vesicle.bifurcation.checkpoint import Checkpoint
from vesicle.bifurcation.critical import critical_lambda, critical_summary
from vesicle.bifurcation.neutral import neutral_curve
from vesicle.bifurcation.neutral_bq import neutral_curve_bq
from vesicle.bifurcation.neutral_codim2 import curve_memo, neutral_curve_codim2
from vesicle.bifurcation.steady_codim2 import FORMS
from vesicle.dynamics.integrators import RUN_DEFAULTS, STOP_KEYS, RunParameters
from vesicle.dynamics.simulation import load_parameters, simulate
from vesicle.geometry.diagnostics import diagnose, summarize
from vesicle.io.files import read_run, stamped
from vesicle.io.memo import MemoMismatch
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.settings import (
    JACOBIANS,
    MODES,
    ORIENTATIONS,
    UPDATES,
    ContinuationSettings,
    CriticalSearch,
    NewtonSettings,
    StabilitySettings,
)
from vesicle.ranges import parse_range
from vesicle.solve.ellipsoid import equivalent_ellipsoid, flow_stress, stress_map
from vesicle.steady.files import steady_summary
from vesicle.steady.stability import stability

__all__ = ["FOLDERS", "GRID_KEYS", "OPTIONS", "TASKS", "Option", "Task", "analysis",
           "check_options", "solve"]  # fmt: skip

log = logging.getLogger(__name__)

#: Parameters a grid may sweep.
GRID_KEYS = ("v", "lam", "chi", "bq")


# ------------------------------------------------------------------------ options
@dataclass(frozen=True)
class Option:
    """One task option, declared once.

    ``key``: the ``[task]`` key and the keyword (also its JSON key); ``types``: the TOML types
    accepted; ``default``: as on the command line (``None``: decided by the task); ``choices``;
    ``least``: numbers at least this; ``positive``: numbers above 0; ``flag``: the command-line
    spelling where it is not ``--key-with-dashes`` (``"--coarse/--no-coarse"``; ``invert``: a
    flag that sets the key to false, ``--no-type-change``); ``cli``: offered by the commands.
    """

    key: str
    types: tuple[type, ...]
    default: Any
    help: str
    choices: tuple[str, ...] | None = None
    least: int | None = None
    positive: bool = False
    flag: str | None = None
    invert: bool = False
    cli: bool = True

    def check(self, value: Any) -> None:
        """Raise ValueError naming ``[task] key`` if ``value`` is not one this option takes."""
        if not isinstance(value, self.types) or (isinstance(value, bool) and
                                                 bool not in self.types):  # fmt: skip
            names = " or ".join(sorted({t.__name__ for t in self.types}))
            raise ValueError(f"[task] {self.key} must be {names}, got {value!r}")
        if self.choices is not None and value not in self.choices:
            allowed = (" or ".join(map(repr, self.choices)) if len(self.choices) == 2 else
                       "one of " + ", ".join(map(repr, self.choices)))  # fmt: skip
            raise ValueError(f"[task] {self.key} must be {allowed}, got {value!r}")
        if self.positive and not (np.isfinite(value) and value > 0):
            raise ValueError(f"[task] {self.key} must be a positive number, got {value!r}")
        if self.least is not None and value < self.least:
            raise ValueError(f"[task] {self.key} must be at least {self.least}, got {value!r}")


_NUMBER = (int, float)

#: Every task option, once.
OPTIONS: dict[str, Option] = {o.key: o for o in (
    Option("orientation", (str,), "flow", "The TT branch: long axis in the shear plane (flow) "
           "or along the vorticity axis y (vorticity; start: the spheroid along y). A state on "
           "the other branch is refused.", choices=ORIENTATIONS),
    Option("modes", (str,), None, "Perturbations of the stability analysis [default: "
           "symmetric; general with --orientation vorticity, whose instability breaks the x-z "
           "symmetry].", choices=MODES),
    Option("jacobian", (str,), "linearised", "How Newton and stability form Jacobians: the "
           "solve differentiated (no solves per column), or finite differences of perturbed "
           "solves (the reference; --workers/--scheduler run their columns).",
           choices=JACOBIANS),
    Option("max_iterations", (int,), None, "Newton iterations per steady state before giving "
           "up [default: 30; 12 with --updates none].", least=1),
    Option("updates", (str,), "broyden", "Newton's Jacobian: reused with Broyden updates, or "
           "fresh at every step (reference).", choices=UPDATES),
    Option("lam0", _NUMBER, None, "First lambda to try.", positive=True),
    Option("step", _NUMBER, 0.05, "Relative move of lambda from --lam0 to the second "
           "evaluation; secant steps follow.", positive=True),
    Option("xtol", _NUMBER, 1e-3, "Tolerance on lambda_c (a branch's special points: absolute "
           "in lam, relative in chi and v).", positive=True),
    Option("coarse", (bool,), True, "Locate lambda_c first at N = 4 on 16x32 (when "
           "--degree/--grid are finer, --lam0 is not given and the branch is the in-plane one) "
           "and start the search there.", flag="--coarse/--no-coarse"),
    Option("locate", (bool,), True, "Locate stability changes between points.",
           flag="--locate/--no-locate"),
    Option("arclength", (bool,), True, "Where natural continuation stops, follow the branch "
           "by pseudo-arclength to locate the fold.", flag="--arclength/--no-arclength"),
    Option("past_fold", (int,), 0, "Arclength steps beyond a fold, on the unstable side.",
           least=0),
    Option("parameter", (str,), None, "The parameter continued along each branch.",
           choices=PARAMETERS, cli=False),
    Option("values", (str, list), None, 'Its values: "1:9", "1:9:0.5" or a list.', cli=False),
    Option("ellipsoid", (bool,), False, "S^V of each point's equivalent ellipsoid too.",
           cli=False),
    Option("chi", (str, list), "0.1:10", "Shear rates: a list (0.2,1,6) or a range LOW:HIGH, "
           "log-spaced with --points."),
    Option("points", (int,), None, "Points of a --chi range [default: 10].", least=2),
    Option("type_tol", _NUMBER, 0.02, "Relative width in chi to which a change of "
           "bifurcation type is located.", positive=True),
    Option("locate_type_change", (bool,), True, "Do not locate the change of type.",
           flag="--no-type-change", invert=True),
    Option("cusps", (bool,), False, "codim2: continue each fold curve past the change of type "
           "to its cusp, however many refused steps that takes (by default it is given up "
           "there after 3 refused steps in a row: at N = 8 the cusps were not reached in 4-7 "
           "min).", flag="--cusps"),
    Option("continuation", (str,), "codim2", "codim2: the fold and Hopf curves continued in "
           "(chi, lambda) on their augmented systems, with the Bogdanov-Takens and cusp points "
           "and the change of type located, then each chi solved on its curve (every point "
           "'located' only where its system converged). trace: the older one-parameter tracer "
           "(a branch in lambda at each chi); --xtol, --type-tol, --states, --resume, --workers "
           "and --scheduler apply to it only.", choices=("codim2", "trace")),
    Option("form", (str,), "spec", "codim2: the Jacobian the curves are defined by: SPEC 9's "
           "operator (what `critical` and --continuation trace compute) or the Newton matrix "
           "with the multipliers' curvature (its fold is exactly the branch's turning point).",
           choices=FORMS),
    Option("lam_at", (str, list), None, "neutral_bq: viscosity ratios at which to solve for "
           "the critical Bq (a list or a comma list).", cli=False),
    Option("psi", (str, list), "-0.6:0.8", "Inclinations of the ellipsoid map.", cli=False),
    Option("lams", (str, list), "1:12", "Viscosity ratios of the ellipsoid map.", cli=False),
    Option("flow_time", (bool,), False, "run: the [run] save_every and dt_max are in units of "
           "the flow's time 1 / chi of each point, so that a sweep over chi saves and steps "
           "alike per period (chi T varies little with chi).", cli=False),
)}  # fmt: skip


def option_value(options: dict, key: str) -> Any:
    """``options[key]``, else the option's default."""
    return options.get(key, OPTIONS[key].default)


def analysis(options: dict) -> StabilitySettings:
    """A task's branch, modes and Jacobians (``orientation``, ``modes``, ``jacobian``)."""
    return StabilitySettings(option_value(options, "orientation"), option_value(options, "modes"),
                             option_value(options, "jacobian"))  # fmt: skip


def solve(options: dict) -> dict:
    """The settings of a task's Newton solves (``max_iterations``, ``updates``; its branch)."""
    newton = NewtonSettings(max_iterations=option_value(options, "max_iterations"),
                            updates=option_value(options, "updates"))  # fmt: skip
    return {"newton": newton, "analysis": analysis(options)}


# ------------------------------------------------------------------------ tasks
def steady_state(physics: Physics, disc: Discretisation, options: dict, with_stability: bool,
                 executor=None, progress=None):  # fmt: skip
    """``vesicle tt`` (``--stability``) and the ``tt``/``stability`` tasks: the state reached
    (:func:`vesicle.bifurcation.branch.reach`) and its stability (or ``None``)."""
    r = reach(physics, disc, executor=executor, progress=progress, **solve(options))
    s = stability(r, modes=analysis(options).modes, executor=executor) if with_stability else None
    return r, s


def steady_json(r, s, options: dict) -> dict:
    """The JSON of a steady state: :func:`vesicle.steady.files.steady_summary` and how Newton
    formed its Jacobians."""
    return {**steady_summary(r, s), "updates": option_value(options, "updates"),
            "jacobian": option_value(options, "jacobian")}  # fmt: skip


def _tt(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    return steady_json(*steady_state(physics, disc, options, False), options)


def _stability(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    return steady_json(*steady_state(physics, disc, options, True), options)


def critical(physics: Physics, disc: Discretisation, options: dict, executor=None,
             progress=None):  # fmt: skip
    """``vesicle critical`` and the ``critical`` task: the search for lambda_c."""
    search = CriticalSearch(lam0=option_value(options, "lam0"), step=option_value(options, "step"),
                            xtol=option_value(options, "xtol"),
                            coarse="auto" if option_value(options, "coarse") else None)  # fmt: skip
    return critical_lambda(physics, disc, search=search, executor=executor, progress=progress,
                           **solve(options))  # fmt: skip


def critical_json(c, physics: Physics, disc: Discretisation, options: dict) -> dict:
    """The JSON of a critical-lambda search (:func:`critical_summary`, the branch, Jacobians)."""
    return {**critical_summary(c, physics, disc), "jacobian": option_value(options, "jacobian"),
            "orientation": option_value(options, "orientation")}  # fmt: skip


def _critical(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    return critical_json(critical(physics, disc, options), physics, disc, options)


def _branch_values(options: dict) -> list[float]:
    return parse_range(options["values"], "step", name="[task] values")


def _branch(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    name = options["parameter"]
    values = _branch_values(options)
    start = physics.replace(**{name: values[0]})
    keys = ("xtol", "past_fold", "locate", "arclength")
    b = branch(start, disc, name, values, analysis=analysis(options),
               continuation=ContinuationSettings(**{k: option_value(options, k) for k in keys}))
    fixed = {k: x for k, x in physics.to_dict().items() if k != name}
    result = b.to_dict()
    if options.get("ellipsoid"):  # S^V of each point's equivalent ellipsoid (SPEC §11)
        for p in result["points"]:
            shape = equivalent_ellipsoid(p["axes"], p["axis_directions"], disc.grid)
            p["ellipsoid"] = flow_stress(shape, [p["lam"]], bq=physics.bq)[0].summary()
    return stamped({"physics": fixed, "discretisation": disc.to_dict(),
            **{k: physics.to_dict()[k] for k in GRID_KEYS if k != name}, **result})  # fmt: skip


#: settings that name folders of the points' files (not part of what a store's points share)
FOLDERS = ("runs_dir", "curves_dir")

def _neutral_chi(options: dict) -> list[float]:
    return parse_range(options.get("chi", "0.1:10"), "log", points=options.get("points"),
                       name="[task] chi", positive=True)


def _neutral(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    if options.get("continuation", "codim2") == "codim2":
        return _neutral_codim2(physics, disc, options, settings)
    keys = ("xtol", "type_tol", "locate_type_change")
    kwargs = {k: options[k] for k in keys if k in options}
    branch_settings = analysis(options)
    known, keep = [], None
    if settings.get("curves_dir"):  # the curve's points and states as they are found: a curve
        # cut short by a crash, Ctrl-C or a lost worker goes on from them when tried again
        keep = Checkpoint(Path(settings["curves_dir"]) / f"{physics.key}.json", physics, disc,
                          orientation=branch_settings.orientation, modes=branch_settings.modes,
                          xtol=kwargs.get("xtol", 1e-3),
                          jacobian=branch_settings.jacobian)  # fmt: skip
        keep.out.parent.mkdir(parents=True, exist_ok=True)
        try:
            known = keep.resume()
        except ValueError as err:
            log.warning("neutral curve %s: its checkpoint is not usable (%s): traced again",
                        physics.key, err)  # fmt: skip
        if known:
            log.info("neutral curve %s: %d points from its checkpoint", physics.key, len(known))
    c = neutral_curve(physics, _neutral_chi(options), disc, analysis=branch_settings, known=known,
                      checkpoint=keep, **kwargs)  # fmt: skip
    return c.to_dict()  # a curve that stopped has "failed" entries: see run_point


def _neutral_codim2(physics: Physics, disc: Discretisation, options: dict,
                    settings: dict) -> dict:  # fmt: skip
    """The codim2 curve, its evaluations kept in ``curves_dir`` as it goes (a curve cut short by
    a crash, Ctrl-C or a lost worker replays them when tried again) and removed once it is
    complete and returned to the store."""
    keys = ("locate_type_change", "form", "cusps")
    kwargs = {k: options[k] for k in keys if k in options}
    memo = _curve_memo(physics, disc, options, settings, kwargs.get("form", "spec"),
                       ("lam", "chi"))  # fmt: skip
    c = neutral_curve_codim2(physics, _neutral_chi(options), disc, analysis=analysis(options),
                             memo=memo, **kwargs)  # fmt: skip
    return _cleared(c.to_dict(), memo)


def _curve_memo(physics, disc, options, settings, form, free):
    """The memo of a sweep point's curve in ``curves_dir`` (None without one); one of another
    identity is removed (computed afresh)."""
    if not settings.get("curves_dir"):
        return None
    folder = Path(settings["curves_dir"]) / f"{physics.key}.codim2"
    try:
        memo = curve_memo(folder, physics, disc, analysis(options), form, free)
    except MemoMismatch as err:
        log.warning("curve %s: %s: computed afresh", physics.key, err)
        shutil.rmtree(folder, ignore_errors=True)
        memo = curve_memo(folder, physics, disc, analysis(options), form, free)
    if len(memo):
        log.info("curve %s: replaying %d evaluations kept in %s", physics.key, len(memo),
                 folder)  # fmt: skip
    return memo


def _cleared(out: dict, memo) -> dict:
    """A curve's result, with how many evaluations it read back from its memo instead of
    computing them (``replayed``).  The memo is removed once the curve is complete (the store
    keeps the result); a curve with failures keeps it, so that a retry replays."""
    if memo is not None:
        out["replayed"] = memo.hits
        if _neutral_incomplete(out) is None:
            memo.clear()
    return out


def _bq_values(options: dict) -> list[float]:
    """``neutral_bq``'s Boussinesq numbers (``[task] values``, default 0 to 10 by 1)."""
    values = parse_range(options.get("values", "0:10"), "step", name="[task] values")
    if any(not b >= 0 for b in values):
        raise ValueError(f"[task] values (Boussinesq numbers) must be >= 0, got "
                         f"{options.get('values')!r}")  # fmt: skip
    return values


def _lam_at(options: dict) -> list[float]:
    spec = options.get("lam_at")
    if spec is None:
        return []
    return parse_range(spec, "linear", name="[task] lam_at", positive=True)


def _neutral_bq(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    """lambda_c(Bq) at the point's v and chi by continuation in (Bq, lambda), and the critical
    Bq at ``lam_at`` (:func:`vesicle.bifurcation.neutral_bq.neutral_curve_bq`)."""
    form = option_value(options, "form")
    memo = _curve_memo(physics, disc, options, settings, form, ("lam", "bq"))
    c = neutral_curve_bq(physics, _bq_values(options), disc, lam_at=_lam_at(options),
                         analysis=analysis(options), form=form, lam0=options.get("lam0"),
                         memo=memo)  # fmt: skip
    return _cleared(c.to_dict(), memo)


def _values(spec, points: int, name: str) -> list[float]:
    """``ellipsoid_map``'s ``psi``/``lams``: a list, or ``LOW:HIGH`` with ``points`` values."""
    if isinstance(spec, list):
        return parse_range(spec, "linear", name=name)
    return parse_range(spec, "linear", points=points, name=name)


def _ellipsoid_map(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    """S^V of the TT state's equivalent ellipsoid turned over ``psi`` for every ``lams``."""
    state = reach(physics, disc, analysis=analysis(options))
    d = diagnose(state.shape)
    psis = _values(options.get("psi", "-0.6:0.8"), int(options.get("points", 15)), "[task] psi")
    lams = _values(options.get("lams", "1:12"), int(options.get("points", 15)), "[task] lams")
    m = stress_map(d.lengths, d.axes, state.psi, psis, lams, disc.grid, bq=physics.bq)
    return stamped({"physics": physics.to_dict(),
            "discretisation": disc.to_dict(), "v": physics.v, "lam": physics.lam,
            "chi": physics.chi, "state": {"psi": state.psi, "axes": d.lengths.tolist(),
                                          "axis_directions": d.axes.tolist()},
            "map_psi": m["psi"].tolist(), "map_lam": m["lam"].tolist(),
            **{k: np.asarray(m[k]).tolist() for k in ("S_xz", "N1", "N2")}})  # fmt: skip


#: The run settings that ``[task] flow_time`` gives in units of the flow's time 1 / chi.
FLOW_TIME_KEYS = ("save_every", "dt_max")


def _run_settings(physics: Physics, options: dict, settings: dict) -> dict:
    """The point's ``[run]`` settings; with ``flow_time``, :data:`FLOW_TIME_KEYS` divided by
    its chi (the defaults too, where the table leaves them out)."""
    run = dict(settings.get("run", {}))
    if option_value(options, "flow_time"):
        if not physics.chi > 0.0:
            raise ValueError(f"[task] flow_time needs chi > 0 at every point, got {physics.chi}")
        for key in FLOW_TIME_KEYS:
            run[key] = float(run.get(key, RUN_DEFAULTS[key])) / physics.chi
    return run


def _run_params(physics: Physics, disc: Discretisation, options: dict, settings: dict):
    return RunParameters(physics, disc, settings.get("solver"),
                         **_run_settings(physics, options, settings))  # fmt: skip


def _run_result(physics: Physics, disc: Discretisation, run) -> dict:
    return stamped({"physics": physics.to_dict(),
            "discretisation": disc.to_dict(), "v": physics.v, "lam": physics.lam,
            "chi": physics.chi, "bq": physics.bq, **summarize(run)})  # fmt: skip


def reanalysed_run(physics: Physics, disc: Discretisation, options: dict,
                   settings: dict) -> dict | None:  # fmt: skip
    """A ``run`` point's result computed again from its run file (``settings["runs_dir"]``),
    without stepping: the analysis of this version (regime, period, means) of the trajectory
    that was computed.  None when the point keeps no run file, or when the file is not this
    point's run (other parameters than the point's, besides the stop criteria)."""
    if not settings.get("runs_dir"):
        return None
    path = Path(settings["runs_dir"]) / f"{physics.key}.h5"
    if not path.exists():
        return None
    try:
        run = read_run(path)
    except (OSError, ValueError, KeyError) as err:  # as _run: such a file is not this run
        log.warning("run file %s unreadable (%s): not re-analysed", path, err)
        return None
    params = _run_params(physics, disc, options, settings)
    stops = {k: getattr(params, k) for k in STOP_KEYS}
    if load_parameters(run).replace(**stops) != params:
        log.warning("run file %s holds another run than point %s: not re-analysed", path,
                    physics.key)  # fmt: skip
        return None
    return _run_result(physics, disc, run)


def _run(physics: Physics, disc: Discretisation, options: dict, settings: dict) -> dict:
    params = _run_params(physics, disc, options, settings)
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
                stops = {k: getattr(params, k) for k in STOP_KEYS}
                same = load_parameters(previous).replace(**stops) == params
                if previous.checkpoint is not None and same:
                    resume = previous
                    log.info("point %s resumes its run from t = %.4g", physics.key,
                             float(previous.checkpoint["t"]))  # fmt: skip
                else:
                    path.unlink()
    run = simulate(params, out=path, resume=resume)
    return _run_result(physics, disc, run)


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
    """A branch that stopped before its last value is not done, unless it ends at a located
    fold: the values beyond it lie on no state of the branch (the TT branch of Figure 14 at
    chi = 0.2 folds at lam = 7.48 at N = 4, inside its lam = 1 ... 9), so what was asked for is
    all there is.  A fold estimated, or a stop short of a located fold (a failed step), is not
    done."""
    if not result.get("stopped"):
        return None
    if _ends_at_fold(result):
        return None
    return f"the branch stopped before its last value: {result['stopped']}"


def _ends_at_fold(result: dict) -> bool:
    """Whether the branch's stop (``stopped_between``: its last state and the value it could
    not reach) is at a located fold: one lying beyond the last state, towards that value, no
    farther than one more step of the same size."""
    between = result.get("stopped_between")
    if not between:
        return False
    last, target = (float(x) for x in between)
    name = result.get("parameter", "lam")
    width = abs(target - last)
    for s in result.get("special_points", []):
        if s.get("type") in ("saddle-node", "fold") and s.get("located") and name in s:
            beyond = (float(s[name]) - last) * np.sign(target - last)
            if -1e-9 * max(1.0, abs(last)) <= beyond <= 2.0 * width + 1e-12:
                return True
    return False


def _neutral_incomplete(result: dict) -> str | None:
    """A neutral curve with points it could not trace is not done."""
    if not result.get("failed"):
        return None
    if "plane" in result:  # neutral_bq's failures name what they miss
        return "the curve stopped: " + "; ".join(f["error"] for f in result["failed"])
    where = [f"before chi = {f['chi']:.4g}: {f['error']}" for f in result["failed"]]
    return "the curve stopped: " + "; ".join(where)


#: The tasks, by name; each point's result has the keys of the command's own --json output.
_STEADY = ("jacobian", "max_iterations", "updates", "orientation")

#: The tasks, by name; each point's result has the keys of the command's own --json output.
TASKS = {
    "tt": Task(_tt, GRID_KEYS, _STEADY),
    "stability": Task(_stability, GRID_KEYS, (*_STEADY, "modes")),
    "critical": Task(_critical, ("v", "chi", "bq"),
                     ("jacobian", "max_iterations", "updates", "xtol", "lam0", "step",
                      "orientation", "modes", "coarse")),
    "branch": Task(_branch, GRID_KEYS,
                   ("parameter", "values", "jacobian", "xtol", "past_fold", "locate",
                    "arclength", "ellipsoid", "orientation", "modes"),
                   _branch_incomplete),
    "neutral": Task(_neutral, ("v", "bq"),
                    ("chi", "points", "jacobian", "xtol", "type_tol", "locate_type_change",
                     "orientation", "modes", "continuation", "form", "cusps"),
                    _neutral_incomplete),
    "neutral_bq": Task(_neutral_bq, ("v", "chi"),
                       ("values", "lam_at", "lam0", "form", "orientation", "modes", "jacobian"),
                       _neutral_incomplete),
    "ellipsoid_map": Task(_ellipsoid_map, GRID_KEYS, ("psi", "lams", "points", "jacobian")),
    "run": Task(_run, GRID_KEYS, ("flow_time",)),
}  # fmt: skip


# ------------------------------------------------------------------------ checks
def check_options(task: str, options: dict, grid: dict, points) -> None:
    """A ``[task]`` table of ``task``, checked before any work (raises ValueError naming the
    key): each value as its :class:`Option` takes it (type, choices, bounds), then the task's
    own rules between keys.  Unknown keys are the caller's (with the closest known one)."""
    for key, value in options.items():
        OPTIONS[key].check(value)
    analysis(options)  # the settings object refuses what the options cannot give together
    _check_task(task, options, grid, points)


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
    if task == "neutral_bq":
        _bq_values(options)
        _lam_at(options)
        for p in points:
            if not p.chi > 0:
                raise ValueError(f"[grid] chi must be positive for task = 'neutral_bq', got "
                                 f"{p.chi}")  # fmt: skip
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
        how = option_value(options, "continuation")
        if how == "codim2":
            for key in ("xtol", "type_tol"):
                if key in options:
                    raise ValueError(f"[task] {key} applies to continuation = 'trace' only "
                                     "(the two-parameter continuation solves each point to "
                                     "its own tolerance)")  # fmt: skip
        else:
            for key in ("form", "cusps"):
                if key in options:
                    raise ValueError(f"[task] {key} applies to continuation = 'codim2' only")


