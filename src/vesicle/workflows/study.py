"""Parametric studies of the paper (issue 14): ready-made sweeps with their figures and tables.

A study is a TOML file (those shipped are in ``vesicle/studies/``; any path works too): a sweep
configuration as :func:`vesicle.workflows.sweep.read_sweep_config` reads it (without ``out``), a
``[study]`` table that says what it is and how to draw it, and an optional ``[quick]`` table
whose sub-tables (``[quick.discretisation]``, ``[quick.task]``, ``[quick.grid]``) replace those
keys for ``--quick`` (reduced resolution)::

    [study]
    title = "Figure 4: ..."
    figure = "branches"      # y along branches (task branch), or "runs": y of each run (task run:
                             #   "mean.S_xz", "period", "chiT" = chi * period), marked by regime,
                             #   or "maps": contours of the ellipsoid maps (task ellipsoid_map),
                             #   or "series": y(t) of each run's file and the D-psi orbit
    x = "chi"                # the branch parameter, or "Delta" (excess area) for v-branches
    xscale = "log"           # or "linear" (default)
    y = ["psi", "D"]         # point keys; "bending.S_xz" / "flow.S_xz" for the split
    curves = "lam"           # the grid key that names each curve
    theory = "misbah_psi"    # optional: a leading-order curve beside each (THEORIES)
    cost = "..."             # measured cost, shown by --list (a shipped study's comes from
                             #   vesicle.workflows.costs.STUDY_COSTS)
    overlay = "NAME"         # optional: a study of runs in the same folder drawn on this one
    fit = "period"           # optional (runs): T = c (lam - lam_c)^(-p) fitted per curve

:func:`run_study` writes the sweep config into the output folder (``DIR/NAME.toml``), runs it
on the sweep engine (resumable: a second call computes only what is missing) and draws
``DIR/NAME.png`` with the table ``DIR/NAME.csv`` (one row per branch point: the curve's
parameters, x, every y, stability).
"""

from __future__ import annotations

import csv
import json
import logging
import tempfile
import tomllib
from collections.abc import Callable
from importlib import resources
from pathlib import Path

import numpy as np

from vesicle.io.files import text_written_atomically, write_text_atomically
from vesicle.model.published import PAPER_LABEL, PAPER_LAMBDA_C_CHI1, PAPER_PERIOD_EXPONENT
from vesicle.model.theory import danker_misbah_tt_rheology, excess_area, misbah_tt_inclination
from vesicle.workflows.config import ConfigError, toml_text
from vesicle.workflows.costs import study_cost
from vesicle.workflows.sweep import (
    SweepConfig,
    SweepStore,
    read_sweep_config,
    reanalyse_runs,
    run_sweeps,
)

__all__ = [
    "THEORIES",
    "list_studies",
    "load_study",
    "period_fit",
    "plot_study",
    "run_studies",
    "run_study",
    "study_of_store",
    "study_rows",
]

log = logging.getLogger(__name__)

#: Leading-order theories drawn beside a study's curves: (v, lam, chi) -> {y key: value}.
THEORIES: dict[str, Callable[[float, float, float], dict]] = {
    "misbah_psi": lambda v, lam, chi: {"psi": misbah_tt_inclination(v, lam)},
    "danker_misbah_tt": lambda v, lam, chi: danker_misbah_tt_rheology(v, lam),
}

_STUDY_KEYS = {"title", "figure", "x", "xscale", "y", "curves", "theory", "cost", "notes",
               "overlay", "fit"}  # fmt: skip
_FIGURES = ("branches", "runs", "maps", "series", "neutral_bq")

#: Marker of each regime in the figures of runs.
_REGIME_MARKERS = {"TT": "o", "TR": "^", "TU": "s"}


def _shipped() -> dict[str, Path]:
    folder = resources.files("vesicle.workflows") / "studies"
    return {Path(str(p)).stem: Path(str(p)) for p in folder.iterdir() if str(p).endswith(".toml")}


def list_studies() -> dict[str, dict]:
    """The shipped studies: name -> their ``[study]`` table."""
    return {name: load_study(name)[0] for name in sorted(_shipped())}


def load_study(
    name_or_path: str | Path, quick: bool = False, resolution: dict | None = None
) -> tuple[dict, dict]:
    """``(study table, sweep tables)`` of a shipped study's name or a TOML path, with the
    ``[quick]`` replacements applied when ``quick`` and then ``resolution`` (keys of
    ``[discretisation]``, e.g. ``{"degree": 8, "grid": 24}``); errors name the file and the
    key."""
    shipped = _shipped()
    path = shipped.get(str(name_or_path), Path(name_or_path))
    if not path.is_file():
        raise ValueError(f"no study {name_or_path!r}: the shipped ones are "
                         f"{', '.join(sorted(shipped))} (or give a TOML path)")  # fmt: skip
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:  # a binary file: not a study
        raise ValueError(f"{path} is not valid TOML: {err}") from None
    study = data.pop("study", None)
    if not isinstance(study, dict):
        raise ValueError(f"{path}: a study needs a [study] table")
    unknown = sorted(set(study) - _STUDY_KEYS)
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)} in [study]; expected "
                         f"{', '.join(sorted(_STUDY_KEYS))}")  # fmt: skip
    if study.get("figure", "branches") not in _FIGURES:
        raise ValueError(f"{path}: [study] figure must be one of {_FIGURES}")
    if study.get("theory") is not None and study["theory"] not in THEORIES:
        raise ValueError(f"{path}: [study] theory must be one of {', '.join(THEORIES)}")
    if not isinstance(study.get("y"), list) or not study["y"]:
        raise ValueError(f"{path}: [study] y must be a list of point keys")
    replacements = data.pop("quick", {})
    if quick:
        for table, values in replacements.items():
            if not isinstance(values, dict):
                raise ValueError(f"{path}: [quick.{table}] must be a table")
            data.setdefault(table, {}).update(values)
    if resolution:
        data.setdefault("discretisation", {}).update(resolution)
    # a shipped study by its name, not by where this machine installed it (the config
    # travels with a report folder that is copied and committed)
    source = (f"the shipped study {path.stem}" if path == shipped.get(path.stem)
              else str(path))  # fmt: skip
    study = {"name": path.stem, "source": source, "quick": bool(quick), **study}
    if path == shipped.get(path.stem) and study_cost(path.stem) is not None:
        study["cost"] = study_cost(path.stem)  # the one table of measured costs
    return study, data


