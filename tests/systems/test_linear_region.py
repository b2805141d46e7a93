"""Linear shape limits a robot declares (LinearRegion): the margin is the least distance to a face, its gradient
is the nearest face's; a Python robot's own region and a bridge driver's declared one keep every gait the
optimiser and the path follower command inside it."""

import sys

import numpy as np
import pytest
from _robots import BareRobot
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from geogait.control import PathTracker, ReferencePath
from geogait.gaits import seed_gait
from geogait.optimize import InSituOptimizer, robot_feasibility
from geogait.robots import ProcessRobot
from geogait.simulate import SwimmerStream
from geogait.systems import LinearRegion, PurcellSwimmer

PHASES = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
APART = 1.6  # |r0 - r1| <= 1.6: the seed gait (amplitude 1, a quarter period apart) reaches √2


def apart():
    return LinearRegion([[1.0, -1.0], [-1.0, 1.0]], [APART, APART])


finite = st.floats(-3, 3, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(arrays(float, (3, 2), elements=finite), arrays(float, 3, elements=finite),
       arrays(float, (5, 2), elements=finite))
def test_the_margin_is_the_least_distance_to_a_face_and_its_gradient_the_nearest_faces(normals, bounds, shapes):
    normals = normals + np.where(np.linalg.norm(normals, axis=1, keepdims=True) < 0.1, 1.0, 0.0)  # no zero rows
    region = LinearRegion(normals, bounds)
    value, gradient = region.feasibility(shapes, jacobian=True)
    lengths = np.linalg.norm(normals, axis=1)
    distances = (bounds - shapes @ normals.T) / lengths  # each face's signed distance, independently
    np.testing.assert_allclose(value, distances.min(axis=1), atol=1e-12)
    np.testing.assert_array_equal(region.feasible(shapes), distances.min(axis=1) >= 0)
    unique = np.sort(distances, axis=1)[:, 1] - distances.min(axis=1) > 1e-4  # (a kink where two faces tie)
    step = 1e-6
    numeric = np.stack([(region.feasibility(shapes + step * e) - region.feasibility(shapes - step * e)) / (2 * step)
                        for e in np.eye(2)], axis=-1)
    np.testing.assert_allclose(gradient[unique], numeric[unique], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(gradient, axis=1), 1.0)  # a distance: unit slope


def test_bad_limits_are_named():
    with pytest.raises(ValueError, match="'normals' parameter of LinearRegion"):
        LinearRegion([[0.0, 0.0]], [1.0])
    with pytest.raises(ValueError, match="'normals' parameter of LinearRegion"):
        LinearRegion([[1.0, 0.0]], [1.0, 2.0])
    with pytest.raises(ValueError, match="'normals' parameter of LinearRegion"):
        LinearRegion([[1.0, np.nan]], [1.0])
    with pytest.raises(ValueError, match="'shapes'"):
        apart().feasibility(np.zeros((4, 3)))


@pytest.mark.parametrize(("make", "match"), [
    (lambda: LinearRegion([[True, False]], [1.0]), "'normals'.*Got 'booleans"),
    (lambda: LinearRegion([[1.0, 0.0]], [True]), "'bounds'.*Got 'booleans"),
    (lambda: LinearRegion.from_rows([[1.0, True, 1.0]]), "'rows'.*Got 'text, booleans or complex numbers"),
    (lambda: LinearRegion.from_rows(np.array([[1 + 1j, 0, 1]])), "'rows'.*Got 'complex numbers'"),
    (lambda: LinearRegion.from_rows([[1 + 1j, 0, 1]]), "'rows'.*Got 'complex numbers'"),
    (lambda: LinearRegion.from_rows([[1.0, 0.0, 1e300]]), r"'rows'.*within ±1e\+12"),
])
def test_booleans_and_complex_limits_are_refused_not_cast(make, match):
    """Issue 58 (confusing): True was read as 1 and 1 + 1j as 1; a complex list was a TypeError."""
    with pytest.raises(ValueError, match=match):
        make()


class LimitedRobot(BareRobot):
    """A swimmer behind a wall whose joints may not bend more than ``limit`` rad against each other; it declares
    its chain front-back symmetric, as the bridge's reference driver does."""

    front_back_symmetric = True

    def __init__(self, seed=1, limit=APART):
        super().__init__(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=seed))
        self.feasibility = LinearRegion([[1.0, -1.0], [-1.0, 1.0]], [limit, limit]).feasibility


class FreeRobot(BareRobot):
    front_back_symmetric = True


