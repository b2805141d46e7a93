"""Robots for tests: a simulator seen only through the Robot protocol, and robots with physics outside the built-in
swimmer's (actuators that lag or saturate, a body that coasts, poses that mislead the model), written here
independently of the package's robots; and the perturbed, noisy swimmer the optimiser's tests run on."""

import dataclasses

import numpy as np

from geogait import se2
from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.simulate import SwimmerStream, Trajectory
from geogait.systems import PurcellSwimmer


class BareRobot:
    """Only the protocol's members of a SwimmerStream (no truth, no state): a swimmer behind a wall."""

    def __init__(self, stream):
        self._stream = stream
        self.n_joints, self.cycle_period = stream.n_joints, stream.cycle_period

    @property
    def gait(self):
        return self._stream.gait

    def set_gait(self, gait):
        self._stream.set_gait(gait)

    def next_cycle(self):
        return self._stream.next_cycle()


LAGGING_TAU = 0.6 / (2 * np.pi)  # actuator time constant: the best period of LaggingRobot is near 2πτ = 0.6 s


def lagging_gain(period):
    """Amplitude response of a first-order actuator at the gait's frequency 2π / T."""
    return 1 / np.sqrt(1 + (2 * np.pi * LAGGING_TAU / period) ** 2)


class LaggingRobot:
    """A kinematic 3-link swimmer driven by first-order actuators: at period T every joint realises
    the command scaled by 1/√(1 + (2πτ/T)²). Shorter cycles are faster until the joints no longer
    follow, so speed per second peaks at a period the model cannot know (about 2πτ). With ``joint_stop``
    every joint also stops at ±joint_stop rad (it rests there, at zero rate, while the command goes beyond).
    Written here, independently of the package's robots: the Robot protocol and set_cycle_period.
    """

    def __init__(self, cycle_period=1.0, samples_per_cycle=80, seed=0, joint_stop=None):
        self.joint_stop = joint_stop
        self.system = PurcellSwimmer(3)
        self.n_joints, self.cycle_period, self.samples = 2, cycle_period, samples_per_cycle
        self._gait, self.pose, self.elapsed = seed_gait(2), np.zeros(3), 0.0
        self.rng = np.random.default_rng(seed)
        self.periods = []

    @property
    def gait(self):
        return self._gait

    def set_gait(self, gait):
        self._gait = gait

    def set_cycle_period(self, period):
        self.cycle_period = round(period / 0.01) * 0.01  # a robot with a 10 ms clock

    def robot_state(self):
        return {"rng": self.rng.bit_generator.state, "pose": self.pose.copy(), "elapsed": self.elapsed,
                "cycle_period": self.cycle_period, "gait": self._gait.coefficients.copy()}

    def restore_robot_state(self, state):
        self.rng.bit_generator.state = state["rng"]
        self.pose, self.elapsed = np.asarray(state["pose"]), state["elapsed"]
        self.cycle_period, self._gait = state["cycle_period"], FourierGait(np.asarray(state["gait"]))

    def next_cycle(self):
        n, period = self.samples, self.cycle_period
        rate, gain = 2 * np.pi / period, lagging_gain(period)
        phase = 2 * np.pi * np.arange(n) / n
        offset = self.rng.uniform(0, 2 * np.pi, 2)
        wobble = 0.1 * np.sin(np.outer(phase, [3, 5]) + offset)
        wobble_rate = 0.1 * np.array([3, 5]) * np.cos(np.outer(phase, [3, 5]) + offset)
        commanded = self._gait.shape(phase) + wobble
        shape = gain * commanded
        shape_velocity = gain * (self._gait.velocity(phase) + wobble_rate) * rate
        if self.joint_stop is not None:
            stopped = np.abs(shape) > self.joint_stop
            shape = np.clip(shape, -self.joint_stop, self.joint_stop)
            shape_velocity = np.where(stopped, 0, shape_velocity)
        body_velocity = -np.einsum("nij,nj->ni", self.system.connection(shape), shape_velocity)
        poses = se2.integrate_body_velocity(body_velocity, period / n, self.pose)
        self.pose = poses[-1]
        time = self.elapsed + np.arange(n) * period / n
        self.elapsed += period
        self.periods.append(period)
        return Trajectory(time=time, phase=phase, cycle=np.full(n, len(self.periods) - 1), shape=shape,
                          shape_velocity=shape_velocity, body_velocity=body_velocity, pose=poses[:-1],
                          commanded_shape=commanded)