def _write_config(study: dict, tables: dict, folder: Path) -> Path:
    """The study as a sweep config in ``folder`` (its store beside it)."""
    tables = {**tables, "sweep": {**tables.get("sweep", {}), "out": f"{study['name']}.h5"}}
    meta = {k: v for k, v in study.items() if k not in ("source",)}
    header = (study.get("title", study["name"]),
              f"written by vesicle study from {study['source']}"
              + (" (--quick)" if study["quick"] else ""))  # fmt: skip
    path = folder / f"{study['name']}.toml"
    write_text_atomically(path, toml_text({"study": meta, **tables}, header))
    return path


def run_study(
    name_or_path: str | Path,
    outdir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[dict], None] | None = None,
    priority: int = 0,
    resolution: dict | None = None,
) -> dict:
    """Run a study into ``outdir`` (resumable) and draw it; returns ``{"config", "store",
    "figure", "table", "status"}``.  ``priority``: its points' Dask priority (higher first);
    ``resolution``: ``[discretisation]`` keys that replace the study's (after ``quick``)."""
    return run_studies([name_or_path], outdir, quick, workers, scheduler, progress,
                       priority, resolution=resolution)[0]  # fmt: skip


def _check_configs(loaded: list[tuple[dict, dict]], folder: Path) -> None:
    """Read every study's sweep config in a scratch folder, so that a bad resolution or point
    (``vesicle study NAME --degree 1``) is refused before anything is written into ``folder``;
    errors name the config as it will be written there."""
    with tempfile.TemporaryDirectory(prefix="vesicle-study-") as scratch:
        for study, tables in loaded:
            try:
                read_sweep_config(_write_config(study, tables, Path(scratch)))
            except ConfigError as err:
                raise ConfigError(str(err).replace(str(Path(scratch)), str(folder))) from None


def run_studies(
    names: list[str | Path],
    outdir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[dict], None] | None = None,
    priority: int = 0,
    compute: bool = True,
    extra: list[SweepConfig] | None = None,
    resolution: dict | None = None,
) -> list[dict]:
    """:func:`run_study` for several studies into one folder: their points side by side on one
    Dask client, then each drawn in turn (an ``overlay`` study listed first is drawn on the
    one that names it).  ``compute=False``: draw what the stores hold; ``extra``: other sweep
    configs computed alongside (not drawn; ``SweepStore.open`` reads their stores)."""
    folder = Path(outdir)
    loaded = [load_study(name, quick, resolution) for name in names]
    _check_configs(loaded, folder)
    folder.mkdir(parents=True, exist_ok=True)
    configs = [read_sweep_config(_write_config(study, tables, folder))
               for study, tables in loaded]  # fmt: skip
    extra = list(extra or [])
    if compute:
        stores = run_sweeps(configs + extra, workers=workers, scheduler=scheduler,
                            progress=progress, priority=priority)  # fmt: skip
    else:  # drawn again: the finished runs' results from this version's analysis of their
        # files, where the files are there (no stepping)
        stores = [SweepStore.open(config) for config in configs + extra]
        for config, store in zip(configs, stores, strict=False):
            reanalyse_runs(config, store)
    out = []
    for (study, _), config, store in zip(loaded, configs, stores, strict=False):
        figure, table = plot_study(store, study, folder)
        out.append({"config": str(config.path), "store": str(config.out), "figure": str(figure),
                    "table": str(table), "status": store.status(config)})  # fmt: skip
    return out


def _get(point: dict, key: str):
    value = point
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    return np.nan if value is None else float(value)


def _x(point: dict, study: dict) -> float:
    if study["x"] == "bq":  # results from before the membrane's viscosity have no bq: 0
        return float(point.get("bq", (point.get("physics") or {}).get("bq", 0.0)))
    return excess_area(point["v"]) if study["x"] == "Delta" else float(point[study["x"]])


def _run_value(result: dict, key: str) -> float:
    if key == "chiT":
        period = result.get("period")
        return np.nan if period is None else float(result["chi"]) * float(period)
    return _get(result, key)


def study_rows(store: SweepStore, study: dict) -> list[dict]:
    """One row per branch point of every finished curve (figure "branches": the curve's key,
    its fixed parameters, x, every y and whether the point is stable), or per finished run
    (figure "runs": the same with the regime instead of the stability)."""
    rows = []
    if study.get("figure") == "runs":
        for record in store.records.values():
            r = record.get("result") or {}
            if record.get("status") != "done" or not r:
                continue
            rows.append({"curve": f"{study['curves']} = {r[study['curves']]:g}",
                         **{k: r[k] for k in ("v", "lam", "chi")}, study["x"]: _x(r, study),
                         **{y: _run_value(r, y) for y in study["y"]},
                         "regime": r.get("regime"), "periods_seen": r.get("regime_detail"),
                         "t_final": r.get("t_final")})  # fmt: skip
        return sorted(rows, key=lambda r: (r["curve"], r[study["x"]]))
    for record in store.records.values():
        result = record.get("result") or {}
        for p in result.get("points", []):
            row = {"curve": f"{study['curves']} = {p[study['curves']]:g}",
                   **{k: p[k] for k in ("v", "lam", "chi")}, study["x"]: _x(p, study),
                   **{y: _get(p, y) for y in study["y"]},
                   "stable": p["n_unstable"] == 0}  # fmt: skip
            rows.append(row)
    return sorted(rows, key=lambda r: (r["curve"], r[study["x"]]))


