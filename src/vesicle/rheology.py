"""Particle stress of one vesicle and its specific (normalised) form (SPEC §11).

``sigma^p_ij = (1/Omega) int [f]_i x_j dA + (1/Omega) int (lambda - 1)(u_i n_j + u_j n_i) dA``;
with the volume fraction ``c = V/Omega`` the specific stress is ``S = sigma^p / (c chi)``:
``S_xz = sigma^p_xz / (c chi)``, ``N1 = S_xx - S_zz``, ``N2 = S_zz - S_yy`` with the normal
stresses scaled by ``|chi|`` (so they keep their sign when the shear is reversed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .surface import Shape

__all__ = ["ParticleStress", "particle_stress"]


@dataclass(frozen=True)
class ParticleStress:
    """``sigma^p / c`` (the stress per unit volume fraction) and the shear rate ``chi``.

    With ``chi = 0`` the chi-normalised quantities are undefined and are ``nan``.
    """

    per_volume_fraction: (
        np.ndarray
    )  # (3, 3): sigma^p / c = (1/V) [int f x + (lam-1) int (u n + n u)]
    chi: float

    @property
    def defined(self) -> bool:
        return self.chi != 0.0

    @property
    def S(self) -> np.ndarray:
        """Specific stress ``sigma^p / (c chi)``, (3, 3); ``nan`` when ``chi = 0``."""
        if not self.defined:
            return np.full((3, 3), np.nan)
        return self.per_volume_fraction / self.chi

    @property
    def S_xz(self) -> float:
        return float(self.S[0, 2])

    @property
    def N1(self) -> float:
        """``(sigma^p_xx - sigma^p_zz) / (c |chi|)``."""
        if not self.defined:
            return float("nan")
        s = self.per_volume_fraction
        return float((s[0, 0] - s[2, 2]) / abs(self.chi))

    @property
    def N2(self) -> float:
        """``(sigma^p_zz - sigma^p_yy) / (c |chi|)``."""
        if not self.defined:
            return float("nan")
        s = self.per_volume_fraction
        return float((s[2, 2] - s[1, 1]) / abs(self.chi))

    def summary(self) -> dict:
        """``S_xz``, ``N1``, ``N2`` as JSON-able floats (``None`` when undefined)."""
        return {k: (None if not self.defined else getattr(self, k)) for k in ("S_xz", "N1", "N2")}

    def __add__(self, other: ParticleStress) -> ParticleStress:
        if other.chi != self.chi:
            raise ValueError("stresses at different shear rates cannot be added")
        return ParticleStress(self.per_volume_fraction + other.per_volume_fraction, self.chi)


def particle_stress(
    shape: Shape, force: np.ndarray, u: np.ndarray, lam: float, chi: float
) -> ParticleStress:
    """Particle stress from the membrane load ``[f]`` and velocity ``u`` on the grid.

    Moments are taken about the volume centroid (the result does not depend on the origin for a
    force-free vesicle; the centroid keeps it well conditioned).
    """
    x = shape.x - shape.centroid[:, None, None]
    n = shape.normal
    moment = shape.integrate(np.einsum("i...,j...->ij...", force, x))
    un = shape.integrate(np.einsum("i...,j...->ij...", u, n))
    total = (moment + (lam - 1.0) * (un + un.T)) / shape.volume
    return ParticleStress(total, float(chi))
