r"""Causal, per-sample phase from a fitted :class:`~geogait.phase.Phaser`, for live streams.

:meth:`Phaser.transform` is not causal: the analytic signal of a record uses all of it. Its old
causal form took the last sample of a Phaser run on a sliding window; the edge of an FFT
Hilbert transform is accurate only when the window holds a whole number of periods, so on the
3-link swimmer its median error rose from 0.1 rad (window = 2 periods) to 1.2 rad (2.3 periods)
and to 0.4 rad under a drifting rate. :class:`OnlinePhaser` now needs no analytic signal:

1. **Measure** each sample's phase on the limit cycle learnt at training. The fitted Phaser
   holds the phase-averaged z-scored channels :math:`W(\psi)` (a Fourier series of order
   ``order`` in its own phase :math:`\psi`, :attr:`Phaser.waveform_`) and the residual spread
   :math:`\sigma_c` of each channel about it. The measured phase is the nearest point of that
   curve, channels weighted by their spread:

   .. math::
       \hat\psi_n = \arg\min_\psi \sum_c \frac{\bigl(z_{n,c} - W_c(\psi)\bigr)^2}{\sigma_c^2},

   found on a grid of ``max(256, 32 K)`` phases and refined by a parabola through the best
   grid point and its neighbours. It uses one sample, so it does not depend on the period or
   the rate and has no delay; it inherits the Phaser's phase (its zero and its uniform
   advance), and all the noise of that sample (perturbations move a shape off the limit cycle).
2. **Track** the measured phases with a straight line in time fitted by exponentially
   discounted least squares (the fading-memory polynomial filter of degree 1, Morrison 1969;
   an α–β tracker with gains :math:`g = 1 - \lambda^2`, :math:`h = (1 - \lambda)^2`), on the
   circle: with the prediction :math:`p_n = \phi_{n-1} + \omega_{n-1}` and the innovation
   :math:`e_n = \mathrm{wrap}(\hat\psi_n - p_n)`,

   .. math::
       \phi_n = p_n + g\, e_n, \qquad \omega_n = \omega_{n-1} + h\, e_n .

   The discount is :math:`\lambda = 1 - 4 / \mathrm{window}`: the line rests on about the last
   ``window / 4`` samples (time constant), half a cycle with the default window of two training
   cycles. From a start or a :meth:`OnlinePhaser.reset` the gains are those of the growing-memory
   filter (an exact least-squares line through all samples so far, :math:`g_n =
   2(2n+1)/((n+1)(n+2))`, :math:`h_n = 6/((n+1)(n+2))`) until they fall to the fading ones, so
   the rate is learnt from the stream itself, not assumed from training. The rate
   :math:`\omega` (rad per sample) is kept within :math:`[-\pi/2, \pi/2]` (at least 4 samples
   per cycle).

Delay. The estimate is the line's value at the newest sample: no look-ahead and no group delay
at a constant rate (a line fit is unbiased for a line). While the rate changes, the line lags
behind by :math:`\lambda^2 \dot\omega / (1 - \lambda)^2 \approx \dot\omega\, \tau^2` rad
(:math:`\dot\omega` in rad per sample², :math:`\tau` = ``window / 4`` samples).

Accuracy. The line averages out perturbations that the whole-record analytic signal of
:meth:`Phaser.transform` keeps, so the online estimate is about as accurate as the offline one
(``python studies/online_phase.py`` compares them at several windows and under a rate ramp).

Limits. The phase is that of the training limit cycle: a stream whose waveform differs (another
gait, a saturating actuator) gets a biased phase, as it does offline, where the corrections are
frozen too. Where the limit cycle passes close to itself (a figure-eight in the channels) the
nearest point can jump between the two branches; the tracker then smooths the jump over about
``window / 4`` samples but does not prevent it. The window trades noise for lag and its
default suits noisy shapes: on clean shapes whose rate changes fast, a shorter window lags less.
The rate is per sample: the stream must be
uniformly sampled (a gap is a :meth:`OnlinePhaser.reset`, see
:class:`~geogait.io.StreamLearner`).

Until ``min_samples`` samples have arrived (after the start or a :meth:`OnlinePhaser.reset`),
:meth:`OnlinePhaser.update` returns None: the line is not yet settled.
"""

from __future__ import annotations

import math

import numpy as np

from .._estimator import check_is_fitted
from .._validation import check_array, check_int, check_magnitude, fail
from ._phaser import Phaser, limit_cycle_grid, nearest_on_curve

__all__ = ["OnlinePhaser"]

_OWNER = "OnlinePhaser"
_MAX_RATE = math.pi / 2  # rad per sample: at least 4 samples per cycle


