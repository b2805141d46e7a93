"""The bridge checks a driver's measurements against each other and its hello against the machine's limits, and
trusts a driver with nothing (issue 21): every field, line and cycle checked, long texts cut, and whatever fault a
driver injects, a plausible cycle, a quarantined one or one clear error (fuzz)."""

import json
import shlex
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from _cli import invoke, one_error_line
from _fuzz import FUZZ, WILD
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait._validation import GeogaitError
from geogait.gaits import FourierGait
from geogait.optimize import InSituOptimizer
from geogait.optimize._measure import measure_cycle
from geogait.robots import ProcessRobot

FAULT_DRIVER = [sys.executable, str(Path(__file__).parents[1] / "_fault_driver.py")]


def fault_robot(**config):
    return ProcessRobot(FAULT_DRIVER + [json.dumps(config)], timeout=20)


def _net_motions(robot, cycles=3):
    return [measure_cycle(robot.next_cycle(), robot.gait, robot.cycle_period, "test").net for _ in range(cycles)]


@pytest.mark.parametrize("sample", [-1, 0, 10])
def test_one_body_velocity_glitch_is_quarantined_wherever_it_is_in_the_cycle(sample):
    """[100, 0, 0] on the last sample set the cycle's end pose: 2.44 per cycle measured, true about 0.07."""
    with fault_robot() as robot:
        clean = _net_motions(robot)
    with pytest.warns(match="quarantined"), fault_robot(fault="velocity_glitch", cycle=1, magnitude=100.0,
                                                        sample=sample) as robot:
        glitched = _net_motions(robot)
    assert len(robot.quarantined) == 1 and f"at sample {sample % 40}" in robot.quarantined[0]
    assert ("it sets the cycle's end pose" in robot.quarantined[0]) == (sample == -1)
    np.testing.assert_allclose(glitched[0], clean[0])  # the glitched cycle was run again, not learned
    assert max(np.hypot(*net[:2]) for net in glitched) < 0.2


def test_body_velocities_in_other_units_than_the_poses_end_the_run_naming_the_factor():
    with warnings.catch_warnings(), fault_robot(fault="velocity_scale", cycles=99, magnitude=1000.0) as robot:
        warnings.simplefilter("ignore")
        with pytest.raises(GeogaitError, match=r"implausible cycles in a row; the last: its body velocities move the "
                                               r"body (99\d|1e\+03)× as far as its poses do .*different units"):
            robot.next_cycle()


HELLO = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
         "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}}
CHAIN = {"link_lengths": [0.3, 0.4, 0.3], "body_frame": 1}


def hello_driver(tmp_path, hello):
    script = tmp_path / "driver.py"
    script.write_text(f"import json, sys\nprint(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")
    return [sys.executable, str(script)]


@pytest.mark.parametrize(("fields", "name"), [
    ({"chain": dict(CHAIN, frame_offset=[1e300, 0, 0])}, "chain"),
    ({"chain": dict(CHAIN, frame_offset=[0, 0, -2e12])}, "chain"),
    ({"chain": dict(CHAIN, link_lengths=[0.3, 1e300, 0.3])}, "chain"),
    ({"chain": {"link_lengths": [0.25] * 4, "shape_map": [[1, 0], [0.5, 1e300], [0, 1]]}}, "chain"),
    ({"joint_ranges": [[-1e300, 1], [-1, 1]]}, "joint_ranges"),
    ({"joint_ranges": [[-1, 1], [-1, 2e12]]}, "joint_ranges"),
    ({"shape_constraints": [[1, -1, 1e300]]}, "shape_constraints"),
    ({"shape_constraints": [[1e300, 0, 1e300]]}, "shape_constraints"),
])
def test_hello_numbers_beyond_the_documented_bound_are_refused_naming_the_field(tmp_path, fields, name):
    """1e300 in chain.frame_offset, shape_map or joint_ranges gave Γ NaN every cycle, no step, exit 0."""
    with pytest.raises(GeogaitError, match=rf"robot driver .*'{name}' must be .*within ±1e\+12"):
        ProcessRobot(hello_driver(tmp_path, dict(HELLO, **fields)))
    bounded = json.loads(json.dumps(fields).replace("1e+300", "1e12").replace("2000000000000.0", "1e12"))
    ProcessRobot(hello_driver(tmp_path, dict(HELLO, **bounded))).close()  # the bound itself is accepted


