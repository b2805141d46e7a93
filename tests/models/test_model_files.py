"""Saved models and phasers hold values within the ±1e12 every input is held to, both ways; a file that is not a
model is said to be so, never a pickle (issue 11); a file is checked before anything is allocated for it, and
hyper-parameters or shapes that would overflow the state are refused (issue 21)."""

import json
import os
import re
import time

import numpy as np
import pytest
from _cli import invoke, one_error_line
from _reference import GAIT
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import write_state
from geogait.cli import app
from geogait.control import ReferencePath
from geogait.models import AdaptiveGaitModel, BatchGaitModel, ShapeSpaceModel, load_model
from geogait.phase import Phaser
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 6, seed=1)


@pytest.fixture(scope="module")
def model(run):
    return AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)


def written(path, estimator, name, value):
    metadata, state = estimator.get_state()
    state = dict(state)
    array = np.array(state[name], dtype=float)
    array.flat[1] = value
    state[name] = array
    write_state(path, json.loads(json.dumps(metadata)), state)  # (what an edited or corrupted file holds)
    return path


@pytest.mark.parametrize(("name", "value"), [("psi", 1e300), ("weights", -1e13), ("covariance", 2e12)])
def test_a_model_file_holding_a_value_beyond_the_bound_is_refused_naming_the_array(model, tmp_path, name, value):
    """Issue 58, finding 7: a model whose psi was 1e300 loaded, and every Γ it gave was 0.0."""
    path = written(tmp_path / "m.npz", model, name, value)
    with pytest.raises(GeogaitError, match=rf"m.npz: The '{name}' parameter of the saved model must be plausible "
                                           rf"values, within ±1e\+12. Got '{re.escape(f'{value:g}')} at index"):
        load_model(path)


def test_a_batch_model_and_a_phaser_are_held_to_the_same_bound(run, tmp_path):
    batch = BatchGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    with pytest.raises(GeogaitError, match=r"'gram' parameter of the saved model must be plausible values"):
        load_model(written(tmp_path / "b.npz", batch, "gram", 1e300))
    phaser = Phaser().fit(run.shape)
    name = next(name for name, value in phaser.get_state()[1].items() if np.asarray(value).dtype.kind == "f")
    with pytest.raises(GeogaitError, match=rf"'{name}' parameter of the saved phaser must be plausible values"):
        Phaser.load(written(tmp_path / "p.npz", phaser, name, -1e300))


def test_a_state_beyond_the_bound_is_never_saved(model, tmp_path):
    path = model.save(tmp_path / "m.npz")
    before = path.read_bytes()
    metadata, state = model.get_state()
    with pytest.raises(GeogaitError, match=r"Refusing to save .*m.npz: the state went beyond ±1e\+12 \(in psi\); "
                                           "the previous file, if any, is kept"):
        write_state(path, metadata, {**state, "psi": np.full_like(state["psi"], 1e300)}, require_finite=True)
    assert path.read_bytes() == before and list(tmp_path.iterdir()) == [path]


def test_garbage_model_file_error_does_not_mention_pickle(tmp_path):
    for content in (b"garbage" * 10, b"\x80\x04\x95" + b"x" * 40):
        path = tmp_path / "m.npz"
        path.write_bytes(content)
        with pytest.raises(GeogaitError) as info:
            load_model(path)
        assert "pickle" not in str(info.value) and "not a readable geogait model" in str(info.value)
        result = CliRunner().invoke(app, ["stream", str(path)], input="")
        assert "pickle" not in one_error_line(result, "not a readable geogait model")


# -- model files checked before anything is allocated (issue 21) ----------------------------------------------
@pytest.fixture(scope="module")
def samples():
    return simulate(PurcellSwimmer(3), GAIT, 4, seed=1)


@pytest.fixture(scope="module")
def model_state(samples):
    model = AdaptiveGaitModel(gait=GAIT).fit(samples.phase, samples.shape, samples.shape_velocity,
                                             samples.body_velocity)
    return model.get_state()


def _write(path, metadata, state, **changes):
    metadata = json.loads(json.dumps(metadata))
    state = dict(state)
    for key, value in changes.items():
        if key in state:
            state[key] = value
        elif key in metadata["params"]:
            metadata["params"][key] = value
        else:
            metadata[key] = value
    write_state(path, metadata, state)
    return path


