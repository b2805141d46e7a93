"""Fig. 3 (changing environments): the CLI's outputs, their content, recovery and exact checks."""

import json

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread
from typer.testing import CliRunner

from geogait.cli import app
from geogait.experiments import (
    EnvironmentConfig,
    EnvironmentResult,
    environment_summary,
    recovery_table,
    run_environments,
)
from geogait.experiments._common import cycle_block
from geogait.gaits import Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel, BatchGaitModel
from geogait.simulate import DragRatioSchedule, simulate
from geogait.systems import PurcellSwimmer

QUICK = EnvironmentConfig.quick()
MODELS = {"adaptive_0.99", "adaptive_0.7", "batch"}


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """``geogait figure environments --quick`` once for the module: (folder, frame, manifest)."""
    folder = tmp_path_factory.mktemp("environments")
    result = CliRunner().invoke(app, ["figure", "environments", "--quick", "--out", str(folder)])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(folder / "environments.csv")
    manifest = json.loads((folder / "environments.json").read_text())
    return folder, frame, manifest


def settled(frame, model, environment, cycles=5):
    """Median over trials of the mean error over the last ``cycles`` cycles of an environment."""
    part = frame[(frame.model == model) & (frame.environment == environment)]
    tail = part[part.cycle > part.cycle.max() - cycles]
    return tail.groupby("trial").error.mean().median()


def test_csv_has_one_row_per_trial_model_cycle_with_the_schedule(quick_run):
    _, frame, _ = quick_run
    assert list(frame.columns) == list(EnvironmentResult.COLUMNS)
    n_cycles = QUICK.n_cycles
    assert len(frame) == QUICK.n_trials * len(MODELS) * (n_cycles - 1)
    assert set(frame.model) == MODELS and sorted(frame.trial.unique()) == list(range(QUICK.n_trials))
    assert not frame.duplicated(["trial", "model", "cycle"]).any()
    assert frame.cycle.min() == 1 and frame.cycle.max() == n_cycles - 1
    expected_env = frame.cycle // QUICK.cycles_per_environment + 1
    np.testing.assert_array_equal(frame.environment, expected_env)
    np.testing.assert_array_equal(frame.drag_ratio, np.asarray(QUICK.drag_ratios)[expected_env - 1])
    assert (frame.error > 0).all()
    np.testing.assert_array_equal(frame.error, frame.error_measured)  # no sensor noise by default


def test_adaptive_models_beat_the_frozen_batch_model_after_each_switch(quick_run):
    _, frame, _ = quick_run
    assert settled(frame, "batch", 1) < 0.02  # in its own environment the batch model is fine
    for environment in (2, 3):
        batch = settled(frame, "batch", environment)
        for model in ("adaptive_0.99", "adaptive_0.7"):
            assert settled(frame, model, environment) < 0.5 * batch
    assert settled(frame, "batch", 3) > settled(frame, "batch", 2) > 3 * settled(frame, "batch", 1)


def test_recovery_is_reported_per_switch_and_model(quick_run):
    _, frame, manifest = quick_run
    summary = manifest["results"]["summary"]
    assert [s["switch_cycle"] for s in summary["switches"]] == [15, 30]
    recovery = summary["recovery"]
    assert recovery["batch"]["switch_1"]["recovery_cycles_median_curve"] == "never"
    assert recovery["batch"]["switch_1"]["fraction_of_trials_recovered"] == 0
    fast, slow = (recovery[m]["switch_1"]["recovery_cycles_median_curve"] for m in ("adaptive_0.7", "adaptive_0.99"))
    assert isinstance(fast, int) and isinstance(slow, int) and fast < slow < QUICK.cycles_per_environment
    assert summary["headline"]["adaptive_0.7_recovery_cycles_switch_1"] == fast
    table = recovery_table(frame)
    assert len(table) == QUICK.n_trials * len(MODELS) * 2
    jump = table[(table.model == "batch") & (table.switch == 1)].jump
    assert (jump > 2).all()


def test_recovery_counts_cycles_until_within_factor_of_the_pre_switch_error():
    cycles = np.arange(1, 13)
    curves = {"fast": [1, 1, 1, 1, 1, 8, 3, 1, 5, 5, 1, 1], "never": [1, 1, 1, 1, 1, 8, 8, 8, 8, 8, 8, 8]}
    frame = pd.concat([pd.DataFrame({"trial": 0, "model": name, "cycle": cycles, "environment": 1 + (cycles >= 6)
                                     + (cycles >= 9), "drag_ratio": 2.0, "error": np.asarray(curve, float),
                                     "error_measured": 0.0}) for name, curve in curves.items()])
    table = recovery_table(frame, factor=2.0, reference_cycles=3).set_index(["model", "switch"])
    assert table.loc[("fast", 1), "recovery_cycles"] == 2  # 8, 3, then 1 ≤ 2 × 1
    assert table.loc[("fast", 1), "jump"] == 8
    assert table.loc[("fast", 2), "pre_switch_error"] == pytest.approx(4.0)  # mean of 8, 3, 1
    assert table.loc[("fast", 2), "recovery_cycles"] == 0  # 5 ≤ 2 × 4 at once
    assert np.isnan(table.loc[("never", 1), "recovery_cycles"])
    summary = environment_summary(frame, factor=2.0, reference_cycles=3)
    assert summary["recovery"]["never"]["switch_1"]["recovery_cycles_median_curve"] == "never"
    assert summary["recovery"]["fast"]["switch_1"]["recovery_cycles_median_curve"] == 2


