"""The climb's search rules as ask/tell parts: the evolution strategy on its own, a rule of one's own in a run, and
checkpoints of the strategy before it was a search of its own."""

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _robots import LaggingRobot

from geogait._files import read_state
from geogait.gaits import MirrorGaitFamily
from geogait.optimize import Climb, EvolutionStrategy, InSituOptimizer, SearchRule, onto_joint_limit
from geogait.optimize._evolution import EvolutionSearch
from geogait.optimize._search import MeasuredSearch
from geogait.optimize._state import CHECKPOINT_FORMAT, CHECKPOINT_VERSION, params_from_json

OPTIMUM = np.array([0.4, -0.3, 0.8, 0.1])
DATA = Path(__file__).parents[1] / "data"


def _value(x):  # to maximise: a bowl, its top at OPTIMUM
    return -float(np.sum((x - OPTIMUM) ** 2))


def _strategy(**settings):
    return EvolutionSearch(origin=np.zeros(4), radius=0.3, final_radius=1e-3, period=1.0, max_radius=1.0,
                           **settings)


def _climb(search, rng, n):
    """The climb's protocol: the base is the best kept point; a candidate is kept when it beats the base."""
    base = search.origin
    search.tell(base, _value(base), 0.0)
    for _ in range(n):
        point = search.ask(rng=rng)
        kept = _value(point) > _value(base)
        search.tell(point, _value(point), 0.0, kept)
        if kept:
            base = point
            search.recentre(point, 1.0)
    return base


def test_the_strategy_climbs_a_bowl_from_its_base():
    rng = np.random.default_rng(0)
    start = np.linalg.norm(OPTIMUM)
    best = _climb(_strategy(), rng, 150)
    assert np.linalg.norm(best - OPTIMUM) < 0.05 * start


def test_sigma_grows_on_success_shrinks_on_failure_and_a_failed_direction_is_mirrored():
    rng = np.random.default_rng(1)
    search = _strategy()
    search.tell(search.origin, 0.0, 0.0)
    first = search.ask(rng=rng)
    direction = search.direction.copy()
    np.testing.assert_allclose(first, 0.3 * direction, rtol=0, atol=1e-15)
    search.tell(first, -1.0, 0.0, kept=False)
    assert search.sigma == pytest.approx(0.3 * 0.85) and search.mirror
    mirrored = search.ask(rng=rng)
    np.testing.assert_array_equal(search.direction, -direction)  # no draw: the opposite direction
    np.testing.assert_allclose(mirrored, -0.3 * 0.85 * direction, rtol=0, atol=1e-15)
    search.tell(mirrored, 1.0, 0.0, kept=True)
    assert search.sigma == pytest.approx(0.3 * 0.85 * 1.5) and not search.mirror
    search.sigma = 0.9
    search.tell(search.ask(rng=rng), 2.0, 0.0, kept=True)
    assert search.sigma == 1.0  # at most max_radius
    assert not np.allclose(np.abs(search.direction), np.abs(direction))  # after a success: a fresh draw


def test_a_refused_candidate_is_asked_again_shorter_until_the_direction_is_given_up():
    rng = np.random.default_rng(2)
    search = _strategy(shortenings=3)
    search.tell(search.origin, 0.0, 0.0)
    lengths = []
    for _ in range(3):
        lengths.append(np.linalg.norm(search.ask(rng=rng)))
        search.refuse(None)
    np.testing.assert_allclose(lengths, [0.3, 0.15, 0.075])
    assert search.ask(rng=rng) is None and not search.converged  # nothing to run this cycle; not converged
    assert search.sigma == pytest.approx(0.15)
    before = search.direction.copy()
    assert np.linalg.norm(search.ask(rng=rng)) == pytest.approx(0.15)
    assert not np.allclose(search.direction, before)  # a fresh direction at the halved step


def test_a_checkpointed_strategy_asks_what_the_original_would():
    rng = np.random.default_rng(3)
    search = _strategy(growth=1.3)
    _climb(search, rng, 12)
    search.refuse(search.ask(rng=rng))  # (a direction left open, at half length)
    metadata, arrays = search.to_checkpoint("climb/search")
    restored = MeasuredSearch.from_checkpoint(metadata, arrays, "climb/search")
    assert isinstance(restored, EvolutionSearch) and restored.growth == 1.3
    twin = np.random.default_rng()
    twin.bit_generator.state = rng.bit_generator.state
    for _ in range(3):
        np.testing.assert_array_equal(restored.ask(rng=twin), search.ask(rng=rng))
        restored.tell(restored.points[-1], 0.0, 0.0, False)
        search.tell(search.points[-1], 0.0, 0.0, False)


