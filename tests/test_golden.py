"""The numbers of the code before the parameter-object refactor (issue 11), unchanged.

``data/golden.json`` was written by ``python tests/golden_numbers.py --old --write`` on commit
dac684e, *before* any of the refactor; the test recomputes each quantity with today's API
(:class:`NewAPI`) and holds it to those numbers.  That is an independent reference for "no
number changed": the old code, not today's.

Tolerance: 1e-12 relative (norm-wise per quantity) on the machine that wrote the file.  On
another CPU, BLAS kernels round differently; through Newton and a finite-difference Jacobian
(step 1e-4) a 1e-16 difference in ``adot`` grows to ~1e-11 in the eigenvalues, so there the
bound is 1e-9, still far below any physical change.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import vesicle as vs
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.sphere.rotation import rotation_matrix
from vesicle.stokes.spectra import schur_symbol, sphere_relaxation_rates

from golden_numbers import PATH, OldAPI, _cpu, compute


class NewAPI:
    """The same calls as ``golden_numbers.OldAPI``, through the parameter objects."""

    def table1_n4(self):
        p = vs.Physics(v=0.95, lam=8.0, chi=10.0)
        d = vs.Discretisation(grid=16, degree=4)
        r = vs.steady_tank_treading(
            p, d, newton=vs.NewtonSettings(updates="none", constraints="first-order"),
            analysis=vs.StabilitySettings(jacobian="differences"))  # fmt: skip
        # the reference path (differences, no Broyden, first-order constraints) that wrote them
        return vs.stability(r).omega

    def twenty_steps(self):
        p = RunParameters(
            vs.Physics(v=0.95, lam=8.0, chi=10.0),
            vs.Discretisation(grid=16, degree=6),
            t_end=0.02, save_every=0.01, dt0=1e-3, dt_max=1e-3, checkpoint_every=1e9,
            # the recorded run's settings, which were then the defaults
            integrator="ros2", rtol=1e-4, steady_tol=0.0,
        )  # fmt: skip
        run = simulate(p)
        assert run.checkpoint["steps"] == 20
        return run.checkpoint["coefficients"]

    def ellipsoid(self):
        s = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=16).rotated(
            rotation_matrix("y", -np.radians(20.0))
        )
        r = vs.solve_flow(s, vs.Physics(v=s.reduced_volume, lam=8.0), tolerances="steady")
        return [r.S_xz, r.N1, r.N2]

    # LayerPotentials kept its interface: the same call as before
    layers = OldAPI.layers

    def spectra(self):
        return [*schur_symbol(10, 8.0), *sphere_relaxation_rates(10, 8.0, 0.3)]


@pytest.fixture(scope="module")
def recorded():
    return json.loads(PATH.read_text())


@pytest.fixture(scope="module")
def today():
    return compute(NewAPI())


def test_numbers_are_those_of_the_code_before_the_refactor(recorded, today):
    rtol = 1e-12 if recorded["cpu"] == _cpu() else 1e-9
    for name, old in recorded["values"].items():
        old, new = np.asarray(old), np.asarray(today[name])
        assert new.shape == old.shape, name
        error = np.max(np.abs(new - old)) / np.max(np.abs(old))
        assert error <= rtol, f"{name}: relative change {error:.2e}"
