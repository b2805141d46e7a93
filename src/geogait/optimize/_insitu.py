r"""In-situ gait optimisation (paper Fig. 4) of any :class:`~geogait.robots.Robot`: perturbed cycles →
model → confidence-gated trust-region step → Taylor rebase (eq. 7) → repeat.

The optimiser is composed from a model (default :class:`~geogait.models.AdaptiveGaitModel`; the
prior-work baseline is a :class:`~geogait.models.BatchGaitModel` with the ``"cycles"`` gate). Time
is in seconds at the robot: the model's phase rate is 2π / ``robot.cycle_period``.

What a gait is judged by is **measured**: the net SE(2) motion of every cycle from the robot's own
poses (the last pose advanced by the last measured body velocity over one sample interval), in the
body frame at the start of the cycle. A simulator's truth (``current_system()``) only adds
``true_*`` columns to the log.

Gait family (``family``): the free Fourier family of ``order``, or, on chains with front–back
symmetry, the rotation-free :class:`~geogait.gaits.SymmetricGaitFamily` about the seed gait's φ₀
(half the parameters; every commanded gait has exactly zero net rotation, so the rotation
constraint below is dropped). Step rule (``step_rule``): ``"linear"`` as below, or ``"sqp"`` — the
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
  new gait whose tracking error exceeds ``max_tracking_error`` is rejected: the previous gait is
  commanded again and the trust radius halves;
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

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .. import __version__, models, se2
from .._estimator import Boolean, Estimator, Integer, Options, Real
from .._files import read_state, write_state
from .._validation import GeogaitError, GeogaitWarning, check_float, check_int, fail
from ..gaits import FourierGait, FreeGaitFamily, SymmetricGaitFamily
from ..models import AdaptiveGaitModel, model_from_state
from ..robots import check_robot
from ..simulate import Trajectory, cycle_displacement
from ..systems import PurcellSwimmer
from ._climb import MeasuredClimb
from ._exploration import Exploration
from ._objective import OBJECTIVES, feasibility_constraint, joint_limit_constraints, objective
from ._period import PeriodSearch
from ._steps import STEP_RULES, StepProblem, take_step

__all__ = ["InSituOptimizer", "InSituResult"]

CHECKPOINT_FORMAT = "geogait-optimizer-checkpoint"
CHECKPOINT_VERSION = 1
_TRACKING_FLOOR = 0.05  # shape_scale units: the automatic tracking limit never falls below this
#: r_max of a robot that declares no joint ranges (the design's 2π/3).
DEFAULT_MAX_JOINT_ANGLE = 2 * np.pi / 3


@dataclass
class InSituResult:
    """Outcome of :meth:`InSituOptimizer.run`.

    Attributes
    ----------
    log : pandas.DataFrame
        One row per cycle: ``cycle``, ``iteration``, ``settling`` (a settle cycle after a gait
        change, not learned from), ``gamma`` (online Γ over the iteration so far; NaN on settle
        cycles and on the burn-in cycle after a step, which only trains the reset baseline),
        ``step`` (a step was taken after this cycle), ``rejected`` (this cycle's gait was rejected
        for poor tracking and the previous one commanded again), ``reverted`` (measured worse than
        the best gait so far, which was commanded again), ``prediction_ok`` (the prediction
        check at a gate decision; NaN when none was made), ``trust_radius``,
        ``predicted_objective`` (the model's estimate for the gait of this cycle at the last step
        decision); measured from the robot: ``measured_x``, ``measured_y``, ``measured_heading``
        (net motion of the cycle in the body frame at its start), ``measured_progress`` (its
        length), ``measured_objective``, ``measured_speed`` (progress per second),
        ``tracking_error`` (RMS realised − commanded shape, rad), ``world_x``, ``world_y``,
        ``world_heading`` (pose at the start of the cycle), ``cycle_period`` (s), ``climb`` (the step
        after this cycle came from the measured climb), ``period_change`` (a period trial started or
        ended after it), ``candidate`` (this cycle ran a climb candidate or period trial that was
        not kept: not a result); with a simulator's truth ``true_x``,
        ``true_y``, ``true_heading``, ``true_progress``, ``true_objective``; ``improvement``
        (relative to the seed: true values where there is a truth, else the measured objective over
        the mean measured objective of the seed's cycles so far), ``ceiling_fraction`` (when a
        ceiling is given), and ``param_*``.
    initial_gait, final_gait : FourierGait
    gaits : list of FourierGait
        Every nominal gait commanded, in order (rejected ones included).
    trajectory : Trajectory or None
        Every sample of the run (when ``record=True``; after a resume only the resumed part).
    max_joint_angle, shape_scale : float or None
        The joint limit and unit of shape the run used (resolved from the robot for ``"auto"``).
    direction : ndarray of shape (2,) or None
        The unit direction of ``"forward"`` the run used (in its ``direction_frame``).
    cycle_period : float or None
        The period (s) to run ``final_gait`` at (the robot's, unless ``optimize_period``).
    model : object or None
        The model as the run left it (learned from every learned cycle; with the ``"cycles"`` gate
        the last fit): what the next step would have used. Inspect it against a simulator's truth,
        or save it.
    """

    log: pd.DataFrame
    initial_gait: FourierGait
    final_gait: FourierGait
    gaits: list = field(default_factory=list)
    trajectory: Trajectory | None = None
    model: object | None = None
    max_joint_angle: float | None = None
    shape_scale: float | None = None
    direction: np.ndarray | None = None
    cycle_period: float | None = None

    @property
    def n_steps(self) -> int:
        return int(self.log["step"].sum())

    @property
    def n_rejected(self) -> int:
        return int(self.log["rejected"].sum())

    def summary(self, ceiling=None) -> dict:
        """Headline numbers of the run (what ``geogait optimize`` writes to ``summary.json``).

        Measured values average the learned cycles (no settle or rejected cycles) of the seed's
        iteration and of the last one; with a simulator's truth also the true displacement per cycle
        of the seed and final gaits and the largest |net rotation| of any commanded gait; with a
        ``ceiling`` (:class:`~geogait.optimize.Ceiling`) its value, the final share of it and the
        first cycle at 90 %. Non-finite values become ``None`` (valid JSON).
        """
        log = self.log
        measured = log[~log["settling"] & ~log["rejected"]]
        if "candidate" in measured:  # the result is the last gait that was not an unjudged climb candidate
            measured = measured[~measured["candidate"].astype(bool)]
        seed_rows = measured["iteration"] == 0
        final_rows = measured["iteration"] == measured["iteration"].iloc[-1]
        seed = measured.loc[seed_rows, "measured_objective"].mean()
        final = measured.loc[final_rows, "measured_objective"].mean()
        # per second: the same ratio at a fixed period, the objective's own with optimize_period
        periods = measured["cycle_period"] if "cycle_period" in measured else pd.Series(1.0, measured.index)
        seed_rate = (measured["measured_objective"] / periods)[seed_rows].mean()
        final_rate = (measured["measured_objective"] / periods)[final_rows].mean()
        summary = {
            "seed_measured_objective": _finite(seed),
            "final_measured_objective": _finite(final),
            "final_measured_improvement": _finite(final_rate / seed_rate - 1),
            "seed_cycle_period": _finite(periods[seed_rows].mean()),
            "final_cycle_period": _finite(periods[final_rows].mean()),
            "steps": self.n_steps,
            "rejected_steps": self.n_rejected,
            "reverted_to_best": int(self.log["reverted"].sum()) if "reverted" in self.log else 0,
            "max_tracking_error_rad": _finite(log["tracking_error"].max()),
            "max_joint_angle": _finite(self.max_joint_angle),
            "shape_scale": _finite(self.shape_scale),
            "forward_direction": None if self.direction is None else [float(v) for v in self.direction],
            "final_gait_params": self.final_gait.params.tolist(),
        }
        if "true_objective" in log:
            summary.update({
                "seed_displacement_per_cycle": _finite(log["true_objective"].iloc[0]),
                "final_displacement_per_cycle": _finite(log["true_objective"].iloc[-1]),
                "final_improvement": _finite(log["improvement"].iloc[-1]),
                "max_abs_rotation_of_commanded_gaits": _finite(np.abs(log["true_heading"]).max()),
            })
        if ceiling is not None:
            first_90 = log.index[log["ceiling_fraction"] >= 0.9]
            summary.update({
                "ceiling_displacement_per_cycle": ceiling.value,
                "final_ceiling_fraction": _finite(log["ceiling_fraction"].iloc[-1]),
                "first_cycle_at_90_percent_of_ceiling": int(log["cycle"][first_90[0]]) if len(first_90) else None,
            })
        return summary


def _finite(value):
    return None if value is None or not np.isfinite(value) else float(value)


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
        4 and 8 joints: the filters must remember more samples when they have more weights).
    gate : {"gamma", "cycles"}, optional
        ``"gamma"`` (paper): a step as soon as the online Γ over the current iteration reaches
        ``gamma_threshold``. ``"cycles"`` (Bittner et al. 2018): ``cycles_per_iteration`` cycles,
        then ``model.fit`` on them, then a step. Default ``"gamma"`` for models with an online Γ,
        else ``"cycles"``.
    gamma_threshold : float
        Γ* (default 1/2).
    order : int
        Fourier order of the gait family optimised (the seed is embedded in it).
    family : {"auto", "free", "symmetric"}
        Gait family searched. ``"symmetric"``: the front–back symmetric, rotation-free family about
        the seed's symmetry phase (the seed must be a member). ``"auto"`` (default): symmetric when
        the robot declares the symmetry (a truthy ``front_back_symmetric`` attribute, or a simulated
        :class:`~geogait.systems.PurcellSwimmer` whose link lengths read the same from both ends)
        and the seed gait is a member; free otherwise.
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
        Largest RMS realised − commanded shape error (rad) of an accepted gait. ``"auto"``: twice the
        seed gait's own mean tracking error over its measured cycles, at least 0.05 rad. ``None`` disables the check.
    prediction_tolerance : float or None
        Largest relative difference between the model's predicted objective of the current gait and
        its mean measured objective for the gate to open. ``None`` disables the check.
    optimize_period : bool
        Make the cycle period a decision variable and the objective a rate (per second): gait steps
        from the model alternate with period trials judged on measured outcomes
        (a measured line search on log T, module :mod:`geogait.optimize._period`), within ``period_range`` and
        ``max_joint_velocity``. Needs a robot with ``set_cycle_period`` (e.g.
        :class:`~geogait.robots.MujocoRobot`). Default False: the robot's period is kept.
    period_range : tuple of 2 floats, optional
        (shortest, longest) period in seconds for ``optimize_period``; default half to twice the
        robot's period.
    climb : bool
        When measured outcomes contradict the model — two broken promises in a row (a promised gain
        of at least 1 % unconfirmed at the smallest trust radius, or a revert to the best gait), its
        prediction check failed twice in a row, or cycles without exploration — or when the model
        has levelled off (three gate decisions in a row without a step promising 1 %), take steps from the
        measured outcomes instead (a mirrored (1+1) evolution strategy in the same family and limits,
        module :mod:`geogait.optimize._climb`), and return to model steps once the model predicts
        the measured gains again. Default True.
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
        "family": Options(("auto", "free", "symmetric")),
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
        "climb": Boolean(),
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
                 optimize_period: bool = False, period_range=None, climb: bool = True, exploration="auto",
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
        self.exploration = exploration
        self.random_state = random_state

    # -- scikit-learn protocol (get_params, set_params, repr: Estimator) ---------------------
    def describe(self) -> dict:
        """Hyper-parameters as JSON values (the model as its class name and parameters)."""
        return _params_to_json(self)

    def _check_param_combinations(self) -> None:
        owner = "InSituOptimizer"
        if self.gate == "gamma" and not _has_online_gamma(self._model_template()):
            raise fail("gate", owner, "'cycles' for a model without an online Γ (gamma_, reset_gamma)", self.gate)
        if self.model is not None:
            needs = ("get_params", "predict_displacement") + (
                ("partial_fit", "rebase") if self._gate() == "gamma" else ("fit",))
            for member in needs:
                if not hasattr(self.model, member):
                    raise fail("model", owner, f"a gait model with {member}() (e.g. AdaptiveGaitModel)", self.model)
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
            last) with everything needed by :meth:`resume`: hyper-parameters, model, gait, trust
            radius, log, and the robot's own state when it offers ``robot_state()``.
        checkpoint_every : int
        checkpoint_tag : dict, optional
            JSON values stored in the checkpoint as ``tag`` and kept by :meth:`resume` (the CLI's run
            identity: a resume can check that the checkpoint is the run it means).
        """
        self.validate()
        owner = "InSituOptimizer.run"
        n_cycles = check_int(n_cycles, "n_cycles", owner, minimum=1)
        checkpoint_every = check_int(checkpoint_every, "checkpoint_every", owner, minimum=1)
        if ceiling is not None:
            ceiling = check_float(ceiling, "ceiling", owner, low=0, low_open=True)
        checkpoint = _checkpoint_path(checkpoint, owner)
        template = self._model_template()
        if checkpoint is not None and not getattr(template, "can_save", lambda: True)():
            raise fail("checkpoint", owner, f"None for a {type(template).__name__}, which cannot be saved",
                       str(checkpoint))
        check_robot(robot, owner)
        period = check_float(robot.cycle_period, "robot.cycle_period", owner, low=0, low_open=True)
        gait = robot.gait.with_order(self.order)
        r_max = self._joint_limit(robot, owner)
        if gait.joint_limit().max() > r_max + 1e-12:
            raise fail("robot", owner, f"a seed gait within max_joint_angle = {r_max:.4g}",
                       f"a gait reaching {gait.joint_limit().max():.4g} rad")
        if self.max_joint_velocity is not None:
            speed = _peak_phase_speed(gait) * 2 * np.pi / period
            if speed > self.max_joint_velocity * (1 + 1e-9):
                raise fail("robot", owner, f"a seed gait within max_joint_velocity = {self.max_joint_velocity:.4g}",
                           f"a gait reaching {speed:.4g} rad/s")
        period_range = self._period_range(robot, period, owner)
        excites = self._excites(robot, owner)
        family = self._family(robot, gait)
        feasibility = _feasibility(robot, gait, self.order)
        if feasibility is not None and feasibility(gait.params)[0].min() < 0:
            raise fail("robot", owner, "a seed gait inside the system's feasible region (its singular set's "
                       "margin; e.g. the system's own seed_gait())", "a seed gait that leaves it")
        robot.set_gait(gait)
        scale = self._shape_scale(gait)
        state = _State(gait=gait, radius=self.trust_radius * scale, model=self._new_model(gait, period, family, scale),
                       n_cycles=n_cycles, ceiling=ceiling, period=period, family=family,
                       settle_left=self.settle_cycles, max_joint_angle=r_max, scale=scale,
                       feasibility=feasibility, robot_period=period, seed_period=period,
                       period_search=PeriodSearch(*period_range) if period_range is not None else None,
                       climb=self._new_climb(scale), rng=np.random.default_rng(self.random_state))
        if excites:
            state.exploration = Exploration(self._exploration_std() * scale, gait.n_joints, state.rng)
        return _Loop(self, robot, state, checkpoint, checkpoint_every, checkpoint_tag).run(callback, record)

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
        path = Path(checkpoint)
        metadata, arrays = read_state(path, "checkpoint", CHECKPOINT_FORMAT, CHECKPOINT_VERSION)
        try:
            optimizer = cls(**_params_from_json(metadata["params"])).validate()
            state = _State.from_checkpoint(metadata, arrays)
        except (KeyError, TypeError, ValueError, IndexError) as error:
            raise GeogaitError(f"{path} is an inconsistent optimiser checkpoint: {error}") from None
        if state.model is None:  # not fitted yet when saved (the "cycles" gate's first iteration)
            state.model = optimizer._new_model(state.gait, state.period, state.family,
                                               optimizer._shape_scale(state.gaits[0]))
        check_robot(robot, "InSituOptimizer.resume")
        if robot.gait.n_joints != state.gait.n_joints:
            raise fail("robot", "InSituOptimizer.resume", f"a robot with {state.gait.n_joints} joints",
                       robot.gait.n_joints)
        state.max_joint_angle = optimizer._joint_limit(robot, "InSituOptimizer.resume")
        state.scale = optimizer._shape_scale(state.gaits[0])
        if state.climb is None:  # checkpoints before the climb
            state.climb = optimizer._new_climb(state.scale)
        if "rng" not in metadata["state"]:
            state.rng = np.random.default_rng(optimizer.random_state)
        state.feasibility = _feasibility(robot, state.gait, optimizer.order)
        if n_cycles is not None:
            state.n_cycles = check_int(n_cycles, "n_cycles", "InSituOptimizer.resume", minimum=max(1, state.cycle))
        robot_state = metadata.get("robot_state")
        if robot_state is not None and hasattr(robot, "restore_robot_state"):
            robot.restore_robot_state({**robot_state, **_prefixed(arrays, "robot/")})
        else:
            robot.set_gait(state.robot_gait)
            if state.period_search is not None and robot.cycle_period != state.robot_period:
                robot.set_cycle_period(state.robot_period)
        loop = _Loop(optimizer, robot, state, path, metadata["checkpoint_every"], metadata.get("tag"))
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
        """The family searched (``family`` parameter): SymmetricGaitFamily about the seed or FreeGaitFamily."""
        if self.family == "free" or gait.n_joints < 2:
            if self.family == "symmetric":
                raise fail("family", "InSituOptimizer.run", "'free' for a robot with one joint", self.family)
            return FreeGaitFamily(gait.n_joints, self.order)
        symmetric = SymmetricGaitFamily.from_gait(gait, self.order)
        member = symmetric.residual(gait) <= 1e-9
        if self.family == "symmetric":
            if not member:
                raise fail("robot", "InSituOptimizer.run", "a seed gait with front-back symmetry for family "
                           "'symmetric'", f"a gait at distance {symmetric.residual(gait):.3g} from the family")
            return symmetric
        return symmetric if member and _declares_symmetry(robot) else FreeGaitFamily(gait.n_joints, self.order)

    # -- model --------------------------------------------------------------------------------
    def _model_template(self):
        # both default models offer the same protocol (online Γ, partial_fit, rebase, saving)
        return self.model if self.model is not None else AdaptiveGaitModel()

    def _new_model(self, gait: FourierGait, period: float, family=None, scale: float = 1.0):
        if self.model is None:
            if isinstance(family, SymmetricGaitFamily):
                return symmetric_chain_model(gait.n_joints, shape_scale=scale)
            return AdaptiveGaitModel(gait=gait, forgetting_factor=1 - 0.1 / gait.n_joints,
                                     phase_rate=2 * np.pi / period)
        params = self.model.get_params(deep=False)
        params.update({k: v for k, v in (("gait", gait), ("phase_rate", 2 * np.pi / period)) if k in params})
        return type(self.model)(**params)

    def _new_climb(self, scale: float) -> MeasuredClimb:
        return MeasuredClimb(sigma=self.max_trust_radius * scale, min_sigma=self.min_trust_radius * scale,
                             max_sigma=4 * self.max_trust_radius * scale)

    def _gate(self) -> str:
        if self.gate is not None:
            return self.gate
        return "gamma" if _has_online_gamma(self._model_template()) else "cycles"

    # -- one step -----------------------------------------------------------------------------
    def _direction(self, state) -> np.ndarray | None:
        """Unit direction of ``"forward"`` in the body frame at the start of the latest cycle."""
        if self.objective != "forward":
            return None
        u = state.direction
        if self.direction_frame == "world":
            c, s = np.cos(state.world_heading), np.sin(state.world_heading)
            u = np.array([c * u[0] + s * u[1], -s * u[0] + c * u[1]])
        return u

    def _evaluate(self, pose, pose_jacobian, gait, state):
        return objective(self.objective, pose, pose_jacobian, gait, self._direction(state))

    def _predict(self, state, gait, jacobian=False):
        if not jacobian:
            pose = state.model.predict_displacement(gait)
            return pose, self._evaluate(pose, np.zeros((3, gait.params.size)), gait, state)[0]
        pose, pose_jacobian = state.model.predict_displacement(gait, jacobian=True)
        return pose, pose_jacobian, *self._evaluate(pose, pose_jacobian, gait, state)

    def _limits(self, state):
        speed = None if self.max_joint_velocity is None else self.max_joint_velocity * state.period / (2 * np.pi)
        return joint_limit_constraints(state.gait.n_joints, self.order, state.max_joint_angle, speed)

    def _step(self, state) -> bool:
        """Propose, check and (maybe) take a step; returns whether the gait changed.

        A predicted rotation beyond twice its standard error is real: the step brings it to zero.
        One within it cannot be told from noise: the step then keeps the predicted rotation where it
        is (J_ω Δ = 0) instead of chasing it, and is taken only for a predicted gain of at least
        ``min_gain``.
        """
        gait, family = state.gait, state.family
        problem = StepProblem(state.model.predict_displacement, family, objective=self.objective,
                              limits=self._limits(state), rotation_tolerance=self.rotation_tolerance,
                              direction=self._direction(state), feasibility=state.feasibility)
        params = family.params_of(gait, tolerance=1e-8)
        value, _, pose, _ = problem.evaluate(params)
        state.update_radius(value, self.min_trust_radius * state.scale, self.max_trust_radius * state.scale)
        state.last_prediction = value
        if self.climb and state.distrust >= 2:  # promised gains unconfirmed at the smallest radius
            return False
        restores = False
        target = 0.0
        if problem.rotation:
            resolution = 2 * state.rotation_std()
            restores = abs(pose[2]) > max(self.rotation_tolerance, resolution)
            target = 0.0 if restores else pose[2]
        step = take_step(self.step_rule, problem, params, state.radius, rotation_target=target,
                         min_gain=self.min_gain, restore=restores)
        if step.accepted:
            state.promised = (value, step.predicted_value, step.boundary)
            self._change_gait(state, step.gait)
            return True
        if restores:  # the model could not find a feasible restoring step: trust it less far
            state.radius = max(self.min_trust_radius * state.scale, state.radius / 2)
        return False

    def _change_gait(self, state, gait, period=None) -> None:
        """Re-centre the model on ``gait`` (a fresh model at a new ``period``) and start a new iteration."""
        period = state.period if period is None else float(period)
        if period != state.period:  # another period: what was learned need not hold (dynamics)
            state.promised = None
            state.model = self._new_model(gait, period, state.family, state.scale)
        elif self._gate() == "cycles" or not getattr(state.model, "__sklearn_is_fitted__", lambda: True)():
            # (not fitted yet: a fresh model whose first cycles were all settling or rejected)
            state.model = self._new_model(gait, state.period, state.family, state.scale)
        else:
            state.model.rebase(gait, terms=self.rebase, covariance_inflation=self.covariance_inflation,
                               constant_variance=self.constant_variance)
            state.model.reset_gamma()
        state.previous_gait, state.gait = state.gait, gait
        state.previous_period, state.period = state.period, period
        state.iteration += 1
        state.restart_iteration()
        state.settle_left = self.settle_cycles


def _peak_phase_speed(gait: FourierGait) -> float:
    """Largest |θ_j'(φ)| of ``gait`` (shape units per radian of phase) on a 256-point phase grid."""
    return float(np.abs(gait.velocity(np.linspace(0, 2 * np.pi, 256, endpoint=False))).max())


def _is_numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def symmetric_chain_model(n_joints: int, shape_scale: float = 1.0):
    """The default model where the optimiser searches the rotation-free symmetric family.

    :class:`~geogait.models.ShapeSpaceModel` of degree 4 with the chain's mirror and front–back
    symmetries in its basis and each higher degree shrunk 30× (paper Fig. 5's model), forgetting
    factor 0.999 up to 4 joints and 0.9999 beyond (more weights need a longer memory). On the
    built-in 5- and 9-link swimmers it reaches 95–96 % and 71–74 % of the ceiling in 30–60 cycles,
    against 85–91 % and 59–64 % for the local window model (``make bench-robots``).

    Parameters
    ----------
    n_joints : int
        Shape dimension d.
    shape_scale : float
        The model's unit of shape (the optimiser passes its own ``shape_scale``).

    Returns
    -------
    ShapeSpaceModel
    """
    return models.ShapeSpaceModel(degree=4, degree_shrinkage=30.0, symmetry="mirror+reversal",
                                  forgetting_factor=0.999 if n_joints <= 4 else 0.9999, shape_scale=shape_scale)


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


def _feasibility(robot, gait: FourierGait, order: int):
    """The feasible region of a simulator's system (``current_system()``) as step constraints, or None."""
    system = robot.current_system() if hasattr(robot, "current_system") else None
    return None if system is None else feasibility_constraint(system, gait.n_joints, order)


def _has_online_gamma(model) -> bool:
    return hasattr(model, "reset_gamma") and hasattr(type(model), "gamma_") and hasattr(model, "partial_fit")


# -- measuring a cycle --------------------------------------------------------------------------
@dataclass(frozen=True)
class CycleMeasurement:
    """What one cycle of a robot tells about its gait, from its own samples.

    Parameters
    ----------
    net : ndarray of shape (3,)
        Net motion (x, y, heading) over the cycle, in the body frame at its start.
    start : ndarray of shape (3,)
        World pose at the start of the cycle.
    tracking_error : float
        RMS realised − commanded shape over the cycle (shape units).
    excitation : float
        RMS commanded − nominal shape (the exploration the cycle carried), or realised − nominal
        for a robot that does not report ``commanded_shape`` (shape units).
    """

    net: np.ndarray
    start: np.ndarray
    tracking_error: float
    excitation: float = np.nan


def measure_cycle(chunk: Trajectory, gait: FourierGait, period: float, owner: str) -> CycleMeasurement:
    """Net SE(2) motion, start pose and tracking error of one cycle of robot samples.

    The end pose is the last sample's pose advanced by its measured body velocity over one sample
    interval (exact for a zero-order-hold robot such as ``SwimmerStream``). Without
    ``commanded_shape`` the tracking error is measured against the nominal gait θ(φ) itself.

    Parameters
    ----------
    chunk : Trajectory
        One cycle of a robot (``next_cycle()``), without a trial axis.
    gait : FourierGait
        The nominal gait the robot ran.
    period : float
        Seconds per cycle (the last sample's interval is ``period / n``).
    owner : str
        Name used in error messages (who asked).

    Returns
    -------
    CycleMeasurement
    """
    if not isinstance(chunk, Trajectory):
        raise fail("robot", owner, "a next_cycle() returning a geogait.simulate.Trajectory", type(chunk).__name__)
    n, d = chunk.time.shape[-1], gait.n_joints
    if chunk.time.ndim != 1 or n < 4:
        raise fail("robot", owner, "cycles of at least 4 samples without a trial axis",
                   f"time of shape {chunk.time.shape}")
    expected = {"phase": (n,), "shape": (n, d), "shape_velocity": (n, d), "body_velocity": (n, 3), "pose": (n, 3)}
    for name, shape in expected.items():
        value = np.asarray(getattr(chunk, name))
        if value.shape != shape:
            raise fail(f"cycle.{name}", owner, f"an array of shape {shape}", f"shape {value.shape}")
        if not np.all(np.isfinite(value)):
            raise fail(f"cycle.{name}", owner, "finite values", "NaN or inf")
    if not np.all(np.isfinite(chunk.time)) or np.any(np.diff(chunk.time) <= 0):
        raise fail("cycle.time", owner, "strictly increasing finite time stamps (seconds)", chunk.time[:5])
    dt = period / n
    end = se2.compose(chunk.pose[-1], se2.exp(chunk.body_velocity[-1] * dt))
    nominal = gait.shape(chunk.phase)
    commanded = chunk.commanded_shape if chunk.commanded_shape is not None else nominal
    error = float(np.sqrt(np.mean((chunk.shape - commanded) ** 2)))
    excited = commanded if chunk.commanded_shape is not None else chunk.shape
    return CycleMeasurement(net=se2.between(chunk.pose[0], end), start=np.array(chunk.pose[0], dtype=float),
                            tracking_error=error, excitation=float(np.sqrt(np.mean((excited - nominal) ** 2))))


# -- the run ------------------------------------------------------------------------------------
@dataclass
class _State:
    """Everything a run carries from cycle to cycle (and saves in its checkpoint)."""

    gait: FourierGait
    radius: float
    model: object
    n_cycles: int
    ceiling: float | None
    period: float
    cycle: int = 0
    iteration: int = 0
    cycles_in_iteration: int = 0
    settle_left: int = 0
    last_prediction: float = np.nan
    promised: tuple | None = None  # (value before the step, predicted value after, at the boundary)
    previous_gait: FourierGait | None = None
    robot_gait: FourierGait | None = None  # gait the robot runs next
    iteration_data: list = field(default_factory=list)  # the "cycles" gate's samples of this iteration
    iteration_measured: list = field(default_factory=list)  # measured objective of this iteration's cycles
    residual_variance: float = np.nan  # recent mean squared a-priori error of ω
    gamma: float = np.nan
    direction: np.ndarray | None = None
    world_heading: float = 0.0
    tracking_limit: float = np.nan
    seed_measured: list = field(default_factory=list)
    seed_tracking: list = field(default_factory=list)  # tracking errors of the seed's measured cycles
    seed_value: float = np.nan  # true objective of the seed (oracle), NaN without one
    rows: list = field(default_factory=list)
    gaits: list = field(default_factory=list)
    family: object = None  # FreeGaitFamily or SymmetricGaitFamily searched
    measured: dict = field(default_factory=dict)  # gait -> measured objective of each of its learned cycles
    feasibility: object = None  # the system's feasible region as step constraints (None: none declared)
    seed_nets: list = field(default_factory=list)  # the seed's measured motion per cycle, direction frame
    direction_fixed: bool = False  # "forward" fixed (given, or from all the seed's cycles at the first gate)
    max_joint_angle: float = 2 * np.pi / 3  # r_max in force (resolved from the robot for "auto")
    scale: float = 1.0  # the robot's unit of shape (shape_scale)
    robot_period: float = np.nan  # period the robot runs next (s)
    previous_period: float = np.nan
    seed_period: float = np.nan
    period_search: PeriodSearch | None = None  # optimize_period's line search (None: period fixed)
    trial_tracking: list = field(default_factory=list)  # tracking errors of a period trial's cycles
    climb: MeasuredClimb | None = None  # steps from measured outcomes (the climb parameter)
    rng: np.random.Generator | None = None  # the climb's directions
    distrust: int = 0  # ratio tests failed in a row at the smallest trust radius
    prediction_failures: int = 0  # prediction checks failed in a row
    stall: int = 0  # gate decisions in a row whose model step was declined or promised under 1 %
    rotations: dict = field(default_factory=dict)  # (gait, period) -> measured net rotation of each learned cycle
    exploration: Exploration | None = None  # the optimiser's own excitation (None: the robot's)
    excitation_next: tuple | None = None  # (δ, δ̇) commanded for the next cycle (re-sent on resume)
    iteration_excitation: list = field(default_factory=list)  # excitation RMS of this iteration's cycles
    warned_no_excitation: bool = False

    def rate(self, period: float) -> float:
        """Factor from an objective per cycle to the one compared across gaits: 1/T when the period is
        optimised (a rate), else 1."""
        return 1.0 / period if self.period_search is not None else 1.0

    def restart_iteration(self):
        self.cycles_in_iteration = 0
        self.iteration_data = []
        self.iteration_measured = []
        self.iteration_excitation = []

    def learn(self, chunk, gate):
        self.cycles_in_iteration += 1
        args = (chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
        if gate == "cycles":
            self.iteration_data.append(args)
            return
        self.model.partial_fit(*args)
        error = float(np.mean((self.model.prior_prediction_[..., 2] - chunk.body_velocity[..., 2]) ** 2))
        previous = self.residual_variance
        self.residual_variance = error if np.isnan(previous) else 0.8 * previous + 0.2 * error
        if self.iteration > 0 and self.cycles_in_iteration == 1:
            self.model.reset_gamma()  # the fresh baseline has now seen the new gait once
            self.gamma = np.nan
        else:
            self.gamma = float(self.model.gamma_)

    def fit_iteration(self):
        """The ``"cycles"`` gate: fit the model on this iteration's cycles from scratch."""
        self.model.fit(*(np.concatenate(parts) for parts in zip(*self.iteration_data, strict=True)))

    def rotation_std(self) -> float:
        """Standard error of the model's predicted net rotation of its own nominal gait.

        At δ = 0 the predicted rotation is ≈ Σ_m C_m,ω · 2π / (M φ̇) (the smoothed constant terms'
        mean over a cycle), so its variance is ≈ σ_ω² (2π / (M φ̇))² Σ_m P_m[0, 0], with σ_ω² the
        recent mean squared a-priori error of ω. Only a predicted rotation beyond twice this is
        treated as real and restored. Models without RLS covariances report 0.
        """
        if hasattr(self.model, "rotation_std"):  # models that know their own error (ShapeSpaceModel)
            return float(self.model.rotation_std(self.gait, self.residual_variance)) \
                if np.isfinite(self.residual_variance) else np.inf
        covariance = getattr(self.model, "covariance_", None)
        if covariance is None or not hasattr(self.model, "phase_rate"):
            return 0.0
        if not np.isfinite(self.residual_variance):
            return np.inf
        p00 = covariance[..., 0, 0]
        scale = 2 * np.pi / (p00.shape[-1] * self.model.phase_rate)
        return float(np.sqrt(self.residual_variance * p00.sum()) * scale)

    def update_radius(self, value_now, low, high):
        """Ratio test: compare the gain the last step promised with what the new model sees."""
        if self.promised is None:
            return
        before, promised, boundary = self.promised
        ratio = (value_now - before) / (promised - before) if promised != before else 1.0
        # a promise worth checking (at least 1 %) broken at the smallest radius: the model misleads
        significant = abs(promised - before) >= 0.01 * abs(before)
        self.distrust = self.distrust + 1 if ratio < 0.25 and significant and self.radius <= low * (1 + 1e-12) \
            else 0
        if ratio < 0.25:
            self.radius = max(low, self.radius / 2)
        elif ratio > 0.75 and boundary:
            self.radius = min(high, self.radius * 1.5)
        self.promised = None

    # -- checkpoint ---------------------------------------------------------------------------
    _SCALARS = ("radius", "n_cycles", "ceiling", "period", "cycle", "iteration", "cycles_in_iteration",
                "settle_left", "last_prediction", "residual_variance", "gamma", "world_heading", "tracking_limit",
                "seed_value")
    _PERIOD_SCALARS = ("robot_period", "previous_period", "seed_period")  # newer than the checkpoint format
    _COUNTERS = ("distrust", "prediction_failures", "stall")

    def to_checkpoint(self) -> tuple[dict, dict]:
        metadata = {name: _json_float(getattr(self, name)) for name in self._SCALARS + self._PERIOD_SCALARS}
        metadata["period_search"] = None if self.period_search is None else self.period_search.to_json()
        metadata.update({name: int(getattr(self, name)) for name in self._COUNTERS})
        metadata["rng"] = self.rng.bit_generator.state
        climb = self.climb
        metadata["climb"] = {"sigma": climb.sigma, "min_sigma": climb.min_sigma, "max_sigma": climb.max_sigma,
                             "active": climb.active, "mirror": climb.mirror, "failures": climb.failures,
                             "agreements": climb.agreements, "predicted_gain": _json_float(climb.predicted_gain),
                             "rotation_limit": _json_float(climb.rotation_limit),
                             "base_period": None if climb.base is None else climb.base[1],
                             "candidate_period": None if climb.candidate is None else climb.candidate[1]}
        metadata["promised"] = None if self.promised is None else [float(v) for v in self.promised]
        family = self.family
        metadata["family"] = {"kind": "symmetric" if isinstance(family, SymmetricGaitFamily) else "free",
                              "n_joints": family.n_joints, "order": family.order,
                              "center": float(getattr(family, "center", 0.0))}
        arrays = {"gait": self.gait.coefficients, "robot_gait": self.robot_gait.coefficients,
                  "iteration_measured": np.asarray(self.iteration_measured, dtype=float),
                  "seed_measured": np.asarray(self.seed_measured, dtype=float),
                  "seed_tracking": np.asarray(self.seed_tracking, dtype=float),
                  "gaits": np.stack([g.coefficients for g in self.gaits])}
        arrays.update(_pack_records("measured", self.measured, self.rotations))
        arrays.update(_pack_records("climb/measured", self.climb.measured, self.climb.rotations))
        for name, value in (("climb/base", self.climb.base), ("climb/candidate", self.climb.candidate)):
            if value is not None:
                arrays[name] = value[0].coefficients
        if self.climb.direction is not None:
            arrays["climb/direction"] = self.climb.direction
        if self.previous_gait is not None:
            arrays["previous_gait"] = self.previous_gait.coefficients
        if self.direction is not None:
            arrays["direction"] = self.direction
        if self.seed_nets:
            arrays["seed_nets"] = np.asarray(self.seed_nets, dtype=float)
        if self.trial_tracking:
            arrays["trial_tracking"] = np.asarray(self.trial_tracking, dtype=float)
        arrays["iteration_excitation"] = np.asarray(self.iteration_excitation, dtype=float)
        metadata["warned_no_excitation"] = bool(self.warned_no_excitation)
        if self.exploration is not None:
            metadata["exploration_std"] = self.exploration.std
            arrays["exploration/state"] = self.exploration.state
            arrays["exploration/next_shape"], arrays["exploration/next_shape_velocity"] = self.excitation_next
        metadata["direction_fixed"] = bool(self.direction_fixed)
        for k, parts in enumerate(self.iteration_data):
            for name, value in zip(("phase", "shape", "shape_velocity", "body_velocity"), parts, strict=True):
                arrays[f"iteration_data/{k}/{name}"] = value
        frame = pd.DataFrame(self.rows)
        for column in frame.columns:
            arrays[f"log/{column}"] = frame[column].to_numpy()
        metadata["log_columns"] = list(frame.columns)
        metadata["iteration_data"] = len(self.iteration_data)
        return metadata, arrays

    @classmethod
    def from_checkpoint(cls, metadata: dict, arrays: dict) -> _State:
        scalars = metadata["state"]
        state = cls(gait=FourierGait(arrays["gait"]), radius=0.0, model=None, n_cycles=1, ceiling=None,
                    period=1.0)
        for name in cls._SCALARS:
            value = scalars[name]
            setattr(state, name, np.nan if value is None and name not in ("ceiling",) else value)
        for name in cls._PERIOD_SCALARS:  # checkpoints before the period could change: the one period
            value = scalars.get(name, state.period)
            setattr(state, name, np.nan if value is None else value)
        search = scalars.get("period_search")
        state.period_search = None if search is None else PeriodSearch.from_json(search)
        for name in cls._COUNTERS:
            setattr(state, name, int(scalars.get(name, 0)))
        state.rng = np.random.default_rng()
        if scalars.get("rng") is not None:
            state.rng.bit_generator.state = scalars["rng"]
        climb = scalars.get("climb")
        if climb is not None:
            state.climb = MeasuredClimb(
                sigma=climb["sigma"], min_sigma=climb["min_sigma"], max_sigma=climb["max_sigma"],
                active=climb["active"], mirror=climb["mirror"], failures=climb["failures"],
                agreements=climb["agreements"],
                predicted_gain=np.nan if climb["predicted_gain"] is None else climb["predicted_gain"],
                rotation_limit=np.nan if climb.get("rotation_limit") is None else climb["rotation_limit"],
                base=None if climb["base_period"] is None
                else (FourierGait(arrays["climb/base"]), climb["base_period"]),
                candidate=None if climb["candidate_period"] is None
                else (FourierGait(arrays["climb/candidate"]), climb["candidate_period"]),
                direction=arrays.get("climb/direction"))
        state.n_cycles, state.cycle = int(state.n_cycles), int(state.cycle)
        promised = scalars["promised"]
        state.promised = None if promised is None else (*promised[:2], bool(promised[2]))
        state.robot_gait = FourierGait(arrays["robot_gait"])
        family = scalars.get("family") or {"kind": "free", "n_joints": state.gait.n_joints, "order": state.gait.order}
        state.family = (SymmetricGaitFamily(family["n_joints"], family["order"], family["center"])
                        if family["kind"] == "symmetric" else FreeGaitFamily(family["n_joints"], family["order"]))
        state.previous_gait = FourierGait(arrays["previous_gait"]) if "previous_gait" in arrays else None
        state.direction = arrays.get("direction")
        # checkpoints before the averaged direction fixed it at the first measured cycle
        state.direction_fixed = bool(scalars.get("direction_fixed", state.direction is not None))
        state.seed_nets = list(arrays["seed_nets"]) if "seed_nets" in arrays else []
        state.trial_tracking = arrays["trial_tracking"].tolist() if "trial_tracking" in arrays else []
        state.iteration_excitation = arrays["iteration_excitation"].tolist() if "iteration_excitation" in arrays else []
        state.warned_no_excitation = bool(scalars.get("warned_no_excitation", False))
        if scalars.get("exploration_std") is not None:
            state.exploration = Exploration(scalars["exploration_std"], state.gait.n_joints, state.rng,
                                            initial_state=np.array(arrays["exploration/state"], dtype=float))
            state.excitation_next = (np.array(arrays["exploration/next_shape"], dtype=float),
                                     np.array(arrays["exploration/next_shape_velocity"], dtype=float))
        state.iteration_measured = arrays["iteration_measured"].tolist()
        state.seed_measured = arrays["seed_measured"].tolist()
        state.seed_tracking = arrays["seed_tracking"].tolist()
        state.gaits = [FourierGait(c) for c in arrays["gaits"]]
        state.measured, state.rotations = _unpack_records("measured", arrays, state.period)
        if state.climb is not None:
            state.climb.measured, state.climb.rotations = _unpack_records("climb/measured", arrays, state.period)
        names = ("phase", "shape", "shape_velocity", "body_velocity")
        state.iteration_data = [tuple(arrays[f"iteration_data/{k}/{n}"] for n in names)
                                for k in range(scalars["iteration_data"])]
        columns = scalars["log_columns"]
        state.rows = pd.DataFrame({c: arrays[f"log/{c}"] for c in columns}).to_dict("records")
        if metadata["model"] is not None:
            state.model = model_from_state(metadata["model"]["metadata"], _prefixed(arrays, "model/"))
        return state


def _pack_records(prefix: str, values: dict, rotations: dict) -> dict:
    """Arrays of a record {(gait, period): [value per cycle]} and its rotations (a checkpoint's)."""
    if not values:
        return {}
    return {f"{prefix}/gaits": np.stack([g.coefficients for g, _ in values]),
            f"{prefix}/periods": np.array([period for _, period in values], dtype=float),
            f"{prefix}/counts": np.array([len(v) for v in values.values()]),
            f"{prefix}/values": np.concatenate([np.asarray(v, dtype=float) for v in values.values()]),
            f"{prefix}/rotations": np.concatenate([np.asarray(rotations[k], dtype=float) for k in values])}


def _unpack_records(prefix: str, arrays: dict, period: float) -> tuple[dict, dict]:
    """Inverse of :func:`_pack_records`; older checkpoints lack periods (the one period) and rotations."""
    if f"{prefix}/gaits" not in arrays:
        return {}, {}
    split = np.cumsum(arrays[f"{prefix}/counts"])[:-1]
    values = np.split(arrays[f"{prefix}/values"], split)
    periods = arrays.get(f"{prefix}/periods", np.full(len(values), period))
    keys = [(FourierGait(c), float(t)) for c, t in zip(arrays[f"{prefix}/gaits"], periods, strict=True)]
    rotations = (np.split(arrays[f"{prefix}/rotations"], split) if f"{prefix}/rotations" in arrays
                 else [np.zeros(0)] * len(values))
    return ({k: v.tolist() for k, v in zip(keys, values, strict=True)},
            {k: r.tolist() for k, r in zip(keys, rotations, strict=True)})


def _json_float(value):
    if isinstance(value, float | np.floating) and not np.isfinite(value):
        return None
    return value.item() if isinstance(value, np.generic) else value


def _prefixed(arrays: dict, prefix: str) -> dict:
    return {k.removeprefix(prefix): v for k, v in arrays.items() if k.startswith(prefix)}


def _checkpoint_path(checkpoint, owner):
    if checkpoint is None:
        return None
    path = Path(checkpoint)
    if path.is_dir() or not path.parent.is_dir():
        raise fail("checkpoint", owner, "a file path in an existing folder", str(path))
    return path


class _Loop:
    """One optimisation run: the per-cycle loop over a robot, with checkpoints."""

    def __init__(self, optimizer, robot, state, checkpoint, checkpoint_every, tag=None):
        self.optimizer, self.robot, self.state, self.tag = optimizer, robot, state, tag
        self.checkpoint, self.checkpoint_every = checkpoint, checkpoint_every
        self.gate = optimizer._gate()
        self.truth = _Oracle(robot, optimizer)
        if not state.gaits:
            state.gaits = [state.gait]
            state.robot_gait = state.gait
            state.seed_value = self.truth(state.gait, state)[1]
            if optimizer.direction is not None:
                direction = np.asarray(optimizer.direction, dtype=float)
                state.direction, state.direction_fixed = direction / np.hypot(*direction), True

    def run(self, callback, record) -> InSituResult:
        state, chunks = self.state, []
        if state.exploration is not None:  # the first cycle's, or the one a checkpoint had commanded
            if state.excitation_next is None:
                self._command_excitation()
            else:
                self.robot.set_excitation(*state.excitation_next)
        while state.cycle < state.n_cycles:
            chunk = self.robot.next_cycle()
            if record:
                chunks.append(chunk)
            row = self._cycle(chunk)
            state.rows.append(row)
            state.cycle += 1
            if callback is not None:
                callback(row)
            due = state.cycle % self.checkpoint_every == 0 or state.cycle == state.n_cycles
            if self.checkpoint is not None and due:
                self._save()
        # a climb candidate not yet judged is not a result: the base it was drawn from is
        final, period = state.gait, state.period
        if state.climb.active and state.climb.candidate is not None:
            final, period = state.climb.base
        elif state.period_search is not None and state.period_search.trial_from is not None:
            period = state.period_search.trial_from
        return InSituResult(log=pd.DataFrame(state.rows), initial_gait=state.gaits[0], final_gait=final,
                            cycle_period=period,
                            gaits=list(state.gaits), model=state.model, max_joint_angle=state.max_joint_angle,
                            shape_scale=state.scale, direction=state.direction,
                            trajectory=Trajectory.concatenate(chunks) if record and chunks else None)

    def _cycle(self, chunk) -> dict:
        optimizer, state = self.optimizer, self.state
        ran, ran_period = state.robot_gait, state.robot_period
        measured = measure_cycle(chunk, ran, ran_period, "InSituOptimizer.run")
        search = state.period_search
        was_trial = search is not None and search.trial_from is not None
        was_candidate = state.climb.candidate == (ran, ran_period)
        state.world_heading = float(measured.start[2])
        settling = state.settle_left > 0
        rejected = reverted = False
        kind, prediction_ok = None, np.nan
        value = np.nan
        if settling:
            state.settle_left -= 1
            state.gamma = np.nan
        else:
            self._set_direction(measured)
            value = optimizer._evaluate(measured.net, np.zeros((3, ran.params.size)), ran, state)[0]
            if state.iteration == 0:
                state.seed_measured.append(value)
                state.seed_tracking.append(measured.tracking_error)
                state.tracking_limit = max(_TRACKING_FLOOR * state.scale, 2 * float(np.mean(state.seed_tracking)))
            rejected = self._tracking_rejects(measured)
            if not rejected:
                state.learn(chunk, self.gate)
                state.iteration_measured.append(value)
                state.iteration_excitation.append(measured.excitation)
                key = (state.gait, state.period)
                if state.climb.active:
                    state.climb.record(key, value * state.rate(state.period), float(measured.net[2]))
                else:
                    state.measured.setdefault(key, []).append(value * state.rate(state.period))
                    state.rotations.setdefault(key, []).append(float(measured.net[2]))
                if not state.climb.active and state.cycles_in_iteration >= optimizer.min_cycles_per_iteration \
                        and self._unexcited() and optimizer.climb:  # (Γ cannot rise without exploration)
                    self._start_climb()
                if self._gate_open():
                    self._fix_direction()
                    reverted = self._measured_reverts()
                if self._gate_open() and not reverted:
                    kind, prediction_ok = self._decide()
        step = kind is not None
        row = self._row(ran, state.gamma if not (settling or rejected) else np.nan, step, rejected, settling,
                        prediction_ok, measured, value, reverted, ran_period)
        row.update(climb=kind == "climb", period_change=kind == "period",
                   candidate=bool(was_candidate and state.climb.base != (ran, ran_period)
                                  or was_trial and not (search.trial_from is None and state.period == ran_period)))
        if step or rejected or reverted:
            state.gaits.append(state.gait)
        state.robot_gait = state.gait
        self.robot.set_gait(state.gait)
        self._command_period()
        self._command_excitation()
        return row

    def _command_excitation(self) -> None:
        """Send the next cycle's excitation when the optimiser owns the exploration (none while climbing)."""
        state = self.state
        if state.exploration is None:
            return
        delta, rate = state.exploration.next_cycle(state.robot_period)
        if state.climb.active:  # the climb measures outcomes: clean cycles, as a black-box method runs them
            delta, rate = np.zeros_like(delta), np.zeros_like(rate)
        state.excitation_next = (delta, rate)
        self.robot.set_excitation(delta, rate)

    def _unexcited(self) -> bool:
        """The current gait's cycles carried no exploration (below 1 % of shape_scale): say so, once."""
        state = self.state
        if not state.iteration_excitation or np.mean(state.iteration_excitation) >= 0.01 * state.scale:
            return False
        if not state.warned_no_excitation:
            warnings.warn(
                f"InSituOptimizer: the robot's cycles carry no exploration (RMS commanded - nominal shape "
                f"{np.mean(state.iteration_excitation):.2g}, below 1 % of shape_scale {state.scale:.3g}); the model "
                "cannot learn the gait's neighbourhood, so it takes no step"
                + (" (the measured climb does)" if self.optimizer.climb else "")
                + ". Give the robot set_excitation (geogait then explores) or a perturbation of its own.",
                GeogaitWarning, stacklevel=4)
            state.warned_no_excitation = True
        return True

    def _decide(self) -> tuple[str | None, float]:
        """The gate is open: a period trial, a model step or a climb step (or none).

        Returns the kind of change made (``"period"``, ``"model"``, ``"climb"`` or None) and the
        prediction check's outcome (NaN when none was made).
        """
        state, optimizer = self.state, self.optimizer
        if self.gate == "cycles":
            state.fit_iteration()
        if state.period_search is not None and not state.climb.active and self._period_move():
            return "period", np.nan
        kind, prediction_ok = None, np.nan
        if not state.climb.active and self._unexcited():
            if optimizer.climb:
                self._start_climb()
        elif not state.climb.active:
            prediction_ok = float(self._prediction_agrees())
            state.prediction_failures = 0 if prediction_ok else state.prediction_failures + 1
            if optimizer.climb and state.stall >= 3:  # the model has levelled off: climb on from here
                self._start_climb()
            elif prediction_ok and optimizer._step(state):
                kind = "model"
            if prediction_ok and not state.climb.active:  # no step, or one promising under 1 %: level
                before, promised = state.promised[:2] if kind == "model" else (0.0, 0.0)
                small = kind is None or abs(promised - before) < 0.01 * abs(before)
                state.stall = state.stall + 1 if small else 0
            if kind is None and optimizer.climb and (state.distrust >= 2 or state.prediction_failures >= 2):
                self._start_climb()
        if kind is None and state.climb.active and self._climb_move():
            kind = "climb"
        if state.period_search is not None:
            state.period_search.turn = True
            if kind is not None:
                state.period_search.gait_changed()
        if kind is None and self.gate == "cycles":  # prior work: another block of cycles, then retry
            state.cycles_in_iteration = 0
        return kind, prediction_ok

    def _command_period(self) -> None:
        """Command the state's period; the robot may round it (its timing), and the run uses what it runs."""
        state = self.state
        if state.period != state.robot_period:
            self.robot.set_cycle_period(state.period)
            realised = float(self.robot.cycle_period)
            if realised != state.period:  # the model was built for the asked period: rebuild it
                if state.climb.candidate == (state.gait, state.period):
                    state.climb.candidate = (state.gait, realised)
                state.period = realised
                state.model = self.optimizer._new_model(state.gait, realised, state.family, state.scale)
        state.robot_period = state.period

    def _start_climb(self, base: tuple | None = None) -> None:
        """Hand the steps to the measured climb, from the best gait measured so far (measured again:
        the climb's cycles carry no exploration when the optimiser owns it). A period trial in
        progress is dropped: while climbing, the period is one of the climb's coordinates."""
        state = self.state
        best = self._best_key() if base is None else base
        state.climb.start(best, self.optimizer.max_trust_radius * state.scale)
        if state.period_search is not None:
            state.period_search.trial_from = None

    def _best_key(self) -> tuple:
        """The (gait, period) with the best mean measured objective (of those measured twice or more)."""
        state = self.state
        current = (state.gait, state.period)
        keys = [k for k, v in state.measured.items() if len(v) >= 2 or k == current]
        return max(keys, key=lambda k: float(np.mean(state.measured[k]))) if keys else current

    def _climb_move(self) -> bool:
        """The climb's turn at a gate decision (:class:`MeasuredClimb`): judge the candidate just measured,
        go back to the base to measure it again after three failures, or command the next candidate;
        returns whether the gait changed."""
        state, optimizer, climb = self.state, self.optimizer, self.state.climb
        key = (state.gait, state.period)
        measured = climb.measured
        if np.isnan(climb.rotation_limit) and climb.base in measured:  # the start base, measured as the climb
            rotation = abs(float(np.mean(climb.rotations[climb.base])))  # measures (clean, when it can)
            climb.rotation_limit = max(rotation, optimizer.rotation_tolerance)
        if climb.candidate is not None:
            if climb.candidate == key and climb.base in measured:
                climb.judge(float(np.mean(measured[key])), float(np.mean(measured[climb.base])),
                            self._rotation_holds(key, climb.base))
                if climb.model_trusted_again:  # back to model steps, from the best gait, on a fresh record
                    climb.active = False
                    state.distrust = state.prediction_failures = state.stall = 0
                    state.radius = optimizer.trust_radius * state.scale
                    state.measured, state.rotations = {}, {}
                    optimizer._change_gait(state, *climb.base)
                    return True
            climb.candidate = None  # a candidate left early (rejected) is not judged
        if climb.base not in measured or (key != climb.base and climb.failures >= 3):
            climb.failures = 0  # measure the base (again: it may have been lucky)
            optimizer._change_gait(state, *climb.base)
            return True
        return self._climb_candidate()

    def _climb_candidate(self) -> bool:
        """Command the climb's next candidate: σ from the base in its next direction, shortened until it
        keeps the joint limits and the feasible region."""
        state, optimizer, climb = self.state, self.optimizer, self.state.climb
        base_gait, base_period = climb.base
        family, search = state.family, state.period_search
        base = family.params_of(base_gait, tolerance=1e-8)
        # with optimize_period, log T is one more coordinate (σ / shape_scale in log units)
        direction = climb.next_direction(state.rng, base.size + (search is not None))
        for shrink in range(6):
            length = climb.sigma * 0.5 ** shrink
            gait = family.gait(base + length * direction[:base.size])
            period = base_period
            if search is not None:
                period = float(np.clip(base_period * np.exp(length * direction[-1] / state.scale),
                                       search.low, search.high))
            speed = None if optimizer.max_joint_velocity is None else \
                optimizer.max_joint_velocity * period / (2 * np.pi)
            rows, bounds = joint_limit_constraints(base_gait.n_joints, optimizer.order, state.max_joint_angle, speed)
            if np.all(rows @ gait.params <= bounds + 1e-12) and (
                    state.feasibility is None or state.feasibility(gait.params)[0].min() >= 0):
                break
        else:
            climb.sigma = max(climb.min_sigma, climb.sigma / 2)
            return False
        climb.predicted_gain = (optimizer._predict(state, gait)[1] * state.rate(period)
                                - optimizer._predict(state, base_gait)[1] * state.rate(base_period))
        climb.candidate = (gait, period)
        optimizer._change_gait(state, gait, period)
        return True

    def _rotation_holds(self, key, base) -> bool:
        """The candidate's mean measured net rotation is within the climb's rotation limit (the start
        base's, fixed) beyond twice its standard error."""
        rotations = np.asarray(self.state.climb.rotations.get(key, []))
        if rotations.size == 0:
            return True
        error = float(np.std(rotations, ddof=1) / np.sqrt(rotations.size)) if rotations.size > 1 else 0.0
        return abs(float(rotations.mean())) <= self.state.climb.rotation_limit + 2 * error

    def _period_move(self) -> bool:
        """The period's turn at a gate decision (``optimize_period``): judge the trial in progress, or
        start the next one; returns whether the period was changed (counted as a step)."""
        state, search = self.state, self.state.period_search
        if search.trial_from is not None:
            reference = state.measured.get((state.gait, search.trial_from))
            origin = search.trial_from
            trial = float(np.mean(state.measured[(state.gait, state.period)]))
            kept = search.judge(trial, float(np.mean(reference)) if reference else -np.inf)
            search.turn = False
            tracking, state.trial_tracking = state.trial_tracking, []
            if kept:  # the automatic tracking limit follows the period: twice what this one tracks
                state.tracking_limit = max(_TRACKING_FLOOR * state.scale, 2 * float(np.mean(tracking)))
                return False
            self.optimizer._change_gait(state, state.gait, origin)
            return True
        if not search.turn:
            return False
        shortest = 0.0  # the period at which the gait's fastest joint reaches max_joint_velocity
        if self.optimizer.max_joint_velocity is not None:
            shortest = _peak_phase_speed(state.gait) * 2 * np.pi / self.optimizer.max_joint_velocity
        period = search.propose(state.period, shortest)
        if period is None:
            search.turn = False
            return False
        search.trial_from = state.period
        state.trial_tracking = []
        self.optimizer._change_gait(state, state.gait, period)
        return True

    def _set_direction(self, measured):
        """The direction of ``"forward"`` (default): the mean motion of the seed's measured cycles.

        Until the first gate decision it is the running mean of the seed's cycles so far (in the
        ``direction_frame``); :meth:`_fix_direction` then fixes it from all of them.
        """
        state = self.state
        if self.optimizer.objective != "forward" or state.direction_fixed:
            return
        net = measured.net[:2]
        if self.optimizer.direction_frame == "world":
            c, s = np.cos(measured.start[2]), np.sin(measured.start[2])
            net = np.array([c * net[0] - s * net[1], s * net[0] + c * net[1]])
        state.seed_nets.append(net)
        mean = np.mean(state.seed_nets, axis=0)
        norm = np.hypot(*mean)
        if norm == 0:
            raise GeogaitError("InSituOptimizer: the seed gait did not move in its measured cycles, so "
                               "objective 'forward' has no direction; pass 'direction' explicitly.")
        state.direction = mean / norm

    def _fix_direction(self) -> None:
        """Fix "forward" from every measured seed cycle, or refuse when their mean motion cannot be told
        from their spread (|mean| < 2 standard errors along it); re-score the seed's cycles with it."""
        state = self.state
        if self.optimizer.objective != "forward" or state.direction_fixed:
            return
        nets = np.asarray(state.seed_nets)
        mean = nets.mean(axis=0)
        norm = float(np.hypot(*mean))
        error = float(np.sqrt(state.direction @ np.cov(nets.T) @ state.direction / len(nets))) if len(nets) > 1 \
            else 0.0
        if norm < 2 * error:
            raise GeogaitError(
                f"InSituOptimizer: the seed gait's mean motion over its {len(nets)} measured cycles "
                f"({norm:.3g} per cycle, standard error {error:.3g}) cannot be told from noise, so objective "
                "'forward' has no direction; pass 'direction' explicitly or start from a gait that moves.")
        state.direction, state.direction_fixed = mean / norm, True
        values = [float(net @ state.direction) for net in nets]  # "forward" of every seed cycle, fixed direction
        state.seed_measured = values
        state.iteration_measured = list(values)
        state.measured[(state.gait, state.period)] = [v * state.rate(state.period) for v in values]

    def _tracking_rejects(self, measured) -> bool:
        """Reject the current gait (back to the previous one) if the robot could not follow it."""
        optimizer, state = self.optimizer, self.state
        search = state.period_search
        if search is not None and search.trial_from is not None:
            state.trial_tracking.append(measured.tracking_error)
            if optimizer.max_tracking_error == "auto":  # another period tracks otherwise: judged by outcome
                return False
        limit = state.tracking_limit if optimizer.max_tracking_error == "auto" else optimizer.max_tracking_error
        if limit is None or state.previous_gait is None or not measured.tracking_error > limit:
            return False
        state.promised = None
        state.radius = max(optimizer.min_trust_radius * state.scale, state.radius / 2)
        if state.climb.candidate == (state.gait, state.period):  # a candidate the robot cannot follow
            state.climb.judge(-np.inf, 0.0, rotation_holds=False)
        previous = state.previous_gait
        optimizer._change_gait(state, previous, state.previous_period)
        if search is not None and search.trial_from is not None:  # a period the robot cannot follow
            search.judge(-np.inf, 0.0)
            search.turn = False
        state.previous_gait = None  # the gait we fall back to was accepted; nothing further back to try
        return True

    def _measured_reverts(self) -> bool:
        """Measured outcomes over the model: go back to the best gait measured so far when the current
        one is worse beyond noise.

        Each gait's learned cycles give its mean measured objective; σ is the pooled cycle-to-cycle
        standard deviation within gaits. When the current gait's mean falls below the best other
        gait's by more than 2 σ √(1/n + 1/n_best), the model's steps have led the robot downhill,
        whatever the model predicts: the best gait is commanded again (its further cycles refine its
        mean, so a lucky best is corrected) and the trust radius halves.
        """
        state, optimizer = self.state, self.optimizer
        if state.iteration == 0 or optimizer.revert_tolerance is None or state.climb.active:
            return False  # (the climb judges its own candidates)
        current = (state.gait, state.period)
        counts = {g: len(v) for g, v in state.measured.items() if len(v) >= 2}
        if current not in counts or len(counts) < 2:
            return False
        means = {g: float(np.mean(state.measured[g])) for g in counts}
        dof = sum(n - 1 for n in counts.values())
        sigma = np.sqrt(sum(np.var(state.measured[g], ddof=1) * (n - 1) for g, n in counts.items()) / dof)
        best = max((g for g in counts if g != current), key=means.get)
        margin = optimizer.revert_tolerance * sigma * np.sqrt(1 / counts[current] + 1 / counts[best])
        if not means[current] < means[best] - margin:
            return False
        state.promised = None
        state.radius = max(optimizer.min_trust_radius * state.scale, state.radius / 2)
        search = state.period_search
        if search is not None and search.trial_from is not None:  # the trial lost beyond noise
            search.judge(-np.inf, 0.0)
            search.turn = False
        optimizer._change_gait(state, *best)
        if not (search is not None and best[0] == current[0]):  # the model led downhill: a broken promise
            state.distrust += 1
        state.previous_gait = None
        return True

    def _gate_open(self) -> bool:
        state = self.state
        if state.climb.active:  # measured outcomes need measured cycles, not a model's confidence:
            # one clean cycle (no exploration: the optimiser owns it) or the usual number
            needed = 1 if state.exploration is not None else self.optimizer.min_cycles_per_iteration
            return state.cycles_in_iteration >= needed
        if self.gate == "cycles":
            return state.cycles_in_iteration >= self.optimizer.cycles_per_iteration
        return (state.cycles_in_iteration >= self.optimizer.min_cycles_per_iteration
                and np.isfinite(state.gamma) and state.gamma >= self.optimizer.gamma_threshold)

    def _prediction_agrees(self) -> bool:
        """Model's predicted objective of the current gait vs the mean measured one (module docstring)."""
        tolerance = self.optimizer.prediction_tolerance
        if tolerance is None:
            return True
        predicted = self.optimizer._predict(self.state, self.state.gait)[1]
        measured = float(np.mean(self.state.iteration_measured))
        return bool(abs(predicted - measured) <= tolerance * abs(measured))

    def _row(self, gait, gamma, step, rejected, settling, prediction_ok, measured, value, reverted, period) -> dict:
        state = self.state
        net = measured.net
        progress = float(np.hypot(net[0], net[1]))
        row = {"cycle": state.cycle, "iteration": state.iteration - int(step) - int(rejected) - int(reverted),
               "settling": settling, "gamma": gamma, "step": step, "rejected": rejected, "reverted": reverted,
               "prediction_ok": prediction_ok,
               "trust_radius": state.radius, "predicted_objective": state.last_prediction,
               "measured_x": net[0], "measured_y": net[1], "measured_heading": net[2],
               "measured_progress": progress, "measured_objective": value,
               "measured_speed": progress / period, "cycle_period": period, "tracking_error": measured.tracking_error,
               "excitation": measured.excitation,
               "world_x": measured.start[0], "world_y": measured.start[1], "world_heading": measured.start[2]}
        pose, true_value = self.truth(gait, state)
        if self.truth.available:
            row.update({"true_x": pose[0], "true_y": pose[1], "true_heading": pose[2],
                        "true_progress": float(np.hypot(pose[0], pose[1])), "true_objective": true_value,
                        "improvement": true_value * state.rate(period)
                        / (state.seed_value * state.rate(state.seed_period)) - 1})
            reference = true_value
        else:
            seed = float(np.mean(state.seed_measured)) if state.seed_measured else np.nan
            row["improvement"] = (value * state.rate(period) / (seed * state.rate(state.seed_period)) - 1
                                  if seed else np.nan)
            reference = value
        if state.ceiling is not None:
            row["ceiling_fraction"] = reference / state.ceiling
        row.update({f"param_{k}": v for k, v in enumerate(gait.params)})
        return row

    def _save(self):
        """Write the checkpoint (one atomic ``.npz``: JSON metadata + arrays)."""
        metadata, arrays = self.state.to_checkpoint()
        model = self.state.model
        model_metadata = None
        if hasattr(model, "get_state") and hasattr(model, "batch_shape_"):  # fitted
            model_metadata, model_arrays = model.get_state()
            arrays.update({f"model/{k}": np.asarray(v) for k, v in model_arrays.items()})
        robot_state = None
        if hasattr(self.robot, "robot_state"):
            robot_state = {}
            for key, value in self.robot.robot_state().items():
                if isinstance(value, np.ndarray):
                    arrays[f"robot/{key}"] = value
                else:
                    robot_state[key] = value
        payload = {"format": CHECKPOINT_FORMAT, "format_version": CHECKPOINT_VERSION, "geogait": __version__,
                   "params": _params_to_json(self.optimizer), "state": metadata,
                   "model": None if model_metadata is None else {"metadata": model_metadata},
                   "robot_state": robot_state, "checkpoint_every": self.checkpoint_every, "tag": self.tag}
        write_state(self.checkpoint, payload, arrays)


def _params_to_json(optimizer) -> dict:
    """Hyper-parameters as JSON values; the model template as its class name and parameters."""
    params = optimizer.get_params(deep=False)
    if params["model"] is not None:
        model = params["model"]
        params["model"] = {"class": type(model).__name__,
                           "params": {k: v for k, v in model.get_params(deep=False).items() if k != "gait"}}
    if params["direction"] is not None:
        params["direction"] = [float(v) for v in np.asarray(params["direction"], dtype=float)]
    return params


def _params_from_json(params: dict) -> dict:
    params = dict(params)
    if params.get("model") is not None:
        name = params["model"]["class"]
        if name not in models.__all__:
            raise ValueError(f"unknown model class {name!r}")
        params["model"] = getattr(models, name)(**params["model"]["params"])
    return params


class _Oracle:
    """True (x, y, heading) and objective per cycle of a gait, when the robot exposes its system."""

    def __init__(self, robot, optimizer):
        self.system = getattr(robot, "current_system", None)
        self.available = self.system is not None
        self.optimizer = optimizer
        self.cache = {}

    def __call__(self, gait, state):
        if self.system is None:
            return np.full(3, np.nan), np.nan
        system = self.system()
        key = (id(system), gait)
        if key not in self.cache:
            self.cache[key] = cycle_displacement(system, gait, resolution=128)
        pose = self.cache[key]
        if self.optimizer.objective == "forward" and state.direction is None:
            return pose, np.nan
        return pose, self.optimizer._evaluate(pose, np.zeros((3, gait.params.size)), gait, state)[0]
