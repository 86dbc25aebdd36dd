"""The neutral curve by two-parameter continuation (vesicle.bifurcation.neutral_codim2).

Fast tests: the rule that picks the neutral point among the curves (the upper edge of the
stable region: the largest lambda at which a state loses stability, among points with no other
unstable eigenvalue) on hand-made curves with exact answers, and the JSON of the result.
Slow: the vesicle at v = 0.95, N = 4 on 16x32, against the one-parameter tracer's bracket of
the type change and the stability analysis at the BT point."""

import math

import numpy as np
import pytest

import vesicle as vs
from vesicle.bifurcation import codim2
from vesicle.bifurcation.neutral import NeutralPoint
from vesicle.bifurcation.neutral_codim2 import _candidates, _Curve, _winner, neutral_curve_codim2
from vesicle.io.memo import MemoMismatch


def _pt(kind, chi, lam, other=False, converged=True):
    return codim2.CurvePoint(kind=kind, x=np.zeros(3), p=np.array([math.log(chi), lam]),
                             omega=0.3 if kind == "hopf" else 0.0, residual=1e-10,
                             converged=converged, iterations=2, tests={},
                             eigenvalues=np.zeros(0), other_unstable=other, v=np.zeros(3),
                             w=np.zeros(3))  # fmt: skip


def _curve(kind, points):
    return _Curve(kind, codim2.Curve(kind, "minaug", tuple(points), (), "bounds",
                                     codim2.Evaluations()))  # fmt: skip


def test_the_neutral_point_is_the_upper_edge_of_the_stable_region():
    """A lower-sheet fold curve rising 7.45 -> 7.55 over chi 0.1 -> 0.3 and an upper-sheet
    Hopf curve rising 7.2 -> 7.8 over chi 0.2 -> 0.3 (both linear in log chi): below their
    crossing the fold is the edge, above it the Hopf point; the crossing of the two straight
    lines in log chi is where the winner changes."""
    fold = _curve("fold", [_pt("fold", 0.1, 7.45), _pt("fold", 0.3, 7.55)])
    hopf = _curve("hopf", [_pt("hopf", 0.2, 7.2), _pt("hopf", 0.3, 7.8)])
    curves = [fold, hopf]
    assert _winner(curves, 0.15, 1).kind == "fold"  # only the fold covers it
    t = math.log
    lam_f = lambda c: 7.45 + 0.1 * (t(c) - t(0.1)) / (t(0.3) - t(0.1))  # noqa: E731
    lam_h = lambda c: 7.2 + 0.6 * (t(c) - t(0.2)) / (t(0.3) - t(0.2))  # noqa: E731
    w = _winner(curves, 0.22, 1)
    assert w.kind == "fold" and w.lam == pytest.approx(lam_f(0.22), rel=1e-14)
    w = _winner(curves, 0.29, 1)
    assert w.kind == "hopf" and w.lam == pytest.approx(lam_h(0.29), rel=1e-14)
    assert _winner(curves, 0.05, 1) is None  # outside every curve
    # the vorticity branch is stable above its curve: the lowest loss counts
    assert _winner(curves, 0.22, -1).kind == "hopf"


def test_points_with_another_unstable_eigenvalue_or_not_converged_are_not_candidates():
    """A curve segment counts only between two converged points with no other unstable
    eigenvalue (there the curve is not a stability boundary)."""
    off = _curve("fold", [_pt("fold", 0.1, 9.0, other=True), _pt("fold", 0.3, 9.5)])
    failed = _curve("hopf", [_pt("hopf", 0.1, 9.9), _pt("hopf", 0.3, 9.9, converged=False)])
    good = _curve("hopf", [_pt("hopf", 0.1, 8.0), _pt("hopf", 0.3, 8.5)])
    kinds = [c.lam for c in _candidates([off, failed, good], 0.2)]
    assert len(kinds) == 1 and 8.0 < kinds[0] < 8.5


