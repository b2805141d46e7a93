"""The Climb part: steps from measured outcomes where the model does not deliver. When it starts (``"first"``, the
default, climbs from the first gate decision without a confident model; ``"stalled"`` where the model levels off or
its promises break; ``"contradicted"`` only where measurements contradict the model), what its search rules command
(COBYQA's initial design, Bayesian candidates moving every parameter, ``"auto"`` picking between them; a point
beyond the joint limit scaled back onto it), how it judges rotation in a rotation-free family, and when it hands
the steps back to a model that predicts its own steps."""

import numpy as np
import pandas as pd
import pytest
from _robots import LaggingRobot
from _robots import MisleadingPoses as _MisleadingPoses

from geogait.gaits import FourierGait, seed_gait
from geogait.optimize import Climb, Gate, InSituOptimizer, Limits, Safety
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


def test_the_climb_takes_over_from_a_model_that_leads_downhill_and_keeps_the_limits():
    """Without the revert, the model's unconfirmed promises hand the steps to the measured climb, which
    keeps the best gait measured (the robot's motion shrinks away from the seed gait)."""
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.05, seed=6)
    result = InSituOptimizer(safety=Safety(revert_tolerance=None), limits=Limits(max_joint_angle=1.2),
                             family="free").run(
        _MisleadingPoses(stream, seed_gait(2)), 40)
    log = result.log
    assert log["climb"].sum() >= 3 and not (log["climb"] & log["period_change"]).any()
    measured = log[~log["settling"]].groupby("iteration")["measured_objective"].mean()
    final = np.all(np.isclose(log.filter(like="param_").to_numpy(), result.final_gait.params), axis=1)
    assert log.loc[final, "measured_objective"].mean() >= 0.8 * measured.max()  # the result: the best measured
    assert result.summary()["final_measured_objective"] >= 0.8 * measured.max()
    assert max(gait.joint_limit().max() for gait in result.gaits) <= 1.2 + 1e-9
    # the same seed repeats the run exactly; another seed draws other directions
    again = InSituOptimizer(safety=Safety(revert_tolerance=None), limits=Limits(max_joint_angle=1.2),
                            family="free").run(
        _MisleadingPoses(SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.05, seed=6), seed_gait(2)), 40)
    pd.testing.assert_frame_equal(again.log, log)


def test_the_climb_carries_on_where_the_model_levels_off():
    """On the built-in 5-link swimmer the model's steps level off short of the ceiling; three gate
    decisions without a step promising 1 % hand the steps to the measured climb (clean candidates:
    the optimiser stops exploring), which ends above where the model stopped."""
    from geogait.optimize import cached_ceiling

    swimmer = PurcellSwimmer(5)
    result = InSituOptimizer(climb=Climb(start="stalled")).run(SwimmerStream(swimmer, seed_gait(4), sensor_noise=0.1,
                                                                             seed=1), 60)
    log = result.log
    first = log.index[log["climb"]][0]
    ceiling = cached_ceiling(swimmer, family="symmetric").value
    levelled = log.loc[first, "true_objective"] / ceiling
    final = np.hypot(*cycle_displacement(swimmer, result.final_gait)[:2]) / ceiling
    assert 0.9 < levelled < 0.99 and final > levelled + 0.005
    assert log.loc[first + 1:, "excitation"].median() < 1e-12  # climb cycles run clean
    assert not (log.loc[:first - 1, "climb"]).any()


def test_a_contradicted_climb_leaves_a_model_that_levels_off_at_its_optimum():
    """Climb(start="contradicted"): the measured climb starts only when measured outcomes contradict the model. The
    perfect-information model levels off at the optimum without being contradicted: with start="stalled" the steps
    pass to the climb (measured: at cycle 20 of 30), with "contradicted" they never do."""
    from geogait.models import PerfectInformationModel

    logs = {}
    for start in ("stalled", "contradicted"):
        stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=1)
        model = PerfectInformationModel(system=stream.current_system())
        logs[start] = InSituOptimizer(climb=Climb(start=start), model=model).run(stream, 30).log
    assert logs["stalled"]["climb"].any() and not logs["contradicted"]["climb"].any()
    assert logs["contradicted"]["step"].sum() >= 5  # the model's own steps carried it


def test_climb_first_climbs_from_the_first_decision_and_hands_over_to_a_model_that_predicts():
    """Climb(start="first"): the first gate decision commands a climb candidate at its first_sigma
    from the seed (nothing else moved the gait before it); a model that predicts the measured gains (the
    perfect-information model) then takes the steps back, and the run still beats its seed."""
    from geogait.gaits import SymmetricGaitFamily
    from geogait.models import PerfectInformationModel

    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=1)
    optimizer = InSituOptimizer(model=PerfectInformationModel(system=stream.current_system()))
    result = optimizer.run(stream, 40)
    log = result.log
    params = log.filter(like="param_").to_numpy()
    moved = np.flatnonzero(np.any(params != params[0], axis=1))[0]  # the first cycle off the seed gait
    assert log.loc[moved - 1, "climb"]  # the climb moved it, and no model step before
    assert log.loc[:moved - 1, "step"].sum() == log.loc[:moved - 1, "climb"].sum()
    family = SymmetricGaitFamily.from_gait(seed_gait(2))
    first = family.params_of(FourierGait.from_params(params[moved], 2))
    distance = np.linalg.norm(first - family.params_of(seed_gait(2)))
    assert distance == pytest.approx(Climb().first_sigma)
    changed = log.index[log["climb"]]
    handed_back = log.index[log["step"] & ~log["climb"]]
    assert len(handed_back) and handed_back[0] > changed[0]  # model steps, after the climb
    assert log["true_objective"].iloc[-1] > 1.2 * log["true_objective"].iloc[0]


