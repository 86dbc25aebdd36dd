"""The chi–lambda phase diagram of one or more neutral curves (``vesicle neutral --out``).

``phase_diagram.png``: lambda_c against chi (log scale) for each curve, its points marked by the
bifurcation type (filled: Hopf, the TR side above; open: saddle-node, the TU side above), the
located type change as a star, and the leading-order theory's critical viscosity ratio of each
v (:func:`vesicle.theory.misbah_critical_lambda`, independent of chi) as a dotted line.
Tank-treading is stable below each curve.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from .plots import _figure, _save
from .theory import misbah_critical_lambda

__all__ = ["is_neutral_file", "plot_neutral"]

logger = logging.getLogger(__name__)


def is_neutral_file(path: str | Path) -> bool:
    """Whether ``path`` is the JSON of a neutral curve."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and {"points", "type_change", "v"} <= set(data)


def plot_neutral(curves: list[dict], outdir: str | Path, dpi: int = 120) -> list[Path]:
    """Draw the phase diagram of the neutral-curve dictionaries ``curves`` into ``outdir``."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    fig = _figure((6.4, 4.6))
    ax = fig.add_subplot()
    for k, curve in enumerate(curves):
        color = f"C{k}"
        pts = sorted(curve["points"], key=lambda p: p["chi"])
        chi = np.array([p["chi"] for p in pts])
        lam = np.array([p["lambda_c"] for p in pts])
        hopf = np.array([p["bifurcation"] == "hopf" for p in pts])
        label = f"v = {curve['v']:g}, N = {curve['degree']} ({curve['grid']}×{2 * curve['grid']})"
        ax.plot(chi, lam, color=color, lw=1.4, label=label)
        ax.scatter(chi[hopf], lam[hopf], color=color, s=28, zorder=3)
        ax.scatter(chi[~hopf], lam[~hopf], facecolor="white", edgecolor=color, s=28, zorder=3)
        change = curve.get("type_change")
        if change:
            ax.scatter([change["chi"]], [change["lambda_c"]], marker="*", s=120, color=color,
                       edgecolor="k", zorder=4)  # fmt: skip
        theory = misbah_critical_lambda(curve["v"])
        if np.isfinite(theory):
            ax.axhline(theory, color=color, ls=":", lw=1.0)
    ax.set_xscale("log")
    ax.set_xlabel(r"$\chi$ (shear rate)")
    ax.set_ylabel(r"$\lambda_c$")
    ax.grid(alpha=0.3, which="both")
    ax.scatter([], [], color="0.3", s=28, label="Hopf (TR above)")
    ax.scatter([], [], facecolor="white", edgecolor="0.3", s=28, label="saddle-node (TU above)")
    ax.plot([], [], color="0.3", ls=":", lw=1.0, label="leading-order theory")
    ax.legend(loc="best", fontsize="x-small")
    ax.set_title("neutral curves: TT stable below", fontsize="medium")
    paths = [_save(fig, outdir / "phase_diagram.png", dpi)]
    logger.info("wrote %s", paths[0])
    return paths
