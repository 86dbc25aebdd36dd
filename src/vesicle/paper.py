"""``vesicle paper``: the seed paper's tables and figures regenerated as a static report (issue 16).

Each item of :data:`ITEMS` is one of the paper's tables or figures: a function that computes it
into its own folder ``DIR/<item>/`` (through the sweep engine and the studies where it is a
parametric study, so it is resumable), and returns what the page shows: figures, data files
(CSV), parameters and resolution, and, where SPEC §14 states a value of the paper, that value
beside ours with the difference.  A finished item writes ``DIR/<item>/item.json``; a second
call only redraws the page from those (``--redo`` recomputes).  ``DIR/index.html`` is plain
static HTML: no server, no network, readable offline.

Items that need what the package cannot compute yet are listed on the page as missing, with the
reason; nothing is faked.
"""

from __future__ import annotations

import csv
import html
import json
import logging
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from . import __version__

__all__ = ["ITEMS", "Item", "build_report", "write_index"]

log = logging.getLogger(__name__)

#: SPEC §14, Table 1 of the paper: the most unstable mode (omega_R, omega_I) of the steady TT
#: state at v = 0.95, lam = 8, chi = 10 against the shape degree N (32 x 64 grid).
TABLE1_PAPER = {2: (4.989, 7.336e-2), 4: (3.226, -5.602e-2), 6: (2.967, -7.542e-2),
                8: (2.939, -8.064e-2), 10: (2.937, -8.254e-2), 12: (2.937, -8.295e-2),
                14: (2.937, -8.310e-2)}  # fmt: skip


@dataclass(frozen=True)
class Item:
    """One table or figure of the paper."""

    key: str  # folder name and --only key: "table1", "fig5", ...
    title: str  # as the paper numbers it: "Table 1", "Figure 5"
    what: str  # one line: what it shows
    compute: Callable[[Path, bool, dict], dict] | None  # (folder, quick, options) -> content
    missing: str = ""  # why it cannot be computed yet (compute is None)


# --------------------------------------------------------------------- the items
def _table1(folder: Path, quick: bool, options: dict) -> dict:
    """The most unstable mode against N at v = 0.95, lam = 8, chi = 10 (and v = 0.90,
    lam = 6.5, chi = 10), one steady state + stability per N, each cached in its own JSON."""
    from .branch import reach
    from .parameters import Discretisation, Physics
    from .stability import stability

    grid = options.get("grid", 16 if quick else 32)
    degrees = options.get("degrees", [2, 4, 6] if quick else [2, 4, 6, 8, 10, 12, 14])
    cases = [(0.95, 8.0, 10.0), (0.90, 6.5, 10.0)]
    rows, comparisons = [], []
    for v, lam, chi in cases:
        for n in degrees:
            cache = folder / f"v{v:g}_N{n}.json"
            if cache.exists():
                row = json.loads(cache.read_text())
            else:
                t0 = time.perf_counter()
                r = reach(Physics(v=v, lam=lam, chi=chi), Discretisation(grid, n))
                w_r, w_i = stability(r).most_unstable
                row = {"v": v, "lam": lam, "chi": chi, "N": n, "grid": grid, "omega_R": w_r,
                       "omega_I": w_i, "psi": r.psi, "D": r.D,
                       "seconds": time.perf_counter() - t0}  # fmt: skip
                cache.write_text(json.dumps(row))
            rows.append(row)
            if v == 0.95 and n in TABLE1_PAPER and grid == 32:
                p_r, p_i = TABLE1_PAPER[n]
                comparisons += [
                    {"quantity": f"omega_R, N = {n}", "paper": p_r, "ours": row["omega_R"]},
                    {"quantity": f"omega_I, N = {n}", "paper": p_i, "ours": row["omega_I"]},
                ]
    table = _write_csv(folder / "table1.csv", rows)
    note = ""
    if grid != 32:
        note = f"the paper's values are at 32x64; this grid is {grid}x{2 * grid}: not compared"
    return {"tables": [table], "figures": [], "comparisons": comparisons, "note": note,
            "parameters": {"cases": cases, "degrees": degrees, "grid": grid}}  # fmt: skip


