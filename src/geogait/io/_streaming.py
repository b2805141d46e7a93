r"""Live streams: learn an :class:`~geogait.models.AdaptiveGaitModel` sample by sample.

The loop behind ``geogait stream`` and ``examples/robot_stream.py``. For every sample, in order:

1. **Phase**: the sample's own ``phase``, or — with a fitted :class:`~geogait.phase.Phaser` — the
   causal estimate of :class:`~geogait.phase.OnlinePhaser` (last sample of a sliding window of
   the last two cycles by default; latency/accuracy trade-off in :mod:`geogait.phase._online`).
2. **Shape velocity**: the sample's own ``shape_velocity``, or the derivative of a polynomial
   fitted by least squares to the newest ``derivative_window`` shapes against their time stamps,
   evaluated at the newest sample (:class:`OnlineDifferentiator`: a one-sided, causal
   Savitzky–Golay filter that accepts irregular stamps). Measured relative RMS error of ṙ on the
   3-link swimmer (100 samples per cycle): window 5, order 2 (default): 0.006 on a smooth gait,
   0.044 with 0.1° encoder noise, 0.19 with the simulator's perturbations (whose ṙ is rough:
   white noise drives δ̈); the centred filter of :func:`~geogait.io.read_log` reaches
   0.000 / 0.010 / 0.14 on the same data but needs future samples. A model fitted on a log
   (centred ṙ) and then streamed (causal ṙ) sees slightly noisier ṙ than it was trained on.
3. **Predict, then learn**: ``model.partial_fit`` on the one sample. Its a-priori prediction
   ``model.prior_prediction_`` (the mean of the covering windows' filter predictions *before*
   the sample is learned) and the updated online Γ (eq. 6, ``model.gamma_``) are the output.
   Because the filters see each sample once, in order, the model after a stream equals the
   model from one batch ``partial_fit`` of the same samples (RLS weights and covariances are
   bit-identical; a-priori predictions agree to rounding, ~1e-15).
4. **Checkpoint** every ``save_every`` learned samples, and at the end, with
   :meth:`~geogait.models.AdaptiveGaitModel.save` (temporary file + rename: a crash during a
   save leaves the previous file intact).

Warm-up: a sample without a usable phase (the Phaser window holds fewer than ``min_samples``
samples) or shape velocity (the first sample of a differentiated stream) is neither predicted
nor learned; its output says ``learned: false``. The same happens after a gap: a time step
longer than ``gap_factor`` times the median of the recent steps restarts the differentiator and
the phase window (no differentiation and no Hilbert window across a gap).

Input records (:func:`run_stream`): JSON lines with the keys ``time``, ``phase``, ``shape``,
``shape_velocity``, ``body_velocity`` (lists for the vectors; unknown keys are errors), or CSV
with a header naming ``time``, ``phase``, ``shape_0``…, ``shape_velocity_0``…,
``body_velocity_x``, ``body_velocity_y``, ``body_velocity_theta`` (the columns of
:meth:`~geogait.simulate.Trajectory.to_pandas`; other columns are ignored and listed in
:attr:`CsvReader.ignored`). ``shape`` and ``body_velocity`` are required; ``time`` is required when
``shape_velocity`` is absent; ``phase`` is required without a Phaser and ignored with one.
Angles in radians. Blank lines are skipped. The first bad record stops the stream with an
error naming its line and field; everything learned before it is saved.

Stopping: SIGINT (Ctrl-C) and SIGTERM stop the loop at once while it waits for input; while a
sample is being learned or the model saved, they take effect after that (the model is never
saved half-updated), and a signal during the final save is ignored: the save completes. A
signal that arrives while an output line is being written may cut that line. SIGKILL cannot be
caught: the last checkpoint (``save_every``) survives intact, a temporary ``.<name>.<pid>.*.tmp``
file may be left beside it (the next save of that model removes it).
"""

from __future__ import annotations

import csv
import json
import math
import signal
import statistics
import threading
import warnings
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from .._files import check_writable, dumps_json
from .._validation import (
    MAX_MAGNITUDE,
    GeogaitError,
    GeogaitWarning,
    check_array,
    check_choice,
    check_float,
    check_int,
    fail,
)
from ..gaits import FourierGait
from ..models import AdaptiveGaitModel, load_model
from ..models._base import MAX_PHASE
from ..phase import OnlinePhaser, Phaser
from ..simulate import BODY_VELOCITY_COLUMNS
from ._logs import DEFAULT_OUTLIER_LIMIT, TIME_UNITS

