"""``geogait fit`` / ``geogait predict`` check the logs they read and the files they write (issue 11): implausible
and garbage logs named by column and row, time units, predictions and summary in two files that are never an input,
versions in the report; an earlier run's files kept unless told to replace them (issue 21)."""

import numpy as np
import pandas as pd
import pytest
from _cli import invoke, one_error_line
from _noisy_run import frame as frame
from _noisy_run import run as run
from _reference import BODY, CLI_COLUMNS, GAIT, strict_json
from typer.testing import CliRunner

from geogait._files import write_text
from geogait.cli import app
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def fitted(tmp_path_factory, frame):
    folder = tmp_path_factory.mktemp("fitted")
    frame.to_csv(folder / "log.csv", index=False)
    result = CliRunner().invoke(app, ["fit", str(folder / "log.csv"), *CLI_COLUMNS, "--out", str(folder / "fit")])
    assert result.exit_code == 0, result.stderr
    return folder


def test_fit_rejects_a_huge_pose_naming_column_and_row(run, tmp_path):
    log = run.to_pandas()[["time", "shape_0", "shape_1", "x", "y", "heading"]].copy()
    log.loc[500, "x"] = 1e300
    log.to_csv(tmp_path / "log.csv", index=False)
    base = ["fit", str(tmp_path / "log.csv"), "--shape", "shape_0,shape_1", "--pose", "x,y,heading"]
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "out")])
    one_error_line(result, "the log's column 'x' must be", "within ±1e+12", "1e+300 at row 500")
    assert not (tmp_path / "out" / "model.npz").exists()
    log.loc[500, "x"] = log.loc[499, "x"] + 50.0  # finite, but a 50-length jump in one step
    log.to_csv(tmp_path / "log.csv", index=False)
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "out")])
    one_error_line(result, "the log's column 'x' must be", "--outlier-limit = 1000", "a step of 50", "at row 500")


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
                   "error: the log must be", message)


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


def test_fit_report_carries_versions(fitted):
    report = strict_json((fitted / "fit" / "report.json").read_text())
    assert report["command"] == "fit" and report["geogait_version"] and report["numpy_version"]
    assert report["options"]["time_unit"] is None


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


def test_fit_predict_and_the_figures_keep_an_earlier_runs_files_unless_told_to_replace_them(tmp_path):
    """Each is refused before any work, naming the file and --overwrite, and leaves the earlier files as they were."""
    run = simulate(PurcellSwimmer(3), GAIT, 12, seed=0, samples_per_cycle=100)
    pd.DataFrame({"time": run.time, "shape_0": run.shape[:, 0], "shape_1": run.shape[:, 1], "x": run.pose[:, 0],
                  "y": run.pose[:, 1], "heading": run.pose[:, 2]}).to_csv(tmp_path / "log.csv", index=False)
    fit = ["fit", str(tmp_path / "log.csv"), "--shape", "shape_0,shape_1", "--pose", "x,y,heading",
           "--out", str(tmp_path / "fit")]
    predict = ["predict", str(tmp_path / "fit" / "model.npz"), str(tmp_path / "log.csv"), "--phaser",
               str(tmp_path / "fit" / "phaser.npz"), "--shape", "shape_0,shape_1", "--out", str(tmp_path / "p.csv")]
    for command in (fit, predict):
        assert invoke(*command).exit_code == 0
    (tmp_path / "figures").mkdir()
    for name in ("accuracy", "environments"):
        (tmp_path / "figures" / f"{name}.csv").write_text("a full run's results")
    write_text(tmp_path / "optimization.json", "{}")
    write_text(tmp_path / "tracking.png", "")
    saved = {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()}
    figures = str(tmp_path / "figures")
    for command, name in ((fit, "model.npz"), (predict, "p.csv"),
                          (["figure", "accuracy", "--quick", "--out", figures], "accuracy.csv"),
                          (["figure", "environments", "--quick", "--out", figures], "environments.csv"),
                          (["figure", "optimization", "--quick", "--out", str(tmp_path)], "optimization.json"),
                          (["figure", "tracking", "--quick", "--out", str(tmp_path)], "tracking.png")):
        one_error_line(invoke(*command), f"{name} exists", "give --overwrite to replace it")
    assert {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()} == saved
    assert invoke(*predict, "--overwrite").exit_code == 0
