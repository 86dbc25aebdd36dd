"""Branches of steady states with their stability and special points (issue 13, part 1)."""

from __future__ import annotations

import importlib
import json

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.bifurcation.branch import branch
from vesicle.cli import main


@pytest.fixture(scope="module")
def hopf_branch():
    """v = 0.95, chi = 1, N = 4 on 16 x 32 through lambda_c = 8.3371 (the bracketing search
    `critical_lambda` at xtol 1e-3, bracket [8.3366, 8.3380]; Hopf, omega_R = 0.387)."""
    p = vs.Physics(v=0.95, chi=1.0)
    return branch(
        p,
        vs.Discretisation(16, 4),
        "lam",
        [8.0, 8.2, 8.4, 8.6],
        continuation=vs.ContinuationSettings(xtol=1e-3),
    )


def test_branch_reports_the_values_asked_for_with_their_stability(hopf_branch):
    pts = [p for p in hopf_branch.points if p.requested]
    assert [p.physics.lam for p in pts] == [8.0, 8.2, 8.4, 8.6]
    assert [p.n_unstable for p in pts] == [0, 0, 2, 2]  # a complex pair beyond lambda_c
    assert [p.oscillatory for p in pts] == [False, False, True, True]
    assert all(p.steady.residual < 1e-8 for p in pts)
    psi = [p.steady.psi for p in pts]
    assert np.all(np.diff(psi) < 0)  # psi falls with lam (SPEC §10)
    assert hopf_branch.stopped is None


def test_hopf_point_is_located_where_the_bracketing_search_puts_it(hopf_branch):
    (hopf,) = hopf_branch.special_points
    assert hopf.kind == "hopf" and hopf.located and hopf.bracket == (8.2, 8.4)
    assert hopf.value == pytest.approx(8.3371, abs=2e-3)  # both to xtol = 1e-3
    assert hopf.omega_R == pytest.approx(0.387, rel=0.02)


def test_branch_json_has_the_issue_keys(hopf_branch):
    out = json.loads(json.dumps(hopf_branch.to_dict()))
    keys = {"lam", "chi", "v", "psi", "D", "axes", "S_xz", "N1", "N2", "omega_R", "omega_I",
            "n_unstable"}  # fmt: skip
    assert all(keys <= set(p) for p in out["points"]) and len(out["points"]) == 4
    assert out["special_points"][0]["type"] == "hopf"


def test_branch_refuses_bad_input_before_any_work():
    p = vs.Physics()
    with pytest.raises(ValueError, match="parameter"):
        branch(p, parameter="kappa", values=[1.0])
    with pytest.raises(ValueError, match="lam"):
        branch(p, parameter="lam", values=[1.0, -2.0])
    r = CliRunner().invoke(main, ["branch", "--lam", "1:3", "--chi", "1,2"])
    assert r.exit_code != 0 and "exactly one" in r.output
    r = CliRunner().invoke(main, ["branch", "--lam", "1:3", "--v", "1.5"])
    assert r.exit_code != 0 and "reduced volume" in r.output and "Traceback" not in r.output