def test_a_rule_by_name_and_the_same_rule_as_a_part_run_alike():
    by_name = InSituOptimizer(climb=Climb(rule="es"), random_state=4).run(LaggingRobot(seed=4), 40).log
    as_part = InSituOptimizer(climb=Climb(rule=EvolutionStrategy()), random_state=4).run(LaggingRobot(seed=4), 40).log
    assert by_name["steps_by_climb"].iloc[-1] > 5
    assert by_name.equals(as_part)
    changed = InSituOptimizer(climb=Climb(rule=EvolutionStrategy(growth=3.0)), random_state=4).run(
        LaggingRobot(seed=4), 40).log
    assert not changed.filter(like="param_").equals(by_name.filter(like="param_"))


class _CoordinateSearch(MeasuredSearch):
    """A rule of one's own: ± a fixed step along one coordinate after another, from the best point told."""

    rule = "test-coordinates"

    def ask(self, bounds=None, known=None, rotation_limit=None, rng=None):
        best = self.points[int(np.argmax(self.values))]
        k = len(self.points) - 1
        step = np.zeros_like(best)
        step[(k // 2) % best.size] = self.radius * (1 if k % 2 == 0 else -1)
        return best + step


class _Coordinates(SearchRule):
    def search(self, origin, *, radius, final_radius, max_radius, period, rng):
        return _CoordinateSearch(origin=origin, radius=radius, final_radius=final_radius, period=period)


def test_a_rule_of_ones_own_proposes_the_climbs_candidates():
    asked = []
    original = _CoordinateSearch.ask

    def spy(self, *args, **kwargs):
        asked.append(original(self, *args, **kwargs))
        return asked[-1]

    _CoordinateSearch.ask = spy
    try:
        result = InSituOptimizer(climb=Climb(rule=_Coordinates()), random_state=5).run(LaggingRobot(seed=5), 30)
    finally:
        _CoordinateSearch.ask = original
    params = result.log.filter(like="param_").to_numpy()
    assert len(asked) >= 5 and result.summary()["steps_by_climb"] >= 5
    family = MirrorGaitFamily(2, 1)
    assert result.family == "mirror"
    for point in asked:  # every point asked ran as a gait (held to the joint limit)
        gait = onto_joint_limit(family, point, result.max_joint_angle)
        assert np.any(np.all(np.isclose(params, gait.params, rtol=0, atol=1e-12), axis=1))


def test_a_climb_with_a_rule_part_round_trips_through_its_description():
    optimizer = InSituOptimizer(climb=Climb(rule=EvolutionStrategy(shrink=0.8)))
    rebuilt = InSituOptimizer(**params_from_json(optimizer.describe()))
    assert rebuilt.climb == optimizer.climb and rebuilt.climb.rule.shrink == 0.8


def test_a_checkpoint_written_before_the_rules_were_parts_resumes_its_climb(tmp_path):
    """tests/data/es_climb_checkpoint_before_rules.npz was written at cycle 45 of this run by the code before the
    evolution strategy was a search of its own (its step length, mirror and direction in the climb's record). Resumed,
    its cycles are kept and its climb goes on from the strategy it held. (With the code of its day the resumed run
    was bit-identical to the uninterrupted one; later changes of the optimiser's behaviour move the cycles after
    the resume.)"""
    checkpoint = tmp_path / "run.npz"
    shutil.copy(DATA / "es_climb_checkpoint_before_rules.npz", checkpoint)
    metadata, arrays = read_state(checkpoint, "checkpoint", CHECKPOINT_FORMAT, CHECKPOINT_VERSION)
    kept = pd.DataFrame({column: arrays[f"log/{column}"] for column in metadata["state"]["log_columns"]})
    climb = metadata["state"]["climb"]
    assert climb["search"] is None and climb["active"]  # (the old layout: the strategy in the climb's record)
    resumed = InSituOptimizer.resume(checkpoint, LaggingRobot(seed=3), n_cycles=90).log
    assert len(resumed) == 90
    pd.testing.assert_frame_equal(resumed.iloc[:45][kept.columns].reset_index(drop=True), kept, check_dtype=False)
    assert resumed["steps_by_climb"].iloc[-1] > resumed["steps_by_climb"].iloc[44]  # the strategy climbs on


def test_a_run_with_a_rule_of_ones_own_resumes_from_its_checkpoint(tmp_path):
    optimizer = InSituOptimizer(climb=Climb(rule=_Coordinates()), random_state=6)
    whole = optimizer.run(LaggingRobot(seed=6), 30).log
    optimizer.run(LaggingRobot(seed=6), 15, checkpoint=tmp_path / "run.npz")
    resumed = InSituOptimizer.resume(tmp_path / "run.npz", LaggingRobot(seed=6), n_cycles=30).log
    assert resumed.reset_index(drop=True).equals(whole.reset_index(drop=True))
