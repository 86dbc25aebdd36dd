"""Stokes kernels and layer potentials with spectrally accurate singular quadrature (SPEC §5)."""

from vesicle.stokes.evaluation import evaluate_double_layer, evaluate_single_layer
from vesicle.stokes.kernels import stokeslet, stresslet
from vesicle.stokes.operators import METHODS, LayerPotentials, double_layer, single_layer
from vesicle.stokes.quadrature import SingularQuadrature, singular_quadrature

__all__ = [
    "METHODS",
    "LayerPotentials",
    "SingularQuadrature",
    "double_layer",
    "evaluate_double_layer",
    "evaluate_single_layer",
    "single_layer",
    "singular_quadrature",
    "stokeslet",
    "stresslet",
]