__all__ = ["CONFIG_FORMAT", "CsvReader", "JsonLinesReader", "OnlineDifferentiator", "StreamLearner",
           "StreamOutput", "StreamSample", "StreamSummary", "load_stream_model", "model_config",
           "model_from_config", "run_stream"]

CONFIG_FORMAT = "geogait-model-config"
CONFIG_VERSION = 1
PREDICTION_COLUMNS = ("predicted_body_velocity_x", "predicted_body_velocity_y", "predicted_body_velocity_theta")
_KEYS = ("time", "phase", "shape", "shape_velocity", "body_velocity")
#: Accepted samples whose medians and spreads define the stream's plausibility bound.
PLAUSIBILITY_WINDOW = 1000
#: Accepted samples before the relative bound applies (before: only ±1e12).
PLAUSIBILITY_MIN_SAMPLES = 50
#: Accepted samples between refreshes of the medians and spreads (each costs ~1 ms).
PLAUSIBILITY_REFRESH = 250


# -- records ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StreamSample:
    """One input record.

    Attributes
    ----------
    line : int
        Line of the input it came from (1-based), for error messages.
    shape : ndarray of shape (d,)
    body_velocity : ndarray of shape (3,)
    time, phase : float or None
    shape_velocity : ndarray of shape (d,) or None
    """

    line: int
    shape: np.ndarray
    body_velocity: np.ndarray
    time: float | None = None
    phase: float | None = None
    shape_velocity: np.ndarray | None = None


@dataclass(frozen=True)
class StreamOutput:
    """The result of one sample: its a-priori prediction and the online Γ after learning it.

    Attributes
    ----------
    index : int
        Sample index, from 0.
    time, phase : float or None
        The sample's time stamp and the phase used (None while warming up).
    prediction : ndarray of shape (3,) or None
        A-priori ξ̂ (before the sample was learned); None when the sample was not learned.
    gamma : float or None
        Online Γ after the sample (None before anything was learned).
    learned : bool
    rejected : str or None
        Why the sample was quarantined (implausible values, see :class:`StreamLearner`); None otherwise.
    """

    index: int
    time: float | None
    phase: float | None
    prediction: np.ndarray | None
    gamma: float | None
    learned: bool
    rejected: str | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict (floats are written exactly by :func:`json.dumps`; ``rejected`` only when set)."""
        record = {"index": self.index, "time": self.time, "phase": self.phase,
                  "prediction": None if self.prediction is None else self.prediction.tolist(),
                  "gamma": self.gamma, "learned": self.learned}
        if self.rejected is not None:
            record["rejected"] = self.rejected
        return record


@dataclass(frozen=True)
class StreamSummary:
    """How a stream ended.

    Attributes
    ----------
    n_samples : int
        Records read and processed.
    n_learned : int
        Samples learned (not warming up).
    gamma : float or None
        Online Γ at the end.
    reason : {"eof", "error", "SIGINT", "SIGTERM", "output closed"}
    error : str or None
        The error message when ``reason == "error"``.
    saved : Path or None
        Where the model was last written during the stream or at its end (None if nothing was
        learned, or if the model could not be saved: see ``error``).
    n_rejected : int
        Samples quarantined as implausible (neither predicted nor learned).
    first_rejection : str or None
        Line and reason of the first of them.
    """

    n_samples: int
    n_learned: int
    gamma: float | None
    reason: str
    error: str | None
    saved: Path | None
    n_rejected: int = 0
    first_rejection: str | None = None


# -- model configs ------------------------------------------------------------------------------
def model_config(model: AdaptiveGaitModel) -> dict:
    """A JSON-ready config that starts a fresh model with ``model``'s hyper-parameters and nominal gait.

    Parameters
    ----------
    model : AdaptiveGaitModel
        Fitted, or unfitted with ``gait`` given.

    Returns
    -------
    dict with keys ``format``, ``format_version``, ``params`` and ``gait`` (coefficients ``(d, 2K+1)``).
    """
    gait = getattr(model, "gait_", None)
    gait = model.gait if gait is None else gait
    if gait is None:
        raise fail("gait", "model_config", "known (a fitted model, or one built with a gait)", None)
    params = {k: v for k, v in model.get_params(deep=False).items() if k != "gait"}
    return {"format": CONFIG_FORMAT, "format_version": CONFIG_VERSION, "params": params,
            "gait": gait.coefficients.tolist()}


def model_from_config(config: dict, source: str = "config") -> AdaptiveGaitModel:
    """A fresh :class:`AdaptiveGaitModel` from a config of :func:`model_config`.

    Only ``gait`` is required; ``params`` holds any ``AdaptiveGaitModel`` hyper-parameters, and
    ``format`` / ``format_version`` are checked when present. Unknown keys are errors. The
    hyper-parameters are validated here, not at the first sample.
    """
    owner = f"the model config {source}"
    if not isinstance(config, dict):
        raise fail("config", owner, "a JSON object", type(config).__name__)
    unknown = sorted(set(config) - {"format", "format_version", "params", "gait"})
    if unknown:
        raise fail("config", owner, "an object with keys among format, format_version, params, gait",
                   f"unknown key(s) {unknown}")
    if config.get("format", CONFIG_FORMAT) != CONFIG_FORMAT or config.get("format_version", 1) != 1:
        raise fail("format", owner, f"{CONFIG_FORMAT!r} version {CONFIG_VERSION}",
                   f"{config.get('format')!r} version {config.get('format_version')}")
    if "gait" not in config:
        raise fail("gait", owner, "given: the nominal gait's Fourier coefficients, a list of d lists "
                   "[a_0, a_1..a_K, b_1..b_K]", None)
    gait = FourierGait(check_array(config["gait"], "gait", owner, ndim=2))
    params = config.get("params", {})
    if not isinstance(params, dict):
        raise fail("params", owner, "an object of AdaptiveGaitModel hyper-parameters", params)
    return AdaptiveGaitModel(gait=gait).set_params(**params).validate()


def load_stream_model(path) -> AdaptiveGaitModel:
    """A saved model (``.npz``) or a fresh one from a JSON config (``.json``).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    AdaptiveGaitModel
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        if not path.is_file():
            raise fail("path", "load_stream_model", "an existing file", str(path))
        try:
            config = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as error:
            raise fail("path", "load_stream_model", "a valid JSON file", f"{path}: {error}") from None
        return model_from_config(config, source=str(path))
    if path.suffix.lower() != ".npz":
        raise fail("path", "load_stream_model", "a saved model (.npz) or a model config (.json)", str(path))
    model = load_model(path)
    if not isinstance(model, AdaptiveGaitModel):
        raise GeogaitError(f"{path} holds a {type(model).__name__}; streaming needs an AdaptiveGaitModel.")
    return model


