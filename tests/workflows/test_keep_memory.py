"""The allocator keeps freed memory (``vesicle.parallel.keep_freed_memory``), here and on Dask
workers.

What is checked is the behaviour the setting exists for, counted by the kernel: a process that
allocates, fills and frees a large array several times takes new pages (minor page faults) for
each round under glibc's defaults, and for the first round only once the setting applies.  The
expected counts come from the kernel's ``getrusage``, not from this package."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux") or os.confstr("CS_GNU_LIBC_VERSION") is None,
    reason="the setting is glibc's malloc",
)

#: Rounds of a 64 MB array (above glibc's largest automatic mmap threshold, 32 MB).
ROUNDS, MEGABYTES = 6, 64


def _faults_of_churn(rounds: int = ROUNDS, megabytes: int = MEGABYTES) -> tuple[int, int]:
    """(minor page faults of ``rounds`` allocations of a filled ``megabytes`` array, those of
    the first alone); run where the allocator is to be tested."""
    import resource

    import numpy as np

    n = megabytes * 2**20 // 8

    def churn(k):
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(k):
            a = np.empty(n)
            a.fill(1.0)
            del a
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

    first = churn(1)
    return first + churn(rounds - 1), first


_SCRIPT = f"""
import sys, threading
sys.path.insert(0, {os.path.dirname(__file__)!r})
from vesicle.parallel import keep_freed_memory
from test_keep_memory import _faults_of_churn
applied = keep_freed_memory()
out = [applied, *_faults_of_churn()]
def in_thread():  # as the assembly's ring threads allocate
    out.extend(_faults_of_churn())
thread = threading.Thread(target=in_thread)
thread.start()
thread.join()
print(*out)
"""


def _in_subprocess(keep: str) -> tuple[bool, int, int, int, int]:
    """(applied, faults of the churn and of its first round, the same in a new thread) in a new
    process, with ``VESICLE_KEEP_MEMORY=keep``."""
    env = {**os.environ, "VESICLE_KEEP_MEMORY": keep}
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    env.pop("MALLOC_MMAP_MAX_", None)
    env.pop("MALLOC_ARENA_MAX", None)
    out = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, capture_output=True,
                         text=True, check=True).stdout.split()  # fmt: skip
    return out[0] == "True", *(int(x) for x in out[1:])


def test_keep_freed_memory_reuses_pages():
    # the reference: glibc's defaults map a block above 32 MB afresh each round and unmap it
    # when freed, so every round faults its pages in again
    applied, total, first, thread_total, thread_first = _in_subprocess("0")
    assert not applied
    assert total > 2.5 * first
    assert thread_total > 2.5 * thread_first
    # kept: the rounds after the first reuse its pages, in the main thread and in another
    # (which shares the main thread's arena, whose pages the first rounds faulted in already)
    applied, total, first, thread_total, thread_first = _in_subprocess("1")
    assert applied
    assert total < 1.5 * first
    assert thread_total < 0.5 * first


def test_dask_workers_keep_freed_memory(monkeypatch):
    from distributed import Client

    from vesicle.parallel import close_cluster, local_cluster

    counts = {}
    for keep in ("0", "1"):
        monkeypatch.setenv("VESICLE_KEEP_MEMORY", keep)
        # a nanny sets its pre-spawn environment in this process too (distributed's own
        # note): an earlier test's LocalCluster may have left the kept settings here, which
        # the reference's worker would inherit
        for name in ("MALLOC_MMAP_MAX_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_ARENA_MAX"):
            monkeypatch.delenv(name, raising=False)
        cluster = local_cluster(1)
        try:
            with Client(cluster) as client:
                counts[keep] = client.submit(_faults_of_churn, pure=False).result()
        finally:
            close_cluster(cluster)
    (total0, first0), (total1, first1) = counts["0"], counts["1"]
    assert total0 > 2.5 * first0  # Dask's own setting: mapped and trimmed every round
    assert total1 < 1.5 * first1  # kept from the worker's start (the nanny's pre-spawn environ)
