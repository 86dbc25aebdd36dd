"""Normalised associated Legendre functions and their theta derivatives.

Convention (SPEC §2): ``Pbar_lm(cos theta)`` with ``int_{-1}^{1} Pbar_lm^2 dx = 1`` and no
Condon–Shortley phase, so ``Pbar_lm >= 0`` near the north pole.  A field is
``f = sum_l sum_{|m|<=l} f_lm Pbar_l|m|(cos theta) e^{i m phi}`` with ``f_{l,-m} = conj(f_lm)``.
"""

from __future__ import annotations

import numpy as np
from scipy.special import sph_harm_y

__all__ = ["legendre_reference", "legendre_table"]


def legendre_table(lmax: int, theta: np.ndarray, derivatives: int = 0) -> tuple[np.ndarray, ...]:
    """Tables of ``Pbar_lm(cos theta)`` and its theta derivatives.

    Parameters
    ----------
    lmax : int
        Highest degree.
    theta : array_like, shape (n,)
        Polar angles, strictly inside (0, pi) when derivatives are requested.
    derivatives : {0, 1, 2}
        How many theta derivatives to return as well.

    Returns
    -------
    tuple of ndarray, each of shape (n, lmax + 1, lmax + 1) indexed ``[i, m, l]``
        (``P`` itself is a transposed view of an ``[m, l, i]``-contiguous array)
        ``P`` and, as requested, ``dP/dtheta`` and ``d^2P/dtheta^2``; zero where ``l < m``.

    Notes
    -----
    Stable three-term recurrence in ``l`` at fixed ``m``, seeded by
    ``Pbar_00 = 1/sqrt(2)``, ``Pbar_mm = sqrt((2m+1)/(2m)) sin(theta) Pbar_{m-1,m-1}``.
    Derivatives use ``sin(theta) dPbar_lm/dtheta = l cos(theta) Pbar_lm
    - sqrt((l^2-m^2)(2l+1)/(2l-1)) Pbar_{l-1,m}`` and the Legendre equation
    ``P'' = -cot(theta) P' - (l(l+1) - m^2/sin^2 theta) P``.
    """
    theta = np.asarray(theta, dtype=float).ravel()
    x, s = np.cos(theta), np.sin(theta)
    n, L = theta.size, lmax + 1
    Pml = np.zeros((L, L, n))  # computed as [m, l, i] so that each recurrence step is contiguous
    pmm = np.full(n, 1.0 / np.sqrt(2.0))
    for m in range(L):
        if m > 0:
            pmm = pmm * np.sqrt((2 * m + 1) / (2 * m)) * s
        Pml[m, m] = pmm
        if m + 1 < L:
            Pml[m, m + 1] = np.sqrt(2 * m + 3) * x * pmm
        for l in range(m + 2, L):
            a = np.sqrt((4 * l * l - 1) / (l * l - m * m))
            b = np.sqrt(((l - 1) ** 2 - m * m) * (2 * l + 1) / ((2 * l - 3) * (l * l - m * m)))
            Pml[m, l] = a * x * Pml[m, l - 1] - b * Pml[m, l - 2]
    P = Pml.transpose(2, 0, 1)
    if derivatives == 0:
        return (P,)
    if np.any(s <= 0.0):
        raise ValueError("theta derivatives need 0 < theta < pi")
    l = np.arange(L)[None, None, :]
    m = np.arange(L)[None, :, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.sqrt(np.where(l > m, (l * l - m * m) * (2 * l + 1) / (2 * l - 1.0), 0.0))
    Pm1 = np.zeros_like(P)
    Pm1[:, :, 1:] = P[:, :, :-1]
    dP = (l * x[:, None, None] * P - c * Pm1) / s[:, None, None]
    if derivatives == 1:
        return P, dP
    s2 = (s * s)[:, None, None]
    d2P = -(x / s)[:, None, None] * dP - (l * (l + 1) - m * m / s2) * P
    return P, dP, d2P


def legendre_reference(l: int, m: int, theta: np.ndarray) -> np.ndarray:
    """``Pbar_lm(cos theta)`` from SciPy's orthonormal spherical harmonics (a slow check).

    ``Pbar_lm e^{i m phi} = (-1)^m sqrt(2 pi) Y_lm`` for SciPy's ``Y_lm`` (which carries the
    Condon–Shortley phase and unit norm on the sphere).
    """
    theta = np.asarray(theta, dtype=float)
    y = sph_harm_y(l, m, theta, np.zeros_like(theta))
    return np.real((-1) ** m * np.sqrt(2 * np.pi) * y)
