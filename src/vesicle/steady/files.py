"""Steady-state files: a converged tank-treading state, its Jacobian and its spectrum (HDF5).

Written by ``vesicle tt --out FILE`` (:func:`write_steady`), read by :func:`read_steady` (to
start a run from the state without repeating Newton: ``vesicle run --init FILE``; to draw the
spectrum and the unstable modes: ``vesicle plot FILE``) and by :func:`open_steady` as an
:class:`xarray.Dataset`.

Layout:

``/`` attributes
    ``format = "vesicle-steady"``, ``format_version``, ``vesicle_version``, library versions,
    ``created``, ``checksum`` (verified on reading), the command line.
``/parameters`` attributes
    ``physics``, ``discretisation`` (the parameter objects as JSON), ``basis``, ``jacobian``.
``/state``
    ``coefficients`` (l, m) complex radius coefficients (SPEC §2), ``a`` (the basis
    coordinates), ``multipliers`` (lambda_A, lambda_V), ``axes`` (full lengths, descending),
    ``S``, ``S_bending``, ``S_flow`` (3, 3), ``residual_history``; attributes ``psi``, ``D``,
    ``S_xz``, ``N1``, ``N2``, ``solves``, ``seconds``.
``/jacobian``
    ``M`` = d adot / d a (basis coordinates), ``gradients`` (dA/da, dV/da), ``basis_l``,
    ``basis_m``, ``basis_part`` (0: cosine, 1: sine) of each coordinate.
``/stability`` (when it was computed)
    ``omega_R``, ``omega_I`` (mode) sorted most unstable first, ``modes`` (mode, l, m) complex
    perturbations of the radius coefficients; attribute ``basis``.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.io.files import open_file, stamp, stamped, write_atomically
from vesicle.model.parameters import Discretisation, Physics
from vesicle.model.rheology import ParticleStress
from vesicle.steady.newton import NEWTON_TOLERANCES, SteadyResult
from vesicle.steady.problem import SteadyProblem
from vesicle.steady.stability import StabilityResult

__all__ = [
    "FORMAT",
    "SteadyFile",
    "is_steady_file",
    "open_steady",
    "read_steady",
    "steady_summary",
    "write_steady",
]

FORMAT = "vesicle-steady"
FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class SteadyFile:
    """The content of a steady-state file."""

    physics: Physics
    discretisation: Discretisation
    coefficients: np.ndarray  # (N+1, N+1) complex
    multipliers: np.ndarray
    summary: dict  # psi, D, S_xz, N1, N2, solves, seconds
    arrays: dict  # a, axes, S, S_bending, S_flow, residual_history, M, gradients, basis_*
    omega: np.ndarray | None = None  # (k, 2): (omega_R, omega_I)
    modes: np.ndarray | None = None  # (k, N+1, N+1) complex
    mode_parts: np.ndarray | None = None  # (k, 2, N+1, N+1): real and imaginary parts
    stability_basis: str | None = None
    attributes: dict = field(default_factory=dict)
    basis: str = "symmetric"  # of the unknowns (the Jacobian's columns)
    jacobian_method: str = "linearised"

    @property
    def shape(self) -> Shape:
        return Shape(self.coefficients, self.discretisation.grid)

    @property
    def jacobian(self) -> np.ndarray:
        return self.arrays["M"]

    def steady_result(self, discretisation: Discretisation | None = None) -> SteadyResult:
        """The state as a :class:`~vesicle.steady.newton.SteadyResult`, without a solve: the stored
        coordinates, multipliers and Jacobian bit for bit, so that a continuation from it (a
        neutral curve resumed, :mod:`vesicle.bifurcation.checkpoint`) takes the steps it would have
        taken from the state in memory.  ``discretisation``: how to go on computing (its backend,
        method, workers); its grid, degree and n_rot must be the file's."""
        if "M" not in self.arrays:
            raise ValueError("this steady-state file has no Jacobian: it cannot start Newton")
        disc = self.discretisation if discretisation is None else discretisation
        if _resolution(disc) != _resolution(self.discretisation):
            raise ValueError(f"the state is at {_resolution(self.discretisation)} (degree, grid, "
                             f"n_rot, multipliers), not {_resolution(disc)}")  # fmt: skip
        problem = SteadyProblem(self.physics, disc, NEWTON_TOLERANCES, modes=self.basis,
                                jacobian_method=self.jacobian_method)  # fmt: skip
        a = np.asarray(self.arrays["a"], float)
        if a.size != problem.basis.size:
            raise ValueError(f"the file's {a.size} coordinates do not match the {self.basis} "
                             f"basis of degree {self.discretisation.degree}")  # fmt: skip
        chi = self.physics.chi

        def stress(S):
            return ParticleStress(np.asarray(S, float) * chi, chi)

        s = self.summary
        return SteadyResult(
            a=a,
            multipliers=(float(self.multipliers[0]), float(self.multipliers[1])),
            shape=problem.shape(a),
            problem=problem,
            residual_history=tuple(float(r) for r in self.arrays["residual_history"]),
            converged=True,
            jacobian=np.asarray(self.arrays["M"], float),
            gradients=np.asarray(self.arrays["gradients"], float),
            psi=float(s["psi"]),
            D=float(s["D"]),
            axes=np.asarray(self.arrays["axes"], float),
            stress=stress(self.arrays["S"]),
            split={"bending": stress(self.arrays["S_bending"]),
                   "flow": stress(self.arrays["S_flow"])},
            seconds=float(s["seconds"]),
            solves=int(s["solves"]),
            start=str(s.get("start", UNKNOWN_START)),
        )


