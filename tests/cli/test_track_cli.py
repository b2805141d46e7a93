"""Issue 23: ``geogait track --trials``, paths of the user's own (closed CSVs, errors naming file and
row), per-trial statistics and drag-change windows, and the tracking figures' styles; issue 21: a failed run leaves
the earlier one whole, --out is checked before the run, a run that ends before its budget says so."""

import json
import time
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from _cli import invoke, one_error_line, snapshot
from _reference import nulls_without_reason
from matplotlib.colors import to_rgba
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait.cli import app
from geogait.control import ReferencePath
from geogait.experiments.tracking import (
    CONTROLLER_STYLE,
    drag_change_metrics,
    per_trial_ratios,
    plot_error_curves,
    plot_paths,
    plot_reference,
    plot_steering_family,
    trial_stats,
)
from geogait.plotting import plt


def _run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _summary(folder):
    return json.loads((folder / "summary.json").read_text())


def _square(tmp_path, side=0.3, close=True, name="square.csv"):
    rows = [(0, 0), (side, 0), (side, side), (0, side)] + ([(0, 0)] if close else [])
    file = tmp_path / name
    file.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in rows))
    return file


# -- paths of one's own ------------------------------------------------------------------------
def test_a_csv_whose_last_row_repeats_the_first_is_closed(tmp_path):
    closed = ReferencePath.from_csv(_square(tmp_path, side=1.0))
    assert closed.closed and closed.points.shape == (4, 2) and closed.length == pytest.approx(4.0)
    np.testing.assert_allclose(closed.point(4.5), [0.5, 0.0])  # lap two: on around the first waypoint
    assert not closed.at_end(10.0)
    opened = ReferencePath.from_csv(_square(tmp_path, side=1.0, close=False, name="open.csv"))
    assert not opened.closed and opened.length == pytest.approx(3.0) and opened.at_end(3.0)


def test_the_tracker_goes_round_a_closed_csv_path_and_stops_at_the_end_of_an_open_one(tmp_path):
    """The 3-link swimmer steps ≈ 0.1 body lengths a cycle: 16 cycles are more than one lap of the 1.2 body
    length square. Closed, it keeps going; open, the run stops at the last waypoint."""
    options = ["track", "--links", "3", "--quick", "--warmup", "3", "--cycles", "16", "--controllers", "adaptive"]
    closed = _run(*options, "--path", _square(tmp_path), "--out", tmp_path / "closed", "--json")
    assert closed.exit_code == 0, closed.output
    results = _summary(tmp_path / "closed")["results"]
    assert json.loads(closed.stdout) == results  # --json: the results as one JSON document on stdout
    assert results["path_closed"] is True and results["path_length"] == pytest.approx(1.2)
    assert results["adaptive"]["stopped_early"] is False
    assert len(pd.read_csv(tmp_path / "closed" / "cycles.csv")) == 16
    opened = _run(*options, "--path", _square(tmp_path, close=False, name="open.csv"), "--out", tmp_path / "open")
    assert opened.exit_code == 0, opened.output
    results = _summary(tmp_path / "open")["results"]
    assert results["path_closed"] is False and results["adaptive"]["stopped_early"] is True


@pytest.mark.parametrize(("text", "message"), [
    ("x,y\n0,0\n1,0\n1,0\n1,1\n", "Got data row 3 equal to row 2 (1, 0)"),
    ("x,y\n0,0\n0,0\n", "Got data row 2 equal to row 1 (0, 0)"),
    ("x,y\n0,0\n1,0\n0,0\n", "at least 3 distinct waypoints"),
    ("x,y\n0,0\n1,zero\n", "bad value in data row 2"),
])
def test_bad_waypoint_rows_are_named_with_file_and_row(tmp_path, text, message):
    file = tmp_path / "mine.csv"
    file.write_text(text)
    with pytest.raises(GeogaitError, match="mine.csv") as error:
        ReferencePath.from_csv(file)
    assert message in str(error.value)
    result = _run("track", "--quick", "--path", file, "--out", tmp_path / "x")
    # (the CLI says it of --path: "--path must be …; got …")
    assert result.exit_code == 1 and str(file) in result.stderr and message.lower() in result.stderr.lower()
    assert len(result.stderr.splitlines()) == 1


