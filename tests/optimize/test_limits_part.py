"""The Limits part: joint angle and speed limits, the unit of shape, and the feasible region a robot declares. The
linear joint-limit constraints imply the continuous limit, no commanded gait ever exceeds the angle or speed limit,
a limit below what the seed gait needs is refused naming it, ``max_joint_angle="auto"`` comes from the joint ranges
the robot declares, ``shape_scale="auto"`` makes the defaults work in any unit of shape, and a robot's feasible
region is checked as it is read."""

import numpy as np
import pytest
from _robots import DeclaredRanges
from _robots import perturbed_stream as _stream

from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.optimize import InSituOptimizer, Limits, ModelStep, joint_limit_constraints
from geogait.robots import RobotWrapper
from geogait.simulate import SwimmerStream
from geogait.systems import FunctionSystem, PurcellSwimmer


@pytest.mark.parametrize("order", [1, 2, 3])
def test_joint_limit_constraints_imply_the_continuous_limit(rng, order):
    matrix, bound = joint_limit_constraints(2, order, 1.2)
    for _ in range(200):
        params = rng.normal(size=2 * (2 * order + 1))
        scale = (matrix @ params / bound).max()
        params = params / scale  # now on the boundary of the grid constraints
        assert FourierGait.from_params(params, 2).joint_limit().max() <= 1.2 + 1e-9


@pytest.mark.parametrize("r_max", [1.05, 1.3])
def test_joint_limits_are_never_violated(r_max):
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation.from_std(0.1),
                           sensor_noise=0.05, seed=3)
    result = InSituOptimizer(step=ModelStep(trust_radius=0.15), limits=Limits(max_joint_angle=r_max)).run(stream, 12)
    assert result.n_steps >= 2
    for gait in result.gaits:
        assert gait.joint_limit().max() <= r_max + 1e-9


def test_limits_below_the_seed_gait_are_refused_naming_the_limit():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    with pytest.raises(GeogaitError, match=r"'max_joint_angle' parameter .* at least the largest joint angle of the "
                                           r"robot's seed gait \(1 rad\).* Got 0.5"):
        InSituOptimizer(limits=Limits(max_joint_angle=0.5)).run(stream, 2)
    with pytest.raises(GeogaitError, match=r"'max_joint_velocity' parameter .* at least the peak joint speed of the "
                                           r"robot's seed gait \(6.283 rad/s\).* Got 3"):
        InSituOptimizer(limits=Limits(max_joint_velocity=3.0)).run(stream, 2)
    assert stream.gait == seed_gait(2)


def test_seed_outside_joint_limits_is_rejected():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2, amplitude=1.5), seed=0)
    with pytest.raises(ValueError, match="max_joint_angle"):
        InSituOptimizer(limits=Limits(max_joint_angle=1.0)).run(stream, 2)


def test_joint_limit_auto_comes_from_the_robots_declared_ranges():
    ranges = np.array([[-1.2, 1.5], [-1.3, 1.1]])
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.05, seed=4)
    result = InSituOptimizer(step=ModelStep(trust_radius=0.15), family="free").run(DeclaredRanges(stream, ranges), 12)
    assert result.max_joint_angle == pytest.approx(1.1)  # the tightest side of any joint
    assert result.n_steps >= 2 and all(g.joint_limit().max() <= 1.1 + 1e-9 for g in result.gaits)
    assert result.summary()["max_joint_angle"] == pytest.approx(1.1)
    plain = InSituOptimizer(family="free").run(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=4), 2)
    assert plain.max_joint_angle == pytest.approx(2 * np.pi / 3)  # nothing declared: the design's default
    for bad in ([[-1.0, 1.0]], [[0.2, 1.0], [-1.0, 1.0]], "wide"):
        with pytest.raises(GeogaitError, match="robot.joint_ranges"):
            InSituOptimizer().run(DeclaredRanges(SwimmerStream(PurcellSwimmer(3), seed_gait(2)), bad), 1)
    with pytest.raises(GeogaitError, match="max_joint_angle"):
        InSituOptimizer(limits=Limits(max_joint_angle="tight")).validate()


