"""Run-time checks an :class:`~geogait.optimize.InSituOptimizer` may be composed with (its ``checks``).

A check is a declared part: it runs at a fixed point of the run, and what it changes is logged
(a column of the run's log) and said (a warning), never done silently.

* :class:`ModelClassTest` — before anything else, the seed gait at two cycle periods: a robot whose net motion
  per cycle changes with the period is outside the model class, and the model's gate stays shut.
* :class:`StructureCheck` — on the seed gait, a structured model whose residual carries more than ``limit`` of
  its prediction is contradicted by its data: the run switches to the check's own step and climb.
"""

from __future__ import annotations

from .._estimator import InstanceOf, Integer, Real
from .._validation import fail
from ._part import Part
from ._parts import DATA_DRIVEN_CLIMB, DATA_DRIVEN_STEP, Climb, ModelStep

__all__ = ["ModelClassTest", "StructureCheck"]


class ModelClassTest(Part):
    """The model-class test (module :mod:`geogait.optimize._model_class`): the seed gait runs ``cycles`` clean
    cycles at the robot's period and as many at twice (or half) it; when its net motion per cycle changes with
    the period beyond noise and by more than 5 %, the run warns and keeps the model's gate shut (steps come from
    the measured climb only). Costs 2 × ``cycles`` + 2 cycles, more with settling; needs a robot with
    ``set_cycle_period``. The log's ``model_class_check`` column marks its cycles.

    Parameters
    ----------
    cycles : int
        Measured cycles at each period (at least 3).
    """

    _parameter_constraints = {"cycles": Integer(minimum=3)}

    def __init__(self, *, cycles: int = 3):
        self.cycles = cycles


class StructureCheck(Part):
    """Lean on the data when a structured model's physics does not hold.

    On the seed gait, at every measured cycle once there are the gate's ``min_cycles`` of them, a model that
    reports how much of its prediction the physics leaves to the data (``residual_share_``, the hybrid
    :class:`~geogait.models.ResistanceModel`) and reports more than ``limit`` hands the run to ``step`` and
    ``climb``, once. The switch is logged (column ``residual_share``) and said (a warning).

    Parameters
    ----------
    limit : float
        Largest residual share for which the physics holds.
    step : ModelStep, optional
        The model step after the switch; default: the run's with the data-driven step rule and trust region
        (``ModelStep()``'s).
    climb : Climb or False, optional
        The climb after the switch (False: none); default: the run's with the data-driven start, rule and radii
        (``Climb()``'s), or none for a run without a climb.
    """

    _parameter_constraints = {"limit": Real(low=0, high=1), "step": InstanceOf(ModelStep, "a ModelStep")}

    def __init__(self, *, limit: float = 0.15, step: ModelStep | None = None, climb: Climb | bool | None = None):
        self.limit = limit
        self.step = step
        self.climb = climb

    def _check_param_combinations(self) -> None:
        if not (self.climb is None or self.climb is False or isinstance(self.climb, Climb)):
            raise fail("climb", type(self).__name__, "a Climb, False or None", self.climb)

    def fallback(self, step: ModelStep, climb: Climb | None) -> tuple[ModelStep, Climb | None]:
        """The step and climb a run of ``step`` and ``climb`` switches to."""
        new_step = self.step if self.step is not None else ModelStep(**{**step.get_params(), **DATA_DRIVEN_STEP})
        if self.climb is not None:
            return new_step, (None if self.climb is False else self.climb)
        return new_step, None if climb is None else Climb(**{**climb.get_params(), **DATA_DRIVEN_CLIMB})
