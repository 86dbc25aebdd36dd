"""Neutral curves (issue 13, part 2): the critical point continued in chi."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main
from vesicle.critical import critical_lambda
from vesicle.neutral import neutral_curve

DISC = vs.Discretisation(grid=16, degree=4)


@pytest.fixture(scope="module")
def curve():
    # the type change (bisection near the Bogdanov-Takens point) is the slow test below
    return neutral_curve(vs.Physics(v=0.95), [0.2, 1.0, 3.0], DISC, xtol=1e-3,
                         locate_type_change=False)  # fmt: skip


def test_traced_point_agrees_with_the_bracketing_search(curve):
    """At chi = 3 the tracer continued the critical point from chi = 1; critical_lambda
    brackets afresh from its default start (the reference): the two agree to their tolerances
    (1e-3 each).  Before its far secant steps went by a branch, one Newton jump (lam 5.85 ->
    8.78) landed on a second, stable steady state (psi = +0.021 where the branch has
    psi = -0.011 and is unstable), and at chi = 3.162 it returned lam_c = 6.627 (measured)."""
    traced = next(p for p in curve.points if p.chi == 3.0)
    reference = critical_lambda(vs.Physics(v=0.95, chi=3.0), DISC, xtol=1e-3)
    assert traced.lambda_c == pytest.approx(reference.lambda_c, abs=3e-3)
    assert traced.bifurcation == reference.bifurcation == "hopf"
    assert traced.omega_R == pytest.approx(reference.omega_R, rel=0.02)


def test_low_shear_end_is_a_fold(curve):
    """chi = 0.2 is below the type change (SPEC §14: near 0.25 at v = 0.95): a saddle-node
    with a real critical eigenvalue, where critical_lambda's bracketing cannot go.  Its
    lambda_c is the fold of the branch, 7.4833 (the branch tracer's pseudo-arclength gives
    7.48326 at this resolution, docs/continuation.md); the state just below it is stable."""
    low = curve.points[0]
    assert low.chi == 0.2 and low.bifurcation == "saddle-node" and low.omega_R < 1e-2
    assert low.lambda_c == pytest.approx(7.4833, abs=2e-3)
    assert vs.stability(low.start).most_unstable[1] < 0 and low.start.lam < low.lambda_c
    high = curve.points[-1]
    assert high.bifurcation == "hopf" and high.omega_R > 0.1
    assert curve.type_change is None  # not asked for


@pytest.mark.slow
def test_the_type_change_is_located_between_fold_and_hopf():
    """Bisection in log chi between 0.2 (fold) and 0.5 (Hopf) at N = 4."""
    c = neutral_curve(vs.Physics(v=0.95), [0.2, 0.5], DISC, xtol=1e-3, type_tol=0.05)
    assert c.type_change is not None
    lo, hi = c.type_change["bracket"]
    assert 0.2 <= lo < hi <= 0.5 and c.type_change["below"] == "saddle-node"


def test_neutral_json_has_the_issue_keys(tmp_path):
    out = tmp_path / "n.json"
    r = CliRunner().invoke(main, ["neutral", "--v", "0.95", "--chi", "1,2", "--grid", "16",
                                  "--degree", "4", "--no-type-change", "--out", str(out),
                                  "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    result = json.loads(r.output.strip().splitlines()[-1])
    assert {"v", "degree", "grid", "points", "type_change"} <= set(result)
    assert [p["chi"] for p in result["points"]] == [1.0, 2.0]
    assert {"chi", "lambda_c", "bifurcation", "omega_R", "psi", "D"} <= set(result["points"][0])
    assert json.loads(out.read_text()) == result


@pytest.mark.parametrize("args, message", [
    (["--chi", "0.1:10", "--points", "1"], "--points"),
    (["--chi", "1,-2"], "positive"),
    (["--chi", "1,2", "--points", "3"], "range"),
    (["--chi", "a:b"], "LOW:HIGH"),
])  # fmt: skip
def test_bad_chi_is_refused(args, message):
    r = CliRunner().invoke(main, ["neutral", *args])
    assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output


def test_phase_diagram_of_neutral_files(tmp_path):
    """`vesicle plot n.json --with m.json` draws phase_diagram.png (synthetic curves)."""
    for name, v in (("a.json", 0.95), ("b.json", 0.9)):
        points = [
            {
                "chi": c,
                "lambda_c": 8 + 0.1 * c,
                "bifurcation": "hopf" if c > 0.3 else "saddle-node",
                "omega_R": 0.1,
                "psi": 0.1,
                "D": 0.2,
            }
            for c in (0.2, 1, 5)
        ]
        data = {"v": v, "degree": 4, "grid": 16, "points": points,
                "type_change": {"chi": 0.3, "lambda_c": 8.0}}  # fmt: skip
        (tmp_path / name).write_text(json.dumps(data))
    r = CliRunner().invoke(
        main,
        [
            "plot",
            str(tmp_path / "a.json"),
            "--with",
            str(tmp_path / "b.json"),
            "--out",
            str(tmp_path / "fig"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert (tmp_path / "fig" / "phase_diagram.png").read_bytes()[:4] == b"\x89PNG"


def _fake_point(self, start, chi, lam_pred):
    """A stand-in for the tracer's point (no numerics): fails beyond chi = 2."""
    from vesicle.neutral import NeutralPoint
    from vesicle.steady import NewtonError

    if chi > 2.0:
        raise NewtonError(f"no stable tank-treading state found at chi = {chi:g}")
    p = NeutralPoint(chi, 8.0 + 0.1 * chi, "hopf", 0.3 * chi, -0.01, 0.2, True, 0.0, start=start)
    if self.progress is not None:
        self.progress({k: v for k, v in p.to_dict().items() if k != "located"})
    return p


