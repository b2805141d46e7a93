"""The learners check what they are given (issue 11): the stream learner's plausibility bound, input that cannot
be decoded, and every argument of fit_log before it fits the phaser."""

import pytest
from _noisy_run import frame as frame
from _noisy_run import run as run
from _reference import COLUMNS, GAIT, lines
from _reference import Sink as _Sink

from geogait import GeogaitError
from geogait.learn import StreamLearner, run_stream
from geogait.models import AdaptiveGaitModel, load_model


def test_stream_learner_bound_is_relative_and_settable(run):
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), outlier_limit=None)
    sink = _Sink()
    text = lines(run, 0, 200, {150: {"body_velocity": [0.0, 1e4, 0.0]}})
    summary = run_stream(learner, text.splitlines(True), sink)
    assert summary.n_rejected == 0 and summary.n_learned == 200  # switched off: learned (only ±1e12 applies)
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT))
    assert run_stream(learner, lines(run, 0, 400).splitlines(True), _Sink()).n_rejected == 0  # clean data pass
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), outlier_limit=3)
    summary = run_stream(learner, lines(run, 0, 200).splitlines(True), _Sink())
    assert summary.n_rejected > 0 and "outlier_limit = 3 robust standard deviations" in summary.first_rejection


def test_undecodable_stream_input_stops_with_a_clear_error(run, tmp_path):
    class Broken:
        def __iter__(self):
            yield from lines(run, 0, 5).splitlines(True)
            raise UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte")

    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), path=tmp_path / "m.npz")
    summary = run_stream(learner, Broken(), _Sink())
    assert summary.reason == "error" and "unreadable input after 5 sample(s)" in summary.error
    assert summary.saved == tmp_path / "m.npz" and load_model(summary.saved).n_samples_seen_ == 5


@pytest.mark.parametrize(("options", "match"), [
    (dict(forgetting_factor=2.0), "'forgetting_factor' parameter"),
    (dict(n_windows=-1), "'n_windows' parameter"),
    (dict(max_gait_order="x"), "'max_gait_order' parameter of fit_log"),
    (dict(gait_order=-1), "'gait_order' parameter of fit_log"),
    (dict(refit="no"), "'refit' parameter of fit_log must be True or False"),
])
def test_fit_log_checks_every_argument_before_it_fits_the_phaser(frame, options, match):
    """The phaser handed in was fitted first and the bad argument refused after; 'no' counted as True."""
    from geogait.io import read_log
    from geogait.learn import fit_log
    from geogait.phase import Phaser

    log = read_log(frame.drop(columns="phase"), **{**COLUMNS, "phase": None})
    phaser = Phaser()
    with pytest.raises(GeogaitError, match=match):
        fit_log(log, phaser=phaser, **options)
    assert not phaser.__sklearn_is_fitted__()
    fitted = fit_log(log, phaser=phaser).phaser
    assert fitted is phaser and phaser.__sklearn_is_fitted__()
    with pytest.raises(GeogaitError, match="'phaser' parameter of fit_log must be an unfitted Phaser"):
        fit_log(log, phaser=phaser)
