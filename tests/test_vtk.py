"""VTK export of the surfaces of a run (vesicle.vtk)."""

import xml.etree.ElementTree as ET
from collections import Counter

import numpy as np
import pytest

from vesicle import Shape
from vesicle.io import RunData
from vesicle.sphere.transforms import evaluate
from vesicle.vtk import export_vtk, surface_mesh

GRID = 8


def tilted(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def synthetic_run(n: int = 5) -> RunData:
    base = Shape.spheroid(0.9, grid=GRID, degree=6)
    t = np.linspace(0.0, 2.0, n)
    psi = 0.3 * np.exp(-t) * np.cos(3.0 * t)
    coefficients = np.stack([base.rotated(tilted(p)).coefficients for p in psi])
    params = {"v": 0.9, "lam": 1.0, "chi": 1.0, "grid": GRID, "degree": 6}
    return RunData(parameters=params, series={"t": t, "psi": psi}, coefficients=coefficients)


def read_array(piece: ET.Element, section: str, name: str) -> np.ndarray:
    element = piece.find(f"{section}/DataArray[@Name='{name}']")
    assert element is not None, (section, name)
    dtype = int if element.get("type") == "Int64" else float
    values = np.array(element.text.split(), dtype=dtype)
    components = int(element.get("NumberOfComponents", "1"))
    return values.reshape(-1, components) if components > 1 else values


def parse_vtp(path):
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData"
    piece = root.find("PolyData/Piece")
    arrays = {
        name: read_array(piece, section, name)
        for section, names in (
            ("Points", ["Points"]),
            ("Polys", ["connectivity", "offsets"]),
            ("PointData", ["mean_curvature", "normal", "radius"]),
        )
        for name in names
    }
    return piece, arrays


def cells_of(arrays) -> list[np.ndarray]:
    offsets = arrays["offsets"]
    starts = np.concatenate([[0], offsets[:-1]])
    return [arrays["connectivity"][a:b] for a, b in zip(starts, offsets, strict=True)]


def test_export_writes_closed_meshes_and_collection(tmp_path):
    run = synthetic_run()
    paths = export_vtk(run, tmp_path / "vtk")
    assert [p.name for p in paths] == [f"surface_{i:06d}.vtp" for i in range(5)] + ["surface.pvd"]
    n_theta, n_phi = GRID, 2 * GRID
    n_points = n_theta * n_phi + 2
    n_cells = (n_theta - 1) * n_phi + 2 * n_phi
    for i, path in enumerate(paths[:-1]):
        piece, arrays = parse_vtp(path)
        assert int(piece.get("NumberOfPoints")) == n_points
        assert int(piece.get("NumberOfPolys")) == n_cells
        assert arrays["Points"].shape == (n_points, 3)
        assert arrays["normal"].shape == (n_points, 3)
        assert arrays["mean_curvature"].shape == arrays["radius"].shape == (n_points,)
        cells = cells_of(arrays)
        assert len(cells) == n_cells
        assert Counter(len(c) for c in cells) == {4: (n_theta - 1) * n_phi, 3: 2 * n_phi}
        used = arrays["connectivity"]
        assert used.min() == 0 and used.max() == n_points - 1
        assert set(used.tolist()) == set(range(n_points))
        shape = run.shape(i)
        np.testing.assert_allclose(arrays["Points"][:-2], shape.x.reshape(3, -1).T, rtol=1e-14)
        np.testing.assert_allclose(arrays["radius"][:-2], shape.radius.ravel(), rtol=1e-14)


def test_mesh_is_watertight_and_outward():
    shape = Shape.spheroid(0.9, grid=GRID, degree=6).rotated(tilted(0.4))
    mesh = surface_mesh(shape)
    cells = cells_of(mesh)
    directed = Counter((int(c[k]), int(c[(k + 1) % len(c)])) for c in cells for k in range(len(c)))
    assert max(directed.values()) == 1  # consistently oriented: no directed edge twice
    undirected = Counter(tuple(sorted(edge)) for edge in directed)
    assert set(undirected.values()) == {2}  # closed: every edge shared by exactly two cells
    for edge in directed:
        assert edge[::-1] in directed
    # Signed volume by fanning each cell into triangles: positive (outward) and close to exact.
    p = mesh["points"]
    volume = sum(
        np.linalg.det(p[[c[0], c[k], c[k + 1]]]) / 6.0 for c in cells for k in range(1, len(c) - 1)
    )
    assert 0.85 * shape.volume < volume < shape.volume  # inscribed polyhedron of a convex body


def test_pole_values():
    shape = Shape.spheroid(0.9, grid=GRID, degree=6)
    mesh = surface_mesh(shape)
    r = evaluate(shape.coefficients, np.array([0.0, np.pi]), np.zeros(2))
    np.testing.assert_allclose(mesh["points"][-2:], [[0, 0, r[0]], [0, 0, -r[1]]])
    np.testing.assert_allclose(mesh["normal"][-2:], [[0, 0, 1], [0, 0, -1]], atol=1e-12)
    np.testing.assert_allclose(mesh["radius"][-2:], r)
    H = shape.mean_curvature
    np.testing.assert_allclose(mesh["mean_curvature"][-2:], [H[0].mean(), H[-1].mean()])
    np.testing.assert_allclose(np.linalg.norm(mesh["normal"], axis=1), 1.0)


def test_pvd_lists_steps_with_times(tmp_path):
    run = synthetic_run(n=7)
    paths = export_vtk(run, tmp_path, every=3)
    assert [p.name for p in paths[:-1]] == [f"surface_{i:06d}.vtp" for i in (0, 3, 6)]
    assert all(p.exists() and p.parent == tmp_path for p in paths)
    root = ET.parse(paths[-1]).getroot()
    assert root.get("type") == "Collection"
    datasets = root.findall("Collection/DataSet")
    assert [d.get("file") for d in datasets] == [p.name for p in paths[:-1]]
    times = [float(d.get("timestep")) for d in datasets]
    assert times == run.series["t"][::3].tolist()


@pytest.mark.parametrize("every", [0, -2, 1.5, "2", True, None])
def test_every_is_validated(tmp_path, every):
    with pytest.raises(ValueError, match="every must be an integer >= 1"):
        export_vtk(synthetic_run(n=2), tmp_path, every=every)
    assert not any(tmp_path.iterdir())
