"""A connection sampled on a grid (GridSystem): interpolation against the analytic swimmer, its
derivatives, its ceiling, sysplotter files, and bad input."""

import numpy as np
import pytest
from scipy.io import savemat

from geogait import GeogaitError
from geogait.optimize import optimize_ceiling
from geogait.systems import GridSystem, PurcellSwimmer

SWIMMER = PurcellSwimmer(3)
AXIS = np.linspace(-2.2, 2.2, 45)  # covers the joint limits ±2π/3 with the Magnus nodes and finite differences


@pytest.fixture(scope="module")
def grid():
    return GridSystem.sample(SWIMMER, [AXIS, AXIS])


def test_exact_at_the_grid_points_and_close_between(grid):
    nodes = np.stack(np.meshgrid(AXIS[::7], AXIS[::5], indexing="ij"), axis=-1)
    np.testing.assert_allclose(grid.connection(nodes), SWIMMER.connection(nodes), rtol=0, atol=1e-13)
    shapes = np.random.default_rng(0).uniform(-2.2, 2.2, (500, 2))
    error = np.abs(grid.connection(shapes) - SWIMMER.connection(shapes)).max()
    assert error < 2e-5 * np.abs(SWIMMER.connection(shapes)).max()  # cubic: h⁴ with h = 0.1


def test_derivatives_agree_with_the_analytic_connection(grid):
    shapes = np.random.default_rng(1).uniform(-2.0, 2.0, (200, 2))
    step = 1e-6
    expected = np.stack([(SWIMMER.connection(shapes + step * e) - SWIMMER.connection(shapes - step * e)) / (2 * step)
                         for e in np.eye(2)], axis=-1)
    derivative = grid.connection_derivative(shapes)
    assert derivative.shape == (200, 3, 2, 2)
    assert np.abs(derivative - expected).max() < 1e-3 * np.abs(expected).max()


def test_the_grid_reproduces_the_analytic_swimmers_ceiling(grid):
    analytic = optimize_ceiling(SWIMMER, starts=2)
    sampled = optimize_ceiling(grid, starts=2)
    assert sampled.value == pytest.approx(analytic.value, rel=1e-3)
    np.testing.assert_allclose(sampled.gait.joint_limit(), analytic.gait.joint_limit(), atol=1e-2)


def sysplotter_file(path, transposed=False, change=lambda field: field):
    """The swimmer's connection as sysplotter saves it: −A on ndgrid arrays in a 3 × d cell (d × 3 if
    ``transposed``), cells column by column (as MATLAB writes them); ``change`` applied to the first field."""
    r1, r2 = np.meshgrid(AXIS, AXIS, indexing="ij")
    values = SWIMMER.connection(np.stack([r1, r2], axis=-1))
    cells = np.empty((2, 3) if transposed else (3, 2), dtype=object)
    for row in range(3):
        for col in range(2):
            cells[(col, row) if transposed else (row, col)] = -values[..., row, col]
    cells[0, 0] = change(cells[0, 0])
    grids = np.empty((2, 1), dtype=object)
    grids[0, 0], grids[1, 0] = r1, r2
    savemat(path, {"s": {"grid": {"eval": grids}, "vecfield": {"eval": {"content": {"Avec": cells}}}}})
    return path


def test_a_sysplotter_file_gives_the_same_system(tmp_path, grid):
    """sysplotter keeps −A on ndgrid arrays, cells column by column (as MATLAB writes them)."""
    loaded = GridSystem.from_sysplotter(sysplotter_file(tmp_path / "sysf_swimmer_calc.mat"))
    assert loaded.name == "sysf_swimmer_calc" and loaded.n_joints == 2
    shapes = np.random.default_rng(2).uniform(-2, 2, (50, 2))
    np.testing.assert_allclose(loaded.connection(shapes), grid.connection(shapes), rtol=0, atol=1e-13)
    assert repr(loaded).split("sha256=")[1] == repr(grid).split("sha256=")[1]  # same data, same cache key


def test_different_grids_have_different_cache_keys():
    twice = GridSystem.sample(PurcellSwimmer(3, drag_ratio=4.0), [AXIS, AXIS], name="PurcellSwimmer (grid)")
    once = GridSystem.sample(SWIMMER, [AXIS, AXIS], name="PurcellSwimmer (grid)")
    assert repr(twice) != repr(once)


