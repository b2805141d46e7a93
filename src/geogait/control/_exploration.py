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

A simulated robot takes a new δ std between cycles through :class:`ExplorationStream`; any robot with
a ``set_perturbation_std(std)`` method can be driven the same way.
"""

from __future__ import annotations

import numpy as np

from .._validation import GeogaitError, check_float, check_int, fail
from ..gaits import Perturbation
from ..simulate import SwimmerStream

__all__ = ["AdaptiveExploration", "ExplorationStream", "prediction_surprise"]


def prediction_surprise(predicted, measured, std: float) -> float:
    """Surprise ε of one cycle (module docstring): prediction error in steps per radian of δ std.

    Parameters
    ----------
    predicted, measured : array-like of shape (3,)
        Net motion per cycle ``(Δx, Δy, Δθ)`` predicted before the cycle and measured.
    std : float > 0
        δ std the cycle ran with (rad).
    """
    predicted, measured = np.asarray(predicted, dtype=float), np.asarray(measured, dtype=float)
    step = max(float(np.hypot(*predicted[:2])), 1e-12)
    error = measured - predicted
    return float(np.sqrt((error[0] ** 2 + error[1] ** 2) / step**2 + error[2] ** 2) / std)


class AdaptiveExploration:
    """Rule for the δ std of each cycle (module docstring); the state is reset by :meth:`start`.

    Parameters
    ----------
    low : float > 0
        σ_low, δ std (rad) while the model predicts well.
    high : float >= low
        σ_high, δ std (rad) through the warm-up and after an alarm.
    alarm : float > 1
        a: a cycle whose surprise exceeds a × the median of the previous ``window`` cycles raises
        the alarm (h = 1). In exploratory runs of the 5-link swimmer (line and circle, 3 trials each,
        60 cycles) the surprise of undisturbed cycles had a median near 1.6 and reached 5.4, and the
        first cycle after the drag change 2 → 4 scored 10–19; an alarm at 3× fired without a change in
        3 of the 6 runs.
    decay : float in [0, 1)
        γ: h is multiplied by it every cycle without an alarm (0.8: σ is within 11 % of the way
        from σ_low to σ_high after 10 cycles).
    window : int >= 3
        Past cycles whose median surprise is the reference.

    Attributes
    ----------
    level_ : float
        h after the last update.
    surprises_ : list of float
        Surprise of every cycle since :meth:`start`.
    std_ : float
        δ std for the next cycle.
    """

    def __init__(self, *, low: float = 0.05, high: float = 0.15, alarm: float = 5.0, decay: float = 0.8,
                 window: int = 10):
        self.low = low
        self.high = high
        self.alarm = alarm
        self.decay = decay
        self.window = window

    def validate(self) -> AdaptiveExploration:
        """Check every parameter (errors name it); returns ``self``."""
        owner = "AdaptiveExploration"
        low = check_float(self.low, "low", owner, low=0, high=1, low_open=True)
        check_float(self.high, "high", owner, low=low, high=1)
        check_float(self.alarm, "alarm", owner, low=1, low_open=True)
        check_float(self.decay, "decay", owner, low=0, high=1, high_open=True)
        check_int(self.window, "window", owner, minimum=3)
        return self

    def start(self) -> float:
        """Forget the past; returns σ_high, the δ std of the warm-up and the first tracking cycle."""
        self.validate()
        self.level_, self.surprises_ = 1.0, []
        self.std_ = float(self.high)
        return self.std_

    def update(self, predicted, measured) -> float:
        """Take the cycle just run (predicted and measured net motion ``(3,)``, run at ``std_``) and
        return the δ std for the next cycle."""
        if not hasattr(self, "std_"):
            raise GeogaitError("AdaptiveExploration.update needs a started rule: call start() first.")
        surprise = prediction_surprise(predicted, measured, self.std_)
        past = self.surprises_[-self.window:]
        alarm = len(past) >= 3 and surprise > self.alarm * float(np.median(past))
        self.level_ = 1.0 if alarm else self.decay * self.level_
        self.surprises_.append(surprise)
        self.std_ = float(self.low + (self.high - self.low) * self.level_)
        return self.std_


class ExplorationStream:
    """A :class:`~geogait.simulate.SwimmerStream` whose δ std can be changed between cycles.

    Takes the arguments of :class:`~geogait.simulate.SwimmerStream` (one trial) and implements
    :class:`geogait.robots.Robot` and its simulator extras. :meth:`set_perturbation_std` keeps the
    perturbation's spectrum (its α, β) and scales η; the SDE state (δ, δ̇), the random generators,
    the pose and the gait carry over (the stream is rebuilt through ``robot_state`` /
    ``restore_robot_state``), so δ stays continuous and relaxes to the new size with the time
    constant 2 / α (0.11 cycle for ``Perturbation.from_std``'s spectrum), and two streams with the
    same seed and the same schedule of sizes give the same samples.

    Parameters
    ----------
    system : System
    gait : FourierGait
    **options
        Keywords of :class:`~geogait.simulate.SwimmerStream` except ``n_trials``; ``perturbation``
        (default ``Perturbation()``, δ std 0.15) sets the spectrum and the starting size.
    """

    def __init__(self, system, gait, **options):
        if "n_trials" in options:
            raise fail("n_trials", "ExplorationStream", "absent (one trial per stream)", options["n_trials"])
        self._options = dict(options)
        self._stream = SwimmerStream(system, gait, **options)
        self._system = system

    @property
    def n_joints(self) -> int:
        """Shape dimension d."""
        return self._stream.n_joints

    @property
    def cycle_period(self) -> float:
        """Duration of a cycle."""
        return self._stream.cycle_period

    @property
    def gait(self):
        """Nominal gait of the next cycle."""
        return self._stream.gait

    @property
    def perturbation(self) -> Perturbation:
        """The perturbation in force."""
        return self._stream.perturbation

    @property
    def perturbation_std(self) -> float:
        """Stationary δ std (rad) in force."""
        return float(self._stream.perturbation.stationary_std[0])

    def set_gait(self, gait) -> None:
        """Command ``gait`` from the next cycle boundary on."""
        self._stream.set_gait(gait)

    def next_cycle(self):
        """Run one cycle (:meth:`geogait.simulate.SwimmerStream.next_cycle`)."""
        return self._stream.next_cycle()

    def current_system(self):
        """The system in force for the current cycle."""
        return self._stream.current_system()

    def robot_state(self) -> dict:
        """State of the stream (:meth:`geogait.simulate.SwimmerStream.robot_state`) and the δ std."""
        return {**self._stream.robot_state(), "perturbation_std": self.perturbation_std}

    def restore_robot_state(self, state: dict) -> None:
        """Put back ``state`` from :meth:`robot_state` (δ std included)."""
        if "perturbation_std" in state:
            self.set_perturbation_std(state["perturbation_std"])
        self._stream.restore_robot_state({k: v for k, v in state.items() if k != "perturbation_std"})

    def set_perturbation_std(self, std: float) -> None:
        """Run the following cycles with δ std ``std`` (rad, >= 0)."""
        std = check_float(std, "std", "ExplorationStream.set_perturbation_std", low=0)
        if np.isclose(std, self.perturbation_std, rtol=1e-12, atol=0):
            return
        base = self._stream.perturbation
        perturbation = Perturbation(alpha=base.alpha, beta=base.beta, eta=std * np.sqrt(2 * base.alpha * base.beta))
        stream = SwimmerStream(self._system, self._stream.gait, **(self._options | {"perturbation": perturbation}))
        stream.restore_robot_state(self._stream.robot_state())
        self._stream = stream
