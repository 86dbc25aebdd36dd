"""Scalar spherical-harmonic transforms on a Gauss–Legendre grid, batched over fields.

Coefficients are complex arrays of shape ``(..., lmax + 1, lmax + 1)`` indexed ``[l, m]`` with
``m >= 0`` (entries with ``m > l`` are zero); negative orders follow from ``f_{l,-m} =
conj(f_lm)`` for real fields.  Normalisation as in :mod:`vesicle.sphere.legendre`, so that
``f = sum_l sum_{|m|<=l} f_lm Pbar_lm(cos theta) e^{i m phi}`` and the modal energy is
``E_l = |f_l0|^2 + 2 sum_{m>0} |f_lm|^2``.

The fast path is an FFT in ``phi`` (ducc0) and one batched BLAS product per order ``m`` for the
Legendre stage.  :func:`analysis_reference` and :func:`synthesis_reference` are plain loops
over ``(l, m)`` kept for the tests.
"""

from __future__ import annotations

from functools import cached_property
from typing import NamedTuple

import ducc0
import numpy as np

from vesicle.caches import bounded_cache
from vesicle.sphere.grid import SphereGrid
from vesicle.sphere.legendre import legendre_reference, legendre_table

__all__ = [
    "Derivatives",
    "SHTransform",
    "analysis_reference",
    "evaluate",
    "mode_energy",
    "real_matmul",
    "resize",
    "synthesis_reference",
    "transform",
]


class Derivatives(NamedTuple):
    """A field and its first and second derivatives in ``theta`` (t) and ``phi`` (p)."""

    f: np.ndarray
    t: np.ndarray
    p: np.ndarray
    tt: np.ndarray
    tp: np.ndarray
    pp: np.ndarray


def real_matmul(mat: np.ndarray, data: np.ndarray) -> np.ndarray:
    """``mat @ data``: real ``mat`` (K, a, b), complex ``data`` (K, b, B), without upcasting."""
    k, _, nb = data.shape
    re = np.ascontiguousarray(data).view(np.float64)  # (K, b, 2B), interleaved re/im
    out = np.matmul(mat, re)
    return out.view(np.complex128).reshape(k, mat.shape[1], nb)


