"""The optimiser's model-class test (``model_class_cycles``): the seed gait at two periods before anything else.
The built-in swimmer passes it and is optimised as usual; a body that coasts (its body velocity lags the
kinematic one) fails it, and then the model takes no step; a robot whose joints cannot follow the faster cycles
runs another gait, and the test declines to judge."""

import numpy as np
import pandas as pd
import pytest
from _robots import CoastingSwimmer, LaggingRobot
from typer.testing import CliRunner

from geogait import GeogaitWarning
from geogait.cli import app
from geogait.gaits import seed_gait
from geogait.optimize import Climb, InSituOptimizer, ModelClassTest, PeriodSearch
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

N = 3  # cycles per period


def test_the_swimmer_passes_and_is_optimised_after_the_test():
    robot = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=1)
    result = InSituOptimizer(checks=[ModelClassTest(cycles=N)]).run(robot, 24)
    log = result.log
    test = log["model_class_check"].to_numpy(dtype=bool)
    assert test[:2 * N + 2].all() and not test[2 * N + 2:].any()
    assert log["settling"][test].all()  # neither learned from nor measured for the objective
    assert log["measured_objective"][test].isna().all()
    # T for N cycles, then 2 T (a settling cycle and N measured), then one settling cycle back at T
    np.testing.assert_array_equal(log["cycle_period"][test], [1.0] * N + [2.0] * (N + 1) + [1.0])
    assert (log["cycle_period"][~test] == 1.0).all()
    # clean while testing (the optimiser owns the exploration); the seed's cycles after it are explored
    assert (log["excitation"][test] == 0).all() and (log["excitation"][~test].iloc[:2] > 0.05).all()
    verdict = result.model_class
    assert verdict.principally_kinematic is True, verdict.reason
    assert verdict.periods == (1.0, 2.0) and verdict.n_cycles == (N, N)
    assert result.n_steps >= 3 and result.summary()["model_class"]["principally_kinematic"] is True
    assert result.summary()["final_measured_improvement"] > 0.1


def test_a_coasting_body_fails_and_the_model_takes_no_step():
    with pytest.warns(GeogaitWarning, match="outside the model class.*gate stays shut: steps come from the "
                                            "measured climb only"):
        result = InSituOptimizer(climb=Climb(start="stalled"),
                                 checks=[ModelClassTest(cycles=N)]).run(CoastingSwimmer(), 30)
    verdict = result.model_class
    assert verdict.principally_kinematic is False
    short, long = verdict.progress  # (this lag makes it move farther per cycle at the short period)
    assert abs(short - long) > 0.1 * long and "changes with the cycle period" in verdict.reason
    log = result.log
    assert log["step"].sum() >= 3 and (log["climb"] == log["step"]).all()  # every step is the climb's
    # without the climb nothing steps; the same robot without the test is stepped by its model
    with pytest.warns(GeogaitWarning, match="no step is taken"):
        frozen = InSituOptimizer(climb=False, checks=[ModelClassTest(cycles=N)]).run(CoastingSwimmer(), 20)
    assert frozen.n_steps == 0 and frozen.final_gait == frozen.initial_gait
    untested = InSituOptimizer(climb=False).run(CoastingSwimmer(), 20)
    assert untested.n_steps > 0 and untested.model_class is None


def test_joints_that_cannot_follow_the_faster_cycles_leave_the_test_undecided():
    """LaggingRobot's actuators realise a smaller gait at the short period: another gait, so no verdict and no
    exclusion."""
    robot = LaggingRobot(cycle_period=0.6)
    result = InSituOptimizer(checks=[ModelClassTest(cycles=N)]).run(robot, 14)
    verdict = result.model_class
    assert verdict.principally_kinematic is None and "realised gait differs" in verdict.reason
    assert result.log["cycle_period"].iloc[N + 1] == pytest.approx(1.2)


def test_the_second_period_respects_the_period_range_and_joint_speed():
    robot = LaggingRobot(cycle_period=1.0)
    test = [ModelClassTest(cycles=N)]
    result = InSituOptimizer(period=PeriodSearch(period_range=(0.25, 1.5)), checks=test).run(robot, 10)
    assert result.log["cycle_period"].iloc[N + 1] == 0.5  # twice is beyond the range: half
    with pytest.raises(ValueError, match="'checks'.*period range and joint-velocity limit"):
        InSituOptimizer(period=PeriodSearch(period_range=(0.8, 1.5)), checks=test).run(LaggingRobot(), 20)


def test_bad_settings_are_named_before_the_robot_moves():
    robot = LaggingRobot()
    for bad in (1, 2, -1, 2.5, "3"):
        with pytest.raises(ValueError, match="'cycles' parameter of ModelClassTest"):
            InSituOptimizer(checks=[ModelClassTest(cycles=bad)]).run(robot, 3)

    class FixedPeriod(LaggingRobot):
        set_cycle_period = None

    with pytest.raises(ValueError, match="set_cycle_period.*ModelClassTest"):
        InSituOptimizer(checks=[ModelClassTest(cycles=N)]).run(FixedPeriod(), 20)
    assert robot.periods == [] and robot.pose.tolist() == [0, 0, 0]


def test_resume_during_the_test_is_bit_identical(tmp_path):
    path = tmp_path / "run.npz"
    with pytest.warns(GeogaitWarning, match="outside the model class"):
        whole = InSituOptimizer(checks=[ModelClassTest(cycles=N)]).run(CoastingSwimmer(seed=2), 14)

    def stop(row):
        if row["cycle"] == N + 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        InSituOptimizer(checks=[ModelClassTest(cycles=N)]).run(CoastingSwimmer(seed=2), 14, checkpoint=path,
                                                               callback=stop)
    with pytest.warns(GeogaitWarning, match="outside the model class"):  # the verdict comes after the resume
        resumed = InSituOptimizer.resume(path, CoastingSwimmer(seed=2))
    assert resumed.model_class == whole.model_class
    pd.testing.assert_frame_equal(resumed.log, whole.log, check_dtype=False)


def test_geogait_optimize_records_the_verdict_and_names_a_bad_option(tmp_path):
    runner = CliRunner()
    out = tmp_path / "run"
    result = runner.invoke(app, ["optimize", "--links", "3", "--cycles", "9", "--model-class-cycles", "3",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    import json
    summary = json.loads((out / "summary.json").read_text())
    assert summary["results"]["model_class"]["principally_kinematic"] is True
    assert summary["config"]["model_class_cycles"] == 3
    bad = runner.invoke(app, ["optimize", "--cycles", "3", "--model-class-cycles", "2", "--out", str(tmp_path / "b")])
    assert bad.exit_code == 1 and "--model-class-cycles" in bad.output and len(bad.output.strip().splitlines()) == 1
