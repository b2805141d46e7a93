"""COBYQA one measured point at a time (geogait.optimize._search)."""

import numpy as np
import pytest
from scipy.optimize import NonlinearConstraint, minimize

from geogait.optimize._search import QuadraticSearch

WEIGHTS = np.array([1.0, 3.0, 0.5, 2.0])
OPTIMUM = np.array([0.4, -0.3, 0.8, 0.1])


def _objective(x):  # to maximise: a tilted quadratic bowl, its top at OPTIMUM
    return -float(np.sum(WEIGHTS * (x - OPTIMUM) ** 2)) + 0.3 * float((x[0] - OPTIMUM[0]) * (x[1] - OPTIMUM[1]))


def _drive(search, n, **constraints):
    for _ in range(n):
        point = search.ask(**constraints)
        if point is None:
            break
        search.tell(point, _objective(point), 0.0)
    return search


def test_one_point_at_a_time_asks_exactly_what_scipys_own_run_evaluates():
    """The replayed search proposes the same points, in the same order, as scipy's COBYQA run on the same
    function in one call (an independent run of the method)."""
    evaluated = []

    def fun(x):
        evaluated.append(np.array(x, copy=True))
        return -_objective(x)

    minimize(fun, np.zeros(4), method="COBYQA",
             options={"initial_tr_radius": 0.3, "final_tr_radius": 1e-4, "maxfev": 25})
    search = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-4, period=1.0), 25)
    np.testing.assert_allclose(np.array(search.points), np.array(evaluated[:25]), rtol=0, atol=1e-12)


def test_it_finds_the_top_of_a_quadratic_in_few_evaluations_and_then_stops():
    search = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-6, period=1.0), 200)
    best = search.points[int(np.argmax(search.values))]
    np.testing.assert_allclose(best, OPTIMUM, atol=1e-3)
    assert len(search.values) < 80  # an evolution strategy needs hundreds here
    assert search.ask() is None  # converged at its final radius: it asks for nothing more


def test_known_limits_and_bounds_are_passed_to_cobyqa():
    """With x₀² + x₁² ≤ 0.04 (a limit computed, not measured; the optimum lies outside it) and x₂ in
    [−1, 0.5], the search ends on the limit and keeps the bounds at every point it asks for."""
    def known(x):
        return np.array([x[0] ** 2 + x[1] ** 2 - 0.04])

    bounds = [(-np.inf, np.inf), (-np.inf, np.inf), (-1.0, 0.5), (-np.inf, np.inf)]
    search = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-6, period=1.0), 200,
                    known=known, bounds=bounds)
    points = np.array(search.points)
    assert np.all(points[:, 2] <= 0.5 + 1e-12)
    values = [v if known(p)[0] <= 1e-6 else -np.inf for p, v in zip(points, search.values, strict=True)]
    best = points[int(np.argmax(values))]
    assert np.hypot(best[0], best[1]) == pytest.approx(0.2, abs=1e-3) and best[2] == pytest.approx(0.5, abs=1e-3)


def test_a_known_limit_is_computed_once_per_point_although_every_replay_asks_again():
    """Each replay re-runs COBYQA over every point so far and asks the known limit again at each; the search
    computes it once per distinct point (the rest of a replay costs milliseconds, the limit may not: a robot's
    feasible region), and still proposes what scipy's own single run with the same limit evaluates."""
    def limit(x):
        return np.array([x[0] ** 2 + x[1] ** 2 - 0.04])

    calls = []

    def known(x):
        calls.append(np.array(x, copy=True))
        return limit(x)

    evaluated = []

    def fun(x):
        evaluated.append(np.array(x, copy=True))
        return -_objective(x)

    minimize(fun, np.zeros(4), method="COBYQA", constraints=[NonlinearConstraint(limit, -np.inf, 0.0)],
             options={"initial_tr_radius": 0.3, "final_tr_radius": 1e-4, "maxfev": 30})
    search = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-4, period=1.0), 30,
                    known=known)
    np.testing.assert_allclose(np.array(search.points), np.array(evaluated[:30]), rtol=0, atol=1e-12)
    distinct = {point.tobytes() for point in calls}
    assert len(calls) == len(distinct) <= len(search.points) + 1


def test_a_measured_rotation_limit_keeps_the_search_off_turning_points():
    """A rotation per cycle of 2·x₃ limited to 0.1: the best feasible point has x₃ = 0.05, not the 0.1
    the objective alone would choose."""
    search = QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-6, period=1.0)
    for _ in range(200):
        point = search.ask(rotation_limit=0.1)
        if point is None:
            break
        search.tell(point, _objective(point), 2 * point[3])
    feasible = [(v, p) for p, v, r in zip(search.points, search.values, search.rotations, strict=True)
                if abs(r) <= 0.1 + 1e-6]
    best = max(feasible, key=lambda item: item[0])[1]
    assert best[3] == pytest.approx(0.05, abs=2e-3)


def test_a_checkpoint_round_trip_asks_for_the_same_next_point():
    search = _drive(QuadraticSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-6, period=2.0), 12)
    metadata, arrays = search.to_checkpoint("climb/search")
    restored = QuadraticSearch.from_checkpoint(metadata, arrays, "climb/search")
    assert restored.period == 2.0
    np.testing.assert_array_equal(restored.ask(), search.ask())


def test_the_initial_design_is_the_origin_and_one_radius_along_each_coordinate_then_model_steps():
    """``designing`` marks COBYQA's initial design: its first 2n + 1 points are the origin and the origin ±
    radius along one coordinate (the method's published start), every later point a step of its model."""
    search = QuadraticSearch(origin=np.full(4, 0.2), radius=0.3, final_radius=1e-4, period=1.0)
    for _ in range(2 * 4 + 1):
        point = search.ask()
        offset = point - search.origin
        assert np.count_nonzero(offset) <= 1 and np.abs(offset).max() in (0.0, pytest.approx(0.3))
        search.tell(point, _objective(point), 0.0)
        assert search.designing
    point = search.ask()
    search.tell(point, _objective(point), 0.0)
    assert not search.designing


def test_a_gait_beyond_the_joint_limit_is_scaled_back_onto_it():
    """onto_joint_limit shrinks every parameter by one factor until the largest joint angle is the limit (the
    gait's shape kept); a gait within the limit is left as it is."""
    from geogait.gaits import FreeGaitFamily
    from geogait.optimize._search import onto_joint_limit

    family = FreeGaitFamily(3, 1)
    params = np.random.default_rng(4).normal(size=family.n_params)
    reach = family.gait(params).joint_limit().max()
    scaled = onto_joint_limit(family, params, 0.5 * reach)
    assert scaled.joint_limit().max() == pytest.approx(0.5 * reach, rel=1e-5)
    np.testing.assert_allclose(family.params_of(scaled), 0.5 * params, rtol=1e-5)
    np.testing.assert_array_equal(onto_joint_limit(family, params, 2 * reach).params, family.gait(params).params)
