"""Regression tests for issue 11: nothing lost, no raw traceback, no silent garbage.

One test (or a few) per item of the issue, numbered as there. CLI tests assert the printed
message and the exit code, never ``result.exception``.
"""

import json
import os
import re
import stat
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _reference import GAIT, lines, record
from typer.testing import CliRunner

from geogait import GeogaitError, GeogaitWarning
from geogait._files import atomic_write, check_writable, json_ready, write_json
from geogait.cli import app
from geogait.cli._common import comma_list, write_manifest
from geogait.gaits import seed_gait
from geogait.io import read_log
from geogait.io._records import StreamOutput, _JsonLinesWriter
from geogait.learn import StreamLearner, fit_log, run_stream
from geogait.models import AdaptiveGaitModel, PhaseModel, load_model
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

BODY = ["body_velocity_x", "body_velocity_y", "body_velocity_theta"]
COLUMNS = dict(shape=["shape_0", "shape_1"], body_velocity=BODY, phase="phase",
               shape_velocity=["shape_velocity_0", "shape_velocity_1"])
CLI_COLUMNS = ["--shape", "shape_0,shape_1", "--body-velocity", ",".join(BODY), "--phase", "phase",
               "--shape-velocity", "shape_velocity_0,shape_velocity_1"]


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 12, seed=4, sensor_noise=0.1)  # 1 200 samples, 1 cycle per time unit


@pytest.fixture(scope="module")
def frame(run):
    return run.to_pandas()


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    return path


def strict_json(text: str):
    """json.loads that refuses NaN / Infinity tokens."""
    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


def one_error_line(result, *fragments):
    """Exit code 1, exactly one 'error: …' line containing every fragment, no traceback."""
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1, result.stderr
    assert "Traceback" not in result.output and "unexpected" not in errors[0], result.output
    for fragment in fragments:
        assert fragment in errors[0], errors[0]
    return errors[0]


# -- 1. plausibility ----------------------------------------------------------------------------
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


def test_stream_learner_bound_is_relative_and_settable(run):
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), outlier_limit=None)
    sink = _Sink()
    text = lines(run, 0, 200, {150: {"body_velocity": [0.0, 1e4, 0.0]}})
    summary = run_stream(learner, text.splitlines(True), sink)
    assert summary.n_rejected == 0 and summary.n_learned == 200  # switched off: learned (only ±1e12 applies)
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT))
    assert run_stream(learner, lines(run, 0, 400).splitlines(True), _Sink()).n_rejected == 0  # clean data pass
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), outlier_limit=3)
    summary = run_stream(learner, lines(run, 0, 200).splitlines(True), _Sink())
    assert summary.n_rejected > 0 and "outlier_limit = 3 robust standard deviations" in summary.first_rejection


def test_fit_rejects_a_huge_pose_naming_column_and_row(run, tmp_path):
    log = run.to_pandas()[["time", "shape_0", "shape_1", "x", "y", "heading"]].copy()
    log.loc[500, "x"] = 1e300
    log.to_csv(tmp_path / "log.csv", index=False)
    base = ["fit", str(tmp_path / "log.csv"), "--shape", "shape_0,shape_1", "--pose", "x,y,heading"]
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "out")])
    one_error_line(result, "'x' parameter of read_log", "within ±1e+12", "1e+300 at row 500")
    assert not (tmp_path / "out" / "model.npz").exists()
    log.loc[500, "x"] = log.loc[499, "x"] + 50.0  # finite, but a 50-length jump in one step
    log.to_csv(tmp_path / "log.csv", index=False)
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "out")])
    one_error_line(result, "'x' parameter of read_log", "outlier_limit = 1000", "a step of 50", "at row 500")


def test_read_log_outlier_limit_names_column_and_row(frame):
    bad = frame.copy()
    bad.loc[77, "shape_velocity_1"] = 1e6
    with pytest.raises(GeogaitError, match=r"'shape_velocity_1' parameter of read_log must be plausible.*row 77"):
        read_log(bad, **COLUMNS)
    assert read_log(bad, outlier_limit=None, **COLUMNS).shape_velocity[77, 1] == 1e6
    with pytest.raises(GeogaitError, match="'outlier_limit' parameter of read_log"):
        read_log(frame, outlier_limit=-1, **COLUMNS)


def test_models_refuse_values_that_would_overflow(run):
    model = AdaptiveGaitModel(gait=GAIT)
    body = run.body_velocity[:10].copy()
    body[3, 0] = 1e200
    with pytest.raises(GeogaitError, match=r"'body_velocity' parameter of AdaptiveGaitModel.partial_fit must be "
                                           r"plausible values, within ±1e\+12. Got '1e\+200 at index \(3, 0\)'"):
        model.partial_fit(run.phase[:10], run.shape[:10], run.shape_velocity[:10], body)
    assert not hasattr(model, "batch_shape_")  # nothing learned