@pytest.mark.parametrize(("fields", "fragment"), [
    ({"n_joints": 300, "gait": {"order": 1, "params": [0.0, 1, 0] * 300}}, "at most 37 joints, even at order 1"),
    ({"gait": {"order": 1000, "params": [0.0] * 2 * 2001}}, "at most order 21 with 2 joints"),
])
def test_a_hello_whose_gait_no_optimisation_could_hold_is_refused(tmp_path, fields, fragment):
    """Before: the bridge accepted 10,000 joints and order 1000 (30 GiB of joint-limit rows at 2 joints)."""
    with pytest.raises(GeogaitError, match=r"robot driver .*the hello's 'gait'.*(4 GiB|SIGTERM)") as error:
        ProcessRobot(hello_driver(tmp_path, dict(HELLO, **fields)))
    assert fragment in str(error.value)


@pytest.mark.parametrize(("fields", "fragment"), [
    ({"joint_ranges": [[-0.5, 0.5], [-0.5, 0.5]]},
     "the hello's 'gait' moves joint 0 over [-1, 1] rad, outside its 'joint_ranges' [-0.5, 0.5]"),
    ({"joint_ranges": [[-2, 2], [-0.5, 3]]},
     "the hello's 'gait' moves joint 1 over [-1, 1] rad, outside its 'joint_ranges' [-0.5, 3]"),
    ({"shape_constraints": [[1, 0, 0.5]]},
     "the hello's 'gait' leaves the region its 'shape_constraints' declare (by 0.5"),
])
def test_a_hello_whose_seed_gait_leaves_its_own_ranges_or_region_is_refused_naming_them(tmp_path, fields, fragment):
    """Before: the run was refused as "--robot must be a seed gait within max_joint_angle = 0.5" (or "inside the
    robot's feasible region (its system's singular set's margin ...)"), naming the optimiser, not the hello."""
    with pytest.raises(GeogaitError, match=r"^robot driver ") as error:
        ProcessRobot(hello_driver(tmp_path, dict(HELLO, **fields)))
    assert fragment in str(error.value)
    # the same seed inside the declared ranges and region is accepted
    inside = {"joint_ranges": [[-1, 1], [-1, 1]], "shape_constraints": [[1, 0, 1]]}
    ProcessRobot(hello_driver(tmp_path, dict(HELLO, **inside))).close()


@pytest.mark.parametrize(("fields", "fragment"), [
    ({"joint_ranges": [[-0.5, 0.5], [-0.5, 0.5]]}, "outside its 'joint_ranges' [-0.5, 0.5]"),
    # within each joint's own range, beyond the symmetric limit the optimiser takes from the ranges
    ({"gait": {"order": 1, "params": [0.5, 1, 0, 0, 0, 1]}, "joint_ranges": [[-0.6, 2], [-1.5, 1.5]]},
     "--robot must be a seed gait within the automatic joint limit, 0.6 rad (the nearest bound of the joint_ranges "
     "it declares; a larger --max-joint-angle lets it start, and the joint_ranges still hold); got 'a gait reaching "
     "1.5 rad'"),
])
def test_the_cli_names_the_hello_field_a_seed_gait_leaves(tmp_path, fields, fragment):
    driver = shlex.join(hello_driver(tmp_path, dict(HELLO, **fields)))
    one_error_line(invoke("optimize", "--robot", driver, "--cycles", 4, "--out", tmp_path / "run"), fragment)


