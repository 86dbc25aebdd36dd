"""The out-of-plane (vorticity-aligned) TT branch (issue 15, part 1)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main
from vesicle.steady.newton import NewtonError

DISC = vs.Discretisation(grid=12, degree=4)
POINT = vs.Physics(v=0.95, lam=11.0, chi=4.0)


@pytest.fixture(scope="module")
def vorticity():
    return vs.steady_tank_treading(
        POINT, DISC, analysis=vs.StabilitySettings(orientation="vorticity")
    )


def test_the_vorticity_branch_has_its_long_axis_along_y(vorticity):
    """Newton from the spheroid along y converges to a state whose longest axis is y (exactly,
    by the y -> -y symmetry of the basis); the in-plane start at the same point gives the
    in-plane branch, a different state."""
    assert vorticity.orientation == "vorticity"
    assert abs(vorticity.long_axis[1]) == pytest.approx(1.0, abs=1e-12)
    flow = vs.steady_tank_treading(POINT, DISC)
    assert flow.orientation == "flow" and abs(flow.long_axis[1]) < 1e-12
    assert not np.allclose(flow.axes, vorticity.axes, atol=1e-2)


def test_a_state_on_the_other_branch_is_refused(vorticity):
    """Continuation keeps the branch of its start; asking for the other one from it is refused
    (Newton 'slid onto the other branch'), not reported."""
    again = vs.steady_tank_treading(POINT.replace(lam=11.5), DISC, initial=vorticity)
    assert again.orientation == "vorticity"
    with pytest.raises(NewtonError, match="'vorticity' branch"):
        vs.steady_tank_treading(
            POINT, DISC, initial=vorticity, analysis=vs.StabilitySettings(orientation="flow")
        )
    with pytest.raises(ValueError, match="orientation"):
        vs.steady_tank_treading(POINT, DISC, analysis=vs.StabilitySettings(orientation="y"))


def test_tt_orientation_json_has_the_long_axis():
    args = ["--lam", "11", "--chi", "4", "--grid", "12", "--degree", "4", "--json"]
    r = CliRunner().invoke(main, ["tt", *args, "--orientation", "vorticity"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output.strip().splitlines()[-1])
    assert out["orientation"] == "vorticity" and abs(out["long_axis"][1]) == pytest.approx(1.0)


def test_a_branch_of_the_vorticity_state_with_general_modes(vorticity):
    """The branch stays on the vorticity branch and analyses general modes: the pair that breaks
    the x-z symmetry is the most unstable (at N = 4 on 16x32, lam = 11, chi = 4: (1.2572,
    +0.0081) in general modes while every symmetric mode decays, (2.1866, -0.0606); measured),
    so the symmetric analysis alone would call the state stable."""
    b = vs.branch(
        POINT,
        DISC,
        "lam",
        [11.0, 12.0],
        start=vorticity,
        analysis=vs.StabilitySettings(modes="general"),
    )
    assert all(p.steady.orientation == "vorticity" for p in b.points)
    general = b.points[-1].omega
    symmetric = vs.stability(b.points[-1].steady).omega
    assert general.shape[0] > 0 and symmetric[0, 1] < 0
    assert general[0, 1] > symmetric[0, 1]  # a symmetry-breaking mode leads


def test_vorticity_searches_start_where_the_branch_exists():
    """At v = 0.90, chi = 2 (N = 4, 12x24) Newton from the spheroid along y slides onto the
    in-plane branch at lam = 4.28 (twice the leading-order in-plane lambda_c, the old default
    start of vorticity searches) and the vorticity-aligned branch, continued down from 8.56,
    ends near lam = 5.27 (measured 2026-12-03): the default start is now four times the
    leading-order value (at least 4), where Newton converges on that branch; below, ``reach``
    says which easier starts it tried and where the continuation stopped."""
    from vesicle.bifurcation.branch import reach
    from vesicle.bifurcation.critical import vorticity_start_lambda
    from vesicle.model.theory import misbah_critical_lambda

    d = vs.Discretisation(grid=12, degree=4)
    lam = vorticity_start_lambda(0.90)
    assert lam == pytest.approx(4.0 * misbah_critical_lambda(0.90)) and lam > 8.0
    r = reach(
        vs.Physics(v=0.90, lam=lam, chi=2.0),
        d,
        analysis=vs.StabilitySettings(orientation="vorticity"),
    )
    assert r.orientation == "vorticity" and abs(r.long_axis[1]) > 0.99
    with pytest.raises(NewtonError, match=r"continuation towards lam = 4\.28 stopped"):
        reach(
            vs.Physics(v=0.90, lam=4.28, chi=2.0),
            d,
            analysis=vs.StabilitySettings(orientation="vorticity"),
        )