def test_a_non_finite_model_is_never_saved(run, tmp_path):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    path = model.save(tmp_path / "m.npz")
    before = path.read_bytes()
    model.bank_.weights[0, 0, 0] = np.nan
    with pytest.raises(GeogaitError, match=r"Refusing to save .*m.npz: the state went non-finite \(NaN or inf in "
                                           r"weights\)"):
        model.save(path)
    assert path.read_bytes() == before and list(tmp_path.iterdir()) == [path]


# -- 2. stream --out checked before the first sample ---------------------------------------------
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


# -- 3. time units ------------------------------------------------------------------------------
def test_time_unit_converts_and_implausible_rates_are_reported(frame):
    reference = fit_log(read_log(frame, **COLUMNS))
    in_ms = frame.copy()
    in_ms["time"] *= 1000
    for name in ("shape_velocity_0", "shape_velocity_1", *BODY):
        in_ms[name] /= 1000
    with pytest.warns(GeogaitWarning, match=r"0.001 cycles per time unit .*pass time_unit='ms'"):
        fit_log(read_log(in_ms, **COLUMNS))
    log = read_log(in_ms, time_unit="ms", **COLUMNS)
    assert log.time_unit == "s" and np.allclose(log.time, frame["time"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        converted = fit_log(log)
    assert converted.held_out_gamma() == pytest.approx(reference.held_out_gamma(), abs=1e-9)
    in_ns = frame.assign(time=frame["time"] * 1e9)
    with pytest.raises(GeogaitError, match=r"1e-09 cycles per s.*time_unit='ns'"):
        fit_log(read_log(in_ns, time_unit="s", **COLUMNS))
    with pytest.raises(GeogaitError, match="'time_unit' parameter of read_log must be one of 's', 'ms'"):
        read_log(frame, time_unit="minutes", **COLUMNS)


def test_cli_fit_time_unit_and_warning_line(frame, tmp_path):
    in_ms = frame.assign(time=frame["time"] * 1000)
    in_ms.to_csv(tmp_path / "ms.csv", index=False)
    base = ["fit", str(tmp_path / "ms.csv"), "--shape", "shape_0,shape_1", "--pose", "x,y,heading", "--phase", "phase"]
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, result.stderr
    assert "warning: The phase rate found by fit_log is 0.001 cycles per time unit" in result.stderr
    assert "--time-unit ms" in result.stderr
    result = CliRunner().invoke(app, [*base, "--time-unit", "ms", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0 and "warning" not in result.stderr, result.stderr
    report = strict_json((tmp_path / "b" / "report.json").read_text())
    assert report["results"]["phase_rate"] == pytest.approx(2 * np.pi, rel=1e-3)
    result = CliRunner().invoke(app, [*base, "--time-unit", "hours", "--out", str(tmp_path / "c")])
    one_error_line(result, "--time-unit must be one of s, ms, us, ns")


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


# -- 4. one error path --------------------------------------------------------------------------
def test_every_command_reports_os_errors_in_one_line(tmp_path, frame):
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    frame.to_csv(tmp_path / "log.csv", index=False)
    runner = CliRunner()
    one_error_line(runner.invoke(app, ["simulate", "--cycles", "2", "--out", str(a_file)]),
                   f"The output folder {a_file} is a file")
    one_error_line(runner.invoke(app, ["fit", str(tmp_path / "log.csv"), *CLI_COLUMNS, "--out", str(a_file)]),
                   "is a file")
    one_error_line(runner.invoke(app, ["figure", "accuracy", "--quick", "--out", str(a_file)]), "is a file")
    one_error_line(runner.invoke(app, ["optimize", "--cycles", "1", "--out", str(a_file / "x")]))


@pytest.mark.parametrize("content, suffix, message", [
    (b"\x00\x01\x02garbage\xff\xfe", ".csv", "must be a readable CSV file"),
    (b"a,b\n1,2\n3,4,5,6,7\n", ".csv", "Expected 2 fields in line 3, saw 5"),
    (b"", ".csv", "must be a readable CSV file"),
    (b"PAR1 not really parquet", ".parquet", "must be a readable Parquet file"),
])
def test_garbage_logs_give_one_error_line(tmp_path, content, suffix, message):
    path = tmp_path / f"log{suffix}"
    path.write_bytes(content)
    one_error_line(CliRunner().invoke(app, ["fit", str(path), *CLI_COLUMNS, "--out", str(tmp_path / "out")]),
                   "'source' parameter of read_log", message)


def test_bad_option_values_give_one_error_line(tmp_path):
    runner = CliRunner()
    one_error_line(runner.invoke(app, ["simulate", "--cycles", "0", "--out", str(tmp_path)]),
                   "--cycles must be")
    one_error_line(runner.invoke(app, ["simulate", "--noise", "abc", "--out", str(tmp_path)]),
                   "--noise must be")
    one_error_line(runner.invoke(app, ["simulate", "--drag-ratio", "2,nan", "--out", str(tmp_path)]),
                   "--drag-ratio", "finite")
    one_error_line(runner.invoke(app, ["figure", "environments", "--quick", "--drag-ratios", "2,", "--out",
                                       str(tmp_path)]), "--drag-ratios", "comma-separated numbers")
    one_error_line(runner.invoke(app, ["figure", "accuracy", "--from-csv", str(tmp_path / "nope.csv"), "--out",
                                       str(tmp_path)]), "does not exist")
    one_error_line(runner.invoke(app, ["nonsense"]), "No such command 'nonsense'")


def test_comma_list_parses_and_rejects():
    assert comma_list("2, 3,4", "--x") == (2.0, 3.0, 4.0) and comma_list(None, "--x") is None
    assert comma_list("3,5", "--links", int) == (3, 5) and comma_list("a, b", "--shape", str) == ("a", "b")
    for text, kind in (("2,x", float), ("3.5", int), ("a,,b", str), ("inf", float)):
        with pytest.raises(Exception, match="expected"):
            comma_list(text, "--option", kind)


# -- 5. predict never overwrites an input; two outputs ------------------------------------------
@pytest.fixture(scope="module")
def fitted(tmp_path_factory, frame):
    folder = tmp_path_factory.mktemp("fitted")
    frame.to_csv(folder / "log.csv", index=False)
    result = CliRunner().invoke(app, ["fit", str(folder / "log.csv"), *CLI_COLUMNS, "--out", str(folder / "fit")])
    assert result.exit_code == 0, result.stderr
    return folder


def test_predict_refuses_to_overwrite_an_input(fitted):
    log = fitted / "log.csv"
    before = log.read_bytes()
    for out in (log, fitted / "fit" / "model.npz"):
        result = CliRunner().invoke(app, ["predict", str(fitted / "fit" / "model.npz"), str(log), *CLI_COLUMNS,
                                          "--out", str(out)])
        one_error_line(result, "--out must be a file other than the inputs")
    result = CliRunner().invoke(app, ["predict", str(fitted / "fit" / "model.npz"), str(log), *CLI_COLUMNS,
                                      "--out", str(fitted / "p.csv"), "--summary", str(log)])
    one_error_line(result, "--summary must be a file other than the inputs")
    assert log.read_bytes() == before


def test_predict_writes_predictions_and_summary_to_two_files(fitted):
    command = ["predict", str(fitted / "fit" / "model.npz"), str(fitted / "log.csv"), *CLI_COLUMNS, "--out"]
    result = CliRunner().invoke(app, [*command, str(fitted / "p.json")])  # (a CSV under a JSON name: refused)
    one_error_line(result, "--out is the predictions CSV file: give a name ending in .csv. Got")
    assert not (fitted / "p.json").exists() and not (fitted / "p.summary.json").exists()
    out = fitted / "p.csv"
    result = CliRunner().invoke(app, [*command, str(out), "--summary", str(fitted / "p.summary.json")])
    assert result.exit_code == 0, result.stderr
    predictions = pd.read_csv(out)
    summary = strict_json((fitted / "p.summary.json").read_text())
    assert len(predictions) == 1200 and summary["results"]["gamma"] > 0.5
    assert summary["geogait_version"] and summary["numpy_version"] and summary["options"]["outlier_limit"] == 1000


# -- 6. PhaseModel.save ---------------------------------------------------------------------------
def test_phase_model_saves_and_loads(run, tmp_path):
    model = PhaseModel(n_windows=12).fit(run.phase, run.body_velocity)
    loaded = load_model(model.save(tmp_path / "phase.npz"))
    assert isinstance(loaded, PhaseModel) and loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.predict(run.phase), model.predict(run.phase))
    assert PhaseModel.load(tmp_path / "phase.npz").n_samples_seen_ == run.n_samples


# -- 7. strict JSON everywhere --------------------------------------------------------------------
def test_json_outputs_have_null_and_a_reason_instead_of_nan(tmp_path):
    value = {"gamma": float("nan"), "series": np.array([1.0, np.inf]), "nested": {"x": -np.inf}, "n": np.int64(3)}
    assert json_ready(value) == {"gamma": None, "gamma_null_reason": "was nan", "series": [1.0, None],
                                 "series_null_reason": "[1] was inf", "nested": {"x": None,
                                                                                  "x_null_reason": "was -inf"},
                                 "n": 3}
    path = write_manifest(tmp_path / "m.json", command="test", config={"a": np.nan}, results=value, started=0.0)
    manifest = strict_json(path.read_text())
    assert manifest["config"] == {"a": None, "a_null_reason": "was nan"} and manifest["geogait_version"]
    sink = _Sink()
    _JsonLinesWriter(sink).write(StreamOutput(0, 1.0, 0.5, np.array([np.nan, 0.0, 1.0]), float("inf"), True))
    line = strict_json(sink.text)
    assert line["gamma"] is None and line["gamma_null_reason"] == "was inf"
    assert line["prediction"] == [None, 0.0, 1.0] and line["prediction_null_reason"] == "[0] was nan"


# -- 8. modes and symbolic links ------------------------------------------------------------------
def test_saving_keeps_the_mode_and_writes_through_links(run, tmp_path):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase[:300], run.shape[:300], run.shape_velocity[:300],
                                             run.body_velocity[:300])
    path = model.save(tmp_path / "m.npz")
    path.chmod(0o640)
    model.save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    link = tmp_path / "link.npz"
    link.symlink_to(path)
    model.partial_fit(run.phase[300:400], run.shape[300:400], run.shape_velocity[300:400],
                      run.body_velocity[300:400])
    model.save(link)
    assert link.is_symlink() and load_model(path).n_samples_seen_ == 400
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    previous = os.umask(0o027)
    try:
        fresh = write_json(tmp_path / "new.json", {"a": 1})
    finally:
        os.umask(previous)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o640


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = write_json(tmp_path / "a.json", {"a": 1})

    def explode(stream):
        stream.write(b"partial")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        atomic_write(path, explode)
    assert strict_json(path.read_text()) == {"a": 1} and sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_stale_temporary_files_of_dead_processes_are_removed(tmp_path):
    stale = tmp_path / ".m.npz.999999999.abc123.tmp"  # no such pid
    alive = tmp_path / f".m.npz.{os.getppid()}.def456.tmp"  # a live process may still be writing it
    other = tmp_path / ".other.npz.999999999.x.tmp"
    for path in (stale, alive, other):
        path.write_bytes(b"half")
    write_json(tmp_path / "m.npz", {"a": 1})
    assert not stale.exists() and alive.exists() and other.exists()


def test_check_writable(tmp_path):
    assert check_writable(tmp_path / "x.npz") == tmp_path / "x.npz" and not (tmp_path / "x.npz").exists()
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(GeogaitError, match="its folder .*missing does not exist"):
        check_writable(tmp_path / "missing" / "x.npz")
    (tmp_path / "notes.txt").write_text("a file")  # a path through a file is said as such
    with pytest.raises(GeogaitError, match=r"notes.txt is a file, not a folder"):
        check_writable(tmp_path / "notes.txt" / "sub" / "x.npz", "model file")


# -- 9. figures redrawn from CSV --------------------------------------------------------------------
def test_redraw_keeps_the_run_manifest(tmp_path):
    runner = CliRunner()
    result = runner.invoke(app, ["figure", "environments", "--quick", "--trials", "2", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.stderr
    manifest = (tmp_path / "environments.json").read_text()
    result = runner.invoke(app, ["figure", "environments", "--from-csv", str(tmp_path / "environments.csv"),
                                 "--out", str(tmp_path)])
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "environments.json").read_text() == manifest
    redraw = strict_json((tmp_path / "environments.redraw.json").read_text())
    assert redraw["config"]["from_csv"].endswith("environments.csv")
    assert "wrote environments.png, environments.redraw.json to" in result.stderr.replace("\n", " ")
    assert "environments.csv" not in result.stderr.split("wrote")[-1]


# -- 10. end-of-stream message ----------------------------------------------------------------------
def test_end_message_when_save_every_divides_the_sample_count(run, config, tmp_path):
    out = tmp_path / "m.npz"
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(out), "--save-every", "50"],
                                input=lines(run, 0, 200))
    assert result.exit_code == 0
    assert "200 of 200 samples learned; online Γ" in result.stderr and f"saved the model to {out}" in result.stderr
    manifest = strict_json((tmp_path / "m.stream.json").read_text())
    assert manifest["command"] == "stream" and manifest["geogait_version"] and manifest["results"]["n_learned"] == 200
    assert load_model(out).n_samples_seen_ == 200


# -- 11. the rest -------------------------------------------------------------------------------------
def test_rebase_validates_every_argument_before_changing_anything(run):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    weights, covariance = model.window_weights_.copy(), model.covariance_.copy()
    new_gait = seed_gait(2, 1.2)
    for kwargs, name in (({"baseline": "bogus"}, "baseline"), ({"covariance_inflation": 0.5}, "covariance_inflation"),
                         ({"constant_variance": -1.0}, "constant_variance"), ({"terms": "x"}, "terms")):
        with pytest.raises(GeogaitError, match=f"'{name}' parameter of AdaptiveGaitModel.rebase"):
            model.rebase(new_gait, **kwargs)
        np.testing.assert_array_equal(model.window_weights_, weights)
        np.testing.assert_array_equal(model.covariance_, covariance)
        assert model.gait_ == GAIT


def test_degrees_given_as_radians_are_warned_about(run, config, tmp_path):
    message = r"'shape' values of AdaptiveGaitModel.partial_fit reach \d+\.\d+, more than a full turn.*degrees"
    with pytest.warns(GeogaitWarning, match=message):
        AdaptiveGaitModel(gait=GAIT).partial_fit(run.phase, np.rad2deg(run.shape), run.shape_velocity,
                                                 run.body_velocity)
    text = "".join(json.dumps(record(run, s, shape=np.rad2deg(run.shape[s]).tolist())) + "\n" for s in range(60))
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "m.npz")], input=text)
    assert result.exit_code == 0 and result.stderr.count("warning: The 'shape' values") == 1, result.stderr


