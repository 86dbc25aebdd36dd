"""Continuation and bifurcations of the steady states (SPEC §16).

- ``continuation``: pseudo-arclength steps on any ``G(y, p) = 0``;
- ``branch``: one-parameter branches with stability and special points, and ``reach`` (the
  start strategy: Newton, else continuation from an easier point);
- ``critical``: lambda_c at fixed (v, chi) by bracketing; ``neutral``: the neutral curve
  lambda_c(chi); ``checkpoint``: a neutral curve's points kept as they are found;
- ``codim2``: two-parameter continuation of fold and Hopf curves (minimally augmented
  systems) with Bogdanov–Takens and cusp points located, on an abstract problem (residual,
  Jacobian, mass matrix): it imports nothing of the package (docs/reference/codim2.md);
- ``steady_codim2``: the steady equations as such a problem (``x = (a, mu)``, ``p = (log chi,
  lambda)``) and the type change solved for; ``neutral_codim2``: the neutral curve from the
  fold and Hopf curves (the default of ``vesicle neutral``; ``neutral`` is the older tracer).

May import: :mod:`vesicle.steady` and everything below it.
"""
