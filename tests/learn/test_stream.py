"""``geogait stream`` and the streaming library: equality with the batch path, signals, kills, bad
lines, online phase and differentiation, Phaser persistence, the robot example."""

import contextlib
import importlib.util
import io
import json
import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from _reference import GAIT, fit_args, lines
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import savgol_coeffs
from typer.testing import CliRunner

from geogait import GeogaitError, _kernels
from geogait.cli import app
from geogait.io import JsonLinesReader
from geogait.learn import OnlineDifferentiator, StreamLearner, load_stream_model, run_stream
from geogait.models import AdaptiveGaitModel, load_model
from geogait.phase import OnlinePhaser, Phaser
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = Path(sys.executable).with_name("geogait")
COMMAND = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-c", "from geogait.cli import main; main()"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 50, seed=4, sensor_noise=0.1)  # 5 000 samples


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    return path


def assert_same_model(saved, expected):
    """RLS state of a streamed model equal to the batch path's: bit for bit on the NumPy reference path,
    to 1e-12 of each array's scale on the compiled one (summation order only; geogait._kernels)."""
    exact = not _kernels.fast_path_available()
    for a, b in ((saved.window_weights_, expected.window_weights_), (saved.covariance_, expected.covariance_),
                 (saved.psi_, expected.psi_), (saved.phase_model_.bank_.weights, expected.phase_model_.bank_.weights),
                 (saved.phase_model_.bank_.covariance, expected.phase_model_.bank_.covariance)):
        if exact:
            np.testing.assert_array_equal(a, b)
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    assert saved.n_samples_seen_ == expected.n_samples_seen_ and saved.gait_ == expected.gait_


# -- the real console script ----------------------------------------------------------------------
def test_5000_samples_through_the_console_script_equal_the_in_process_and_batch_paths(run, config, tmp_path):
    out = tmp_path / "model.npz"
    done = subprocess.run([*COMMAND, "stream", str(config), "--out", str(out)], input=lines(run), text=True,
                          capture_output=True, env=ENV, timeout=120)
    assert done.returncode == 0, done.stderr
    outputs = [json.loads(line) for line in done.stdout.splitlines()]
    assert len(outputs) == 5000 and [o["index"] for o in outputs] == list(range(5000))
    assert all(o["learned"] for o in outputs) and outputs[7]["time"] == run.time[7]
    prediction = np.array([o["prediction"] for o in outputs])
    gamma = np.array([o["gamma"] for o in outputs])
    single = AdaptiveGaitModel(gait=GAIT)  # the same samples, one partial_fit each, in process
    expected_prediction, expected_gamma = [], []
    for s in range(run.n_samples):
        single.partial_fit(*(a[s] for a in fit_args(run)))
        expected_prediction.append(single.prior_prediction_[0])
        expected_gamma.append(single.gamma_)
    np.testing.assert_array_equal(prediction, expected_prediction)
    np.testing.assert_array_equal(gamma, expected_gamma)
    batch = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run))  # one partial_fit of all 5 000 samples
    np.testing.assert_allclose(prediction, batch.prior_prediction_, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gamma, batch.online_gamma_, rtol=0, atol=1e-12)
    assert_same_model(load_model(out), batch)  # RLS state as the batch path's (bit for bit without numba)
    assert "5000 of 5000 samples learned" in done.stderr and gamma[-1] > 0.6  # measured 0.741 (noise 0.1)


def _start(arguments, tmp_path):
    return subprocess.Popen([*COMMAND, "stream", *arguments], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, bufsize=1, env=ENV, cwd=tmp_path)


def _close_pipes(process):
    """Close a killed process's pipes here (one left to the collector warns in a later test)."""
    for pipe in (process.stdin, process.stdout, process.stderr):
        with contextlib.suppress(BrokenPipeError):
            pipe.close()


def _feed(process, text):
    try:
        process.stdin.write(text)
        process.stdin.flush()
    except BrokenPipeError:  # the process was killed while we were writing
        pass


