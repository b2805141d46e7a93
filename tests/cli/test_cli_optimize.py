"""``geogait optimize`` as a user meets it: its folder after a run, its output, an interrupted run."""

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from geogait._files import LOCK_FILE
from geogait.cli import app

RUN = ["optimize", "--links", "3", "--cycles", "2"]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished 2-cycle optimisation run (seed 0) in its folder."""
    folder = tmp_path_factory.mktemp("runs") / "a"
    result = invoke(*RUN, "--out", folder)
    assert result.exit_code == 0, result.output
    return folder


def test_a_finished_run_leaves_no_lock_file(finished):
    assert (finished / "summary.json").is_file()
    assert not (finished / LOCK_FILE).exists()


def test_a_resumed_run_leaves_no_lock_file(finished, tmp_path):
    folder = tmp_path / "b"
    shutil.copytree(finished, folder)
    result = invoke("optimize", "--resume", folder, "--cycles", "3")
    assert result.exit_code == 0, result.output
    assert not (folder / LOCK_FILE).exists()
