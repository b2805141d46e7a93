"""The stream learner (:mod:`geogait.learn._streaming`): phase, shape velocity and plausibility of each
sample, then predict-and-learn with an :class:`~geogait.models.AdaptiveGaitModel`; and the model a
stream starts from."""

from __future__ import annotations

import json
import math
import statistics
import warnings
from collections import deque
from pathlib import Path

import numpy as np

from .. import _kernels
from .._defaults import DEFAULT_OUTLIER_LIMIT, TIME_UNITS
from .._files import check_writable, describe_path_kind, read_utf8
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
from ..io import StreamOutput, StreamSample
from ..models import MAX_PHASE, AdaptiveGaitModel, load_model
from ..phase import OnlinePhaser, Phaser

__all__ = ["OnlineDifferentiator", "StreamLearner", "load_stream_model"]

_TWO_PI = 2 * np.pi
#: Accepted samples whose medians and spreads define the stream's plausibility bound.
PLAUSIBILITY_WINDOW = 1000
#: Accepted samples before the relative bound applies (until then only the absolute bound ±1e12).
PLAUSIBILITY_MIN_SAMPLES = 50
#: Accepted samples between refreshes of the medians and spreads (each costs ~1 ms).
PLAUSIBILITY_REFRESH = 250


# -- the model a stream starts from ------------------------------------------------------------
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
            raise fail("path", "load_stream_model", "an existing file",
                       f"{path} ({describe_path_kind(path) or 'does not exist'})")
        try:
            config = json.loads(read_utf8(path, "load_stream_model"))
        except json.JSONDecodeError as error:
            raise fail("path", "load_stream_model", "a valid JSON file", f"{path}: {error}") from None
        return AdaptiveGaitModel.from_config(config, source=str(path))
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
    ``k ≤ window`` samples against their times; :meth:`derivative` is its slope at the newest time and
    :meth:`value` its value there (the same low-pass without the derivative).

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
        self._fitted: tuple[np.ndarray, np.ndarray] | None = None
        return self

    def push(self, time: float, value) -> None:
        """Buffer one sample (``time`` must exceed the previous one; callers check).

        Parameters
        ----------
        time : float
            Sample time, in the stream's time unit (seconds, or cycles).
        value : array-like of shape (k,)
            The signal at ``time`` (e.g. the joint angles, radians); :meth:`derivative` returns its slope.
        """
        self._times.append(float(time))
        self._values.append(np.asarray(value, dtype=float))
        self._fitted = None

    def derivative(self) -> np.ndarray | None:
        """Slope at the newest sample, or None with fewer than 2 samples buffered."""
        return None if len(self._times) < 2 else self._fit()[1]

    def value(self) -> np.ndarray | None:
        """The fitted polynomial at the newest sample (the newest sample itself while only one is buffered), or
        None with none buffered."""
        if len(self._times) < 2:
            return self._values[-1].copy() if self._values else None
        return self._fit()[0]

    def _fit(self) -> tuple[np.ndarray, np.ndarray]:
        """(value, slope) at the newest sample, computed once per pushed sample."""
        if self._fitted is None:
            offsets = np.asarray(self._times) - self._times[-1]
            scale = -offsets[0]
            value, slope = self._weights(offsets / scale)[:2] @ np.asarray(self._values)
            self._fitted = (value, slope / scale)
        return self._fitted

    def _weights(self, offsets: np.ndarray) -> np.ndarray:
        """Least-squares pseudo-inverse of the polynomial fit (row 0: value, row 1: slope at the newest sample);
        reused while the steps repeat."""
        if self._cache is not None:
            cached_offsets, cached_weights = self._cache
            if cached_offsets.shape == offsets.shape and np.allclose(cached_offsets, offsets, rtol=0, atol=1e-9):
                return cached_weights
        order = min(self.polyorder, offsets.size - 1)
        weights = np.linalg.pinv(np.vander(offsets, order + 1, increasing=True))
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
        Memory of the OnlinePhaser in samples (its phase line's time constant is a quarter of it;
        default two training cycles).
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
        _kernels.warm_up()  # load the compiled one-sample path now, not at the first sample (no-op without numba)
        self.online_phaser = None if phaser is None else OnlinePhaser(phaser, window=phase_window)
        if phaser is not None and phaser.n_channels_ != self.n_joints:
            raise fail("phaser", owner, f"a Phaser of {self.n_joints} channels (the model's joints)",
                       f"{phaser.n_channels_} channels")
        derivative_window = check_int(derivative_window, "derivative_window", owner, minimum=2)
        self.differentiator = OnlineDifferentiator(derivative_window, min(2, derivative_window - 1))
        self.gap_factor = check_float(gap_factor, "gap_factor", owner, low=1, low_open=True)
        self.save_every = None if save_every is None else check_int(save_every, "save_every", owner, minimum=1)
        self.path = None if path is None else check_writable(path, "model file")
        self.n_samples = self.n_learned = self.n_rejected = 0
        self.first_rejection: str | None = None
        self.last_saved: Path | None = None
        self.broken: str | None = None
        # the last PLAUSIBILITY_WINDOW accepted samples, one column each, written round the ring (a median does
        # not depend on the order of its values); the first _n_history columns are filled
        self._history = np.empty((2 * self.n_joints + 3, PLAUSIBILITY_WINDOW))
        self._n_history = 0
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
        if self.time_scale != 1.0:
            sample = self._in_seconds(sample)
        values = self._checked_values(sample)  # (before any state changes: a refused sample leaves no trace)
        self._clock(sample)
        d = self.n_joints
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
        self.model.partial_fit(phase, sample.shape, rate, self._body_velocity(sample))
        self._gamma = float(self.model.online_gamma_[-1])  # = model.gamma_, without recomputing it
        prediction = self.model.prior_prediction_[0]
        x, y, theta = prediction.tolist()
        if not (math.isfinite(self._gamma) and math.isfinite(x) and math.isfinite(y) and math.isfinite(theta)):
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
        if not np.count_nonzero(np.abs(values - self._centre) > self._bound):  # (count_nonzero: C, no Python wrapper)
            return None
        big = np.abs(values) > MAX_MAGNITUDE
        if big.any():
            c = int(np.flatnonzero(big)[0])
            return f"{self._channel_names()[c]} = {values[c]:g} is beyond ±{MAX_MAGNITUDE:g}"
        c = int(np.flatnonzero(np.abs(values - self._centre) > self._bound)[0])
        return (f"{self._channel_names()[c]} = {values[c]:g} is implausible: more than outlier_limit = "
                f"{self.outlier_limit:g} robust standard deviations ({self._spread[c]:.3g}) from the median "
                f"{self._centre[c]:.4g} of the last {self._n_history} accepted samples")

    def _remember(self, values: np.ndarray) -> None:
        """Add an accepted sample; refresh the medians and spreads every ``PLAUSIBILITY_REFRESH`` samples."""
        self._history[:, self.n_learned % PLAUSIBILITY_WINDOW] = values
        n = self._n_history = min(self._n_history + 1, PLAUSIBILITY_WINDOW)
        if self.outlier_limit is None or n < PLAUSIBILITY_MIN_SAMPLES or (
                self._spread is not None and self.n_learned % PLAUSIBILITY_REFRESH):
            return
        history = self._history[:, :n]
        self._centre = np.median(history, axis=1)
        self._spread = 1.4826 * np.median(np.abs(history - self._centre[:, None]), axis=1)
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

    def _checked_values(self, sample: StreamSample) -> np.ndarray:
        """[shape, ṙ, ξ] of ``sample`` (NaN where ṙ is not given), or an error naming its line and field: a
        field of the wrong length, a non-finite value, a time stamp or phase that is not finite, or no phase to
        learn against. (Cheap on the common path: one finiteness count over the whole row.)"""
        time, phase = sample.time, sample.phase
        if not ((time is None or type(time) is float and math.isfinite(time))
                and (phase is None or type(phase) is float and math.isfinite(phase))):
            self._refuse_scalars(sample)
        if phase is None and self.online_phaser is None:
            raise fail("phase", f"input line {sample.line}", "given (or stream with a fitted Phaser)", None)
        d, values, rate = self.n_joints, self._values, sample.shape_velocity
        try:
            values[:d], values[2 * d:] = sample.shape, sample.body_velocity
            values[d:2 * d] = np.nan if rate is None else rate
        except (TypeError, ValueError):
            self._refuse_field(sample)
        if np.count_nonzero(np.isfinite(values)) != (d + 3 if rate is None else 2 * d + 3):
            self._refuse_field(sample)
        return values

    def _refuse_scalars(self, sample: StreamSample) -> None:
        for name in ("time", "phase"):
            if getattr(sample, name) is not None:
                check_float(getattr(sample, name), name, f"input line {sample.line}")

    def _refuse_field(self, sample: StreamSample) -> None:
        """The error for the first of ``sample``'s arrays of the wrong length, not numbers, or not finite."""
        for name, size in (("shape", self.n_joints), ("shape_velocity", self.n_joints), ("body_velocity", 3)):
            if getattr(sample, name) is not None or name != "shape_velocity":
                check_array(getattr(sample, name), name, f"input line {sample.line}", trailing=(size,), ndim=1)

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
        return float(sample.phase) % _TWO_PI  # float % is np.mod (both take the sign of the divisor)

    def _rate(self, sample: StreamSample) -> np.ndarray | None:
        if sample.time is not None:  # (ξ beside the shape: the same fit smooths it, see _body_velocity)
            self.differentiator.push(sample.time, np.concatenate([sample.shape, sample.body_velocity]))
        if sample.shape_velocity is not None:
            return sample.shape_velocity
        if sample.time is None:
            raise fail("time", f"input line {sample.line}", "given when 'shape_velocity' is not (ṙ is then "
                       "differentiated from the time stamps)", None)
        derivative = self.differentiator.derivative()
        return None if derivative is None else derivative[:self.n_joints]

    def _body_velocity(self, sample: StreamSample) -> np.ndarray:
        """ξ as learned: beside a differentiated ṙ, smoothed by the same causal fit (its value, not its slope),
        so that ξ = −A ṙ holds between the filtered signals as in :func:`~geogait.io.read_log`; else as given."""
        if sample.shape_velocity is not None:
            return sample.body_velocity
        return self.differentiator.value()[self.n_joints:]


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