def test_sigkill_mid_stream_leaves_the_last_checkpoint_valid(run, config, tmp_path):
    out = tmp_path / "model.npz"
    process = _start([str(config), "--out", str(out), "--save-every", "500"], tmp_path)
    feeder = threading.Thread(target=_feed, args=(process, lines(run, 0, 4000)), daemon=True)
    feeder.start()
    for _ in range(2600):
        assert process.stdout.readline()
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    feeder.join(timeout=30)
    _close_pipes(process)
    assert process.returncode == -signal.SIGKILL
    saved = load_model(out)  # valid and loadable: the saves are atomic
    assert saved.n_samples_seen_ % 500 == 0 and 2500 <= saved.n_samples_seen_ <= 4000
    assert_same_model(saved, AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run, saved.n_samples_seen_)))


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_sigint_and_sigterm_save_everything_learned(run, tmp_path, signum):
    path = tmp_path / "model.npz"
    AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run, 1000)).save(path)  # keeps learning in place
    process = _start([str(path)], tmp_path)
    process.stdin.write(lines(run, 1000, 1300))
    process.stdin.flush()
    for _ in range(300):  # all learned; the stream now waits for input
        assert process.stdout.readline()
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode == 128 + signum, stderr
    assert f"stopped ({signal.Signals(signum).name})" in stderr and "300 of 300 samples learned" in stderr
    assert_same_model(load_model(path), AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run, 1300)))


# -- bad input: the line and field named, exit 1, what was learned saved ---------------------------
GOOD = {"time": 1.0, "phase": 0.5, "shape": [1.0, 0.0], "shape_velocity": [0.0, 6.0], "body_velocity": [0, 0, 0]}


@pytest.mark.parametrize("bad, message", [
    ("not json", r"error: input line 21 must be a JSON object; got 'invalid JSON"),
    ('[1, 2]', r"error: input line 21 must be a JSON object"),
    ('{"time": 1.0, "phase": 0.5, "shape": [1, 0], "body_velocity": [0, 0, 0], "phase": 0.6}',
     r"error: input line 21 must be a JSON object giving each key once; got \"key 'phase' more"),
    ({"extra": 1}, r"unknown key\(s\) \['extra'\]"),
    ({"shape": [1.0, 2.0, 3.0]}, r"error: input line 21's 'shape' must be a list of 2 numbers"),
    ({"shape": [1.0, "x"]}, r"error: input line 21's 'shape' must be a list of 2 numbers"),
    ('{"time": 1.0, "phase": 0.5, "shape": [NaN, 0], "body_velocity": [0, 0, 0]}', r"2 finite numbers"),
    ({"body_velocity": None}, r"error: input line 21's 'body_velocity' must be given"),
    ({"phase": None}, r"error: input line 21's 'phase' must be given \(or stream with a fitted Phaser\)"),
    ({"time": 0.0}, r"error: input line 21's 'time' must be greater than the previous sample's time"),
    ({"phase": "0.1"}, r"error: input line 21's 'phase' must be a finite number"),
])
def test_bad_lines_name_line_and_field_and_save_what_was_learned(run, config, tmp_path, bad, message):
    if isinstance(bad, dict):
        entry = {**GOOD, "time": float(run.time[20]), **bad}
        bad = json.dumps({k: v for k, v in entry.items() if v is not None})
    out = tmp_path / "m.npz"
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(out)],
                                input=lines(run, 0, 20) + bad + "\n" + lines(run, 21, 30))
    assert result.exit_code == 1
    assert re.search(message, result.stderr), result.stderr
    assert "20 of 20 samples learned" in result.stderr
    assert load_model(out).n_samples_seen_ == 20