@pytest.mark.parametrize(("change", "fragment"), [
    ({"weights": "nan"}, "holds NaN or infinity"),
    ({"covariance": "inf"}, "holds NaN or infinity"),
    ({"psi": "complex"}, "complex128"),
    ({"n_windows": 60_000_000}, "60000000 windows"),
    ({"batch_shape": [10**9]}, "batch shape (1000000000,)"),
    ({"n_joints": 100_000}, "n_joints must be an integer"),
    ({"n_joints": 7}, "claim 7 joints"),
])
def test_model_files_are_checked_before_anything_is_allocated(model_state, tmp_path, change, fragment):
    metadata, state = model_state
    (key, value), = change.items()
    if value in ("nan", "inf", "complex"):
        array = np.array(state[key], dtype=complex if value == "complex" else float)
        if value != "complex":
            array.flat[3] = np.nan if value == "nan" else np.inf
        value = array
    path = _write(tmp_path / "bad.npz", metadata, state, **{key: value})
    started = time.perf_counter()
    with pytest.raises(GeogaitError, match="bad.npz") as error:
        load_model(path)
    assert fragment in str(error.value) and time.perf_counter() - started < 2


def test_deeply_nested_metadata_is_a_clear_error(model_state, tmp_path):
    metadata, state = model_state
    arrays = {f"state/{k}": np.asarray(v) for k, v in state.items()}
    arrays["metadata"] = np.frombuffer(json.dumps(metadata).replace('"params"', '"x": ' + "[" * 100_000 + "]" * 100_000
                                                                    + ', "params"').encode(), np.uint8)
    np.savez(tmp_path / "deep.npz", **arrays)
    with pytest.raises(GeogaitError, match="not a readable geogait model"):
        load_model(tmp_path / "deep.npz")


def test_predict_with_a_nan_model_is_one_error_line(model_state, samples, tmp_path):
    metadata, state = model_state
    weights = np.array(state["weights"])
    weights[0, 0, 0] = np.nan
    path = _write(tmp_path / "nan.npz", metadata, state, weights=weights)
    log = tmp_path / "log.csv"
    samples.to_pandas().to_csv(log, index=False)
    result = invoke("predict", path, log, "--shape", "shape_0,shape_1", "--phase", "phase", "--shape-velocity",
                    "shape_velocity_0,shape_velocity_1", "--out", tmp_path / "p.csv")
    one_error_line(result, "NaN or infinity")
    assert not (tmp_path / "p.csv").exists()


@pytest.mark.parametrize("path, fragment", [("folder", "is a folder"), ("fifo", "FIFO"), ("/dev/zero", "device")])
def test_paths_that_are_not_files_say_what_they_are(tmp_path, path, fragment):
    if path == "folder":
        path = tmp_path
    elif path == "fifo":
        path = tmp_path / "pipe.npz"
        os.mkfifo(path)
    with pytest.raises(GeogaitError, match=fragment):
        load_model(path)
    with pytest.raises(GeogaitError, match=fragment):
        ReferencePath.from_csv(path)


@pytest.mark.parametrize(("model", "message"), [
    (lambda: AdaptiveGaitModel(initial_covariance=1e300), "'initial_covariance' parameter"),
    (lambda: ShapeSpaceModel(shape_scale=1e-300), "'shape_scale' parameter"),
])
def test_hyper_parameters_that_overflow_the_state_are_refused(samples, model, message):
    with pytest.raises(GeogaitError, match=message):
        model().fit(samples.phase, samples.shape, samples.shape_velocity, samples.body_velocity)


@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_shapes_too_large_for_the_model_are_a_clear_error(samples):
    scale = 1e11  # inside the documented ±1e12
    with pytest.raises(GeogaitError, match="shape_scale"):
        ShapeSpaceModel().fit(samples.phase, samples.shape * scale, samples.shape_velocity, samples.body_velocity)
    # at their scale the same shapes are learned
    model = ShapeSpaceModel(shape_scale=1e3).fit(samples.phase, samples.shape * 1e3, samples.shape_velocity,
                                                 samples.body_velocity)
    assert all(np.all(np.isfinite(v)) for v in model.get_state()[1].values())
