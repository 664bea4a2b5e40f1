"""Compensation models and optimisers. Knows arrays and features, not physics; imports nothing
from ``sim`` or ``twin``. torch is imported inside the functions that need it."""

import os

# MKL's conditional numerical reproducibility (torch's sgemm): without it a GEMM may take another
# code path for differently aligned buffers, and the same seed may not give identical networks.
os.environ.setdefault("MKL_CBWR", "AUTO,STRICT")

from fitting.features import CONVENTIONAL, EXTENSION, PAPER, FeatureSet  # noqa: E402
from fitting.models import EvolvedBPNN, PolynomialCompensator  # noqa: E402
from fitting.network import BPNN  # noqa: E402
from fitting.optimizers import GA, PSO, PSOGA, PopulationOptimizer  # noqa: E402

__all__ = ["BPNN", "CONVENTIONAL", "EXTENSION", "EvolvedBPNN", "FeatureSet", "GA", "PAPER", "PSO", "PSOGA",
           "PolynomialCompensator", "PopulationOptimizer"]
