"""The ceiling (``optimize_ceiling``, ``cached_ceiling``): the best gait of a family found offline with the true
connection, the yardstick the in-situ optimiser's parts are judged against rather than a part of it. It must agree
with a brute-force grid search over the first-order gaits, start from the seed gait (or a lower-order gait it is
given), never mistake one system for another in its cache, and raise a named error, not return a number, when no
gait can be found or its arguments are wrong."""

import numpy as np
import pytest

from geogait import se2
from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, fourier_basis
from geogait.optimize import cached_ceiling, optimize_ceiling
from geogait.se2 import gauss_phases, magnus_steps
from geogait.systems import FunctionSystem, PurcellSwimmer


def batched_displacement(system, coefficients, resolution=48):
    """Net motion of many first-order gaits at once (coefficients (N, d, 3)) — a second integrator."""
    nodes, step = gauss_phases(resolution)
    basis, d_basis = fourier_basis(nodes, 1), fourier_basis(nodes, 1, 1)  # (n, 2, 3)
    shape = np.einsum("nkc,gjc->gnkj", basis, coefficients)
    rate = np.einsum("nkc,gjc->gnkj", d_basis, coefficients)
    velocity = -np.einsum("...ij,...j->...i", system.connection(shape), rate)
    return se2.product_of_exponentials(magnus_steps(velocity, step))


@pytest.mark.slow
def test_ceiling_matches_brute_force_grid_search():
    swimmer = PurcellSwimmer(3)
    ceiling = optimize_ceiling(swimmer, starts=3)
    assert abs(ceiling.displacement[2]) < 1e-6 and ceiling.gait.joint_limit().max() <= 2 * np.pi / 3 + 1e-9
    # Grid over the first-order family; the phase origin is fixed (b_1 of joint 1 = 0), which only
    # rotates the translation of a non-rotating gait and so leaves |t| unchanged.
    amplitude = np.linspace(0.4, 2.0, 9)
    signed = np.linspace(-2.0, 2.0, 17)
    offset = np.array([-0.1, 0.0, 0.1])
    grid = np.array(np.meshgrid(offset, amplitude, offset, signed, signed, indexing="ij")).reshape(5, -1).T
    coefficients = np.zeros((grid.shape[0], 2, 3))
    coefficients[:, 0, 0], coefficients[:, 0, 1] = grid[:, 0], grid[:, 1]
    coefficients[:, 1, 0], coefficients[:, 1, 1], coefficients[:, 1, 2] = grid[:, 2], grid[:, 3], grid[:, 4]
    limit = np.abs(coefficients[:, :, 0]) + np.hypot(coefficients[:, :, 1], coefficients[:, :, 2])
    coefficients = coefficients[np.all(limit <= 2 * np.pi / 3, axis=1)]
    pose = batched_displacement(swimmer, coefficients, resolution=32)
    progress = np.hypot(pose[:, 0], pose[:, 1])
    best = progress[np.abs(pose[:, 2]) < 0.01].max()
    # The grid may only approach the optimum from below (up to the rotation slack it is allowed).
    assert 0.93 * ceiling.value < best < 1.02 * ceiling.value


def test_ceiling_start_defaults_to_the_seed_gait_and_accepts_a_lower_order():
    from geogait.gaits import seed_gait
    from geogait.optimize import optimize_ceiling
    from geogait.systems import PurcellSwimmer

    swimmer = PurcellSwimmer(3)
    default = optimize_ceiling(swimmer, starts=1)
    given = optimize_ceiling(swimmer, starts=1, start=seed_gait(2, amplitude=1.0))
    assert given.value == default.value
    raised = optimize_ceiling(swimmer, order=2, objective_kind="progress", starts=1, start=default.gait)
    assert raised.gait.order == 2 and raised.value >= default.value - 1e-9


def test_the_ceiling_cache_never_mistakes_one_system_for_another(tmp_path, monkeypatch):
    """A FunctionSystem's repr names its function by address, which a later lambda may reuse: each drag ratio
    got the first one's ceiling from the cache."""
    monkeypatch.setenv("GEOGAIT_CACHE", str(tmp_path))
    for ratio in (2.0, 4.0, 8.0):
        swimmer = PurcellSwimmer(3, drag_ratio=ratio)
        wrapped = FunctionSystem(lambda r, swimmer=swimmer: swimmer.connection(r), n_joints=2)
        assert cached_ceiling(wrapped, starts=1).value == pytest.approx(optimize_ceiling(swimmer, starts=1).value,
                                                                         rel=1e-9)
    assert not list(tmp_path.iterdir())  # (not cached at all)


@pytest.mark.parametrize(("call", "match"), [
    (lambda: optimize_ceiling(PurcellSwimmer(4, link_lengths=[1, 2, 3, 4]), family="symmetric", starts=2),
     "found no feasible gait of purcell-4"),
    (lambda: optimize_ceiling(PurcellSwimmer(3), starts=1, family="symmetric",
                              start=FourierGait([[0, 1, 0], [0, 0, 0]])), "'start' parameter .* front-back symmetric"),
    (lambda: optimize_ceiling(PurcellSwimmer(3), objective_kind="forward"), "'objective_kind' parameter"),
    (lambda: optimize_ceiling(None), "'system' parameter of optimize_ceiling"),
    (lambda: optimize_ceiling(PurcellSwimmer(3), seed=-1), "'seed' parameter of optimize_ceiling"),
])
def test_a_ceiling_that_cannot_be_found_is_an_error_not_a_number(call, match):
    """Every start infeasible used to give a ceiling of -inf (cached as null, read back as None); a start off the
    symmetric family was projected onto it without a word."""
    with pytest.raises(GeogaitError, match=match):
        call()
