r"""Exploration sized online: the perturbation δ std of each cycle from the model's prediction residual.

The adaptive model learns the connection around the current gait from the perturbations δ (paper
eq. 8); the same perturbations are noise to a controller that steers cycle by cycle. A fixed δ std
trades one against the other once and for all. :class:`AdaptiveExploration` sizes it per cycle:
large while the model is new and after it stops fitting (an unannounced change of the environment),
small while it predicts well.

The signal is the controller's own **prediction residual** of the cycle it just ran: with the net
motion per cycle predicted before the cycle :math:`\hat m_k = (\hat x, \hat y, \hat\theta)` (of the
commanded nominal gait) and the one measured :math:`m_k`, the surprise

.. math:: \varepsilon_k = \frac{1}{\sigma_k}\sqrt{\frac{(x_k - \hat x_k)^2 + (y_k - \hat y_k)^2}{\hat\ell_k^2}
          + (\theta_k - \hat\theta_k)^2},\qquad \hat\ell_k = \sqrt{\hat x_k^2 + \hat y_k^2},

is the prediction error in steps (a turn error of θ rad puts the next step θ steps off), per radian of
the δ std :math:`\sigma_k` the cycle ran with: the part of the residual the perturbations cause grows
in proportion to :math:`\sigma_k`, so dividing by it keeps a change of δ itself from looking like a
change of the environment. With :math:`\tilde\varepsilon_k` the median surprise of the previous
``window`` cycles (at least 3),

.. math:: h_k = \begin{cases} 1 & \varepsilon_k > a\,\tilde\varepsilon_k \\ \gamma\, h_{k-1} & \text{otherwise}
          \end{cases},\qquad \sigma_{k+1} = \sigma_{low} + (\sigma_{high} - \sigma_{low})\, h_k,

with the alarm factor :math:`a`, the decay :math:`\gamma` and :math:`h = 1` through the warm-up (the
model is new). The std stays in :math:`[\sigma_{low}, \sigma_{high}]`.

Why not Γ (eq. 6): Γ compares the model's a-priori error with the phase average's, and the phase
average misses exactly the part of ξ that δ causes, so Γ falls with δ at the same model (0.65–0.73 at
δ std 0.15, 0.44–0.48 at 0.05 in the tracking experiment): a rule "explore more when Γ is low" would
keep raising δ because it lowered it.

A robot takes a new δ std between cycles through its ``set_perturbation_std(std)`` method
(:meth:`geogait.simulate.SwimmerStream.set_perturbation_std` for the simulated swimmers).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from .._estimator import Estimator, Integer, Real
from .._validation import GeogaitError, check_array, check_float, check_int

__all__ = ["AdaptiveExploration", "prediction_surprise", "surprise_alarm"]


def prediction_surprise(predicted, measured, std: float) -> float:
    """Surprise ε of one cycle (module docstring): prediction error in steps per radian of δ std.

    Parameters
    ----------
    predicted, measured : array-like of shape (3,)
        Net motion per cycle ``(Δx, Δy, Δθ)`` predicted before the cycle and measured.
    std : float > 0
        δ std the cycle ran with (rad).
    """
    owner = "prediction_surprise"
    predicted = check_array(predicted, "predicted", owner, ndim=1, trailing=(3,))
    measured = check_array(measured, "measured", owner, ndim=1, trailing=(3,))
    std = check_float(std, "std", owner, low=0, low_open=True)
    step = max(float(np.hypot(*predicted[:2])), 1e-12)
    error = measured - predicted
    return float(np.sqrt((error[0] ** 2 + error[1] ** 2) / step**2 + error[2] ** 2) / std)


def surprise_alarm(surprise: float, past, alarm: float = 5.0, window: int = 10) -> bool:
    """Whether ``surprise`` exceeds ``alarm`` × the median of the last ``window`` of the ``past``
    surprises (never with fewer than 3): the change test of :class:`AdaptiveExploration`."""
    owner = "surprise_alarm"
    window = check_int(window, "window", owner, minimum=3)  # (list[-0:] would be the whole history)
    surprise = check_float(surprise, "surprise", owner, low=0)
    alarm = check_float(alarm, "alarm", owner, low=0, low_open=True)
    past = list(past)[-window:]
    return len(past) >= 3 and surprise > alarm * float(np.median(past))


class AdaptiveExploration(Estimator):
    """Rule for the δ std of each cycle (module docstring); the state is reset by :meth:`start`.

    Parameters
    ----------
    low : float > 0
        σ_low, δ std (rad) while the model predicts well.
    high : float >= low
        σ_high, δ std (rad) through the warm-up and after an alarm.
    alarm : float > 1
        a: a cycle whose surprise exceeds a × the median of the previous ``window`` cycles raises
        the alarm (h = 1). Set it above the spread of undisturbed cycles' surprise, so that only a
        change of the environment raises it.
    decay : float in [0, 1)
        γ: h is multiplied by it every cycle without an alarm (0.8: σ is within 11 % of the way
        from σ_low to σ_high after 10 cycles).
    window : int >= 3
        Past cycles whose median surprise is the reference.

    Attributes
    ----------
    level_ : float
        h after the last update.
    alarm_ : bool
        Whether the last update raised the alarm.
    surprises_ : list of float
        Surprise of every cycle since :meth:`start`.
    std_ : float
        δ std for the next cycle.
    """

    _parameter_constraints: ClassVar[dict] = {
        "low": Real(low=0, high=1, low_open=True),
        "high": Real(low=0, high=1),
        "alarm": Real(low=1, low_open=True),
        "decay": Real(low=0, high=1, high_open=True),
        "window": Integer(minimum=3),
    }
    _fitted_attribute: ClassVar[str] = "std_"

    def __init__(self, *, low: float = 0.05, high: float = 0.15, alarm: float = 5.0, decay: float = 0.8,
                 window: int = 10):
        self.low = low
        self.high = high
        self.alarm = alarm
        self.decay = decay
        self.window = window

    def _check_param_combinations(self) -> None:
        check_float(self.high, "high", "AdaptiveExploration", low=self.low, high=1)

    def start(self) -> float:
        """Forget the past; returns σ_high, the δ std of the warm-up and the first tracking cycle."""
        self.validate()
        self.level_, self.surprises_, self.alarm_ = 1.0, [], False
        self.std_ = float(self.high)
        return self.std_

    def update(self, predicted, measured) -> float:
        """Take the cycle just run (predicted and measured net motion ``(3,)``, run at ``std_``) and
        return the δ std for the next cycle."""
        if not hasattr(self, "std_"):
            raise GeogaitError("AdaptiveExploration.update needs a started rule: call start() first.")
        surprise = prediction_surprise(predicted, measured, self.std_)
        alarm = surprise_alarm(surprise, self.surprises_, self.alarm, self.window)
        self.alarm_ = alarm
        self.level_ = 1.0 if alarm else self.decay * self.level_
        self.surprises_.append(surprise)
        self.std_ = float(self.low + (self.high - self.low) * self.level_)
        return self.std_