@pytest.mark.filterwarnings("ignore:.*more than a full turn")
def test_shape_scale_makes_the_defaults_work_in_any_shape_unit():
    """The same swimmer with its shape measured in units 7× smaller than radians (a curvature-mode
    robot, say): with shape_scale='auto' (the seed's amplitude) the default run improves the gait as
    it does in radians; with the radian defaults (shape_scale=1) its steps are 7× too short."""
    unit = 7.0
    swimmer = PurcellSwimmer(3)
    scaled = FunctionSystem(lambda r: swimmer.connection(r / unit) / unit, n_joints=2, name="scaled")

    def improvement(system, gait, std, **options):
        """Mean over four seeds: one 20-cycle run varies with its draws by ±0.2."""
        runs = []
        for seed in range(4):
            stream = SwimmerStream(system, gait, perturbation=Perturbation.from_std(std), sensor_noise=0.05,
                                   seed=seed)
            log = InSituOptimizer(family="free", random_state=seed, **options).run(stream, 20).log
            runs.append(log["improvement"].iloc[-1])
        return float(np.mean(runs))

    radians = improvement(swimmer, seed_gait(2), 0.15)
    in_units = improvement(scaled, seed_gait(2, amplitude=unit), 0.15 * unit,
                           limits=Limits(max_joint_angle=unit * 2 * np.pi / 3))
    unscaled = improvement(scaled, seed_gait(2, amplitude=unit), 0.15 * unit,
                           limits=Limits(max_joint_angle=unit * 2 * np.pi / 3, shape_scale=1.0))
    assert radians > 0.3
    assert in_units > 0.8 * radians
    assert unscaled < 0.5 * in_units


def test_joint_speed_limit_holds_for_every_commanded_gait():
    limit = 1.3 * 2 * np.pi / 1.5  # rad/s at a period of 1.5 s; the seed needs 2π/1.5 · 1.0
    result = InSituOptimizer(step=ModelStep(trust_radius=0.15),
                             limits=Limits(max_joint_velocity=limit)).run(_stream(seed=6, cycle_period=1.5), 20)
    assert result.n_steps >= 3
    phase = np.linspace(0, 2 * np.pi, 512)
    for gait in result.gaits:
        assert np.abs(gait.velocity(phase)).max() * 2 * np.pi / 1.5 <= limit * (1 + 1e-9)
    with pytest.raises(ValueError, match="max_joint_velocity"):
        InSituOptimizer(limits=Limits(max_joint_velocity=0.5)).run(_stream(cycle_period=1.5), 2)


def test_a_robots_feasible_region_is_checked_as_it_is_read():
    """Order 0 gave rows over no phase at all (the region silently not enforced); NaN rows went straight to the
    solver; a scalar answer failed to unpack."""
    from geogait.optimize import robot_feasibility

    class Fenced(RobotWrapper):  # (a robot that declares its feasible region)
        def __init__(self, answer):
            super().__init__(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0))
            self.answer = answer

        def feasibility(self, shapes, jacobian=False):
            return self.answer(shapes)

    good = Fenced(lambda s: (1.0 - s[:, 0], np.tile([-1.0, 0.0], (len(s), 1))))
    rows = robot_feasibility(good, 2, 1)
    value, gradient = rows(np.zeros(6))
    assert value.shape == (256,) and gradient.shape == (256, 6)
    for n_joints, order, match in ((2, 0, "'order'"), (0, 1, "'n_joints'")):
        with pytest.raises(ValueError, match=match):
            robot_feasibility(good, n_joints, order)
    for answer in (lambda s: (np.full(len(s), np.nan), np.zeros_like(s)), lambda s: 1.0,
                   lambda s: (np.ones(3), np.zeros_like(s))):
        with pytest.raises(ValueError, match=r"feasibility\(shapes, jacobian=True\) must return finite"):
            robot_feasibility(Fenced(answer), 2, 1)(np.zeros(6))


