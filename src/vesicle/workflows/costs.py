"""The measured costs that the README, the docs and the CLI's help quote (issue 38).

One table, so that the figures cannot drift apart: ``vesicle --help``, ``vesicle paper --help``
and ``vesicle study --list`` are built from it, and ``tests/workflows/test_costs.py`` checks
that the README and the docs quote exactly these figures wherever they quote the cost of one of
these commands. To update a cost: measure it, change its entry here (figure, measured value,
date, source), change the sentence in the doc it comes from, and run
``tests/workflows/test_costs.py``: it names every place that still quotes the old figure.

Every figure is a measurement stated in the docs or in the git log; none is estimated here.
Where two sources disagree, the one measured most recently is taken, and the comment of the
entry says which one lost. All are on the project's 2-core machine unless said otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["COSTS", "STUDY_COSTS", "Cost", "StudyCost", "command_help", "study_cost"]


@dataclass(frozen=True)
class Cost:
    """One measured cost.

    ``figure`` is the text the README and the help quote ("19 s"); ``measured`` the value as
    the source states it ("18.6 s"); ``source`` the file (or commit) that states it."""

    command: str
    figure: str
    resolution: str
    measured: str
    when: str
    source: str


COSTS: MappingProxyType[str, Cost] = MappingProxyType({
    # 18.6 s: docs/reference/performance.md target 1, the benchmark of 2026-12-03 with the machine
    # otherwise idle. Older and superseded: 33 s (vesicle --help, 2026-12-02, before the
    # preconditioned solves); 39 s in docs/reference/performance.md *Memory* had a neutral-curve job
    # on the other core.
    "tt_stability": Cost(
        command="vesicle tt --stability",
        figure="19 s",
        resolution="N = 8 on 32x64, v = 0.95, lam = 8, chi = 10",
        measured="18.6 s",
        when="2026-12-03, `python benchmarks/run.py steady` (VESICLE_BENCH_FULL=1), machine "
             "otherwise idle",
        source="docs/reference/performance.md",
    ),
    # 12.2 s: docs/reference/performance.md *Target 2*, 2026-12-03. Superseded: 28 s (2026-12-02,
    # the studies' old cost keys) and 42.8 s (the machine of 2026-12-02).
    "continuation_step": Cost(
        command="one continuation step with its stability (lam 7 -> 7.3 at chi = 1)",
        figure="12 s",
        resolution="N = 8 on 32x64, v = 0.95",
        measured="12.2 s",
        when="2026-12-03, `benchmarks/bench_steady.py` (VESICLE_BENCH_FULL=1), alone",
        source="docs/reference/performance.md",
    ),
    # 71.5 s: docs/reference/performance.md *Target 2* (commit ca2273b, 2026-12-03 05:46). Lost:
    # docs/notes/steady-measurements.md's 81 s (commit 460ec3c, 04:55 the same day) and "about 5
    # min" of the old vesicle --help (2026-12-02, from the leading-order start without the coarse
    # search).
    "critical": Cost(
        command="vesicle critical --v 0.95 --chi 1",
        figure="72 s",
        resolution="N = 8 on 32x64 (a coarse search at N = 4 on 16x32 first)",
        measured="71.5 s",
        when="2026-12-03, `benchmarks/bench_steady.py` (VESICLE_BENCH_FULL=1), alone",
        source="docs/reference/performance.md",
    ),
    "critical_no_coarse": Cost(
        command="vesicle critical --v 0.95 --chi 1 --no-coarse",
        figure="3.5 min",
        resolution="N = 8 on 32x64",
        measured="207.6 s",
        when="2026-12-03, the same run as `critical`",
        source="docs/reference/performance.md",
    ),
    # 160.0 s per unit of time: docs/notes/dynamics-measurements.md *Equal accuracy* (2026-12-02, to
    # t = 1 within 1e-4 of a tight reference psi). Lost: 260 s per unit of time (about 3 s a step)
    # of the old vesicle --help, docs/notes/dynamics-measurements.md *Cost* of 2026-11-22 (the
    # start-up transient to t = 0.2 at rtol 1e-4, before the fused kernels of later sessions).
    "run_ros2": Cost(
        command="vesicle run (ROS2, rtol 3e-5), near lam = 8, per unit of time",
        figure="160 s",
        resolution="N = 8 on 32x64, v = 0.95, chi = 1, from the spheroid to t = 1",
        measured="160.0 s",
        when="2026-12-02, `python benchmarks/run.py integrators` (VESICLE_BENCH_FULL=1), "
             "machine otherwise idle",
        source="docs/notes/dynamics-measurements.md",
    ),
    "run_ros34pw2": Cost(
        command="vesicle run --integrator ros34pw2 --rtol 1e-1, near lam = 8, per unit of time",
        figure="47 s",
        resolution="N = 8 on 32x64, v = 0.95, chi = 1, from the spheroid to t = 1",
        measured="47.4 s",
        when="2026-12-02, the same run as run_ros2",
        source="docs/notes/dynamics-measurements.md",
    ),
    # The README's quick-start command 1 (the default run: v = 0.95, lam = 1, chi = 1, N = 8 on
    # 32x64, ROS34PW2 at rtol 1e-3, until settled on TT at t = 2.85). Remeasure when the default
    # run changes. 71 s on a fresh clone, figures included, alone (103 s beside another job).
    "run_default": Cost(
        command="vesicle run",
        figure="1 min 10 s",
        resolution="the default run: N = 8 on 32x64, v = 0.95, lam = 1, chi = 1, until it "
                   "settles on tank-treading (t = 2.85)",
        measured="71 s (fresh clone, figures included, nothing else running)",
        when="2026-12-06; the install is not included",
        source="issue 38's session (measured with /usr/bin/time)",
    ),
    # The README's quick-start command 2, from a fresh clone (the thirteenth session's, its
    # tests alone on the machine; docs/notes/studies-measurements.md). Superseded: 13 min 59 s
    # for 992 tests (tenth session), 7 min 30 s for 874 tests (2026-12-06, before issue 42's
    # tests), 10 min 21 s for 861 tests (earlier).
    "tests": Cost(
        command="OPENBLAS_NUM_THREADS=1 python -m pytest -q",
        figure="about 17 min",
        resolution="the default selection (slow tests deselected)",
        measured="16 min 44 s for 1018 tests",
        when="2026-12-07: a fresh clone and virtual environment, alone on the 2-core machine "
             "(pytest's own clock)",
        source="docs/notes/studies-measurements.md",
    ),
    # 16 min 44 s: docs/paper.md *Cost of the quick report*, the last row (2026-12-03 evening,
    # commit f37d9e4). Lost: "about half an hour" of the old vesicle paper --help (never a
    # measurement), and the earlier rows 19 min 55 s, 18 min 32 s, 13 min 42 s (earlier code).
    "paper_quick": Cost(
        command="vesicle paper --quick",
        figure="17 min",
        resolution="N = 4 on 12x24, fewer points, shorter runs",
        measured="16 min 44 s",
        when="2026-12-03 evening, `vesicle paper --quick --workers 2` from a fresh clone, "
             "machine otherwise idle",
        source="docs/paper.md",
    ),
    "neutral_quick": Cost(
        command="vesicle neutral --continuation trace --v 0.95 --chi 0.2,1,3 --degree 4 --grid 16",
        figure="2.5 min",
        resolution="N = 4 on 16x32",
        measured="about 2.5 min",
        when="2026-12-02",
        source="git d8850ff",
    ),
    # docs/notes/continuation-measurements.md *Neutral curves measured*: v = 0.98 5.2 min and v =
    # 0.95 13 min (2026-12-02); v = 0.90 17 min when retraced on 2026-12-03 (its 33 min of
    # 2026-12-02 lost).
    "neutral_13": Cost(
        command="vesicle neutral --continuation trace --chi 0.1:10 --points 13 (v = 0.98 to 0.90)",
        figure="5–17 min",
        resolution="N = 4 on 16x32",
        measured="5.2 min (v = 0.98), 13 min (v = 0.95), 17 min (v = 0.90)",
        when="2026-12-02 and (v = 0.90) 2026-12-03, with other jobs beside it",
        source="docs/notes/continuation-measurements.md",
    ),
    # docs/notes/continuation-measurements.md, N = 8 retraced 2026-12-03. Lost: the README's "2–7
    # min per chi" (commit bd29ad0, 2026-12-02).
    "neutral_n8": Cost(
        command="vesicle neutral --continuation trace --degree 8 --grid 32, per chi",
        figure="1.6–3 min a point at χ ≥ 0.36, 13–31 min at the folds",
        resolution="N = 8 on 32x64, v = 0.95",
        measured="1.6–3 min a point at χ ≥ 0.36, 5 min at 0.278, 13–31 min at the folds",
        when="2026-12-03, the other core busy",
        source="docs/notes/continuation-measurements.md",
    ),
    # docs/notes/codim2-measurements.md *One thread on small grids* (2026-12-06, sixth
    # session, alone, /usr/bin/time; 129 s in the fifth session on two threads, 202 s in the
    # fourth, 364 s in the second).
    "neutral_codim2_13": Cost(
        command="vesicle neutral --v 0.95 --chi 0.1:10 --points 13 --degree 4 --grid 16",
        figure="1 min",
        resolution="N = 4 on 16x32, v = 0.95 (BT point, type change and 13 located points)",
        measured="66.1 s",
        when="2026-12-06, alone",
        source="docs/notes/codim2-measurements.md",
    ),
    # docs/notes/codim2-measurements.md *The N = 8 curves under 20 min* (2026-12-06, fifth
    # session, alone, /usr/bin/time; 1454 s and 2112 s in the fourth session, 2009 s in the
    # third).
    "neutral_codim2_n8": Cost(
        command="vesicle neutral --v 0.95 --chi 0.1:10 --points 13 --degree 8 --grid 32",
        figure="18 min",
        resolution="N = 8 on 32x64, v = 0.95 and 0.90 (BT point, type change and 13 located "
                   "points)",
        measured="963 s (v = 0.95), 1079 s (v = 0.90)",
        when="2026-12-06, alone",
        source="docs/notes/codim2-measurements.md",
    ),
})  # fmt: skip


@dataclass(frozen=True)
class StudyCost:
    """A study's measured cost: its ``--quick`` points in ``vesicle paper --quick`` (N = 4 on
    12x24, 2 one-thread workers, 2026-12-03; docs/howto/studies.md *Costs*) and, where measured, its
    full resolution; ``size`` says how much work the full study is."""

    points: str
    cpu_s: int
    longest_s: int
    size: str
    full: str = ""


#: docs/howto/studies.md *Costs*. Superseded: the cost keys the study files had (tt-shape-chi 3 min
#: 56 s and tt-shape-lambda 1 min 39 s at 16x32 with 4 other jobs; "about 28 s" a continuation
#: step, now 12 s).
STUDY_COSTS: MappingProxyType[str, StudyCost] = MappingProxyType({
    "tt-shape-chi": StudyCost("3 branches", 53, 30, "3 branches of 11 points"),
    "tt-shape-lambda": StudyCost("1 branch", 19, 19, "1 branch of 21 points"),
    "tt-excess-area": StudyCost("3 branches", 16, 7, "3 branches in v of 8 points"),
    "orbits": StudyCost("3 runs", 219, 149, "3 runs of 4 periods"),
    # measured with the quick runs to t = 30; they go to t = 40 since
    "stress-time": StudyCost("2 runs", 284, 226, "2 runs of 4 periods"),
    "periods-high-shear": StudyCost("4 runs", 137, 64, "6 runs of 3 periods"),
    # measured with saves and steps of 0.5; 2.0 since 2026-12-07 (half the solves at lam = 8)
    "periods-low-shear": StudyCost("4 runs", 519, 167, "6 runs of 3 periods, T of order 100"),
    "stress-lambda-runs": StudyCost("1 run", 58, 58, "7 runs of 3 periods"),
    "stress-lambda": StudyCost("3 branches", 165, 131, "3 branches of 17 points",
                               full="1223 s wall at N = 8 on 24x48 (one worker, 2026-12-03)"),
    "stress-chi": StudyCost("4 branches", 76, 30, "4 branches of 11 points"),
    # measured 2026-12-07 with `vesicle study stress-chi-runs --quick --workers 1` beside three
    # other jobs on the 2 cores (the point's wall time: its CPU time is less)
    "stress-chi-runs": StudyCost("1 run", 342, 342, "9 runs of 3 periods at lam = 8.7"),
    "stress-split": StudyCost("2 branches", 29, 16, "2 branches of 17 points"),
    "ellipsoid-maps": StudyCost("3 maps", 40, 15, "3 maps of 15 x 15 solves"),
    # measured 2026-12-07 with `vesicle study NAME --quick --workers 1`, beside two other jobs
    "membrane-viscosity": StudyCost("1 curve", 103, 103, "4 curves in (Bq, lambda) at N = 8",
                                    full="v = 0.95: 1212 s (chi = 1) at N = 8 on 32x64"),
    "membrane-viscosity-check": StudyCost("1 curve", 77, 77, "1 curve at N = 4 on 16x32"),
    "membrane-viscosity-runs": StudyCost("2 runs", 191, 162, "10 runs at N = 4 on 16x32, "
                                         "to 3 settled periods or a steady state"),
})  # fmt: skip


def study_cost(name: str) -> str | None:
    """The cost line ``vesicle study --list`` shows for a shipped study (None if unknown)."""
    c = STUDY_COSTS.get(name)
    if c is None:
        return None
    if c.full:
        full = c.full
    elif "branch" in c.size:
        step = COSTS["continuation_step"].figure
        full = f"not measured ({c.size}; a continuation step takes about {step} at N = 8)"
    else:
        full = f"not measured ({c.size})"
    return (f"--quick {c.cpu_s} s of CPU, longest point {c.longest_s} s ({c.points}; in "
            f"`vesicle paper --quick`, 2026-12-03); full resolution: {full}")  # fmt: skip


def command_help(summary: str) -> str:
    """``vesicle --help``: ``summary`` and the measured costs of the expensive commands."""
    c = COSTS
    return (
        f"{summary}\n\n"
        f"Measured costs on a 2-core machine at the default resolution (N = 8 on 32 x 64): "
        f"`tt --stability` {c['tt_stability'].figure}; a continuation step with its stability "
        f"{c['continuation_step'].figure}; `critical --v 0.95 --chi 1` {c['critical'].figure} "
        f"(--no-coarse {c['critical_no_coarse'].figure}); `run` near lambda = 8: "
        f"{c['run_ros2'].figure} per unit of time (ROS2, rtol 3e-5), "
        f"{c['run_ros34pw2'].figure} with --integrator ros34pw2 --rtol 1e-1; `run` with its "
        f"defaults {c['run_default'].figure}. `neutral --v 0.95 --chi 0.1:10 --points 13` at "
        f"N = 4 on 16 x 32: about {c['neutral_codim2_13'].figure} (the one-parameter tracer, "
        f"--continuation trace, about {c['neutral_quick'].figure} for --chi 0.2,1,3). "
        f"`paper --quick`: about {c['paper_quick'].figure}. "
        f"Dates and sources: vesicle.workflows.costs."
    )
