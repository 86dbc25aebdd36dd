"""Time-dependent runs: restart, interruption, relaxation, drift control, diagnostics."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vesicle as vs
from vesicle.dynamics.integrators import (
    Integrator,
    RunParameters,
    rate_of_change,
    restore_area_volume,
)
from vesicle.dynamics.simulation import load_parameters, simulate, summarize
from vesicle.geometry.diagnostics import classify_regime, diagnose, recentered
from vesicle.io.files import read_run, write_run
from vesicle.sphere.rotation import rotation_matrix

FAST = {"grid": 12, "degree": 4, "save_every": 0.02, "dt0": 1e-3}


def params(**changes):
    """The small run, with ``changes`` (flat physics and discretisation keys too)."""
    return RunParameters().replace(**{**FAST, "t_end": 0.06, **changes})


def test_restart_is_bit_identical(tmp_path):
    straight = simulate(params(t_end=0.06), out=tmp_path / "a.h5")
    simulate(params(t_end=0.04), out=tmp_path / "b.h5")  # a save time: same step sequence
    first = read_run(tmp_path / "b.h5")
    resumed = simulate(params(t_end=0.06), out=tmp_path / "b.h5", resume=first)
    for key, value in straight.series.items():
        np.testing.assert_array_equal(resumed.series[key], value, err_msg=key)
    np.testing.assert_array_equal(resumed.coefficients, straight.coefficients)
    np.testing.assert_array_equal(read_run(tmp_path / "b.h5").coefficients, straight.coefficients)


def _interrupted_after(steps: int, run_params: RunParameters, path: Path):
    """The run file of ``run_params`` interrupted (Ctrl-C) after ``steps`` accepted steps."""
    calls = []

    def interrupt(info):
        calls.append(info)
        if len(calls) == steps:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate(run_params, out=path, progress=interrupt)
    return read_run(path)


def test_interrupted_run_resumes_exactly(tmp_path):
    straight = simulate(params())
    partial = _interrupted_after(4, params(), tmp_path / "c.h5")
    assert partial.checkpoint["steps"] == 4 and partial.checkpoint["t"] < 0.06
    resumed = simulate(load_parameters(partial), resume=partial)
    np.testing.assert_array_equal(resumed.coefficients, straight.coefficients)
    np.testing.assert_array_equal(resumed.series["S_xz"], straight.series["S_xz"])


def test_a_viscous_membranes_run_resumes_exactly_with_its_preconditioner(tmp_path, monkeypatch):
    """Bq > 0: the solves are preconditioned by a kept factorised system, refreshed when GMRES
    needs more than REFRESH_ITERATIONS (here 1: a refresh at nearly every solve, so that the
    kept system's shape is not the run's start).  The checkpoint keeps that shape; the
    resumed run factorises it again and repeats the same iterations: bit-identical.  Against
    the nested solves (the reference, viscous_solve = "nested"): the same run to the solves'
    tolerance (1e-4 relative on the system; measured 2e-7 in the radius coefficients)."""
    import vesicle.dynamics.integrators as integrators

    monkeypatch.setattr(integrators, "REFRESH_ITERATIONS", 1)
    viscous = params(bq=2.0, lam=3.0, t_end=0.06)
    straight = simulate(viscous)
    partial = _interrupted_after(4, viscous, tmp_path / "v.h5")
    anchor = partial.checkpoint["preconditioner_shape"]
    assert not np.array_equal(anchor, straight.coefficients[0])  # refreshed since the start
    resumed = simulate(load_parameters(partial), resume=partial)
    np.testing.assert_array_equal(resumed.coefficients, straight.coefficients)
    np.testing.assert_array_equal(resumed.series["S_xz"], straight.series["S_xz"])
    # the membrane's viscous part of S is a series of viscous runs only
    part = straight.series["S_membrane"]
    assert part.shape == straight.series["S"].shape and np.all(np.isfinite(part))
    assert 0 < np.abs(part[-1]).max() < np.abs(straight.series["S"][-1]).max()
    assert "S_membrane" not in simulate(params(t_end=0.02)).series
    nested = simulate(viscous.replace(viscous_solve="nested"))
    scale = np.abs(straight.coefficients).max()
    assert np.abs(nested.coefficients - straight.coefficients).max() < 1e-5 * scale
    with pytest.raises(ValueError, match="viscous_solve"):
        params(viscous_solve="other")


def test_interrupted_write_never_corrupts_the_file(tmp_path, monkeypatch):
    run = simulate(params(t_end=0.02))
    path = tmp_path / "d.h5"
    write_run(path, run)
    before = path.read_bytes()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    import h5py

    monkeypatch.setattr(h5py.Group, "create_dataset", broken)
    with pytest.raises(OSError, match="disk full"):
        write_run(path, run)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert read_run(path).n_saved == run.n_saved


def test_file_carries_parameters_and_version(tmp_path):
    simulate(params(t_end=0.02, lam=3.0), out=tmp_path / "e.h5")
    data = read_run(tmp_path / "e.h5")
    assert data.attributes["vesicle_version"] == vs.__version__
    physics = data.parameters["physics"]
    assert physics["lam"] == 3.0 and physics["flow"]["gradient"][0][2] == 1.0
    assert data.parameter("lam") == 3.0 and data.parameter("t_end") == 0.02
    assert load_parameters(data) == params(t_end=0.02, lam=3.0)


def test_parameters_of_files_before_the_parameter_objects_still_load(tmp_path):
    """Format 1 stored the parameters flat; they load to the same RunParameters."""
    p = params(t_end=0.02, lam=3.0)
    flat = {
        **{k: x for k, x in p.to_dict().items() if k not in ("physics", "discretisation")},
        "v": p.v, "lam": p.lam, "chi": p.chi, "flow": "shear",
        "flow_gradient": [[0, 0, 1], [0, 0, 0], [0, 0, 0]],
        "grid": p.grid, "degree": p.degree, "tolerances": "time-dependent",
    }  # fmt: skip
    del flat["solver"]
    assert RunParameters.from_dict(flat) == p


def test_relaxation_at_rest_lowers_bending_energy():
    run = simulate(params(chi=0.0, t_end=0.1, save_every=0.01))
    energy = run.series["bending_energy"]
    assert np.all(np.diff(energy) < 0), energy
    assert np.isnan(run.series["S_xz"]).all()


def test_drift_control_holds_area_and_volume():
    p = params(t_end=0.06, drift_tol=1e-6)
    run = simulate(p)
    area, volume = run.series["area"], run.series["volume"]
    assert np.abs(area / area[0] - 1).max() <= p.drift_tol
    assert np.abs(volume / volume[0] - 1).max() <= p.drift_tol
    summary = summarize(run)
    assert summary["corrections"]["area"] > 0 and summary["drift"]["area"] <= p.drift_tol


def test_rate_of_change_of_a_rigid_rotation_matches_rotated_shape():
    """dr/dt for u = w x x equals the time derivative of the rotated radius function."""
    shape = vs.Shape.ellipsoid(1.2, 0.9, 0.8, grid=16, degree=8)
    w = np.array([0.0, 0.7, 0.0])
    u = np.cross(w[:, None, None], shape.x, axis=0)
    rate = rate_of_change(shape, u, 8)
    h = 1e-5
    plus = shape.rotated(rotation_matrix("y", 0.7 * h)).coefficients
    minus = shape.rotated(rotation_matrix("y", -0.7 * h)).coefficients
    np.testing.assert_allclose(rate, (plus - minus) / (2 * h), atol=1e-7)


def test_restore_area_volume():
    shape = vs.Shape.spheroid(0.9, grid=16, degree=8)
    bumped = shape.scaled(1.001).perturbed(0.002, seed=3)
    fixed, da, dv = restore_area_volume(bumped, shape.area, shape.volume, 8)
    assert fixed.area == pytest.approx(shape.area, rel=1e-12)
    assert fixed.volume == pytest.approx(shape.volume, rel=1e-12)
    assert abs(da) > 1e-4 and abs(dv) > 1e-4


def test_recentering_and_diagnostics():
    shape = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=24, degree=12).rotated(
        rotation_matrix("y", -0.4)
    )
    d = diagnose(shape)
    assert d.psi == pytest.approx(0.4, abs=1e-8)
    np.testing.assert_allclose(d.lengths, [2.6, 1.8, 1.6], atol=2e-4)
    assert d.D == pytest.approx((2.6 - 1.6) / (2.6 + 1.6), abs=1e-4)
    shifted = vs.Shape.from_radius(
        lambda t, p: 0.05 * np.cos(t) + np.sqrt(1 - 0.0025 * np.sin(t) ** 2), grid=24, degree=16
    )
    np.testing.assert_allclose(recentered(shifted).radius, 1.0, atol=1e-10)


def test_regime_classification_on_synthetic_series():
    t = np.linspace(0, 20, 2001)
    tt = classify_regime(t, 0.3 + 0.1 * np.exp(-2 * t) * np.cos(3 * t))
    assert tt.name == "TT"
    slow = classify_regime(t, 0.03 * np.exp(-0.08 * t) * np.cos(2.94 * t))  # SPEC §14's case
    assert slow.name == "TT" and "damped" in slow.detail
    tr = classify_regime(t, 0.4 * np.cos(2 * np.pi * t / 2.5))
    assert tr.name == "TR" and tr.period == pytest.approx(2.5, rel=1e-2)
    angle = np.pi / 2 - (np.pi * t / 3.0) % np.pi  # half a turn every 3 time units
    tu = classify_regime(t, angle)
    assert tu.name == "TU" and tu.period == pytest.approx(3.0, rel=1e-2)
    assert classify_regime(t[:3], t[:3]).name == "undetermined"


def test_periods_are_accurate_below_the_save_interval():
    """Saved every 0.1 (about 25 and 31 samples a period, incommensurate), the TR period from
    refined minima and the TU period from interpolated passages through -pi/2 are exact to 1e-4
    relative (the sample times alone: 4e-3 here).  The series
    are exact: a TR oscillation of period 2.47 with a harmonic, and a non-uniform tumbling of
    half-turn period 3 (psi' = -(pi/3)(1 + 0.3 cos 2 psi'), its exact period from the integral
    of 1/psi')."""
    t = np.arange(0.0, 30.0, 0.1)
    psi = 0.4 * np.cos(2 * np.pi * t / 2.47) + 0.05 * np.cos(4 * np.pi * t / 2.47 + 0.3)
    tr = classify_regime(t, psi)
    assert tr.name == "TR" and tr.period == pytest.approx(2.47, rel=1e-4)
    # tumbling with angular speed (pi/3)(1 + 0.3 cos 2 phi): phi(t) from the exact inverse of
    # t(phi) = (3/pi) int dphi/(1 + 0.3 cos 2 phi) = (3/pi) atan(sqrt(0.7/1.3) tan phi)/sqrt(0.91)
    k = np.sqrt(1.3 / 0.7)
    theta = np.pi * t * np.sqrt(0.91) / 3.0  # phase per half turn runs over pi
    phi = np.arctan(k * np.tan(theta)) + np.pi * np.round(theta / np.pi)  # continuous
    angle = np.pi / 2 - (phi + np.pi / 2) % np.pi  # psi decreasing through (-pi/2, pi/2]
    tu = classify_regime(t, angle)
    assert tu.name == "TU" and tu.period == pytest.approx(3.0 / np.sqrt(0.91), rel=1e-4)


