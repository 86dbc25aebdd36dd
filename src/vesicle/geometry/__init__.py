"""A shape and its differential geometry, and what is measured of shapes.

- ``surface``: :class:`Shape`, a spherical-harmonic radius on the Gauss–Legendre grid, with its
  metric, curvatures, normal, area, volume, surface operators (SPEC §2–3).
- ``diagnostics``: the inertia ellipsoid (axes, inclination psi, deformation D), and what is
  read off a run's time series: regimes (TT/TR/TU), periods, orbits, damped-oscillation fits.

May import: :mod:`vesicle.sphere` and the base modules (``caches``, ``blas``).
"""
