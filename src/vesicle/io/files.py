"""HDF5 run files: parameters, time series, shapes at saved steps, and the restart checkpoint.

Layout of a run file (all written by :func:`write_run`):

``/`` attributes
    ``format = "vesicle-run"``, ``format_version``, ``vesicle_version``, ``created``, ``updated``.
``/parameters`` attributes
    the run parameters (:meth:`vesicle.dynamics.integrators.RunParameters.to_dict`): ``physics``,
    ``discretisation`` and ``solver`` (the parameter objects' dictionaries, as JSON strings) and
    the run's own settings (``t_end, save_every, integrator, ...``).  Files of format version 1
    hold the flat ``v, lam, chi, flow, flow_gradient, grid, degree, tolerances, ...``; both read
    back to equal :class:`~vesicle.dynamics.integrators.RunParameters`.
``/series/<name>``
    one entry per saved step for each name of :data:`SERIES` (the one list of saved series,
    with each one's trailing shape and meaning; :data:`OPTIONAL_SERIES` only when asked for),
    and, unless the run opted out, the :data:`FIELDS` ``sigma`` (t, theta, phi) and
    ``velocity`` (t, i, theta, phi) on the grid.  netCDF dimension scales (``t``, ``i``, ``j``,
    ``l``, ``theta``, ``phi``) make the group an xarray Dataset as it is.
``/shapes/coefficients``
    (n, N+1, N+1) complex radius coefficients at the saved steps (SPEC §2 normalisation).
``/checkpoint``
    the integrator state to resume from (arrays and attributes; see
    :mod:`vesicle.dynamics.integrators`).

Every write goes to ``FILE.tmp`` and is then renamed over ``FILE``, so an interrupted write never
corrupts an existing file.  The root attribute ``checksum`` (:func:`content_checksum`) is
verified on reading: a damaged or altered file is refused with a clear error.
"""

from __future__ import annotations

import errno
import gc
import hashlib
import io
import json
import logging
import os
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import h5py
import numpy as np

from vesicle._version import __version__
from vesicle.geometry.surface import Shape
from vesicle.sphere.grid import SphereGrid

log = logging.getLogger(__name__)

__all__ = [
    "FIELDS",
    "FORMAT",
    "FORMAT_VERSION",
    "OPTIONAL_SERIES",
    "SERIES",
    "VISCOUS_SERIES",
    "RunData",
    "content_checksum",
    "open_file",
    "open_run",
    "read_run",
    "series_dtype",
    "series_shape",
    "stamp",
    "write_atomically",
    "write_run",
    "write_text_atomically",
]

FORMAT = "vesicle-run"
FORMAT_VERSION = 2

#: Series stored per saved step: trailing shape (``"N+1"``: one per degree), long name, units.
#: Lengths in units of a = sqrt(A / 4 pi), times of mu a^3 / kappa, energies of kappa; the
#: stresses are the specific stress of SPEC §11 (dimensionless).
SERIES = {
    "t": ((), "time", "mu a^3 / kappa"),
    "psi": ((), "inclination angle in the x-z plane", "rad"),
    "D": ((), "deformation (L1 - L2) / (L1 + L2) in the x-z plane", "1"),
    "L": ((3,), "principal-axis lengths, descending", "a"),
    "axes": ((3, 3), "principal axes: row k is the unit vector of axis k", "1"),
    "area": ((), "area", "a^2"),
    "volume": ((), "volume", "a^3"),
    "reduced_volume": ((), "reduced volume", "1"),
    "bending_energy": ((), "bending energy", "kappa"),
    "S": ((3, 3), "specific particle stress (SPEC §11)", "1"),
    "S_bending": ((3, 3), "bending part S^B of S (nan unless asked for)", "1"),
    "S_flow": ((3, 3), "flow-resistance part S^V of S (nan unless asked for)", "1"),
    "S_membrane": ((3, 3), "the membrane viscosity's part of S: the moment of its viscous load "
                   "(runs with Bq > 0 only)", "1"),
    "S_xz": ((), "specific shear stress", "1"),
    "N1": ((), "first normal stress difference S_xx - S_zz (scaled by |chi|)", "1"),
    "N2": ((), "second normal stress difference S_zz - S_yy (scaled by |chi|)", "1"),
    "dt": ((), "the step that reached this time", "mu a^3 / kappa"),
    "outer_iterations": ((), "Schur GMRES iterations of this state's solve", "1"),
    "inner_iterations": ((), "A_uu GMRES iterations of this state's solve", "1"),
    "centroid": ((3,), "volume centroid before re-centring", "a"),
    "area_correction": ((), "total relative area restored by drift control so far", "1"),
    "volume_correction": ((), "total relative volume restored by drift control so far", "1"),
    "spectrum": (("N+1",), "modal energy E_l of the radius (SPEC (3.5))", "a^2"),
}

