"""Neutral curves (issue 13, part 2): the critical point continued in chi."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.bifurcation.critical import critical_lambda
from vesicle.bifurcation.neutral import neutral_curve
from vesicle.cli import main

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
    reference = critical_lambda(
        vs.Physics(v=0.95, chi=3.0), DISC, search=vs.CriticalSearch(xtol=1e-3)
    )
    assert traced.lambda_c == pytest.approx(reference.lambda_c, abs=3e-3)
    assert traced.bifurcation == reference.bifurcation == "hopf"
    assert traced.omega_R == pytest.approx(reference.omega_R, rel=0.02)


def test_low_shear_end_is_a_fold(curve):
    """chi = 0.2 is below the type change (SPEC §14: near 0.25 at v = 0.95): a saddle-node
    with a real critical eigenvalue, where critical_lambda's bracketing cannot go.  Its
    lambda_c is the fold of the branch, located to the tracer's xtol (1e-3).  Independent
    reference: the fold solved for on its minimally augmented system (a singular Jacobian,
    vesicle.bifurcation.codim2.locate_fold, not the tracer's pseudo-arclength secant) at
    7.483254 (docs/notes/codim2-measurements.md); the state just below it is stable."""
    low = curve.points[0]
    assert low.chi == 0.2 and low.bifurcation == "saddle-node" and low.omega_R < 1e-2
    assert low.located
    assert low.lambda_c == pytest.approx(7.483254, abs=2e-3)
    assert vs.stability(low.start).most_unstable[1] < 0 and low.start.lam < low.lambda_c
    high = curve.points[-1]
    assert high.bifurcation == "hopf" and high.omega_R > 0.1
    assert curve.type_change is None  # not asked for


@pytest.mark.slow
def test_the_type_change_is_located_between_fold_and_hopf():
    """Bisection in log chi between 0.2 (fold) and 0.5 (Hopf) at N = 4 to 5 %.  Independent
    reference: the change solved for where the fold curve meets the upper sheet's Hopf curve,
    each point on its augmented system, at chi = 0.256642 (steady_codim2.locate_type_change,
    docs/notes/codim2-measurements.md): the tracer's bracket must hold it."""
    c = neutral_curve(vs.Physics(v=0.95), [0.2, 0.5], DISC, xtol=1e-3, type_tol=0.05)
    assert c.type_change is not None
    lo, hi = c.type_change["bracket"]
    assert c.type_change["below"] == "saddle-node" and c.type_change["above"] == "hopf"
    assert lo <= 0.256642 <= hi and hi / lo - 1.0 <= 0.06


def test_neutral_json_has_the_issue_keys(tmp_path):
    out = tmp_path / "n.json"
    r = CliRunner().invoke(main, ["neutral", "--v", "0.95", "--chi", "1,2", "--grid", "16",
                                  "--degree", "4", "--no-type-change", "--out", str(out),
                                  "--json", "--continuation", "trace"])  # fmt: skip
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
    (["--chi", "a:b"], "'a' is not a number"),
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


def _fake_point(self, start, chi, lam_pred, fallbacks=()):
    """A stand-in for the tracer's point (no numerics): fails beyond chi = 2."""
    from vesicle.bifurcation.neutral import NeutralPoint
    from vesicle.steady.newton import NewtonError

    if chi > 2.0:
        raise NewtonError(f"no stable tank-treading state found at chi = {chi:g}")
    p = NeutralPoint(chi, 8.0 + 0.1 * chi, "hopf", 0.3 * chi, -0.01, 0.2, True, 0.0, start=start)
    if self.progress is not None:
        self.progress({k: v for k, v in p.to_dict().items() if k != "located"})
    return p


@pytest.fixture
def failing_tracer(monkeypatch):
    import vesicle.bifurcation.neutral as neutral

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
    args = ["--chi", "0.5,1,2,3,4", "--grid", "16", "--degree", "4", "--no-type-change",
            "--continuation", "trace"]  # fmt: skip
    r = CliRunner().invoke(main, ["neutral", *args, "--out", str(out)])
    assert r.exit_code != 0 and "the curve stopped" in r.output and "chi = 3" in r.output
    written = json.loads(out.read_text())
    assert [p["chi"] for p in written["points"]] == [0.5, 1.0, 2.0]
    assert written["failed"][0]["chi"] == 3.0 and written["vesicle_version"] == vs.__version__


def _run_store(path, rows):
    from vesicle.workflows.sweep import SweepStore

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
    from vesicle.workflows.sweep import runs_from_store

    runs = runs_from_store(store)
    assert sorted(r["regime"] for r in runs) == ["TR", "TT", "TU"]
    r = CliRunner().invoke(main, ["plot", str(curve), "--runs", str(store), "--out",
                                  str(tmp_path / "fig")])  # fmt: skip
    assert r.exit_code == 0, r.output
    for name in ("phase_diagram.png", "phase_SLambda.png"):
        assert (tmp_path / "fig" / name).read_bytes()[:4] == b"\x89PNG"
    from vesicle.workflows.sweep import SweepStore

    SweepStore(tmp_path / "tt.h5", "f", "", "tt", {}).write()
    r = CliRunner().invoke(main, ["plot", str(curve), "--runs", str(tmp_path / "tt.h5")])
    assert r.exit_code != 0 and "sweep of runs" in r.output


def test_curves_of_one_volume_share_a_colour():
    """The dashed vorticity-aligned curve of a v is drawn in the colour of the in-plane curve of
    the same v (the colours used to follow the order of the curves)."""
    from vesicle.plots.phase import _colors

    curves = [{"v": 0.95, "orientation": "vorticity"}, {"v": 0.90}, {"v": 0.95}, {"v": 0.98}]
    colors = _colors(curves)
    assert colors == {0.98: "C0", 0.95: "C1", 0.90: "C2"}


def test_a_seed_that_fails_moves_to_the_next_chi(monkeypatch):
    """Where no critical point can be found at the chi nearest 1 (the vorticity branch at
    v = 0.90, chi = 2), the curve is seeded at the next chi and traced back: here the seed at
    chi = 1 is made to fail; chi = 3 seeds the curve and chi = 1 is reached by continuing the
    critical point down, which agrees with the bracketing search there (8.337 at N = 4 on
    12x24, the quick report's fig7)."""
    from vesicle.bifurcation import neutral
    from vesicle.steady.newton import NewtonError

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
    from vesicle.bifurcation import neutral
    from vesicle.steady.newton import NewtonError

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
            neutral_curve(
                vs.Physics(v=0.90),
                chis,
                DISC,
                analysis=vs.StabilitySettings(orientation=orientation),
            )
        assert tried == order


def test_an_interrupted_curve_resumes_from_its_checkpoint(
    small_state, stand_in, monkeypatch, tmp_path
):
    """`vesicle neutral --out F` keeps each point's state in F's checkpoint folder as it is
    found; after a stop (here a failure above chi = 1.6), `--resume` takes the points kept and
    traces only the rest: no seed search, no point traced twice."""
    import vesicle.bifurcation.neutral as neutral

    calls = []
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: small_state)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, calls, fail_above=1.6))
    out = tmp_path / "n.json"
    args = ["neutral", "--chi", "0.8,1,1.5,2,3", "--grid", "12", "--degree", "4",
            "--no-type-change", "--out", str(out), "--continuation", "trace"]  # fmt: skip
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
def test_resume_refuses_another_curve(small_state, stand_in, monkeypatch, tmp_path, change, key):
    import vesicle.bifurcation.neutral as neutral

    out = tmp_path / "n.json"
    args = ["neutral", "--chi", "1,2", "--grid", "12", "--degree", "4", "--no-type-change",
            "--out", str(out), "--continuation", "trace"]  # fmt: skip
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: small_state)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, []))
    assert CliRunner().invoke(main, args).exit_code == 0
    r = CliRunner().invoke(main, [*args, *change, "--resume"])
    assert r.exit_code != 0 and f"file's {key}" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(main, ["neutral", "--chi", "1,2", "--resume", "--continuation",
                                  "trace"])  # fmt: skip
    assert r.exit_code != 0 and "give --out" in r.output
    # the two-parameter continuation writes its curve when complete: no --states; --resume
    # replays its kept evaluations (tests/cli/test_output_rules.py) and needs --out
    r = CliRunner().invoke(main, ["neutral", "--chi", "1,2", "--states", str(tmp_path / "st")])
    assert r.exit_code != 0 and "--continuation trace" in r.output
    r = CliRunner().invoke(main, ["neutral", "--chi", "1,2", "--resume"])
    assert r.exit_code != 0 and "give --out" in r.output


