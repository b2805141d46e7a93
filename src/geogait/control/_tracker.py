r"""Path following with a receding-horizon controller on the per-cycle SE(2) motion of steering gaits.

Every cycle boundary :math:`k` the controller knows the robot's pose :math:`g_k` (from the robot's
own poses) and a steering family — for turning rates :math:`\omega_j`, the gait nearest the straight
optimum that turns by :math:`\omega_j` per cycle and its predicted net motion
:math:`m(\omega_j) \in SE(2)` (:mod:`geogait.control._steering`). It predicts the poses of the next
:math:`H` cycles for candidate turn sequences (first turn on a fine grid, then one held turn from
the family, "move blocking"),

.. math:: g_{k+i} = g_{k+i-1}\, m(\omega_i), \qquad m(\omega)\ \text{interpolated between members},

and picks the sequence minimising

.. math:: J = \sum_{i=1}^{H} e(g_{k+i})^2 + \bigl(w_\chi\, \ell\, \mathrm{wrap}(\chi_i - \psi_i)\bigr)^2,

with :math:`e` the cross-track error of the predicted position, :math:`\chi_i` the course of the
chord :math:`g_{k+i-1} \to g_{k+i}`, :math:`\psi_i` the path tangent at the chord's midpoint,
:math:`\ell` the straight gait's step per cycle as the current motion source predicts it (updated
every cycle) and :math:`w_\chi` the heading weight. Both terms then scale with :math:`\ell`, so an
offset of so many steps gets about the same correction per cycle at any speed — also right after the
swimmer becomes faster or slower (a drag change), where a weight fixed at the old step would weigh
the course too little for a faster swimmer and overshoot (tested). Only the first turn is used: its
steering gait is solved exactly (warm-started from the family) and commanded for one cycle; then the
loop repeats with the newly measured pose.

The horizon follows the path: within one step of it, where its tangent turns by less than
:data:`STRAIGHT_BEND` over the reach of :math:`H` cycles ahead, the controller predicts only
``straight_horizon`` cycles. A long horizon is needed to see a bend coming and to approach the path from
afar without overshooting; holding a straight stretch it only dilutes the correction of a drift, and a
controller that knows the true connection then zig-zags more than one that mispredicts its turns.

Three sources of the motion :math:`m`:

* ``"adaptive"``: a gait model (``model``: the window model :class:`~geogait.models.AdaptiveGaitModel`
  centred on the straight gait by default, or e.g. the connection over shape space) learns every
  sample of every cycle, warm-up and tracking, perturbations included, and forgets its evidence at a
  surprise alarm if ``change_forgetting`` > 1; the family is re-solved from the updated model every
  ``family_every`` cycles (continuation);
* ``"frozen"``: the same model after the warm-up, never updated again;
* ``"true"``: the true connection of the system in force (:meth:`current_system`, simulators only).

The perturbations δ the robot adds to each commanded gait are the adaptive model's excitation and the
controller's noise; ``exploration="adaptive"`` sizes them every cycle from the controller's own
prediction residual (:mod:`geogait.control._exploration`), and a logged schedule can be replayed so
that other controllers run with the same perturbations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pandas as pd

from .. import se2
from .._defaults import FEASIBILITY_TOLERANCE
from .._estimator import Estimator, Integer, Options, Real
from .._validation import (
    MAX_BYTES,
    MAX_MAGNITUDE,
    GeogaitError,
    check_bytes,
    check_callback,
    check_choice,
    check_float,
    check_int,
    fail,
)
from ..gaits import FourierGait
from ..models import AdaptiveGaitModel, check_gait_model, clone_for_gait
from ..optimize import robot_feasibility
from ..robots import check_within_joint_ranges, perturbation_std, read_robot_spec
from ..simulate import Trajectory, TrueMotion, end_pose
from ._exploration import AdaptiveExploration, prediction_surprise, surprise_alarm
from ._paths import ReferencePath
from ._steering import (
    DEFAULT_MAX_JOINT_ANGLE,
    TURN_SPACING,
    ModelMotion,
    SteeringFamily,
    max_feasible_turn,
    solve_steering_gait,
    steering_family,
)

__all__ = ["CONTROLLERS", "DEFAULT_TURN_LIMIT", "EXPLORATION", "PathTracker", "TrackingResult", "check_plan_size"]

CONTROLLERS = ("adaptive", "frozen", "true")
EXPLORATION = ("fixed", "adaptive")
DEFAULT_TURN_LIMIT = 1.0
#: Largest turn of the path's tangent (rad) over the horizon's reach ahead that counts as straight.
STRAIGHT_BEND = 0.1
#: Bytes a plan takes per predicted cycle and candidate (first turn, held turn): its poses, their projections onto
#: the path and the temporaries of both (about 50 floats).
_PLAN_BYTES = 400


def check_plan_size(horizon: int, n_first_turns: int, n_turns: int | None, owner: str, name: str = "horizon") -> None:
    """Refuse a receding horizon whose plans would take more than MAX_BYTES, naming the longest that fits.

    Parameters
    ----------
    horizon, n_first_turns : int
    n_turns : int or None
        None: the most turns the default spacing gives (turn limit π).
    owner, name : str
        For the message: who asked, and the horizon's name there.
    """
    turns = n_turns if n_turns is not None else 2 * int(round(np.pi / TURN_SPACING)) + 1
    per_cycle = _PLAN_BYTES * n_first_turns * turns
    check_bytes(per_cycle * (horizon + 1), f"a plan of {horizon} cycles over {n_first_turns} × {turns} turns", owner,
                f"the {name} can be at most {max(0, int(MAX_BYTES // per_cycle) - 1)}")
"""Largest |turn| per cycle (rad) asked of the steering family when ``turn_limit`` is None, before the
joint limits cut it."""
WARMUP_TURN_LEVELS = (0.5, -0.5, 1.0, -1.0)
"""Turns of the turning warm-up cycles, as fractions of the turn limit (repeated for more than four)."""


@dataclass
class TrackingResult:
    """Outcome of :meth:`PathTracker.run`.

    Attributes
    ----------
    log : pandas.DataFrame
        One row per tracking cycle: ``cycle``, ``controller``, ``x``, ``y``, ``heading`` (pose at the
        end of the cycle in the path frame), ``s`` (arc length), ``cross_track`` (body lengths, left
        positive), ``heading_error`` (course of the cycle's chord minus the path tangent at its
        midpoint, rad), ``turn_command``, ``predicted_x/y/turn`` (the controller's prediction of the
        cycle's net motion), ``measured_x/y/turn`` (from the robot's poses), ``true_x/y/turn`` (oracle
        motion of the commanded nominal gait, simulators only, else NaN), ``gamma`` (online Γ of the
        adaptive model, NaN otherwise), ``drag_ratio`` (simulators with a drag ratio, else NaN),
        ``solved`` (the steering gait met its command), ``perturbation_std`` (δ std the cycle ran
        with, rad; NaN when the robot does not say), ``surprise`` (the cycle's prediction residual in
        steps per radian of δ std, :func:`~geogait.control.prediction_surprise`), ``alarm`` (the
        cycle raised the change alarm of ``change_forgetting``) and ``param_*``.
    path : ReferencePath
    start : ndarray of shape (3,)
        Pose at the start of tracking, path frame.
    direction : float
        Travel direction α of the straight gait in the body frame (rad), from the warm-up poses.
    reference : FourierGait
        The straight gait the steering gaits stay near.
    family : SteeringFamily
        The steering family in use at the end.
    trajectory : Trajectory or None
        Tracking samples with poses in the path frame (``record=True``).
    perturbation_std : ndarray of shape (warm-up + tracking cycles,) or None
        δ std of every cycle run, warm-up first (``exploration`` other than ``"fixed"``): pass it as
        another tracker's ``exploration`` to replay the schedule.
    """

    log: pd.DataFrame
    path: ReferencePath
    start: np.ndarray
    direction: float
    reference: FourierGait
    family: SteeringFamily
    trajectory: Trajectory | None = None
    perturbation_std: np.ndarray | None = None

    def summary(self, skip: int = 0) -> dict:
        """Mean and 95th percentile of |cross-track| (body lengths) and |heading error| (rad) over
        the cycles from ``skip`` on."""
        part = self.log[self.log["cycle"] >= skip]
        cross, heading = np.abs(part["cross_track"].to_numpy()), np.abs(part["heading_error"].to_numpy())
        return {"cycles": int(len(part)),
                "cross_track_mean": float(cross.mean()) if len(part) else None,
                "cross_track_p95": float(np.percentile(cross, 95)) if len(part) else None,
                "heading_error_mean": float(heading.mean()) if len(part) else None,
                "heading_error_p95": float(np.percentile(heading, 95)) if len(part) else None}


class PathTracker(Estimator):
    """Receding-horizon path following with steering gaits (module docstring).

    Parameters
    ----------
    controller : {"adaptive", "frozen", "true"}
        Source of the predicted motion per cycle.
    horizon : int
        Cycles H predicted per decision where the path bends ahead.
    straight_horizon : int or None
        Cycles predicted within one step of the path where it is straight ahead (its tangent turns by less
        than :data:`STRAIGHT_BEND` over H cycles' reach, at the step the motion source predicts); at most
        ``horizon``. None: ``horizon`` everywhere.
    turn_limit : float or None
        Largest |turn| per cycle (rad) in the steering family; members the joint limits make
        infeasible are dropped. None (default): :data:`DEFAULT_TURN_LIMIT` = 1 rad cut to what the
        joint limits allow — after the warm-up, the largest multiple of 0.1 rad up to 1 rad that the
        controller's own motion source (the warm-up model, or the true connection) turns in both
        directions within ``max_joint_angle`` (:func:`~geogait.control.max_feasible_turn`); 0.5 rad for
        the 3-link and 1.0 for the 5-link Purcell swimmer. The limit in use is ``turn_limit_`` after
        :meth:`run`.
    n_turns : int or None
        Members of the steering family (odd, so that zero turn is one of them). None (default): turns
        spaced 0.1 rad.
    n_first_turns : int
        Candidate first turns (fine grid between the family's extreme feasible turns).
    heading_weight : float
        :math:`w_\\chi`, weight of the course error (times the current step) against the cross-track
        error.
    forgetting_factor : float
        λ_RLS of the gait model (adaptive and frozen).
    warmup_cycles : int
        Cycles of the straight gait before tracking: the model learns them and their measured motion
        gives the travel direction α. At least 1.
    warmup_turns : int
        Turning cycles after the straight ones, before tracking: the steering gaits of the model learned
        so far for ½, −½, 1 and −1 × the turn limit (:data:`WARMUP_TURN_LEVELS`, repeated), one cycle
        each (the straight gait where the model has none), so that the model has seen the turns a path
        asks for before the first one is asked. The frozen controller's model is the one after them.
        Every controller runs the same warm-up (the true one too), so paired trials stay paired.
        Default 0 (the straight gait only). Worth it with a model that can represent the connection over
        the turning range, such as the built-in swimmers' symmetric shape-space model; a model that
        extrapolates poorly from a few turning cycles can be led astray by them.
    max_joint_angle : float
        r_max (rad) of every commanded gait.
    n_windows : int
        Phase windows of the gait model.
    resolution : int
        Magnus steps of the motion predictions of the window model and the true connection (a ``model``
        that predicts with its own ``predict_displacement`` uses its own, e.g.
        ``ShapeSpaceModel(resolution=...)``).
    family_every : int
        The adaptive controller re-solves its steering family from the learning model every this many
        cycles (warm-started from the last one); in between it re-predicts the motion of the family's
        gaits with the current model every cycle.
    exploration : {"fixed", "adaptive"}, AdaptiveExploration or array-like of float
        Size of the perturbations δ. ``"fixed"`` (default): whatever the robot does. ``"adaptive"``:
        sized every cycle by :class:`~geogait.control.AdaptiveExploration` with its defaults (δ std
        0.15 rad through the warm-up and after a surprise in the controller's own prediction
        residual, decaying to 0.05 while the predictions hold); an :class:`AdaptiveExploration`
        for other settings. An array ``(n,)`` replays a schedule of δ stds, one per cycle, warm-up
        first (e.g. ``result.perturbation_std`` of another controller's run, so that both run with
        the same perturbations), its last value held beyond its end. All but ``"fixed"`` need a robot
        with ``set_perturbation_std(std)`` (:meth:`geogait.simulate.SwimmerStream.set_perturbation_std`).
    model : estimator or None
        The learning model of the adaptive and frozen controllers. None (default): the window model
        (:class:`~geogait.models.AdaptiveGaitModel` of ``forgetting_factor`` and ``n_windows``, centred on
        the straight gait). Otherwise an unfitted model with ``partial_fit`` and ``predict_displacement``,
        cloned per run (given the straight gait and phase rate if it takes them), e.g. a connection over
        shape space (:class:`~geogait.models.ShapeSpaceModel`), which learns A(r) from every sample of
        every steering gait instead of a local expansion about the straight one.
    change_forgetting : float >= 1
        Covariance resetting after a change of the environment: when a cycle's prediction surprise
        (:func:`~geogait.control.prediction_surprise`) raises the alarm of
        :func:`~geogait.control.surprise_alarm` — with the alarm factor and window of ``exploration``
        when it is an :class:`AdaptiveExploration`, else 5 and 10, against the surprises since the last
        alarm only (the log's ``alarm`` column) — the adaptive model forgets all its evidence by this
        factor (``model.forget``) before it learns that cycle, so that it re-learns within a few cycles
        instead of the ``1 / (1 - λ)`` samples of its forgetting factor. 1 (default): never.
    """

    _parameter_constraints: ClassVar[dict] = {
        "controller": Options(CONTROLLERS),
        "horizon": Integer(minimum=1),
        "straight_horizon": Integer(minimum=1, none=True),
        "turn_limit": Real(low=0, high=np.pi, low_open=True, none=True),
        "n_turns": Integer(minimum=3, none=True),
        "n_first_turns": Integer(minimum=3),
        "heading_weight": Real(low=0),
        "forgetting_factor": Real(low=0, high=1, low_open=True),
        "warmup_cycles": Integer(minimum=1),
        "warmup_turns": Integer(minimum=0),
        "max_joint_angle": Real(low=0, high=np.pi, low_open=True),
        "n_windows": Integer(minimum=3),
        "resolution": Integer(minimum=8),
        "family_every": Integer(minimum=1),
        "change_forgetting": Real(low=1),
    }
    _fitted_attribute: ClassVar[str] = "turn_limit_"

    def __init__(self, *, controller: str = "adaptive", horizon: int = 4, straight_horizon: int | None = 2,
                 turn_limit: float | None = None,
                 n_turns: int | None = None, n_first_turns: int = 21, heading_weight: float = 0.5,
                 forgetting_factor: float = 0.99, warmup_cycles: int = 10, warmup_turns: int = 0,
                 max_joint_angle: float = DEFAULT_MAX_JOINT_ANGLE, n_windows: int = 20, resolution: int = 64,
                 family_every: int = 5, exploration="fixed", model=None, change_forgetting: float = 1.0):
        self.controller = controller
        self.horizon = horizon
        self.straight_horizon = straight_horizon
        self.turn_limit = turn_limit
        self.n_turns = n_turns
        self.n_first_turns = n_first_turns
        self.heading_weight = heading_weight
        self.forgetting_factor = forgetting_factor
        self.warmup_cycles = warmup_cycles
        self.warmup_turns = warmup_turns
        self.max_joint_angle = max_joint_angle
        self.n_windows = n_windows
        self.resolution = resolution
        self.family_every = family_every
        self.exploration = exploration
        self.model = model
        self.change_forgetting = change_forgetting

    def _check_param_combinations(self) -> None:
        owner = "PathTracker"
        if self.straight_horizon is not None and self.straight_horizon > self.horizon:
            raise fail("straight_horizon", owner, f"None or an int in 1..horizon ({self.horizon})",
                       self.straight_horizon)
        if self.n_turns is not None and self.n_turns % 2 == 0:
            raise fail("n_turns", owner, "an odd int >= 3 (zero turn is a member) or None", self.n_turns)
        check_plan_size(self.horizon, self.n_first_turns, self.n_turns, owner)
        self._exploration_plan()
        if self.model is not None:
            needs = ("get_params", "partial_fit", "predict_displacement") + (("forget",) if self.change_forgetting > 1
                                                                              else ())
            check_gait_model(self.model, needs, owner, prefix="None or an unfitted")

    def _new_model(self, reference: FourierGait, period: float):
        """A fresh learning model: the window model of ``forgetting_factor`` and ``n_windows`` centred on
        the straight gait, or a clone of ``model`` (given the straight gait and phase rate if it takes them)."""
        rate = 2 * np.pi / period
        if self.model is None:
            return AdaptiveGaitModel(gait=reference, forgetting_factor=self.forgetting_factor,
                                     n_windows=self.n_windows, phase_rate=rate)
        return clone_for_gait(self.model, reference, rate)

    def _exploration_plan(self):
        """``None`` (fixed), a fresh :class:`AdaptiveExploration`, or the schedule to replay ``(n,)``."""
        value, owner = self.exploration, "PathTracker"
        expected = "'fixed', 'adaptive', an AdaptiveExploration or a 1-D array of δ stds >= 0"
        if isinstance(value, str):
            check_choice(value, "exploration", owner, EXPLORATION)
            return None if value == "fixed" else AdaptiveExploration()
        if isinstance(value, AdaptiveExploration):
            return AdaptiveExploration(**value.get_params())
        try:
            schedule = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise fail("exploration", owner, expected, value) from None
        if schedule.ndim != 1 or schedule.size == 0 or not np.all(np.isfinite(schedule)) or np.any(schedule < 0):
            raise fail("exploration", owner, expected, value)
        return schedule

    def _resolve_turns(self, motion, reference, direction) -> np.ndarray:
        """Turning rates of the steering family's members (rad per cycle); sets ``turn_limit_``."""
        limit = self.turn_limit
        if limit is None:
            limit = max_feasible_turn(motion, reference, direction=direction, upper=DEFAULT_TURN_LIMIT,
                                      max_joint_angle=self.max_joint_angle, feasibility=self._region)
            if limit == 0:
                raise GeogaitError("No steering gait turns by 0.1 rad per cycle within the joint limits and the "
                                   "joint ranges or region the robot declares (give turn_limit, or relax "
                                   "max_joint_angle).")
        n_turns = 2 * int(round(limit / TURN_SPACING)) + 1 if self.n_turns is None else self.n_turns
        self.turn_limit_ = float(limit)
        return np.linspace(-limit, limit, n_turns)

    # -- the loop -----------------------------------------------------------------------------
    def run(self, robot, path: ReferencePath, n_cycles: int, *, gait: FourierGait | None = None,
            start_offset: float = 0.0, callback: Callable[[dict], None] | None = None,
            record: bool = False) -> TrackingResult:
        """Warm up on the straight gait (and ``warmup_turns`` turning cycles), then follow ``path`` for up to
        ``n_cycles`` cycles.

        Parameters
        ----------
        robot : geogait.robots.Robot
            Any robot (``n_joints``, ``cycle_period``, ``gait``, ``set_gait``, ``next_cycle``); the
            ``"true"`` controller also needs ``current_system()`` (simulators).
        path : ReferencePath
            In its own frame; it is placed so that the robot starts at its start point, moved
            ``start_offset`` body lengths to the left, travelling along its start tangent.
        n_cycles : int
            Tracking cycles (fewer when an open path's end is reached).
        gait : FourierGait, optional
            The straight gait (current optimum) the steering gaits stay near; ``robot.gait`` by default.
        start_offset : float
            Initial cross-track offset (body lengths, left positive).
        callback : callable, optional
            Called with each log row (a dict) as it is produced.
        record : bool
            Keep the tracking samples (``result.trajectory``, poses in the path frame).

        Returns
        -------
        TrackingResult
        """
        self.validate()
        owner = "PathTracker.run"
        check_callback(callback, record, owner)
        spec = read_robot_spec(robot, owner)
        if not isinstance(path, ReferencePath):
            raise fail("path", owner, "a ReferencePath", type(path).__name__)
        n_cycles = check_int(n_cycles, "n_cycles", owner, minimum=1)
        start_offset = check_float(start_offset, "start_offset", owner, low=-MAX_MAGNITUDE, high=MAX_MAGNITUDE)
        reference = robot.gait if gait is None else gait
        if not isinstance(reference, FourierGait) or reference.n_joints != robot.n_joints:
            raise fail("gait", owner, f"a FourierGait with {robot.n_joints} joints", reference)
        if reference.joint_limit().max() > self.max_joint_angle + 1e-9:
            raise fail("gait", owner, f"a gait within max_joint_angle = {self.max_joint_angle:.4g}",
                       f"a gait reaching {reference.joint_limit().max():.4g} rad")
        oracle = robot.current_system if spec.simulated else None  # (a simulator's truth, asked again as it changes)
        # the robot's feasible region (its own, or its simulator's): every steering gait keeps it, as the joint limits
        check_within_joint_ranges(reference, spec, "gait", owner)
        self._region = robot_feasibility(robot, reference.n_joints, reference.order, self.max_joint_angle)
        lowest = float(self._region(reference.params)[0].min()) if self._region is not None else 0.0
        if lowest < -FEASIBILITY_TOLERANCE:
            raise fail("gait", owner, "a straight gait inside the robot's feasible region",
                       f"a gait whose feasibility falls to {lowest:.4g}")
        if self.controller == "true" and not callable(oracle):
            raise GeogaitError(f"The 'true' controller of {owner} needs a simulated robot with current_system(); "
                               f"{type(robot).__name__} has none. Use controller='adaptive' or 'frozen'.")
        plan = self._exploration_plan()
        if plan is not None and not spec.perturbation_control:
            raise GeogaitError(f"exploration={self.exploration!r} of {owner} needs a robot with "
                               f"set_perturbation_std(std); {type(robot).__name__} has none "
                               "(geogait.simulate.SwimmerStream has one), or use exploration='fixed'.")
        sizes = _Sizes(robot, plan)
        change = _ChangeTest(*((plan.alarm, plan.window) if isinstance(plan, AdaptiveExploration) else ()))
        model = self._new_model(reference, float(robot.cycle_period))
        robot.set_gait(reference)
        chords = []
        for _ in range(self.warmup_cycles):
            sizes.apply()
            chunk = robot.next_cycle()
            model.partial_fit(chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
            world = end_pose(chunk, robot.cycle_period)
            chords.append(se2.between(chunk.pose[0], world))
        direction = float(np.arctan2(*np.mean(chords, axis=0)[1::-1]))
        world = self._turning_warmup(robot, model, reference, direction, sizes) if self.warmup_turns else world
        travel = se2.compose(world, [0.0, 0.0, direction])  # the travel frame of the robot, world
        normal = path.start_heading + np.pi / 2
        wanted = np.array([path.points[0, 0] + start_offset * np.cos(normal),
                           path.points[0, 1] + start_offset * np.sin(normal), path.start_heading])
        anchor = se2.compose(wanted, se2.inverse(travel))  # path frame <- world
        pose = se2.compose(anchor, world)
        start = pose.copy()
        s, _, _ = path.project(pose[:2])
        s = float(s) if path.closed else 0.0
        motion, family, family_system = self._motion(model, oracle), None, None
        turns = self._resolve_turns(motion, reference, direction)
        rows, chunks = [], []
        for cycle in range(n_cycles):
            system = oracle() if callable(oracle) else None
            if self.controller == "true" and system is not family_system:
                motion, family_system = TrueMotion(system, self.resolution), system
                family = self._family(motion, reference, direction, family, turns)
            elif family is None or (self.controller == "adaptive" and cycle % self.family_every == 0):
                motion = self._motion(model, oracle)
                family = self._family(motion, reference, direction, family, turns)
            elif self.controller == "adaptive":
                motion = self._motion(model, oracle)
                family = family.repredicted(motion)
            step_length = float(np.hypot(*family.interpolate(0.0)[:2]))  # predicted now: the cost scales with it
            # search the path as far as the horizon can reach with the family's longest step
            window = 0.3 + 1.5 * self.horizon * float(np.hypot(family.poses[:, 0], family.poses[:, 1]).max())
            turn = self._plan(pose, s, family, path, step_length, window)
            solution = solve_steering_gait(motion, reference, [np.nan, np.nan, turn], direction=direction,
                                           start=family.start_for(turn), max_joint_angle=self.max_joint_angle,
                                           feasibility=self._region)
            command = solution.gait if solution.converged else family.start_for(turn)
            predicted = solution.pose if solution.converged else family.interpolate(turn)
            truth = TrueMotion(system, self.resolution)(command) if system is not None else np.full(3, np.nan)
            robot.set_gait(command)
            std = sizes.apply()
            chunk = robot.next_cycle()
            world_start, world = chunk.pose[0], end_pose(chunk, robot.cycle_period)
            measured = se2.between(world_start, world)
            surprise = sizes.update(predicted, measured, std)
            alarm = change.update(prediction_surprise(predicted, measured, std if std > 0 else 1.0))
            if self.controller == "adaptive":
                if alarm and self.change_forgetting > 1:  # before the alarming cycle is learned
                    model.forget(self.change_forgetting)
                model.partial_fit(chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
            begin, pose = se2.compose(anchor, world_start), se2.compose(anchor, world)
            s_new, cross_track, _ = path.project(pose[:2], near=s, window=window)
            _, _, tangent = path.project((begin[:2] + pose[:2]) / 2, near=s, window=window)
            course = np.arctan2(pose[1] - begin[1], pose[0] - begin[0])
            s = float(s_new)
            row = {"cycle": cycle, "controller": self.controller, "x": pose[0], "y": pose[1], "heading": pose[2],
                   "s": s, "cross_track": float(cross_track), "heading_error": float(se2.wrap_angle(course - tangent)),
                   "turn_command": turn, "solved": bool(solution.converged),
                   **_motion_columns("predicted", predicted), **_motion_columns("measured", measured),
                   **_motion_columns("true", truth),
                   "gamma": float(getattr(model, "gamma_", np.nan)) if self.controller == "adaptive" else np.nan,
                   "drag_ratio": float(getattr(system, "drag_ratio", np.nan)) if system is not None else np.nan,
                   "perturbation_std": std, "surprise": surprise, "alarm": alarm}
            row.update({f"param_{k}": v for k, v in enumerate(command.params)})
            rows.append(row)
            if record:
                chunks.append(_in_path_frame(chunk, anchor))
            if callback is not None:
                callback(row)
            if path.at_end(s + 0.5 * step_length):
                break
        return TrackingResult(log=pd.DataFrame(rows), path=path, start=start, direction=direction,
                              reference=reference, family=family,
                              trajectory=Trajectory.concatenate(chunks) if record and chunks else None,
                              perturbation_std=sizes.history())

    @property
    def warmup_length(self) -> int:
        """Cycles a run commands before its first tracking cycle: ``warmup_cycles`` straight, then
        ``warmup_turns`` turning (e.g. to time an environment change by tracking cycle)."""
        return self.warmup_cycles + self.warmup_turns

    def _turning_warmup(self, robot, model, reference, direction, sizes):
        """Run and learn the ``warmup_turns`` turning cycles (class docstring); returns the last end pose."""
        learned = ModelMotion(model, self.resolution)
        limit = self.turn_limit if self.turn_limit is not None else max_feasible_turn(
            learned, reference, direction=direction, upper=DEFAULT_TURN_LIMIT,
            max_joint_angle=self.max_joint_angle, feasibility=self._region)
        levels = np.resize(WARMUP_TURN_LEVELS, self.warmup_turns)
        for turn in limit * levels:
            gait = reference
            if turn != 0:
                solution = solve_steering_gait(ModelMotion(model, self.resolution), reference, [np.nan, np.nan, turn],
                                               direction=direction, start=reference,
                                               max_joint_angle=self.max_joint_angle, feasibility=self._region)
                gait = solution.gait if solution.converged else reference
            robot.set_gait(gait)
            sizes.apply()
            chunk = robot.next_cycle()
            model.partial_fit(chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
        return end_pose(chunk, robot.cycle_period)

    def _motion(self, model, oracle):
        if self.controller == "true":
            return TrueMotion(oracle(), self.resolution)
        return ModelMotion(model, self.resolution)

    def _family(self, motion, reference, direction, previous, turns) -> SteeringFamily:
        family = steering_family(motion, reference, turns, direction=direction, previous=previous,
                                 max_joint_angle=self.max_joint_angle, max_iterations=20, contiguous=True,
                                 feasibility=self._region)
        if not family.feasible[turns.size // 2]:
            raise GeogaitError("No straight steering gait: the model's zero-turn gait is out of reach within "
                               "the joint limits (warm up for more cycles or relax max_joint_angle).")
        return family

    def _horizon_at(self, path: ReferencePath, s: float, step_length: float, cross_track: float = 0.0) -> int:
        """Cycles to predict from arc length ``s``: ``straight_horizon`` within one step of the path
        (|``cross_track``| ≤ ``step_length``) where its tangent turns by less than :data:`STRAIGHT_BEND` over
        ``horizon`` steps of ``step_length`` ahead, else ``horizon``."""
        if self.straight_horizon is None or abs(cross_track) > step_length:
            return self.horizon
        headings = path.heading(s + np.linspace(0.0, self.horizon * step_length, 2 * self.horizon + 1))
        bend = float(np.abs(se2.wrap_angle(headings - headings[0])).max())
        return self.straight_horizon if bend < STRAIGHT_BEND else self.horizon

    def _plan(self, pose, s, family: SteeringFamily, path: ReferencePath, step_length: float, window: float) -> float:
        """First turn of the best candidate sequence over the horizon (module docstring): a grid of
        first turns, then two finer grids around the best one (turns are continuous; a coarse grid
        alone would leave a small steady drift)."""
        low, high = family.turn_range
        held = family.turns[family.usable()]
        later = family.interpolate(held)  # (C, 3)
        _, offset, here = path.project(pose[:2], near=s, window=window)
        horizon = self._horizon_at(path, s, step_length, float(offset))

        def cost(first_turns):  # (F,) -> (F, C)
            first = family.interpolate(first_turns)
            shape = (first_turns.size, held.size)
            current = np.broadcast_to(se2.compose(pose, first)[:, None, :], shape + (3,))
            poses = [np.broadcast_to(pose, shape + (3,)), current]
            for _ in range(horizon - 1):
                current = se2.compose(current, later[None, :, :])
                poses.append(current)
            poses = np.stack(poses)  # (H + 1, F, C, 3)
            ends, begins = poses[1:, ..., :2], poses[:-1, ..., :2]
            _, cross_track, tangent = path.project(ends, near=s, window=window)
            previous = np.concatenate([np.broadcast_to(here, (1,) + shape), tangent[:-1]])
            tangent = previous + 0.5 * se2.wrap_angle(tangent - previous)  # tangent at the chord's midpoint
            course = np.arctan2(ends[..., 1] - begins[..., 1], ends[..., 0] - begins[..., 0])
            heading = self.heading_weight * step_length * se2.wrap_angle(course - tangent)
            return np.sum(cross_track**2 + heading**2, axis=0)

        grid = np.linspace(low, high, self.n_first_turns)
        turn = float(grid[np.argmin(cost(grid).min(axis=1))])
        spacing = grid[1] - grid[0]
        for _ in range(2):
            local = np.unique(np.clip(turn + np.linspace(-spacing, spacing, 11), low, high))
            turn = float(local[np.argmin(cost(local).min(axis=1))])
            spacing /= 5
        return turn


class _Sizes:
    """The δ std of each cycle: set on the robot before the cycle (``apply``), the rule fed after it."""

    def __init__(self, robot, plan):
        self.robot, self.plan, self.used = robot, plan, []
        if isinstance(plan, AdaptiveExploration):
            plan.start()

    def apply(self) -> float:
        """Set the next cycle's δ std on the robot (not for ``"fixed"``); returns it (NaN if unknown)."""
        if self.plan is None:
            std = perturbation_std(self.robot)
        else:
            std = (self.plan.std_ if isinstance(self.plan, AdaptiveExploration)
                   else float(self.plan[min(len(self.used), self.plan.size - 1)]))
            self.robot.set_perturbation_std(std)
        self.used.append(std)
        return std

    def update(self, predicted, measured, std) -> float:
        """Feed the rule the cycle just run; returns its surprise (NaN when the δ std is unknown or 0)."""
        if isinstance(self.plan, AdaptiveExploration):
            self.plan.update(predicted, measured)
            return self.plan.surprises_[-1]
        return prediction_surprise(predicted, measured, std) if std > 0 else np.nan

    def history(self) -> np.ndarray | None:
        return None if self.plan is None else np.array(self.used)


class _ChangeTest:
    """The alarm of ``change_forgetting``: :func:`~geogait.control.surprise_alarm` against the surprises
    since the last alarm only — the model forgot at that alarm, and the surprises of its first cycles
    of re-learning would otherwise raise it again and again, each time discarding what they taught."""

    def __init__(self, alarm: float = 5.0, window: int = 10):
        self.alarm, self.window, self.since = alarm, window, []

    def update(self, surprise: float) -> bool:
        alarm = surprise_alarm(surprise, self.since, self.alarm, self.window)
        self.since = [] if alarm else self.since + [surprise]
        return alarm


def _motion_columns(prefix: str, pose) -> dict:
    return {f"{prefix}_x": float(pose[0]), f"{prefix}_y": float(pose[1]), f"{prefix}_turn": float(pose[2])}


def _in_path_frame(chunk: Trajectory, anchor) -> Trajectory:
    arrays = {name: getattr(chunk, name) for name in ("time", "phase", "cycle", "shape", "shape_velocity",
                                                      "body_velocity", "commanded_shape")}
    return Trajectory(**arrays, pose=se2.compose(anchor, chunk.pose))
