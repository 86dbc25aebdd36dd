"""Pure mathematics on the unit sphere: grids, quadrature, transforms, derivatives, rotations.

Nothing in this package knows about vesicles.
"""
