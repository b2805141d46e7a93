"""Fig. 2 (accuracy vs experience): the CLI's outputs, their content, and exact re-computations."""

import json

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread
from typer.testing import CliRunner

from geogait.cli import app
from geogait.experiments import AccuracyConfig, AccuracyResult, accuracy_summary, accuracy_trials
from geogait.experiments._common import box_stats, child_seeds, cycle_block
from geogait.experiments.accuracy import plot_gamma_boxes
from geogait.gaits import Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel, BatchGaitModel
from geogait.plotting import plt
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

QUICK = AccuracyConfig.quick()


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """``geogait figure accuracy --quick`` once for the module: (folder, frame, manifest)."""
    folder = tmp_path_factory.mktemp("accuracy")
    result = CliRunner().invoke(app, ["figure", "accuracy", "--quick", "--out", str(folder)])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(folder / "accuracy.csv")
    manifest = json.loads((folder / "accuracy.json").read_text())
    return folder, frame, manifest


def test_csv_is_long_format_with_one_row_per_pair_model_checkpoint(quick_run):
    _, frame, _ = quick_run
    assert list(frame.columns) == list(AccuracyResult.COLUMNS)
    n_pairs, checkpoints = QUICK.n_pairs, QUICK.checkpoints
    held = frame[frame.metric == "held_out"]
    online = frame[frame.metric == "online"]
    assert sorted(frame.trial.unique()) == list(range(n_pairs))
    assert len(held) == n_pairs * 2 * len(checkpoints)
    assert len(online) == n_pairs * QUICK.n_cycles * QUICK.online_points_per_cycle
    assert not frame.duplicated(["trial", "model", "metric", "cycles"]).any()
    assert set(held.model) == {"adaptive", "batch"} and set(online.model) == {"adaptive"}
    np.testing.assert_array_equal(np.sort(held.cycles.unique()), checkpoints)
    assert np.isfinite(frame.gamma).all()


def test_gamma_is_in_the_noisy_regime_and_online_gamma_grows(quick_run):
    _, frame, _ = quick_run
    held = frame[frame.metric == "held_out"].groupby(["model", "cycles"]).gamma.median()
    assert (held > 0.25).all() and (held < 0.6).all()  # sensor noise 0.3: far from the noise-free 0.98
    online = frame[frame.metric == "online"].groupby("cycles").gamma.median()
    assert online.iloc[0] < 0.1 < online.iloc[-1]


def test_manifest_records_config_versions_and_percentiles(quick_run):
    _, frame, manifest = quick_run
    assert manifest["command"] == "figure accuracy" and manifest["numpy_version"] == np.__version__
    config = manifest["config"]
    assert config["n_trials"] == QUICK.n_trials and config["seed"] == 0 and config["sensor_noise"] == 0.3
    assert manifest["wall_time_s"] > 0 and manifest["results"]["sweep_wall_time_s"] > 0
    summary = manifest["results"]["summary"]
    assert summary["n_pairs"] == QUICK.n_pairs
    batch_5 = frame.query("metric == 'held_out' and model == 'batch' and cycles == 5").gamma
    expected = np.percentile(batch_5, [5, 25, 50, 75, 95])
    reported = summary["held_out_gamma"]["batch"]["5"]
    np.testing.assert_allclose([reported[k] for k in ("p5", "p25", "p50", "p75", "p95")], expected, rtol=1e-12)
    headline = summary["headline"]  # recomputed from the CSV, pair by pair
    adaptive_5 = frame.query("metric == 'held_out' and model == 'adaptive' and cycles == 5").set_index("trial").gamma
    paired = adaptive_5 - batch_5.set_axis(frame.query(
        "metric == 'held_out' and model == 'batch' and cycles == 5").trial).reindex(adaptive_5.index)
    assert headline["adaptive_median_gamma_at_5"] == pytest.approx(float(adaptive_5.median()), rel=1e-12)
    assert headline["fraction_adaptive_above_0.4_at_5"] == pytest.approx(float((adaptive_5 > 0.4).mean()), rel=1e-12)
    assert headline["median_paired_difference_at_5"] == pytest.approx(float(paired.median()), rel=1e-12)
    assert headline["fraction_adaptive_better_at_5"] == pytest.approx(float((paired > 0).mean()), rel=1e-12)


