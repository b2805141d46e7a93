"""A run's log rows and checkpoints."""

from __future__ import annotations

import numpy as np

from .. import __version__
from .._files import write_state
from ..models import model_fitted
from ..simulate import TrueMotion
from ._state import (
    CHECKPOINT_FORMAT,
    CHECKPOINT_VERSION,
    params_to_json,
)


class RunRecords:
    """Methods of :class:`~geogait.optimize._loop.CycleLoop` (a mixin: it reads the loop's ``parts``, ``state``
    and ``robot``)."""

    def _row(self, gait, gamma, step, rejected, settling, prediction_ok, measured, value, reverted, period) -> dict:
        state = self.state
        net = measured.net
        progress = float(np.hypot(net[0], net[1]))
        row = {"cycle": state.cycle, "iteration": state.iteration - int(step) - int(rejected) - int(reverted),
               "settling": settling, "gamma": gamma, "step": step, "rejected": rejected, "reverted": reverted,
               "prediction_ok": prediction_ok,
               "trust_radius": state.radius, "predicted_objective": state.last_prediction,
               "measured_x": net[0], "measured_y": net[1], "measured_heading": net[2],
               "measured_progress": progress, "measured_objective": value,
               "measured_speed": progress / period, "cycle_period": period, "tracking_error": measured.tracking_error,
               "tracking_limit": self._tracking_limit(), "excitation": measured.excitation,
               "world_x": measured.start[0], "world_y": measured.start[1], "world_heading": measured.start[2]}
        pose, true_value = self.truth(gait, state)
        if self.truth.available:
            row.update({"true_x": pose[0], "true_y": pose[1], "true_heading": pose[2],
                        "true_progress": float(np.hypot(pose[0], pose[1])), "true_objective": true_value,
                        "improvement": true_value * state.rate(period)
                        / (state.seed_value * state.rate(state.seed_period)) - 1})
            reference = true_value
        else:
            seed = float(np.mean(state.seed_measured)) if state.seed_measured else np.nan
            row["improvement"] = (value * state.rate(period) / (seed * state.rate(state.seed_period)) - 1
                                  if seed else np.nan)
            reference = value
        if state.ceiling is not None:
            row["ceiling_fraction"] = reference / state.ceiling
        row.update({f"param_{k}": v for k, v in enumerate(gait.params)})
        return row

    def _save(self):
        """Write the checkpoint (one atomic ``.npz``: JSON metadata + arrays)."""
        metadata, arrays = self.state.to_checkpoint()
        model = self.state.model
        model_metadata = None
        if "save" in self.capabilities and model_fitted(model):
            model_metadata, model_arrays = model.get_state()
            arrays.update({f"model/{k}": np.asarray(v) for k, v in model_arrays.items()})
        robot_state = None
        if self.spec.saves_state:
            robot_state = {}
            for key, value in self.robot.robot_state().items():
                if isinstance(value, np.ndarray):
                    arrays[f"robot/{key}"] = value
                else:
                    robot_state[key] = value
        payload = {"format": CHECKPOINT_FORMAT, "format_version": CHECKPOINT_VERSION, "geogait": __version__,
                   "params": params_to_json(self.optimizer), "state": metadata,
                   "model": None if model_metadata is None else {"metadata": model_metadata},
                   "robot_state": robot_state, "checkpoint_every": self.checkpoint_every, "tag": self.tag}
        write_state(self.checkpoint, payload, arrays)


class _Oracle:
    """True (x, y, heading) and objective per cycle of a gait, when the robot exposes its system."""

    def __init__(self, robot, objective_name, evaluate):
        self.system = None if robot is None else robot.current_system
        self.available = self.system is not None
        self.objective, self.evaluate = objective_name, evaluate
        self.cache = {}

    def __call__(self, gait, state):
        if self.system is None:
            return np.full(3, np.nan), np.nan
        system = self.system()
        key = (id(system), gait)
        if key not in self.cache:
            self.cache[key] = TrueMotion(system, resolution=128)(gait)
        pose = self.cache[key]
        if self.objective == "forward" and state.direction is None:
            return pose, np.nan
        return pose, self.evaluate(pose, np.zeros((3, gait.params.size)), gait)[0]
