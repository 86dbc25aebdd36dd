"""The settings objects (vesicle.model.settings): validated once, JSON round trip, one default
for the modes, the former loose keywords mapped onto them."""

from __future__ import annotations

import json

import pytest

import vesicle as vs
from vesicle.model.settings import legacy_settings

ALL = [vs.NewtonSettings, vs.StabilitySettings, vs.ContinuationSettings, vs.CriticalSearch,
       vs.Execution]  # fmt: skip


@pytest.mark.parametrize("cls", ALL)
def test_defaults_round_trip_through_json(cls):
    obj = cls()
    again = cls.from_dict(json.loads(json.dumps(obj.to_dict())))
    assert again == obj and again.key == obj.key


def test_non_default_values_round_trip():
    objects = [
        vs.NewtonSettings(tolerance=1e-9, max_iterations=5, updates="none",
                          constraints="first-order", solver=vs.SolverTolerances(1e-7, 1e-8)),
        vs.StabilitySettings("vorticity", jacobian="differences"),
        vs.ContinuationSettings(step=0.1, locate=False, past_fold=3),
        vs.CriticalSearch(lam0=4.0, coarse=vs.Discretisation(12, 4)),
        vs.CriticalSearch(coarse=None),
        vs.Execution(workers=2, scheduler="tcp://127.0.0.1:8786"),
    ]  # fmt: skip
    for obj in objects:
        again = type(obj).from_dict(json.loads(json.dumps(obj.to_dict())))
        assert again == obj, obj


def test_the_vorticity_branch_defaults_to_general_modes():
    """SPEC §13: the vorticity-aligned branch loses stability to perturbations that break the
    x-z symmetry, so its analysis needs the full basis unless asked otherwise."""
    assert vs.StabilitySettings().modes == "symmetric"
    assert vs.StabilitySettings("vorticity").modes == "general"
    assert vs.StabilitySettings("vorticity", "symmetric").modes == "symmetric"
    assert vs.StabilitySettings("flow", "general").modes == "general"


@pytest.mark.parametrize(
    "cls, changes, message",
    [
        (vs.NewtonSettings, {"tolerance": 0.0}, "tolerance must be positive"),
        (vs.NewtonSettings, {"max_iterations": 0}, "at least 1"),
        (vs.NewtonSettings, {"updates": "bfgs"}, "updates must be one of"),
        (vs.NewtonSettings, {"chord_contraction": 1.0}, r"lie in \(0, 1\)"),
        (vs.NewtonSettings, {"constraints": "exact"}, "constraints must be one of"),
        (vs.NewtonSettings, {"preconditioned": 1}, "true or false"),
        (vs.StabilitySettings, {"orientation": "y"}, "orientation must be one of"),
        (vs.StabilitySettings, {"modes": "odd"}, "modes must be one of"),
        (vs.StabilitySettings, {"jacobian": "exact"}, "jacobian must be one of"),
        (vs.ContinuationSettings, {"xtol": -1.0}, "xtol must be positive"),
        (vs.ContinuationSettings, {"past_fold": -1}, "at least 0"),
        (vs.ContinuationSettings, {"step": 0.0}, "step must be positive"),
        (vs.CriticalSearch, {"factor": 1.0}, "factor must be above 1"),
        (vs.CriticalSearch, {"lam0": -2.0}, "lam0 must be positive"),
        (vs.CriticalSearch, {"coarse": "fast"}, "coarse must be"),
        (vs.Execution, {"workers": 0}, "at least 1"),
        (vs.Execution, {"scheduler": ""}, "scheduler must be an address"),
    ],
)
def test_bad_settings_are_refused_by_name(cls, changes, message):
    with pytest.raises(ValueError, match=message):
        cls(**changes)
    with pytest.raises(ValueError, match="unknown"):
        cls.from_dict({"typo": 1})


def test_newton_iteration_limit_by_update_strategy():
    """30 iterations with Broyden updates (one solve each), 12 with fresh Jacobians."""
    assert vs.NewtonSettings().iterations == 30
    assert vs.NewtonSettings(updates="none").iterations == 12
    assert vs.NewtonSettings(max_iterations=7).iterations == 7


def test_legacy_keywords_map_onto_the_object_and_warn():
    legacy = {"tolerance": 1e-9, "modes": None, "other": 1}
    with pytest.warns(vs.VesicleDeprecationWarning, match=r"NewtonSettings\(tolerance=\.\.\.\)"):
        newton = legacy_settings("f", vs.NewtonSettings, None, legacy)
    assert newton == vs.NewtonSettings(tolerance=1e-9)
    assert legacy == {"modes": None, "other": 1}  # what the object took is removed
    assert legacy_settings("f", vs.StabilitySettings, None, legacy) is None  # None: default
    assert legacy == {"other": 1}
    with pytest.raises(TypeError, match="not both"):
        legacy_settings("f", vs.NewtonSettings, vs.NewtonSettings(), {"tolerance": 1e-9})


def test_execution_serial_gives_no_executor():
    with vs.Execution().executor() as pool:
        assert pool is None


def test_a_loose_none_that_means_something_is_kept():
    """``critical_lambda(..., coarse=None)`` meant "no coarse search", not the default "auto";
    ``lam0=None`` meant the default, so it alone is no loose keyword at all."""
    with pytest.warns(vs.VesicleDeprecationWarning, match="coarse"):
        search = legacy_settings("f", vs.CriticalSearch, None, {"coarse": None, "lam0": None})
    assert search == vs.CriticalSearch(coarse=None) and search.coarse is None
    assert legacy_settings("f", vs.CriticalSearch, None, {"lam0": None}) is None
