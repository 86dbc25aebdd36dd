"""The sweep engine (issue 13, part 3): config checks, Dask runs, the store, resume, kills."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from vesicle.cli import main
from vesicle.workflows.config import ConfigError
from vesicle.workflows.sweep import (
    SweepStore,
    load,
    read_sweep_config,
    run_point,
    run_sweep,
    task_key,
)

SMALL = "[discretisation]\ndegree = 4\ngrid = 12\n"


def write(tmp_path, body: str, name="s.toml"):
    path = tmp_path / name
    path.write_text(body)
    return path


def tt_config(tmp_path, lam="[1.0, 2.0, 4.0]", extra=""):
    return write(tmp_path, f'[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nv = [0.95]\n'
                           f"lam = {lam}\nchi = [1.0]\n{SMALL}{extra}")  # fmt: skip


# ----------------------------------------------------------------- config checks
@pytest.mark.parametrize(
    "body, message",
    [
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlamda = [1.0]\n', "unknown key 'lamda'"),
        ('[sweep]\ntask = "tx"\nout = "s.h5"\n[grid]\nlam = [1.0]\n', "task must be one of"),
        ('[sweep]\ntask = "critical"\nout = "s.h5"\n[grid]\nlam = [1.0]\n', "unknown key 'lam'"),
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = []\n', "empty list"),
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = ["a"]\n', "must hold numbers"),
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nv = [1.5]\n', "v must"),
        ('[sweep]\ntask = "critical"\nout = "s.h5"\n[grid]\nbq = [0.0, -1.0]\n', "bq must"),
        ('[sweep]\ntask = "neutral_bq"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
         'values = "-1:2"\n', "values"),
        ('[sweep]\ntask = "neutral_bq"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
         'lam_at = [0.0]\n', "lam_at"),
        ('[sweep]\ntask = "neutral_bq"\nout = "s.h5"\n[grid]\nchi = [-1.0]\n', "chi must"),
        ('[sweep]\ntask = "neutral_bq"\nout = "s.h5"\n[grid]\nlam = [1.0]\n', "lam"),
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[physics]\nlam = 2.0\n', "both"),
        (
            '[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[discretisation]\ngrid = 4\n',
            "grid",
        ),
        (
            '[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[run]\nt_end = 1.0\n',
            "for task",
        ),
        ('[sweep]\ntask = "tt"\n[grid]\nlam = [1.0]\n', "task and out"),
        (
            '[sweep]\ntask = "tt"\nout = "s.h5"\npoints = "list"\n[grid]\nlam = [1.0, 2.0]\n'
            "chi = [1.0]\n",
            "one length",
        ),
        (
            '[sweep]\ntask = "stability"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[task]\nmodes = "x"\n',
            "modes",
        ),
        ('[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = [1.0, 1.0]\n', "repeats"),
        ('[sweeps]\ntask = "tt"\n', "did you mean [sweep]"),
        (
            '[sweep]\ntask = "branch"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
            'parameter = "mu"\nvalues = "1:3"\n',
            "parameter must be one of",
        ),
        (
            '[sweep]\ntask = "branch"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[task]\n'
            'parameter = "lam"\nvalues = "1:3"\n',
            "cannot also be in [grid]",
        ),
        (
            '[sweep]\ntask = "branch"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
            'parameter = "lam"\n',
            "values",
        ),
        (
            '[sweep]\ntask = "branch"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
            'parameter = "v"\nvalues = "0.9:1.2:0.1"\n',
            "v must",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\nchi = "0.1:x"\n',
            "[task] chi: 'x' is not a number",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            "chi = [1.0, -2.0]\n",
            "positive",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            "chi = [1.0]\npoints = 4\n",
            "points goes with",
        ),
        ('[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nlam = [8.0]\n', "unknown key 'lam'"),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            'continuation = "arclength"\n',
            "continuation must be 'codim2' or 'trace'",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\nxtol = 1e-4\n',
            "xtol applies to continuation = 'trace' only",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            'continuation = "trace"\nform = "spec"\n',
            "form applies to continuation = 'codim2' only",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            'continuation = "trace"\ncusps = true\n',
            "cusps applies to continuation = 'codim2' only",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\ncusps = 1\n',
            "cusps must be bool, got 1",
        ),
        (
            '[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\nlam = [1.0]\n[task]\njacobian = "x"\n',
            "jacobian",
        ),
        (
            '[sweep]\ntask = "neutral"\nout = "s.h5"\n[grid]\nv = [0.95]\n[task]\n'
            'orientation = "y"\n',
            "orientation must be 'flow' or 'vorticity'",
        ),
        (
            '[sweep]\ntask = "branch"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
            'parameter = "lam"\nvalues = "1:3"\norientation = "up"\n',
            "[task] orientation must be 'flow' or 'vorticity', got 'up'",
        ),
        (
            '[sweep]\ntask = "critical"\nout = "s.h5"\n[grid]\nchi = [1.0]\n[task]\n'
            'coarse = "yes"\n',
            "coarse",
        ),
    ],
)
def test_bad_configs_are_refused_naming_the_key(tmp_path, body, message):
    path = write(tmp_path, body)
    with pytest.raises(ConfigError, match=r"s\.toml") as err:
        read_sweep_config(path)
    assert message in str(err.value)
    r = CliRunner().invoke(main, ["sweep", str(path)])
    assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output
    assert not (tmp_path / "s.h5").exists()


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(["v", "lam", "chi"]),
       st.one_of(st.just(-1.0), st.just(0.0), st.just(float("inf")), st.text(max_size=3),
                 st.booleans(), st.just([])))  # fmt: skip
def test_property_bad_grid_values(tmp_path_factory, key, value):
    """Random bad values of any swept parameter: a ConfigError naming the key, no store."""
    if key == "chi" and value in (-1.0, 0.0):
        return  # valid: chi may be zero (rest) or negative (reversed shear)
    tmp = tmp_path_factory.mktemp("p")
    text = repr(value) if isinstance(value, float) else json.dumps(value)  # TOML literals
    path = write(tmp, f'[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\n{key} = [{text}]\n')
    with pytest.raises(ConfigError) as err:
        read_sweep_config(path)
    assert key in str(err.value) or "TOML" in str(err.value)
    assert not (tmp / "s.h5").exists()


def test_points_product_and_list(tmp_path):
    c = read_sweep_config(write(tmp_path, '[sweep]\ntask = "tt"\nout = "s.h5"\n[grid]\n'
                                          "lam = [1.0, 2.0]\nchi = [1.0, 3.0]\n"))  # fmt: skip
    assert [(p.lam, p.chi) for p in c.points] == [(1, 1), (1, 3), (2, 1), (2, 3)]
    c = read_sweep_config(
        write(
            tmp_path,
            '[sweep]\ntask = "tt"\nout = "s.h5"\npoints = "list"\n'
            "[grid]\nlam = [1.0, 2.0]\nchi = [1.0, 3.0]\n",
        )
    )
    assert [(p.lam, p.chi) for p in c.points] == [(1, 1), (2, 3)]
    assert c.out == tmp_path / "s.h5"


def test_task_keys_share_identical_work_and_separate_any_difference(tmp_path):
    """Sweeps sharing one scheduler (``vesicle paper``) submit their points under these keys:
    the same branch in two stores is one task; another option, resolution or run folder is
    another task (a shared key would hand one sweep the other's result)."""
    base = ('[sweep]\ntask = "branch"\nout = "{out}"\n[grid]\nchi = [1.0]\n[task]\n'
            'parameter = "lam"\n')

    def key(folder, out="s.h5", task='values = "1:9:0.5"\n', extra=""):
        (tmp_path / folder).mkdir(exist_ok=True)
        path = write(tmp_path / folder, base.format(out=out) + task + extra)
        c = read_sweep_config(path)
        return task_key(c, c.points[0])

    same = key("a")
    assert key("b", out="other.h5") == same  # another store, the same work
    assert key("c", task='values = "1:9:0.4"\n') != same  # other options
    assert key("d", task='values = "1:9:0.5"\nellipsoid = true\n') != same
    assert key("e", extra="[discretisation]\ndegree = 4\ngrid = 12\n") != same
    runs = '[sweep]\ntask = "run"\nout = "{out}"\n[grid]\nlam = [9.0]\n[run]\nt_end = 1.0\n'
    one = read_sweep_config(write(tmp_path / "a", runs.format(out="r1.h5")))
    two = read_sweep_config(write(tmp_path / "a", runs.format(out="r2.h5")))
    assert task_key(one, one.points[0]) != task_key(two, two.points[0])  # run files differ


# --------------------------------------------------------------------- running
@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sweep")
    config = read_sweep_config(tt_config(tmp))
    store = run_sweep(config, workers=2)
    return tmp, config, store


def test_a_tt_sweep_gives_what_tt_gives(swept):
    """Each point's result has the keys of `vesicle tt --json`, with the same numbers."""
    _, config, store = swept
    assert store.status(config) == {"done": 3, "failed": 0, "pending": 0}
    r = CliRunner().invoke(main, ["tt", "--v", "0.95", "--lam", "2", "--chi", "1", "--degree",
                                  "4", "--grid", "12", "--json"])  # fmt: skip
    direct = json.loads(r.output.strip().splitlines()[-1])
    point = next(r for r in store.rows() if r["lam"] == 2.0)
    assert set(direct) - {"updates", "jacobian"} <= set(point)
    assert point["psi"] == pytest.approx(direct["psi"], rel=1e-9)
    assert point["vesicle_version"] == direct["vesicle_version"]


def test_status_table_and_dataframe(swept):
    _, config, _ = swept
    path = str(config.path)
    r = CliRunner().invoke(main, ["sweep", path, "--status", "--json"])
    assert json.loads(r.output) == {"done": 3, "failed": 0, "pending": 0}
    r = CliRunner().invoke(main, ["sweep", path, "--table", "--json"])
    rows = json.loads(r.output)["rows"]
    assert [row["lam"] for row in rows] == [1.0, 2.0, 4.0] and all("psi" in row for row in rows)
    r = CliRunner().invoke(main, ["sweep", path, "--table", "--csv"])
    header = r.output.splitlines()[0].split(",")
    assert {"v", "lam", "chi", "psi", "status"} <= set(header)
    frame = load(config.out)
    assert list(frame["lam"]) == [1.0, 2.0, 4.0] and frame["psi"].notna().all()


def test_a_rerun_skips_done_points_and_adds_new_ones(swept):
    tmp, config, store = swept
    before = {k: r["finished"] for k, r in store.records.items()}
    again = run_sweep(config, workers=1)
    assert {k: r["finished"] for k, r in again.records.items()} == before  # nothing recomputed
    wider = read_sweep_config(tt_config(tmp, lam="[1.0, 2.0, 4.0, 3.0]"))
    grown = run_sweep(wider, workers=1)
    assert grown.status(wider) == {"done": 4, "failed": 0, "pending": 0}
    assert all(grown.records[k]["finished"] == t for k, t in before.items())


def test_another_discretisation_is_refused_on_the_same_store(swept):
    tmp, _, _ = swept
    other = write(tmp, (tt_config(tmp).read_text()).replace("degree = 4", "degree = 6"),
                  name="other.toml")  # fmt: skip
    with pytest.raises(ConfigError, match="another task, discretisation"):
        SweepStore.open(read_sweep_config(other))


def test_a_failing_point_is_recorded_and_the_others_go_on(tmp_path):
    """v = 0.3 has no representable start at N = 4 (Newton fails): recorded with its error."""
    entry = run_point("tt", {"v": 0.3, "lam": 1.0, "chi": 1.0, "flow": "shear"},
                      {"grid": 12, "degree": 4}, {}, {})  # fmt: skip
    assert entry["status"] == "failed" and entry["error"]
    config = read_sweep_config(write(tmp_path, '[sweep]\ntask = "tt"\nout = "s.h5"\n'
                                               f"[grid]\nv = [0.3, 0.95]\n{SMALL}"))  # fmt: skip
    store = run_sweep(config, workers=2)
    assert store.status(config) == {"done": 1, "failed": 1, "pending": 0}
    failed = next(r for r in store.rows() if r["status"] == "failed")
    assert failed["v"] == 0.3 and failed["error"]


def test_a_killed_worker_loses_no_point(tmp_path):
    """One of two workers is SIGKILLed while points are running: Dask reschedules its point on
    the restarted worker and every point ends done, once."""
    from distributed import Client, LocalCluster

    config = read_sweep_config(tt_config(tmp_path, lam="[1.0, 1.5, 2.0, 2.5, 3.0, 4.0]"))
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)  # fmt: skip
    client = Client(cluster)
    killed = []

    def kill_one():
        time.sleep(3.0)  # the first points are running
        pids = client.run(os.getpid)
        pid = sorted(pids.values())[0]
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    try:
        thread = threading.Thread(target=kill_one)
        thread.start()
        store = run_sweep(config, scheduler=cluster.scheduler_address)
        thread.join()
    finally:
        client.close()
        cluster.close()
    assert killed
    assert store.status(config) == {"done": 6, "failed": 0, "pending": 0}
    assert len(store.records) == 6