#: The units of the figures (SPEC §1, §11): time in ``mu_out a^3 / kappa``; the specific
#: stresses ``S = sigma^p / (c chi)`` (``c`` the volume fraction), that is the particle stress in
#: units of ``c mu_out gamma_dot``; ``chi T`` is a period in units of ``1 / gamma_dot``.
STRESS_UNIT = r"[$c\,\mu\dot\gamma$]"
TIME_UNIT = r"[$\mu a^3/\kappa$]"
_SYMBOLS = {"S_xz": "S_{xz}", "N1": "N_1", "N2": "N_2"}
_PARTS = {"bending": ("B", "bending part"), "flow": ("V", "flow-resistance part"),
          "ellipsoid": ("V", "equivalent ellipsoid")}  # fmt: skip
_LABELS = {"psi": r"inclination $\psi$ [rad]", "D": "deformation D",
           "period": rf"period $T$ {TIME_UNIT}",
           "chiT": r"$\chi T$ (period [$1/\dot\gamma$])", "t": rf"$t$ {TIME_UNIT}",
           "lam": r"$\lambda$", "chi": r"$\chi$", "Delta": r"excess area $\Delta$",
           "v": "v"}  # fmt: skip


def is_stress(key: str) -> bool:
    """Whether the point key ``key`` is a stress (``S_xz``, ``mean.N1``, ``flow.S_xz``, ...)."""
    return key.rsplit(".", 1)[-1] in _SYMBOLS


def axis_label(key: str, unit: bool = True) -> str:
    """A readable label of the point key ``key`` (with its unit when ``unit``): ``mean.S_xz``
    is the period average, ``bending.S_xz`` / ``flow.S_xz`` the parts of the split,
    ``ellipsoid.S_xz`` the equivalent ellipsoid's."""
    prefix, _, name = key.rpartition(".")
    if name not in _SYMBOLS:
        return _LABELS.get(key, key)
    symbol = _SYMBOLS[name]
    if prefix == "mean":
        text = rf"$\langle {symbol} \rangle$ (period average)"
    elif prefix in _PARTS:
        sup, what = _PARTS[prefix]
        base, _, sub = symbol.partition("_")
        text = rf"${base}^{{{sup}}}_{sub}$ ({what})"
    elif prefix:
        text = rf"${symbol}$ ({prefix})"
    else:
        text = rf"${symbol}$"
    return f"{text} {STRESS_UNIT}" if unit else text


#: The leading-order theories' legend entries: what they are and why they depart from the data
#: (docs/reference/rheology.md: psi and N1 approach them as v -> 1; S_xz - 5/2 and N2 do
#: not).
THEORY_LABELS = {
    "misbah_psi": "leading-order small-deformation theory, Misbah (3.6) (dotted): the limit "
                  "v → 1, departs at finite excess area",
    "danker_misbah_tt": "leading-order small-deformation rheology, Danker & Misbah (dotted): "
                        "valid as v → 1 (its N1; its S_xz − 5/2 and N2 need higher order)",
}  # fmt: skip


def _regime_handles(regimes) -> list:
    """Legend handles of the regimes present (grey: the colour is the curve's)."""
    from matplotlib.lines import Line2D

    return [Line2D([], [], ls="", marker=_REGIME_MARKERS[r], color="0.55", mec="k", mew=0.4,
                   ms=6, label=f"run in {r}")
            for r in _REGIME_MARKERS if r in regimes]  # fmt: skip


def _stability_handles() -> list:
    from matplotlib.lines import Line2D

    return [Line2D([], [], ls="", marker="o", color="0.3", ms=4, label="stable TT"),
            Line2D([], [], ls="", marker="o", mfc="white", mec="0.3", ms=4,
                   label="unstable TT")]  # fmt: skip


def _legend(fig, axes, extra: list | None = None) -> None:
    """One legend for the figure, below the axes (inside them it hid data): every labelled
    artist of ``axes`` once, then ``extra`` handles."""
    handles, labels = [], []
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels(), strict=True):
            if label not in labels:
                handles.append(h)
                labels.append(label)
    for h in extra or []:
        if h.get_label() not in labels:
            handles.append(h)
            labels.append(h.get_label())
    from vesicle.plots.runs import legend_below

    legend_below(fig, handles, labels)


def _note_handle(text: str):
    """A legend entry that is only text (a statement of the paper with no value to draw)."""
    from matplotlib.lines import Line2D

    return Line2D([], [], ls="", label=text)