def test_a_codim2_point_keeps_its_residual_and_spectrum_check_in_the_json():
    p = NeutralPoint(0.3, 7.8, "hopf", 0.09, -0.1, 0.19, True, 4.0, None, None, -0.003,
                     7.5, True, residual=4e-10, other_unstable=False)  # fmt: skip
    d = p.to_dict()
    assert d["residual"] == 4e-10 and d["other_unstable"] is False and d["located"] is True
    back = NeutralPoint.from_dict(d)
    assert back.residual == 4e-10 and back.other_unstable is False
    assert back.lower_fold == 7.5 and back.lower_fold_located
    # a tracer point has neither key, and reads back without them
    old = {k: v for k, v in d.items() if k not in ("residual", "other_unstable")}
    assert NeutralPoint.from_dict(old).residual is None


def test_bad_arguments_are_refused_before_any_work():
    with pytest.raises(ValueError, match="chi"):
        neutral_curve_codim2(vs.Physics(v=0.95), [], vs.Discretisation(grid=8, degree=2))
    with pytest.raises(ValueError, match="lam_range"):
        neutral_curve_codim2(vs.Physics(v=0.95), [1.0], vs.Discretisation(grid=8, degree=2),
                             lam_range=(5.0, 1.0))  # fmt: skip


@pytest.mark.slow
def test_the_curve_near_the_type_change_is_located_at_v095_n4():
    """v = 0.95, N = 4 on 16x32, chi = 0.23 and 0.28 (about 5 min): the Hopf curve from 0.28
    down to its BT point, the lower sheet's fold found from low lambda at 0.23 and continued
    up, the type change where they cross.  Independent references: the one-parameter tracer
    bracketed the change in [0.2544, 0.2577] with lambda_c about 7.520
    (docs/notes/continuation-measurements.md) and SPEC 14 puts it near 0.25; the BT point is a
    double zero of the pencil's finite eigenvalues, computed apart from the BT system's Newton
    (the pencil is the stability analysis of vesicle.steady.stability: test_steady_codim2; a
    double zero solved to 1e-8 splits by about its square root, 1e-4).  Measured (2026-12-06,
    the whole curve 0.1-10): type change 0.256642, lambda_c 7.51972; BT 0.21855, 7.19111."""
    disc = vs.Discretisation(grid=16, degree=4)
    curve = neutral_curve_codim2(vs.Physics(v=0.95), [0.23, 0.28], disc)
    assert not curve.failed
    low, high = curve.points
    assert low.located and high.located and not low.other_unstable and not high.other_unstable
    assert low.bifurcation == "saddle-node" and high.bifurcation == "hopf"
    assert low.residual < 1e-8 and high.residual < 1e-8
    t = curve.type_change
    assert t["located"] and t["below"] == "saddle-node" and t["above"] == "hopf"
    assert 0.2544 <= t["chi"] <= 0.2577
    assert t["lambda_c"] == pytest.approx(7.520, abs=5e-3)
    bt = [q for q in curve.bt_points if q["located"]]
    assert bt and all(abs(complex(*z)) < 1e-3 for z in bt[0]["smallest_eigenvalues"])
    assert t["chi"] == pytest.approx(0.256642, abs=2e-5)


@pytest.mark.slow
def test_above_the_coarse_resolution_the_seed_comes_from_the_coarse_search():
    """N = 5 on 18x36 (finer than N = 4 on 16x32): the seed at chi = 3 is solved for from the
    coarse first loss of stability (the progress says so), located on the N = 5 augmented system,
    and equals, to that search's 1e-3, the lambda_c of the bracketing search at N = 5 itself
    (critical_lambda without its coarse start: the independent way); a curve seeded on the
    only requested chi is not continued, the seed is its point.  Measured: 8.575964 against
    the search's 8.575974 (N = 4's 8.575966: at chi = 3 the two resolutions nearly agree, so
    this checks the path and the agreement, not the refinement's size)."""
    physics = vs.Physics(v=0.95, chi=3.0)
    disc = vs.Discretisation(grid=18, degree=5)
    said = []
    c = neutral_curve_codim2(physics, [3.0], disc, locate_type_change=False,
                             progress=said.append)  # fmt: skip
    assert any("from_coarse" in d for d in said)
    assert not any("direction" in d for d in said)
    (point,) = c.points
    assert point.located and point.bifurcation == "hopf"
    full = vs.critical_lambda(physics.replace(lam=1.0), disc, search=vs.CriticalSearch(coarse=None))
    assert point.lambda_c == pytest.approx(full.lambda_c, abs=2e-3)


