"""Diagnostic figures of a run (vesicle.plots)."""

import numpy as np
import pytest

from vesicle import Shape
from vesicle.io import RunData
from vesicle.plots import is_out_of_plane, plot_run, section_xy, section_xz
from vesicle.sphere.transforms import mode_energy

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
IN_PLANE = ["psi", "deformation", "stress", "orbit", "shape_xz", "shape_xy"]


def rotation(psi: float, azimuth: float = 0.0) -> np.ndarray:
    """Tilt x towards z by ``psi``, then turn about z by ``azimuth``."""
    c, s = np.cos(psi), np.sin(psi)
    ry = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    c, s = np.cos(azimuth), np.sin(azimuth)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry


def synthetic_run(n: int = 5, azimuth: float = 0.0, chi: float = 1.0) -> RunData:
    base = Shape.spheroid(0.95, grid=12, degree=6)
    t = np.linspace(0.0, 3.0, n)
    psi = 0.3 * np.exp(-t) * np.cos(3.0 * t)
    rots = np.stack([rotation(p, azimuth * tk / 3.0) for p, tk in zip(psi, t, strict=True)])
    coefficients = np.stack([base.rotated(R).coefficients for R in rots])
    stress = np.full(n, np.nan) if chi == 0 else 0.5 + 0.1 * np.sin(t)
    series = {
        "t": t,
        "psi": psi,
        "D": 0.2 + 0.01 * np.cos(3.0 * t),
        "L": np.tile([2.6, 1.8, 1.8], (n, 1)),
        "axes": np.transpose(rots, (0, 2, 1)),  # row k = R e_k
        "S_xz": stress,
        "N1": stress * 0.3,
        "N2": -stress * 0.1,
        "spectrum": mode_energy(coefficients),
        "dt": np.full(n, 0.01),
    }
    params = {"v": 0.95, "lam": 1.0, "chi": chi, "grid": 12, "degree": 6}
    return RunData(parameters=params, series=series, coefficients=coefficients)


def assert_pngs(paths, names, outdir, prefix=""):
    assert paths == [outdir / f"{prefix}{name}.png" for name in names]
    for path in paths:
        data = path.read_bytes()
        assert len(data) > 1000 and data.startswith(PNG_SIGNATURE)


def test_in_plane_run_writes_all_figures(tmp_path):
    run = synthetic_run()
    assert not is_out_of_plane(run)
    outdir = tmp_path / "figs" / "nested"
    paths = plot_run(run, outdir, prefix="run1_", dpi=50)
    assert_pngs(paths, IN_PLANE, outdir, "run1_")
    assert not (outdir / "run1_axes_sphere.png").exists()
    assert not (outdir / "run1_axes_projection.png").exists()


def test_out_of_plane_run_adds_axes_sphere(tmp_path):
    run = synthetic_run(azimuth=0.4)
    assert is_out_of_plane(run)
    paths = plot_run(run, tmp_path, dpi=50)
    assert_pngs(paths, [*IN_PLANE, "axes_sphere", "axes_projection"], tmp_path)


def test_tilt_parameter_marks_out_of_plane():
    run = synthetic_run(n=2)
    run.parameters["tilt"] = 0.1
    assert is_out_of_plane(run)
    run.parameters["tilt"] = 0.0
    assert not is_out_of_plane(run)
    run.parameters["tilt"] = "thirty"  # a corrupt file: an error, not a silent in-plane run
    with pytest.raises(ValueError, match="tilt"):
        is_out_of_plane(run)


def test_all_nan_stress_still_plots(tmp_path):
    run = synthetic_run(chi=0.0)
    assert np.all(np.isnan(run.series["S_xz"]))
    paths = plot_run(run, tmp_path, dpi=50)
    assert_pngs(paths, IN_PLANE, tmp_path)


def test_single_step_run(tmp_path):
    run = synthetic_run(n=1)
    assert_pngs(plot_run(run, tmp_path, dpi=40), IN_PLANE, tmp_path)


def test_sections_lie_on_the_surface():
    shape = Shape.spheroid(0.95, grid=12, degree=6)
    a = shape.radius_at(np.array([0.5 * np.pi]), np.array([0.0]))[0]  # long semi-axis (x)
    b = shape.radius_at(np.array([0.0]), np.array([0.0]))[0]  # z semi-axis
    x, z = section_xz(shape.coefficients, m=101)
    assert x.max() == pytest.approx(a) and x.min() == pytest.approx(-a)
    assert z.max() == pytest.approx(b) and z.min() == pytest.approx(-b)
    x, y = section_xy(shape.coefficients, m=101)
    assert np.hypot(x, y).max() == pytest.approx(a)
    assert (x[0], y[0]) == pytest.approx((x[-1], y[-1]))  # closed curve


def test_missing_series_is_reported(tmp_path):
    run = synthetic_run(n=2)
    del run.series["D"]
    with pytest.raises(ValueError, match="'D'"):
        plot_run(run, tmp_path)
