"""ElasticaSnake: the Robot contract on PyElastica's continuum snake, forward motion, tracking, state."""

import sys

import numpy as np
import pytest

from geogait import GeogaitError, GeogaitWarning, se2
from geogait.gaits import FourierGait, Perturbation
from geogait.optimize import Gate, InSituOptimizer, Limits, ModelClassTest, Objective, Safety
from geogait.robots import ElasticaSnake, ProcessRobot, Robot, elastica_snake, read_robot_spec, snake_seed_gait
from geogait.robots.continuum import body_pose, curvature_profile
from geogait.systems import PurcellSwimmer

STILL = Perturbation(eta=0)


def needs_elastica():
    pytest.importorskip("elastica", reason="PyElastica not installed: pip install 'geogait[elastica]'")


@pytest.fixture(scope="module")
def still_cycles():
    """Three clean cycles of the seed gait (one snake for the whole module: PyElastica builds are slow)."""
    needs_elastica()
    snake = elastica_snake(perturbation=STILL, seed=0)
    return snake, [snake.next_cycle() for _ in range(3)]


def test_missing_pyelastica_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "elastica", None)
    with pytest.raises(ImportError, match=r"pip install 'geogait\[elastica\]'"):
        ElasticaSnake()


def test_snake_is_a_robot(still_cycles):
    snake, cycles = still_cycles
    assert isinstance(snake, Robot)
    assert read_robot_spec(snake).joint_ranges.shape == (4, 2)  # (check_robot would run the shared snake on)
    assert snake.n_joints == 4 and snake.cycle_period == 1.0
    assert snake.joint_ranges.shape == (4, 2) and snake.gait.joint_limit().max() <= snake.max_joint_angle
    for index, cycle in enumerate(cycles):
        n = snake.samples_per_cycle
        assert cycle.shape.shape == cycle.shape_velocity.shape == cycle.commanded_shape.shape == (n, 4)
        assert cycle.body_velocity.shape == cycle.pose.shape == (n, 3)
        for array in (cycle.time, cycle.phase, cycle.shape, cycle.shape_velocity, cycle.body_velocity, cycle.pose):
            assert np.all(np.isfinite(array))
        np.testing.assert_allclose(cycle.time, index + np.arange(n) / n)
        np.testing.assert_allclose(cycle.phase, 2 * np.pi * np.arange(n) / n)
        assert np.all(cycle.cycle == index)


def test_seed_gait_moves_the_snake_forward_and_straight(still_cycles):
    _, cycles = still_cycles
    for cycle in cycles[1:]:
        net = se2.between(cycle.pose[0], cycle.pose[-1])
        assert net[0] > 0.1 * 0.35 * (1 - 1 / 100)  # more than 0.1 body length per cycle, head first
        assert abs(net[2]) < 0.05
        assert np.mean(cycle.body_velocity[:, 0]) > 0.035


def test_realised_shape_tracks_the_commanded_one(still_cycles):
    _, cycles = still_cycles
    error = np.sqrt(np.mean((cycles[-1].shape - cycles[-1].commanded_shape) ** 2))
    assert error < 0.05  # rad, against a 1 rad seed amplitude (measured 0.022)


def test_measured_rates_are_the_derivatives_of_the_measured_samples(still_cycles):
    snake, cycles = still_cycles
    cycle = cycles[-1]
    dt = snake.cycle_period / snake.samples_per_cycle
    numeric = np.gradient(cycle.shape, dt, axis=0)[1:-1]
    scale = np.abs(cycle.shape_velocity).max()
    assert np.abs(numeric - cycle.shape_velocity[1:-1]).max() < 0.05 * scale
    heading_rate = np.gradient(cycle.pose[:, 2], dt)[1:-1]
    assert np.abs(heading_rate - cycle.body_velocity[1:-1, 2]).max() < 0.05 * np.abs(heading_rate).max()


