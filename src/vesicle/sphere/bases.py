"""Real bases of spherical-harmonic series (SPEC §8, §9, (2.1)).

In the complex convention of :mod:`.transforms`, a real field has coefficients ``c_lm`` for
``m >= 0``; a cosine coefficient of ``Pbar_lm cos(m phi)`` is ``w_m Re c_lm`` and a sine
coefficient of ``Pbar_lm sin(m phi)`` is ``-w_m Im c_lm`` (``w_0 = 1``, ``w_m = 2``).
"""

from __future__ import annotations

import numpy as np

from vesicle.sphere.grid import SphereGrid
from vesicle.sphere.transforms import transform

__all__ = ["BASES", "FullBasis", "RealBasis", "SymmetricBasis", "basis"]


class RealBasis:
    """Real coefficients of ``Pbar_lm cos(m phi)`` (part 0) and ``Pbar_lm sin(m phi)`` (part 1)."""

    #: The name of the basis in :data:`BASES` (subclasses set it).
    kind = "real"

    def __init__(self, degree: int, index: list[tuple[int, int, int]]):
        self.degree = degree
        self.index = index
        self.l = np.array([i[0] for i in index])
        self.m = np.array([i[1] for i in index])
        self.part = np.array([i[2] for i in index])
        self.weight = np.where(self.m == 0, 1.0, 2.0)

    @property
    def size(self) -> int:
        return len(self.index)

    def to_coefficients(self, a: np.ndarray) -> np.ndarray:
        c = np.zeros((self.degree + 1, self.degree + 1), dtype=complex)
        a = np.asarray(a, float) / self.weight
        cos, sin = self.part == 0, self.part == 1
        c[self.l[cos], self.m[cos]] += a[cos]
        c[self.l[sin], self.m[sin]] -= 1j * a[sin]
        return c

    def from_coefficients(self, c: np.ndarray) -> np.ndarray:
        """Project coefficients (any symmetry) onto the basis."""
        c = np.asarray(c)[self.l, self.m]
        return self.weight * np.where(self.part == 0, c.real, -c.imag)

    def functions(self, grid: SphereGrid) -> np.ndarray:
        """The basis functions on a grid, (size, n_theta, n_phi)."""
        T = transform(grid.n_theta, self.degree)
        return T.synthesis(np.stack([self.to_coefficients(e) for e in np.eye(self.size)]))


class SymmetricBasis(RealBasis):
    """``a_lm`` (l even, 0 <= m <= l) of ``Pbar_lm cos(m phi)``: shapes symmetric under inversion
    through the origin and ``y -> -y`` (SPEC §8)."""

    kind = "symmetric"

    def __init__(self, degree: int):
        if degree < 2:
            raise ValueError(f"the symmetric basis needs degree >= 2, got {degree}")
        super().__init__(degree, [(l, m, 0) for l in range(0, degree + 1, 2) for m in range(l + 1)])


class FullBasis(RealBasis):
    """The full real basis (2.1): all degrees, cosine and sine parts."""

    kind = "general"

    def __init__(self, degree: int):
        cos = [(l, m, 0) for l in range(degree + 1) for m in range(l + 1)]
        sin = [(l, m, 1) for l in range(degree + 1) for m in range(1, l + 1)]
        super().__init__(degree, cos + sin)


#: Bases by the name of the perturbations they span (``modes=`` in the stability analysis).
BASES = {"symmetric": SymmetricBasis, "general": FullBasis}


def basis(kind: str, degree: int) -> RealBasis:
    """The basis ``kind`` (a key of :data:`BASES`) of ``degree``."""
    if kind not in BASES:
        raise ValueError(f"modes must be one of {sorted(BASES)}, got {kind!r}")
    return BASES[kind](degree)
