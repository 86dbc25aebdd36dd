"""The time-dependent run: stepping, saved diagnostics, checkpoints, restart and stop conditions.

:func:`simulate` drives :class:`vesicle.dynamics.integrators.Integrator` from a start shape (or a
checkpoint)
to ``t_end``, saving diagnostics every ``save_every`` time units and at the end (steps land
exactly on save times) and writing the whole run file atomically every ``checkpoint_every`` wall
seconds, at the end, and when interrupted (``KeyboardInterrupt``, which the CLI also raises on
SIGTERM).  A run resumed from its file continues bit-identically: the checkpoint holds the
state, the proposed step and the tension warm start with which the current state was
evaluated.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vesicle.dynamics.integrators import (
    STOP_KEYS,
    Evaluation,
    Integrator,
    RunParameters,
    StepState,
    initial_shape,
    post_step,
)
from vesicle.geometry.diagnostics import (
    ORBIT_TOL,
    SETTLE_TOL,
    classify_regime,
    diagnose,
    settled_orbit,
    settled_periods,
    summarize,
)
from vesicle.geometry.surface import Shape
from vesicle.io.files import (
    OPTIONAL_SERIES,
    SERIES,
    VISCOUS_SERIES,
    RunData,
    series_dtype,
    series_shape,
    write_run,
)
from vesicle.solve.solver import solve_flow

__all__ = ["SimulationError", "load_parameters", "simulate", "summarize"]

log = logging.getLogger(__name__)

Progress = Callable[[dict], None]


class SimulationError(RuntimeError):
    """The run could not continue (step size underflow, solver failure); a checkpoint exists."""


def load_parameters(run: RunData) -> RunParameters:
    """The :class:`RunParameters` stored in a run file (also the flat format of older files)."""
    return RunParameters.from_dict(run.parameters)


def _new_run(params: RunParameters, shape: Shape) -> RunData:
    parameters = params.to_dict()
    keep = [k for k in SERIES if (params.split_stress or k not in OPTIONAL_SERIES)
            and (params.bq > 0 or k not in VISCOUS_SERIES)]  # fmt: skip
    series = {
        k: np.zeros((0, *series_shape(k, params.degree)), dtype=series_dtype(k)) for k in keep
    }
    coefficients = np.zeros((0, params.degree + 1, params.degree + 1), complex)
    return RunData(parameters, series, coefficients)


def _split_stress(ev: Evaluation, params: RunParameters):
    """The stress, ``S^B`` and ``S^V`` of the evaluated shape, solved at the steady tolerances
    (1e-6/1e-7: the parts must add up to the total well below the stress differences of
    interest); ``(ev's stress, None, None)`` when the split was not asked for (nan at rest,
    where the chi-normalised parts are undefined)."""
    if not params.split_stress:
        return ev.flow.stress, None, None
    if params.chi == 0.0:
        nan = np.full((3, 3), np.nan)
        return ev.flow.stress, nan, nan
    r = solve_flow(
        ev.shape,
        params.physics,
        tolerances="steady",
        discretisation=params.discretisation,
        sigma0=ev.flow.sigma,
        split=True,
    )
    return r.stress, r.split["bending"].S, r.split["flow"].S


def _record(run: RunData, ev: Evaluation, state: StepState, dt: float, params: RunParameters):
    """Append the diagnostics of the evaluated state; returns its psi."""
    d = diagnose(ev.shape)
    stress, s_bending, s_flow = _split_stress(ev, params)
    row = {
        "t": state.t,
        "psi": d.psi,
        "D": d.D,
        "L": d.lengths,
        "axes": d.axes,
        "area": d.area,
        "volume": d.volume,
        "reduced_volume": d.reduced_volume,
        "bending_energy": d.bending_energy,
        "S": stress.S,
        "S_bending": s_bending,
        "S_flow": s_flow,
        "S_xz": stress.S_xz,
        "N1": stress.N1,
        "N2": stress.N2,
        "dt": dt,
        "outer_iterations": ev.flow.outer_iterations,
        "inner_iterations": ev.flow.inner_iterations,
        "centroid": d.centroid,
        "area_correction": state.corrections["area"],
        "volume_correction": state.corrections["volume"],
        "spectrum": d.spectrum,
    }
    if s_bending is None:
        del row["S_bending"], row["S_flow"]
    if params.bq > 0:  # the membrane's viscous part of S (the moment of its load)
        row["S_membrane"] = (ev.flow.viscous.S if ev.flow.viscous is not None
                             else np.zeros((3, 3)))  # fmt: skip
    expected = (SERIES.keys() - (set() if s_bending is not None else set(OPTIONAL_SERIES))
                - (set() if params.bq > 0 else set(VISCOUS_SERIES)))  # fmt: skip
    if row.keys() != expected:  # the one list of saved series is io.SERIES
        raise RuntimeError(f"saved series {sorted(row)} differ from io.SERIES")
    for key in sorted(set(row) | set(run.series)):
        old = run.series.get(key)
        if key in row:
            value = np.asarray(row[key], old.dtype if old is not None else series_dtype(key))
        else:  # kept by an older file of this run, not recorded now: nan
            value = np.full(old.shape[1:], np.nan)
        if old is None:  # a file written before this series existed
            old = np.full((run.n_saved, *value.shape), np.nan)
        run.series[key] = np.concatenate([old, value[None]])
    run.coefficients = np.concatenate([run.coefficients, ev.shape.coefficients[None]])
    if params.save_fields:
        _append_fields(run, {"sigma": ev.flow.sigma, "velocity": ev.flow.u})
    return d.psi


def _append_fields(run: RunData, values: dict[str, np.ndarray]) -> None:
    """Append one saved step's fields (steps saved before fields were kept are nan)."""
    for key, value in values.items():
        old = run.fields.get(key)
        if old is None:
            old = np.full((run.n_saved - 1, *value.shape), np.nan)
        run.fields[key] = np.concatenate([old, np.asarray(value, float)[None]])


