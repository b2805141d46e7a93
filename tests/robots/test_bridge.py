"""The JSON-lines robot bridge: the reference driver through a process, and drivers that misbehave."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from geogait.gaits import Perturbation, seed_gait
from geogait.models import ResistanceModel
from geogait.optimize import Climb, InSituOptimizer
from geogait.optimize._setup import gait_family
from geogait.robots import ProcessRobot, Robot
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

DRIVER = [sys.executable, "-m", "geogait.robots.driver"]
GEOGAIT = [sys.executable, "-c", "from geogait.cli import main; main()"]


@pytest.mark.slow
def test_the_reference_driver_through_a_process_gives_the_in_process_result():
    with ProcessRobot(DRIVER + ["--period", "2", "--seed", "3"]) as robot:
        assert isinstance(robot, Robot) and robot.cycle_period == 2.0
        bridged = InSituOptimizer().run(robot, 8)
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation.from_std(0.15, frequency=1.0),
                           sensor_noise=0.1, seed=3, cycle_period=2.0)
    direct = InSituOptimizer().run(stream, 8)
    assert direct.n_steps >= 2
    np.testing.assert_array_equal(bridged.final_gait.params, direct.final_gait.params)  # JSON floats round-trip


def test_a_driver_without_exploration_of_its_own_is_optimised_as_one_with():
    """Protocol 2: geogait sends the exploration with every cycle, so the driver's own does not matter;
    a version-1 driver that explores not at all is told apart: a warning, and no model step."""
    runs = []
    for own in ("0", "0.3"):
        with ProcessRobot(DRIVER + ["--perturbation", own, "--seed", "2"]) as robot:
            assert robot.protocol_version == 2 and robot.accepts_excitation
            runs.append(InSituOptimizer(climb=Climb(start="stalled")).run(robot, 10))  # model steps first: it explores
    assert runs[0].n_steps >= 2
    pd.testing.assert_frame_equal(runs[0].log, runs[1].log)
    assert runs[0].log["excitation"].min() > 0.05  # δ std 0.15 rad, commanded
    with ProcessRobot(DRIVER + ["--protocol", "1", "--perturbation", "0", "--seed", "2"]) as robot:
        assert robot.protocol_version == 1 and not robot.accepts_excitation
        with pytest.warns(UserWarning, match="carry no exploration"):
            log = InSituOptimizer().run(robot, 10).log
    assert log["excitation"].max() < 1e-9
    assert not (log["step"] & ~log["climb"] & ~log["period_change"]).any()  # no model step: only the climb


def test_hello_declares_joint_ranges_and_checks_them(tmp_path):
    hello = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
             "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}, "joint_ranges": [[-1.5, 1.5], [-1.2, 1.4]]}
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")) as robot:
        np.testing.assert_array_equal(robot.joint_ranges, [[-1.5, 1.5], [-1.2, 1.4]])
        from geogait.optimize import Limits
        from geogait.optimize._setup import joint_limit
        from geogait.robots import read_robot_spec

        assert joint_limit(Limits(), read_robot_spec(robot)) == 1.2
    for bad in ([[-1.5, 1.5]], [[0.5, 1.5], [-1, 1]], [[-1, "1"], [-1, 1]]):
        wrong = dict(hello, joint_ranges=bad)
        with pytest.raises(ValueError, match="'joint_ranges'"):
            ProcessRobot(_driver(tmp_path, f"print(json.dumps({wrong!r}), flush=True)\nsys.stdin.readline()\n"))
    with pytest.raises(ValueError, match="'excitation'.*version 2"):
        ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, version=1, excitation=True)!r}), "
                                       "flush=True)\nsys.stdin.readline()\n"))


def test_hello_declares_mirror_symmetry_and_the_optimiser_searches_that_family(tmp_path):
    """A 4-link swimmer with unequal links is mirror symmetric but not front–back symmetric: declared in the
    hello, the optimiser's automatic family is the half-wave one; declared false, the free one; not declared, the
    half-wave one on trial (the Adaptation widens it once a gait turns), or the free one without an Adaptation."""
    from geogait.gaits import FreeGaitFamily, MirrorGaitFamily
    from geogait.robots import read_robot_spec

    hello = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
             "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}, "mirror_symmetric": True}
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")) as robot:
        assert robot.mirror_symmetric is True and robot.front_back_symmetric is None
        assert isinstance(gait_family(InSituOptimizer(), read_robot_spec(robot), robot.gait), MirrorGaitFamily)
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, mirror_symmetric=False)!r}), flush=True)\n"
                                        "sys.stdin.readline()\n")) as robot:
        assert isinstance(gait_family(InSituOptimizer(), read_robot_spec(robot), robot.gait), FreeGaitFamily)
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, mirror_symmetric=None)!r}), flush=True)\n"
                                        "sys.stdin.readline()\n")) as robot:
        assert robot.mirror_symmetric is None
        spec = read_robot_spec(robot)
        assert isinstance(gait_family(InSituOptimizer(), spec, robot.gait), MirrorGaitFamily)
        assert isinstance(gait_family(InSituOptimizer(checks=[]), spec, robot.gait), FreeGaitFamily)
    with pytest.raises(ValueError, match="'mirror_symmetric' must be true or false"):
        ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, mirror_symmetric='yes')!r}), "
                                       "flush=True)\nsys.stdin.readline()\n"))


def test_hello_declares_a_chain_for_the_resistance_model(tmp_path):
    """The reference driver declares its swimmer's chain; the resistance model built from it is the swimmer's own
    (its connection equals PurcellSwimmer's at the default drags); a malformed chain is refused naming the field."""
    with ProcessRobot(DRIVER + ["--links", "4"]) as robot:
        geometry = robot.chain_geometry()
    assert geometry == {"link_lengths": (0.25,) * 4, "body_frame": "middle", "frame_offset": None}
    shapes = np.random.default_rng(0).uniform(-1, 1, (5, 3))
    np.testing.assert_allclose(ResistanceModel(**geometry).fit(*_swimmer_samples(4)).system_.connection(shapes),
                               PurcellSwimmer(4).connection(shapes), rtol=0.05, atol=0.02)
    hello = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
             "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}}
    chain = {"link_lengths": [0.3, 0.4, 0.3], "body_frame": 1, "frame_offset": [0.1, 0, 3.14159]}
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, chain=chain)!r}), flush=True)\n"
                                        "sys.stdin.readline()\n")) as robot:
        assert robot.chain_geometry() == {"link_lengths": (0.3, 0.4, 0.3), "body_frame": 1,
                                          "frame_offset": (0.1, 0.0, 3.14159)}
        assert not robot.resistive_medium  # not said: the data-driven default model
    resistive = dict(chain, resistive=True)
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, chain=resistive)!r}), flush=True)\n"
                                        "sys.stdin.readline()\n")) as robot:
        assert robot.resistive_medium and "resistive" not in robot.chain_geometry()
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")) as robot:
        with pytest.raises(ValueError, match="declares no chain geometry"):
            robot.chain_geometry()
    # a body driven through fewer coordinates than its chain has joints: 4 links, 3 joints, 2 shape coordinates
    mapped = {"link_lengths": [0.25] * 4, "body_frame": "center_of_mass", "shape_map": [[1, 0], [0.5, 0.5], [0, 1]]}
    with ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, chain=mapped)!r}), flush=True)\n"
                                        "sys.stdin.readline()\n")) as robot:
        geometry = robot.chain_geometry()
    assert geometry["shape_map"] == ((1.0, 0.0), (0.5, 0.5), (0.0, 1.0)) and geometry["body_frame"] == "center_of_mass"
    assert ResistanceModel(**geometry).validate().shape_map == geometry["shape_map"]
    for bad in ({"link_lengths": [0.3, 0.4]}, {"link_lengths": [0.3, -0.4, 0.3]}, {"link_lengths": [0.3, 0.4, "a"]},
                dict(chain, body_frame=3), dict(chain, body_frame="head"), dict(chain, frame_offset=[0, 0]),
                dict(chain, links=3), dict(chain, resistive="yes"), dict(mapped, shape_map=[[1, 0], [0, 1]]),
                dict(mapped, shape_map=[[1, 0, 0]] * 3), dict(mapped, shape_map=[[1, "a"]] * 3),
                dict(mapped, body_frame=4)):
        with pytest.raises(ValueError, match="'chain' must be"):
            ProcessRobot(_driver(tmp_path, f"print(json.dumps({dict(hello, chain=bad)!r}), flush=True)\n"
                                           "sys.stdin.readline()\n"))


