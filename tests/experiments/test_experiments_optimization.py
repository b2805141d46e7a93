import json
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from geogait.cli import app
from geogait.experiments import OptimizationConfig, OptimizationResult, run_optimization


def test_quick_figure_writes_consistent_outputs(tmp_path):
    result = CliRunner().invoke(app, ["figure", "optimization", "--quick", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(tmp_path / "optimization.csv")
    config = OptimizationConfig.quick()
    n_params = 6  # 3-link swimmer, order-1 gaits: 2 joints × 3 coefficients, one number per column
    assert list(frame.columns) == list(OptimizationResult.COLUMNS) + [f"param_{i}" for i in range(n_params)]
    assert np.isfinite(frame[[f"param_{i}" for i in range(n_params)]].to_numpy()).all()
    adaptive = frame[frame["method"] == "adaptive"]
    assert adaptive["trial"].nunique() == config.n_trials and adaptive["cycle"].max() == config.budgets[0] - 1
    batch = frame[frame["method"] == "batch"]
    assert batch["cycle"].max() == 30 * config.baseline_iterations - 1
    # The batch method only moves at the end of each 30-cycle iteration.
    steps = batch.loc[batch["step"], "cycle"].to_numpy()
    assert np.all((steps + 1) % 30 == 0)
    manifest = json.loads((tmp_path / "optimization.json").read_text())
    headline = manifest["results"]["3-link"]
    final = adaptive[adaptive["cycle"] == adaptive["cycle"].max()]["improvement"]
    assert headline["improvement_percentiles"]["p50"] == round(float(np.percentile(final, 50)), 4)
    assert headline["improvement_percentiles"]["p50"] > 0.2  # the optimiser improves within 12 cycles
    assert 0.9 < headline["ceiling_improvement"] < 1.05  # ceiling: +97 % over the seed gait
    assert (tmp_path / "optimization.png").stat().st_size > 20_000
    # Redraw from the CSV without rerunning.
    again = CliRunner().invoke(app, ["figure", "optimization", "--from-csv", str(tmp_path / "optimization.csv"),
                                     "--out", str(tmp_path / "redraw")])
    assert again.exit_code == 0, again.output
    redrawn = json.loads((tmp_path / "redraw" / "optimization.json").read_text())["results"]["3-link"]
    assert redrawn["improvement_percentiles"] == headline["improvement_percentiles"]
    # Redrawn into the run's own folder: the run's manifest stays, the redraw's goes beside it.
    before = (tmp_path / "optimization.json").read_bytes()
    again = CliRunner().invoke(app, ["figure", "optimization", "--from-csv", str(tmp_path / "optimization.csv"),
                                     "--out", str(tmp_path)])
    assert again.exit_code == 0, again.output
    assert (tmp_path / "optimization.json").read_bytes() == before
    assert "from_csv" in json.loads((tmp_path / "optimization.redraw.json").read_text())["config"]


@pytest.mark.slow
def test_sweep_is_identical_for_one_and_two_workers():
    config = OptimizationConfig.quick(n_trials=2, budgets=(6,), baseline_trials=0)
    one = run_optimization(config, jobs=1, progress=False).frame
    two = run_optimization(config, jobs=2, progress=False).frame
    pd.testing.assert_frame_equal(one, two)


def test_optimize_command_writes_report(tmp_path):
    result = CliRunner().invoke(app, ["optimize", "--links", "3", "--cycles", "8", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(tmp_path / "cycles.csv")
    assert len(log) == 8 and {"gamma", "true_progress", "ceiling_fraction"} <= set(log.columns)
    summary = json.loads((tmp_path / "summary.json").read_text())["results"]
    final = log[np.all(log.filter(like="param_").to_numpy() == summary["final_gait_params"], axis=1)]
    assert summary["final_displacement_per_cycle"] == final["true_objective"].iloc[-1]
    for name in ("gait.png", "progress.png", "path.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_the_summary_reports_the_final_gait_not_a_trial_left_unjudged(tmp_path):
    """The demo run ends on a climb candidate that was never judged: the summary's final numbers are those of the
    gait the run settled on (its final_gait_params), not those of that last trial."""
    result = CliRunner().invoke(app, ["optimize", "--links", "3", "--cycles", "40", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    log = pd.read_csv(tmp_path / "cycles.csv")
    summary = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert log["candidate"].iloc[-1]  # (the run this test is about)
    final = log[np.all(log.filter(like="param_").to_numpy() == summary["final_gait_params"], axis=1)]
    assert not final["candidate"].any()
    assert summary["final_displacement_per_cycle"] == final["true_objective"].iloc[-1]
    assert summary["final_ceiling_fraction"] == final["ceiling_fraction"].iloc[-1] > 0.99
    assert summary["final_ceiling_fraction"] != log["ceiling_fraction"].iloc[-1]
    kept = log[~log["candidate"] & (log["ceiling_fraction"] >= 0.9)]
    assert summary["first_cycle_at_90_percent_of_ceiling"] == kept["cycle"].iloc[0]


def test_optimize_command_takes_model_family_and_step_rule(tmp_path):
    options = ["--method", "shape", "--family", "free", "--step-rule", "sqp"]
    result = CliRunner().invoke(app, ["optimize", "--links", "3", "--cycles", "10", *options, "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    optimizer = json.loads((tmp_path / "summary.json").read_text())["config"]["optimizer"]
    model = optimizer["model"]
    assert model["class"] == "ShapeSpaceModel" and model["params"]["degree"] == 4  # Fig. 5's model
    assert model["params"]["degree_shrinkage"] == 30 and model["params"]["forgetting_factor"] == 0.999
    assert model["params"]["symmetry"] == "mirror+reversal"  # the built-in swimmer's symmetries
    assert optimizer["family"] == "free" and optimizer["step"]["params"]["rule"] == "sqp"
    log = pd.read_csv(tmp_path / "cycles.csv")
    assert log["step"].any() and log["param_0"].notna().all()  # it moved, in the free family's parameters
    resumed = CliRunner().invoke(app, ["optimize", "--resume", str(tmp_path), "--cycles", "12"])
    assert resumed.exit_code == 0, resumed.output
    assert len(pd.read_csv(tmp_path / "cycles.csv")) == 12


def _optimize(*args):
    return CliRunner().invoke(app, ["optimize", *map(str, args)])


def _optimizer_config(folder):
    return json.loads((folder / "summary.json").read_text())["config"]["optimizer"]


def test_optimize_command_takes_the_climb(tmp_path):
    """--climb first: the run's optimiser climbs first (recorded, and kept on resume); a bad value is refused in
    one line."""
    result = _optimize("--links", 3, "--cycles", 8, "--climb", "first", "--out", tmp_path)
    assert result.exit_code == 0, result.output
    assert _optimizer_config(tmp_path)["climb"]["params"]["start"] == "first"
    log = pd.read_csv(tmp_path / "cycles.csv")
    assert log["climb"].any() and not (log["step"] & ~log["climb"]).any()  # only climb moves in 8 cycles
    resumed = _optimize("--resume", tmp_path, "--cycles", 10)
    assert resumed.exit_code == 0, resumed.output
    assert _optimizer_config(tmp_path)["climb"]["params"]["start"] == "first"
    bad = _optimize("--links", 3, "--cycles", 2, "--climb", "sometimes", "--out", tmp_path / "bad")
    assert bad.exit_code == 1 and "--climb must be one of on, off, contradicted, first" in bad.output
    assert bad.output.count("\n") == 1


def test_optimize_command_takes_the_climb_rule(tmp_path):
    """--climb-rule cobyqa: the climb's candidates come from COBYQA (recorded in the summary and run.json, kept
    on resume); a bad value is refused in one line."""
    result = _optimize("--links", 3, "--cycles", 10, "--climb", "first", "--climb-rule", "cobyqa", "--out", tmp_path)
    assert result.exit_code == 0, result.output
    assert _optimizer_config(tmp_path)["climb"]["params"]["rule"] == "cobyqa"
    assert json.loads((tmp_path / "run.json").read_text())["climb_rule"] == "cobyqa"
    assert pd.read_csv(tmp_path / "cycles.csv")["climb"].sum() >= 2
    resumed = _optimize("--resume", tmp_path, "--cycles", 12)
    assert resumed.exit_code == 0, resumed.output
    assert _optimizer_config(tmp_path)["climb"]["params"]["rule"] == "cobyqa"
    bad = _optimize("--links", 3, "--cycles", 2, "--climb-rule", "bobyqa", "--out", tmp_path / "bad")
    assert bad.exit_code == 1 and "--climb-rule must be one of auto, es, cobyqa, bayes; got 'bobyqa'" in bad.output
    assert bad.output.count("\n") == 1


def test_optimize_command_with_the_resistance_model(tmp_path):
    """--method resistance: the swimmer's geometry, its drags learned; SQP up to R 0.5, the climb only when
    contradicted, unless a step rule is given; refused with one line for a --robot whose driver declares no chain."""
    result = CliRunner().invoke(app, ["optimize", "--links", "5", "--cycles", "14", "--method", "resistance",
                                      "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    optimizer = summary["config"]["optimizer"]
    assert optimizer["model"]["class"] == "ResistanceModel" and len(optimizer["model"]["params"]["link_lengths"]) == 5
    step, climb = optimizer["step"]["params"], optimizer["climb"]["params"]
    assert (step["rule"], step["max_trust_radius"], climb["start"]) == ("sqp", 0.5, "contradicted")
    assert summary["results"]["final_ceiling_fraction"] > 0.9  # 5 links from 42 % in 14 cycles
    resumed = CliRunner().invoke(app, ["optimize", "--resume", str(tmp_path), "--cycles", "16"])
    assert resumed.exit_code == 0, resumed.output
    assert len(pd.read_csv(tmp_path / "cycles.csv")) == 16
    linear = CliRunner().invoke(app, ["optimize", "--links", "3", "--cycles", "2", "--method", "resistance",
                                      "--step-rule", "linear", "--out", str(tmp_path / "linear")])
    assert linear.exit_code == 0, linear.output
    assert json.loads((tmp_path / "linear" / "summary.json").read_text())["config"]["optimizer"]["step"][
        "params"]["rule"] == "linear"
    hello = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
             "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}}  # no "chain"
    script = tmp_path / "driver.py"
    script.write_text(f"import json, sys\nprint(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")
    driver = f"{sys.executable} {script}"
    refused = CliRunner().invoke(app, ["optimize", "--method", "resistance", "--robot", driver,
                                       "--out", str(tmp_path / "robot")])
    assert refused.exit_code == 1 and "declares no chain geometry" in refused.stderr, refused.output


def test_bad_figure_options_are_reported(tmp_path):
    result = CliRunner().invoke(app, ["figure", "optimization", "--links", "3,5", "--cycles", "40", "--out",
                                      str(tmp_path)])
    assert result.exit_code == 1 and "error: --cycles must be one budget per swimmer" in result.stderr


def test_fig5_models_per_swimmer():
    """'auto' is the symmetric connection model of degree 4 with a graded prior (λ 0.999 up to 5 links, 0.9999
    beyond); the others as named."""
    from geogait.experiments.optimization import in_situ_model
    from geogait.models import AdaptiveGaitModel, ShapeSpaceModel

    for n_links, forgetting in ((3, 0.999), (5, 0.999), (9, 0.9999)):
        model = in_situ_model("auto", n_links)
        assert isinstance(model, ShapeSpaceModel) and model.symmetry == "mirror+reversal"
        assert model.degree == 4 and model.degree_shrinkage == 30 and model.forgetting_factor == forgetting
    assert in_situ_model("shape", 5).symmetry is None
    assert in_situ_model("adaptive", 5).get_params()["forgetting_factor"] == 1 - 0.1 / 4
    assert isinstance(in_situ_model("adaptive", 9), AdaptiveGaitModel)


def test_fig5_runs_the_papers_loop_steps_from_the_model_alone():
    """Fig. 5's runs take steps from the model alone: no measured climb and no revert to the best gait measured,
    which on this 5-link trial the library's default makes within 24 cycles."""
    from geogait.experiments.optimization import paper_optimizer
    from geogait.gaits import Perturbation, seed_gait
    from geogait.simulate import SwimmerStream
    from geogait.systems import PurcellSwimmer

    def stream():
        return SwimmerStream(PurcellSwimmer(5), seed_gait(4), perturbation=Perturbation.from_std(0.15),
                             sensor_noise=0.1, seed=1)

    paper = paper_optimizer("adaptive", "auto", 5, 0.5)
    log = paper.run(stream(), 24).log
    assert not log["reverted"].any() and not log["climb"].any() and log["step"].sum() >= 5
    assert log["excitation"].max() > 0.05  # the swimmer's own exploration (eq. 8), not commanded
    assert paper.set_params(safety__revert_tolerance=2.0).run(stream(), 24).log["reverted"].sum() == 1


def test_shape_method_model_for_swimmer_and_robot():
    """--method shape: Fig. 5's model on the built-in swimmer; degree 3 without symmetry for a robot, whose
    symmetries are not known; --forgetting-factor overrides λ in both."""
    from geogait.experiments.optimization import shape_method_model

    swimmer = shape_method_model(9)
    assert (swimmer.degree, swimmer.symmetry, swimmer.forgetting_factor) == (4, "mirror+reversal", 0.9999)
    robot = shape_method_model(9, robot=True, forgetting_factor=0.99)
    assert (robot.degree, robot.symmetry, robot.degree_shrinkage, robot.forgetting_factor) == (3, None, 1.0, 0.99)


def test_the_progress_figure_holds_the_kept_gait_through_trials_not_kept():
    """A trial the run did not keep is drawn apart: the 'gait held' line stays on the gait kept before it."""
    from geogait.plotting import plot_progress, plt
    log = pd.DataFrame({"cycle": range(6), "measured_objective": [1.0, 1.1, 0.5, 1.6, 0.7, 1.5],
                        "true_objective": [1.0, 1.0, 0.4, 1.5, 0.6, 1.5], "gamma": np.nan,
                        "step": [False, True, True, True, True, False], "climb": [False, True, True, True, True, False],
                        "candidate": [False, False, True, False, True, False], "rejected": False})
    fig, ax = plt.subplots()
    plot_progress(ax, log, seed_value=1.0)
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_array_equal(lines["gait held (true)"].get_ydata(), [1.0, 1.0, 1.0, 1.5, 1.5, 1.5])
    np.testing.assert_array_equal(lines["trial not kept (climb candidate, period)"].get_ydata(), [0.4, 0.6])
    assert "model step taken" not in lines  # (every step here was the climb's)
    plt.close(fig)