# -- online differentiation ---------------------------------------------------------------------
class OnlineDifferentiator:
    """Causal derivative at the newest sample: a one-sided Savitzky–Golay filter on time stamps.

    A polynomial of order ``min(polyorder, k - 1)`` is fitted by least squares to the newest
    ``k ≤ window`` samples against their times, and its slope at the newest time is returned.

    Parameters
    ----------
    window : int >= 2
    polyorder : int >= 1

    Examples
    --------
    >>> differentiator = OnlineDifferentiator(window=5, polyorder=2)
    >>> for t in np.arange(6) * 0.1:
    ...     differentiator.push(t, [t ** 2, 3 * t])
    >>> differentiator.derivative().round(12)
    array([1., 3.])
    """

    def __init__(self, window: int = 5, polyorder: int = 2):
        self.window = check_int(window, "window", "OnlineDifferentiator", minimum=2)
        self.polyorder = check_int(polyorder, "polyorder", "OnlineDifferentiator", minimum=1)
        self._cache: tuple[np.ndarray, np.ndarray] | None = None
        self.reset()

    def reset(self) -> OnlineDifferentiator:
        """Forget the buffered samples; returns ``self``."""
        self._times: deque[float] = deque(maxlen=self.window)
        self._values: deque[np.ndarray] = deque(maxlen=self.window)
        return self

    def push(self, time: float, value) -> None:
        """Buffer one sample (``time`` must exceed the previous one; callers check)."""
        self._times.append(float(time))
        self._values.append(np.asarray(value, dtype=float))

    def derivative(self) -> np.ndarray | None:
        """Slope at the newest sample, or None with fewer than 2 samples buffered."""
        if len(self._times) < 2:
            return None
        offsets = np.asarray(self._times) - self._times[-1]
        scale = -offsets[0]
        return self._weights(offsets / scale) @ np.asarray(self._values) / scale

    def _weights(self, offsets: np.ndarray) -> np.ndarray:
        """Row of the least-squares pseudo-inverse giving the slope; reused while the steps repeat."""
        if self._cache is not None:
            cached_offsets, cached_weights = self._cache
            if cached_offsets.shape == offsets.shape and np.allclose(cached_offsets, offsets, rtol=0, atol=1e-9):
                return cached_weights
        order = min(self.polyorder, offsets.size - 1)
        weights = np.linalg.pinv(np.vander(offsets, order + 1, increasing=True))[1]
        self._cache = (offsets, weights)
        return weights


