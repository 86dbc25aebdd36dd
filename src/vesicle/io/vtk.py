"""Export the surfaces of a run as a VTK time series (XML PolyData + a ParaView ``.pvd`` file).

Each saved step becomes ``surface_<step>.vtp``: the ``n_theta x n_phi`` grid points (row-major,
``index = i_theta * n_phi + j_phi``) followed by the north and the south pole, quadrilaterals
between neighbouring rings (periodic in ``phi``) and triangle fans from each pole to the first
and last ring, so the mesh is closed.  Cells are ordered counter-clockwise seen from outside
(outward orientation).  ``surface.pvd`` collects the files with ``timestep = t``.

Point data: ``mean_curvature``, ``normal``, ``radius`` and, for runs that kept their fields,
``tension`` and ``velocity``.  By default (``encoding="binary"``) the arrays are appended raw
after the XML, zlib-compressed (``vtkZLibDataCompressor``, UInt64 headers), as Float32 (points
and point data: what a viewer needs; the run file keeps double precision) and Int32 (cells):
about 5x smaller than ``encoding="ascii"``, which writes every value as text, in double
precision.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.io.files import RunData
from vesicle.sphere.transforms import evaluate

__all__ = ["ENCODINGS", "export_vtk", "surface_mesh"]

#: Encodings of the data arrays.
ENCODINGS = ("binary", "ascii")

logger = logging.getLogger(__name__)


def _check_every(every: object) -> int:
    if isinstance(every, bool) or not isinstance(every, int | np.integer) or every < 1:
        raise ValueError(f"every must be an integer >= 1 (export every k-th step), got {every!r}")
    return int(every)


def _cells(n_theta: int, n_phi: int) -> tuple[np.ndarray, np.ndarray]:
    """Connectivity and offsets (VTK convention) of the closed quad + pole-fan mesh."""
    ring = np.arange(n_phi)
    nxt = (ring + 1) % n_phi
    i = np.arange(n_theta - 1)[:, None]
    quads = np.stack(
        [i * n_phi + ring, (i + 1) * n_phi + ring, (i + 1) * n_phi + nxt, i * n_phi + nxt],
        axis=-1,
    ).reshape(-1, 4)
    north, south = n_theta * n_phi, n_theta * n_phi + 1
    last = (n_theta - 1) * n_phi
    north_fan = np.stack([np.full(n_phi, north), ring, nxt], axis=-1)
    south_fan = np.stack([np.full(n_phi, south), last + nxt, last + ring], axis=-1)
    connectivity = np.concatenate([quads.ravel(), north_fan.ravel(), south_fan.ravel()])
    sizes = np.concatenate([np.full(len(quads), 4), np.full(2 * n_phi, 3)])
    return connectivity.astype(np.int64), np.cumsum(sizes).astype(np.int64)


def _with_poles(values: np.ndarray) -> np.ndarray:
    """Grid values (..., n_theta, n_phi) as point data (n, ...): the grid, then each pole as
    the mean over its adjacent ring."""
    flat = values.reshape(*values.shape[:-2], -1)
    poles = np.stack([values[..., 0, :].mean(axis=-1), values[..., -1, :].mean(axis=-1)], -1)
    return np.concatenate([flat, poles], axis=-1).T


def surface_mesh(shape: Shape, fields: dict[str, np.ndarray] | None = None) -> dict:
    """Closed polygon mesh of a shape with point data.

    Parameters
    ----------
    shape : Shape
        The surface.
    fields : dict, optional
        ``{"tension": (n_theta, n_phi), "velocity": (3, n_theta, n_phi)}`` grid fields to add as
        point data (pole values: the mean over the adjacent ring).

    Returns
    -------
    dict
        ``points`` (n_theta * n_phi + 2, 3), ``connectivity`` and ``offsets`` (VTK cell arrays),
        and point data ``mean_curvature`` (n,), ``normal`` (n, 3), ``radius`` (n,).  Pole values:
        the radius series evaluated at ``theta = 0, pi``; mean curvature the mean over the
        adjacent ring; normal the normalised mean of the adjacent ring's normals (``(0, 0, +-1)``
        for shapes symmetric about the z axis).
    """
    n_theta, n_phi = shape.grid.shape
    r_poles = evaluate(shape.coefficients, np.array([0.0, np.pi]), np.zeros(2))
    poles = np.array([[0.0, 0.0, r_poles[0]], [0.0, 0.0, -r_poles[1]]])
    points = np.concatenate([shape.x.reshape(3, -1).T, poles])

    H = shape.mean_curvature
    normal = shape.normal
    pole_normals = np.stack([normal[:, 0].mean(axis=-1), normal[:, -1].mean(axis=-1)])
    pole_normals /= np.linalg.norm(pole_normals, axis=1, keepdims=True)
    connectivity, offsets = _cells(n_theta, n_phi)
    return {
        "points": points,
        "connectivity": connectivity,
        "offsets": offsets,
        "mean_curvature": np.concatenate([H.ravel(), [H[0].mean(), H[-1].mean()]]),
        "normal": np.concatenate([normal.reshape(3, -1).T, pole_normals]),
        "radius": np.concatenate([shape.radius.ravel(), r_poles]),
        **{name: _with_poles(np.asarray(v, float)) for name, v in (fields or {}).items()},
    }


class _Arrays:
    """DataArray elements of one file: text (``ascii``) or offsets into the appended block."""

    def __init__(self, encoding: str):
        self.encoding = encoding
        self.appended: list[bytes] = []
        self.offset = 0

    def add(self, parent: ET.Element, name: str, values: np.ndarray, components: int = 1) -> None:
        integer = np.issubdtype(values.dtype, np.integer)
        if self.encoding == "ascii":
            kind = "Int64" if integer else "Float64"
        else:
            kind = "Int32" if integer else "Float32"
        attrs = {"type": kind, "Name": name}
        if components > 1:
            attrs["NumberOfComponents"] = str(components)
        if self.encoding == "ascii":
            element = ET.SubElement(parent, "DataArray", {**attrs, "format": "ascii"})
            element.text = " ".join(map(repr, values.ravel().tolist()))
            return
        raw = np.ascontiguousarray(values, dtype="<i4" if integer else "<f4").tobytes()
        block = zlib.compress(raw, 6)
        # one block: count, uncompressed block size, last (partial) block size, compressed size
        header = np.array([1, len(raw), len(raw), len(block)], dtype="<u8").tobytes()
        ET.SubElement(parent, "DataArray", {**attrs, "format": "appended",
                                            "offset": str(self.offset)})  # fmt: skip
        self.appended.append(header + block)
        self.offset += len(header) + len(block)


#: Point arrays beyond the geometry, with their number of components.
_FIELD_ARRAYS = {"tension": 1, "velocity": 3}


def _write_vtp(path: Path, mesh: dict[str, np.ndarray], encoding: str = "binary") -> Path:
    attrs = {"type": "PolyData", "version": "1.0", "byte_order": "LittleEndian"}
    if encoding == "binary":
        attrs.update(header_type="UInt64", compressor="vtkZLibDataCompressor")
    root = ET.Element("VTKFile", attrs)
    piece = ET.SubElement(ET.SubElement(root, "PolyData"), "Piece")
    piece.attrib.update(
        NumberOfPoints=str(len(mesh["points"])),
        NumberOfVerts="0",
        NumberOfLines="0",
        NumberOfStrips="0",
        NumberOfPolys=str(len(mesh["offsets"])),
    )
    arrays = _Arrays(encoding)
    data = ET.SubElement(piece, "PointData", {"Scalars": "mean_curvature", "Normals": "normal"})
    for name, components in {"mean_curvature": 1, "normal": 3, "radius": 1,
                             **_FIELD_ARRAYS}.items():  # fmt: skip
        if name in mesh:
            arrays.add(data, name, mesh[name], components)
    arrays.add(ET.SubElement(piece, "Points"), "Points", mesh["points"], 3)
    polys = ET.SubElement(piece, "Polys")
    arrays.add(polys, "connectivity", mesh["connectivity"])
    arrays.add(polys, "offsets", mesh["offsets"])
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode")
    with open(path, "wb") as f:
        f.write(b'<?xml version="1.0" encoding="utf-8"?>\n')
        if encoding == "ascii":
            f.write(text.encode())
        else:  # the raw block goes between the XML and the closing tag
            head, closing = text.rsplit("</VTKFile>", 1)
            f.write(head.encode() + b'  <AppendedData encoding="raw">\n   _')
            f.write(b"".join(arrays.appended))
            f.write(b"\n  </AppendedData>\n</VTKFile>" + closing.encode() + b"\n")
    return path


def _write_pvd(path: Path, entries: list[tuple[float, Path]]) -> Path:
    root = ET.Element(
        "VTKFile", {"type": "Collection", "version": "0.1", "byte_order": "LittleEndian"}
    )
    collection = ET.SubElement(root, "Collection")
    for time, file in entries:
        attrs = {"timestep": repr(float(time)), "group": "", "part": "0", "file": file.name}
        ET.SubElement(collection, "DataSet", attrs)
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def export_vtk(
    run: RunData, outdir: str | Path, every: int = 1, encoding: str = "binary"
) -> list[Path]:
    """Write the surfaces at the saved steps as VTK PolyData files plus a ``.pvd`` collection.

    Parameters
    ----------
    run : RunData
        The run; shapes are evaluated on its own grid.
    outdir : str or Path
        Output directory; created if needed.
    every : int
        Export saved steps ``0, every, 2 every, ...``.
    encoding : {"binary", "ascii"}
        Of the data arrays (see the module docstring).

    Returns
    -------
    list of Path
        The ``surface_<step>.vtp`` files (``<step>`` the saved-step index, six digits) in time
        order, then ``surface.pvd``.

    Raises
    ------
    ValueError
        If ``every`` is not an integer >= 1.
    """
    every = _check_every(every)
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {ENCODINGS}, got {encoding!r}")
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    times = np.asarray(run.series["t"], dtype=float) if "t" in run.series else None
    entries: list[tuple[float, Path]] = []
    for i in range(0, run.n_saved, every):
        time = float(times[i]) if times is not None else float(i)
        fields = {}
        if "sigma" in run.fields and np.all(np.isfinite(run.fields["sigma"][i])):
            fields = {"tension": run.fields["sigma"][i], "velocity": run.fields["velocity"][i]}
        mesh = surface_mesh(run.shape(i), fields)
        path = _write_vtp(outdir / f"surface_{i:06d}.vtp", mesh, encoding)
        entries.append((time, path))
    pvd = _write_pvd(outdir / "surface.pvd", entries)
    logger.info("wrote %d VTK surfaces and %s", len(entries), pvd)
    return [path for _, path in entries] + [pvd]
