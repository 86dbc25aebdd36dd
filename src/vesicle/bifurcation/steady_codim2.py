"""The steady tank-treading equations as a two-parameter problem of :mod:`.codim2`, and the
neutral curve traced on it: the Hopf curve and the fold curve of the steady states in the
``(chi, lambda)`` plane at fixed ``v``, joined at their Bogdanov–Takens point (issue 40).

The problem
-----------
Unknowns ``x = (a, mu)``: the shape's basis coordinates and the two multipliers of the area and
volume constraints (SPEC §8); parameters ``p = (log chi, lambda)`` (the log keeps both O(1)
for the continuation's unit weights).  The residual is the steady problem's
``G = (adot(a) - mu . g, A - A0, V - V0)`` and its Jacobian the Newton matrix

    G_y = [[M - mu . H, -g^T], [g, 0]]

(``M = d adot / d a`` linearised, ``g`` the constraint gradients, ``H`` their Hessians), with
the mass matrix ``B = diag(I, 0, 0)``: the finite eigenvalues of the pencil ``(G_y, B)`` are the
growth rates of the linearised dynamics held on the constraints (the ``curvature=True`` form of
:func:`vesicle.steady.stability.stability`).  A fold of this system is where the branch of steady
states turns; a Hopf point where a complex pair of that pencil crosses the axis.

SPEC §9's stability operator ``Q^T M Q`` leaves out the multipliers' curvature ``mu . H``; the
two forms differ by the state's ``curvature_shift`` (1.5e-3 in the growth rate at N = 8, 5.8e-3
at N = 4 at Table 1's state), which vanishes with the resolution.  The neutral curve here is that
of the system whose fold is the branch's turning point; see docs/reference/codim2.md.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from vesicle.bifurcation import codim2
from vesicle.geometry.surface import ShapeError
from vesicle.model.parameters import Discretisation, Physics
from vesicle.solve.solver import SolverError
from vesicle.steady.newton import NEWTON_TOLERANCES, SteadyResult
from vesicle.steady.problem import SteadyProblem

__all__ = [
    "ACTIONS",
    "FORMS",
    "PLANE_PARAMETERS",
    "SteadyEquations",
    "TypeChange",
    "locate_type_change",
    "trace_from_hopf",
]

#: The Jacobian the curves are defined by: ``"curvature"``, the Newton matrix with the
#: multipliers' curvature (its fold is exactly where the branch of steady states turns), or
#: ``"spec"``, SPEC §9's operator without it (``Q^T M Q`` on the constraints' tangent space:
#: what ``vesicle critical`` and the one-parameter tracer bracket).  With ``"spec"`` Newton on
#: ``G = 0`` runs on a Jacobian off by ``mu . H`` (small: its convergence is linear with that
#: rate) and the fold curve is that of the real crossings of SPEC §9's operator.
FORMS = ("curvature", "spec")

#: How Newton's matrices get the derivative of the Jacobian along a direction: ``"linearised"``,
#: Jacobian-vector products at the moved point from the linearisation along the vectors only
#: (:meth:`SteadyEquations.newton_action_derivative`), or ``"jacobians"``, differences of
#: whole Jacobians (the reference, the core's default).
ACTIONS = ("linearised", "jacobians")

#: Relative step of :meth:`SteadyEquations.newton_action_derivative`'s forward difference.
ACTION_STEP = 1e-5

#: The Jacobians of the last this many points are kept (a few kB each: 27 x 27 at N = 8 in
#: the symmetric basis), so that a point's report does not compute its Jacobian again.
KEPT_JACOBIANS = 256

#: How ``G_p`` is formed: ``"exact"``, the system differentiated in its parameters
#: (:meth:`SteadyEquations.parameter_derivative`), or ``"differences"`` of residuals (the
#: reference, and what the continuation does for a problem without the hook).
PARAMETER_DERIVATIVES = ("exact", "differences")

log = logging.getLogger(__name__)


#: The planes the steady equations are continued in: two of ``chi`` (continued in ``log chi``),
#: ``lam`` and ``bq`` (the Boussinesq number of the membrane's viscosity, issue 42), in order.
PLANE_PARAMETERS = ("chi", "lam", "bq")

#: A Boussinesq number this far below 0 is rounding (a direction's p component of 1e-18 times a
#: step) and is taken as 0; further below, the physics has none: the differences of the Newton
#: matrices at ``Bq = 0`` then take their one-sided form on the side of ``Bq >= 0``.
BQ_ROUNDING = 1e-12


def _inputs(x, p) -> tuple[np.ndarray, np.ndarray]:
    """A point's inputs as the memo's keys see them (float64)."""
    return np.asarray(x, float), np.asarray(p, float)


class SteadyEquations(codim2.Problem):
    """The steady equations at fixed ``v`` (and flow) as a :class:`codim2.Problem` in
    ``p = (log chi, lambda)`` (the default ``plane=("chi", "lam")``), or in another plane of
    two of :data:`PLANE_PARAMETERS`: ``plane=("bq", "lam")`` continues in ``p = (Bq, lambda)``
    at fixed ``chi`` (the curves of a viscous membrane, issue 42).  The other parameters are
    those of ``physics``.

    Each parameter point gets one :class:`SteadyProblem`, kept while the continuation stays
    there, so that a residual and the Jacobian at the same point share one assembly of the
    layer potentials (the problem keeps those of its last shape).

    With :attr:`memo` set, each evaluation (residual, Jacobian, parameter derivative, Jacobian
    action) is looked up there by its inputs first and kept there when computed: a curve run
    again with the memo of an interrupted run replays its evaluations and computes from where
    it stopped (:mod:`vesicle.io.memo`)."""

    def __init__(
        self,
        physics: Physics,
        discretisation: Discretisation,
        *,
        modes: str = "symmetric",
        jacobian: str = "linearised",
        form: str = "curvature",
        actions: str = "linearised",
        parameter_derivatives: str = "exact",
        reuse_factorisation: bool = True,
        plane: tuple[str, str] = ("chi", "lam"),
    ):
        plane = tuple(plane)
        if len(plane) != 2 or plane[0] == plane[1] or \
                any(q not in PLANE_PARAMETERS for q in plane):  # fmt: skip
            raise ValueError(f"plane must be two different names of {PLANE_PARAMETERS}, "
                             f"got {plane!r}")  # fmt: skip
        self.plane = plane
        if form not in FORMS:
            raise ValueError(f"form must be one of {FORMS}, got {form!r}")
        if actions not in ACTIONS:
            raise ValueError(f"actions must be one of {ACTIONS}, got {actions!r}")
        if parameter_derivatives not in PARAMETER_DERIVATIVES:
            raise ValueError(f"parameter_derivatives must be one of {PARAMETER_DERIVATIVES}, "
                             f"got {parameter_derivatives!r}")  # fmt: skip
        self.newton_actions = actions == "linearised"
        self.exact_parameter_derivative = parameter_derivatives == "exact"
        self.reuse_factorisation = bool(reuse_factorisation)
        self.physics, self.discretisation = physics, discretisation
        self.modes, self.jacobian_method, self.form = modes, jacobian, form
        self._kept: tuple[tuple[float, float], SteadyProblem] | None = None
        self._jacobians: OrderedDict[tuple, np.ndarray] = OrderedDict()
        self._sigma = None
        #: an :class:`~vesicle.io.memo.EvaluationMemo` where the residuals, Jacobians, parameter
        #: derivatives and Jacobian actions are kept and looked up (a curve that resumes by
        #: replaying them); None: none kept
        self.memo = None
        probe = self.problem_at(self.coordinates(physics))
        self.size = probe.basis.size
        mass = np.eye(self.size + 2)
        mass[-2:, -2:] = 0.0
        if probe.rate_weights is not None:  # the rates weighed (multipliers along L2 gradients)
            mass[: self.size, : self.size] = np.diag(probe.rate_weights)
        self.mass = mass
        # the translations (degree 1) of the general basis: neutral modes that the dynamics'
        # re-centring removes, excluded from the spectrum as in vesicle.steady.stability
        self.translations = (np.flatnonzero(probe.basis.l == 1) if modes == "general"
                             else np.zeros(0, int))  # fmt: skip

    def spectrum_pencil(self, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pencil whose finite eigenvalues the spectrum check and the reports use: ``(J,
        B)`` with, in the general basis, the translations held fixed by three more algebraic
        rows (and their multipliers), as the area and volume are; its finite eigenvalues are
        those of :func:`vesicle.steady.stability.stability` (``Q^T J Q`` on perturbations that
        keep A, V and the centre).  Measured on the vorticity branch at v = 0.95, N = 8 on
        32x64, chi = 4, lambda = 14.39: the translations' eigenvalues of ``(J, B)`` are
        +0.0206, +0.00065 and -0.0199 (from the shape's radial representation about the
        origin; zero in the continuous problem), which made every point of its Hopf curve look
        as if another eigenvalue were unstable."""
        k = self.translations.size
        if k == 0:
            return J, self.mass
        n = J.shape[0]
        C = np.zeros((k, n))
        C[np.arange(k), self.translations] = 1.0
        A = np.block([[J, -C.T], [C, np.zeros((k, k))]])
        B = np.zeros((n + k, n + k))
        B[:n, :n] = self.mass
        return A, B

    # ------------------------------------------------------------------ points
    def coordinates(self, physics: Physics) -> np.ndarray:
        """The continuation's ``p`` of ``physics`` (``log chi`` for ``chi``)."""
        return np.array([math.log(physics.chi) if q == "chi" else float(getattr(physics, q))
                         for q in self.plane])  # fmt: skip

    def physics_at(self, p) -> Physics:
        values = {q: float(math.exp(x)) if q == "chi" else float(x)
                  for q, x in zip(self.plane, p, strict=True)}  # fmt: skip
        if "bq" in values and -BQ_ROUNDING <= values["bq"] < 0.0:
            values["bq"] = 0.0
        return self.physics.replace(**values)

    def problem_at(self, p) -> SteadyProblem:
        key = (float(p[0]), float(p[1]))
        if self._kept is None or self._kept[0] != key:
            problem = SteadyProblem(self.physics_at(key), self.discretisation, NEWTON_TOLERANCES,
                                    modes=self.modes, jacobian_method=self.jacobian_method,
                                    reuse_factorisation=self.reuse_factorisation)  # fmt: skip
            if self._kept is not None:  # its shape's operators and preconditioner
                problem.adopt(self._kept[1])
            self._kept = (key, problem)
        return self._kept[1]

    def state(self, steady: SteadyResult) -> tuple[np.ndarray, np.ndarray]:
        """``(x, p)`` of a converged steady state (its shape's coordinates in this problem's
        basis: a state found in the symmetric basis is taken into the general one)."""
        p = self.coordinates(steady.physics)
        a = np.asarray(steady.a, float)
        basis = self.problem_at(p).basis
        if a.size != basis.size:
            a = self.problem_at(p).coefficients_of(steady.shape)
        return np.concatenate([a, steady.multipliers]), p

    # --------------------------------------------------------------- equations
    def _outside(self, p) -> bool:
        """Parameters no physics has (lambda <= 0, Bq < 0, or not finite): a corrector's wild
        iterate."""
        if not np.all(np.isfinite(p)):
            return True
        values = dict(zip(self.plane, p, strict=True))
        return values.get("lam", 1.0) <= 0 or values.get("bq", 0.0) < -BQ_ROUNDING

    def residual(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``G(x, p)``; NaN where the shape cannot be represented or solved for, or ``lambda``
        is not positive (a corrector's wild iterate: the continuation refuses the step and
        halves it; at v = 0.85, N = 8 an iterate at lambda = -27.7 ended a fold curve)."""
        if self._outside(p):
            return np.full(np.asarray(x).size, np.nan)
        if self.memo is not None:
            return self.memo.cached("residual", lambda: self._residual(x, p), *_inputs(x, p))
        return self._residual(x, p)

    def _residual(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        P = self.problem_at(p)
        a, mu = np.asarray(x[:-2], float), np.asarray(x[-2:], float)
        try:
            shape = P.shape(a)
            rate, flow = P.adot(a, self._sigma)
        except (ShapeError, SolverError) as err:
            log.debug("residual at p = %s: %s", p, err)
            return np.full(a.size + 2, np.nan)
        self._sigma = flow.sigma
        G, _ = P.residual(shape, rate, mu, P.gradients(shape))
        return G

    def jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``G_y(x, p)``; NaN where the shape cannot be represented or solved for, or ``lambda``
        is not positive."""
        if self._outside(p):
            return np.full((x.size, x.size), np.nan)
        try:
            return self._jacobian(x, p)
        except (ShapeError, SolverError) as err:  # (kept by the memo as NaN: replayed so)
            log.debug("Jacobian at p = %s: %s", p, err)
            return np.full((x.size, x.size), np.nan)

    def _jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        key = self._point_key(x, p)
        if key in self._jacobians:  # a point's Jacobian asked for again (its report, a
            self._jacobians.move_to_end(key)  # located point's neighbour): not recomputed
            J = self._jacobians[key].copy()
            self._last_jacobian = (key, J)
            return J
        if self.memo is not None:
            J = self._memoised("jacobian", "Jacobian", lambda: self._computed_jacobian(x, p),
                               (x.size, x.size), (ShapeError, SolverError), x, p)  # fmt: skip
            self._keep_jacobian(key, J)
            return J.copy()
        return self._computed_jacobian(x, p)

    def _memoised(self, name: str, what: str, compute, shape: tuple, failures: tuple, x, p,
                  *more) -> np.ndarray:  # fmt: skip
        """``compute()`` looked up in :attr:`memo` first under ``name`` and the point's inputs
        (and ``more``), kept when computed.  A failure (``failures``) is kept as NaN of
        ``shape``, so that a resumed curve meets the same failure at the same point (the
        solver's state then may differ), and raised again as a ``SolverError`` when replayed."""

        def or_nan() -> np.ndarray:
            try:
                return compute()
            except failures as err:
                log.debug("%s at p = %s: %s", what, p, err)
                return np.full(shape, np.nan)

        out = self.memo.cached(name, or_nan, *_inputs(x, p), *more)
        if out.size and np.all(np.isnan(out)):  # a failure, replayed
            raise SolverError(f"the {what} failed here when it was computed (replayed)")
        return out

    def _computed_jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        key = self._point_key(x, p)
        P = self.problem_at(p)
        a, mu = np.asarray(x[:-2], float), np.asarray(x[-2:], float)
        M, _ = P.jacobian(a, sigma0=self._sigma)
        g = P.gradients(P.shape(a))
        H = P.constraint_hessians(a) if self.form == "curvature" else None
        n = M.shape[0]
        J = np.zeros((n + 2, n + 2))
        J[:n, :n] = M - np.einsum("k,kij->ij", mu, H) if self.form == "curvature" else M
        J[:n, n:], J[n:, :n] = -g.T, g
        self._keep_jacobian(key, J)
        return J

    def _keep_jacobian(self, key: tuple, J: np.ndarray) -> None:
        self._last_jacobian = (key, J)
        self._jacobians[key] = J.copy()
        while len(self._jacobians) > KEPT_JACOBIANS:
            self._jacobians.popitem(last=False)

    def parameter_derivative(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``G_p`` in the plane's ``p`` (e.g. ``(log chi, lambda)``): the velocity-tension
        system differentiated in its parameters
        (:meth:`~vesicle.steady.problem.SteadyProblem.parameter_rates`; two solves with the
        factorised system of the same point's Jacobian) instead of two or four residuals at
        moved parameters.  The constraint rows do not depend on ``p``.  With
        ``parameter_derivatives="differences"`` (the reference) the continuation differences
        residuals instead.  NaN where the shape cannot be represented or a solve fails."""
        if self._outside(p):
            return np.full((x.size, 2), np.nan)
        if self.memo is not None:
            return self.memo.cached("parameter_derivative",
                                    lambda: self._parameter_derivative(x, p), *_inputs(x, p))
        return self._parameter_derivative(x, p)

    def _parameter_derivative(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        P = self.problem_at(p)
        m = x.size - 2
        out = np.zeros((x.size, 2))
        try:
            out[:m] = P.parameter_rates(np.asarray(x[:m], float), self.plane)
        except (ShapeError, SolverError, ValueError) as err:
            log.debug("parameter derivative at p = %s: %s", p, err)
            return np.full((x.size, 2), np.nan)
        return out

    def newton_action_derivative(self, x, p, q, direction, J=None) -> np.ndarray:
        """``d/dt [J(x + t dx, p + t dp)] q`` for Newton's matrices, without a factorisation.

        ``[J(y) q - J(x) q] / h`` with ``y = (x, p) + h d``: ``J(y) q`` from the linearisation
        of the velocity-tension solve along the columns of ``q`` only, its solves by GMRES
        preconditioned with the factorised system kept from ``J(x)``
        (:meth:`~vesicle.steady.problem.SteadyProblem.jacobian_action`); ``J(x) q`` from the
        caller's ``J`` (computed here the same way when not given).  At N = 8 on 32x64 it
        costs the layer potentials' assembly and ``1 + k`` GMRES solves instead of a
        factorisation and 25 shape derivatives.  Forward difference of step ``ACTION_STEP``
        relative: O(h) truncation and the solves' 1e-11 over ``h``, both far below what slows
        Newton.  NaN where the shape cannot be represented or a solve fails.
        """
        x, p = np.asarray(x, float), np.asarray(p, float)
        d = np.asarray(direction, float)
        q = np.asarray(q)
        Q = q.reshape(q.shape[0], -1)
        n = x.size
        size = float(np.max(np.abs(d)))
        if size == 0.0:
            return np.zeros(q.shape)
        h = ACTION_STEP * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(p)))) / size
        if self._outside(p + h * d[n:]) and not self._outside(p - h * d[n:]):
            h = -h  # at Bq = 0 moving to Bq < 0: the backward difference
        try:
            base = np.asarray(J, float) @ Q if J is not None else self._times(x, p, Q)
            out = (self._times(x + h * d[:n], p + h * d[n:], Q) - base) / h
        except (ShapeError, SolverError, ValueError) as err:
            log.debug("Newton action at p = %s: %s", p, err)
            return np.full(q.shape, np.nan)
        return out.reshape(q.shape)

    def jacobian_action_derivative(self, x, p, q, direction) -> np.ndarray:
        """``d/dt [J(x + t dx, p + t dp)] q`` for the test functions (the cusp coefficient):
        central differences of the linearisation along the columns of ``q`` only
        (:meth:`_times` at ``z +- h d``, ``h = eps^(1/3)`` relative, as the core's default),
        instead of central differences of two whole Jacobians.  Error: O(h^2) and the solves'
        1e-11 over ``h``, about 2e-6 relative.  With ``actions="jacobians"`` (the reference)
        the whole Jacobians' differences.  Where no factorised system is kept to precondition
        the solves, or a solve fails, the whole Jacobians' differences too."""
        if not self.newton_actions:
            return super().jacobian_action_derivative(x, p, q, direction)
        x, p = np.asarray(x, float), np.asarray(p, float)
        d = np.asarray(direction, float)
        q = np.asarray(q)
        size = float(np.max(np.abs(d)))
        if size == 0.0:
            return np.zeros(q.shape)
        n = x.size
        h = codim2.FD_STEP * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(p)))) / size
        Q = q.reshape(q.shape[0], -1)
        one_sided = [side for side in (1.0, -1.0) if self._outside(p + side * h * d[n:])]
        try:
            if len(one_sided) == 1:  # at Bq = 0, one side has Bq < 0: the other side's
                # one-sided difference (O(h), about 6e-6 relative: for Newton's matrices)
                g = -one_sided[0] * h
                return ((self._times(x + g * d[:n], p + g * d[n:], Q) - self._times(x, p, Q))
                        / g).reshape(q.shape)  # fmt: skip
            plus = self._times(x + h * d[:n], p + h * d[n:], Q)
            minus = self._times(x - h * d[:n], p - h * d[n:], Q)
        except (ShapeError, SolverError, ValueError) as err:
            log.debug("action derivative at p = %s: %s; whole Jacobians instead", p, err)
            return super().jacobian_action_derivative(x, p, q, direction)
        return ((plus - minus) / (2.0 * h)).reshape(q.shape)

    def _times(self, x: np.ndarray, p: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """``J(x, p) Q`` for a few columns (n, k), without forming ``J``."""
        if self._outside(p):
            raise ValueError(f"parameters outside the physics: {self.plane} = {tuple(p)}")
        if self.memo is not None:
            return self._memoised("times", "Jacobian action",
                                  lambda: self._computed_times(x, p, Q), (x.size, Q.shape[1]),
                                  (ShapeError, SolverError, ValueError), x, p,
                                  np.asarray(Q, float))  # fmt: skip
        return self._computed_times(x, p, Q)

    def _computed_times(self, x: np.ndarray, p: np.ndarray, Q: np.ndarray) -> np.ndarray:
        P = self.problem_at(p)
        m = x.size - 2
        if (self.memo is not None and P.jacobian_method == "linearised"
                and P.kept.system is None and P.kept.preconditioner is None):  # fmt: skip
            # the Jacobian was looked up (a resumed curve), so no factorised system is kept:
            # this shape's, to precondition the solves (as the Jacobian's was, when computed)
            P.factorise(P.shape(np.asarray(x[:m], float)))
        a, mu = x[:m], x[m:]
        g = P.gradients(P.shape(a))
        top = P.jacobian_action(a, Q[:m]) - g.T @ Q[m:]
        if self.form == "curvature":
            top -= np.einsum("k,kij->ij", mu, P.constraint_hessians(a)) @ Q[:m]
        return np.vstack([top, g @ Q[:m]])

    @staticmethod
    def _point_key(x: np.ndarray, p: np.ndarray) -> tuple:
        return (np.asarray(x, float).tobytes(), np.asarray(p, float).tobytes())

    def state_jacobian(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``G_y``, the exact derivative of the residual (with the multipliers' curvature
        ``- mu . H``), for the rows of ``G`` in Newton's matrices: with ``form="spec"`` the
        matrix :meth:`jacobian` returns is SPEC §9's operator, which is not; then Newton on
        the augmented systems converged only linearly, and next to a cusp (where the fold
        system's row along the null vector vanishes) not at all (v = 0.95, N = 4: correctors
        stuck at residuals of 1e-3 to 1e-5).  Reuses the Jacobian of the same point."""
        last = getattr(self, "_last_jacobian", None)
        J = last[1] if last is not None and last[0] == self._point_key(x, p) else \
            self.jacobian(x, p)  # fmt: skip
        if self.form == "curvature":
            return J
        try:
            a, mu = np.asarray(x[:-2], float), np.asarray(x[-2:], float)
            H = self.problem_at(p).constraint_hessians(a)
        except (ShapeError, SolverError):
            return np.full_like(J, np.nan)
        out = J.copy()
        n = a.size
        out[:n, :n] -= np.einsum("k,kij->ij", mu, H)
        return out


@dataclass(frozen=True)
class NeutralPointC2:
    """A point of the neutral curve solved for on its augmented system."""

    chi: float
    lambda_c: float
    bifurcation: str  # "hopf" or "saddle-node"
    omega_R: float
    located: bool
    residual: float
    other_unstable: bool

    def to_dict(self) -> dict:
        return {"chi": self.chi, "lambda_c": self.lambda_c, "bifurcation": self.bifurcation,
                "omega_R": self.omega_R, "located": self.located, "residual": self.residual,
                "other_unstable": self.other_unstable}  # fmt: skip


def curve_points(curve: codim2.Curve, kind: str) -> list[NeutralPointC2]:
    """The points of a fold or Hopf curve as neutral-curve points."""
    out = []
    for q in curve.points:
        omega = float(q.omega) if kind == "hopf" and q.omega is not None else 0.0
        out.append(NeutralPointC2(chi=float(math.exp(q.p[0])), lambda_c=float(q.p[1]),
                                  bifurcation=kind, omega_R=omega, located=bool(q.converged),
                                  residual=float(q.residual),
                                  other_unstable=bool(q.other_unstable)))  # fmt: skip
    return out


@dataclass
class Codim2Trace:
    """What :func:`trace_from_hopf` found: the Hopf curve, the fold curve, the special points."""

    hopf: list[codim2.Curve] = field(default_factory=list)
    fold: list[codim2.Curve] = field(default_factory=list)
    special: list[codim2.SpecialPoint] = field(default_factory=list)


def trace_from_hopf(
    equations: SteadyEquations,
    steady: SteadyResult,
    *,
    chi_range: tuple[float, float] = (0.1, 10.0),
    lam_range: tuple[float, float] = (0.5, 50.0),
    max_points: int = 60,
    settings: codim2.Settings | None = None,
    progress: Callable[[codim2.CurvePoint], None] | None = None,
) -> Codim2Trace:
    """The neutral curve from a steady state near a Hopf point (one-parameter branch in
    lambda): the Hopf point located, the Hopf curve continued both ways in chi, and from a
    Bogdanov–Takens point at its end the fold curve on to ``chi_range[0]``."""
    x, p = equations.state(steady)
    start = codim2.locate_hopf(equations, x, p, free=1, settings=settings)
    if not start.converged:
        raise RuntimeError(f"the Hopf point near lam = {p[1]:.6g} did not converge "
                           f"(residual {start.residual:.2e})")  # fmt: skip
    bounds = [[math.log(chi_range[0]), math.log(chi_range[1])], list(lam_range)]
    out = Codim2Trace()
    for direction in ((1.0, 0.0), (-1.0, 0.0)):
        curve = codim2.hopf_curve(equations, start, direction=direction, bounds=bounds,
                                  max_points=max_points, settings=settings,
                                  progress=progress)  # fmt: skip
        out.hopf.append(curve)
        for s in curve.special:
            out.special.append(s)
            if s.kind == "bt" and s.located:
                fold = codim2.fold_curve(equations, s, direction=(-1.0, 0.0), bounds=bounds,
                                         max_points=max_points, settings=settings,
                                         progress=progress)  # fmt: skip
                out.fold.append(fold)
                out.special.extend(fold.special)
    return out


@dataclass(frozen=True)
class TypeChange:
    """Where the neutral curve changes type: the lower sheet's fold curve meets the upper
    sheet's Hopf curve (an S-shaped branch: below ``chi`` tank-treading ends at the fold, above
    it the state it jumps to stays stable up to its Hopf point).  Both points are solved for on
    their augmented systems at ``chi``, which Brent's method found to ``xtol``; ``located`` when
    both converged there (``gap``: their difference in lambda, left by ``xtol``)."""

    chi: float
    lambda_c: float
    omega_R: float
    fold: codim2.CurvePoint
    hopf: codim2.CurvePoint
    gap: float
    located: bool

    def to_dict(self) -> dict:
        return {"chi": self.chi, "lambda_c": self.lambda_c, "omega_R": self.omega_R,
                "gap": self.gap, "located": self.located,
                "fold_residual": float(self.fold.residual),
                "hopf_residual": float(self.hopf.residual)}  # fmt: skip


def locate_type_change(
    equations: SteadyEquations,
    fold: codim2.CurvePoint,
    hopf: codim2.CurvePoint,
    chi_bracket: tuple[float, float],
    *,
    xtol: float = 1e-6,
    settings: codim2.Settings | None = None,
    progress: Callable[[dict], None] | None = None,
    start: Callable[[str, float], codim2.CurvePoint] | None = None,
    probes: Sequence[float] = (),
    gap_tol: float = 1e-4,
    guess: float | None = None,
    slope: float | None = None,
    method: str = "secant",
) -> TypeChange:
    """The ``chi`` in ``chi_bracket`` where the fold point (held ``chi``, free ``lambda``) and
    the Hopf point of the other sheet have the same ``lambda``: a root of the gap
    ``lambda_hopf(chi) - lambda_fold(chi)``, each point solved for on its augmented system.
    ``fold`` and ``hopf`` are located points near the bracket (:func:`codim2.locate_fold`,
    :func:`codim2.locate_hopf` from states on the two sheets).  Raises ``ValueError`` if the
    gap does not change sign over the bracket, ``RuntimeError`` if a point does not converge.

    How (``method``)
    ----------------
    ``"secant"`` (the default, with ``guess``): secant iterations on the gap from ``guess``
    (e.g. where the curves' own points cross) and a second point one estimated Newton step
    away (``slope``: an estimate of the gap's derivative in ``chi``), until the next step is
    below ``xtol``; a root it does not reach inside the bracket in ``SECANT_EVALUATIONS``
    evaluations falls back to Brent's method, which ``"brent"`` (the reference, and the path
    without ``guess``) uses from the start: the gap evaluated at ``probes`` from the high end
    down to the first change of sign, then Brent's method between those two (the high end
    first: at v = 0.95 the low end of the overlap is the BT point, where the Hopf point is
    hardest to solve).  Each ``chi``'s gap is solved once.

    Each solve starts from the linear extrapolation in ``log chi`` of the two nearest of the
    points of its kind found so far and ``start(kind, chi)`` (e.g. the nearest point of its
    own curve), with the nearest one's null vectors.  ``located`` needs both points
    converged and their lambdas within ``gap_tol`` at the found ``chi`` (measured: 3e-6 at xtol
    1e-6; a jump between sheets leaves about 0.1)."""
    if method not in ("secant", "brent"):
        raise ValueError(f"method must be 'secant' or 'brent', got {method!r}")
    found: dict[str, list[codim2.CurvePoint]] = {"fold": [fold], "hopf": [hopf]}

    def at(kind: str, chi: float) -> codim2.CurvePoint:
        t = math.log(chi)
        known = found[kind] + ([start(kind, chi)] if start is not None else [])
        q, x, lam, omega = _predicted(known, t)
        p = np.array([t, lam])
        if kind == "fold":
            r = codim2.locate_fold(equations, x, p, free=1, v=q.v, w=q.w, settings=settings)
        else:
            r = codim2.locate_hopf(equations, x, p, free=1, omega=omega, settings=settings)
        if not r.converged:
            raise RuntimeError(f"the {kind} point at chi = {chi:.6g} did not converge "
                               f"(residual {r.residual:.2e})")  # fmt: skip
        found[kind].append(r)
        return r

    gaps_at: dict[float, float] = {}

    def gap(chi: float) -> float:
        if chi in gaps_at:
            return gaps_at[chi]
        f, h = at("fold", chi), at("hopf", chi)
        if progress is not None:
            progress({"chi": chi, "fold": float(f.p[1]), "hopf": float(h.p[1]),
                      "omega_R": float(h.omega)})  # fmt: skip
        gaps_at[chi] = float(h.p[1] - f.p[1])
        return gaps_at[chi]

    lo, hi = sorted(chi_bracket)
    if method == "secant" and guess is not None and lo < guess < hi:
        try:
            chi = _secant(gap, guess, slope, lo, hi, xtol)
        except (RuntimeError, ValueError) as err:  # a solve failed: the reference path
            log.info("type change: the secant iterations stopped (%s); Brent's method", err)
            chi = None
        if chi is not None:
            return _type_change_at(found, chi, gap_tol)
        # the bracket is still the one given: its ends and probes are solved afresh (once)
    nodes = [hi, *sorted((c for c in probes if lo < c < hi), reverse=True), lo]
    gaps = [gap(nodes[0])]
    for c in nodes[1:]:  # down to the first change of sign
        gaps.append(gap(c))
        if gaps[-2] * gaps[-1] <= 0:
            break
    if gaps[-2] * gaps[-1] > 0:
        raise ValueError(
            f"the Hopf and fold points do not cross in chi = [{lo:g}, {hi:g}] "
            f"(gaps {', '.join(f'{g:+.3g}' for g in gaps)} from the top)"
        )
    k = len(gaps) - 1
    chi = brentq(gap, nodes[k], nodes[k - 1], xtol=xtol)
    gap(chi)
    return _type_change_at(found, chi, gap_tol)


#: Gap evaluations the secant iterations of :func:`locate_type_change` may take before Brent's
#: method takes over (from the curves' crossing they take 3-4).
SECANT_EVALUATIONS = 6


def _secant(gap, guess: float, slope: float | None, lo: float, hi: float,
            xtol: float) -> float | None:  # fmt: skip
    """Secant iterations on ``gap`` from ``guess`` inside ``(lo, hi)``: the evaluated ``chi``
    whose next step is below ``xtol`` (the root is that close), or None where they leave the
    bracket or do not get there in :data:`SECANT_EVALUATIONS` evaluations.  Once two
    evaluations change sign, a step outside the closest such pair is replaced by its midpoint."""
    width = hi - lo
    g0 = gap(guess)
    if g0 == 0.0:
        return guess
    step = -g0 / slope if slope is not None and slope != 0.0 and math.isfinite(slope) else \
        0.05 * width  # fmt: skip
    step = math.copysign(min(max(abs(step), 10.0 * xtol), 0.25 * width), step)
    second = min(max(guess + step, lo + 0.5 * xtol), hi - 0.5 * xtol)
    pts = [(guess, g0), (second, gap(second))]
    while True:
        (a, ga), (b, gb) = pts[-2], pts[-1]
        if gb == 0.0:
            return b
        if gb == ga:
            return None
        c = b - gb * (b - a) / (gb - ga)
        pairs = [(x0, x1) for (x0, y0), (x1, y1) in itertools.pairwise(sorted(pts))
                 if y0 * y1 < 0]  # fmt: skip
        if pairs:
            x0, x1 = min(pairs, key=lambda pr: pr[1] - pr[0])
            if not x0 < c < x1:
                c = 0.5 * (x0 + x1)
        if not lo < c < hi:
            return None
        if abs(c - b) <= xtol:
            return b
        if len(pts) >= SECANT_EVALUATIONS:
            return None
        pts.append((c, gap(c)))


def _type_change_at(found: dict[str, list[codim2.CurvePoint]], chi: float,
                    gap_tol: float) -> TypeChange:  # fmt: skip
    """The type change at ``chi`` from the two points solved for there."""
    t = math.log(chi)
    f = next(q for q in reversed(found["fold"]) if q.p[0] == t)
    h = next(q for q in reversed(found["hopf"]) if q.p[0] == t)
    gap_c = float(h.p[1] - f.p[1])
    # located: both points converged and they meet (a jump of one of them to another sheet
    # between the evaluations would leave a change of sign at a discontinuity instead)
    located = bool(f.converged and h.converged and abs(gap_c) <= gap_tol)
    return TypeChange(chi=float(chi), lambda_c=float(0.5 * (f.p[1] + h.p[1])),
                      omega_R=float(h.omega), fold=f, hopf=h, gap=gap_c,
                      located=located)  # fmt: skip


def _predicted(points: Sequence[codim2.CurvePoint], t: float):
    """The start of a solve at ``log chi = t``: the nearest point found, and its state
    ``(x, lambda, omega)`` extrapolated linearly in ``t`` through the second nearest."""
    near = sorted(points, key=lambda q: abs(q.p[0] - t))
    q = near[0]
    if len(near) < 2 or near[1].p[0] == q.p[0]:
        return q, q.x, float(q.p[1]), float(q.omega)
    r = near[1]
    s = (t - q.p[0]) / (r.p[0] - q.p[0])
    x = q.x + s * (r.x - q.x)
    return q, x, float(q.p[1] + s * (r.p[1] - q.p[1])), float(q.omega + s * (r.omega - q.omega))