def test_a_resumed_trace_is_the_uninterrupted_one(curve, tmp_path):
    """The point at chi = 1 written as a checkpoint and read back (its start state from the
    file) continues to chi = 1.3 exactly as from the state in memory: lambda_c, omega_R and the
    start state there agree to rounding."""
    from vesicle.bifurcation.checkpoint import read_checkpoint, write_point_state
    from vesicle.bifurcation.neutral import NeutralCurve

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


def test_tank_treading_past_a_fold_sets_lambda_c(monkeypatch):
    """A model of the S-shaped branch next to the change of type (v = 0.90, N = 4: the branch
    from low lam folds at F(chi), the part above it is stable up to its Hopf point H(chi)):
    every fold point whose other branch is stable past the fold takes that branch's Hopf point
    as lambda_c (with the fold kept as ``lower_fold``), so the curve is max(F, H) and the type
    changes where H crosses F + PAST_FOLD xtol, not where the fold itself ends (the cusp, here
    chi = 0.8).  The model's lines: F = 5.40 + 0.1 chi, H = 5.0 + 0.8 chi; they cross
    3 xtol apart at chi = 0.403 / 0.7 = 0.5757."""
    import vesicle.bifurcation.neutral as neutral

    F, H = (lambda c: 5.40 + 0.1 * c), (lambda c: 5.0 + 0.8 * c)
    starts = []

    # the branch from low lam: folds below the cusp
    def point(self, start, chi, lam_pred, fallbacks=()):
        starts.append((chi, start))
        if chi >= 0.8:
            return neutral.NeutralPoint(chi, H(chi), "hopf", 0.1, 0.0, 0.3, True, 0.0,
                                        start=("hopf", chi))  # fmt: skip
        return neutral.NeutralPoint(chi, F(chi), "saddle-node", 0.0, 0.0, 0.3, True, 0.0,
                                    start=("fold", chi))  # fmt: skip

    def past_fold(self, fold, hopf):
        assert fold.bifurcation == "saddle-node" and hopf.bifurcation == "hopf"
        if H(fold.chi) <= fold.lambda_c + neutral.PAST_FOLD * self.xtol:
            return None
        return neutral.NeutralPoint(fold.chi, H(fold.chi), "hopf", 0.1, 0.0, 0.3, True, 0.0,
                                    start=("upper", fold.chi),
                                    lower_fold=fold.lambda_c)  # fmt: skip

    monkeypatch.setattr(neutral._Tracer, "point", point)
    monkeypatch.setattr(neutral._Tracer, "past_fold", past_fold)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: None)
    c = neutral_curve(vs.Physics(v=0.90), [0.3, 0.5, 0.6, 0.7, 1.0], DISC, type_tol=0.01)
    kinds = {p.chi: (p.bifurcation, p.lower_fold) for p in c.points}
    assert kinds[0.3] == ("saddle-node", None) and kinds[0.5] == ("saddle-node", None)
    assert kinds[0.6] == ("hopf", pytest.approx(F(0.6))) and kinds[0.7][0] == "hopf"
    assert [p.lambda_c for p in c.points] == pytest.approx([F(0.3), F(0.5), H(0.6), H(0.7),
                                                            H(1.0)])  # fmt: skip
    t = c.type_change
    assert t["below"] == "saddle-node" and t["above"] == "hopf" and t["located"]
    assert t["bracket"][0] < 0.403 / 0.7 < t["bracket"][1]
    assert t["bracket"][1] / t["bracket"][0] <= 1.01
    # every bisection point starts from the fold side's state (the branch from low lam)
    bisected = {p.chi for p in c.bisection} - {p.chi for p in c.points}
    assert bisected and all(s[0] == "fold" for x, s in starts if x in bisected)
    assert c.to_dict()["points"][2]["lower_fold"] == pytest.approx(F(0.6))
    assert "lower_fold" not in c.to_dict()["points"][0]