def _study_item(*names: str, regimes_on: str | None = None) -> Callable[[Path, bool, dict], dict]:
    """An item drawn by the studies ``names`` (vesicle.study), run into the item's folder.

    ``regimes_on``: another item with neutral curves (``fig7``); when it has run, the studies'
    time-dependent runs are drawn on its phase diagrams by the regime each run's analysis found
    (the TR and TU points of the paper's Figure 7), in ``folder/phase/``."""

    def compute(folder: Path, quick: bool, options: dict) -> dict:
        from .study import run_study

        out = {"figures": [], "tables": [], "comparisons": [], "parameters": {}}
        stores = []
        for name in names:
            r = run_study(name, folder, quick=quick, workers=options.get("workers"),
                          scheduler=options.get("scheduler"))  # fmt: skip
            stores.append(r["store"])
            out["figures"].append(r["figure"])
            out["tables"].append(r["table"])
            out["parameters"][name] = r["config"]
            if r["status"]["failed"]:
                failed = r["status"]["failed"]
                out.setdefault("failures", []).append(f"{name}: {failed} point(s) failed")
        if regimes_on is not None:
            out["figures"] += _regimes_on_curves(folder, regimes_on, stores)
        return out

    return compute


def _curves(path: Path, degrees: set[int] | None = None) -> list[dict]:
    """The neutral curves with points in the sweep store at ``path`` (of ``degrees`` only, if
    given)."""
    from .sweep import SweepStore

    return [r["result"] for r in SweepStore.read(path).records.values()
            if r.get("result") and r["result"].get("points")
            and (degrees is None or r["result"]["degree"] in degrees)]  # fmt: skip


def _regimes_on_curves(folder: Path, item: str, stores: list[str]) -> list[str]:
    """The runs of the sweep ``stores`` on the phase diagrams of ``item``'s neutral curves at
    the runs' degree (none when that item has not run)."""
    from .phase_plots import plot_neutral, runs_from_store
    from .sweep import SweepStore

    other = folder.parent / item / "neutral.h5"
    runs = [r for path in stores for r in runs_from_store(path)]
    degrees = {tomllib.loads(SweepStore.read(path).config_text or "")
               .get("discretisation", {}).get("degree", 8) for path in stores}  # fmt: skip
    if not other.exists() or not runs:
        return []
    curves = _curves(other, degrees)
    if not curves:
        return []
    return [str(p) for p in plot_neutral(curves, folder / "phase", runs=runs)]


def _fig_spectrum(folder: Path, quick: bool, options: dict) -> dict:
    """The steady state of Table 1's case, its E_l spectra and most unstable modes."""
    from .branch import reach
    from .parameters import Discretisation, Physics
    from .stability import stability
    from .steady_io import read_steady, write_steady
    from .steady_plots import plot_steady

    grid, degree = (16, 4) if quick else (32, 8)
    path = folder / "tt.h5"
    if not path.exists():
        r = reach(Physics(v=0.95, lam=8.0, chi=10.0), Discretisation(grid, degree))
        write_steady(path, r, stability(r))
    figures = [str(p) for p in plot_steady(read_steady(path), folder)]
    return {"figures": figures, "tables": [str(path)], "comparisons": [],
            "parameters": {"v": 0.95, "lam": 8.0, "chi": 10.0, "degree": degree,
                           "grid": grid}}  # fmt: skip