def test_sigkill_of_the_sweep_keeps_what_was_done(tmp_path):
    """The sweep process itself is killed mid-way: the store is readable, holds the points
    completed so far, and the same command finishes the rest without redoing them."""
    config = tt_config(tmp_path, lam="[1.0, 1.5, 2.0, 2.5, 3.0, 4.0]")
    cmd = [sys.executable, "-m", "vesicle", "sweep", str(config), "--workers", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)  # fmt: skip
    store_path = tmp_path / "s.h5"
    deadline = time.time() + 240
    done = 0
    while time.time() < deadline and done < 2:
        time.sleep(0.5)
        assert proc.poll() is None, "the sweep ended before it could be killed"
        if store_path.exists():
            try:
                done = SweepStore.read(store_path).status()["done"]
            except (OSError, ValueError):
                pass  # caught between the rename and the read: try again
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = SweepStore.read(store_path)
    before = {k: r["finished"] for k, r in kept.records.items() if r["status"] == "done"}
    assert 2 <= len(before) < 6
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    final = SweepStore.read(store_path)
    assert final.status() == {"done": 6, "failed": 0}
    assert all(final.records[k]["finished"] == t for k, t in before.items())


# ------------------------------------------------------------- branch and neutral
def test_a_branch_sweep_gives_what_branch_gives(tmp_path):
    """task = "branch": one branch per grid point, with the keys of `vesicle branch --json` and
    its numbers; `vesicle plot` of the store draws each branch's figures."""
    path = write(tmp_path, '[sweep]\ntask = "branch"\nout = "b.h5"\n[grid]\nchi = [1.0]\n'
                           '[task]\nparameter = "lam"\nvalues = "1:2:0.5"\n' + SMALL)  # fmt: skip
    store = run_sweep(read_sweep_config(path), workers=1)
    (record,) = store.records.values()
    assert record["status"] == "done", record
    result = record["result"]
    assert [p["lam"] for p in result["points"]] == [1.0, 1.5, 2.0]
    r = CliRunner().invoke(main, ["branch", "--chi", "1", "--lam", "1:2:0.5", "--degree", "4",
                                  "--grid", "12", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    direct = json.loads(r.output.strip().splitlines()[-1])
    for a, b in zip(result["points"], direct["points"], strict=True):
        assert a["psi"] == pytest.approx(b["psi"], abs=1e-9)
        assert a["omega_I"] == pytest.approx(b["omega_I"], abs=1e-7)
    r = CliRunner().invoke(main, ["plot", str(tmp_path / "b.h5"), "--out", str(tmp_path / "f")])
    assert r.exit_code == 0, r.output
    assert len(list((tmp_path / "f").glob("*/branch_omega.png"))) == 1


def test_a_neutral_point_that_stopped_keeps_its_points_and_counts_as_failed(monkeypatch):
    """task = "neutral": a curve that stopped part-way is recorded as failed (a rerun retries
    it) with the points it found and where it stopped."""
    import vesicle.workflows.tasks as sweep
    from vesicle.bifurcation.neutral import NeutralCurve

    def stopped(physics, chi, disc, **options):
        return NeutralCurve(physics, disc, [], None, [], 0.0, [{"chi": 3.0, "error": "no TT"}])

    monkeypatch.setattr(sweep, "neutral_curve", stopped)
    entry = run_point("neutral", {"v": 0.95}, {"degree": 4, "grid": 12},
                      {"chi": [1.0, 3.0], "continuation": "trace"}, {})  # fmt: skip
    assert entry["status"] == "failed" and "before chi = 3: no TT" in entry["error"]
    assert entry["result"]["failed"] == [{"chi": 3.0, "error": "no TT"}]


def test_a_neutral_point_is_continued_in_two_parameters_by_default(monkeypatch):
    """task = "neutral" without ``continuation``: the two-parameter continuation, as
    ``vesicle neutral``, given the task's options (and not the tracer's); its failures count
    as the tracer's do."""
    import vesicle.workflows.tasks as sweep
    from vesicle.bifurcation.neutral import NeutralCurve
    from vesicle.model.settings import StabilitySettings

    seen = {}

    def codim2(physics, chi, disc, **options):
        seen.update(options, chi=list(chi))
        return NeutralCurve(physics, disc, [], None, [], 0.0, [{"chi": None, "error": "stop"}])

    monkeypatch.setattr(sweep, "neutral_curve_codim2", codim2)
    monkeypatch.setattr(sweep, "neutral_curve", lambda *a, **k: pytest.fail("traced"))
    entry = run_point("neutral", {"v": 0.95}, {"degree": 4, "grid": 12},
                      {"chi": [1.0, 3.0], "form": "curvature", "modes": "general"}, {})
    assert seen == {"chi": [1.0, 3.0], "form": "curvature", "memo": None,
                    "analysis": StabilitySettings(modes="general")}  # fmt: skip
    assert entry["status"] == "failed"


def test_a_neutral_bq_point_gets_its_values_and_counts_its_failures(monkeypatch, tmp_path):
    """task = "neutral_bq": lambda_c(Bq) at the point's (v, chi), given the Bq values, the
    lambdas of the critical Bq and the analysis; a curve that stopped is a failed point."""
    import vesicle.workflows.tasks as sweep
    from vesicle.bifurcation.neutral_bq import BqCurve
    from vesicle.model.settings import StabilitySettings

    seen = {}

    def curve(physics, bq, disc, **options):
        seen.update(options, bq=list(bq), chi=physics.chi)
        return BqCurve(physics, disc, "spec", [], [], [], [], [{"bq": 5.0, "error": "stop"}],
                       0.0, 1e-8)  # fmt: skip

    monkeypatch.setattr(sweep, "neutral_curve_bq", curve)
    entry = run_point("neutral_bq", {"v": 0.95, "chi": 6.0}, {"degree": 4, "grid": 12},
                      {"values": [0, 2, 5], "lam_at": "1", "modes": "general"}, {})
    assert seen == {"bq": [0.0, 2.0, 5.0], "chi": 6.0, "lam_at": [1.0], "form": "spec",
                    "lam0": None, "analysis": StabilitySettings(modes="general"),
                    "memo": None}  # fmt: skip
    assert entry["status"] == "failed" and "stop" in entry["error"]
    assert entry["result"]["plane"] == ["bq", "lam"]
    # in a sweep (a curves folder) its evaluations are kept for a retry: the memo's identity
    # holds chi and not the curve's parameters Bq and lambda
    run_point("neutral_bq", {"v": 0.95, "chi": 6.0}, {"degree": 4, "grid": 12},
              {"values": [0, 2, 5]}, {"curves_dir": str(tmp_path)})  # fmt: skip
    held = seen["memo"].identity["physics"]
    assert held["chi"] == 6.0 and "bq" not in held and "lam" not in held


def test_a_neutral_point_cut_short_resumes_from_its_checkpoint(tmp_path, monkeypatch,
                                                               small_state, stand_in):
    """task = "neutral": each curve keeps its points and states beside the store
    (`<store>_curves/<key>.json`, `<key>.states/`) as they are found; a curve cut short (here a
    failure above chi = 1.6, as a lost worker would leave it) is tried again from them: the
    points kept are not traced again, nor is the seed searched."""
    import vesicle as vs
    import vesicle.bifurcation.neutral as neutral

    path = write(tmp_path, '[sweep]\ntask = "neutral"\nout = "n.h5"\n[grid]\nv = [0.95]\n'
                           '[task]\nchi = [0.8, 1.0, 1.5, 2.0]\nlocate_type_change = false\n'
                           'continuation = "trace"\n' + SMALL)  # fmt: skip
    config = read_sweep_config(path)
    assert config.settings["curves_dir"] == str(tmp_path / "n_curves")
    same = read_sweep_config(write(tmp_path, path.read_text().replace("n.h5", "m.h5"), "m.toml"))
    assert same.fingerprint() == config.fingerprint()  # the folder is not part of the work
    calls = []
    monkeypatch.setattr(neutral, "reach", lambda *a, **k: small_state)
    monkeypatch.setattr(neutral, "critical_lambda",
                        lambda *a, **k: vs.CriticalResult(8.1, "hopf", 0.3, ()))  # fmt: skip
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, calls, fail_above=1.6))
    args = ("neutral", config.points[0].to_dict(), config.discretisation.to_dict(),
            config.options, config.plain_settings())  # fmt: skip
    first = run_point(*args)
    assert first["status"] == "failed" and sorted(calls) == [0.8, 1.0, 1.5]
    key = config.points[0].key
    assert (tmp_path / "n_curves" / f"{key}.json").exists()
    assert len(list((tmp_path / "n_curves" / f"{key}.states").glob("chi_*.h5"))) == 3
    calls.clear()
    monkeypatch.setattr(neutral._Tracer, "point", stand_in(small_state, calls))
    monkeypatch.setattr(neutral, "critical_lambda", lambda *a, **k: pytest.fail("seed searched"))
    again = run_point(*args)
    assert again["status"] == "done" and calls == [2.0]
    assert [p["chi"] for p in again["result"]["points"]] == [0.8, 1.0, 1.5, 2.0]
    assert again["result"]["resumed"] == 3


