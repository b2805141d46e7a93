"""The Objective part: what a gait is judged by. The objective functions' gradients agree with finite differences,
a higher Fourier order cannot win the budget or efficiency objective by running the same loop more than once per
cycle, and ``Objective(kind="forward")`` takes its direction from the mean motion of the seed's measured cycles
(refusing a seed whose motion is noise), moves every cycle along it without turning round, and turns the gait
round when asked to go the other way."""

import numpy as np
import pytest
from _robots import perturbed_stream as _stream

from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, seed_gait
from geogait.optimize import (
    Gate,
    InSituOptimizer,
    ModelStep,
    Objective,
    default_objective,
    objective,
    optimize_ceiling,
    path_length,
    rms_speed,
)
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


def test_objective_gradients_match_finite_differences(rng):
    swimmer, gait = PurcellSwimmer(3), FourierGait(rng.normal(scale=0.5, size=(2, 5)))
    for kind in ("progress", "efficiency", "budget"):
        pose, jac = cycle_displacement(swimmer, gait, jacobian=True)
        _, gradient = objective(kind, pose, jac, gait)
        fd = []
        for k in range(gait.params.size):
            step = np.zeros(gait.params.size)
            step[k] = 1e-6
            plus, minus = gait.with_params(gait.params + step), gait.with_params(gait.params - step)
            fd.append((objective(kind, cycle_displacement(swimmer, plus), jac, plus)[0]
                       - objective(kind, cycle_displacement(swimmer, minus), jac, minus)[0]) / 2e-6)
        np.testing.assert_allclose(gradient, fd, rtol=1e-5, atol=1e-8)
    circle = FourierGait(np.array([[0, 1.0, 0], [0, 0, 1.0]]))
    np.testing.assert_allclose(path_length(circle), 2 * np.pi, rtol=1e-9)  # unit circle in shape space


def repeated(gait: FourierGait, times: int) -> FourierGait:
    """θ(times · φ): the same loop run ``times`` times per cycle, in the family of order ``times * K``."""
    coefficients = np.zeros((gait.n_joints, 2 * times * gait.order + 1))
    coefficients[:, 0] = gait.coefficients[:, 0]
    k = np.arange(1, gait.order + 1)
    coefficients[:, times * k] = gait.coefficients[:, k]
    coefficients[:, times * gait.order + times * k] = gait.coefficients[:, gait.order + k]
    return FourierGait(coefficients)


def test_higher_orders_are_not_won_by_repeating_the_loop():
    swimmer = PurcellSwimmer(3)
    assert default_objective(1) == "progress" and default_objective(2) == "budget"
    single = optimize_ceiling(swimmer, objective_kind="budget", starts=1)
    twice = repeated(single.gait, 2)
    phase = np.linspace(0, 2 * np.pi, 16)
    np.testing.assert_allclose(twice.shape(phase), single.gait.shape(2 * phase), atol=1e-12)
    values = {}
    for kind in ("progress", "budget", "efficiency"):
        values[kind] = [objective(kind, cycle_displacement(swimmer, g), np.zeros((3, g.params.size)), g)[0]
                        for g in (single.gait, twice)]
    assert np.isclose(values["progress"][1], 2 * values["progress"][0], rtol=1e-6)  # progress rewards repeats
    assert np.isclose(values["budget"][1], values["budget"][0], rtol=1e-6)  # budget and efficiency do not
    assert np.isclose(values["efficiency"][1], values["efficiency"][0], rtol=1e-6)
    assert np.isclose(rms_speed(twice), 2 * rms_speed(single.gait))
    # The order-2 optimum of the default objective is a single loop as good as the order-1 one (for the
    # 3-link swimmer the second harmonic adds nothing), not a loop run twice.
    order2 = optimize_ceiling(swimmer, order=2, starts=3)
    assert single.value * (1 - 1e-6) <= order2.value <= 1.01 * single.value
    harmonics = np.hypot(order2.gait.coefficients[:, 1:3], order2.gait.coefficients[:, 3:5])  # (d, k)
    assert harmonics[:, 0].max() > 10 * harmonics[:, 1].max()


def test_forward_direction_is_the_mean_motion_of_the_seeds_cycles():
    """"forward" comes from every measured cycle of the seed, not the first one alone, and a seed whose
    motion cannot be told from noise is refused."""
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=1)
    result = InSituOptimizer(gate=Gate(min_cycles=4), objective=Objective(kind="forward"), family="free").run(stream, 8)
    log = result.log
    seed = log[(log["iteration"] == 0) & ~log["settling"]]
    heading = seed["world_heading"].to_numpy()
    world = np.column_stack([np.cos(heading) * seed["measured_x"] - np.sin(heading) * seed["measured_y"],
                             np.sin(heading) * seed["measured_x"] + np.cos(heading) * seed["measured_y"]])
    mean = world[:4].mean(axis=0)  # the four cycles before the first gate decision
    np.testing.assert_allclose(result.direction, mean / np.hypot(*mean), atol=1e-9)
    assert result.summary()["forward_direction"] == pytest.approx(list(result.direction))
    assert result.n_steps >= 1
    # a reciprocal seed (one joint moving) goes nowhere: exploration alone moves it, in no direction
    still = FourierGait(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))
    noisy = SwimmerStream(PurcellSwimmer(3), still, sensor_noise=0.1, seed=2)
    with pytest.raises(GeogaitError, match="cannot be told from noise"):
        InSituOptimizer(gate=Gate(min_cycles=4), objective=Objective(kind="forward"), family="free").run(noisy, 10)


def test_forward_objective_follows_the_commanded_heading_and_never_turns_round():
    # Default direction: the way the seed started. Every cycle moves forward along it in the world.
    log = InSituOptimizer(objective=Objective(kind="forward")).run(_stream(seed=2), 20).log
    start = log[["world_x", "world_y"]].to_numpy()
    direction = start[1] - start[0]
    advance = np.diff(start, axis=0) @ (direction / np.linalg.norm(direction))
    assert np.all(advance > 0)
    assert log["measured_objective"].tail(3).mean() > log["measured_objective"].head(3).mean()


def test_forward_objective_sign_matters():
    # Asked to go the other way, the optimiser turns the gait round: the objective starts negative.
    seed_motion = cycle_displacement(PurcellSwimmer(3), seed_gait(2))[:2]
    log = InSituOptimizer(step=ModelStep(trust_radius=0.15),
                          objective=Objective(kind="forward", direction=-seed_motion)).run(_stream(seed=3), 40).log
    assert log["measured_objective"].iloc[0] < 0
    assert log["measured_objective"].iloc[-1] > log["measured_objective"].iloc[0] + 0.02