@settings(max_examples=30, deadline=None)
@given(
    st.sampled_from(["v", "lam", "t_end", "save_every", "rtol", "dt0"]),
    st.one_of(st.floats(max_value=0.0), st.just(float("nan")), st.just(float("inf"))),
)
def test_bad_run_parameters_are_refused(name, value):
    with pytest.raises(ValueError, match=name if name != "v" else "reduced volume|v must"):
        RunParameters(**{name: value})


def test_too_coarse_grid_is_refused():
    with pytest.raises(ValueError, match="too coarse"):
        RunParameters(vs.Physics(), vs.Discretisation(grid=8, degree=8))


class _ModelIntegrator(Integrator):
    """The integrator on a model stiff ODE, ``y' = -G_l y + cos(y) / 2`` per coefficient, with a
    deliberately wrong approximate Jacobian (half the true stiffness)."""

    G = np.array([0.0, 0.0, 3.0, 40.0, 400.0])

    def evaluate(self, y, sigma0):
        rate = -self.G[:, None] * y + 0.5 * np.cos(y.real)
        return SimpleNamespace(rate=rate, flow=SimpleNamespace(sigma=None), shape=None)

    def stiffness(self, first):
        return 0.5 * self.G


@pytest.mark.parametrize("integrator", ["ros2", "ros34pw2", "bs3", "heun"])
def test_integrators_converge_at_their_order_with_an_approximate_jacobian(integrator):
    """ROS2 and ROS34PW2 are W-methods: orders 2 and 3 for any approximate Jacobian (here half
    the true one); the orders are those their papers state (Verwer et al. 1999; Rang &
    Angermann 2005), measured here on a stiff model problem."""
    integ = _ModelIntegrator(
        RunParameters(vs.Physics(), vs.Discretisation(grid=12, degree=4), integrator=integrator)
    )
    if integrator not in ("ros2", "ros34pw2"):  # explicit: stable only for dt < ~2.5/400
        # drop that mode
        integ.G = np.array([0.0, 0.0, 3.0, 40.0, 0.0])
    y0 = np.full((5, 5), 0.3 + 0.0j)

    def solve(n):
        y = y0.copy()
        for _ in range(n):
            y = integ.step(y, 1.0 / n, integ.evaluate(y, None)).y_new
        return y

    reference = solve(4096)
    errors = [np.abs(solve(n) - reference).max() for n in (64, 128, 256)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > integ.order - 0.3), (errors, orders)


