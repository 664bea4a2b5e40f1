"""Compensation models and optimisers. Knows arrays and features, not physics; imports nothing
from ``sim`` or ``twin``. torch is imported inside the functions that need it."""

from fitting.features import CONVENTIONAL, EXTENSION, PAPER, FeatureSet
from fitting.models import EvolvedBPNN, PolynomialCompensator
from fitting.network import BPNN
from fitting.optimizers import GA, PSO, PSOGA, PopulationOptimizer

__all__ = ["BPNN", "CONVENTIONAL", "EXTENSION", "EvolvedBPNN", "FeatureSet", "GA", "PAPER", "PSO", "PSOGA",
           "PolynomialCompensator", "PopulationOptimizer"]
