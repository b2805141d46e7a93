"""Path following within the machine's limits: memory held to what a path needs, SIGTERM honoured at once."""

import numpy as np
from _limits import within_memory

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
