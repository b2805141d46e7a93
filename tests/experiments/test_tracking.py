"""The path-following experiment and the ``geogait track`` / ``geogait figure tracking`` commands."""

import json

import numpy as np
import pandas as pd
import pytest
from _reference import nulls_without_reason
from typer.testing import CliRunner

from geogait.cli import app
from geogait.experiments.tracking import (
    TrackingConfig,
    TrackingResult,
    drag_change_cycle,
    drag_change_metrics,
    feasible_turn_limit,
    plot_exploration,
    run_tracking,
    tracking_model,
    tracking_path,
)
from geogait.models import ShapeSpaceModel


def _strict_json(path):
    def refuse(constant):
        raise ValueError(f"{constant} in {path}")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_quick_experiment_pairs_controllers_and_round_trips(tmp_path):
    config = TrackingConfig.quick(n_trials=1, paths=("line",), n_cycles=8, change_cycle=4, warmup_cycles=4)
    result = run_tracking(config, progress=False)
    frame = result.frame
    assert set(frame["controller"]) == {"adaptive", "frozen", "true"}
    assert set(zip(frame["path"], frame["environment"], strict=True)) == {("line", "constant"), ("circle", "change")}
    assert frame.groupby(["path", "controller"]).size().eq(8).all()
    change = frame[frame["environment"] == "change"]
    assert change[change["cycle"] < 4]["drag_ratio"].eq(2.0).all()
    assert change[change["cycle"] >= 4]["drag_ratio"].eq(4.0).all()
    adaptive = frame[frame["controller"] == "adaptive"]
    assert adaptive["gamma"].between(0, 1).all() and frame[frame["controller"] != "adaptive"]["gamma"].isna().all()
    true = frame[frame["controller"] == "true"]
    np.testing.assert_allclose(true["predicted_turn"], true["true_turn"], atol=1e-6)  # the oracle predicts itself
    summary = result.summary()
    line = summary["3-link line constant"]
    assert line["adaptive"]["cross_track_p95"] >= line["adaptive"]["cross_track_mean"] > 0
    assert line["adaptive_over_true_cross_track"] == pytest.approx(
        line["adaptive"]["cross_track_mean"] / line["true"]["cross_track_mean"])
    assert "drag_change" in summary["3-link circle change"]
    result.to_csv(tmp_path / "t.csv")
    again = TrackingResult.from_csv(tmp_path / "t.csv")
    pd.testing.assert_frame_equal(again.frame, frame, check_dtype=False)
    assert again.plot(tmp_path / "t.png").stat().st_size > 10_000


def test_adaptive_exploration_is_replayed_by_the_other_controllers(tmp_path):
    """Paired trials: the adaptive controller sizes δ; the frozen and true controllers run with its schedule,
    cycle by cycle, and so with the very same perturbations."""
    config = TrackingConfig.quick(n_trials=2, paths=(), n_cycles=10, change_cycle=5, warmup_cycles=4,
                                  exploration="adaptive", exploration_low=0.05)
    frame = run_tracking(config, progress=False).frame
    stds = frame.pivot_table(index=["trial", "cycle"], columns="controller", values="perturbation_std")
    np.testing.assert_array_equal(stds["frozen"], stds["adaptive"])
    np.testing.assert_array_equal(stds["true"], stds["adaptive"])
    assert stds["adaptive"].between(0.05, 0.15).all() and stds["adaptive"].min() < 0.1
    assert frame["surprise"].notna().all()
    fixed = run_tracking(TrackingConfig.quick(n_trials=1, paths=(), n_cycles=4, change_cycle=2, warmup_cycles=3),
                         progress=False).frame
    assert fixed["perturbation_std"].eq(0.05).all()  # the default fixed δ std
    figure = plot_exploration({"adaptive δ": frame, "δ 0.05": fixed}, tmp_path / "e.png", change_cycle=5)
    assert figure.stat().st_size > 10_000
    with pytest.raises(ValueError, match="'exploration' parameter of TrackingConfig"):
        TrackingConfig(exploration="greedy").validate()
    with pytest.raises(ValueError, match="'exploration_low' parameter of TrackingConfig"):
        TrackingConfig(exploration="adaptive", exploration_low=0.2).validate()
    with pytest.raises(ValueError, match="'exploration_high' parameter of TrackingConfig"):
        TrackingConfig(exploration="adaptive", exploration_high=-0.1).validate()


