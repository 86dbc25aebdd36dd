"""Small-deformation theories of a quasi-spherical vesicle in shear (SPEC §12): baselines.

All take the reduced volume ``v`` (through the excess area ``Delta = 4 pi (v^(-2/3) - 1)``) and the
viscosity ratio ``lam``; they hold to leading order in ``Delta``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "danker_misbah_rheology",
    "danker_misbah_tt_rheology",
    "effective_viscosity_ratio",
    "excess_area",
    "lebedev_parameters",
    "misbah_critical_lambda",
    "misbah_tt_inclination",
]


def excess_area(v: float) -> float:
    """``Delta = 4 pi (v^(-2/3) - 1)`` for a reduced volume ``v`` in (0, 1]."""
    v = float(v)
    if not (np.isfinite(v) and 0.0 < v <= 1.0):
        raise ValueError(f"reduced volume v must lie in (0, 1], got {v}")
    return 4.0 * np.pi * (v ** (-2.0 / 3.0) - 1.0)


def _lam(lam: float) -> float:
    lam = float(lam)
    if not (np.isfinite(lam) and lam > 0.0):
        raise ValueError(f"viscosity ratio lam must be positive and finite, got {lam}")
    return lam


def _misbah_argument(v: float, lam: float) -> float:
    return (23.0 * _lam(lam) + 32.0) / 120.0 * np.sqrt(15.0 * excess_area(v) / (2.0 * np.pi))


def misbah_tt_inclination(v: float, lam: float) -> float:
    """Leading-order tank-treading angle (Misbah 2006, SPEC (3.6)), in radians.

    ``psi = arccos[(23 lam + 32)/120 sqrt(15 Delta / 2 pi)] / 2``; ``nan`` where the bracket
    exceeds 1 (no tank-treading at this order).
    """
    arg = _misbah_argument(v, lam)
    return float(0.5 * np.arccos(arg)) if arg <= 1.0 else float("nan")


def effective_viscosity_ratio(lam: float, bq: float) -> float:
    """``lam + (16/23) Bq``: the viscosity ratio of an inviscid membrane whose ``l = 2`` shape
    modes have the drag of a membrane of Boussinesq number ``bq`` (the drag ``23 lam + 32 +
    16 Bq``, docs/reference/membrane-viscosity.md §4): the leading-order theories' use of ``Bq``."""
    return _lam(lam) + 16.0 * float(bq) / 23.0


def misbah_critical_lambda(v: float) -> float:
    """``lam`` where the bracket of (3.6) reaches 1: leading-order TT-TU transition."""
    delta = excess_area(v)
    if delta == 0.0:
        return float("inf")
    return float((120.0 / np.sqrt(15.0 * delta / (2.0 * np.pi)) - 32.0) / 23.0)


def lebedev_parameters(v: float, chi: float, lam: float) -> tuple[float, float]:
    """Lebedev et al. (2007) ``(S, Lambda)`` of a parameter point (SPEC (3.8)).

    ``S = 7 pi / (3 sqrt 3) chi v / Delta``, ``Lambda = 4/sqrt(30 pi) sqrt(Delta) (1 + 23 lam/32)``.
    """
    delta = excess_area(v)
    if delta == 0.0:
        raise ValueError("the Lebedev parameters are undefined for a sphere (Delta = 0)")
    S = 7.0 * np.pi / (3.0 * np.sqrt(3.0)) * float(chi) * v / delta
    Lam = 4.0 / np.sqrt(30.0 * np.pi) * np.sqrt(delta) * (1.0 + 23.0 * _lam(lam) / 32.0)
    return float(S), float(Lam)


def _h(lam: float) -> float:
    return 60.0 * np.sqrt(2.0 * np.pi / 15.0) / (23.0 * _lam(lam) + 32.0)


def danker_misbah_rheology(v: float, lam: float, R: float, psi: float) -> dict[str, float]:
    """Leading-order specific stress for shape amplitude ``R`` and angle ``psi`` (SPEC (3.14)).

    ``S_xz = 5/2 - sqrt(30/pi) h + (h/Delta) sqrt(480/pi) R^2 sin^2(2 psi)``,
    ``N1 = -2 N2 = (h/Delta) sqrt(480/pi) R^2 sin(4 psi)``, ``h = 60 sqrt(2 pi/15)/(23 lam + 32)``.
    """
    delta = excess_area(v)
    h = _h(lam)
    c = h / delta * np.sqrt(480.0 / np.pi) * R * R
    n1 = c * np.sin(4.0 * psi)
    return {
        "S_xz": float(2.5 - np.sqrt(30.0 / np.pi) * h + c * np.sin(2.0 * psi) ** 2),
        "N1": float(n1),
        "N2": float(-0.5 * n1),
    }


def danker_misbah_tt_rheology(v: float, lam: float) -> dict[str, float]:
    """Leading-order tank-treading stress: ``R = sqrt(Delta)/2`` (SPEC §12).

    ``S_xz = 5/2 - sqrt(15/(8 pi)) Delta / h``, ``N1 = -2 N2 = sqrt(15 Delta (4h^2 - Delta) /
    (2 pi h^2))``; all ``nan`` where TT does not exist at this order (``4 h^2 < Delta``).
    """
    delta = excess_area(v)
    h = _h(lam)
    disc = 15.0 * delta * (4.0 * h * h - delta) / (2.0 * np.pi * h * h)
    if disc < 0.0:  # beyond the leading-order TT-TU transition
        return {"S_xz": float("nan"), "N1": float("nan"), "N2": float("nan")}
    s_xz = 2.5 - np.sqrt(15.0 / (8.0 * np.pi)) * delta / h
    n1 = np.sqrt(disc)
    return {"S_xz": float(s_xz), "N1": float(n1), "N2": float(-0.5 * n1)}