#: Series stored only when the run asks for them (``split_stress``).
OPTIONAL_SERIES = ("S_bending", "S_flow")

#: Series stored only by runs of a viscous membrane (``Bq > 0``).
VISCOUS_SERIES = ("S_membrane",)

#: Fields on the grid per saved step (``save_fields``): dimensions after ``t``, long name, units.
#: ``theta`` and ``phi`` are the grid's colatitudes (Gauss-Legendre) and longitudes.
FIELDS = {
    "sigma": (("theta", "phi"), "membrane tension", "kappa / a^2"),
    "velocity": (("i", "theta", "phi"), "membrane velocity (lab frame)", "kappa / (mu a^2)"),
}

#: Dimension names of the series' trailing axes (netCDF dimensions of the HDF5 layout).
_TRAILING = {(): (), (3,): ("i",), (3, 3): ("i", "j"), ("N+1",): ("l",)}


#: Series that count (stored as integers).
COUNTS = ("outer_iterations", "inner_iterations")


def series_dtype(name: str) -> type:
    """``int64`` for the counts, else ``float64``."""
    return np.int64 if name in COUNTS else np.float64


def series_shape(name: str, degree: int) -> tuple[int, ...]:
    """The trailing shape of series ``name`` for shape degree ``degree``."""
    return tuple(degree + 1 if n == "N+1" else n for n in SERIES[name][0])


@dataclass
class RunData:
    """Everything in a run file, in memory.

    ``series`` maps the names of :data:`SERIES` to arrays whose first axis runs
    over the saved steps; ``coefficients`` holds the shapes at those steps.
    """

    parameters: dict
    series: dict[str, np.ndarray]
    coefficients: np.ndarray  # (n, N+1, N+1) complex
    checkpoint: dict | None = None
    attributes: dict = field(default_factory=dict)
    fields: dict[str, np.ndarray] = field(default_factory=dict)  # FIELDS, per saved step

    @property
    def n_saved(self) -> int:
        return int(self.coefficients.shape[0])

    def parameter(self, name: str, default=None):
        """A stored parameter by its flat name (``v``, ``lam``, ``grid``, ``t_end``, ...): from the
        ``physics`` / ``discretisation`` / ``solver`` groups, or from the flat layout of files
        written before the parameter objects."""
        p = self.parameters
        for group in ("physics", "discretisation", "solver"):
            if isinstance(p.get(group), dict) and name in p[group]:
                return p[group][name]
        return p.get(name, default)

    @property
    def grid(self) -> int:
        return int(self.parameter("grid"))

    @property
    def degree(self) -> int:
        return int(self.parameter("degree"))

    def __getattr__(self, name: str) -> np.ndarray:
        series = self.__dict__.get("series", {})
        if name in series:
            return series[name]
        raise AttributeError(name)

    def shape(self, index: int = -1, grid: int | None = None) -> Shape:
        """The shape at saved step ``index`` (default: the last), on its grid or another."""
        return Shape(self.coefficients[index], self.grid if grid is None else grid)