def test_the_cobyqa_climb_commands_cobyqas_points_within_the_limits_and_hands_over_its_best():
    """Climb(rule="cobyqa") in the free family: from the first gate decision the candidates are COBYQA's own
    initial design (the base, then the base ± σ along each family parameter in turn: the method's published
    start), every commanded gait keeps the joint limit, and the result is the best candidate measured,
    well above the seed (the 3-link swimmer, measured with little noise)."""
    from geogait.gaits import FreeGaitFamily

    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.01, seed=3)
    optimizer = InSituOptimizer(climb=Climb(rule="cobyqa"), limits=Limits(max_joint_angle=1.5), family="free")
    result = optimizer.run(stream, 60)
    log = result.log
    family = FreeGaitFamily(2, 1)
    params = log.filter(like="param_").to_numpy()
    changes = np.flatnonzero(np.any(np.diff(params, axis=0) != 0, axis=1)) + 1
    base = family.params_of(seed_gait(2))
    sigma = Climb().first_sigma * result.shape_scale
    offsets = [params[k] - base for k in changes[:4]]  # the base first: measured once more, clean
    expected = [sigma * np.eye(base.size)[i] for i in range(4)]
    first_candidate = 0 if np.allclose(offsets[0], expected[0]) else 1
    for offset, step in zip(offsets[first_candidate:], expected, strict=False):
        np.testing.assert_allclose(offset, step, atol=1e-9)
    assert max(gait.joint_limit().max() for gait in result.gaits) <= 1.5 + 1e-9
    # the result is the best candidate that kept its rotation (a straight one beats it by under 5 %)
    final = np.all(np.isclose(params, result.final_gait.params), axis=1)
    straight = log["excitation"].eq(0) & (log["measured_heading"].abs() < 0.002)
    assert log.loc[final, "measured_objective"].max() >= 0.95 * log.loc[straight, "measured_objective"].max()
    seed_value = np.hypot(*cycle_displacement(PurcellSwimmer(3), seed_gait(2))[:2])
    assert np.hypot(*cycle_displacement(PurcellSwimmer(3), result.final_gait)[:2]) > 1.3 * seed_value


def test_the_bayesian_climb_moves_every_parameter_at_once_within_the_limits_and_climbs():
    """Climb(rule="bayes") in the free family: its candidates move several parameters at once (COBYQA's first
    2n + 1 move one), every commanded gait keeps the joint limit, and after 40 cycles the result is well above
    the seed (the 3-link swimmer, measured with little noise)."""
    from geogait.gaits import FreeGaitFamily

    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.01, seed=3)
    optimizer = InSituOptimizer(climb=Climb(rule="bayes"), limits=Limits(max_joint_angle=1.5), family="free")
    result = optimizer.run(stream, 40)
    params = result.log.filter(like="param_").to_numpy()
    base = FreeGaitFamily(2, 1).params_of(seed_gait(2))
    moved = [np.sum(~np.isclose(p, base, atol=1e-9)) for p in np.unique(params, axis=0)]
    assert sorted(moved)[-3] >= 3
    assert max(gait.joint_limit().max() for gait in result.gaits) <= 1.5 + 1e-9
    seed_value = np.hypot(*cycle_displacement(PurcellSwimmer(3), seed_gait(2))[:2])
    assert np.hypot(*cycle_displacement(PurcellSwimmer(3), result.final_gait)[:2]) > 1.2 * seed_value


@pytest.mark.parametrize(("n", "settle", "rule"), [(10, 1, "bayes"), (8, 1, "bayes"), (7, 1, "cobyqa"),
                                                    (12, 0, "cobyqa"), (15, 0, "bayes"), (4, 2, "cobyqa")])
def test_the_automatic_climb_rule_is_bayesian_where_cobyqas_design_takes_more_than_thirty_cycles(n, settle, rule):
    """(2n + 1)(settle + 1) cycles before COBYQA's first step of its own: 42, 34, 30, 25, 31 and 27 here."""
    from geogait.optimize._climb import climb_rule_for

    assert climb_rule_for("auto", n, settle) == rule
    assert climb_rule_for("cobyqa", n, settle) == "cobyqa" and climb_rule_for("es", 40, 3) == "es"