class _Checkpointer:
    def __init__(self, out: Path | None, every: float, integ: Integrator):
        self.out, self.every, self.last = out, every, time.perf_counter()
        self.integ = integ

    def __call__(self, run: RunData, state: StepState, force: bool = False) -> None:
        state.solves = self.integ.solves  # the integrator counts; the state carries it
        state.anchor = self.integ.anchor  # and keeps the preconditioner's shape
        if self.out is None or not (force or time.perf_counter() - self.last >= self.every):
            return
        run.checkpoint = state.to_checkpoint()
        write_run(self.out, run)
        self.last = time.perf_counter()
        log.debug("checkpoint at t=%.5f written to %s", state.t, self.out)


def simulate(
    params: RunParameters,
    out: str | Path | None = None,
    progress: Progress | None = None,
    start: Shape | None = None,
    resume: RunData | None = None,
    attributes: dict | None = None,
) -> RunData:
    """Run the time-dependent simulation; returns the run data (also written to ``out``).

    Parameters
    ----------
    params : RunParameters
    out : path, optional
        HDF5 run file, written at checkpoints, at the end and on interruption.
    progress : callable, optional
        Called after every accepted step with ``t, dt, psi, steps, rejected, outer, inner``.
    start : Shape, optional
        Start shape instead of the spheroid of ``params.v`` (tilt and perturbation still apply).
    resume : RunData, optional
        A run file's content to continue from its checkpoint (``params.t_end`` may extend it).
    attributes : dict, optional
        Extra root attributes of the file (e.g. ``{"command": ...}``, which the CLI records).
    """
    integ = Integrator(params)
    if resume is not None:
        if resume.checkpoint is None:
            raise ValueError("the run file has no checkpoint to resume from")
        run, state = resume, StepState.from_checkpoint(resume.checkpoint)
        integ.previous_error = state.previous_error
        integ.solves = state.solves
        for key in STOP_KEYS:  # the stop criteria may change
            run.parameters[key] = getattr(params, key)
        state.stopped = ""
        integ.restore_anchor(state.anchor)  # a viscous membrane's preconditioner, as it was
        current = integ.evaluate(state.coefficients, state.sigma_in)
        log.info("resuming at t=%.6f (step %d)", state.t, state.steps)
    else:
        shape = initial_shape(params, start)
        run = _new_run(params, shape)
        run.attributes.update(attributes or {})
        state = StepState(
            t=0.0,
            coefficients=shape.coefficients,
            dt=params.dt0,
            area0=shape.area,
            volume0=shape.volume,
        )
        current = integ.evaluate(state.coefficients, None)
    checkpoint = _Checkpointer(
        Path(out) if out is not None else None, params.checkpoint_every, integ
    )
    try:
        _loop(params, integ, run, state, current, checkpoint, progress)
    except KeyboardInterrupt:
        log.warning("interrupted at t=%.6f; checkpoint written to %s", state.t, out)
        checkpoint(run, state, force=True)
        raise
    except Exception:
        checkpoint(run, state, force=True)
        raise
    checkpoint(run, state, force=True)
    run.checkpoint = state.to_checkpoint()
    return run


