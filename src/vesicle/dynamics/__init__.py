"""Time-dependent runs (SPEC §7).

- ``integrators``: :class:`RunParameters` (with ``RUN_DEFAULTS``), the linearly implicit
  Rosenbrock-W and explicit integrators, drift control of area and volume;
- ``simulation``: :func:`simulate`, which drives an integrator from a start shape or a
  checkpoint, saves, checkpoints and stops (t_end, steady, periods).

May import: :mod:`vesicle.solve`, :mod:`vesicle.model`, :mod:`vesicle.io` (run files),
:mod:`vesicle.geometry` and below.  Not :mod:`vesicle.steady` (a sibling).
"""
