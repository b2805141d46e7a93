"""Saved models and phasers hold values within the ±1e12 every input is held to, both ways; a file that is not a
model is said to be so, never a pickle (issue 11)."""

import json
import re

import numpy as np
import pytest
from _cli import one_error_line
from _reference import GAIT
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import write_state
from geogait.cli import app
from geogait.models import AdaptiveGaitModel, BatchGaitModel, load_model
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
