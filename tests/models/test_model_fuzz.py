"""Fuzz tests (issue 11) of the models: partial_fit learns finitely or names the field; the model loader gives a
usable model or a clear error (see tests/_fuzz.py)."""

import json
import math

import numpy as np
import pytest
from _fuzz import FUZZ, WILD, names_a_field
from _fuzz import fitted as fitted
from _fuzz import run as run
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait import GeogaitError
from geogait.gaits import seed_gait
from geogait.models import AdaptiveGaitModel, load_model


@FUZZ
@given(n=st.integers(0, 30), d=st.integers(1, 3), value=WILD, where=st.sampled_from(["shape", "rate", "body", "phase"]),
       transpose=st.booleans(), rate_width=st.integers(1, 3))
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_partial_fit_learns_finitely_or_names_the_field(n, d, value, where, transpose, rate_width):
    rng = np.random.default_rng(n * 7 + d)
    arrays = {"phase": rng.uniform(0, 2 * np.pi, n), "shape": rng.normal(size=(n, d)),
              "rate": rng.normal(size=(n, rate_width)), "body": rng.normal(size=(n, 3))}
    if n:
        arrays[where].reshape(-1)[0] = value
    if transpose:
        arrays["shape"] = arrays["shape"].T
    model = AdaptiveGaitModel(gait=None if n % 2 else seed_gait(d))
    try:
        model.partial_fit(arrays["phase"], arrays["shape"], arrays["rate"], arrays["body"])
    except GeogaitError as error:
        assert names_a_field(error), error
        assert not hasattr(model, "batch_shape_")
        return
    assert np.all(np.isfinite(model.window_weights_)) and np.all(np.isfinite(model.covariance_))
    assert math.isfinite(model.gamma_)


LOADER_EDITS = st.lists(st.one_of(
    st.tuples(st.just("param"), st.sampled_from(["n_windows", "smoothing_order", "forgetting_factor", "phase_rate",
                                                 "window_width", "interaction", "initial_covariance"]),
              st.one_of(WILD, st.none(), st.booleans(), st.text(max_size=3), st.lists(st.integers(), max_size=2))),
    st.tuples(st.just("meta"), st.sampled_from(["n_joints", "batch_shape", "class", "format_version"]),
              st.one_of(WILD, st.none(), st.booleans(), st.text(max_size=3), st.lists(WILD, max_size=3))),
    st.tuples(st.just("array"), st.sampled_from(["weights", "covariance", "gait", "n_updates", "psi",
                                                 "phase_model/weights", "n_samples_seen"]),
              st.sampled_from(["nan", "inf", "complex", "empty", "scalar", "transpose", "huge", "int", "drop"]))),
    min_size=1, max_size=3)


def _edited_array(value: np.ndarray, how: str):
    value = np.asarray(value)
    return {"nan": lambda: np.full(value.shape, np.nan), "inf": lambda: np.full(value.shape, -np.inf),
            "complex": lambda: value.astype(complex), "empty": lambda: np.zeros((0,)), "scalar": lambda: np.float64(3),
            "transpose": lambda: value.T.copy(), "huge": lambda: np.full(value.shape, 1e300),
            "int": lambda: value.astype(np.int64)}[how]()


@settings(FUZZ, max_examples=60)
@given(edits=LOADER_EDITS)
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_model_loader_gives_a_usable_model_or_a_clear_error(fitted, run, tmp_path_factory, edits):
    import time

    from geogait._files import write_state

    metadata, state = fitted.get_state()
    metadata, state = json.loads(json.dumps(metadata)), dict(state)
    for kind, name, value in edits:
        if kind == "param":
            metadata["params"][name] = value
        elif kind == "meta":
            metadata[name] = value
        elif value == "drop":
            state.pop(name, None)
        elif name in state:
            state[name] = _edited_array(state[name], value)
    path = tmp_path_factory.mktemp("loader") / "m.npz"
    write_state(path, metadata, state)
    started = time.perf_counter()
    try:
        model = load_model(path)
    except GeogaitError as error:
        assert "m.npz" in str(error), error
    else:
        prediction = model.predict(run.phase[:50], run.shape[:50], run.shape_velocity[:50])
        assert prediction.shape == (50, 3) and np.all(np.isfinite(prediction))
    assert time.perf_counter() - started < 5
