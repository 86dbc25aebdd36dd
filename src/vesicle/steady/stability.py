"""Linear stability of steady tank-treading and the critical viscosity ratio (SPEC §9).

Admissible perturbations keep A and V: they lie orthogonal to ``z_1, z_2``, the Gram–Schmidt
orthonormalisation of ``dA/da``, ``dV/da``.  With ``Q = I - z_1 z_1^T - z_2 z_2^T`` the
eigenvalues ``mu`` of ``Q^T M Q`` other than the trivial zeros are the growth exponents
``-i omega`` of modes ``e^{-i omega t}``: ``omega_R = -Im mu``, ``omega_I = Re mu``
(``omega_I > 0`` unstable).  For ``modes="general"`` the full basis (2.1) is used (all degrees,
cosine and sine parts) and the three translations (degree 1) are excluded as well: a translated
vesicle drifts with the shear, a neutral mode the re-centring of the simulations removes.

``curvature=True`` adds the multipliers' curvature: ``Q^T (M - mu . d^2(A, V)/da^2) Q``, the
linearisation of the discrete dynamics held on the constraints (the Newton matrix of
:mod:`vesicle.steady.newton`).  Its real eigenvalue vanishes exactly where the branch of steady
states
turns (the fold of the discrete system, SPEC §16); SPEC §9's ``Q^T M Q`` (the default) crosses
zero a little away from it wherever the multipliers, which vanish with the resolution, are not
small.  Measured at v = 0.85, chi = 1 (N = 4, 16x32; ``mu = (0.0057, -0.0140)``): the fold at
lam = 4.094968; the real crossing of ``Q^T M Q`` at 4.0739, that of the curvature form at the
fold (docs/reference/continuation.md).  At Table 1's state (v = 0.95, lam = 8, chi = 10, 32x64) the
leading growth rates of the two forms differ by 5.8e-3, 2.5e-3, 1.5e-3, 4.4e-4 and 8.9e-5 at
N = 4, 6, 8, 10 and 12 (``mu_V`` = -7.3e-4, -2.9e-4, -1.7e-4, -5.0e-5, -1.0e-5): the gap
closes with the degree.
Every result carries the gap (``curvature_shift``); above :data:`CURVATURE_WARNING` a warning
says to raise the degree.
"""

from __future__ import annotations

import logging
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from vesicle.model.settings import default_modes  # re-exported: decided there
from vesicle.sphere.bases import FullBasis
from vesicle.steady.newton import SteadyResult

__all__ = ["FullBasis", "StabilityResult", "default_modes", "stability"]

log = logging.getLogger(__name__)


#: |curvature_shift| above which :func:`stability` warns that the resolution is too low for the
#: multipliers to be negligible (measured: Table 1's state, v = 0.95, at N = 4 on 32x64 5.8e-3,
#: at N = 8 1.5e-3; v = 0.85 at N = 4 on 16x32 0.045 at chi = 1 and 0.106 at chi = 0.1).
CURVATURE_WARNING = 1e-2

#: Resolutions ``(degree, grid, modes)`` already warned about in this process: a branch or a
#: sweep at a low degree would repeat the same warning at every point, so later ones are logged
#: at info level (``--verbose``); every result still carries its ``curvature_shift``.
_WARNED: set[tuple[int, int, str]] = set()


@dataclass(frozen=True, eq=False)
class StabilityResult:
    """Eigen-analysis of a steady state: ``omega`` sorted by ``omega_I`` (most unstable first)."""

    omega: np.ndarray  # (k, 2): (omega_R, omega_I)
    modes: np.ndarray  # (k, N+1, N+1) complex: C(Re v) + i C(Im v); see ``parts``
    basis: str
    #: (k, 2, N+1, N+1) complex: the coefficients of the mode's real and imaginary parts (the
    #: perturbation now and a quarter period later), each a real field.  ``modes`` adds them
    #: as ``parts[:, 0] + 1j parts[:, 1]``, which separates again only where every coefficient
    #: is real (the symmetric basis, cos m phi); general modes have sin m phi parts, whose
    #: coefficients are imaginary, and must be read from here.
    parts: np.ndarray | None = None
    #: Leading growth rate of the other operator (with the multipliers' curvature if this one
    #: is without, and the reverse) minus this one's: how much the answer depends on the
    #: multipliers, which vanish with the resolution (docs/reference/continuation.md).  Above
    #: :data:`CURVATURE_WARNING` a warning is logged.
    curvature_shift: float = 0.0

    @property
    def most_unstable(self) -> tuple[float, float]:
        """``(omega_R, omega_I)`` of the mode with the largest growth rate (``omega_R >= 0``)."""
        w_r, w_i = self.omega[0]
        return float(abs(w_r)), float(w_i)