def test_a_point_past_a_fold_is_read_back_as_its_fold(small_state, tmp_path):
    """A fold replaced by the loss of stability of the branch past it keeps the fold's state
    (the trace goes on from the branch from low lam); read back for a resume it is that fold
    again (lambda_c = lower_fold, so that the resumed curve looks past it as the uninterrupted
    one did), while a plain point is read back as written."""
    import dataclasses

    from vesicle.bifurcation.checkpoint import read_checkpoint, write_point_state
    from vesicle.bifurcation.neutral import NeutralCurve, NeutralPoint

    disc = vs.Discretisation(grid=12, degree=4)
    at = {c: dataclasses.replace(small_state, problem=small_state.problem.replace(
        physics=small_state.physics.replace(chi=c))) for c in (0.6, 0.7)}  # fmt: skip
    hopf = NeutralPoint(0.7, 5.56, "hopf", 0.15, 0.03, 0.32, True, 1.0, start=at[0.7])
    upper = NeutralPoint(0.6, 5.50, "hopf", 0.12, 0.04, 0.32, True, 1.0, start=at[0.6],
                         lower_fold=5.45)  # fmt: skip
    folder, out = tmp_path / "n.states", tmp_path / "n.json"
    for p in (hopf, upper):
        write_point_state(folder, p)
    curve = NeutralCurve(small_state.physics, disc, [upper, hopf], None, [], 0.0)
    out.write_text(json.dumps(curve.to_dict()))
    assert json.loads(out.read_text())["points"][0]["lower_fold"] == 5.45
    fold, again = read_checkpoint(out, folder, small_state.physics, disc)
    assert (fold.chi, fold.lambda_c, fold.bifurcation, fold.lower_fold) == (
        0.6, 5.45, "saddle-node", None)  # fmt: skip
    assert again.to_dict() == hopf.to_dict()


