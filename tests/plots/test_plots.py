"""Diagnostic figures of a run (vesicle.plots.runs)."""

import numpy as np
import pytest

from vesicle import Shape
from vesicle.io.files import RunData
from vesicle.plots.runs import is_out_of_plane, plot_run, section_xy, section_xz
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


# ------------------------------------------------ the report's figures (issue 38)
def _capture_figures(monkeypatch):
    """The figures saved through ``vesicle.plots.runs._save``, kept for inspection."""
    import vesicle.plots.runs

    saved = []
    original = vesicle.plots.runs._save

    def save(fig, path, dpi):
        saved.append(fig)
        return original(fig, path, dpi)

    monkeypatch.setattr(vesicle.plots.runs, "_save", save)
    return saved


def _legend_entries(fig) -> dict:
    """label (its lines joined) -> handle of every legend of ``fig`` (the figure's and its
    axes')."""
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    return {t.get_text().replace("\n", " "): h for lg in legends
            for t, h in zip(lg.get_texts(), lg.legend_handles, strict=True)}  # fmt: skip


def _run_store(tmp_path, runs):
    from vesicle.workflows.sweep import SweepStore

    records = {f"p{i}": {"status": "done", "physics": {"v": 0.95, "lam": lam, "chi": chi},
                         "result": {"v": 0.95, "lam": lam, "chi": chi, "regime": regime,
                                    "period": 2.0,
                                    "mean": {"S_xz": 2.0, "N1": 0.01, "N2": -0.01},
                                    "discretisation": {"degree": 4, "grid": 12}}}
               for i, (chi, lam, regime) in enumerate(runs)}  # fmt: skip
    return SweepStore(tmp_path / "runs.h5", "f", "", "run", records)


def test_readable_labels_with_units():
    from vesicle.workflows.study import axis_label, curve_label

    mean = r"$\langle S_{xz} \rangle$ (period average) [$c\,\mu\dot\gamma$]"
    assert axis_label("mean.S_xz") == mean
    assert "flow-resistance part" in axis_label("flow.N1") and "N" in axis_label("flow.N1")
    assert "bending part" in axis_label("bending.S_xz")
    assert axis_label("period").endswith(r"[$\mu a^3/\kappa$]")
    assert "rad" in axis_label("psi")
    assert curve_label("lam = 2") == r"$\lambda$ = 2" and curve_label("chi = 6") == r"$\chi$ = 6"


def test_runs_figure_legend_handles_match_the_markers(tmp_path, monkeypatch):
    """The regimes' legend entries carry their own markers (a square for TU, a triangle for TR),
    the curves' entries no circle; the title has no marker codes; stresses in one panel."""
    from vesicle.workflows.study import plot_study

    saved = _capture_figures(monkeypatch)
    store = _run_store(tmp_path, [(6.0, 12.0, "TR"), (6.0, 20.0, "TU")])
    study = {"name": "runs", "figure": "runs", "x": "lam", "curves": "chi", "quick": True,
             "title": "stresses", "y": ["mean.S_xz", "mean.N1", "mean.N2"]}  # fmt: skip
    plot_study(store, study, tmp_path)
    fig = saved[-1]
    assert len(fig.axes) == 1  # three stresses of the same unit: one panel
    entries = _legend_entries(fig)
    assert entries["run in TU"].get_marker() == "s" and entries["run in TR"].get_marker() == "^"
    assert "run in TT" not in entries
    assert all(h.get_marker() in ("None", "", None) for label, h in entries.items()
               if label.startswith("runs:"))  # fmt: skip
    title = fig.get_suptitle()
    assert "o TT" not in title and "s TU" not in title
    assert "$" in fig.axes[0].get_ylabel() and "mean." not in str(list(entries))
    # periods: a panel per y, the paper's exponent named
    study = {**study, "name": "periods-low-shear", "y": ["period", "chiT"], "fit": "period"}
    store = _run_store(tmp_path, [(0.2, lam, "TU") for lam in (8.0, 9.0, 10.0)])
    plot_study(store, study, tmp_path)
    assert len(saved[-1].axes) == 2
    assert any(label.startswith("paper (SPEC §14)") for label in _legend_entries(saved[-1]))


def test_branch_figure_legend_is_outside_and_names_the_theory(tmp_path, monkeypatch):
    """A study of branches: one legend right of the axes (not over the data), stable and
    unstable handles, the leading-order theory named as such, the paper's lambda_c drawn."""
    from vesicle.workflows.study import plot_study
    from vesicle.workflows.sweep import SweepStore

    saved = _capture_figures(monkeypatch)
    points = [{"v": 0.95, "lam": lam, "chi": 1.0, "psi": 0.3 - 0.05 * lam, "D": 0.2,
               "n_unstable": int(lam > 8.4)} for lam in (2.0, 5.0, 8.0, 8.6)]  # fmt: skip
    store = SweepStore(tmp_path / "b.h5", "f", "", "branch",
                       {"c": {"status": "done", "physics": {"v": 0.95, "chi": 1.0},
                              "result": {"points": points}}})  # fmt: skip
    study = {"name": "tt-shape-lambda", "figure": "branches", "x": "lam", "y": ["psi", "D"],
             "curves": "chi", "theory": "misbah_psi", "title": "psi", "quick": True}  # fmt: skip
    plot_study(store, study, tmp_path)
    fig = saved[-1]
    assert len(fig.legends) == 1 and not any(ax.get_legend() for ax in fig.axes)
    entries = _legend_entries(fig)
    assert {"stable TT", "unstable TT"} <= set(entries)
    assert any("small-deformation" in label and "v → 1" in label for label in entries)
    assert any("8.46" in label and label.startswith("paper (SPEC §14)") for label in entries)
    assert fig.axes[0].get_ylabel() == r"inclination $\psi$ [rad]"


def test_phase_diagram_draws_the_papers_values(tmp_path, monkeypatch):
    """lambda_c = 8.46 at chi = 1 and the type changes (v = 0.95, 0.90) labelled "paper (SPEC
    §14)"; the theory lines' entry says they are the leading-order small-deformation limit."""
    from vesicle.plots.phase import plot_neutral

    saved = _capture_figures(monkeypatch)
    curves = [{"v": v, "degree": 4, "grid": 12, "type_change": None,
               "points": [{"chi": c, "lambda_c": lam + 0.1 * c, "bifurcation": "hopf",
                           "located": True} for c in (1.0, 3.0)]}
              for v, lam in ((0.95, 8.3), (0.90, 5.5))]  # fmt: skip
    plot_neutral(curves, tmp_path, dpi=40)
    for fig in saved[-2:]:
        labels = list(_legend_entries(fig))
        assert any("8.46" in label for label in labels)
        assert any("0.25" in label and "v = 0.95" in label for label in labels)
        assert any("0.6" in label and "v = 0.9" in label for label in labels)
        assert any("small-deformation" in label and "v → 1" in label for label in labels)
