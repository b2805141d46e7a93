"""A cycle's body velocities checked against its poses: glitches and unit mismatches named, noise let through."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.gaits import Perturbation, seed_gait
from geogait.simulate import SwimmerStream, end_pose, velocity_pose_disagreement
from geogait.systems import PurcellSwimmer

CHECK = settings(derandomize=True, database=None, deadline=None, max_examples=30)


def _cycle(links=3, noise=0.1, samples=40, seed=0):
    stream = SwimmerStream(PurcellSwimmer(links), seed_gait(links - 1), sensor_noise=noise, seed=seed,
                           perturbation=Perturbation.from_std(0.15, frequency=2.0), samples_per_cycle=samples)
    stream.next_cycle()
    return stream.next_cycle()


@CHECK
@given(links=st.sampled_from([3, 5]), noise=st.sampled_from([0.0, 0.1, 0.5]), samples=st.sampled_from([8, 40, 100]),
       seed=st.integers(0, 100))
def test_a_swimmers_own_cycles_agree_with_sensor_noise_on_the_velocities(links, noise, samples, seed):
    assert velocity_pose_disagreement(_cycle(links, noise, samples, seed), 1.0) is None


@CHECK
@given(index=st.integers(0, 39), size=st.sampled_from([1e3, -1e4, 1e6]), channel=st.sampled_from([0, 1, 2]))
def test_one_glitch_anywhere_is_named_with_its_sample(index, size, channel):
    cycle = _cycle()
    velocity = cycle.body_velocity.copy()
    velocity[index, channel] = size
    reason = velocity_pose_disagreement(dataclasses.replace(cycle, body_velocity=velocity), 1.0)
    assert reason is not None and f"at sample {index}" in reason
    assert ("the last sample's: it sets the cycle's end pose" in reason) == (index == 39)


@pytest.mark.parametrize("factor", [1000.0, 0.001, 180 / np.pi])
def test_velocities_in_other_units_than_the_poses_are_named_with_the_factor(factor):
    cycle = _cycle()
    for scaled in ([factor, factor, factor], [1, 1, factor] if factor > 1 else [factor, factor, 1]):
        reason = velocity_pose_disagreement(dataclasses.replace(cycle, body_velocity=cycle.body_velocity * scaled),
                                            1.0)
        assert reason is not None and "different units" in reason
        shown = float(reason.split("move the body ")[1].split("×")[0])
        assert shown == pytest.approx(factor, rel=0.1)


def test_the_end_pose_of_a_cycle_that_agrees_is_its_extrapolated_last_step():
    """What the check protects: end_pose moves the last pose by the last body velocity alone."""
    cycle = _cycle(noise=0.0)
    velocity = cycle.body_velocity.copy()
    velocity[-1] = [100.0, 0, 0]
    glitched = dataclasses.replace(cycle, body_velocity=velocity)
    assert np.hypot(*(end_pose(glitched, 1.0) - end_pose(cycle, 1.0))[:2]) == pytest.approx(100 / 40, rel=0.05)
    assert velocity_pose_disagreement(cycle, 1.0) is None and velocity_pose_disagreement(glitched, 1.0) is not None


def test_a_cycle_of_too_few_samples_is_refused_naming_the_field():
    cycle = _cycle()
    short = dataclasses.replace(cycle, pose=cycle.pose[:3], body_velocity=cycle.body_velocity[:3], time=cycle.time[:3])
    with pytest.raises(ValueError, match="'cycle' parameter of velocity_pose_disagreement"):
        velocity_pose_disagreement(short)


@pytest.mark.parametrize("samples", [20, 40, 100])
@pytest.mark.parametrize("times", [3.0, 10.0, -5.0])
def test_a_moderate_glitch_on_the_last_sample_is_named_before_it_moves_the_end_pose(samples, times):
    """Before: a last-sample body velocity 10× the body's speed passed (only 20× the cycle's steps was a glitch); it
    moved the end pose by about nine steps, and the cycle's measured objective fell from 0.54 to 0.42."""
    cycle = _cycle(noise=0.1, samples=samples, seed=3)
    velocity = cycle.body_velocity.copy()
    velocity[-1] = times * np.abs(cycle.body_velocity).max(axis=0)
    glitched = dataclasses.replace(cycle, body_velocity=velocity)
    moved = np.hypot(*(end_pose(glitched, 1.0) - end_pose(cycle, 1.0))[:2])
    step = np.median(np.hypot(*np.diff(cycle.pose[:, :2], axis=0).T))
    assert moved > 1.5 * step  # (what it would cost: the end pose off by more than a step)
    reason = velocity_pose_disagreement(glitched, 1.0)
    assert reason is not None and "the last sample's: it sets the cycle's end pose" in reason


@CHECK
@given(links=st.sampled_from([3, 5, 7]), noise=st.sampled_from([0.0, 0.05, 0.3]), samples=st.sampled_from([20, 200]),
       seed=st.integers(0, 10_000))
def test_the_last_samples_own_noise_is_not_a_glitch(links, noise, samples, seed):
    stream = SwimmerStream(PurcellSwimmer(links), seed_gait(links - 1), sensor_noise=noise, seed=seed,
                           perturbation=Perturbation.from_std(0.15, frequency=2.0), samples_per_cycle=samples)
    for _ in range(5):
        assert velocity_pose_disagreement(stream.next_cycle(), 1.0) is None