def test_ros34pw2_error_estimate_is_of_third_order():
    """The embedded order-2 solution makes the local error estimate O(h^3) (ROS2's Euler
    estimate is O(h^2)): halving h divides it by 8, with an approximate Jacobian."""
    integ = _ModelIntegrator(
        RunParameters(vs.Physics(), vs.Discretisation(grid=12, degree=4), integrator="ros34pw2")
    )
    integ.G = np.array([0.0, 0.0, 3.0, 40.0, 0.0])  # h G < 1: the asymptotic regime
    y0 = np.full((5, 5), 0.3 + 0.0j)
    errors = [integ.step(y0, h, integ.evaluate(y0, None)).error for h in (2e-3, 1e-3, 5e-4)]
    ratios = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(ratios - 3.0) < 0.3), (errors, ratios)


@pytest.mark.parametrize("omega", [(2.94, -0.083), (1.2, 0.02), (5.0, -0.4)])
def test_damped_oscillation_fit_recovers_its_parameters(omega):
    from vesicle.geometry.diagnostics import fit_damped_oscillation

    t = np.arange(0.0, 15.0, 0.02)
    psi = 0.3 + 0.05 * np.exp(omega[1] * t) * np.cos(omega[0] * t + 1.0)
    psi += 1e-6 * np.random.default_rng(0).standard_normal(t.size)
    fit = fit_damped_oscillation(t, psi, t_min=1.0)
    assert fit.omega == pytest.approx(omega, rel=1e-3, abs=1e-4)
    assert fit.psi_inf == pytest.approx(0.3, abs=1e-5)
    assert fit.amplitude == pytest.approx(0.05, rel=1e-3)
    late = t > 3.0  # the fit evaluates to the series it was fitted to
    np.testing.assert_allclose(fit(t[late]), psi[late], atol=1e-5)
    assert fit.rms_residual < 2e-6
    with pytest.raises(ValueError, match="periods"):
        fit_damped_oscillation(t[:75], psi[:75], t_min=0.0)  # 1.2 periods at most


