"""Steady tank-treading and its stability (SPEC §8–9).

- ``problem``: :class:`SteadyProblem`, the steady equations in a basis of shape coordinates:
  the rate ``adot(a)``, its Jacobian (linearised or by differences), the constraints;
- ``newton``: Newton–Raphson with Broyden updates (:func:`steady_tank_treading`);
- ``stability``: the eigenvalues of the constrained Jacobian;
- ``files``: steady-state files (state, Jacobian, spectrum) and the ``--json`` summary.

May import: :mod:`vesicle.solve`, :mod:`vesicle.model`, :mod:`vesicle.io`,
:mod:`vesicle.geometry` and below.  Not :mod:`vesicle.dynamics` (a sibling).
"""
