"""Diagnostic figures of a run: inclination, deformation, stresses, orbit, shapes, axis traces.

All figures are drawn on :class:`matplotlib.figure.Figure` objects with an Agg canvas, so the
module never touches pyplot's global state and works without a display.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vesicle.geometry.diagnostics import continuous_axes, out_of_plane_angle, tilt_growth
from vesicle.io.files import RunData
from vesicle.sphere.transforms import evaluate

__all__ = ["is_out_of_plane", "plot_out_of_plane", "plot_run", "section_xy", "section_xz"]

logger = logging.getLogger(__name__)

#: |y component| of the longest axis above which a run counts as out of the shear plane.
OUT_OF_PLANE_THRESHOLD = 0.05

#: Points along each cross-section curve.
SECTION_POINTS = 361

#: Axis labels with their units (SPEC §1: time in mu_out a^3 / kappa; SPEC §11: the specific
#: stresses S = sigma^p / (c chi), the particle stress in units of c mu_out gamma_dot).
T_LABEL = r"$t$ [$\mu a^3/\kappa$]"
STRESS_LABEL = r"specific stress [$c\,\mu\dot\gamma$]"


# --------------------------------------------------------------------- helpers
def _fmt(value: object) -> str:
    if isinstance(value, int | float | np.number) and not isinstance(value, bool):
        return f"{float(value):g}"
    return "?" if value is None else str(value)


def _title(run: RunData, what: str) -> str:
    params = ", ".join(
        f"{name} = {_fmt(run.parameter(key))}"
        for name, key in (("v", "v"), ("λ", "lam"), ("χ", "chi"))
    )
    return f"{what}  ({params})"


def _series(run: RunData, name: str) -> np.ndarray:
    if name not in run.series:
        raise ValueError(f"run has no series {name!r} (needed for the plots)")
    return np.asarray(run.series[name], dtype=float)


def _figure(figsize: tuple[float, float] = (6.4, 4.2)) -> Figure:
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _json_file_with(path: str | Path, keys: set[str]) -> bool:
    """Whether ``path`` is a JSON object with at least the ``keys`` (what a figure reads)."""
    import json

    try:
        data = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and keys <= set(data)


def wrap_label(text: str, width: int = 60) -> str:
    """``text`` broken into lines of about ``width`` characters at spaces outside mathtext
    (``$...$``), so that a long legend entry keeps the legend narrow."""
    lines, line, math = [], "", False
    for word in text.split(" "):
        if line and not math and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
        if word.count("$") % 2:
            math = not math
    return "\n".join([*lines, line])


def legend_below(
    fig: Figure, handles: list, labels: list[str], ncols: int = 2, width: int = 60
) -> None:
    """One legend for ``fig`` below its axes (never over the data), its labels wrapped."""
    if handles:
        fig.legend(handles, [wrap_label(label, width) for label in labels],
                   loc="outside lower center", ncols=min(ncols, len(handles)),
                   fontsize="x-small")  # fmt: skip


def _save(fig: Figure, path: Path, dpi: int) -> Path:
    fig.savefig(path, dpi=dpi, format="png")
    logger.debug("wrote %s", path)
    return path


def is_out_of_plane(run: RunData) -> bool:
    """Whether the run leaves the shear plane (tilted start, or long axis gaining a y part).

    Parameters
    ----------
    run : RunData
        The run; uses ``series["axes"]`` and ``parameters["tilt"]`` when present.

    Returns
    -------
    bool
        True if any ``|axes[:, 0, 1]| > 0.05`` or a non-zero ``tilt`` parameter is set.
    """
    tilt = run.parameter("tilt", 0.0)
    try:
        tilted = float(0.0 if tilt is None else tilt) != 0.0
    except (TypeError, ValueError):
        raise ValueError(f"the run's tilt parameter is not a number: {tilt!r}") from None
    axes = run.series.get("axes")
    if axes is None or np.size(axes) == 0:
        return tilted
    y = np.abs(np.asarray(axes, dtype=float)[:, 0, 1])
    return tilted or bool(np.any(y[np.isfinite(y)] > OUT_OF_PLANE_THRESHOLD))


# ------------------------------------------------------------------ sections
def section_xz(coefficients: np.ndarray, m: int = SECTION_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Closed cross-section curve of the surface with the plane ``y = 0``.

    Parameters
    ----------
    coefficients : complex array (N+1, N+1)
        Radius coefficients of the shape.
    m : int
        Number of points on the curve.

    Returns
    -------
    x, z : ndarray (m,)
        The curve, running over ``phi = 0`` from the north to the south pole and back over
        ``phi = pi``.
    """
    s = np.linspace(0.0, 2.0 * np.pi, m)
    theta = np.where(s <= np.pi, s, 2.0 * np.pi - s)
    phi = np.where(s <= np.pi, 0.0, np.pi)
    r = evaluate(coefficients, theta, phi)
    return r * np.sin(theta) * np.cos(phi), r * np.cos(theta)