@pytest.fixture
def failing_tracer(monkeypatch):
    import vesicle.neutral as neutral

    monkeypatch.setattr(neutral._Tracer, "point", _fake_point)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: None)


def test_a_failing_direction_keeps_what_was_found(failing_tracer, tmp_path):
    """A point the tracer cannot reach ends its direction: the points found on both sides are
    kept, the failure is reported with the curve, and the CLI writes them to --out (as they
    come, and at the end) but exits non-zero."""
    c = neutral_curve(vs.Physics(v=0.95), [0.5, 1.0, 2.0, 3.0, 4.0], DISC,
                      locate_type_change=False)  # fmt: skip
    assert [p.chi for p in c.points] == [0.5, 1.0, 2.0]
    assert [f["chi"] for f in c.failed] == [3.0] and "chi = 3" in c.failed[0]["error"]
    assert c.to_dict()["failed"] == c.failed
    out = tmp_path / "n.json"
    args = ["--chi", "0.5,1,2,3,4", "--grid", "16", "--degree", "4", "--no-type-change"]
    r = CliRunner().invoke(main, ["neutral", *args, "--out", str(out)])
    assert r.exit_code != 0 and "the curve stopped" in r.output and "chi = 3" in r.output
    written = json.loads(out.read_text())
    assert [p["chi"] for p in written["points"]] == [0.5, 1.0, 2.0]
    assert written["failed"][0]["chi"] == 3.0 and written["vesicle_version"] == vs.__version__


def _run_store(path, rows):
    from vesicle.sweep import SweepStore

    records = {f"p{i}": {"status": "done", "physics": {"v": v, "chi": chi, "lam": lam},
                         "result": {"regime": regime, "period": 10.0}, "seconds": 1.0}
               for i, (v, chi, lam, regime) in enumerate(rows)}  # fmt: skip
    SweepStore(path, "f", "", "run", records).write()


