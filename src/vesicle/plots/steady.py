"""Figures of a steady-state file: its spectrum, its most unstable modes and its mode spectra.

- ``spectrum_eigenvalues.png``: the growth exponents ``-i omega`` in the complex plane
  (``omega_I`` against ``omega_R``), the unstable half shaded;
- ``spectrum_El.png``: the modal energy ``E_l`` of the radius and of the normal bending force
  (the paper's Fig. 2b, 3b);
- ``eigenmode_<k>.png``: the ``k``-th most unstable mode as a perturbation of the shape,
  cross-sections in the x–z and x–y planes (the paper's Fig. 10); a complex mode is shown at
  two phases (its real and imaginary parts), a quarter period apart.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from vesicle.model.membrane import bending_force
from vesicle.plots.runs import _figure, _save, section_xy, section_xz
from vesicle.sphere.transforms import mode_energy, transform
from vesicle.steady.files import SteadyFile

__all__ = ["plot_steady"]

logger = logging.getLogger(__name__)

#: Largest radius change of a mode as drawn, relative to the mean radius.
MODE_AMPLITUDE = 0.15


def _title(s: SteadyFile, what: str) -> str:
    p = s.physics
    return f"{what}  (v = {p.v:g}, λ = {p.lam:g}, χ = {p.chi:g}, N = {s.discretisation.degree})"


def _plot_eigenvalues(s: SteadyFile, path: Path, dpi: int, reference: list | None = None) -> Path:
    fig = _figure((7.6, 4.4))
    ax = fig.add_subplot()
    w_r, w_i = s.omega[:, 0], s.omega[:, 1]
    ax.axhspan(0.0, max(0.05, 1.2 * w_i.max()), color="C3", alpha=0.08, lw=0)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.scatter(w_r, w_i, s=18, color="C0", zorder=3)
    ax.scatter(w_r[:1], w_i[:1], s=60, facecolor="none", edgecolor="C3", zorder=4,
               label=f"most unstable ({abs(w_r[0]):.4g}, {w_i[0]:.4g})")  # fmt: skip
    for ref in reference or []:  # e.g. the paper's mode (SPEC §14), at both signs of omega_R
        r_r, r_i = ref["omega"]
        ax.scatter([r_r, -r_r], [r_i, r_i], marker="D", s=40, facecolor="none", edgecolor="k",
                   lw=1.2, zorder=5, label=ref["label"])  # fmt: skip
    ax.set_xlabel(r"$\omega_R$ (frequency) [$\kappa/\mu a^3$]")
    ax.set_ylabel(r"$\omega_I$ (growth rate) [$\kappa/\mu a^3$]")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small")
    ax.set_title(_title(s, f"{s.stability_basis} spectrum"), fontsize="medium")
    return _save(fig, path, dpi)


def _plot_mode_spectra(s: SteadyFile, path: Path, dpi: int) -> Path:
    shape = s.shape
    radius = mode_energy(shape.coefficients)
    f_n = np.einsum("i...,i...->...", bending_force(shape), shape.normal)
    force = mode_energy(transform(shape.grid.n_theta).analysis(f_n))
    fig = _figure((5.6, 4.2))
    ax = fig.add_subplot()
    for values, label, marker in ((radius, "radius r", "o"), (force, "bending force f_B·n", "s")):
        l = np.arange(values.size)
        keep = (
            values > 1e-14 * values.max()
        )  # below: rounding (the odd degrees of a symmetric state)
        ax.semilogy(l[keep], values[keep], marker=marker, ms=4, lw=1.2, label=label)
    ax.axvline(s.discretisation.degree, color="0.6", ls=":", lw=1.0, label="shape degree N")
    ax.set_xlabel("degree l")
    ax.set_ylabel(r"$E_l$")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best", fontsize="small", framealpha=0.8)
    ax.set_title(_title(s, "mode spectra"), fontsize="medium")
    return _save(fig, path, dpi)


def _plot_mode(s: SteadyFile, k: int, path: Path, dpi: int) -> Path:
    base = s.coefficients
    n = base.shape[0]
    if s.mode_parts is not None:
        real, imag = s.mode_parts[k]
    else:  # a file from before mode_parts: modes separate only for the symmetric basis
        real, imag = s.modes[k].real + 0j, s.modes[k].imag + 0j
    parts = [("real part", real)]
    w_r, w_i = s.omega[k]
    if abs(w_r) > 1e-8:
        parts.append(("imaginary part (a quarter period later)", imag))
    sections = ((section_xz, ("x", "z")), (section_xy, ("x", "y")))
    perturbations = []
    for what, part in parts:
        c = np.zeros_like(base)
        c[: part.shape[0], : part.shape[1]] = part[:n, :n]
        # one scale for both sections, from the larger: a mode odd in y vanishes on y = 0, and
        # a scale from that section alone would magnify its rounding into a shape
        size = max(np.abs(sec(c)[0]).max() + np.abs(sec(c)[1]).max() for sec, _ in sections)
        perturbations.append((what, MODE_AMPLITUDE / size * c if size > 0 else 0.0 * c))
    fig = _figure((9.6, 4.6))
    axes = fig.subplots(1, 2)
    for (section, labels), ax in zip(sections, axes, strict=True):
        ax.plot(*section(base), color="0.3", lw=1.6, label="steady state")
        for j, (what, c) in enumerate(perturbations):
            ax.plot(*section(base + c), color=f"C{j}", lw=1.2, ls="--",
                    label=f"perturbed: {what}")  # fmt: skip
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.grid(alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=3,
               fontsize="x-small")  # fmt: skip
    fig.suptitle(_title(s, f"mode {k + 1}: ω = ({abs(w_r):.4g}, {w_i:.4g})"), fontsize="medium")
    return _save(fig, path, dpi)


def plot_steady(
    s: SteadyFile,
    outdir: str | Path,
    prefix: str = "",
    dpi: int = 120,
    modes: int = 2,
    reference: list[dict] | None = None,
) -> list[Path]:
    """Write the figures of a steady-state file (see the module docstring).

    ``reference``: eigenvalues to draw beside the spectrum, ``{"label", "omega": (omega_R,
    omega_I)}`` each (the paper's, where it states one).

    The eigenvalue and eigenmode figures need a file written with the stability analysis
    (``vesicle tt --stability --out FILE``); without it only ``spectrum_El`` is drawn.
    ``modes`` is the number of most unstable modes drawn (one per complex pair).
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = [_plot_mode_spectra(s, outdir / f"{prefix}spectrum_El.png", dpi)]
    if s.omega is not None:
        paths.insert(0, _plot_eigenvalues(s, outdir / f"{prefix}spectrum_eigenvalues.png", dpi,
                                          reference))  # fmt: skip
        picked, k = [], 0
        while len(picked) < modes and k < len(s.omega):
            if (
                not picked
                or not np.isclose(s.omega[k, 0], -s.omega[picked[-1], 0])
                or not (np.isclose(s.omega[k, 1], s.omega[picked[-1], 1]))
            ):  # skip the conjugate of the mode just drawn
                picked.append(k)
            k += 1
        if s.mode_parts is None and s.stability_basis == "general":
            # written before mode_parts: its general modes' sin parts cannot be told apart
            logger.warning("%s's general modes predate mode_parts: no eigenmode figures (write "
                           "the file again with vesicle tt --out)", s.attributes.get("file", "the "
                           "file"))  # fmt: skip
            picked = []
        for number, k in enumerate(picked, start=1):
            paths.append(_plot_mode(s, k, outdir / f"{prefix}eigenmode_{number}.png", dpi))
    logger.info("wrote %d figures to %s", len(paths), outdir)
    return paths