@pytest.mark.parametrize("arrays, message", [
    (lambda r: (None, r.shape, r.shape_velocity, r.body_velocity), r"'phase' .* an array of real numbers. Got None"),
    (lambda r: (r.phase[:0], r.shape[:0], r.shape_velocity[:0], r.body_velocity[:0]), r"at least one sample"),
    (lambda r: (r.phase, r.shape.T, r.shape_velocity, r.body_velocity), r"'shape' .*\(transposed\?"),
    (lambda r: (r.phase, r.shape, r.shape_velocity, r.body_velocity.T), r"'body_velocity' .*\(transposed\?"),
    (lambda r: (r.phase, r.shape + 1j, r.shape_velocity, r.body_velocity), r"'shape' .* real numbers. Got 'complex"),
    (lambda r: (r.phase.astype(str), r.shape, r.shape_velocity, r.body_velocity), r"'phase' .* Got 'text \(<U"),
    (lambda r: (r.phase, r.shape, r.shape_velocity.astype(object).astype(str).astype(object), r.body_velocity),
     r"'shape_velocity' .* Got 'text, booleans or complex numbers among"),
    (lambda r: (r.phase[None, :0], r.shape[None, :0], r.shape_velocity[None, :0], r.body_velocity[None, :0]),
     r"at least one sample"),
    (lambda r: (r.phase[None][:0], r.shape[None][:0], r.shape_velocity[None][:0], r.body_velocity[None][:0]),
     r"'phase' .* at least one trial along each leading axis"),
    (lambda r: (r.phase, r.shape[:, :0], r.shape_velocity[:, :0], r.body_velocity), r"'shape' .* at least one column"),
])
def test_partial_fit_bad_arrays_have_clear_errors(run, arrays, message):
    with pytest.raises(GeogaitError, match=message):
        AdaptiveGaitModel(gait=GAIT).partial_fit(*arrays(run))


