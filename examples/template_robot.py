"""Template: your own robot as a geogait ``Robot``, checked, then its gait optimised in situ.

Copy this file and replace the two hardware methods, ``_command`` and ``_measure``, with your robot's
calls. Everything else (timing, phase, the ``Trajectory`` of one cycle, body velocity from
motion-capture poses) stays as it is.

As shipped, the two methods drive a stand-in body so that the file runs anywhere: a 3-link swimmer
in a viscous fluid whose joints follow their targets with a 50 ms lag, seen by a motion-capture
system with 0.2 mm of noise.

Run::

    python examples/template_robot.py               # 30 cycles, about 10 s
    python examples/template_robot.py --cycles 60
"""

from __future__ import annotations

import argparse

import numpy as np

from geogait import se2
from geogait.gaits import FourierGait, check_excitation, excitation_at, seed_gait
from geogait.optimize import for_robot
from geogait.robots import check_robot
from geogait.simulate import Trajectory
from geogait.systems import PurcellSwimmer


class MyRobot:
    """A robot that geogait drives cycle by cycle (the :class:`geogait.robots.Robot` protocol).

    Parameters
    ----------
    cycle_period : float
        Seconds per gait cycle.
    samples_per_cycle : int
        Control ticks per cycle: one joint command and one measurement each.
    seed : int
        Seed of the stand-in body's sensor noise.
    """

    n_joints = 2
    #: Joint limits in radians, one (low, high) row per joint: the optimiser keeps every gait inside.
    joint_ranges = np.array([[-1.4, 1.4], [-1.4, 1.4]])

    def __init__(self, cycle_period: float = 2.0, samples_per_cycle: int = 50, seed: int = 0):
        self.cycle_period = cycle_period
        self.samples_per_cycle = samples_per_cycle
        self._gait = seed_gait(self.n_joints)  # the gait the robot starts with
        self._clock = 0.0  # seconds since the run started: one clock for the whole run
        self._cycle = 0
        self._excitation = None  # the exploration geogait asked for, for the next cycle only
        self._stand_in = StandInBody(self._gait.shape(0.0), seed)

    # -- the Robot protocol: three members and two methods, and set_excitation ------------------------
    @property
    def gait(self) -> FourierGait:
        """The gait that the next cycle runs."""
        return self._gait

    def set_gait(self, gait: FourierGait) -> None:
        """Run ``gait`` from the next cycle on."""
        self._gait = gait

    def set_excitation(self, shape, shape_velocity) -> None:
        """Add this exploration to the next cycle: δ (rad) at M phases 2πk / M, and its rate (optional member)."""
        self._excitation = check_excitation(shape, shape_velocity, self.n_joints, "MyRobot.set_excitation")

    def next_cycle(self) -> Trajectory:
        """Run one whole gait cycle and return what was measured."""
        n = self.samples_per_cycle
        dt = self.cycle_period / n
        phase = 2 * np.pi * np.arange(n) / n
        time = self._clock + dt * np.arange(n)
        commanded = self._gait.shape(phase)
        if self._excitation is not None:  # small perturbations: the model learns the gait's neighbourhood from them
            commanded = commanded + excitation_at(phase, *self._excitation)[0]
            self._excitation = None
        shape = np.empty((n, self.n_joints))
        pose = np.empty((n, 3))
        for k in range(n):
            self._command(commanded[k], dt)
            shape[k], pose[k] = self._measure()
        self._clock += self.cycle_period
        cycle = Trajectory(
            time=time, phase=phase, cycle=np.full(n, self._cycle),
            shape=shape,
            shape_velocity=np.gradient(shape, time, axis=0),  # encoders give angles: differentiate them
            body_velocity=se2.body_velocity_from_poses(time, pose, scheme="central"),  # motion capture gives poses
            pose=pose, commanded_shape=commanded)
        self._cycle += 1
        return cycle

    # -- your hardware: replace these two methods ---------------------------------------------------
    def _command(self, joint_angles: np.ndarray, seconds: float) -> None:
        """Send the joint targets (rad) and wait one control tick."""
        self._stand_in.step(joint_angles, seconds)

    def _measure(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (rad) from the encoders, and the body's world pose (x, y, heading) from motion capture."""
        return self._stand_in.read()


class StandInBody:
    """The body behind the template's hardware methods: a 3-link swimmer in a viscous fluid.

    Parameters
    ----------
    shape : ndarray of shape (2,)
        Joint angles at the start (rad).
    seed : int
        Seed of the motion-capture noise.
    """

    lag = 0.05  # seconds: the joints' first-order response to a new target
    pose_noise = 2e-4  # body lengths: motion-capture noise

    def __init__(self, shape, seed: int):
        self._physics = PurcellSwimmer(3)
        self._shape = np.array(shape, dtype=float)
        self._pose = np.zeros(3)
        self._rng = np.random.default_rng(seed)

    def step(self, target, seconds: float) -> None:
        moved = (np.asarray(target) - self._shape) * (1 - np.exp(-seconds / self.lag))
        middle = self._shape + moved / 2
        body_velocity = -self._physics.connection(middle) @ (moved / seconds)  # ξ = −A(r) ṙ
        self._pose = se2.compose(self._pose, se2.exp(body_velocity * seconds))
        self._shape = self._shape + moved

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        return self._shape.copy(), self._pose + self._rng.normal(0.0, self.pose_noise, 3)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=30, help="gait cycles to optimise for (default 30)")
    args = parser.parse_args(argv)

    robot = MyRobot()
    check_robot(robot)  # runs one cycle: a clear error naming what is wrong, before the optimiser drives it
    optimizer = for_robot(robot, random_state=0)  # the optimiser for what the robot declares; print it to see
    result = optimizer.run(robot, args.cycles)
    print(result.log[["cycle", "gamma", "step", "measured_progress"]].tail(5).to_string(index=False))
    summary = result.summary()
    print(f"net motion per cycle: {summary['seed_measured_objective']:.4f} body lengths with the seed gait, "
          f"{summary['final_measured_objective']:.4f} after {args.cycles} cycles ({summary['steps']} steps)")
    return result


if __name__ == "__main__":
    main()