class CoastingSwimmer:
    """The built-in 3-link swimmer whose body velocity lags the kinematic one through a first-order filter
    (time constant ``tau`` s): a body with inertia that coasts. Its net motion per cycle changes with the cycle
    period. Written here, around SwimmerStream, with its pose re-integrated from the lagged velocity."""

    def __init__(self, tau=0.1, seed=0):
        self.stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=seed, samples_per_cycle=100)
        self.tau, self.velocity, self.pose = tau, np.zeros(3), np.zeros(3)
        self.n_joints = 2

    gait = property(lambda self: self.stream.gait)
    cycle_period = property(lambda self: self.stream.cycle_period)

    def set_gait(self, gait):
        self.stream.set_gait(gait)

    def set_excitation(self, shape, shape_velocity):
        self.stream.set_excitation(shape, shape_velocity)

    def set_cycle_period(self, period):
        self.stream.set_cycle_period(period)

    def robot_state(self):
        return {**self.stream.robot_state(), "coast_velocity": self.velocity.copy(), "coast_pose": self.pose.copy()}

    def restore_robot_state(self, state):
        state = dict(state)
        self.velocity, self.pose = np.asarray(state.pop("coast_velocity")), np.asarray(state.pop("coast_pose"))
        self.stream.restore_robot_state(state)

    def next_cycle(self):
        cycle = self.stream.next_cycle()
        dt = float(np.diff(cycle.time[:2])[0])
        lagged = np.empty_like(cycle.body_velocity)
        for i, kinematic in enumerate(cycle.body_velocity):
            lagged[i] = self.velocity
            self.velocity = self.velocity + (1 - np.exp(-dt / self.tau)) * (kinematic - self.velocity)
        poses = se2.integrate_body_velocity(lagged, dt, self.pose)
        self.pose = poses[-1]
        return dataclasses.replace(cycle, body_velocity=lagged, pose=poses[:-1])


class SaturatingRobot:
    """A kinematic 3-link swimmer whose joints cannot follow commands beyond ``limit`` (rad).

    The realised shape is limit · tanh(commanded / limit): an actuator that saturates smoothly.
    Written here, independently of SwimmerStream: it offers only the Robot protocol.
    """

    def __init__(self, limit=1.1, samples_per_cycle=100, cycle_period=1.5, seed=0):
        self.system, self.limit = PurcellSwimmer(3), limit
        self.n_joints, self.cycle_period, self.samples = 2, cycle_period, samples_per_cycle
        self._gait, self.pose, self.cycle = seed_gait(2), np.zeros(3), 0
        self.rng = np.random.default_rng(seed)

    @property
    def gait(self):
        return self._gait

    def set_gait(self, gait):
        self._gait = gait

    def next_cycle(self):
        n, rate = self.samples, 2 * np.pi / self.cycle_period
        phase = 2 * np.pi * np.arange(n) / n
        offset = self.rng.uniform(0, 2 * np.pi, 2)
        wobble = 0.1 * np.sin(np.outer(phase, [3, 5]) + offset)  # exploration
        commanded = self._gait.shape(phase) + wobble
        wobble_rate = 0.1 * np.array([3, 5]) * np.cos(np.outer(phase, [3, 5]) + offset)
        commanded_rate = (self._gait.velocity(phase) + wobble_rate) * rate
        shape = self.limit * np.tanh(commanded / self.limit)
        shape_velocity = commanded_rate / np.cosh(commanded / self.limit) ** 2
        body_velocity = -np.einsum("nij,nj->ni", self.system.connection(shape), shape_velocity)
        dt = self.cycle_period / n
        poses = se2.integrate_body_velocity(body_velocity, dt, self.pose)
        self.pose = poses[-1]
        time = (self.cycle + np.arange(n) / n) * self.cycle_period
        self.cycle += 1
        return Trajectory(time=time, phase=phase, cycle=np.full(n, self.cycle - 1), shape=shape,
                          shape_velocity=shape_velocity, body_velocity=body_velocity, pose=poses[:-1],
                          commanded_shape=commanded)


class WrappedStream:
    """A robot that is the stream it wraps in every member a subclass does not override: its truth and state too."""

    def __init__(self, stream):
        self.stream = stream

    def __getattr__(self, name):
        return getattr(self.stream, name)

    gait = property(lambda self: self.stream.gait)


class DeclaredRanges(WrappedStream):
    """A swimmer stream that declares joint ranges, as MujocoRobot does from its model, and keeps every gait it is
    commanded."""

    def __init__(self, stream, joint_ranges):
        super().__init__(stream)
        self.joint_ranges, self.commanded = joint_ranges, []

    def set_gait(self, gait):
        self.commanded.append(gait)
        self.stream.set_gait(gait)


class MisleadingPoses(WrappedStream):
    """A swimmer whose measured poses shrink the further the gait moves from the seed, while the
    body velocities the model learns from stay the swimmer's: the model is right about each gait's ξ
    and wrong about where progress lies (a model error only measured outcomes reveal)."""

    def __init__(self, stream, seed):
        super().__init__(stream)
        self.seed = seed

    def next_cycle(self):
        gait = self.stream.gait
        cycle = self.stream.next_cycle()
        factor = np.exp(-25 * np.sum((gait.params - self.seed.params) ** 2))
        pose = cycle.pose.copy()
        pose[:, :2] = pose[0, :2] + factor * (pose[:, :2] - pose[0, :2])
        body_velocity = cycle.body_velocity.copy()
        body_velocity[-1, :2] *= factor  # the last sample's motion closes the cycle in measure_cycle
        return dataclasses.replace(cycle, pose=pose, body_velocity=body_velocity)


def perturbed_stream(seed=0, **options):
    """The built-in 3-link swimmer with perturbations (std 0.15) and sensor noise (0.1)."""
    return SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation.from_std(0.15),
                         sensor_noise=0.1, seed=seed, **options)
