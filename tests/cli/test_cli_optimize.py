"""``geogait optimize`` as a user meets it: its folder after a run, its output, an interrupted run; and runs that
never lose one another (issue 21): the run's identity, --overwrite, the folder's lock, --resume conflicts, SIGTERM."""

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
from _cli import invoke, one_error_line, snapshot
from _limits import interruptible

from geogait._files import LOCK_FILE, OutputLock, read_state, write_text

RUN = ["optimize", "--links", "3", "--cycles", "2"]


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


# -- run identity, --overwrite, the lock, resume conflicts (issue 21) ---------------------------------------
GEOGAIT = [sys.executable, "-c", "from geogait.cli import main; main()"]


def copy_of(folder: Path, tmp_path: Path) -> Path:
    target = tmp_path / folder.name
    shutil.copytree(folder, target)
    return target


def test_run_identity_is_in_run_json_the_checkpoint_and_the_summary(finished):
    run_id = json.loads((finished / "run.json").read_text())["run_id"]
    metadata, _ = read_state(finished / "checkpoint.npz", "checkpoint", "geogait-optimizer-checkpoint", 1)
    assert metadata["tag"] == {"run_id": run_id} and len(run_id) == 16
    assert json.loads((finished / "summary.json").read_text())["config"]["run_id"] == run_id