def _attr_value(value):
    if isinstance(value, dict | list | tuple) or value is None:
        return json.dumps(value)
    return value


def _from_attr(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    if isinstance(value, np.generic):
        return value.item()
    return value


def content_checksum(run: RunData) -> str:
    """SHA-256 of what a resume and the analysis rely on: the parameters, the series, the saved
    shapes and the checkpoint (arrays by their bytes, the rest as sorted JSON)."""
    h = hashlib.sha256()

    def add(name: str, value) -> None:
        h.update(name.encode())
        if isinstance(value, np.ndarray):
            h.update(str((value.dtype.str, value.shape)).encode())
            h.update(np.ascontiguousarray(value).tobytes())
        else:
            h.update(json.dumps(plain(value), sort_keys=True).encode())

    for key in sorted(run.parameters):
        add("parameters/" + key, run.parameters[key])
    for key in sorted(run.series):
        add("series/" + key, np.asarray(run.series[key]))
    add("shapes/coefficients", np.asarray(run.coefficients))
    for key in sorted(run.fields):  # absent from files before fields: their checksums hold
        add("fields/" + key, np.asarray(run.fields[key]))
    for key in sorted(run.checkpoint or {}):
        add("checkpoint/" + key, run.checkpoint[key])
    return h.hexdigest()


def grid_coordinates(n_theta: int) -> dict[str, np.ndarray]:
    """The ``theta`` (colatitude) and ``phi`` (longitude) coordinates of a run's grid."""
    grid = SphereGrid(n_theta)
    return {"theta": np.asarray(grid.theta), "phi": np.asarray(grid.phi)}


_COORDINATE_MEANING = {
    "theta": ("colatitude of the grid (Gauss-Legendre nodes)", "rad"),
    "phi": ("longitude of the grid", "rad"),
}


def flat_parameters(run: RunData) -> dict:
    """The run's physics and discretisation as flat attributes (``lam``, ``grid``, ``flow``:
    the flow's name, ...) with the package version, beside the JSON of the parameter objects:
    what an xarray or netCDF user looks for (``ds.attrs["lam"]``)."""
    flat = {}
    for group in ("physics", "discretisation"):
        table = run.parameters.get(group)
        if not isinstance(table, dict):
            continue
        for key, value in table.items():
            if key == "flow" and isinstance(value, dict):
                value = value.get("name")
            if isinstance(value, bool | int | float | str) and not isinstance(value, bool):
                flat[key] = value
    version = run.attributes.get("vesicle_version")
    if version is not None:
        flat["vesicle_version"] = str(version)
    return flat


def _label_series(group: h5py.Group, run: RunData) -> None:
    """netCDF dimensions for the series and fields (``t``, the trailing ``i``, ``j``, ``l`` and
    the grid's ``theta``, ``phi``) and each one's ``long_name`` and ``units``: the group opens
    in xarray (engine h5netcdf) as is."""
    if "t" not in group:
        return
    group["t"].make_scale("t")
    flat = {"vesicle_version": __version__, **flat_parameters(run)}  # written by this version
    for key, value in flat.items():  # xarray.open_dataset(group="series") shows them
        group.attrs[key] = value
    degree = run.parameter("degree")
    coordinates = {
        "i": np.arange(3), "j": np.arange(3),
        "l": np.arange(int(degree) + 1) if degree is not None else np.zeros(0),
    }  # fmt: skip
    if run.fields:
        coordinates.update(grid_coordinates(int(run.parameter("grid"))))
    for name, values in coordinates.items():
        if values.size and name not in group:
            d = group.create_dataset(name, data=values)
            d.attrs["vesicle_dimension"] = 1
            if name in _COORDINATE_MEANING:
                d.attrs["long_name"], d.attrs["units"] = _COORDINATE_MEANING[name]
            d.make_scale(name)
    for key in group:
        ds = group[key]
        if key in FIELDS:
            ds.attrs["long_name"], ds.attrs["units"] = FIELDS[key][1], FIELDS[key][2]
            for axis, dim in enumerate(("t", *FIELDS[key][0])):
                ds.dims[axis].attach_scale(group[dim])
            continue
        if key in SERIES:
            ds.attrs["long_name"] = SERIES[key][1]
            ds.attrs["units"] = SERIES[key][2]
        if key == "t" or "vesicle_dimension" in ds.attrs:
            continue
        trailing = _TRAILING.get(SERIES[key][0], ()) if key in SERIES else ()
        for axis, dim in enumerate(("t", *trailing)):
            if axis < ds.ndim and dim in group and group[dim].shape[0] == ds.shape[axis]:
                ds.dims[axis].attach_scale(group[dim])


#: Root attributes that write_run sets itself.
_RESERVED = {"format", "format_version", "vesicle_version", "created", "updated", "checksum",
             "numpy_version", "scipy_version", "numba_version", "h5py_version"}  # fmt: skip


def _library_versions() -> dict[str, str]:
    """The versions of the libraries whose numerics a result depends on."""
    out = {"numpy_version": np.__version__, "h5py_version": h5py.__version__}
    for name in ("scipy", "numba"):
        try:
            out[f"{name}_version"] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[f"{name}_version"] = "not installed"
    return out


def write_text_atomically(path: str | os.PathLike, text: str) -> Path:
    """``path`` replaced by ``text`` at once (a crash, Ctrl-C or a full disk leaves the old
    file or the new one, and no partial one): the JSON and HTML outputs' writer."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


@contextmanager
def text_written_atomically(path: str | os.PathLike) -> Iterator[io.StringIO]:
    """A text buffer that replaces ``path`` at once when the block ends without an error (CSV
    tables: ``csv.writer`` on it as on a file); nothing is written if the block raises."""
    buffer = io.StringIO()
    yield buffer
    write_text_atomically(path, buffer.getvalue())


def stamped(out: dict, **parameters) -> dict:
    """The one stamp of a JSON output: ``vesicle_version``, then the given parameter objects
    (their ``to_dict()``) or values, then ``out`` (``--json`` objects, sweep results, neutral
    curves and their checkpoints, the steady summaries)."""
    extra = {k: (v.to_dict() if hasattr(v, "to_dict") else v) for k, v in parameters.items()}
    return {"vesicle_version": __version__, **extra, **out}


def plain(value, nonfinite_as_none: bool = False):
    """A JSON-able form of ``value``: dicts with string keys, lists for tuples and arrays,
    Python scalars for NumPy ones; with ``nonfinite_as_none`` NaN and infinities become None
    (strict JSON).  Checksums use the default, which keeps them as they were."""
    if isinstance(value, dict):
        return {str(k): plain(x, nonfinite_as_none) for k, x in value.items()}
    if isinstance(value, list | tuple):
        return [plain(x, nonfinite_as_none) for x in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist(), nonfinite_as_none)
    if isinstance(value, np.generic):
        value = value.item()
    if nonfinite_as_none and isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_atomically(path: str | os.PathLike, fill, nbytes: int) -> Path:
    """Write an HDF5 file by ``fill(h5py.File)`` to ``path.tmp`` and rename it over ``path``.

    ``nbytes`` (the arrays' size) is checked against the free space first; an interrupted or
    failed write (a full disk) leaves the previous file intact and removes the partial one.
    The one atomic writer of run, steady-state and sweep files.
    """
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    _check_space(path, nbytes)
    try:
        with h5py.File(tmp, "w") as f:
            fill(f)
            f.flush()
        os.replace(tmp, path)
    except (OSError, RuntimeError) as err:  # HDF5 reports a full disk as a RuntimeError
        _release_failed_file()
        tmp.unlink(missing_ok=True)
        free = shutil.disk_usage(path.parent).free if path.parent.is_dir() else 0
        raise OSError(
            errno.EIO, f"writing {path} failed ({err}; {free / 1e6:.1f} MB free there)"
        ) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def stamp(f: h5py.File, kind: str, version: int, attributes: dict, checksum: str) -> str:
    """The root attributes every vesicle file carries: format, versions, times, checksum and
    the caller's (e.g. the command line); returns the creation time."""
    now = datetime.now(UTC).isoformat(timespec="seconds")
    f.attrs["format"] = kind
    f.attrs["format_version"] = version
    f.attrs["vesicle_version"] = __version__
    f.attrs["created"] = attributes.get("created", now)
    f.attrs["updated"] = now
    f.attrs["checksum"] = checksum
    for key, value in _library_versions().items():
        f.attrs[key] = value
    for key, value in attributes.items():
        if key not in _RESERVED:
            f.attrs[key] = str(value)
    return str(f.attrs["created"])


def write_run(path: str | os.PathLike, run: RunData) -> Path:
    """Write ``run`` atomically to ``path`` (HDF5), with its :func:`content_checksum`
    (:func:`write_atomically`)."""
    created = {}

    def fill(f: h5py.File) -> None:
        created["at"] = stamp(f, FORMAT, FORMAT_VERSION, run.attributes, content_checksum(run))
        params = f.create_group("parameters")
        for key, value in run.parameters.items():
            params.attrs[key] = _attr_value(value)
        series = f.create_group("series")
        for key, value in run.series.items():
            series.create_dataset(key, data=np.asarray(value))
        for key, value in run.fields.items():
            series.create_dataset(key, data=np.asarray(value))
        _label_series(series, run)
        f.create_group("shapes").create_dataset("coefficients", data=run.coefficients)
        if run.checkpoint is not None:
            ck = f.create_group("checkpoint")
            for key, value in run.checkpoint.items():
                if isinstance(value, np.ndarray):
                    ck.create_dataset(key, data=value)
                else:
                    ck.attrs[key] = _attr_value(value)

    path = write_atomically(path, fill, _stored_bytes(run))
    run.attributes.setdefault("created", created["at"])
    return path


def _stored_bytes(run: RunData) -> int:
    arrays = [*run.series.values(), *run.fields.values(), run.coefficients]
    arrays += [v for v in (run.checkpoint or {}).values() if isinstance(v, np.ndarray)]
    return sum(np.asarray(a).nbytes for a in arrays)


def _check_space(path: Path, nbytes: int) -> None:
    """Refuse a write that cannot fit (the data plus 5 % and 48 kB of HDF5 metadata: a 21-step
    run with fields at 12 x 24 holds 212 kB of arrays in a 242 kB file) before HDF5 runs out of
    space half-way."""
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        return  # the write itself reports it
    need = int(1.05 * nbytes) + 48 * 1024
    free = shutil.disk_usage(folder).free
    if free < need:
        raise OSError(
            errno.ENOSPC,
            f"not enough space to write {path}: it needs about {need / 1e6:.1f} MB and "
            f"{free / 1e6:.1f} MB are free there",
        )


def _release_failed_file() -> None:
    """Collect the HDF5 objects of a write that failed (a full disk) now, with their release
    errors ('file write failed', already reported by the write) logged, not printed."""
    previous = sys.unraisablehook

    def quiet(unraisable):
        log.debug("after a failed write: %s", unraisable.exc_value)

    sys.unraisablehook = quiet
    try:
        gc.collect()
    finally:
        sys.unraisablehook = previous


def open_run(path: str | os.PathLike):
    """A run file's series as an :class:`xarray.Dataset`: coordinate ``t``, data variables with
    ``long_name`` and ``units``, the shapes' radius coefficients as ``coefficients`` (``t``,
    ``l``, ``m``; complex), and the parameters, package version and format as attributes
    (dictionaries as JSON strings, as netCDF attributes must be)."""
    # xarray (and pandas under it) is imported only here: it costs ~0.5 s at start-up
    import xarray as xr

    run = read_run(path)
    t = run.series["t"]
    data = {}
    for key, value in run.series.items():
        if key == "t":
            continue
        shape = SERIES[key][0] if key in SERIES else ()
        dims = ("t", *_TRAILING.get(shape, tuple(f"{key}_{k}" for k in range(value.ndim - 1))))
        attrs = {"long_name": SERIES[key][1], "units": SERIES[key][2]} if key in SERIES else {}
        data[key] = (dims[: value.ndim], value, attrs)
    meaning = {"long_name": "radius coefficients r_lm (SPEC §2)", "units": "a"}
    data["coefficients"] = (("t", "l", "m"), run.coefficients, meaning)
    for key, value in run.fields.items():
        dims, long_name, units = FIELDS[key]
        data[key] = (("t", *dims), value, {"long_name": long_name, "units": units})
    attrs = {k: json.dumps(plain(v)) if isinstance(v, dict | list) else v
             for k, v in run.parameters.items()}  # fmt: skip
    attrs.update({f"file_{k}": str(v) for k, v in run.attributes.items()})
    attrs.update({k: v for k, v in flat_parameters(run).items() if k not in attrs})
    coords = {"t": ("t", t, {"long_name": SERIES["t"][1], "units": SERIES["t"][2]})}
    n = run.coefficients.shape[-1]
    coords["l"] = ("l", np.arange(n), {"long_name": "spherical-harmonic degree l"})
    coords["m"] = ("m", np.arange(n), {"long_name": "spherical-harmonic order m >= 0 "
                                       "(r_l,-m = conj(r_lm))"})  # fmt: skip
    if run.fields:
        for name, values in grid_coordinates(run.grid).items():
            long_name, units = _COORDINATE_MEANING[name]
            coords[name] = (name, values, {"long_name": long_name, "units": units})
    return xr.Dataset(data, coords=coords, attrs=attrs)


def open_file(path: str | os.PathLike, kind: str, what: str) -> h5py.File:
    """``path`` opened for reading, if it is an HDF5 file of format ``kind`` (else a
    ``FileNotFoundError`` or ``ValueError`` naming ``what`` it should have been)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no {what} at {path}")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise ValueError(f"{path} is not a readable HDF5 file: {err}") from None
    if _from_attr(f.attrs.get("format")) != kind:
        f.close()
        raise ValueError(f"{path} is not a vesicle {what}")
    return f


def read_run(path: str | os.PathLike) -> RunData:
    """Load a run file written by :func:`write_run`."""
    path = Path(path)
    with open_file(path, FORMAT, "run file") as f:
        attributes = {k: _from_attr(v) for k, v in f.attrs.items()}
        parameters = {k: _from_attr(v) for k, v in f["parameters"].attrs.items()}
        stored = {
            k: f["series"][k][()]
            for k in f["series"]
            if "vesicle_dimension" not in f["series"][k].attrs
        }
        series = {k: v for k, v in stored.items() if k not in FIELDS}
        fields = {k: v for k, v in stored.items() if k in FIELDS}
        coefficients = f["shapes"]["coefficients"][()]
        checkpoint = None
        if "checkpoint" in f:
            ck = f["checkpoint"]
            checkpoint = {k: _from_attr(v) for k, v in ck.attrs.items()}
            checkpoint.update({k: ck[k][()] for k in ck})
    run = RunData(parameters, series, coefficients, checkpoint, attributes, fields)
    stored = attributes.get("checksum")
    if stored is not None and stored != content_checksum(run):
        raise ValueError(
            f"{path} is corrupted: its content does not match the checksum written with it "
            "(the file was changed or damaged after it was written)"
        )
    return run
