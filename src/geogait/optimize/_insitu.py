r"""In-situ gait optimisation (paper Fig. 4) of any :class:`~geogait.robots.Robot`: perturbed cycles →
model → confidence-gated trust-region step → Taylor rebase (eq. 7) → repeat.

The optimiser is composed from parts (module :mod:`geogait.optimize._parts`): the model learned in situ, the
gate, the model's step, the measured climb, safety, limits, the objective, the period search, the exploration
and run-time checks. Presets (:func:`~geogait.optimize.paper_loop`, :func:`~geogait.optimize.prior_work`,
:func:`~geogait.optimize.structured`, :func:`~geogait.optimize.for_robot`) return explicit, printable
compositions.

What a gait is judged by is **measured**: the net SE(2) motion of every cycle from the robot's own
poses, in the body frame at the start of the cycle. A simulator's truth (``current_system()``) only adds
``true_*`` columns to the log.

Gait family (``family``): the free Fourier family of ``order``, or a rotation-free family — on chains with
front–back symmetry :class:`~geogait.gaits.SymmetricGaitFamily` about the seed gait's φ₀, on other bodies that
declare mirror symmetry the half-wave symmetric :class:`~geogait.gaits.MirrorGaitFamily` (odd harmonics only).
Every commanded gait of those has exactly zero net rotation, so the rotation constraint is dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._defaults import FEASIBILITY_TOLERANCE
from .._estimator import Estimator, InstanceOf, Integer, Options
from .._files import read_state
from .._validation import GeogaitError, check_bytes, check_callback, check_float, check_gait_size, check_int, fail
from ..models import check_gait_model, model_capabilities
from ..robots import check_within_joint_ranges, read_robot_spec
from ._adaptation import Adaptation
from ._checks import ModelClassTest, StructureCheck
from ._exploration import Exploration
from ._loop import CycleLoop, new_climb
from ._measure import peak_phase_speed
from ._models import gate_kind, gate_members, model_template, run_model, symmetric_chain_model
from ._objective import Objective, spec_feasibility
from ._parts import Climb, Gate, Limits, ModelStep, PeriodSearch, Safety
from ._period import PeriodLineSearch
from ._result import InSituResult
from ._setup import (
    check_budget,
    commands_excitation,
    gait_family,
    joint_limit,
    model_class_check,
    period_range,
    settle_at_start,
    shape_scale,
    stop_rule,
)
from ._state import (
    CHECKPOINT_FORMAT,
    CHECKPOINT_VERSION,
    RunState,
    checkpoint_path,
    params_from_json,
    params_to_json,
    prefixed_arrays,
)

__all__ = ["Composition", "InSituOptimizer", "symmetric_chain_model"]

#: The parts ``checks`` takes (one of each at most).
CHECKS = (Adaptation, ModelClassTest, StructureCheck)


@dataclass
class Composition:
    """The parts a run uses: the optimiser's, with every ``None`` resolved to a fresh default part.

    Parameters
    ----------
    model : estimator or None
        The model template (None: the default for the family searched).
    gate : Gate
    gate_kind : {"gamma", "cycles"}
        The gate resolved for the model.
    step : ModelStep
    climb : Climb or None
        None: no climb.
    safety : Safety
    limits : Limits
    objective : Objective
    order : int
    period : PeriodSearch or None
    exploration : Exploration or None
        None: never commanded (``"auto"`` resolves to ``Exploration()``, commanded where the robot takes it).
    model_class : ModelClassTest or None
    structure : StructureCheck or None
    adaptation : Adaptation or None
        None: no change is watched for.
    """

    model: object
    gate: Gate
    gate_kind: str
    step: ModelStep
    climb: Climb | None
    safety: Safety
    limits: Limits
    objective: Objective
    order: int
    period: PeriodSearch | None
    exploration: object
    model_class: ModelClassTest | None
    structure: StructureCheck | None
    adaptation: Adaptation | None = None


class InSituOptimizer(Estimator):
    """The paper's in-situ optimiser, composed from parts.

    Parameters
    ----------
    model : estimator, optional
        The model learned in situ; cloned with the seed gait and the robot's phase rate at every run. It must offer
        ``partial_fit`` (or ``fit``), ``predict_displacement(gait, jacobian=...)`` and ``rebase``
        (:class:`~geogait.models.GaitModel`). Default: in the symmetric family the symmetric shape-space model of
        :func:`symmetric_chain_model`, elsewhere :class:`~geogait.models.AdaptiveGaitModel` with λ = 1 − 0.1 / d.
    gate : Gate, optional
        When the model may step (default ``Gate()``: Γ ≥ 1/2 after 2 measured cycles).
    step : ModelStep, optional
        The model's trust-region step (default ``ModelStep()``).
    climb : Climb or False, optional
        Steps from measured outcomes (default ``Climb()``: from the first decision, by COBYQA or Bayesian
        optimisation); False: none.
    safety : Safety, optional
        Settling, rejecting gaits the robot cannot follow, reverting to the best gait measured (default
        ``Safety()``).
    limits : Limits, optional
        Joint angle and speed limits and the unit of shape (default ``Limits()``: from the robot's joint ranges).
    objective : Objective, optional
        What a gait is judged by (default ``Objective()``: straight-line progress per cycle, no net rotation).
    family : {"auto", "free", "symmetric", "mirror"}
        Gait family searched. ``"auto"``: symmetric when the robot declares front–back symmetry and the seed is a
        member, else mirror when it declares mirror symmetry and the seed is a member, else free. A robot that
        declares no symmetry starts in the mirror family when the seed is a member and an
        :class:`~geogait.optimize.Adaptation` may widen it (to the free family, once a gait turns the body).
    order : int
        Fourier order of the gait family (a seed of higher order is refused rather than cut).
    period : PeriodSearch, optional
        Make the cycle period a decision variable (the robot needs ``set_cycle_period``); None: the robot's.
    exploration : "auto", Exploration or None
        ``"auto"``: ``Exploration()`` commanded to robots that offer ``set_excitation``, none to others (they
        explore on their own). An ``Exploration``: commanded (the robot must offer ``set_excitation``). None:
        never commanded (the robot's own perturbation, as the paper's simulated swimmer).
    checks : sequence of Adaptation, ModelClassTest and StructureCheck, optional
        Run-time checks (module :mod:`geogait.optimize._checks`). Default (None): ``[Adaptation()]``, which notices
        a change of the robot or its world, forgets the records it made stale and leads the recovery
        (:mod:`geogait.optimize._adaptation`); ``[]``: none, records are kept for the whole run.
    random_state : int or None
        Seed of the exploration and the climb (default 0: runs repeat exactly; None draws fresh entropy).

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> from geogait.optimize import Climb, InSituOptimizer, ModelStep
    >>> from geogait.simulate import SwimmerStream
    >>> from geogait.systems import PurcellSwimmer
    >>> robot = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=0)
    >>> optimizer = InSituOptimizer(step=ModelStep(trust_radius=0.05), climb=Climb(start="stalled"))
    >>> optimizer
    InSituOptimizer(step=ModelStep(trust_radius=0.05), climb=Climb(start='stalled'))
    >>> result = optimizer.run(robot, 4)
    >>> len(result.log)
    4
    """

    _parameter_constraints = {
        "gate": InstanceOf(Gate, "a Gate"),
        "step": InstanceOf(ModelStep, "a ModelStep"),
        "safety": InstanceOf(Safety, "a Safety"),
        "limits": InstanceOf(Limits, "a Limits"),
        "objective": InstanceOf(Objective, "an Objective"),
        "family": Options(("auto", "free", "symmetric", "mirror")),
        "order": Integer(minimum=1),
        "period": InstanceOf(PeriodSearch, "a PeriodSearch"),
        "random_state": Integer(minimum=0, none=True),
    }

    def __init__(self, *, model=None, gate: Gate | None = None, step: ModelStep | None = None,
                 climb: Climb | bool | None = None, safety: Safety | None = None, limits: Limits | None = None,
                 objective: Objective | None = None, family: str = "auto", order: int = 1,
                 period: PeriodSearch | None = None, exploration="auto", checks=None,
                 random_state: int | None = 0):
        self.model = model
        self.gate = gate
        self.step = step
        self.climb = climb
        self.safety = safety
        self.limits = limits
        self.objective = objective
        self.family = family
        self.order = order
        self.period = period
        self.exploration = exploration
        self.checks = checks
        self.random_state = random_state

    def describe(self) -> dict:
        """Hyper-parameters as JSON values (parts and the model as their class name and parameters)."""
        return params_to_json(self)

    def _check_param_combinations(self) -> None:
        owner = "InSituOptimizer"
        if self.climb is not False and self.climb is not None and not isinstance(self.climb, Climb):
            raise fail("climb", owner, "a Climb, False (no climb) or None (Climb())", self.climb)
        if not (self.exploration in ("auto", None) or isinstance(self.exploration, Exploration)):
            raise fail("exploration", owner, "'auto', an Exploration or None", self.exploration)
        checks = () if self.checks is None else self.checks
        if not isinstance(checks, list | tuple) or not all(isinstance(c, CHECKS) for c in checks):
            raise fail("checks", owner, "a list of Adaptation, ModelClassTest and StructureCheck parts", self.checks)
        for kind in CHECKS:
            if sum(isinstance(c, kind) for c in checks) > 1:
                raise fail("checks", owner, f"at most one {kind.__name__}", self.checks)
        for name in ("gate", "step", "safety", "limits", "objective", "period"):
            part = getattr(self, name)
            if part is not None:
                part.validate()
        for part in checks:
            part.validate()
        if isinstance(self.climb, Climb):
            self.climb.validate()

        if isinstance(self.exploration, Exploration):
            self.exploration.validate()
        gate = self.gate or Gate()
        if gate.kind == "gamma":
            check_gait_model(model_template(self.model), gate_members("gamma"), owner,
                             prefix="for Gate(kind='gamma') a")
        if self.model is not None:
            check_gait_model(self.model, ("get_params", "predict_displacement")
                             + gate_members(gate_kind(gate.kind, self.model)), owner)

    def composition(self) -> Composition:
        """The parts a run uses, every ``None`` resolved to a fresh default part (validated first)."""
        self.validate()
        gate = self.gate or Gate()
        checks = [Adaptation()] if self.checks is None else self.checks
        return Composition(
            model=self.model, gate=gate, gate_kind=gate_kind(gate.kind, self.model), step=self.step or ModelStep(),
            climb=None if self.climb is False else (self.climb or Climb()), safety=self.safety or Safety(),
            limits=self.limits or Limits(), objective=self.objective or Objective(), order=self.order,
            period=self.period, exploration=Exploration() if self.exploration == "auto" else self.exploration,
            model_class=next((c for c in checks if isinstance(c, ModelClassTest)), None),
            structure=next((c for c in checks if isinstance(c, StructureCheck)), None),
            adaptation=next((c for c in checks if isinstance(c, Adaptation)), None))

    # -- running ------------------------------------------------------------------------------
    def run(self, robot, n_cycles: int | None, *, ceiling: float | None = None,
            callback: Callable[[dict], None] | None = None, record: bool = False,
            checkpoint=None, checkpoint_every: int = 1, checkpoint_tag: dict | None = None,
            stop=None) -> InSituResult:
        """Optimise in situ for ``n_cycles`` cycles of ``robot``, or until ``stop``.

        Parameters
        ----------
        robot : Robot
            Anything implementing :class:`geogait.robots.Robot` (``SwimmerStream``, ``MujocoRobot``,
            ``ProcessRobot``, your own driver). With ``current_system()`` the log also holds the true displacement
            per cycle.
        n_cycles : int or None
            The cycle budget; None: no budget (continuous operation), the run goes on until ``stop`` says so or
            the process is interrupted (the checkpoint then holds every cycle run).
        ceiling : float, optional
            Ceiling objective value; adds ``ceiling_fraction`` to the log.
        callback : callable, optional
            Called with each log row (a dict) as it is produced (live progress displays).
        record : bool
            Keep every sample (``result.trajectory``).
        checkpoint : path-like, optional
            ``.npz`` file rewritten atomically every ``checkpoint_every`` cycles (and after the first and the last)
            with everything needed by :meth:`resume`, and the robot's own state when it offers ``robot_state()``.
        checkpoint_every : int
        checkpoint_tag : dict, optional
            JSON values stored in the checkpoint as ``tag`` and kept by :meth:`resume`.
        stop : callable or path-like, optional
            Asked after every cycle: a callable ``stop() -> bool``, or a file whose existence ends the run. The
            run then ends as at its budget (its checkpoint written, its result returned).
        """
        parts = self.composition()
        owner = "InSituOptimizer.run"
        check_callback(callback, record, owner)
        n_cycles = check_budget(n_cycles, parts, owner)
        stop = stop_rule(stop, owner)
        checkpoint_every = check_int(checkpoint_every, "checkpoint_every", owner, minimum=1)
        if ceiling is not None:
            ceiling = check_float(ceiling, "ceiling", owner, low=0, low_open=True)
        checkpoint = checkpoint_path(checkpoint, owner)
        template = model_template(self.model)
        if checkpoint is not None and "save" not in model_capabilities(template):
            raise fail("checkpoint", owner, f"None for a {type(template).__name__}, which cannot be saved",
                       str(checkpoint))
        spec = read_robot_spec(robot, owner)
        period = check_float(robot.cycle_period, "robot.cycle_period", owner, low=0, low_open=True)
        if self.order < robot.gait.highest_harmonic():
            raise fail("order", owner, f"at least the highest harmonic of the robot's seed gait "
                       f"({robot.gait.highest_harmonic()}), which would be dropped", self.order)
        check_gait_size(robot.gait.n_joints, self.order, owner, speed_limit=parts.limits.max_joint_velocity is not None)
        gait = robot.gait.with_order(self.order)
        limits = parts.limits
        check_within_joint_ranges(gait, spec, "robot", owner, what="seed gait")
        r_max = joint_limit(limits, spec)
        reach = gait.joint_limit().max()
        if reach > r_max + 1e-12:
            if limits.max_joint_angle == "auto":  # (the limit the robot declares)
                source = "the nearest bound of the joint_ranges it declares; a larger max_joint_angle lets it start, " \
                    "and the joint_ranges still hold" if spec.joint_ranges is not None \
                    else "the default joint limit: it declares no joint_ranges; give max_joint_angle"
                raise fail("robot", owner, f"a seed gait within the automatic joint limit, {r_max:.4g} rad ({source})",
                           f"a gait reaching {reach:.4g} rad")
            raise fail("max_joint_angle", owner, f"at least the largest joint angle of the robot's seed gait "
                       f"({reach:.4g} rad), where the run starts", r_max)
        if limits.max_joint_velocity is not None:
            speed = peak_phase_speed(gait) * 2 * np.pi / period
            if speed > limits.max_joint_velocity * (1 + 1e-9):
                raise fail("max_joint_velocity", owner, f"at least the peak joint speed of the robot's seed gait "
                           f"({speed:.4g} rad/s), where the run starts", limits.max_joint_velocity)
        periods = period_range(parts.period, spec, period, owner)
        excites = commands_excitation(self.exploration, spec, owner)
        family = gait_family(self, spec, gait)
        feasibility = spec_feasibility(spec, gait.n_joints, self.order, r_max)
        if feasibility is not None and feasibility(gait.params)[0].min() < -FEASIBILITY_TOLERANCE:
            raise fail("robot", owner, "a seed gait inside the robot's feasible region (its system's singular set's "
                       "margin, or the region it declares; e.g. the system's own seed_gait())",
                       "a seed gait that leaves it")
        scale = shape_scale(limits, gait)
        check = model_class_check(parts, spec, gait, period, periods, owner)
        model = run_model(self.model, gait, period, family, scale)
        if "memory" in model_capabilities(model):
            check_bytes(model.memory_bytes(gait.n_joints), f"a {type(model).__name__} of {gait.n_joints} joints", owner,
                        "fewer joints, or a model of fewer weights")
        robot.set_gait(gait)  # (every check passed: a refused run leaves the robot as it was)
        state = RunState(gait=gait, radius=parts.step.trust_radius * scale, model=model,
                         n_cycles=n_cycles, ceiling=ceiling, period=period, family=family,
                         settle_left=settle_at_start(parts.safety, spec), max_joint_angle=r_max, scale=scale,
                         settle_cycles=settle_at_start(parts.safety, spec),
                         settle_due=parts.safety.settle_cycles == "auto" and spec.settle_cycles is None,
                         feasibility=feasibility, robot_period=period, seed_period=period,
                         period_search=PeriodLineSearch(*periods) if periods is not None else None,
                         climb=new_climb(parts.climb, scale), rng=np.random.default_rng(self.random_state))
        if excites:
            state.exploration = parts.exploration.signal(scale, gait.n_joints, state.rng)
        state.check = check
        if state.check is not None:  # the test's plan runs the start's settle cycles
            state.settle_left = 0
        loop = CycleLoop(self, parts, robot, spec, state, checkpoint, checkpoint_every, checkpoint_tag)
        return loop.run(callback, record, stop)

    @classmethod
    def resume(cls, checkpoint, robot, *, callback: Callable[[dict], None] | None = None,
               record: bool = False, n_cycles: int | None = None, stop=None) -> InSituResult:
        """Continue a run from its checkpoint file (written by :meth:`run`) to its cycle budget.

        A robot offering ``restore_robot_state`` (simulators: ``SwimmerStream``, ``MujocoRobot``) is put back
        exactly where the checkpoint left it, so the resumed run is bit-identical to an uninterrupted one. Any
        other robot continues from where it physically is, commanded the checkpoint's gait.

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
            New total cycle budget (counting the cycles already run); the checkpoint's by default (a run without a
            budget goes on without one).
        stop : callable or path-like, optional
            As in :meth:`run`.
        """
        check_callback(callback, record, "InSituOptimizer.resume")
        stop = stop_rule(stop, "InSituOptimizer.resume")
        path = Path(checkpoint)
        metadata, arrays = read_state(path, "checkpoint", CHECKPOINT_FORMAT, CHECKPOINT_VERSION)
        try:
            optimizer = cls(**params_from_json(metadata["params"])).validate()
            parts = optimizer.composition()
            state = RunState.from_checkpoint(metadata, arrays)
        except (KeyError, TypeError, ValueError, IndexError) as error:
            raise GeogaitError(f"{path} is an inconsistent optimiser checkpoint: {error}") from None
        if state.model is None:  # not fitted yet when saved (the "cycles" gate's first iteration)
            state.model = run_model(optimizer.model, state.gait, state.period, state.family,
                                    shape_scale(parts.limits, state.gaits[0]))
        spec = read_robot_spec(robot, "InSituOptimizer.resume")
        if robot.gait.n_joints != state.gait.n_joints:
            raise fail("robot", "InSituOptimizer.resume", f"a robot with {state.gait.n_joints} joints",
                       robot.gait.n_joints)
        state.max_joint_angle = joint_limit(parts.limits, spec)
        state.scale = shape_scale(parts.limits, state.gaits[0])
        if state.climb is None:  # checkpoints before the climb
            state.climb = new_climb(parts.climb, state.scale)
        if "rng" not in metadata["state"]:
            state.rng = np.random.default_rng(optimizer.random_state)
        state.feasibility = spec_feasibility(spec, state.gait.n_joints, optimizer.order, state.max_joint_angle)
        if "settle" not in metadata["state"]:  # (checkpoints before "auto")
            state.settle_cycles = settle_at_start(parts.safety, spec)
        if n_cycles is not None:
            n_cycles = check_budget(n_cycles, parts, "InSituOptimizer.resume")
            state.n_cycles = check_int(n_cycles, "n_cycles", "InSituOptimizer.resume", minimum=max(1, state.cycle))
        robot_state = metadata.get("robot_state")
        if robot_state is not None and spec.saves_state:
            robot.restore_robot_state({**robot_state, **prefixed_arrays(arrays, "robot/")})
        else:
            robot.set_gait(state.robot_gait)
            if state.period_search is not None and robot.cycle_period != state.robot_period:
                robot.set_cycle_period(state.robot_period)
        loop = CycleLoop(optimizer, parts, robot, spec, state, path, metadata["checkpoint_every"], metadata.get("tag"))
        return loop.run(callback, record, stop)
