"""Neutral curves (issue 13, part 2): the critical point continued in chi."""

import json

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
    brackets afresh (the reference): the two agree to their tolerances (1e-3 each).  The
    reference starts near the root (lam0 = 8.4, 1 % steps, as docs/steady.md uses it): from its
    default start its secant jumps (lam 5.85 -> 8.78 in one Newton solve) land on a second,
    stable steady state (psi = +0.021 where the branch continued in small steps has
    psi = -0.011 and is unstable), and it brackets nothing (measured)."""
    traced = next(p for p in curve.points if p.chi == 3.0)
    reference = critical_lambda(vs.Physics(v=0.95, chi=3.0), DISC, lam0=8.4, step=0.01,
                                xtol=1e-3)  # fmt: skip
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
