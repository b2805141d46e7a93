r"""The parts an :class:`~geogait.optimize.InSituOptimizer` is composed of.

Each part is an estimator in scikit-learn's sense: its hyper-parameters are the keyword arguments of
``__init__``, stored unchanged; ``get_params`` / ``set_params`` (nested, ``step__trust_radius``), ``clone``,
``repr`` and :meth:`Part.describe` work on it. Lengths in parameter space are in units of the robot's
``shape_scale`` (:class:`Limits`), so the same values serve joints in radians, curvature modes or metres.

========================  ==========================================================================
part                      decides
========================  ==========================================================================
:class:`Gate`             when the model may step: Γ ≥ Γ* (the paper) or a block of cycles (prior
                          work), and whether its prediction of the current gait agrees with what
                          was measured
:class:`ModelStep`        the model's step: the trust-region step rule, its radius and ratio test,
                          the Taylor rebase (eq. 7) after it
:class:`Climb`            steps from measured outcomes when the model does not deliver: when it starts,
                          its own step radii, and the search rule that proposes candidates
:class:`Safety`           settling cycles after a gait change, rejecting gaits the robot cannot follow,
                          and the revert to the best gait measured
:class:`Limits`           joint angle and speed limits, and the unit of shape
:class:`PeriodSearch`     the cycle period as a decision variable
========================  ==========================================================================

The objective (:class:`~geogait.optimize.Objective`), the optimiser's own exploration
(:class:`~geogait.optimize.Exploration`) and the run-time checks (:class:`~geogait.optimize.ModelClassTest`,
:class:`~geogait.optimize.StructureCheck`) are parts too, in their own modules.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from .._estimator import Integer, Options, Real
from .._validation import check_float, check_int, fail
from ._climb import CLIMB_RULES, SearchRule
from ._part import Part
from ._steps import STEP_RULES

__all__ = ["DATA_DRIVEN_CLIMB", "DATA_DRIVEN_STEP", "STRUCTURED_CLIMB", "STRUCTURED_STEP", "Climb", "Gate", "Limits",
           "ModelStep", "Part", "PeriodSearch", "Safety"]

#: The step and climb settings of a data-driven model (the parts' defaults).
DATA_DRIVEN_STEP = {"rule": "linear", "trust_radius": 0.1, "min_trust_radius": 0.02, "max_trust_radius": 0.15}
DATA_DRIVEN_CLIMB = {"start": "first", "rule": "auto", "sigma": 0.15, "first_sigma": 0.3, "min_sigma": 0.02,
                     "max_sigma": 0.6}
#: The step and climb settings of a structured model (:class:`~geogait.models.ResistanceModel`): SQP on its nonlinear
#: prediction over a trust region of 0.25 to 0.5, because a structured model's prediction holds far from the data and
#: long chains have optima along curved ridges that only large SQP steps follow. The measured climb starts only where
#: measured outcomes contradict the model, not where it levels off: at the model's optimum, single noisy cycles would
#: lead an accurate model astray. That climb is the local evolution strategy, not COBYQA: COBYQA starts with 2n + 1
#: probes at a large radius, which spends the cycles a local repair near the model's optimum needs.
STRUCTURED_STEP = {"rule": "sqp", "trust_radius": 0.25, "min_trust_radius": 0.25, "max_trust_radius": 0.5}
STRUCTURED_CLIMB = {"start": "contradicted", "rule": "es", "sigma": 0.5, "first_sigma": 1.0, "min_sigma": 0.25,
                    "max_sigma": 2.0}

#: The two-sided level of :meth:`Safety.settle_count`'s test (a cycle that may still carry the last change).
SETTLE_LEVEL = 0.05
#: Smallest shift of a gait change's first cycle, relative to the settled cycles' mean, that counts as settling: the
#: differences a climb resolves near an optimum, not the objective's size. Gymnasium's swimmer shifts its first cycle
#: by 0.2–3.5 % while its settled cycles repeat to 0.1 %; a floor of 5 % judged its candidates on transients.
SETTLE_FLOOR = 0.005

#: When the measured climb takes the steps (:class:`Climb`'s ``start``).
CLIMB_STARTS = ("first", "stalled", "contradicted")


class Gate(Part):
    """When the model may step (paper Fig. 4's confidence gate).

    Parameters
    ----------
    kind : {"gamma", "cycles"} or None
        ``"gamma"`` (the paper): a decision as soon as the online Γ over the current gait's cycles reaches
        ``gamma_threshold``. ``"cycles"`` (Bittner et al. 2018): ``cycles`` cycles, then ``model.fit`` on them,
        then a decision. None (default): ``"gamma"`` for a model with an online Γ, else ``"cycles"``.
    gamma_threshold : float
        Γ* (default 1/2).
    min_cycles : int
        Measured cycles on a gait before Γ may open the gate (and before the measured climb decides).
    cycles : int
        Cycles per iteration of the ``"cycles"`` gate.
    prediction_tolerance : float or None
        Largest relative difference between the model's predicted objective of the current gait and its mean
        measured objective for the gate to open; None: no check.
    """

    _parameter_constraints = {
        "kind": Options((None, "gamma", "cycles")),
        "gamma_threshold": Real(high=1.0, high_open=True),
        "min_cycles": Integer(minimum=1),
        "cycles": Integer(minimum=1),
        "prediction_tolerance": Real(low=0, low_open=True, none=True),
    }

    def __init__(self, *, kind: str | None = None, gamma_threshold: float = 0.5, min_cycles: int = 2,
                 cycles: int = 30, prediction_tolerance: float | None = 0.5):
        self.kind = kind
        self.gamma_threshold = gamma_threshold
        self.min_cycles = min_cycles
        self.cycles = cycles
        self.prediction_tolerance = prediction_tolerance


class ModelStep(Part):
    r"""The model's trust-region step and what follows it.

    The step maximises the model's predicted objective within the trust radius R, keeping the predicted net
    rotation at zero and every limit exactly (module :mod:`geogait.optimize._steps`). The ratio test compares
    the gain the next model sees with the gain promised: under ``broken_promise`` of it R halves; over
    ``kept_promise`` of a step that reached the boundary R grows by ``radius_growth``; R stays within
    [``min_trust_radius``, ``max_trust_radius``].

    Parameters
    ----------
    rule : {"linear", "sqp"}
        The linearised constrained step, or SQP on the model's own nonlinear prediction.
    trust_radius, min_trust_radius, max_trust_radius : float
        Initial, smallest and largest step length (shape_scale units).
    rotation_tolerance : float
        Largest model-predicted |net rotation| per cycle of an accepted gait.
    min_gain : float
        Smallest predicted relative gain worth a step.
    rebase : {"constant", "all", "none"}
        Taylor rebase terms after a step (eq. 7 is ``"constant"``).
    covariance_inflation, constant_variance : float
        Passed to the model's ``rebase``.
    broken_promise, kept_promise, radius_growth : float
        The ratio test's constants.
    significant_gain : float
        Smallest relative promised change that a measurement can break.
    """

    _parameter_constraints = {
        "rule": Options(tuple(STEP_RULES)),
        "trust_radius": Real(low=0, low_open=True),
        "min_trust_radius": Real(low=0, low_open=True),
        "max_trust_radius": Real(low=0, low_open=True),
        "rotation_tolerance": Real(low=0, low_open=True),
        "min_gain": Real(low=0),
        "rebase": Options(("constant", "all", "none")),
        "covariance_inflation": Real(low=1),
        "constant_variance": Real(low=0),
        "broken_promise": Real(low=0, high=1),
        "kept_promise": Real(low=0, high=1),
        "radius_growth": Real(low=1),
        "significant_gain": Real(low=0),
    }

    def __init__(self, *, rule: str = "linear", trust_radius: float = 0.1, min_trust_radius: float = 0.02,
                 max_trust_radius: float = 0.15, rotation_tolerance: float = 1e-3, min_gain: float = 0.005,
                 rebase: str = "all", covariance_inflation: float = 1.0, constant_variance: float = 0.0,
                 broken_promise: float = 0.25, kept_promise: float = 0.75, radius_growth: float = 1.5,
                 significant_gain: float = 0.01):
        self.rule = rule
        self.trust_radius = trust_radius
        self.min_trust_radius = min_trust_radius
        self.max_trust_radius = max_trust_radius
        self.rotation_tolerance = rotation_tolerance
        self.min_gain = min_gain
        self.rebase = rebase
        self.covariance_inflation = covariance_inflation
        self.constant_variance = constant_variance
        self.broken_promise = broken_promise
        self.kept_promise = kept_promise
        self.radius_growth = radius_growth
        self.significant_gain = significant_gain

    def _check_param_combinations(self) -> None:
        owner = type(self).__name__
        check_float(self.max_trust_radius, "max_trust_radius", owner, low=self.min_trust_radius)
        check_float(self.trust_radius, "trust_radius", owner, low=self.min_trust_radius, high=self.max_trust_radius)
        check_float(self.kept_promise, "kept_promise", owner, low=self.broken_promise)

    def breaks(self, before: float, promised: float, seen: float) -> bool:
        """A promise worth checking (a change of at least ``significant_gain``) of which under ``broken_promise``
        was seen.

        Parameters
        ----------
        before, promised, seen : float
            The objective before the step, the one the step promised, and the one seen after it.

        Returns
        -------
        bool
        """
        if promised == before or abs(promised - before) < self.significant_gain * abs(before):
            return False
        return (seen - before) / (promised - before) < self.broken_promise


class Climb(Part):
    """Steps from measured outcomes when the model's steps do not deliver (module :mod:`geogait.optimize._climb`).

    Parameters
    ----------
    start : {"first", "stalled", "contradicted"}
        ``"first"``: from the first decision, after the gate's ``min_cycles`` measured cycles of the seed, at
        ``first_sigma``; the model takes over once it predicts the climb's measured gains. ``"stalled"``: when
        measured outcomes contradict the model (two broken promises in a row, a revert, two failed prediction
        checks, cycles without exploration) or the model levels off (three decisions in a row without a step
        promising 1 %). ``"contradicted"``: only when measured outcomes contradict the model.
    rule : {"auto", "es", "cobyqa", "bayes"} or SearchRule
        How candidates are proposed: a :class:`~geogait.optimize.SearchRule` (an ask/tell search), or one by
        name: COBYQA's quadratic models (:class:`~geogait.optimize.Cobyqa`), trust-region Bayesian optimisation
        (:class:`~geogait.optimize.BayesianOptimization`), or a mirrored (1+1) evolution strategy
        (:class:`~geogait.optimize.EvolutionStrategy`); ``"auto"``: Bayesian where COBYQA's initial design would
        take more than 30 robot cycles, else COBYQA (:func:`~geogait.optimize.climb_rule_for`).
    sigma : float
        Step length of a climb that starts after the model (shape_scale units).
    first_sigma : float
        Step length of a climb that starts first (nothing is known yet).
    min_sigma, max_sigma : float
        Bounds of the evolution strategy's step length; ``min_sigma`` is also the final radius of the searches.
    rotation_tolerance : float
        Smallest rotation limit of a kept candidate (|mean measured net rotation| per cycle).
    """

    _parameter_constraints = {
        "start": Options(CLIMB_STARTS),
        "sigma": Real(low=0, low_open=True),
        "first_sigma": Real(low=0, low_open=True),
        "min_sigma": Real(low=0, low_open=True),
        "max_sigma": Real(low=0, low_open=True),
        "rotation_tolerance": Real(low=0, low_open=True),
    }

    def __init__(self, *, start: str = "first", rule: str = "auto", sigma: float = 0.15, first_sigma: float = 0.3,
                 min_sigma: float = 0.02, max_sigma: float = 0.6, rotation_tolerance: float = 1e-3):
        self.start = start
        self.rule = rule
        self.sigma = sigma
        self.first_sigma = first_sigma
        self.min_sigma = min_sigma
        self.max_sigma = max_sigma
        self.rotation_tolerance = rotation_tolerance

    def _check_param_combinations(self) -> None:
        owner = type(self).__name__
        check_float(self.max_sigma, "max_sigma", owner, low=self.min_sigma)
        if not isinstance(self.rule, SearchRule) and not (isinstance(self.rule, str) and self.rule in CLIMB_RULES):
            raise fail("rule", owner, f"one of {', '.join(map(repr, CLIMB_RULES))} or a SearchRule", self.rule)


class Safety(Part):
    """What keeps the robot safe from the model (the robot is not the model).

    Parameters
    ----------
    settle_cycles : int or "auto"
        Cycles after each gait change (and at the start) that are run but neither measured nor judged. ``"auto"``
        (default): the robot's own ``settle_cycles`` where it declares them (0 for a simulator of a principally
        kinematic system), else measured. The first gait change of a run (and the first
        after a change of the robot is detected) holds its new gait for three cycles; its first cycle is a settling
        cycle when it differs from the mean of the next two beyond noise (:data:`SETTLE_LEVEL`, at least 0.5 %), and
        so is its second when it differs from the third. The count found (0 to 2) holds for every later gait
        change; none is run at the start.
    max_tracking_error : float, "auto" or None
        Largest RMS realised − commanded shape error of an accepted gait; a gait beyond it is rejected and the
        run goes back to the gait before it. ``"auto"``: twice the mean tracking error of the seed's measured
        cycles, then of each gait kept for its measured outcome, at least 0.05 × shape_scale; the measured
        climb's candidates and period trials are then judged by their outcome. None: no check.
    revert_tolerance : float or None
        When the current gait's mean measured objective falls this many standard errors below the best gait
        measured so far, the best gait is commanded again and the trust radius halves. None: no revert.
    """

    _parameter_constraints = {
        "revert_tolerance": Real(low=0, low_open=True, none=True),
    }

    def __init__(self, *, settle_cycles="auto", max_tracking_error="auto", revert_tolerance: float | None = 2.0):
        self.settle_cycles = settle_cycles
        self.max_tracking_error = max_tracking_error
        self.revert_tolerance = revert_tolerance

    def _check_param_combinations(self) -> None:
        if self.max_tracking_error not in (None, "auto"):
            check_float(self.max_tracking_error, "max_tracking_error", type(self).__name__, low=0, low_open=True)
        if self.settle_cycles != "auto":
            check_int(self.settle_cycles, "settle_cycles", type(self).__name__, minimum=0)

    @property
    def declared_settle_cycles(self) -> int:
        """The settling cycles fixed before the run: ``settle_cycles``, or 0 for ``"auto"`` (measured in the
        run)."""
        return 0 if self.settle_cycles == "auto" else int(self.settle_cycles)

    def settle_count(self, values, noise: float, dof: int) -> int:
        """Settling cycles of a gait change whose first cycles measured ``values`` (three), with cycle-to-cycle
        ``noise`` of ``dof`` degrees of freedom: the leading cycles that differ from the mean of the cycles after
        them beyond Student's two-sided :data:`SETTLE_LEVEL` band (at least :data:`SETTLE_FLOOR` of that mean)."""
        values = np.asarray(values, dtype=float)
        for count in range(values.size - 1):
            later = values[count + 1:]
            band = stats.t.isf(SETTLE_LEVEL / 2, dof) * noise * np.sqrt(1 + 1 / later.size) if dof > 0 else np.inf
            shift = abs(values[count] - later.mean())
            if not shift > max(band if np.isfinite(band) else 0.0, SETTLE_FLOOR * abs(later.mean())):
                return count
        return values.size - 1