def test_split_stress_at_saved_steps_adds_up(tmp_path):
    run = simulate(params(t_end=0.04, split_stress=True), out=tmp_path / "s.h5")
    s = read_run(tmp_path / "s.h5").series
    total = s["S_bending"] + s["S_flow"]
    assert np.isfinite(total).all()
    np.testing.assert_allclose(total, s["S"], atol=1e-5 * np.abs(s["S"]).max())
    np.testing.assert_allclose(s["S"][:, 0, 2], s["S_xz"], rtol=1e-14)
    plain = simulate(params(t_end=0.02)).series
    assert "S_bending" not in plain and "S_flow" not in plain  # stored only when asked for
    np.testing.assert_array_equal(run.coefficients[:2], simulate(params(t_end=0.02)).coefficients)


def test_post_step_recentres_then_restores_area_and_volume():
    """Re-centring re-measures the radius at degree N, which moves the area and volume; the
    drift correction must come after it (it once came first and was undone)."""
    from vesicle.dynamics.integrators import StepState, post_step
    from vesicle.sphere.transforms import resize

    p = params(degree=6, grid=16, drift_tol=1e-9)
    base = vs.Shape.spheroid(0.95, 16, 6)
    state = StepState(0.0, base.coefficients, 1e-3, area0=base.area, volume0=base.volume)
    off = recentered(base, origin=np.array([0.05, 0.0, 0.03]))  # centroid now off the origin
    moved = vs.Shape(resize(off.coefficients, 6) * (1 + 3e-5), 16)  # and area/volume drifted
    shape, changed = post_step(moved, state, p)
    assert changed and state.corrections["recentered"] == 1
    assert np.linalg.norm(shape.centroid) < p.recenter_threshold
    assert abs(shape.area / base.area - 1) <= p.drift_tol
    assert abs(shape.volume / base.volume - 1) <= p.drift_tol


