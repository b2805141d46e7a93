"""MujocoRobot: the Robot contract, physics checked against independent facts, state, errors."""

import json
import re
import sys

import numpy as np
import pytest

from geogait import se2
from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.optimize import Climb, InSituOptimizer, ModelClassTest, Objective, Safety, for_robot
from geogait.robots import (
    MODELS_DIRECTORY,
    MujocoRobot,
    Robot,
    check_robot,
    gymnasium_swimmer,
    load_mujoco_model,
    mujoco_swimmer,
    purcell_swimmer_xml,
)

pytest.importorskip("mujoco")

STILL = Perturbation(eta=0)
ROBOTS = {"purcell3": lambda **kw: mujoco_swimmer(3, **kw), "purcell5": lambda **kw: mujoco_swimmer(5, **kw),
          "gymnasium": lambda **kw: gymnasium_swimmer(**kw)}


def net_motion(trajectory, start, stop):
    """Net SE(2) motion between samples ``start`` and ``stop``, in the frame of ``start``."""
    return se2.between(trajectory.pose[start], trajectory.pose[stop])


def realised_amplitude(trajectory):
    """Per joint, the amplitude of the first harmonic of the measured shapes."""
    coefficients = FourierGait.from_shapes(trajectory.phase, trajectory.shape, 1).coefficients
    return np.hypot(coefficients[:, 1], coefficients[:, 2])


# -- the contract ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_robot_protocol_and_trajectory_contract(name):
    robot = ROBOTS[name](seed=0)
    assert isinstance(robot, Robot)
    assert check_robot(ROBOTS[name](seed=0)).saves_state  # (it runs a cycle, then again from the restored state)
    d, n, period = robot.n_joints, robot.samples_per_cycle, robot.cycle_period
    first, second = robot.next_cycle(), robot.next_cycle()
    for k, cycle in enumerate((first, second)):
        assert cycle.time.shape == cycle.phase.shape == cycle.cycle.shape == (n,)
        assert cycle.shape.shape == cycle.shape_velocity.shape == cycle.commanded_shape.shape == (n, d)
        assert cycle.body_velocity.shape == cycle.pose.shape == (n, 3)
        np.testing.assert_allclose(cycle.time, (k + np.arange(n) / n) * period, rtol=0, atol=1e-12)
        assert np.all((cycle.phase >= 0) & (cycle.phase < 2 * np.pi)) and np.all(np.diff(cycle.phase) > 0)
        assert np.all(cycle.cycle == k)
        assert np.all(np.isfinite(cycle.body_velocity)) and np.all(np.isfinite(cycle.pose))
    assert robot.cycle == 2
    # The commanded shape is the nominal gait plus a perturbation of the stated size (0.15 rad std).
    delta = np.concatenate([c.commanded_shape - robot.gait.shape(c.phase) for c in (first, second)])
    assert 0.03 < delta.std() < 0.4


def test_default_joints_body_and_gait_come_from_the_model():
    robot = mujoco_swimmer(5)
    assert robot.joint_names == ("joint0", "joint1", "joint2", "joint3")
    assert robot.body_name == "link2"  # the middle link carries the planar base
    assert robot.gait == seed_gait(4)
    gym = gymnasium_swimmer()
    assert gym.joint_names == ("motor1_rot", "motor2_rot") and gym.body_name == "torso"
    assert gym.steps_per_sample == 2  # 2 s / 100 samples / 0.01 s
    # Tight joint ranges shrink the default seed amplitude to 80 % of the tightest range.
    tight = MujocoRobot(purcell_swimmer_xml(3, joint_range=0.5))
    assert tight.gait.joint_limit() == pytest.approx([0.4, 0.4])


def test_shipped_models_are_the_generator_output():
    for n in (3, 5):
        assert (MODELS_DIRECTORY / f"purcell{n}.xml").read_text() == purcell_swimmer_xml(n)
    assert load_mujoco_model("geogait:purcell5").nu == 4 + 3 * 5  # 4 motors, 3 passive drag actuators per link
    assert load_mujoco_model("gymnasium:swimmer").nu == 2
    model = load_mujoco_model(purcell_swimmer_xml(4))
    assert load_mujoco_model(model) is model
    four = mujoco_swimmer(4, seed=0)  # generated, not shipped
    assert four.n_joints == 3 and four.body_name == "link1" and four.next_cycle().shape.shape == (100, 3)


def test_public_names_are_documented():
    import inspect

    import geogait.robots

    missing = [name for name in geogait.robots.__all__
               if (inspect.isclass(getattr(geogait.robots, name)) or inspect.isfunction(getattr(geogait.robots, name)))
               and not inspect.getdoc(getattr(geogait.robots, name))]
    missing += [f"MujocoRobot.{name}" for name, member in vars(MujocoRobot).items()
                if not name.startswith("_") and callable(member) and not inspect.getdoc(member)]
    assert not missing


# -- physics against independent facts ------------------------------------------------------------
@pytest.mark.parametrize("name", ["purcell3", "gymnasium"])
def test_integrated_body_velocity_reproduces_the_poses(name):
    """ξ from mj_objectVelocity, integrated with SE(2) exponentials, converges (first order in the
    sample interval) to the poses read from xpos / xmat: two independent computations."""
    errors = []
    for samples in (50, 250) if name == "purcell3" else (40, 200):
        robot = ROBOTS[name](samples_per_cycle=samples, seed=1)
        run = robot.next_cycles(2)
        poses = se2.integrate_body_velocity(run.body_velocity, robot.cycle_period / samples, run.pose[0])[:-1]
        errors.append(np.abs(poses - run.pose).max(axis=0))
        scale = np.ptp(run.pose, axis=0)
    coarse, fine = errors
    assert np.all(fine < 0.025 * scale), (fine, scale)
    assert np.all(coarse / fine > 2.5), (coarse, fine)


