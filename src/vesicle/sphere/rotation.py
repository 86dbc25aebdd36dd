"""Rotations of spherical-harmonic coefficients (Wigner matrices).

For a rotation ``R`` and a field ``f`` with coefficients ``c`` we compute the coefficients of the
*pulled-back* field ``g(y) = f(R y)``: the values of ``f`` seen from a parameter sphere rotated by
``R``.  This is what the singular quadrature needs (SPEC §5): to integrate around a target we
place it at the north pole of a rotated parameter sphere.

Rotations about ``z`` are diagonal (``c_lm -> c_lm e^{i m alpha}``).  A rotation about ``y`` mixes
orders within each degree; for real fields it maps real parts to real parts and imaginary parts
to imaginary parts, through two real matrices per degree (``plus`` acts on ``Re c``, ``minus`` on
``Im c``).  Those matrices are computed *exactly* by quadrature: the basis functions evaluated at
rotated Gauss–Legendre points are projected back onto each degree; the quadrature is exact for
the degree-``2 lmax`` products involved.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vesicle.caches import bounded_cache
from vesicle.sphere.grid import SphereGrid, spherical_basis
from vesicle.sphere.legendre import legendre_table

__all__ = [
    "YRotation",
    "euler_zyz",
    "rotate_coefficients",
    "rotate_z",
    "rotated_angles",
    "rotation_matrix",
    "y_rotation",
    "y_rotation_quadrature",
]


class YRotation(NamedTuple):
    """Real Wigner blocks of a rotation about ``y``, each of shape (lmax+1, lmax+1, lmax+1).

    Indexed ``[l, m_out, m_in]``: ``Re c'_{l m'} = sum_m plus[l, m', m] Re c_lm`` and
    ``Im c'_{l m'} = sum_m minus[l, m', m] Im c_lm``.
    """

    plus: np.ndarray
    minus: np.ndarray

    def apply(self, c: np.ndarray) -> np.ndarray:
        """Rotate coefficients ``(..., l, m)``."""
        c = np.asarray(c)
        re = np.einsum("lab,...lb->...la", self.plus, c.real)
        im = np.einsum("lab,...lb->...la", self.minus, c.imag)
        return re + 1j * im


def rotation_matrix(axis: str, angle: float) -> np.ndarray:
    """Active rotation by ``angle`` about the coordinate ``axis`` ('x', 'y' or 'z')."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def euler_zyz(R: np.ndarray) -> tuple[float, float, float]:
    """Angles ``(alpha, beta, gamma)`` with ``R = Rz(alpha) Ry(beta) Rz(gamma)``."""
    R = np.asarray(R, dtype=float)
    beta = float(np.arctan2(np.hypot(R[0, 2], R[1, 2]), R[2, 2]))  # arccos loses digits at 0, pi
    if abs(np.sin(beta)) > 1e-12:
        alpha = float(np.arctan2(R[1, 2], R[0, 2]))
        gamma = float(np.arctan2(R[2, 1], -R[2, 0]))
    else:  # gimbal lock: only alpha + gamma (or alpha - gamma) is defined
        alpha = (
            float(np.arctan2(R[1, 0], R[0, 0]))
            if R[2, 2] > 0
            else float(np.arctan2(-R[1, 0], -R[0, 0]))
        )
        gamma = 0.0
    return alpha, beta, gamma


def rotate_z(c: np.ndarray, alpha: float | np.ndarray) -> np.ndarray:
    """Coefficients of ``f(Rz(alpha) y)``: multiply by ``e^{i m alpha}``."""
    c = np.asarray(c)
    m = np.arange(c.shape[-1])
    return c * np.exp(1j * m * np.asarray(alpha)[..., None, None])


def y_rotation_quadrature(beta: float, lmax: int) -> YRotation:
    """Wigner blocks for the pull-back by ``Ry(beta)``, by exact quadrature (O(lmax^4)).

    The basis functions are evaluated at rotated Gauss–Legendre points and projected back onto
    each degree; the quadrature is exact for the degree-``2 lmax`` products involved.
    """
    grid = SphereGrid(lmax + 1)
    e_r = grid.unit_vectors[0].reshape(3, -1)
    z = rotation_matrix("y", beta) @ e_r
    th_z, ph_z = _angles(z)
    th, ph = (a.ravel() for a in grid.meshgrid())
    P = legendre_table(lmax, th)[0].transpose(1, 2, 0)  # (m, l, q), contiguous
    Pz = legendre_table(lmax, th_z)[0].transpose(1, 2, 0)
    m = np.arange(lmax + 1)
    wq = grid.weights.ravel()
    norm = np.where(m == 0, 2.0 * np.pi, np.pi)
    w = np.where(m == 0, 1.0, 2.0)
    blocks = []
    for trig in (np.cos, np.sin):
        basis = P * (trig(np.outer(m, ph)) * wq)[:, None, :]  # weighted test functions
        rotated = Pz * trig(np.outer(m, ph_z))[:, None, :]
        # A[l, m', m] = sum_q basis[m', l, q] rotated[m, l, q]
        A = np.matmul(
            np.ascontiguousarray(basis.transpose(1, 0, 2)),
            np.ascontiguousarray(rotated.transpose(1, 2, 0)),
        )
        blocks.append(A / norm[None, :, None] * (w[None, None, :] / w[None, :, None]))
    plus, minus = blocks
    minus[:, 0, :] = 0.0
    minus[:, :, 0] = 0.0
    return YRotation(plus, minus)


@bounded_cache("quarter_turns")
def _quarter_turns(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """Fixed factors of ``Ry(beta) = M^T Rz(beta) M``, ``M = Rz(-pi/2) Ry(pi/2) Rz(pi/2)``.

    As real operators on ``[Re c_l; Im c_l]`` (shape (l, 2(L+1), 2(L+1))), the pull-back by
    ``Ry(beta)`` is ``A Z(beta) B`` with ``B = Y(-pi/2) Z(-pi/2)``, ``A = Z(pi/2) Y(pi/2)``
    (operators applied right to left), ``Z`` the z-phases and ``Y`` quadrature Wigner blocks.
    """
    n = lmax + 1
    half = np.pi / 2

    def y_op(beta):
        b = y_rotation_quadrature(beta, lmax)
        op = np.zeros((n, 2 * n, 2 * n))
        op[:, :n, :n], op[:, n:, n:] = b.plus, b.minus
        return op

    A = np.matmul(_z_op(half, n), y_op(half))
    B = np.matmul(y_op(-half), _z_op(-half, n))
    return A, B


def _z_op(alpha: float, n: int) -> np.ndarray:
    """``c -> c e^{i m alpha}`` on ``[Re; Im]``, as (1, 2n, 2n)."""
    m = np.arange(n)
    C, S = np.diag(np.cos(m * alpha)), np.diag(np.sin(m * alpha))
    return np.block([[C, -S], [S, C]])[None]


def y_rotation(beta: float, lmax: int) -> YRotation:
    """Wigner blocks for the pull-back by ``Ry(beta)`` up to degree ``lmax`` (O(lmax^4)).

    Uses ``Ry(beta) = M^T Rz(beta) M`` with fixed quarter-turn factors computed once per degree
    by exact quadrature (:func:`y_rotation_quadrature`, the reference), so each new angle costs
    one batched product of ``2(L+1)``-square matrices per degree.
    """
    n = lmax + 1
    A, B = _quarter_turns(lmax)
    m = np.arange(n)
    c, s = np.cos(m * beta), np.sin(m * beta)
    zb = np.concatenate(
        [
            c[:, None] * B[:, :n] - s[:, None] * B[:, n:],
            s[:, None] * B[:, :n] + c[:, None] * B[:, n:],
        ],
        axis=1,
    )
    op = np.matmul(A, zb)
    l_idx = np.arange(n)
    mask = (m[None, :] <= l_idx[:, None])[:, :, None] & (m[None, :] <= l_idx[:, None])[:, None, :]
    plus, minus = op[:, :n, :n] * mask, op[:, n:, n:] * mask
    minus[:, 0, :] = 0.0
    minus[:, :, 0] = 0.0
    return YRotation(plus, minus)


def rotate_coefficients(c: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Coefficients of ``g(y) = f(R y)`` for a rotation matrix ``R``.

    ``R = Rz(alpha) Ry(beta) Rz(gamma)`` gives
    ``g = f o Rz(alpha) o Ry(beta) o Rz(gamma)``: a z-phase, a y-rotation, a z-phase.
    """
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-10):
        raise ValueError("R must be a 3x3 rotation matrix")
    if np.linalg.det(R) < 0:
        raise ValueError("R must be a proper rotation (det = +1)")
    alpha, beta, gamma = euler_zyz(R)
    lmax = np.shape(c)[-1] - 1
    c1 = rotate_z(c, alpha)
    c2 = y_rotation(beta, lmax).apply(c1)
    return rotate_z(c2, gamma)


def rotated_angles(R: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, ...]:
    """Spherical angles of ``R e_r(theta, phi)``."""
    e_r = spherical_basis(theta, phi)[0]
    z = np.einsum("ij,j...->i...", R, e_r)
    return _angles(z)


def _angles(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Polar and azimuthal angles of unit vectors (3, ...); ``arctan2`` keeps full precision
    near the poles, where ``arccos`` would lose half the digits."""
    return np.arctan2(np.hypot(z[0], z[1]), z[2]), np.arctan2(z[1], z[0])
