"""TOML configuration files (issue 18, part 1)."""

from __future__ import annotations

import string

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import vesicle as vs
from vesicle.cli import main
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import load_parameters, simulate
from vesicle.io.files import read_run
from vesicle.workflows.config import SECTIONS, ConfigError, read_config, to_toml


def cli(*args):
    return CliRunner().invoke(main, list(args))


def test_template_round_trips_to_equal_parameters(tmp_path):
    p = RunParameters(vs.Physics(v=0.9, lam=3.0, chi=2.0, flow="planar-extension"),
                      vs.Discretisation(grid=16, degree=4, n_rot=12, backend="numpy"),
                      "steady", t_end=0.5, tilt=10.0, split_stress=True)  # fmt: skip
    path = tmp_path / "p.toml"
    path.write_text(to_toml(p))
    c = read_config(path)
    q = RunParameters(vs.Physics(**c["physics"]), vs.Discretisation(**c["discretisation"]),
                      vs.SolverTolerances(**c["solver"]), **c["run"])  # fmt: skip
    assert q == p


def test_cli_options_override_the_file_and_the_merge_is_what_is_written(tmp_path):
    (tmp_path / "a.toml").write_text("[physics]\nlam = 3.0\nchi = 2.0\n[run]\nt_end = 0.5\n")
    r = cli("run", "--config", str(tmp_path / "a.toml"), "--lam", "5",
            "--write-config", str(tmp_path / "b.toml"))  # fmt: skip
    assert r.exit_code == 0, r.output
    b = read_config(tmp_path / "b.toml")
    assert b["physics"]["lam"] == 5.0 and b["physics"]["chi"] == 2.0 and b["run"]["t_end"] == 0.5


def test_a_run_file_exports_to_a_config_that_repeats_it(tmp_path):
    run = tmp_path / "r.h5"
    p = RunParameters(
        vs.Physics(v=0.9, lam=2.0),
        vs.Discretisation(grid=12, degree=4),
        t_end=0.01,
        save_every=0.01,
    )
    simulate(p, out=run)
    r = cli("config", str(run), "--out", str(tmp_path / "r.toml"))
    assert r.exit_code == 0, r.output
    r = cli("run", "--config", str(tmp_path / "r.toml"), "--out", str(tmp_path / "again.h5"),
            "--no-progress", "--no-plot")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert load_parameters(read_run(tmp_path / "again.h5")) == load_parameters(read_run(run))


@pytest.mark.parametrize(
    "text, message",
    [
        ("[physics]\nlamda = 2\n", "unknown key 'lamda' in [physics] (did you mean 'lam'?)"),
        ("[phsics]\nv = 0.9\n", "unknown table [phsics] (did you mean [physics]?)"),
        ('[physics]\nlam = "x"\n', "[physics] lam must be"),
        ("[discretisation]\ngrid = 32.5\n", "[discretisation] grid must be int"),
        ("[physics]\nv = 1.5\n", "reduced volume"),
        ("[discretisation]\ngrid = 10\ndegree = 8\n", "too coarse"),
        ('[solver]\npreset = "fast"\n', "tolerances must be one of"),
        ("[run]\nperiods = -1\n", "periods"),
        ("[run]\nsplit_stress = 1\n", "[run] split_stress must be bool"),
        ("[physics\nv = 1\n", "not valid TOML"),
    ],
)
def test_bad_files_are_refused_naming_the_key_and_the_file(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        read_config(path)
    assert message in str(err.value) and str(path) in str(err.value)
    out = tmp_path / "never.h5"
    r = cli("run", "--config", str(path), "--out", str(out), "--no-progress")
    assert r.exit_code != 0 and message in r.output and not out.exists()


def test_steady_commands_take_physics_and_discretisation_only(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[physics]\nlam = 3\n[run]\nt_end = 1.0\n")
    r = cli("tt", "--config", str(path))
    assert r.exit_code != 0 and "unknown table [run]" in r.output
    path.write_text("[physics]\nlam = 3\n")
    r = cli("critical", "--config", str(path))
    assert r.exit_code != 0 and "critical does not use [physics] lam" in r.output


_names = st.text(alphabet=string.ascii_lowercase + "_", min_size=1, max_size=10)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(SECTIONS)), _names)
def test_random_unknown_keys_are_refused_by_name(tmp_path_factory, section, key):
    if key in SECTIONS[section]:
        return
    path = tmp_path_factory.mktemp("cfg") / "k.toml"
    path.write_text(f"[{section}]\n{key} = 1\n")
    with pytest.raises(ConfigError, match=f"unknown key '{key}'"):
        read_config(path)


def test_branch_reads_its_range_and_resolution_from_a_config(tmp_path):
    """`vesicle branch --config`: [physics] lam = "1:2" is the range, chi and v fixed;
    [discretisation] the resolution; a typo is refused before any work."""
    import json

    from click.testing import CliRunner

    from vesicle.cli import main

    path = tmp_path / "b.toml"
    path.write_text('[physics]\nv = 0.95\nlam = "1:2"\nchi = 1.0\n'
                    "[discretisation]\ngrid = 12\ndegree = 4\n")  # fmt: skip
    r = CliRunner().invoke(main, ["branch", "--config", str(path), "--no-locate", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output.strip().splitlines()[-1])
    assert [p["lam"] for p in out["points"]] == [1.0, 2.0] and out["grid"] == 12
    assert out["vesicle_version"] and out["physics"]["chi"] == 1.0
    path.write_text('[physics]\nlamda = "1:2"\n')
    r = CliRunner().invoke(main, ["branch", "--config", str(path)])
    assert r.exit_code != 0 and "lamda" in r.output and "did you mean 'lam'" in r.output
    path.write_text('[physics]\nlam = "1:x"\n')
    r = CliRunner().invoke(main, ["branch", "--config", str(path)])
    assert r.exit_code != 0 and "range/list" in r.output