def test_outside_the_grid_is_an_error_not_an_extrapolation(grid):
    with pytest.raises(GeogaitError, match=r"'shapes' argument .* joint 1 is 2.5, outside \[-2.2, 2.2\]"):
        grid.connection([0.0, 2.5])
    with pytest.raises(GeogaitError, match="'shapes'"):
        grid.connection_derivative([np.nan, 0.0])


@pytest.mark.parametrize(("axes", "values", "match"), [
    ([np.linspace(0, 1, 3), np.linspace(0, 1, 5)], np.zeros((3, 5, 3, 2)), r"'axes\[0\]'.*at least 4 points"),
    ([np.linspace(1, 0, 5), np.linspace(0, 1, 5)], np.zeros((5, 5, 3, 2)), r"'axes\[0\]'.*strictly increasing"),
    ([np.linspace(0, 1, 5), np.linspace(0, 1, 5)], np.zeros((5, 5, 2, 2)), r"'connection'.*\(5, 5, 3, 2\)"),
    ([np.linspace(0, 1, 5), np.linspace(0, 1, 5)], np.full((5, 5, 3, 2), np.nan), "'connection'"),
    (np.linspace(0, 1, 5), np.zeros((5, 3, 1)), "'axes'.*sequence of d one-dimensional arrays"),
])
def test_bad_grids_are_refused(axes, values, match):
    with pytest.raises(GeogaitError, match=match):
        GridSystem(axes, values)


AXES = [np.linspace(0, 1, 5), np.linspace(0, 1, 5)]


@pytest.mark.parametrize(("axes", "values", "match"), [
    (AXES, np.full((5, 5, 3, 2), 1e300), r"'connection'.*within ±1e\+12. Got '1e\+300 at index \(0, 0, 0, 0\)'"),
    (AXES, np.full((5, 5, 3, 2), 1j), r"'connection'.*real numbers. Got 'complex numbers'"),
    (AXES, np.ones((5, 5, 3, 2), dtype=bool), r"'connection'.*real numbers. Got 'booleans"),
    ([AXES[0] * 1e300, AXES[1]], np.zeros((5, 5, 3, 2)), r"'axes\[0\]'.*within ±1e\+12"),
    ([[False, True, True, True, True], AXES[1]], np.zeros((5, 5, 3, 2)), r"'axes\[0\]'.*Got 'booleans"),
])
def test_grids_beyond_the_bound_or_not_real_are_refused(axes, values, match):
    """Issue 58, finding 7: a 1e300 connection was interpolated into 1e297 velocities."""
    with pytest.raises(GeogaitError, match=match):
        GridSystem(axes, values)


@pytest.mark.parametrize(("change", "match"), [
    (lambda field: field + 1e-3j, "must be an array of real numbers. Got 'complex numbers'"),
    (lambda field: field * 1e300, r"must be plausible values, within ±1e\+12"),
    (lambda field: np.where(np.arange(field.size).reshape(field.shape) == 100, np.nan, field),
     r"must be finite \(no NaN or inf\)"),
])
def test_a_sysplotter_field_that_is_not_real_finite_and_bounded_is_named(tmp_path, change, match):
    """Issue 58, finding 7: a complex field lost its imaginary part silently (a ComplexWarning at most)."""
    path = sysplotter_file(tmp_path / "sysf_calc.mat", change=change)
    with pytest.raises(GeogaitError, match=r"'s\.vecfield\.eval\.content\.Avec\{1\} in .*sysf_calc.mat' parameter of "
                                           rf"GridSystem.from_sysplotter {match}"):
        GridSystem.from_sysplotter(path)


def test_bad_sysplotter_files_get_one_clear_line(tmp_path):
    with pytest.raises(GeogaitError, match="no file at"):
        GridSystem.from_sysplotter(tmp_path / "missing.mat")
    (tmp_path / "text.mat").write_text("not a MATLAB file")
    with pytest.raises(GeogaitError, match="not a MATLAB file scipy can read"):
        GridSystem.from_sysplotter(tmp_path / "text.mat")
    savemat(tmp_path / "other.mat", {"x": np.ones(3)})
    with pytest.raises(GeogaitError, match="no sysplotter struct 's'"):
        GridSystem.from_sysplotter(tmp_path / "other.mat")


def test_a_transposed_sysplotter_cell_is_refused_not_misread(tmp_path):
    """A d × 3 Avec cell holds the same count of fields as a 3 × d one; read column by column it built a
    connection 0.3 off the true one."""
    with pytest.raises(GeogaitError, match=r"Avec in .* is a 2 × 3 cell; expected 3 × 2"):
        GridSystem.from_sysplotter(sysplotter_file(tmp_path / "transposed.mat", transposed=True))
