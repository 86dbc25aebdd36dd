"""The chi–lambda phase diagram of one or more neutral curves (``vesicle neutral --out``).

``phase_diagram.png``: lambda_c against chi (log scale) for each curve, its points marked by the
bifurcation type (filled: Hopf, the TR side above; open: saddle-node, the TU side above), the
located type change as a star, and the leading-order theory's critical viscosity ratio of each
v (:func:`vesicle.model.theory.misbah_critical_lambda`, independent of chi) as a dotted line.
Tank-treading is stable below each curve.  Time-dependent runs (a ``task = "run"`` sweep store,
``vesicle plot n.json --runs s.h5``) are overlaid by the regime their analysis found (TT, TR,
TU).

``phase_SLambda.png``: the same curves and runs in the plane of Lebedev et al. (2007),
``S = 7 pi/(3 sqrt 3) chi v/Delta`` against ``Lambda = 4/sqrt(30 pi) sqrt(Delta) (1 + 23 lam/32)``
(:func:`vesicle.model.theory.lebedev_parameters`), where the leading-order boundaries of every v
collapse; the leading-order TT–TU boundary of strong flow, ``Lambda = 1`` (Misbah's critical
viscosity ratio, the same for every v in this plane), is drawn dashed.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from vesicle.model.published import PAPER_LABEL, PAPER_LAMBDA_C_CHI1, PAPER_TYPE_CHANGE
from vesicle.model.theory import lebedev_parameters, misbah_critical_lambda
from vesicle.plots.runs import _figure, _json_file_with, _save

__all__ = ["REGIME_STYLE", "is_neutral_file", "plot_neutral"]

#: Marker and colour of each regime of a run.
REGIME_STYLE = {"TT": ("o", "tab:green"), "TR": ("^", "tab:orange"), "TU": ("s", "tab:red")}

logger = logging.getLogger(__name__)


def is_neutral_file(path: str | Path) -> bool:
    """Whether ``path`` is the JSON of a neutral curve."""
    return _json_file_with(path, {"points", "type_change", "v"})


def _scatter_runs(ax, runs: list[dict], xy) -> None:
    seen = set()
    for r in runs:
        marker, color = REGIME_STYLE.get(r["regime"], ("x", "0.4"))
        label = None if r["regime"] in seen else f"run: {r['regime']}"
        seen.add(r["regime"])
        x, y = xy(r)
        ax.scatter([x], [y], marker=marker, color=color, s=46, edgecolor="k", lw=0.5,
                   zorder=5, label=label)  # fmt: skip


def plot_neutral(
    curves: list[dict], outdir: str | Path, dpi: int = 120, runs: list[dict] | None = None
) -> list[Path]:
    """Draw the phase diagrams of the neutral-curve dictionaries ``curves`` (and the classified
    ``runs``, see :func:`vesicle.workflows.sweep.runs_from_store`) into ``outdir``."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    runs = runs or []
    paths = [_chi_lambda(curves, runs, outdir, dpi), _s_lambda(curves, runs, outdir, dpi)]
    for p in paths:
        logger.info("wrote %s", p)
    return paths


def _label(curve: dict) -> str:
    label = f"v = {curve['v']:g}, N = {curve['degree']} ({curve['grid']}×{2 * curve['grid']})"
    return label + (", vorticity-aligned" if curve.get("orientation") == "vorticity" else "")


def _colors(curves: list[dict]) -> dict[float, str]:
    """One colour per reduced volume (largest v first), so that a curve of the vorticity-aligned
    branch takes the colour of the in-plane curve of the same v."""
    volumes = sorted({c["v"] for c in curves}, reverse=True)
    return {v: f"C{k}" for k, v in enumerate(volumes)}


def _style(curve: dict) -> str:
    """Dashed: the vorticity-aligned branch (stable above its curve); solid: the in-plane one."""
    return "--" if curve.get("orientation") == "vorticity" else "-"


def _outside_legend(fig, ax) -> None:
    """The legend below the axes (it hid points inside them, and right of them its long
    entries squeezed the axes); the figure's constrained layout makes room."""
    from vesicle.plots.runs import legend_below

    legend_below(fig, *ax.get_legend_handles_labels(), width=70)


#: The leading-order lines' legend entry: what they are and why they lie far from the curves.
THEORY_NOTE = ("leading-order small-deformation theory{what}: valid as v → 1, far from the "
               "curves at v ≤ 0.95 (finite excess area)")  # fmt: skip


def _paper_marks(ax, curves: list[dict], colors: dict, xy) -> None:
    """What SPEC §14 states of the in-plane curves drawn (labelled "paper (SPEC §14)"):
    lambda_c = 8.46 at chi = 1, v = 0.95 (a black diamond), and the change of type near chi =
    0.25 at v = 0.95 and 0.6 at v = 0.90 (a dash-dot line in the curve's colour).  ``xy(v, chi,
    lam)``: the point in the plot's plane; the lines are vertical (S depends on chi, not lam)."""

    volumes = {c["v"] for c in curves if c.get("orientation", "flow") != "vorticity"}
    if 0.95 in volumes:
        x, y = xy(0.95, 1.0, PAPER_LAMBDA_C_CHI1)
        ax.scatter([x], [y], marker="D", s=40, facecolor="none", edgecolor="k", lw=1.2, zorder=6,
                   label=rf"{PAPER_LABEL}: $\lambda_c$ = {PAPER_LAMBDA_C_CHI1} at $\chi$ = 1, "
                         "v = 0.95")  # fmt: skip
    for v, chi in sorted(PAPER_TYPE_CHANGE.items(), reverse=True):
        if v in volumes:
            ax.axvline(xy(v, chi, 1.0)[0], color=colors[v], ls="-.", lw=1.0,
                       label=rf"{PAPER_LABEL}: type change near $\chi$ ≈ {chi:g} "
                             f"(v = {v:g})")  # fmt: skip