# -- the learner --------------------------------------------------------------------------------
class StreamLearner:
    """Predict, learn and checkpoint one sample at a time (the loop of the module notes).

    Parameters
    ----------
    model : AdaptiveGaitModel
        Fitted (e.g. by ``geogait fit``), or fresh with its nominal ``gait`` given; updated in place.
    phaser : Phaser, optional
        Estimate the phase with an :class:`~geogait.phase.OnlinePhaser`; samples' own phases are
        then ignored.
    phase_window : int, optional
        Window of the OnlinePhaser in samples (default two cycles).
    derivative_window : int >= 2
        Samples of the :class:`OnlineDifferentiator` (polynomial order ``min(2, window - 1)``).
    gap_factor : float > 1
        A time step longer than this many times the median recent step restarts the warm-up.
    path : path-like, optional
        Where :meth:`save` writes the model; nothing is saved without it.
    save_every : int >= 1, optional
        Also save after every ``save_every`` learned samples.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the samples' ``time`` and of their rates (``shape_velocity``, ``body_velocity``),
        converted to seconds before use; None keeps the stream's own unit.
    outlier_limit : float > 0, optional
        Quarantine a sample with a value (shape, shape velocity, body velocity) further than this
        many robust standard deviations (1.4826 × MAD) from the median of the last
        ``PLAUSIBILITY_WINDOW`` accepted samples (active once ``PLAUSIBILITY_MIN_SAMPLES`` were
        accepted); None switches it off. Values beyond ±1e12 are always quarantined. A quarantined
        sample is neither predicted nor learned and does not reach the phase estimator or the
        differentiator; its output says why (``rejected``).

    Notes
    -----
    ``path`` is checked for writability here, before the first sample. The model is never saved
    once it holds NaN or infinity (the previous file is kept and the stream stops with an error);
    a checkpoint's path is kept in :attr:`last_saved`.

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> learner = StreamLearner(AdaptiveGaitModel(gait=seed_gait(2)))
    >>> sample = StreamSample(line=1, shape=np.array([1.0, 0.0]), body_velocity=np.zeros(3), phase=0.0,
    ...                       shape_velocity=np.array([0.0, 6.28]))
    >>> out = learner.step(sample)
    >>> out.learned, out.prediction.tolist(), learner.n_learned
    (True, [0.0, 0.0, 0.0], 1)
    """

    def __init__(self, model: AdaptiveGaitModel, *, phaser: Phaser | None = None, phase_window: int | None = None,
                 derivative_window: int = 5, gap_factor: float = 3.0, path=None, save_every: int | None = None,
                 time_unit: str | None = None, outlier_limit: float | None = DEFAULT_OUTLIER_LIMIT):
        owner = "StreamLearner"
        if not isinstance(model, AdaptiveGaitModel):
            raise fail("model", owner, "an AdaptiveGaitModel", type(model).__name__)
        self.time_scale = 1.0 if time_unit is None else TIME_UNITS[check_choice(time_unit, "time_unit", owner,
                                                                                  tuple(TIME_UNITS))]
        self.time_unit = time_unit
        self.outlier_limit = None if outlier_limit is None else check_float(outlier_limit, "outlier_limit", owner,
                                                                            low=0, low_open=True)
        self.model = model
        self.n_joints = _n_joints(model)
        self.online_phaser = None if phaser is None else OnlinePhaser(phaser, window=phase_window)
        if phaser is not None and phaser.n_channels_ != self.n_joints:
            raise fail("phaser", owner, f"a Phaser of {self.n_joints} channels (the model's joints)",
                       f"{phaser.n_channels_} channels")
        self.differentiator = OnlineDifferentiator(derivative_window, min(2, derivative_window - 1))
        self.gap_factor = check_float(gap_factor, "gap_factor", owner, low=1, low_open=True)
        self.save_every = None if save_every is None else check_int(save_every, "save_every", owner, minimum=1)
        self.path = None if path is None else check_writable(path, "model file")
        self.n_samples = self.n_learned = self.n_rejected = 0
        self.first_rejection: str | None = None
        self.last_saved: Path | None = None
        self.broken: str | None = None
        self._history: deque[np.ndarray] = deque(maxlen=PLAUSIBILITY_WINDOW)
        width = 2 * self.n_joints + 3
        self._values = np.empty(width)
        self._centre = np.zeros(width)
        self._spread: np.ndarray | None = None
        self._bound = np.full(width, MAX_MAGNITUDE)
        self._advance = self._duration = 0.0
        self._previous: tuple[float, float] | None = None
        self._rate_checked = False
        self._gamma = float(model.gamma_) if hasattr(model, "batch_shape_") else None
        self._unsaved = 0
        self._last_time: float | None = None
        self._steps: deque[float] = deque(maxlen=15)

    @property
    def gamma(self) -> float | None:
        """Online Γ now (None before anything was learned)."""
        return self._gamma

    def step(self, sample: StreamSample) -> StreamOutput:
        """Process one sample: plausibility, phase, ṙ, a-priori prediction, learning, checkpoint."""
        if self.broken is not None:
            raise GeogaitError(self.broken)
        sample = self._in_seconds(sample)
        self._clock(sample)
        d = self.n_joints
        values = self._values  # [shape, ṙ, ξ]; NaN where not given
        values[:d], values[2 * d:] = sample.shape, sample.body_velocity
        values[d:2 * d] = np.nan if sample.shape_velocity is None else sample.shape_velocity
        problem = self._implausible(values)
        own_phase = self.online_phaser is None and sample.phase is not None
        if problem is None and own_phase and abs(sample.phase) > MAX_PHASE:
            problem = f"phase = {sample.phase:g} is beyond ±{MAX_PHASE:g} rad (wrap it to [0, 2π))"
        if problem is None:
            phase = self._phase(sample)
            rate = self._rate(sample)
            if rate is not None and sample.shape_velocity is None:
                values[d:2 * d] = rate
                problem = self._implausible(values)
        index = self.n_samples
        self.n_samples += 1
        if problem is not None:
            self.n_rejected += 1
            self.first_rejection = self.first_rejection or f"input line {sample.line}: {problem}"
            return StreamOutput(index, sample.time, None, None, self.gamma, False, rejected=problem)
        if phase is None or rate is None:
            return StreamOutput(index, sample.time, phase, None, self.gamma, False)
        self._check_phase_rate(sample.time, phase)
        self.model.partial_fit(phase, sample.shape, rate, sample.body_velocity)
        self._gamma = float(self.model.online_gamma_[-1])  # = model.gamma_, without recomputing it
        prediction = self.model.prior_prediction_[0]
        if not (math.isfinite(self._gamma) and np.all(np.isfinite(prediction))):
            self.broken = (f"The model went non-finite at input line {sample.line} (online Γ {self._gamma}); it is "
                           "not saved (the last checkpoint, if any, is kept).")
            raise GeogaitError(self.broken)
        self._remember(values)
        self.n_learned += 1
        self._unsaved += 1
        output = StreamOutput(index, sample.time, phase, prediction, self._gamma, True)
        if self.save_every is not None and self.n_learned % self.save_every == 0:
            self.save()
        return output

    def save(self) -> Path | None:
        """Write the model to ``path`` if anything was learned since the last save; returns the path.

        Nothing is written once the model went non-finite (:attr:`broken`).
        """
        if self.path is None or self._unsaved == 0 or self.broken is not None:
            return None
        self.model.save(self.path)
        self._unsaved = 0
        self.last_saved = self.path
        return self.path

    # -- plausibility and units ---------------------------------------------------------------
    def _in_seconds(self, sample: StreamSample) -> StreamSample:
        if self.time_scale == 1.0:
            return sample
        scale = self.time_scale
        return StreamSample(line=sample.line, shape=sample.shape, body_velocity=sample.body_velocity / scale,
                            time=None if sample.time is None else sample.time * scale, phase=sample.phase,
                            shape_velocity=None if sample.shape_velocity is None else sample.shape_velocity / scale)

    def _channel_names(self) -> list[str]:
        d = self.n_joints
        return ([f"shape[{j}]" for j in range(d)] + [f"shape_velocity[{j}]" for j in range(d)]
                + [f"body_velocity[{k}]" for k in range(3)])

    def _implausible(self, values: np.ndarray) -> str | None:
        """Why ``values`` ([shape, ṙ, ξ], NaN = not given) are implausible, or None.

        One vectorised test per sample against ``_bound`` (±MAX_MAGNITUDE about 0 until the
        statistics exist); comparisons with NaN are False, so channels not given pass.
        """
        if not (np.abs(values - self._centre) > self._bound).any():
            return None
        big = np.abs(values) > MAX_MAGNITUDE
        if big.any():
            c = int(np.flatnonzero(big)[0])
            return f"{self._channel_names()[c]} = {values[c]:g} is beyond ±{MAX_MAGNITUDE:g}"
        c = int(np.flatnonzero(np.abs(values - self._centre) > self._bound)[0])
        return (f"{self._channel_names()[c]} = {values[c]:g} is implausible: more than outlier_limit = "
                f"{self.outlier_limit:g} robust standard deviations ({self._spread[c]:.3g}) from the median "
                f"{self._centre[c]:.4g} of the last {len(self._history)} accepted samples")

    def _remember(self, values: np.ndarray) -> None:
        """Add an accepted sample; refresh the medians and spreads every ``PLAUSIBILITY_REFRESH`` samples."""
        self._history.append(values.copy())
        n = len(self._history)
        if self.outlier_limit is None or n < PLAUSIBILITY_MIN_SAMPLES or (
                self._spread is not None and self.n_learned % PLAUSIBILITY_REFRESH):
            return
        history = np.asarray(self._history)
        self._centre = np.median(history, axis=0)
        self._spread = 1.4826 * np.median(np.abs(history - self._centre), axis=0)
        # a channel without spread cannot be judged; nothing beyond ±MAX_MAGNITUDE passes either way
        relative = np.where(self._spread > 0, self.outlier_limit * self._spread, np.inf)
        self._bound = np.minimum(relative, MAX_MAGNITUDE - np.abs(self._centre))

    def _check_phase_rate(self, time: float | None, phase: float) -> None:
        """Warn once when the stream's phase rate disagrees 10-fold with the model's ``phase_rate``."""
        if self._rate_checked or time is None:
            return
        if self._previous is not None:
            step = (phase - self._previous[1] + np.pi) % (2 * np.pi) - np.pi
            self._advance += step
            self._duration += time - self._previous[0]
        self._previous = (time, phase)
        if self._advance < 4 * np.pi or self._duration <= 0:
            return
        self._rate_checked = True
        rate, expected = self._advance / self._duration, float(self.model.phase_rate)
        if not 0.1 <= rate / expected <= 10:
            warnings.warn(f"The stream's phase advances at {rate:.4g} rad per time unit, {rate / expected:.3g} times "
                          f"the model's phase_rate {expected:.4g}: are the time stamps in another unit than the "
                          "model's (time_unit, --time-unit s|ms|us|ns)? Shape velocities differentiated from them "
                          "are then wrong by the same factor.", GeogaitWarning, stacklevel=3)

    def _clock(self, sample: StreamSample) -> None:
        """Check the time stamp increases; after a gap, restart the differentiator and phase window."""
        if sample.time is None:
            return
        if self._last_time is not None:
            step = sample.time - self._last_time
            if step <= 0:
                raise fail("time", f"input line {sample.line}", f"greater than the previous sample's time "
                           f"{self._last_time!r} (strictly increasing)", sample.time)
            if self._is_gap(step):
                self._restart()
            else:
                self._steps.append(step)
        self._last_time = sample.time

    def _is_gap(self, step: float) -> bool:
        """Longer than ``gap_factor`` × the median recent step (the minimum rules most steps out cheaply)."""
        if len(self._steps) < 2 or step <= self.gap_factor * min(self._steps):
            return False
        return step > self.gap_factor * statistics.median(self._steps)

    def _restart(self) -> None:
        self.differentiator.reset()
        self._steps.clear()
        if self.online_phaser is not None:
            self.online_phaser.reset()

    def _phase(self, sample: StreamSample) -> float | None:
        if self.online_phaser is not None:
            return self.online_phaser.update(sample.shape)
        if sample.phase is None:
            raise fail("phase", f"input line {sample.line}", "given (or stream with a fitted Phaser)", None)
        return float(np.mod(sample.phase, 2 * np.pi))

    def _rate(self, sample: StreamSample) -> np.ndarray | None:
        if sample.time is not None:
            self.differentiator.push(sample.time, sample.shape)
        if sample.shape_velocity is not None:
            return sample.shape_velocity
        if sample.time is None:
            raise fail("time", f"input line {sample.line}", "given when 'shape_velocity' is not (ṙ is then "
                       "differentiated from the time stamps)", None)
        return self.differentiator.derivative()


