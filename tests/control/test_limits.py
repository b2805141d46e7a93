"""Path following within the machine's limits: memory held to what a path needs, SIGTERM honoured at once."""

import numpy as np
import pytest
from _limits import within_memory
from _robots import DeclaredRanges

from geogait.control import ReferencePath


def test_a_waypoint_path_with_a_tiny_segment_is_projected_within_the_memory_limit():
    """One 1e-10 segment sized the search by it: 2e10 candidates, 157 GiB."""
    code = ("from geogait.control import ReferencePath\n"
            "path = ReferencePath.waypoints([[0, 0], [1, 0], [1 + 1e-10, 0], [2, 0]])\n"
            "s, error, _ = path.project([[0.5, 0.1]] * 40 + [[1.5, -0.1]], near=0.5, window=1.0)\n"
            "print(float(s[0]), float(error[0]), float(s[-1]), float(error[-1]))\n")
    result = within_memory(code)
    assert result.returncode == 0, result.stderr[-2000:]
    np.testing.assert_allclose(list(map(float, result.stdout.split())), [0.5, 0.1, 1.5, -0.1])


def test_a_windowed_search_finds_what_the_whole_path_search_finds():
    rng = np.random.default_rng(3)
    for closed in (False, True):
        path = ReferencePath.waypoints(np.cumsum(rng.uniform(1e-9, 1, (30, 2)) * [1, 0.2], axis=0), closed=closed)
        positions = path.point(rng.uniform(0, path.length, 50)) + rng.normal(0, 1e-3, (50, 2))
        s, error, _ = path.project(positions)
        near, near_error, _ = path.project(positions, near=s, window=0.5)
        np.testing.assert_allclose(near_error, error, atol=1e-12)


def test_a_projection_onto_a_long_path_runs_in_bounded_compiled_calls(monkeypatch):
    """A planner's horizon projects thousands of positions onto a path of up to 200 000 segments: one compiled call
    over them all held SIGTERM off for minutes. Each call now tests at most _KERNEL_TESTS position-segment pairs (about
    10 ms), and Python handles a signal between calls; the result is the one of a single call."""
    from geogait.control import _paths

    kernel = _paths.nearest_segment_kernel()
    if kernel is None:
        pytest.skip("the compiled kernel is not available here")
    tests = []

    def counted(x, y, start_x, start_y, step_x, step_y, length, best, along):
        tests.append(x.size * length.size)
        return kernel(x, y, start_x, start_y, step_x, step_y, length, best, along)

    path = ReferencePath.circle(1000.0)  # (about 314 000 segments: capped at 200 000)
    positions = np.random.default_rng(0).uniform(-10, 10, (64, 2)) + [0, 1000]
    monkeypatch.setattr(_paths, "nearest_segment_kernel", lambda: counted)
    bound = _paths._KERNEL_TESTS
    monkeypatch.setattr(_paths, "_KERNEL_TESTS", 10**12)
    whole = path.project(positions)
    assert tests == [64 * 200_000]
    monkeypatch.setattr(_paths, "_KERNEL_TESTS", bound)
    tests.clear()
    parts = path.project(positions)
    assert len(tests) > 1 and max(tests) <= bound, tests
    for part, one in zip(parts, whole, strict=True):
        assert np.array_equal(part, one)


@pytest.mark.parametrize(("half_width", "kept"), [(1.4, True), (3.0, False)])
def test_every_steering_gait_keeps_the_joint_ranges_the_robot_declares(half_width, kept):
    """Ranges tighter than the tracker's joint limit (2π/3) bound every steering gait; wider ones leave the
    limit in force, and the gaits then reach beyond 1.4 rad: the ranges are what held them."""
    from geogait.control import PathTracker
    from geogait.gaits import seed_gait
    from geogait.simulate import SwimmerStream
    from geogait.systems import PurcellSwimmer

    robot = DeclaredRanges(SwimmerStream(PurcellSwimmer(3), seed_gait(2), samples_per_cycle=200, seed=0),
                       np.array([[-half_width, half_width]] * 2))
    PathTracker(controller="true", warmup_cycles=1).run(robot, ReferencePath.circle(0.6), 10)
    reach = max(np.abs(gait.shape(np.linspace(0, 2 * np.pi, 4096, endpoint=False))).max() for gait in robot.commanded)
    assert len(robot.commanded) > 5
    assert (reach <= 1.4 + 1e-9) == kept