def test_bad_models_and_configs(tmp_path, config):
    runner = CliRunner()
    (tmp_path / "bad.json").write_text(json.dumps({"gait": GAIT.coefficients.tolist(), "params": {"forgetting_factor":
                                                                                                   1.5}}))
    result = runner.invoke(app, ["stream", str(tmp_path / "bad.json")], input="")
    assert result.exit_code == 1 and "'forgetting_factor' parameter of AdaptiveGaitModel" in result.stderr
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['lambda'\]"):
        AdaptiveGaitModel.from_config({"gait": [[0, 1, 0]], "lambda": 0.9})
    with pytest.raises(ValueError, match="'gait' parameter of the model config.*Fourier coefficients"):
        AdaptiveGaitModel.from_config({"params": {}})
    with pytest.raises(ValueError, match="'n_windowz' parameter of AdaptiveGaitModel"):
        AdaptiveGaitModel.from_config({"gait": [[0, 1, 0]], "params": {"n_windowz": 3}})
    result = runner.invoke(app, ["stream", str(tmp_path / "missing.npz")], input="")
    assert result.exit_code == 1 and "does not exist" in result.stderr
    result = runner.invoke(app, ["stream", str(config), "--format", "xml"], input="")
    assert result.exit_code != 0 and "--format must be one of jsonl, csv" in result.output
    result = runner.invoke(app, ["stream", str(config)], input="")  # empty input: nothing to save
    assert result.exit_code == 0 and "no model written" in result.stderr and not (tmp_path / "config.npz").exists()
    assert isinstance(load_stream_model(config), AdaptiveGaitModel)


# -- CSV, derivatives, online phase, gaps -----------------------------------------------------------
def test_csv_stream_differentiates_and_notes_ignored_columns(run, config, tmp_path):
    frame = run.to_pandas().iloc[:400].drop(columns=["shape_velocity_0", "shape_velocity_1"])
    result = CliRunner().invoke(app, ["stream", str(config), "--format", "csv", "--out", str(tmp_path / "m.npz")],
                                input=frame.to_csv(index=False))
    assert result.exit_code == 0, result.output
    ignored = "['cycle', 'commanded_shape_0', 'commanded_shape_1', 'x', 'y', 'heading']"
    assert f"ignoring input columns {ignored}" in result.stderr
    rows = result.stdout.splitlines()
    assert rows[0] == ("index,time,phase,predicted_body_velocity_x,predicted_body_velocity_y,"
                       "predicted_body_velocity_theta,gamma,learned")
    assert len(rows) == 401 and rows[1].endswith(",0") and all(row.endswith(",1") for row in rows[2:])
    assert rows[1].split(",")[3] == "" and "399 of 400 samples learned" in result.stderr
    bad = frame.to_csv(index=False).replace("\n", "\nnot,enough\n", 1)
    result = CliRunner().invoke(app, ["stream", str(config), "--format", "csv", "--out", str(tmp_path / "n.npz")],
                                input=bad)
    assert result.exit_code == 1 and "error: input line 2 must be" in result.stderr
    result = CliRunner().invoke(app, ["stream", str(config), "--format", "csv", "--out", str(tmp_path / "n.npz")],
                                input=frame.drop(columns="body_velocity_y").to_csv(index=False))
    assert result.exit_code == 1 and "without ['body_velocity_y']" in result.stderr


def test_online_differentiator_is_a_causal_savitzky_golay_filter():
    rng = np.random.default_rng(0)
    differentiator = OnlineDifferentiator(window=7, polyorder=2)
    times = np.cumsum(rng.uniform(0.5, 1.5, 12))  # irregular stamps: exact for quadratics
    for t in times:
        differentiator.push(t, [3 * t**2 - t, 5.0])
    np.testing.assert_allclose(differentiator.derivative(), [6 * times[-1] - 1, 0.0], rtol=1e-9, atol=1e-9)
    values = rng.normal(size=(20, 2))
    differentiator.reset()
    assert differentiator.derivative() is None
    for n, value in enumerate(values):
        differentiator.push(0.1 * n, value)
    expected = savgol_coeffs(7, 2, deriv=1, delta=0.1, pos=6, use="dot") @ values[-7:]
    np.testing.assert_allclose(differentiator.derivative(), expected, rtol=1e-10, atol=1e-12)
    smoothed = savgol_coeffs(7, 2, deriv=0, pos=6, use="dot") @ values[-7:]
    np.testing.assert_allclose(differentiator.value(), smoothed, rtol=1e-10, atol=1e-12)
    differentiator.reset()
    assert differentiator.value() is None
    differentiator.push(0.0, values[0])
    np.testing.assert_array_equal(differentiator.value(), values[0])  # one sample: itself
    with pytest.raises(ValueError, match="'window' parameter of OnlineDifferentiator"):
        OnlineDifferentiator(window=1)