def _chi_lambda(curves, runs, outdir, dpi) -> Path:
    fig = _figure((9.0, 6.4))
    ax = fig.add_subplot()
    colors = _colors(curves)
    for curve in curves:
        color = colors[curve["v"]]
        pts = sorted(curve["points"], key=lambda p: p["chi"])
        chi = np.array([p["chi"] for p in pts])
        lam = np.array([p["lambda_c"] for p in pts])
        hopf = np.array([p["bifurcation"] == "hopf" for p in pts])
        ax.plot(chi, lam, color=color, lw=1.4, ls=_style(curve), label=_label(curve))
        ax.scatter(chi[hopf], lam[hopf], color=color, s=28, zorder=3)
        ax.scatter(chi[~hopf], lam[~hopf], facecolor="white", edgecolor=color, s=28, zorder=3)
        estimate = np.array([p.get("located") is False for p in pts])
        if estimate.any():  # not located to xtol: crossed out
            ax.scatter(chi[estimate], lam[estimate], marker="x", color="k", s=30, zorder=4)
        change = curve.get("type_change")
        if change:
            ax.scatter([change["chi"]], [change["lambda_c"]], marker="*", s=120, color=color,
                       edgecolor="k", zorder=4)  # fmt: skip
            if change.get("located") is False:  # bracketed, not to its tolerance
                ax.scatter([change["chi"]], [change["lambda_c"]], marker="x", color="k", s=30,
                           zorder=5)  # fmt: skip
        theory = misbah_critical_lambda(curve["v"])
        if np.isfinite(theory):
            ax.axhline(theory, color=color, ls=":", lw=1.0)
    _scatter_runs(ax, runs, lambda r: (r["chi"], r["lam"]))
    _paper_marks(ax, curves, colors, lambda v, chi, lam: (chi, lam))
    ax.set_xscale("log")
    ax.set_xlabel(r"$\chi$ (shear rate)")
    ax.set_ylabel(r"$\lambda_c$")
    ax.grid(alpha=0.3, which="both")
    ax.scatter([], [], color="0.3", s=28, label="Hopf: a complex pair crosses")
    ax.scatter([], [], facecolor="white", edgecolor="0.3", s=28,
               label="saddle-node: a real eigenvalue crosses")  # fmt: skip
    if any(c.get("type_change") for c in curves):
        ax.scatter([], [], marker="*", s=120, color="0.3", edgecolor="k", label="change of type")
    ax.plot([], [], color="0.3", ls=":", lw=1.0,
            label=THEORY_NOTE.format(what=r" (Misbah's $\lambda_c$, dotted)"))  # fmt: skip
    estimates = [p.get("located") is False for c in curves for p in c["points"]]
    estimates += [(c.get("type_change") or {}).get("located") is False for c in curves]
    if any(estimates):
        ax.scatter([], [], marker="x", color="k", s=30, label="estimate (not located)")
    _outside_legend(fig, ax)
    ax.set_title("neutral curves: TT stable below", fontsize="medium")
    return _save(fig, outdir / "phase_diagram.png", dpi)


def _s_lambda(curves, runs, outdir, dpi) -> Path:
    fig = _figure((9.0, 6.4))
    ax = fig.add_subplot()
    colors = _colors(curves)
    for curve in curves:
        color = colors[curve["v"]]
        pts = sorted(curve["points"], key=lambda p: p["chi"])
        sl = np.array([lebedev_parameters(curve["v"], p["chi"], p["lambda_c"]) for p in pts])
        hopf = np.array([p["bifurcation"] == "hopf" for p in pts])
        ax.plot(sl[:, 0], sl[:, 1], color=color, lw=1.4, ls=_style(curve), label=_label(curve))
        ax.scatter(sl[hopf, 0], sl[hopf, 1], color=color, s=28, zorder=3)
        ax.scatter(sl[~hopf, 0], sl[~hopf, 1], facecolor="white", edgecolor=color, s=28,
                   zorder=3)  # fmt: skip
    _scatter_runs(ax, runs, lambda r: lebedev_parameters(r["v"], r["chi"], r["lam"]))
    _paper_marks(ax, curves, colors, lebedev_parameters)
    ax.axhline(1.0, color="k", ls="--", lw=1.0,
               label=THEORY_NOTE.format(what=r", strong flow: $\Lambda = 1$ (TT–TU)"))  # fmt: skip
    ax.set_xscale("log")
    ax.set_xlabel(r"$S = 7\pi\chi v / (3\sqrt{3}\,\Delta)$")
    ax.set_ylabel(r"$\Lambda = 4\sqrt{\Delta/(30\pi)}\,(1 + 23\lambda/32)$")
    ax.grid(alpha=0.3, which="both")
    _outside_legend(fig, ax)
    ax.set_title("neutral curves in the S–Λ plane (Lebedev et al. 2007)", fontsize="medium")
    return _save(fig, outdir / "phase_SLambda.png", dpi)
