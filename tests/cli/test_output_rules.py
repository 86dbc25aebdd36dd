"""Issue 38: one overwrite/resume rule for the commands that write, what Ctrl-C keeps, a sweep
point done only when complete, the provenance of a steady state, and run files as xarray users
expect them.  Expected behaviours come from the README ("An existing output file is not replaced
without --overwrite") and the issue's list; each test fails if that rule is broken."""

import json
import sys

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main
from vesicle.cli import steady as cli_steady
from vesicle.steady.files import read_steady, steady_summary, write_steady
from vesicle.steady.newton import NewtonError
from vesicle.workflows.sweep import run_point
from vesicle.workflows.tasks import TASKS, Task

TINY = vs.Discretisation(grid=8, degree=2)
# the modules (``vesicle.bifurcation.branch`` is also the name of a function in the package
# namespace)
branch_module = sys.modules["vesicle.bifurcation.branch"]
critical_module = sys.modules["vesicle.bifurcation.critical"]


def run(*args):
    return CliRunner().invoke(main, list(args))


@pytest.fixture(scope="module")
def tiny_state():
    """A converged state at N = 2 on 8x16 (about a second)."""
    return vs.steady_tank_treading(vs.Physics(v=0.95, lam=1.0, chi=1.0), TINY)


# ------------------------------------------------------------------ overwrite and resume
@pytest.mark.parametrize("command", [
    ("branch", "--lam", "1,2"), ("neutral", "--chi", "1,2"), ("tt",),
])  # fmt: skip
def test_an_existing_out_file_is_refused_without_overwrite(tmp_path, command):
    out = tmp_path / "x.json"
    out.write_text("{}")
    r = run(*command, "--degree", "2", "--grid", "8", "--out", str(out))
    assert r.exit_code != 0 and "exists" in r.output and "--overwrite" in r.output
    assert out.read_text() == "{}"


def test_neutral_refuses_to_mix_a_new_curve_with_old_states(tmp_path):
    out = tmp_path / "n.json"
    folder = tmp_path / "n.states"
    folder.mkdir()
    (folder / "chi_1.h5").write_text("an earlier curve's state")
    r = run("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8", "--out", str(out),
            "--continuation", "trace")  # fmt: skip
    assert r.exit_code != 0 and "holds 1 states" in r.output and "--resume" in r.output
    r = run("neutral", "--chi", "1,2", "--out", str(out), "--resume", "--overwrite",
            "--continuation", "trace")  # fmt: skip
    assert r.exit_code != 0 and "give one" in r.output


def test_neutral_overwrite_clears_the_old_states_before_tracing(tmp_path, monkeypatch):
    out = tmp_path / "n.json"
    out.write_text("{}")
    folder = tmp_path / "n.states"
    folder.mkdir()
    (folder / "chi_1.h5").write_text("old")

    def stop(*args, **kwargs):  # the trace itself is not what is tested
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_steady, "neutral_curve", stop)
    r = run("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8", "--out", str(out),
            "--overwrite", "--continuation", "trace")  # fmt: skip
    assert not (folder / "chi_1.h5").exists()
    # Ctrl-C says what was kept and how to go on, not click's bare "Aborted!"
    assert r.exit_code == 130 and "interrupted" in r.output and "--resume" in r.output


def test_branch_states_are_not_replaced_without_overwrite(tmp_path):
    folder = tmp_path / "st"
    folder.mkdir()
    (folder / "lam_2.h5").write_text("kept")
    r = run("branch", "--lam", "1,2", "--degree", "2", "--grid", "8", "--states", str(folder))
    assert r.exit_code != 0 and "lam_2.h5" in r.output and "--overwrite" in r.output


def test_run_resumed_to_a_time_it_has_passed_is_refused(tmp_path):
    out = tmp_path / "r.h5"
    r = run("run", "--grid", "8", "--degree", "2", "--t-end", "0.01", "--no-plot",
            "--no-progress", "--out", str(out))  # fmt: skip
    assert r.exit_code == 0, r.output
    r = run("run", "--resume", str(out), "--t-end", "0.005", "--no-plot", "--no-progress")
    assert r.exit_code != 0 and "already at t" in r.output


