"""Run files that xarray reads (issue 18, part 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

import vesicle as vs
from vesicle.dynamics.integrators import RunParameters
from vesicle.dynamics.simulation import simulate
from vesicle.io.files import OPTIONAL_SERIES, SERIES, VISCOUS_SERIES, read_run


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("out") / "r.h5"
    params = RunParameters(vs.Physics(v=0.9, lam=2.0), vs.Discretisation(grid=12, degree=4),
                           t_end=0.02, save_every=0.01)  # fmt: skip
    simulate(params, out=path)
    return path


def test_series_open_in_xarray_with_named_dimensions_and_units(run_file):
    ds = xr.open_dataset(run_file, group="series", engine="h5netcdf")
    assert set(ds.sizes) == {"t", "i", "j", "l", "theta", "phi"}  # no phony_dim_N
    assert ds.sizes["t"] == 3 and ds.sizes["l"] == 5
    assert ds["S"].dims == ("t", "i", "j") and ds["spectrum"].dims == ("t", "l")
    assert ds["psi"].attrs["units"] == "rad" and ds["t"].attrs["units"] == "mu a^3 / kappa"
    assert ds["outer_iterations"].dtype.kind == "i"  # counts are integers
    np.testing.assert_array_equal(ds["psi"].values, read_run(run_file).series["psi"])
    ds.close()


def test_open_run_gives_a_dataset_with_the_parameters(run_file):
    ds = vs.open_run(run_file)
    assert ds["t"].values.tolist() == pytest.approx([0.0, 0.01, 0.02])
    assert ds["coefficients"].dims == ("t", "l", "m") and ds["coefficients"].dtype.kind == "c"
    assert json.loads(ds.attrs["physics"])["lam"] == 2.0
    assert ds.attrs["file_vesicle_version"] == vs.__version__
    for name, (_, long_name, units) in SERIES.items():
        if name != "t" and name not in (*OPTIONAL_SERIES, *VISCOUS_SERIES):  # only when asked
            # for (the split stress), or with Bq > 0 (the membrane's viscous part)
            assert ds[name].attrs == {"long_name": long_name, "units": units}
    frame = ds[["psi", "D", "S_xz"]].to_dataframe()  # and pandas
    assert list(frame.index) == pytest.approx([0.0, 0.01, 0.02])


def test_dimension_scales_are_not_series_and_the_checksum_holds(run_file):
    run = read_run(run_file)  # verifies the checksum
    assert not {"i", "j", "l"} & set(run.series)


def test_the_file_records_the_command_and_library_versions(tmp_path):
    from click.testing import CliRunner

    from vesicle.cli import main

    out = tmp_path / "c.h5"
    args = ["run", "--grid", "12", "--degree", "4", "--t-end", "0.01", "--lam", "3",
            "--out", str(out), "--no-progress", "--no-plot"]  # fmt: skip
    assert CliRunner().invoke(main, args).exit_code == 0
    attrs = read_run(out).attributes
    assert attrs["command"].startswith("main run") or attrs["command"].startswith("vesicle run")
    assert "--lam 3.0" in attrs["command"] and "--grid 12" in attrs["command"]
    assert attrs["numpy_version"] == np.__version__ and "scipy_version" in attrs


def test_fields_in_the_dataset_on_the_grid(run_file):
    """sigma (t, theta, phi) and velocity (t, i, theta, phi) with the grid's coordinates, in
    vs.open_run and in the HDF5 group as xarray reads it."""
    ds = vs.open_run(run_file)
    assert ds["sigma"].dims == ("t", "theta", "phi") and ds["sigma"].shape == (3, 12, 24)
    assert ds["velocity"].dims == ("t", "i", "theta", "phi")
    assert ds["sigma"].attrs["units"] == "kappa / a^2"
    grid = vs.sphere.grid.SphereGrid(12)
    np.testing.assert_allclose(ds["theta"], grid.theta)
    np.testing.assert_allclose(ds["phi"], grid.phi)
    raw = xr.open_dataset(run_file, group="series", engine="h5netcdf")
    assert raw["velocity"].dims == ("t", "i", "theta", "phi")
    assert not any(d.startswith("phony_dim") for d in raw.dims)
    assert "S_bending" not in ds and "S_bending" not in raw  # only when asked for


def test_stored_velocity_moves_the_stored_shapes(tmp_path):
    """An independent check of the velocity field: the filtered dr/dt it implies (2.18)-(2.19)
    against the central difference of the saved shapes around that step (dt = 1e-3, no drift
    control or re-centring to move them otherwise)."""
    from vesicle.model.kinematics import rate_of_change

    path = tmp_path / "r.h5"
    params = RunParameters(vs.Physics(v=0.9, lam=2.0, chi=3.0), vs.Discretisation(12, 4),
                           t_end=0.006, save_every=0.001, dt0=1e-3, dt_max=1e-3,
                           drift_control=False, recenter_threshold=1e9,
                           tolerances="steady")  # fmt: skip
    simulate(params, out=path)
    run = read_run(path)
    c, t = run.coefficients, run.series["t"]
    for i in (2, 3):
        rate = rate_of_change(run.shape(i), run.fields["velocity"][i], run.degree)
        moved = (c[i + 1] - c[i - 1]) / (t[i + 1] - t[i - 1])
        assert np.abs(rate - moved).max() < 2e-3 * np.abs(moved).max()


def test_split_stress_and_no_fields_are_honoured(tmp_path):
    path = tmp_path / "r.h5"
    simulate(
        RunParameters(
            vs.Physics(v=0.9, lam=2.0),
            vs.Discretisation(grid=12, degree=4),
            t_end=0.01,
            save_every=0.01,
            split_stress=True,
            save_fields=False,
        ),
        out=path,
    )
    run = read_run(path)
    assert run.fields == {} and "S_bending" in run.series
    np.testing.assert_allclose(run.series["S_bending"] + run.series["S_flow"], run.series["S"],
                               atol=1e-5)  # fmt: skip
    ds = vs.open_run(path)
    assert "sigma" not in ds and "theta" not in ds.coords
