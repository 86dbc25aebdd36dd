"""Validation against the paper (SPEC §14). Long: marked ``slow``; run with ``pytest -m slow``.

Measured 2026-11-22 on the 2-core machine (with other work running):
- Table 1, v = 0.95, lam = 8, chi = 10, N = 8 on 32 x 64: omega = (2.93790, -0.08282) against
  the paper's (2.939, -0.08064); about 6-11 min.
- The same case at N = 4 on 16 x 32, perturbed and time-stepped to t = 12: the fit of psi(t)
  gives (3.2531, -0.06221) against the stability analysis' (3.2294, -0.06263); about 18 min.
- Its out-of-plane (y-reflection-breaking) mode, N = 4 on 16 x 32: the steady state tilted by 2
  degrees and time-stepped to t = 12; the fit of the long axis' y-component gives
  (2.6462, -0.0671) against the general-mode analysis' (2.646, -0.0656); about 15 min.
"""

import numpy as np
import pytest

import vesicle as vs
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.geometry.diagnostics import fit_damped_oscillation
from vesicle.steady.newton import steady_tank_treading
from vesicle.steady.stability import stability

pytestmark = pytest.mark.slow


def test_table1_row_at_N8():
    r = steady_tank_treading(
        vs.Physics(v=0.95, lam=8.0, chi=10.0), vs.Discretisation(grid=32, degree=8)
    )
    w_r, w_i = stability(r).most_unstable
    assert w_r == pytest.approx(2.939, rel=0.01)
    assert w_i == pytest.approx(-0.08064, rel=0.05)
    assert r.residual < 1e-8


@pytest.fixture(scope="module")
def steady4():
    """The SPEC §14 case (v = 0.95, lam = 8, chi = 10) at N = 4 on 16 x 32."""
    return steady_tank_treading(
        vs.Physics(v=0.95, lam=8.0, chi=10.0), vs.Discretisation(grid=16, degree=4)
    )


def _run_from(shape, **changes):
    """Time-step the SPEC §14 case at N = 4, 16 x 32, from ``shape`` to t = 12."""
    params = RunParameters(
        **{
            "v": 0.95,
            "lam": 8.0,
            "chi": 10.0,
            "grid": 16,
            "degree": 4,
            "t_end": 12.0,
            "save_every": 0.02,
            "tolerances": "steady",
            **changes,
        }
    )
    return simulate(params, start=shape)


def test_time_stepping_agrees_with_stability(steady4):
    r = steady4
    w_r, w_i = stability(r).most_unstable
    run = _run_from(r.shape.perturbed(0.01, seed=4, degree=4), rtol=1e-5)
    fit = fit_damped_oscillation(run.series["t"], run.series["psi"], t_min=1.0)
    assert fit.omega_R == pytest.approx(w_r, rel=0.02)
    assert fit.omega_I == pytest.approx(w_i, rel=0.05)


def test_out_of_plane_mode_agrees_with_general_stability(steady4):
    """The least damped non-symmetric mode tilts the vesicle out of the shear plane: a tilted
    start's long axis leaves the x-z plane and returns with the mode's (omega_R, omega_I)."""
    r = steady4
    general = stability(r, modes="general")
    symmetric = np.abs(stability(r).omega[:, 0])
    out_of_plane = next(
        w for w in general.omega if np.min(np.abs(symmetric - abs(w[0]))) > 1e-3 * abs(w[0])
    )
    run = _run_from(r.shape, tilt=2.0)
    fit = fit_damped_oscillation(run.series["t"], run.series["axes"][:, 0, 1], t_min=1.0)
    assert fit.omega_R == pytest.approx(abs(out_of_plane[0]), rel=0.01)
    assert fit.omega_I == pytest.approx(out_of_plane[1], rel=0.05)


def test_vorticity_branch_growth_agrees_with_time_stepping():
    """Issue 15: the out-of-plane (y-reflection-breaking) unstable pair of the vorticity-aligned
    state (v = 0.95, chi = 4, lam = 11; N = 4 on 12 x 24), time-stepped from the state perturbed
    by 1e-3.  The run is projected onto the pair's left eigenvector ``w`` (normalised so that
    ``w . v = 1``): ``c(t) = w . (a(t) - a0)`` removes every other mode exactly, so its modulus
    grows at the pair's rate from the start, and its phase turns at omega_R.

    Expected, measured 2026-12-02 at N = 4 on 16 x 32 to t = 60: growth 0.00704 and phase rate
    1.25721 from every t_min of 5 ... 40, against (1.25720, 0.00741) for the linearisation held
    on the constraints (``stability(curvature=True)``, the operator the time stepping follows,
    since it keeps area and volume) and 0.00810 for SPEC §9's form.  The bounds: omega_R to 1e-3;
    the growth within 10 % of the constrained linearisation, which is tighter than the two
    linearisations' own 9 % gap at N = 4 and excludes the 0.015-0.018 that one-mode fits of the
    long axis had given."""
    import scipy.linalg

    from vesicle.geometry.surface import Shape
    from vesicle.model.parameters import Discretisation, Physics

    r = steady_tank_treading(
        Physics(v=0.95, lam=11.0, chi=4.0),
        Discretisation(grid=12, degree=4),
        analysis=vs.StabilitySettings(orientation="vorticity"),
    )
    problem = r.problem.replace(modes="general")
    a0 = problem.coefficients_of(r.shape)
    M, _ = problem.jacobian(a0, central=True)
    mu, W, V = scipy.linalg.eig(M, left=True, right=True)
    w_r, w_i = stability(r, modes="general", curvature=True).most_unstable
    assert w_i > 0  # the pair is unstable at this resolution
    k = int(np.argmin(np.abs(mu.imag + w_r) + np.abs(mu.real - w_i)))
    w = W[:, k].conj() / (W[:, k].conj() @ V[:, k])
    params = RunParameters(
        vs.Physics(v=0.95, lam=11.0, chi=4.0),
        vs.Discretisation(grid=12, degree=4),
        t_end=30.0,
        save_every=0.25,
        integrator="ros34pw2",
        rtol=1e-5,
        tolerances="steady",
    )
    run = simulate(params, start=r.shape.perturbed(1e-3, seed=3, degree=4))
    t = run.series["t"]
    c = np.array([w @ (problem.coefficients_of(Shape(run.coefficients[i], 12)) - a0)
                  for i in range(t.size)])  # fmt: skip
    window = t >= 5.0
    growth = np.polyfit(t[window], np.log(np.abs(c[window])), 1)[0]
    phase_rate = abs(np.polyfit(t[window], np.unwrap(np.angle(c[window])), 1)[0])
    assert phase_rate == pytest.approx(w_r, rel=1e-3)
    assert growth == pytest.approx(w_i, rel=0.10)
