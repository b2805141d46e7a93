"""Gait optimisation: the in-situ optimiser (paper Fig. 4), the model-based ceiling, the
prior-work batch baseline and the trust-region step rules."""

from .._defaults import STRUCTURED_MODEL_STEPS
from ._ceiling import Ceiling, cached_ceiling, optimize_ceiling
from ._climb import BAYES_DESIGN_CYCLES, CLIMB_RULES, climb_rule_for
from ._exploration import Exploration
from ._insitu import InSituOptimizer, symmetric_chain_model
from ._measure import CycleMeasurement, measure_cycle
from ._objective import (
    OBJECTIVES,
    default_objective,
    feasibility_constraint,
    joint_limit_constraints,
    objective,
    path_length,
    rms_speed,
    robot_feasibility,
)
from ._result import InSituResult
from ._state import read_checkpoint_metadata
from ._steps import STEP_RULES, Step, StepProblem, linear_step, sqp_step, take_step

__all__ = [
    "BAYES_DESIGN_CYCLES",
    "CLIMB_RULES",
    "OBJECTIVES",
    "STEP_RULES",
    "STRUCTURED_MODEL_STEPS",
    "Ceiling",
    "CycleMeasurement",
    "Exploration",
    "InSituOptimizer",
    "InSituResult",
    "Step",
    "StepProblem",
    "cached_ceiling",
    "climb_rule_for",
    "default_objective",
    "feasibility_constraint",
    "joint_limit_constraints",
    "linear_step",
    "measure_cycle",
    "objective",
    "robot_feasibility",
    "optimize_ceiling",
    "read_checkpoint_metadata",
    "path_length",
    "rms_speed",
    "sqp_step",
    "symmetric_chain_model",
    "take_step",
]