def test_from_csv_redraws_the_same_figure_and_numbers(quick_run, tmp_path):
    folder, _, manifest = quick_run
    result = CliRunner().invoke(app, ["figure", "accuracy", "--from-csv", str(folder / "accuracy.csv"),
                                      "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    redrawn = json.loads((tmp_path / "accuracy.json").read_text())
    assert redrawn["results"]["summary"] == manifest["results"]["summary"]
    assert redrawn["config"]["from_csv"].endswith("accuracy.csv")
    np.testing.assert_array_equal(imread(tmp_path / "accuracy.png"), imread(folder / "accuracy.png"))
    assert not (tmp_path / "accuracy.csv").exists()


def test_checkpoints_equal_a_direct_refit_and_a_one_call_adaptive_fit(quick_run):
    """Pair 0 rebuilt by hand: batch refit on the first 5 cycles, adaptive fed them in one call."""
    _, frame, _ = quick_run
    seed = np.random.SeedSequence(QUICK.seed).spawn(QUICK.n_pairs)[0]
    system, gait = PurcellSwimmer(QUICK.n_links), seed_gait(QUICK.n_links - 1)
    options = dict(perturbation=Perturbation.from_std(QUICK.perturbation), sensor_noise=QUICK.sensor_noise)
    train = simulate(system, gait, QUICK.n_cycles, seed=child_seeds([seed], 0), **options)
    test = cycle_block(simulate(system, gait, QUICK.n_cycles, seed=child_seeds([seed], 1), **options), 0,
                       QUICK.n_cycles, QUICK.samples_per_cycle)
    first = cycle_block(train, 0, 5, QUICK.samples_per_cycle)
    batch = BatchGaitModel(gait=gait).fit(*first).score(*test)[0]
    adaptive = AdaptiveGaitModel(gait=gait, forgetting_factor=QUICK.forgetting_factor).fit(*first).score(*test)[0]
    row = frame.query("trial == 0 and metric == 'held_out' and cycles == 5").set_index("model").gamma
    assert row["batch"] == pytest.approx(batch, rel=1e-9)
    assert row["adaptive"] == pytest.approx(adaptive, rel=1e-9)


def test_pairs_do_not_depend_on_their_chunk():
    options = AccuracyConfig.quick(n_cycles=5).trial_options()
    seeds = np.random.SeedSequence(3).spawn(3)
    together = accuracy_trials(np.arange(3), seeds, **options)
    alone = accuracy_trials(np.array([2]), seeds[2:], **options)
    pd.testing.assert_frame_equal(together[together.trial == 2].reset_index(drop=True), alone, rtol=1e-10)


def test_box_whiskers_are_the_5th_and_95th_percentiles():
    values = np.arange(101.0)
    stats = box_stats(values, "x")
    assert (stats["whislo"], stats["q1"], stats["med"], stats["q3"], stats["whishi"]) == (5, 25, 50, 75, 95)
    assert stats["fliers"] == []
    frame = pd.DataFrame({"trial": np.tile(np.arange(101), 2), "model": np.repeat(["adaptive", "batch"], 101),
                          "metric": "held_out", "cycles": 5.0, "gamma": np.concatenate([values, values])})
    fig, ax = plt.subplots()
    plot_gamma_boxes(ax, frame)
    whisker_ends = {y for line in ax.lines for y in line.get_ydata()}
    plt.close(fig)
    assert {5.0, 95.0} <= whisker_ends and 0.0 not in whisker_ends and 100.0 not in whisker_ends


def test_summary_compares_pairs():
    frame = pd.DataFrame({"trial": [0, 0, 1, 1, 0, 1], "model": ["adaptive", "batch"] * 2 + ["adaptive"] * 2,
                          "metric": ["held_out"] * 4 + ["online"] * 2, "cycles": 5.0,
                          "gamma": [0.5, 0.3, 0.2, 0.4, 0.1, 0.3]})
    headline = accuracy_summary(frame)["headline"]
    assert headline["fraction_adaptive_better_at_5"] == 0.5
    assert headline["median_paired_difference_at_5"] == pytest.approx(0.0)
    assert headline["fraction_adaptive_above_0.4_at_5"] == 0.5


@pytest.mark.parametrize("change, field", [({"n_trials": 7}, "n_trials"), ({"n_cycles": 12}, "n_cycles"),
                                           ({"sensor_noise": -0.1}, "sensor_noise"), ({"n_links": 1}, "n_links")])
def test_bad_config_names_the_field(change, field):
    with pytest.raises(ValueError, match=f"'{field}' parameter of AccuracyConfig"):
        AccuracyConfig.quick(**change).validate()


def test_cli_rejects_a_csv_of_another_experiment(tmp_path):
    path = tmp_path / "other.csv"
    pd.DataFrame({"trial": [0], "value": [1.0]}).to_csv(path, index=False)
    result = CliRunner().invoke(app, ["figure", "accuracy", "--from-csv", str(path), "--out", str(tmp_path)])
    assert result.exit_code == 1 and "error: " in result.stderr and "expected columns" in result.stderr


def test_docstring_examples_run():
    import doctest

    from geogait.experiments import accuracy

    outcome = doctest.testmod(accuracy)
    assert outcome.attempted > 0 and outcome.failed == 0
