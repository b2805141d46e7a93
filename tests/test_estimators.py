"""The estimator contract (geogait._estimator), checked on every estimator geogait ships.

scikit-learn's own ``clone`` is the reference for the parameter protocol; the rest is geogait's
contract: fit returns self, save → load → predict is identical, predicting changes nothing, and a bad
hyper-parameter raises the one error template before any state changes.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from _reference import GAIT, SWIMMER
from sklearn.base import clone

from geogait import GeogaitError
from geogait._estimator import Boolean, InstanceOf, Integer, Options, Real
from geogait.control import AdaptiveExploration, PathTracker
from geogait.models import (
    AdaptiveGaitModel,
    BatchGaitModel,
    PerfectInformationModel,
    PhaseModel,
    ResistanceModel,
    ShapeSpaceModel,
    load_model,
)
from geogait.optimize import Gate, InSituOptimizer, ModelStep
from geogait.phase import Phaser
from geogait.simulate import simulate

RUN = simulate(SWIMMER, GAIT, n_cycles=12, samples_per_cycle=60, sensor_noise=0.05, seed=3)
HELD_OUT = simulate(SWIMMER, GAIT, n_cycles=2, samples_per_cycle=60, sensor_noise=0.05, seed=4)

# name → factory; the kind says which data the estimator learns from
ESTIMATORS = {
    "adaptive": (lambda: AdaptiveGaitModel(gait=GAIT, forgetting_factor=0.98), "gait model"),
    "adaptive, gait estimated": (lambda: AdaptiveGaitModel(n_windows=16, smoothing_order=3), "gait model"),
    "batch": (lambda: BatchGaitModel(gait=GAIT), "gait model"),
    "shape space": (lambda: ShapeSpaceModel(degree=2), "gait model"),
    "shape space, symmetric": (lambda: ShapeSpaceModel(degree=3, symmetry="mirror+reversal"), "gait model"),
    "perfect information": (lambda: PerfectInformationModel(system=SWIMMER), "gait model"),
    "resistance": (lambda: ResistanceModel.from_swimmer(SWIMMER), "gait model"),
    "resistance hybrid": (lambda: ResistanceModel.from_swimmer(SWIMMER, residual_degree=2), "gait model"),
    "phase model": (lambda: PhaseModel(n_windows=12, forgetting_factor=0.99), "phase model"),
    "phaser": (lambda: Phaser(order=6), "phaser"),
    "optimizer": (lambda: InSituOptimizer(model=AdaptiveGaitModel(forgetting_factor=0.95),
                                          step=ModelStep(trust_radius=0.05)),
                  "optimizer"),
    "path tracker": (lambda: PathTracker(model=ShapeSpaceModel(degree=2), exploration=AdaptiveExploration(low=0.03)),
                     "optimizer"),
    "adaptive exploration": (lambda: AdaptiveExploration(low=0.02, high=0.1), "optimizer"),
}
STATELESS = {"perfect information"}  # nothing to learn: fitted by construction
FITTABLE = [name for name, (_, kind) in ESTIMATORS.items() if kind != "optimizer"]
SAVEABLE = [name for name in FITTABLE if name != "perfect information"]


def data(kind: str, run=RUN) -> tuple:
    return {"gait model": (run.phase, run.shape, run.shape_velocity, run.body_velocity),
            "phase model": (run.phase, run.body_velocity),
            "phaser": (run.shape,)}[kind]


def use(estimator, kind: str):
    """What a fitted estimator answers on held-out data (every public read-only method)."""
    if kind == "phaser":
        return [estimator.transform(HELD_OUT.shape)]
    if kind == "phase model":
        return [estimator.predict(HELD_OUT.phase)]
    answers = [estimator.predict(HELD_OUT.phase, HELD_OUT.shape, HELD_OUT.shape_velocity),
               estimator.predict_displacement(GAIT),
               estimator.score(*data(kind, HELD_OUT))]
    return answers


def snapshot(estimator) -> dict:
    """Hyper-parameters and learned state; private attributes (lazy caches) may change on use."""
    return copy.deepcopy({k: v for k, v in vars(estimator).items() if not k.startswith("_")})


def assert_same_state(before: dict, after: dict) -> None:
    assert before.keys() == after.keys()
    for key in before:
        assert_same_value(before[key], after[key], key)


def assert_same_value(a, b, key) -> None:
    if isinstance(a, np.ndarray | float | int):
        np.testing.assert_array_equal(a, b, err_msg=key)  # NaN equals NaN here
    elif isinstance(a, tuple | list):
        assert len(a) == len(b), key
        for x, y in zip(a, b, strict=True):
            assert_same_value(x, y, key)
    elif isinstance(a, dict):
        assert_same_state(a, b)
    elif hasattr(a, "__dict__") and not isinstance(a, type):
        assert type(a) is type(b), key  # a nested estimator: its private caches may change on use too
        assert_same_state(*({k: v for k, v in vars(x).items() if not k.startswith("_")} for x in (a, b)))
    else:
        assert a == b, key


@pytest.fixture(params=list(ESTIMATORS))
def named(request):
    factory, kind = ESTIMATORS[request.param]
    return request.param, factory(), kind


# -- the parameter protocol ----------------------------------------------------------------------
def test_sklearn_clone_gives_an_unfitted_equal_copy(named):
    name, estimator, kind = named
    if kind != "optimizer":
        estimator.fit(*data(kind))
    copied = clone(estimator)
    assert type(copied) is type(estimator) and copied is not estimator
    assert copied.__sklearn_is_fitted__() == (name in STATELESS)
    for key, value in estimator.get_params(deep=False).items():
        if hasattr(value, "get_params"):
            assert value.get_params() == copied.get_params(deep=False)[key].get_params()
        else:
            assert copied.get_params(deep=False)[key] == value or value is None


def test_get_set_params_round_trip_and_repr(named):
    name, estimator, _ = named
    params = estimator.get_params(deep=False)
    assert estimator.set_params(**params) is estimator
    assert estimator.get_params(deep=False).keys() == params.keys()
    assert repr(estimator).startswith(type(estimator).__name__ + "(")
    assert type(estimator)().get_params(deep=False).keys() == params.keys()


def test_nested_parameters_reach_the_model():
    optimizer = InSituOptimizer(model=AdaptiveGaitModel())
    assert optimizer.get_params()["model__forgetting_factor"] == 0.99
    optimizer.set_params(model__forgetting_factor=0.9, gate=Gate(), gate__gamma_threshold=0.4)
    assert optimizer.model.forgetting_factor == 0.9 and optimizer.gate.gamma_threshold == 0.4
    assert optimizer.get_params()["gate__gamma_threshold"] == 0.4
    with pytest.raises(GeogaitError, match="'forgetting_factor' parameter of AdaptiveGaitModel"):
        optimizer.set_params(model__forgetting_factor=1.5)


def test_unknown_parameter_is_named(named):
    _, estimator, _ = named
    with pytest.raises(GeogaitError, match=r"The 'bogus' parameter of \w+ must be one of"):
        estimator.set_params(bogus=1)


def invalid_value(constraint):
    """A value the constraint must refuse."""
    if isinstance(constraint, Real):
        return -np.inf if constraint.low is None else constraint.low - 1.0
    if isinstance(constraint, Integer):
        return 2.5 if constraint.minimum is None else constraint.minimum - 1
    if isinstance(constraint, Options):
        return "no such option"
    if isinstance(constraint, Boolean):
        return "yes"
    if isinstance(constraint, InstanceOf):
        return "not an object of the right kind"
    if type(constraint).__name__ in ("_LinkLengths", "_BodyFrame", "_FrameOffset", "_ShapeMap"):
        return [1.0, -1.0]
    raise AssertionError(f"no invalid value for {constraint!r}")


CONSTRAINED = [(name, parameter) for name, (factory, _) in ESTIMATORS.items()
               for parameter in factory()._parameter_constraints]


@pytest.mark.parametrize(("name", "parameter"), CONSTRAINED, ids=[f"{n}-{p}" for n, p in CONSTRAINED])
def test_bad_parameter_raises_the_template_before_any_change(name, parameter):
    factory, kind = ESTIMATORS[name]
    estimator = factory()
    bad = invalid_value(estimator._parameter_constraints[parameter])
    pattern = rf"The '{parameter}' parameter of {type(estimator).__name__} must be"
    params = estimator.get_params(deep=False)
    with pytest.raises(GeogaitError, match=pattern):
        estimator.set_params(**{parameter: bad})
    assert estimator.get_params(deep=False) == params  # set_params changed nothing
    if kind == "optimizer":
        setattr(estimator, parameter, bad)
        with pytest.raises(GeogaitError, match=pattern):
            estimator.validate()
        return
    estimator.fit(*data(kind))
    before = snapshot(estimator)
    setattr(estimator, parameter, bad)  # bypassing set_params: fit must still refuse it
    with pytest.raises(GeogaitError, match=pattern):
        estimator.fit(*data(kind))
    before[parameter] = bad
    assert_same_state(before, snapshot(estimator))


def test_every_parameter_of_every_estimator_is_constrained(named):
    """Each hyper-parameter is declared, or checked with the others (then validate names it)."""
    _, estimator, _ = named
    checked_together = {"InSituOptimizer": {"model", "climb", "exploration", "checks"},
                        "PathTracker": {"model", "exploration"}}
    declared = set(estimator._parameter_constraints) | checked_together.get(type(estimator).__name__, set())
    assert declared == set(estimator.get_params(deep=False))


# -- fitting, prediction and persistence -----------------------------------------------------------
@pytest.mark.parametrize("name", FITTABLE)
def test_fit_returns_self_and_use_leaves_state_unchanged(name):
    factory, kind = ESTIMATORS[name]
    estimator = factory()
    if name not in STATELESS:
        with pytest.raises(GeogaitError, match="is not fitted yet"):
            use(estimator, kind)
    assert estimator.fit(*data(kind)) is estimator
    assert estimator.__sklearn_is_fitted__()
    before = snapshot(estimator)
    first = use(estimator, kind)
    assert_same_state(before, snapshot(estimator))
    for a, b in zip(first, use(estimator, kind), strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", FITTABLE)
def test_scikit_learns_own_fitted_check_reads_our_estimators(name):
    from sklearn.exceptions import NotFittedError
    from sklearn.utils.validation import check_is_fitted as sklearn_check_is_fitted

    factory, kind = ESTIMATORS[name]
    estimator = factory()
    if name not in STATELESS:
        with pytest.raises(NotFittedError):
            sklearn_check_is_fitted(estimator)
    sklearn_check_is_fitted(estimator.fit(*data(kind)))


@pytest.mark.parametrize("name", SAVEABLE)
def test_save_load_predicts_identically(name, tmp_path):
    factory, kind = ESTIMATORS[name]
    estimator = factory().fit(*data(kind))
    path = estimator.save(tmp_path / "estimator.npz")
    loaded = type(estimator).load(path)
    assert type(loaded) is type(estimator)
    assert repr(loaded.get_params(deep=False)) == repr(estimator.get_params(deep=False))  # values, not only names
    for a, b in zip(use(estimator, kind), use(loaded, kind), strict=True):
        np.testing.assert_array_equal(a, b)
    if kind != "phaser":  # the gait-model format is one family: load_model reads every member
        assert type(load_model(path)) is type(estimator)


def test_loading_the_wrong_class_is_refused(tmp_path):
    path = PhaseModel().fit(*data("phase model")).save(tmp_path / "phase.npz")
    with pytest.raises(GeogaitError, match="holds a PhaseModel, not a AdaptiveGaitModel"):
        AdaptiveGaitModel.load(path)
    with pytest.raises(GeogaitError, match="not a geogait phaser file"):
        Phaser.load(path)


def test_an_estimator_without_a_saved_form_says_so(tmp_path):
    model = PerfectInformationModel(system=SWIMMER)
    assert not model.can_save() and all(ESTIMATORS[name][0]().can_save() for name in SAVEABLE)
    with pytest.raises(GeogaitError, match="PerfectInformationModel cannot be saved"):
        model.save(tmp_path / "perfect.npz")
    assert not (tmp_path / "perfect.npz").exists()


def test_the_gait_model_contract_is_checked_in_one_place():
    """check_gait_model: unfitted built-in models pass (gamma_ is a property of their class); anything
    lacking a member gets the standard error naming it, from the optimiser and the tracker alike."""
    from geogait.models import AdaptiveGaitModel, ShapeSpaceModel, check_gait_model
    from geogait.optimize import InSituOptimizer

    for model in (AdaptiveGaitModel(), ShapeSpaceModel()):
        check_gait_model(model, ("partial_fit", "predict_displacement", "forget", "reset_gamma", "gamma_"), "test")

    class Partial:
        def partial_fit(self, *args):
            return self

    with pytest.raises(GeogaitError, match=r"'model' parameter of test .*without predict_displacement\(\)"):
        check_gait_model(Partial(), ("partial_fit", "predict_displacement"), "test")
    with pytest.raises(GeogaitError, match="without gamma_"):
        check_gait_model(Partial(), ("partial_fit", "gamma_"), "test")
    with pytest.raises(GeogaitError, match=r"'model' parameter of InSituOptimizer.*without get_params\(\)"):
        InSituOptimizer(model=Partial(), gate=Gate(kind="cycles")).validate()
    with pytest.raises(GeogaitError, match=r"'model' parameter of PathTracker.*None or an unfitted gait model"):
        PathTracker(model=Partial()).validate()


@pytest.mark.parametrize(("factory", "match"), [
    (lambda: ResistanceModel.from_swimmer(SWIMMER, residual_degree=0, residual_symmetry="mirror"),
     "'residual_degree' parameter of ResistanceModel"),
    (lambda: ShapeSpaceModel(smoothing_order=50), "'smoothing_order' parameter of ShapeSpaceModel"),
    (lambda: ResistanceModel.from_swimmer(SWIMMER, smoothing_order=50), "'smoothing_order' parameter of Resistance"),
    (lambda: AdaptiveGaitModel(), "'gait' parameter of AdaptiveGaitModel"),
    (lambda: BatchGaitModel(), "'gait' parameter of BatchGaitModel"),
], ids=["residual without weights", "shape-space smoothing", "resistance smoothing", "adaptive", "batch"])
def test_a_failed_first_partial_fit_leaves_the_model_unfitted_as_it_was(factory, match):
    """A hyper-parameter only the data can judge, or data too short to estimate the gait from: the first
    partial_fit raises, naming the model's own parameter, and the model is exactly as before (not half-fitted)."""
    model = factory()
    before = dict(vars(model))
    short = slice(None) if "gait" not in match else slice(0, 3)
    with pytest.raises(GeogaitError, match=match):
        model.partial_fit(RUN.phase[short], RUN.shape[short], RUN.shape_velocity[short], RUN.body_velocity[short])
    assert vars(model).keys() == before.keys() and not model.__sklearn_is_fitted__()