def test_a_run_point_cut_short_resumes_from_its_run_file(tmp_path, caplog):
    """task = "run": each point's run file lies beside the store; a point whose run was cut
    short (here interrupted at t > 0.05) resumes from the file's checkpoint and ends where an
    uninterrupted run ends (the restart is exact: SPEC, docs/reference/file-formats.md)."""
    from vesicle.dynamics.integrators import RunParameters
    from vesicle.dynamics.simulation import simulate
    from vesicle.model.parameters import Discretisation, Physics

    body = ('[sweep]\ntask = "run"\nout = "r.h5"\n[grid]\nlam = [2.0]\n[run]\nt_end = 0.12\n'
            "save_every = 0.03\nsave_fields = false\n" + SMALL)  # fmt: skip
    config = read_sweep_config(write(tmp_path, body))
    (point,) = config.points
    params = RunParameters(point, config.discretisation, config.settings["solver"],
                           **config.settings["run"])  # fmt: skip
    runs = tmp_path / "r_runs"
    runs.mkdir()

    def stop(info):
        if info["t"] > 0.05:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate(params, out=runs / f"{point.key}.h5", progress=stop)
    with caplog.at_level("INFO", logger="vesicle.workflows.tasks"):
        entry = run_point("run", point.to_dict(), config.discretisation.to_dict(), {},
                          config.settings)  # fmt: skip
    assert entry["status"] == "done", entry.get("error")
    assert "resumes its run from t = 0.0" in caplog.text
    settings = config.settings
    whole = simulate(RunParameters(Physics(lam=2.0), Discretisation(12, 4), settings["solver"],
                                   **settings["run"]))  # fmt: skip
    assert entry["result"]["t_final"] == pytest.approx(0.12)
    assert entry["result"]["final"]["psi"] == pytest.approx(float(whole.series["psi"][-1]),
                                                            abs=1e-12)  # fmt: skip