def test_a_repeated_vertex_names_its_index():
    with pytest.raises(GeogaitError, match="the first vertex 2 repeating vertex 1"):
        ReferencePath(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]))


def test_the_readme_rectangle_is_a_built_in_path(tmp_path):
    result = _run("track", "--links", "3", "--quick", "--warmup", "3", "--cycles", "2", "--controllers", "adaptive",
                  "--path", "waypoints", "--out", tmp_path / "w")
    assert result.exit_code == 0, result.output
    step = _summary(tmp_path / "w")["results"]["step_per_cycle"]
    assert _summary(tmp_path / "w")["results"]["path_length"] == pytest.approx(5 * 10 * step, rel=0.01)


# -- paired trials -----------------------------------------------------------------------------
def test_track_trials_pairs_seeds_across_controllers_and_reports_each_trial(tmp_path):
    out = tmp_path / "trials"
    result = _run("track", "--links", "3", "--path", "circle", "--drag-ratio", "2,4", "--quick", "--warmup", "3",
                  "--cycles", "4", "--change-cycle", "2", "--trials", "3", "--seed", "5", "--out", out)
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    assert sorted(log["trial"].unique()) == [0, 1, 2] and log.groupby(["trial", "controller"]).size().eq(4).all()
    # paired: the same warm-up and first decision for the adaptive and frozen models of a trial (both fitted
    # on the same seeded warm-up), different from trial to trial
    first = log[log["cycle"] == 0].pivot(index="trial", columns="controller", values=["x", "y", "predicted_turn"])
    for column in ("x", "y", "predicted_turn"):
        np.testing.assert_array_equal(first[column]["adaptive"], first[column]["frozen"])
    assert first["x"]["adaptive"].nunique() == 3
    # per-trial results, checked against the cycles
    trials = pd.read_csv(out / "trials.csv")
    means = log.assign(e=log["cross_track"].abs()).groupby(["trial", "controller"])["e"].mean()
    np.testing.assert_allclose(trials.set_index(["trial", "controller"])["cross_track_mean"], means.sort_index())
    ratios = means.xs("adaptive", level="controller") / means.xs("true", level="controller")
    results = _summary(out)["results"]
    per_trial = results["adaptive_over_true_per_trial"]
    np.testing.assert_allclose(per_trial["ratios"], ratios.to_numpy())
    assert results["adaptive_over_true_worst_trial"] == pytest.approx(ratios.max())
    assert per_trial["worst_trial"] == int(ratios.idxmax())
    assert results["share_trials_within_1.5x_true"] == pytest.approx(np.mean(ratios <= 1.5))
    window = results["drag_change"]["windows"]["cycles_0_9_after"]
    after = log[log["cycle"] >= 2].assign(e=lambda f: f["cross_track"].abs())
    assert window["frozen"] == pytest.approx(after[after["controller"] == "frozen"]["e"].mean())
    assert window["adaptive_over_true_per_trial"]["trials"] == [0, 1, 2]
    assert results["drag_change"]["windows"]["cycles_10_29_after"]["adaptive"] is None  # not reached: said why
    assert "before cycle 12" in results["drag_change"]["windows"]["cycles_10_29_after"]["adaptive_null_reason"]
    assert nulls_without_reason(results) == []
    config = _summary(out)["config"]
    assert config["trials"] == 3 and config["seed"] == 5
    assert (out / "path.png").stat().st_size > 10_000 and not (out / "family.png").exists()