def _n_joints(model: AdaptiveGaitModel) -> int:
    if hasattr(model, "batch_shape_"):
        if model.batch_shape_ != ():
            raise fail("model", "StreamLearner", "a single model (no trial axes)",
                       f"batch shape {model.batch_shape_}")
        return model.n_joints_
    if not isinstance(model.gait, FourierGait):
        raise fail("gait", "StreamLearner", "given for a fresh model (a single sample cannot estimate the "
                   "nominal gait)", model.gait)
    return model.gait.n_joints


# -- readers and writers ------------------------------------------------------------------------
def _vector(value, name: str, line: int, size: int, required: bool) -> np.ndarray | None:
    if value is None:
        if required:
            raise fail(name, f"input line {line}", f"given: a list of {size} numbers", None)
        return None
    if not isinstance(value, list) or len(value) != size or not all(type(v) in (int, float) for v in value):
        raise fail(name, f"input line {line}", f"a list of {size} numbers", value)
    if not all(math.isfinite(v) for v in value):
        raise fail(name, f"input line {line}", f"a list of {size} finite numbers", value)
    return np.array(value, dtype=float)


def _scalar(value, name: str, line: int) -> float | None:
    if value is None:
        return None
    if type(value) not in (int, float) or not math.isfinite(value):
        raise fail(name, f"input line {line}", "a finite number", value)
    return float(value)