def _swimmer_samples(n_links, n=400):
    """Noise-free samples of the built-in swimmer along its seed gait with exploration."""
    stream = SwimmerStream(PurcellSwimmer(n_links), seed_gait(n_links - 1), sensor_noise=0.0, seed=1)
    cycles = stream.next_cycles(n // stream.samples_per_cycle)
    return cycles.phase, cycles.shape, cycles.shape_velocity, cycles.body_velocity


@pytest.mark.slow
def test_poses_only_drivers_get_body_velocities_from_poses():
    with ProcessRobot(DRIVER + ["--poses-only", "--perturbation", "0", "--noise", "0"]) as robot:
        cycle = robot.next_cycle()
    with ProcessRobot(DRIVER + ["--perturbation", "0", "--noise", "0"]) as robot:
        reference = robot.next_cycle()
    np.testing.assert_allclose(cycle.body_velocity[:-1], reference.body_velocity[:-1], atol=1e-9)


def _driver(tmp_path, body):
    script = tmp_path / "driver.py"
    script.write_text("import json, sys, time\n" + body)
    return [sys.executable, str(script)]


HELLO = ('print(json.dumps({"type": "hello", "protocol": "geogait-robot", "version": 1, "n_joints": 2, '
         '"cycle_period": 1.0, "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}}), flush=True)\n')


@pytest.mark.parametrize(("body", "match"), [
    ("sys.exit(3)\n", "closed its output \\(exit code 3\\)"),
    ("print('hello there', flush=True)\n", "line 1 is not JSON"),
    (HELLO.replace('"version": 1', '"version": 7'), "protocol version 7"),
    (HELLO + "sys.stdin.readline(); sys.stdin.readline()\n"
     "print(json.dumps({'type': 'sample', 'time': 0, 'phase': 0, 'shape': [0], 'shape_velocity': [0, 0], "
     "'pose': [0, 0, 0]}), flush=True)\n", "field 'shape' must be a list of 2 finite numbers"),
    (HELLO + "sys.stdin.readline(); sys.stdin.readline()\n"
     "print(json.dumps({'type': 'error', 'message': 'battery low'}), flush=True)\n", "battery low"),
    (HELLO + "sys.stderr.write('motor 2 fault\\n'); sys.stderr.flush(); time.sleep(0.3); sys.exit(1)\n",
     "motor 2 fault"),
    (HELLO + "time.sleep(30)\n", "within 1 s \\(hung\\)"),
])
def test_misbehaving_drivers_give_clear_errors(tmp_path, body, match):
    with pytest.raises(ValueError, match=match):
        with ProcessRobot(_driver(tmp_path, body), timeout=1.0) as robot:
            InSituOptimizer().run(robot, 3)


def test_a_driver_that_cannot_start_is_a_clear_error():
    with pytest.raises(ValueError, match="could not start the robot driver"):
        ProcessRobot("/nonexistent/driver --fast")


@pytest.mark.slow
def test_cli_optimises_a_process_robot_and_fails_cleanly(tmp_path):
    driver = " ".join(DRIVER + ["--period", "0.5"])
    done = subprocess.run(GEOGAIT + ["optimize", "--robot", driver, "--cycles", "6", "--out", str(tmp_path / "r")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["results"]["steps"] >= 1 and "ceiling_displacement_per_cycle" not in summary["results"]
    declared = summary["results"]["robot"]  # what the robot declared, not the built-in swimmer's options
    assert declared["n_joints"] == 2 and declared["cycle_period_s"] == 0.5
    assert declared["max_joint_angle_used"] == pytest.approx(2 * np.pi / 3)  # the driver declares no ranges
    assert not {"links", "noise", "perturbation", "period"} & set(summary["config"])
    assert summary["config"]["seed"] == 0  # (the optimiser's own random numbers: its exploration and climb)
    assert summary["results"]["model_used"] == "ShapeSpaceModel"  # the symmetric chain's default
    assert declared["front_back_symmetric"] and declared["mirror_symmetric"]
    assert declared["gait_family_used"] == summary["results"]["gait_family"] == "symmetric"
    assert len(pd.read_csv(tmp_path / "r" / "cycles.csv")) == 6
    structured = subprocess.run(GEOGAIT + ["optimize", "--robot", " ".join(DRIVER + ["--links", "5"]), "--method",
                                           "resistance", "--cycles", "4", "--out", str(tmp_path / "s")],
                                capture_output=True, text=True, timeout=120)
    assert structured.returncode == 0, structured.stderr  # the chain the driver declared
    structured_summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    model = structured_summary["config"]["optimizer"]["model"]
    assert model["class"] == "ResistanceModel" and model["params"]["link_lengths"] == [0.2] * 5
    declared = structured_summary["results"]["robot"]
    assert declared["chain"]["link_lengths"] == [0.2] * 5 and declared["resistive_medium"] is False
    assert structured_summary["results"]["model_used"] == "ResistanceModel"
    broken = subprocess.run(GEOGAIT + ["optimize", "--robot", "false", "--cycles", "3", "--out", str(tmp_path / "b")],
                            capture_output=True, text=True, timeout=60)
    assert broken.returncode == 1 and broken.stderr.strip().splitlines()[-1].startswith("error: robot driver 'false'")


@pytest.mark.slow
def test_sigkill_then_resume_gives_the_uninterrupted_final_gait(tmp_path):
    options = ["optimize", "--links", "3", "--cycles", "24", "--seed", "7"]
    whole = subprocess.run(GEOGAIT + options + ["--out", str(tmp_path / "whole")], capture_output=True, text=True,
                           timeout=180)
    assert whole.returncode == 0, whole.stderr
    killed = tmp_path / "killed"
    process = subprocess.Popen(GEOGAIT + options + ["--out", str(killed)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline:  # kill it mid-run, once a few checkpoints exist
        if (killed / "checkpoint.npz").exists() and os.path.getmtime(killed / "checkpoint.npz") > 0:
            time.sleep(0.6)
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait()
    resumed = subprocess.run(GEOGAIT + ["optimize", "--resume", str(killed)], capture_output=True, text=True,
                             timeout=180)
    assert resumed.returncode == 0, resumed.stderr
    first = json.loads((tmp_path / "whole" / "summary.json").read_text())["results"]
    second = json.loads((killed / "summary.json").read_text())["results"]
    assert second["final_gait_params"] == first["final_gait_params"]
    pd.testing.assert_frame_equal(pd.read_csv(killed / "cycles.csv"), pd.read_csv(tmp_path / "whole" / "cycles.csv"))


@pytest.mark.parametrize(("options", "fragment"), [
    (["--period", "0"], "error: --period must be a finite number of seconds > 0"),
    (["--period", "nan"], "error: --period must be a finite number of seconds > 0"),
    (["--links", "1"], "error: The 'n_links' parameter of PurcellSwimmer"),
    (["--noise", "-1"], "error: The 'sensor_noise' parameter of SwimmerStream"),
])
def test_the_reference_driver_ends_a_bad_option_in_one_line(options, fragment):
    done = subprocess.run([sys.executable, "-m", "geogait.robots.driver", *options], input='{"type": "stop"}\n',
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith(fragment) and "Traceback" not in done.stderr