def test_a_non_empty_out_is_refused_without_overwrite(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    before = snapshot(folder)
    one_error_line(invoke(*RUN, "--seed", "3", "--out", folder), "not empty", "--overwrite")
    assert snapshot(folder) == before  # nothing replaced
    assert invoke(*RUN, "--seed", "3", "--overwrite", "--out", folder).exit_code == 0
    assert json.loads((folder / "run.json").read_text())["seed"] == 3


def test_a_folder_another_run_writes_is_refused(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    before = snapshot(folder)
    with OutputLock(folder):  # as a run in another process holds it
        one_error_line(invoke(*RUN, "--overwrite", "--out", folder), "being written by another geogait run")
        one_error_line(invoke("optimize", "--resume", folder, "--cycles", "3"), "being written by another geogait run")
    assert snapshot(folder) == before


@pytest.mark.parametrize(("options", "names"), [
    (["--out", "elsewhere", "--links", "5", "--method", "batch"], "--links, --method, --out"),
    (["--seed", "4"], "--seed"),
    (["--overwrite"], "--overwrite"),
])
def test_resume_refuses_options_it_would_ignore(finished, options, names):
    one_error_line(invoke("optimize", "--resume", finished, *options), "--resume continues a run", names)


def test_resume_refuses_fewer_cycles_than_already_run(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    one_error_line(invoke("optimize", "--resume", folder, "--cycles", "1"), "fewer than the 2 cycles already run")
    result = invoke("optimize", "--resume", folder, "--cycles", "3")
    assert result.exit_code == 0, result.output
    assert len(pd.read_csv(folder / "cycles.csv")) == 3
    # the new total is the run's: a later --resume without --cycles continues to it, not to the first total
    assert json.loads((folder / "run.json").read_text())["cycles"] == 3
    result = invoke("optimize", "--resume", folder)
    assert result.exit_code == 0, result.output
    assert len(pd.read_csv(folder / "cycles.csv")) == 3


def test_resume_refuses_a_checkpoint_of_another_run(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    other = tmp_path / "other"
    assert invoke(*RUN, "--seed", "5", "--out", other).exit_code == 0
    shutil.copy(other / "checkpoint.npz", folder / "checkpoint.npz")  # B's checkpoint beside A's run.json
    one_error_line(invoke("optimize", "--resume", folder), "belongs to another run")
    settings = json.loads((other / "run.json").read_text())
    settings["noise"] = 0.3  # settings edited after the run started
    write_text(other / "run.json", json.dumps(settings))
    one_error_line(invoke("optimize", "--resume", other), "was changed after the run started")


def test_a_run_refused_at_its_start_leaves_the_run_it_would_replace_whole(finished, tmp_path):
    """--overwrite replaces the earlier run only once the new one is under way: a run refused by a check that can
    only be made at its start (a driver that cannot start, a joint limit the seed gait breaks) keeps it."""
    folder = copy_of(finished, tmp_path)
    before = {path.name: path.read_bytes() for path in folder.iterdir() if path.is_file()}
    one_error_line(invoke("optimize", "--robot", "false", "--overwrite", "--out", folder), "robot driver")
    one_error_line(invoke("optimize", "--max-joint-angle", "0.5", "--overwrite", "--out", folder),
                   "--max-joint-angle", "[1, π]", "seed gait's largest joint angle")
    one_error_line(invoke("optimize", "--max-joint-angle", "3.5", "--overwrite", "--out", folder),
                   "--max-joint-angle", "[1, π]")
    assert {path.name: path.read_bytes() for path in folder.iterdir() if path.is_file()} == before
    fresh = tmp_path / "fresh" / "run"  # folders the refused run created are not left behind
    one_error_line(invoke("optimize", "--robot", "false", "--out", fresh), "robot driver")
    assert not (tmp_path / "fresh").exists()


def test_a_run_that_replaced_another_and_died_is_resumed_as_itself(finished, tmp_path):
    """Once a run is under way its run.json replaces the earlier run's, the earlier summary and checkpoint are gone,
    and its own checkpoint follows its first cycle (whatever --checkpoint-every): failing later, it writes its own
    summary of the cycles that checkpoint holds, and is resumed as itself, never as the run it replaced."""
    folder = copy_of(finished, tmp_path)
    driver = shlex.join([sys.executable, str(Path(__file__).parents[1] / "_fault_driver.py"),
                         json.dumps({"fault": "huge_error", "cycle": 2, "magnitude": 10})])  # fails in its 3rd cycle
    one_error_line(invoke("optimize", "--robot", driver, "--checkpoint-every", "5", "--overwrite", "--out", folder),
                   "EEEEEEEEEE")
    run = json.loads((folder / "run.json").read_text())
    summary = json.loads((folder / "summary.json").read_text())
    assert run["robot"] == driver and summary["config"]["run_id"] == run["run_id"]
    assert summary["results"]["cycles_run"] == 1
    from geogait.optimize import read_checkpoint_metadata

    metadata = read_checkpoint_metadata(folder / "checkpoint.npz")
    assert metadata["tag"]["run_id"] == run["run_id"] and metadata["state"]["cycle"] == 1


@pytest.mark.parametrize(("content", "fragment"), [("{}", "'links' must be an integer, got missing"),
                                                   ('{"links": "3"}', "'links' must be an integer"),
                                                   ("[1, 2]", "a JSON object expected"),
                                                   ("[" * 100_000, "not valid JSON")])
def test_a_broken_run_json_is_a_clear_error(finished, tmp_path, content, fragment):
    folder = copy_of(finished, tmp_path)
    (folder / "run.json").write_text(content)
    one_error_line(invoke("optimize", "--resume", folder), fragment)


@pytest.mark.slow
def test_two_runs_into_one_folder_at_once_cannot_both_write_it(tmp_path):
    folder = tmp_path / "run"
    first = subprocess.Popen(GEOGAIT + ["optimize", "--cycles", "100000", "--out", str(folder)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not (folder / "checkpoint.npz").exists():
            time.sleep(0.05)
        second = subprocess.run(GEOGAIT + ["optimize", "--cycles", "2", "--seed", "1", "--overwrite", "--out",
                                           str(folder)], capture_output=True, text=True, timeout=120)
        assert second.returncode == 1
        assert f"being written by another geogait run (process {first.pid})" in second.stderr.strip().splitlines()[-1]
        assert first.poll() is None and json.loads((folder / "run.json").read_text())["seed"] == 0
    finally:
        first.send_signal(signal.SIGTERM)
        first.wait(timeout=60)


@pytest.mark.slow
def test_sigterm_ends_a_run_like_ctrl_c(tmp_path):
    folder = tmp_path / "run"
    process = subprocess.Popen(GEOGAIT + ["optimize", "--cycles", "100000", "--out", str(folder)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not (folder / "checkpoint.npz").exists():
        time.sleep(0.05)
    time.sleep(1.0)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1, stderr
    assert stderr.strip().splitlines()[-1] == "error: terminated (SIGTERM); files already written are complete"
    assert [p.name for p in folder.iterdir() if p.name.endswith(".tmp") or "staging" in p.name] == []
    read_state(folder / "checkpoint.npz", "checkpoint", "geogait-optimizer-checkpoint", 1)  # whole