@pytest.mark.parametrize("turns", [None, 0, 2])
def test_the_drag_change_lands_on_its_tracking_cycle_after_any_turning_warmup(tmp_path, turns):
    """The turning warm-up cycles (4 by default on the built-in swimmer) come before the first tracking cycle,
    so the change still lands on ``--change-cycle``; the run records how many there were."""
    extra = [] if turns is None else ["--warmup-turns", turns]
    out = tmp_path / f"t{turns}"
    result = _run("track", "--links", "3", "--path", "circle", "--drag-ratio", "2,4", "--quick", "--warmup", "3",
                  "--cycles", "4", "--change-cycle", "2", "--controllers", "adaptive", *extra, "--out", out)
    assert result.exit_code == 0, result.output
    log = pd.read_csv(out / "cycles.csv")
    assert log["drag_ratio"].tolist() == [2.0, 2.0, 4.0, 4.0]
    assert _summary(out)["config"]["warmup_turns"] == (4 if turns is None else turns)


def test_warmup_turns_default_to_none_with_a_robot_and_are_refused_below_zero(tmp_path):
    from geogait.experiments.track import TrackSettings

    robot = TrackSettings(robot="python -m driver", step=0.05, controllers=("adaptive",)).resolved()
    assert robot.warmup_turns == 0 and TrackSettings().resolved().warmup_turns == 4
    result = _run("track", "--quick", "--warmup-turns", "-1", "--out", tmp_path / "x")
    assert result.exit_code == 1 and "--warmup-turns" in result.stderr
    assert not (tmp_path / "x").exists()
    result = _run("track", "--quick", "--horizon", "3", "--straight-horizon", "4", "--out", tmp_path / "y")
    assert result.exit_code == 1 and "--straight-horizon" in result.stderr
    assert result.stderr.count("\n") == 1 and not (tmp_path / "y").exists()


@pytest.mark.parametrize(("options", "message"), [
    (["--robot", "no-such-driver", "--trials", "2"], "--trials"),
    (["--jobs", "2"], "--jobs and --scheduler"),
])
def test_track_trials_options_refused_where_they_cannot_act(tmp_path, options, message):
    result = _run("track", "--quick", *options, "--out", tmp_path / "x")
    assert result.exit_code == 1 and message in result.stderr and not (tmp_path / "x").exists()


@pytest.mark.parametrize("offset", ["1e300", "-1.1e12"])
def test_an_offset_beyond_the_bound_is_refused_before_the_run(tmp_path, offset):
    """Issue 58, finding 7: --offset 1e300 ran and reported a cross-track error of 1e300."""
    result = _run("track", "--quick", "--offset", offset, "--out", tmp_path / "x")
    assert result.exit_code == 1 and not (tmp_path / "x").exists()
    assert result.stderr.splitlines() == [f"error: --offset must be a finite number of body lengths within ±1e+12; "
                                          f"got {float(offset)}."]


# -- per-trial statistics and the drag-change windows -----------------------------------------
def _frame(errors: dict, cycles=40):
    """Long-format frame: ``errors`` maps (trial, controller) to |e| as a function of the cycle."""
    return pd.concat([pd.DataFrame({"trial": trial, "controller": controller, "cycle": np.arange(cycles),
                                    "cross_track": (-1) ** trial * error(np.arange(cycles)), "heading_error": 0.1})
                      for (trial, controller), error in errors.items()], ignore_index=True)


