"""vesicle: spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."""

from vesicle._version import __version__
from vesicle.bifurcation.branch import Branch, BranchPoint, SpecialPoint, branch
from vesicle.bifurcation.critical import CriticalResult, critical_lambda
from vesicle.bifurcation.neutral import NeutralCurve, NeutralPoint, neutral_curve
from vesicle.bifurcation.neutral_codim2 import neutral_curve_codim2
from vesicle.caches import cache_info, clear_caches
from vesicle.geometry.surface import Shape, ShapeError
from vesicle.io.files import open_run
from vesicle.model.flows import LinearFlow
from vesicle.model.membrane import bending_energy, bending_force, membrane_force, tension_force
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances
from vesicle.model.rheology import ParticleStress
from vesicle.model.settings import (
    ContinuationSettings,
    CriticalSearch,
    Execution,
    NewtonSettings,
    StabilitySettings,
    VesicleDeprecationWarning,
)
from vesicle.solve.solver import FlowResult, SolverError, solve_flow
from vesicle.sphere.grid import SphereGrid
from vesicle.steady.newton import NewtonError, SteadyResult, steady_tank_treading
from vesicle.steady.problem import SteadyProblem
from vesicle.steady.stability import StabilityResult, stability
from vesicle.stokes import LayerPotentials, double_layer, single_layer

__all__ = [
    "Branch",
    "BranchPoint",
    "ContinuationSettings",
    "CriticalResult",
    "CriticalSearch",
    "Discretisation",
    "Execution",
    "FlowResult",
    "LayerPotentials",
    "LinearFlow",
    "NeutralCurve",
    "NeutralPoint",
    "NewtonError",
    "NewtonSettings",
    "ParticleStress",
    "Physics",
    "Shape",
    "ShapeError",
    "SolverError",
    "SolverTolerances",
    "SpecialPoint",
    "SphereGrid",
    "StabilityResult",
    "StabilitySettings",
    "SteadyProblem",
    "SteadyResult",
    "VesicleDeprecationWarning",
    "__version__",
    "bending_energy",
    "bending_force",
    "branch",
    "cache_info",
    "clear_caches",
    "critical_lambda",
    "double_layer",
    "membrane_force",
    "neutral_curve",
    "neutral_curve_codim2",
    "open_run",
    "single_layer",
    "solve_flow",
    "stability",
    "steady_tank_treading",
    "tension_force",
]
