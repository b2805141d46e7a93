"""The model-class verdict: a snake with dry friction and inertia (the kinematic-snake package's, a log written by
studies/kinematic_snake_log.py) is outside the model class; the principally kinematic swimmer is not; one period
cannot tell."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from geogait import GeogaitWarning
from geogait.cli import app
from geogait.gaits import Perturbation, seed_gait
from geogait.io import read_log
from geogait.learn import fit_log, model_class_verdict
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

SNAKE = Path(__file__).resolve().parents[1] / "data" / "kinematic_snake_froude1.csv"
COLUMNS = dict(shape=["shape_0", "shape_1"], phase="phase", shape_velocity=["shape_velocity_0", "shape_velocity_1"],
               body_velocity=["body_velocity_x", "body_velocity_y", "body_velocity_theta"])


def swimmer_log(periods, cycles=14, noise=0.1, perturbation=None):
    """The built-in 3-link swimmer, perturbed and with sensor noise, one log segment per period."""
    parts, offset = [], 0.0
    for seed, period in enumerate(periods):
        run = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=noise, seed=seed, cycle_period=period,
                            samples_per_cycle=40, perturbation=perturbation).next_cycles(cycles)
        frame = run.to_pandas()
        frame["time"] += offset - frame["time"].iloc[0]
        offset = float(frame["time"].iloc[-1]) + 10 * period  # a gap: a new segment
        parts.append(frame)
    return read_log(pd.concat(parts, ignore_index=True), **COLUMNS)


def test_the_kinematic_snake_with_inertia_is_outside_the_model_class():
    # its shape coordinates are curvature-mode amplitudes (up to 8.8), so the window model asks about degrees
    with pytest.warns(GeogaitWarning, match="more than a full turn"):
        fit = fit_log(read_log(pd.read_csv(SNAKE), **COLUMNS))
    verdict = fit.model_class()
    assert verdict.principally_kinematic is False
    assert "changes with the cycle period" in verdict.reason and "progress" in verdict.reason
    short, long = verdict.progress
    assert verdict.periods == pytest.approx((0.5, 1.0), rel=0.01) and short < 0.9 * long  # it moves less when fast
    assert fit.summary()["model_class"]["principally_kinematic"] is False


def test_the_swimmer_moves_the_same_per_cycle_at_any_period():
    """Without exploration and noise the motion per cycle is the same to rounding at both periods (the principally
    kinematic invariance itself): consistent with the model class. With them the difference is within noise, which
    cannot bound it below 5 % in 12 cycles: the verdict says it cannot tell, never "outside"."""
    clean = fit_log(swimmer_log((1.0, 0.5), noise=0.0, perturbation=Perturbation(eta=0.0))).model_class()
    assert clean.principally_kinematic is True, clean.reason
    assert clean.n_cycles == (12, 12)
    np.testing.assert_allclose(*clean.progress, rtol=1e-6)
    noisy = fit_log(swimmer_log((1.0, 0.5))).model_class()
    assert noisy.principally_kinematic is None and noisy.reason.startswith("cannot tell"), noisy.reason
    gap, error = abs(np.subtract(*noisy.progress)), np.hypot(*noisy.progress_se)
    assert gap < 3 * error


def test_one_period_cannot_tell_and_says_what_would():
    log = swimmer_log((1.0,), cycles=20)
    verdict = fit_log(log).model_class()
    assert verdict.principally_kinematic is None and "another period" in verdict.reason
    assert verdict.progress is None


def test_a_period_dependent_body_is_caught_whatever_produced_it():
    """A swimmer whose body velocity lags the kinematic one (first-order, τ = 0.1 s: a body that coasts) moves
    less per cycle when its cycles are short: the verdict needs nothing but the log."""
    parts, offset = [], 0.0
    for seed, period in enumerate((1.0, 0.25)):
        run = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=seed, cycle_period=period,
                            samples_per_cycle=200).next_cycles(12)
        frame = run.to_pandas()
        dt, tau = period / 200, 0.1
        lagged = np.zeros((len(frame), 3))
        kinematic = frame[["body_velocity_x", "body_velocity_y", "body_velocity_theta"]].to_numpy()
        for i in range(1, len(frame)):  # exact discretisation of τ ξ̇ = ξ_kinematic − ξ
            lagged[i] = lagged[i - 1] + (1 - np.exp(-dt / tau)) * (kinematic[i - 1] - lagged[i - 1])
        frame[["body_velocity_x", "body_velocity_y", "body_velocity_theta"]] = lagged
        frame["time"] += offset - frame["time"].iloc[0]
        offset = float(frame["time"].iloc[-1]) + 10 * period
        parts.append(frame)
    fit = fit_log(read_log(pd.concat(parts, ignore_index=True), **COLUMNS))
    assert fit.model_class().principally_kinematic is False


def test_bad_settings_are_named():
    log = swimmer_log((1.0,), cycles=6)
    with pytest.raises(ValueError, match="'z' parameter of model_class_verdict"):
        model_class_verdict(log, np.zeros(log.n_samples, int), z=0)
    with pytest.raises(ValueError, match="'min_period_ratio' parameter"):
        model_class_verdict(log, np.zeros(log.n_samples, int), min_period_ratio=1.0)
    with pytest.raises(ValueError, match=r"'cycle' parameter of model_class_verdict must be an int array of shape"):
        model_class_verdict(log, np.zeros(3, int))


def test_geogait_fit_warns_in_one_line(tmp_path):
    result = CliRunner().invoke(app, ["fit", str(SNAKE), "--shape", "shape_0,shape_1", "--phase", "phase",
                                      "--shape-velocity", "shape_velocity_0,shape_velocity_1", "--body-velocity",
                                      "body_velocity_x,body_velocity_y,body_velocity_theta", "--out",
                                      str(tmp_path / "fit")])
    assert result.exit_code == 0, result.output
    warning = [line for line in result.stderr.splitlines() if line.startswith("warning: outside the model class")]
    assert len(warning) == 1 and "changes with the cycle period" in warning[0]