@pytest.mark.slow
def test_where_the_fold_curve_turns_in_chi_the_curve_ends_and_is_said_to():
    """v = 0.85, N = 4 on 16x32, chi = 0.1 and 0.147 (about 2 min): the fold curve from
    chi = 0.147 down turns in chi (a smooth extremum, not a cusp), the turn is located, and
    chi = 0.1, beyond it, is a failure that says so (no stable state for lambda in [0.5, 100]).
    Independent reference: the same fold curve traced with steps of 0.05 (the fifth session's
    measurement, docs/notes/codim2-measurements.md) sampled chi down to 0.125171 at
    lambda = 1.695 and 0.125178 at 1.615, so the extremum lies at or below 0.125171 and near
    lambda = 1.65; located there at 0.1251487, 1.66738."""
    disc = vs.Discretisation(grid=16, degree=4)
    curve = neutral_curve_codim2(vs.Physics(v=0.85), [0.1, 0.147], disc)
    (point,) = curve.points
    assert point.located and point.bifurcation == "saddle-node" and point.chi == 0.147
    (turn,) = [q for q in curve.turn_points if q["located"]]
    assert 0.12505 <= turn["chi"] <= 0.125171 and turn["lambda"] == pytest.approx(1.66, abs=0.04)
    (fail,) = curve.failed
    assert fail["chi"] == 0.1 and "turns back" in fail["error"] and "no stable" in fail["error"]
    assert not curve.cusp_points


def test_an_interruption_carries_the_curves_traced_so_far():
    """Ctrl-C at the Hopf curve's first point (v = 0.98, N = 4 on 12x24: Hopf points only):
    CurveInterrupted (a KeyboardInterrupt) carries that curve with its point, marked
    incomplete; nothing is picked as a neutral point."""
    from vesicle.bifurcation.neutral_codim2 import CurveInterrupted

    def progress(d):
        if "lam" in d and "curve" in d:  # a point of a curve under way
            raise KeyboardInterrupt

    with pytest.raises(CurveInterrupted) as err:
        neutral_curve_codim2(vs.Physics(v=0.98), [1.0, 2.0], vs.Discretisation(grid=12, degree=4),
                             progress=progress)  # fmt: skip
    assert isinstance(err.value, KeyboardInterrupt)
    partial = err.value.partial
    assert partial["interrupted"] and partial["complete"] is False
    (curve,) = partial["curves"]
    assert curve["kind"] == "hopf" and curve["end"] == "interrupted"
    (point,) = curve["points"]
    assert point["converged"] and 11 < point["lam"] < 14  # v = 0.98's Hopf curve, 12.7 at chi = 1
    assert "points" not in partial


