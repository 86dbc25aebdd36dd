"""Export the surfaces of a run as a VTK time series (XML PolyData + a ParaView ``.pvd`` file).

Each saved step becomes ``surface_<step>.vtp``: the ``n_theta x n_phi`` grid points (row-major,
``index = i_theta * n_phi + j_phi``) followed by the north and the south pole, quadrilaterals
between neighbouring rings (periodic in ``phi``) and triangle fans from each pole to the first
and last ring, so the mesh is closed.  Cells are ordered counter-clockwise seen from outside
(outward orientation).  ``surface.pvd`` collects the files with ``timestep = t``.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .io import RunData
from .sphere.transforms import evaluate
from .surface import Shape

__all__ = ["export_vtk", "surface_mesh"]

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


def surface_mesh(shape: Shape) -> dict[str, np.ndarray]:
    """Closed polygon mesh of a shape with point data.

    Parameters
    ----------
    shape : Shape
        The surface.

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
    }


def _data_array(parent: ET.Element, name: str, values: np.ndarray, components: int = 1) -> None:
    kind = "Int64" if np.issubdtype(values.dtype, np.integer) else "Float64"
    attrs = {"type": kind, "Name": name, "format": "ascii"}
    if components > 1:
        attrs["NumberOfComponents"] = str(components)
    element = ET.SubElement(parent, "DataArray", attrs)
    element.text = " ".join(map(repr, values.ravel().tolist()))


def _write_vtp(path: Path, mesh: dict[str, np.ndarray]) -> Path:
    root = ET.Element(
        "VTKFile", {"type": "PolyData", "version": "1.0", "byte_order": "LittleEndian"}
    )
    piece = ET.SubElement(ET.SubElement(root, "PolyData"), "Piece")
    piece.attrib.update(
        NumberOfPoints=str(len(mesh["points"])),
        NumberOfVerts="0",
        NumberOfLines="0",
        NumberOfStrips="0",
        NumberOfPolys=str(len(mesh["offsets"])),
    )
    data = ET.SubElement(piece, "PointData", {"Scalars": "mean_curvature", "Normals": "normal"})
    _data_array(data, "mean_curvature", mesh["mean_curvature"])
    _data_array(data, "normal", mesh["normal"], 3)
    _data_array(data, "radius", mesh["radius"])
    _data_array(ET.SubElement(piece, "Points"), "Points", mesh["points"], 3)
    polys = ET.SubElement(piece, "Polys")
    _data_array(polys, "connectivity", mesh["connectivity"])
    _data_array(polys, "offsets", mesh["offsets"])
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
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


def export_vtk(run: RunData, outdir: str | Path, every: int = 1) -> list[Path]:
    """Write the surfaces at the saved steps as VTK PolyData files plus a ``.pvd`` collection.

    Parameters
    ----------
    run : RunData
        The run; shapes are evaluated on its own grid.
    outdir : str or Path
        Output directory; created if needed.
    every : int
        Export saved steps ``0, every, 2 every, ...``.

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
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    times = np.asarray(run.series["t"], dtype=float) if "t" in run.series else None
    entries: list[tuple[float, Path]] = []
    for i in range(0, run.n_saved, every):
        time = float(times[i]) if times is not None else float(i)
        path = _write_vtp(outdir / f"surface_{i:06d}.vtp", surface_mesh(run.shape(i)))
        entries.append((time, path))
    pvd = _write_pvd(outdir / "surface.pvd", entries)
    logger.info("wrote %d VTK surfaces and %s", len(entries), pvd)
    return [path for _, path in entries] + [pvd]