def test_garbage_model_file_error_does_not_mention_pickle(tmp_path):
    for content in (b"garbage" * 10, b"\x80\x04\x95" + b"x" * 40):
        path = tmp_path / "m.npz"
        path.write_bytes(content)
        with pytest.raises(GeogaitError) as info:
            load_model(path)
        assert "pickle" not in str(info.value) and "not a readable geogait model" in str(info.value)
        result = CliRunner().invoke(app, ["stream", str(path)], input="")
        assert "pickle" not in one_error_line(result, "not a readable geogait model")


def test_sizes_and_scales_are_bounded(tmp_path):
    one_error_line(CliRunner().invoke(app, ["simulate", "--samples-per-cycle", str(10**7), "--out", str(tmp_path)]),
                   "--samples-per-cycle must be")
    one_error_line(CliRunner().invoke(app, ["simulate", "--samples-per-cycle", "100000", "--cycles", "1000",
                                            "--out", str(tmp_path)]), "at most 10,000,000 samples")
    assert not (tmp_path / "trajectory.csv").exists()
    for kwargs, message in (({"n_links": 10**6}, r"'n_links' .* an int in \[2, 200\]"),
                            ({"drag_coefficient": 1e-320}, r"'drag_coefficient' .* in \[1e-06, 1e\+06\]"),
                            ({"link_lengths": [1e200, 1, 1]}, r"'link_lengths' .* lengths in \[1e-06"),
                            ({"link_lengths": [1e-200, 1, 1]}, r"'link_lengths' .* lengths in \[1e-06"),
                            ({"drag_ratio": 1e300}, r"'drag_ratio'")):
        with pytest.raises(GeogaitError, match=message):
            PurcellSwimmer(**kwargs)