def test_a_step_near_a_save_time_is_split_evenly_not_into_a_sliver():
    from vesicle.dynamics.simulation import _landing_step

    assert _landing_step(0.06, 0.05) == 0.05  # covers it: land
    assert _landing_step(0.03, 0.05) == 0.025  # more than half: two even steps, no 0.02 sliver
    assert _landing_step(0.02, 0.05) == 0.02  # less than half: the proposal


def test_landing_on_a_save_time_does_not_shrink_the_next_step():
    """A step cut short to hit a save time keeps the proposal it was cut from: the steps right
    after each save are not smaller than the cut step's proposal would make them."""
    params = RunParameters(
        vs.Physics(v=0.95, lam=1.0, chi=1.0),
        vs.Discretisation(grid=12, degree=4),
        t_end=0.3,
        save_every=0.05,
        rtol=1e-4,
    )
    run = simulate(params)
    assert np.allclose(np.diff(run.series["t"]), 0.05)
    # 53 steps when the cut step's proposal was taken; 45 now, none rejected
    assert run.checkpoint["steps"] <= 48 and run.checkpoint["rejected"] == 0


@pytest.mark.parametrize("omega_i, regime", [(-0.08, "TT"), (0.0, "TR")])
def test_regime_from_a_short_tail(omega_i, regime):
    """SPEC §14's case run to t = 10: about 2.3 periods in the tail. A damping of -0.08 is TT
    (damped), none is TR; one pair of minima alone must not decide it either way."""
    t = np.arange(0.0, 10.0001, 0.05)
    psi = 2e-4 + 3.5e-3 * np.exp(omega_i * t) * np.cos(2.94 * t + 1.6)
    assert classify_regime(t, psi).name == regime
    short = t <= 7.0  # the tail t >= 3.5 holds 1.6 periods: the fit still works
    assert classify_regime(t[short], psi[short]).name == regime


def test_ray_radius_reports_non_convergence():
    """One secant step cannot meet an off-centre ellipsoid: an error, not the last iterate."""
    from vesicle.geometry.diagnostics import ray_radius

    s = vs.Shape.ellipsoid(1.4, 1.0, 0.8, grid=12)
    dirs = s.grid.unit_vectors[0]
    origin = np.array([0.3, 0.1, -0.2])
    assert np.all(np.isfinite(ray_radius(s, origin, dirs)))
    with pytest.raises(vs.ShapeError, match="did not meet the surface"):
        ray_radius(s, origin, dirs, iterations=1)


def test_drift_control_reports_non_convergence():
    s = vs.Shape.ellipsoid(1.3, 1.0, 0.9, grid=12, degree=4)
    area, volume = s.area * 1.01, s.volume * 0.99
    restored, _, _ = restore_area_volume(s, area, volume, 4)
    assert restored.area == pytest.approx(area, rel=1e-12)
    with pytest.raises(vs.ShapeError, match="drift control did not restore"):
        restore_area_volume(s, area, volume, 4, iterations=2)