def test_a_differentiated_stream_learns_body_velocity_smoothed_by_the_same_fit(run):
    """ṙ differentiated causally carries the fit's low-pass; ξ learned beside it carries the same (the fit's value,
    as read_log does with its centred filter): the streamed model equals a batch fit on ṙ and ξ filtered by SciPy's
    one-sided Savitzky–Golay coefficients (window 5, order 2; fewer samples at the start), and a stream given ṙ
    learns ξ as given."""
    n = 600
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT))
    outputs = [learner.step(sample) for sample in JsonLinesReader(io.StringIO(lines(run, 0, n, rate=False)), 2)]
    assert not outputs[0].learned and all(output.learned for output in outputs[1:])
    rate, body = np.empty((n, 2)), np.empty((n, 3))
    for k in range(1, n):
        first = max(0, k - 4)
        size, step = k - first + 1, run.time[1] - run.time[0]
        order = min(2, size - 1)
        rate[k] = savgol_coeffs(size, order, deriv=1, delta=step, pos=size - 1, use="dot") @ run.shape[first:k + 1] \
            if size > 2 else (run.shape[k] - run.shape[k - 1]) / step
        body[k] = savgol_coeffs(size, order, pos=size - 1, use="dot") @ run.body_velocity[first:k + 1] \
            if size > 2 else run.body_velocity[k]
    expected = AdaptiveGaitModel(gait=GAIT).fit(run.phase[1:n], run.shape[1:n], rate[1:], body[1:])
    for a, b in ((learner.model.window_weights_, expected.window_weights_),
                 (learner.model.covariance_, expected.covariance_)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * np.abs(b).max())
    given = StreamLearner(AdaptiveGaitModel(gait=GAIT))
    for sample in JsonLinesReader(io.StringIO(lines(run, 0, 50)), 2):
        given.step(sample)
    reference = AdaptiveGaitModel(gait=GAIT).fit(run.phase[:50], run.shape[:50], run.shape_velocity[:50],
                                                 run.body_velocity[:50])
    np.testing.assert_allclose(given.model.window_weights_, reference.window_weights_, rtol=0,
                               atol=1e-12 * np.abs(reference.window_weights_).max())


@pytest.fixture(scope="module")
def phaser(run):
    return Phaser().fit(run.shape[:3000])


def test_online_phaser_defaults_warm_up_and_errors(run, phaser):
    online = OnlinePhaser(phaser)
    assert online.window == 200 and online.min_samples == 100
    estimates = [online.update(shape) for shape in run.shape[3000:]]
    assert estimates[:99] == [None] * 99 and None not in estimates[99:] and online.n_buffered == 200
    phases = np.array(estimates[100:], dtype=float)
    difference = np.exp(1j * (phases - run.phase[3100:]))
    error = np.abs(np.angle(difference * np.conj(difference.mean())))
    assert np.median(error) < 0.07  # measured 0.045 rad (data not fitted on)
    assert abs(online.rate - 2 * np.pi / 100) < 0.002  # the stream's own rate, rad per sample
    assert online.reset().n_buffered == 0 and online.update(run.shape[0]) is None
    with pytest.raises(ValueError, match="'shape' parameter of OnlinePhaser.update"):
        online.update([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="'min_samples' parameter of OnlinePhaser"):
        OnlinePhaser(phaser, window=10, min_samples=11)
    with pytest.raises(ValueError, match="'window' parameter of OnlinePhaser must be an int >= 4"):
        OnlinePhaser(phaser, window=3)
    with pytest.raises(ValueError, match="'phaser' parameter of OnlinePhaser must be a fitted Phaser"):
        OnlinePhaser(AdaptiveGaitModel(gait=GAIT))
    with pytest.raises(ValueError, match="Phaser is not fitted yet"):
        OnlinePhaser(Phaser())


def test_stream_with_a_phaser_and_a_gap(run, phaser, tmp_path):
    phaser.save(tmp_path / "phaser.npz")
    learner = StreamLearner(AdaptiveGaitModel(gait=GAIT), phaser=Phaser.load(tmp_path / "phaser.npz"),
                            path=tmp_path / "m.npz")
    text = lines(run, 3000, 4000, phase=False) + lines(run, 4300, 4600, phase=False)  # a gap of 3 cycles
    sink = io.StringIO()
    summary = run_stream(learner, io.StringIO(text), sink)
    outputs = [json.loads(line) for line in sink.getvalue().splitlines()]
    learned = np.array([o["learned"] for o in outputs])
    # Warm-up of one cycle (99 samples without a phase) at the start and again after the gap.
    assert not learned[:99].any() and learned[99:1000].all() and not learned[1000:1099].any() and learned[1099:].all()
    assert summary.reason == "eof" and summary.n_learned == 1300 - 2 * 99 and summary.saved == tmp_path / "m.npz"
    assert summary.gamma > 0.7 and load_model(tmp_path / "m.npz").n_samples_seen_ == summary.n_learned


def test_phaser_files_round_trip_without_pickle(run, phaser, tmp_path):
    path = phaser.save(tmp_path / "phaser.npz")
    with np.load(path, allow_pickle=False) as archive:
        assert "state/channel_coefficients_.imag" in archive.files
        assert all(archive[name].dtype != object for name in archive.files)
    loaded = Phaser.load(path)
    np.testing.assert_array_equal(loaded.transform(run.shape[3000:]), phaser.transform(run.shape[3000:]))
    assert loaded.samples_per_cycle_ == phaser.samples_per_cycle_
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[:200])
    with pytest.raises(ValueError, match="not a readable geogait phaser"):
        Phaser.load(truncated)
    model_path = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run, 300)).save(tmp_path / "model.npz")
    with pytest.raises(ValueError, match="not a geogait phaser file"):
        Phaser.load(model_path)
    with pytest.raises(ValueError, match="does not exist"):
        Phaser.load(tmp_path / "none.npz")
    with pytest.raises(ValueError, match="Phaser is not fitted yet"):
        Phaser().save(tmp_path / "unfitted.npz")