def stability(
    result: SteadyResult,
    modes: str = "symmetric",
    executor: Executor | None = None,
    curvature: bool = False,
) -> StabilityResult:
    """Growth exponents of perturbations of a steady tank-treading state (SPEC §9).

    ``curvature``: include the multipliers' curvature ``-mu . d^2(A, V)/da^2`` in the operator
    (see the module's text); the default is SPEC §9's ``Q^T M Q``."""
    if modes not in ("symmetric", "general"):
        raise ValueError("modes must be 'symmetric' or 'general'")
    if modes == "symmetric":
        problem, basis, M = result.problem, result.basis, result.jacobian
        if M is None:
            raise ValueError("the steady result carries no Jacobian (Newton did not converge)")
        g, a0 = result.gradients, result.a
        extra = np.zeros((0, basis.size))
    else:
        problem = result.problem.replace(modes="general")
        basis = problem.basis
        a0 = problem.coefficients_of(result.shape)
        M, _ = problem.jacobian(a0, central=True, executor=executor)
        g = problem.gradients(result.shape)
        extra = np.eye(basis.size)[basis.l == 1]  # translations
    H = problem.constraint_hessians(a0)
    curved = M - np.einsum("k,kij->ij", np.asarray(result.multipliers, float), H)
    C = np.concatenate([g, extra])
    Z, _ = np.linalg.qr(C.T)
    Q = np.eye(basis.size) - Z @ Z.T
    W = problem.rate_weights

    def spectrum(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if W is not None:  # multipliers along W^-1 g: the pencil with the mass diag(W, 0)
            return _weighed_spectrum(A, C, W)
        mu, vec = np.linalg.eig(Q.T @ A @ Q)
        # drop the trivial zeros: eigenvectors in the constrained span (killed by Q)
        keep = np.argsort(np.linalg.norm(Q @ vec, axis=0))[Z.shape[1] :]
        return mu[keep], vec[:, keep]

    mu, vec = spectrum(curved if curvature else M)
    shift = float(spectrum(M if curvature else curved)[0].real.max() - mu.real.max())
    if abs(shift) > CURVATURE_WARNING:
        disc = result.discretisation
        seen = (disc.degree, disc.grid, modes)
        level = logging.INFO if seen in _WARNED else logging.WARNING
        _WARNED.add(seen)
        log.log(
            level,
            "the multipliers (%.2g, %.2g) are not small at this resolution (N = %d, %dx%d): the "
            "leading growth rate %s the multipliers' curvature differs by %.3g (SPEC §9's "
            "Q^T M Q against the linearisation held on the constraints; see "
            "docs/reference/continuation.md): raise the degree%s",
            *result.multipliers, disc.degree, disc.grid, 2 * disc.grid,
            "with" if not curvature else "without", shift,
            "" if level == logging.INFO else " (said once per resolution; every result "
            "carries its curvature_shift)",
        )  # fmt: skip
    omega = np.stack([-mu.imag, mu.real], axis=1)
    # most unstable first; a conjugate pair (equal omega_I but for rounding) with -omega_R
    # first, so that the order does not depend on the last bits of the eigen-solver's output
    growth, speed = np.round(omega[:, 1], 10), np.round(np.abs(omega[:, 0]), 10)
    order = np.lexsort((omega[:, 0], -speed, -growth))
    omega, vec = omega[order], vec[:, order]
    parts = np.stack(
        [np.stack([basis.to_coefficients(v.real), basis.to_coefficients(v.imag)]) for v in vec.T]
    ).astype(np.complex128)
    shapes = parts[:, 0] + 1j * parts[:, 1]
    log.info("most unstable %s mode: omega = (%.4g, %.4g)", modes, *omega[0])
    return StabilityResult(omega, shapes, modes, parts, shift)


def _weighed_spectrum(A: np.ndarray, C: np.ndarray, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The growth rates of ``W da/dt = A da - C^T nu``, ``C da = 0`` (the rates weighed by
    ``W``: ``Discretisation(multipliers="l2")``, :attr:`SteadyProblem.rate_weights`): the
    finite eigenvalues of the pencil ``([[A, -C^T], [C, 0]], diag(W, 0))``, ``n - c`` of them,
    and their eigenvectors' ``da`` parts.  With ``W = I`` they are those of ``Q^T A Q``."""
    n, c = A.shape[0], C.shape[0]
    K = np.block([[A, -C.T], [C, np.zeros((c, c))]])
    B = np.zeros_like(K)
    B[np.arange(n), np.arange(n)] = W
    mu, vec = scipy.linalg.eig(K, B)
    finite = np.flatnonzero(np.isfinite(mu))
    keep = finite[np.argsort(np.abs(mu[finite]))[: n - c]]
    return mu[keep], vec[:n, keep]