@pytest.mark.parametrize("integrator", ["ros2", "ros34pw2", "bs3", "heun"])
def test_a_small_mode_of_a_quasi_sphere_relaxes_at_its_exact_rate(integrator):
    """Through ``simulate``, against SPEC §15: r = 1 + e Y_20 + (e/10) Y_30 at rest.  Area
    conservation holds the l = 2 mode (its rate vanishes at the tension sigma = -6, where the
    membrane settles); the l = 3 mode then decays at Gamma_3(sigma = -6) = 4.4720 (lam = 1,
    ``sphere_relaxation_rates``, derived from the §15 eigenvalues).  The measured rate carries an
    O(e) shape correction (9.7 %, 5.2 %, 2.9 % at e = 0.04, 0.02, 0.01 on 16 x 32), removed by
    extrapolation from e = 0.02 and 0.01; the rest is O(e^2) and the grid: 1.2-1.5 % here on
    12 x 24, N = 4 (0.7 % on 16 x 32, N = 6)."""
    from vesicle.stokes.spectra import sphere_relaxation_rates

    rates = []
    for e in (0.02, 0.01):
        c = vs.Shape.sphere(grid=12, degree=4).coefficients.copy()
        c[2, 0] += e
        c[3, 0] += e / 10
        start = vs.Shape(c, 12)
        p = RunParameters(
            vs.Physics(v=min(1.0, start.reduced_volume), lam=1.0, chi=0.0),
            vs.Discretisation(12, 4),
            t_end=0.3, save_every=0.02, integrator=integrator, rtol=1e-5,
            tolerances="steady", drift_tol=1e-9,
        )  # fmt: skip
        run = simulate(p, start=start)
        t, c3 = run.series["t"], run.coefficients[:, 3, 0].real
        rates.append(-np.polyfit(t[3:], np.log(np.abs(c3[3:])), 1)[0])
    exact = sphere_relaxation_rates(3, 1.0, -6.0)[3]
    assert 2 * rates[1] - rates[0] == pytest.approx(exact, rel=0.02)


def test_a_run_stopped_at_a_steady_state_is_tt_and_says_why():
    """steady_tol stops a run once max |dr/dt| falls below it: the file records why
    (checkpoint "stopped"), and the analysis calls it TT even where psi's tail alone would be
    'undetermined' (here: the run starts on the Newton state and stops at once; its rate is
    about 1e-3, not 0, the multipliers' share of docs/architecture.md, hence 2e-2)."""
    import vesicle as vs
    from vesicle.dynamics.integrators import RunParameters
    from vesicle.dynamics.simulation import simulate
    from vesicle.geometry.diagnostics import summarize

    steady = vs.steady_tank_treading(vs.Physics(v=0.95, lam=1.0, chi=1.0), vs.Discretisation(12, 4))
    params = RunParameters(
        vs.Physics(v=0.95, lam=1.0, chi=1.0),
        vs.Discretisation(grid=12, degree=4),
        t_end=1.0,
        steady_tol=2e-2,
        save_fields=False,
    )
    run = simulate(params, start=steady.shape)
    summary = summarize(run)
    assert run.checkpoint["stopped"] == "steady" and summary["stopped"] == "steady"
    assert summary["regime"] == "TT" and summary["t_final"] < 1.0