# -- the robot example -------------------------------------------------------------------------------
def test_robot_example_runs_quick(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("robot_stream", ROOT / "examples" / "robot_stream.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    summary = example.main(["--quick", "--save-every", "200", "--out", str(tmp_path)])
    assert summary["samples"] == 500 and summary["saves"] == 3 and summary["online_gamma"] > 0.5
    assert load_model(tmp_path / "model.npz").n_samples_seen_ == 500
    assert "cycle   5  online Γ" in capsys.readouterr().out


def test_docstring_examples_run():
    import doctest

    from geogait.learn import _fit, _learner
    from geogait.phase import _online, _phaser

    for module in (_learner, _fit, _online, _phaser):
        outcome = doctest.testmod(module)
        assert outcome.attempted > 0 and outcome.failed == 0, module.__name__


# -- the fast paths of the reader and the writer ---------------------------------------------------
_finite = st.floats(allow_nan=False, allow_infinity=False)
_number = st.one_of(_finite, st.integers(-10, 10), st.sampled_from([float("nan"), float("inf"), True, "1.0", None]))


@settings(max_examples=200, deadline=None)
@given(shape=st.lists(_number, min_size=1, max_size=3), rate=st.one_of(st.none(), st.lists(_number, min_size=2,
       max_size=2)), velocity=st.lists(_number, min_size=3, max_size=3), time=_number, phase=_number)
def test_the_plain_record_path_parses_like_the_checks(shape, rate, velocity, time, phase):
    """A record the fast path takes gives the sample the field-by-field checks give; others still fail alike."""
    from geogait.io._records import StreamSample, _scalar, _vector

    text = json.dumps({"time": time, "phase": phase, "shape": shape, "shape_velocity": rate,
                       "body_velocity": velocity})
    reader = JsonLinesReader([], 2)
    try:
        expected = StreamSample(line=3, shape=_vector(shape, "shape", 3, 2, True),
                                body_velocity=_vector(velocity, "body_velocity", 3, 3, True),
                                time=_scalar(time, "time", 3), phase=_scalar(phase, "phase", 3),
                                shape_velocity=_vector(rate, "shape_velocity", 3, 2, False))
    except GeogaitError as error:
        with pytest.raises(GeogaitError, match=re.escape(str(error))):
            reader.parse(text, 3)
        return
    sample = reader.parse(text, 3)
    for name in ("shape", "body_velocity", "shape_velocity"):
        a, b = getattr(sample, name), getattr(expected, name)
        assert (a is None and b is None) or (a.dtype == b.dtype and np.array_equal(a, b))
    assert (sample.line, sample.time, sample.phase) == (expected.line, expected.time, expected.phase)
    assert all(type(v) in (float, type(None)) for v in (sample.time, sample.phase))


@settings(max_examples=200, deadline=None)
@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=6, max_size=6),
       index=st.integers(0, 10**9), learned=st.booleans(), no_time=st.booleans())