def _neutral_item(
    vs_: list[float],
    key: str,
    orientation: str = "flow",
    quick_chi: str = "[0.2, 0.5, 1.0, 3.0, 10.0]",
    quick_vs: list[float] | None = None,
    beside: str | None = None,
) -> Callable[[Path, bool, dict], dict]:
    """Neutral curves at the reduced volumes ``vs_`` (a neutral sweep: the curves side by side on
    the workers), drawn as the chi-lambda and S-Lambda diagrams.  ``orientation``: the TT
    branch traced; ``beside``: another item whose store's curves are drawn too (the in-plane
    curves beside the vorticity-aligned ones), when that item has run."""

    def compute(folder: Path, quick: bool, options: dict) -> dict:
        from .phase_plots import plot_neutral
        from .sweep import SweepStore, read_sweep_config, run_sweep

        chi = quick_chi if quick else '"0.1:10"\npoints = 13'
        volumes = list(quick_vs or vs_) if quick else list(vs_)
        grid, degree = (16, 4) if quick else (32, 8)
        config = folder / f"{key}.toml"
        config.write_text(f'[sweep]\ntask = "neutral"\nout = "{key}.h5"\n[grid]\n'
                          f"v = {volumes}\n[task]\nchi = {chi}\n"
                          f'orientation = "{orientation}"\n[discretisation]\n'
                          f"degree = {degree}\ngrid = {grid}\n")  # fmt: skip
        store = run_sweep(read_sweep_config(config), workers=options.get("workers"),
                          scheduler=options.get("scheduler"))  # fmt: skip
        curves = _curves(store.path)
        drawn = list(curves)
        other = folder.parent / beside / "neutral.h5" if beside else None
        if other is not None and other.exists():
            drawn += _curves(other, {degree})
        figures = [str(p) for p in plot_neutral(drawn, folder)]
        rows = [{"v": c["v"], "degree": c["degree"], "grid": c["grid"], **p}
                for c in curves for p in c["points"]]  # fmt: skip
        comparisons = []
        for c in curves:  # SPEC §14: the type change near chi = 0.25 at v = 0.95
            t = c.get("type_change")
            if t and c["v"] == 0.95 and orientation == "flow":
                comparisons.append({"quantity": "type change chi (v = 0.95)", "paper": 0.25,
                                    "ours": t["chi"]})  # fmt: skip
            if c["v"] == 0.95 and orientation == "flow":
                one = [p for p in c["points"] if abs(p["chi"] - 1.0) < 1e-9]
                if one and degree == 8:
                    comparisons.append({"quantity": "lambda_c (v = 0.95, chi = 1)",
                                        "paper": 8.46, "ours": one[0]["lambda_c"]})  # fmt: skip
        failures = [f"v = {r['physics']['v']}: {r.get('error')}"
                    for r in SweepStore.read(store.path).records.values()
                    if r["status"] != "done"]  # fmt: skip
        return {"figures": figures, "tables": [_write_csv(folder / f"{key}.csv", rows)],
                "comparisons": comparisons, "failures": failures,
                "parameters": {"v": volumes, "degree": degree, "grid": grid,
                               "orientation": orientation}}  # fmt: skip

    return compute


def _fig8(folder: Path, quick: bool, options: dict) -> dict:
    """The leading eigenvalues along the chi = 0.2 branch as lam approaches the fold."""
    from .branch import branch
    from .branch_plots import fold_approach, plot_branch
    from .parameters import Discretisation, Physics

    grid, degree = (16, 4) if quick else (32, 8)
    path = folder / "branch.json"
    if path.exists():
        data = json.loads(path.read_text())
    else:
        values = [6.0, 6.5, 7.0, 7.2, 7.3, 7.35, 7.4, 7.42, 7.44, 7.46, 7.47, 7.48, 7.5, 7.6]
        b = branch(Physics(v=0.95, chi=0.2), Discretisation(grid, degree), "lam", values)
        data = {**b.to_dict(all_points=True), "physics": {"v": 0.95, "chi": 0.2}}
        path.write_text(json.dumps(data))
    figures = [str(p) for p in plot_branch(data, folder)]
    fit = fold_approach(data)
    comparisons = []
    if fit is not None:
        comparisons.append({"quantity": "exponent of omega_I -> 0 at the fold", "paper": 0.5,
                            "ours": fit["exponent"]})  # fmt: skip
    return {"figures": figures, "tables": [str(path)], "comparisons": comparisons,
            "parameters": {"v": 0.95, "chi": 0.2, "degree": degree, "grid": grid},
            "fit": fit}  # fmt: skip


