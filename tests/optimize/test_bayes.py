"""Trust-region Bayesian optimisation one measured point at a time (geogait.optimize._bayes)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.optimize._bayes import BayesianSearch, GaussianProcess
from geogait.optimize._search import QuadraticSearch

WEIGHTS = np.array([1.0, 3.0, 0.5, 2.0])
OPTIMUM = np.array([0.4, -0.3, 0.8, 0.1])


def _objective(x):  # to maximise: a tilted quadratic bowl, its top at OPTIMUM
    return -float(np.sum(WEIGHTS * (x - OPTIMUM) ** 2)) + 0.3 * float((x[0] - OPTIMUM[0]) * (x[1] - OPTIMUM[1]))


def _drive(search, n, rotation=lambda x: 0.0, **constraints):
    for _ in range(n):
        point = search.ask(**constraints)
        if point is None:
            break
        search.tell(point, _objective(point), rotation(point))
    return search


def test_the_evidence_gradient_matches_finite_differences():
    """The analytic gradient of −log p(y | x, θ) (Rasmussen & Williams eq. 5.9) against central differences."""
    rng = np.random.default_rng(3)
    x, y = rng.normal(size=(12, 3)), rng.normal(size=12)
    process = GaussianProcess(scale=0.5)
    theta = np.r_[np.log([0.4, 0.9, 1.6]), np.log(1.3), np.log(0.02)]
    _, gradient = process._negative_log_evidence(theta, x, y)
    step = 1e-6
    numeric = [(process._negative_log_evidence(theta + step * e, x, y)[0]
                - process._negative_log_evidence(theta - step * e, x, y)[0]) / (2 * step) for e in np.eye(theta.size)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-5, atol=1e-7)


def test_the_process_recovers_a_smooth_function_and_knows_where_it_has_not_looked():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(40, 2))
    truth = lambda z: np.sin(2 * z[:, 0]) + 0.5 * z[:, 1] ** 2  # noqa: E731
    process = GaussianProcess(scale=0.5).fit(x, truth(x))
    test = rng.uniform(-0.8, 0.8, size=(200, 2))
    mean, std = process.predict(test)
    assert np.max(np.abs(mean - truth(test))) < 0.05
    far_mean, far_std = process.predict(np.array([[6.0, 6.0]]))
    assert far_std[0] > 20 * np.median(std)  # far from the data: the prior's spread, not the data's certainty
    np.testing.assert_allclose(process.predict(x)[0], truth(x), atol=1e-3)  # it (nearly) interpolates


def test_it_climbs_a_quadratic_faster_than_a_coordinate_design_and_then_stops():
    """After 9 measured points COBYQA has only finished its design (2n + 1 = 9 probes along the axes); the
    process, moving every coordinate at once, is further up (median of 8 seeds)."""
    design = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-3, period=1.0), 9)
    gains = [max(_drive(BayesianSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-3, period=1.0, seed=seed),
                        9).values) for seed in range(8)]
    start = _objective(np.zeros(4))
    assert np.median(gains) - start > 1.2 * (max(design.values) - start)
    search = BayesianSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-3, period=1.0, seed=1)
    search = _drive(search, 150)
    best = search.points[int(np.argmax(search.values))]
    np.testing.assert_allclose(best, OPTIMUM, atol=0.05)
    assert search.ask() is None  # converged at its final half-width


def test_known_limits_bounds_and_the_rotation_limit_are_kept():
    """x₀² + x₁² ≤ 0.04 (computed, not measured), x₂ in [−1, 0.5], and a measured rotation 0.1 · x₃ held to
    |rotation| ≤ 0.005: the optimum (x₃ = 0.1) lies beyond each limit."""
    def known(x):
        return np.array([x[0] ** 2 + x[1] ** 2 - 0.04])

    bounds = [(-np.inf, np.inf), (-np.inf, np.inf), (-1.0, 0.5), (-np.inf, np.inf)]
    search = _drive(BayesianSearch(origin=np.zeros(4), radius=0.2, final_radius=1e-3, period=1.0, seed=2), 80,
                    rotation=lambda x: 0.1 * x[3], known=known, bounds=bounds, rotation_limit=0.005)
    points = np.array(search.points)
    assert np.all(points[:, 2] <= 0.5 + 1e-12)
    assert np.all([known(p)[0] <= 1e-12 for p in points])
    best = points[int(np.argmax(search.values))]
    assert best[2] == pytest.approx(0.5, abs=0.02) and np.hypot(best[0], best[1]) == pytest.approx(0.2, abs=0.01)
    assert abs(0.1 * best[3]) <= 0.005 * 1.05
    assert np.mean(np.abs(0.1 * points[10:, 3]) > 0.0075) < 0.2  # it rarely proposes a clear break of the limit


def test_a_search_restored_from_its_checkpoint_proposes_what_the_original_would():
    search = _drive(BayesianSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-3, period=2.0, seed=7), 12)
    metadata, arrays = search.to_checkpoint("s")
    restored = BayesianSearch.from_checkpoint(metadata, arrays, "s")
    np.testing.assert_array_equal(restored.ask(), search.ask())


def _history(steps):
    values = [0.0]
    for step in steps:  # an improvement clears the best by 1, a failure falls 1 below it
        values.append(max(values) + 1 if step > 0 else max(values) - 1)
    return BayesianSearch(origin=np.zeros(8), radius=1.0, final_radius=1e-9, period=1.0,
                          points=[np.zeros(8)] * len(values), values=values, rotations=[0.0] * len(values))


@pytest.mark.parametrize(("steps", "width"), [
    ([1, 1], 1.0), ([1, 1, 1], 2.0), ([1] * 6, 4.0), ([1] * 30, 4.0),  # three successes double it, up to 4×
    ([-1] * 3, 1.0), ([-1] * 4, 0.5), ([-1] * 12, 0.125),  # patience max(4, 8 / 2) = 4 failures halve it
    ([1, 1, -1, 1, 1, -1], 1.0),  # a failure breaks the run of successes
    ([-1, -1, -1, 1, -1, -1, -1], 1.0),  # and a success the run of failures
])
def test_the_half_width_follows_the_trust_region_rule(steps, width):
    assert _history(steps).half_width() == width


@settings(max_examples=50, deadline=None)
@given(st.lists(st.sampled_from([-1, 1]), min_size=1, max_size=60))
def test_the_half_width_stays_within_its_range_and_only_successes_widen_it(steps):
    widths = [_history(steps[:k]).half_width() for k in range(len(steps) + 1)]
    assert all(0 < w <= 4.0 for w in widths)
    for k in range(1, len(steps) + 1):
        if widths[k] > widths[k - 1]:
            assert steps[k - 3:k] == [1, 1, 1]
