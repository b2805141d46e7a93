"""Gaits: Fourier-series nominal gaits and the stochastic perturbations around them."""

from ._fourier import FourierGait, fourier_basis, seed_gait
from ._perturbation import Perturbation, PerturbationStream

__all__ = ["FourierGait", "Perturbation", "PerturbationStream", "fourier_basis", "seed_gait"]