def _fig9(folder: Path, quick: bool, options: dict) -> dict:
    """Table 1's steady state perturbed and time-stepped: psi(t) and the fit of its damped
    oscillation against the most unstable eigenvalue of the stability analysis (SPEC §14)."""
    from .analysis import fit_damped_oscillation
    from .branch import reach
    from .dynamics import RunParameters
    from .io import read_run
    from .parameters import Discretisation, Physics
    from .plots import _figure, _save
    from .simulation import simulate
    from .stability import stability

    grid, degree = (16, 4) if quick else (32, 8)
    physics, disc = Physics(v=0.95, lam=8.0, chi=10.0), Discretisation(grid, degree)
    cache, run_path = folder / "stability.json", folder / "run.h5"
    if cache.exists() and run_path.exists():
        w_r, w_i = json.loads(cache.read_text())["omega"]
    else:
        r = reach(physics, disc)
        w_r, w_i = stability(r).most_unstable
        params = RunParameters(physics, disc, t_end=12.0, save_every=0.05, dt_max=0.05,
                               integrator="ros34pw2", rtol=1e-4, save_fields=False,
                               checkpoint_every=1e9)  # fmt: skip
        simulate(params, start=r.shape.perturbed(0.01, seed=4, degree=degree), out=run_path)
        cache.write_text(json.dumps({"omega": [w_r, w_i]}))
    run = read_run(run_path)
    t, psi = run.series["t"], run.series["psi"]
    fit = fit_damped_oscillation(t, psi, t_min=1.0)
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(t, psi, lw=1.0, label="time stepping")
    window = t >= fit.t_min
    ax.plot(t[window], fit(t[window]), "--", lw=1.0,
            label=f"fit: omega = ({fit.omega_R:.4f}, {fit.omega_I:.4f})")  # fmt: skip
    ax.set_xlabel("t")
    ax.set_ylabel("psi")
    ax.set_title(f"v = 0.95, lam = 8, chi = 10, N = {degree}, {grid}x{2 * grid}: stability "
                 f"({w_r:.4f}, {w_i:.4f})", fontsize=9)  # fmt: skip
    ax.legend(fontsize=8)
    figure = str(_save(fig, folder / "relaxation.png", 120))
    rows = [{"source": "stability", "omega_R": w_r, "omega_I": w_i},
            {"source": "time stepping (fit)", "omega_R": fit.omega_R,
             "omega_I": fit.omega_I}]  # fmt: skip
    comparisons = [{"quantity": "omega_R: fit against stability", "paper": w_r,
                    "ours": fit.omega_R},
                   {"quantity": "omega_I: fit against stability", "paper": w_i,
                    "ours": fit.omega_I}]  # fmt: skip
    return {"figures": [figure], "tables": [_write_csv(folder / "fig9.csv", rows)],
            "comparisons": comparisons,
            "note": "both columns are ours: the 'paper' column holds the stability analysis, "
                    "which the paper's Fig. 9 shows the time stepping agrees with",
            "parameters": {"v": 0.95, "lam": 8.0, "chi": 10.0, "degree": degree, "grid": grid,
                           "perturbation": 0.01, "t_end": 12.0, "integrator": "ros34pw2",
                           "rtol": 1e-4}}  # fmt: skip


#: SPEC §13 and the paper's Fig. 23, 24: tilted starts at v = 0.95, chi = 4 as (lam, tilt in
#: degrees): lam = 11 at 0.2 pi ... 0.5 pi, lam = 10.5, 10 and 9 at 0.3 pi.
TILTED = [(11.0, 36.0), (11.0, 54.0), (11.0, 72.0), (11.0, 90.0), (10.5, 54.0), (10.0, 54.0),
          (9.0, 54.0)]  # fmt: skip