@pytest.mark.parametrize("command", [["simulate"], ["fit"], ["predict"], ["stream"], ["optimize"],
                                     ["figure", "accuracy"], ["figure", "environments"], ["figure", "optimization"]])
def test_help_shows_defaults_without_stray_periods(command):
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert not re.search(r" \.(\s|$)", result.stdout), result.stdout  # rich ate a "[default: …]"
    if command[0] == "figure" and command[1] != "optimization":
        assert "[default: 3]" in result.stdout and "geogait[dask]" in result.stdout


def test_fit_report_carries_versions(fitted):
    report = strict_json((fitted / "fit" / "report.json").read_text())
    assert report["command"] == "fit" and report["geogait_version"] and report["numpy_version"]
    assert report["options"]["time_unit"] is None


class _Sink:
    """A text sink that remembers what was written."""

    def __init__(self):
        self.text = ""

    def write(self, text):
        self.text += text

    def flush(self):
        pass


def test_files_module_is_the_only_atomic_writer():
    source = Path(__file__).resolve().parents[1] / "src" / "geogait"
    writers = [path.relative_to(source).as_posix() for path in source.rglob("*.py")
               if "os.replace(" in path.read_text() or "mkstemp(" in path.read_text()]
    assert writers == ["_files.py"]


def test_a_failed_fit_leaves_the_fitted_model_unchanged(run):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    weights, seen = model.window_weights_.copy(), model.n_samples_seen_
    with pytest.raises(GeogaitError, match="'shape_velocity' parameter"):
        model.fit(run.phase, run.shape, run.shape_velocity[:, :1], run.body_velocity)
    np.testing.assert_array_equal(model.window_weights_, weights)
    assert model.n_samples_seen_ == seen
    phase_model = PhaseModel().fit(run.phase, run.body_velocity)
    with pytest.raises(GeogaitError, match="'body_velocity' parameter"):
        phase_model.fit(run.phase, run.body_velocity[:, :2])
    assert phase_model.n_samples_seen_ == run.n_samples