# -- a driver is trusted with nothing (issue 21) ----------------------------------------------------------------
@pytest.mark.parametrize(("config", "fragment"), [
    ({"hello": {"cycle_period": 1e300}}, "'cycle_period' must be in [0.001, 86400] seconds, got 1e+300"),
    ({"hello": {"cycle_period": 1e-300}}, "'cycle_period' must be in"),
    ({"hello": {"version": 1.0}}, "protocol version 1.0 (must be the integer 1 or 2)"),
    ({"hello": {"version": True}}, "protocol version True"),
    ({"hello": {"n_joints": 2.0}}, "'n_joints' must be an integer"),
    ({"hello": {"gait": {"order": True, "params": [0, 1, 0, 0, 0, 1]}}}, "'gait' must be"),
    ({"fault": "string_numbers", "cycle": 1}, "field 'time' must be a finite number (JSON numbers within ±1e+12), "
                                              "got '"),
    ({"fault": "huge_numbers", "cycle": 1}, "field 'pose' must be a list of 3 finite numbers (JSON numbers within "
                                            "±1e+12)"),
    ({"fault": "bool_numbers", "cycle": 1}, "field 'shape' must be a list of 2 finite numbers"),
    ({"fault": "second_hello", "cycle": 1}, "a second 'hello' in the middle of the run"),
    ({"fault": "bad_utf8", "cycle": 1}, "is not UTF-8 (byte 0xff"),
    ({"fault": "endless_line", "cycle": 1}, "longer than 1048576 bytes"),
    ({"fault": "deep_json", "cycle": 1}, "is not JSON (nested too deeply)"),
    ({"fault": "repeated_key", "cycle": 1}, "key 'time' appears more than once in one JSON object"),
    ({"fault": "clock_per_cycle", "cycle": 1, "cycles": 9},
     "3 implausible cycles in a row; the last: its first time stamp (0.0 s) is not after the last accepted cycle's "
     "last (0.975 s)"),
    ({"fault": "phase_stuck", "cycle": 1, "cycles": 9}, "3 implausible cycles in a row; the last: the commanded phase"),
    ({"fault": "time_scale", "cycle": 0, "cycles": 9}, "span 1000 s, but the hello's cycle_period is 1 s"),
    ({"fault": "frozen_joints", "cycle": 0, "cycles": 9}, "joint(s) [0, 1] never moved (less than 1%"),
])
def test_a_driver_is_trusted_with_nothing(config, fragment):
    started = time.perf_counter()
    with pytest.raises(GeogaitError) as error, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with fault_robot(**config) as robot:
            for _ in range(5):
                robot.next_cycle()
    message = str(error.value)
    assert fragment in message and "_fault_driver.py" in message  # the whole command, not argv[0]
    assert len(message) < 1000 and time.perf_counter() - started < 15  # no full timeout, no megabyte "line"


def test_after_a_cycle_broke_off_the_robot_refuses_to_go_on():
    """The rest of a broken cycle's samples are still in the pipe: read on, they would be taken for the next cycle
    (39 samples starting mid-cycle, plausible enough to pass), and every later cycle would be one behind."""
    with fault_robot(fault="string_numbers", cycle=1) as robot:
        robot.next_cycle()
        with pytest.raises(GeogaitError, match="field 'time' must be a finite number"):
            robot.next_cycle()
        with pytest.raises(GeogaitError, match="an earlier cycle broke off part-way .* no longer in step"):
            robot.next_cycle()


@pytest.mark.parametrize("fault", ["huge_error", "huge_stderr"])
def test_long_driver_texts_are_cut(fault):
    with pytest.raises(GeogaitError) as error:
        with fault_robot(fault=fault, cycle=0, magnitude=500_000) as robot:
            robot.next_cycle()
    assert len(str(error.value)) < 1000 and ("EEEE" in str(error.value) or "SSSS" in str(error.value))


@pytest.mark.parametrize(("config", "fragment"), [({"fault": "pose_jump", "cycle": 2}, "the pose jumps by 1000"),
                                                  ({"fault": "phase_stuck", "cycle": 1}, "commanded phase covers"),
                                                  ({"fault": "time_scale", "cycle": 1}, "span 1000 s"),
                                                  ({"fault": "time_scale", "cycle": 1, "magnitude": 0.001},
                                                   "its first time stamp (0.001 s) is not after")])
def test_an_implausible_cycle_is_quarantined_and_logged(config, fragment):
    with pytest.warns(match="quarantined"), fault_robot(**config) as robot:
        cycles = [robot.next_cycle() for _ in range(4)]
    assert len(robot.quarantined) >= 1 and fragment in robot.quarantined[0]
    assert [int(c.cycle[0]) for c in cycles] == [0, 1, 2, 3] and robot.cycles_run == 4 + len(robot.quarantined)


def test_a_driver_that_ignores_set_gait_does_not_get_a_summary_of_a_gait_it_never_ran():
    with warnings.catch_warnings(), fault_robot(fault="ignore_set_gait") as robot:
        warnings.simplefilter("ignore")
        robot.next_cycle()
        robot.set_gait(FourierGait(robot.gait.coefficients * 1.5))
        with pytest.raises(GeogaitError, match="implausible cycles (in a row|since the last set_gait).*ignored"):
            for _ in range(8):
                robot.next_cycle()
    assert any("follow an earlier gait" in reason for reason in robot.quarantined)