def _landing_step(dt: float, remaining: float) -> float:
    """The step towards the next save time (or t_end) ``remaining`` away, given the proposal
    ``dt``: the remaining interval itself when ``dt`` covers it, its half when ``dt`` covers
    more than half of it (two even steps instead of a full one and a sliver: a sliver costs as
    many solves as a full step and, taken from the proposal, upsets the controller)."""
    if dt >= remaining:
        return remaining
    if 2.0 * dt > remaining:
        return 0.5 * remaining
    return dt


def _loop(params, integ, run, state, current, checkpoint, progress) -> None:
    eps = 1e-12 * max(params.t_end, 1.0)
    while True:
        if state.t >= state.next_save - eps:
            _record(run, current, state, state.last_dt, params)
            state.next_save = state.t + params.save_every
        reason = "t_end" if state.t >= params.t_end - eps else _should_stop(params, run, current)
        if reason:
            state.stopped = reason
            # the final state is saved even between save times (t_end or an early stop)
            if not (run.n_saved and run.series["t"][-1] >= state.t - eps):
                _record(run, current, state, state.last_dt, params)
            break
        dt = _landing_step(state.dt, min(state.next_save, params.t_end) - state.t)
        integ.start_up = state.steps == 0 and state.rejected == 0
        result = integ.step(state.coefficients, dt, current)
        if not result.accepted:
            state.rejected += 1
            state.dt = result.dt_next
            if dt <= params.dt_min * (1 + 1e-9):
                raise SimulationError(
                    f"step size underflow at t={state.t:.6g}: error {result.error:.2e} at "
                    f"dt = dt_min = {params.dt_min:g}"
                )
            continue
        state.t += dt
        state.steps += 1
        # A step shortened to land on a save time says little about the step size: keep the
        # proposal it was cut from unless the controller now asks for a smaller one.
        state.dt = max(result.dt_next, state.dt) if dt < state.dt else result.dt_next
        state.previous_error = integ.previous_error
        state.last_dt = dt
        shape, changed = post_step(Shape(result.y_new, params.grid), state, params)
        state.coefficients = shape.coefficients
        if result.final is not None and not changed:
            current, state.sigma_in = result.final, result.sigma
        else:
            state.sigma_in = result.sigma if result.final is None else result.final.flow.sigma
            current = integ.evaluate(state.coefficients, state.sigma_in)
            state.corrections["evaluations"] += 1
        if progress is not None:
            progress(
                {
                    "t": state.t,
                    "dt": dt,
                    "psi": diagnose(current.shape).psi,  # now, not at the last save
                    "steps": state.steps,
                    "rejected": state.rejected,
                    "outer": current.flow.outer_iterations,
                    "inner": current.flow.inner_iterations,
                }
            )
        checkpoint(run, state)


def _should_stop(params: RunParameters, run: RunData, current: Evaluation) -> str:
    """Why the run stops early ("steady", "periods" or "orbit"), or "" to go on."""
    if params.steady_tol > 0 and np.max(np.abs(current.rate)) < params.steady_tol:
        log.info("steady state: max |dr/dt| coefficient below %g", params.steady_tol)
        return "steady"
    if params.periods > 0 and run.n_saved >= 5:
        # count only periods on the limit cycle: a TR oscillation still growing out of the
        # start, or a tumbling still speeding up, is the transient (docs/reference/dynamics.md)
        regime = classify_regime(run.series["t"], run.series["psi"], run.series["axes"], tail=1.0)
        settled = 0 if regime.name == "out-of-plane" else settled_periods(run.series["t"],
                                                                          run.series["psi"])
        if settled >= params.periods:
            log.info("%d settled periods of psi completed (lengths and swings within %g)",
                     params.periods, SETTLE_TOL)  # fmt: skip
            return "periods"
    if params.orbits > 0 and run.n_saved >= 5 and run.n_saved % 5 == 0:  # judged every 5 saves
        orbit = settled_orbit(run.series["t"], run.series["axes"], params.orbits)
        if orbit is not None:
            log.info("the long axis's %s has settled: %d of its periods (%.4g) twice over, "
                     "agreeing within %g", orbit.name, params.orbits, orbit.period,
                     ORBIT_TOL)  # fmt: skip
            return "orbit"
    return ""
