"""Parametric studies (issue 14): shipped study files, a small study run end to end, errors."""

import csv

import pytest
from click.testing import CliRunner

from vesicle.cli import main
from vesicle.workflows.study import _write_config, list_studies, load_study, run_study, study_rows
from vesicle.workflows.sweep import SweepStore, read_sweep_config

SMALL = """
[study]
title = "psi against lambda"
figure = "branches"
x = "lam"
y = ["psi", "D", "bending.S_xz"]
curves = "chi"
theory = "misbah_psi"

[sweep]
task = "branch"

[grid]
v = [0.95]
chi = [1.0]

[task]
parameter = "lam"
values = "1:2:0.5"

[discretisation]
degree = 4
grid = 12
"""


@pytest.mark.parametrize("quick", [False, True])
def test_every_shipped_study_is_a_valid_sweep(tmp_path, quick):
    """Each shipped study (full and --quick) writes a sweep config the engine accepts: every
    point and every continued value is checked before any work."""
    studies = list_studies()
    assert {"tt-shape-chi", "tt-shape-lambda", "tt-excess-area", "stress-lambda"} <= set(studies)
    for name in studies:
        study, tables = load_study(name, quick)
        config = read_sweep_config(_write_config(study, tables, tmp_path))
        kinds = {"runs": "run", "maps": "ellipsoid_map", "branches": "branch", "series": "run",
                 "neutral_bq": "neutral_bq"}  # fmt: skip
        assert config.task == kinds[study["figure"]] and config.points
        # the membrane viscosity's check compares runs with the curve at N = 4 on 16x32 (runs
        # of a viscous membrane at N = 8 cost 40-70 min each: their own file's header)
        low = name in ("membrane-viscosity-check", "membrane-viscosity-runs")
        assert config.discretisation.degree == (4 if quick or low else 8)
        assert study["cost"]


def test_a_small_study_runs_resumes_and_draws(tmp_path):
    """A study run end to end: store, figure and table (one row per branch point with its
    y keys, the split included); a second run computes nothing and redraws."""
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    result = run_study(path, tmp_path / "out", workers=1)
    assert result["status"] == {"done": 1, "failed": 0, "pending": 0}
    with open(result["table"]) as f:
        rows = list(csv.DictReader(f))
    assert [float(r["lam"]) for r in rows] == [1.0, 1.5, 2.0]
    assert all(float(r["bending.S_xz"]) != 0.0 for r in rows)
    # psi decreases with lam along the branch at chi = 1 (Misbah's trend; docs/howto/studies.md)
    assert float(rows[0]["psi"]) > float(rows[1]["psi"]) > float(rows[2]["psi"]) > 0
    with open(result["figure"], "rb") as f:
        assert f.read(4) == b"\x89PNG"
    store = SweepStore.read(result["store"])
    before = store.records[next(iter(store.records))]["finished"]
    again = run_study(path, tmp_path / "out", workers=1)
    after = SweepStore.read(again["store"])
    assert after.records[next(iter(after.records))]["finished"] == before
    study, _ = load_study(path)
    assert len(study_rows(after, study)) == 3
    r = CliRunner().invoke(main, ["plot", str(again["store"]), "--out", str(tmp_path / "fig")])
    assert r.exit_code == 0, r.output  # `vesicle plot` of a study's store: its own figure
    assert (tmp_path / "fig" / "small.png").read_bytes()[:4] == b"\x89PNG"
    # another resolution into the same folder is refused before any work, saying what to do
    r = CliRunner().invoke(main, ["study", str(path), "--grid", "16", "--out",
                                  str(tmp_path / "out")])  # fmt: skip
    assert r.exit_code != 0 and "another --out" in r.output and "Traceback" not in r.output
    assert SweepStore.read(result["store"]).records == after.records


def test_a_study_at_another_resolution():
    """--degree/--grid (``resolution``) replace the study's [discretisation], after --quick."""
    _, tables = load_study("stress-lambda", quick=True, resolution={"degree": 8, "grid": 24})
    assert tables["discretisation"] == {"degree": 8, "grid": 24}
    _, tables = load_study("stress-lambda", resolution={"grid": 24})
    assert tables["discretisation"] == {"degree": 8, "grid": 24}
    r = CliRunner().invoke(main, ["study", "stress-lambda", "--grid", "0"])
    assert r.exit_code != 0 and "--grid must be at least 1" in r.output


@pytest.mark.parametrize("edit, message", [
    (("figure = \"branches\"", "figure = \"contours\""), "figure must be one of"),
    (("theory = \"misbah_psi\"", "theory = \"lebedev\""), "theory must be one of"),
    (("curves = \"chi\"", "curve = \"chi\""), "unknown key(s) curve"),
    (("y = [\"psi\", \"D\", \"bending.S_xz\"]", "y = []"), "y must be a list"),
])  # fmt: skip
def test_bad_studies_are_refused(tmp_path, edit, message):
    path = tmp_path / "bad.toml"
    path.write_text(SMALL.replace(*edit))
    with pytest.raises(ValueError, match=r"bad\.toml") as err:
        load_study(path)
    assert message in str(err.value)
    r = CliRunner().invoke(main, ["study", str(path), "--out", str(tmp_path / "o")])
    assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output


def test_study_list_and_unknown_name():
    r = CliRunner().invoke(main, ["study", "--list"])
    assert r.exit_code == 0 and "tt-shape-chi" in r.output and "cost" in r.output
    r = CliRunner().invoke(main, ["study", "no-such-study"])
    assert r.exit_code != 0 and "the shipped ones are" in r.output