class JsonLinesReader:
    """Samples from JSON lines (one object per line; see the module notes).

    Parameters
    ----------
    source : iterable of str
        Lines, e.g. ``sys.stdin``.
    n_joints : int
    """

    def __init__(self, source, n_joints: int):
        self.source = source
        self.n_joints = n_joints

    def __iter__(self) -> Iterator[StreamSample]:
        for line, text in enumerate(self.source, start=1):
            if text.strip():
                yield self.parse(text, line)

    def parse(self, text: str, line: int) -> StreamSample:
        """One record; errors name ``line`` and the field."""
        try:
            record = json.loads(text)
        except json.JSONDecodeError as error:
            raise fail("record", f"input line {line}", "a JSON object",
                       f"invalid JSON ({error.msg} at column {error.colno})") from None
        if not isinstance(record, dict):
            raise fail("record", f"input line {line}", "a JSON object", record)
        unknown = sorted(set(record) - set(_KEYS))
        if unknown:
            raise fail("record", f"input line {line}", f"an object with keys among {list(_KEYS)}",
                       f"unknown key(s) {unknown}")
        d = self.n_joints
        return StreamSample(line=line, shape=_vector(record.get("shape"), "shape", line, d, True),
                            body_velocity=_vector(record.get("body_velocity"), "body_velocity", line, 3, True),
                            time=_scalar(record.get("time"), "time", line),
                            phase=_scalar(record.get("phase"), "phase", line),
                            shape_velocity=_vector(record.get("shape_velocity"), "shape_velocity", line, d, False))


