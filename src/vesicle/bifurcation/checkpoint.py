"""Checkpoints of a neutral curve: each traced point's start state as a steady-state file, so
that an interrupted trace resumes where it stopped (``vesicle neutral --out F --resume``).

A point of a neutral curve costs minutes to an hour at N = 8 (a fold next to the type change:
an hour), and each new ``chi`` starts from its neighbour's stable state and Jacobian.  Its JSON
entry alone (``--out``, written as each point is found) cannot restart the trace; the state can.
:func:`write_point_state` writes the state of each new point (``NeutralPoint.start``) to a
folder, before the point is listed in the JSON; :func:`read_checkpoint` reads the points of an
``--out`` file back with their states (the Jacobian bit for bit:
:meth:`vesicle.steady.files.SteadyFile.steady_result`), refusing a file of another curve, and
:func:`vesicle.bifurcation.neutral.neutral_curve` (``known=``) takes them instead of tracing them
again.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
from pathlib import Path

from vesicle.bifurcation.neutral import NeutralPoint
from vesicle.io.files import stamped, write_text_atomically
from vesicle.model.parameters import Discretisation, Physics
from vesicle.steady.files import read_steady, write_steady
from vesicle.steady.stability import default_modes, stability

__all__ = ["Checkpoint", "read_checkpoint", "state_path", "states_folder", "write_point_state"]

log = logging.getLogger(__name__)


def states_folder(out: str | os.PathLike, suffix: str = ".states") -> Path:
    """The default checkpoint folder of an ``--out`` file: ``curve.json`` -> ``curve.states``
    (another ``suffix``: ``curve.codim2`` for a codim2 curve's evaluations)."""
    out = Path(out)
    return out.with_suffix(suffix) if out.suffix else out.with_name(out.name + suffix)


def state_path(folder: str | os.PathLike, chi: float) -> Path:
    """The steady-state file of the point at ``chi`` (ten digits: bisection points may lie
    close together)."""
    return Path(folder) / f"chi_{chi:.10g}.h5"


def write_point_state(folder: str | os.PathLike, point: NeutralPoint,
                      attributes: dict | None = None) -> Path:  # fmt: skip
    """The point's start state (with its stability analysis), written atomically."""
    if point.start is None:
        raise ValueError(f"the point at chi = {point.chi:g} has no state to write")
    Path(folder).mkdir(parents=True, exist_ok=True)
    return write_steady(state_path(folder, point.chi), point.start, stability(point.start),
                        attributes=attributes)  # fmt: skip


def _check(name: str, found, expected) -> None:
    if found is not None and found != expected:
        raise ValueError(f"cannot resume: the file's {name} is {found!r}, this curve's "
                         f"{expected!r} (another --out, or the same options)")  # fmt: skip


def read_checkpoint(
    out: str | os.PathLike,
    folder: str | os.PathLike,
    physics: Physics,
    discretisation: Discretisation,
    *,
    orientation: str = "flow",
    modes: str = "symmetric",
    xtol: float = 1e-3,
    jacobian: str = "linearised",
) -> list[NeutralPoint]:
    """The points of the neutral-curve file ``out`` (partial or complete) whose state is in
    ``folder``, each with that state as its ``start``.  A file of another curve (v, flow,
    degree, grid, orientation, modes, xtol, and the membrane's ``bq``) is refused with
    ValueError; a point whose state file is missing or does not match is left out (traced
    again), with a warning."""
    out = Path(out)
    try:
        data = json.loads(out.read_text())
    except (OSError, ValueError) as err:
        raise ValueError(f"cannot resume from {out}: {err}") from err
    if not isinstance(data, dict) or not isinstance(data.get("points"), list):
        raise ValueError(f"cannot resume from {out}: not a neutral-curve file (no 'points')")
    _check("v", data.get("v"), physics.v)
    _check("degree", data.get("degree"), discretisation.degree)
    _check("grid", data.get("grid"), discretisation.grid)
    _check("orientation", data.get("orientation"), orientation)
    _check("modes", data.get("modes"), modes)
    _check("xtol", data.get("xtol"), xtol)
    if "physics" in data:
        flow = json.loads(json.dumps(physics.to_dict()["flow"]))  # as the file holds it
        _check("flow", data["physics"].get("flow"), flow)
    # files written before the membrane's viscosity existed are of Bq = 0
    _check("bq", float(data.get("physics", {}).get("bq", 0.0)), physics.bq)
    points = []
    for entry in data["points"] + data.get("bisection", []):
        path = state_path(folder, float(entry["chi"]))
        try:
            state = read_steady(path)
        except (OSError, ValueError) as err:
            log.warning("chi = %.4g is traced again: its state %s cannot be read (%s)",
                        entry["chi"], path, err)  # fmt: skip
            continue
        if state.physics.chi != float(entry["chi"]) or state.physics.v != physics.v:
            log.warning("chi = %.4g is traced again: %s holds another state", entry["chi"], path)
            continue
        if state.jacobian_method != jacobian:
            log.warning("chi = %.4g is traced again: its state's Jacobian was formed by %s",
                        entry["chi"], state.jacobian_method)  # fmt: skip
            continue
        try:
            start = state.steady_result(discretisation)
        except ValueError as err:
            log.warning("chi = %.4g is traced again: %s (%s)", entry["chi"], err, path)
            continue
        point = NeutralPoint.from_dict(entry, start)
        if point.lower_fold is not None:
            # a fold replaced by the loss of stability of the branch past it (an S-shaped
            # branch, neutral._Tracer.past_fold): the state kept is the fold's (the branch from
            # low lam, which the trace goes on from), so the point is read back as that fold
            # and the resumed curve looks past it again, as the uninterrupted one did (psi and
            # D are the other branch's until then)
            point = dataclasses.replace(point, lambda_c=point.lower_fold,
                                        bifurcation="saddle-node", omega_R=0.0,
                                        located=point.lower_fold_located,
                                        bracket=None, lower_fold=None)  # fmt: skip
        points.append(point)
    return points


class Checkpoint:
    """Where a neutral curve keeps its points as they are found: each new point's state in
    ``folder`` (default: beside ``out``, :func:`states_folder`), then the points so far in
    ``out`` as a partial curve file (written atomically); :meth:`resume` reads them back.
    Called with each new point (``neutral_curve(..., checkpoint=this)``).

    ``extra``: more keys of the partial file (the command line, say)."""

    def __init__(self, out, physics: Physics, discretisation: Discretisation, *,
                 folder=None, orientation: str = "flow", modes: str | None = None,
                 xtol: float = 1e-3, jacobian: str = "linearised",
                 extra: dict | None = None):  # fmt: skip
        self.out = None if out is None else Path(out)
        if folder is None and self.out is None:
            raise ValueError("a checkpoint needs a file or a folder")
        self.folder = Path(folder) if folder is not None else states_folder(self.out)
        self.physics, self.disc = physics, discretisation
        self.orientation, self.xtol, self.jacobian = orientation, float(xtol), jacobian
        self.modes = default_modes(orientation, modes)
        self.extra = dict(extra or {})
        self.found: list[dict] = []

    def resume(self) -> list[NeutralPoint]:
        """The points kept by an earlier trace (none if ``out`` does not exist); raises
        ValueError for a file of another curve."""
        if self.out is None or not self.out.exists():
            return []
        points = read_checkpoint(self.out, self.folder, self.physics, self.disc,
                                 orientation=self.orientation, modes=self.modes,
                                 xtol=self.xtol, jacobian=self.jacobian)  # fmt: skip
        self.found = [p.to_dict() for p in points]
        return points

    def __call__(self, point: NeutralPoint) -> None:
        write_point_state(self.folder, point, {k: v for k, v in self.extra.items()
                                               if isinstance(v, str)})  # fmt: skip
        self.found.append(point.to_dict())
        if self.out is not None:
            self.write_partial()

    def write_partial(self) -> None:
        physics = {k: x for k, x in self.physics.to_dict().items() if k not in ("lam", "chi")}
        partial = stamped({"v": self.physics.v,
                   "degree": self.disc.degree, "grid": self.disc.grid, "partial": True,
                   "xtol": self.xtol, "orientation": self.orientation, "modes": self.modes,
                   "physics": physics, **self.extra, "type_change": None,
                   "points": sorted(self.found, key=lambda p: p["chi"])})  # fmt: skip
        write_text_atomically(self.out, json.dumps(partial, indent=1))
