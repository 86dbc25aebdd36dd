"""Pseudo-arclength continuation of ``G(y, p) = 0`` (SPEC §16): the numerical core.

Pure numerics on callables, independent of vesicles (tested on model folds):

- :func:`tangent`: the unit null vector of ``[G_y | G_p]`` (the branch direction in ``(y, p)``),
  oriented along a previous tangent;
- :func:`corrector`: Newton on the bordered system ``G(y, p) = 0``,
  ``t . ((y, p) - (y, p)_pred) = 0`` with a fixed (chord) bordered matrix, which passes folds
  where ``p`` is extremal and ``G_y`` singular.

A fold is where the tangent's ``p`` component changes sign.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["ArclengthPoint", "CorrectorResult", "arclength_step", "corrector", "tangent"]


def tangent(G_y: np.ndarray, G_p: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """The unit vector spanning the null space of ``[G_y | G_p]`` (n x (n + 1)), with a
    non-negative projection on ``previous`` (the direction of travel)."""
    A = np.hstack([np.asarray(G_y, float), np.asarray(G_p, float).reshape(-1, 1)])
    t = np.linalg.svd(A)[2][-1]
    if previous is not None and t @ previous < 0:
        t = -t
    return t / np.linalg.norm(t)


@dataclass(frozen=True)
class CorrectorResult:
    z: np.ndarray  # (y, p) at the end
    residuals: tuple[float, ...]
    converged: bool
    data: object  # what ``residual`` returned with the last residual (e.g. a solve)


def corrector(
    residual: Callable[[np.ndarray, float], tuple[np.ndarray, float, object]],
    G_y: np.ndarray,
    G_p: np.ndarray,
    z_pred: np.ndarray,
    t: np.ndarray,
    tolerance: float,
    max_iterations: int = 12,
    contraction: float = 0.8,
) -> CorrectorResult:
    """Chord Newton on the bordered system from the predictor ``z_pred = (y, p)``.

    ``residual(y, p)`` returns ``(G, size, data)``: the residual vector, the norm that is held
    to ``tolerance`` and anything to keep from the evaluation.  The bordered matrix
    ``[[G_y, G_p], [t]]`` is the one at the previous point (one evaluation per iteration); the
    iteration gives up (``converged = False``) when a step contracts the residual by less than
    ``contraction`` twice in a row, so that the caller can shorten the step.
    """
    n = G_y.shape[0]
    B = np.zeros((n + 1, n + 1))
    B[:n, :n], B[:n, n], B[n] = G_y, G_p, t
    z = np.array(z_pred, float)
    sizes: list[float] = []
    slow = 0
    data = None
    for _ in range(max_iterations + 1):
        G, size, data = residual(z[:-1], float(z[-1]))
        sizes.append(size)
        if size < tolerance:
            return CorrectorResult(z, tuple(sizes), True, data)
        if len(sizes) > 1:
            slow = slow + 1 if sizes[-1] > contraction * sizes[-2] else 0
            if slow >= 2 or not np.isfinite(size):
                break
        rhs = -np.concatenate([G, [t @ (z - z_pred)]])
        z = z + np.linalg.solve(B, rhs)
    return CorrectorResult(z, tuple(sizes), False, data)


@dataclass(frozen=True)
class ArclengthPoint:
    """A converged point of :func:`arclength_step`: ``z = (y, p)``, its tangent, its Jacobian
    blocks, the arclength step that reached it, and the caller's data."""

    z: np.ndarray
    tangent: np.ndarray
    G_y: np.ndarray
    G_p: np.ndarray
    ds: float
    data: object


def arclength_step(
    residual: Callable[[np.ndarray, float], tuple[np.ndarray, float, object]],
    jacobian: Callable[[np.ndarray, object], tuple[np.ndarray, np.ndarray, object]],
    point: ArclengthPoint,
    ds: float,
    tolerance: float,
    ds_min: float,
) -> ArclengthPoint:
    """One predictor-corrector step of length ``ds`` from ``point`` (halved while the corrector
    fails, down to ``ds_min``; then ``RuntimeError``).  ``jacobian(z, data)`` returns the blocks
    ``(G_y, G_p)`` at a converged point and the data to keep (e.g. a steady-state result)."""
    while abs(ds) >= ds_min:
        z_pred = point.z + ds * point.tangent
        c = corrector(residual, point.G_y, point.G_p, z_pred, point.tangent, tolerance)
        if c.converged:
            G_y, G_p, data = jacobian(c.z, c.data)
            t = tangent(G_y, G_p, previous=point.tangent)
            return ArclengthPoint(c.z, t, G_y, G_p, ds, data)
        ds *= 0.5
    raise RuntimeError(f"the arclength corrector failed down to ds = {ds_min:g}")