def test_runs_figure_and_period_fit_on_a_synthetic_store(tmp_path):
    """figure = "runs": rows per run with chi T, the regime markers, and the period fit, which
    recovers an exact T = 3 (lam - 7.5)^(-1/2) (lam_c and the exponent of a saddle-node)."""
    import json

    from vesicle.workflows.study import period_fit, plot_study

    lams = [7.6, 7.8, 8.0, 8.5, 9.0, 10.0]
    records = {f"p{i}": {"status": "done", "physics": {"v": 0.95, "lam": lam, "chi": 0.2},
                         "result": {"v": 0.95, "lam": lam, "chi": 0.2, "regime": "TU",
                                    "period": 3.0 * (lam - 7.5) ** -0.5,
                                    "mean": {"S_xz": 2.0, "N1": 0.0, "N2": 0.0},
                                    "discretisation": {"degree": 4, "grid": 16}}}
               for i, lam in enumerate(lams)}  # fmt: skip
    store = SweepStore(tmp_path / "p.h5", "f", "", "run", records)
    fit = period_fit(lams, [r["result"]["period"] for r in records.values()])
    assert fit["p"] == pytest.approx(0.5, abs=1e-6)
    assert fit["lambda_c"] == pytest.approx(7.5, abs=1e-6)
    study = {"name": "p", "figure": "runs", "x": "lam", "y": ["period", "chiT"],
             "curves": "chi", "fit": "period", "quick": True}  # fmt: skip
    figure, table = plot_study(store, study, tmp_path)
    assert figure.read_bytes()[:4] == b"\x89PNG"
    with open(table) as f:
        rows = list(csv.DictReader(f))
    assert float(rows[0]["chiT"]) == pytest.approx(0.2 * 3.0 * 0.1**-0.5)
    assert json.loads((tmp_path / "p_fit.json").read_text())["chi = 0.2"]["p"] == pytest.approx(
        0.5, abs=1e-6)  # fmt: skip
    assert period_fit([8.0, 9.0], [1.0, 2.0]) is None
    # lam_c given (the fold located on the branch): two runs fix c and p exactly
    fixed = period_fit([9.0, 12.0], [3.0 * 1.5**-0.5, 3.0 * 4.5**-0.5], lambda_c=7.5)
    assert fixed["p"] == pytest.approx(0.5, rel=1e-12) and fixed["c"] == pytest.approx(3.0)
    assert fixed["lambda_c_fixed"] and fixed["lambda_c"] == 7.5
    assert period_fit([7.5, 9.0], [1.0, 2.0], lambda_c=7.5) is None  # a run at lam_c


def test_an_ellipsoid_map_study_runs_and_draws(tmp_path):
    """figure = "maps" on task ellipsoid_map: the TT state's equivalent ellipsoid turned over psi,
    solved for every lam; the map at the state's own psi and lam is the ellipsoid S^V there
    (flow_stress of the same ellipsoid: an independent call), and S_xz(psi) is even about 0."""
    import numpy as np

    from vesicle.solve.ellipsoid import equivalent_ellipsoid, flow_stress

    path = tmp_path / "maps.toml"
    path.write_text("""[study]
title = "maps"
figure = "maps"
x = "lam"
y = ["S_xz", "N1"]
curves = "chi"
[sweep]
task = "ellipsoid_map"
[grid]
v = [0.95]
lam = [2.0]
chi = [1.0]
[task]
psi = [-0.3, 0.0, 0.3]
lams = [1.0, 2.0]
[discretisation]
degree = 4
grid = 12
""")
    result = run_study(path, tmp_path / "out", workers=1)
    assert result["status"]["done"] == 1
    (record,) = SweepStore.read(result["store"]).records.values()
    m = record["result"]
    assert np.allclose(np.asarray(m["S_xz"])[0], np.asarray(m["S_xz"])[2], rtol=1e-6)
    state = m["state"]
    shape = equivalent_ellipsoid(state["axes"], state["axis_directions"], 12,
                                 turn=0.0 - state["psi"])  # fmt: skip
    direct = flow_stress(shape, [2.0])[0]
    assert m["S_xz"][1][1] == pytest.approx(direct.S_xz, rel=1e-8)
    with open(result["figure"], "rb") as f:
        assert f.read(4) == b"\x89PNG"


def test_a_series_study_draws_from_the_run_files(tmp_path):
    """figure = "series": each run's psi(t) and D-psi orbit, read from the run files the sweep
    keeps beside its store (the file's series has every saved step)."""
    path = tmp_path / "series.toml"
    path.write_text("""[study]
title = "series"
figure = "series"
x = "lam"
y = ["psi"]
curves = "chi"
[sweep]
task = "run"
[grid]
lam = [2.0]
[run]
t_end = 0.1
save_every = 0.02
save_fields = false
[discretisation]
degree = 4
grid = 12
""")
    result = run_study(path, tmp_path / "out", workers=1)
    assert result["status"]["done"] == 1
    runs = list((tmp_path / "out" / "series_runs").glob("*.h5"))
    assert len(runs) == 1
    with open(result["table"]) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and float(rows[0]["t_final"]) == pytest.approx(0.1)
    with open(result["figure"], "rb") as f:
        assert f.read(4) == b"\x89PNG"
