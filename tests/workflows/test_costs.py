"""The measured costs are quoted from one table (``vesicle.workflows.costs``; issue 38): the
README, the
docs and the help texts say exactly what it says, and it says what its sources measured."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from click.testing import CliRunner

from vesicle.cli import main
from vesicle.workflows.costs import COSTS, STUDY_COSTS, study_cost
from vesicle.workflows.study import list_studies, load_study

ROOT = Path(__file__).resolve().parents[2]


def _text(path: str) -> str:
    """A file's text with every run of white space one blank (quotes may wrap lines)."""
    return " ".join((ROOT / path).read_text().split())


def _help(*args: str) -> str:
    r = CliRunner().invoke(main, list(args), terminal_width=100)
    assert r.exit_code == 0, r.output
    return " ".join(r.output.split())


#: Where the README and the docs quote a cost of the table: (file, entry, pattern whose group 1
#: is the figure quoted there; the entry's ``figure``, or its ``measured`` value where the key
#: ends in ":measured"). A new quote of one of these costs belongs here.
QUOTES = [
    ("README.md", "tt_stability", r"`vesicle tt --stability` (\S+ s);"),
    ("README.md", "continuation_step", r"one continuation step with its stability (\S+ s)"),
    ("README.md", "critical", r"`vesicle critical --v 0\.95 --chi 1` (\S+ s) from its default"),
    ("README.md", "critical_no_coarse", r"`--no-coarse` ([\d.]+ min)"),
    ("README.md", "run_ros2", r"reference ψ: (\S+ s) with ROS2"),
    ("README.md", "run_ros34pw2", r"(\S+ s) with `--integrator ros34pw2"),
    ("README.md", "run_default", r"< 1e-3\) \(about (\d+ min(?: \d+ s)?) on 2 cores"),
    ("README.md", "tests", r"the command CI runs\): (about \d+ min) on 2 cores"),
    ("README.md", "tests:measured", r"\(measured: (\d+ min \d+ s for \d+ tests), a fresh"),
    ("README.md", "paper_quick", r"shorter runs\): about (\d+ min) on 2 cores"),
    ("README.md", "paper_quick:measured", r"\((\d+ min \d+ s) measured on 2026-12-03"),
    ("README.md", "neutral_quick", r"about ([\d.]+ min) for χ = 0\.2, 1, 3"),
    ("README.md", "neutral_13", r"and (\S+ min) for 13 χ"),
    ("README.md", "neutral_n8", r"other core busy\), (1\.6.*? at the folds)"),
    ("README.md", "neutral_codim2_13",
     r"at N = 4 on 16×32 about (\d+ min) for 13 χ from 0\.1 to 10 at"),
    ("docs/paper.md", "paper_quick", r"fewer points \(about (\d+ min)\)"),
    ("docs/notes/steady-measurements.md", "tt_stability",
     r"`vesicle tt --stability` there takes (\S+ s)"),
    ("docs/howto/steady-states.md", "tt_stability", r"`vesicle tt --stability` (\S+ s);"),
    ("docs/howto/steady-states.md", "critical",
     r"`vesicle critical --v 0\.95 --chi 1` (\S+ s) from its default"),
    ("docs/howto/steady-states.md", "critical_no_coarse", r"`--no-coarse` ([\d.]+ min)"),
    ("docs/howto/running.md", "run_default",
     r"ψ = 0\.5648, in about (\d+ min(?: \d+ s)?) on 2 cores"),
    ("docs/howto/running.md", "run_ros2", r"reference ψ: (\S+ s) with ROS2"),
    ("docs/howto/running.md", "run_ros34pw2", r"(\S+ s) with `--integrator ros34pw2"),
    ("docs/howto/continuation.md", "continuation_step",
     r"one continuation step with its stability (\S+ s)"),
    ("docs/howto/continuation.md", "neutral_quick", r"about ([\d.]+ min) for χ = 0\.2, 1, 3"),
    ("docs/howto/continuation.md", "neutral_13", r"and (\S+ min) for 13 χ"),
    ("docs/howto/continuation.md", "neutral_n8", r"other core busy\), (1\.6.*? at the folds)"),
    ("docs/howto/continuation.md", "neutral_codim2_13",
     r"at N = 4 on 16×32 about (\d+ min) for 13 χ from 0\.1 to 10 at"),
    ("docs/howto/continuation.md", "neutral_codim2_n8",
     r"at N = 8 on 32×64 about (\d+ min) for the same \(alone\)"),
    ("docs/howto/report.md", "paper_quick", r"The quick report: about (\d+ min) on 2 cores"),
    ("docs/howto/report.md", "paper_quick:measured", r"\((\d+ min \d+ s) measured on 2026-12-03"),
]