@pytest.mark.parametrize("command", ["accuracy", "environments", "optimization"])
@pytest.mark.parametrize("option", [["--links", "300"], ["--seed", "-1"], ["--trials", "0"], ["--jobs", "0"]])
def test_figure_options_are_checked_before_running(tmp_path, command, option):
    result = CliRunner().invoke(app, ["figure", command, "--quick", *option, "--out", str(tmp_path)])
    assert option[0].lstrip("-") in one_error_line(result).lower()
    assert not any(tmp_path.iterdir())


def test_more_entry_points_name_the_field(tmp_path):
    from geogait.phase import Phaser
    from geogait.simulate import cycle_displacement

    with pytest.raises(GeogaitError, match=r"'x' parameter of Phaser.fit must be plausible values, within ±1e\+12"):
        Phaser().fit(np.full((1000, 2), 1e300))
    with pytest.raises(GeogaitError, match=r"'gait' parameter of cycle_displacement must be a FourierGait with 2 "
                                           r"joints \(the system's\). Got '3 joints'"):
        cycle_displacement(PurcellSwimmer(3), seed_gait(3))
    for option, value in (("--noise", "1e300"), ("--amplitude", "1e6"), ("--seed", "-1")):
        one_error_line(CliRunner().invoke(app, ["simulate", option, value, "--out", str(tmp_path)]),
                       f"{option} must be")


def test_undecodable_stream_input_stops_with_a_clear_error(run, tmp_path):
    class Broken:
        def __iter__(self):
            yield from lines(run, 0, 5).splitlines(True)
            raise UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte")

    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), path=tmp_path / "m.npz")
    summary = run_stream(learner, Broken(), _Sink())
    assert summary.reason == "error" and "unreadable input after 5 sample(s)" in summary.error
    assert summary.saved == tmp_path / "m.npz" and load_model(summary.saved).n_samples_seen_ == 5


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


def test_predict_warns_when_the_log_is_in_another_time_unit(fitted, frame):
    in_ms = frame.assign(time=frame["time"] * 1000)  # time and rates in ms
    for name in ("shape_velocity_0", "shape_velocity_1", *BODY):
        in_ms[name] /= 1000
    in_ms.to_csv(fitted / "ms.csv", index=False)
    base = ["predict", str(fitted / "fit" / "model.npz"), str(fitted / "ms.csv"), *CLI_COLUMNS]
    result = CliRunner().invoke(app, [*base, "--out", str(fitted / "ms_p.csv")])
    assert result.exit_code == 0 and "warning: The log's phase advances at 0.006283 rad per time unit, 0.001 times" \
        in result.stderr, result.stderr
    result = CliRunner().invoke(app, [*base, "--time-unit", "ms", "--out", str(fitted / "ms_p.csv"), "--overwrite"])
    assert result.exit_code == 0 and "warning" not in result.stderr, result.stderr
    assert strict_json((fitted / "ms_p.json").read_text())["results"]["gamma"] > 0.5  # converted: a good fit


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


@pytest.mark.parametrize(("options", "match"), [
    (dict(seed=-1), "'seed'.*>= 0"),
    (dict(sensor_noise=1e300), "'sensor_noise'"),
    (dict(shape_noise=-0.1), "'shape_noise'"),
    (dict(samples_per_cycle=10**7), "'samples_per_cycle'"),
])
def test_swimmer_stream_bounds(options, match):
    from geogait.gaits import seed_gait as _seed_gait
    from geogait.simulate import SwimmerStream as _Stream
    from geogait.systems import PurcellSwimmer as _Swimmer

    with pytest.raises(ValueError, match=match):
        _Stream(_Swimmer(3), _seed_gait(2), **options)


