"""The boundary-integral system of the vesicle (SPEC §5–6, §17), written once.

For a membrane velocity ``u`` and tension ``sigma`` on the surface,

    (1 + lam)/2 u - (1 - lam)/(8 pi) K u + N[f_sigma(sigma) + f_eta(u)]/(8 pi)
                                                               = u_inf - N[f_B]/(8 pi)
    div_s u = 0

with ``N`` the single layer, ``K`` the double layer (principal value), ``f_B`` the bending,
``f_sigma = -2 H sigma n - grad_s sigma`` the tension traction (SPEC §4) and
``f_eta = -2 Bq div_s D_s(u)`` the membrane's viscous load (SPEC §17,
:func:`vesicle.model.membrane.viscous_force`).  In block form ``A_uu u + A_us sigma = b_u``,
``A_su u = 0`` with

    A_uu = alpha I - c K + Bq N V / (8 pi),   alpha = (1 + lam)/2,   c = (1 - lam)/(8 pi),
    A_us sigma = N[f_sigma(sigma)]/(8 pi),   b_u = u_inf - N[f_B]/(8 pi),

``V u = -2 div_s D_s(u)`` (the viscous load at ``Bq = 1``).  ``A_uu`` is the identity only when
``lam = 1`` and ``Bq = 0``.

Every solver builds on this one object: the GMRES velocity–tension solve
(:class:`vesicle.solve.solver.VelocityTensionSolver`), the factorised system and its Woodbury solve
(:mod:`vesicle.solve.factorised`), the linearised Jacobian (:mod:`vesicle.solve.linearisation`) and
the
steady problem's choice of kernels (:mod:`vesicle.steady.problem`).  A new membrane term (membrane
viscosity: a traction linear in ``u``) is one more term here and its linearisation.

The arithmetic is kept as the solvers had it (``N[f] / (8 pi)`` divides, ``alpha u - c K u``
multiplies), so that every number is bit-identical to the code before (tests/test_golden.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.model.membrane import viscous_force
from vesicle.model.parameters import Physics

__all__ = ["Formulation"]

#: ``8 pi mu`` with ``mu = 1``: the single layer's Green's function factor (SPEC §5).
EIGHT_PI = 8.0 * np.pi


@dataclass(frozen=True)
class Formulation:
    """The blocks of the boundary-integral system at viscosity ratio ``lam`` and Boussinesq
    number ``bq`` (module notes)."""

    lam: float
    bq: float = 0.0

    @classmethod
    def of(cls, physics: Physics) -> Formulation:
        return cls(float(physics.lam), float(physics.bq))

    @property
    def viscous(self) -> bool:
        """Whether the membrane has a viscosity (``Bq > 0``)."""
        return self.bq != 0.0

    @property
    def identity_uu(self) -> bool:
        """Whether ``A_uu`` is the identity (``lam = 1``, ``Bq = 0``): no inner solve."""
        return self.lam == 1.0 and not self.viscous

    @property
    def kernels(self) -> tuple[str, ...]:
        """The layer potentials the system needs: no double layer at ``lam = 1``."""
        return ("single",) if self.lam == 1.0 else ("single", "double")

    @property
    def alpha(self) -> float:
        """The identity's coefficient in ``A_uu``: ``(1 + lam)/2``."""
        return 0.5 * (1.0 + self.lam)

    @property
    def c(self) -> float:
        """The double layer's coefficient in ``A_uu``: ``(1 - lam)/(8 pi)``."""
        return (1.0 - self.lam) / EIGHT_PI

    def A_uu(
        self,
        u: np.ndarray,
        double_layer: Callable[[np.ndarray], np.ndarray],
        single_layer: Callable[[np.ndarray], np.ndarray] | None = None,
        shape: Shape | None = None,
    ) -> np.ndarray:
        """``alpha u - c K u + Bq N[V u]/(8 pi)`` (``u`` itself at ``lam = 1``, ``Bq = 0``);
        the membrane term needs the ``single_layer`` and the ``shape``."""
        out = u if self.lam == 1.0 else self.alpha * u - self.c * double_layer(u)
        if self.viscous:
            out = out + self.traction_velocity(single_layer(self.viscous_load(shape, u)))
        return out

    def viscous_load(self, shape: Shape, u: np.ndarray) -> np.ndarray:
        """The membrane's viscous load ``f_eta = Bq V u`` of velocities (..., 3, nt, np)
        (zero at ``Bq = 0``)."""
        if not self.viscous:
            return np.zeros_like(u)
        return viscous_force(shape, u, self.bq)

    @staticmethod
    def traction_velocity(single_layer_of_traction: np.ndarray) -> np.ndarray:
        """The velocity ``N[f]/(8 pi)`` of a traction jump ``f`` given ``N[f]``."""
        return single_layer_of_traction / EIGHT_PI

    def shape_derivative(
        self, dN: np.ndarray, du_inf: np.ndarray, dK: np.ndarray | None
    ) -> np.ndarray:
        """The derivative of the residual ``A_uu u + N[f]/(8 pi) - u_inf`` along a shape change,
        at fixed ``u`` and ``sigma``: ``dN/(8 pi) - du_inf - c dK`` (``dN`` the change of the
        single layer of the traction, with the traction's own change; ``dK`` that of ``K u``)."""
        dG = self.traction_velocity(dN) - du_inf
        if dK is not None:
            dG -= self.c * dK
        return dG
