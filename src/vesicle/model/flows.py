"""Background flows: linear flows ``u_inf = chi G x`` with a traceless velocity gradient ``G``.

In the units of SPEC §1 the simple shear is ``u_inf = (chi z, 0, 0)``: x the flow direction,
z the gradient direction, y the vorticity direction.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FLOWS", "LinearFlow"]


@dataclass(frozen=True)
class LinearFlow:
    """``u_inf(x) = chi * gradient @ x`` for a traceless 3x3 ``gradient`` (unit strength).

    Parameters
    ----------
    gradient : array_like (3, 3)
        ``G_ij = d u_i / d x_j`` for ``chi = 1``; must be finite and traceless (incompressible).
    name : str
        A label stored in output files.
    """

    gradient: tuple = field(default=((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    name: str = "shear"

    def __post_init__(self) -> None:
        G = np.asarray(self.gradient, dtype=float)
        if G.shape != (3, 3):
            raise ValueError(f"a linear flow needs a 3x3 velocity gradient, got shape {G.shape}")
        if not np.all(np.isfinite(G)):
            raise ValueError("the velocity gradient contains NaN or infinity")
        scale = max(np.abs(G).max(), 1.0)
        if abs(np.trace(G)) > 1e-12 * scale:
            raise ValueError(
                f"the velocity gradient must be traceless (incompressible), trace = {np.trace(G):g}"
            )
        object.__setattr__(self, "gradient", tuple(map(tuple, G.tolist())))

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.gradient)

    @property
    def is_zero(self) -> bool:
        return not np.any(self.matrix)

    def velocity(self, x: np.ndarray, chi: float = 1.0) -> np.ndarray:
        """``chi G x`` for points ``x`` of shape (3, ...)."""
        return chi * np.einsum("ij,j...->i...", self.matrix, x)

    @property
    def rate_of_strain(self) -> np.ndarray:
        G = self.matrix
        return 0.5 * (G + G.T)

    @property
    def vorticity(self) -> np.ndarray:
        """Angular velocity of the rigid-rotation part (half the vorticity vector)."""
        W = 0.5 * (self.matrix - self.matrix.T)
        return np.array([W[2, 1], W[0, 2], W[1, 0]])

    @classmethod
    def shear(cls) -> LinearFlow:
        """Simple shear ``(z, 0, 0)``."""
        return cls()

    @classmethod
    def planar_extension(cls) -> LinearFlow:
        """Planar extension ``(x, 0, -z)`` in the x-z plane."""
        return cls(((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)), "planar-extension")

    @classmethod
    def rotation(cls) -> LinearFlow:
        """Rigid rotation about y with the vorticity of the unit shear: ``(z, 0, -x)/2``."""
        return cls(((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), (-0.5, 0.0, 0.0)), "rotation")

    @classmethod
    def none(cls) -> LinearFlow:
        """No background flow (relaxation at rest)."""
        return cls(((0.0,) * 3,) * 3, "none")


FLOWS = {
    "shear": LinearFlow.shear,
    "planar-extension": LinearFlow.planar_extension,
    "rotation": LinearFlow.rotation,
    "none": LinearFlow.none,
}
