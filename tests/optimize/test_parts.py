"""The contract every optimiser part keeps (scikit-learn's estimator contract, as pysindy's and optuna's parts do):
parameters only, cloned and compared by value, nested parameters through the optimiser, described as JSON and
rebuilt from it, checked before any robot moves; and the presets, explicit and printable."""

import json

import numpy as np
import pytest
from sklearn.base import clone

from geogait.gaits import seed_gait
from geogait.models import BatchGaitModel, ResistanceModel
from geogait.optimize import (
    Climb,
    EvolutionStrategy,
    Exploration,
    Gate,
    InSituOptimizer,
    Limits,
    ModelClassTest,
    ModelStep,
    Objective,
    PeriodSearch,
    Safety,
    StructureCheck,
    default,
    for_robot,
    paper_loop,
    prior_work,
    structured,
)
from geogait.optimize._state import params_from_json
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

PARTS = [Gate(gamma_threshold=0.4), ModelStep(trust_radius=0.05, rule="sqp"), Climb(start="stalled", rule="es"),
         Safety(settle_cycles=2), Limits(max_joint_angle=1.5), Objective(kind="forward", direction=[1.0, 0.0]),
         PeriodSearch(period_range=(0.5, 2.0)), Exploration(std=0.1), EvolutionStrategy(shrink=0.8),
         Climb(rule=EvolutionStrategy(growth=2.0)), ModelClassTest(cycles=4),
         StructureCheck(limit=0.2, step=ModelStep(), climb=False)]


@pytest.mark.parametrize("part", PARTS, ids=lambda p: type(p).__name__)
def test_every_part_keeps_the_estimator_contract(part):
    copy = clone(part)
    assert copy is not part and copy == part and repr(copy) == repr(part)
    assert copy.get_params() == part.get_params() or isinstance(part, Objective | StructureCheck)
    json.dumps(part.describe())  # JSON values
    first = next(iter(part.get_params(deep=False)))
    with pytest.raises(ValueError, match=f"'{first}' parameter of {type(part).__name__}"):
        clone(part).set_params(**{first: "not a value"}).validate()
    assert part.validate() is part


def test_an_optimiser_of_parts_round_trips_through_its_description():
    optimizer = InSituOptimizer(model=BatchGaitModel(), gate=Gate(kind="cycles"), climb=False, checks=PARTS[-2:],
                                step=PARTS[1], safety=PARTS[3], limits=PARTS[4], objective=PARTS[5],
                                period=PARTS[6], exploration=PARTS[7])
    described = json.loads(json.dumps(optimizer.describe()))
    rebuilt = InSituOptimizer(**params_from_json(described))
    assert rebuilt.describe() == described and rebuilt.checks == PARTS[-2:]
    assert len(InSituOptimizer().get_params(deep=False)) <= 13


def test_nested_parameters_reach_the_parts_and_the_optimiser_never_shares_a_default():
    optimizer = default(step__trust_radius=0.05, climb__start="contradicted")
    assert optimizer.step.trust_radius == 0.05 and optimizer.climb.start == "contradicted"
    assert default().step is not default().step
    bare = InSituOptimizer()
    assert bare.composition().step is not InSituOptimizer().composition().step
    assert bare.step is None  # a default is made at run time; the parameter stays as given


def test_the_presets_are_explicit_and_differ_where_their_papers_do():
    for preset in (default(), paper_loop(), prior_work(), structured(ResistanceModel.from_swimmer(PurcellSwimmer(3)))):
        assert None not in (preset.gate, preset.step, preset.safety, preset.limits, preset.objective)
        assert all(f"{name}=" in repr(preset) for name in ("gate", "step", "safety", "limits", "objective"))
    assert paper_loop().climb is False and paper_loop().safety.revert_tolerance is None
    assert paper_loop().exploration is None and default().exploration == "auto"
    assert prior_work().gate.kind == "cycles" and isinstance(prior_work().model, BatchGaitModel)
    assert prior_work().climb is False
    robot = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    assert for_robot(robot).describe() == default().describe()  # declares no resistive chain


def test_an_explicit_part_is_never_rewritten_by_a_run():
    step = ModelStep(rule="sqp", trust_radius=0.25, min_trust_radius=0.25, max_trust_radius=0.5)
    optimizer = InSituOptimizer(step=step, climb=False)
    before = optimizer.describe()
    optimizer.run(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0, sensor_noise=0.1), 6)
    assert optimizer.describe() == before and optimizer.step is step


def test_bad_parts_are_named_before_the_robot_moves():
    robot = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    for optimizer, match in ((InSituOptimizer(step=Gate()), "'step' parameter of InSituOptimizer must be a ModelStep"),
                             (InSituOptimizer(step=ModelStep(trust_radius=-1)), "'trust_radius'"),
                             (InSituOptimizer(gate=Gate(kind="gamma"), model=BatchGaitModel()),
                              "Gate\\(kind='gamma'\\)"),
                             (InSituOptimizer(period=PeriodSearch(period_range=(2, 1))), "'period_range'")):
        with pytest.raises(ValueError, match=match):
            optimizer.run(robot, 3)
    assert robot.cycle == 0


