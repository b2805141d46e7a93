"""Gait optimisation: the in-situ optimiser (paper Fig. 4) composed from parts, its presets, the model-based
ceiling and the trust-region step rules."""

from ._adaptation import Adaptation
from ._ceiling import Ceiling, cached_ceiling, optimize_ceiling
from ._checks import ModelClassTest, StructureCheck
from ._climb import (
    BAYES_DESIGN_CYCLES,
    CLIMB_RULES,
    BayesianOptimization,
    Cobyqa,
    EvolutionStrategy,
    SearchRule,
    climb_rule_for,
)
from ._exploration import ExcitationSignal, Exploration
from ._insitu import Composition, InSituOptimizer, symmetric_chain_model
from ._measure import CycleMeasurement, measure_cycle
from ._model_class import smallest_budget
from ._objective import (
    OBJECTIVES,
    Objective,
    default_objective,
    feasibility_constraint,
    joint_limit_constraints,
    objective,
    path_length,
    rms_speed,
    robot_feasibility,
)
from ._part import Part
from ._parts import Climb, Gate, Limits, ModelStep, PeriodSearch, Safety
from ._presets import default, for_robot, from_flat_params, paper_loop, prior_work, structured
from ._result import InSituResult
from ._search import onto_joint_limit
from ._state import read_checkpoint_metadata
from ._steps import STEP_RULES, Step, StepProblem, linear_step, sqp_step, take_step

__all__ = [
    "Adaptation",
    "BAYES_DESIGN_CYCLES",
    "CLIMB_RULES",
    "OBJECTIVES",
    "STEP_RULES",
    "BayesianOptimization",
    "Ceiling",
    "Climb",
    "Cobyqa",
    "Composition",
    "CycleMeasurement",
    "EvolutionStrategy",
    "ExcitationSignal",
    "Exploration",
    "Gate",
    "InSituOptimizer",
    "InSituResult",
    "Limits",
    "ModelClassTest",
    "ModelStep",
    "Objective",
    "Part",
    "PeriodSearch",
    "Safety",
    "SearchRule",
    "Step",
    "StepProblem",
    "StructureCheck",
    "cached_ceiling",
    "climb_rule_for",
    "default",
    "default_objective",
    "feasibility_constraint",
    "for_robot",
    "from_flat_params",
    "joint_limit_constraints",
    "linear_step",
    "measure_cycle",
    "objective",
    "onto_joint_limit",
    "optimize_ceiling",
    "paper_loop",
    "path_length",
    "prior_work",
    "read_checkpoint_metadata",
    "rms_speed",
    "robot_feasibility",
    "smallest_budget",
    "sqp_step",
    "structured",
    "symmetric_chain_model",
    "take_step",
]
