"""`vesicle validation`: the validation page's table from a full and a quick report's records.

The reports here are written by hand (item.json records with the fields the report writes), so
every expected number is one put in below: the test checks the matching by key, the
differences, that an estimate is never compared, the page's other text kept, and the stored
values beside a quick report's own."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from vesicle.cli import main
from vesicle.workflows import paper, validation


def _record(folder: Path, key: str, quick: bool, degree: int, grid: int, comparisons: list):
    (folder / key).mkdir(parents=True, exist_ok=True)
    (folder / key / "item.json").write_text(json.dumps({
        "status": "done", "seconds": 12.0, "quick": quick, "figures": [], "tables": [],
        "parameters": {"degree": degree, "grid": grid}, "comparisons": comparisons}))  # fmt: skip


@pytest.fixture
def reports(tmp_path):
    full, quick = tmp_path / "full", tmp_path / "quick"
    # Table 1: the N = 4 row in both, the N = 8 row in the full report only
    _record(full, "table1", False, 14, 32, [
        paper._compare("omega_R, N = 4", 3.226, 3.22943),
        paper._compare("omega_R, N = 8", 2.939, 2.93790)])  # fmt: skip
    _record(quick, "table1", True, 6, 16, [paper._compare("omega_R, N = 4", 3.226, 3.22936)])
    # a neutral curve: lambda_c located at N = 8; the change of type an estimate there
    _record(full, "fig7", False, 8, 32, [
        paper._compare("lambda_c (v = 0.95, chi = 1)", 8.46, 8.45263, located=True),
        paper._compare("change of type chi, v = 0.95", 0.3, 0.2593, located=False)])
    _record(quick, "fig7", True, 4, 12, [
        paper._compare("lambda_c (v = 0.95, chi = 1)", 8.46, 8.33, located=True)])
    # a check against our own reference, whose quantity names a computed value: matched by key
    _record(full, "fig12", False, 8, 24, [paper._check(
        "chi = 6: TR period at lam = 9.1 against ...", "2π/ω_R at our Hopf point", 2.5, 2.45,
        key="tr-period")])  # fmt: skip
    _record(quick, "fig12", True, 4, 12, [paper._check(
        "chi = 6: TR period at lam = 9 against ...", "2π/ω_R at our Hopf point", 2.54, 2.39,
        key="tr-period")])  # fmt: skip
    return full, quick


def test_rows_set_the_full_value_beside_the_quick_one(reports):
    full, quick = reports
    table = validation.rows(validation.collect(full), validation.collect(quick))
    by = {(r["item"], r["key"]): r for r in table}
    r = by["table1", "omega_R, N = 4"]
    assert (r["full"], r["quick"], r["reference_value"]) == (3.22943, 3.22936, 3.226)
    assert r["difference"] == pytest.approx(3.22943 - 3.226)
    assert r["relative"] == pytest.approx((3.22943 - 3.226) / 3.226)
    assert r["full_resolution"] == "N = 14, 32×64" and r["quick_resolution"] == "N = 6, 16×32"
    assert by["table1", "omega_R, N = 8"]["quick"] is None
    estimate = by["fig7", "change of type chi, v = 0.95"]
    assert estimate["full_located"] is False and not estimate["full_compared"]
    assert estimate["difference"] is None and estimate["relative"] is None
    assert validation._status(estimate) == "estimate, not compared"
    check = by["fig12", "tr-period"]
    assert (check["full"], check["quick"]) == (2.45, 2.39)
    assert check["reference"] == "2π/ω_R at our Hopf point"
    assert check["command"] == "vesicle paper --only fig12"
    assert [r["item"] for r in table] == ["table1", "table1", "fig7", "fig7", "fig12"]


def test_the_page_section_is_replaced_and_the_rest_kept(reports, tmp_path):
    full, quick = reports
    page, data, package = tmp_path / "v.md", tmp_path / "v", tmp_path / "pkg"
    page.write_text("# Validation\n\nWritten by hand.\n")
    r = CliRunner().invoke(main, ["validation", "--full", str(full), "--quick", str(quick),
                                  "--page", str(page), "--data", str(data),
                                  "--package", str(package)])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "5 comparisons (4 compared at the full resolution)" in r.output
    text = page.read_text()
    assert text.startswith("# Validation\n\nWritten by hand.\n")
    assert text.count(validation.BEGIN) == 1 and text.count(validation.END) == 1
    assert "| Table 1 | omega_R, N = 8 | paper (SPEC §14) | 2.939 | 2.9379 |" in text
    assert "estimate, not compared" in text
    again = CliRunner().invoke(main, ["validation", "--full", str(full), "--page", str(page),
                                      "--data", str(data)])  # fmt: skip
    assert again.exit_code == 0, again.output
    assert page.read_text().count(validation.BEGIN) == 1  # replaced, not appended again
    assert page.read_text().startswith("# Validation\n\nWritten by hand.\n")
    with open(data / "report.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(validation.COLUMNS) and len(rows) == 5
    stored = json.loads((package / validation.STORED).read_text())
    assert stored["fig7"]["values"]["lambda_c (v = 0.95, chi = 1)"]["ours"] == 8.45263
    assert "vesicle_version" in stored


def test_the_page_lists_every_finished_item_with_its_figures(reports, tmp_path):
    """One row per item of the full report, its figures linked from the page's folder (the
    full report's folder beside it, as docs/validation.md and docs/validation/full)."""
    full, _ = reports
    record = json.loads((full / "fig7" / "item.json").read_text())
    record["figures"] = ["fig7/phase_diagram.png"]  # as the report writes it: relative
    (full / "fig7" / "item.json").write_text(json.dumps(record))
    page = tmp_path / "v.md"
    r = CliRunner().invoke(main, ["validation", "--full", str(full), "--page", str(page),
                                  "--data", str(tmp_path / "v")])  # fmt: skip
    assert r.exit_code == 0, r.output
    text = page.read_text()
    assert text.index("### The full report's items") < text.index("### The report's comparisons")
    row = next(line for line in text.splitlines() if line.startswith("| Figures 7, 13 |"))
    assert "[phase_diagram.png](full/fig7/phase_diagram.png)" in row
    assert "| done | N = 8, 32×64 | 0.2 min |" in row and "| 1 of 2 |" in row
    assert "| Table 1 | most unstable mode" in text and "2 of 2" in text


def test_the_quick_page_shows_the_stored_full_values(reports, tmp_path, monkeypatch):
    full, quick = reports
    validation.write_validation(full, None, tmp_path / "v.md", tmp_path / "v", tmp_path / "pkg")
    stored = json.loads((tmp_path / "pkg" / validation.STORED).read_text())
    monkeypatch.setattr(validation, "stored_values", lambda: stored)
    html = paper.write_index(quick, paper.ITEMS, quick=True).read_text()
    assert "full report (stored)" in html
    assert "<td>8.45263</td>" in html  # beside the quick report's 8.33
    assert "Resolution: N = 4, 12×24." in html  # each item states its own resolution


def test_reports_of_the_wrong_kind_are_refused(reports, tmp_path):
    _, quick = reports
    r = CliRunner().invoke(main, ["validation", "--full", str(quick), "--page",
                                  str(tmp_path / "v.md"), "--data", str(tmp_path / "v")])
    assert r.exit_code != 0 and "is a quick report" in r.output
    r = CliRunner().invoke(main, ["validation", "--full", str(tmp_path)])
    assert r.exit_code != 0 and "holds no report items" in r.output
