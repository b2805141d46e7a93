"""``geogait stream`` as a command: the files it may replace."""

import json

import numpy as np
import pandas as pd
import pytest
from _reference import GAIT, lines
from typer.testing import CliRunner

from geogait.cli import app
from geogait.models import AdaptiveGaitModel, load_model
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 3, seed=4)


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    return path


def stream(*args, text):
    return CliRunner().invoke(app, ["stream", *map(str, args)], input=text)


def one_error_line(result, *fragments):
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    assert all(fragment in errors[0] for fragment in fragments), errors[0]


@pytest.mark.parametrize("name", ["notes.txt", "log.csv", "other.npz", "config.npz"])
def test_stream_out_refuses_to_replace_a_file_without_overwrite(run, config, tmp_path, name):
    """Issue 58, finding 1: --out naming an existing file (a user's notes, a log, another model, the default
    <config>.npz of an earlier run) is refused before reading stdin, the file kept; --overwrite replaces it."""
    target = tmp_path / name
    if name == "log.csv":
        run.to_pandas().to_csv(target, index=False)
    else:
        target.write_bytes(b"a user's file")
    before = target.read_bytes()
    args = [config] if name == "config.npz" else [config, "--out", target]
    one_error_line(stream(*args, text=lines(run, 0, 50)), f"{target} exists", "--overwrite")
    assert target.read_bytes() == before and not target.with_name(f"{target.stem}.stream.json").exists()
    result = stream(*args, "--overwrite", text=lines(run, 0, 50))
    assert result.exit_code == 0, result.output
    assert load_model(target).n_samples_seen_ == 50


def test_stream_refuses_to_replace_a_manifest_it_did_not_make(run, config, tmp_path):
    (tmp_path / "m.stream.json").write_text("a user's notes")
    one_error_line(stream(config, "--out", tmp_path / "m.npz", text=lines(run, 0, 50)), "m.stream.json exists")
    assert not (tmp_path / "m.npz").exists()


def test_stream_goes_on_learning_in_the_model_it_was_given(run, config, tmp_path):
    """The model given is the default output (learning goes on in it): no --overwrite needed, also with --out."""
    model = tmp_path / "m.npz"
    assert stream(config, "--out", model, text=lines(run, 0, 50)).exit_code == 0
    assert stream(model, text=lines(run, 50, 100)).exit_code == 0
    assert stream(model, "--out", model, text=lines(run, 100, 150)).exit_code == 0
    assert load_model(model).n_samples_seen_ == 150
    assert pd.read_json(model.with_name("m.stream.json"), typ="series")["command"] == "stream"


def test_stream_refuses_a_csv_header_naming_a_used_column_twice(run, config, tmp_path):
    """Issue 58, finding 6: the stream used the last of two `shape_0` columns (fit and predict the first)."""
    frame = run.to_pandas()
    text = pd.concat([frame, frame[["shape_0"]] * 2], axis=1).to_csv(index=False)
    result = stream(config, "--format", "csv", "--out", tmp_path / "m.npz", text=text)
    one_error_line(result, "error: input line 1 must be a CSV header naming each column once",
                   "['shape_0'] more than once")
    assert not (tmp_path / "m.npz").exists()


def test_stream_names_the_header_it_got_when_a_column_it_reads_is_missing(run, config, tmp_path):
    """Before: "got 'a header without ['shape_0', 'shape_1']'", which did not show the header read."""
    frame = run.to_pandas().rename(columns={"shape_0": "q1", "shape_1": "q2"})
    result = stream(config, "--format", "csv", "--out", tmp_path / "m.npz", text=frame.to_csv(index=False))
    one_error_line(result, "error: input line 1 must be a CSV header with the columns ['shape_0', 'shape_1']",
                   "rename the log's columns", "got \"a header without ['shape_0', 'shape_1']: time,", "q1,q2")
    assert not (tmp_path / "m.npz").exists()


def test_saved_bytes_is_the_size_of_the_saved_file(tmp_path):
    """What the note below reads: at 10 joints the window covariances are the file, to within 10 %."""
    from geogait.gaits import seed_gait

    gait, rng = seed_gait(10), np.random.default_rng(0)
    phase = np.linspace(0, 2 * np.pi, 40)
    model = AdaptiveGaitModel(gait=gait).partial_fit(phase, gait.shape(phase) + 0.1 * rng.normal(size=(40, 10)),
                                                     rng.normal(size=(40, 10)), rng.normal(size=(40, 3)))
    model.save(tmp_path / "m.npz")
    assert model.saved_bytes(10) == pytest.approx((tmp_path / "m.npz").stat().st_size, rel=0.1)


@pytest.mark.parametrize("n_joints, noted", [(2, False), (40, True)])
def test_stream_says_when_saving_its_model_outlasts_a_signal(tmp_path, n_joints, noted):
    """Issue 58: a model whose save takes longer than the 2 s other commands answer SIGTERM in is declared at the
    start (its size and the seconds to allow before a kill); a small one is not."""
    from geogait.gaits import seed_gait

    config = tmp_path / "config.json"
    config.write_text(json.dumps(AdaptiveGaitModel(gait=seed_gait(n_joints)).to_config()))
    result = stream(config, text="")
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if "saving this model" in line]
    assert len(notes) == noted
    if noted:  # 20 windows of 1681² covariances: 0.45 GB
        assert "(0.45 GB)" in notes[0] and "before a kill" in notes[0]
