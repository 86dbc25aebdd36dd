"""Singular quadrature by rotation of the parameter sphere (SPEC §5).

For a target at parameter point ``(theta_i, phi_k)`` (grid ring ``i``, column ``k``), the rotation
``R_ik = Rz(phi_k) Ry(theta_i)`` takes the north pole to the target.  In rotated spherical
coordinates ``(theta', phi')`` the area element ``dA = J sin(theta') dtheta' dphi'`` cancels the
``1/|x - x0|`` singularity; Gauss–Legendre in ``theta'`` on ``(0, pi)`` and the trapezoidal rule in
``phi'`` then converge spectrally.

Values of a field ``f`` at the rotated nodes are ``f(R_ik y')``: the coefficients of ``f`` are
multiplied by ``e^{i m phi_k}`` (a rotation about z, the only thing that differs between the
targets of one ring), rotated about y by ``theta_i`` with precomputed real Wigner blocks, and
synthesised on the rotated grid.  Every stage is a batched BLAS product over all targets of a ring.

The adjoint of that chain (:meth:`SingularQuadrature.pull_back`) turns weighted kernel values at the
rotated nodes into rows of the layer-potential operators in coefficient space (assembly).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache, cached_property

import ducc0
import numpy as np

from ..sphere.grid import SphereGrid, spherical_basis
from ..sphere.legendre import legendre_table
from ..sphere.rotation import rotation_matrix, y_rotation

__all__ = ["RingGeometry", "SingularQuadrature", "singular_quadrature"]


@dataclass(frozen=True, eq=False)
class RingGeometry:
    """A shape seen from the rotated grids of the targets on one ring.

    Arrays have shape (3, Q, K) or (Q, K): Q = 2 n_rot * n_rot rotated nodes (ordered
    ``phi'``-major), K targets on the ring.
    """

    xh: np.ndarray  # x(node) - x(target)
    weight: np.ndarray  # quadrature weight times area element, w' J
    normal_weighted: np.ndarray  # w' J n at the nodes

    @cached_property
    def inv_r(self) -> np.ndarray:
        return 1.0 / np.sqrt(np.einsum("i...,i...->...", self.xh, self.xh))


class SingularQuadrature:
    """Tables for rotated-grid quadrature on a grid of ``n_theta`` rings.

    Densities are resolved to the grid's full degree ``L = n_theta - 1``; the rotated grid has
    ``n_rot`` Gauss–Legendre nodes in ``theta'`` and ``2 n_rot`` in ``phi'``.
    Use :func:`singular_quadrature` for a shared, cached instance.

    Layouts: coefficients of a batch of fields are ``(l, m, B)``; values at the rotated nodes
    are ``(Q, B)`` with node index ``j * n_rot + a`` for ``(phi'_j, theta'_a)``.  Batches over the
    targets of a ring put the target index ``k`` fastest: ``B = b * K + k``.
    """

    def __init__(self, n_theta: int, n_rot: int):
        if n_rot < 2:
            raise ValueError(f"the rotated grid needs n_rot >= 2, got {n_rot}")
        self.grid = SphereGrid(n_theta)
        self.lmax = self.grid.max_degree
        self.n_rot = n_rot
        self.n_rot_phi = 2 * n_rot
        t, w = np.polynomial.legendre.leggauss(n_rot)
        self.theta_rot = 0.5 * np.pi * (t + 1.0)
        self.phi_rot = 2.0 * np.pi * np.arange(self.n_rot_phi) / self.n_rot_phi
        # weights of int dOmega' = int sin(theta') dtheta' dphi' at the Q nodes
        wt = 0.5 * np.pi * w * np.sin(self.theta_rot)
        self.weights_rot = np.tile(wt * 2.0 * np.pi / self.n_rot_phi, self.n_rot_phi)

    @property
    def n_nodes(self) -> int:
        return self.n_rot * self.n_rot_phi

    def node_angles(self) -> tuple[np.ndarray, np.ndarray]:
        """``(theta', phi')`` of the Q rotated nodes."""
        return np.tile(self.theta_rot, self.n_rot_phi), np.repeat(self.phi_rot, self.n_rot)

    # ------------------------------------------------------------------ tables
    @cached_property
    def wigner(self) -> tuple[np.ndarray, np.ndarray]:
        """Real Wigner blocks for each ring, each (n_theta, L+1, L+1, L+1) ``[i, l, m', m]``."""
        with ThreadPoolExecutor(2) as pool:
            blocks = list(pool.map(lambda b: y_rotation(b, self.lmax), self.grid.theta))
        return np.stack([b.plus for b in blocks]), np.stack([b.minus for b in blocks])

    @cached_property
    def legendre_rot(self) -> tuple[np.ndarray, np.ndarray]:
        """``Pbar`` and ``dPbar/dtheta`` at the rotated ``theta'``, each (m, a, l)."""
        P, dP = legendre_table(self.lmax, self.theta_rot, derivatives=1)
        return P.transpose(1, 0, 2).copy(), dP.transpose(1, 0, 2).copy()

    @cached_property
    def basis_rot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rotated-frame unit vectors ``e_r', e_theta', e_phi'`` at the nodes, each (3, Q)."""
        return spherical_basis(*self.node_angles())

    def ring_rotations(self, i: int) -> np.ndarray:
        """``R_ik = Rz(phi_k) Ry(theta_i)`` for the targets of ring ``i``, shape (K, 3, 3)."""
        Ry = rotation_matrix("y", self.grid.theta[i])
        return np.stack([rotation_matrix("z", p) @ Ry for p in self.grid.phi])

    # ------------------------------------------------------- forward (values)
    def phase(self, c: np.ndarray) -> np.ndarray:
        """Coefficients (b, l, m) -> (l, m, b*K) for the K targets of a ring (z-rotation)."""
        m = np.arange(c.shape[-1])
        e = np.exp(1j * np.outer(m, self.grid.phi))  # (m, K)
        out = c.transpose(1, 2, 0)[..., None] * e[None, :, None, :]
        return out.reshape(*out.shape[:2], -1)

    def rotate(self, i: int, c: np.ndarray, degree: int | None = None) -> np.ndarray:
        """Y-rotate coefficients (l, m, B) by ring ``i``'s polar angle, up to ``degree``."""
        n = (self.lmax if degree is None else degree) + 1
        plus, minus = self.wigner
        c = c[:n, :n]
        re = np.matmul(plus[i, :n, :n, :n], np.ascontiguousarray(c.real))  # (l, m', B)
        im = np.matmul(minus[i, :n, :n, :n], np.ascontiguousarray(c.imag))
        return re + 1j * im

    def synthesize(self, c: np.ndarray, derivative: bool = False):
        """Rotated coefficients (l, m, B) -> values (Q, B) at the rotated nodes.

        With ``derivative`` it returns ``(f, df/dtheta', df/dphi')``, each (Q, B).
        """
        n = c.shape[0]
        P, dP = self.legendre_rot
        cm = c.transpose(1, 0, 2)  # (m, l, B)
        tables = (P, dP) if derivative else (P,)
        spectra = [_real_matmul(T[:n, :, :n], cm) for T in tables]  # (m, a, B)
        if not derivative:
            return self._azimuthal(spectra[0])
        spectra.append(1j * np.arange(n)[:, None, None] * spectra[0])
        return tuple(self._azimuthal(F) for F in spectra)

    def _azimuthal(self, F: np.ndarray) -> np.ndarray:
        """Spectrum (m, a, B) -> real values (Q, B): ``sum_m w_m F_m e^{i m phi'}``.

        Orders beyond the rotated grid's Nyquist alias onto its bins (exact at the nodes).
        """
        n = F.shape[0]
        w = np.where(np.arange(n) == 0, 1.0, 2.0)[:, None, None]
        G = np.zeros((self.n_rot_phi, *F.shape[1:]), dtype=np.complex128)
        for start in range(0, n, self.n_rot_phi):
            chunk = w[start : start + self.n_rot_phi] * F[start : start + self.n_rot_phi]
            G[: len(chunk)] += chunk
        vals = ducc0.fft.c2c(G, axes=(0,), forward=False, inorm=0, out=G).real
        return vals.reshape(self.n_nodes, -1)

    def values(self, i: int, c: np.ndarray) -> np.ndarray:
        """Fields with coefficients (b, l, m) at the rotated nodes of ring ``i``: (Q, b, K)."""
        vals = self.synthesize(self.rotate(i, self.phase(c)))
        return vals.reshape(self.n_nodes, c.shape[0], self.grid.n_phi)

    # --------------------------------------------------------- adjoint (rows)
    def pull_back(self, i: int, v: np.ndarray) -> np.ndarray:
        """Adjoint of :meth:`values`, one field per target: weights (Q, b, K) -> rows (b, K, l, m).

        For weights ``v`` at the rotated nodes of target ``k`` it returns the complex row ``q``
        with ``sum_nodes v * f(node) = Re sum_lm conj(q_lm) c_lm`` for every field ``f`` with
        coefficients ``c`` (``Re``/``Im`` parts of ``c`` paired with those of ``q``).
        """
        _, b, k = v.shape
        n = self.lmax + 1
        vals = v.reshape(self.n_rot_phi, self.n_rot, b * k).astype(np.complex128)
        G = ducc0.fft.c2c(vals, axes=(0,), forward=True, inorm=0, out=vals)
        w = np.where(np.arange(n) == 0, 1.0, 2.0)[:, None, None]
        F = w * G[np.arange(n) % self.n_rot_phi]  # (m, a, B)
        P, _ = self.legendre_rot
        c = _real_matmul(np.ascontiguousarray(P.transpose(0, 2, 1)), F)  # (m, l, B)
        c = c.transpose(1, 0, 2)  # (l, m', B)
        plus, minus = self.wigner
        re = np.matmul(plus[i].transpose(0, 2, 1), np.ascontiguousarray(c.real))  # (l, m, B)
        im = np.matmul(minus[i].transpose(0, 2, 1), np.ascontiguousarray(c.imag))
        q = (re + 1j * im).reshape(n, n, b, k)
        e = np.exp(-1j * np.outer(np.arange(n), self.grid.phi))  # (m, K)
        return (q * e[None, :, None, :]).transpose(2, 3, 0, 1)

    # --------------------------------------------------------------- geometry
    def ring_geometry(
        self, i: int, radius_coefficients: np.ndarray, x0: np.ndarray
    ) -> RingGeometry:
        """Rotated geometry of a radius series for the targets ``x0`` (3, K) of ring ``i``."""
        degree = radius_coefficients.shape[-1] - 1
        if degree > self.lmax:
            raise ValueError(f"shape degree {degree} exceeds the grid's {self.lmax}")
        cp = self.phase(radius_coefficients[None])  # (l, m, K)
        r, rt, rp = self.synthesize(self.rotate(i, cp, degree), derivative=True)  # (Q, K)
        e_r, e_t, e_p = (e[:, :, None] for e in self.basis_rot)
        sin_t = np.sin(self.node_angles()[0])[:, None]
        x_rot = r * e_r  # rotated frame, (3, Q, K)
        jn_rot = r * (r * e_r - rt * e_t - (rp / sin_t) * e_p)
        R = self.ring_rotations(i)
        x = np.einsum("kij,jqk->iqk", R, x_rot)
        jn = np.einsum("kij,jqk->iqk", R, jn_rot)
        J = np.sqrt(np.einsum("iqk,iqk->qk", jn, jn))
        w = self.weights_rot[:, None]
        return RingGeometry(xh=x - x0[:, None, :], weight=w * J, normal_weighted=w * jn)


def _real_matmul(mat: np.ndarray, data: np.ndarray) -> np.ndarray:
    """``mat @ data``: real ``mat`` (K, a, b), complex ``data`` (K, b, B), without upcasting."""
    k, _, nb = data.shape
    re = np.ascontiguousarray(data).view(np.float64)
    return np.matmul(mat, re).view(np.complex128).reshape(k, mat.shape[1], nb)


@cache
def singular_quadrature(n_theta: int, n_rot: int | None = None) -> SingularQuadrature:
    """Shared quadrature tables; ``n_rot`` defaults to ``n_theta`` (see docs for convergence)."""
    return SingularQuadrature(n_theta, n_theta if n_rot is None else n_rot)