# -------------------------------------------------------------------- sweep completeness
def test_a_branch_that_stopped_short_is_not_a_done_sweep_point(monkeypatch):
    def stopped_branch(physics, disc, options, settings):
        return {"points": [], "stopped": "Newton failed past the fold at lam = 7.5"}

    monkeypatch.setitem(TASKS, "branch", Task(stopped_branch, (), (),
                                              TASKS["branch"].incomplete))  # fmt: skip
    entry = run_point("branch", vs.Physics().to_dict(), TINY.to_dict(), {}, {})
    assert entry["status"] == "failed" and "stopped before its last value" in entry["error"]
    assert entry["result"]["stopped"]  # what it found is kept


# -------------------------------------------------------------------- provenance of a start
def test_a_state_is_stamped_with_its_start_in_json_and_files(tiny_state, tmp_path):
    assert tiny_state.start == "direct" and not tiny_state.suspect
    assert steady_summary(tiny_state)["start"] == "direct"
    again = vs.steady_tank_treading(tiny_state.physics.replace(lam=1.1), TINY,
                                    initial=tiny_state)  # fmt: skip
    assert again.start == "initial"
    path = write_steady(tmp_path / "s.h5", again)
    assert read_steady(path).steady_result().start == "initial"


@pytest.mark.parametrize("lam, chi", [(1.0, 1.0), (2.0, 3.0)])
def test_reach_flags_a_suspect_state_and_critical_refuses_it(tiny_state, monkeypatch, lam, chi):
    """Newton from the default start lands on a state with a real unstable mode (faked: the
    stability analysis reports one) and no easier start works (at lam = chi = 1 there is none;
    at (2, 3) both fail): reach keeps the state but flags it, and the critical-lambda search
    refuses to start from it."""
    target = vs.Physics(v=0.95, lam=lam, chi=chi)

    def newton(physics, disc, *args, initial=None, **kwargs):
        if physics != target or initial is not None:
            raise NewtonError("no convergence (faked)")
        return tiny_state

    class Unstable:
        most_unstable = (0.0, 0.8)  # a real mode growing: the saddle half of a fold, say
        omega = np.array([[0.0, 0.8]])

    monkeypatch.setattr(branch_module, "steady_tank_treading", newton)
    monkeypatch.setattr(branch_module, "stability", lambda *a, **k: Unstable())
    state = branch_module.reach(target, TINY)
    assert state.suspect and "real unstable mode" in state.start
    assert steady_summary(state)["start"].startswith("suspect")
    with pytest.raises(NewtonError, match="no trustworthy first state"):
        critical_module._first_state(target, TINY, None, {})


# --------------------------------------------------------------------------- run files
def test_run_files_have_flat_parameters_and_l_m_coordinates(tmp_path):
    out = tmp_path / "r.h5"
    r = run("run", "--grid", "8", "--degree", "2", "--t-end", "0.01", "--lam", "3",
            "--no-plot", "--no-progress", "--out", str(out))  # fmt: skip
    assert r.exit_code == 0, r.output
    ds = vs.open_run(out)
    assert ds.attrs["lam"] == 3.0 and ds.attrs["grid"] == 8 and ds.attrs["flow"] == "shear"
    assert json.loads(ds.attrs["physics"])["lam"] == 3.0  # the object's JSON stays beside
    assert list(ds["l"].values) == [0, 1, 2] and list(ds["m"].values) == [0, 1, 2]
    import xarray as xr

    series = xr.open_dataset(out, group="series", engine="h5netcdf")
    assert series.attrs["lam"] == 3.0 and series.attrs["vesicle_version"] == vs.__version__


def test_the_recorded_command_spells_options_as_they_are_typed():
    """Files record the command that made them (``command``): it must run as written. The
    parameter ``chi_text`` is the option ``--chi``; a flag stays a flag."""
    from vesicle.cli import main
    from vesicle.cli.base import command_line

    args = ["--v", "0.9", "--chi", "2:8", "--points", "4", "--no-type-change", "--cusps"]
    ctx = main.commands["neutral"].make_context("vesicle neutral", list(args))
    line = command_line(ctx)
    assert line.startswith("vesicle neutral ")
    assert "--chi 2:8" in line and "--chi-text" not in line
    assert "--no-type-change" in line and "--cusps" in line
    # parsed again it gives the same parameters
    again = main.commands["neutral"].make_context("vesicle neutral", line.split()[2:])
    assert again.params == ctx.params


