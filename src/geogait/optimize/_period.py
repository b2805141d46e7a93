r"""The cycle period as a decision variable: a line search on log T judged by measured outcomes.

A principally kinematic model predicts the displacement per cycle, which does not depend on the
period T; a per-second objective J = D / T would then always favour the shortest period. What
bounds it on a robot is outside the model class (actuators that saturate, inertia, drag that is
not viscous), so the period is chosen from what the robot measures: the in-situ optimiser
alternates the model's gait steps with period trials. A trial runs the current gait at
T' = T · exp(±s) (shorter first); when its measured objective per second beats the same gait's at
T, the period stays and s grows by half, otherwise T is commanded again, the direction flips and s
halves. The search ends when s falls below ``min_step`` (2 %), and a gait step that changes the
gait starts it again at no more than ``restart_step``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PeriodLineSearch"]


@dataclass
class PeriodLineSearch:
    """State of the measured line search on the cycle period (module docstring).

    Parameters
    ----------
    low, high : float
        Shortest and longest period (s).
    step : float
        Current log step s (0.2: a trial 18 % shorter or 22 % longer).
    direction : int
        −1 (shorter) or +1 (longer): the side of the next trial.
    trial_from : float or None
        The period a trial in progress is judged against (None: no trial in progress).
    turn : bool
        True when the next gate decision is a period trial rather than a gait step.
    """

    low: float
    high: float
    step: float = 0.2
    direction: int = -1
    trial_from: float | None = None
    turn: bool = True
    min_step: float = 0.02
    max_step: float = 0.4
    restart_step: float = 0.1

    def propose(self, period: float, shortest: float = 0.0) -> float | None:
        """The period of the next trial from ``period`` (None when the search has ended or is boxed in).

        ``shortest`` is a further lower bound (the joint-velocity limit of the current gait).
        """
        if self.step < self.min_step:
            return None
        low = max(self.low, shortest)
        for direction in (self.direction, -self.direction):
            candidate = float(np.clip(period * np.exp(direction * self.step), low, self.high))
            if abs(np.log(candidate / period)) >= self.min_step / 2:
                self.direction = direction
                return candidate
        return None

    def judge(self, trial_value: float, reference_value: float) -> bool:
        """Record a trial's outcome (mean measured objective per second, trial vs reference); True if kept."""
        kept = bool(trial_value >= reference_value)
        if kept:
            self.step = min(self.max_step, 1.5 * self.step)
        else:
            self.direction, self.step = -self.direction, self.step / 2
        self.trial_from = None
        return kept

    def gait_changed(self) -> None:
        """A gait step moved the gait: the best period may have moved with it."""
        if self.step < self.min_step:
            self.step = self.restart_step

    def to_json(self) -> dict:
        return {"low": self.low, "high": self.high, "step": self.step, "direction": self.direction,
                "trial_from": self.trial_from, "turn": self.turn}

    @classmethod
    def from_json(cls, values: dict) -> PeriodLineSearch:
        return cls(low=float(values["low"]), high=float(values["high"]), step=float(values["step"]),
                   direction=int(values["direction"]),
                   trial_from=None if values["trial_from"] is None else float(values["trial_from"]),
                   turn=bool(values["turn"]))