class SHTransform:
    """Forward/inverse transforms between a :class:`SphereGrid` and coefficients up to ``lmax``.

    Use :func:`transform` to obtain a shared, cached instance.
    """

    def __init__(self, grid: SphereGrid, lmax: int):
        if not 0 <= lmax <= grid.max_degree:
            raise ValueError(
                f"degree {lmax} needs a grid with n_theta >= {lmax + 1}; "
                f"got n_theta = {grid.n_theta}"
            )
        self.grid = grid
        self.lmax = lmax

    @cached_property
    def _tables(self) -> tuple[np.ndarray, np.ndarray]:
        P, dP, d2P = legendre_table(self.lmax, self.grid.theta, derivatives=2)
        # Synthesis tables [m, i, l]: the three theta-derivative orders stacked along i.
        syn = np.concatenate([P, dP, d2P], axis=0).transpose(1, 0, 2).copy()
        # Analysis table [m, l, i] with the Gauss weights folded in.
        ana = (P * self.grid.gauss_weights[:, None, None]).transpose(1, 2, 0).copy()
        return syn, ana

    @property
    def shape(self) -> tuple[int, int]:
        return (self.lmax + 1, self.lmax + 1)

    # ------------------------------------------------------------------ analysis
    def analysis(self, f: np.ndarray) -> np.ndarray:
        """Grid values ``(..., n_theta, n_phi)`` -> coefficients ``(..., lmax+1, lmax+1)``.

        Exact (to rounding) for fields band-limited to degree ``n_theta - 1``; for others it is
        the discrete projection onto degree ``lmax``.
        """
        f = np.asarray(f, dtype=np.float64)
        g = self.grid
        if f.shape[-2:] != g.shape:
            raise ValueError(f"field shape {f.shape} does not end with the grid shape {g.shape}")
        batch = f.shape[:-2]
        M = self.lmax + 1
        F = ducc0.fft.r2c(f.reshape(-1, *g.shape), axes=(2,), inorm=2)[:, :, :M]
        F = F.transpose(2, 1, 0)  # (m, i, B)
        c = real_matmul(self._tables[1], F)  # (m, l, B)
        return c.transpose(2, 1, 0).reshape(*batch, M, M)

    # ----------------------------------------------------------------- synthesis
    def _legendre_stage(self, c: np.ndarray, orders: int) -> tuple[np.ndarray, tuple]:
        c = resize(np.asarray(c), self.lmax)
        batch = c.shape[:-2]
        M = self.lmax + 1
        cm = c.reshape(-1, M, M).transpose(2, 1, 0)  # (m, l, B)
        nt = self.grid.n_theta
        G = real_matmul(self._tables[0][:, : orders * nt], cm)  # (m, orders*i, B)
        return G.reshape(M, orders, nt, -1), batch

    def _fourier_stage(self, spectra: np.ndarray) -> np.ndarray:
        """``spectra`` (K, m, i, B) -> real fields (K, B, i, phi)."""
        k, M, nt, nb = spectra.shape
        full = np.zeros((k, nb, nt, self.grid.n_phi // 2 + 1), dtype=np.complex128)
        full[..., :M] = spectra.transpose(0, 3, 2, 1)
        return ducc0.fft.c2r(full, axes=(3,), lastsize=self.grid.n_phi, forward=False, inorm=0)

    def synthesis(self, c: np.ndarray) -> np.ndarray:
        """Coefficients ``(..., l, m)`` (any degree up to ``lmax``) -> grid values."""
        G, batch = self._legendre_stage(c, 1)
        return self._fourier_stage(G[:, 0][None])[0].reshape(*batch, *self.grid.shape)

    def derivatives(self, c: np.ndarray) -> Derivatives:
        """Field, first and second ``theta``/``phi`` derivatives from coefficients, in one pass."""
        G, batch = self._legendre_stage(c, 3)
        im = 1j * np.arange(self.lmax + 1)[:, None, None]
        G0, G1, G2 = G[:, 0], G[:, 1], G[:, 2]
        spectra = np.stack([G0, im * G0, im * im * G0, G1, im * G1, G2])
        out = self._fourier_stage(spectra).reshape(6, *batch, *self.grid.shape)
        return Derivatives(f=out[0], p=out[1], pp=out[2], t=out[3], tp=out[4], tt=out[5])

    def gradient(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(d/dtheta, d/dphi)`` of the fields with coefficients ``c`` (what :meth:`derivatives`
        gives as ``t`` and ``p``, at a third of its cost)."""
        G, batch = self._legendre_stage(c, 2)
        im = 1j * np.arange(self.lmax + 1)[:, None, None]
        out = self._fourier_stage(np.stack([G[:, 1], im * G[:, 0]]))
        out = out.reshape(2, *batch, *self.grid.shape)
        return out[0], out[1]

    def filter(self, f: np.ndarray, degree: int | None = None) -> np.ndarray:
        """Project grid values onto spherical harmonics of degree <= ``degree`` (default lmax)."""
        c = self.analysis(f)
        if degree is not None:
            c = resize(resize(c, degree), self.lmax)
        return self.synthesis(c)


@bounded_cache("transform")
def transform(n_theta: int, lmax: int | None = None) -> SHTransform:
    """Shared transform for ``n_theta`` rings up to degree ``lmax`` (default ``n_theta - 1``)."""
    grid = SphereGrid(n_theta)
    return SHTransform(grid, grid.max_degree if lmax is None else lmax)


def resize(c: np.ndarray, lmax: int) -> np.ndarray:
    """Truncate or zero-pad coefficients ``(..., l, m)`` to degree ``lmax``."""
    c = np.asarray(c)
    n = c.shape[-1] - 1
    if n == lmax:
        return c
    out = np.zeros((*c.shape[:-2], lmax + 1, lmax + 1), dtype=np.result_type(c, np.complex128))
    k = min(n, lmax) + 1
    out[..., :k, :k] = c[..., :k, :k]
    return out


def mode_energy(c: np.ndarray) -> np.ndarray:
    """Modal energy ``E_l = sum_{|m|<=l} |f_lm|^2`` (SPEC (3.5)), shape ``(..., lmax+1)``."""
    a2 = np.abs(c) ** 2
    return a2[..., 0] + 2.0 * a2[..., 1:].sum(axis=-1)


def evaluate(
    c: np.ndarray, theta: np.ndarray, phi: np.ndarray, derivatives: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Evaluate the series at arbitrary points (``theta``, ``phi`` of equal shape), directly.

    Returns an array of shape ``(..., *theta.shape)`` for coefficients ``(..., l, m)``; with
    ``derivatives`` the tuple ``(f, df/dtheta, df/dphi)`` (needs ``0 < theta < pi``).
    """
    c = np.asarray(c)
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    lmax = c.shape[-1] - 1
    tables = legendre_table(lmax, theta.ravel(), derivatives=int(derivatives))  # (n, m, l)
    m = np.arange(lmax + 1)
    w = np.where(m == 0, 1.0, 2.0) * np.exp(1j * np.outer(phi.ravel(), m))  # (n, m)
    out = []
    for P in tables:
        F = np.einsum("nml,...lm->...nm", P, c)
        out.append(np.real(np.einsum("...nm,nm->...n", F, w)))
        if len(out) == 1 and derivatives:
            dphi = np.real(np.einsum("...nm,nm->...n", F, 1j * m * w))
    if not derivatives:
        return out[0].reshape(*c.shape[:-2], *theta.shape)
    return tuple(v.reshape(*c.shape[:-2], *theta.shape) for v in (out[0], out[1], dphi))


# ------------------------------------------------------------------ references
def analysis_reference(grid: SphereGrid, f: np.ndarray, lmax: int) -> np.ndarray:
    """Plain quadrature loop over ``(l, m)`` for one field (SciPy Legendre functions)."""
    c = np.zeros((lmax + 1, lmax + 1), dtype=np.complex128)
    th, ph = grid.meshgrid()
    for l in range(lmax + 1):
        for m in range(l + 1):
            basis = legendre_reference(l, m, th) * np.exp(-1j * m * ph)
            c[l, m] = np.sum(grid.weights * f * basis) / (2.0 * np.pi)
    return c


def synthesis_reference(grid: SphereGrid, c: np.ndarray) -> np.ndarray:
    """Direct summation of the series on the grid for one field."""
    th, ph = grid.meshgrid()
    f = np.zeros(grid.shape)
    for l in range(c.shape[0]):
        for m in range(l + 1):
            term = legendre_reference(l, m, th) * np.exp(1j * m * ph) * c[l, m]
            f += term.real if m == 0 else 2.0 * term.real
    return f
