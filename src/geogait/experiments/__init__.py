"""Experiments of the paper and the seeded trial runner they share."""

from .runner import SweepFailedError, SweepResult, TrialFailure, run_trials

__all__ = ["run_trials", "SweepResult", "TrialFailure", "SweepFailedError"]
