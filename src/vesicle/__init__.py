"""vesicle: spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."""

from ._version import __version__
from .branch import Branch, BranchPoint, SpecialPoint, branch
from .caches import cache_info, clear_caches
from .critical import CriticalResult, critical_lambda
from .flows import LinearFlow
from .io import open_run
from .membrane import bending_energy, bending_force, membrane_force, tension_force
from .neutral import NeutralCurve, NeutralPoint, neutral_curve
from .parameters import Discretisation, Physics, SolverTolerances
from .problem import SteadyProblem
from .rheology import ParticleStress
from .solver import FlowResult, SolverError, solve_flow
from .sphere.grid import SphereGrid
from .stability import StabilityResult, stability
from .steady import NewtonError, SteadyResult, steady_tank_treading
from .stokes import LayerPotentials, double_layer, single_layer
from .surface import Shape, ShapeError

__all__ = [
    "Branch",
    "BranchPoint",
    "CriticalResult",
    "Discretisation",
    "FlowResult",
    "LayerPotentials",
    "LinearFlow",
    "NeutralCurve",
    "NeutralPoint",
    "NewtonError",
    "ParticleStress",
    "Physics",
    "Shape",
    "ShapeError",
    "SolverError",
    "SolverTolerances",
    "SpecialPoint",
    "SphereGrid",
    "StabilityResult",
    "SteadyProblem",
    "SteadyResult",
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
    "open_run",
    "single_layer",
    "solve_flow",
    "stability",
    "steady_tank_treading",
    "tension_force",
]