def test_what_counts_as_tank_treading_going_on_past_a_fold():
    """Past the cusp of an S-shaped branch the real eigenvalue may poke above zero in a narrow
    window (v = 0.90, chi = 0.6813, N = 4 on 16x32, from a pseudo-arclength scan: growth
    <= 0.0019 for lam in [5.4724, 5.4770], curvature shift -0.0092, then stable up to the Hopf
    point at 5.541): such a state counts as tank-treading going on; a resolvable real growth
    or a growing complex pair does not.  Going up, the window's upper end regains stability
    and the Hopf point loses it: only the second is lambda_c."""
    from types import SimpleNamespace

    from vesicle.bifurcation.branch import BranchPoint, SpecialPoint
    from vesicle.bifurcation.neutral import _goes_on, _lost_upwards

    def at(lam, w_r, w_i, shift=-0.0092):
        omega = np.array([[-w_r, w_i], [w_r, w_i] if w_r else [0.0, -0.25]])
        return BranchPoint(vs.Physics(v=0.90, chi=0.6813, lam=lam), None, omega, False, shift)

    window, above = at(5.4757, 0.0, 0.00192), at(5.4802, 0.0, -0.0147)
    hopf = at(5.5478, 0.154, 0.0045)
    assert _goes_on(window) and _goes_on(above) and not _goes_on(hopf)
    assert not _goes_on(at(5.4757, 0.0, 0.02))  # a real growth the resolution resolves
    assert not _goes_on(at(5.4757, 0.0, 0.00192, shift=-0.001))
    b = SimpleNamespace(points=[hopf, above, window])  # followed down in lam
    regain = SpecialPoint("saddle-node", "lam", 5.4770, 0.0, True, (5.4802, 5.4757))
    loss = SpecialPoint("hopf", "lam", 5.5413, 0.15, True, (5.5478, 5.4802))
    assert not _lost_upwards(b, regain) and _lost_upwards(b, loss)