def test_flow_time_gives_the_saves_and_steps_in_units_of_one_over_chi(tmp_path):
    """[task] flow_time = true: a run point at chi = 2 with save_every = dt_max = 0.1 in units
    of 1 / chi saves every 0.05 (to t_end 0.1: at 0, 0.05, 0.1) and steps at most 0.05; without
    it, every 0.1.  A point at chi = 0 (no time scale) is refused."""
    from vesicle.io.files import read_run

    def sweep(flag: str, name: str):
        body = (f'[sweep]\ntask = "run"\nout = "{name}.h5"\n[grid]\nlam = [2.0]\nchi = [2.0]\n'
                "[run]\nt_end = 0.1\nsave_every = 0.1\ndt_max = 0.1\nsave_fields = false\n"
                f"{flag}" + SMALL)  # fmt: skip
        store = run_sweep(read_sweep_config(write(tmp_path, body, f"{name}.toml")), workers=1)
        (record,) = store.records.values()
        assert record["status"] == "done", record
        (path,) = (tmp_path / f"{name}_runs").glob("*.h5")
        return read_run(path)

    scaled = sweep("[task]\nflow_time = true\n", "scaled")
    assert scaled.parameters["save_every"] == pytest.approx(0.05)
    assert scaled.parameters["dt_max"] == pytest.approx(0.05)
    assert np.asarray(scaled.series["t"]) == pytest.approx([0.0, 0.05, 0.1])
    plain = sweep("", "plain")
    assert np.asarray(plain.series["t"]) == pytest.approx([0.0, 0.1])
    from vesicle.model.parameters import Physics
    from vesicle.workflows.tasks import _run_settings

    with pytest.raises(ValueError, match="flow_time needs chi > 0"):
        _run_settings(Physics(chi=0.0, flow="none"), {"flow_time": True}, {"run": {}})