def test_the_chain_geometry_reconstructs_the_rod_and_its_body_frame(still_cycles):
    """The rod as a chain of its elements: the shape map's joint angles from the measured modal shape rebuild
    the rod's element directions (to the curvature the modes leave out), and the chain's centre-of-mass
    frame is the pose the snake measures."""
    snake, _ = still_cycles
    geometry = snake.chain_geometry()
    nodes = snake._nodes()[0]
    edges = np.diff(nodes, axis=0)
    element_angle = np.unwrap(np.arctan2(edges[:, 1], edges[:, 0]))
    _, curvature = curvature_profile(nodes)
    shape = curvature @ snake._projector.T  # what the snake measures as its shape
    joints = np.asarray(geometry["shape_map"]) @ shape
    turning = np.diff(element_angle)
    assert np.abs(joints - turning).max() < 0.05 * np.abs(turning).max()  # sign, scale, order agree
    chain = PurcellSwimmer(snake.n_elements, link_lengths=geometry["link_lengths"],
                           body_frame=geometry["body_frame"])
    frame = chain._geometry
    relative = frame["incidence"] @ turning  # the rod's own element angles in element 0's frame
    np.testing.assert_allclose(relative, element_angle - element_angle[0], atol=1e-12)
    pose = body_pose(nodes, masses=snake._masses)
    heading = element_angle[0] + relative @ frame["frame_angle"]
    assert abs(heading - pose[2]) < 1e-9
    unit = np.stack([np.cos(element_angle), np.sin(element_angle)])
    centres = (unit @ frame["centres"].T).T
    origin = nodes[0] + edges[0] / 2 - centres[0]  # the chain's construction point in the world
    # (the rod's elements stretch a little; the chain's are its rest lengths)
    np.testing.assert_allclose(centres + origin, (nodes[:-1] + nodes[1:]) / 2, atol=1e-3 * snake.length)
    np.testing.assert_allclose(unit @ frame["frame_point"] + origin, pose[:2], atol=1e-3 * snake.length)


def test_exploration_perturbs_the_command_and_restore_is_bit_identical():
    needs_elastica()
    snake = elastica_snake(seed=1, warmup_cycles=0, samples_per_cycle=50, cycle_period=0.5)
    state = snake.robot_state()
    first = snake.next_cycle()
    delta = first.commanded_shape - snake.gait.shape(first.phase)
    assert 0.03 < np.std(delta) < 0.5  # 15 % of the 1 rad seed amplitude
    snake.restore_robot_state(state)
    again = snake.next_cycle()
    for name in ("shape", "shape_velocity", "body_velocity", "pose", "commanded_shape"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))


def test_set_gait_takes_effect_at_the_next_cycle_and_is_checked():
    needs_elastica()
    snake = elastica_snake(perturbation=STILL, warmup_cycles=0, samples_per_cycle=20, cycle_period=0.2)
    gait = snake_seed_gait(4, 0.5)
    snake.set_gait(gait)
    cycle = snake.next_cycle()
    np.testing.assert_allclose(cycle.commanded_shape, gait.shape(cycle.phase))
    with pytest.raises(ValueError, match="'gait' parameter of ElasticaSnake.set_gait must be a FourierGait with 4"):
        snake.set_gait(snake_seed_gait(3))
    with pytest.raises(ValueError, match="within max_joint_angle"):
        snake.set_gait(FourierGait(np.full((4, 3), 1.0)))
    snake.close()
    with pytest.raises(ValueError, match="closed"):
        snake.next_cycle()


#: A Gaussian-process optimiser's first candidate on the benchmark's snake (seed 9): every mode near 1.5 rad.
WIDE_GAIT = FourierGait(np.array([[0.0, -1.531609, 1.290501], [0.0, -1.500974, -1.167771],
                                  [0.0, 0.576142, -0.323349], [0.0, -1.446999, -1.514158]]))


def test_an_instant_switch_between_large_gaits_breaks_the_rod_and_is_refused():
    needs_elastica()
    snake = elastica_snake(perturbation=STILL, switch_cycles=0)
    snake.next_cycle()
    snake.set_gait(WIDE_GAIT)
    with pytest.raises(GeogaitError, match=r"broke in cycle 1 \(an element at .*× .* its rest length\).*switch_cycles"):
        snake.next_cycle()