def plot_study(store: SweepStore, study: dict, folder: str | Path) -> tuple[Path, Path]:
    """``NAME.png`` (a panel per y: each curve, stable points filled, unstable open, the
    theory dotted, what the paper states drawn where SPEC §14 states it; a figure of runs whose
    y are all stresses has one panel) and ``NAME.csv`` (:func:`study_rows`) of a study's
    store."""
    from vesicle.plots.runs import _figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if study.get("figure") == "maps":
        return _plot_maps(store, study, folder)
    if study.get("figure") == "series":
        return _plot_series(store, study, folder)
    if study.get("figure") == "neutral_bq":
        return _plot_neutral_bq(store, study, folder)
    rows = study_rows(store, study)
    table = folder / f"{study['name']}.csv"
    with text_written_atomically(table) as f:
        if rows:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    ys = study["y"]
    runs = study.get("figure") == "runs"
    one_panel = runs and len(ys) > 1 and all(is_stress(y) for y in ys)  # one unit: one panel
    panels = 1 if one_panel else len(ys)
    fig = _figure((7.6, 2.4 * panels + 2.2))
    axes = np.atleast_1d(fig.subplots(panels, 1, sharex=True))
    extra, regimes = [], set()
    if runs:
        if one_panel:
            fits = _draw_runs_one_panel(axes[0], ys, rows, study)
        else:
            fits = _draw_runs(axes, ys, rows, study)
        regimes = {r["regime"] for r in rows}
    else:
        fits = {}
        _draw_branches(axes, ys, rows, study)
        extra += _stability_handles()
        overlay = study.get("overlay")
        if overlay and (folder / f"{overlay}.h5").exists():  # runs beyond lambda_c
            other, _ = load_study(overlay, study.get("quick", False))
            overlaid = study_rows(SweepStore.read(folder / f"{overlay}.h5"), other)
            mapped = [{**r, **{y: r.get(f"mean.{y}", np.nan) for y in ys}} for r in overlaid]
            _draw_runs(axes, ys, mapped, {**other, "fit": None}, legend_curves=False)
            regimes = {r["regime"] for r in overlaid}
    extra += _regime_handles(regimes)
    for ax, y in zip(axes, ["stress"] if one_panel else ys, strict=True):
        ax.set_ylabel(f"stress {STRESS_UNIT}" if one_panel else axis_label(y))
        ax.grid(alpha=0.3, which="both")
        ax.set_xscale(study.get("xscale", "linear"))
    axes[-1].set_xlabel(_LABELS.get(study["x"], study["x"]))
    if study.get("theory"):
        extra.append(_theory_handle(study["theory"]))
    mark = PAPER_MARKS.get(study["name"])
    if mark is not None:
        extra += mark(axes, ys, rows, study, fits)
    _legend(fig, axes, extra)
    if fits:
        write_text_atomically(folder / f"{study['name']}_fit.json", json.dumps(fits, indent=1))
    return _finish(fig, store, study, folder, table)


def _finish(fig, store: SweepStore, study: dict, folder: Path, table: Path) -> tuple[Path, Path]:
    """The figure's title (with the store's resolution) and its file ``NAME.png``."""
    from vesicle.plots.runs import _save

    d = store_discretisation(store)
    label = (f"N = {d.get('degree')}, {d.get('grid')}×{2 * d.get('grid', 0)}"
             + (", quick" if study.get("quick") else ""))  # fmt: skip
    fig.suptitle(f"{study.get('title', study['name'])}\n({label})", fontsize="small")
    figure = _save(fig, folder / f"{study['name']}.png", 120)
    log.info("wrote %s and %s", figure, table)
    return figure, table


def _theory_handle(name: str):
    from matplotlib.lines import Line2D

    label = THEORY_LABELS.get(name, f"leading-order theory ({name}, dotted): valid as v → 1")
    return Line2D([], [], color="0.3", ls=":", lw=1.0, label=label)


def neutral_bq_rows(store: SweepStore) -> list[dict]:
    """One row per requested Bq of every finished (or stopped) ``neutral_bq`` curve and one
    per critical Bq: ``kind`` ("lambda_c" or "critical_bq"), v, chi, bq, lambda, the
    bifurcation, ``located`` (solved to tolerance; else an estimate) and ``other_unstable``."""
    rows = []
    for record in store.records.values():
        r = record.get("result") or {}
        if "plane" not in r:
            continue
        for p in r.get("points", []):
            rows.append({"kind": "lambda_c", "v": r["v"], "chi": r["chi"], "bq": p["bq"],
                         "lam": p["lambda_c"], "bifurcation": p["bifurcation"],
                         "omega_R": p.get("omega_R"), "located": p["located"],
                         "other_unstable": p.get("other_unstable"),
                         "note": p.get("note", p.get("estimate", ""))})  # fmt: skip
        for q in r.get("critical_bq", []):
            rows.append({"kind": "critical_bq", "v": r["v"], "chi": r["chi"], "bq": q["bq"],
                         "lam": q["lam"], "bifurcation": q["bifurcation"],
                         "omega_R": q.get("omega_R"), "located": q["located"],
                         "other_unstable": q.get("other_unstable"), "note": ""})  # fmt: skip
    return sorted(rows, key=lambda r: (r["v"], r["chi"], r["kind"], r["bq"]))


