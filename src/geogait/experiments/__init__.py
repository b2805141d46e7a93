"""Experiments of the paper, one module per figure, on the sweep engine (:mod:`geogait.sweep`, whose runner is
also importable from here)."""

from ..sweep import SweepFailedError, SweepResult, TrialFailure, run_trials
from ._common import PERCENTILES
from .accuracy import AccuracyConfig, AccuracyResult, accuracy_summary, accuracy_trials, plot_accuracy, run_accuracy
from .changes import ChangingRobot, elastica_friction, mujoco_joint_gear, mujoco_link_drag, swimmer_link_drag
from .environments import (
    EnvironmentConfig,
    EnvironmentResult,
    environment_summary,
    environment_trials,
    plot_environments,
    recovery_table,
    run_environments,
)
from .optimization import (
    OptimizationConfig,
    OptimizationResult,
    optimization_summary,
    optimization_trials,
    plot_optimization,
    run_optimization,
)
from .tracking import (
    TrackingConfig,
    TrackingResult,
    plot_tracking,
    run_tracking,
    tracking_summary,
    tracking_trials,
)

__all__ = [
    "run_trials",
    "SweepResult",
    "TrialFailure",
    "SweepFailedError",
    "PERCENTILES",
    "ChangingRobot",
    "swimmer_link_drag",
    "mujoco_link_drag",
    "mujoco_joint_gear",
    "elastica_friction",
    "AccuracyConfig",
    "AccuracyResult",
    "accuracy_summary",
    "accuracy_trials",
    "plot_accuracy",
    "run_accuracy",
    "EnvironmentConfig",
    "EnvironmentResult",
    "environment_summary",
    "environment_trials",
    "plot_environments",
    "recovery_table",
    "run_environments",
    "OptimizationConfig",
    "OptimizationResult",
    "optimization_summary",
    "optimization_trials",
    "plot_optimization",
    "run_optimization",
    "TrackingConfig",
    "TrackingResult",
    "plot_tracking",
    "run_tracking",
    "tracking_summary",
    "tracking_trials",
]
