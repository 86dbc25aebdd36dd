"""The allocator keeping freed memory (``vesicle.parallel.keep_freed_memory``) against glibc's
own behaviour (``VESICLE_KEEP_MEMORY=0``, the reference), in the two places the package runs:

- the command line: ``vesicle tt --stability`` in a new process each;
- a Dask worker of ``vesicle.parallel.local_cluster`` (whose nanny sets glibc to trim anything
  above 64 kB unless the package keeps the memory): the same state twice in one worker, as a
  neutral curve's worker computes state after state.

Reported per case: wall time, the process's user and system CPU seconds and its minor page
faults (``getrusage``), and the ratio of CPU seconds reference / kept.  System time is where
fresh pages cost: the kernel zeroes each page it hands out.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time

#: The state: v = 0.95, lam = 8, chi = 1 with its stability (``vesicle tt``'s defaults else).
ARGS = ["tt", "--v", "0.95", "--lam", "8", "--chi", "1", "--stability", "--threads", "1"]


def _cli(keep: str, degree: int, grid: int) -> dict:
    env = {**os.environ, "VESICLE_KEEP_MEMORY": keep, "OPENBLAS_NUM_THREADS": "1"}
    for name in ("MALLOC_MMAP_MAX_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_ARENA_MAX"):
        env.pop(name, None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "vesicle", *ARGS, "--degree", str(degree),
                    "--grid", str(grid)], env=env, check=True, capture_output=True)  # fmt: skip
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"wall_s": time.perf_counter() - t0, "user_s": after.ru_utime - before.ru_utime,
            "sys_s": after.ru_stime - before.ru_stime,
            "minflt": after.ru_minflt - before.ru_minflt}  # fmt: skip


def _state(degree: int, grid: int) -> dict:
    """On a worker: the state of :data:`ARGS` through the command's own code, timed."""
    from vesicle.cli import main

    r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    main([*ARGS, "--degree", str(degree), "--grid", str(grid)], standalone_mode=False)
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    return {"wall_s": time.perf_counter() - t0, "user_s": r1.ru_utime - r0.ru_utime,
            "sys_s": r1.ru_stime - r0.ru_stime, "minflt": r1.ru_minflt - r0.ru_minflt}  # fmt: skip


def _worker(keep: str, degree: int, grid: int) -> list[dict]:
    import cloudpickle
    from distributed import Client

    from vesicle.parallel import close_cluster, local_cluster

    old = os.environ.get("VESICLE_KEEP_MEMORY")
    os.environ["VESICLE_KEEP_MEMORY"] = keep
    try:
        cluster = local_cluster(1)
    finally:
        if old is None:
            os.environ.pop("VESICLE_KEEP_MEMORY")
        else:
            os.environ["VESICLE_KEEP_MEMORY"] = old
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers lack this folder
    try:
        with Client(cluster) as client:
            return [client.submit(_state, degree, grid, pure=False).result() for _ in range(2)]
    finally:
        close_cluster(cluster)


def _line(label: str, r: dict) -> str:
    return (f"  {label:<34} wall {r['wall_s']:6.1f} s  user {r['user_s']:6.1f} s  "
            f"sys {r['sys_s']:6.1f} s  page faults {r['minflt']:>9}")  # fmt: skip


def run(degree: int = 8, grid: int = 32) -> dict:
    out = {"degree": degree, "grid": grid}
    print(f"vesicle tt --stability at N = {degree} on {grid}x{2 * grid}, one thread")
    for keep, name in (("0", "reference"), ("1", "kept")):
        out[f"cli_{name}"] = r = _cli(keep, degree, grid)
        print(_line(f"command line, {name}", r))
    cpu = {k: out[f"cli_{k}"]["user_s"] + out[f"cli_{k}"]["sys_s"] for k in ("reference", "kept")}
    out["cli_cpu_ratio"] = cpu["reference"] / cpu["kept"]
    print(f"  command line: CPU reference / kept = {out['cli_cpu_ratio']:.2f}")
    for keep, name in (("0", "reference"), ("1", "kept")):
        out[f"worker_{name}"] = rows = _worker(keep, degree, grid)
        for i, r in enumerate(rows):
            print(_line(f"Dask worker, {name}, state {i + 1}", r))
    cpu = {k: out[f"worker_{k}"][1]["user_s"] + out[f"worker_{k}"][1]["sys_s"]
           for k in ("reference", "kept")}  # fmt: skip
    out["worker_cpu_ratio"] = cpu["reference"] / cpu["kept"]
    print(f"  Dask worker, second state: CPU reference / kept = {out['worker_cpu_ratio']:.2f}")
    return out


if __name__ == "__main__":
    run()