def _run_states():
    """One run state of each part that keeps one, part way through (what a checkpoint holds)."""
    from geogait.optimize._adaptation import ChangeWatch
    from geogait.optimize._bayes import BayesianSearch
    from geogait.optimize._evolution import EvolutionSearch
    from geogait.optimize._model_class import ModelClassCheck
    from geogait.optimize._period import PeriodLineSearch
    from geogait.optimize._search import QuadraticSearch

    rng = np.random.default_rng(0)
    searches = [QuadraticSearch(origin=np.zeros(3), radius=0.3, final_radius=1e-3, period=1.0),
                BayesianSearch(origin=np.zeros(3), radius=0.3, final_radius=1e-3, period=1.0, seed=4),
                EvolutionSearch(origin=np.zeros(3), radius=0.3, final_radius=1e-3, period=1.0, max_radius=1.0)]
    for search in searches:
        search.tell(search.origin, 0.0, 0.0)
        for _ in range(4):
            point = search.ask(rng=rng)
            search.tell(point, -float(np.sum((point - 0.2) ** 2)), 0.01, kept=bool(rng.random() < 0.5))
    period = PeriodLineSearch(0.5, 2.0)
    period.propose(1.0)
    watch = ChangeWatch(since_check=3, suspect=[4, 2, 5, True], events=[{"cycle": 7}], turning=1,
                        residuals=[0.01, -0.02], surprise=1, noise_ss=0.5, noise_dof=9)
    check = ModelClassCheck(1.0, 2.0, 3, settle_cycles=1)
    return [("search", s) for s in searches] + [("period", period), ("watch", watch), ("model class", check)]


@pytest.mark.parametrize(("kind", "state"), _run_states(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_parts_run_state_round_trips_its_checkpoint(kind, state):
    """A resumed run continues from the same state: written as JSON values and arrays, read back equal."""
    from geogait.optimize._adaptation import ChangeWatch
    from geogait.optimize._model_class import ModelClassCheck
    from geogait.optimize._period import PeriodLineSearch
    from geogait.optimize._search import MeasuredSearch

    if kind == "search":
        metadata, arrays = state.to_checkpoint("climb/search")
        restored = MeasuredSearch.from_checkpoint(json.loads(json.dumps(metadata)), arrays, "climb/search")
        assert type(restored) is type(state)
        rng, twin = np.random.default_rng(5), np.random.default_rng(5)
        np.testing.assert_array_equal(restored.ask(rng=twin), state.ask(rng=rng))
    elif kind == "model class":
        metadata, arrays = state.to_checkpoint()
        restored = ModelClassCheck.from_checkpoint(json.loads(json.dumps(metadata)), arrays)
        assert restored.to_checkpoint()[0] == metadata
    else:
        kind_class = PeriodLineSearch if kind == "period" else ChangeWatch
        restored = kind_class.from_json(json.loads(json.dumps(state.to_json())))
        assert restored.to_json() == state.to_json()


def test_a_runs_setup_reads_only_the_spec_and_a_stub_spec_is_enough():
    """What a run fixes before its first cycle comes from what the robot declares (a RobotSpec), nothing else."""
    from geogait.gaits import FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily
    from geogait.optimize._setup import gait_family, joint_limit, period_range, settle_at_start
    from geogait.robots import RobotSpec

    gait = seed_gait(2)
    bare = RobotSpec(kind="Stub", n_joints=2, cycle_period=1.0, symmetry_declared=False)
    declared = RobotSpec(kind="Stub", n_joints=2, cycle_period=1.0, joint_ranges=np.array([[-1.0, 1.2], [-1.5, 0.9]]),
                         front_back_symmetric=True, mirror_symmetric=True, period_control=True, settle_cycles=2)
    assert isinstance(gait_family(InSituOptimizer(), declared, gait), SymmetricGaitFamily)
    assert isinstance(gait_family(InSituOptimizer(), bare, gait), MirrorGaitFamily)  # measured: on trial
    assert isinstance(gait_family(InSituOptimizer(checks=[]), bare, gait), FreeGaitFamily)
    assert joint_limit(Limits(), declared) == 0.9 and joint_limit(Limits(), bare) == pytest.approx(2 * np.pi / 3)
    assert settle_at_start(Safety(), declared) == 2 and settle_at_start(Safety(), bare) == 0
    assert period_range(PeriodSearch(), declared, 1.0, "test") == (0.5, 2.0)
    with pytest.raises(ValueError, match="set_cycle_period"):
        period_range(PeriodSearch(), bare, 1.0, "test")
