"""Small-deformation theories (SPEC §12)."""

import numpy as np
import pytest

from vesicle import theory


def test_tt_inclination_limits_and_transition():
    assert theory.misbah_tt_inclination(0.999999, 1.0) == pytest.approx(np.pi / 4, abs=1e-2)
    lam_c = theory.misbah_critical_lambda(0.95)
    assert theory.misbah_tt_inclination(0.95, lam_c * 0.999) > 0
    assert theory.misbah_tt_inclination(0.95, lam_c * 0.999) < 0.03
    assert np.isnan(theory.misbah_tt_inclination(0.95, lam_c * 1.01))
    # psi decreases with lam and with the excess area
    assert theory.misbah_tt_inclination(0.95, 1) > theory.misbah_tt_inclination(0.95, 2)
    assert theory.misbah_tt_inclination(0.97, 1) > theory.misbah_tt_inclination(0.95, 1)


def test_tt_rheology_is_the_general_formula_at_the_tt_state():
    for v, lam in ((0.95, 1.0), (0.98, 3.0), (0.9, 0.5)):
        psi = theory.misbah_tt_inclination(v, lam)
        delta = theory.excess_area(v)
        general = theory.danker_misbah_rheology(v, lam, np.sqrt(delta) / 2, psi)
        tt = theory.danker_misbah_tt_rheology(v, lam)
        for key in ("S_xz", "N1", "N2"):
            assert tt[key] == pytest.approx(general[key], rel=1e-12)
        assert tt["N1"] > 0 > tt["N2"] and tt["N1"] == pytest.approx(-2 * tt["N2"])
        assert tt["S_xz"] < 2.5


def test_sphere_limits():
    assert theory.danker_misbah_tt_rheology(1.0, 3.0)["S_xz"] == pytest.approx(2.5)
    assert theory.misbah_critical_lambda(1.0) == np.inf
    with pytest.raises(ValueError, match="sphere"):
        theory.lebedev_parameters(1.0, 1.0, 1.0)


def test_lebedev_parameters_scale():
    S, Lam = theory.lebedev_parameters(0.95, 2.0, 8.0)
    S1, Lam1 = theory.lebedev_parameters(0.95, 1.0, 8.0)
    assert S == pytest.approx(2 * S1) and Lam == pytest.approx(Lam1)
    # Lambda = 1 on the leading-order TT boundary
    lam_c = theory.misbah_critical_lambda(0.95)
    Lam_c = theory.lebedev_parameters(0.95, 1.0, lam_c)[1]
    assert Lam_c == pytest.approx(
        4 / np.sqrt(30 * np.pi) * np.sqrt(theory.excess_area(0.95)) * (1 + 23 * lam_c / 32)
    )


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.5, np.nan])
def test_bad_reduced_volume(bad):
    with pytest.raises(ValueError, match="reduced volume"):
        theory.misbah_tt_inclination(bad, 1.0)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_bad_lambda(bad):
    with pytest.raises(ValueError, match="lam"):
        theory.danker_misbah_tt_rheology(0.95, bad)