def test_only_settled_periods_are_counted():
    """A TR oscillation growing out of its start (amplitude 0.3 (1 - exp(-t/4)), period 2,
    saved every 0.1): its early periods differ in swing by more than 2 % and are not counted,
    the late ones are (the swing's deficit exp(-t/4) is below 2 % from t = 15.6: about the last
    12 periods); a steady tumbling's half turns all count; a swing that keeps growing never
    settles."""
    from vesicle.geometry.diagnostics import settled_periods

    t = np.arange(0.0, 40.0, 0.1)
    psi = 0.2 + 0.3 * (1 - np.exp(-t / 4)) * np.cos(np.pi * t)
    assert settled_periods(t[t <= 8], psi[t <= 8]) == 0
    late = settled_periods(t, psi)
    assert 10 <= late <= 13  # the periods from t of about 16 to 39
    growing = 0.2 + 0.01 * np.exp(0.1 * t) * np.cos(np.pi * t)
    assert settled_periods(t, growing) == 0
    # Keller-Skalak-like tumbling: dpsi/dt = -(1 - 0.5 cos 2 psi), half turn pi / sqrt(0.75)
    tt = np.arange(0.0, 30.0, 0.05)
    angle = -np.arctan(np.sqrt(3.0) * np.tan(np.sqrt(0.75) * tt))  # the exact solution
    wrapped = (angle + np.pi / 2) % np.pi - np.pi / 2
    # 8 passages through -pi/2 in t < 30: 7 half turns between them, all equal
    assert settled_periods(tt, wrapped) == 7
    # a TT run creeping under the drift control: psi falls by 1.7e-6 at each correction (every
    # 1.0) and rises by 2e-8 between (N = 4, lam = 7.50, chi = 0.2, dt_max 0.1: it stopped on
    # "periods" in TT before MIN_SWING): regular minima, but swings far below any TR's
    # (its last saves: increments alternating -1.7e-6 and +2e-8, saved every 0.5)
    ts = np.arange(0.0, 40.0, 0.5)
    creep = -0.0128 + np.concatenate([[0.0], np.cumsum(np.tile([-1.7e-6, 2e-8], 40)[:79])])
    assert settled_periods(ts, creep) == 0


def test_a_run_stopped_on_settled_periods_is_classified_from_the_whole_run():
    """A TR run stopped once two periods settled (t = 5.8 at period 2.388: three minima, as the
    quick report's chi = 6, lam = 9 run at N = 4) has one swing in its last half: its regime
    comes from the whole run's swings (sustained: TR; damped by 30 % a period: TT), not
    "undetermined"."""
    from vesicle.geometry.diagnostics import settled_periods

    t = np.arange(0.0, 5.80001, 0.1)
    phase = 2 * np.pi * (t + 0.891) / 2.388  # minima at t = 0.9, 3.29, 5.68
    sustained = 0.05 + 0.1 * np.sin(phase)
    assert settled_periods(t, sustained) == 2  # what stopped the run
    tr = classify_regime(t, sustained)
    assert tr.name == "TR" and "over the run" in tr.detail
    assert tr.period == pytest.approx(2.388, rel=1e-3)
    damped = 0.05 + 0.1 * np.exp(-np.log(1 / 0.7) * t / 2.388) * np.sin(phase)
    assert classify_regime(t, damped).name == "TT"


def test_a_large_sustained_swing_is_tr_not_a_damped_approach():
    """A TR run at N = 8 (v = 0.95, lam = 10.5, chi = 8, 24x48; tests/data holds its psi(t) as
    saved): psi swings by 0.9406, 0.9452, 0.9471, 0.9483 between its minima, period 1.498, a
    sustained oscillation by inspection.  Its waveform is far from a sinusoid, and a damped
    sinusoid fitted to its tail reads a decay x0.75 (rms error 0.17 of its 0.50 amplitude):
    the classifier called it TT before it read the rate from the swings."""
    data = json.loads((Path(__file__).parents[1] / "data" / "tr_psi_n8_24x48.json").read_text())
    r = classify_regime(np.array(data["t"]), np.array(data["psi"]))
    assert r.name == "TR" and "sustained" in r.detail
    assert r.period == pytest.approx(1.4976, abs=1e-3)


def _slow_then_flip(t, period=194.0, flip=4.0):
    """psi of an orbit that turns by a half turn per period: slowly by 0.8 rad over all but
    ``flip`` of it, then the rest of the half turn within ``flip`` (as the run at v = 0.95,
    chi = 0.2, lam = 7.7, N = 8 does: docs/notes/dynamics-measurements.md)."""
    k, s = np.divmod(t, period)
    slow = period - flip
    turned = np.where(s < slow, 0.8 * s / slow, 0.8 + (np.pi - 0.8) * (s - slow) / flip)
    angle = 1.2 - k * np.pi - turned
    return -((0.5 * np.pi - angle) % np.pi - 0.5 * np.pi)  # into (-pi/2, pi/2]


