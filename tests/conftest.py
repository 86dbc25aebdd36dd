"""Shared fixtures: the catalogue of states many tests use (computed once per session), and a
stand-in for the neutral tracer's point.

The catalogue (session scope; a state is read-only: tests that change one copy it first):

- ``small_state``: v = 0.95, lam = 2, chi = 1 at N = 4 on 12x24;
- ``table1_n4``: the SPEC §14 case (v = 0.95, lam = 8, chi = 10) at N = 4 on 16x32, by the
  default Newton (linearised Jacobians, Broyden updates): the steady, rheology and linearisation
  tests' state.
"""

import pytest

import vesicle as vs


@pytest.fixture(scope="session")
def small_state():
    """A converged state (N = 4 on 12x24) that the stand-in points carry as their start."""
    return vs.steady_tank_treading(vs.Physics(v=0.95, lam=2.0, chi=1.0),
                                   vs.Discretisation(grid=12, degree=4))  # fmt: skip


@pytest.fixture(scope="session")
def table1_n4():
    """Table 1's parameters at N = 4 on 16x32 (SPEC §14), the default Newton."""
    return vs.steady_tank_treading(vs.Physics(v=0.95, lam=8.0, chi=10.0),
                                   vs.Discretisation(grid=16, degree=4))  # fmt: skip


def _stand_in(state, calls, fail_above=None):
    """A tracer point without numerics whose start is ``state`` moved to its chi (what the
    checkpoint writes and a resume reads back)."""
    import dataclasses

    from vesicle.bifurcation.neutral import NeutralPoint
    from vesicle.steady.newton import NewtonError

    def point(self, start, chi, lam_pred, fallbacks=()):
        if chi in self.known:
            self.resumed.add(chi)
            return self.known[chi]
        if fail_above is not None and chi > fail_above:
            raise NewtonError(f"no stable tank-treading state found at chi = {chi:g}")
        calls.append(chi)
        problem = state.problem.replace(physics=state.physics.replace(chi=chi))
        p = NeutralPoint(chi, 8.0 + 0.1 * chi, "hopf", 0.3 * chi, -0.01, 0.2, True, 1.0,
                         start=dataclasses.replace(state, problem=problem))  # fmt: skip
        if self.checkpoint is not None:
            self.checkpoint(p)
        if self.progress is not None:
            self.progress(p.to_dict())
        return p

    return point


@pytest.fixture
def stand_in():
    """``stand_in(state, calls, fail_above=None)``: a replacement for
    ``vesicle.bifurcation.neutral._Tracer.point`` (see :func:`_stand_in`)."""
    return _stand_in
