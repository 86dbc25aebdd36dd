"""Gauss–Legendre x uniform grids on the unit sphere."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["SphereGrid"]


@dataclass(frozen=True)
class SphereGrid:
    """``n_theta`` Gauss–Legendre nodes in ``cos theta`` x ``n_phi = 2 n_theta`` uniform ``phi``.

    The nodes run from the north pole southwards (``theta`` increasing); ``phi_j = 2 pi j / n_phi``.
    The grid holds spherical harmonics up to degree ``n_theta - 1`` exactly: transforms are exact
    for band-limited fields of that degree, and the quadrature is exact for degree
    ``2 n_theta - 1``.
    """

    n_theta: int

    def __post_init__(self) -> None:
        n = self.n_theta
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"grid needs an integer n_theta >= 2, got {n!r}")

    @property
    def n_phi(self) -> int:
        return 2 * self.n_theta

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n_theta, self.n_phi)

    @property
    def max_degree(self) -> int:
        """Highest spherical-harmonic degree the grid resolves."""
        return self.n_theta - 1

    @cached_property
    def _gauss(self) -> tuple[np.ndarray, np.ndarray]:
        x, w = np.polynomial.legendre.leggauss(self.n_theta)
        # North pole first: theta increasing.
        return x[::-1].copy(), w[::-1].copy()

    @property
    def cos_theta(self) -> np.ndarray:
        return self._gauss[0]

    @property
    def gauss_weights(self) -> np.ndarray:
        """Gauss–Legendre weights in ``cos theta`` (they sum to 2)."""
        return self._gauss[1]

    @cached_property
    def theta(self) -> np.ndarray:
        return np.arccos(self.cos_theta)

    @cached_property
    def phi(self) -> np.ndarray:
        return 2.0 * np.pi * np.arange(self.n_phi) / self.n_phi

    @cached_property
    def weights(self) -> np.ndarray:
        """Quadrature weights on the unit sphere, shape (n_theta, n_phi); they sum to 4 pi.

        ``int f dOmega ~= sum(weights * f)``; on a surface ``int f dA = sum(weights * J * f)``
        with ``J = sqrt(g) / sin(theta)``.
        """
        w = np.outer(self.gauss_weights, np.full(self.n_phi, 2.0 * np.pi / self.n_phi))
        w.setflags(write=False)
        return w

    @cached_property
    def unit_vectors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(e_r, e_theta, e_phi)`` on the grid, each of shape (3, n_theta, n_phi)."""
        return spherical_basis(self.theta[:, None], self.phi[None, :])

    def meshgrid(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta`` and ``phi`` as (n_theta, n_phi) arrays."""
        return np.meshgrid(self.theta, self.phi, indexing="ij")


def spherical_basis(
    theta: np.ndarray, phi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors ``e_r, e_theta, e_phi`` (leading axis of length 3) at broadcast angles."""
    theta, phi = np.broadcast_arrays(theta, phi)
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    e_r = np.stack([st * cp, st * sp, ct])
    e_t = np.stack([ct * cp, ct * sp, -st])
    e_p = np.stack([-sp, cp, np.zeros_like(theta)])
    return e_r, e_t, e_p
