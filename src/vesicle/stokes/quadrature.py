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

import threading
from dataclasses import dataclass
from functools import cached_property

import ducc0
import numpy as np

from vesicle.caches import bounded_cache
from vesicle.sphere.grid import SphereGrid, spherical_basis
from vesicle.sphere.legendre import legendre_table
from vesicle.sphere.rotation import rotation_matrix, y_rotation
from vesicle.sphere.transforms import real_matmul

__all__ = ["RingGeometry", "SingularQuadrature", "singular_quadrature"]

#: Per-thread scratch arrays of the pull-back (assembly runs rings in threads).
_SCRATCH = threading.local()


def _scratch(*shapes: tuple[int, ...]) -> list[np.ndarray]:
    """This thread's scratch arrays of the given shapes, reused between calls of equal shapes.

    Writing the pull-back's intermediate products into arrays that stay mapped (``out=``) saves
    the page faults of fresh ones: measured pair by pair over 100–400 calls, 0.98x the time
    of fresh arrays at 32x64 (within noise) and 0.89x at 48x96.  A thread keeps one set
    (18 MB at 32x64, 63 MB at 48x96), freed with the thread."""
    if getattr(_SCRATCH, "shapes", None) != shapes:
        _SCRATCH.arrays = [np.empty(shape) for shape in shapes]
        _SCRATCH.shapes = shapes
    return _SCRATCH.arrays


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
    def wigner(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Real Wigner blocks per ring, (n_theta, L+1, L+1, L+1) ``[i, l, m', m]``.

        ``(plus, minus, plus^T, minus^T)``: the transposes (``[i, l, m, m']``) are stored
        contiguously for the adjoint.
        """
        blocks = [y_rotation(beta, self.lmax) for beta in self.grid.theta]
        plus = np.stack([b.plus for b in blocks])
        minus = np.stack([b.minus for b in blocks])
        return plus, minus, plus.transpose(0, 1, 3, 2).copy(), minus.transpose(0, 1, 3, 2).copy()

    @cached_property
    def legendre_rot(self) -> tuple[np.ndarray, np.ndarray]:
        """``Pbar`` and ``dPbar/dtheta`` at the rotated ``theta'``, each (m, a, l)."""
        P, dP = legendre_table(self.lmax, self.theta_rot, derivatives=1)
        return P.transpose(1, 0, 2).copy(), dP.transpose(1, 0, 2).copy()

    @cached_property
    def _legendre_adjoint(self) -> np.ndarray:
        """``w_m Pbar_lm(theta'_a)`` as (m, l, a), ``w_0 = 1``, else 2: adjoint of synthesis."""
        P = self.legendre_rot[0].transpose(0, 2, 1)
        return np.ascontiguousarray(
            P * np.where(np.arange(self.lmax + 1) == 0, 1.0, 2.0)[:, None, None]
        )

    @property
    def _real_fft(self) -> bool:
        """Whether all orders fit below the rotated grid's Nyquist (then real FFTs suffice)."""
        return self.lmax < self.n_rot

    @cached_property
    def basis_rot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rotated-frame unit vectors ``e_r', e_theta', e_phi'`` at the nodes, each (3, Q)."""
        return spherical_basis(*self.node_angles())

    def ring_rotations(self, i: int) -> np.ndarray:
        """``R_ik = Rz(phi_k) Ry(theta_i)`` for the targets of ring ``i``, shape (K, 3, 3)."""
        Ry = rotation_matrix("y", self.grid.theta[i])
        return np.stack([rotation_matrix("z", p) @ Ry for p in self.grid.phi])

    @cached_property
    def _phases(self) -> np.ndarray:
        """``e^{i m phi_k}``, (m, K)."""
        return np.exp(1j * np.outer(np.arange(self.lmax + 1), self.grid.phi))

    # ------------------------------------------------------- forward (values)
    def phase(self, c: np.ndarray, targets: slice = slice(None)) -> np.ndarray:
        """Coefficients (b, l, m) -> (l, m, b*K) for K targets of a ring (z-rotation)."""
        n = c.shape[-1]
        out = c.transpose(1, 2, 0)[..., None] * self._phases[None, :n, None, targets]
        return out.reshape(*out.shape[:2], -1)

    def rotate(self, i: int, c: np.ndarray, degree: int | None = None) -> np.ndarray:
        """Y-rotate coefficients (l, m, B) by ring ``i``'s polar angle, up to ``degree``."""
        n = (self.lmax if degree is None else degree) + 1
        plus, minus = self.wigner[:2]
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
        spectra = [real_matmul(T[:n, :, :n], cm) for T in tables]  # (m, a, B)
        if not derivative:
            return self._azimuthal(spectra[0])
        spectra.append(1j * np.arange(n)[:, None, None] * spectra[0])
        return tuple(self._azimuthal(F) for F in spectra)

    @cached_property
    def theta_major(self) -> np.ndarray:
        """Node permutation to ``theta'``-major order: ``values[..., theta_major]`` has node
        ``a * 2 n_rot + j`` for ``(theta'_a, phi'_j)`` (the :meth:`synthesize_by_field` layout)."""
        j, a = np.meshgrid(np.arange(self.n_rot_phi), np.arange(self.n_rot))
        return (j * self.n_rot + a).ravel()

    def synthesize_by_field(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`synthesize` with derivatives, field-first and ``theta'``-major: each of
        ``(f, df/dtheta', df/dphi')`` is (B, Q) with the nodes ordered as :attr:`theta_major`.

        Meant for low-degree coefficients (directions of a shape of degree N): the azimuthal
        sum is one real matrix product over all fields instead of strided FFTs."""
        n = c.shape[0]
        P, dP = self.legendre_rot
        cm = c.transpose(1, 2, 0)  # (m, B, l)
        re, im = np.ascontiguousarray(cm.real), np.ascontiguousarray(cm.imag)
        m = np.arange(n)[:, None, None]
        spectra = []  # [Re F; Im F] as (2m, B, a) for f, df/dtheta', df/dphi'
        for T in (P, dP):
            Tt = T[:n, :, :n].transpose(0, 2, 1)  # (m, l, a)
            spectra.append((np.matmul(re, Tt), np.matmul(im, Tt)))
        spectra.append((-m * spectra[0][1], m * spectra[0][0]))
        angles = np.outer(np.arange(n), self.phi_rot)  # (m, j)
        w = np.where(np.arange(n) == 0, 1.0, 2.0)[:, None]
        E = np.concatenate([w * np.cos(angles), -w * np.sin(angles)])  # (2m, j)
        out = []
        for F_re, F_im in spectra:
            F = np.concatenate([F_re, F_im]).reshape(2 * n, -1)  # (2m, B * a)
            out.append((F.T @ E).reshape(c.shape[-1], self.n_nodes))  # (B, a * j)
        return out[0], out[1], out[2]

    def _azimuthal(self, F: np.ndarray) -> np.ndarray:
        """Spectrum (m, a, B) -> real values (Q, B): ``sum_m w_m F_m e^{i m phi'}``.

        Orders beyond the rotated grid's Nyquist alias onto its bins (exact at the nodes).
        """
        n, nphi = F.shape[0], self.n_rot_phi
        if n <= nphi // 2:  # real inverse FFT; c2r doubles the orders 0 < m < Nyquist itself
            G = np.zeros((nphi // 2 + 1, *F.shape[1:]), dtype=np.complex128)
            G[:n] = F
            vals = ducc0.fft.c2r(G, axes=(0,), lastsize=nphi, forward=False, inorm=0)
            return vals.reshape(self.n_nodes, -1)
        w = np.where(np.arange(n) == 0, 1.0, 2.0)[:, None, None]
        G = np.zeros((nphi, *F.shape[1:]), dtype=np.complex128)
        for start in range(0, n, nphi):
            chunk = w[start : start + nphi] * F[start : start + nphi]
            G[: len(chunk)] += chunk
        vals = ducc0.fft.c2c(G, axes=(0,), forward=False, inorm=0, out=G).real
        return vals.reshape(self.n_nodes, -1)

    def values(self, i: int, c: np.ndarray, targets: slice = slice(None)) -> np.ndarray:
        """Fields with coefficients (b, l, m) at the rotated nodes of ring ``i``: (Q, b, K)."""
        vals = self.synthesize(self.rotate(i, self.phase(c, targets)))
        return vals.reshape(self.n_nodes, c.shape[0], -1)

    # --------------------------------------------------------- adjoint (rows)
    #: How :meth:`pull_back_unphased` transforms in phi': ``"gemm"`` (default: one real DFT
    #: matrix product, only the orders m <= lmax, into contiguous Re/Im blocks) or ``"fft"``
    #: (the reference: an FFT of every column, then the orders taken out).
    pull_back_transform = "gemm"

    @cached_property
    def _dft_rows(self) -> np.ndarray:
        """``[cos(m phi'_j); -sin(m phi'_j)]`` for m = 0..lmax: (2 (lmax+1), n_rot_phi), the
        forward DFT's real and imaginary rows (aliased orders m >= n_rot_phi wrap, as the FFT
        path's index m mod n_rot_phi does)."""
        angles = np.outer(np.arange(self.lmax + 1), self.phi_rot)
        return np.concatenate([np.cos(angles), -np.sin(angles)])

    def pull_back_unphased(
        self, i: int, v: np.ndarray, transform: str | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`pull_back` before the adjoint z-phase: ``(Re, Im)``, each (T, b, K), of the
        y-rotated coefficients; the phase ``e^{-i m phi_k}`` (:attr:`phase_parts`) turns them
        into the rows.  ``transform``: see :attr:`pull_back_transform`."""
        _, b, k = v.shape
        n = self.lmax + 1
        vals = v.reshape(self.n_rot_phi, self.n_rot, b * k)
        transform = transform or self.pull_back_transform
        F_out, c = _scratch((2 * n, self.n_rot * b * k), (n, n, b * k))
        if transform == "gemm":
            F = np.matmul(self._dft_rows, vals.reshape(self.n_rot_phi, -1), out=F_out)
            F = F.reshape(2, n, self.n_rot, -1)
            real_imag = (F[0], F[1])
        elif transform == "fft":
            if n <= self.n_rot_phi // 2 + 1:
                G = ducc0.fft.r2c(vals, axes=(0,), forward=True, inorm=0)[:n]  # (m, a, B)
            else:
                G = ducc0.fft.c2c(vals.astype(np.complex128), axes=(0,), forward=True, inorm=0)
                G = G[np.arange(n) % self.n_rot_phi]
            real_imag = (np.ascontiguousarray(G.real), np.ascontiguousarray(G.imag))
        else:
            raise ValueError(f"transform must be 'gemm' or 'fft', got {transform!r}")
        # Only l >= m (and m' <= l) is non-zero: loop over orders and degrees so that the
        # Legendre and Wigner products skip the zero halves (a third of the full products),
        # and write the Wigner output straight into the packed triangle.
        adj = self._legendre_adjoint  # (m, l, a), w_m included
        plusT, minusT = self.wigner[2:]
        parts = []
        for part, wig in zip(real_imag, (plusT[i], minusT[i]), strict=True):
            # c: (l, m', B), only m' <= l is set and read
            for m in range(n):
                np.matmul(adj[m, m:], part[m], out=c[m:, m])
            packed = np.empty((n * (n + 1) // 2, b * k))
            for l in range(n):
                rows = packed[l * (l + 1) // 2 : (l + 1) * (l + 2) // 2]
                np.matmul(wig[l, : l + 1, : l + 1], c[l, : l + 1], out=rows)
            parts.append(packed.reshape(-1, b, k))
        return parts[0], parts[1]

    def pull_back(self, i: int, v: np.ndarray, targets: slice = slice(None)) -> np.ndarray:
        """Adjoint of :meth:`values`, one field per target: weights (Q, b, K) -> rows (2, T, b, K).

        For weights ``v`` at the rotated nodes of target ``k`` it returns the real row ``q`` with
        ``sum_nodes v * f(node) = sum_t q[0, t] Re c_t + q[1, t] Im c_t`` for every field ``f``
        with coefficients ``c``, ``t`` running over the packed lower triangle ``l >= m``
        (:attr:`packed`).
        """
        re, im = self.pull_back_unphased(i, v)
        # adjoint of the z-phase e^{i m phi_k}: rotate (Re, Im) pairs by -m phi_k
        cos, sin = self.phase_parts
        cos, sin = cos[:, None, targets], sin[:, None, targets]
        return np.stack([re * cos + im * sin, im * cos - re * sin])

    @cached_property
    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """``(l, m)`` indices of the packed lower triangle ``m <= l`` (row-major in ``l``)."""
        return np.tril_indices(self.lmax + 1)

    @cached_property
    def phase_parts(self) -> tuple[np.ndarray, np.ndarray]:
        """``cos(m phi_k)``, ``sin(m phi_k)`` on the packed triangle, each (T, K)."""
        angles = np.outer(self.packed[1], self.grid.phi)
        return np.cos(angles), np.sin(angles)

    # --------------------------------------------------------------- geometry
    def ring_radius(
        self, i: int, radius_coefficients: np.ndarray, targets: slice = slice(None)
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``r``, ``dr/dtheta'``, ``dr/dphi'`` at the rotated nodes of ring ``i``'s targets,
        each (Q, K)."""
        degree = radius_coefficients.shape[-1] - 1
        if degree > self.lmax:
            raise ValueError(f"shape degree {degree} exceeds the grid's {self.lmax}")
        cp = self.phase(radius_coefficients[None], targets)  # (l, m, K)
        return self.synthesize(self.rotate(i, cp, degree), derivative=True)

    def ring_frame(self, i: int) -> np.ndarray:
        """``e_r', e_theta', e_phi'`` at the rotated nodes, turned by ring ``i``'s y-rotation,
        (3 [vector], 3 [component], Q)."""
        Ry = rotation_matrix("y", self.grid.theta[i])
        return np.stack([Ry @ e for e in self.basis_rot])

    @cached_property
    def inv_sin_rot(self) -> np.ndarray:
        """``1 / sin(theta')`` at the Q rotated nodes."""
        return 1.0 / np.sin(self.node_angles()[0])

    def ring_geometry(
        self, i: int, radius_coefficients: np.ndarray, x0: np.ndarray, targets: slice = slice(None)
    ) -> RingGeometry:
        """Rotated geometry of a radius series for the ``targets`` of ring ``i`` at ``x0`` (3, K).

        With ``x = r e_r`` the weighted normal is ``J n = r^2 e_r - r grad_1 r`` (``grad_1`` the
        gradient on the unit sphere), evaluated in the rotated frame and turned to the lab frame
        by ``R_ik = Rz(phi_k) Ry(theta_i)``: the ``Ry`` part is shared by the ring, the ``Rz`` part
        is a cheap per-target rotation of the x, y components.
        """
        r, rt, rp = self.ring_radius(i, radius_coefficients, targets)  # (Q, K)
        e_r, e_t, e_p = self.ring_frame(i)[:, :, :, None]  # each (3, Q, 1)
        x_y = r * e_r  # components in the frame rotated by Rz(phi_k)
        jn_y = r * (r * e_r - rt * e_t - (rp * self.inv_sin_rot[:, None]) * e_p)
        c, s = np.cos(self.grid.phi[targets]), np.sin(self.grid.phi[targets])
        x = np.stack([c * x_y[0] - s * x_y[1], s * x_y[0] + c * x_y[1], x_y[2]])
        jn = np.stack([c * jn_y[0] - s * jn_y[1], s * jn_y[0] + c * jn_y[1], jn_y[2]])
        J = np.sqrt(np.einsum("iqk,iqk->qk", jn, jn))
        w = self.weights_rot[:, None]
        x -= x0[:, None, :]
        jn *= w
        return RingGeometry(xh=x, weight=w * J, normal_weighted=jn)


@bounded_cache("singular_quadrature")
def singular_quadrature(n_theta: int, n_rot: int | None = None) -> SingularQuadrature:
    """Shared quadrature tables; ``n_rot`` defaults to ``n_theta`` (see docs for convergence)."""
    return SingularQuadrature(n_theta, n_theta if n_rot is None else n_rot)
