"""``geogait figure``: options checked before anything runs, and a redraw from CSV that keeps the run's manifest
(issue 11) and never leaves two runs' files in one folder (issue 21)."""

import json

import pytest
from _cli import invoke, one_error_line
from _reference import strict_json
from typer.testing import CliRunner

from geogait.cli import app


@pytest.mark.parametrize("command", ["accuracy", "environments", "optimization"])
@pytest.mark.parametrize("option", [["--links", "300"], ["--seed", "-1"], ["--trials", "0"], ["--jobs", "0"]])
def test_figure_options_are_checked_before_running(tmp_path, command, option):
    result = CliRunner().invoke(app, ["figure", command, "--quick", *option, "--out", str(tmp_path)])
    assert option[0].lstrip("-") in one_error_line(result).lower()
    assert not any(tmp_path.iterdir())


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


def test_a_figure_redraws_its_own_run_freely_and_another_runs_only_with_overwrite(tmp_path):
    """A redraw of the folder's own CSV adds its figure and a manifest beside the run's; a redraw of another run's
    CSV would leave the folder holding two runs' files: refused, and with --overwrite the earlier run's data go."""
    a, b = tmp_path / "a", tmp_path / "b"
    for folder, seed in ((a, "0"), (b, "5")):
        assert invoke("figure", "accuracy", "--quick", "--trials", "2", "--cycles", "5", "--seed", seed,
                      "--out", folder).exit_code == 0
    data = (a / "accuracy.csv").read_bytes()
    assert invoke("figure", "accuracy", "--from-csv", a / "accuracy.csv", "--out", a).exit_code == 0
    assert (a / "accuracy.csv").read_bytes() == data and (a / "accuracy.redraw.json").exists()
    one_error_line(invoke("figure", "accuracy", "--from-csv", b / "accuracy.csv", "--out", a),
                   "accuracy.csv exists", "--overwrite")
    assert invoke("figure", "accuracy", "--from-csv", b / "accuracy.csv", "--out", a, "--overwrite").exit_code == 0
    assert sorted(path.name for path in a.iterdir()) == ["accuracy.json", "accuracy.png"]
    assert json.loads((a / "accuracy.json").read_text())["config"]["from_csv"] == str(b / "accuracy.csv")
