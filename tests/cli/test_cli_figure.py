"""``geogait figure``: options checked before anything runs, and a redraw from CSV that keeps the run's manifest
(issue 11)."""

import pytest
from _cli import one_error_line
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
