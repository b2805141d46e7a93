r"""In-situ gait optimisation (paper Fig. 4) of any :class:`~geogait.robots.Robot`: perturbed cycles →
model → confidence-gated trust-region step → Taylor rebase (eq. 7) → repeat.

The optimiser is composed from a model (default :class:`~geogait.models.AdaptiveGaitModel`; the
prior-work baseline is a :class:`~geogait.models.BatchGaitModel` with the ``"cycles"`` gate). Time
is in seconds at the robot: the model's phase rate is 2π / ``robot.cycle_period``.

What a gait is judged by is **measured**: the net SE(2) motion of every cycle from the robot's own
poses (the last pose advanced by the last measured body velocity over one sample interval), in the
body frame at the start of the cycle. A simulator's truth (``current_system()``) only adds
``true_*`` columns to the log.

Gait family (``family``): the free Fourier family of ``order``, or a rotation-free family — on
chains with front–back symmetry :class:`~geogait.gaits.SymmetricGaitFamily` about the seed gait's
φ₀, on other bodies that declare mirror symmetry the half-wave symmetric
:class:`~geogait.gaits.MirrorGaitFamily` (odd harmonics only). Every commanded gait of those has
exactly zero net rotation, so the rotation constraint below is dropped. Step rule (``step_rule``):
``"linear"`` as below, or ``"sqp"`` — the
model's own nonlinear predicted objective maximised inside the trust region by SQP
(:func:`~geogait.optimize.sqp_step`). Both are the standalone functions of
:mod:`geogait.optimize._steps`.

Linear step rule (documented choice for the zero-rotation constraint: a *constrained step*). With the
model's predicted net motion :math:`g(p)` at the current gait parameters :math:`p_0`, its objective
gradient :math:`\nabla f` and rotation row :math:`J_\omega`, the step solves the linearised problem

.. math:: \max_{\Delta} \nabla f^T\Delta \ \text{ s.t. }\ \omega_0 + J_\omega\Delta = 0,\
   \|\Delta\| \le R,\ G(p_0+\Delta) \le h \ \text{(joint angle and speed limits)},

then corrects the predicted rotation with a few Newton steps on the model's own (nonlinear)
prediction, backtracks while the model does not predict an improvement, and is accepted only if
the predicted rotation is below ``rotation_tolerance`` and the limits hold exactly. The trust
radius R follows the ratio test: when the next iteration's model confirms less than a quarter of
the predicted gain, R halves; when it confirms more than three quarters of a step that reached the
boundary, R grows by half, within [``min_trust_radius``, ``max_trust_radius``].

Safety (the robot is not the model):

* **settling** — the ``settle_cycles`` cycles after every gait change are run and logged but not
  learned from or measured (a body with momentum needs them to forget the old gait);
* **tracking** — every cycle's RMS difference between realised and commanded shapes is logged; a
  new gait whose tracking error exceeds ``max_tracking_error`` is rejected: the previous gait (for a
  measured-climb candidate, the climb's base) is commanded again and the trust radius halves (with
  ``"auto"``, the measured climb's gaits and period trials are judged by their outcome instead);
* **prediction check** — the gate stays closed while the model's predicted objective of the
  current gait differs from the mean measured objective of its cycles by more than
  ``prediction_tolerance`` (relative), however high Γ is;
* **measured outcomes over the model** — every gait's learned cycles are kept with their measured
  objective; when the gate would open on a gait whose mean is below the best gait measured so far by
  more than ``revert_tolerance`` standard errors (pooled cycle-to-cycle spread), the steps have led
  downhill whatever the model predicts (a model right about the current gait can be wrong about its
  gradient): the best gait is commanded again and the trust radius halves.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import models
from .._defaults import FEASIBILITY_TOLERANCE, MAX_JOINT_ANGLE, STRUCTURED_MODEL_STEPS
from .._estimator import Boolean, Estimator, Integer, Options, Real
from .._files import read_state
from .._validation import GeogaitError, check_callback, check_float, check_int, fail
from ..gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily
from ..models import check_gait_model, has_gait_model_members
from ..robots import check_robot
from ..systems import PurcellSwimmer
from ._climb import CLIMB_RULES
from ._exploration import Exploration
from ._loop import CycleLoop, new_climb
from ._measure import peak_phase_speed
from ._model_class import PERIOD_RATIO, ModelClassCheck, second_period
from ._models import ONLINE_GAMMA, gate_kind, model_template, run_model, symmetric_chain_model
from ._objective import OBJECTIVES, robot_feasibility
from ._period import PeriodSearch
from ._result import InSituResult
from ._state import (
    CHECKPOINT_FORMAT,
    CHECKPOINT_VERSION,
    RunState,
    checkpoint_path,
    params_from_json,
    params_to_json,
    prefixed_arrays,
)
from ._steps import STEP_RULES

__all__ = ["InSituOptimizer", "symmetric_chain_model"]

#: r_max of a robot that declares no joint ranges (the design's 2π/3).
DEFAULT_MAX_JOINT_ANGLE = MAX_JOINT_ANGLE


class InSituOptimizer(Estimator):
    """The paper's in-situ optimiser for any robot; the prior-work baseline with a batch model.

    Parameters
    ----------
    model : estimator, optional
        The model learned in situ; cloned (``type(model)(**model.get_params(deep=False))``) with the seed gait
        and the robot's phase rate at every run. It must offer ``partial_fit`` (or ``fit``),
        ``predict_displacement(gait, jacobian=...)`` and ``rebase``; with ``gamma_`` and
        ``reset_gamma`` it can use the Γ gate. Default: in the symmetric family (a front–back
        symmetric chain), the symmetric shape-space model of :func:`symmetric_chain_model`; otherwise
        ``AdaptiveGaitModel`` with λ = 1 − 0.1 / d for shape dimension d (0.95, 0.975 and 0.9875 for 2,
        4 and 8 joints: the filters must remember more samples when they have more weights). A robot
        that declares a chain in a resistive medium (a truthy ``resistive_medium`` and
        ``chain_geometry()``: :class:`~geogait.robots.MujocoRobot` reads both from its model, a bridge
        driver declares them in its hello) gets :class:`~geogait.models.ResistanceModel` on its geometry
        instead, with the structured model's step settings (``geogait.optimize.STRUCTURED_MODEL_STEPS``:
        SQP, trust radius 0.25–0.5, the measured climb only when contradicted and by the evolution strategy) for
        those of ``step_rule``, ``climb`` with ``climb_rule``, and the trust region (``trust_radius``,
        ``min_trust_radius``, ``max_trust_radius``; each group taken together) left at their defaults. A
        structured model that reports how much of its prediction the physics leaves to the data
        (``residual_share_``: the hybrid ``ResistanceModel(residual_degree=...)``) and reports more than 0.15
        at a decision on the seed gait (before the first step or climb; period trials aside) is contradicted
        by its data: the run leans on them, with the data-driven step settings (the defaults of ``step_rule``,
        ``climb`` with ``climb_rule``, and the trust region) for those still at the structured model's, and
        logs the share (column ``residual_share``).
    gate : {"gamma", "cycles"}, optional
        ``"gamma"`` (paper): a step as soon as the online Γ over the current iteration reaches
        ``gamma_threshold``. ``"cycles"`` (Bittner et al. 2018): ``cycles_per_iteration`` cycles,
        then ``model.fit`` on them, then a step. Default ``"gamma"`` for models with an online Γ,
        else ``"cycles"``.
    gamma_threshold : float
        Γ* (default 1/2).
    order : int
        Fourier order of the gait family optimised (the seed is embedded in it; a seed of higher order is
        refused rather than cut).
    family : {"auto", "free", "symmetric", "mirror"}
        Gait family searched. ``"symmetric"``: the front–back symmetric, rotation-free family about
        the seed's symmetry phase (the seed must be a member). ``"mirror"``: the half-wave symmetric
        gaits θ(φ + π) = −θ(φ), rotation-free on any body whose physics is mirror symmetric (the seed
        must be a member: no offsets or even harmonics). ``"auto"`` (default): symmetric when the
        robot declares front–back symmetry (a truthy ``front_back_symmetric`` attribute, or a
        simulated :class:`~geogait.systems.PurcellSwimmer` whose link lengths read the same from both
        ends) and the seed gait is a member; else mirror when it declares mirror symmetry (a truthy
        ``mirror_symmetric`` attribute, or any simulated ``PurcellSwimmer``) and the seed is a
        member; free otherwise.
    step_rule : {"linear", "sqp"}
        Trust-region step on the model's prediction (module docstring).
    objective : {"progress", "efficiency", "forward", "budget"}
        Straight-line progress per cycle, progress per shape-space path length, or signed progress
        along ``direction``; all with zero net rotation.
    direction : array-like of 2 floats, optional
        Direction of ``"forward"``. Default: the mean motion of the seed gait's measured cycles,
        fixed at the first gate decision (a running mean before it), so the run keeps going the way
        it started; a seed whose mean motion is within 2 standard errors of zero (its cycles' spread)
        is refused with a clear error rather than optimised in a direction set by noise.
    direction_frame : {"world", "body"}
        ``direction`` is fixed in the world (a heading to follow; the objective uses the measured
        heading at the start of the latest cycle) or in the body frame at the start of a cycle.
    max_joint_angle : float or "auto"
        r_max (the robot's shape units, rad for joint angles); every commanded gait satisfies
        |θ_j(φ)| ≤ r_max. ``"auto"`` (default): from the joint ranges the robot declares (a
        ``joint_ranges`` array of shape (d, 2), as :class:`~geogait.robots.MujocoRobot` reads them
        from its model): the smallest ``min(|low|, |high|)`` over the joints; 2π/3 for a robot that
        declares none (or only unlimited joints).
    max_joint_velocity : float, optional
        Largest commanded joint speed |θ̇_j| (rad per second at the robot's cycle period).
    trust_radius, min_trust_radius, max_trust_radius : float
        Initial, smallest and largest step length in parameter space, in units of ``shape_scale``.
    revert_tolerance : float or None
        Measured outcomes over the model (module docstring): when the current gait's mean measured
        objective falls this many standard errors below the best gait measured so far, the best gait
        is commanded again. ``None`` disables it.
    shape_scale : float or "auto"
        The robot's unit of shape: trust radii and the automatic tracking limit's floor are multiples
        of it, so the same defaults serve joints in radians, curvature modes or metres. ``"auto"``
        (default): the seed gait's largest joint amplitude (√(Σ_k a_jk² + b_jk²) over its harmonics;
        1 for ``seed_gait``, so radians on the built-in swimmers).
    rotation_tolerance : float
        Largest model-predicted |net rotation| per cycle of an accepted gait.
    min_cycles_per_iteration : int
        Measured cycles on a gait before Γ may trigger a step. After a step the baseline phase model
        starts afresh and the first cycle on the new gait only trains it.
    cycles_per_iteration : int
        Cycles per iteration of the ``"cycles"`` gate.
    rebase : {"constant", "all", "none"}
        Taylor rebase terms (eq. 7 is ``"constant"``).
    covariance_inflation, constant_variance : float
        Passed to the model's ``rebase`` (see ``AdaptiveGaitModel.rebase``).
    min_gain : float
        Smallest predicted relative gain worth a step (a gait the model sees rotating is restored
        regardless).
    settle_cycles : int
        Cycles after each gait change — and at the start, when a robot may start from rest — that are
        run but neither learned from nor measured.
    max_tracking_error : float or "auto" or None
        Largest RMS realised − commanded shape error (rad) of an accepted gait; a gait beyond it is rejected and the run
        goes back to the gait before it (a climb's candidate: to the climb's base). ``"auto"``: twice the mean tracking
        error of the seed's measured cycles, then of each gait kept for its measured outcome (a climb's candidate, a
        period trial, the base a climb hands back to the model), at least 0.05 × ``shape_scale`` (the log's
        ``tracking_limit``); it guards the model's steps (and the gaits they lead back to), while the measured climb and
        the period trials are judged by what they measure (on Gymnasium's swimmer, whose fastest gaits its PD joints
        follow to 0.2–0.7 rad, refusing them cost 7 / 6 / 2 points of the seed's speed at 30 / 60 / 100 cycles). A
        number holds every gait to it, the climb's candidates too (refused, as beyond a limit). ``None`` disables the
        check.
    prediction_tolerance : float or None
        Largest relative difference between the model's predicted objective of the current gait and
        its mean measured objective for the gate to open. ``None`` disables the check.
    optimize_period : bool
        Make the cycle period a decision variable and the objective a rate (per second): gait steps
        from the model alternate with period trials judged on measured outcomes
        (a measured line search on log T, module :mod:`geogait.optimize._period`), within ``period_range`` and
        ``max_joint_velocity``; while the measured climb runs, and from the start with ``climb="first"``, the
        period is one of the climb's coordinates instead. Needs a robot with ``set_cycle_period`` (e.g.
        :class:`~geogait.robots.MujocoRobot`). Default False: the robot's period is kept.
    period_range : tuple of 2 floats, optional
        (shortest, longest) period in seconds for ``optimize_period``; default half to twice the
        robot's period.
    climb : bool, "contradicted" or "first"
        When measured outcomes contradict the model — two broken promises in a row (a promised gain
        of at least 1 % unconfirmed at the smallest trust radius, a revert to the best gait, or a model
        step to a gait the robot could not follow whose cycle measured under a quarter of the promised
        gain), its
        prediction check failed twice in a row, or cycles without exploration — or when the model
        has levelled off (three gate decisions in a row without a step promising 1 %), take steps from the
        measured outcomes instead (COBYQA or an evolution strategy in the same family and limits:
        ``climb_rule``; module :mod:`geogait.optimize._climb`), and return to model steps once the model predicts
        the measured gains again. ``"contradicted"``: only when measured outcomes contradict the model,
        not when it levels off (a model that holds far from its data, levelled off at its optimum, would
        otherwise be led astray by single noisy cycles). ``"first"`` (default): climb from the first
        decision — after ``min_cycles_per_iteration`` measured cycles of the seed, without waiting for the
        model's Γ — at twice the largest trust radius, and hand the steps to the model once it predicts the
        measured gains of the climb's own steps (True, its former default, lets the model step first). On
        the robot benchmark (24 paired seeds) climbing first is ahead of model steps first (level on 3
        links at 100 cycles) on every robot with a data-driven model, most on those outside the model class
        and on the 9-link swimmer; the
        structured model's settings keep ``"contradicted"``.
    climb_rule : {"auto", "es", "cobyqa", "bayes"}
        How the climb proposes its candidates. ``"es"``: the mirrored (1+1) evolution strategy
        above. ``"cobyqa"``: SciPy's COBYQA (module :mod:`geogait.optimize._search`), a
        derivative-free trust-region method that interpolates quadratic models of the measured outcomes
        from every candidate it has measured (2n + 1 of them before its first model step, n the search's
        coordinates), starting at the climb's σ and ending at ``min_trust_radius``; a point beyond the joint
        limit is run scaled back onto it, and in the free family the measured rotation is its constraint. Far fewer
        cycles than the strategy (measured on the robot benchmark: ahead or level on every robot there);
        it trusts every single measurement, so a very noisy one can mislead it. ``"bayes"``: trust-region
        Bayesian optimisation (module :mod:`geogait.optimize._bayes`): a Gaussian process of the measured
        outcomes proposes every candidate from all the points measured, with no initial design, in a box
        of half-width σ around the best, down to ``min_trust_radius``. ``"auto"`` (default): ``"bayes"`` where
        COBYQA's design would take more than 30 robot cycles ((2n + 1)(``settle_cycles`` + 1)), else
        ``"cobyqa"`` (:func:`geogait.optimize.climb_rule_for`).
    exploration : "auto", float or None
        Who explores. ``"auto"`` (default): the optimiser commands the excitation of eq. 8
        (δ std 0.15 × ``shape_scale``, two oscillations per cycle; :class:`Exploration`) to robots
        that offer ``set_excitation`` (and to none while the measured climb runs: its outcomes are
        measured clean); robots without it explore on their own. A float: that δ std in units of
        ``shape_scale`` (the robot must offer ``set_excitation``). None: never commanded — the
        robot's own perturbation (the paper's simulated swimmer). Either way, the log's
        ``excitation`` column is each cycle's RMS commanded (or, without ``commanded_shape``,
        realised) − nominal shape, and when the cycles of a gait show none (below 1 % of
        ``shape_scale``) the model cannot learn: the run says so (a warning) and takes no model step.
    model_class_cycles : int
        Test whether the robot is inside the model class before anything else (module
        :mod:`geogait.optimize._model_class`): the seed gait runs this many clean cycles at the robot's
        period and as many at twice (or half) it, and when its net motion per cycle changes with the
        period (beyond noise and by more than 5 %) the run warns and keeps the model's gate shut: steps come
        from measured outcomes only. Costs 2 × this + 2 cycles (more with ``settle_cycles``); needs a robot
        with ``set_cycle_period``.
        0 (default): no test. Otherwise at least 3.
    random_state : int or None
        Seed of the climb's random directions (default 0: runs repeat exactly; an int, so that a
        checkpoint can name it; None draws fresh entropy).
    """

    _parameter_constraints = {
        "gate": Options((None, "gamma", "cycles")),
        "gamma_threshold": Real(high=1.0, high_open=True),
        "order": Integer(minimum=1),
        "objective": Options(tuple(OBJECTIVES)),
        "direction_frame": Options(("world", "body")),
        "family": Options(("auto", "free", "symmetric", "mirror")),
        "step_rule": Options(tuple(STEP_RULES)),
        "max_joint_velocity": Real(low=0, low_open=True, none=True),
        "trust_radius": Real(low=0, low_open=True),
        "min_trust_radius": Real(low=0, low_open=True),
        "max_trust_radius": Real(low=0, low_open=True),
        "rotation_tolerance": Real(low=0, low_open=True),
        "min_gain": Real(low=0),
        "min_cycles_per_iteration": Integer(minimum=1),
        "cycles_per_iteration": Integer(minimum=1),
        "rebase": Options(("constant", "all", "none")),
        "covariance_inflation": Real(low=1),
        "constant_variance": Real(low=0),
        "settle_cycles": Integer(minimum=0),
        "prediction_tolerance": Real(low=0, low_open=True, none=True),
        "revert_tolerance": Real(low=0, low_open=True, none=True),
        "optimize_period": Boolean(),
        "climb": Options((True, False, "contradicted", "first")),
        "climb_rule": Options(tuple(CLIMB_RULES)),
        "model_class_cycles": Integer(minimum=0),
        "random_state": Integer(minimum=0, none=True),
    }
    #: δ std of the optimiser's own excitation, in units of ``shape_scale`` (``exploration="auto"``).
    EXPLORATION_STD = 0.15

    def __init__(self, *, model=None, gate: str | None = None, gamma_threshold: float = 0.5, order: int = 1,
                 objective: str = "progress", direction=None, direction_frame: str = "world",
                 family: str = "auto", step_rule: str = "linear",
                 max_joint_angle="auto", max_joint_velocity: float | None = None,
                 trust_radius: float = 0.1, min_trust_radius: float = 0.02, max_trust_radius: float = 0.15,
                 rotation_tolerance: float = 1e-3, min_cycles_per_iteration: int = 2, cycles_per_iteration: int = 30,
                 rebase: str = "all", covariance_inflation: float = 1.0, constant_variance: float = 0.0,
                 min_gain: float = 0.005, settle_cycles: int = 0, max_tracking_error="auto",
                 prediction_tolerance: float | None = 0.5, shape_scale="auto", revert_tolerance: float | None = 2.0,
                 optimize_period: bool = False, period_range=None, climb: bool | str = "first",
                 climb_rule: str = "auto", exploration="auto", model_class_cycles: int = 0,
                 random_state: int | None = 0):
        self.model = model
        self.gate = gate
        self.gamma_threshold = gamma_threshold
        self.order = order
        self.objective = objective
        self.direction = direction
        self.direction_frame = direction_frame
        self.family = family
        self.step_rule = step_rule
        self.max_joint_angle = max_joint_angle
        self.max_joint_velocity = max_joint_velocity
        self.trust_radius = trust_radius
        self.min_trust_radius = min_trust_radius
        self.max_trust_radius = max_trust_radius
        self.rotation_tolerance = rotation_tolerance
        self.min_cycles_per_iteration = min_cycles_per_iteration
        self.cycles_per_iteration = cycles_per_iteration
        self.rebase = rebase
        self.covariance_inflation = covariance_inflation
        self.constant_variance = constant_variance
        self.min_gain = min_gain
        self.settle_cycles = settle_cycles
        self.max_tracking_error = max_tracking_error
        self.prediction_tolerance = prediction_tolerance
        self.shape_scale = shape_scale
        self.revert_tolerance = revert_tolerance
        self.optimize_period = optimize_period
        self.period_range = period_range
        self.climb = climb
        self.climb_rule = climb_rule
        self.exploration = exploration
        self.model_class_cycles = model_class_cycles
        self.random_state = random_state

    # -- scikit-learn protocol (get_params, set_params, repr: Estimator) ---------------------
    def describe(self) -> dict:
        """Hyper-parameters as JSON values (the model as its class name and parameters)."""
        return params_to_json(self)

    def _check_param_combinations(self) -> None:
        owner = "InSituOptimizer"
        if self.gate == "gamma" and not has_gait_model_members(model_template(self.model), ONLINE_GAMMA):
            raise fail("gate", owner, "'cycles' for a model without an online Γ (gamma_, reset_gamma)", self.gate)
        if self.model is not None:
            check_gait_model(self.model, ("get_params", "predict_displacement") + (
                ("partial_fit", "rebase") if self._gate() == "gamma" else ("fit",)), owner)
        if self.direction is not None:
            direction = np.asarray(self.direction, dtype=float) if _is_numeric(self.direction) else None
            if direction is None or direction.shape != (2,) or not np.all(np.isfinite(direction)) \
                    or np.hypot(*direction) == 0:
                raise fail("direction", owner, "a non-zero finite 2-vector or None", self.direction)
        check_float(self.max_trust_radius, "max_trust_radius", owner, low=self.min_trust_radius)
        check_float(self.trust_radius, "trust_radius", owner, low=self.min_trust_radius, high=self.max_trust_radius)
        for name in ("max_joint_angle", "shape_scale"):  # in the robot's shape units: no upper bound
            value = getattr(self, name)
            if isinstance(value, str):
                if value != "auto":
                    raise fail(name, owner, "a positive float or 'auto'", value)
            else:
                check_float(value, name, owner, low=0, low_open=True)
        if self.max_tracking_error not in (None, "auto"):
            check_float(self.max_tracking_error, "max_tracking_error", owner, low=0, low_open=True)
        if isinstance(self.exploration, str):
            if self.exploration != "auto":
                raise fail("exploration", owner, "'auto', a float >= 0 (δ std in shape_scale units) or None",
                           self.exploration)
        elif self.exploration is not None:
            check_float(self.exploration, "exploration", owner, low=0)
        if 0 < self.model_class_cycles < 3:
            raise fail("model_class_cycles", owner, "0 (no test) or at least 3 cycles per period",
                       self.model_class_cycles)
        if self.period_range is not None:
            bounds = np.asarray(self.period_range, dtype=float) if _is_numeric(self.period_range) else None
            if bounds is None or bounds.shape != (2,) or not np.all(np.isfinite(bounds)) \
                    or not 0 < bounds[0] < bounds[1]:
                raise fail("period_range", owner, "None or (shortest, longest) seconds with 0 < shortest < longest",
                           self.period_range)

    # -- running ------------------------------------------------------------------------------
    def run(self, robot, n_cycles: int, *, ceiling: float | None = None,
            callback: Callable[[dict], None] | None = None, record: bool = False,
            checkpoint=None, checkpoint_every: int = 1, checkpoint_tag: dict | None = None) -> InSituResult:
        """Optimise in situ for ``n_cycles`` cycles of ``robot``.

        Parameters
        ----------
        robot : Robot
            Anything implementing :class:`geogait.robots.Robot` (``SwimmerStream``,
            ``MujocoRobot``, ``ProcessRobot``, your own driver). With ``current_system()`` the log
            also holds the true displacement per cycle.
        n_cycles : int
        ceiling : float, optional
            Ceiling objective value; adds ``ceiling_fraction`` to the log.
        callback : callable, optional
            Called with each log row (a dict) as it is produced (live progress displays).
        record : bool
            Keep every sample (``result.trajectory``).
        checkpoint : path-like, optional
            ``.npz`` file rewritten atomically every ``checkpoint_every`` cycles (and after the
            first and the last) with everything needed by :meth:`resume`: hyper-parameters, model, gait, trust
            radius, log, and the robot's own state when it offers ``robot_state()``.
        checkpoint_every : int
        checkpoint_tag : dict, optional
            JSON values stored in the checkpoint as ``tag`` and kept by :meth:`resume` (the CLI's run
            identity: a resume can check that the checkpoint is the run it means).
        """
        self.validate()
        owner = "InSituOptimizer.run"
        check_callback(callback, record, owner)
        n_cycles = check_int(n_cycles, "n_cycles", owner, minimum=1)
        checkpoint_every = check_int(checkpoint_every, "checkpoint_every", owner, minimum=1)
        if ceiling is not None:
            ceiling = check_float(ceiling, "ceiling", owner, low=0, low_open=True)
        checkpoint = checkpoint_path(checkpoint, owner)
        template = model_template(self.model)
        if checkpoint is not None and not getattr(template, "can_save", lambda: True)():
            raise fail("checkpoint", owner, f"None for a {type(template).__name__}, which cannot be saved",
                       str(checkpoint))
        check_robot(robot, owner)
        structured = self._structured_default(robot)
        if structured is not None:
            return structured.run(robot, n_cycles, ceiling=ceiling, callback=callback, record=record,
                                  checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                  checkpoint_tag=checkpoint_tag)
        period = check_float(robot.cycle_period, "robot.cycle_period", owner, low=0, low_open=True)
        if self.order < robot.gait.highest_harmonic():
            raise fail("order", owner, f"at least the highest harmonic of the robot's seed gait "
                       f"({robot.gait.highest_harmonic()}), which would be dropped", self.order)
        gait = robot.gait.with_order(self.order)
        r_max = self._joint_limit(robot, owner)
        reach = gait.joint_limit().max()
        if reach > r_max + 1e-12:
            if self.max_joint_angle == "auto":  # (the limit the robot declares)
                raise fail("robot", owner, f"a seed gait within max_joint_angle = {r_max:.4g}",
                           f"a gait reaching {reach:.4g} rad")
            raise fail("max_joint_angle", owner, f"at least the largest joint angle of the robot's seed gait "
                       f"({reach:.4g} rad), where the run starts", r_max)
        if self.max_joint_velocity is not None:
            speed = peak_phase_speed(gait) * 2 * np.pi / period
            if speed > self.max_joint_velocity * (1 + 1e-9):
                raise fail("max_joint_velocity", owner, f"at least the peak joint speed of the robot's seed gait "
                           f"({speed:.4g} rad/s), where the run starts", self.max_joint_velocity)
        period_range = self._period_range(robot, period, owner)
        excites = self._excites(robot, owner)
        family = self._family(robot, gait)
        feasibility = robot_feasibility(robot, gait.n_joints, self.order)
        if feasibility is not None and feasibility(gait.params)[0].min() < -FEASIBILITY_TOLERANCE:
            raise fail("robot", owner, "a seed gait inside the robot's feasible region (its system's singular set's "
                       "margin, or the region it declares; e.g. the system's own seed_gait())",
                       "a seed gait that leaves it")
        scale = self._shape_scale(gait)
        check = self._model_class_check(robot, gait, period, period_range, owner)
        robot.set_gait(gait)  # (every check passed: a refused run leaves the robot as it was)
        state = RunState(gait=gait, radius=self.trust_radius * scale,
                         model=run_model(self.model, gait, period, family, scale),
                         n_cycles=n_cycles, ceiling=ceiling, period=period, family=family,
                         settle_left=self.settle_cycles, max_joint_angle=r_max, scale=scale,
                         feasibility=feasibility, robot_period=period, seed_period=period,
                         period_search=PeriodSearch(*period_range) if period_range is not None else None,
                         climb=new_climb(self, scale), rng=np.random.default_rng(self.random_state))
        if excites:
            state.exploration = Exploration(self._exploration_std() * scale, gait.n_joints, state.rng)
        state.check = check
        if state.check is not None:  # the test's plan runs the start's settle cycles
            state.settle_left = 0
        return CycleLoop(self, robot, state, checkpoint, checkpoint_every, checkpoint_tag).run(callback, record)

    @classmethod
    def resume(cls, checkpoint, robot, *, callback: Callable[[dict], None] | None = None,
               record: bool = False, n_cycles: int | None = None) -> InSituResult:
        """Continue a run from its checkpoint file (written by :meth:`run`) to its cycle budget.

        A robot offering ``restore_robot_state`` (simulators: ``SwimmerStream``, ``MujocoRobot``) is
        put back exactly where the checkpoint left it, so the resumed run is bit-identical to an
        uninterrupted one. Any other robot simply continues from where it physically is, commanded
        the checkpoint's gait. ``n_cycles`` extends (or shortens) the total budget.

        Parameters
        ----------
        checkpoint : path-like
            ``.npz`` checkpoint written by :meth:`run`; it keeps being rewritten as the run goes on.
        robot : Robot
            The robot to continue on, with the checkpoint gait's number of joints.
        callback : callable, optional
            Called with each new log row (a dict) as it is produced, as in :meth:`run`.
        record : bool, default False
            Keep every sample of the resumed part (``result.trajectory``).
        n_cycles : int, optional
            New total cycle budget (counting the cycles already run); the checkpoint's by default.
        """
        check_callback(callback, record, "InSituOptimizer.resume")
        path = Path(checkpoint)
        metadata, arrays = read_state(path, "checkpoint", CHECKPOINT_FORMAT, CHECKPOINT_VERSION)
        try:
            optimizer = cls(**params_from_json(metadata["params"])).validate()
            state = RunState.from_checkpoint(metadata, arrays)
        except (KeyError, TypeError, ValueError, IndexError) as error:
            raise GeogaitError(f"{path} is an inconsistent optimiser checkpoint: {error}") from None
        if state.model is None:  # not fitted yet when saved (the "cycles" gate's first iteration)
            state.model = run_model(optimizer.model, state.gait, state.period, state.family,
                                    optimizer._shape_scale(state.gaits[0]))
        check_robot(robot, "InSituOptimizer.resume")
        if robot.gait.n_joints != state.gait.n_joints:
            raise fail("robot", "InSituOptimizer.resume", f"a robot with {state.gait.n_joints} joints",
                       robot.gait.n_joints)
        state.max_joint_angle = optimizer._joint_limit(robot, "InSituOptimizer.resume")
        state.scale = optimizer._shape_scale(state.gaits[0])
        if state.climb is None:  # checkpoints before the climb
            state.climb = new_climb(optimizer, state.scale)
        if "rng" not in metadata["state"]:
            state.rng = np.random.default_rng(optimizer.random_state)
        state.feasibility = robot_feasibility(robot, state.gait.n_joints, optimizer.order)
        if n_cycles is not None:
            state.n_cycles = check_int(n_cycles, "n_cycles", "InSituOptimizer.resume", minimum=max(1, state.cycle))
        robot_state = metadata.get("robot_state")
        if robot_state is not None and hasattr(robot, "restore_robot_state"):
            robot.restore_robot_state({**robot_state, **prefixed_arrays(arrays, "robot/")})
        else:
            robot.set_gait(state.robot_gait)
            if state.period_search is not None and robot.cycle_period != state.robot_period:
                robot.set_cycle_period(state.robot_period)
        loop = CycleLoop(optimizer, robot, state, path, metadata["checkpoint_every"], metadata.get("tag"))
        return loop.run(callback, record)

    # -- scale and limits from the robot --------------------------------------------------------
    def _excites(self, robot, owner: str) -> bool:
        """Whether the optimiser commands the excitation (``exploration``) to this robot."""
        accepts = callable(getattr(robot, "set_excitation", None)) and bool(getattr(robot, "accepts_excitation", True))
        if self.exploration is None:
            return False
        if self.exploration != "auto" and not accepts:
            raise fail("robot", owner, "a robot with set_excitation(shape, shape_velocity) for a numeric "
                       "'exploration' (or exploration='auto' / None)", type(robot).__name__)
        return accepts

    def _exploration_std(self) -> float:
        return self.EXPLORATION_STD if self.exploration == "auto" else float(self.exploration)

    def _period_range(self, robot, period: float, owner: str):
        """(shortest, longest) period for ``optimize_period`` (None when the period is fixed)."""
        if not self.optimize_period:
            return None
        if not callable(getattr(robot, "set_cycle_period", None)):
            raise fail("robot", owner, "a robot with set_cycle_period(seconds) for optimize_period=True "
                       "(e.g. geogait.robots.MujocoRobot)", type(robot).__name__)
        low, high = (period / 2, 2 * period) if self.period_range is None else map(float, self.period_range)
        if not low <= period <= high:
            raise fail("period_range", owner, f"a range holding the robot's period ({period:g} s)", (low, high))
        return low, high

    def _model_class_check(self, robot, gait: FourierGait, period: float, period_range, owner: str):
        """The run's model-class test (``model_class_cycles``), or None."""
        if not self.model_class_cycles:
            return None
        if not callable(getattr(robot, "set_cycle_period", None)):
            raise fail("robot", owner, "a robot with set_cycle_period(seconds) for model_class_cycles > 0 (the "
                       "test runs the seed gait at two periods)", type(robot).__name__)
        low, high = period_range if period_range is not None else (0.0, np.inf)
        shortest = 0.0 if self.max_joint_velocity is None \
            else peak_phase_speed(gait) * 2 * np.pi / self.max_joint_velocity
        other = second_period(period, low, high, shortest)
        if other is None:
            raise fail("model_class_cycles", owner, f"0, or a period range and joint-velocity limit that allow "
                       f"{PERIOD_RATIO:g} x or 1/{PERIOD_RATIO:g} x the robot's period ({period:g} s)",
                       self.model_class_cycles)
        return ModelClassCheck(period, other, self.model_class_cycles, settle_cycles=self.settle_cycles)

    def _joint_limit(self, robot, owner: str) -> float:
        """r_max: the parameter, or (``"auto"``) from the robot's declared joint ranges."""
        if not isinstance(self.max_joint_angle, str):
            return float(self.max_joint_angle)
        ranges = getattr(robot, "joint_ranges", None)
        if ranges is None:
            return DEFAULT_MAX_JOINT_ANGLE
        ranges = np.asarray(ranges, dtype=float) if _is_numeric(ranges) else None
        if ranges is None or ranges.shape != (robot.n_joints, 2) or np.any(np.isnan(ranges)) \
                or np.any(ranges[:, 0] >= 0) or np.any(ranges[:, 1] <= 0):
            raise fail("robot.joint_ranges", owner, f"an array of shape ({robot.n_joints}, 2) of (low < 0 < high) "
                       "joint ranges (rad)", getattr(robot, "joint_ranges", None))
        limit = float(np.min(np.minimum(-ranges[:, 0], ranges[:, 1])))
        return limit if np.isfinite(limit) else DEFAULT_MAX_JOINT_ANGLE

    def _shape_scale(self, seed: FourierGait) -> float:
        """The unit of shape (``shape_scale``): the parameter, or the seed gait's largest amplitude."""
        if not isinstance(self.shape_scale, str):
            return float(self.shape_scale)
        amplitude = float(np.sqrt((seed.coefficients[:, 1:] ** 2).sum(axis=1)).max())
        if not amplitude > 0:
            raise fail("robot", "InSituOptimizer.run", "a seed gait that moves its joints (shape_scale='auto' "
                       "is its amplitude)", "a constant gait")
        return amplitude

    # -- gait family --------------------------------------------------------------------------
    def _family(self, robot, gait: FourierGait):
        """The family searched (``family`` parameter): SymmetricGaitFamily about the seed, MirrorGaitFamily or
        FreeGaitFamily."""
        owner = "InSituOptimizer.run"
        if self.family == "free":
            return FreeGaitFamily(gait.n_joints, self.order)
        if self.family in ("auto", "symmetric") and gait.n_joints >= 2:
            symmetric = SymmetricGaitFamily.from_gait(gait, self.order)
            member = symmetric.residual(gait) <= 1e-9
            if self.family == "symmetric" and not member:
                raise fail("robot", owner, "a seed gait with front-back symmetry for family 'symmetric'",
                           f"a gait at distance {symmetric.residual(gait):.3g} from the family")
            if self.family == "symmetric" or (member and _declares_symmetry(robot)):
                return symmetric
        elif self.family == "symmetric":
            raise fail("family", owner, "'free' or 'mirror' for a robot with one joint", self.family)
        mirror = MirrorGaitFamily(gait.n_joints, self.order)
        member = mirror.residual(gait) <= 1e-9
        if self.family == "mirror" and not member:
            raise fail("robot", owner, "a half-wave symmetric seed gait (no offsets or even harmonics) for family "
                       "'mirror'", f"a gait at distance {mirror.residual(gait):.3g} from the family")
        if self.family == "mirror" or (member and _declares_mirror_symmetry(robot)):
            return mirror
        return FreeGaitFamily(gait.n_joints, self.order)

    # -- model --------------------------------------------------------------------------------
    def _structured_default(self, robot):
        """This optimiser with the structured model, for the default model on a declared resistive chain (the
        ``model`` parameter); None otherwise."""
        if self.model is not None or not getattr(robot, "resistive_medium", False) \
                or not callable(getattr(robot, "chain_geometry", None)):
            return None
        steps = self._replace_steps(self._defaults(), STRUCTURED_MODEL_STEPS)
        return type(self)(**{**self.get_params(deep=False), **steps,
                             "model": models.ResistanceModel(**robot.chain_geometry())}).validate()

    def _leaning_on_data(self):
        """This optimiser with the data-driven step settings (the defaults of ``step_rule``, ``climb`` and the
        trust region) for each of them still at the structured model's (``STRUCTURED_MODEL_STEPS``), for a
        structured model whose physics the data contradict; None when every one was set otherwise."""
        steps = self._replace_steps(STRUCTURED_MODEL_STEPS, self._defaults())
        return type(self)(**{**self.get_params(deep=False), **steps}).validate() if steps else None

    @classmethod
    def _defaults(cls) -> dict:
        """Every parameter's default value."""
        return {name: p.default for name, p in inspect.signature(cls.__init__).parameters.items()}

    def _replace_steps(self, current: dict, new: dict) -> dict:
        """``new``'s values of each group of step settings (the step rule; the climb and its rule; the trust region
        taken together: one given is kept whole) whose values here are all ``current``'s."""
        steps = {}
        trust_region = ("trust_radius", "min_trust_radius", "max_trust_radius")
        for group in (("step_rule",), ("climb", "climb_rule"), trust_region):
            if all(getattr(self, name) == current[name] for name in group):
                steps.update({name: new[name] for name in group})
        return steps

    def _gate(self) -> str:
        return gate_kind(self.gate, self.model)


def _is_numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _declares_mirror_symmetry(robot) -> bool:
    """The robot says its body and medium are mirror symmetric, or simulates a Purcell swimmer (any links)."""
    declared = getattr(robot, "mirror_symmetric", None)
    if declared is not None:
        return bool(declared)
    system = robot.current_system() if hasattr(robot, "current_system") else None
    return isinstance(system, PurcellSwimmer)


def _declares_symmetry(robot) -> bool:
    """The robot says its chain is front–back symmetric, or simulates a symmetric Purcell swimmer."""
    declared = getattr(robot, "front_back_symmetric", None)
    if declared is not None:
        return bool(declared)
    system = robot.current_system() if hasattr(robot, "current_system") else None
    if not isinstance(system, PurcellSwimmer):
        return False
    lengths = np.asarray(system.link_lengths)
    return bool(np.allclose(lengths, lengths[::-1]))