def _plot_neutral_bq(store: SweepStore, study: dict, folder: Path) -> tuple[Path, Path]:
    """``lambda_c(Bq)`` of each (v, chi) curve: the continued curve (line), the requested Bq
    (filled: located; open: an estimate), the critical Bq at each requested lambda (star),
    the leading-order shift ``lambda_c(0) - 16 Bq/23`` (dotted); with an ``overlay`` study of
    runs in the same folder, each run at its (Bq, lambda) marked by its regime."""
    from vesicle.plots.runs import _figure

    rows = neutral_bq_rows(store)
    table = folder / f"{study['name']}.csv"
    with text_written_atomically(table) as f:
        writer = csv.DictWriter(f, fieldnames=["kind", "v", "chi", "bq", "lam", "bifurcation",
                                               "omega_R", "located", "other_unstable", "note"])
        writer.writeheader()
        writer.writerows(rows)
    fig = _figure((7.6, 5.4))
    ax = fig.subplots(1, 1)
    results = sorted((rec["result"] for rec in store.records.values()
                      if "plane" in (rec.get("result") or {})),
                     key=lambda r: (-r["v"], r["chi"]))  # fmt: skip
    bq_max = max([p["bq"] for r in results for c in r.get("curves", []) for p in c["points"]]
                 + [1.0])  # fmt: skip
    for k, r in enumerate(results):
        color = f"C{k}"
        for c in r.get("curves", []):
            pts = c["points"]
            ax.plot([p["bq"] for p in pts], [p["lambda_c"] for p in pts], color=color, lw=1.2,
                    label=(rf"$v$ = {r['v']:g}, $\chi$ = {r['chi']:g}"
                           if c is r["curves"][0] else None))  # fmt: skip
        got = [p for p in r.get("points", []) if p.get("lambda_c") is not None]
        for located, face in ((True, color), (False, "white")):
            sel = [p for p in got if bool(p["located"]) is located]
            ax.scatter([p["bq"] for p in sel], [p["lambda_c"] for p in sel], s=22,
                       facecolor=face, edgecolor=color, zorder=3)  # fmt: skip
        for q in r.get("critical_bq", []):
            ax.scatter([q["bq"]], [q["lam"]], marker="*", s=110, color=color, edgecolor="k",
                       lw=0.5, zorder=5)  # fmt: skip
    for k, r in enumerate(results):  # the leading-order shift from the curve's own Bq = 0
        start = next((p for p in r.get("points", []) if p["bq"] == 0.0 and p["located"]), None)
        if start is None:
            continue
        b = np.linspace(0.0, bq_max, 50)
        line = start["lambda_c"] + r["leading_order"]["slope"] * b
        keep = line > 0
        ax.plot(b[keep], line[keep], color=f"C{k}", ls=":", lw=1.0)
    extra = [_note_handle("filled: located (augmented system converged); open: an estimate"),
             _note_handle("★ critical Bq at the requested λ (λ held, Bq solved for)"),
             _note_handle("dotted: λ_c(0) − 16 Bq/23, the leading-order shift (as v → 1)")]
    regimes = set()
    overlay = study.get("overlay")
    if overlay and (folder / f"{overlay}.h5").exists():  # runs either side of the curve
        other, _ = load_study(overlay, study.get("quick", False))
        runs = study_rows(SweepStore.read(folder / f"{overlay}.h5"), {**other, "x": "bq"})
        for regime, marker in _REGIME_MARKERS.items():
            sel = [r for r in runs if r["regime"] == regime]
            ax.scatter([r["bq"] for r in sel], [r["lam"] for r in sel], marker=marker, s=40,
                       color="0.85", edgecolor="k", lw=0.6, zorder=6)  # fmt: skip
        other_regimes = [r for r in runs if r["regime"] not in _REGIME_MARKERS]
        ax.scatter([r["bq"] for r in other_regimes], [r["lam"] for r in other_regimes],
                   marker="x", s=40, color="k", zorder=6)  # fmt: skip
        if other_regimes:
            extra.append(_note_handle("x: a run whose regime was not determined"))
        regimes = {r["regime"] for r in runs}
        extra.append(_note_handle("markers: time-dependent runs, by regime (same resolution)"))
    extra += _regime_handles(regimes)
    ax.set_xlabel(r"Boussinesq number Bq = $\eta_m/(\mu_{out} a)$")
    ax.set_ylabel(r"critical viscosity ratio $\lambda_c$")
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    _legend(fig, [ax], extra)
    return _finish(fig, store, study, folder, table)


def _runs_dir(store: SweepStore) -> Path:
    return store.path.parent / f"{store.path.stem}_runs"


def _plot_series(store: SweepStore, study: dict, folder: Path) -> tuple[Path, Path]:
    """Each run's series ``y`` against t (a row per run) and its D-psi orbit, from the run files
    beside the store; the table lists the runs with their regime and period."""
    from vesicle.io.files import read_run
    from vesicle.plots.runs import _figure, _save

    runs = []
    for key, record in sorted(store.records.items()):
        path = _runs_dir(store) / f"{key}.h5"
        if record.get("status") == "done" and path.exists():
            runs.append((record["result"], read_run(path)))
    runs.sort(key=lambda r: (r[0]["chi"], r[0]["lam"]))
    table = folder / f"{study['name']}.csv"
    with text_written_atomically(table) as f:
        writer = csv.writer(f)
        writer.writerow(["v", "lam", "chi", "regime", "period", "t_final", "stopped"])
        for r, _ in runs:
            writer.writerow([r["v"], r["lam"], r["chi"], r.get("regime"), r.get("period"),
                             r.get("t_final"), r.get("stopped")])  # fmt: skip
    ys = study["y"]
    fig = _figure((4.0 * (len(ys) + 1), 2.6 * max(len(runs), 1) + 0.6))
    axes = np.atleast_2d(fig.subplots(max(len(runs), 1), len(ys) + 1, squeeze=False))
    for row, (r, run) in zip(axes, runs, strict=False):
        t = run.series["t"]
        for ax, y in zip(row, ys, strict=False):
            ax.plot(t, run.series[y], lw=1.0)
            ax.set_xlabel(_LABELS["t"])
            ax.set_ylabel(axis_label(y))
            ax.grid(alpha=0.3)
        ax = row[-1]
        ax.plot(run.series["psi"], run.series["D"], lw=0.8)
        ax.set_xlabel(_LABELS["psi"])
        ax.set_ylabel(_LABELS["D"])
        ax.grid(alpha=0.3)
        row[0].set_title(rf"$\lambda$ = {r['lam']:g}, $\chi$ = {r['chi']:g}: {r.get('regime')}"
                         + (f", T = {r['period']:.3g}" if r.get("period") else ""),
                         fontsize="x-small")  # fmt: skip
    fig.suptitle(study.get("title", study["name"]), fontsize="small")
    figure = _save(fig, folder / f"{study['name']}.png", 120)
    return figure, table


def _curves(rows: list[dict]) -> list[str]:
    return sorted({r["curve"] for r in rows}, key=lambda c: float(c.split("=")[1]))