def test_a_switch_moves_the_command_continuously_and_the_rod_stays_whole():
    needs_elastica()
    snake = elastica_snake(perturbation=STILL)
    seed = snake.gait
    snake.next_cycle()
    snake.set_gait(WIDE_GAIT)
    switch = snake.next_cycle()
    weight = (switch.phase / (2 * np.pi))[:, None]
    np.testing.assert_allclose(switch.commanded_shape,
                               (1 - weight) * seed.shape(switch.phase) + weight * WIDE_GAIT.shape(switch.phase))
    after = snake.next_cycle()
    np.testing.assert_allclose(after.commanded_shape, WIDE_GAIT.shape(after.phase))
    assert np.max(np.abs(snake.rod.dilatation - 1)) < 0.05
    snake.set_gait(WIDE_GAIT)  # the same gait again: no switch
    np.testing.assert_allclose(snake.next_cycle().commanded_shape, after.commanded_shape)


def test_a_switch_under_way_is_restored_bit_identically():
    needs_elastica()
    snake = elastica_snake(seed=2, samples_per_cycle=50, cycle_period=0.5, switch_cycles=3)
    snake.set_gait(snake_seed_gait(4, 0.5))
    snake.next_cycle()
    state = snake.robot_state()
    assert state["switch_done"] == 1 and state["switch_from"].shape == (4, 3)
    first = [snake.next_cycle() for _ in range(3)]
    again = elastica_snake(seed=2, samples_per_cycle=50, cycle_period=0.5, switch_cycles=3)
    again.restore_robot_state(state)
    for cycle, other in zip(first, (again.next_cycle() for _ in range(3)), strict=True):
        np.testing.assert_array_equal(cycle.commanded_shape, other.commanded_shape)
        np.testing.assert_array_equal(cycle.pose, other.pose)
    assert again.robot_state()["switch_from"] is None  # (three cycles: the switch's last two, then the gait)
    with pytest.raises(ValueError, match="switch_done from 0 to switch_cycles − 1 = 2"):
        again.restore_robot_state({**state, "switch_done": 3})


def test_legendre_modes_track_too():
    needs_elastica()
    coefficients = np.zeros((3, 3))
    coefficients[1, 1] = coefficients[2, 2] = 1.5  # rad per body length of P1 and P2 curvature
    snake = elastica_snake(n_modes=3, modes="legendre", gait=FourierGait(coefficients), perturbation=STILL,
                           samples_per_cycle=50)
    cycle = snake.next_cycle()
    assert snake.modes.kind == "legendre"
    # measured 0.25 rad: standing polynomial bends drag the body sideways, unlike the sliding seed wave (0.022)
    assert np.sqrt(np.mean((cycle.shape - cycle.commanded_shape) ** 2)) < 0.3 * 1.5


def test_bad_options_are_named():
    needs_elastica()
    with pytest.raises(ValueError, match="'cycle_period' parameter of ElasticaSnake must be a positive multiple"):
        ElasticaSnake(cycle_period=1.00001)
    with pytest.raises(ValueError, match="'timestep' parameter of ElasticaSnake must be at most"):
        ElasticaSnake(timestep=1e-3, cycle_period=1.0)
    with pytest.raises(ValueError, match="'gait' parameter of ElasticaSnake must be given when modes='legendre'"):
        ElasticaSnake(modes="legendre")
    with pytest.raises(ValueError, match="'friction' parameter of ElasticaSnake"):
        ElasticaSnake(friction=[0.1, 0.2])


def test_the_period_can_change_between_cycles_and_is_restored():
    needs_elastica()
    snake = elastica_snake(perturbation=STILL, warmup_cycles=0, samples_per_cycle=20, cycle_period=0.2)
    first = snake.next_cycle()
    snake.set_cycle_period(0.4321)  # the nearest whole number of steps per sample: 86 × 20 × 0.25 ms
    assert snake.cycle_period == pytest.approx(0.43) and snake.steps_per_sample == 86
    state = snake.robot_state()
    slow = snake.next_cycle()
    np.testing.assert_allclose(slow.time, 0.2 + np.arange(20) * 0.43 / 20)  # stamps run on from the first cycle
    assert slow.time[0] > first.time[-1]
    other = elastica_snake(perturbation=STILL, warmup_cycles=0, samples_per_cycle=20, cycle_period=0.2)
    other.restore_robot_state(state)
    assert other.cycle_period == snake.cycle_period
    np.testing.assert_array_equal(other.next_cycle().pose, slow.pose)
    with pytest.raises(ValueError, match="'cycle_period' parameter of ElasticaSnake.set_cycle_period"):
        snake.set_cycle_period(0.001)


