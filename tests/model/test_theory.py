"""Small-deformation theories (SPEC §12)."""

import numpy as np
import pytest

from vesicle.model import theory


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
        assert tt["N1"] > 0 > tt["N2"]
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


@pytest.mark.parametrize("v", [0.85, 0.95, 0.99])
@pytest.mark.parametrize("lam", [0.2, 1.0, 3.0, 12.0])
def test_lebedevs_lambda_is_misbahs_tt_bracket(v, lam):
    """Two papers, two formulas: Lebedev et al. 2007's Lambda = 4/sqrt(30 pi) sqrt(Delta)
    (1 + 23 lam/32) and Misbah 2006's cos(2 psi) = (23 lam + 32)/120 sqrt(15 Delta/(2 pi)) are
    the same number (both are the ratio of the vorticity's rotation to the strain's alignment
    at leading order); so Lambda = 1 is the TT boundary.  A slip in either fails here."""
    Lam = theory.lebedev_parameters(v, 1.0, lam)[1]
    psi = theory.misbah_tt_inclination(v, lam)
    if Lam <= 1.0:
        assert np.cos(2 * psi) == pytest.approx(Lam, rel=1e-12)
    else:
        assert np.isnan(psi)
    lam_c = theory.misbah_critical_lambda(v)
    assert theory.lebedev_parameters(v, 1.0, lam_c)[1] == pytest.approx(1.0, rel=1e-12)


def test_the_lambda_dependence_is_that_of_the_l2_relaxation_rate():
    """The viscosity ratio enters the leading-order theory only through the relaxation rate of
    the l = 2 shape mode of a sphere.  Independently of theory.py, the §15 eigenvalues give
    Gamma_2 = 144 / (23 lam + 32) (``sphere_relaxation_rates``, zero tension); so cos(2 psi)
    must scale like 1 / Gamma_2 and the theory's h like Gamma_2.  Swapping 23 and 32 fails."""
    from vesicle.stokes.spectra import sphere_relaxation_rates

    lams = np.array([0.1, 0.5, 1.0, 2.0, 4.0])
    gamma = np.array([sphere_relaxation_rates(2, lam)[2] for lam in lams])
    np.testing.assert_allclose(gamma * (23 * lams + 32), 144.0, rtol=1e-12)
    cos2psi = np.array([np.cos(2 * theory.misbah_tt_inclination(0.99, lam)) for lam in lams])
    np.testing.assert_allclose(cos2psi * gamma, cos2psi[0] * gamma[0], rtol=1e-12)
    # the TT viscosity's excess over 5/2 scales like 1/h, i.e. like 1/Gamma_2
    excess = np.array([2.5 - theory.danker_misbah_tt_rheology(0.99, lam)["S_xz"] for lam in lams])
    np.testing.assert_allclose(excess * gamma, excess[0] * gamma[0], rtol=1e-12)


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.5, np.nan])
def test_bad_reduced_volume(bad):
    with pytest.raises(ValueError, match="reduced volume"):
        theory.misbah_tt_inclination(bad, 1.0)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_bad_lambda(bad):
    with pytest.raises(ValueError, match="lam"):
        theory.danker_misbah_tt_rheology(0.95, bad)