#: ``--quick``: two of them, to t = 30 (at N = 4 on 16x32 one run to t = 60 takes about 12 min).
TILTED_QUICK = [(11.0, 54.0), (9.0, 54.0)]


def _fig23(folder: Path, quick: bool, options: dict) -> dict:
    """Tilted starts (SPEC §13): each run to ``t_end`` (resumed from its file when cut short),
    the orbit of its long axis classified (:func:`vesicle.analysis.classify_orbit`) over the last
    half, its axes drawn on the unit sphere and seen along the vorticity axis."""
    from .analysis import summarize
    from .dynamics import RunParameters
    from .io import read_run
    from .plots import plot_out_of_plane
    from .simulation import simulate

    grid, degree = (16, 4) if quick else (32, 8)
    grid = int(options.get("grid", grid))
    t_end = float(options.get("t_end", 30.0 if quick else 60.0))
    cases = options.get("tilted", TILTED_QUICK if quick else TILTED)
    rows, figures = [], []
    for lam, tilt in cases:
        name = f"lam{lam:g}_tilt{tilt:g}_N{degree}_{grid}"  # a resolution never reuses another's
        path = folder / f"{name}.h5"
        params = RunParameters(v=0.95, lam=lam, chi=4.0, grid=grid, degree=degree, t_end=t_end,
                               save_every=0.05, dt_max=0.25, tilt=tilt, integrator="ros34pw2",
                               rtol=1e-3, save_fields=False)  # fmt: skip
        run = read_run(path) if path.exists() else None
        if run is not None and run.checkpoint is None:  # written before its first checkpoint
            run = None
        if run is None or float(run.checkpoint["t"]) < t_end - 1e-9:  # new, cut short or
            run = simulate(params, out=path, resume=run)  # asked to go further: resume
        s = summarize(run)
        orbit = s.get("orbit") or {}
        rows.append({"lam": lam, "tilt_deg": tilt, "tilt_over_pi": tilt / 180.0,
                     "regime": s["regime"], "orbit": orbit.get("class"),
                     "orbit_period": orbit.get("period"), "psi_period": s["period"],
                     "detail": orbit.get("detail", s["regime_detail"]),
                     "t_end": s["t_final"], "solves": s["solves"]})  # fmt: skip
        figures += [str(p) for p in plot_out_of_plane(run, folder, prefix=f"{name}_", dpi=100)]
    return {"figures": figures, "tables": [_write_csv(folder / "fig23.csv", rows)],
            "comparisons": [], "rows": rows,
            "note": "orbit classes over the last half of each run: in-plane (then the psi regime "
                    "decides TR or TU), vorticity-TT, precession about y, figure-8 about x",
            "parameters": {"v": 0.95, "chi": 4.0, "degree": degree, "grid": grid,
                           "t_end": t_end, "integrator": "ros34pw2", "rtol": 1e-3,
                           "cases": [list(c) for c in cases]}}  # fmt: skip