def test_trajectory_files_are_written_atomically_and_empty_joins_refused(tmp_path):
    from geogait.gaits import seed_gait as _seed_gait
    from geogait.simulate import Trajectory as _Trajectory
    from geogait.simulate import simulate as _simulate
    from geogait.systems import PurcellSwimmer as _Swimmer

    run = _simulate(_Swimmer(3), _seed_gait(2), 2, seed=0)
    link = tmp_path / "link.csv"
    target = tmp_path / "target.csv"
    target.write_text("old")
    link.symlink_to(target)
    run.to_csv(link)
    assert link.is_symlink() and len(pd.read_csv(target)) == run.n_samples
    run.to_parquet(tmp_path / "run.parquet")
    assert _Trajectory.from_pandas(pd.read_parquet(tmp_path / "run.parquet")).n_samples == run.n_samples
    assert not list(tmp_path.glob(".*tmp*"))
    with pytest.raises(ValueError, match="'parts'"):
        _Trajectory.concatenate([])


@pytest.mark.parametrize(("arguments", "fragments"), [
    (["optimize", "--method", "adaptive", "--forgetting-factor", "1.5"], ["--forgetting-factor", "(0, 1]"]),
    (["optimize", "--forgetting-factor", "0.95"], ["--forgetting-factor applies to --method adaptive or shape"]),
    (["optimize", "--method", "batch", "--forgetting-factor", "0.95"], ["--method batch does not use it"]),
    (["optimize", "--noise", "inf"], ["--noise", "finite number ≥ 0"]),
    (["optimize", "--noise", "200"], ["--noise", "[0, 100]"]),
    (["optimize", "--perturbation", "1e308"], ["--perturbation", "[0, 2π]"]),
    (["optimize", "--robot", "python -m geogait.robots.driver", "--model-class-cycles", "3"],
     ["--model-class-cycles", "no message that changes a driver's period"]),
    (["track", "--quick", "--cycles", "-3"], ["--cycles", "1..1000000"]),
    (["track", "--quick", "--warmup", "0"], ["--warmup"]),
    (["track", "--quick", "--offset", "nan"], ["--offset", "finite"]),
    (["track", "--quick", "--links", "2"], ["--links", ">= 3"]),
    (["track", "--quick", "--noise", "inf"], ["--noise"]),
    (["track", "--quick", "--seed", "-1"], ["--seed"]),
    (["simulate", "--links", "2"], ["--links"]),
    (["figure", "optimization", "--quick", "--links", "2"], ["--links", ">= 3"]),
    (["figure", "accuracy", "--quick", "--links", "1"], ["--links", ">= 2"]),
    (["figure", "environments", "--quick", "--forgetting-factors", "2"], ["--forgetting-factors", "(0, 1]"]),
    (["figure", "tracking", "--quick", "--links", "2"], ["--links", ">= 3"]),
    (["figure", "tracking", "--quick", "--exploration-low", "-1"], ["--exploration-low"]),
    (["figure", "tracking", "--quick", "--cycles", "1"], ["--cycles", ">= 2"]),
    (["simulate", "--amplitude", "nan"], ["--amplitude", "finite number ≥ 0 and ≤ 6.28319", "got nan"]),
    (["simulate", "--noise=-inf"], ["--noise", "finite number ≥ 0 and ≤ 100"]),
    (["optimize", "--noise", "NaN"], ["--noise", "finite number ≥ 0"]),
    (["fit", "no-such-log.csv"], ["LOG argument", "'no-such-log.csv' (does not exist)"]),
    (["fit", "no-such-log.csv", "--smoothing-window", "2"], ["--smoothing-window", "odd number of samples >= 3"]),
    (["optimize", "--robot-timeout", "5"], ["--robot-timeout", "built-in swimmer has none"]),
    (["optimize", "--robot", "python -m geogait.robots.driver", "--links", "5", "--period", "2"],
     ["--links, --period set up the built-in swimmer"]),
    (["optimize", "--links", "2"], ["--links must be ≥ 3; got 2."]),
    (["optimize", "--max-joint-angle", "3.5"], ["--max-joint-angle", "[1, π]"]),
    (["optimize", "--robot", "python -m geogait.robots.driver", "--robot-timeout", "-1"], ["--robot-timeout", "> 0"]),
    (["track", "--quick", "--step", "0.05"], ["--step", "robot"]),
])
def test_bad_options_are_refused_before_anything_runs_or_is_written(tmp_path, arguments, fragments):
    """Each of these was once refused only after the run had started (a progress line, then the error, and a
    run.json or lock left in --out that blocked the corrected command), or failed deep inside with another
    field's name: now one line, naming the option, and --out untouched."""
    out = tmp_path / "out"
    result = CliRunner().invoke(app, [*arguments, "--out", str(out)])
    one_error_line(result, *fragments)
    assert not out.exists() or not any(out.iterdir())


def test_simulate_keeps_an_earlier_simulation_unless_told_to_replace_it(tmp_path):
    out = tmp_path / "sim"
    arguments = ["simulate", "--cycles", "1", "--samples-per-cycle", "20", "--out", str(out)]
    assert CliRunner().invoke(app, arguments).exit_code == 0
    before = (out / "trajectory.csv").read_bytes()
    one_error_line(CliRunner().invoke(app, [*arguments[:-2], "--seed", "3", "--out", str(out)]),
                   "is not empty", "--overwrite")
    assert (out / "trajectory.csv").read_bytes() == before
    replaced = CliRunner().invoke(app, [*arguments[:-2], "--seed", "3", "--overwrite", "--out", str(out)])
    assert replaced.exit_code == 0, replaced.output
    assert (out / "trajectory.csv").read_bytes() != before
    assert json.loads((out / "manifest.json").read_text())["config"]["seed"] == 3