@pytest.mark.parametrize(("path", "key", "pattern"), QUOTES)
def test_the_readme_and_docs_quote_the_table(path, key, pattern):
    found = re.findall(pattern, _text(path))
    assert found, f"{path} no longer quotes {key} as {pattern!r}: update QUOTES"
    name, _, field = key.partition(":")
    figure = getattr(COSTS[name], field or "figure")
    for quoted in found:
        assert quoted == figure, (
            f"{path} quotes {key} as {quoted!r}, vesicle.workflows.costs {figure!r}"
        )


@pytest.mark.parametrize("key", sorted(COSTS))
def test_each_measurement_is_stated_by_its_source(key):
    """Every value in ``measured`` (a number and its unit) is written in the doc the entry
    names; entries from the git log or the issue name no file."""
    cost = COSTS[key]
    if not cost.source.startswith("docs/"):
        pytest.skip(f"{key}: from {cost.source}")
    values = re.findall(r"[\d.]+(?:–[\d.]+)? (?:min \d+ s|min|s)\b", cost.measured)
    assert values, cost.measured
    text = _text(cost.source)
    for value in values:
        assert value in text, f"{cost.source} does not state {value} ({key})"


def test_the_study_costs_are_the_table_of_docs_studies():
    """docs/howto/studies.md *Costs*: one row per study, the CPU and longest point of the table."""
    rows = re.findall(r"^\| `([\w-]+)` \| ([^|]+) \| (\d+) \| (\d+)[^|]*\|$",
                      (ROOT / "docs/howto/studies.md").read_text(), flags=re.M)  # fmt: skip
    assert {name for name, *_ in rows} == set(STUDY_COSTS)
    for name, points, cpu, longest in rows:
        c = STUDY_COSTS[name]
        assert (int(cpu), int(longest)) == (c.cpu_s, c.longest_s), name
        assert points.startswith(c.points), (name, points)
    assert "| `stress-lambda` (N = 8, 24×48) |" in (ROOT / "docs/howto/studies.md").read_text()
    assert "1223 s" in STUDY_COSTS["stress-lambda"].full
    assert "| 1223 |" in _text("docs/howto/studies.md")


def test_vesicle_help_shows_the_table():
    text = _help("--help")
    for key in (
        "tt_stability",
        "continuation_step",
        "critical",
        "critical_no_coarse",
        "run_ros2",
        "run_ros34pw2",
        "run_default",
        "neutral_quick",
        "neutral_codim2_13",
        "paper_quick",
    ):
        assert COSTS[key].figure in text, key
    for stale in ("33 s", "about 5 min", "260 s", "3 s per time step"):
        assert stale not in text


def test_paper_help_shows_the_quick_cost():
    text = _help("paper", "--help")
    assert f"about {COSTS['paper_quick'].figure} on 2 cores" in text
    assert COSTS["paper_quick"].measured in text
    assert "half an hour" not in text


def test_study_list_shows_the_table_and_the_files_hold_no_cost():
    text = _help("study", "--list")
    for name in STUDY_COSTS:
        assert name in text
        assert " ".join(study_cost(name).split()) in text, name
        assert load_study(name)[0]["cost"] == study_cost(name)
        assert load_study(name, quick=True)[0]["cost"] == study_cost(name)
    assert "not measured yet" not in text and "28 s" not in text
    assert set(list_studies()) == set(STUDY_COSTS)  # every shipped study has its entry
    folder = ROOT / "src/vesicle/workflows/studies"
    for path in folder.glob("*.toml"):
        assert "cost" not in tomllib.loads(path.read_text())["study"], path.name


def test_a_study_file_of_ones_own_keeps_its_cost(tmp_path):
    """Only the shipped studies take their cost from the table; a study file's own stays."""
    source = (ROOT / "src/vesicle/workflows/studies/tt-shape-lambda.toml").read_text()
    path = tmp_path / "tt-shape-lambda.toml"
    path.write_text(source.replace("[study]\n", '[study]\ncost = "mine"\n', 1))
    assert load_study(path)[0]["cost"] == "mine"


def test_sweep_help_names_every_task():
    from vesicle.workflows.tasks import TASKS

    text = _help("sweep", "--help")
    for task in TASKS:
        assert task in text, task