def test_in_a_rotation_free_family_the_climb_judges_rotation_against_the_noise_of_its_own_cycles():
    """The climb's rotation limit (the start base's) is at least twice the RMS rotation of its clean cycles
    in a rotation-free family, where a single cycle's rotation is noise; in the free family it is not."""
    from types import SimpleNamespace

    from geogait.gaits import FreeGaitFamily, MirrorGaitFamily
    from geogait.optimize._climb import MeasuredClimb
    from geogait.optimize._loop import CycleLoop

    rng = np.random.default_rng(0)
    climb = MeasuredClimb(sigma=0.1, min_sigma=0.01, max_sigma=0.4, rotation_limit=1e-3)
    noise = 0.004
    for k in range(30):  # thirty other gaits measured once each: rotation noise 0.004 rad per cycle
        climb.record((k, 1.0), 0.1, float(rng.normal(0, noise)))
    climb.record(("turning", 1.0), 0.2, 0.05)
    climb.record(("noisy", 1.0), 0.2, 0.006)
    loop = CycleLoop.__new__(CycleLoop)
    loop.state = SimpleNamespace(climb=climb, family=MirrorGaitFamily(2, 1))
    assert loop._rotation_holds(("noisy", 1.0), None)  # 1.5 σ: noise
    assert not loop._rotation_holds(("turning", 1.0), None)  # far outside the spread
    loop.state.family = FreeGaitFamily(2, 1)
    assert not loop._rotation_holds(("noisy", 1.0), None)  # the free family: the start base's limit


def test_the_climb_hands_back_only_on_the_model_predicting_its_own_steps():
    """Agreement of the model with a probe of COBYQA's initial design is not counted towards handing the
    steps back, and a disagreement there does not break a run of agreements either."""
    from geogait.optimize._climb import MeasuredClimb

    climb = MeasuredClimb(sigma=0.1, min_sigma=0.01, max_sigma=0.3)
    for tests_model, predicted, expected in ((True, 0.1, 1), (False, 0.1, 1), (False, -0.1, 1), (True, 0.1, 2),
                                             (True, -0.1, 0)):
        climb.predicted_gain = predicted
        climb.judge(1.1, 1.0, True, tests_model=tests_model)  # measured gain 0.1
        assert climb.agreements == expected
    for _ in range(3):
        climb.predicted_gain = 0.1
        climb.judge(1.1, 1.0, True)
    assert climb.model_trusted_again


def test_climb_first_is_the_default_and_needs_no_confident_model():
    """By default the climb starts at the first decision, after min_cycles_per_iteration measured cycles of
    the seed, even where the model's Γ never reaches Γ* (here Γ* = 0.999 against 10 % sensor noise)."""
    assert InSituOptimizer().composition().climb == Climb(start="first")
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=2)
    log = InSituOptimizer(gate=Gate(gamma_threshold=0.999)).run(stream, 8).log
    assert (log["gamma"].dropna() < 0.999).all()
    assert log["climb"].iloc[1] and not log["climb"].iloc[0]  # the base, measured again clean, then COBYQA
    assert log["excitation"].iloc[3:].max() < 1e-12 and log["step"].sum() >= 4


def test_a_cobyqa_point_beyond_the_joint_limit_runs_scaled_back_onto_it():
    """Near the limit COBYQA's first probes (base + σ along one parameter) reach past it: each is commanded with
    its amplitude scaled back until its largest joint angle is the limit, the same gait shape."""
    from geogait.gaits import FreeGaitFamily

    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.01, seed=3)
    optimizer = InSituOptimizer(climb=Climb(rule="cobyqa"), limits=Limits(max_joint_angle=1.02), family="free")
    result = optimizer.run(stream, 10)
    family = FreeGaitFamily(2, 1)
    base = family.params_of(seed_gait(2))
    sigma = Climb().first_sigma * result.shape_scale
    probes = [base + sign * sigma * np.eye(base.size)[i] for i in range(base.size) for sign in (1, -1)]
    beyond = 0
    for gait in result.gaits[1:]:
        ran = family.params_of(gait)
        if np.allclose(ran, base):
            continue
        asked = next(p for p in probes if abs(_cosine(ran, p) - 1) < 1e-9)  # the same shape as a probe
        if family.gait(asked).joint_limit().max() > 1.02:  # beyond the limit: run on it
            beyond += 1
            assert gait.joint_limit().max() == pytest.approx(1.02, rel=1e-5)
        else:
            np.testing.assert_allclose(ran, asked, atol=1e-12)
    assert beyond >= 1


def _cosine(a, b):
    return float(a @ b / np.linalg.norm(a) / np.linalg.norm(b))


@pytest.mark.parametrize("start", ["stalled", "contradicted"])
def test_model_steps_the_robot_cannot_follow_hand_the_steps_to_the_measured_climb(start):
    """Joints that stop at 1.1 rad: the model (kinematic, no actuator limits) keeps proposing larger gaits, which
    the robot cannot follow and which do not gain what the model promised. Two such rejections without a kept
    promise between them are two broken promises: the climb takes over (before they counted, none had by cycle
    30)."""
    log = InSituOptimizer(climb=Climb(start=start), safety=Safety(settle_cycles=0)).run(  # (no settling probe)
        LaggingRobot(cycle_period=20.0, joint_stop=1.1, seed=1), 30).log
    assert log["climb"].any()
    first = int(np.flatnonzero(log["climb"])[0])
    assert log["rejected"][:first].sum() >= 2