@pytest.mark.parametrize("order", [1, 2])
def test_declared_joint_ranges_as_rows_imply_the_continuous_ranges(rng, order):
    """The rows a declared asymmetric range adds to the feasible region keep the continuous loop inside it."""
    from geogait.optimize._objective import spec_feasibility
    from geogait.robots import RobotSpec

    ranges = np.array([[-0.4, 1.3], [-1.1, 0.7]])
    spec = RobotSpec(kind="Stub", n_joints=2, cycle_period=1.0, joint_ranges=ranges)
    rows = spec_feasibility(spec, 2, order, max_joint_angle=2.0)
    assert spec_feasibility(spec, 2, order, max_joint_angle=0.4) is None  # the symmetric limit keeps them already
    for _ in range(200):
        params = rng.normal(size=2 * (2 * order + 1))
        gait = FourierGait.from_params(params, 2)
        shapes = gait.shape(np.linspace(0, 2 * np.pi, 4096, endpoint=False))
        value, jacobian = rows(params)
        inside = bool(value.min() >= 0)
        if inside:
            assert np.all(shapes >= ranges[:, 0] - 1e-9) and np.all(shapes <= ranges[:, 1] + 1e-9)
        if np.any(shapes < ranges[:, 0]) or np.any(shapes > ranges[:, 1]):
            assert not inside
        step = 1e-6 * rng.normal(size=params.size)  # rows are linear: their Jacobian is exact
        np.testing.assert_allclose(rows(params + step)[0] - value, jacobian @ step, atol=1e-12)


def test_a_joint_limit_given_beyond_the_declared_ranges_keeps_them():
    """max_joint_angle wider than the ranges a robot declares (to start an asymmetric seed, say) never lets a
    commanded gait leave those ranges; a seed that leaves them is refused naming the joint and its range."""
    ranges = np.array([[-1.2, 1.5], [-1.5, 1.05]])

    def run(declared):
        stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation.from_std(0.1),
                               sensor_noise=0.05, seed=4)
        robot = DeclaredRanges(stream, ranges) if declared else stream
        return InSituOptimizer(step=ModelStep(trust_radius=0.15), family="free",
                               limits=Limits(max_joint_angle=2.0)).run(robot, 16)

    phase = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    assert max(gait.shape(phase)[:, 1].max() for gait in run(False).gaits) > 1.05  # (undeclared, it goes beyond)
    result = run(True)
    assert result.max_joint_angle == pytest.approx(2.0)  # the user's limit, as given
    assert len(set(result.gaits)) >= 3
    for gait in result.gaits:
        shapes = gait.shape(phase)
        assert np.all(shapes >= ranges[:, 0] - 1e-9) and np.all(shapes <= ranges[:, 1] + 1e-9)
    wide = DeclaredRanges(SwimmerStream(PurcellSwimmer(3), seed_gait(2, amplitude=1.2), seed=0), ranges)
    with pytest.raises(GeogaitError, match=r"'robot' parameter .* a seed gait within the joint_ranges the robot "
                                           r"declares \(joint 1: \[-1.5, 1.05\] rad\).* joint 1 over \[-1.2, 1.2\]"):
        InSituOptimizer(limits=Limits(max_joint_angle=2.0)).run(wide, 2)
    assert wide.gait == seed_gait(2, amplitude=1.2)


def test_the_automatic_limit_below_an_asymmetric_seed_says_how_to_start_it():
    ranges = np.array([[-0.8, 2.5], [-0.8, 2.5]])
    seed = FourierGait(np.array([[0.8, 1.0, 0.0], [0.8, 0.0, 1.0]]))  # over [-0.2, 1.8]: inside both ranges
    robot = DeclaredRanges(SwimmerStream(PurcellSwimmer(3), seed, seed=0), ranges)
    with pytest.raises(GeogaitError, match=r"automatic joint limit, 0.8 rad \(the nearest bound of the joint_ranges "
                                           r"it declares; a larger max_joint_angle lets it start"):
        InSituOptimizer().run(robot, 2)
    result = InSituOptimizer(family="free", limits=Limits(max_joint_angle=2.5)).run(robot, 4)
    assert len(result.gaits) == 4
