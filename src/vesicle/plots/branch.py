"""Figures of a branch file (``vesicle branch --out``).

- ``branch_shape.png``: psi, D and S_xz against the varied parameter; stable points filled,
  unstable ones open; special points as vertical lines.
- ``branch_omega.png`` (the paper's Fig. 8): the leading eigenvalues' growth rates omega_I
  against the parameter (filled where omega_R = 0: real modes, open: complex pairs) and, where
  the branch has a saddle-node or fold, ``|omega_I|`` of the most unstable real mode against the
  distance to it in log-log with the fitted exponent
  (:func:`vesicle.bifurcation.branch.approach_exponent`)
  beside the square-root law of a saddle-node.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from vesicle.bifurcation.branch import REAL_TOLERANCE, approach_exponent
from vesicle.plots.runs import _figure, _json_file_with, _save

__all__ = ["fold_approach", "is_branch_file", "plot_branch"]

logger = logging.getLogger(__name__)


def is_branch_file(path: str | Path) -> bool:
    """Whether ``path`` is the JSON of a branch."""
    return _json_file_with(path, {"parameter", "points", "special_points"})


def _fold(data: dict) -> dict | None:
    folds = [s for s in data["special_points"] if s["type"] in ("saddle-node", "fold")]
    return folds[0] if folds else None


def fold_approach(data: dict) -> dict | None:
    """The exponent of the leading real growth rate's approach to the branch's first saddle-node
    or fold (``None`` if it has none): the points on the stable side, within 10 % of it."""
    fold = _fold(data)
    if fold is None:
        return None
    name, critical = data["parameter"], fold[data["parameter"]]
    pts = [p for p in data["points"] if abs(p["omega_R"]) <= REAL_TOLERANCE
           and p["omega_I"] < 0 and 0 < abs(critical - p[name]) <= 0.1 * abs(critical)]  # fmt: skip
    if len(pts) < 2:
        return None
    values, growth = [p[name] for p in pts], [p["omega_I"] for p in pts]
    fit = approach_exponent(values, growth, critical)
    located = bool(fold.get("located", True))  # False: the square-root law's estimate
    out = {**fit, "type": fold["type"], "parameter": name, "located": located}
    if len(pts) >= 3:  # the fold fitted too: independent of its location on the branch
        free = approach_exponent(values, growth)
        out["free"] = {k: free[k] for k in ("exponent", "coefficient", "critical")}
    return out


def plot_branch(data: dict, outdir: str | Path, dpi: int = 120) -> list[Path]:
    """Draw the figures of the branch dictionary ``data`` into ``outdir``."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    name = data["parameter"]
    pts = sorted(data["points"], key=lambda p: p[name])
    x = np.array([p[name] for p in pts])
    stable = np.array([p["n_unstable"] == 0 for p in pts])
    label = {"lam": r"$\lambda$", "chi": r"$\chi$", "v": r"$v$"}[name]
    symbol = {"v": "v", "lam": "λ", "chi": "χ"}
    fixed = ", ".join(f"{symbol[k]} = {data.get('physics', {}).get(k):g}"
                      for k in ("v", "lam", "chi")
                      if k != name and k in data.get("physics", {}))  # fmt: skip
    title = f"{fixed}; N = {data['degree']} ({data['grid']}×{2 * data['grid']})"

    fig = _figure((6.4, 6.4))
    axes = fig.subplots(3, 1, sharex=True)
    ylabels = (r"$\psi$ [rad]", "D", r"$S_{xz}$ [$c\,\mu\dot\gamma$]")
    for ax, key, ylabel in zip(axes, ("psi", "D", "S_xz"), ylabels, strict=True):
        y = np.array([p[key] for p in pts])
        ax.plot(x, y, color="C0", lw=1.2)
        ax.scatter(x[stable], y[stable], color="C0", s=18, zorder=3)
        ax.scatter(x[~stable], y[~stable], facecolor="white", edgecolor="C0", s=18, zorder=3)
        for s in data["special_points"]:
            ax.axvline(s[name], color="C3", ls="--", lw=0.8)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].set_title(f"steady branch: {title} (open: unstable)", fontsize="medium")
    axes[-1].set_xlabel(label)
    paths = [_save(fig, outdir / "branch_shape.png", dpi)]

    approach = fold_approach(data)
    fig = _figure((6.4, 6.4) if approach else (6.4, 4.2))
    axes = fig.subplots(2, 1) if approach else [fig.add_subplot()]
    ax = axes[0]
    for p in pts:
        w = np.asarray(p.get("eigenvalues") or [[p["omega_R"], p["omega_I"]]], dtype=float)
        real = np.abs(w[:, 0]) <= REAL_TOLERANCE
        ax.scatter(np.full(real.sum(), p[name]), w[real, 1], color="C0", s=14)
        ax.scatter(np.full((~real).sum(), p[name]), w[~real, 1], facecolor="white",
                   edgecolor="C1", s=14)  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.8)
    for s in data["special_points"]:
        estimate = "" if s.get("located", True) else " (estimate, not located)"
        ax.axvline(s[name], color="C3", ls="--", lw=0.8,
                   label=f"{s['type']} {s[name]:.5g}{estimate}")  # fmt: skip
    ax.scatter([], [], color="C0", s=14, label=r"real ($\omega_R = 0$)")
    ax.scatter([], [], facecolor="white", edgecolor="C1", s=14, label="complex pair")
    ax.set_xlabel(label)
    ax.set_ylabel(r"growth rate $\omega_I$ [$\kappa/\mu a^3$]")
    ax.set_title(f"leading eigenvalues along the branch: {title}", fontsize="medium")
    ax.legend(fontsize="x-small", framealpha=0.8)
    ax.grid(alpha=0.3)
    if approach:
        ax = axes[1]
        xs = np.array([abs(approach["critical"] - p[name]) for p in pts])
        ys = np.array([abs(p["omega_I"]) for p in pts])
        real = np.array([abs(p["omega_R"]) <= REAL_TOLERANCE and p["omega_I"] < 0 for p in pts])
        keep = real & (xs > 0)
        ax.loglog(xs[keep], ys[keep], "o", color="C0", ms=4, label="computed")
        grid = np.geomspace(*approach["range"], 20)
        ax.loglog(grid, approach["coefficient"] * grid ** approach["exponent"], color="C0",
                  label=f"fit: exponent {approach['exponent']:.3f}")  # fmt: skip
        if "free" in approach:
            f = approach["free"]
            ax.plot([], [], ls="", label=f"fold fitted too: exponent {f['exponent']:.3f} at "
                    f"{f['critical']:.6g}")  # fmt: skip
        x0 = approach["range"][1]
        y0 = approach["coefficient"] * x0 ** approach["exponent"]
        ax.loglog(grid, y0 * np.sqrt(grid / x0), color="k", ls=":",
                  label="saddle-node normal form: exponent 1/2")  # fmt: skip
        where = ("" if approach.get("located", True)
                 else " (an estimate from the square-root law: not located)")  # fmt: skip
        ax.set_xlabel(f"distance to the {approach['type']} at {label} = "
                      f"{approach['critical']:.6g}{where}", fontsize="small")  # fmt: skip
        ax.set_ylabel(r"$|\omega_I|$ (leading real mode)")
        ax.legend(fontsize="x-small", framealpha=0.8)
        ax.grid(alpha=0.3, which="both")
    paths.append(_save(fig, outdir / "branch_omega.png", dpi))
    for p in paths:
        logger.info("wrote %s", p)
    return paths
