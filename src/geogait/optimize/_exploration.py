r"""Exploration owned by the optimiser: the perturbation of eq. 8, generated here and commanded.

The model learns from how the body moves when the shape leaves the nominal gait, so every cycle it
learns from must carry an excitation of the right size. Left to each robot, it is whatever an
adapter or a bridge driver happens to add — or nothing. Robots that offer
``set_excitation(shape, shape_velocity)`` (a robot-protocol extra: :class:`~geogait.robots.MujocoRobot`,
:class:`~geogait.simulate.SwimmerStream`, bridge drivers that declare ``"excitation": true``)
receive it from the optimiser instead: the stochastic oscillator of eq. 8 (``Perturbation``),
integrated in cycle time on a grid of ``GRID`` phases per cycle with its state carried across
cycles (so δ is continuous), sized in the robot's shape units (``std × shape_scale``), two
oscillations per cycle whatever the period. The robot adds δ(φ) to the commanded shape and δ̇ to
the commanded rate (linear interpolation in phase) for that one cycle.
"""

from __future__ import annotations

import numpy as np

from .._estimator import Real
from ..gaits import Perturbation
from ._part import Part

__all__ = ["ExcitationSignal", "Exploration", "GRID"]

#: Phases per cycle on which the excitation is sent (δ and δ̇ at 2πk / GRID).
GRID = 128


class Exploration(Part):
    """The optimiser's own exploration, a part of :class:`~geogait.optimize.InSituOptimizer`.

    Parameters
    ----------
    std : float
        Stationary standard deviation of δ, in units of the robot's ``shape_scale``.
    frequency : float
        Oscillations per cycle.
    """

    _parameter_constraints = {"std": Real(low=0), "frequency": Real(low=0, low_open=True)}

    def __init__(self, *, std: float = 0.15, frequency: float = 2.0):
        self.std = std
        self.frequency = frequency

    def signal(self, scale: float, n_joints: int, rng: np.random.Generator, initial_state=None) -> ExcitationSignal:
        """The excitation of a run: δ std ``std × scale`` shape units.

        Parameters
        ----------
        scale : float
            The robot's unit of shape (``shape_scale``).
        n_joints : int
        rng : numpy.random.Generator
            The run's generator (its draws are the run's).
        initial_state : ndarray of shape (d, 2), optional
            (δ, δ̇) to start from (a checkpoint's).

        Returns
        -------
        ExcitationSignal
        """
        return ExcitationSignal(self.std * scale, n_joints, rng, self.frequency, initial_state)


class ExcitationSignal:
    """The optimiser's excitation generator (module docstring).

    Parameters
    ----------
    std : float
        Stationary standard deviation of δ, shape units (0: no excitation).
    n_joints : int
    rng : numpy.random.Generator
        Draws the initial state and the white noise (the optimiser's own generator).
    frequency : float
        Oscillations per cycle (eq. 8's natural frequency in cycle time).
    initial_state : ndarray of shape (d, 2), optional
        (δ, δ̇) to start from (a checkpoint's); a stationary draw from ``rng`` by default.
    """

    def __init__(self, std: float, n_joints: int, rng: np.random.Generator, frequency: float = 2.0,
                 initial_state=None):
        self.std, self.n_joints, self.rng, self.frequency = float(std), int(n_joints), rng, float(frequency)
        self.perturbation = Perturbation.from_std(self.std, frequency=frequency)
        self.stream = self.perturbation.stream(1.0 / GRID, self.n_joints, rng, initial_state=initial_state)

    def next_cycle(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """δ (GRID, d) in shape units and δ̇ (GRID, d) in shape units per second for one cycle of ``period`` s."""
        states = self.stream.run(self.rng.standard_normal((GRID, self.n_joints, 2)))
        return states[..., 0].copy(), states[..., 1] / period

    @property
    def state(self) -> np.ndarray:
        """(δ, δ̇) per joint at the start of the next cycle (checkpointed)."""
        return self.stream.state

