"""Fault injection (issue 17, item 12): killed runs, damaged files, a full disk.

Nothing the user asked for may be lost: a run killed at any moment (SIGKILL: no handler runs)
resumes from its last checkpoint to a final state bit-identical to an uninterrupted run; a
truncated or altered run file is refused with a clear error; a full disk stops the run with a
clear error and leaves the previous file intact.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from vesicle.cli import main
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.io.files import read_run

#: A small run that checkpoints after every step (checkpoint_every is in wall seconds).
PARAMS = {"grid": 12, "degree": 4, "t_end": 0.3, "save_every": 0.01, "checkpoint_every": 1e-9}

CHILD = """
import sys
from pathlib import Path
from vesicle.dynamics.integrators import RunParameters
from vesicle.io.files import read_run
from vesicle.dynamics.simulation import load_parameters, simulate
out = Path(sys.argv[1])
def step(info):
    print("step", flush=True)  # the parent counts these to kill at a chosen step
if out.exists():
    data = read_run(out)
    simulate(load_parameters(data), out=out, resume=data, progress=step)
else:
    simulate(RunParameters().replace(**{params!r}), out=out, progress=step)
print("done", flush=True)
"""


def _reference(params=PARAMS):
    return simulate(RunParameters().replace(**params))


def _killed_and_resumed(out: Path, kills: int, seed: int, params=PARAMS) -> int:
    """Run the child, SIGKILL it ``kills`` times at random moments, then let it finish.

    The moments are drawn in steps, not wall seconds, so that the test does not depend on the
    machine's speed: each child is killed after 1 or 2 accepted steps of its own plus a random
    fraction of a step's time (so the kill lands anywhere: in a solve, in the checkpoint write
    that follows the step, between steps). Returns how many kills interrupted a running child."""
    rng = np.random.default_rng(seed)
    code = CHILD.format(params=params)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    interrupted = 0
    for _ in range(kills + 1):
        child = subprocess.Popen(
            [sys.executable, "-c", code, str(out)], env=env, stdout=subprocess.PIPE
        )
        if interrupted < kills:
            steps, started = int(rng.integers(1, 3)), None
            while steps > 0:
                line = child.stdout.readline()
                if line != b"step\n":
                    break  # finished (or failed): checked below
                steps -= 1
                started = started or time.perf_counter()
            if steps == 0:
                per_step = time.perf_counter() - started + 0.01
                time.sleep(rng.uniform(0.0, per_step))
                if child.poll() is None:
                    child.send_signal(signal.SIGKILL)
                    child.wait()
                    child.stdout.close()
                    interrupted += 1
                    continue
        stdout, _ = child.communicate(timeout=300)
        assert child.returncode == 0 and b"done" in stdout
        ck = read_run(out).checkpoint
        assert ck["t"] >= params["t_end"] - 1e-12
        # a run that ends before every kill was made has too few steps for this test
        assert interrupted >= kills, f"the run finished after {interrupted} of {kills} kills"
        return interrupted
    raise AssertionError("unreachable: the last child is never killed")


def _assert_identical(run, ref):
    assert run.n_saved == ref.n_saved
    for key, value in ref.series.items():
        np.testing.assert_array_equal(run.series[key], value, err_msg=key)
    np.testing.assert_array_equal(run.coefficients, ref.coefficients)
    np.testing.assert_array_equal(run.checkpoint["coefficients"], ref.checkpoint["coefficients"])


def test_sigkill_at_random_moments_then_resume_is_bit_identical(tmp_path):
    out = tmp_path / "killed.h5"
    assert _killed_and_resumed(out, kills=3, seed=1) >= 3
    _assert_identical(read_run(out), _reference())
    assert not (tmp_path / "killed.h5.tmp").exists()


@pytest.mark.slow
def test_twenty_sigkills_then_resume_is_bit_identical(tmp_path):
    out = tmp_path / "killed.h5"
    params = {**PARAMS, "t_end": 0.9}  # about 180 steps: 20 kills take at most 60
    assert _killed_and_resumed(out, kills=20, seed=2, params=params) >= 20
    _assert_identical(read_run(out), _reference(params))


@pytest.fixture
def run_file(tmp_path):
    out = tmp_path / "r.h5"
    simulate(RunParameters().replace(**{**PARAMS, "t_end": 0.02}), out=out)
    return out


def test_truncated_file_is_refused_clearly(run_file):
    data = run_file.read_bytes()
    run_file.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="not a readable HDF5 file"):
        read_run(run_file)
    r = CliRunner().invoke(main, ["run", "--resume", str(run_file), "--no-progress"])
    assert r.exit_code != 0 and "not a readable HDF5 file" in r.output
    assert "Traceback" not in r.output


@pytest.mark.parametrize("where", ["checkpoint", "series", "parameters"])
def test_altered_file_is_refused_by_its_checksum(run_file, where):
    with h5py.File(run_file, "r+") as f:
        if where == "checkpoint":
            f["checkpoint"]["coefficients"][0, 0] += 1e-9
        elif where == "series":
            f["series"]["psi"][-1] += 1e-9
        else:
            f["parameters"].attrs["t_end"] = 5.0
    with pytest.raises(ValueError, match="corrupted"):
        read_run(run_file)
    r = CliRunner().invoke(main, ["run", "--resume", str(run_file), "--no-progress"])
    assert r.exit_code != 0 and "corrupted" in r.output and "Traceback" not in r.output


@pytest.fixture
def small_disk(tmp_path):
    """A 160 KB tmpfs (needs root; skipped elsewhere)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=160k", "tmpfs", str(mount)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def test_full_disk_is_a_clear_error_and_keeps_the_previous_file(small_disk):
    out = small_disk / "r.h5"
    args = ["run", "--grid", "12", "--degree", "4", "--t-end", "2", "--save-every", "0.002",
            "--checkpoint-every", "0.000001", "--out", str(out), "--no-progress",
            "--no-plot"]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0, r.output
    assert "could not write" in r.output and "Traceback" not in r.output
    kept = read_run(out)  # intact: readable, checksum verified
    assert 0 < kept.checkpoint["t"] < 2.0
    assert not Path(str(out) + ".tmp").exists()