def curve_label(name: str) -> str:
    """``"lam = 1"`` as ``"λ = 1"`` (the curves' names in the tables stay as they are)."""
    key, _, value = name.partition(" = ")
    return f"{_LABELS.get(key, key)} = {value}"


def _draw_branches(axes, ys, rows, study) -> None:
    theory = THEORIES.get(study.get("theory") or "")
    for k, name in enumerate(_curves(rows)):
        pts = [r for r in rows if r["curve"] == name]
        x = np.array([r[study["x"]] for r in pts])
        stable = np.array([r["stable"] for r in pts])
        for ax, y in zip(axes, ys, strict=True):
            v = np.array([r[y] for r in pts])
            ax.plot(x, v, color=f"C{k}", lw=1.2,
                    label=f"TT branch, {curve_label(name)}" if y == ys[0] else None)  # fmt: skip
            ax.scatter(x[stable], v[stable], color=f"C{k}", s=14, zorder=3)
            ax.scatter(x[~stable], v[~stable], facecolor="white", edgecolor=f"C{k}", s=14,
                       zorder=3)  # fmt: skip
        if theory is not None and len(pts) > 1:
            _theory_curve(axes, ys, theory, pts, study, f"C{k}")


def _fit_range(lambda_c: float, x: list[float]) -> np.ndarray:
    """Where a fitted ``(lam - lam_c)^(-p)`` is drawn: from a quarter of the way between lam_c
    and the first run (not from lam_c, where it diverges and hides the runs) to the last."""
    lo, hi = min(x), max(x)
    return np.linspace(lambda_c + 0.25 * (lo - lambda_c), hi, 80)


def _draw_period_fit(axes, ys, pts, study, name: str, color: str) -> dict | None:
    """The fit ``T = c (lam - lam_c)^(-p)`` of one curve's periods, drawn dashed on its period
    and chi T panels."""
    fit = period_fit([r[study["x"]] for r in pts], [r.get("period") for r in pts])
    if fit is None:
        return None
    for ax, y in zip(axes, ys, strict=True):
        if y in ("period", "chiT"):
            scale = float(pts[0]["chi"]) if y == "chiT" else 1.0
            xs = _fit_range(fit["lambda_c"], [r[study["x"]] for r in pts])
            label = (rf"fit ({curve_label(name)}): $p$ = {fit['p']:.3f}, "
                     rf"$\lambda_c$ = {fit['lambda_c']:.4g}")  # fmt: skip
            ax.plot(xs, scale * fit["c"] * (xs - fit["lambda_c"]) ** -fit["p"], color=color,
                    ls="--", lw=0.9, label=label)  # fmt: skip
    return fit


def _draw_runs(axes, ys, rows, study, legend_curves: bool = True) -> dict:
    """Each run's y, marked by its regime (the legend's regime handles are the caller's:
    :func:`_regime_handles`), coloured by its curve; with ``fit = "period"`` the fit of each
    curve's periods ``T = c (lam - lam_c)^(-p)`` (returned by curve)."""
    fits = {}
    for k, name in enumerate(_curves(rows)):
        pts = [r for r in rows if r["curve"] == name]
        for ax, y in zip(axes, ys, strict=True):
            for regime, marker in _REGIME_MARKERS.items():
                sel = [r for r in pts if r["regime"] == regime]
                ax.scatter([r[study["x"]] for r in sel], [r[y] for r in sel], marker=marker,
                           color=f"C{k}", s=26, edgecolor="k", lw=0.4, zorder=4)  # fmt: skip
            if legend_curves and y == ys[0]:  # the colour only: the marker is the regime's
                ax.plot([], [], color=f"C{k}", lw=4, label=f"runs: {curve_label(name)}")
        if study.get("fit") == "period":
            fit = _draw_period_fit(axes, ys, pts, study, name, f"C{k}")
            if fit is not None:
                fits[name] = fit
    return fits


def _draw_runs_one_panel(ax, ys, rows, study) -> dict:
    """Runs whose y are all stresses in one panel: a colour per quantity, the marker of each
    run's regime, the runs of each curve joined (a line style per curve)."""
    styles = ["-", "--", ":", "-."]
    names = _curves(rows)
    for j, y in enumerate(ys):
        color = f"C{j}"
        for k, name in enumerate(names):
            pts = sorted((r for r in rows if r["curve"] == name), key=lambda r: r[study["x"]])
            if len(pts) > 1:
                ax.plot([r[study["x"]] for r in pts], [r[y] for r in pts], color=color,
                        ls=styles[k % len(styles)], lw=0.8)  # fmt: skip
            for regime, marker in _REGIME_MARKERS.items():
                sel = [r for r in pts if r["regime"] == regime]
                ax.scatter([r[study["x"]] for r in sel], [r[y] for r in sel], marker=marker,
                           color=color, s=30, edgecolor="k", lw=0.4, zorder=4)  # fmt: skip
        ax.plot([], [], color=color, lw=4, label=axis_label(y, unit=False))
    ax.axhline(0.0, color="0.6", lw=0.8, ls=":")
    if len(names) > 1:
        for k, name in enumerate(names):
            ax.plot([], [], color="0.3", ls=styles[k % len(styles)], lw=0.8,
                    label=f"runs: {curve_label(name)}")  # fmt: skip
    elif names:
        ax.plot([], [], ls="", label=f"runs: {curve_label(names[0])}")
    return {}


