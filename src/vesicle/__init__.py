"""vesicle: spectral boundary-integral simulation of a lipid vesicle in Stokes shear flow."""

from importlib.metadata import PackageNotFoundError, version

from .flows import LinearFlow
from .membrane import bending_energy, bending_force, membrane_force, tension_force
from .rheology import ParticleStress
from .solver import FlowParameters, FlowResult, SolverError, SolverTolerances, solve_flow
from .sphere.grid import SphereGrid
from .stokes import LayerPotentials, double_layer, single_layer
from .surface import Shape, ShapeError

try:
    __version__ = version("vesicle")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = [
    "FlowParameters",
    "FlowResult",
    "LayerPotentials",
    "LinearFlow",
    "ParticleStress",
    "Shape",
    "ShapeError",
    "SolverError",
    "SolverTolerances",
    "SphereGrid",
    "__version__",
    "bending_energy",
    "bending_force",
    "double_layer",
    "membrane_force",
    "single_layer",
    "solve_flow",
    "tension_force",
]