def test_branch_command_json(tmp_path):
    out = tmp_path / "b.json"
    r = CliRunner().invoke(main, ["branch", "--lam", "1,2", "--degree", "2", "--grid", "12",
                                  "--out", str(out), "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    result = json.loads(r.output.strip().splitlines()[-1])
    assert [p["lam"] for p in result["points"]] == [1.0, 2.0]
    assert json.loads(out.read_text()) == result


def test_fold_estimate_follows_the_square_root_law():
    """Near a saddle-node the real leading eigenvalue goes like -sqrt(c (lam_f - lam)) (SPEC §16):
    the estimate from the last three points of a model branch is lam_f."""
    from vesicle.bifurcation.branch import _fold_estimate, _Tracer

    tracer = _Tracer(vs.Physics(chi=0.2), vs.Discretisation(16, 4), "lam", None, None, 4)
    for lam in (5.0, 5.5, 5.8):
        omega = np.array([[0.0, -np.sqrt(0.03 * (6.1 - lam))], [1.0, -1.0]])
        tracer.add(vs.BranchPoint(vs.Physics(lam=lam, chi=0.2), None, omega, True))
    fold = _fold_estimate(tracer)
    assert fold.kind == "fold" and not fold.located
    assert fold.value == pytest.approx(6.1, rel=1e-12)
    # a complex leading pair is not a fold
    tracer.path[-1] = vs.BranchPoint(vs.Physics(lam=5.8, chi=0.2), None,
                                       np.array([[0.4, -0.01]]), True)  # fmt: skip
    assert _fold_estimate(tracer) is None


@pytest.mark.slow
def test_a_hard_start_is_reached_by_continuation():
    """chi = 0.2, lam = 6 (N = 4, 16 x 32): Newton from the tilted spheroid fails there (near
    the low-shear fold, SPEC §16); `reach` continues from chi = 1 instead.  The state must be the
    one a branch in lam from lam = 2 (where Newton converges) arrives at: psi 0.20678,
    omega_I -0.0941 (measured both ways, 2026-12-01; 53 s and ~90 s)."""
    from vesicle.bifurcation.branch import reach

    p, d = vs.Physics(v=0.95, lam=6.0, chi=0.2), vs.Discretisation(16, 4)
    with pytest.raises((vs.NewtonError, vs.ShapeError, vs.SolverError)):
        vs.steady_tank_treading(p, d)
    r = reach(p, d)
    assert r.physics == p and r.residual < 1e-8
    other = (
        branch(
            p,
            d,
            "lam",
            [2.0, 3.0, 4.0, 5.0, 6.0],
            continuation=vs.ContinuationSettings(locate=False),
        )
        .points[-1]
        .steady
    )
    np.testing.assert_allclose(r.a, other.a, atol=1e-7)
    assert vs.stability(r).most_unstable[1] == pytest.approx(-0.0941, abs=5e-4)


def test_a_state_with_several_unstable_modes_is_checked_by_continuation():
    """lam = 4, chi = 10 (N = 4, 16 x 32): Newton from the tilted spheroid converges to
    psi = -0.338 with 7 unstable modes (leading (15.9, 9.6); measured 2026-12-03), which no TT
    state just past its own Hopf point has (one pair crosses there).  TT is stable at lam = 4
    (lambda_c(chi = 10) = 8.79 at this resolution, the quick report's neutral curve), and psi
    falls with lam (0.5626 at lam = 1 and 0.4854 at lam = 2 on the chi = 10 branch of the same
    report), so `reach` must return a stable state with 0 < psi < 0.4854."""
    from vesicle.bifurcation.branch import reach

    p, d = vs.Physics(v=0.95, lam=4.0, chi=10.0), vs.Discretisation(16, 4)
    trap = vs.stability(vs.steady_tank_treading(p, d))
    assert np.sum(trap.omega[:, 1] > 0) > 2
    r = reach(p, d)
    assert r.physics == p and 0.0 < r.psi < 0.4854
    assert vs.stability(r).most_unstable[1] < 0


@pytest.mark.slow
def test_pseudo_arclength_locates_the_low_shear_fold():
    """chi = 0.2, N = 4 on 16 x 32: natural continuation in lam stops near 7.482; pseudo-arclength
    passes the fold and locates it at lam = 7.48326 (measured 2026-12-01, approaching from the
    saddle half; the fold is the same from either half), a saddle-node: the leading eigenvalue
    is real and tends to zero there."""
    p, d = vs.Physics(v=0.95, chi=0.2), vs.Discretisation(16, 4)
    b = branch(p, d, "lam", [7.0, 7.25, 7.5], continuation=vs.ContinuationSettings(locate=False))
    folds = [s for s in b.special_points if s.kind == "saddle-node" and s.located]
    assert len(folds) == 1 and folds[0].value == pytest.approx(7.48326, abs=2e-3)
    assert b.stopped is not None and "folds at" in b.stopped
    near = [q for q in b.points if abs(q.physics.lam - folds[0].value) < 0.01]
    assert near and all(q.most_unstable[0] < 1e-2 and abs(q.most_unstable[1]) < 0.02 for q in near)


def test_approach_exponent_recovers_known_power_laws():
    """Synthetic growth rates with exact power laws (the square root of a saddle-node, a linear
    crossing): the fit returns their exponents and coefficients."""
    from vesicle.bifurcation.branch import approach_exponent

    lam = np.linspace(6.0, 7.49, 12)
    fit = approach_exponent(lam, -0.8 * np.sqrt(7.5 - lam), 7.5)
    assert fit["exponent"] == pytest.approx(0.5, abs=1e-12)
    assert fit["coefficient"] == pytest.approx(0.8, rel=1e-12) and fit["points"] == 12
    assert approach_exponent(lam, 2.0 * (7.5 - lam), 7.5)["exponent"] == pytest.approx(1.0)
    free = approach_exponent(lam, -0.8 * np.sqrt(7.5 - lam))  # the fold fitted too
    assert free["exponent"] == pytest.approx(0.5, abs=1e-8)
    assert free["critical"] == pytest.approx(7.5, abs=1e-8)
    with pytest.raises(ValueError, match="two points"):
        approach_exponent([7.5, 8.0], [0.0, 1.0], 7.5)


def test_branch_figures_with_the_fold_approach(tmp_path):
    """`vesicle plot branch.json`: branch_shape.png and branch_omega.png; the fold approach of a
    synthetic branch whose leading real eigenvalue is -0.5 sqrt(7.5 - lam) has exponent 1/2."""
    from vesicle.plots.branch import fold_approach

    pts = []
    for lam in np.linspace(7.0, 7.49, 8):
        w = -0.5 * np.sqrt(7.5 - lam)
        pts.append({"lam": lam, "chi": 0.2, "v": 0.95, "psi": 0.1, "D": 0.2, "S_xz": 2.0,
                    "omega_R": 0.0, "omega_I": w, "eigenvalues": [[0.0, w], [1.0, -2.0]],
                    "n_unstable": 0})  # fmt: skip
    fold = {"type": "fold", "lam": 7.5, "omega_R": 0.0, "located": True, "bracket": [7.5, 7.5]}
    data = {"parameter": "lam", "degree": 4, "grid": 16, "physics": {"v": 0.95, "chi": 0.2},
            "points": pts, "special_points": [fold]}  # fmt: skip
    fit = fold_approach(data)
    assert fit["exponent"] == pytest.approx(0.5, abs=1e-9) and fit["critical"] == 7.5
    path = tmp_path / "b.json"
    path.write_text(json.dumps(data))
    r = CliRunner().invoke(main, ["plot", str(path), "--out", str(tmp_path / "fig")])
    assert r.exit_code == 0, r.output
    for name in ("branch_shape.png", "branch_omega.png"):
        assert (tmp_path / "fig" / name).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_the_fold_is_the_zero_of_the_curvature_form_of_the_stability_operator():
    """v = 0.85, chi = 1, N = 4 on 16 x 32, where the multipliers are not small (0.0057,
    -0.0140): the branch turns (lam extremal, located by pseudo-arclength) at lam = 4.09497
    (measured 2026-12-03). There the operator with the multipliers' curvature,
    Q^T (M - mu . H) Q, has a zero eigenvalue (a singular bordered Jacobian is a zero of it:
    the fold's defining property, SPEC §16): its leading growth rate changes sign across the
    fold; SPEC §9's Q^T M Q has crossed zero already, near lam = 4.074 (reported as the
    branch's first saddle-node), and is 0.04-0.05 at the fold."""
    from vesicle.steady.stability import stability

    p, d = vs.Physics(v=0.85, chi=1.0), vs.Discretisation(16, 4)
    b = branch(
        p,
        d,
        "lam",
        [3.9, 4.0, 4.05, 4.07, 4.09, 4.1],
        continuation=vs.ContinuationSettings(past_fold=3),
    )
    folds = [s for s in b.special_points if s.kind == "saddle-node" and s.located]
    assert len(folds) == 2
    crossing, turn = sorted(s.value for s in folds)
    assert crossing == pytest.approx(4.0739, abs=2e-3) and turn == pytest.approx(4.09497, abs=1e-3)
    i = int(np.argmax([q.physics.lam for q in b.points]))  # the last point before the turn
    before, after = b.points[i - 1], b.points[i + 1]
    w_before = stability(before.steady, curvature=True).most_unstable[1]
    w_after = stability(after.steady, curvature=True).most_unstable[1]
    assert w_before < 0 < w_after and max(-w_before, w_after) < 5e-3
    assert before.most_unstable[1] > 0.03  # SPEC §9's operator: unstable before the turn


def test_the_tangent_predictor_of_a_lone_start_is_second_order(hopf_branch):
    """The first step from a start has the tangent predictor ``a + (da/dlam) h`` (so that the
    jump guard works from the first step).  Taylor: its error is O(h^2), so halving h divides
    it by about 4 (the states at lam = 8.0 and 8.2 from the fixture, 8.1 solved here; all
    converged to residual 1e-8, far below the errors compared).  A wrong sign or a wrong dG/dlam
    would make the error O(h), a ratio near 2."""
    from vesicle.bifurcation.branch import _analyse, _Tracer
    from vesicle.steady.newton import steady_tank_treading

    p0, p2 = (next(p for p in hopf_branch.points if p.physics.lam == x) for x in (8.0, 8.2))
    tracer = _Tracer(p0.physics, hopf_branch.discretisation, "lam", None, None, 4)
    start = tracer.add(_analyse(p0.steady, requested=False))
    mid = steady_tank_treading(p0.physics.replace(lam=8.1), hopf_branch.discretisation,
                               initial=p0.steady)  # fmt: skip
    err = [np.linalg.norm(tracer.tangent_guess(start, r.physics.lam) - r.a)
           for r in (mid, p2.steady)]  # fmt: skip
    # measured: errors 2.04e-4 and 7.70e-4 (ratio 3.78) against a step of 7.75e-3
    assert 3.0 < err[1] / err[0] < 5.0


def test_a_failed_step_is_not_halved_below_a_quarter_of_xtol(monkeypatch):
    """A model branch with a fold at lam = 7.6002 (the corrector fails beyond it): natural
    continuation in steps of 0.004 from 7.59 halves failed steps down to xtol/4 = 2.5e-4, no
    further, and stops there, the fold between the last state and the first failed value; before
    the floor it crept on in steps of 1e-5 (v = 0.95, chi = 0.2594, N = 8, 4 min a failure)."""
    vb = importlib.import_module("vesicle.bifurcation.branch")

    fold, tried = 7.6002, []

    def correct(self, value, requested=True, on_path=True):
        tried.append(value)
        if value > fold:
            raise vs.NewtonError(f"no state at lam = {value}")
        return self.add(vs.BranchPoint(vs.Physics(lam=value, chi=0.2), None,
                                       np.array([[0.0, -0.1]]), requested), on_path)  # fmt: skip

    monkeypatch.setattr(vb._Tracer, "correct", correct)
    tracer = vb._Tracer(vs.Physics(chi=0.2), vs.Discretisation(16, 4), "lam", None, None, 4,
                        min_step=vb.MIN_STEP * 1e-3)  # fmt: skip
    tracer.add(vs.BranchPoint(vs.Physics(lam=7.59, chi=0.2), None, np.array([[0.0, -0.1]]), True))
    with pytest.raises(vb._Stop) as stop:
        for value in (7.594, 7.598, 7.602, 7.606):
            tracer.step_to(value)
    last, failed = stop.value.last, stop.value.target
    assert last <= fold < failed and failed - last >= 2.5e-4 and failed - last < 1e-3
    assert "below 0.00025" in stop.value.why
    steps = np.diff(sorted(set(tried)))
    assert steps.min() >= 2.5e-4 - 1e-12  # never closer than the floor
    # without the floor: halved 4 times after each success, creeping to 1e-5 of the fold
    tried.clear()
    creeper = vb._Tracer(vs.Physics(chi=0.2), vs.Discretisation(16, 4), "lam", None, None, 4)
    creeper.add(vs.BranchPoint(vs.Physics(lam=7.59, chi=0.2), None, np.array([[0.0, -0.1]]),
                               True))  # fmt: skip
    with pytest.raises(vb._Stop) as stop:
        for value in (7.594, 7.598, 7.602, 7.606):
            creeper.step_to(value)
    assert fold - stop.value.last < 1e-5 and len(tried) > 2 * len(set(tried) & {7.594, 7.598})


def _model_fold_tracer(monkeypatch, omega_R: float):
    """A model branch with a fold at lam = 7.6002 (the corrector fails beyond it) whose leading
    eigenvalue is ``omega_R + i omega_I`` with omega_I = -sqrt(fold - lam) (the saddle-node law,
    SPEC §16) or, with omega_R != 0, a complex pair."""
    vb = importlib.import_module("vesicle.bifurcation.branch")
    fold, tried = 7.6002, []

    def point(value):
        growth = -np.sqrt(max(fold - value, 0.0))
        return vs.BranchPoint(vs.Physics(lam=value, chi=0.2), None,
                              np.array([[omega_R, growth]]), True)  # fmt: skip

    def correct(self, value, requested=True, on_path=True):
        tried.append(value)
        if value > fold:
            raise vs.NewtonError(f"no state at lam = {value}")
        return self.add(point(value), on_path)

    monkeypatch.setattr(vb._Tracer, "correct", correct)
    tracer = vb._Tracer(vs.Physics(chi=0.2), vs.Discretisation(16, 4), "lam", None, None, 4,
                        min_step=vb.MIN_STEP * 1e-3)  # fmt: skip
    tracer.add(point(7.55))
    return vb, tracer, tried, fold


def test_failed_steps_next_to_a_fold_hand_over_to_the_arclength_early(monkeypatch):
    """After EARLY_FAILURES failed correctors next to a fold (real leading eigenvalue, growth
    nearing zero) natural continuation stops for the arclength; the same model without the early
    stop needs many more failed correctors (each one 4-5 s at N = 4 and minutes at N = 8)."""
    vb, tracer, tried, fold = _model_fold_tracer(monkeypatch, 0.0)
    with pytest.raises(vb._Stop) as stop:
        for value in (7.57, 7.59, 7.61, 7.63):
            tracer.step_to(value, early=True)
    assert stop.value.early and stop.value.last <= fold < stop.value.target
    early_failures = sum(x > fold for x in tried)
    assert early_failures == vb.EARLY_FAILURES
    vb, tracer, tried, fold = _model_fold_tracer(monkeypatch, 0.0)
    with pytest.raises(vb._Stop) as stop:
        for value in (7.57, 7.59, 7.61, 7.63):
            tracer.step_to(value)
    assert not stop.value.early and sum(x > fold for x in tried) >= 2 * early_failures


def test_a_complex_leading_pair_does_not_stop_early(monkeypatch):
    """With a complex leading pair (|omega_R| > REAL_TOLERANCE) failed steps are not a
    saddle-node fold ahead: halving goes on as before."""
    vb, tracer, tried, fold = _model_fold_tracer(monkeypatch, 0.05)
    with pytest.raises(vb._Stop) as stop:
        for value in (7.57, 7.59, 7.61, 7.63):
            tracer.step_to(value, early=True)
    assert not stop.value.early and sum(x > fold for x in tried) > vb.EARLY_FAILURES


@pytest.mark.slow
def test_halved_steps_next_to_a_fold_take_the_tangent_not_the_long_secant():
    """v = 0.95, chi = 0.2, N = 8 on 16 x 32, lam = 6.5 ... 8 in steps of 0.5 (Figure 14's TT
    branch at chi = 0.2): the step 7.5 -> 8 fails past the fold and is halved.  The halved
    steps used the secant through 7.0 and 7.5, which misses the branch's bend by more than the
    short step itself, so the jump guard refused 7.5625 and 7.53125 on the same branch
    ("moved 3.83e-03 ... more than the step itself (2.93e-03)"), the branch stopped at 7.5 and
    its fold was only estimated (the full report's fig14 failed this way on 32 x 64,
    2026-12-08).  With the tangent predictor on such steps it reaches 7.5625 and locates the
    fold.  Expected: the fold of the same branch located on 32 x 64 by fig8 (7.5642850,
    docs/validation/full/fig8/item.json) and on 16 x 32 with the time stepping's multipliers
    (7.56413); about 2 min."""
    d = vs.Discretisation(16, 8)
    b = branch(vs.Physics(v=0.95, chi=0.2), d, "lam", [6.5, 7.0, 7.5, 8.0])
    folds = [s for s in b.special_points if s.kind in ("saddle-node", "fold")]
    assert folds and folds[0].located
    assert folds[0].value == pytest.approx(7.5643, abs=1e-3)
    assert max(p.physics.lam for p in b.points) > 7.55
