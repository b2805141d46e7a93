"""``geogait optimize`` as a user meets it: its folder after a run, its output, an interrupted run."""

import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from _limits import interruptible
from typer.testing import CliRunner

from geogait._files import LOCK_FILE
from geogait.cli import app

RUN = ["optimize", "--links", "3", "--cycles", "2"]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A finished 2-cycle optimisation run (seed 0): its folder and what it printed."""
    folder = tmp_path_factory.mktemp("runs") / "a"
    result = invoke(*RUN, "--out", folder)
    assert result.exit_code == 0, result.output
    return folder, result


@pytest.fixture(scope="module")
def finished(run) -> Path:
    return run[0]


def test_the_results_are_a_table_on_stdout_and_what_was_written_on_stderr(run):
    folder, result = run
    assert "cycles run" in result.stdout and "share of the ceiling" in result.stdout
    assert "{" not in result.stdout and f"wrote {folder}/" in result.stderr


def test_with_json_the_results_are_one_json_document_on_stdout(tmp_path):
    result = invoke(*RUN, "--out", tmp_path / "j", "--json")
    assert result.exit_code == 0, result.output
    printed = json.loads(result.stdout)  # (valid JSON: nothing wrapped, nothing else on stdout)
    assert printed == json.loads((tmp_path / "j" / "summary.json").read_text())["results"]
    assert printed["cycles_run"] == 2 and "\\u" not in result.stdout


def test_a_finished_run_leaves_no_lock_file(finished):
    assert (finished / "summary.json").is_file()
    assert not (finished / LOCK_FILE).exists()


def test_a_resumed_run_leaves_no_lock_file(finished, tmp_path):
    folder = tmp_path / "b"
    shutil.copytree(finished, folder)
    result = invoke("optimize", "--resume", folder, "--cycles", "3")
    assert result.exit_code == 0, result.output
    assert not (folder / LOCK_FILE).exists()


# -- an interrupted or failed run --------------------------------------------------------------------------------
OUTPUTS = ("cycles.csv", "summary.json", "gait.png", "progress.png", "path.png")


def checkpoint_cycles(folder: Path) -> int:
    """Cycles the run's checkpoint holds (0 before its first)."""
    from geogait import GeogaitError
    from geogait.optimize import read_checkpoint_metadata

    try:
        return read_checkpoint_metadata(folder / "checkpoint.npz")["state"]["cycle"]
    except (GeogaitError, OSError):
        return 0


def written_for(folder: Path, outputs=OUTPUTS) -> int:
    """The cycles the run's outputs cover (each output there, the CSV and summary.json agreeing)."""
    assert all((folder / name).is_file() for name in outputs), sorted(p.name for p in folder.iterdir())
    cycles = len(pd.read_csv(folder / "cycles.csv"))
    assert json.loads((folder / "summary.json").read_text())["results"]["cycles_run"] == cycles
    return cycles


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_writes_the_outputs_of_the_cycles_it_ran(tmp_path, signum):
    """Its CSV and summary.json, not the figures (a signal ends the process within 2 s; they take 1.7 s on a loaded
    machine): the line names the resume that draws them."""
    folder = tmp_path / "run"
    command = [sys.executable, "-c", "from geogait.cli import main; main()", "optimize", "--links", "3", "--cycles",
               "1000", "--out", str(folder)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "MPLBACKEND": "Agg"}, preexec_fn=interruptible)
    try:
        while checkpoint_cycles(folder) < 3:  # a few cycles run (the budget is far off)
            assert process.poll() is None, process.communicate()
            time.sleep(0.2)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=600)
    finally:
        process.kill()
    assert process.returncode == 1, stderr
    cycles = written_for(folder, ("cycles.csv", "summary.json"))
    assert 3 <= cycles < 1000
    assert not any((folder / name).exists() for name in OUTPUTS if name.endswith(".png")), stderr[-2000:]
    lines = stderr.strip().splitlines()
    assert lines[-1].startswith(f"error: {'interrupted' if signum == signal.SIGINT else 'terminated'}")
    assert f"(its figures: geogait optimize --resume {folder} --cycles {cycles})" in lines[-2]
    assert f"continue with: geogait optimize --resume {folder}" in lines[-2]
    if signum == signal.SIGINT:  # what the line says draws the figures, then continues it
        result = invoke("optimize", "--resume", folder, "--cycles", cycles)
        assert result.exit_code == 0, result.output
        assert written_for(folder) == cycles
        result = invoke("optimize", "--resume", folder, "--cycles", cycles + 1)
        assert result.exit_code == 0, result.output
        assert written_for(folder) == cycles + 1


def test_a_run_whose_driver_fails_writes_the_outputs_of_the_cycles_it_ran(tmp_path):
    driver = shlex.join([sys.executable, str(Path(__file__).parents[1] / "_fault_driver.py"),
                         json.dumps({"fault": "string_numbers", "cycle": 3})])
    result = invoke("optimize", "--robot", driver, "--cycles", "10", "--robot-timeout", "60", "--out", tmp_path / "r")
    assert result.exit_code == 1, result.output
    assert written_for(tmp_path / "r") == 3
    assert f"continue with: geogait optimize --resume {tmp_path / 'r'}" in result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith("error: ")


def test_a_run_stopped_before_its_first_cycle_writes_nothing(tmp_path):
    result = invoke("optimize", "--robot", "no-such-driver-command", "--out", tmp_path / "r")
    assert result.exit_code == 1 and "note:" not in result.stderr
    assert not (tmp_path / "r").exists()