def test_per_trial_ratios_and_windows_on_known_errors():
    """Trial 0: adaptive 1.2× the true connection everywhere; trial 1: 2× after the change (cycle 10),
    1× before. The pooled ratio hides trial 1; the per-trial one shows it."""
    def step(before, after):
        return lambda c: np.where(c < 10, before, after)

    frame = _frame({(0, "adaptive"): step(0.12, 0.12), (0, "true"): step(0.1, 0.1), (0, "frozen"): step(0.1, 0.3),
                    (1, "adaptive"): step(0.1, 0.2), (1, "true"): step(0.1, 0.1), (1, "frozen"): step(0.1, 0.3)})
    stats = trial_stats(frame, change_cycle=10)
    row = stats.set_index(["trial", "controller"]).loc[(1, "adaptive")]
    assert row["cross_track_mean"] == pytest.approx((10 * 0.1 + 30 * 0.2) / 40)
    assert row["cycles_0_9_after"] == pytest.approx(0.2) and row["cycles_10_29_after"] == pytest.approx(0.2)
    ratios = per_trial_ratios(stats)
    assert ratios["ratios"] == pytest.approx([1.2, 0.175 / 0.1])
    assert ratios["worst"] == pytest.approx(1.75) and ratios["worst_trial"] == 1
    assert ratios["share_within"] == 0.5 and ratios["share_below_one"] == 0.0
    windows = drag_change_metrics(frame, 10)["windows"]
    late = windows["cycles_10_29_after"]
    assert late["adaptive"] == pytest.approx(0.16) and late["frozen"] == pytest.approx(0.3)
    assert late["true"] == pytest.approx(0.1)
    assert late["adaptive_over_true_per_trial"]["ratios"] == pytest.approx([1.2, 2.0])
    assert late["adaptive_over_frozen_per_trial"]["share_below_one"] == 1.0
    assert windows["cycles_0_9_after"]["adaptive"] == pytest.approx(0.16)


def test_windows_without_the_change_reached_say_why():
    frame = _frame({(0, "adaptive"): lambda c: 0.1 + 0 * c, (0, "true"): lambda c: 0.1 + 0 * c}, cycles=15)
    late = drag_change_metrics(frame, 10)["windows"]["cycles_10_29_after"]
    assert late["adaptive"] is None and "before cycle 20" in late["adaptive_null_reason"]


# -- figures -----------------------------------------------------------------------------------
def test_one_controller_style_in_every_tracking_figure():
    fig, axes = plt.subplots(1, 3)
    family = SimpleNamespace(steps=np.array([0.1, 0.2]), poses=np.zeros((2, 3)), feasible=np.ones(2, bool))
    plot_steering_family(axes[0], {"adaptive": family, "frozen": family, "true": family}, 3)
    frame = _frame({(0, c): (lambda c: 0.1 + 0 * c) for c in CONTROLLER_STYLE}, cycles=12).assign(
        links=3, path="circle", environment="constant", x=lambda f: f["cycle"] * 0.1, y=0.0)
    plot_paths(axes[1], frame, 3, "circle", "constant", 0)
    plot_error_curves(axes[2], frame.assign(environment="change"), 3, "circle", change_cycle=6)
    for ax in axes:
        colours = {line.get_label(): to_rgba(line.get_color()) for line in ax.lines}
        for name, style in CONTROLLER_STYLE.items():
            label = next(k for k in colours if name in k and (name != "true" or "k=4" not in k))
            assert colours[label] == to_rgba(style["color"]), (ax, name)
    zorder = {line.get_label(): line.get_zorder() for line in axes[1].lines}
    assert zorder["true"] < zorder["frozen"] < zorder["adaptive"]  # the true controller underneath
    assert axes[1].get_ylabel() == "y (body lengths)"
    assert any(np.allclose(line.get_xdata(), 6) for line in axes[2].lines)  # the drag change marked
    plt.close(fig)


def test_a_closed_reference_path_is_drawn_whole():
    fig, ax = plt.subplots()
    plot_reference(ax, ReferencePath.circle(1.0), np.array([[0.0, 0.0], [0.3, 0.05]]))
    points = np.column_stack(ax.lines[0].get_data())
    assert np.isfinite(points).all() and np.allclose(points[0], points[-1])  # no arcs: one closed curve
    plot_reference(ax, ReferencePath.line(100.0), np.array([[0.0, 0.0], [0.3, 0.05]]))
    assert np.isnan(ax.lines[1].get_xydata()).any()  # a long open line is still cut around the robot
    plt.close(fig)


