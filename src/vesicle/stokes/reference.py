"""Slow, plain reference for the layer potentials: one target at a time, direct series evaluation.

Everything the fast path takes from rotations of coefficients is recomputed here from first
principles: the rotated nodes' parameter angles in the lab frame, the density and the radius (with
its lab-frame derivatives) summed directly at those angles, and the kernels applied pointwise.
The tests hold :class:`vesicle.stokes.LayerPotentials` to it on small grids.
"""

from __future__ import annotations

import numpy as np

from vesicle.geometry.surface import Shape
from vesicle.sphere.grid import spherical_basis
from vesicle.sphere.rotation import rotated_angles, rotation_matrix
from vesicle.sphere.transforms import evaluate, transform
from vesicle.stokes.kernels import stokeslet_apply, stresslet_apply
from vesicle.stokes.quadrature import singular_quadrature

__all__ = ["layer_potential_reference"]


def layer_potential_reference(
    shape: Shape,
    density: np.ndarray,
    kind: str,
    targets: list[tuple[int, int]],
    n_rot: int | None = None,
) -> np.ndarray:
    """``N[density]`` (``kind="single"``) or ``K[density]`` (``"double"``) at grid ``targets``.

    Returns an array (3, len(targets)).
    """
    quad = singular_quadrature(shape.grid.n_theta, n_rot)
    c_density = transform(shape.grid.n_theta).analysis(density)
    th_rot, ph_rot = quad.node_angles()
    w_rot = quad.weights_rot
    out = np.zeros((3, len(targets)))
    for n, (i, k) in enumerate(targets):
        R = rotation_matrix("z", shape.grid.phi[k]) @ rotation_matrix("y", shape.grid.theta[i])
        th, ph = rotated_angles(R, th_rot, ph_rot)
        r, r_t, r_p = evaluate(shape.coefficients, th, ph, derivatives=True)
        e_r, e_t, e_p = spherical_basis(th, ph)
        x = r * e_r
        jn = r * r * e_r - r * (r_t * e_t + r_p / np.sin(th) * e_p)  # sqrt(g)/sin(theta) n
        J = np.linalg.norm(jn, axis=0)
        psi = evaluate(c_density, th, ph)
        x0 = shape.x[:, i, k]
        xh = x - x0[:, None]
        if kind == "single":
            integrand = stokeslet_apply(xh, psi) * (w_rot * J)
            out[:, n] = integrand.sum(axis=1)
        elif kind == "double":
            u0 = density[:, i, k]
            integrand = stresslet_apply(xh, jn / J, psi - u0[:, None]) * (w_rot * J)
            out[:, n] = integrand.sum(axis=1) - 4.0 * np.pi * u0
        else:
            raise ValueError(f"kind must be 'single' or 'double', got {kind!r}")
    return out