def test_a_quote_left_open_in_robot_is_a_clear_error(tmp_path):
    with pytest.raises(GeogaitError, match="a command line a shell could split"):
        ProcessRobot("python -m 'geogait.robots.driver")
    one_error_line(invoke("optimize", "--robot", "python -c 'oops", "--out", tmp_path / "x"), "shell could split")


@pytest.mark.slow
def test_the_reference_driver_is_plausible_through_a_whole_run():
    with ProcessRobot([sys.executable, "-m", "geogait.robots.driver", "--period", "2"]) as robot:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = InSituOptimizer().run(robot, 20)
    assert robot.quarantined == [] and result.n_steps >= 2


# -- fuzz (issue 21; see tests/_fuzz.py) ----------------------------------------------------------------------------
FAULTS = ["none", "phase_stuck", "time_scale", "pose_jump", "frozen_joints", "ignore_set_gait", "string_numbers",
          "bool_numbers", "bad_utf8", "endless_line", "huge_error", "huge_stderr", "deep_json"]


HELLOS = st.one_of(st.just({}), st.fixed_dictionaries({}, optional={
    "version": st.sampled_from([1.0, True, "1", 2, None]),
    "cycle_period": st.one_of(WILD, st.sampled_from(["1", True, None])),
    "n_joints": st.sampled_from([2.0, "2", True, 0, 3, -1]),
    "protocol": st.sampled_from(["geogait-robot ", None, 1])}))


@settings(FUZZ, max_examples=16)
@given(fault=st.sampled_from(FAULTS), cycle=st.integers(0, 3), cycles=st.sampled_from([1, 9]),
       magnitude=st.sampled_from([10.0, 1000.0, 1e6]), hello=HELLOS)
@pytest.mark.slow
def test_bridge_takes_a_plausible_cycle_or_quarantines_or_stops_in_one_line(fault, cycle, cycles, magnitude, hello):
    """A fault-injecting driver (tests/_fault_driver.py): every injected fault is quarantined or ends the run with a
    clear, bounded error; nothing else escapes, nothing hangs."""
    import sys
    import time
    import warnings
    from pathlib import Path

    from geogait.optimize import InSituOptimizer
    from geogait.robots import ProcessRobot

    driver = [sys.executable, str(Path(__file__).parents[1] / "_fault_driver.py"),
              json.dumps({"fault": fault, "cycle": cycle, "cycles": cycles, "magnitude": magnitude, "hello": hello})]
    started = time.perf_counter()
    robot = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with ProcessRobot(driver, timeout=20) as robot:
                InSituOptimizer().run(robot, 5)
    except GeogaitError as error:
        assert str(error).startswith("robot driver '") and len(str(error)) < 1200, error
    else:
        injected = fault != "none" and (fault == "ignore_set_gait" or cycle < 5)
        if injected and fault not in ("ignore_set_gait", "time_scale") and not hello:
            assert robot.quarantined, (fault, cycle)  # an injected fault is never learned from silently
    assert time.perf_counter() - started < 40


def test_a_joint_limit_given_beyond_the_hellos_ranges_keeps_them(tmp_path):
    """Before: --max-joint-angle 4 with a hello declaring ±3 rad commanded 3.3 rad, exit 0 and no warning. Now
    the ranges join the feasible region: the same run that climbs past 1.03 rad without them stays within them."""
    import pandas as pd

    def reach(hello, out):
        driver = shlex.join(FAULT_DRIVER + [json.dumps({"hello": hello})])
        result = invoke("optimize", "--robot", driver, "--max-joint-angle", 2, "--cycles", 12, "--out", out)
        assert result.exit_code == 0, result.output
        params = pd.read_csv(out / "cycles.csv")[[f"param_{i}" for i in range(6)]].to_numpy()
        return max(FourierGait.from_params(row, 2).joint_limit().max() for row in params)

    assert reach({}, tmp_path / "free") > 1.03
    assert reach({"joint_ranges": [[-1.03, 1.5], [-1.5, 1.03]]}, tmp_path / "ranged") <= 1.03 + 1e-9


@pytest.mark.parametrize(("dropped", "named"), [("protocol", "'protocol': 'geogait-robot'"),
                                               ("type", "'type': 'hello'")])
def test_a_hello_without_its_type_or_protocol_names_the_field(tmp_path, dropped, named):
    hello = {key: value for key, value in HELLO.items() if key != dropped}
    with pytest.raises(GeogaitError, match=r"^robot driver ") as error:
        ProcessRobot(hello_driver(tmp_path, hello))
    assert f"the first line must be a 'geogait-robot' hello (with {named})" in str(error.value)