def test_shape_space_model_with_change_forgetting_runs_the_experiment():
    """``model="shape"`` gives the adaptive and frozen controllers the shape-space model (with the
    swimmers' symmetries), and the log shows it: Γ of the shape model, and the frozen controller's
    predictions differ from the window model's run on the same trial; bad names are refused."""
    assert tracking_model("window") is None
    shape = tracking_model("shape")
    assert isinstance(shape, ShapeSpaceModel) and shape.symmetry == "mirror+reversal"
    robot_model = tracking_model("shape", symmetric=False)
    assert robot_model.symmetry is None and robot_model.degree == 2
    options = dict(n_trials=1, paths=(), n_cycles=6, change_cycle=3, warmup_cycles=3,
                   controllers=("adaptive", "frozen"))
    window = run_tracking(TrackingConfig.quick(model="window", change_forgetting=1.0, **options), progress=False).frame
    shaped = run_tracking(TrackingConfig.quick(**options), progress=False).frame  # the defaults
    assert TrackingConfig().model == "shape" and TrackingConfig().change_forgetting == 100.0
    assert shaped.groupby("controller").size().eq(6).all()
    assert shaped[shaped.controller == "adaptive"]["gamma"].notna().all()
    assert not np.allclose(window["predicted_turn"], shaped["predicted_turn"])
    with pytest.raises(ValueError, match="'model'"):
        TrackingConfig(model="spline").validate()
    with pytest.raises(ValueError, match="'change_forgetting'"):
        TrackingConfig(change_forgetting=0.5).validate()
    with pytest.raises(ValueError, match="'model'"):
        tracking_model("spline")


def test_a_run_of_some_scenarios_repeats_the_full_runs_trials():
    both = TrackingConfig.quick(n_trials=1, paths=("line",), n_cycles=5, change_cycle=2, warmup_cycles=3)
    alone = TrackingConfig.quick(n_trials=1, paths=(), n_cycles=5, change_cycle=2, warmup_cycles=3)
    frames = [run_tracking(c, progress=False).frame for c in (both, alone)]
    change = [f[f["environment"] == "change"].reset_index(drop=True) for f in frames]
    pd.testing.assert_frame_equal(change[0], change[1])


def test_drag_change_metrics_on_known_curves():
    cycles = np.arange(30)
    level = np.where(cycles < 10, 0.1, np.where(cycles < 15, 0.5, 0.12))  # error jumps at 10, back at 15
    frozen = np.where(cycles < 10, 0.1, 0.3)
    frame = pd.concat([pd.DataFrame({"cycle": cycles, "cross_track": level, "controller": "adaptive", "trial": 0}),
                       pd.DataFrame({"cycle": cycles, "cross_track": -frozen, "controller": "frozen", "trial": 0})])
    metrics = drag_change_metrics(frame, change_cycle=10)
    assert metrics["pre_change_level"] == pytest.approx(0.1)
    # 3-cycle running mean from the change: 0.5 0.5 0.5 0.5 0.5 (0.5+0.5+0.12)/3 ... ≤ 0.15 first at cycle 17
    assert metrics["cycles_to_recover"] == 7
    assert metrics["cycles_until_below_frozen"] == 0  # the adaptive mean from the change on is already lower
    assert metrics["frozen_mean_first_10_after"] == pytest.approx(0.3)


