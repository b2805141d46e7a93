"""``geogait stream`` checks what it reads and where it writes (issue 11): implausible samples quarantined,
--out checked before the first sample and never one of the inputs, time units and degrees warned about, the end
message, and the temporary file of a writer killed by SIGKILL removed."""

import json
import os

import numpy as np
import pytest
from _cli import one_error_line
from _noisy_run import run as run
from _reference import GAIT, lines, record, strict_json
from typer.testing import CliRunner

from geogait import GeogaitError, GeogaitWarning
from geogait.cli import app
from geogait.learn import StreamLearner
from geogait.models import AdaptiveGaitModel, load_model


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    return path


@pytest.mark.parametrize("change, channel", [({"body_velocity": [1e300, 0.0, 0.0]}, "body_velocity[0] = 1e+300"),
                                             ({"shape_velocity": [1e200, 0.0]}, "shape_velocity[0] = 1e+200"),
                                             ({"body_velocity": [0.0, 1e4, 0.0]}, "body_velocity[1] = 10000")])
def test_stream_quarantines_implausible_samples_and_saves_a_finite_model(run, config, tmp_path, change, channel):
    out = tmp_path / "m.npz"
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(out)],
                                input=lines(run, 0, 400, {300: change}))
    assert result.exit_code == 0, result.stderr
    outputs = [strict_json(line) for line in result.stdout.splitlines()]
    assert channel in outputs[300]["rejected"] and not outputs[300]["learned"]
    assert all("rejected" not in o for i, o in enumerate(outputs) if i != 300)
    assert np.isfinite([o["gamma"] for o in outputs[1:]]).all() and outputs[-1]["gamma"] > 0.5
    assert "1 implausible sample(s) quarantined" in result.stderr and "input line 301" in result.stderr
    assert "399 of 400 samples learned" in result.stderr
    model = load_model(out)
    assert model.n_samples_seen_ == 399 and np.isfinite(model.window_weights_).all()


def test_stream_checks_out_before_reading(run, config, tmp_path):
    for out, message in ((tmp_path / "missing" / "m.npz", "does not exist"), (tmp_path, "it is a folder")):
        result = CliRunner().invoke(app, ["stream", str(config), "--out", str(out)], input=lines(run, 0, 50))
        one_error_line(result, "Cannot write the model file", message)
        assert result.stdout == ""  # not one sample was read
    with pytest.raises(GeogaitError, match="Cannot write the model file"):
        StreamLearner(AdaptiveGaitModel(gait=GAIT), path=tmp_path / "no" / "m.npz")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_stream_refuses_a_read_only_folder(run, config, tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        result = CliRunner().invoke(app, ["stream", str(config), "--out", str(folder / "m.npz")],
                                    input=lines(run, 0, 50))
        one_error_line(result, "Cannot write the model file")
    finally:
        folder.chmod(0o755)


def test_stream_warns_when_time_stamps_disagree_with_the_model(run, config, tmp_path):
    def in_ms(s):
        entry = record(run, s)
        entry["time"] *= 1000
        entry.pop("shape_velocity")  # differentiated from the stamps
        return json.dumps(entry) + "\n"

    text = "".join(in_ms(s) for s in range(300))
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "m.npz")], input=text)
    assert result.exit_code == 0 and "warning: The stream's phase advances at 0.006283 rad per time unit" \
        in result.stderr, result.stderr
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "m.npz"), "--time-unit", "ms",
                                      "--overwrite"], input=text)
    assert result.exit_code == 0 and "warning" not in result.stderr, result.stderr


def test_end_message_when_save_every_divides_the_sample_count(run, config, tmp_path):
    out = tmp_path / "m.npz"
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(out), "--save-every", "50"],
                                input=lines(run, 0, 200))
    assert result.exit_code == 0
    assert "200 of 200 samples learned; online Γ" in result.stderr and f"saved the model to {out}" in result.stderr
    manifest = strict_json((tmp_path / "m.stream.json").read_text())
    assert manifest["command"] == "stream" and manifest["geogait_version"] and manifest["results"]["n_learned"] == 200
    assert load_model(out).n_samples_seen_ == 200


def test_degrees_given_as_radians_are_warned_about(run, config, tmp_path):
    message = r"'shape' values of AdaptiveGaitModel.partial_fit reach \d+\.\d+, more than a full turn.*degrees"
    with pytest.warns(GeogaitWarning, match=message):
        AdaptiveGaitModel(gait=GAIT).partial_fit(run.phase, np.rad2deg(run.shape), run.shape_velocity,
                                                 run.body_velocity)
    text = "".join(json.dumps(record(run, s, shape=np.rad2deg(run.shape[s]).tolist())) + "\n" for s in range(60))
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "m.npz")], input=text)
    assert result.exit_code == 0 and result.stderr.count("warning: The 'shape' values") == 1, result.stderr


def test_stream_never_saves_over_its_phaser_or_config(run, config, tmp_path):
    from geogait.phase import Phaser

    phaser = Phaser().fit(run.shape).save(tmp_path / "phaser.npz")
    before = phaser.read_bytes()
    result = CliRunner().invoke(app, ["stream", str(config), "--phaser", str(phaser), "--out", str(phaser)],
                                input=lines(run, 0, 10))
    one_error_line(result, "--out must be a file other than the inputs")
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(config)], input=lines(run, 0, 10))
    one_error_line(result, "--out must be a file other than the inputs")
    assert phaser.read_bytes() == before and json.loads(config.read_text())["format"] == "geogait-model-config"


def test_a_stream_after_kill_9_removes_the_dead_writers_temporary(run, config, tmp_path, monkeypatch):
    import subprocess
    import sys

    import geogait._files

    out = tmp_path / "m.npz"
    CliRunner().invoke(app, ["stream", str(config), "--out", str(out)], input=lines(run, 0, 50))
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # a pid that is certainly gone, as after kill -9 during a save
    leftover = tmp_path / f".m.npz.{dead.pid}.k9x3.tmp"
    leftover.write_bytes(b"half a model")
    monkeypatch.setattr(geogait._files, "_CLEANED", set())  # the next `geogait stream` is a new process
    result = CliRunner().invoke(app, ["stream", str(out)], input=lines(run, 50, 100))
    assert result.exit_code == 0 and not leftover.exists()
    assert load_model(out).n_samples_seen_ == 100