class Limits(Part):
    """Joint limits every commanded gait keeps, and the robot's unit of shape.

    Parameters
    ----------
    max_joint_angle : float or "auto"
        r_max (shape units); every commanded gait satisfies |θ_j(φ)| ≤ r_max. ``"auto"``: the smallest
        ``min(|low|, |high|)`` of the joint ranges the robot declares; 2π/3 where it declares none.
    max_joint_velocity : float or None
        Largest commanded joint speed |θ̇_j| (shape units per second at the robot's period).
    shape_scale : float or "auto"
        The unit of shape of the trust radii and step lengths. ``"auto"``: the seed gait's largest joint
        amplitude.
    """

    _parameter_constraints = {"max_joint_velocity": Real(low=0, low_open=True, none=True)}

    def __init__(self, *, max_joint_angle="auto", max_joint_velocity: float | None = None, shape_scale="auto"):
        self.max_joint_angle = max_joint_angle
        self.max_joint_velocity = max_joint_velocity
        self.shape_scale = shape_scale

    def _check_param_combinations(self) -> None:
        for name in ("max_joint_angle", "shape_scale"):  # in the robot's shape units: no upper bound
            value = getattr(self, name)
            if isinstance(value, str):
                if value != "auto":
                    raise fail(name, type(self).__name__, "a positive float or 'auto'", value)
            else:
                check_float(value, name, type(self).__name__, low=0, low_open=True)


class PeriodSearch(Part):
    """The cycle period as a decision variable: the objective becomes a rate (per second), and model steps
    alternate with period trials judged on measured outcomes (module :mod:`geogait.optimize._period`); while the
    measured climb runs, the period is one of its coordinates. Needs a robot with ``set_cycle_period``.

    Parameters
    ----------
    period_range : tuple of 2 floats, optional
        (shortest, longest) period in seconds; default half to twice the robot's period.
    """

    def __init__(self, *, period_range=None):
        self.period_range = period_range

    def _check_param_combinations(self) -> None:
        if self.period_range is None:
            return
        try:
            bounds = np.asarray(self.period_range, dtype=float)
        except (TypeError, ValueError):
            bounds = None
        if bounds is None or bounds.shape != (2,) or not np.all(np.isfinite(bounds)) or not 0 < bounds[0] < bounds[1]:
            raise fail("period_range", type(self).__name__,
                       "None or (shortest, longest) seconds with 0 < shortest < longest", self.period_range)

    def bounds(self, period: float) -> tuple[float, float]:
        """(shortest, longest) period for a robot whose period is ``period``."""
        return (period / 2, 2 * period) if self.period_range is None else tuple(map(float, self.period_range))
