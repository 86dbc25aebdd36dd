"""Record (``python tests/golden_numbers.py --write``) or recompute the fixed outputs that the
parameter-object refactor must leave unchanged (issue 11); ``test_golden.py`` compares them.

The numbers were first written by the code *before* the refactor (commit dac684e), so the test
holds today's code to the old one, not to itself: an independent reference for "no number
changed".  Each quantity is cheap: N = 4 on 16 x 32, a 20-step run, one solve, sphere spectra.
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

import numpy as np

PATH = Path(__file__).with_name("data") / "golden.json"


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def compute(api) -> dict:
    """The fixed outputs; ``api`` supplies the version-specific calls (see test_golden.py)."""
    out = {}
    # Table 1's case at N = 4 on 16 x 32: Newton, central-difference Jacobian, eigenvalues.
    w = api.table1_n4()
    out["table1_n4_omega"] = [list(map(float, row)) for row in w[:6]]
    # A 20-step time-dependent run (ros2, lam = 8, chi = 10, N = 6 on 16 x 32).
    c = api.twenty_steps()
    out["run20_coefficients"] = [np.real(c).ravel().tolist(), np.imag(c).ravel().tolist()]
    # One solve of the tilted ellipsoid at lam = 8 (steady tolerances).
    out["ellipsoid_lam8"] = list(map(float, api.ellipsoid()))
    # Layer potentials of a fixed density on the unit sphere and on an ellipsoid; sphere spectra.
    out["layer_potentials"] = [float(x) for x in api.layers()]
    out["sphere_spectra"] = [float(x) for x in api.spectra()]
    return out


class OldAPI:
    """Calls of the code before the parameter objects (dac684e)."""

    def table1_n4(self):
        from vesicle.steady.newton import steady_tank_treading
        from vesicle.steady.stability import stability

        r = steady_tank_treading(0.95, 8.0, 10.0, degree=4, grid=16)
        return stability(r).omega

    def twenty_steps(self):
        from vesicle.dynamics.integrators import RunParameters
        from vesicle.dynamics.simulation import simulate

        p = RunParameters(v=0.95, lam=8.0, chi=10.0, grid=16, degree=6, t_end=0.02,
                          save_every=0.01, dt0=1e-3, dt_max=1e-3, checkpoint_every=1e9)  # fmt: skip
        run = simulate(p)
        assert run.checkpoint["steps"] == 20, run.checkpoint["steps"]
        return run.checkpoint["coefficients"]

    def ellipsoid(self):
        import vesicle as vs
        from vesicle.sphere.rotation import rotation_matrix

        s = vs.Shape.ellipsoid(1.3, 0.9, 0.8, grid=16).rotated(
            rotation_matrix("y", -np.radians(20.0))
        )
        r = vs.solve_flow(s, lam=8.0, chi=1.0, tolerances="steady")
        return [r.S_xz, r.N1, r.N2]

    def layers(self):
        import vesicle as vs

        values = []
        for shape in (vs.Shape.sphere(grid=12), vs.Shape.ellipsoid(1.2, 1.0, 0.9, grid=12)):
            th, ph = np.meshgrid(shape.grid.theta, shape.grid.phi, indexing="ij")
            f = np.stack([np.cos(th) * np.sin(ph), np.sin(th) ** 2, np.cos(2 * ph) * np.sin(th)])
            lp = vs.LayerPotentials(shape)
            single, double = lp.single_layer(f), lp.double_layer(f)
            values += [*single[:, ::3, ::5].ravel(), *double[:, ::3, ::5].ravel()]
        return values

    def spectra(self):
        from vesicle.solve.solver import schur_symbol, sphere_relaxation_rates

        return [*schur_symbol(10, 8.0), *sphere_relaxation_rates(10, 8.0, 0.3)]


def main() -> None:
    if "--old" in sys.argv:
        api = OldAPI()
    else:
        from test_golden import NewAPI

        api = NewAPI()
    values = compute(api)
    if "--write" in sys.argv:
        PATH.write_text(json.dumps({"cpu": _cpu(), "values": values}, indent=1))
        print(f"wrote {PATH}")
    else:
        print(json.dumps(values))


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).parent))
    main()
