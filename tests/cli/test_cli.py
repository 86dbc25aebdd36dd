"""Command-line interface."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_shape_json():
    r = run("shape", "--ellipsoid", "1.3", "0.9", "0.8", "--grid", "24", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    for key in (
        "area",
        "volume",
        "reduced_volume",
        "excess_area",
        "bending_energy",
        "grid",
        "degree",
    ):
        assert key in out
    assert out["volume"] == pytest.approx(4 * np.pi * 1.3 * 0.9 * 0.8 / 3, rel=1e-9)
    assert out["grid"] == [24, 48] and out["degree"] == 23


def test_shape_table_and_spheroid():
    r = run("shape", "--spheroid", "0.95", "--degree", "8")
    assert r.exit_code == 0, r.output
    assert "reduced volume v" in r.output and "bending energy" in r.output


@pytest.mark.parametrize(
    "args",
    [
        ("shape", "--ellipsoid", "1", "-1", "1"),
        ("shape", "--ellipsoid", "1", "nan", "1"),
        ("shape", "--ellipsoid", "1", "1", "1", "--grid", "8", "--degree", "12"),
        ("shape", "--spheroid", "1.2"),
        ("shape",),
    ],
)
def test_shape_bad_input_is_a_clear_error(args):
    r = run(*args)
    assert r.exit_code != 0
    assert "Error" in r.output and "Traceback" not in r.output


def test_solve_json_with_split():
    r = run(
        "solve",
        "--shape",
        "ellipsoid:1.2,0.95,0.85",
        "--tilt",
        "20",
        "--lam",
        "2",
        "--grid",
        "16",
        "--split",
        "--json",
    )
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    for key in ("S_xz", "N1", "N2", "iterations", "div_residual", "seconds"):
        assert key in out
    for part in ("bending", "flow"):
        assert set(out[part]) >= {"S_xz", "N1", "N2"}
    assert out["S_xz"] == pytest.approx(out["bending"]["S_xz"] + out["flow"]["S_xz"], rel=1e-3)


def test_solve_sphere_is_einstein():
    r = run("solve", "--shape", "sphere", "--lam", "5", "--grid", "12", "--steady", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["S_xz"] == pytest.approx(2.5, abs=1e-6)


@pytest.mark.parametrize(
    "args",
    [
        ("solve", "--lam", "0"),
        ("solve", "--lam", "nan"),
        ("solve", "--shape", "cube"),
        ("solve", "--shape", "ellipsoid:1,2"),
    ],
)
def test_solve_bad_input(args):
    r = run(*args)
    assert r.exit_code != 0 and "Error" in r.output and "Traceback" not in r.output


def test_run_analyze_plot_export_resume(tmp_path):
    out = tmp_path / "r.h5"
    r = run(
        "run",
        "--grid",
        "12",
        "--degree",
        "4",
        "--t-end",
        "0.04",
        "--save-every",
        "0.01",
        "--out",
        str(out),
        "--no-progress",
    )
    assert r.exit_code == 0, r.output
    assert out.exists() and (tmp_path / "r" / "psi.png").exists()
    r = run("analyze", str(out), "--json")
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    for key in ("regime", "period", "final", "mean", "drift"):
        assert key in summary
    assert set(summary["final"]) >= {"psi", "D", "axes", "bending_energy"}
    assert summary["final"]["axes"] == sorted(summary["final"]["axes"], reverse=True)
    assert set(summary["mean"]) == {"S_xz", "N1", "N2"}
    assert set(summary["drift"]) == {"area", "volume"}
    r = run("analyze", str(out), "--csv")
    header = r.output.splitlines()[0].split(",")
    assert header[:12] == [
        "t",
        "psi",
        "D",
        "L1",
        "L2",
        "L3",
        "bending_energy",
        "area",
        "volume",
        "S_xz",
        "N1",
        "N2",
    ]
    assert len(r.output.splitlines()) == 1 + 5
    r = run("plot", str(out), "--out", str(tmp_path / "figs"))
    assert r.exit_code == 0 and (tmp_path / "figs" / "orbit.png").exists()
    r = run("export", str(out), "--vtk", str(tmp_path / "vtk"))
    assert r.exit_code == 0 and (tmp_path / "vtk" / "surface.pvd").exists()
    r = run("run", "--resume", str(out), "--t-end", "0.06", "--no-plot", "--no-progress")
    assert r.exit_code == 0, r.output
    r = run("analyze", str(out), "--json")
    assert json.loads(r.output)["t_final"] == pytest.approx(0.06)


@pytest.mark.parametrize(
    "args",
    [
        ("run", "--v", "1.5"),
        ("run", "--lam", "-1"),
        ("run", "--v", "nan"),
        ("run", "--grid", "8", "--degree", "8"),
        ("run", "--init", "missing.h5"),
        ("analyze", "nonexistent.h5"),
    ],
)
def test_run_bad_input(args, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = run(*args, "--no-progress") if args[0] == "run" else run(*args)
    assert r.exit_code != 0 and "Traceback" not in r.output


def test_tt_json_with_stability():
    r = run(
        "tt",
        "--v",
        "0.95",
        "--lam",
        "8",
        "--chi",
        "10",
        "--degree",
        "2",
        "--grid",
        "12",
        "--stability",
        "--json",
    )
    assert r.exit_code == 0, r.output
    out = json.loads(r.output.strip().splitlines()[-1])
    for key in (
        "psi",
        "D",
        "axes",
        "S_xz",
        "N1",
        "N2",
        "newton_iterations",
        "residual",
        "omega_R",
        "omega_I",
        "eigenvalues",
        "curvature_shift",
    ):
        assert key in out
    assert out["residual"] < 1e-8
    # like the paper, N = 2 wrongly predicts instability (omega_I = +7.3e-2 at 32 x 64)
    assert out["omega_I"] > 0


def test_critical_bad_input():
    r = run("critical", "--v", "1.5", "--degree", "2", "--grid", "8")
    assert r.exit_code != 0 and "Traceback" not in r.output


FAST_RUN = ("run", "--grid", "12", "--degree", "4", "--no-progress", "--no-plot")


def test_run_refuses_a_missing_output_folder_before_any_work(tmp_path):
    out = tmp_path / "missing" / "x.h5"
    r = run(*FAST_RUN, "--out", str(out))
    assert r.exit_code != 0 and "does not exist" in r.output and "Traceback" not in r.output


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs Linux's /proc")
def test_run_refuses_a_folder_that_takes_no_files_before_any_work():
    # /proc exists and its permission bits say writable to root, but it takes no new files: the
    # check tries to create one (it used to compute, then report a full disk)
    r = run(*FAST_RUN, "--out", "/proc/x.h5")
    assert r.exit_code != 0 and "does not take new files" in r.output
    assert "Traceback" not in r.output


@pytest.mark.parametrize("command", ["plot", "export"])
def test_plot_and_export_to_an_unwritable_place_are_clear_errors(tmp_path, command):
    out = tmp_path / "r.h5"
    assert run(*FAST_RUN, "--t-end", "0.01", "--out", str(out)).exit_code == 0
    target = "/proc/vesicle-cannot-write-here/x"  # not writable, even for root
    args = ("--out", target) if command == "plot" else ("--vtk", target)
    r = run(command, str(out), *args)
    assert r.exit_code != 0 and "cannot write" in r.output and "Traceback" not in r.output


def test_final_state_is_saved_between_save_times(tmp_path):
    out = tmp_path / "r.h5"
    r = run(*FAST_RUN, "--t-end", "0.03", "--save-every", "0.02", "--out", str(out))
    assert r.exit_code == 0, r.output
    summary = json.loads(run("analyze", str(out), "--json").output)
    assert summary["t_final"] == pytest.approx(0.03) and summary["saved_steps"] == 3


def test_resume_refuses_options_it_would_ignore(tmp_path):
    out = tmp_path / "r.h5"
    assert run(*FAST_RUN, "--t-end", "0.01", "--out", str(out)).exit_code == 0
    before = out.read_bytes()
    r = run("run", "--resume", str(out), "--lam", "8", "--t-end", "0.02", "--no-progress")
    assert r.exit_code != 0 and "--lam" in r.output and "cannot be changed" in r.output
    assert out.read_bytes() == before  # untouched


def test_run_does_not_overwrite_without_being_asked(tmp_path):
    out = tmp_path / "r.h5"
    assert run(*FAST_RUN, "--t-end", "0.01", "--out", str(out)).exit_code == 0
    before = out.read_bytes()
    r = run(*FAST_RUN, "--t-end", "0.01", "--lam", "2", "--out", str(out))
    assert r.exit_code != 0 and "exists" in r.output and out.read_bytes() == before
    r = run(*FAST_RUN, "--t-end", "0.01", "--lam", "2", "--out", str(out), "--overwrite")
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize(
    "args, message",
    [
        (("--grid", "10", "--degree", "8"), "too coarse"),
        (("--perturb", "-5"), "perturb"),
        (("--backend", "cuda"), "backend"),
        (("--save-every", "0"), "save_every"),
    ],
)
def test_run_refuses_bad_settings_before_any_work(tmp_path, args, message):
    out = tmp_path / "r.h5"
    r = run("run", "--out", str(out), "--no-progress", *args)
    assert r.exit_code != 0 and message in r.output and not out.exists()


def test_tt_progress_names_the_parameter_point_and_takes_an_iteration_limit():
    args = ("tt", "--lam", "8", "--chi", "10", "--degree", "2", "--grid", "12")
    r = run(*args)
    assert r.exit_code == 0, r.output
    assert "lam=8 chi=10 iteration=0" in r.output
    r = run(*args, "--max-iterations", "1")
    assert r.exit_code != 0 and "did not converge in 1 iterations" in r.output
    assert "allow more iterations" in r.output


def test_critical_at_low_resolution_against_an_independent_fine_bracket():
    """``vesicle critical`` at N = 4 on 16 x 32 (lambda_c = 8.3371, Hopf, omega_R = 0.387); then
    fresh Newton solves from the default start (not the search's continuation) 0.3 % either side
    must have growth rates of opposite signs."""
    from vesicle.steady.newton import steady_tank_treading
    from vesicle.steady.stability import stability

    args = ("--degree", "4", "--grid", "16", "--lam0", "8", "--step", "0.02", "--xtol", "1e-3")
    r = run("critical", "--v", "0.95", "--chi", "1", *args, "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.output.strip().splitlines()[-1])
    lam_c = out["lambda_c"]
    assert out["bifurcation"] == "hopf" and 8.2 < lam_c < 8.5
    grow = [
        stability(
            steady_tank_treading(
                vs.Physics(v=0.95, lam=lam, chi=1.0), vs.Discretisation(grid=16, degree=4)
            )
        ).most_unstable[1]
        for lam in (lam_c * 0.997, lam_c * 1.003)
    ]
    assert grow[0] < 0 < grow[1]


def test_every_option_has_help_and_its_default_is_shown():
    """Issue 18, item 6: no option without a help text; a default is shown or said."""
    import click

    from vesicle.cli import main as group

    for name, command in group.commands.items():
        for p in command.params:
            if not isinstance(p, click.Option):
                continue
            assert p.help, f"{name} {p.opts} has no help text"
            has_default = p.default not in (None, False) and not p.is_flag and p.required is False
            if has_default and p.default is not click.core.UNSET:
                said = p.show_default or "default" in p.help.lower()
                assert said, f"{name} {p.opts}: default {p.default!r} not shown"
    help_text = CliRunner().invoke(group, ["run", "--help"]).output
    assert "'tt'" in help_text and "steady-state file" in help_text
    assert "-v," not in CliRunner().invoke(group, ["--help"]).output  # --v is the reduced volume


def test_info_records_of_other_libraries_stay_off_the_terminal():
    """Dask's scheduler logs at info level; its records propagate to the root's handler past
    the root's level, so the command line's handler filters by level itself (a fresh process:
    the test runner's own handlers would hide this)."""
    import subprocess
    import sys

    code = (
        "import logging\n"
        "from vesicle.cli.base import configure_logging\n"
        "configure_logging(logging.WARNING)\n"
        "noisy = logging.getLogger('distributed.scheduler')\n"
        "noisy.setLevel(logging.INFO)\n"
        "noisy.info('scheduler noise')\n"
        "logging.getLogger('vesicle.x').warning('kept')\n"
    )
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stderr  # fmt: skip
    assert "kept" in err and "scheduler noise" not in err
