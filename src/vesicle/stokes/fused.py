"""Fused kernel values at the rotated nodes of one ring (Numba), for layer-potential assembly.

From the radius and its rotated-frame derivatives at the rotated nodes of the targets on one ring,
one pass computes what :meth:`~vesicle.stokes.quadrature.SingularQuadrature.ring_geometry`
followed by the kernel products of :class:`~vesicle.stokes.operators.LayerPotentials` computes
with NumPy temporaries: position and weighted normal (turned to the lab frame by the target's
z-rotation), then the six symmetric components

- single layer: ``w J (delta_ab / r + xh_a xh_b / r^3)``;
- double layer: ``-6 (xh . w J n) xh_a xh_b / r^5``, and the sum of these over the nodes (the
  singularity subtraction's diagonal).

The NumPy path in :mod:`.operators` is the reference; tests hold this one to it.  Compiled on
first use and cached on disk; it releases the GIL, so rings run in threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vesicle.stokes.kernels import PAIRS as KERNEL_PAIRS

__all__ = ["PAIRS", "ring_components", "ring_shape_difference", "scatter_rows"]

#: The six stored components of a symmetric kernel: the one definition of :mod:`.kernels`.
PAIRS = KERNEL_PAIRS


@njit(cache=True, nogil=True)
def _fill(r, rt, rp, frame, inv_sin, w, cos_k, sin_k, x0, single, double, comps, diag):
    n_nodes, n_targets = r.shape
    off = 6 if single else 0
    for q in range(n_nodes):
        er0, er1, er2 = frame[0, 0, q], frame[0, 1, q], frame[0, 2, q]
        et0, et1, et2 = frame[1, 0, q], frame[1, 1, q], frame[1, 2, q]
        ep0, ep1, ep2 = frame[2, 0, q], frame[2, 1, q], frame[2, 2, q]
        wq, isq = w[q], inv_sin[q]
        for k in range(n_targets):
            rr, rtt, rpp = r[q, k], rt[q, k], rp[q, k] * isq
            # x and J n = r (r e_r - r_theta e_theta - r_phi / sin e_phi) in the Ry frame
            y0, y1, y2 = rr * er0, rr * er1, rr * er2
            n0 = rr * (rr * er0 - rtt * et0 - rpp * ep0)
            n1 = rr * (rr * er1 - rtt * et1 - rpp * ep1)
            n2 = rr * (rr * er2 - rtt * et2 - rpp * ep2)
            c, s = cos_k[k], sin_k[k]
            h0 = c * y0 - s * y1 - x0[0, k]
            h1 = s * y0 + c * y1 - x0[1, k]
            h2 = y2 - x0[2, k]
            m0, m1 = c * n0 - s * n1, s * n0 + c * n1
            weight = wq * np.sqrt(m0 * m0 + m1 * m1 + n2 * n2)
            d2 = h0 * h0 + h1 * h1 + h2 * h2
            inv_r = 1.0 / np.sqrt(d2)
            p00, p01, p02 = h0 * h0, h0 * h1, h0 * h2
            p11, p12, p22 = h1 * h1, h1 * h2, h2 * h2
            if single:
                a = weight * inv_r * inv_r * inv_r
                b = weight * inv_r
                comps[q, 0, k] = a * p00 + b
                comps[q, 1, k] = a * p01
                comps[q, 2, k] = a * p02
                comps[q, 3, k] = a * p11 + b
                comps[q, 4, k] = a * p12
                comps[q, 5, k] = a * p22 + b
            if double:
                ir2 = inv_r * inv_r
                t = -6.0 * wq * (h0 * m0 + h1 * m1 + h2 * n2) * ir2 * ir2 * inv_r
                v00, v01, v02 = t * p00, t * p01, t * p02
                v11, v12, v22 = t * p11, t * p12, t * p22
                comps[q, off + 0, k] = v00
                comps[q, off + 1, k] = v01
                comps[q, off + 2, k] = v02
                comps[q, off + 3, k] = v11
                comps[q, off + 4, k] = v12
                comps[q, off + 5, k] = v22
                diag[k, 0, 0] -= v00
                diag[k, 0, 1] -= v01
                diag[k, 0, 2] -= v02
                diag[k, 1, 1] -= v11
                diag[k, 1, 2] -= v12
                diag[k, 2, 2] -= v22


def ring_components(
    r: np.ndarray,
    rt: np.ndarray,
    rp: np.ndarray,
    frame: np.ndarray,
    inv_sin: np.ndarray,
    weights: np.ndarray,
    phi: np.ndarray,
    x0: np.ndarray,
    kinds: tuple[str, ...],
) -> tuple[np.ndarray, np.ndarray | None]:
    """Kernel components at the rotated nodes of one ring's targets.

    Parameters
    ----------
    r, rt, rp : (Q, K)
        Radius and its ``theta'``, ``phi'`` derivatives at the rotated nodes of each target.
    frame : (3, 3, Q)
        ``e_r', e_theta', e_phi'`` at the nodes, turned by the ring's y-rotation.
    inv_sin : (Q,)
        ``1 / sin(theta')``.
    weights : (Q,)
        Quadrature weights of ``dOmega'``.
    phi : (K,)
        The targets' azimuths (their z-rotations).
    x0 : (3, K)
        The targets.
    kinds : tuple of {"single", "double"}
        In this order in the output.

    Returns
    -------
    comps : (Q, 6 * len(kinds), K)
        The six symmetric components ``(00, 01, 02, 11, 12, 22)`` of each kind.
    diagonal : (K, 3, 3) or None
        ``-sum_q`` of the double-layer components (symmetric), when "double" is in ``kinds``.
    """
    single, double = "single" in kinds, "double" in kinds
    n_nodes, n_targets = r.shape
    comps = np.empty((n_nodes, 6 * (single + double), n_targets))
    diag = np.zeros((n_targets, 3, 3))
    _fill(
        np.ascontiguousarray(r),
        np.ascontiguousarray(rt),
        np.ascontiguousarray(rp),
        np.ascontiguousarray(frame),
        np.ascontiguousarray(inv_sin),
        np.ascontiguousarray(weights),
        np.cos(phi),
        np.sin(phi),
        np.ascontiguousarray(x0),
        single,
        double,
        comps,
        diag,
    )
    if not double:
        return comps, None
    iu = np.triu_indices(3, 1)
    diag[:, iu[1], iu[0]] = diag[:, iu[0], iu[1]]
    return comps, diag


_PAIR_A = np.array([a for a, _ in PAIRS])
_PAIR_B = np.array([b for _, b in PAIRS])


@njit(cache=True, nogil=True)
def _scatter(re, im, cos, sin, out, ring, first, pair_a, pair_b):
    n_tri, _, n_targets = re.shape
    for t in range(n_tri):
        for p in range(6):
            a, b = pair_a[p], pair_b[p]
            for k in range(n_targets):
                x, y = re[t, first + p, k], im[t, first + p, k]
                c, s = cos[t, k], sin[t, k]
                v0, v1 = x * c + y * s, y * c - x * s
                out[b, 0, t, a, ring, k] = v0
                out[b, 1, t, a, ring, k] = v1
                out[a, 0, t, b, ring, k] = v0
                out[a, 1, t, b, ring, k] = v1


def scatter_rows(
    re: np.ndarray,
    im: np.ndarray,
    cos: np.ndarray,
    sin: np.ndarray,
    out: np.ndarray,
    ring: int,
    first: int,
) -> None:
    """Write one kernel's operator rows for ring ``ring`` into the transposed matrix ``out``.

    ``re``, ``im`` (T, components, K) are the pulled-back coefficients before the z-phase; the
    six components ``first .. first + 5`` are one kernel's ``(00, 01, 02, 11, 12, 22)``.  The
    phase ``e^{-i m phi_k}`` (``cos``, ``sin``: (T, K)) is applied on the way, and each symmetric
    component is written to both of its places in ``out`` (3 [density], 2 [Re, Im], T,
    3 [output], rings, K).  The NumPy equivalent:
    :func:`.backends.numpy_backend.assemble_ring_numpy`.
    """
    _scatter(re, im, cos, sin, out, ring, first, _PAIR_A, _PAIR_B)


# ------------------------------------------------- shape derivatives at fixed densities
@njit(inline="always", fastmath=True, error_model="numpy")
def _moved_node(rr, rtt, rpp, fr, c, s, t0, t1, t2, wq, ws, wd, f0, f1, f2, g0, g1, g2):
    """Single- and double-layer terms of one node for one moved geometry (formulas of _fill);
    ``fr`` holds the node's ``e_r', e_theta', e_phi'`` components."""
    y0, y1, y2 = rr * fr[0], rr * fr[1], rr * fr[2]
    n0 = rr * (y0 - rtt * fr[3] - rpp * fr[6])
    n1 = rr * (y1 - rtt * fr[4] - rpp * fr[7])
    n2 = rr * (y2 - rtt * fr[5] - rpp * fr[8])
    h0, h1, h2 = c * y0 - s * y1 - t0, s * y0 + c * y1 - t1, y2 - t2
    m0, m1 = c * n0 - s * n1, s * n0 + c * n1
    inv_r = 1.0 / np.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    ir2 = inv_r * inv_r
    # single layer: w J (f / r + h (h . f) / r^3)
    b = ws * wq * np.sqrt(m0 * m0 + m1 * m1 + n2 * n2) * inv_r
    a = b * ir2 * (h0 * f0 + h1 * f1 + h2 * f2)
    # double layer: -6 (h . w J n) h (h . g) / r^5
    t = wd * -6.0 * wq * (h0 * m0 + h1 * m1 + h2 * n2) * ir2 * ir2 * inv_r
    t *= h0 * g0 + h1 * g1 + h2 * g2
    return a * h0 + b * f0, a * h1 + b * f1, a * h2 + b * f2, t * h0, t * h1, t * h2


@njit(cache=True, nogil=True, fastmath=True, error_model="numpy")
def _node_sums(r, rt, rp, dr, drt, drp, fr, isn, w, c, s, p, m, f, g, eps, ws, wd):
    """The sums over the nodes of one target and one direction (1-D arrays over the nodes)."""
    s0 = s1 = s2 = d0 = d1 = d2 = 0.0
    for q in range(r.size):
        frq = (fr[0, q], fr[1, q], fr[2, q], fr[3, q], fr[4, q], fr[5, q], fr[6, q], fr[7, q],
               fr[8, q])  # fmt: skip
        f0, f1, f2, g0, g1, g2 = f[0, q], f[1, q], f[2, q], g[0, q], g[1, q], g[2, q]
        er, et, ep = eps * dr[q], eps * drt[q], eps * drp[q]
        a = _moved_node(
            r[q] + er, rt[q] + et, (rp[q] + ep) * isn[q], frq, c, s, p[0], p[1], p[2], w[q],
            ws, wd, f0, f1, f2, g0, g1, g2,
        )  # fmt: skip
        b = _moved_node(
            r[q] - er, rt[q] - et, (rp[q] - ep) * isn[q], frq, c, s, m[0], m[1], m[2], w[q],
            ws, wd, f0, f1, f2, g0, g1, g2,
        )  # fmt: skip
        s0 += a[0] - b[0]
        s1 += a[1] - b[1]
        s2 += a[2] - b[2]
        d0 += a[3] - b[3]
        d1 += a[4] - b[4]
        d2 += a[5] - b[5]
    return s0, s1, s2, d0, d1, d2


@njit(cache=True, nogil=True)
def _shape_difference(
    r, rt, rp, dr, drt, drp, frame, inv_sin, w, cos_k, sin_k, x0, dx0, f, u, u0, eps,
    single, double, out_s, out_d,
):  # fmt: skip
    """``sum_q [k(x + eps d) - k(x - eps d)] . density`` for every direction ``d``.

    Layouts put the nodes last (``r[k, q]``, ``dr[j, k, q]``, ``f[k, c, q]``) so that the sum
    over nodes is a vectorised reduction; the difference is taken node by node, before the sum.
    """
    n_dir, n_targets, n_nodes = dr.shape
    ws = 1.0 if single else 0.0
    wd = 1.0 if double else 0.0
    fr = frame.reshape(9, n_nodes)
    g = np.empty((3, n_nodes))
    p = np.empty(3)
    m = np.empty(3)
    for k in range(n_targets):
        for a in range(3):
            g[a] = u[k, a] - u0[a, k]
        for j in range(n_dir):
            for a in range(3):
                p[a] = x0[a, k] + eps * dx0[j, a, k]
                m[a] = x0[a, k] - eps * dx0[j, a, k]
            sums = _node_sums(
                r[k], rt[k], rp[k], dr[j, k], drt[j, k], drp[j, k], fr, inv_sin, w,
                cos_k[k], sin_k[k], p, m, f[k], g, eps, ws, wd,
            )  # fmt: skip
            out_s[j, 0, k], out_s[j, 1, k], out_s[j, 2, k] = sums[0], sums[1], sums[2]
            out_d[j, 0, k], out_d[j, 1, k], out_d[j, 2, k] = sums[3], sums[4], sums[5]


def ring_shape_difference(
    base: tuple[np.ndarray, np.ndarray, np.ndarray],
    directions: tuple[np.ndarray, np.ndarray, np.ndarray],
    frame: np.ndarray,
    inv_sin: np.ndarray,
    weights: np.ndarray,
    phi: np.ndarray,
    x0: np.ndarray,
    dx0: np.ndarray,
    f: np.ndarray | None,
    u: np.ndarray | None,
    u0: np.ndarray | None,
    eps: float,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Central differences, times ``2 eps``, of the layer potentials of fixed densities at the
    targets of one ring when the radius moves by ``+- eps`` along each direction.

    Parameters
    ----------
    base : (r, r_theta', r_phi'), each (K, Q)
        The radius and its rotated-frame derivatives at the rotated nodes of each target.
    directions : (dr, dr_theta', dr_phi'), each (J, K, Q)
        The same for the J radius directions.
    frame, inv_sin, weights, phi, x0
        As in :func:`ring_components`.
    dx0 : (J, 3, K)
        How the targets move along each direction.
    f, u : (K, 3, Q) or None
        Single- and double-layer densities at the rotated nodes (grid values, fixed).
    u0 : (3, K)
        The double-layer density at the targets (its singularity subtraction).

    Returns
    -------
    single, double : (J, 3, K) or None
        ``N[f](x + eps d) - N[f](x - eps d)`` and the same for ``K[u]`` (the ``-4 pi u0`` of the
        subtraction does not move).
    """
    n_dir, n_targets, n_nodes = directions[0].shape
    single, double = f is not None, u is not None
    dummy = np.zeros((n_targets, 3, n_nodes))
    out_s = np.zeros((n_dir, 3, n_targets))
    out_d = np.zeros((n_dir, 3, n_targets))
    contiguous = np.ascontiguousarray
    _shape_difference(
        *(contiguous(a) for a in base),
        *(contiguous(a) for a in directions),
        contiguous(frame),
        contiguous(inv_sin),
        contiguous(weights),
        np.cos(phi),
        np.sin(phi),
        contiguous(x0),
        contiguous(dx0),
        contiguous(f) if single else dummy,
        contiguous(u) if double else dummy,
        contiguous(u0) if double else dummy[:, :, 0].T,
        float(eps),
        single,
        double,
        out_s,
        out_d,
    )
    return (out_s if single else None), (out_d if double else None)
