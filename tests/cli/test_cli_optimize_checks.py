"""``geogait optimize``: budgets, option ranges and run.json fields checked before the robot moves."""

import json
import shlex
import shutil
import sys

import pytest
from typer.testing import CliRunner

from geogait.cli import app


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def one_error_line(result, *fragments):
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "a bug in geogait" not in errors[0] and all(fragment in errors[0] for fragment in fragments), errors[0]
    return errors[0]


@pytest.mark.parametrize(("options", "message"), [
    (["--settle-cycles", "6", "--cycles", "6"], "--cycles 6 holds no measured cycle: with --settle-cycles 6 the "
     "first 6 cycles are not measured; give --cycles 7 or more, or fewer --settle-cycles."),
    (["--model-class-cycles", "3", "--cycles", "8"], "--cycles 8 holds no measured cycle: with --model-class-cycles "
     "3 the first 8 cycles are not measured; give --cycles 9 or more, or fewer --model-class-cycles."),
    (["--model-class-cycles", "3", "--settle-cycles", "50"], "the default budget of 40 cycles holds no measured "
     "cycle: with --settle-cycles 50 and --model-class-cycles 3 the first 156 cycles are not measured; give "
     "--cycles 157 or more"),
])
def test_a_budget_that_holds_no_measured_cycle_is_refused_before_the_run(tmp_path, options, message):
    """Issue 58, finding 8: such a run spent every cycle, then ended in an IndexError with no cycles.csv."""
    one_error_line(invoke("optimize", *options, "--out", tmp_path / "run"), message)
    assert not (tmp_path / "run").exists()


def test_a_robot_is_not_started_for_a_budget_that_holds_no_measured_cycle(tmp_path):
    moved = tmp_path / "moved"
    driver = shlex.join([sys.executable, "-c", f"open({str(moved)!r}, 'w')"])
    one_error_line(invoke("optimize", "--robot", driver, "--settle-cycles", "5", "--cycles", "5", "--out",
                          tmp_path / "run"), "--cycles 5 holds no measured cycle", "give --cycles 6 or more")
    assert not moved.exists() and not (tmp_path / "run").exists()


@pytest.mark.parametrize("period", ["1e-300", "0.0009", "86401", "1e300", "0", "-1"])
def test_a_period_the_swimmer_cannot_run_is_an_option_error(tmp_path, period):
    """Issue 58, finding 8: --period 1e-300 ended in an OverflowError (1e-100: a model error after the start)."""
    one_error_line(invoke("optimize", "--period", period, "--out", tmp_path / "run"),
                   "--period must be")
    assert not (tmp_path / "run").exists()


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs") / "a"
    result = invoke("optimize", "--cycles", "2", "--out", folder)
    assert result.exit_code == 0, result.output
    return folder


@pytest.mark.parametrize(("field", "value", "expected"), [
    ("model_class_cycles", "3", "an integer"), ("model_class_cycles", [3], "an integer"),
    ("climb", ["on"], "a string or null"), ("climb", {}, "a string or null"),
    ("climb_rule", 1, "a string or null"), ("direction_frame", None, "a string"),
])
def test_a_run_json_field_of_the_wrong_type_is_named_on_resume(finished, tmp_path, field, value, expected):
    """Issue 58, finding 8: an edited run.json gave a TypeError on --resume."""
    folder = tmp_path / "run"
    shutil.copytree(finished, folder)
    settings = json.loads((folder / "run.json").read_text())
    (folder / "run.json").write_text(json.dumps({**settings, field: value}))
    before = {path.name: path.read_bytes() for path in folder.iterdir()}
    one_error_line(invoke("optimize", "--resume", folder, "--cycles", "4"),
                   f"run.json is not the settings record of a run: '{field}' must be {expected}, got")
    assert {path.name: path.read_bytes() for path in folder.iterdir()} == before