@pytest.mark.slow
def test_past_the_cusp_lambda_c_is_the_hopf_point():
    """v = 0.90, chi = 0.6813, N = 4 on 16x32: the branch from low lam is monotone here (a
    pseudo-arclength scan in lam, fixed arclength steps, never turns: dlam/ds >= 0.26), its real
    eigenvalue crosses zero at 5.4723 and back at 5.4770 (growth <= 0.0019, curvature shift
    0.0092), and it stays stable up to the Hopf point at 5.5401 (the scan's omega_I: -0.00282
    at 5.53559, +0.00094 at 5.54170; natural continuation: -0.00008 at 5.54).  The tracer finds
    the real crossing first and looks past it from chi = 1: lambda_c is the Hopf point, the
    crossing kept as lower_fold."""
    c = neutral_curve(vs.Physics(v=0.90), [0.6813, 1.0], DISC, locate_type_change=False)
    p = c.points[0]
    assert p.chi == 0.6813 and p.bifurcation == "hopf"
    assert p.lambda_c == pytest.approx(5.5401, abs=2e-3)
    assert p.lower_fold == pytest.approx(5.4723, abs=2e-3)
    assert 0.13 < p.omega_R < 0.17  # the scan: 0.1443 at 5.5356, 0.1494 at 5.5417


@pytest.mark.slow
def test_a_step_past_the_fold_of_an_s_shaped_branch_is_refused():
    """v = 0.95, chi = 0.2449, N = 4 on 16x32: a pseudo-arclength scan in lam (fixed arclength
    steps, docs/notes/continuation-measurements.md) shows an S-shaped branch: the part from low lam
    folds at lam = 7.510, the upper part (from its own fold near 7.41) has a Hopf point at 7.446, so
    it is unstable at 7.510 and lambda_c is the fold. Before the first step of a branch had a
    predictor, the 3 % step from 7.388 to 7.610 landed on the upper part unseen and the crossing was
    reported there (Hopf 7.4457, or a saddle-node at 7.4567 between the lower and the middle part,
    depending on the start)."""
    from vesicle.bifurcation.branch import reach
    from vesicle.bifurcation.neutral import _Tracer

    chi = 0.2449
    tracer = _Tracer(vs.Physics(v=0.95), DISC, 1e-3, 0.03, None, vs.StabilitySettings(), None)
    start = reach(vs.Physics(v=0.95, chi=chi, lam=7.2), DISC)  # one state there, below the S
    p = tracer.point(start, chi, 7.6166)  # the bisection's prediction, from chi = 0.2 and 0.3
    assert p.bifurcation == "saddle-node" and p.located
    assert p.lambda_c == pytest.approx(7.510, abs=2e-3)
    assert p.psi > -0.06  # the lower part's psi (about -0.05 at the fold; the upper part's -0.19)


def _at_chi(state, chi, lam):
    """``state`` relabelled to (chi, lam): a stand-in start state, no numerics."""
    import dataclasses

    physics = state.physics.replace(chi=chi, lam=lam)
    return dataclasses.replace(state, problem=state.problem.replace(physics=physics))


