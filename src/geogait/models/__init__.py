"""Data-driven local gait models (paper §III): features, phase windows, the adaptive RLS bank,
the batch baseline, the phase model and the Γ metric."""

from ._adaptive import AdaptiveGaitModel
from ._base import (
    CAPABILITIES,
    MAX_PHASE,
    GaitModel,
    check_gait_model,
    clone_for_gait,
    gamma,
    has_gait_model_members,
    load_model,
    model_capabilities,
    model_fitted,
    model_from_state,
)
from ._batch import BatchGaitModel
from ._displacement import ModelMotion, predicted_displacement
from ._features import PhaseWindows, n_regressors, regressors, split_coefficients
from ._perfect import PerfectInformationModel
from ._phase import PhaseModel
from ._resistance import ResistanceModel
from ._rls import RLSBank
from ._shape_space import ShapeSpaceModel, monomial_exponents, monomials, symmetry_blocks

__all__ = [
    "CAPABILITIES",
    "MAX_PHASE",
    "GaitModel",
    "AdaptiveGaitModel",
    "BatchGaitModel",
    "ModelMotion",
    "PerfectInformationModel",
    "PhaseModel",
    "PhaseWindows",
    "RLSBank",
    "ResistanceModel",
    "ShapeSpaceModel",
    "check_gait_model",
    "clone_for_gait",
    "gamma",
    "has_gait_model_members",
    "load_model",
    "model_capabilities",
    "model_fitted",
    "monomial_exponents",
    "monomials",
    "model_from_state",
    "n_regressors",
    "predicted_displacement",
    "regressors",
    "split_coefficients",
    "symmetry_blocks",
]
