"""Particle stress of one vesicle and its specific (normalised) form (SPEC §11).

``sigma^p_ij = (1/Omega) int [f]_i x_j dA + (1/Omega) int (lambda - 1)(u_i n_j + u_j n_i) dA``;
with the volume fraction ``c = V/Omega`` the specific stress is ``S = sigma^p / (c chi)``:
``S_xz = sigma^p_xz / (c chi)``, ``N1 = S_xx - S_zz``, ``N2 = S_zz - S_yy`` with the normal
stresses scaled by ``|chi|`` (so they keep their sign when the shear is reversed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.stokes.evaluation import evaluate_double_layer, evaluate_single_layer

__all__ = ["ParticleStress", "disturbance_velocity", "far_field_stresslet", "particle_stress"]


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


def disturbance_velocity(
    shape: Shape, force: np.ndarray, u: np.ndarray, lam: float, points: np.ndarray
) -> np.ndarray:
    """``u - u_inf`` at points (3, ...) outside the vesicle: the boundary-integral
    representation ``-N[f]/(8 pi) + (1 - lam) K[u]/(8 pi)`` evaluated off the surface."""
    out = -evaluate_single_layer(shape, force, points) / (8.0 * np.pi)
    if lam != 1.0:
        out += (1.0 - lam) / (8.0 * np.pi) * evaluate_double_layer(shape, u, points)
    return out


def far_field_stresslet(
    shape: Shape,
    force: np.ndarray,
    u: np.ndarray,
    lam: float,
    radius: float,
    directions: int = 48,
    seed: int = 0,
) -> np.ndarray:
    """The stresslet read off the disturbance velocity at distance ``radius``: an independent
    measure of the particle stress (SPEC §11) through the far field.

    A force- and torque-free particle disturbs the flow like ``u'_i = -(3 / 8 pi) x_i (x . S .
    x) / r^5 + O(r^-4)`` about its centroid, where ``S`` is the symmetric traceless part of
    ``Omega sigma^p = int [f] x dA + (lam - 1) int (u n + n u) dA`` (Batchelor 1970; a rigid
    sphere in a strain ``E`` gives ``S = 20 pi E / 3``).  ``u'`` is evaluated on ``directions``
    antipodal pairs (random, reproducible by ``seed``); the odd part of each pair removes the
    even multipoles (Stokeslet, quadrupole), and ``S`` and a rotlet are fitted by least squares.
    The octupole left over biases ``S`` by O(r^-2): extrapolate from two radii.

    Returns ``S`` (3, 3), in the units of ``ParticleStress.per_volume_fraction * V``.
    """
    d = np.random.default_rng(seed).standard_normal((3, directions))
    d /= np.linalg.norm(d, axis=0)
    c = shape.centroid[:, None]
    plus = disturbance_velocity(shape, force, u, lam, c + radius * d)
    minus = disturbance_velocity(shape, force, u, lam, c - radius * d)
    odd = 0.5 * (plus - minus) * radius**2
    pairs = ((0, 0), (1, 1), (0, 1), (0, 2), (1, 2))
    tensors = []
    for a, b in pairs:  # a basis of symmetric traceless tensors
        B = np.zeros((3, 3))
        B[a, b] = B[b, a] = 1.0
        if a == b:
            B[2, 2] = -1.0
        tensors.append(B)
    columns = [-3.0 / (8.0 * np.pi) * d * np.einsum("ik,ij,jk->k", d, B, d) for B in tensors]
    columns += [np.cross(e, d, axis=0) for e in np.eye(3)]  # rotlet: numerical torque
    A = np.stack([col.ravel() for col in columns], axis=1)
    coef = np.linalg.lstsq(A, odd.ravel(), rcond=None)[0]
    return sum(x * B for x, B in zip(coef[:5], tensors, strict=True))