ITEMS: list[Item] = [
    Item("table1", "Table 1", "most unstable mode against the shape degree N", _table1),
    Item(
        "fig2",
        "Figures 2, 3, 10",
        "steady TT state, E_l spectra, most unstable modes",
        _fig_spectrum,
    ),
    Item(
        "fig4",
        "Figure 4",
        "TT inclination and deformation against chi",
        _study_item("tt-shape-chi"),
    ),
    Item(
        "fig5",
        "Figure 5",
        "TT inclination against lambda, Misbah's (3.6)",
        _study_item("tt-shape-lambda"),
    ),
    Item(
        "fig6", "Figure 6", "TT inclination against the excess area", _study_item("tt-excess-area")
    ),
    Item(
        "fig7",
        "Figures 7, 13",
        "neutral curves and the S-Lambda plane",
        # quick: the paper's Figure 7 volumes, their Hopf part only (measured at N = 4 on 16x32
        # with the fold part, chi = 0.2 ... 10 and the type change located: 23 min for v = 0.95,
        # 31 min for 0.90, and v = 0.85 unresolved at that degree; from chi = 0.5: 5.4 and about
        # 18 min, chi = 0.5 being a fold at v = 0.90; the fold itself is fig8's)
        _neutral_item([0.98, 0.95, 0.90, 0.85], "neutral", quick_chi="[1.0, 3.0, 10.0]",
                      quick_vs=[0.95, 0.90]),
    ),
    Item("fig8", "Figure 8", "omega along the chi = 0.2 branch towards the fold", _fig8),
    Item("fig9", "Figure 9", "relaxation of psi from a perturbed start against the stability",
         _fig9),
    Item("fig11", "Figures 11, 15", "psi(t), D-psi orbits and S_xz(t) in TR and TU",
         _study_item("orbits", "stress-time")),
    Item("fig12", "Figure 12", "periods of TR and TU against lambda (and the runs' regimes "
         "on Figure 7's neutral curves)",
         _study_item("periods-high-shear", "periods-low-shear", regimes_on="fig7")),
    Item("fig14", "Figure 14", "S_xz, N1, N2 against lambda", _study_item("stress-lambda")),
    Item("fig16", "Figure 16", "S_xz against chi", _study_item("stress-chi")),
    Item(
        "fig17",
        "Figures 17, 20",
        "stress decomposition and the equivalent ellipsoid",
        _study_item("stress-split"),
    ),
    Item(
        "fig18",
        "Figures 18, 19, 21",
        "the equivalent ellipsoid's stress maps",
        _study_item("tt-shape-lambda", "ellipsoid-maps"),
    ),
    Item(
        "fig22",
        "Figure 22",
        "neutral curves of the vorticity-aligned branch (dashed) beside the in-plane ones",
        _neutral_item([0.95, 0.90], "neutral", orientation="vorticity",
                      quick_chi="[2.0, 4.0, 8.0]", quick_vs=[0.95], beside="fig7"),
    ),
    Item("fig23", "Figures 23, 24", "tilted starts: orbits of the principal axes", _fig23),
]


# ------------------------------------------------------------------------ driver
def _write_csv(path: Path, rows: list[dict]) -> str:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    return str(path)