def widest(gaits):
    return max(float(np.abs(np.diff(gait.shape(PHASES), axis=1)).max()) for gait in gaits)


def test_a_robots_own_region_keeps_every_commanded_gait_inside():
    limited = InSituOptimizer().run(LimitedRobot(), 30)
    assert widest(limited.gaits) <= APART + 1e-9
    assert limited.summary()["final_measured_improvement"] > 0.3  # it still climbs, inside
    free = InSituOptimizer().run(FreeRobot(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=1)), 30)
    assert widest(free.gaits) > APART + 0.2
    assert robot_feasibility(BareRobot(SwimmerStream(PurcellSwimmer(3), seed_gait(2))), 2, 1) is None


def test_a_seed_outside_the_robots_region_is_refused_before_the_robot_moves():
    robot = LimitedRobot()
    robot.feasibility = LinearRegion([[1.0, -1.0]], [1.0]).feasibility  # the seed reaches r0 - r1 = √2
    with pytest.raises(ValueError, match="feasible region"):
        InSituOptimizer().run(robot, 3)
    with pytest.raises(ValueError, match="feasible region"):
        PathTracker(warmup_cycles=1).run(robot, ReferencePath.line(), 2)
    assert robot._stream.cycle == 0 if hasattr(robot._stream, "cycle") else True


def test_the_path_follower_keeps_the_robots_region():
    """Its straight gait (the seed, |r0 - r1| up to √2) sits just inside |r0 - r1| <= 1.45, so the region binds as
    soon as it steers: every commanded gait stays inside, where the same run without the region leaves it."""

    def commanded(result):
        return [seed_gait(2).with_params(p) for p in result.log.filter(like="param_").to_numpy()]

    path = ReferencePath.circle(0.5)
    limited = PathTracker(warmup_cycles=3).run(LimitedRobot(seed=3, limit=1.45), path, 8)
    assert widest(commanded(limited)) <= 1.45 + 1e-9
    free = PathTracker(warmup_cycles=3).run(FreeRobot(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=3)), path, 8)
    assert widest(commanded(free)) > 1.45 + 0.05


def test_a_bridge_driver_declares_shape_constraints(tmp_path):
    driver = [sys.executable, "-m", "geogait.robots.driver", "--seed", "1",
              "--shape-constraints", f"[[1, -1, {APART}], [-1, 1, {APART}]]"]
    with ProcessRobot(driver) as robot:
        np.testing.assert_array_equal(robot.shape_constraints.normals, [[1, -1], [-1, 1]])
        result = InSituOptimizer().run(robot, 16)
    assert widest(result.gaits) <= APART + 1e-9
    bad = [sys.executable, "-m", "geogait.robots.driver", "--shape-constraints", "[[1, -1]]"]
    with pytest.raises(ValueError, match="'shape_constraints' must be a list of rows"):
        ProcessRobot(bad)


def test_a_robot_runs_summary_records_the_declared_limits(tmp_path):
    import json
    import shlex

    from typer.testing import CliRunner

    from geogait.cli import app

    driver = shlex.join([sys.executable, "-m", "geogait.robots.driver", "--shape-constraints",
                         f"[[1, -1, {APART}], [-1, 1, {APART}]]"])
    result = CliRunner().invoke(app, ["optimize", "--robot", driver, "--cycles", "2", "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["results"]["robot"]["shape_constraints"] == [[1.0, -1.0, APART], [-1.0, 1.0, APART]]


def test_regions_and_snakes_refuse_what_they_cannot_hold():
    """Text or complex normals raised a raw TypeError or were cast; 1e200 normals overflowed to a zero margin;
    a 1e300 link made an infinite connection; a region without a feasibility function failed later."""
    import pytest

    from geogait import GeogaitError
    from geogait.gaits import seed_gait
    from geogait.systems import KinematicSnake, LinearRegion, PurcellSwimmer, RegionSystem

    for make, match in ((lambda: LinearRegion([["a", 1]], [1]), "'normals' parameter .* real numbers"),
                        (lambda: LinearRegion([[1 + 1j, 1]], [1]), "'normals' parameter .*'complex numbers'"),
                        (lambda: LinearRegion([[1e200, 1e200]], [1]), "'normals' parameter .* within ±1e\\+12"),
                        (lambda: KinematicSnake(link_lengths=(1e300, 1, 1)), "'link_lengths' parameter"),
                        (lambda: RegionSystem(PurcellSwimmer(3), None, seed=seed_gait(2)), "'feasibility' param")):
        with pytest.raises(GeogaitError, match=match):
            make()