def test_phase_diagrams_with_classified_runs(tmp_path):
    """`vesicle plot n.json --runs s.h5` overlays the regimes of a sweep of runs on the chi-lambda
    and the S-Lambda diagrams; a sweep of another task is refused by name."""
    points = [{"chi": c, "lambda_c": 8 + 0.1 * c, "bifurcation": "hopf", "omega_R": 0.1,
               "psi": 0.1, "D": 0.2} for c in (0.3, 1, 5)]  # fmt: skip
    curve = tmp_path / "n.json"
    curve.write_text(json.dumps({"v": 0.95, "degree": 4, "grid": 16, "points": points,
                                 "type_change": None}))  # fmt: skip
    store = tmp_path / "runs.h5"
    _run_store(store, [(0.95, 1.0, 7.0, "TT"), (0.95, 6.0, 9.5, "TR"), (0.95, 1.0, 12.0, "TU")])
    from vesicle.phase_plots import runs_from_store

    runs = runs_from_store(store)
    assert sorted(r["regime"] for r in runs) == ["TR", "TT", "TU"]
    r = CliRunner().invoke(main, ["plot", str(curve), "--runs", str(store), "--out",
                                  str(tmp_path / "fig")])  # fmt: skip
    assert r.exit_code == 0, r.output
    for name in ("phase_diagram.png", "phase_SLambda.png"):
        assert (tmp_path / "fig" / name).read_bytes()[:4] == b"\x89PNG"
    from vesicle.sweep import SweepStore

    SweepStore(tmp_path / "tt.h5", "f", "", "tt", {}).write()
    r = CliRunner().invoke(main, ["plot", str(curve), "--runs", str(tmp_path / "tt.h5")])
    assert r.exit_code != 0 and "sweep of runs" in r.output


def test_curves_of_one_volume_share_a_colour():
    """The dashed vorticity-aligned curve of a v is drawn in the colour of the in-plane curve of
    the same v (the colours used to follow the order of the curves)."""
    from vesicle.phase_plots import _colors

    curves = [{"v": 0.95, "orientation": "vorticity"}, {"v": 0.90}, {"v": 0.95}, {"v": 0.98}]
    colors = _colors(curves)
    assert colors == {0.98: "C0", 0.95: "C1", 0.90: "C2"}


def test_a_seed_that_fails_moves_to_the_next_chi(monkeypatch):
    """Where no critical point can be found at the chi nearest 1 (the vorticity branch at
    v = 0.90, chi = 2), the curve is seeded at the next chi and traced back: here the seed at
    chi = 1 is made to fail; chi = 3 seeds the curve and chi = 1 is reached by continuing the
    critical point down, which agrees with the bracketing search there (8.337 at N = 4 on
    12x24, the quick report's fig7)."""
    from vesicle import neutral
    from vesicle.steady import NewtonError

    real = neutral._seed

    def seed(tracer, chi, *args):
        if chi == 1.0:
            raise NewtonError("no critical point here (test)")
        return real(tracer, chi, *args)

    monkeypatch.setattr(neutral, "_seed", seed)
    disc = vs.Discretisation(grid=12, degree=4)
    c = neutral_curve(vs.Physics(v=0.95), [1.0, 3.0], disc, locate_type_change=False)
    assert [p.chi for p in c.points] == [1.0, 3.0] and c.failed == []
    assert c.points[0].lambda_c == pytest.approx(8.337, abs=3e-3)
    monkeypatch.setattr(neutral, "_seed", lambda *a: (_ for _ in ()).throw(NewtonError("none")))
    with pytest.raises(NewtonError, match="no critical point found at any chi"):
        neutral_curve(vs.Physics(v=0.95), [1.0, 3.0], disc, locate_type_change=False)


def test_seed_order_flow_nearest_one_vorticity_largest_first(monkeypatch):
    """The seeds tried, in order (every one made to fail, so nothing is computed): the in-plane
    branch from chi nearest 1 outwards; the vorticity branch from the largest chi down."""
    from vesicle import neutral
    from vesicle.steady import NewtonError

    tried = []

    def seed(tracer, chi, *args):
        tried.append(chi)
        raise NewtonError("none (test)")

    monkeypatch.setattr(neutral, "_seed", seed)
    chis = [0.2, 0.5, 2.0, 4.0, 8.0]
    for orientation, order in (("flow", [0.5, 2.0, 4.0, 0.2, 8.0]),
                               ("vorticity", [8.0, 4.0, 2.0, 0.5, 0.2])):  # fmt: skip
        tried.clear()
        with pytest.raises(NewtonError, match="chi = 8: none"):
            neutral_curve(vs.Physics(v=0.90), chis, DISC, orientation=orientation)
        assert tried == order