def test_the_optimisers_model_class_test_finds_the_snake_outside():
    """The snake moves 6.4 % less per cycle at 2 s than at 1 s (docs/results/model-class.md, measured the same
    way): the run says so and its model takes no step. Without the settling cycle the first cycles after the
    warm-up vary by a few per cent and the test cannot tell."""
    needs_elastica()
    snake = elastica_snake(seed=0)
    optimizer = InSituOptimizer(safety=Safety(settle_cycles=1), limits=Limits(max_joint_angle=snake.max_joint_angle),
                                # (the warm-up's transient settles first)
                                objective=Objective(kind="forward", frame="body"), checks=[ModelClassTest(cycles=3)])
    with pytest.warns(GeogaitWarning, match="outside the model class"):
        result = optimizer.run(snake, 10)
    verdict = result.model_class
    assert verdict.principally_kinematic is False and verdict.periods == (1.0, 2.0)
    np.testing.assert_allclose(verdict.progress, (0.0512, 0.0479), atol=5e-4)
    assert not (result.log["step"] & ~result.log["climb"]).any()


def test_in_situ_optimiser_runs_on_the_snake():
    needs_elastica()
    snake = elastica_snake(seed=2)
    optimizer = InSituOptimizer(gate=Gate(min_cycles=1), limits=Limits(max_joint_angle=snake.max_joint_angle),
                                objective=Objective(kind="forward", frame="body"))
    result = optimizer.run(snake, 4)
    assert len(result.log) == 4
    assert np.all(result.log["measured_progress"] > 0)


def test_the_reference_driver_serves_the_snake_through_the_bridge():
    """``geogait optimize --robot "python -m geogait.robots.driver --robot elastica"`` needs no user glue."""
    needs_elastica()
    driver = [sys.executable, "-m", "geogait.robots.driver", "--robot", "elastica", "--seed", "4"]
    with ProcessRobot(driver + ["--period", "0.5", "--samples-per-cycle", "50"], timeout=120) as robot:
        read_robot_spec(robot)
        assert robot.n_joints == 4 and robot.cycle_period == 0.5 and not robot.front_back_symmetric
        assert robot.mirror_symmetric and elastica_snake().mirror_symmetric
        bridged = robot.next_cycle()
    direct = elastica_snake(seed=4, cycle_period=0.5, samples_per_cycle=50).next_cycle()
    np.testing.assert_allclose(bridged.pose, direct.pose, atol=1e-12)
    with pytest.raises(ValueError, match="--links applies to the swimmer"):
        with ProcessRobot(driver + ["--links", "5"], timeout=60) as robot:
            robot.next_cycle()


@pytest.mark.slow
def test_optimiser_resumes_a_snake_run_bit_identically(tmp_path):
    needs_elastica()
    path = tmp_path / "run.npz"

    def make(seed):
        return elastica_snake(seed=seed, samples_per_cycle=50)

    def stop(row):
        if row["cycle"] == 8:
            raise KeyboardInterrupt

    optimizer = InSituOptimizer(gate=Gate(min_cycles=1), objective=Objective(kind="forward", frame="body"))
    whole = optimizer.run(make(6), 11)
    with pytest.raises(KeyboardInterrupt):
        optimizer.run(make(6), 11, checkpoint=path, callback=stop)
    resumed = InSituOptimizer.resume(path, make(123))
    assert whole.n_steps >= 1
    np.testing.assert_array_equal(resumed.final_gait.params, whole.final_gait.params)
    assert resumed.log.equals(whole.log)


@pytest.mark.slow
def test_example_runs_quick(tmp_path):
    needs_elastica()
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "elastica_snake.py"
    spec = importlib.util.spec_from_file_location("elastica_snake_example", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    summary = example.main(["--quick", "--out", str(tmp_path)])
    row = summary["optimisation"]
    assert row["seed"]["forward_speed"] > 0.04  # m/s; measured 0.048
    assert row["final"]["forward_speed"] > row["seed"]["forward_speed"]  # measured +51 % in 16 cycles
    assert (tmp_path / "summary.json").is_file()