def test_a_stability_sweep_on_the_vorticity_branch(tmp_path):
    """[task] orientation = "vorticity": the point is the vorticity-aligned state (long axis
    along y, as `vesicle tt --orientation vorticity` reports) analysed in general modes."""
    path = write(tmp_path, '[sweep]\ntask = "stability"\nout = "s.h5"\n[grid]\nchi = [4.0]\n'
                           'lam = [11.0]\n[task]\norientation = "vorticity"\n' + SMALL)  # fmt: skip
    store = run_sweep(read_sweep_config(path), workers=1)
    (record,) = store.records.values()
    assert record["status"] == "done", record
    result = record["result"]
    assert result["orientation"] == "vorticity"
    assert abs(abs(result["long_axis"][1]) - 1.0) < 1e-9
    assert result["modes"] == "general"
    r = CliRunner().invoke(main, ["tt", "--orientation", "vorticity", "--lam", "11", "--chi", "4",
                                  "--degree", "4", "--grid", "12", "--stability", "--modes",
                                  "general", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    direct = json.loads(r.output.strip().splitlines()[-1])
    assert result["omega_I"] == pytest.approx(direct["omega_I"], abs=1e-9)


def test_a_codim2_curve_keeps_its_evaluations_until_it_is_complete(monkeypatch, tmp_path):
    """A sweep's codim2 curve gets a memo in its curves folder (vesicle.io.memo): kept when
    the curve is cut short or stops with failures (the next try replays it, and says in
    ``replayed`` how many it read back), removed once the curve is complete."""
    import numpy as np

    import vesicle.workflows.tasks as sweep
    from vesicle.bifurcation.neutral import NeutralCurve

    folder = tmp_path / "curves"
    seen = []

    def codim2(physics, chi, disc, memo=None, **options):
        seen.append((memo.folder, len(memo)))
        memo.cached("residual", lambda: np.ones(3), np.zeros(2))
        if len(seen) == 1:
            raise KeyboardInterrupt
        failed = [{"chi": 1.0, "error": "no TT"}] if len(seen) == 2 else []
        return NeutralCurve(physics, disc, [], None, [], 0.0, failed)

    monkeypatch.setattr(sweep, "neutral_curve_codim2", codim2)
    settings = {"curves_dir": str(folder)}
    args = ("neutral", {"v": 0.95}, {"degree": 4, "grid": 12}, {"chi": [1.0]}, settings)
    with pytest.raises(KeyboardInterrupt):
        run_point(*args)
    (memo_folder, before), = seen
    assert memo_folder.parent == folder and memo_folder.name.endswith(".codim2") and before == 0
    assert memo_folder.exists()
    entry = run_point(*args)  # stopped with a failure: kept for the retry
    assert seen[1] == (memo_folder, 1) and entry["result"]["replayed"] == 1
    assert entry["status"] == "failed" and memo_folder.exists()
    entry = run_point(*args)
    assert seen[2] == (memo_folder, 1) and entry["status"] == "done"
    assert not memo_folder.exists()


def _log_on_worker(message: str) -> int:
    import logging
    import os

    logging.getLogger("vesicle.test_forwarding").info(message)
    return os.getpid()


def test_with_verbose_the_workers_progress_reaches_the_command(caplog):
    """vesicle --verbose: a worker process's INFO records of the vesicle logger are forwarded
    to the command's (a curve's progress on a worker shows); at the default level nothing is
    set up.  One real worker process."""
    import logging
    import os
    import time

    from distributed import Client

    from vesicle.parallel import close_cluster, forward_worker_logs, local_cluster

    cluster = local_cluster(1)
    try:
        with Client(cluster) as client:
            logger = logging.getLogger("vesicle")
            old = logger.level
            try:
                logger.setLevel(logging.WARNING)
                assert not forward_worker_logs(client)
                logger.setLevel(logging.INFO)
                with caplog.at_level(logging.INFO, logger="vesicle"):
                    assert forward_worker_logs(client)
                    pid = client.submit(_log_on_worker, "a point of the curve").result()
                    for _ in range(50):  # the record travels on its own message
                        if any("a point of the curve" in r.getMessage() for r in caplog.records):
                            break
                        time.sleep(0.1)
            finally:
                logger.setLevel(old)
    finally:
        close_cluster(cluster)
    assert pid != os.getpid()
    assert any(r.name == "vesicle.test_forwarding" and "a point of the curve" in r.getMessage()
               for r in caplog.records)  # fmt: skip


def test_a_branch_that_ends_at_a_located_fold_is_done_and_one_stopped_short_is_not():
    """The sweep's completeness rule for branches (``tasks._branch_incomplete``), on the
    result dicts ``vesicle branch --json`` writes.  The first is the quick report's Figure 14
    branch at chi = 0.2 (N = 4, 12x24, 2026-12-07): natural continuation stopped between
    7.4834 and 7.48389 and the fold was located at 7.48362 by pseudo-arclength; before this
    rule the sweep recorded it as failed and the item with it.  A fold only estimated, a
    located fold far from the stop (the step failed for another reason) and a stop with no
    fold are not done."""
    from vesicle.workflows.tasks import _branch_incomplete

    def result(folds, between=(7.4834, 7.48389)):
        return {"parameter": "lam", "stopped": "no steady state found beyond lam = 7.4834",
                "stopped_between": list(between),
                "special_points": [{"type": "saddle-node", "lam": lam, "omega_R": 0.0,
                                    "located": located} for lam, located in folds]}  # fmt: skip

    assert _branch_incomplete({"parameter": "lam", "stopped": None}) is None
    assert _branch_incomplete(result([(7.4833984375, True), (7.483620415443056, True)])) is None
    assert _branch_incomplete(result([(7.48362, False)])) is not None  # an estimate
    assert _branch_incomplete(result([(6.9, True)])) is not None  # behind the stop
    assert _branch_incomplete(result([(7.6, True)])) is not None  # far beyond the failed step
    assert _branch_incomplete(result([])) is not None
    # continued downwards (a branch in decreasing lam): the fold lies below the last state
    assert _branch_incomplete(result([(2.9995, True)], between=(3.0, 2.999))) is None


def test_finished_runs_are_analysed_again_from_their_files(tmp_path, caplog):
    """A drawn-again study shows this version's analysis of runs already computed
    (`reanalyse_runs`, called by `run_studies(compute=False)`, i.e. `vesicle paper --redraw`):
    a stored result that differs from the analysis of its run file is replaced by it, without
    stepping, and marked `reanalysed`; a point whose file is gone keeps its stored result, and
    a file holding another run than its point's is not read as that point's."""
    from vesicle.workflows.sweep import reanalyse_runs

    body = ('[sweep]\ntask = "run"\nout = "r.h5"\n[grid]\nlam = [2.0, 3.0, 4.0]\n[run]\n'
            "t_end = 0.06\nsave_every = 0.03\nsave_fields = false\n" + SMALL)  # fmt: skip
    config = read_sweep_config(write(tmp_path, body))
    store = run_sweep(config, workers=1)
    assert store.status(config)["done"] == 3
    two, three, four = config.points
    runs = tmp_path / "r_runs"
    computed = json.loads(json.dumps(store.records[two.key]["result"]))
    for point in config.points:  # results as an older analysis might have left them
        store.records[point.key]["result"]["period"] = 123.0
    (runs / f"{three.key}.h5").unlink()
    (runs / f"{four.key}.h5").unlink()
    two_file = runs / f"{two.key}.h5"
    store.write()
    assert reanalyse_runs(config, store) == 1
    again = SweepStore.read(config.out)
    assert again.records[two.key]["result"] == computed
    assert "reanalysed" in again.records[two.key]
    assert again.records[three.key]["result"]["period"] == 123.0  # no file: kept
    assert reanalyse_runs(config, again) == 0  # nothing left to change
    # a file of another point's run under this point's name is not taken for it
    two_file.rename(runs / f"{three.key}.h5")
    again.records[three.key]["result"]["period"] = 123.0
    with caplog.at_level("WARNING", logger="vesicle.workflows.tasks"):
        assert reanalyse_runs(config, again) == 0
    assert "holds another run" in caplog.text
    # an unreadable file is not a result either: the redraw goes on without it
    (runs / f"{three.key}.h5").write_bytes(b"not a run file")
    with caplog.at_level("WARNING", logger="vesicle.workflows.tasks"):
        assert reanalyse_runs(config, again) == 0
    assert "unreadable" in caplog.text
