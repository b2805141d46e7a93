"""Gait optimisation: the in-situ optimiser (paper Fig. 4), the model-based ceiling and the
prior-work batch baseline."""

from ._ceiling import Ceiling, cached_ceiling, optimize_ceiling
from ._insitu import InSituOptimizer, OptimizationResult
from ._objective import OBJECTIVES, default_objective, joint_limit_constraints, objective, path_length, rms_speed

__all__ = [
    "OBJECTIVES",
    "Ceiling",
    "InSituOptimizer",
    "OptimizationResult",
    "cached_ceiling",
    "default_objective",
    "joint_limit_constraints",
    "objective",
    "optimize_ceiling",
    "path_length",
    "rms_speed",
]