def test_from_csv_redraws_the_same_figure_and_numbers(quick_run, tmp_path):
    folder, _, manifest = quick_run
    result = CliRunner().invoke(app, ["figure", "environments", "--from-csv", str(folder / "environments.csv"),
                                      "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    redrawn = json.loads((tmp_path / "environments.json").read_text())
    assert redrawn["results"]["summary"] == manifest["results"]["summary"]
    np.testing.assert_array_equal(imread(tmp_path / "environments.png"), imread(folder / "environments.png"))


def test_errors_equal_a_hand_built_trial():
    """Trial 0 rebuilt by hand: the batch model frozen after environment 1, the adaptive model a priori."""
    config = EnvironmentConfig.quick(n_trials=2, cycles_per_environment=6, chunk_size=2, sensor_noise=0.2)
    frame = run_environments(config, progress=False).frame
    system, gait = PurcellSwimmer(3), seed_gait(2)
    schedule = DragRatioSchedule(system, config.drag_ratios, config.cycles_per_environment)
    seed = np.random.SeedSequence(config.seed).spawn(config.n_trials)[0]
    run = simulate(system, gait, config.n_cycles, perturbation=Perturbation.from_std(config.perturbation),
                   sensor_noise=config.sensor_noise, environment=schedule, seed=[seed])
    spc, target = config.samples_per_cycle, 9
    phase, shape, rate, measured = cycle_block(run, target, target + 1, spc)
    truth = -np.einsum("...ij,...j->...i", schedule(target).connection(shape), rate)
    batch = BatchGaitModel(gait=gait).fit(*cycle_block(run, 0, config.cycles_per_environment, spc))
    adaptive = AdaptiveGaitModel(gait=gait, forgetting_factor=0.7).fit(*cycle_block(run, 0, target, spc))
    rows = frame[(frame.trial == 0) & (frame.cycle == target)].set_index("model")
    for name, model in (("batch", batch), ("adaptive_0.7", adaptive)):
        predicted = model.predict(phase, shape, rate)
        assert rows.loc[name, "error"] == pytest.approx(np.linalg.norm(predicted - truth, axis=-1).mean(), rel=1e-9)
        assert rows.loc[name, "error_measured"] == pytest.approx(
            np.linalg.norm(predicted - measured, axis=-1).mean(), rel=1e-9)
    assert (frame.error_measured > frame.error).mean() > 0.9  # sensor noise shows in the measured error


@pytest.mark.parametrize("change, field", [({"drag_ratios": (2.0,)}, "drag_ratios"),
                                           ({"forgetting_factors": (1.5,)}, "forgetting_factors"),
                                           ({"cycles_per_environment": 3}, "cycles_per_environment")])
def test_bad_config_names_the_field(change, field):
    with pytest.raises(ValueError, match=f"'{field}' parameter of EnvironmentConfig"):
        EnvironmentConfig.quick(**change).validate()


def test_cli_rejects_bad_drag_ratios(tmp_path):
    result = CliRunner().invoke(app, ["figure", "environments", "--quick", "--drag-ratios", "2,x",
                                      "--out", str(tmp_path)])
    assert result.exit_code != 0 and "comma-separated" in result.output


def test_docstring_examples_run():
    import doctest

    from geogait.experiments import environments

    outcome = doctest.testmod(environments)
    assert outcome.attempted > 0 and outcome.failed == 0


def test_every_forgetting_factor_is_its_own_model_and_drawn():
    """Factors equal to 6 digits were merged into one model; a 6th adaptive model was left out of the figure."""
    from geogait import GeogaitError
    from geogait.experiments.environments import _styles

    with pytest.raises(GeogaitError, match="'forgetting_factors' parameter .* differ in their 6 significant digits"):
        EnvironmentConfig.quick(forgetting_factors=(0.9999991, 0.9999994)).validate()
    with pytest.raises(GeogaitError, match="'forgetting_factors'"):
        EnvironmentConfig.quick(forgetting_factors=(0.99, 0.99)).validate()
    models = [f"adaptive_{lam:g}" for lam in (0.99, 0.9, 0.8, 0.7, 0.6, 0.5)] + ["batch"]
    assert set(_styles(models)) == set(models)
