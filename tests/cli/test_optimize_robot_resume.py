"""``geogait optimize --resume`` of a --robot run reads the driver's hello again and refuses one that changed."""

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from geogait.cli import app

FAULT_DRIVER = Path(__file__).parents[1] / "_fault_driver.py"


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture
def robot_run(tmp_path):
    """A 2-cycle --robot run whose driver reads its hello from hello.json (edited between start and resume)."""
    hello = tmp_path / "hello.json"
    hello.write_text(json.dumps({}))
    wrapper = tmp_path / "driver.py"
    wrapper.write_text("import json, runpy, sys\n"
                       f"hello = json.loads(open({str(hello)!r}).read())\n"
                       f"sys.argv = [{str(FAULT_DRIVER)!r}, json.dumps({{'hello': hello}})]\n"
                       f"runpy.run_path({str(FAULT_DRIVER)!r}, run_name='__main__')\n")
    out = tmp_path / "run"
    result = invoke("optimize", "--robot", f"{sys.executable} {wrapper}", "--cycles", "2", "--out", out)
    assert result.exit_code == 0, result.output
    return out, hello


@pytest.mark.parametrize(("changed", "fragment"), [
    ({"joint_ranges": [[-1.2, 1.2], [-1.2, 1.2]]}, "joint_ranges: none then, [[-1.2, 1.2], [-1.2, 1.2]] now"),
    ({"cycle_period": 2.0}, "cycle_period: 1.0 s then, 2.0 s now"),
    ({"shape_constraints": [[1, -1, 2.5]]}, "shape_constraints: none then, [[1.0, -1.0, 2.5]] now"),
])
def test_a_resumed_robot_whose_hello_changed_is_refused_naming_what_changed(robot_run, changed, fragment):
    """Before: a driver now declaring joint limits of ±1.2 rad was commanded 1.93 rad, one whose period doubled got
    speeds off by 2×."""
    out, hello = robot_run
    before = {path.name: path.read_bytes() for path in out.iterdir()}
    hello.write_text(json.dumps(changed))
    result = invoke("optimize", "--resume", out, "--cycles", "4")
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "hello" in errors[0] and fragment in errors[0], errors[0]
    # refused before a cycle ran: no file rewritten, and no advice to run the command just refused
    assert {path.name: path.read_bytes() for path in out.iterdir()} == before
    assert "continue with" not in result.stderr, result.stderr


def test_a_resumed_robot_whose_hello_is_the_same_continues(robot_run):
    out, _ = robot_run
    result = invoke("optimize", "--resume", out, "--cycles", "3")
    assert result.exit_code == 0, result.output
    assert len((out / "cycles.csv").read_text().splitlines()) == 1 + 3


def test_a_robot_run_without_cycles_goes_on_until_a_stop_file_then_resumes(tmp_path):
    """No --cycles with --robot: continuous operation, ended by OUT/STOP as by a budget (outputs written)."""
    import shlex
    import threading
    import time

    out = tmp_path / "run"

    def stop_once_under_way():
        for _ in range(6000):  # (at most ten minutes: the test fails then rather than hangs)
            if (out / "checkpoint.npz").exists():
                (out / "STOP").touch()
                return
            time.sleep(0.1)

    stopper = threading.Thread(target=stop_once_under_way, daemon=True)
    stopper.start()
    driver = shlex.join([sys.executable, str(FAULT_DRIVER), "{}"])
    result = invoke("optimize", "--robot", driver, "--out", out)
    stopper.join()
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())["results"]
    ran = summary["cycles_run"]
    assert ran >= 1 and json.loads((out / "run.json").read_text())["cycles"] is None
    assert summary["ended_by"] == "the STOP file"
    assert f"STOP ended the run after {ran} cycles; continue with: geogait optimize --resume" in result.stderr
    result = invoke("optimize", "--resume", out, "--cycles", ran + 2)  # (the STOP left is the old run's)
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())["results"]
    assert summary["cycles_run"] == ran + 2 and summary["ended_by"] == "its budget"
    assert "ended the run" not in result.stderr