def section_xy(coefficients: np.ndarray, m: int = SECTION_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Closed cross-section curve of the surface with the plane ``z = 0`` (the equator).

    Parameters
    ----------
    coefficients : complex array (N+1, N+1)
        Radius coefficients of the shape.
    m : int
        Number of points on the curve.

    Returns
    -------
    x, y : ndarray (m,)
        The equatorial curve for ``phi`` from 0 to ``2 pi``.
    """
    phi = np.linspace(0.0, 2.0 * np.pi, m)
    r = evaluate(coefficients, np.full(m, 0.5 * np.pi), phi)
    return r * np.cos(phi), r * np.sin(phi)


# ------------------------------------------------------------------- figures
def _plot_psi(run: RunData, path: Path, dpi: int) -> Path:
    t, psi = _series(run, "t"), _series(run, "psi")
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(t, psi, color="C0", lw=1.5)
    finite = psi[np.isfinite(psi)]
    if finite.size and np.ptp(finite) < 0.5 * np.pi:  # TT or TR: zoom in on the oscillation
        pad = 0.1 * max(np.ptp(finite), 1e-3)
        ax.set_ylim(min(finite.min(), 0.0) - pad, max(finite.max(), 0.0) + pad)
        ax.axhline(0.0, color="0.6", lw=0.8, ls=":")
    else:  # TU: the full range, with the half-turn levels
        for level in (-0.5 * np.pi, 0.0, 0.5 * np.pi):
            ax.axhline(level, color="0.6", lw=0.8, ls="--" if level else ":")
        ax.set_ylim(-0.55 * np.pi, 0.55 * np.pi)
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel(r"$\psi$ [rad]")
    ax.secondary_yaxis("right", functions=(np.degrees, np.radians)).set_ylabel(r"$\psi$ [deg]")
    ax.set_title(_title(run, "inclination angle"))
    return _save(fig, path, dpi)


def _plot_deformation(run: RunData, path: Path, dpi: int) -> Path:
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(_series(run, "t"), _series(run, "D"), color="C1", lw=1.5)
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel("deformation D")
    ax.set_title(_title(run, "deformation parameter"))
    return _save(fig, path, dpi)


def _plot_stress(run: RunData, path: Path, dpi: int) -> Path:
    t = _series(run, "t")
    fig = _figure()
    ax = fig.add_subplot()
    plotted = 0
    for key, label in (("S_xz", r"$S_{xz}$"), ("N1", r"$N_1$"), ("N2", r"$N_2$")):
        y = np.asarray(run.series.get(key, np.full_like(t, np.nan)), dtype=float)
        if np.any(np.isfinite(y)):
            ax.plot(t, y, lw=1.5, label=label)  # NaN entries leave gaps
            plotted += 1
    for key, label, style in (("S_bending", "bending", "--"), ("S_flow", "flow", "-.")):
        part = np.asarray(run.series.get(key, np.full((t.size, 3, 3), np.nan)), dtype=float)
        if part.ndim == 3 and np.any(np.isfinite(part[:, 0, 2])):  # the split S_xz
            ax.plot(t, part[:, 0, 2], ls=style, color="C0", lw=1.0, label=rf"$S_{{xz}}$ {label}")
    if plotted:
        ax.axhline(0.0, color="0.6", lw=0.8, ls=":")
        ax.legend(loc="best")
    else:
        note = "stress undefined at chi = 0"
        ax.text(0.5, 0.5, note, ha="center", va="center", transform=ax.transAxes, color="C3")
        finite = t[np.isfinite(t)]
        if finite.size and finite.min() < finite.max():
            ax.set_xlim(finite.min(), finite.max())
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel(STRESS_LABEL)
    ax.set_title(_title(run, "rheology"))
    return _save(fig, path, dpi)


def _plot_orbit(run: RunData, path: Path, dpi: int) -> Path:
    t, psi, D = _series(run, "t"), _series(run, "psi"), _series(run, "D")
    fig = _figure()
    ax = fig.add_subplot()
    ax.plot(psi, D, color="0.75", lw=0.8, zorder=1)
    points = ax.scatter(psi, D, c=t, s=10, cmap="viridis", zorder=2)
    fig.colorbar(points, ax=ax, label=T_LABEL)
    ax.plot(psi[-1:], D[-1:], "o", mfc="none", mec="C3", ms=9, label="final")
    ax.set_xlabel(r"$\psi$ [rad]")
    ax.set_ylabel("D")
    ax.legend(loc="best")
    ax.set_title(_title(run, "D–ψ orbit"))
    return _save(fig, path, dpi)


def _plot_section(
    run: RunData,
    path: Path,
    dpi: int,
    section: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    labels: tuple[str, str],
) -> Path:
    fig = _figure((5.2, 5.2))
    ax = fig.add_subplot()
    if run.n_saved > 1:
        ax.plot(*section(run.coefficients[0]), color="0.6", lw=1.0, ls="--", label="initial")
    ax.plot(*section(run.coefficients[-1]), color="C0", lw=1.8, label="final")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    ax.set_title(_title(run, f"{labels[0]}–{labels[1]} section"), fontsize="medium")
    return _save(fig, path, dpi)


def _plot_axes_sphere(run: RunData, path: Path, dpi: int) -> Path:
    axes = continuous_axes(_series(run, "axes"))
    fig = _figure((6.0, 6.0))
    ax = fig.add_subplot(projection="3d")
    u, w = np.meshgrid(np.linspace(0, 2 * np.pi, 25), np.linspace(0, np.pi, 13))
    sphere = (np.cos(u) * np.sin(w), np.sin(u) * np.sin(w), np.cos(w))
    ax.plot_wireframe(*sphere, color="0.85", lw=0.4)
    for k, name in enumerate(("long", "middle", "short")):
        a = axes[:, k]
        ax.plot(a[:, 0], a[:, 1], a[:, 2], color=f"C{k}", lw=1.5, label=f"{name} axis")
        ax.scatter(*a[-1], color=f"C{k}", s=25)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1, 1, 1))
    ax.legend(loc="upper left", fontsize="small")
    ax.set_title(_title(run, "principal axes"), fontsize="medium")
    return _save(fig, path, dpi)


def _plot_axes_projection(run: RunData, path: Path, dpi: int) -> Path:
    """The 2-D companion of the sphere plot: the axes seen along the vorticity axis (their x-z
    projections, the unit circle drawn) and the long axis's polar angle from y and azimuth about
    y against time (the coordinates :func:`vesicle.geometry.diagnostics.classify_orbit` reads), and
    the out-of-plane angle on a log scale with its growth
    (:func:`vesicle.geometry.diagnostics.tilt_growth`: the
    samples once per half turn in TU and the fitted line)."""
    axes = continuous_axes(_series(run, "axes"))
    t = np.asarray(run.series["t"], dtype=float)
    fig = _figure((14.5, 4.6))
    left, right, tilt_ax = fig.subplots(1, 3)
    circle = np.linspace(0.0, 2.0 * np.pi, 200)
    left.plot(np.cos(circle), np.sin(circle), color="0.8", lw=0.8)
    for k, name in enumerate(("long", "middle", "short")):
        a = axes[:, k]
        left.plot(a[:, 0], a[:, 2], color=f"C{k}", lw=1.2, label=f"{name} axis")
        left.scatter(a[-1, 0], a[-1, 2], color=f"C{k}", s=20)
    left.set_aspect("equal")
    left.set_xlabel("x")
    left.set_ylabel("z")
    left.set_title("seen along the vorticity axis y", fontsize="medium")
    left.legend(loc="upper right", fontsize="small")
    a = axes[:, 0]
    polar = np.arccos(np.clip(np.abs(a[:, 1]), 0.0, 1.0))
    azimuth = np.unwrap(np.arctan2(a[:, 2], a[:, 0]))
    right.plot(t, polar / np.pi, color="C0", label="angle from y / pi")
    right.plot(t, azimuth / (2.0 * np.pi), color="C3", label="azimuth about y / 2 pi")
    right.set_xlabel(T_LABEL)
    right.grid(alpha=0.3)
    right.legend(loc="best", fontsize="small")
    right.set_title(_title(run, "long axis"), fontsize="medium")
    angle = out_of_plane_angle(axes)
    growth = tilt_growth(t, _series(run, "psi"), axes)
    positive = angle > 0
    tilt_ax.semilogy(t[positive], angle[positive], color="0.4", lw=0.8, label="angle")
    if growth.rate is not None and (growth.per_half_turn is not None or growth.small):
        if growth.per_half_turn is not None:  # once per half turn
            tilt_ax.semilogy(growth.times, growth.angles, "o", color="C0", ms=3, label="samples")
        fit = growth.angles[0] * np.exp(growth.rate * (growth.times - growth.times[0]))
        tilt_ax.semilogy(growth.times, fit, "--", color="C3", lw=1.0,
                         label=f"rate {growth.rate:.3g}")  # fmt: skip
    tilt_ax.set_xlabel(T_LABEL)
    tilt_ax.set_ylabel("out-of-plane angle of the long axis (rad)")
    tilt_ax.grid(alpha=0.3, which="both")
    tilt_ax.legend(loc="best", fontsize="small")
    tilt_ax.set_title("long axis: elevation above the x-z plane", fontsize="medium")
    return _save(fig, path, dpi)


def plot_out_of_plane(
    run: RunData, outdir: str | Path, prefix: str = "", dpi: int = 120
) -> list[Path]:
    """The two figures of a run's principal axes: ``axes_sphere`` (their trajectories on the
    unit sphere, 3-D) and ``axes_projection`` (seen along the vorticity axis; the long axis's
    angles against time)."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    return [_plot_axes_sphere(run, outdir / f"{prefix}axes_sphere.png", dpi),
            _plot_axes_projection(run, outdir / f"{prefix}axes_projection.png", dpi)]  # fmt: skip


