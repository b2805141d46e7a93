"""Gaits: Fourier-series nominal gaits and the stochastic perturbations around them."""

from ._fourier import FourierGait, fourier_basis, seed_gait
from ._perturbation import Perturbation, PerturbationStream, check_excitation, excitation_at
from ._symmetric import FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily, shift_phase

__all__ = [
    "FourierGait",
    "FreeGaitFamily",
    "MirrorGaitFamily",
    "Perturbation",
    "PerturbationStream",
    "SymmetricGaitFamily",
    "check_excitation",
    "excitation_at",
    "fourier_basis",
    "seed_gait",
    "shift_phase",
]
