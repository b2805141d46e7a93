"""Long logs in blocks of rows (``geogait._blocks``): the same answers as one call over every row."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

import geogait._blocks as blocks
from geogait import GeogaitError
from geogait.gaits import FourierGait, fourier_basis, seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.phase import Phaser
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


@given(st.integers(0, 500), st.integers(1, 64))
def test_row_blocks_cover_every_row_once_in_order(n, size):
    slices = list(blocks.row_blocks(n, size))
    assert [i for s in slices for i in range(s.start, s.stop)] == list(range(n))
    assert all(s.stop - s.start <= size for s in slices) and len(slices) == max(1, -(-n // size))


@pytest.mark.parametrize("columns", [None, 3])
def test_block_lstsq_solves_the_least_squares_problem_of_every_row(columns):
    """Tall-skinny QR over 7 blocks against one SVD-based lstsq: the solution and the singular values."""
    rng = np.random.default_rng(0)
    phase = rng.uniform(0, 2 * np.pi, 1000)
    signal = np.sin(phase) if columns is None else np.sin(phase)[:, None] * np.ones(columns)
    targets = signal + rng.normal(size=signal.shape)
    solution, singular = blocks.block_lstsq(lambda rows: fourier_basis(phase[rows], 6), targets, size=150)
    expected, _, _, expected_singular = np.linalg.lstsq(fourier_basis(phase, 6), targets, rcond=None)
    assert solution.shape == expected.shape
    np.testing.assert_allclose(solution, expected, atol=1e-12)
    np.testing.assert_allclose(singular, expected_singular, rtol=1e-12)


def test_block_lstsq_gives_the_minimum_norm_solution_of_a_rank_deficient_design():
    rng = np.random.default_rng(1)
    design = rng.normal(size=(400, 3))
    design = np.hstack([design, design[:, :1]])  # a repeated column
    targets = rng.normal(size=400)
    solution, singular = blocks.block_lstsq(lambda rows: design[rows], targets, size=64)
    np.testing.assert_allclose(solution, np.linalg.pinv(design) @ targets, atol=1e-12)
    assert singular.min() < 1e-12 * singular.max()


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), seed_gait(2), 6, seed=1)


def test_a_window_model_learns_the_same_in_blocks(run, monkeypatch):
    """Issue 58: a long record goes through the window rounds in blocks (a signal is handled between them). Each
    window takes its samples in the same order, so its filter's bits are the same; the a-priori prediction of a
    sample that two windows cover may sum them in the other order (a last bit)."""
    def learn():
        model = AdaptiveGaitModel(gait=seed_gait(2)).partial_fit(run.phase, run.shape, run.shape_velocity,
                                                                 run.body_velocity)
        return model, model.predict(run.phase, run.shape, run.shape_velocity)

    whole, whole_prediction = learn()
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 37)
    blocked, blocked_prediction = learn()
    np.testing.assert_array_equal(blocked.bank_.covariance, whole.bank_.covariance)
    np.testing.assert_array_equal(blocked_prediction, whole_prediction)
    np.testing.assert_allclose(blocked.prior_prediction_, whole.prior_prediction_, rtol=0, atol=1e-14)


def test_a_phaser_and_a_fourier_fit_are_the_same_in_blocks(run, monkeypatch):
    whole_phaser = Phaser().fit(run.shape)
    whole_gait = FourierGait.from_shapes(run.phase, run.shape, 3)
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 50)
    phaser = Phaser().fit(run.shape)
    np.testing.assert_allclose(phaser.transform(run.shape), whole_phaser.transform(run.shape), atol=1e-10)
    np.testing.assert_allclose(phaser.residual_std_, whole_phaser.residual_std_, rtol=1e-10)
    np.testing.assert_allclose(FourierGait.from_shapes(run.phase, run.shape, 3).coefficients,
                               whole_gait.coefficients, atol=1e-12)
    with pytest.raises(GeogaitError, match="spread enough over the cycle"):  # 60 phases of one value
        FourierGait.from_shapes(np.zeros(60), run.shape[:60], 3)


def test_a_log_file_is_read_the_same_in_blocks(tmp_path, monkeypatch):
    """CSV and Parquet logs read 7 rows at a time: the tables pandas reads in one call (a stored index kept)."""
    from geogait.io._logs import load_frame

    table = pd.DataFrame({"time": np.arange(30) / 10, "shape_0": np.sin(np.arange(30)), "note": ["a"] * 30})
    table.to_csv(tmp_path / "log.csv", index=False)
    table.to_parquet(tmp_path / "log.parquet")
    table.set_index("time").to_parquet(tmp_path / "indexed.parquet")
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 7)
    pd.testing.assert_frame_equal(load_frame(tmp_path / "log.csv"), pd.read_csv(tmp_path / "log.csv"))
    for name in ("log.parquet", "indexed.parquet"):
        pd.testing.assert_frame_equal(load_frame(tmp_path / name), pd.read_parquet(tmp_path / name))


def test_fitting_and_predicting_a_long_log_calls_nothing_over_more_than_a_block(tmp_path, monkeypatch):
    """Issue 58: SIGTERM waits for a compiled call. ``fit_log`` and ``predict_log`` of a log 12 blocks long make no
    least-squares, QR or SVD call over more rows than a block (and the log's file is read a block at a time)."""
    from geogait.io import read_log
    from geogait.learn import fit_log, predict_log

    frame = simulate(PurcellSwimmer(3), seed_gait(2), 12, seed=4, sensor_noise=0.1).to_pandas()  # 1 200 rows
    frame.to_csv(tmp_path / "log.csv", index=False)
    largest = []

    def counted(original):
        def wrapped(a, *args, **kwargs):
            largest.append(np.shape(a)[0])
            return original(a, *args, **kwargs)
        return wrapped

    for name in ("lstsq", "qr", "svd"):
        monkeypatch.setattr(np.linalg, name, counted(getattr(np.linalg, name)))
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 100)
    columns = dict(shape=["shape_0", "shape_1"], body_velocity=["body_velocity_x", "body_velocity_y",
                                                                "body_velocity_theta"], phase="phase")
    fitted = fit_log(read_log(tmp_path / "log.csv", **columns))
    predict_log(fitted.model, read_log(tmp_path / "log.csv", **columns))
    assert largest and max(largest) <= 100 + 64, max(largest)  # (a block, on the factor R of at most 64 columns)