def test_figure_tracking_follows_a_csv_path(tmp_path):
    file = _square(tmp_path, side=0.6)
    out = tmp_path / "fig"
    result = _run("figure", "tracking", "--quick", "--trials", "1", "--cycles", "4", "--path", f"circle,{file}",
                  "--drag-path", file, "--warmup-turns", "0", "--out", out)
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(out / "tracking.csv")
    assert set(zip(frame["path"], frame["environment"], strict=True)) == {
        ("circle", "constant"), ("csv", "constant"), ("csv", "change")}
    manifest = json.loads((out / "tracking.json").read_text())
    assert manifest["config"]["path_file"] == str(file) and manifest["config"]["warmup_turns"] == 0
    assert "adaptive_over_true_per_trial" in manifest["results"]["3-link csv constant"]
    assert "windows" in manifest["results"]["3-link csv change"]["drag_change"]
    assert (out / "tracking.png").stat().st_size > 10_000
    trials = pd.read_csv(out / "tracking-trials.csv")
    assert len(trials) == 3 * 3 and trials[trials["environment"] == "change"]["cycles_0_9_after"].notna().all()
    bad = _run("figure", "tracking", "--quick", "--path", "spiral", "--out", tmp_path / "bad")
    assert bad.exit_code == 1 and "--path" in bad.stderr
    both = _run("figure", "tracking", "--quick", "--drag-only", "--path", file, "--out", tmp_path / "both")
    assert both.exit_code == 1 and "'--drag-path'" in both.stderr
    negative = _run("figure", "tracking", "--quick", "--warmup-turns", "-1", "--out", tmp_path / "negative")
    assert negative.exit_code == 1 and "--warmup-turns must be an int >= 0" in negative.stderr


# -- an earlier run kept whole, --out checked first, a run that ends early (issue 21) ---------------------------
def test_a_failing_track_run_leaves_the_earlier_run_whole(tmp_path, monkeypatch):
    folder = tmp_path / "t"
    options = ["track", "--quick", "--cycles", "2", "--warmup", "2", "--controllers", "adaptive", "--path", "line"]
    assert invoke(*options, "--out", folder).exit_code == 0
    before = snapshot(folder)
    one_error_line(invoke(*options, "--seed", "2", "--out", folder), "not empty")  # checked before the run
    from geogait.experiments import track

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device", "path.png")

    monkeypatch.setattr(track, "_plot_paths", broken)
    one_error_line(invoke(*options, "--seed", "2", "--overwrite", "--out", folder), "No space left on device")
    assert snapshot(folder) == before
    assert [p.name for p in folder.iterdir() if p.name.startswith(".geogait-staging")] == []


def test_track_checks_its_output_folder_before_running(tmp_path):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    started = time.perf_counter()
    one_error_line(invoke("track", "--out", a_file), "is a file")
    assert time.perf_counter() - started < 5  # refused before the (minutes long) default run


def test_a_track_run_that_ends_before_the_budget_says_so(tmp_path):
    waypoints = tmp_path / "short.csv"
    waypoints.write_text("x,y\n0,0\n0.1,0\n")  # ends after about a cycle
    out = tmp_path / "t"
    result = invoke("track", "--quick", "--cycles", "8", "--change-cycle", "6", "--drag-ratio", "2,4", "--path",
                    waypoints, "--controllers", "adaptive,frozen", "--out", out)
    assert result.exit_code == 0, result.output
    assert "warning: the adaptive controller reached the end of the path" in result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["results"]["adaptive"]["stopped_early"] is True
    change = summary["results"]["drag_change"]
    assert change["change_reached"] is False and change["cycles_to_recover"] is None  # not 0
    assert "before the change" in change["cycles_to_recover_null_reason"]
    assert nulls_without_reason(summary) == []