def test_an_interrupted_codim2_curve_keeps_what_it_traced_in_out(tmp_path, monkeypatch):
    """Ctrl-C during the two-parameter continuation: the curves traced so far go to --out
    (complete: false, stamped), and the message says so; without --out it says nothing was
    kept and how to keep it."""
    from vesicle.bifurcation.neutral_codim2 import CurveInterrupted

    partial = {"complete": False, "interrupted": True, "method": "codim2", "v": 0.95,
               "curves": [{"kind": "hopf", "end": "interrupted",
                           "points": [{"curve": "hopf", "chi": 1.0, "lam": 8.3,
                                       "omega_R": 0.39, "converged": True,
                                       "other_unstable": False}]}],
               "bt_points": [], "cusp_points": [], "turn_points": [], "failed": []}  # fmt: skip

    def stop(*args, **kwargs):
        raise CurveInterrupted(partial)

    monkeypatch.setattr(cli_steady, "neutral_curve_codim2", stop)
    out = tmp_path / "n.json"
    r = run("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8", "--out", str(out))
    assert r.exit_code == 130 and "curves traced so far (1, 1 points" in r.output
    data = json.loads(out.read_text())
    assert data["interrupted"] and data["complete"] is False and "vesicle_version" in data
    assert data["curves"][0]["points"][0]["lam"] == 8.3 and "lam" not in data["physics"]
    assert data["command"].split(" ", 1)[1].startswith("neutral --chi 1,2")
    r = run("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8")
    assert r.exit_code == 130 and "nothing was kept: give --out" in r.output


def test_an_interrupted_codim2_curve_resumes_from_its_kept_evaluations(tmp_path, monkeypatch):
    """--out n.json keeps the codim2 curve's evaluations in n.codim2/ while it runs: after
    Ctrl-C the message says --resume; the same command without it is refused before any work;
    with it the memo is given back (its evaluations replayed) and removed once the curve is
    written."""
    import numpy as np

    from vesicle.bifurcation.neutral import NeutralCurve
    from vesicle.bifurcation.neutral_codim2 import CurveInterrupted

    seen = []

    def curve(physics, chis, disc, memo=None, **kwargs):
        seen.append(len(memo))
        memo.cached("jacobian", lambda: np.eye(2), np.zeros(3))
        if len(seen) == 1:
            raise CurveInterrupted({"complete": False, "interrupted": True, "method": "codim2",
                                    "curves": [], "bt_points": [], "cusp_points": [],
                                    "turn_points": [], "failed": []})  # fmt: skip
        memo.cached("jacobian", lambda: pytest.fail("computed again"), np.zeros(3))
        return NeutralCurve(physics, disc, [], None, [], 0.0, [], method="codim2")

    monkeypatch.setattr(cli_steady, "neutral_curve_codim2", curve)
    out = tmp_path / "n.json"
    args = ("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8", "--out", str(out))
    r = run(*args)
    assert r.exit_code == 130 and "--resume" in r.output and (tmp_path / "n.codim2").is_dir()
    r = run(*args)
    assert r.exit_code != 0 and "--resume" in r.output and len(seen) == 1
    r = run(*args, "--resume")
    assert r.exit_code == 0, r.output
    assert seen == [0, 1] and "replaying the 1 evaluations" in r.output
    assert json.loads(out.read_text())["replayed"] == 2 and not (tmp_path / "n.codim2").exists()


def test_a_codim2_resume_with_nothing_kept_is_refused_or_said(tmp_path, monkeypatch):
    """--resume of a codim2 curve whose --out holds a complete curve and no evaluations:
    refused before any work (nothing to resume); with no file at all it says so and computes
    from the start; an --out ending in .codim2 (the memo's folder name) is refused."""
    from vesicle.bifurcation.neutral import NeutralCurve

    calls = []

    def curve(physics, chis, disc, memo=None, **kwargs):
        calls.append(len(memo))
        return NeutralCurve(physics, disc, [], None, [], 0.0, [], method="codim2")

    monkeypatch.setattr(cli_steady, "neutral_curve_codim2", curve)
    out = tmp_path / "n.json"
    args = ("neutral", "--chi", "1,2", "--degree", "2", "--grid", "8", "--out", str(out))
    r = run(*args, "--resume")
    assert r.exit_code == 0 and "nothing to resume" in r.output and calls == [0]
    r = run(*args, "--resume")
    assert r.exit_code != 0 and "holds a complete curve" in r.output and calls == [0]
    r = run("neutral", "--chi", "1", "--out", str(tmp_path / "n.codim2"))
    assert r.exit_code != 0 and ".codim2" in r.output and calls == [0]