def steady_summary(result: SteadyResult, stability: StabilityResult | None = None) -> dict:
    """The JSON summary of a steady state (what ``vesicle tt --json`` prints and a ``tt`` or
    ``stability`` sweep stores per point), with the package version and the parameters."""
    p, d = result.physics, result.discretisation
    out = stamped({
        "v": p.v, "lam": p.lam, "chi": p.chi, "bq": p.bq, "flow_type": p.flow.name,
        "degree": d.degree, "grid": d.grid,
        "physics": p.to_dict(), "discretisation": d.to_dict(),
        "psi": result.psi, "D": result.D, "axes": np.asarray(result.axes).tolist(),
        "orientation": result.orientation, "long_axis": result.long_axis.tolist(),
        **result.stress.summary(),
        "bending": result.split["bending"].summary(),
        "flow": result.split["flow"].summary(),
        **({"membrane_viscous": result.split["membrane_viscous"].summary()}
           if "membrane_viscous" in result.split else {}),
        "newton_iterations": result.newton_iterations,
        "jacobians": result.jacobians,
        "residual": result.residual,
        "residual_history": list(result.residual_history),
        "multipliers": list(result.multipliers),
        "solves": result.solves,
        "seconds": result.seconds,
        "start": result.start,
    })  # fmt: skip
    if stability is not None:
        w_r, w_i = stability.most_unstable
        out.update({"modes": stability.basis, "omega_R": w_r, "omega_I": w_i,
                    "n_unstable": int(np.sum(stability.omega[:, 1] > 0)),
                    "eigenvalues": stability.omega.tolist(),
                    "curvature_shift": float(stability.curvature_shift)})  # fmt: skip
    return out


#: The provenance of a state read from a file written before it was recorded.
UNKNOWN_START = "unknown (a file written before the start was recorded)"


def _resolution(disc: Discretisation) -> tuple:
    """What a state's arrays depend on: the degree, the grids and (for its multipliers and
    Jacobian) the multipliers' directions."""
    return disc.degree, disc.grid, disc.n_rot or disc.grid, disc.multipliers


def _checksum(parameters: dict, arrays: dict[str, np.ndarray], scalars: dict) -> str:
    h = hashlib.sha256()
    h.update(json.dumps(parameters, sort_keys=True).encode())
    h.update(json.dumps(scalars, sort_keys=True, default=float).encode())
    for key in sorted(arrays):
        value = np.ascontiguousarray(arrays[key])
        h.update(key.encode() + str((value.dtype.str, value.shape)).encode() + value.tobytes())
    return h.hexdigest()


def _contents(result: SteadyResult, stability: StabilityResult | None):
    basis = result.basis
    parameters = {
        "physics": result.physics.to_dict(),
        "discretisation": result.discretisation.to_dict(),
        "basis": basis.kind,
        "jacobian": result.problem.jacobian_method,
    }
    arrays = {
        "state/coefficients": result.shape.coefficients,
        "state/a": result.a,
        "state/multipliers": np.array(result.multipliers, float),
        "state/axes": np.asarray(result.axes, float),
        "state/S": result.stress.S,
        "state/S_bending": result.split["bending"].S,
        "state/S_flow": result.split["flow"].S,
        "state/residual_history": np.array(result.residual_history, float),
        "jacobian/gradients": result.gradients,
        "jacobian/basis_l": basis.l,
        "jacobian/basis_m": basis.m,
        "jacobian/basis_part": basis.part,
    }
    if result.jacobian is not None:
        arrays["jacobian/M"] = result.jacobian
    if stability is not None:
        arrays["stability/omega_R"] = stability.omega[:, 0]
        arrays["stability/omega_I"] = stability.omega[:, 1]
        arrays["stability/modes"] = stability.modes
        if stability.parts is not None:
            arrays["stability/mode_parts"] = stability.parts
    scalars = {
        "psi": float(result.psi), "D": float(result.D), "S_xz": float(result.stress.S_xz),
        "N1": float(result.stress.N1), "N2": float(result.stress.N2),
        "solves": int(result.solves), "seconds": float(result.seconds),
        "start": str(result.start),
    }  # fmt: skip
    return parameters, arrays, scalars