def test_a_flip_between_two_saves_is_reported_as_unresolved():
    """The same orbit (a half turn every 194, most of it slow, the rest within 4) saved every
    0.1 and every 2.0.  Saved every 0.1 the classifier sees the half turns: TU, period 194,
    nothing unresolved (psi moves by at most 0.06 rad between saves).  Saved every 2.0 the
    flip turns psi by about 1.2 rad a save, which shows as jumps of about 2 rad, below the
    half-turn threshold 0.75 pi (as the lam = 7.7 run's 1.65-2.03): the label is TR, and the
    detail says that the saves do not resolve the motion; the period is still the orbit's.
    The expected numbers are the construction's own (period 194; the largest move between
    saves of 0.1 is (pi - 0.8) 0.1 / 4)."""
    from vesicle.geometry.diagnostics import UNRESOLVED_CHANGE, unresolved_change

    fine = np.arange(0.0, 1500.0 + 1e-9, 0.1)
    tu = classify_regime(fine, _slow_then_flip(fine))
    assert tu.name == "TU" and tu.period == pytest.approx(194.0, rel=1e-3)
    assert unresolved_change(_slow_then_flip(fine)) == pytest.approx((np.pi - 0.8) / 40, rel=1e-6)
    assert "do not resolve" not in tu.detail
    coarse = np.arange(0.0, 1500.0 + 1e-9, 2.0)
    psi = _slow_then_flip(coarse)
    assert unresolved_change(psi) > UNRESOLVED_CHANGE
    assert 1.5 < np.max(np.abs(np.diff(psi))) < 0.75 * np.pi  # no jump counts as a half turn
    r = classify_regime(coarse, psi)
    assert r.name == "TR" and "do not resolve" in r.detail
    assert r.period == pytest.approx(194.0, rel=1e-3)
    # a swing of 1 rad damped x0.78 over the last half, period 10, saved every 2.0: TT, but
    # moving by up to 0.9 rad between saves, so said to be unresolved; saved every 0.1, not
    damped = lambda t: np.exp(-t / 400) * np.cos(2 * np.pi * t / 10)  # noqa: E731
    sparse = np.arange(0.0, 200.0 + 1e-9, 2.0)
    tt = classify_regime(sparse, damped(sparse))
    assert tt.name == "TT" and "do not resolve" in tt.detail
    tt = classify_regime(fine[fine <= 200], damped(fine[fine <= 200]))
    assert tt.name == "TT" and "do not resolve" not in tt.detail
    # a resolved TR keeps its detail as it was
    tr = classify_regime(fine, 0.4 * np.cos(2 * np.pi * fine / 2.5))
    assert tr.name == "TR" and "do not resolve" not in tr.detail


def test_a_tu_period_counts_the_half_turns_whose_jump_the_saves_make_small():
    """A half turn every 193.3 whose flip takes 3.0, saved every 2.0: the saves catch each
    flip at a different phase, so some show as jumps of more than 0.75 pi (the run is TU) and
    some as smaller ones.  The period must count every half turn: before, the passages were
    taken at the large jumps only, an interval with a missed one counted double, and the mean
    came out too long (as the full report's run at chi = 0.2, lam = 8, N = 8: 152.17 instead
    of 126.81; docs/notes/dynamics-measurements.md).  The expected period is the
    construction's own (193.3)."""
    from vesicle.geometry.diagnostics import half_turn_times, settled_periods

    t = np.arange(0.0, 1500.0 + 1e-9, 2.0)
    psi = _slow_then_flip(t, period=193.3, flip=3.0)
    jumps = np.abs(np.diff(psi))
    assert np.any(jumps > 0.75 * np.pi) and np.sum((jumps > 1.0) & (jumps < 0.75 * np.pi)) >= 1
    times = half_turn_times(t, psi)
    assert times.size == 7  # one passage every 193.3 within 1500 (the first near t = 194)
    r = classify_regime(t, psi)
    assert r.name == "TU" and r.period == pytest.approx(193.3, rel=2e-3)
    assert "half turns of psi" in r.detail  # not all of them were jumps
    assert settled_periods(t, psi) >= 3