class OnlinePhaser:
    r"""Phase of each new sample: nearest point of the Phaser's limit cycle, tracked by a line.

    See the module notes for the method, its delay and its accuracy.

    Parameters
    ----------
    phaser : Phaser
        Fitted on training data of the same channels.
    window : int >= 4, optional
        Memory of the tracker in samples: the line's time constant is ``window / 4`` samples.
        Default two training cycles, ``round(2 * phaser.samples_per_cycle_)``.
    min_samples : int, optional
        Samples needed before the first phase is returned; default one training cycle (half the
        default window), at least 4 and at most ``window``.

    Attributes
    ----------
    phase : float or None
        The newest estimate in ``[0, 2π)`` (None before the first sample).
    rate : float or None
        Phase advance per sample of the tracked line, rad (None before the first sample; the
        training rate at the first).

    Examples
    --------
    A stream at 137.5 samples per cycle, fitted at 100:

    >>> import numpy as np
    >>> t = 2 * np.pi * np.arange(2000) / 100
    >>> online = OnlinePhaser(Phaser().fit(np.stack([np.cos(t), np.sin(t)], axis=1)))
    >>> online.window, online.min_samples
    (200, 100)
    >>> truth = 2 * np.pi * np.arange(600) / 137.5
    >>> phases = [online.update(x) for x in np.stack([np.cos(truth), np.sin(truth)], axis=1)]
    >>> phases[:99].count(None), round(online.rate * 137.5 / (2 * np.pi), 6)
    (99, 1.0)
    >>> error = np.angle(np.exp(1j * (np.array(phases[99:]) - truth[99:] + 3 * np.pi / 2)))
    >>> bool(np.abs(error).max() < 1e-3)
    True
    """

    def __init__(self, phaser: Phaser, *, window: int | None = None, min_samples: int | None = None):
        if not isinstance(phaser, Phaser):
            raise fail("phaser", _OWNER, "a fitted Phaser", type(phaser).__name__)
        check_is_fitted(phaser)
        per_cycle = float(getattr(phaser, "samples_per_cycle_", 0.0))
        if window is None and per_cycle <= 0:
            raise fail("window", _OWNER, "given (the Phaser does not know its samples per cycle)", window)
        self.phaser = phaser
        self.window = check_int(round(2 * per_cycle) if window is None else window, "window", _OWNER, minimum=4)
        default = max(4, min(self.window, round(per_cycle) if per_cycle > 0 else self.window // 2))
        self.min_samples = check_int(default if min_samples is None else min_samples, "min_samples", _OWNER,
                                     minimum=4)
        if self.min_samples > self.window:
            raise fail("min_samples", _OWNER, f"an int <= window = {self.window}", self.min_samples)
        discount = 1.0 - 4.0 / self.window
        self._fading = (1.0 - discount**2, (1.0 - discount) ** 2)
        # first rate guess (replaced by the line through the first two samples)
        self._initial_rate = min(2 * math.pi / per_cycle, _MAX_RATE) if per_cycle > 0 else 0.0
        self._cycle = limit_cycle_grid(phaser.waveform_, phaser.residual_std_, phaser.order)
        self.reset()

    def reset(self) -> OnlinePhaser:
        """Forget the tracked line (e.g. after a gap in the stream); returns ``self``."""
        self._count = 0
        self.phase: float | None = None
        self.rate: float | None = None
        return self

    @property
    def n_buffered(self) -> int:
        """Samples the estimate rests on: those since the start or the last reset, at most ``window``."""
        return min(self._count, self.window)

    def update(self, shape) -> float | None:
        """Add one sample ``(n_channels,)``; return its phase in ``[0, 2π)``, or None while warming up.

        Parameters
        ----------
        shape : array-like of shape (n_channels,)
            The newest sample of the channels the phaser was fitted on (e.g. joint angles, radians).

        Returns
        -------
        float or None
            The tracked phase of this sample in ``[0, 2π)``; None for the first ``min_samples - 1``
            samples after the start or a :meth:`reset`.
        """
        sample = check_magnitude(check_array(shape, "shape", f"{_OWNER}.update", ndim=1), "shape", f"{_OWNER}.update")
        if sample.shape != (self.phaser.n_channels_,):
            raise fail("shape", f"{_OWNER}.update", f"an array of shape ({self.phaser.n_channels_},)",
                       f"shape {sample.shape}")
        self._track(float(self._nearest(sample[None, :])[0]))
        return self.phase if self._count >= self.min_samples else None

    def nearest_phase(self, x) -> np.ndarray:
        """The measured phase of step 1 (no tracking): nearest point of the limit cycle, per sample.

        Parameters
        ----------
        x : array-like of shape (n, n_channels)
            Samples of the channels the phaser was fitted on.

        Returns
        -------
        ndarray of shape (n,)
            Phases in ``[0, 2π)``.
        """
        owner = f"{_OWNER}.nearest_phase"
        x = check_magnitude(check_array(x, "x", owner, trailing=(self.phaser.n_channels_,), ndim=2), "x", owner)
        return self._nearest(x)

    def _nearest(self, x: np.ndarray) -> np.ndarray:
        return nearest_on_curve((x - self.phaser.mean_) / self.phaser.scale_, *self._cycle)

    def _track(self, measured: float) -> None:
        n = self._count
        self._count += 1
        if n == 0:
            self.phase, self.rate = measured, self._initial_rate
            return
        growing = 6.0 / ((n + 1) * (n + 2))
        gain = max(growing * (2 * n + 1) / 3, self._fading[0])
        rate_gain = max(growing, self._fading[1])
        predicted = self.phase + self.rate
        innovation = (measured - predicted + math.pi) % (2 * math.pi) - math.pi
        self.phase = (predicted + gain * innovation) % (2 * math.pi)
        self.rate = min(max(self.rate + rate_gain * innovation, -_MAX_RATE), _MAX_RATE)