def test_an_interrupted_curve_resumes_from_its_checkpoint(small_state, stand_in, monkeypatch,
                                                           tmp_path):
    """`vesicle neutral --out F` keeps each point's state in F's checkpoint folder as it is
    found; after a stop (here a failure above chi = 1.6), `--resume` takes the points kept and
    traces only the rest: no seed search, no point traced twice."""
    import vesicle.neutral as neutral

    calls = []
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: small_state)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, calls, fail_above=1.6))
    out = tmp_path / "n.json"
    args = ["neutral", "--chi", "0.8,1,1.5,2,3", "--grid", "12", "--degree", "4",
            "--no-type-change", "--out", str(out)]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0 and "--resume continues" in r.output
    assert sorted(calls) == [0.8, 1.0, 1.5]
    assert sorted(p.name for p in (tmp_path / "n.states").iterdir()) == [
        "chi_0.8.h5", "chi_1.5.h5", "chi_1.h5"]  # fmt: skip

    calls.clear()
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, calls))
    monkeypatch.setattr(neutral, "critical_lambda", lambda *a, **k: pytest.fail("seed searched"))
    r = CliRunner().invoke(main, [*args, "--resume", "--json"])
    assert r.exit_code == 0, r.output
    assert "resuming" in r.output and calls == [2.0, 3.0]
    result = json.loads(r.output.strip().splitlines()[-1])
    assert [p["chi"] for p in result["points"]] == [0.8, 1.0, 1.5, 2.0, 3.0]
    assert result["resumed"] == 3 and result["failed"] == []
    assert json.loads(out.read_text())["points"] == result["points"]


@pytest.mark.parametrize("change, key", [(["--grid", "16"], "grid"), (["--v", "0.9"], "v"),
                                         (["--xtol", "1e-2"], "xtol")])  # fmt: skip
def test_resume_refuses_another_curve(small_state, stand_in, monkeypatch, tmp_path, change,
                                      key):
    import vesicle.neutral as neutral

    out = tmp_path / "n.json"
    args = ["neutral", "--chi", "1,2", "--grid", "12", "--degree", "4", "--no-type-change",
            "--out", str(out)]  # fmt: skip
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: small_state)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, []))
    assert CliRunner().invoke(main, args).exit_code == 0
    r = CliRunner().invoke(main, [*args, *change, "--resume"])
    assert r.exit_code != 0 and f"file's {key}" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(main, ["neutral", "--chi", "1,2", "--resume"])
    assert r.exit_code != 0 and "give --out" in r.output


def test_a_resumed_trace_is_the_uninterrupted_one(curve, tmp_path):
    """The point at chi = 1 written as a checkpoint and read back (its start state from the
    file) continues to chi = 1.3 exactly as from the state in memory: lambda_c, omega_R and the
    start state there agree to rounding."""
    from vesicle.neutral import NeutralCurve
    from vesicle.neutral_io import read_checkpoint, write_point_state

    p1 = next(p for p in curve.points if p.chi == 1.0)
    folder, out = tmp_path / "n.states", tmp_path / "n.json"
    write_point_state(folder, p1)
    out.write_text(json.dumps(NeutralCurve(curve.physics, DISC, [p1], None, [], 0.0).to_dict()))
    restored = read_checkpoint(out, folder, curve.physics, DISC)
    assert [p.to_dict() for p in restored] == [p1.to_dict()]
    np.testing.assert_array_equal(restored[0].start.jacobian, p1.start.jacobian)
    memory = neutral_curve(curve.physics, [1.0, 1.3], DISC, known=[p1], locate_type_change=False)
    resumed = neutral_curve(curve.physics, [1.0, 1.3], DISC, known=restored,
                            locate_type_change=False)  # fmt: skip
    assert memory.resumed == resumed.resumed == 1
    a, b = memory.points[1], resumed.points[1]
    assert b.chi == 1.3 and b.lambda_c == pytest.approx(a.lambda_c, rel=1e-10, abs=0)
    assert b.omega_R == pytest.approx(a.omega_R, rel=1e-8)
    np.testing.assert_allclose(b.start.a, a.start.a, rtol=0, atol=1e-10)