def period_fit(lam, periods, lambda_c: float | None = None) -> dict | None:
    """``T = c (lam - lam_c)^(-p)`` by least squares in ``log T``: near a saddle-node (SPEC §14)
    ``p = 1/2``.  With ``lambda_c`` free, three or more periods are needed; given (the fold
    located on the branch), two, and the fit is linear in ``log(lam - lambda_c)``.  ``None``
    when there are too few (or, with ``lambda_c`` given, a run at or below it)."""
    from scipy.optimize import least_squares

    pts = [(float(x), float(t)) for x, t in zip(lam, periods, strict=True)
           if t is not None and np.isfinite(t) and t > 0]  # fmt: skip
    if lambda_c is not None:
        if len(pts) < 2 or min(x for x, _ in pts) <= lambda_c:
            return None
        x, t = np.array(pts).T
        slope, intercept = np.polyfit(np.log(x - lambda_c), np.log(t), 1)
        residual = intercept + slope * np.log(x - lambda_c) - np.log(t)
        return {"c": float(np.exp(intercept)), "lambda_c": float(lambda_c), "p": float(-slope),
                "points": len(pts), "lambda_c_fixed": True,
                "rms_log_residual": float(np.sqrt(np.mean(residual**2)))}  # fmt: skip
    if len(pts) < 3:
        return None
    x, t = np.array(pts).T

    def residual(q):
        c, lc, p = q
        d = np.maximum(x - lc, 1e-12)
        return np.log(c) - p * np.log(d) - np.log(t)

    lo = x.min() - 1e-6
    q0 = [t.min() * (x.max() - x.min()) ** 0.5, x.min() - 0.5 * (x.max() - x.min()), 0.5]
    r = least_squares(residual, q0, bounds=([1e-12, -np.inf, 0.0], [np.inf, lo, 5.0]))
    c, lc, p = r.x
    return {"c": float(c), "lambda_c": float(lc), "p": float(p), "points": len(pts),
            "lambda_c_fixed": False,
            "rms_log_residual": float(np.sqrt(np.mean(r.fun**2)))}  # fmt: skip


def _plot_maps(store: SweepStore, study: dict, folder: Path) -> tuple[Path, Path]:
    """Contours of each ellipsoid map (a row per reference state, a column per y) in the
    lam-psi plane, with the TT branch of the ``overlay`` study (psi against lam) on top."""
    from vesicle.plots.runs import _figure, _save

    maps = sorted((r["result"] for r in store.records.values()
                   if r.get("status") == "done" and r.get("result")),
                  key=lambda m: (m["chi"], m["lam"]))  # fmt: skip
    table = folder / f"{study['name']}.csv"
    with text_written_atomically(table) as f:
        writer = csv.writer(f)
        writer.writerow(["state_lam", "state_chi", "state_psi", "psi", "lam", *study["y"]])
        for m in maps:
            for i, psi in enumerate(m["map_psi"]):
                for j, lam in enumerate(m["map_lam"]):
                    writer.writerow([m["lam"], m["chi"], m["state"]["psi"], psi, lam,
                                     *(m[y][i][j] for y in study["y"])])  # fmt: skip
    trajectory = None
    overlay = study.get("overlay")
    if overlay and (folder / f"{overlay}.h5").exists():
        other, _ = load_study(overlay, study.get("quick", False))
        trajectory = study_rows(SweepStore.read(folder / f"{overlay}.h5"), other)
    ys = study["y"]
    fig = _figure((3.4 * len(ys), 3.0 * max(len(maps), 1) + 0.6))
    axes = np.atleast_2d(fig.subplots(max(len(maps), 1), len(ys), squeeze=False))
    for row, m in zip(axes, maps, strict=False):
        lam, psi = np.meshgrid(m["map_lam"], m["map_psi"])
        lengths = ", ".join(f"{x:.3g}" for x in m["state"]["axes"])
        for ax, y in zip(row, ys, strict=True):
            c = ax.contourf(lam, psi, np.asarray(m[y]), levels=14, cmap="viridis")
            ax.contour(lam, psi, np.asarray(m[y]), levels=14, colors="k", linewidths=0.3)
            fig.colorbar(c, ax=ax, shrink=0.85).set_label(STRESS_UNIT if is_stress(y) else "",
                                                          fontsize="x-small")  # fmt: skip
            if trajectory:
                pts = [r for r in trajectory if abs(r["chi"] - m["chi"]) < 1e-12]
                ax.plot([r["lam"] for r in pts], [r["psi"] for r in pts], color="w", lw=1.4)
            ax.plot([m["lam"]], [m["state"]["psi"]], "r*", ms=9)
            ax.set_title(f"{axis_label(y, unit=False)}: axes {lengths}\n(state "
                         rf"$\lambda$ = {m['lam']:g}, $\chi$ = {m['chi']:g})",
                         fontsize="x-small")  # fmt: skip
            ax.set_xlabel(r"$\lambda$")
            ax.set_ylabel(_LABELS["psi"])
    if maps:
        from matplotlib.lines import Line2D

        handles = [Line2D([], [], ls="", marker="*", color="r", ms=9, label="the state mapped")]
        if trajectory:
            handles.insert(0, Line2D([], [], color="w", lw=1.4,
                                     label=r"TT branch $\psi(\lambda)$ at the state's "
                                           r"$\chi$"))  # fmt: skip
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles),
                   fontsize="x-small", facecolor="0.75")  # fmt: skip
    fig.suptitle(study.get("title", study["name"]), fontsize="small")
    figure = _save(fig, folder / f"{study['name']}.png", 120)
    return figure, table


def study_of_store(store: SweepStore) -> dict | None:
    """The ``[study]`` table of the config a store was made with (``None``: not a study)."""
    try:
        study = tomllib.loads(store.config_text).get("study")
    except tomllib.TOMLDecodeError:
        return None
    return study if isinstance(study, dict) and "name" in study else None


def store_discretisation(store: SweepStore) -> dict:
    for record in store.records.values():
        d = (record.get("result") or {}).get("discretisation")
        if d:
            return d
    return {}


