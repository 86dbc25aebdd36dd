"""Two-parameter continuation of fold and Hopf curves, with their codim-2 points (issue 40).

A generic core that knows nothing about vesicles.  The system is

.. math::  B \\dot x = F(x, p), \\qquad x \\in R^n,\\ p \\in R^2,

with a constant, possibly singular, mass matrix ``B`` (a DAE: the vesicle has
``x = (a, mu)`` and ``B = diag(I, 0)``).  Its equilibria are stable when every finite
eigenvalue ``s`` of the pencil ``J v = s B v`` (``J = F_x``) has a negative real part.

* a **fold** (saddle-node) point is an equilibrium with ``J`` singular;
* a **Hopf** point is an equilibrium with ``J - i omega B`` singular for some ``omega > 0``;
* a **Bogdanov-Takens** (BT) point is a double zero of the pencil with one eigenvector
  (``J q0 = 0``, ``J q1 = B q0``), where the fold curve ends the Hopf curve (``omega -> 0``);
* a **cusp** is a fold point where the fold normal-form coefficient
  ``a = 1/2 w^T F_xx(v, v)`` vanishes: the fold curve's projection on the parameter plane
  turns back there.

Fold and Hopf curves are continued in ``(x, p)`` (and ``omega``) by pseudo-arclength, defined
by minimally augmented systems (Govaerts 2000): ``F = 0`` plus one real (fold) or one complex
(Hopf) test function from a bordered linear system, so that the unknowns are only ``(x, p)``
or ``(x, p, omega)``.  Every Newton step is the full Newton step of the augmented system
(quadratic convergence up to the 1e-8 error of the differences that stand in for second
derivatives) yet asks the problem for second derivatives only along two or three directions
per iteration (see :func:`_newton_step`), which is what matters when one residual or Jacobian
costs a second.
The standard extended systems (the null vector ``q`` as unknowns) are implemented too
(``Settings(method="extended")``) for comparison; docs/reference/codim2.md gives the measurements.

Public API: :class:`Problem` (what a problem provides), :class:`Settings`,
:func:`locate_fold`, :func:`locate_hopf`, :func:`locate_bt` (from a point near one: the start
of every curve), :func:`fold_curve`, :func:`hopf_curve` (also from a BT point: the switch fold
-> Hopf), the frozen results :class:`CurvePoint`, :class:`SpecialPoint`, :class:`Curve`,
:class:`Evaluations`, and the helpers :func:`finite_eigenvalues`,
:func:`fd_parameter_derivative`, :func:`fd_jacobian_action_derivative`.

The package's modules, in the order they build on each other: ``core`` (the problem interface,
its evaluations, finite differences), ``results`` (settings, curve and special points),
``linalg`` (pencil eigenvalues, bordered systems), ``systems`` (the defining systems and their
Newton corrector), ``locate`` (a point's analysis; fold, Hopf, BT points from a nearby state),
``curves`` (fold and Hopf curves).

May import: :mod:`numpy`, :mod:`scipy` only (a generic core: nothing of the vesicle).
"""

from __future__ import annotations

from vesicle.bifurcation.codim2.core import (
    FD_STEP,
    Evaluations,
    Problem,
    fd_jacobian_action_derivative,
    fd_parameter_derivative,
)
from vesicle.bifurcation.codim2.curves import (
    fold_curve,
    hopf_curve,
)
from vesicle.bifurcation.codim2.linalg import (
    finite_eigenvalues,
)
from vesicle.bifurcation.codim2.locate import (
    locate_bt,
    locate_fold,
    locate_hopf,
)
from vesicle.bifurcation.codim2.results import (
    Curve,
    CurvePoint,
    Settings,
    SpecialPoint,
)

__all__ = [
    "FD_STEP",
    "Curve",
    "CurvePoint",
    "Evaluations",
    "Problem",
    "Settings",
    "SpecialPoint",
    "fd_jacobian_action_derivative",
    "fd_parameter_derivative",
    "finite_eigenvalues",
    "fold_curve",
    "hopf_curve",
    "locate_bt",
    "locate_fold",
    "locate_hopf",
]