class CsvReader:
    """Samples from CSV rows under a header line (see the module notes).

    Attributes
    ----------
    ignored : list of str
        Header columns that are not read (known after the header).
    """

    def __init__(self, source, n_joints: int):
        self.source = source
        self.n_joints = n_joints
        self.ignored: list[str] = []

    def __iter__(self) -> Iterator[StreamSample]:
        reader = csv.reader(self.source)
        header = next(reader, None)
        if header is None:
            return
        columns = self._columns([name.strip() for name in header])
        for row in reader:
            if row and any(cell.strip() for cell in row):
                yield self._sample(row, reader.line_num, columns, len(header))

    def _columns(self, header: list[str]) -> dict[str, list[int] | None]:
        d = self.n_joints
        groups = {"time": ["time"], "phase": ["phase"], "shape": [f"shape_{j}" for j in range(d)],
                  "shape_velocity": [f"shape_velocity_{j}" for j in range(d)],
                  "body_velocity": list(BODY_VELOCITY_COLUMNS)}
        index = {name: i for i, name in enumerate(header)}
        found: dict[str, list[int] | None] = {}
        for key, names in groups.items():
            present = [name for name in names if name in index]
            required = key in ("shape", "body_velocity")
            if (required and len(present) < len(names)) or 0 < len(present) < len(names):
                raise fail("header", "input line 1", f"a CSV header with the columns {names}",
                           f"a header without {[n for n in names if n not in index]}")
            found[key] = [index[name] for name in names] if present else None
        used = {i for columns in found.values() if columns for i in columns}
        self.ignored = [name for i, name in enumerate(header) if i not in used]
        return found

    def _sample(self, row: list[str], line: int, columns: dict, width: int) -> StreamSample:
        if len(row) != width:
            raise fail("row", f"input line {line}", f"{width} comma-separated values like the header",
                       f"{len(row)} values")
        values = {key: None if idx is None else self._cells(row, idx, key, line) for key, idx in columns.items()}
        for key in ("shape", "body_velocity"):
            if values[key] is None:
                raise fail(key, f"input line {line}", "given (no empty cells)", None)
        return StreamSample(line=line, shape=values["shape"], body_velocity=values["body_velocity"],
                            time=None if values["time"] is None else float(values["time"][0]),
                            phase=None if values["phase"] is None else float(values["phase"][0]),
                            shape_velocity=values["shape_velocity"])

    @staticmethod
    def _cells(row: list[str], idx: list[int], key: str, line: int) -> np.ndarray | None:
        cells = [row[i].strip() for i in idx]
        if not any(cells):
            return None
        try:
            array = np.array([float(cell) for cell in cells])
        except ValueError:
            raise fail(key, f"input line {line}", f"{len(cells)} number(s)", cells) from None
        if not all(cells) or not np.all(np.isfinite(array)):
            raise fail(key, f"input line {line}", f"{len(cells)} finite number(s), none empty", cells)
        return array