def test_built_in_paths_scale_with_the_step():
    circle = tracking_path("circle", 0.2)
    assert circle.length == pytest.approx(2 * np.pi * 2.0, rel=1e-3)
    rectangle = tracking_path("waypoints", 0.1)
    assert rectangle.points.max(axis=0) == pytest.approx([1.5, 1.0])
    assert TrackingConfig(paths=("line",), drag_paths=()).validate().scenarios() == [("line", "constant")]
    with pytest.raises(ValueError, match="'paths' parameter of TrackingConfig"):
        TrackingConfig(paths=("spiral",)).validate()
    with pytest.raises(ValueError, match="'change_cycle' parameter"):
        TrackingConfig(n_cycles=10, change_cycle=10).validate()
    with pytest.raises(ValueError, match="'turn_limit' parameter of TrackingConfig"):
        TrackingConfig(turn_limit=0.05).validate()
    with pytest.raises(ValueError, match="'heading_weight' parameter of TrackingConfig"):
        TrackingConfig(heading_weight=-1.0).validate()
    with pytest.raises(ValueError, match="'warmup_turns' parameter of TrackingConfig"):
        TrackingConfig(warmup_turns=-1).validate()


def test_turn_limit_is_cut_to_the_joint_limits():
    """Within the joint limits 2π/3 the 3-link swimmer turns ≈ 0.55 rad per cycle at most, the 5-link one
    more than 1 rad."""
    assert feasible_turn_limit(3) == pytest.approx(0.5)
    assert feasible_turn_limit(5) == pytest.approx(1.0)
    assert feasible_turn_limit(5, 0.3) == pytest.approx(0.3)
    with pytest.raises(ValueError, match="'upper' parameter of feasible_turn_limit"):
        feasible_turn_limit(5, 0.0)