# ---------------------------------------------------------------------- entry
def plot_run(run: RunData, outdir: str | Path, prefix: str = "", dpi: int = 120) -> list[Path]:
    """Write the diagnostic PNG figures of a run.

    Parameters
    ----------
    run : RunData
        The run (series and shapes at the saved steps).
    outdir : str or Path
        Directory for the figures; created if needed.
    prefix : str
        Prepended to every file name.
    dpi : int
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        In this order: ``psi, deformation, stress, orbit, shape_xz, shape_xy`` and, for runs
        that leave the shear plane (see :func:`is_out_of_plane`), ``axes_sphere`` and
        ``axes_projection``.

    Raises
    ------
    ValueError
        If the run has no saved steps or lacks a needed series.
    """
    if run.n_saved == 0:
        raise ValueError("run has no saved steps to plot")
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)

    def target(name: str) -> Path:
        return outdir / f"{prefix}{name}.png"

    paths = [
        _plot_psi(run, target("psi"), dpi),
        _plot_deformation(run, target("deformation"), dpi),
        _plot_stress(run, target("stress"), dpi),
        _plot_orbit(run, target("orbit"), dpi),
        _plot_section(run, target("shape_xz"), dpi, section_xz, ("x", "z")),
        _plot_section(run, target("shape_xy"), dpi, section_xy, ("x", "y")),
    ]
    if is_out_of_plane(run):
        paths.append(_plot_axes_sphere(run, target("axes_sphere"), dpi))
        paths.append(_plot_axes_projection(run, target("axes_projection"), dpi))
    logger.info("wrote %d figures to %s", len(paths), outdir)
    return paths