def test_heading_rate_is_exact_with_one_physics_step_per_sample():
    """implicitfast advances the base hinge by h · (velocity after the step): the recorded ω of the
    next sample integrates to the recorded heading to rounding."""
    robot = mujoco_swimmer(3, samples_per_cycle=500, seed=2)
    assert robot.steps_per_sample == 1
    run = robot.next_cycle()
    heading = run.pose[0, 2] + np.cumsum(run.body_velocity[1:, 2]) * robot.timestep
    np.testing.assert_allclose(heading, run.pose[1:, 2], rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", ["purcell3", "gymnasium"])
def test_mirrored_gait_gives_mirrored_motion(name):
    """The swimmers are symmetric under y → −y: the gait −θ must give (x, −y, −heading) exactly."""
    gait = ROBOTS[name]().gait
    mirrored_gait = FourierGait(-gait.coefficients)
    run = ROBOTS[name](gait=gait, perturbation=STILL).next_cycles(2)
    mirrored = ROBOTS[name](gait=mirrored_gait, perturbation=STILL).next_cycles(2)
    flip = np.array([1.0, -1.0, -1.0])
    assert np.abs(run.pose[-1, :2]).max() > 0.05  # it does move
    np.testing.assert_allclose(mirrored.pose, run.pose * flip, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mirrored.body_velocity, run.body_velocity * flip, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mirrored.shape, -run.shape, rtol=0, atol=1e-12)


def _net_per_cycle(make, gait, period=1.0):
    """Net motion over the third cycle of ``gait`` without exploration (start transient passed)."""
    robot = make(gait=gait, perturbation=STILL, cycle_period=period)
    robot.next_cycles(2)
    run = robot.next_cycles(2)
    return net_motion(run, 0, robot.samples_per_cycle)


@pytest.mark.parametrize("n_links", [3, 5])
def test_low_reynolds_swimmer_moves_as_geogaits_rft_swimmer(n_links):
    """The shipped MuJoCo swimmer (RFT drag from passive site actuators, PD-driven joints, light
    links) moves per cycle as geogait's analytical PurcellSwimmer: two independent simulators."""
    from geogait.simulate import simulate
    from geogait.systems import PurcellSwimmer

    gait = seed_gait(n_links - 1)
    exact = simulate(PurcellSwimmer(n_links), gait, 1, perturbation=STILL, samples_per_cycle=2000)
    expected = se2.compose(exact.pose[-1], se2.exp(exact.body_velocity[-1] / 2000))
    got = _net_per_cycle(lambda **kw: mujoco_swimmer(n_links, **kw), gait)
    # measured: 0.12 % (3-link) and 0.10 % (5-link) of the displacement (tracking error, inertia)
    assert np.linalg.norm(got[:2] - expected[:2]) < 3e-3 * np.linalg.norm(expected[:2])
    assert abs(got[2]) < 1e-6


def test_unequal_links_move_as_the_analytic_swimmer_of_the_same_geometry():
    """``purcell_swimmer_xml(link_lengths=...)`` builds the chain of ``PurcellSwimmer(link_lengths=...)``:
    on an unequal 5-link chain (no front–back symmetry) MuJoCo's body velocity at every sample is
    −A(r) ṙ of the analytic connection at the realised shapes, and the net motion per cycle of a
    turning gait matches the analytic swimmer's within the PD tracking lag (0.007 rad RMS here)."""
    from geogait.simulate import simulate
    from geogait.systems import PurcellSwimmer

    lengths = (0.3, 0.15, 0.2, 0.25, 0.1)
    swimmer = PurcellSwimmer(5, link_lengths=lengths)
    coefficients = seed_gait(4).coefficients.copy()
    coefficients[0, 1] *= 0.6  # the seed gait itself does not turn on this chain; this one does
    coefficients[2, 0] = 0.2
    gait = FourierGait(coefficients)
    robot = MujocoRobot(purcell_swimmer_xml(5, link_lengths=lengths), gait=gait, perturbation=STILL)
    robot.next_cycles(2)
    cycle = robot.next_cycle()
    analytic = -np.einsum("nij,nj->ni", swimmer.connection(cycle.shape), cycle.shape_velocity)
    # measured: 0.08 % of the largest body velocity
    assert np.abs(analytic - cycle.body_velocity).max() < 3e-3 * np.abs(cycle.body_velocity).max()

    exact = simulate(swimmer, gait, 1, perturbation=STILL, samples_per_cycle=2000)
    expected = se2.compose(exact.pose[-1], se2.exp(exact.body_velocity[-1] / 2000))
    got = _net_per_cycle(lambda **kw: MujocoRobot(purcell_swimmer_xml(5, link_lengths=lengths), **kw), gait)
    assert abs(expected[2]) > 0.02  # the gait turns: the check covers the rotation too
    # measured: 0.65 % of the displacement, 3.5 % of the rotation (the realised gait lags the command)
    assert np.linalg.norm(got[:2] - expected[:2]) < 0.015 * np.linalg.norm(expected[:2])
    assert abs(got[2] - expected[2]) < 0.07 * abs(expected[2])
    with pytest.raises(GeogaitError, match="link_lengths"):
        purcell_swimmer_xml(5, link_lengths=(0.3, 0.2, -0.1, 0.2, 0.2))
    with pytest.raises(GeogaitError, match="link_lengths"):
        purcell_swimmer_xml(3, link_lengths=(0.3, 0.2))


@pytest.mark.parametrize("drag", ["rft", "fluid"])
def test_time_reversed_gait_undoes_the_motion_and_the_period_does_not_matter(drag):
    """Kinematic locomotors: the net motion per cycle depends on the path in shape space only, so
    (a) running the gait backwards (φ → −φ) gives the inverse motion and (b) a twice slower cycle
    gives the same motion per cycle (to the tracking error and the little inertia left). Both hold
    for the linear RFT drag and for MuJoCo's quadratic fluid drag."""
    def make(**options):
        return MujocoRobot(purcell_swimmer_xml(3, drag=drag), **options)

    gait = seed_gait(2)
    backwards = gait.coefficients.copy()
    backwards[:, 2] *= -1  # sin terms change sign: θ(−φ)
    forward = _net_per_cycle(make, gait)
    size = np.hypot(*forward[:2])
    assert size > (0.04 if drag == "rft" else 0.15) and abs(forward[2]) < 1e-4
    tolerance = 0.01 if drag == "rft" else 0.05  # measured 0.33 % (rft), 1.9 % (fluid)
    assert np.linalg.norm(_net_per_cycle(make, FourierGait(backwards))[:2] + forward[:2]) < tolerance * size
    assert np.linalg.norm(_net_per_cycle(make, gait, period=2.0)[:2] - forward[:2]) < tolerance * size


def test_a_free_floating_base_moves_as_the_planar_base():
    """Any base works: with a 6-DoF free joint instead of slide-slide-hinge the (planar) forces give
    the same planar motion, and the body stays in the plane."""
    planar = purcell_swimmer_xml(3)
    base = ('<joint name="x" type="slide" axis="1 0 0"/>\n      <joint name="y" type="slide" axis="0 1 0"/>\n'
            '      <joint name="heading" type="hinge" axis="0 0 1"/>')
    assert base in planar
    free = planar.replace(base, '<freejoint name="base"/>')
    runs = []
    for source in (planar, free):
        robot = MujocoRobot(source, seed=4)
        assert robot.body_name == "link1" and robot.joint_names == ("joint0", "joint1")
        runs.append(robot.next_cycles(2))
    np.testing.assert_allclose(runs[1].pose, runs[0].pose, rtol=0, atol=1e-9)
    np.testing.assert_allclose(runs[1].body_velocity, runs[0].body_velocity, rtol=0, atol=1e-8)
    assert abs(robot.data.qpos[2]) < 1e-12  # z of the free base


def test_no_shape_motion_leaves_the_body_at_rest():
    coefficients = np.zeros((2, 3))
    coefficients[:, 0] = (0.4, -0.3)  # a bent but constant shape
    robot = mujoco_swimmer(3, gait=FourierGait(coefficients), perturbation=STILL)
    run = robot.next_cycles(2)
    assert np.abs(run.body_velocity).max() < 1e-12
    assert np.abs(run.pose - run.pose[0]).max() < 1e-12
    np.testing.assert_allclose(run.shape, np.broadcast_to(coefficients[:, 0], run.shape.shape), atol=1e-12)


def test_pd_tracks_a_gentle_gait_and_saturates_on_an_aggressive_one():
    gentle = mujoco_swimmer(3, gait=seed_gait(2, 0.5), cycle_period=2.0, perturbation=STILL)
    gentle.next_cycle()
    run = gentle.next_cycle()
    error = np.sqrt(np.mean((run.shape - run.commanded_shape) ** 2))
    assert error < 0.01 * 0.5
    np.testing.assert_allclose(realised_amplitude(run), 0.5, rtol=0.02)

    tight = MujocoRobot(purcell_swimmer_xml(3, ctrl_limit=0.01), gait=seed_gait(2, 1.5), perturbation=STILL)
    tight.next_cycle()
    run = tight.next_cycle()
    assert np.all(realised_amplitude(run) < 0.5 * 1.5)  # well below the command (measured 0.55, 0.45)
    assert np.sqrt(np.mean((run.shape - run.commanded_shape) ** 2)) > 0.3
    assert np.all(np.abs(tight.data.ctrl[tight._actuators]) <= 0.01)


def test_position_actuators_track_the_command():
    model = purcell_swimmer_xml(3, actuator="position", position_gain=20.0, ctrl_limit=5.0)
    robot = MujocoRobot(model, control="position", gait=seed_gait(2, 0.5), cycle_period=2.0, perturbation=STILL)
    assert robot.kp is None
    robot.next_cycle()
    run = robot.next_cycle()
    np.testing.assert_allclose(realised_amplitude(run), 0.5, rtol=0.1)
    assert np.hypot(*net_motion(run, 0, -1)[:2]) > 0.01



def _free_base(xml):
    base = ('<joint name="x" type="slide" axis="1 0 0"/>\n      <joint name="y" type="slide" axis="0 1 0"/>\n'
            '      <joint name="heading" type="hinge" axis="0 0 1"/>')
    return xml.replace(base, '<freejoint name="base"/>')


@pytest.mark.parametrize("source", ["rft", "rft-free-base", "gymnasium"])
def test_computed_torque_gives_the_joints_the_acceleration_asked_for(source):
    """Floating-base inverse dynamics checked by MuJoCo's forward dynamics: in a state of a run (joints and base
    moving; RFT dampers as actuators, or Gymnasium's fluid as passive forces; planar or free base), the torque it
    computes makes MuJoCo's own joint acceleration the one asked for."""
    import mujoco

    from geogait.robots._mujoco import _computed_torque
    model = {"rft": purcell_swimmer_xml(3), "rft-free-base": _free_base(purcell_swimmer_xml(3)),
             "gymnasium": "gymnasium:swimmer"}[source]
    robot = MujocoRobot(model, control="computed_torque", seed=2, cycle_period=2.0)
    robot.next_cycle()
    data, dofs, actuators = robot.data, robot._dof, robot._actuators
    assert np.any(np.abs(data.qvel) > 0.05)
    robot.model.actuator_ctrllimited[:] = 0  # (the identity holds beyond the ctrl range, where MuJoCo would clamp)
    for acceleration in ([0.3, -0.2], [-4.0, 1.0]):
        data.ctrl[actuators] = _computed_torque(robot.model, data, dofs, actuators, np.array(acceleration))
        mujoco.mj_forward(robot.model, data)
        np.testing.assert_allclose(data.qacc[dofs], acceleration, rtol=1e-9, atol=1e-9)


def test_computed_torque_follows_the_gait_where_a_held_pd_torque_cannot():
    """At Gymnasium's action rate (one torque per 4 physics steps) a PD law stable at that rate follows the seed
    gait to about 0.2 rad; with the model's dynamics fed forward the joints follow it to millimetres."""
    errors = {}
    for control in ("pd", "computed_torque"):
        robot = gymnasium_swimmer(control=control, perturbation=STILL)
        assert robot.control_interval == 4
        robot.next_cycle()
        run = robot.next_cycles(2)
        errors[control] = np.sqrt(np.mean((run.shape - run.commanded_shape) ** 2))
    assert errors["pd"] > 0.1 and errors["computed_torque"] < 0.01
    robot = gymnasium_swimmer(control="computed_torque", seed=0)
    np.testing.assert_allclose(robot.kp, (0.5 / 0.04) ** 2)
    np.testing.assert_allclose(robot.kd, 2 * 0.5 / 0.04)
    # the exploration's acceleration is fed forward too (its feedback alone: 0.05 rad); it needs more torque than
    # the swimmer's motors give (0.2 rad within their range), so the range is lifted here
    robot.model.actuator_ctrllimited[:] = 0
    explored = robot.next_cycles(3)
    assert np.sqrt(np.mean((explored.shape - explored.commanded_shape)[100:] ** 2)) < 0.03

# -- state ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["purcell3", "gymnasium"])
def test_restored_robot_continues_bit_identically(name):
    robot = ROBOTS[name](seed=3)
    robot.next_cycle()
    robot.set_gait(seed_gait(2, 0.7))
    state = robot.robot_state()
    json.dumps({k: v for k, v in state.items() if not isinstance(v, np.ndarray)})  # JSON values besides arrays
    expected = robot.next_cycles(2)
    other = ROBOTS[name](seed=99)
    other.restore_robot_state(state)
    assert other.gait == seed_gait(2, 0.7) and other.cycle == 1
    got = other.next_cycles(2)
    for field in ("time", "phase", "cycle", "shape", "shape_velocity", "body_velocity", "pose", "commanded_shape"):
        np.testing.assert_array_equal(getattr(got, field), getattr(expected, field), err_msg=field)
    # The same seed gives the same run; another seed another perturbation.
    first = ROBOTS[name](seed=3).next_cycle()
    np.testing.assert_array_equal(first.shape, ROBOTS[name](seed=3).next_cycle().shape)
    assert not np.array_equal(first.commanded_shape, ROBOTS[name](seed=4).next_cycle().commanded_shape)


def test_close_ends_the_robot():
    robot = mujoco_swimmer(3)
    robot.close()
    with pytest.raises(ValueError, match="closed"):
        robot.next_cycle()


# -- a local model learns it -----------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_adaptive_model_reaches_a_positive_held_out_gamma(name):
    robot = ROBOTS[name](seed=0)
    train = robot.next_cycles(20)
    test = ROBOTS[name](seed=1).next_cycles(10)
    model = AdaptiveGaitModel(gait=robot.gait, phase_rate=2 * np.pi / robot.cycle_period)
    model.fit(train.phase, train.shape, train.shape_velocity, train.body_velocity)
    gamma = model.score(test.phase, test.shape, test.shape_velocity, test.body_velocity)
    assert gamma > 0.8  # measured: 0.978 (purcell3), 0.977 (purcell5), 0.905 (gymnasium)


# -- errors --------------------------------------------------------------------------------------
def test_bad_arguments_give_clear_errors():
    model = purcell_swimmer_xml(3)
    with pytest.raises(ValueError, match=r"'joints' parameter of MujocoRobot must be names of joints of the model "
                                         r"\(x, y, heading, joint0, joint1\)\. Got 'elbow'"):
        MujocoRobot(model, joints=["joint0", "elbow"])
    with pytest.raises(ValueError, match="'joints' parameter of MujocoRobot must be a sequence of joint names"):
        MujocoRobot(model, joints="joint0")
    with pytest.raises(ValueError, match="'joints' parameter of MujocoRobot must be names of hinge joints. Got "
                                         "\"'x', a slide joint\""):
        MujocoRobot(model, joints=["x"])
    with pytest.raises(ValueError, match="exactly one motor actuator.*Joint 'heading' has 0"):
        MujocoRobot(model, joints=["heading", "joint0"])
    with pytest.raises(ValueError, match="exactly one position actuator.*Joint 'joint0' has 0; its actuators: "
                                         r"motor0 \(motor\)"):
        MujocoRobot(model, control="position")
    with pytest.raises(ValueError, match=r"'body' parameter of MujocoRobot must be the name of a body of the model "
                                         r"\(link1, link0, link2\)"):
        MujocoRobot(model, body="head")
    with pytest.raises(ValueError, match=r"'cycle_period' parameter of MujocoRobot must be a positive multiple of "
                                         r"samples_per_cycle × the model's timestep \(100 × 0.002 s = 0.2 s\)"):
        MujocoRobot(model, cycle_period=0.5)
    with pytest.raises(ValueError, match="'control' parameter of MujocoRobot must be one of 'pd', 'position', "
                                         "'computed_torque'"):
        MujocoRobot(model, control="torque")
    with pytest.raises(ValueError, match="exactly one motor actuator.*control='computed_torque'"):
        MujocoRobot(purcell_swimmer_xml(3, actuator="position"), control="computed_torque")
    with pytest.raises(ValueError, match="'kd' parameter of MujocoRobot must be a float or an array of shape"):
        MujocoRobot(model, control="computed_torque", kd=[1.0, np.nan])
    with pytest.raises(ValueError, match=r"'gait' parameter of MujocoRobot must be a FourierGait with 2 joints"):
        MujocoRobot(model, gait=seed_gait(3))
    with pytest.raises(ValueError, match="'kp' parameter of MujocoRobot must be a float or an array of shape"):
        MujocoRobot(model, kp=-1.0)
    with pytest.raises(ValueError, match="'kd' parameter of MujocoRobot must be None with control='position'"):
        MujocoRobot(purcell_swimmer_xml(3, actuator="position"), control="position", kd=1.0)
    with pytest.raises(ValueError, match="'start' parameter of MujocoRobot must be one of 'gait', 'rest'"):
        MujocoRobot(model, start="bent")
    with pytest.raises(ValueError, match="'control_interval' parameter of MujocoRobot must be an int >= 1"):
        MujocoRobot(model, control_interval=0)
    with pytest.raises(ValueError, match="'samples_per_cycle' parameter of MujocoRobot must be an int >= 4"):
        MujocoRobot(model, samples_per_cycle=2)
    with pytest.raises(ValueError, match="'perturbation' parameter of MujocoRobot must be a geogait.gaits"):
        MujocoRobot(model, perturbation=0.1)
    with pytest.raises(ValueError, match="'source' parameter of load_mujoco_model must be one of geogait:purcell3, "
                                         "geogait:purcell5"):
        load_mujoco_model("geogait:purcell7")
    with pytest.raises(ValueError, match="'source' parameter of load_mujoco_model must be one of gymnasium:"):
        load_mujoco_model("gymnasium:no_such_env")
    with pytest.raises(ValueError, match="'source' parameter of load_mujoco_model must be an existing MJCF file"):
        load_mujoco_model("no/such/file.xml")
    robot = MujocoRobot(model)
    with pytest.raises(ValueError, match="'gait' parameter of MujocoRobot.set_gait must be a FourierGait with 2"):
        robot.set_gait(seed_gait(4))
    with pytest.raises(ValueError, match="'state' parameter of MujocoRobot.restore_robot_state"):
        robot.restore_robot_state({"physics": np.zeros(3)})
    state = mujoco_swimmer(5).robot_state()
    with pytest.raises(ValueError, match="'state' parameter of MujocoRobot.restore_robot_state must be a physics "
                                         "state of"):
        robot.restore_robot_state(state)


def test_a_body_that_leaves_the_plane_is_rejected():
    tilted = purcell_swimmer_xml(3).replace('<body name="link1">', '<body name="link1" euler="1.5707963 0 0">')
    with pytest.raises(ValueError, match="'body' parameter of MujocoRobot must be a body whose z-axis is the world "
                                         "z-axis"):
        MujocoRobot(tilted)


def test_missing_mujoco_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # `import mujoco` now raises ImportError
    with pytest.raises(ImportError, match=r"pip install 'geogait\[mujoco\]'"):
        mujoco_swimmer(3)


# -- the in-situ optimiser on MuJoCo -------------------------------------------------------------
def _saturating_swimmer(**options):
    """The 3-link swimmer with a 0.05 N·m torque limit: the seed (1 rad at 1 s) is just followed
    (0.045 rad RMS error without exploration); larger amplitudes saturate the motors (0.135 rad at
    1.2 rad, 0.2 at 1.3)."""
    return MujocoRobot(purcell_swimmer_xml(3, ctrl_limit=0.05), seed=0, **options)


def test_optimiser_rejects_steps_the_saturated_actuators_cannot_follow():

    def clean(gait):
        """Progress per cycle and tracking error of ``gait`` on the saturating robot, no exploration."""
        robot = _saturating_swimmer(gait=gait, perturbation=STILL)
        robot.next_cycle()
        run = robot.next_cycles(2)
        error = np.sqrt(np.mean((run.shape - run.commanded_shape) ** 2))
        return np.hypot(*net_motion(run, 0, robot.samples_per_cycle)[:2]), error

    # the window model (the default on a chain that declares no resistive medium): small steps near the limit
    options = dict(objective=Objective(kind="forward", frame="body"), model=AdaptiveGaitModel(forgetting_factor=0.95),
                   climb=Climb(start="stalled"))
    checked = InSituOptimizer(safety=Safety(max_tracking_error=0.1), **options).run(_saturating_swimmer(), 30)
    log = checked.log
    assert checked.n_rejected >= 3  # measured 9
    assert np.all(log.loc[log["rejected"], "tracking_error"] > 0.1)
    net = log[["measured_x", "measured_y"]].to_numpy()
    assert np.all(net @ net[0] > 0)  # never moved backwards
    seed_progress, seed_error = clean(checked.initial_gait)
    progress, error = clean(checked.final_gait)
    assert error <= 0.1 and progress >= 0.95 * seed_progress  # the motors follow what it settled on
    assert (log["prediction_ok"].dropna() == 1).all()  # the model's predictions held (within 50 %)
    # Without the check the commanded gait runs away from what the motors can do; the model, which
    # learns realised shapes, then over-predicts the commanded gait (measured: by 60 %) and only the
    # prediction check keeps closing the gate.
    # (the measured-outcome revert and climb, which also pull such a run back, are off to show the runaway)
    unchecked = InSituOptimizer(**{**options, "climb": False},
                                safety=Safety(max_tracking_error=None,
                                              revert_tolerance=None)).run(_saturating_swimmer(), 30)
    assert unchecked.n_rejected == 0
    assert unchecked.final_gait.joint_limit().max() > 1.5  # far beyond the seed's 1 rad
    assert unchecked.log["tracking_error"].iloc[-10:].mean() > 3 * 0.1
    assert (unchecked.log["prediction_ok"] == 0).sum() >= 5  # measured 13


def test_the_structured_default_shortens_its_steps_after_gaits_the_actuators_cannot_follow():
    """The resistance model (the default on this RFT chain) steps with a trust radius of at least 0.25; a gait the
    saturated motors cannot follow halves it even below that floor (a rejection is measured, not a noisy ratio)."""

    robot = _saturating_swimmer()
    result = for_robot(robot, safety=Safety(max_tracking_error=0.1),
                       objective=Objective(kind="forward", frame="body")).run(robot, 12)
    log = result.log
    assert type(result.model).__name__ == "ResistanceModel" and log["trust_radius"].iloc[0] == 0.25
    assert log["rejected"].sum() >= 2 and np.all(log.loc[log["rejected"], "tracking_error"] > 0.1)
    assert log["trust_radius"].iloc[-1] <= 0.0625  # 0.25 halved at each of the rejections (measured: 4 by cycle 12)


def test_optimiser_resumes_a_mujoco_run_bit_identically(tmp_path):

    path = tmp_path / "run.npz"

    def stop(row):
        if row["cycle"] == 5:
            raise KeyboardInterrupt

    whole = InSituOptimizer().run(mujoco_swimmer(3, seed=6), 10)
    with pytest.raises(KeyboardInterrupt):
        InSituOptimizer().run(mujoco_swimmer(3, seed=6), 10, checkpoint=path, callback=stop)
    resumed = InSituOptimizer.resume(path, mujoco_swimmer(3, seed=123))
    assert whole.n_steps >= 2
    np.testing.assert_array_equal(resumed.final_gait.params, whole.final_gait.params)
    assert resumed.log.equals(whole.log)


def test_example_runs_quick(tmp_path, capsys):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "mujoco_swimmer.py"
    spec = importlib.util.spec_from_file_location("mujoco_swimmer_example", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    summary = example.main(["--quick", "--out", str(tmp_path)])
    row = summary["purcell3"]
    assert row["held_out_gamma"] > 0.9 and row["never_reversed"]
    assert row["improvement"] > 0.3  # measured +88 % in 15 cycles
    assert row["physics_steps"] == 17 * 500  # 2 warm-up + 15 cycles of 500 steps
    assert json.loads((tmp_path / "summary.json").read_text())["purcell3"]["gait_steps"] == row["gait_steps"]
    assert "purcell3   Γ 0.9" in capsys.readouterr().out


def test_docs_mujoco_section_runs():
    import re
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "docs" / "robots.md").read_text()
    block = re.search(r"## A MuJoCo robot.*?```python\n(.*?)```", readme, re.S).group(1)
    assert ".run(robot, 100)" in block
    namespace = {}
    exec(compile(block.replace(".run(robot, 100)", ".run(robot, 3)"), "README MuJoCo section", "exec"), namespace)
    assert len(namespace["result"].log) == 3 and namespace["robot"].cycle == 5


def test_path_following_on_a_mujoco_swimmer():
    """PathTracker on a physics engine geogait did not write: the MuJoCo 3-link swimmer follows a circle
    of 10 steps' radius with the shape-space model (no symmetry assumed), on the path within a tenth of
    the radius and advancing along it at its step."""
    from geogait.control import PathTracker, ReferencePath
    from geogait.experiments.tracking import tracking_model

    robot = mujoco_swimmer(3, seed=0, perturbation=Perturbation.from_std(0.05))
    robot.next_cycles(2)
    step, cycles = 0.0514, 12  # the seed gait's step in MuJoCo (examples/mujoco_tracking.py)
    tracker = PathTracker(model=tracking_model("shape", symmetric=False), change_forgetting=100.0, warmup_cycles=10)
    log = tracker.run(robot, ReferencePath.circle(10 * step), cycles).log
    assert len(log) == cycles and log["solved"].all() and not log["alarm"].any()
    assert np.abs(log["cross_track"]).max() < step  # 0.1 × radius
    assert log["s"].iloc[-1] > 0.8 * cycles * step
    assert log["true_x"].isna().all()  # no oracle behind MuJoCo


def test_set_cycle_period_runs_whole_samples_with_continuous_time():
    def make(seed):
        return MujocoRobot(purcell_swimmer_xml(3), seed=seed)

    robot = make(0)
    robot.next_cycle()
    unit = robot.steps_per_sample * robot.timestep
    robot.set_cycle_period(1.537)
    assert robot.samples_per_cycle == round(1.537 / unit)
    assert robot.cycle_period == pytest.approx(robot.samples_per_cycle * unit)
    cycle = robot.next_cycle()
    assert cycle.time.size == robot.samples_per_cycle and cycle.time[0] == pytest.approx(1.0)
    assert cycle.time[-1] == pytest.approx(1.0 + robot.cycle_period * (1 - 1 / robot.samples_per_cycle))
    other = make(7)
    other.restore_robot_state(robot.robot_state())
    assert other.cycle_period == robot.cycle_period
    np.testing.assert_array_equal(other.next_cycle().pose, robot.next_cycle().pose)
    with pytest.raises(GeogaitError, match="'cycle_period'"):
        robot.set_cycle_period(unit)


def test_front_back_symmetry_is_read_from_the_model():
    assert MujocoRobot(purcell_swimmer_xml(3)).front_back_symmetric
    assert MujocoRobot(purcell_swimmer_xml(5, link_lengths=(0.3, 0.15, 0.2, 0.15, 0.3))).front_back_symmetric
    assert not MujocoRobot(purcell_swimmer_xml(5, link_lengths=(0.3, 0.15, 0.2, 0.25, 0.1))).front_back_symmetric
    tail = '<site name="centre0"'
    heavy_tail = purcell_swimmer_xml(3).replace(f'density="1"/>{tail}', f'density="3"/>{tail}')
    assert heavy_tail != purcell_swimmer_xml(3)  # the tail link 3x heavier
    assert not MujocoRobot(heavy_tail).front_back_symmetric
    shuffled = MujocoRobot(purcell_swimmer_xml(5), joints=["joint0", "joint2", "joint1", "joint3"])
    assert not shuffled.front_back_symmetric  # shape coordinates out of order along the chain
    assert not MujocoRobot(purcell_swimmer_xml(4, drag="fluid")).front_back_symmetric  # quadratic drag: irreversible


def test_time_reversal_family_turns_a_swimmer_with_inertia_and_the_half_wave_family_does_not():
    """Gymnasium's swimmer (three equal capsules, quadratic drag, inertia) reads the same from both ends, but its
    motion does not reverse with time: gaits of the front–back symmetric family turn it, half-wave symmetric
    gaits do not (MuJoCo's own dynamics, heading at cycle starts after settling)."""
    pytest.importorskip("gymnasium")
    from geogait.gaits import MirrorGaitFamily, Perturbation, SymmetricGaitFamily

    robot = gymnasium_swimmer()
    assert not robot.front_back_symmetric and robot.mirror_symmetric
    symmetric, mirror = SymmetricGaitFamily.from_gait(robot.gait), MirrorGaitFamily(2)
    rng = np.random.default_rng(1)
    turns = {"symmetric": [], "mirror": []}
    for _ in range(2):
        for name, family in (("symmetric", symmetric), ("mirror", mirror)):
            gait = family.gait(family.params_of(robot.gait) + rng.normal(scale=0.3, size=family.n_params))
            swimmer = gymnasium_swimmer(gait=gait, perturbation=Perturbation(eta=0))
            swimmer.next_cycles(3)
            start = swimmer.next_cycle().pose[0, 2]
            swimmer.next_cycle()
            turns[name].append(abs(swimmer.next_cycle().pose[0, 2] - start) / 2)
    assert max(turns["mirror"]) < 1e-3 and min(turns["symmetric"]) > max(0.003, 100 * max(turns["mirror"]))


def test_optimiser_searches_the_symmetric_family_on_a_symmetric_model():
    from geogait.gaits import MirrorGaitFamily, SymmetricGaitFamily

    result = InSituOptimizer(objective=Objective(kind="forward", frame="body")).run(
        MujocoRobot(purcell_swimmer_xml(3), seed=2), 10)
    family = SymmetricGaitFamily.from_gait(result.initial_gait, 1)
    assert result.n_steps >= 1 and max(family.residual(gait) for gait in result.gaits) < 1e-9
    unequal = MujocoRobot(purcell_swimmer_xml(5, link_lengths=(0.3, 0.15, 0.2, 0.25, 0.1)), seed=2)
    mirror = InSituOptimizer(objective=Objective(kind="forward", frame="body")).run(unequal, 10)
    assert mirror.n_steps >= 1 and max(MirrorGaitFamily(4).residual(gait) for gait in mirror.gaits) == 0.0


def test_mirror_symmetry_is_read_from_the_model():
    unequal = purcell_swimmer_xml(5, link_lengths=(0.3, 0.15, 0.2, 0.25, 0.1))
    assert MujocoRobot(unequal).mirror_symmetric and not MujocoRobot(unequal).front_back_symmetric
    assert MujocoRobot(purcell_swimmer_xml(3, drag="fluid")).mirror_symmetric
    tail = '<site name="centre0" pos="-0.166666666667 0 0"/>'
    xml = purcell_swimmer_xml(3)
    assert tail in xml
    off_axis = xml.replace(tail, tail + '<geom type="sphere" pos="-0.1 0.04 0" size="0.02"/>')
    assert not MujocoRobot(off_axis).mirror_symmetric  # a lump on one side of the tail
    # a massless lump that touches nothing and has no fluid model of its own exerts no force: a visual geom
    visual = xml.replace(tail, tail + '<geom type="sphere" pos="-0.1 0.04 0" size="0.02" mass="0"/>')
    assert MujocoRobot(visual).mirror_symmetric
    touching = visual.replace('mass="0"/>', 'mass="0" contype="1" conaffinity="1"/>')
    assert not MujocoRobot(touching).mirror_symmetric
    in_the_fluid = visual.replace('mass="0"/>', 'mass="0" fluidshape="ellipsoid"/>')
    assert not MujocoRobot(in_the_fluid).mirror_symmetric
    # an explicit contact pair touches whatever contype and conaffinity say
    paired = visual.replace('mass="0"/>', 'mass="0" name="lump"/>').replace(
        "</worldbody>", '<geom name="floor" type="plane" pos="0 0 -1" size="5 5 0.1"/></worldbody>')
    assert MujocoRobot(paired).mirror_symmetric  # a floor below is allowed
    paired = paired.replace("</worldbody>", '</worldbody><contact><pair geom1="lump" geom2="floor"/></contact>')
    assert not MujocoRobot(paired).mirror_symmetric
    # a heavy body welded to the tail, off its axis: its geom touches nothing, but its mass moves with the tail
    welded = xml.replace(tail, tail + '<body pos="-0.1 0.04 0"><geom type="sphere" size="0.02" density="5000"/></body>')
    assert not MujocoRobot(welded).mirror_symmetric
    lopsided_range = xml.replace('range="-2.09439510239 2.09439510239"', 'range="-2.09439510239 1.5"', 1)
    assert not MujocoRobot(lopsided_range).mirror_symmetric
    joint_end = 'limited="true" armature="0.0001"/>'
    bent_rest = xml.replace(joint_end, joint_end[:-2] + ' springref="0.2"/>', 1)
    assert not MujocoRobot(bent_rest).mirror_symmetric  # straight is not the rest shape
    sideways_gravity = xml.replace('<flag gravity="disable"/>', '').replace('integrator="implicitfast">',
                                                                        'integrator="implicitfast" gravity="0 1 0">')
    assert not MujocoRobot(sideways_gravity).mirror_symmetric
    pytest.importorskip("gymnasium")
    assert gymnasium_swimmer().mirror_symmetric  # capsules on one line, a floor below


def test_half_wave_gaits_do_not_turn_an_unequal_chain_in_its_own_dynamics():
    """MuJoCo's dynamics (PD joints, RFT dampers), not geogait's closed form: a half-wave symmetric gait
    leaves no net rotation per cycle once settled; the same loop with a constant bend turns."""
    from geogait.gaits import FourierGait, MirrorGaitFamily, Perturbation

    xml = purcell_swimmer_xml(5, link_lengths=(0.3, 0.15, 0.2, 0.25, 0.1))
    rng = np.random.default_rng(3)
    gait = MirrorGaitFamily(4).gait(rng.normal(scale=0.4, size=8))
    bent = FourierGait(gait.coefficients + np.array([[0.3], [-0.2], [0.1], [0.2]]) * np.eye(3)[0])
    turns = {}
    for name, run in (("mirror", gait), ("bent", bent)):
        robot = MujocoRobot(xml, gait=run, perturbation=Perturbation(eta=0), seed=0)
        robot.next_cycles(2)  # settle
        start = robot.next_cycle().pose[0, 2]
        robot.next_cycle()
        turns[name] = abs(robot.next_cycle().pose[0, 2] - start) / 2  # heading at cycle starts, two cycles apart
    assert turns["mirror"] < 1e-4 and turns["bent"] > 0.01


@pytest.mark.parametrize("lengths", [(0.3, 0.15, 0.2, 0.25, 0.1), (0.25, 0.25, 0.25, 0.25)])
def test_chain_geometry_is_read_from_the_bodies_and_predicts_the_physics(lengths):
    """The geometry read back is the one the model was written with, and the RFT chain built from it
    (geogait's closed form) predicts what MuJoCo's own dynamics measure, to under 2 % of ξ's spread."""
    from geogait.systems import PurcellSwimmer

    robot = MujocoRobot(purcell_swimmer_xml(len(lengths), link_lengths=lengths), seed=0)
    geometry = robot.chain_geometry()
    np.testing.assert_allclose(geometry["link_lengths"], lengths, atol=1e-12)
    assert geometry["body_frame"] == (len(lengths) - 1) // 2  # the generator's root link
    np.testing.assert_allclose(geometry["frame_offset"], 0.0, atol=1e-12)
    cycles = robot.next_cycles(3)
    chain = PurcellSwimmer(len(lengths), **geometry)
    predicted = -np.einsum("nkj,nj->nk", chain.connection(cycles.shape), cycles.shape_velocity)
    spread = np.linalg.norm(cycles.body_velocity - cycles.body_velocity.mean(axis=0), axis=-1).sum()
    assert np.linalg.norm(predicted - cycles.body_velocity, axis=-1).sum() < 0.02 * spread


def test_chain_geometry_of_a_frame_off_its_link_and_of_a_non_chain():
    pytest.importorskip("gymnasium")
    geometry = gymnasium_swimmer().chain_geometry()  # torso frame 0.5 m beyond its capsule, facing the head
    np.testing.assert_allclose(geometry["link_lengths"], (1.0, 1.0, 1.0), atol=1e-12)
    assert geometry["body_frame"] == 0
    np.testing.assert_allclose(np.abs(geometry["frame_offset"]), (1.0, 0.0, np.pi), atol=1e-12)
    shuffled = MujocoRobot(purcell_swimmer_xml(5), joints=["joint0", "joint2", "joint1", "joint3"])
    with pytest.raises(GeogaitError, match="chain_geometry: the shape joints do not form one planar serial chain"):
        shuffled.chain_geometry()


def test_a_resistive_medium_is_read_from_the_model_and_for_robot_chooses_the_structured_preset():
    """Linear drag on every link (purcell_swimmer_xml's RFT actuators) is a resistive medium; quadratic fluid drag,
    a link without its dampers, or Gymnasium's swimmer is not. ``for_robot`` follows: ResistanceModel on the
    chain's geometry, with the structured steps, only where the medium is resistive; the optimiser itself never
    changes a model or setting it was given."""

    assert mujoco_swimmer(3).resistive_medium and mujoco_swimmer(5).resistive_medium
    assert not MujocoRobot(purcell_swimmer_xml(3, drag="fluid")).resistive_medium
    undamped = re.sub(r'\s*<general name="drag2_y"[^>]*/>', "", purcell_swimmer_xml(3))  # one link free sideways
    assert "drag2_x" in undamped and "drag2_y" not in undamped and not MujocoRobot(undamped).resistive_medium
    explicit = for_robot(mujoco_swimmer(3), model=AdaptiveGaitModel(forgetting_factor=0.95))
    assert type(explicit.run(mujoco_swimmer(3, seed=1), 3).model).__name__ == "AdaptiveGaitModel"  # a model given
    chosen = for_robot(mujoco_swimmer(3))
    assert type(chosen.model).__name__ == "ResistanceModel"
    assert chosen.model.link_lengths == tuple(mujoco_swimmer(3).chain_geometry()["link_lengths"])
    assert (chosen.step.rule, chosen.climb.start, chosen.climb.rule) == ("sqp", "contradicted", "es")
    assert chosen.run(mujoco_swimmer(3, seed=1), 3).log["trust_radius"].iloc[0] == 0.25
    kept = for_robot(mujoco_swimmer(3), step__trust_radius=0.3)
    assert kept.run(mujoco_swimmer(3, seed=1), 3).log["trust_radius"].iloc[0] == 0.3  # a setting given is the user's
    assert type(InSituOptimizer().run(mujoco_swimmer(3, seed=1), 3).model).__name__ != "ResistanceModel"
    pytest.importorskip("gymnasium")
    assert not gymnasium_swimmer().resistive_medium
    assert for_robot(gymnasium_swimmer()).model is None


@pytest.mark.parametrize("case", ["mujoco-purcell5-unequal", "gymnasium-swimmer"])
def test_the_optimisers_model_class_test_passes_both_swimmers(case):
    """The robot benchmark's unequal RFT chain is principally kinematic: it passes and is stepped as usual.
    Gymnasium's swimmer (quadratic drag, inertia) moved within 2 % per cycle at 2 s and 4 s with a PD torque
    updated every physics step (docs/results/model-class.md); at Swimmer-v5's own action rate (25 Hz) the default
    gains follow the 2 s cycles less closely than the 4 s ones, so the test says it cannot judge, and why, and the
    run steps as usual. Both start from rest: the benchmark's settling cycle keeps the start's transient out."""
    from geogait.experiments.robot_benchmark import CASES, case_optimizer

    case = CASES[case]
    robot = case.make_robot(0, explore=True, noise=True)
    period = robot.cycle_period
    result = case_optimizer(case, checks=[ModelClassTest(cycles=3)]).run(robot, 14)
    verdict = result.model_class
    if case.name == "gymnasium-swimmer":
        assert verdict.principally_kinematic is None and "realised gait differs between the periods" in verdict.reason
    else:
        assert verdict.principally_kinematic is True, verdict.reason
        assert verdict.periods == pytest.approx((period, 2 * period), rel=0.02)
    assert result.n_steps > 0


def test_the_control_suites_swimmer_reads_the_same_in_a_mirror_and_moves_so():
    """dm_control's 6-link swimmer: its target (a sphere off the body's axis, contacts off) is left out of the symmetry
    test, and its dynamics agree: the gait −θ gives the mirrored motion (its links lie along y: x → −x, heading →
    −heading), so half-wave symmetric gaits do not turn it once settled."""
    pytest.importorskip("dm_control", reason="the Control Suite's swimmer needs dm_control (pip install "
                                             "'geogait[dmcontrol]')")
    from geogait.robots import dm_control_swimmer

    robot = dm_control_swimmer(6, perturbation=STILL)
    assert robot.mirror_symmetric and not robot.front_back_symmetric and not robot.resistive_medium
    assert robot.body_name == "head" and robot.n_joints == 5 and robot.cycle_period == 4.0
    np.testing.assert_allclose(robot.joint_ranges, [[-np.pi / 3, np.pi / 3]] * 5)
    gait = robot.gait
    run = robot.next_cycles(3)
    mirrored = dm_control_swimmer(6, gait=FourierGait(-gait.coefficients), perturbation=STILL).next_cycles(3)
    assert np.abs(run.pose[-1, :2]).max() > 0.1  # it does move
    np.testing.assert_allclose(mirrored.pose, run.pose * np.array([-1.0, 1.0, -1.0]), rtol=0, atol=1e-9)
    settled = net_motion(run, robot.samples_per_cycle, 2 * robot.samples_per_cycle)  # the second cycle, whole
    assert abs(settled[2]) < 0.005 < np.hypot(*settled[:2])


def test_a_robot_started_at_rest_begins_straight_and_still_and_then_follows_the_gait():
    gait = seed_gait(2)
    on_gait = mujoco_swimmer(3, gait=gait, perturbation=Perturbation(eta=0)).next_cycle()
    at_rest = mujoco_swimmer(3, gait=gait, perturbation=Perturbation(eta=0), start="rest")
    first = at_rest.next_cycle()
    np.testing.assert_allclose(on_gait.shape[0], gait.shape(0.0), atol=1e-12)
    np.testing.assert_array_equal(first.shape[0], 0.0)
    np.testing.assert_array_equal(first.shape_velocity[0], 0.0)
    np.testing.assert_array_equal(first.body_velocity[0], 0.0)
    later = [at_rest.next_cycle() for _ in range(3)][-1]
    assert np.sqrt(np.mean((later.shape - later.commanded_shape) ** 2)) < 0.1


def test_a_held_pd_torque_is_what_the_gymnasium_environment_runs():
    """Swimmer-v5 driven by the same PD policy at its own action rate (one action per 4 physics steps) from a
    reset without noise: the environment's summed forward reward is the benchmark's episode return."""
    gym = pytest.importorskip("gymnasium")
    pytest.importorskip("imageio", reason="gymnasium's MuJoCo environments need gymnasium[mujoco]")
    from geogait.experiments.robot_benchmark import swimmer_v5_return
    robot = gymnasium_swimmer()
    gait, period = FourierGait.from_params([0.1, 1.2, 0.6, -0.1, -0.5, 1.1], 2), 1.6
    env = gym.make("Swimmer-v5", reset_noise_scale=0.0)
    observation, _ = env.reset(seed=0)
    forward = 0.0
    for step in range(1000):
        phase = 2 * np.pi * step * 0.04 / period
        error = gait.shape(phase) - observation[1:3]
        error_rate = gait.velocity(phase) * 2 * np.pi / period - observation[6:8]
        observation, _, _, _, info = env.step(np.clip(robot.kp * error + robot.kd * error_rate, -1, 1))
        forward += info["reward_forward"]
    env.close()
    ours = swimmer_v5_return(gait, period)
    assert ours == pytest.approx(forward, rel=0.01)
    assert robot.control_interval == 4


def test_default_pd_gains_count_the_coupling_between_joints(tmp_path, monkeypatch):
    """The Control Suite's swimmer with its torque limits lifted, so that the stability cap alone sets the default
    gains: its light links are strongly coupled through the free head (ν_max 2.5), and the per-joint cap alone
    (ωT = 0.4 on each joint's effective inertia; gains 1.54 × these) lets a held PD blow up from rest. The
    default stays stable and tracks the gait; Gymnasium's swimmer (ν_max 1.64) keeps its per-joint gains."""
    pytest.importorskip("dm_control", reason="the Control Suite's swimmer needs dm_control (pip install "
                                             "'geogait[dmcontrol]')")
    from geogait.robots import dm_control_swimmer

    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT in the working directory
    suite = dm_control_swimmer(6)
    model = suite.model
    model.actuator_ctrllimited[:] = 0
    options = dict(joints=[model.joint(j).name for j in suite._joint_ids], gait=suite.gait,
                   cycle_period=suite.cycle_period, perturbation=Perturbation(eta=0), start="rest")
    robot = MujocoRobot(model, **options)
    cycles = [robot.next_cycle() for _ in range(2)]
    assert np.sqrt(np.mean((cycles[-1].shape - cycles[-1].commanded_shape) ** 2)) < 0.005
    per_joint = (0.4 * 2.48 / 0.7) ** 2
    reckless = MujocoRobot(model, kp=robot.kp * per_joint, kd=robot.kd * np.sqrt(per_joint), **options)
    with pytest.raises(GeogaitError, match="became unstable"):
        reckless.next_cycle()
    pytest.importorskip("gymnasium")
    import mujoco

    swimmer = gymnasium_swimmer()
    data = mujoco.MjData(swimmer.model)
    mujoco.mj_forward(swimmer.model, data)
    mass = np.zeros((swimmer.model.nv, swimmer.model.nv))
    mujoco.mj_fullM(swimmer.model, data, mass) if not hasattr(data, "qM") else mujoco.mj_fullM(swimmer.model, mass,
                                                                                                data.qM)
    inertia = 1 / np.diag(np.linalg.inv(mass))[swimmer._dof]
    gear = swimmer.model.actuator_gear[swimmer._actuators, 0]
    omega = 0.4 / (swimmer.model.opt.timestep * swimmer.control_interval)
    np.testing.assert_allclose(swimmer.kp, np.minimum(1 / 0.05, inertia * omega**2 / gear), rtol=1e-9)


def test_a_simulation_that_becomes_unstable_is_an_error_not_a_silent_reset(tmp_path, monkeypatch):
    """MuJoCo resets an unstable model to rest and carries on; the robot says so instead of returning the
    samples of that other run (the Control Suite's light 6-link swimmer driven at a 0.2 s period)."""
    pytest.importorskip("dm_control", reason="the Control Suite's swimmer needs dm_control (pip install "
                                             "'geogait[dmcontrol]')")
    from geogait.robots import dm_control_swimmer

    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT in the working directory
    calm = dm_control_swimmer(6, perturbation=Perturbation(eta=0), cycle_period=1.0)
    assert np.all(np.isfinite(calm.next_cycle().pose))
    fast = dm_control_swimmer(6, perturbation=Perturbation(eta=0), cycle_period=0.2)
    with pytest.raises(GeogaitError, match=r"MuJoCo's simulation became unstable in cycle 0 .*timestep \(0.002 s\)"):
        fast.next_cycle()
