r"""The optimiser's own model-class test: the seed gait at two cycle periods, before anything else.

geogait's models are principally kinematic, :math:`\xi = -A(r)\dot r`: a gait moves the body the same per cycle
at any speed. A robot with inertia or rate-dependent forces does not, and a model of it predicts gains its steps
then fail to deliver. With ``InSituOptimizer(model_class_cycles=n)`` a run starts by testing this on the robot:
it runs the seed gait for ``n`` cycles at the robot's period T, then (after settling) ``n`` cycles at a second
period T₂ (2 T, or T / 2 where that is outside the run's period range or joint-velocity limit), then settles
back at T. These cycles carry no exploration the optimiser commands (clean, as the test compares mean motions)
and are neither learned from nor measured for the objective (``settling`` in the log, with
``model_class_check``). The verdict is :func:`geogait.learn.period_verdict`'s — the test ``geogait fit`` runs on
logs. When it finds the robot outside the model class, the run says so (one warning) and keeps the model's gate
shut for the rest of the run: its steps then come from measured outcomes alone (the measured climb; none with
``climb=False``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..learn import ModelClassVerdict, period_verdict

#: The second period of the test, as a multiple of the robot's (or its inverse when that one is not allowed).
PERIOD_RATIO = 2.0


@dataclass
class ModelClassCheck:
    """The plan and the measurements of the test (module docstring).

    Parameters
    ----------
    period, other_period : float
        T and T₂ (s).
    n_cycles : int
        Measured cycles at each period.
    settle_cycles : int
        Cycles run and not measured at the start (the run's ``settle_cycles``) and after each period change (at
        least one).
    position : int
        Cycles of the plan run so far.
    periods, nets, amplitudes : list
        Each measured cycle's period, net motion and realised gait size.
    verdict : ModelClassVerdict or None
        The outcome, once both periods are measured.
    """

    period: float
    other_period: float
    n_cycles: int
    settle_cycles: int = 0
    position: int = 0
    periods: list = field(default_factory=list)
    nets: list = field(default_factory=list)
    amplitudes: list = field(default_factory=list)
    verdict: ModelClassVerdict | None = None

    @property
    def plan(self) -> list[tuple[str, float]]:
        """(``"settle"`` or ``"measure"``, period) of every cycle of the test, in order."""
        change = max(1, self.settle_cycles)
        return ([("settle", self.period)] * self.settle_cycles + [("measure", self.period)] * self.n_cycles
                + [("settle", self.other_period)] * change + [("measure", self.other_period)] * self.n_cycles
                + [("settle", self.period)] * change)

    @property
    def done(self) -> bool:
        return self.position >= len(self.plan)

    @property
    def outside(self) -> bool:
        """The robot was found outside the model class (its gate stays shut)."""
        return self.verdict is not None and self.verdict.principally_kinematic is False

    def record(self, period: float, net, amplitude: float) -> ModelClassVerdict | None:
        """Take the cycle just run (the plan's next); returns the verdict when this cycle completes it."""
        kind, _ = self.plan[self.position]
        self.position += 1
        if kind == "measure":
            self.periods.append(float(period))
            self.nets.append(np.asarray(net, dtype=float))
            self.amplitudes.append(float(amplitude))
        if self.verdict is None and len(self.periods) == 2 * self.n_cycles:
            self.verdict = period_verdict(self.periods, np.reshape(self.nets, (-1, 3)), self.amplitudes,
                                          min_cycles=self.n_cycles, time_unit="s")
            return self.verdict
        return None

    def next_period(self) -> float:
        """The period the next cycle runs at (the robot's own once the test is done)."""
        return self.period if self.done else self.plan[self.position][1]

    # -- checkpoint ---------------------------------------------------------------------------
    def to_checkpoint(self) -> tuple[dict, dict]:
        metadata = {"period": self.period, "other_period": self.other_period, "n_cycles": self.n_cycles,
                    "settle_cycles": self.settle_cycles, "position": self.position,
                    "verdict": None if self.verdict is None else self.verdict.to_dict()}
        arrays = {"model_class/periods": np.asarray(self.periods, dtype=float),
                  "model_class/nets": np.reshape(np.asarray(self.nets, dtype=float), (-1, 3)),
                  "model_class/amplitudes": np.asarray(self.amplitudes, dtype=float)}
        return metadata, arrays

    @classmethod
    def from_checkpoint(cls, metadata: dict, arrays: dict) -> ModelClassCheck:
        verdict = metadata["verdict"]
        if verdict is not None:
            verdict = ModelClassVerdict(**{k: tuple(v) if isinstance(v, list) else v for k, v in verdict.items()})
        return cls(period=metadata["period"], other_period=metadata["other_period"], n_cycles=metadata["n_cycles"],
                   settle_cycles=metadata["settle_cycles"], position=metadata["position"],
                   periods=arrays["model_class/periods"].tolist(), nets=list(arrays["model_class/nets"]),
                   amplitudes=arrays["model_class/amplitudes"].tolist(), verdict=verdict)


def second_period(period: float, low: float, high: float, shortest: float) -> float | None:
    """T₂ for the test: ``PERIOD_RATIO`` × T, else T / ``PERIOD_RATIO``, within [max(low, shortest), high]
    (None when neither is)."""
    for candidate in (period * PERIOD_RATIO, period / PERIOD_RATIO):
        if max(low, shortest) * (1 - 1e-12) <= candidate <= high * (1 + 1e-12):
            return candidate
    return None


def smallest_budget(settle_cycles: int, model_class_cycles: int = 0) -> int:
    """The fewest cycles of an in-situ run (:class:`~geogait.optimize.InSituOptimizer`) that hold one measured
    cycle.

    The optimiser spends its first cycles without measuring: ``settle_cycles`` settle cycles, or, with a
    model-class test (``model_class_cycles`` > 0), the test's plan — the start's ``settle_cycles``, then
    ``model_class_cycles`` cycles at each of two periods, each period change followed by ``max(1,
    settle_cycles)`` settle cycles (the plan of :class:`ModelClassCheck`). A run
    needs one cycle more: a budget below this ends with no measured cycle, every cycle spent for nothing.

    Parameters
    ----------
    settle_cycles, model_class_cycles : int
        The optimiser's settings (checked by it).

    Returns
    -------
    int
    """
    if not model_class_cycles:
        return settle_cycles + 1
    return settle_cycles + 2 * model_class_cycles + 2 * max(1, settle_cycles) + 1