def test_a_new_chi_starts_from_further_back_where_the_neighbour_reaches_nothing(
    small_state, monkeypatch
):
    """Next to the cusp the neighbour's state can sit on the upper part of an S-shaped branch
    that folds going down in lam (v = 0.95, chi = 0.27, N = 8: every lam below 7.598 failed
    from it): the move is then tried from the next state back along the curve, at the same
    lam, before lam is lowered."""
    import types

    import vesicle.bifurcation.neutral as neutral
    from vesicle.steady.newton import NewtonError

    near, far = _at_chi(small_state, 0.27, 7.6), _at_chi(small_state, 0.3746, 7.8)
    calls = []

    def move(self, origin, chi, lam, direct=True):
        calls.append((origin.chi, lam, direct))
        if origin is near:
            raise NewtonError("the branch folds going down")
        return _at_chi(small_state, chi, lam)

    monkeypatch.setattr(neutral._Tracer, "move", move)
    stable = types.SimpleNamespace(most_unstable=(-0.1, -0.02))
    monkeypatch.setattr(neutral, "stability", lambda *a, **k: stable)
    tracer = neutral._Tracer(vs.Physics(v=0.95), DISC, 1e-3, 0.03, None, vs.StabilitySettings(),
                             None)  # fmt: skip
    state = tracer.stable_start(near, 0.23, 7.26, [far])
    assert (state.chi, state.lam) == (0.23, 7.26)  # reached at the first lam asked
    assert calls == [(0.27, 7.26, True), (0.27, 7.26, False), (0.3746, 7.26, True)]
    with pytest.raises(NewtonError, match=r"no stable tank-treading state found at chi = 0\.23"):
        tracer.stable_start(near, 0.23, 7.26)  # no fallback: lam lowered 8 times, then refused


def test_the_trace_offers_the_states_of_the_two_points_further_back(small_state, monkeypatch):
    """Each new chi of the trace gets its neighbour's start state and, as fallbacks, those of
    the two points before it (nearest first)."""
    import vesicle.bifurcation.neutral as neutral
    from vesicle.bifurcation.neutral import NeutralPoint

    offered = {}

    def point(self, start, chi, lam_pred, fallbacks=()):
        offered[chi] = (start and start.chi, [f.chi for f in fallbacks])
        return NeutralPoint(chi, 8.0, "hopf", 0.3, -0.01, 0.2, True, 1.0,
                            start=_at_chi(small_state, chi, 7.8))  # fmt: skip

    monkeypatch.setattr(neutral, "_seed", lambda tracer, chi, *a: point(tracer, None, chi, 8.0))
    monkeypatch.setattr(neutral._Tracer, "point", point)
    neutral_curve(vs.Physics(v=0.95), [1.0, 0.7, 0.5, 0.35, 0.25], DISC,
                  locate_type_change=False)  # fmt: skip
    assert offered[0.7] == (1.0, [])
    assert offered[0.5] == (0.7, [1.0])
    assert offered[0.25] == (0.35, [0.5, 0.7])


def test_a_branch_leg_that_failed_is_not_run_again_from_the_same_state(small_state, monkeypatch):
    """Each lam is tried directly (Newton, then a branch where Newton fails) and then by
    branches alone: the second try's branch from the same state to the same value is the same
    computation, so its failure is taken from the first (at N = 8 such a branch costs minutes)."""
    import types

    import vesicle.bifurcation.neutral as neutral
    from vesicle.steady.newton import NewtonError

    legs = []

    def branch(physics, disc, parameter, values, start=None, **kw):
        legs.append((parameter, values[0]))
        return types.SimpleNamespace(stopped="no steady state found beyond it", points=[])

    def newton(self, physics, start):
        raise NewtonError("diverged")

    monkeypatch.setattr(neutral, "branch", branch)
    monkeypatch.setattr(neutral._Tracer, "newton", newton)
    tracer = neutral._Tracer(vs.Physics(v=0.95), DISC, 1e-3, 0.03, None, vs.StabilitySettings(),
                             None)  # fmt: skip
    start = _at_chi(small_state, 0.27, 7.6)
    with pytest.raises(NewtonError, match="no stable tank-treading state"):
        tracer.stable_start(start, 0.23, 7.26)
    lams = [7.26 * 0.94**k for k in range(8)]  # lowered by twice the margin each time
    assert [p for p, _ in legs] == ["lam"] * 8  # one branch a lam, not two
    assert [v for _, v in legs] == pytest.approx(lams)