def test_track_command_writes_plot_csv_and_strict_json(tmp_path):
    waypoints = tmp_path / "zigzag.csv"
    waypoints.write_text("x,y\n0,0\n0.5,0.1\n1.0,-0.1\n1.5,0.1\n")
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["track", "--links", "3", "--path", str(waypoints), "--drag-ratio", "2,4",
                                      "--quick", "--cycles", "6", "--change-cycle", "3", "--out", str(out)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    assert set(log["controller"]) == {"adaptive", "frozen", "true"} and log.groupby("controller").size().max() <= 6
    summary = _strict_json(out / "summary.json")
    assert summary["config"]["drag_ratios"] == [2.0, 4.0]
    assert summary["config"]["turn_limit"] == pytest.approx(0.5)  # the 3-link swimmer's joint limits
    assert summary["results"]["frozen"]["final_gamma"] is None  # NaN is written as null
    assert set(summary["results"]["drag_change"]) >= {"pre_change_level", "cycles_to_recover"}
    for name in ("path.png", "family.png"):
        assert (out / name).stat().st_size > 10_000


def test_track_command_with_adaptive_exploration(tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["track", "--links", "3", "--path", "circle", "--drag-ratio", "2,4", "--quick",
                                      "--cycles", "6", "--change-cycle", "3", "--exploration", "adaptive",
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    stds = log.pivot(index="cycle", columns="controller", values="perturbation_std")
    assert stds.nunique(axis=1).eq(1).all() and stds["adaptive"].between(0.05, 0.15).all()
    config = _strict_json(out / "summary.json")["config"]
    assert config["exploration"] == "adaptive" and config["exploration_low"] == 0.05


def test_track_command_with_the_shape_space_model(tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["track", "--links", "3", "--path", "line", "--drag-ratio", "2,4", "--quick",
                                      "--cycles", "6", "--change-cycle", "3", "--controllers", "adaptive",
                                      "--model", "shape", "--change-forgetting", "100", "--out", str(out)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    assert len(log) == 6 and log["alarm"].dtype == bool
    config = _strict_json(out / "summary.json")["config"]
    assert config["model"] == "shape" and config["change_forgetting"] == 100


def test_track_command_follows_a_path_with_a_robot_behind_a_driver(tmp_path):
    """``--robot``: each controller gets a fresh driver process (the JSON-lines bridge); the robot's own
    gait is the straight gait and ``--step`` sizes the built-in path."""
    import sys

    driver = f"{sys.executable} -m geogait.robots.driver --links 3 --perturbation 0.05"
    out = tmp_path / "robot"
    result = CliRunner().invoke(app, ["track", "--robot", driver, "--path", "circle", "--step", "0.05",
                                      "--warmup", "10", "--cycles", "3", "--out", str(out)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    assert sorted(log["controller"].unique()) == ["adaptive", "frozen"] and len(log) == 6
    assert log["true_turn"].isna().all()  # no oracle behind a driver
    summary = _strict_json(out / "summary.json")
    assert summary["config"]["robot"] == driver and summary["config"]["links"] is None
    assert summary["results"]["path_length"] == pytest.approx(2 * np.pi * 0.5, rel=1e-3)


@pytest.mark.parametrize(("options", "message"), [
    (["--controllers", "adaptive,true"], "The 'true' controller needs the built-in swimmer"),
    (["--drag-ratio", "2,4"], "--drag-ratio changes the built-in swimmer"),
    (["--exploration", "adaptive"], "Adaptive exploration needs a robot"),
    (["--path", "circle"], "give --step"),
    (["--path", "circle", "--step", "-1"], "--step"),
])
def test_track_command_robot_option_errors(tmp_path, options, message):
    result = CliRunner().invoke(app, ["track", "--robot", "no-such-driver-is-started", "--out", str(tmp_path / "x"),
                                      *options])
    assert result.exit_code == 1
    assert result.stderr.startswith("error: ") and message in result.stderr and len(result.stderr.splitlines()) == 1
    assert not (tmp_path / "x").exists()  # refused before anything was written


def test_track_command_reports_a_driver_that_cannot_start(tmp_path):
    result = CliRunner().invoke(app, ["track", "--robot", "no-such-driver-xyz", "--path", "line", "--step", "0.05",
                                      "--out", str(tmp_path / "x")])
    assert result.exit_code == 1
    assert result.stderr.startswith("error: ") and len(result.stderr.splitlines()) == 1


@pytest.mark.parametrize(("options", "message"), [
    (["--path", "spiral"], "--path"),
    (["--path", "missing.csv"], "does not exist"),
    (["--drag-ratio", "2,x"], "--drag-ratio"),
    (["--drag-ratio", "2,3,4"], "--drag-ratio"),
    (["--controllers", "adaptive,psychic"], "--controllers"),
    (["--drag-ratio", "2,4", "--cycles", "5", "--change-cycle", "7"], "--change-cycle"),
    (["--links", "1"], "--links"),
    (["--turn-limit", "0"], "--turn-limit"),
    (["--exploration", "greedy"], "--exploration"),
    (["--exploration", "adaptive", "--exploration-low", "0.3"], "--exploration-low"),
    (["--exploration", "adaptive", "--exploration-high", "-1"], "--exploration-high"),
    (["--perturbation", "nan"], "--perturbation"),
    (["--model", "spline"], "--model"),
    (["--change-forgetting", "0.5"], "--change-forgetting"),
])
def test_track_command_user_errors(tmp_path, options, message):
    result = CliRunner().invoke(app, ["track", "--quick", "--out", str(tmp_path / "x"), *options])
    assert result.exit_code == 1
    assert result.stderr.startswith("error: ") and message in result.stderr and len(result.stderr.splitlines()) == 1


def test_figure_tracking_redraws_from_csv(tmp_path):
    config = TrackingConfig.quick(n_trials=1, paths=("circle",), drag_paths=(), n_cycles=4, change_cycle=2,
                                  warmup_cycles=3)
    run_tracking(config, progress=False).to_csv(tmp_path / "tracking.csv")
    out = tmp_path / "fig"
    result = CliRunner().invoke(app, ["figure", "tracking", "--from-csv", str(tmp_path / "tracking.csv"),
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    manifest = _strict_json(out / "tracking.json")
    assert "3-link circle constant" in manifest["results"]

    assert nulls_without_reason(manifest) == []
    assert (out / "tracking.png").stat().st_size > 10_000 and (out / "steering-family.png").stat().st_size > 10_000


def test_docs_steering_example_runs(monkeypatch, tmp_path):
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "steering.md").read_text()
    section = re.search(r"## The tracker and its parts(.*?)(?:\n## |\Z)", text, re.S).group(1)
    block = "\n".join(re.findall(r"```python\n(.*?)```", section, re.S))  # (its blocks run in order)
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(block, "README steering example", "exec"), namespace)
    assert namespace["result"].summary()["cross_track_mean"] < 0.2
    assert namespace["family"].feasible.all()
    adaptive, frozen = namespace["adaptive"], namespace["frozen"]
    np.testing.assert_array_equal(frozen.perturbation_std, adaptive.perturbation_std)
    stds = adaptive.log["perturbation_std"].to_numpy()
    assert stds[19] < 0.07 and stds[21] == pytest.approx(0.15)  # k = 4 from tracking cycle 20: the alarm
    shaped = namespace["shaped"].log
    assert shaped["alarm"].to_numpy().nonzero()[0][0] == 20 and shaped["alarm"].sum() <= 2  # forgot at k = 4


@pytest.mark.parametrize("forget", ["directional", "scaled and clamped"])
def test_five_links_relearn_within_a_few_cycles_of_a_drag_change(monkeypatch, forget):
    """On the 5-link swimmer the shape-space model's never-excited directions fill the trace clamp's
    budget, so multiplying the covariance and clamping (the former forget) changed nothing and the
    predicted step stayed near half the measured one; forgetting direction by direction up to the
    prior re-learns: predicted / measured ≥ 0.9 within 5 cycles of the change (drag 2 → 4)."""
    from geogait.control import PathTracker, ReferencePath
    from geogait.experiments.tracking import feasible_turn_limit, straight_gait, tracking_model
    from geogait.gaits import Perturbation
    from geogait.models._rls import RLSBank
    from geogait.simulate import DragRatioSchedule, SwimmerStream

    if forget != "directional":
        monkeypatch.setattr(RLSBank, "forget", RLSBank.inflate)
    system, gait, step = straight_gait(5)
    change = 12
    robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.05), sensor_noise=0.1,
                          environment=DragRatioSchedule(system, (2.0, 4.0), 10 + change), seed=0)
    tracker = PathTracker(warmup_cycles=10, turn_limit=feasible_turn_limit(5), model=tracking_model("shape"),
                          change_forgetting=100.0)
    log = tracker.run(robot, ReferencePath.circle(10 * step), change + 6).log
    predicted = np.hypot(log["predicted_x"], log["predicted_y"])
    ratio = (predicted / np.hypot(log["measured_x"], log["measured_y"])).to_numpy()
    assert log["alarm"].to_numpy().nonzero()[0].tolist() == [change]  # the alarm fires on the first changed cycle
    assert ratio[change] < 0.6  # the change is real: the old model promises about half the step
    relearned = ratio[change + 2:change + 6].mean()
    if forget == "directional":
        assert relearned >= 0.9
    else:
        assert relearned < 0.75


def test_a_tracking_csv_read_back_gives_the_same_summary_whatever_the_change_cycle(tmp_path):
    """Read back without its config, the frame used to place the drag change at half the run: with the change
    at cycle 4 of 16 every drag-change number came out different (the recovery 8 cycles became 0)."""
    result = run_tracking(TrackingConfig.quick(n_trials=1, paths=("line",), change_cycle=4), progress=False)
    result.to_csv(tmp_path / "t.csv")
    again = TrackingResult.from_csv(tmp_path / "t.csv")
    assert again.config is None and drag_change_cycle(again.frame) == 4
    assert json.dumps(again.summary(), default=str) == json.dumps(result.summary(), default=str)


def test_drag_change_metrics_give_every_null_a_reason():
    frame = pd.DataFrame({"controller": ["adaptive"] * 12, "trial": 0, "cycle": np.arange(12),
                          "cross_track": [0.1] * 6 + [1.0] * 6})
    metrics = drag_change_metrics(frame, 6)
    assert metrics["change_reached"] and metrics["cycles_to_recover"] is None
    assert nulls_without_reason(metrics) == []
