"""Exploration owned by the optimiser: the excitation it generates, robots that run it, and a run
that sees no exploration at all."""

import numpy as np
import pytest

from geogait.gaits import FourierGait, Perturbation, check_excitation, excitation_at, seed_gait
from geogait.optimize import Climb, Exploration, InSituOptimizer
from geogait.optimize._exploration import GRID
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def _quiet_stream(gait=None, seed=0):
    """A simulated swimmer with no perturbation of its own."""
    return SwimmerStream(PurcellSwimmer(3), seed_gait(2) if gait is None else gait,
                         perturbation=Perturbation(eta=0), sensor_noise=0.05, seed=seed)


def test_excitation_is_eq8_at_its_size_continuous_across_cycles():
    exploration = Exploration(std=0.15).signal(1.0, 2, np.random.default_rng(0))
    cycles = [exploration.next_cycle(period=2.0) for _ in range(400)]
    delta = np.concatenate([c[0] for c in cycles])
    assert delta.std() == pytest.approx(0.15, rel=0.1)
    # two oscillations per cycle: δ̇ std = 2π · 2 · δ std per cycle, per second at T = 2 s
    rate = np.concatenate([c[1] for c in cycles])
    assert rate.std() == pytest.approx(2 * np.pi * 2 * 0.15 / 2.0, rel=0.15)
    jumps = np.abs(np.diff(delta, axis=0))  # within and across cycle boundaries alike
    boundary = np.abs(np.array([cycles[k + 1][0][0] - cycles[k][0][-1] for k in range(399)]))
    assert boundary.mean() < 2 * jumps.mean()


def test_excitation_at_interpolates_periodically_and_check_names_fields():
    phase = 2 * np.pi * np.arange(8) / 8
    shape = np.stack([np.sin(phase), np.cos(phase)], axis=1)
    delta, rate = excitation_at(np.array([0.0, np.pi / 8, 2 * np.pi - np.pi / 8, 4 * np.pi]), shape, 2 * shape)
    np.testing.assert_allclose(delta[:, 0], [0, np.sin(np.pi / 4) / 2, -np.sin(np.pi / 4) / 2, 0], atol=1e-12)
    np.testing.assert_allclose(rate, 2 * delta)
    with pytest.raises(ValueError, match="'shape'.*M >= 4"):
        check_excitation(np.zeros((3, 2)), np.zeros((3, 2)), 2, "test")
    with pytest.raises(ValueError, match="'shape_velocity'.*finite"):
        check_excitation(np.zeros((8, 2)), np.full((8, 2), np.nan), 2, "test")
    with pytest.raises(ValueError, match="'shape'.*\\(M, 3\\)"):
        check_excitation(np.zeros((8, 2)), np.zeros((8, 2)), 3, "test")


def test_the_optimiser_explores_a_robot_that_does_not_and_sizes_it_in_shape_units():
    # model steps first: the model explores
    result = InSituOptimizer(climb=Climb(start="stalled")).run(_quiet_stream(), 16)
    log = result.log
    assert log["excitation"].mean() == pytest.approx(0.15, rel=0.35) and result.n_steps >= 3
    big = FourierGait(1.5 * seed_gait(2).coefficients)  # shape_scale "auto": the seed's amplitude, 1.5
    scaled = InSituOptimizer(climb=Climb(start="stalled")).run(_quiet_stream(big), 8).log
    assert scaled["excitation"].mean() == pytest.approx(0.225, rel=0.35)
    half = InSituOptimizer(climb=Climb(start="stalled"), exploration=Exploration(std=0.05)).run(_quiet_stream(), 8).log
    assert half["excitation"].mean() == pytest.approx(0.05, rel=0.35)


def test_a_run_without_exploration_says_so_and_takes_no_model_step():
    with pytest.warns(UserWarning, match="carry no exploration"):
        log = InSituOptimizer(climb=False, exploration=None).run(_quiet_stream(), 12).log
    assert log["excitation"].max() < 1e-12 and not log["step"].any()


def test_exploration_options_are_checked_before_the_robot_moves():
    class Bare:
        def __init__(self):
            self.stream = _quiet_stream()
            self.n_joints, self.cycle_period = 2, 1.0

        gait = property(lambda self: self.stream.gait)

        def set_gait(self, gait):
            self.stream.set_gait(gait)

        def next_cycle(self):
            return self.stream.next_cycle()

    robot = Bare()
    with pytest.raises(ValueError, match="set_excitation"):
        InSituOptimizer(exploration=Exploration(std=0.1)).run(robot, 3)
    for bad in (-0.1, "yes", np.nan):
        with pytest.raises(ValueError, match="'std' parameter of Exploration"):
            InSituOptimizer(exploration=Exploration(std=bad)).run(robot, 3)
    with pytest.raises(ValueError, match="'exploration' parameter of InSituOptimizer"):
        InSituOptimizer(exploration=0.1).run(robot, 3)
    assert robot.stream.cycle == 0
    with pytest.warns(UserWarning, match="carry no exploration"):  # "auto": it cannot be commanded
        assert InSituOptimizer().run(robot, 4).log["excitation"].max() < 1e-12


def test_mujoco_robot_runs_the_excitation_it_is_sent():
    pytest.importorskip("mujoco")
    from geogait.robots import MujocoRobot, purcell_swimmer_xml

    robot = MujocoRobot(purcell_swimmer_xml(3), seed=1)
    rng_state = robot._rng.bit_generator.state
    phase = 2 * np.pi * np.arange(GRID) / GRID
    shape = 0.1 * np.stack([np.sin(3 * phase), np.cos(2 * phase)], axis=1)
    rate = 0.1 * np.stack([3 * np.cos(3 * phase), -2 * np.sin(2 * phase)], axis=1) * 2 * np.pi / robot.cycle_period
    robot.set_excitation(shape, rate)
    cycle = robot.next_cycle()
    expected = robot.gait.shape(cycle.phase) + excitation_at(cycle.phase, shape, rate)[0]
    np.testing.assert_allclose(cycle.commanded_shape, expected, atol=1e-12)
    assert robot._rng.bit_generator.state == rng_state  # its own perturbation did not advance
    following = robot.next_cycle()  # one cycle only: then its own perturbation again
    own = following.commanded_shape - robot.gait.shape(following.phase)
    assert not np.allclose(own, excitation_at(following.phase, shape, rate)[0], atol=1e-3)