def test_helpers_refuse_what_would_come_back_as_nan(run):
    """A negative or NaN residual variance, a NaN phase, a negative derivative order: each a clear error, where
    each once returned NaN (or a silent answer) for the caller to carry on with."""
    from geogait.gaits import fourier_basis
    from geogait.models import ResistanceModel, ShapeSpaceModel
    from geogait.systems import PurcellSwimmer

    arrays = (run.phase, run.shape, run.shape_velocity, run.body_velocity)
    for model in (AdaptiveGaitModel(gait=GAIT).fit(*arrays), ShapeSpaceModel().fit(*arrays),
                  ResistanceModel.from_swimmer(PurcellSwimmer(3)).fit(*arrays)):
        for variance in (-1.0, np.nan, "x"):
            with pytest.raises(GeogaitError, match=r"'residual_variance' parameter .* a variance >= 0"):
                model.rotation_std(GAIT, variance)
        assert np.isfinite(model.rotation_std(GAIT, 0.01))
    with pytest.raises(GeogaitError, match=r"'phase' parameter of fourier_basis must be finite"):
        GAIT.shape(np.array([0.0, np.nan]))
    with pytest.raises(GeogaitError, match=r"'derivative' parameter of fourier_basis must be an int >= 0"):
        fourier_basis(0.0, 2, derivative=-1)
    np.testing.assert_allclose(fourier_basis(0.3, 1, derivative=1), [0.0, -np.sin(0.3), np.cos(0.3)])


@pytest.mark.parametrize(("options", "match"), [
    (dict(forgetting_factor=2.0), "'forgetting_factor' parameter"),
    (dict(n_windows=-1), "'n_windows' parameter"),
    (dict(max_gait_order="x"), "'max_gait_order' parameter of fit_log"),
    (dict(gait_order=-1), "'gait_order' parameter of fit_log"),
    (dict(refit="no"), "'refit' parameter of fit_log must be True or False"),
])
def test_fit_log_checks_every_argument_before_it_fits_the_phaser(frame, options, match):
    """The phaser handed in was fitted first and the bad argument refused after; 'no' counted as True."""
    from geogait.io import read_log
    from geogait.learn import fit_log
    from geogait.phase import Phaser

    log = read_log(frame.drop(columns="phase"), **{**COLUMNS, "phase": None})
    phaser = Phaser()
    with pytest.raises(GeogaitError, match=match):
        fit_log(log, phaser=phaser, **options)
    assert not phaser.__sklearn_is_fitted__()
    fitted = fit_log(log, phaser=phaser).phaser
    assert fitted is phaser and phaser.__sklearn_is_fitted__()
    with pytest.raises(GeogaitError, match="'phaser' parameter of fit_log must be an unfitted Phaser"):
        fit_log(log, phaser=phaser)


def test_a_mapping_or_stream_config_that_is_not_utf8_is_bad_input_not_a_bug(tmp_path):
    from geogait.io import load_column_mapping
    from geogait.learn import load_stream_model

    for name, load in (("mapping.json", load_column_mapping), ("config.json", load_stream_model)):
        path = tmp_path / name
        path.write_bytes(b"\xff\xfe{}")
        with pytest.raises(GeogaitError, match=r"'path' parameter of .* must be a UTF-8 text file. .*byte 0xff"):
            load(path)
    mapping = str(tmp_path / "mapping.json")
    result = CliRunner().invoke(app, ["fit", mapping, "--mapping", mapping, "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and "bug" not in result.stderr


def test_small_api_gaps_are_clear_errors(tmp_path):
    """Each of these raised a TypeError or ZeroDivisionError, failed every trial of a sweep, or returned a grid
    spanning 7.5 rad: now one error naming the argument."""
    from geogait.experiments import EnvironmentConfig, OptimizationConfig, TrackingConfig
    from geogait.experiments.robot_benchmark import from_manifest
    from geogait.se2 import gauss_phases

    for make, match in ((lambda: OptimizationConfig(links=3).validate(), "'links' parameter .* a tuple"),
                        (lambda: EnvironmentConfig(drag_ratios=(2.0, 1e7)).validate(), "'drag_ratios'"),
                        (lambda: TrackingConfig(drag_ratios=(2.0, 1e7)).validate(), "'drag_ratios'"),
                        (lambda: gauss_phases(0), "'resolution' parameter of gauss_phases"),
                        (lambda: gauss_phases(2.5), "'resolution' parameter of gauss_phases")):
        with pytest.raises(GeogaitError, match=match):
            make()
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(GeogaitError, match="is not a robot benchmark manifest"):
        from_manifest(tmp_path / "list.json")
