"""Solving the boundary-integral system of one shape.

- ``solver``: the velocity–tension solve by matrix-free Schur-complement GMRES
  (:func:`solve_flow`), its result and the particle stress;
- ``factorised``: the same system factorised (Woodbury), reused as a preconditioner;
- ``krylov``: GMRES for a batch of right-hand sides in lockstep (each dense matrix read once
  per iteration for the whole batch);
- ``linearisation``: the solve differentiated with respect to the shape (the linearised
  Jacobian of ``dr/dt``);
- ``ellipsoid``: the stress of an ellipsoid turned in the flow (the equivalent-ellipsoid maps).

May import: :mod:`vesicle.model`, :mod:`vesicle.stokes`, :mod:`vesicle.geometry`,
:mod:`vesicle.sphere`, the base modules.
"""
