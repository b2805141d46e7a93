"""Gait optimisation: the ceiling against brute force, the in-situ loop's guarantees."""

import numpy as np
import pandas as pd
import pytest
from _robots import MisleadingPoses as _MisleadingPoses

from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, seed_gait
from geogait.models import AdaptiveGaitModel, ShapeSpaceModel
from geogait.optimize import (
    Climb,
    Gate,
    InSituOptimizer,
    Limits,
    ModelClassTest,
    ModelStep,
    Objective,
    Safety,
)
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def noise_free_run():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=0)
    # the model steps first: the paper's loop
    return InSituOptimizer(climb=Climb(start="stalled")).run(stream, 25, record=True)


def test_optimiser_improves_the_seed_gait_on_a_noise_free_swimmer(noise_free_run):
    log = noise_free_run.log
    assert noise_free_run.n_steps >= 5
    assert log["improvement"].iloc[-1] > 0.5  # the ceiling is +97 %; the paper reports ≈ +50 % in 40 cycles
    assert log["true_objective"].iloc[-1] > log["true_objective"].iloc[0]
    assert noise_free_run.trajectory.n_samples == 25 * 100


def test_log_columns_and_gaits(noise_free_run):
    log = noise_free_run.log
    assert {"cycle", "gamma", "step", "trust_radius", "true_progress", "true_heading", "improvement",
            "param_0", "param_5"} <= set(log.columns)
    assert len(noise_free_run.gaits) == noise_free_run.n_steps + 1
    # the last gait commanded, unless the run ends on a climb candidate not yet judged: then its base
    final = noise_free_run.final_gait
    last_run = log.filter(like="param_").to_numpy()[-1]
    assert final == noise_free_run.gaits[-1] or (final in noise_free_run.gaits and not log["candidate"].iloc[-1]
                                                 and np.allclose(final.params, last_run))
    # A model step is only taken when the online Γ over the iteration reached Γ* (the climb's are not).
    model_steps = log["step"] & ~log["climb"] & ~log["period_change"]
    assert model_steps.any() and np.all(log.loc[model_steps, "gamma"] >= 0.5)


def test_result_carries_the_model_the_run_learned(noise_free_run):
    """In the symmetric family the default model is the symmetric shape-space model, and the model
    the run leaves predicts the final gait's motion."""
    model = noise_free_run.model
    assert isinstance(model, ShapeSpaceModel) and model.symmetry == "mirror+reversal"
    truth = cycle_displacement(PurcellSwimmer(3), noise_free_run.final_gait)[:2]
    seed = cycle_displacement(PurcellSwimmer(3), noise_free_run.initial_gait)[:2]
    predicted = model.predict_displacement(noise_free_run.final_gait)[:2]
    assert np.linalg.norm(truth) > 1.5 * np.linalg.norm(seed)  # the run moved far from the seed ...
    assert np.linalg.norm(predicted - truth) < 0.05 * np.linalg.norm(truth)  # ... and the model followed


def test_free_family_default_model_is_the_window_model_recentred_on_the_last_gait():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=0)
    result = InSituOptimizer(climb=Climb(start="stalled"), family="free").run(stream, 12)
    assert isinstance(result.model, AdaptiveGaitModel)
    assert result.model.forgetting_factor == pytest.approx(0.95)  # 1 − 0.1 / d for d = 2
    assert result.n_steps >= 1 and result.model.gait_ == result.final_gait  # re-centred on the last gait


def test_a_higher_order_family_starts_from_the_embedded_seed():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=2)
    result = InSituOptimizer(order=2).run(stream, 6)
    assert result.initial_gait.order == 2
    phase = np.linspace(0, 6, 7)
    np.testing.assert_allclose(result.initial_gait.shape(phase), seed_gait(2).shape(phase))


def test_a_seed_of_higher_order_than_the_family_is_refused_and_the_robot_left_as_it_was():
    """Cutting the seed's second harmonics (stored at order 3) would optimise another gait than the robot's; and a
    run refused by any check (here: a seed that does not move, which has no shape scale) commands nothing."""
    coefficients = np.zeros((2, 7))
    coefficients[0, 1], coefficients[1, 2], coefficients[0, 5] = 1.0, 1.0, 0.3
    seed = FourierGait(coefficients)
    stream = SwimmerStream(PurcellSwimmer(3), seed, seed=0)
    with pytest.raises(GeogaitError, match=r"'order' parameter .* highest harmonic of the robot's seed gait \(2\)"):
        InSituOptimizer().run(stream, 2)
    assert stream.gait == seed
    still = FourierGait(np.zeros((2, 3)))
    lifted = SwimmerStream(PurcellSwimmer(3), still, seed=0)
    with pytest.raises(GeogaitError, match="a seed gait that moves its joints"):
        InSituOptimizer(family="free", order=2).run(lifted, 2)
    assert lifted.gait == still and lifted.gait.order == 1
    assert InSituOptimizer(order=3).run(SwimmerStream(PurcellSwimmer(3), seed, seed=0), 2).initial_gait == seed


@pytest.mark.parametrize(
    ("params", "match"),
    [
        (dict(gate="newton"), "'gate'"),
        (dict(gate=Gate(kind="newton")), "'kind'"),
        (dict(model="adaptive"), "'model'"),
        (dict(objective=Objective(kind="forward", direction=[0, 0])), "'direction'"),
        (dict(safety=Safety(max_tracking_error=-1.0)), "'max_tracking_error'"),
        (dict(safety=Safety(settle_cycles=-1)), "'settle_cycles'"),
        (dict(gate=Gate(gamma_threshold=1.5)), "'gamma_threshold'"),
        (dict(objective="speedy"), "'objective'"),
        (dict(order=0), "'order'"),
        (dict(step=ModelStep(trust_radius=5.0)), "'trust_radius'"),
        (dict(step=ModelStep(rebase="first")), "'rebase'"),
        (dict(climb="first"), "'climb'"),
        (dict(climb=Climb(min_sigma=1.0, max_sigma=0.5)), "'max_sigma'"),
        (dict(exploration=0.2), "'exploration'"),
        (dict(checks=[ModelClassTest(), ModelClassTest()]), "'checks'"),
        (dict(checks=[Gate()]), "'checks'"),
    ],
)
def test_bad_optimizer_parameters(params, match):
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    with pytest.raises(ValueError, match=match):
        InSituOptimizer(**params).run(stream, 2)


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