def build_report(
    outdir: str | Path,
    quick: bool = False,
    only: list[str] | None = None,
    options: dict | None = None,
    items: list[Item] | None = None,
    redo: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Compute every item (or those of ``only``) into ``outdir`` and write ``index.html``.

    A failing item is recorded on the page with its error; the others go on.  Returns the
    page's path.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    items = items if items is not None else ITEMS
    if only:
        unknown = sorted(set(only) - {i.key for i in items})
        if unknown:
            raise ValueError(f"unknown item(s) {', '.join(unknown)}; the items are "
                             f"{', '.join(i.key for i in items)}")  # fmt: skip
    options = options or {}
    for item in items:
        if (only and item.key not in only) or item.compute is None:
            continue
        folder = outdir / item.key
        folder.mkdir(exist_ok=True)
        record = folder / "item.json"
        if record.exists() and not redo:
            continue
        if progress is not None:
            progress(f"{item.title}: computing ({item.what})")
        t0 = time.perf_counter()
        try:
            content = item.compute(folder, quick, options)
            content["status"] = "failed" if content.get("failures") else "done"
        except Exception as err:  # recorded on the page; the other items go on
            log.exception("%s failed", item.title)
            content = {"status": "error", "error": f"{type(err).__name__}: {err}"}
        content.update(seconds=time.perf_counter() - t0, quick=quick, vesicle_version=__version__)
        record.write_text(json.dumps(content, indent=1, default=str))
        if progress is not None:
            progress(f"{item.title}: {content['status']} in {content['seconds']:.0f} s")
    return write_index(outdir, items, quick)


def _rel(path: str, outdir: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(outdir.resolve()))
    except ValueError:
        return str(path)


def write_index(outdir: Path, items: list[Item], quick: bool) -> Path:
    """The static page of the items computed so far in ``outdir``."""
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             f"<title>vesicle: the paper's tables and figures{' (quick)' if quick else ''}</title>",
             "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
             "img{max-width:100%;border:1px solid #ccc;margin:0.3em 0}"
             "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:0.2em 0.6em}"
             ".quick{background:#fff3cd;padding:0.6em;border:1px solid #e0c36c}"
             ".missing{color:#777}.error{color:#a00}</style></head><body>",
             "<h1>The seed paper's tables and figures, regenerated by vesicle "
             f"{e(__version__)}</h1>"]  # fmt: skip
    if quick:
        parts.append('<p class="quick"><b>QUICK REPORT</b>: reduced resolution (N = 4 on 16×32, '
                     "fewer points); its numbers are not the paper's resolution and are not "
                     "compared with the paper's where the resolution differs.</p>")  # fmt: skip
    summary = []
    for item in items:
        record = outdir / item.key / "item.json"
        content = json.loads(record.read_text()) if record.exists() else None
        parts.append(f'<h2 id="{e(item.key)}">{e(item.title)}: {e(item.what)}</h2>')
        if item.compute is None:
            parts.append(f'<p class="missing">Not computed: {e(item.missing)}</p>')
            summary.append((item, "missing"))
            continue
        if content is None:
            parts.append('<p class="missing">Not computed in this folder yet.</p>')
            summary.append((item, "pending"))
            continue
        summary.append((item, content["status"]))
        if content["status"] == "error":
            parts.append(f'<p class="error">Failed: {e(content["error"])}</p>')
        parts.append(f"<p>Wall time {content['seconds']:.0f} s"
                     f"{' (quick)' if content.get('quick') else ''}.</p>")  # fmt: skip
        for fig in content.get("figures", []):
            rel = _rel(fig, outdir)
            parts.append(f'<p><img src="{e(rel)}" alt="{e(item.title)}: {e(Path(rel).name)}">'
                         "</p>")  # fmt: skip
        data = [_rel(t, outdir) for t in content.get("tables", [])]
        if data:
            parts.append("<p>Data: " + ", ".join(f'<a href="{e(d)}">{e(Path(d).name)}</a>'
                                                 for d in data) + "</p>")  # fmt: skip
        if content.get("note"):
            parts.append(f"<p><i>{e(content['note'])}</i></p>")
        for failure in content.get("failures", []):
            parts.append(f'<p class="error">{e(str(failure))}</p>')
        comps = content.get("comparisons", [])
        if comps:
            parts.append("<table><tr><th>quantity</th><th>paper</th><th>vesicle</th>"
                         "<th>difference</th></tr>")  # fmt: skip
            for c in comps:
                diff = c["ours"] - c["paper"]
                parts.append(f"<tr><td>{e(c['quantity'])}</td><td>{c['paper']:.6g}</td>"
                             f"<td>{c['ours']:.6g}</td><td>{diff:+.3g}</td></tr>")  # fmt: skip
            parts.append("</table>")
        params = content.get("parameters")
        if params:
            text = e(json.dumps(params, indent=1, default=str))
            parts.append(f"<details><summary>parameters</summary><pre>{text}</pre></details>")
    parts.append("<h2>Summary</h2><table><tr><th>item</th><th>status</th></tr>")
    parts += [f'<tr><td><a href="#{e(i.key)}">{e(i.title)}</a></td><td>{e(s)}</td></tr>'
              for i, s in summary]  # fmt: skip
    parts.append("</table></body></html>")
    page = outdir / "index.html"
    page.write_text("\n".join(parts))
    return page
