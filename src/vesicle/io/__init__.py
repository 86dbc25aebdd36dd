"""Files: one atomic writer, one stamp (version, parameters, command, time), run files.

- ``files``: the run file format (HDF5: series, shapes, fields, checkpoint), :func:`open_run`
  for xarray, the atomic writers and the stamp every file carries;
- ``vtk``: the surface time series for ParaView.

May import: :mod:`vesicle.geometry`, :mod:`vesicle.sphere`, the base modules.  The steady-state
files live with the steady states (:mod:`vesicle.steady.files`), a neutral curve's checkpoints
with the curves (:mod:`vesicle.bifurcation.checkpoint`).
"""
