"""Every bad option value ends in one line in the CLI's words: ``error: --option must be …; got ….``"""

import pytest
from typer.testing import CliRunner

from geogait.cli import app
from geogait.cli._app import in_cli_words


@pytest.mark.parametrize(("args", "line"), [
    # typer's checks (choices, ranges, types)
    (["optimize", "--objective", "x"],
     "error: --objective must be one of progress, efficiency, forward, budget; got 'x'."),
    (["optimize", "--links", "2"], "error: --links must be ≥ 3; got 2."),
    (["optimize", "--links", "three"], "error: --links must be an integer; got 'three'."),
    (["simulate", "--amplitude", "7"], "error: --amplitude must be ≤ 6.283; got 7."),
    (["stream", "model.npz", "--format", "xml"], "error: --format must be one of jsonl, csv; got 'xml'."),
    # the library's checks of the parameter an option sets
    (["optimize", "--gamma-threshold", "2"], "error: --gamma-threshold must be a finite float in (-inf, 1); got 2.0."),
    (["optimize", "--cycles", "0"], "error: --cycles must be an int >= 1; got 0."),
    (["optimize", "--max-joint-velocity", "1e-9", "--cycles", "1"],
     "error: --max-joint-velocity must be at least the peak joint speed of the robot's seed gait (6.283 rad/s), "
     "where the run starts; got 1e-09."),
    (["optimize", "--period", "1e300"], "error: --period must be ≤ 1e+04; got 1e300."),
    (["simulate", "--links", "1000"], "error: --links must be an int in [2, 200]; got 1000."),
    (["simulate", "--drag-ratio", "0"], "error: --drag-ratio must be a finite float in [1e-06, 1e+06]; got 0.0."),
    (["figure", "optimization", "--links", "2"], "error: --links must be an int >= 3; got 2."),
    # the CLI's own checks
    (["optimize", "--noise", "nan"], "error: --noise must be a finite number ≥ 0; got nan."),
    (["optimize", "--max-tracking-error", "x"],
     "error: --max-tracking-error must be a number, 'auto' or 'off'; got 'x'."),
    (["track", "--drag-ratio", "0"], "error: --drag-ratio must be one positive number or two, comma-separated (before "
                                     "and after the change, e.g. 2,4); got '0.0'."),
])
def test_a_bad_value_is_said_of_its_option(tmp_path, args, line):
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "out")] if args[0] != "stream" else args)
    assert result.exit_code == 1, result.output
    assert [text for text in result.stderr.splitlines() if "error" in text] == [line]
    assert not (tmp_path / "out").exists()


def test_a_library_message_about_no_option_stays_as_it_is():
    text = "The 'source' parameter of read_log must be a CSV or Parquet file. Got 'x.txt' instead."
    assert in_cli_words(text, {"shape": "--shape"}) == text
    assert in_cli_words(text.replace("source", "shape"), {"shape": "--shape"}) == (
        "--shape must be a CSV or Parquet file; got 'x.txt'.")
    assert in_cli_words("The '--jobs' option and '--scheduler' option spread trials.", {}) == (
        "--jobs and --scheduler spread trials.")