def test_the_direct_output_line_is_the_json_line(values, index, learned, no_time):
    from geogait._files import dumps_json
    from geogait.io._records import StreamOutput, _JsonLinesWriter

    time, phase, gamma, *prediction = values
    output = StreamOutput(index, None if no_time else time, phase, np.array(prediction), gamma, learned)
    sink = io.StringIO()
    _JsonLinesWriter(sink).write(output)
    assert sink.getvalue() == dumps_json(output.to_dict()) + "\n"


@pytest.mark.parametrize(("change", "field"), [
    (dict(shape=np.array([np.nan, 0.1])), "shape"),
    (dict(time=np.nan), "time"),
    (dict(time=np.inf), "time"),
    (dict(shape=np.array([0.1, 0.2, 0.3])), "shape"),
    (dict(body_velocity=np.array([0.1, 0.0])), "body_velocity"),
    (dict(shape_velocity=np.array([np.inf, 0.0])), "shape_velocity"),
    (dict(phase=None), "phase"),
], ids=["nan shape", "nan time", "inf time", "long shape", "short body velocity", "inf rate", "no phase"])
def test_a_bad_sample_is_named_and_leaves_the_learner_as_it_was(run, change, field):
    """From Python a sample is not checked by a reader first: each of these once moved the clock or the
    differentiator on (so the next good sample failed too) or failed inside numpy; now the error names the line
    and the field, and the stream goes on as if the sample had never come."""
    from geogait.io import StreamSample

    def sample(i, **fields):
        given = dict(line=i + 1, shape=run.shape[i], body_velocity=run.body_velocity[i], time=float(run.time[i]),
                     phase=float(run.phase[i]))
        return StreamSample(**{**given, **fields})

    learner, twin = (StreamLearner(AdaptiveGaitModel(gait=GAIT)) for _ in range(2))
    for i in range(30):
        learner.step(sample(i))
        twin.step(sample(i))
    with pytest.raises(GeogaitError, match=rf"'{field}' parameter of input line 31 must be"):
        learner.step(sample(30, **change))
    for i in range(30, 40):
        ours, theirs = learner.step(sample(i)), twin.step(sample(i))
        assert (ours.index, ours.phase, ours.gamma, ours.learned) == (theirs.index, theirs.phase, theirs.gamma,
                                                                      theirs.learned) and ours.learned
        np.testing.assert_array_equal(ours.prediction, theirs.prediction)
    assert (learner.n_samples, learner.n_learned, learner.n_rejected) == (twin.n_samples, twin.n_learned, 0)


def test_json_numbers_beyond_a_float_and_deep_nesting_are_input_errors():
    """Both were reported as a bug in geogait (OverflowError, RecursionError); they are bad input lines."""
    reader = JsonLinesReader([], 2)
    huge = "1" + "0" * 400
    for text, match in ((f'{{"time": {huge}, "phase": 0.1, "shape": [0.1, 0.2], "body_velocity": [0, 0, 0]}}',
                         r"'time' parameter of input line 3 must be a finite number"),
                        (f'{{"phase": 0.1, "shape": [{huge}, 0.2], "body_velocity": [0, 0, 0]}}',
                         r"'shape' parameter of input line 3 must be a list of 2 finite numbers"),
                        ('{"shape": ' + "[" * 100_000 + "]" * 100_000 + "}", r"JSON nested too deeply")):
        with pytest.raises(GeogaitError, match=match):
            reader.parse(text, 3)


@pytest.mark.parametrize("window", ["5", None, 2.0, 1])
def test_stream_learner_names_a_bad_derivative_window_as_its_own(window):
    with pytest.raises(GeogaitError, match="'derivative_window' parameter of StreamLearner must be an int >= 2"):
        StreamLearner(AdaptiveGaitModel(gait=GAIT), derivative_window=window)
