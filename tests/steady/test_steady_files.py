"""Steady-state files (issue 18, part 4): ``tt --out``, ``run --init FILE``, ``plot FILE``."""

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main
from vesicle.io.files import read_run
from vesicle.steady.files import open_steady, read_steady

ARGS = ["--grid", "12", "--degree", "4", "--v", "0.95", "--lam", "2", "--chi", "3"]


@pytest.fixture(scope="module")
def steady_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("tt") / "tt.h5"
    r = CliRunner().invoke(main, ["tt", *ARGS, "--stability", "--out", str(path), "--json"])
    assert r.exit_code == 0, r.output
    return path, json.loads(r.output.strip().splitlines()[-1])


def test_the_file_holds_the_state_its_jacobian_and_spectrum(steady_file):
    path, printed = steady_file
    s = read_steady(path)
    assert s.physics == vs.Physics(v=0.95, lam=2.0, chi=3.0)
    assert s.discretisation == vs.Discretisation(grid=12, degree=4)
    np.testing.assert_allclose(s.omega, printed["eigenvalues"], rtol=1e-14)
    assert s.summary["psi"] == pytest.approx(printed["psi"], rel=1e-14)
    size = s.arrays["a"].size
    assert s.jacobian.shape == (size, size) and s.arrays["gradients"].shape == (2, size)
    assert s.modes.shape == (size - 2, 5, 5)  # every eigenvector, as radius coefficients
    assert s.shape.area == pytest.approx(4 * np.pi, rel=1e-8)
    assert "tt" in s.attributes["command"] and s.attributes["vesicle_version"] == vs.__version__
    # the eigenvalues are those of the stored Jacobian on the constrained space
    g = s.arrays["gradients"]
    Z, _ = np.linalg.qr(g.T)
    Q = np.eye(size) - Z @ Z.T
    mu = np.linalg.eigvals(Q.T @ s.jacobian @ Q)
    assert np.min(np.abs(mu - complex(s.omega[0, 1], -s.omega[0, 0]))) < 1e-10


def test_open_steady_and_the_checksum(steady_file, tmp_path):
    path, _ = steady_file
    ds = open_steady(path)
    assert ds["jacobian"].dims == ("row", "column") and ds["modes"].dims == ("mode", "l", "m")
    assert ds["omega_I"].values[0] == ds["omega_I"].values.max()
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "a") as f:
        f["jacobian/M"][0, 0] += 1.0
    with pytest.raises(ValueError, match="corrupted"):
        read_steady(bad)


def test_a_run_starts_from_the_file_without_newton(steady_file, tmp_path):
    """The first saved shape is the file's; being steady, it hardly moves (the time stepping's
    own steady state differs from Newton's by the multipliers' share, ~1e-3 at N = 4)."""
    path, _ = steady_file
    out = tmp_path / "r.h5"
    r = CliRunner().invoke(main, ["run", *ARGS, "--init", str(path), "--t-end", "0.05",
                                  "--out", str(out), "--no-plot", "--no-progress"])  # fmt: skip
    assert r.exit_code == 0, r.output
    run = read_run(out)
    c0 = read_steady(path).coefficients
    np.testing.assert_allclose(run.coefficients[0], c0, atol=1e-14)
    sphere = np.zeros_like(c0)
    sphere[0, 0] = c0[0, 0]
    moved = np.abs(run.coefficients[-1] - c0).max() / np.abs(c0 - sphere).max()
    assert moved < 1e-2


def test_init_from_a_steady_file_checks_the_run(steady_file, tmp_path):
    path, _ = steady_file
    for extra, message in ((["--v", "0.9"], "v = 0.95"), (["--degree", "6"], "degree 4")):
        args = ["run", *ARGS, *extra, "--init", str(path), "--out", str(tmp_path / "x.h5")]
        r = CliRunner().invoke(main, args)
        assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output
        assert not (tmp_path / "x.h5").exists()


def test_plot_of_a_steady_file(steady_file, tmp_path):
    path, _ = steady_file
    r = CliRunner().invoke(main, ["plot", str(path), "--out", str(tmp_path / "fig")])
    assert r.exit_code == 0, r.output
    names = sorted(p.name for p in (tmp_path / "fig").iterdir())
    assert names == ["eigenmode_1.png", "eigenmode_2.png", "spectrum_El.png",
                     "spectrum_eigenvalues.png"]  # fmt: skip
    for name in names:
        assert (tmp_path / "fig" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_tt_out_refuses_to_replace_a_file(steady_file):
    path, _ = steady_file
    r = CliRunner().invoke(main, ["tt", *ARGS, "--out", str(path)])
    assert r.exit_code != 0 and "--overwrite" in r.output
    read_steady(path)  # untouched


def test_branch_states_are_steady_files(tmp_path):
    """`vesicle branch --states DIR`: one steady-state file per point asked for."""
    r = CliRunner().invoke(main, ["branch", "--v", "0.95", "--chi", "3", "--lam", "1,2",
                                  "--grid", "12", "--degree", "4", "--no-locate", "--states",
                                  str(tmp_path / "st")])  # fmt: skip
    assert r.exit_code == 0, r.output
    names = sorted(p.name for p in (tmp_path / "st").iterdir())
    assert names == ["lam_1.h5", "lam_2.h5"]
    s = read_steady(tmp_path / "st" / "lam_2.h5")
    assert (
        s.physics.lam == 2.0 and s.omega is not None and s.jacobian.shape[0] == s.modes.shape[0] + 2
    )


def test_the_state_restarts_newton_bit_for_bit(steady_file):
    """`SteadyFile.steady_result()` (what a resumed neutral curve starts from): the stored
    coordinates, multipliers and Jacobian exactly; it is a solution, independently of how it
    was stored: Newton started from it at the same parameters stops at iteration 0 (its own
    residual below 1e-8), and the stability analysis of the restored Jacobian gives the
    eigenvalues printed by `tt --stability`."""
    path, printed = steady_file
    s = read_steady(path)
    r = s.steady_result()
    np.testing.assert_array_equal(r.a, s.arrays["a"])
    np.testing.assert_array_equal(r.jacobian, s.jacobian)
    assert r.multipliers == tuple(s.multipliers) and r.physics == s.physics
    assert r.psi == printed["psi"] and r.stress.S_xz == pytest.approx(printed["S_xz"], rel=1e-14)
    np.testing.assert_allclose(vs.stability(r).omega, printed["eigenvalues"], rtol=1e-12,
                               atol=1e-14)  # fmt: skip
    again = vs.steady_tank_treading(s.physics, s.discretisation, initial=r)
    assert len(again.residual_history) == 1 and again.residual_history[0] < 1e-8
    with pytest.raises(ValueError, match="degree, grid"):
        s.steady_result(vs.Discretisation(grid=16, degree=4))