def test_an_interrupted_curve_run_again_with_its_memo_replays_and_goes_on(tmp_path):
    """Ctrl-C at the Hopf curve's first point (v = 0.98, N = 4 on 12x24), then the same call
    with the same memo: the seed's search result and the evaluations made after it are looked
    up (none computed twice), the rest computed, and the neutral points are those of a run
    never interrupted, to the augmented systems' tolerance (1e-8; the resumed run's solves
    start from other guesses)."""
    from vesicle.bifurcation.neutral_codim2 import CurveInterrupted, curve_memo

    physics, disc, chis = vs.Physics(v=0.98), vs.Discretisation(grid=12, degree=4), [1.0, 2.0]
    whole = neutral_curve_codim2(physics, chis, disc)

    def progress(d):
        if "lam" in d and "curve" in d:
            raise KeyboardInterrupt

    memo = curve_memo(tmp_path / "m", physics, disc)
    with pytest.raises(CurveInterrupted):
        neutral_curve_codim2(physics, chis, disc, memo=memo, progress=progress)
    kept = len(memo)
    again = curve_memo(tmp_path / "m", physics, disc)
    said = []
    resumed = neutral_curve_codim2(physics, chis, disc, memo=again, progress=said.append)
    # the seed's search is replayed whole (its result kept), not stepped again: its own
    # evaluations are then not looked up, the continuation's are
    assert said[0]["replayed"] == "seed" and said[0]["chi"] == chis[0]
    assert kept > 0 and 0 < again.hits < kept and again.misses > 0
    assert [p.chi for p in resumed.points] == [p.chi for p in whole.points] == chis
    for a, b in zip(resumed.points, whole.points, strict=True):
        assert a.located and b.located and a.bifurcation == b.bifurcation == "hopf"
        assert abs(a.lambda_c - b.lambda_c) < 1e-8 * b.lambda_c
    with pytest.raises(MemoMismatch):
        curve_memo(tmp_path / "m", physics, vs.Discretisation(grid=12, degree=3))


def test_a_replayed_search_puts_back_the_stable_states_it_kept(tmp_path):
    """A search kept in the memo (``_kept``) keeps the stable states it found for later starts
    (``_keep_stable``) with its point; a fresh context that replays it has those states again,
    the same (chi, lambda, discretisation) and radius coefficients bit for bit, after the states
    it already held, and the search is not run a second time.  The stand-in search appends two
    states as the real one does (a spheroid and a perturbed one on 12x24)."""
    from types import SimpleNamespace

    from vesicle.bifurcation import codim2
    from vesicle.bifurcation.neutral_codim2 import _kept, curve_memo
    from vesicle.geometry.surface import Shape

    physics, disc = vs.Physics(v=0.95), vs.Discretisation(grid=12, degree=4)
    coarse = vs.Discretisation(grid=16, degree=4)
    shapes = [Shape.spheroid(0.95, grid=12, degree=4), Shape.spheroid(0.9, grid=12, degree=4)]
    point = codim2.CurvePoint(x=np.arange(5.0), p=np.array([0.1, 7.5]),
                              eigenvalues=np.array([0.0, -1.0]), v=np.ones(3), w=np.ones(3),
                              kind="fold", omega=0.0, residual=1e-10, converged=True,
                              iterations=3, tests={}, other_unstable=False, refused=None)
    calls = []

    def search(ctx):
        calls.append(1)
        ctx.stable.append((1.1, 7.0, disc, shapes[0]))
        ctx.stable.append((1.2, 7.2, coarse, shapes[1]))
        return point

    def context(memo, stable):
        return SimpleNamespace(eq=SimpleNamespace(memo=memo), stable=list(stable),
                               say=lambda d: None)

    before = (0.5, 6.0, disc, shapes[1])
    first = context(curve_memo(tmp_path / "m", physics, disc), [before])
    _kept(first, "first loss", lambda: search(first), 1.0, 7.0)
    again = context(curve_memo(tmp_path / "m", physics, disc), [before])
    replayed = _kept(again, "first loss", lambda: search(again), 1.0, 7.0)
    assert len(calls) == 1 and np.array_equal(replayed.p, point.p)
    assert [(c, lam, d) for c, lam, d, _ in again.stable] == [(c, lam, d) for c, lam, d, _ in
                                                              first.stable]  # fmt: skip
    for (*_, a), (*_, b) in zip(again.stable, first.stable, strict=True):
        assert isinstance(a, Shape) and np.array_equal(a.coefficients, b.coefficients)
        assert a.grid.n_theta == b.grid.n_theta
