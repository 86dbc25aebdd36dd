"""The physics: parameters, flows, membrane forces and the equations written once.

- ``parameters``: the frozen, validated :class:`Physics`, :class:`Discretisation`,
  :class:`SolverTolerances`.
- ``flows``: the background linear flows; ``membrane``: bending and tension tractions (SPEC §4);
  ``kinematics``: ``dr/dt`` of a radial shape from its membrane velocity; ``rheology``: the
  particle stress (SPEC §11); ``theory``: small-deformation theory (for checks and plots).
- ``formulation``: the boundary-integral system (SPEC §5–6) written once; a new membrane term
  goes here.
- ``published``: the seed paper's stated values (data only).

May import: :mod:`vesicle.geometry`, :mod:`vesicle.sphere`, the base modules.
"""