def write_steady(
    path: str | os.PathLike,
    result: SteadyResult,
    stability: StabilityResult | None = None,
    attributes: dict | None = None,
) -> Path:
    """Write a converged state (and its stability analysis) atomically to ``path``."""
    parameters, arrays, scalars = _contents(result, stability)

    def fill(f: h5py.File) -> None:
        stamp(f, FORMAT, FORMAT_VERSION, attributes or {}, _checksum(parameters, arrays, scalars))
        group = f.create_group("parameters")
        for key, value in parameters.items():
            group.attrs[key] = json.dumps(value) if isinstance(value, dict) else value
        for key, value in arrays.items():
            f.create_dataset(key, data=value)
        for key, value in scalars.items():
            f["state"].attrs[key] = value
        if stability is not None:
            f["stability"].attrs["basis"] = stability.basis

    return write_atomically(path, fill, sum(np.asarray(a).nbytes for a in arrays.values()))


def is_steady_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` is an HDF5 file of this format (False for anything else)."""
    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == FORMAT
    except (OSError, ValueError):
        return False


def read_steady(path: str | os.PathLike) -> SteadyFile:
    """Load a steady-state file (its checksum verified)."""
    path = Path(path)
    with open_file(path, FORMAT, "steady-state file") as f:
        attributes = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()}
        parameters = {
            k: json.loads(v) if k in ("physics", "discretisation") else v
            for k, v in f["parameters"].attrs.items()
        }
        arrays = {}
        f.visititems(lambda name, obj: arrays.__setitem__(name, obj[()])
                     if isinstance(obj, h5py.Dataset) else None)  # fmt: skip
        scalars = {k: (v.item() if isinstance(v, np.generic) else v)
                   for k, v in f["state"].attrs.items()}  # fmt: skip
        basis = f["stability"].attrs["basis"] if "stability" in f else None
    if attributes.get("checksum") != _checksum(parameters, arrays, scalars):
        raise ValueError(
            f"{path} is corrupted: its content does not match the checksum written with it"
        )
    stability = "stability/omega_R" in arrays
    return SteadyFile(
        physics=Physics.from_dict(parameters["physics"]),
        discretisation=Discretisation.from_dict(parameters["discretisation"]),
        coefficients=arrays["state/coefficients"],
        multipliers=arrays["state/multipliers"],
        summary=scalars,
        arrays={k.split("/", 1)[1]: v for k, v in arrays.items() if not k.startswith("stab")},
        omega=np.stack([arrays["stability/omega_R"], arrays["stability/omega_I"]], axis=1)
        if stability
        else None,
        modes=arrays.get("stability/modes"),
        mode_parts=arrays.get("stability/mode_parts"),
        stability_basis=basis,
        attributes=attributes,
        basis=str(parameters.get("basis", "symmetric")),
        jacobian_method=str(parameters.get("jacobian", "linearised")),
    )


def open_steady(path: str | os.PathLike):
    """A steady-state file as an :class:`xarray.Dataset`: the coefficients (l, m), the
    Jacobian (row, column), the eigenvalues (mode) and modes (mode, l, m), the summary and the
    parameters as attributes."""
    import xarray as xr  # costs ~0.5 s at start-up: only here

    s = read_steady(path)
    data = {
        "coefficients": (("l", "m"), s.coefficients, {"long_name": "radius coefficients r_lm"}),
        "multipliers": (("constraint",), s.multipliers, {"long_name": "lambda_A, lambda_V"}),
        "S": (("i", "j"), s.arrays["S"], {"long_name": "specific particle stress", "units": "1"}),
        "gradients": (("constraint", "column"), s.arrays["gradients"]),
    }
    if "M" in s.arrays:
        data["jacobian"] = (("row", "column"), s.arrays["M"], {"long_name": "d adot / d a"})
    if s.omega is not None:
        data["omega_R"] = (("mode",), s.omega[:, 0], {"long_name": "frequency", "units": "1/t"})
        data["omega_I"] = (("mode",), s.omega[:, 1], {"long_name": "growth rate", "units": "1/t"})
        data["modes"] = (("mode", "l", "m"), s.modes, {"long_name": "eigenmode coefficients"})
    attrs = {"physics": json.dumps(s.physics.to_dict()),
             "discretisation": json.dumps(s.discretisation.to_dict()),
             **{k: v for k, v in s.summary.items()},
             **{f"file_{k}": str(v) for k, v in s.attributes.items()}}  # fmt: skip
    return xr.Dataset(data, attrs=attrs)
