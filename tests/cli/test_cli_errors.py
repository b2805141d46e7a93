"""Every bad option value ends in one line in the CLI's words: ``error: --option must be …; got ….``; so do OS
errors, and options are refused before anything runs or is written (issue 11)."""

import pytest
from _cli import one_error_line
from _noisy_run import frame as frame
from _noisy_run import run as run
from _reference import CLI_COLUMNS
from typer.testing import CliRunner

from geogait.cli import app
from geogait.cli._app import in_cli_words
from geogait.cli._common import comma_list


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
    text = "The 'alpha' parameter of Perturbation must be finite. Got nan instead."
    assert in_cli_words(text, {"shape": "--shape"}) == text
    assert in_cli_words(text.replace("alpha", "shape"), {"shape": "--shape"}) == "--shape must be finite; got nan."


def test_the_parameters_a_message_names_are_said_as_their_options():
    """A message about --robot that suggests another setting names that setting's option, not the library's."""
    text = ("The 'robot' parameter of InSituOptimizer.run must be a seed gait within 0.8 rad; a larger "
            "max_joint_angle lets it start (not max_joint_angles). Got 'a gait reaching 1.8 rad' instead.")
    said = in_cli_words(text, {"robot": "--robot", "max_joint_angle": "--max-joint-angle", "n_cycles": "--cycles"})
    assert said == ("--robot must be a seed gait within 0.8 rad; a larger --max-joint-angle lets it start "
                    "(not max_joint_angles); got 'a gait reaching 1.8 rad'.")


@pytest.mark.parametrize(("text", "said"), [
    ("The 'source' parameter of read_log must be a CSV or Parquet file. Got 'x.txt' instead.",
     "the log must be a CSV or Parquet file; got 'x.txt'."),
    ("The 'q0' parameter of read_log must be a numeric column. Got 'a' instead.",
     "the log's column 'q0' must be a numeric column; got 'a'."),
    ("The 'header' parameter of input line 1 must be a CSV header naming each column once. Got \"x\" instead.",
     "input line 1 must be a CSV header naming each column once; got \"x\"."),
    ("The 'shape' parameter of input line 21 must be a list of 2 numbers. Got [1] instead.",
     "input line 21's 'shape' must be a list of 2 numbers; got [1]."),
    # a setting of the reader that no option of the running command gave stays as it is
    ("The 'window' parameter of read_log must be an odd int >= 3. Got 4 instead.",
     "The 'window' parameter of read_log must be an odd int >= 3. Got 4 instead."),
])
def test_a_message_about_the_users_log_or_input_line_is_said_of_them(text, said):
    """Issue 58: a log naming a column twice was reported as "The 'source' parameter of read_log must be …"."""
    assert in_cli_words(text, {}) == said
    assert in_cli_words("The '--jobs' option and '--scheduler' option spread trials.", {}) == (
        "--jobs and --scheduler spread trials.")


# -- issue 11: OS errors, unreadable values, options refused before anything runs --------------------------
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


def test_library_warnings_are_lines_and_the_interpreters_resource_warnings_are_not_shown(capsys):
    """A leaked file collected while a command runs (it may be another part of the process's) is nothing the user can
    act on; a library warning is one ``warning: …`` line."""
    import warnings

    from geogait import GeogaitWarning
    from geogait.cli._app import _warnings_as_lines

    with _warnings_as_lines():
        warnings.warn("unclosed file <_io.TextIOWrapper name=21>", ResourceWarning, stacklevel=1)
        warnings.warn("the gait is at its limit\nand stays there", GeogaitWarning, stacklevel=1)
    assert capsys.readouterr().err.splitlines() == ["warning: the gait is at its limit and stays there"]
