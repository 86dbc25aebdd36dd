"""A sweep on a real Dask scheduler (issue 38): ``vesicle sweep CONFIG --scheduler ADDRESS``.

README and docs/howto/sweeps.md: ``--scheduler tcp://host:port`` sends the points to any Dask
scheduler (e.g. one from dask-jobqueue on a cluster).  Here the scheduler and two one-thread
workers are separate processes started with Dask's own command line (``dask scheduler``,
``dask worker ADDRESS``) on localhost, as a cluster's job scripts start them; the sweep runs in
a third process.  Two tt points at N = 2 on 8 x 16: about 20 s in all, mostly start-up.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vesicle.workflows.sweep import SweepStore, read_sweep_config

DASK = Path(sys.executable).with_name("dask")

#: one thread per process, as `vesicle sweep --workers` starts them (vesicle.parallel)
ENV = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
       "VESICLE_THREADS": "1"}  # fmt: skip

CONFIG = """[sweep]
task = "tt"
out = "s.h5"
[grid]
v = [0.95]
lam = [1.0, 2.0]
chi = [1.0]
[discretisation]
degree = 2
grid = 8
"""


def _start(args: list[str], log: Path) -> subprocess.Popen:
    with open(log, "wb") as out:  # the child keeps its own descriptor
        return subprocess.Popen([str(DASK), *args], stdout=out, stderr=subprocess.STDOUT,
                                env=ENV, stdin=subprocess.DEVNULL)  # fmt: skip


def _wait_for(condition, seconds: float, what: str, procs, logs) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        dead = [p for p in procs if p.poll() is not None]
        if dead or time.monotonic() > deadline:
            tails = "\n".join(f"--- {log.name}\n{log.read_text()[-2000:]}" for log in logs)
            pytest.fail(f"{what}: {'a process ended' if dead else 'timed out'}\n{tails}")
        time.sleep(0.2)


def _stop(procs: list[subprocess.Popen]) -> None:
    """Each process started here, by its own id: SIGTERM, then SIGKILL after 10 s."""
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(timeout=10)


@pytest.mark.skipif(not DASK.exists(), reason="the dask command line is not installed")
def test_a_sweep_runs_on_a_dask_scheduler_with_two_workers(tmp_path):
    config_path = tmp_path / "s.toml"
    config_path.write_text(CONFIG)
    info = tmp_path / "scheduler.json"
    logs = [tmp_path / "scheduler.log", tmp_path / "worker-1.log", tmp_path / "worker-2.log"]
    procs: list[subprocess.Popen] = []
    try:
        # port 0: a free port, written with the address to --scheduler-file; the idle timeout
        # and the workers' death timeout end them even if this test could not
        procs.append(_start(["scheduler", "--host", "127.0.0.1", "--port", "0",
                             "--no-dashboard", "--scheduler-file", str(info),
                             "--idle-timeout", "300s"], logs[0]))  # fmt: skip
        _wait_for(lambda: info.exists() and info.stat().st_size > 0, 60,
                  "the scheduler did not start", procs, logs)  # fmt: skip
        address = json.loads(info.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for i, log in enumerate(logs[1:], 1):
            procs.append(_start(["worker", address, "--nthreads", "1", "--no-nanny",
                                 "--no-dashboard", "--name", f"w{i}", "--memory-limit", "0",
                                 "--death-timeout", "60"], log))  # fmt: skip

        def workers() -> int:
            from distributed import Client

            with Client(address, timeout=10) as client:
                return len(client.scheduler_info()["workers"])

        _wait_for(lambda: workers() == 2, 60, "two workers did not connect", procs, logs)

        r = subprocess.run([sys.executable, "-m", "vesicle", "sweep", str(config_path),
                            "--scheduler", address], capture_output=True, text=True, env=ENV,
                           timeout=120, cwd=tmp_path)  # fmt: skip
        assert r.returncode == 0, r.stderr
        assert "2 done, 0 failed, 0 pending" in r.stdout
        r = subprocess.run([sys.executable, "-m", "vesicle", "sweep", str(config_path),
                            "--status", "--json"], capture_output=True, text=True, env=ENV,
                           timeout=60)  # fmt: skip
        assert json.loads(r.stdout) == {"done": 2, "failed": 0, "pending": 0}, r.stderr
    finally:
        _stop(procs)
    config = read_sweep_config(config_path)
    store = SweepStore.read(tmp_path / "s.h5")
    assert store.status(config) == {"done": 2, "failed": 0, "pending": 0}
    rows = store.rows()
    assert [row["lam"] for row in rows] == [1.0, 2.0]
    assert all(isinstance(row["psi"], float) and row["status"] == "done" for row in rows)
    # each point was computed by one of the two worker processes (--no-nanny: the process
    # started here is the worker), not by the sweep's own process
    worker_pids = {p.pid for p in procs[1:]}
    assert {record["pid"] for record in store.records.values()} <= worker_pids