class _JsonLinesWriter:
    def __init__(self, sink: TextIO):
        self.sink = sink

    def write(self, output: StreamOutput) -> None:
        self.sink.write(dumps_json(output.to_dict()) + "\n")
        self.sink.flush()


class _CsvWriter:
    def __init__(self, sink: TextIO):
        self.sink = sink
        self.sink.write(",".join(["index", "time", "phase", *PREDICTION_COLUMNS, "gamma", "learned"]) + "\n")
        self.sink.flush()

    def write(self, output: StreamOutput) -> None:
        prediction = [None] * 3 if output.prediction is None else output.prediction.tolist()
        cells = [output.index, output.time, output.phase, *prediction, output.gamma, int(output.learned)]
        self.sink.write(",".join("" if c is None else repr(c) for c in cells) + "\n")
        self.sink.flush()


_FORMATS = {"jsonl": (JsonLinesReader, _JsonLinesWriter), "csv": (CsvReader, _CsvWriter)}


# -- the loop -----------------------------------------------------------------------------------
class _Stopped(Exception):
    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _StopOnSignal:
    """SIGINT/SIGTERM stop the loop between samples: raised at once while waiting for input,
    deferred to the end of the sample while learning or saving (so the model stays consistent)."""

    def __init__(self):
        self.busy = False
        self.pending: int | None = None
        self._previous: dict[int, object] = {}

    def __call__(self, signum, frame):
        if self.busy:
            self.pending = signum
        else:
            raise _Stopped(signum)

    def check(self) -> None:
        if self.pending is not None:
            raise _Stopped(self.pending)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self)
        return self

    def __exit__(self, *exc):
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        return False


def run_stream(learner: StreamLearner, source, sink: TextIO, *, fmt: str = "jsonl", reader=None) -> StreamSummary:
    """Read samples from ``source``, write one flushed output line per sample to ``sink``, learn.

    Ends at the end of the input, at the first bad record (``reason="error"``), on SIGINT or
    SIGTERM (in the main thread), or when ``sink`` is closed; in every case the learner saves
    what it learned (:meth:`StreamLearner.save`) before returning.

    Parameters
    ----------
    learner : StreamLearner
    source : iterable of str
        Input lines (e.g. ``sys.stdin``).
    sink : text stream
        Output: JSON lines, or CSV with a header, after ``fmt``.
    fmt : {"jsonl", "csv"}
    reader : iterable of StreamSample, optional
        Samples to use instead of parsing ``source`` (e.g. a :class:`CsvReader` the caller keeps
        to inspect :attr:`CsvReader.ignored`); by default a reader of ``fmt`` on ``source``.

    Returns
    -------
    StreamSummary
    """
    if fmt not in _FORMATS:
        raise fail("fmt", "run_stream", "'jsonl' or 'csv'", fmt)
    reader_type, writer_type = _FORMATS[fmt]
    reader = reader_type(source, learner.n_joints) if reader is None else reader
    reason, error = "eof", None
    with _StopOnSignal() as stop:
        try:
            writer = writer_type(sink)
            for sample in reader:
                stop.busy = True
                output = learner.step(sample)
                stop.busy = False
                writer.write(output)
                stop.check()
        except _Stopped as stopped:
            reason = str(stopped)
        except GeogaitError as bad:
            reason, error = "error", str(bad)
        except (UnicodeDecodeError, csv.Error) as bad:  # undecodable bytes, a broken CSV quote
            reason, error = "error", f"unreadable input after {learner.n_samples} sample(s): {bad}"
        except BrokenPipeError:
            reason = "output closed"
        finally:
            stop.busy = True
            try:
                learner.save()
            except (GeogaitError, OSError) as failure:
                message = f"could not save the model: {failure}"
                reason, error = "error", message if error is None else f"{error}; {message}"
    return StreamSummary(learner.n_samples, learner.n_learned, learner.gamma, reason, error, learner.last_saved,
                         learner.n_rejected, learner.first_rejection)