def _theory_curve(axes, ys, theory, pts, study, color) -> None:
    p0 = pts[0]
    xs = np.array([r[study["x"]] for r in pts])
    grid = (np.geomspace(xs.min(), xs.max(), 60) if study.get("xscale") == "log"
            else np.linspace(xs.min(), xs.max(), 60))  # fmt: skip
    vals = []
    for x in grid:
        point = {"v": p0["v"], "lam": p0["lam"], "chi": p0["chi"]}
        if study["x"] == "Delta":  # invert Delta = 4 pi (v^(-2/3) - 1)
            point["v"] = (x / (4.0 * np.pi) + 1.0) ** -1.5
        else:
            point[study["x"]] = x
        vals.append(theory(point["v"], point["lam"], point["chi"]))
    for ax, y in zip(axes, ys, strict=True):
        if y in vals[0]:
            ax.plot(grid, [v[y] for v in vals], color=color, ls=":", lw=1.0)


# ------------------------------------------------------- what the paper states (SPEC §14)
PAPER_STYLE = {"color": "k", "ls": "-.", "lw": 1.0}


def _paper_label(text: str) -> str:

    return f"{PAPER_LABEL}: {text}"


def _marks_lambda_c(axes, ys, rows, study, fits) -> list:
    """Figure 5 (v = 0.95, chi = 1): lambda_c = 8.46, and psi negative before it."""

    if not any(r["v"] == 0.95 and r["chi"] == 1.0 for r in rows):
        return []
    for ax in axes:
        ax.axvline(PAPER_LAMBDA_C_CHI1, **PAPER_STYLE,
                   label=_paper_label(rf"$\lambda_c$ = {PAPER_LAMBDA_C_CHI1} (v = 0.95, "
                                      r"$\chi$ = 1)"))  # fmt: skip
    if "psi" in ys:
        axes[ys.index("psi")].axhline(0.0, color="k", ls=":", lw=0.8,
                                      label=_paper_label(r"$\psi$ < 0 before $\lambda_c$, TT "
                                                         "still stable"))  # fmt: skip
    return []


def _marks_period_exponent(axes, ys, rows, study, fits) -> list:
    """Figure 12 (chi = 0.2): T ~ (lam - lam_c)^(-1/2), drawn through our runs at our fitted
    lam_c (the paper gives the exponent, not the constant)."""
    p = PAPER_PERIOD_EXPONENT

    for name, fit in fits.items():
        pts = [(r[study["x"]], r["period"]) for r in rows if r["curve"] == name
               and r.get("period") is not None and np.isfinite(r["period"])]  # fmt: skip
        x, t = np.array(pts).T
        lc = fit["lambda_c"]
        c = float(np.exp(np.mean(np.log(t) + p * np.log(x - lc))))
        xs = _fit_range(lc, list(x))
        chi = float(next(r["chi"] for r in rows if r["curve"] == name))
        for ax, y in zip(axes, ys, strict=True):
            if y in ("period", "chiT"):
                scale = chi if y == "chiT" else 1.0
                label = _paper_label(r"$T \propto (\lambda-\lambda_c)^{-1/2}$ (drawn "
                                     r"through our runs at our fitted $\lambda_c$)")  # fmt: skip
                ax.plot(xs, scale * c * (xs - lc) ** -p, **PAPER_STYLE, label=label)
    return [_note_handle(_paper_label(r"$\chi T$ nearly independent of $\chi$"))]


def _marks_chi_t(axes, ys, rows, study, fits) -> list:
    return [_note_handle(_paper_label(r"$\chi T$ nearly independent of $\chi$ (compare the "
                                      r"$\chi$ = 0.2 figure)"))]  # fmt: skip


def _marks_stress_lambda(axes, ys, rows, study, fits) -> list:
    """Figure 14 (TT): S_xz has a minimum in lam; N1 > 0, N2 < 0, shrinking towards the
    transition; both about 0 averaged over TR and TU periods."""
    for ax, y in zip(axes, ys, strict=True):
        if y in ("N1", "N2"):
            ax.axhline(0.0, color="k", ls=":", lw=0.8)
    return [_note_handle(_paper_label(r"$S_{xz}(\lambda)$ has a minimum (a cusp at the TT–TU "
                                      "transition at low shear, smooth inside TT at high "
                                      "shear)")),
            _note_handle(_paper_label(r"$N_1 > 0$, $N_2 < 0$ in TT, shrinking towards the "
                                      r"transition; $\approx 0$ averaged over TR and TU "
                                      "(dotted: 0)"))]  # fmt: skip


def _marks_stress_runs(axes, ys, rows, study, fits) -> list:
    return [_note_handle(_paper_label(r"$\langle N_1\rangle$, $\langle N_2\rangle \approx 0$ "
                                      "in TR and TU (dotted: 0)"))]  # fmt: skip


def _marks_shear_thinning(axes, ys, rows, study, fits) -> list:
    return [_note_handle(_paper_label(r"weakly shear-thinning: $S_{xz}$ decreases with "
                                      r"$\chi$"))]  # fmt: skip


def _marks_experiments(axes, ys, rows, study, fits) -> list:
    return [_note_handle(_paper_label("its angles agree with Kantsler & Steinberg (2005) "
                                      "(no values given)"))]  # fmt: skip


#: What SPEC §14 states for a study's figure, drawn on it (a line labelled "paper (SPEC
#: §14)") or, where it states a trend with no value, named in its legend: study name ->
#: ``(axes, ys, rows, study, fits) -> extra legend handles``.
PAPER_MARKS: dict[str, Callable] = {
    "tt-shape-lambda": _marks_lambda_c,
    "periods-low-shear": _marks_period_exponent,
    "periods-high-shear": _marks_chi_t,
    "stress-lambda": _marks_stress_lambda,
    "stress-lambda-runs": _marks_stress_runs,
    "stress-chi": _marks_shear_thinning,
    "tt-excess-area": _marks_experiments,
}
