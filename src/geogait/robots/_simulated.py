"""What the physics simulators (:class:`~geogait.robots.ElasticaSnake`, :class:`~geogait.robots.MujocoRobot`)
share beside their physics: how a cycle period is timed, whole cycles, and the run's state that a checkpoint holds
next to the physics state."""

from __future__ import annotations

import copy

import numpy as np

from .._validation import check_float, check_int, fail
from ..gaits import FourierGait
from ..simulate import Trajectory

#: The run's state beside the physics, in a checkpoint (:meth:`SimulatedRobot._run_state`).
RUN_STATE = ("perturbation", "gait", "rng", "cycle", "heading")


class SimulatedRobot:
    """A simulator that runs one cycle in ``next_cycle``, holds its gait ``_gait``, exploration stream
    ``_perturbation``, generator ``_rng``, ``cycle`` and unwrapped ``_heading``, and checks a gait with
    ``_check_gait(gait, owner)``."""

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` from the next cycle on (:meth:`next_cycle` always runs whole cycles)."""
        self._check_gait(gait, f"{type(self).__name__}.set_gait")
        self._gait = gait

    def next_cycles(self, n_cycles: int) -> Trajectory:
        """``n_cycles`` whole cycles, joined along time."""
        n_cycles = check_int(n_cycles, "n_cycles", f"{type(self).__name__}.next_cycles", minimum=1)
        return Trajectory.concatenate([self.next_cycle() for _ in range(n_cycles)])

    def _units_per_cycle(self, cycle_period, unit: float, fewest: int, too_few: str) -> int:
        """How many ``unit`` s of physics time come nearest ``cycle_period`` (the physics times nothing finer);
        refuses fewer than ``fewest``, saying it needs ``too_few``."""
        owner = f"{type(self).__name__}.set_cycle_period"
        period = check_float(cycle_period, "cycle_period", owner, low=0, low_open=True)
        count = int(round(period / unit))
        if count < fewest:
            raise fail("cycle_period", owner, too_few, period)
        return count

    def _run_state(self) -> dict:
        """The :data:`RUN_STATE` of a checkpoint (JSON values and arrays)."""
        return {"perturbation": self._perturbation.state.copy(), "gait": np.array(self._gait.coefficients),
                "rng": copy.deepcopy(self._rng.bit_generator.state), "cycle": int(self.cycle),
                "heading": float(self._heading)}

    def _check_state_keys(self, state, owner: str, physics: tuple) -> None:
        """Refuse a ``state`` that is not a dict holding the ``physics`` keys and the :data:`RUN_STATE`."""
        keys = set(physics) | set(RUN_STATE)
        if not isinstance(state, dict) or not keys <= set(state):
            raise fail("state", owner, f"a dict from {type(self).__name__}.robot_state() with keys "
                       + ", ".join(sorted(keys)), sorted(state) if isinstance(state, dict) else type(state).__name__)

    def _checked_run_state(self, state: dict, owner: str) -> tuple[np.ndarray, FourierGait]:
        """The checkpoint's exploration state and gait, checked against this robot before anything is restored."""
        perturbation = np.asarray(state["perturbation"], dtype=float)
        if perturbation.shape != self._perturbation.state.shape:
            raise fail("state", owner, f"a perturbation state of shape {self._perturbation.state.shape}",
                       f"shape {perturbation.shape}")
        gait = FourierGait(np.asarray(state["gait"], dtype=float))
        self._check_gait(gait, owner)
        return perturbation, gait

    def _restore_run_state(self, state: dict, perturbation: np.ndarray, gait: FourierGait) -> None:
        """Continue the run of ``state`` (its exploration state and gait checked by :meth:`_checked_run_state`)."""
        self._perturbation.state = perturbation.copy()
        self._gait = gait
        self._rng.bit_generator.state = copy.deepcopy(state["rng"])
        self.cycle = int(state["cycle"])
        self._heading = float(state["heading"])
