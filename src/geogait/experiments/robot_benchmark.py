r"""Robot benchmark: geogait against black-box optimisers, on the same robots and the same cycles.

Every method optimises the same gait family of the same robot, under the same joint limit, judged by
the same **measured** objective (the net motion of a cycle from the robot's own poses, as
:func:`~geogait.optimize.measure_cycle` computes it), and is charged for **every cycle it makes the
robot run** — settling cycles included. Methods:

* ``geogait`` — :class:`~geogait.optimize.InSituOptimizer` with its defaults (the case only declares
  what a user must: objective, joint limit, settling cycles); the robot explores with its own
  perturbation (eq. 8), which is how geogait learns;
* ``geogait-climb`` — the same optimiser whose model predicts no motion (``_MotionlessModel``), so its
  measured climb (COBYQA, or its trust-region Bayesian search where COBYQA's design is long), which runs first,
  never hands the steps to the model: geogait's climb alone, everything else the same. Against ``geogait`` it
  says what the model's steps add;
* ``geogait-resistance`` — the same with :class:`~geogait.models.ResistanceModel` on the chain geometry the
  robot gives (``chain_geometry()``: the built-in and MuJoCo chains), SQP steps over a trust radius up to 0.5
  and the measured climb only when contradicted (:func:`~geogait.optimize.structured`); ``geogait-hybrid`` the
  same with a degree-2 polynomial residual fitted with the drags (mirror-symmetric where the robot's frame is on
  the chain's axis); cases whose robot gives no chain geometry skip both;
* ``geogait-batch`` — the prior-work batch method (Bittner et al. 2018): a
  :class:`~geogait.models.BatchGaitModel` refit every 30 perturbed cycles;
* ``cmaes`` / ``cmaes-tuned`` — CMA-ES (the ``cma`` package) from the seed gait: σ₀ = r_max / 3 and
  the default population (4 + ⌊3 ln n⌋) / σ₀ = r_max / 8 and a population of 5;
* ``tpe`` / ``tpe-tuned`` — Bayesian optimisation with optuna's tree-structured Parzen estimator:
  defaults on the box [−r_max, r_max]ⁿ / multivariate TPE with 5 start-up trials on the box
  seed ± r_max / 2, the seed gait as its first trial;
* ``cobyqa`` — SciPy's COBYQA (``scipy.optimize.minimize(method="COBYQA")``: a derivative-free
  trust-region method on quadratic models interpolated from the values it has seen) from the seed gait,
  initial trust radius r_max / 8 (restarted from its best point if it converges within the budget);
* ``ngopt`` — nevergrad's ``NGOpt``, the portfolio that black-box benchmarks recommend as a default (it picks
  its algorithm from the dimension, the budget in evaluations and the bounds), on the box [−r_max, r_max]ⁿ from
  the seed gait; it hands over its own recommendation;
* ``gp-bayes`` — Gaussian-process Bayesian optimisation (the ``bayesian-optimization`` package: a Matérn GP,
  the upper confidence bound κ = 2.576) on the box [−r_max, r_max]ⁿ, the seed gait its first point;
* ``random`` — random search in [−r_max, r_max]ⁿ after the seed gait (the floor).

A black-box method runs the robot **without exploration** (what a user of CMA-ES would do; sensor
noise stays): each candidate costs the case's settling cycles plus one measured cycle. A candidate
beyond the joint limit is scaled back onto it before it runs (the family is linear, so the scaled
gait stays in the family), and the method is told the value of the gait that ran. Each black-box
method is run twice: ``free`` (the objective alone, so a gait may turn), and ``held`` to the
rotation limit with the penalty :math:`f - w \max(0, |\Delta\theta| - \omega_{max})`,
:math:`w = 2 |f_{seed}| / \omega_{max}` (a gait turning 1.5 ω_max per cycle loses the seed's whole
progress). In the front–back symmetric family of the built-in swimmers nothing turns, so only ``free`` is
run there; in the half-wave symmetric family a body with inertia may still turn while it settles, so both
are run. geogait's gait family and rotation constraint are its own (its ``family="auto"`` on a case with a
rotation-free family, which picks that family from what the robot declares; zero predicted rotation in the
free family).

**What is reported**, at every ``checkpoint`` (cycles used): each method's current gait — geogait's
commanded gait, CMA-ES's mean, the best candidate so far for TPE and random search — re-run on a
clean robot from rest (no exploration, no sensor noise: the case's ``eval_settle_cycles``, then
``eval_cycles`` measured cycles), with its objective, net rotation per cycle, share of the ceiling where one is known
(the analytic swimmer's ceiling gait, re-run on the same clean robot) and a case's own score
(Gymnasium Swimmer-v5: the episode return). One run per method and seed serves every budget: a
method's state after ``c`` cycles does not depend on the budget beyond ``c``.

**Paired verdict** (:func:`verdicts`): at each checkpoint, geogait against the black-box method with the best
median among those whose median gait keeps the case's rotation limit (median |net rotation| per cycle ≤
``rotation_limit``; single seeds may turn more), and against its climb alone (``geogait-climb``: what the model's
steps add), seed by seed (:func:`paired_comparison`): in how many seeds geogait's gait is ahead, the median of the
paired differences and the two-sided Wilcoxon signed-rank test's p-value (ties dropped). A cell is *ahead* or
*behind* when that p-value, Holm-corrected over every cell of the table, is below 0.05, else *level*: medians over
seeds can flip on a difference no larger than the seeds' spread, and many cells tested at 0.05 each find some gaps
by chance. With n paired seeds the smallest p-value is 2¹⁻ⁿ, so a table of m cells needs m · 2¹⁻ⁿ < 0.05 to say
anything (16 seeds for up to about 1600 cells; 8 seeds for none). Gymnasium's swimmer is judged by its steady
forward speed against the gait a long search of the same family holds (:func:`long_search_ceiling`); its episode
return stays a reported column.

**Change cases** (:data:`CHANGE_CASES`): the robot changes before cycle :data:`CHANGE_AT`, unannounced
(:class:`~geogait.experiments.changes.ChangingRobot`); a run lasts that many cycles plus the budget, and every
gait is judged every :data:`CHANGE_GRID` cycles on the changed robot, against its ceiling (or, where none is
known, the gait :func:`long_search_ceiling` holds). Reported after the change: the held gait's share at
:data:`SINCE_CHANGE` cycles, the cycles to :data:`RECOVERED` of the ceiling and the offline error
(:func:`after_change`).
A black-box method that holds its best candidate never measures again and cannot see a change; each also runs with
**detect-and-restart** (``-restart``, change cases only; :class:`_Watch`): every 10th candidate its held gait runs
two measured cycles, and when both fall below its record (the best such pair's mean since it last started) by more
than 3 pooled standard deviations of a cycle, it restarts from that gait. ``cmaes`` itself never stops (no
tolerance ends it): it runs on continuously, sampling around its mean.

Seeds are paired: trial ``s`` of every method drives a robot seeded with ``SeedSequence(seed).spawn(n_seeds)[s]``
(same perturbation stream, same sensor noise); a black-box method's own random numbers come from the same child.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import platform
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from .. import __version__
from .._defaults import FEASIBILITY_TOLERANCE, MAX_JOINT_ANGLE
from .._files import write_text
from .._validation import GeogaitError, check_choice, check_float, check_int, fail
from ..gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, Perturbation, SymmetricGaitFamily, seed_gait
from ..models import AdaptiveGaitModel, ResistanceModel
from ..optimize import (
    Climb,
    InSituOptimizer,
    Objective,
    PeriodSearch,
    cached_ceiling,
    default,
    for_robot,
    measure_cycle,
    onto_joint_limit,
    prior_work,
    robot_feasibility,
    structured,
)
from ..plotting import plt, save_figure
from ..robots import RobotWrapper
from ..simulate import SwimmerStream, end_pose
from ..sweep import run_trials
from ..systems import FeasibleSystem, KinematicSnake, PurcellSwimmer

__all__ = ["BenchmarkCase", "CASES", "METHODS", "BLACK_BOX", "available_cases", "benchmark_trials", "case_optimizer",
           "run_robot_benchmark", "benchmark_table", "paired_comparison", "paired_test", "plot_benchmark",
           "evaluate_gait"]

_OWNER = "run_robot_benchmark"
#: Joint limit of geogait's design (rad), used by the built-in and MuJoCo Purcell swimmers.
_R_MAX = MAX_JOINT_ANGLE
#: Link lengths (tail first) of the unequal MuJoCo Purcell swimmer: no front–back symmetry.
UNEQUAL_LINKS = (0.3, 0.15, 0.2, 0.25, 0.1)
#: Gymnasium's Swimmer-v5: 1000 steps of 4 × 0.01 s; reward x-velocity − 1e-4 |a|².
_SWIMMER_V5_DT, _SWIMMER_V5_STEPS = 0.04, 1000


class _CountingRobot(RobotWrapper):
    """A robot that counts the cycles it runs (what every method is charged)."""

    def __init__(self, robot):
        super().__init__(robot)
        self.cycles = 0

    def next_cycle(self):
        self.cycles += 1
        return self.robot.next_cycle()


# -- cases --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchmarkCase:
    """A robot every method is run on.

    Attributes
    ----------
    name, description : str
    make_robot : callable
        ``make_robot(seed, explore, noise, gait=None) -> Robot``: ``explore`` switches the
        robot's own exploration perturbation, ``noise`` its sensor noise.
    objective : {"progress", "forward"}
        Distance per cycle (any direction), or signed progress along ``direction`` (body frame).
    direction : tuple of 2 floats or None
        Body-frame direction of ``"forward"``; None: the direction the seed gait moves in its clean
        run (what a user would declare as the robot's forward), measured once per benchmark.
    max_joint_angle : float
        Joint limit r_max (rad) of every gait a method may command.
    settle_cycles : int
        Cycles after a gait change before one is measured (a body with momentum, PD lag).
    family : {"free", "symmetric", "mirror"}
        Gait family every method searches (order 1): free, front–back symmetric about the seed's
        symmetry phase, or half-wave symmetric (:class:`~geogait.gaits.MirrorGaitFamily`); the last two
        are rotation-free.
    rotation_limit : float
        |net rotation| per cycle (rad) the ``held`` black-box variants are held to.
    eval_cycles : int
        Measured clean cycles per final-gait evaluation.
    declared : bool
        Whether geogait is told the case's ``settle_cycles`` and ``family`` (else it measures its settling and
        chooses its family itself: ``Safety(settle_cycles="auto")``, ``family="auto"``); the black-box methods run
        ``settle_cycles`` and ``family`` either way.
    eval_settle_cycles : int, optional
        Cycles a final-gait evaluation runs from rest before its measured ones (default ``settle_cycles``):
        enough for a body with momentum to reach the gait's steady speed, which one settling cycle after
        another gait (the methods' own measurements) need not be from rest.
    ceiling : callable, optional
        ``() -> FourierGait`` (or ``(gait, period)`` on a case with a ``period_range``): the gait whose clean
        objective on this robot is the ceiling (of a change case: on the changed robot).
    score : callable, optional
        ``(gait) -> float``: the case's own judgement of a gait (e.g. an episode return).
    score_name : str
    requires : tuple of str
        Optional modules the case needs (``"mujoco"``, ``"gymnasium"``, ``"dm_control"``, ``"elastica"``).
    checkpoints : tuple of int, optional
        Cycles at which gaits are evaluated (default every 10 cycles, 30 and 60); fewer for slow robots.
    period_range : tuple of 2 floats, optional
        (shortest, longest) cycle period (s) every method may choose: the objective is then per
        second and the period a decision variable (geogait's ``optimize_period``; one more
        coordinate, r_max · log(T / T₀), for the black-box methods). None: the robot's period.
    change_at : int, optional
        A change case: the robot (``make_robot``, a :class:`~geogait.experiments.changes.ChangingRobot`) changes
        before this cycle, unannounced; every gait is judged on ``make_changed_robot`` (the same robot changed
        from its first cycle), against that robot's ceiling. Its runs last ``change_at`` + the benchmark's budget.
    make_changed_robot : callable, optional
        As ``make_robot``, the robot after the change (a change case's judge).
    rotation_free_after_change : bool
        Whether the case's rotation-free family stays rotation-free after the change (False: a change that
        breaks the body's symmetry; the black-box methods then also run held to the rotation limit).
    """

    name: str
    description: str
    make_robot: Callable
    objective: str = "progress"
    direction: tuple | None = (1.0, 0.0)
    max_joint_angle: float = _R_MAX
    settle_cycles: int = 0
    declared: bool = True
    family: str = "free"
    rotation_limit: float = 0.02
    eval_cycles: int = 1
    eval_settle_cycles: int | None = None
    ceiling: Callable | None = None
    score: Callable | None = None
    score_name: str = ""
    requires: tuple = field(default_factory=tuple)
    checkpoints: tuple | None = None
    period_range: tuple | None = None
    change_at: int | None = None
    make_changed_robot: Callable | None = None
    rotation_free_after_change: bool = True

    def __post_init__(self):
        owner = f"BenchmarkCase {self.name!r}"
        check_choice(self.objective, "objective", owner, ("progress", "forward"))
        check_choice(self.family, "family", owner, ("symmetric", "mirror", "free"))
        check_int(self.settle_cycles, "settle_cycles", owner, minimum=0)
        check_int(self.eval_cycles, "eval_cycles", owner, minimum=1)
        if self.eval_settle_cycles is not None:
            check_int(self.eval_settle_cycles, "eval_settle_cycles", owner, minimum=0)
        if self.change_at is not None:
            check_int(self.change_at, "change_at", owner, minimum=1)
            if self.make_changed_robot is None:
                raise fail("make_changed_robot", owner, "the changed robot's factory of a change case", None)

    def judged_robot(self, seed=None, gait=None):
        """A clean robot (no exploration, no sensor noise) on which gaits are judged: of a change case, the
        changed one."""
        make = self.make_robot if self.change_at is None else self.make_changed_robot
        return make(seed, explore=False, noise=False, gait=gait)

    def missing(self) -> list[str]:
        """Optional modules this case needs that are not installed."""
        return [name for name in self.requires if importlib.util.find_spec(name) is None]


def _builtin_robot(n_links, seed, explore, noise, gait=None):
    swimmer = PurcellSwimmer(n_links)
    return SwimmerStream(swimmer, seed_gait(n_links - 1) if gait is None else gait, seed=seed,
                         sensor_noise=0.1 if noise else 0.0,
                         perturbation=None if explore else Perturbation(eta=0))


def _wheeled_snake_robot(seed, explore, noise, gait=None):
    snake = KinematicSnake()
    return SwimmerStream(snake, snake.seed_gait() if gait is None else gait, seed=seed,
                         sensor_noise=0.1 if noise else 0.0, perturbation=None if explore else Perturbation(eta=0))


def _wheeled_snake_ceiling():
    return cached_ceiling(KinematicSnake(), family="free").gait


def _builtin_ceiling(n_links):
    return cached_ceiling(PurcellSwimmer(n_links), family="symmetric").gait


def _mujoco_options(explore: bool, gait) -> dict:
    """MujocoRobot keywords of a case's robot: no exploration of its own unless asked, the gait if given."""
    options = {} if explore else {"perturbation": Perturbation(eta=0)}
    if gait is not None:
        options["gait"] = gait
    return options


def _mujoco_unequal_robot(seed, explore, noise, gait=None):
    from ..robots import MujocoRobot, purcell_swimmer_xml
    return MujocoRobot(purcell_swimmer_xml(5, link_lengths=UNEQUAL_LINKS), seed=seed,
                       **_mujoco_options(explore, gait))


def _mujoco_unequal_ceiling():
    return cached_ceiling(PurcellSwimmer(5, link_lengths=UNEQUAL_LINKS), family="free").gait


def _gymnasium_robot(seed, explore, noise, gait=None, start="gait", control="pd"):
    from ..robots import gymnasium_swimmer
    return gymnasium_swimmer(seed=seed, start=start, control=control, **_mujoco_options(explore, gait))


def _dm_control_robot(seed, explore, noise, gait=None):
    from ..robots import dm_control_swimmer
    return dm_control_swimmer(6, seed=seed, **_mujoco_options(explore, gait))


def _set_period(robot, period):
    if period is not None:
        robot.set_cycle_period(period)


def _elastica_robot(seed, explore, noise, gait=None):
    from ..robots import ElasticaSnake
    return ElasticaSnake(gait=gait, seed=seed, perturbation=None if explore else Perturbation(eta=0))


def swimmer_v5_return(gait: FourierGait, period: float | None = None, *, control: str = "pd") -> float:
    """Gymnasium Swimmer-v5's episode return of ``gait`` run at ``period`` s (default 2) from the
    environment's reset state, without exploration.

    The episode's forward reward sums the torso's x-velocity over 1000 steps of 0.04 s, which is
    (x(40 s) − x(0)) / 0.04 on the same MuJoCo model (``gymnasium:swimmer``) driven by
    :class:`~geogait.robots.MujocoRobot`'s tracking of the gait (``control``: its PD law, or
    ``"computed_torque"``), one torque per environment step. The episode starts as a reset does
    (without its noise): the body straight and still (``start="rest"``), so the first cycle drives the
    joints onto the gait; x(40 s) is interpolated between samples. The control cost (weight 1e-4,
    |a| ≤ 1 on two motors: at most 0.2 per episode) is left out.
    """
    robot = _gymnasium_robot(None, explore=False, noise=False, gait=gait, start="rest", control=control)
    _set_period(robot, period)
    duration = _SWIMMER_V5_DT * _SWIMMER_V5_STEPS
    time, x = [], []
    while not time or time[-1][-1] < duration:
        cycle = robot.next_cycle()
        step = cycle.time[-1] - cycle.time[-2]
        time.append(np.append(cycle.time, cycle.time[-1] + step))
        x.append(np.append(cycle.pose[:, 0], end_pose(cycle, robot.cycle_period)[0]))
    time, x = np.concatenate(time), np.concatenate(x)
    return float((np.interp(duration, time, x) - x[0]) / _SWIMMER_V5_DT)


def _cases() -> dict[str, BenchmarkCase]:
    cases = {}
    for n in (3, 5, 9):
        cases[f"swimmer{n}"] = BenchmarkCase(
            name=f"swimmer{n}", description=f"built-in {n}-link Purcell swimmer (RFT), sensor noise 0.1",
            make_robot=partial(_builtin_robot, n), family="symmetric", ceiling=partial(_builtin_ceiling, n))
    cases["wheeled-snake"] = BenchmarkCase(
        name="wheeled-snake", description="3-link wheeled kinematic snake (no-slip axles at the link centres), "
        "kept 0.2 rad from its singular line r0 = r1, sensor noise 0.1", make_robot=_wheeled_snake_robot,
        ceiling=_wheeled_snake_ceiling)
    cases["mujoco-purcell5-unequal"] = BenchmarkCase(
        name="mujoco-purcell5-unequal",
        description=f"MuJoCo 5-link Purcell swimmer, RFT drag, links {UNEQUAL_LINKS}, PD joints",
        make_robot=_mujoco_unequal_robot, settle_cycles=1, eval_cycles=2, ceiling=_mujoco_unequal_ceiling,
        family="mirror", requires=("mujoco",))
    cases["gymnasium-swimmer"] = BenchmarkCase(
        name="gymnasium-swimmer", description="Gymnasium Swimmer-v5 model (quadratic drag, inertia), PD joints, 2 s",
        make_robot=_gymnasium_robot, objective="forward", direction=(1.0, 0.0), max_joint_angle=1.745,
        settle_cycles=1, eval_cycles=2, eval_settle_cycles=4, score=swimmer_v5_return, score_name="episode return",
        ceiling=partial(long_search_ceiling, "gymnasium-swimmer"),
        family="mirror",
        requires=("mujoco", "gymnasium"), period_range=(0.5, 4.0))
    cases["dm-control-swimmer"] = BenchmarkCase(
        name="dm-control-swimmer", description="DeepMind Control Suite's 6-link swimmer (MuJoCo's inertia-based "
        "fluid model), PD on its motors, 4 s", make_robot=_dm_control_robot, objective="forward", direction=None,
        max_joint_angle=np.pi / 3, settle_cycles=1, eval_cycles=2, family="mirror", requires=("mujoco", "dm_control"))
    cases["elastica-snake"] = BenchmarkCase(
        name="elastica-snake", description="PyElastica continuum snake (Cosserat rod, anisotropic friction), "
        "4 curvature modes, 1 s", make_robot=_elastica_robot, objective="forward", direction=None,
        settle_cycles=1, eval_cycles=2, rotation_limit=0.05, family="mirror", requires=("elastica",),
        checkpoints=(30, 60, 100))
    return cases


#: Cycle before which a change case's robot changes.
CHANGE_AT = 60
#: Drag multipliers (longitudinal, lateral) of the built-in 5-link swimmer's links, tail first: both end links lose
#: 70 % of their lateral drag (front–back symmetry kept), or the head link alone does (symmetry broken).
ENDS_DRAG = ((1.0, 0.3), (1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (1.0, 0.3))
HEAD_DRAG = ((1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (1.0, 0.3))
#: The unequal MuJoCo chain's damaged link: its longest (the tail link, 0.3) loses 70 % of its lateral drag.
DAMAGED_LINK, DAMAGED_LATERAL = 0, 0.3
#: Gymnasium's swimmer's weakened joint: the first joint's gear (torque per control and largest torque) halved.
WEAK_GEAR = 0.5
#: The PyElastica snake's new floor: kinetic friction (forward, backward, lateral), lateral halved from (1, 1.5, 2).
NEW_FLOOR = (1.0, 1.5, 1.0)
#: Cycles of the long clean search whose held gait is a change case's ceiling where none is known.
LONG_SEARCH_CYCLES = 300


def _changing_robot(make_robot, change, at_cycle, seed, explore, noise, gait=None):
    from .changes import ChangingRobot
    return ChangingRobot(make_robot(seed, explore, noise, gait=gait), at_cycle, change)


def _change_case(base: BenchmarkCase, name: str, description: str, change, at_cycle: int = CHANGE_AT,
                 **fields) -> BenchmarkCase:
    """``base`` whose robot changes by ``change`` before cycle ``at_cycle``."""
    return dataclasses.replace(
        base, name=name, description=f"{base.description}; {description} before cycle {at_cycle}",
        make_robot=partial(_changing_robot, base.make_robot, change, at_cycle), change_at=at_cycle,
        make_changed_robot=partial(_changing_robot, base.make_robot, change, 0), **fields)


def _drag_ceiling(n_links: int, scale, family: str, link_lengths=None):
    return cached_ceiling(PurcellSwimmer(n_links, link_lengths=link_lengths, link_drag_scale=scale),
                          family=family).gait


def long_search_ceiling(name: str, cycles: int = LONG_SEARCH_CYCLES) -> tuple:
    """The ``(gait, period)`` that CMA-ES (σ₀ = r_max / 8, population 5, from the seed gait) holds after a long
    clean search (no exploration, no sensor noise) of ``cycles`` cycles on case ``name``'s judged robot, in the
    case's family: the reference of a case whose ceiling is not known otherwise."""
    case = directed(CASES[name])
    robot = _CountingRobot(case.judged_robot())
    family = _Family(case, robot.gait, robot.cycle_period)
    trace = _Trace(robot, family.gait(family.seed_params), family.period(family.seed_params))
    objective = _Objective(case, robot, family, cycles, held=False, seed_value=0.0)
    _cmaes(objective, trace, np.random.default_rng(0), tuned=True)
    return trace.at(cycles)


def _change_cases(cases: dict) -> dict:
    from .changes import elastica_friction, mujoco_joint_gear, mujoco_link_drag, swimmer_link_drag

    changed = [
        _change_case(cases["swimmer5"], "swimmer5-ends-drag", "both end links lose 70 % of their lateral drag",
                     swimmer_link_drag(ENDS_DRAG), ceiling=partial(_drag_ceiling, 5, ENDS_DRAG, "symmetric")),
        _change_case(cases["swimmer5"], "swimmer5-head-drag", "the head link loses 70 % of its lateral drag "
                     "(front–back symmetry broken; judged against the rotation-free ceiling of the free family)",
                     swimmer_link_drag(HEAD_DRAG), ceiling=partial(_drag_ceiling, 5, HEAD_DRAG, "free"),
                     rotation_free_after_change=False),
        _change_case(cases["mujoco-purcell5-unequal"], "mujoco-purcell5-damaged",
                     f"link {DAMAGED_LINK} loses {100 * (1 - DAMAGED_LATERAL):.0f} % of its lateral drag",
                     mujoco_link_drag(DAMAGED_LINK, lateral=DAMAGED_LATERAL),
                     ceiling=partial(_drag_ceiling, 5, tuple((1.0, DAMAGED_LATERAL if i == DAMAGED_LINK else 1.0)
                                                            for i in range(5)), "free", UNEQUAL_LINKS)),
        _change_case(cases["gymnasium-swimmer"], "gymnasium-swimmer-weak-joint",
                     f"the first joint's gear falls to {100 * WEAK_GEAR:.0f} %",
                     mujoco_joint_gear("motor1_rot", WEAK_GEAR),
                     ceiling=partial(long_search_ceiling, "gymnasium-swimmer-weak-joint"), score=None, score_name=""),
        _change_case(cases["elastica-snake"], "elastica-snake-new-floor",
                     f"the ground's kinetic friction becomes {NEW_FLOOR} (lateral halved)",
                     elastica_friction(NEW_FLOOR), ceiling=partial(long_search_ceiling, "elastica-snake-new-floor"),
                     checkpoints=None),
    ]
    return {case.name: case for case in changed}


class _UndeclaredRobot(RobotWrapper):
    """A robot as a user brings it: its joints (count, ranges and, where some shapes are out of reach, the region it
    may take), its period and what may be commanded (gait, period, excitation), and nothing else — no resistive
    medium, chain geometry, symmetry or simulator's truth."""

    MEMBERS = frozenset({"n_joints", "cycle_period", "gait", "set_gait", "next_cycle", "next_cycles", "joint_ranges",
                         "feasibility", "set_cycle_period", "set_excitation", "accepts_excitation", "close"})

    def __getattr__(self, name):
        if name == "robot" or name not in self.MEMBERS:
            raise AttributeError(name)
        if name == "feasibility":
            return self._region()
        return getattr(self.robot, name)

    def _region(self):
        """The shapes the robot may take, as a user's robot declares them: its own region, or the one its simulator's
        system has (the wheeled snake's margin from its singular set, which no gait may cross)."""
        own = getattr(self.robot, "feasibility", None)
        if callable(own):
            return own
        current = getattr(self.robot, "current_system", None)
        system = current() if callable(current) else None
        if isinstance(system, FeasibleSystem):
            return system.feasibility
        raise AttributeError("feasibility")


def _undeclared_robot(make_robot, seed, explore, noise, gait=None):
    return _UndeclaredRobot(make_robot(seed, explore, noise, gait=gait))


def _undeclared_cases(cases: dict) -> dict:
    """Every stationary case also as a user brings it (``<name>-undeclared``): the robot declares only its joints,
    period and objective (:class:`_UndeclaredRobot`); no settling cycles or symmetry declared, so every black-box
    method searches the free family and measures a candidate's first cycle, while geogait measures its own settling
    and chooses its family itself (``Safety(settle_cycles="auto")``, ``family="auto"``). Gaits are judged as in the
    case itself (its evaluation settling)."""
    return {f"{name}-undeclared": dataclasses.replace(
        case, name=f"{name}-undeclared", description=f"{case.description}; declaring only its joints, period and "
        "objective", make_robot=partial(_undeclared_robot, case.make_robot), settle_cycles=0, declared=False,
        family="free",
        eval_settle_cycles=case.settle_cycles if case.eval_settle_cycles is None else case.eval_settle_cycles)
        for name, case in cases.items()}


#: Every case, by name.
CASES = _cases()
CASES.update(_undeclared_cases(CASES))
CASES.update(_change_cases(CASES))
#: The change cases' names.
CHANGE_CASES = tuple(name for name, case in CASES.items() if case.change_at is not None)
#: The undeclared cases' names.
UNDECLARED_CASES = tuple(name for name in CASES if name.endswith("-undeclared"))


def available_cases(names: Sequence[str]) -> tuple[list[str], dict[str, str]]:
    """The cases of ``names`` that can run here, and why each other one is skipped."""
    run, skipped = [], {}
    for name in names:
        if name not in CASES:
            raise fail("cases", _OWNER, "names among " + ", ".join(CASES), name)
        missing = CASES[name].missing()
        if missing:
            extra = "elastica" if "elastica" in missing else "dmcontrol" if "dm_control" in missing else "mujoco"
            skipped[name] = f"needs {', '.join(missing)} (pip install 'geogait[{extra}]')"
        else:
            run.append(name)
    return run, skipped


# -- measuring ----------------------------------------------------------------------------------
def _value(case: BenchmarkCase, net: np.ndarray) -> float:
    if case.objective == "forward":
        return float(net[:2] @ np.asarray(case.direction, dtype=float) / np.hypot(*case.direction))
    return float(np.hypot(net[0], net[1]))


def _run_measured(robot, case: BenchmarkCase, gait: FourierGait, n_measured: int, period=None,
                  settle: int | None = None) -> np.ndarray:
    """Command ``gait`` (at ``period``), run ``settle`` cycles (default the case's settling cycles), return the
    net motion of ``n_measured`` cycles."""
    robot.set_gait(gait)
    _set_period(robot, period)
    for _ in range(case.settle_cycles if settle is None else settle):
        robot.next_cycle()
    return np.array([measure_cycle(robot.next_cycle(), gait, robot.cycle_period, _OWNER).net
                     for _ in range(n_measured)])


def seed_direction(case: BenchmarkCase) -> tuple:
    """Unit body-frame direction of the seed gait's clean motion per cycle."""
    robot = case.make_robot(None, explore=False, noise=False)
    net = _run_measured(robot, case, robot.gait, case.eval_cycles, settle=_eval_settle(case)).mean(axis=0)
    norm = np.hypot(net[0], net[1])
    if not norm > 0:
        raise GeogaitError(f"case {case.name}: the seed gait does not move, so it has no forward direction")
    return float(net[0] / norm), float(net[1] / norm)


def directed(case: BenchmarkCase) -> BenchmarkCase:
    """``case`` with its ``direction``: its own, or where it leaves it to be measured, the seed's
    (:func:`seed_direction`)."""
    return case if case.direction is not None else dataclasses.replace(case, direction=seed_direction(case))


def _eval_settle(case: BenchmarkCase) -> int:
    return case.settle_cycles if case.eval_settle_cycles is None else case.eval_settle_cycles


def evaluate_gait(case: BenchmarkCase, gait: FourierGait, period: float | None = None) -> dict:
    """A gait re-run clean (no exploration, no sensor noise) on a fresh robot of ``case`` (of a change case: the
    changed robot), from rest: its
    evaluation settling cycles (``eval_settle_cycles``), then ``eval_cycles`` measured ones.

    Returns
    -------
    dict
        ``objective`` (mean measured objective per cycle; per second for a case with a
        ``period_range``), ``rotation`` (mean net rotation per cycle, rad), ``period`` (s) and,
        when the case has one, ``score``.
    """
    owner = "evaluate_gait"
    if not isinstance(gait, FourierGait) or gait.joint_limit().max() > case.max_joint_angle * (1 + 1e-6):
        raise fail("gait", owner, f"a FourierGait within the case's joint limit {case.max_joint_angle:.4g} rad",
                   f"a gait reaching {gait.joint_limit().max():.4g} rad" if isinstance(gait, FourierGait) else gait)
    if period is not None:
        if case.period_range is None:
            raise fail("period", owner, f"None for case {case.name!r}, which runs at its robot's period", period)
        low, high = case.period_range
        check_float(period, "period", owner, low=low * (1 - 1e-6), high=high * (1 + 1e-6))
    robot = case.judged_robot(gait=gait)
    nets = _run_measured(robot, case, gait, case.eval_cycles, period, settle=_eval_settle(case))
    rate = 1 / robot.cycle_period if case.period_range is not None else 1.0
    result = {"objective": float(np.mean([_value(case, net) for net in nets])) * rate,
              "rotation": float(np.mean(nets[:, 2])), "period": float(robot.cycle_period)}
    if case.score is not None:
        result["score"] = case.score(gait, period) if case.period_range is not None else case.score(gait)
    return result


# -- the gait family shared by every method -----------------------------------------------------
class _Family:
    """Gait family of a case (order 1 for every method; studies may ask for more), with the joint-limit repair
    every black-box method uses."""

    def __init__(self, case: BenchmarkCase, seed: FourierGait, period: float, order: int = 1):
        self.family = {"symmetric": lambda: SymmetricGaitFamily.from_gait(seed, order=order),
                       "mirror": lambda: MirrorGaitFamily(seed.n_joints, order),
                       "free": lambda: FreeGaitFamily(seed.n_joints, order)}[case.family]()
        self.r_max = case.max_joint_angle
        self.period_range, self.seed_period = case.period_range, period
        self.seed_params = self.family.params_of(seed.with_order(order))
        if self.period_range is not None:  # one more coordinate: r_max · log(T / T₀)
            self.seed_params = np.append(self.seed_params, 0.0)

    def gait(self, params) -> FourierGait:
        """The gait of ``params``, scaled back onto the joint limit when beyond it."""
        return onto_joint_limit(self.family, np.asarray(params, dtype=float)[:self.family.n_params], self.r_max)

    def params(self, gait: FourierGait, period: float | None) -> np.ndarray:
        """The parameters of a gait of the family (and its period): the inverse of :meth:`gait` and :meth:`period`."""
        params = self.family.params_of(gait, tolerance=1e-8)
        if self.period_range is None:
            return params
        return np.append(params, self.r_max * np.log(period / self.seed_period))

    def period(self, params) -> float | None:
        """The period of ``params`` (None for a case at the robot's period), clipped to its range."""
        if self.period_range is None:
            return None
        period = self.seed_period * np.exp(float(np.asarray(params, dtype=float)[-1]) / self.r_max)
        return float(np.clip(period, *self.period_range))


# -- methods ------------------------------------------------------------------------------------
class _Trace:
    """The gait a method would hand over after each number of cycles used, and the steps it took: ``steps`` lists
    (cycles used when the step was decided, ``"model"`` or ``"measured"``)."""

    def __init__(self, robot: _CountingRobot, gait: FourierGait, period: float | None = None):
        self.robot = robot
        self.events = [(0, gait, period)]
        self.steps, self.restarts = [], []

    def step_counts(self, cycles: int) -> dict:
        """Steps decided within the first ``cycles`` cycles: by the model and on measured outcomes."""
        counts = {f"{kind}_steps": sum(1 for used, k in self.steps if k == kind and used <= cycles)
                  for kind in ("model", "measured")}
        return {**counts, "restarts": sum(1 for used in self.restarts if used <= cycles)}

    def recommend(self, gait: FourierGait, period: float | None = None):
        self.events.append((self.robot.cycles, gait, period))

    def at(self, cycles: int) -> tuple:
        """(gait, period) handed over after ``cycles`` cycles (period None: the robot's)."""
        return [(gait, period) for used, gait, period in self.events if used <= cycles][-1]


class _Objective:
    """Black-box evaluation of one candidate: charged cycles, measured (penalised) value.

    A candidate outside the robot's declared feasible region (:func:`~geogait.optimize.robot_feasibility`:
    e.g. the wheeled snake's margin from its singular set, on the phase grid geogait's steps use) is not run:
    it is answered with the worst value measured so far (the seed's before any), as geogait's own climb answers
    it, and charged no cycle. A method that keeps asking for such candidates stops after
    ``MAX_REFUSALS_PER_CYCLE`` × budget of them.
    """

    MAX_REFUSALS_PER_CYCLE = 20

    def __init__(self, case: BenchmarkCase, robot: _CountingRobot, family: _Family, budget: int,
                 held: bool, seed_value: float, watch: _Watch | None = None):
        self.case, self.robot, self.family, self.budget, self.watch = case, robot, family, budget, watch
        self.weight = 2 * abs(seed_value) / case.rotation_limit if held else 0.0
        self.region = robot_feasibility(robot, family.family.n_joints, family.family.order)
        self.worst, self.refused = seed_value, 0
        self.runs = []  # cycles used after each candidate that ran

    def affordable(self) -> bool:
        return (self.robot.cycles + self.case.settle_cycles + 1 <= self.budget
                and self.refused < self.MAX_REFUSALS_PER_CYCLE * self.budget)

    def __call__(self, params) -> float:
        gait, period = self.family.gait(params), self.family.period(params)
        if self.region is not None and self.region(gait.params)[0].min() < -FEASIBILITY_TOLERANCE:
            self.refused += 1
            return self.worst
        if self.watch is not None:
            self.watch.before_candidate(self)
        value = self.measure(gait, period, 1)[0]
        self.worst = min(self.worst, value)
        self.runs.append(self.robot.cycles)
        return value

    def measure(self, gait: FourierGait, period: float | None, n_measured: int) -> np.ndarray:
        """The (penalised) value of each of ``n_measured`` cycles of ``gait`` after the settling ones."""
        nets = _run_measured(self.robot, self.case, gait, n_measured, period)
        excess = np.maximum(0.0, np.abs(nets[:, 2]) - self.case.rotation_limit)
        rate = 1 / self.robot.cycle_period if period is not None else 1.0
        return np.array([_value(self.case, net) for net in nets]) * rate - self.weight * excess


class _Spent(Exception):
    """The budget cannot pay for another candidate."""


class _Restart(Exception):
    """A black-box method's held gait has fallen (:class:`_Watch`): the method starts afresh from ``params``."""

    def __init__(self, params: np.ndarray):
        super().__init__()
        self.params = params


class _Watch:
    """Detect-and-restart of a black-box method (its ``-restart`` variant).

    Before every ``RECHECK``-th candidate, the gait the method holds runs two measured cycles (after the case's
    settling ones, charged as any). When both fall below its record — the best mean of such a pair since the
    method last started — by more than ``NOISE`` standard deviations of a cycle's value (pooled over every pair
    measured, σ² = mean((a − b)²) / 2; from the second pair on), the method restarts from the gait it holds.
    """

    RECHECK, NOISE = 10, 3.0

    def __init__(self, trace: _Trace, family: _Family):
        self.trace, self.family = trace, family
        self.candidates, self.record, self.pairs = 0, -np.inf, []

    def before_candidate(self, objective: _Objective) -> None:
        self.candidates += 1
        settle = objective.case.settle_cycles
        if self.candidates % self.RECHECK or objective.robot.cycles + (settle + 2) + (settle + 1) > objective.budget:
            return  # (not its turn, or no room for the pair and the candidate after it)
        gait, period = self.trace.events[-1][1:]
        pair = objective.measure(gait, period, 2)
        self.pairs.append(pair)
        noise = np.sqrt(np.mean([(a - b) ** 2 for a, b in self.pairs]) / 2) if len(self.pairs) >= 2 else np.nan
        if np.isfinite(noise) and pair.max() < self.record - self.NOISE * noise:
            self.record = -np.inf
            self.trace.restarts.append(objective.robot.cycles)
            raise _Restart(self.family.params(gait, period))
        self.record = max(self.record, float(pair.mean()))




def _cmaes(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    import cma
    family = objective.family
    options = {"seed": int(rng.integers(1, 2**31 - 1)), "verbose": -9, "tolfun": 0, "tolx": 0,
               "tolflatfitness": 10**9, "tolstagnation": 10**9}
    if tuned:
        options["popsize"] = 5
    sigma = family.r_max / (8 if tuned else 3)
    strategy = cma.CMAEvolutionStrategy(family.seed_params if start is None else start, sigma, options)
    while objective.affordable():
        candidates = strategy.ask()
        values = []
        for candidate in candidates:
            if not objective.affordable():
                return
            values.append(-objective(candidate))
        strategy.tell(candidates, values)
        trace.recommend(family.gait(strategy.mean), family.period(strategy.mean))


def _tpe(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    import optuna
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    family = objective.family
    seed = family.seed_params if start is None else start
    half = family.r_max / 2 if tuned else family.r_max
    low, high = (seed - half, seed + half) if tuned else (np.full(seed.size, -half), np.full(seed.size, half))
    distributions = {f"p{i}": optuna.distributions.FloatDistribution(float(lo), float(hi))
                     for i, (lo, hi) in enumerate(zip(low, high, strict=True))}
    options = {"multivariate": True, "n_startup_trials": 5} if tuned else {}
    sampler = optuna.samplers.TPESampler(seed=int(rng.integers(2**31 - 1)), **options)
    study = optuna.create_study(direction="maximize", sampler=sampler)
    if tuned or start is not None:  # (a restart: from the gait it held, clipped into the box)
        study.enqueue_trial({f"p{i}": float(np.clip(v, lo, hi)) for i, (v, lo, hi) in enumerate(zip(seed, low, high,
                                                                                                      strict=True))})
    best = -np.inf
    while objective.affordable():
        trial = study.ask(distributions)
        params = np.array([trial.params[f"p{i}"] for i in range(seed.size)])
        value = objective(params)
        study.tell(trial, value)
        if value > best:
            best = value
            trace.recommend(family.gait(params), family.period(params))


def _cobyqa(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    from scipy.optimize import minimize
    family = objective.family
    best = [-np.inf]

    def loss(params):
        if not objective.affordable():  # (detect-and-restart's pairs took cycles its maxfev counted on)
            raise _Spent
        value = objective(params)
        if value > best[0]:
            best[0] = value
            trace.recommend(family.gait(params), family.period(params))
        return -value

    start = family.seed_params if start is None else start
    while objective.affordable():  # (afresh from the best candidate if it converges within the budget)
        left = (objective.budget - objective.robot.cycles) // (objective.case.settle_cycles + 1)
        try:
            result = minimize(loss, start, method="COBYQA",
                              options={"initial_tr_radius": family.r_max / 8, "final_tr_radius": 1e-3 * family.r_max,
                                       "maxfev": max(left, 1)})
        except _Spent:
            return
        start = result.x


def _ngopt(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    import nevergrad as ng
    with warnings.catch_warnings():  # the portfolio's members warn about settings of their own (bounds, COBYLA's ρ)
        warnings.simplefilter("ignore")
        _ngopt_loop(ng, objective, trace, rng, _box_start(objective.family, start))


def _box_start(family: _Family, start) -> np.ndarray:
    """A method's first point: the seed's parameters, or a restart's, clipped into the box [−r_max, r_max]ⁿ."""
    return np.clip(family.seed_params if start is None else start, -family.r_max, family.r_max)


def _ngopt_loop(ng, objective: _Objective, trace: _Trace, rng, start: np.ndarray):
    family = objective.family
    box = family.r_max
    parametrization = ng.p.Array(init=start).set_bounds(-box, box)
    parametrization.random_state = np.random.RandomState(int(rng.integers(2**31 - 1)))
    evaluations = max(objective.budget // (objective.case.settle_cycles + 1), 1)
    optimizer = ng.optimizers.NGOpt(parametrization=parametrization, budget=evaluations, num_workers=1)
    while objective.affordable():
        candidate = optimizer.ask()
        optimizer.tell(candidate, -objective(candidate.value))
        held = optimizer.provide_recommendation().value
        trace.recommend(family.gait(held), family.period(held))


def _gp_bayes(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    from bayes_opt import BayesianOptimization, UtilityFunction
    family = objective.family
    names = [f"p{i}" for i in range(family.seed_params.size)]
    bounds = {name: (-family.r_max, family.r_max) for name in names}
    optimizer = BayesianOptimization(f=None, pbounds=bounds, random_state=int(rng.integers(2**31 - 1)), verbose=0,
                                     allow_duplicate_points=True)
    utility = UtilityFunction(kind="ucb", kappa=2.576, xi=0.0)
    params, best = _box_start(family, start), -np.inf
    while objective.affordable():
        value = objective(params)
        optimizer.register(params=dict(zip(names, params, strict=True)), target=value)
        if value > best:
            best = value
            trace.recommend(family.gait(params), family.period(params))
        suggested = optimizer.suggest(utility)
        params = np.array([suggested[name] for name in names])


def _random(objective: _Objective, trace: _Trace, rng, tuned: bool, start=None):
    family = objective.family
    best, params = -np.inf, family.seed_params if start is None else start
    while objective.affordable():
        value = objective(params)
        if value > best:
            best = value
            trace.recommend(family.gait(params), family.period(params))
        params = rng.uniform(-family.r_max, family.r_max, family.seed_params.size)


BLACK_BOX = {"cmaes": partial(_cmaes, tuned=False), "cmaes-tuned": partial(_cmaes, tuned=True),
             "tpe": partial(_tpe, tuned=False), "tpe-tuned": partial(_tpe, tuned=True),
             "cobyqa": partial(_cobyqa, tuned=False), "ngopt": partial(_ngopt, tuned=False),
             "gp-bayes": partial(_gp_bayes, tuned=False), "random": partial(_random, tuned=False)}
#: Optional module each black-box method needs (``pip install 'geogait[baselines]'``).
_METHOD_REQUIRES = {"cmaes": "cma", "tpe": "optuna", "ngopt": "nevergrad", "gp-bayes": "bayes_opt"}
#: Method names: geogait (its default model, its measured climb alone, the resistance model on a chain whose geometry
#: the robot gives, the prior work's batch model) and each black-box method free and held to the rotation limit, and
#: with detect-and-restart (``-restart``: on change cases only).
METHODS = ("geogait", "geogait-climb", "geogait-resistance", "geogait-hybrid", "geogait-batch",
           *(f"{name}{variant}" for name in BLACK_BOX for variant in ("", "-held")),
           *(f"{name}-restart" for name in BLACK_BOX))


class _MotionlessModel(AdaptiveGaitModel):
    """An :class:`~geogait.models.AdaptiveGaitModel` that predicts no net motion for any gait.

    The measured climb hands the steps back to the model once the model predicts the measured gains of three of
    the climb's steps in a row; a model that predicts none never does, so with ``Climb(start="first")`` every step of
    the run is a climb step (``geogait-climb``: geogait's climb alone, everything else the same).
    """

    def predict_displacement(self, gait: FourierGait | None = None, *, jacobian: bool = False):
        zero = np.zeros(3)
        return (zero, np.zeros((3, gait.params.size))) if jacobian else zero


def _variant_optimizer(robot, variant: str) -> InSituOptimizer | None:
    """The preset of a geogait variant for ``robot``; None when the robot cannot run it (no chain geometry)."""
    if variant == "climb":  # its measured climb from the first decision to the last, never a model step
        return default(model=_MotionlessModel(), climb=Climb(start="first"))
    if variant == "batch":  # the prior work's loop (Bittner et al. 2018): a batch model, steps from it alone
        return prior_work()
    if variant in ("resistance", "hybrid"):
        try:
            geometry = robot.chain_geometry()
        except (AttributeError, GeogaitError):
            return None
        residual = {}
        if variant == "hybrid":  # a frame on the chain's axis keeps the mirror symmetry (A_x odd, A_y and A_θ even)
            x, y, angle = geometry["frame_offset"] or (0.0, 0.0, 0.0)
            on_axis = abs(y) < 1e-9 and min(abs(np.sin(angle)), 1.0) < 1e-9
            residual = {"residual_degree": 2, "residual_symmetry": "mirror" if on_axis else None}
        return structured(ResistanceModel(**geometry, **residual))
    return for_robot(robot)


def case_optimizer(case: BenchmarkCase, optimizer: InSituOptimizer | None = None, **params) -> InSituOptimizer:
    """The in-situ optimiser the benchmark runs on ``case``: ``optimizer`` (default: the library's defaults, every
    part spelled out) with the case's objective (``"forward"`` in the body frame), joint limit, settling cycles,
    gait family, period range and rotation limit (what the held black-box methods are held to), then ``params``.

    Parameters
    ----------
    case : BenchmarkCase
    optimizer : InSituOptimizer, optional
        A preset (:func:`~geogait.optimize.default` by default); its parts are changed in place.
    **params
        Further parameters, as :meth:`~geogait.optimize.InSituOptimizer.set_params` takes them.

    Returns
    -------
    InSituOptimizer
    """
    optimizer = default() if optimizer is None else optimizer
    settings = {"limits__max_joint_angle": case.max_joint_angle,
                "safety__settle_cycles": case.settle_cycles if case.declared else "auto",
                "family": "free" if case.family == "free" and case.declared else "auto",
                "step__rotation_tolerance": case.rotation_limit}
    if isinstance(optimizer.climb, Climb):
        settings["climb__rotation_tolerance"] = case.rotation_limit
    if case.objective == "forward":
        settings["objective"] = Objective(kind="forward", direction=case.direction, frame="body")
    if case.period_range is not None:
        settings["period"] = PeriodSearch(period_range=case.period_range)
    return optimizer.set_params(**settings).set_params(**params)


def _geogait(case: BenchmarkCase, robot: _CountingRobot, budget: int, variant: str, random_state: int,
             geogait_options: dict | None = None) -> _Trace:
    preset = _variant_optimizer(robot.robot, variant)
    if preset is None:
        raise GeogaitError(f"geogait-{variant} needs a robot that gives its chain geometry")
    # its exploration and climb: the seed's own random numbers
    optimizer = case_optimizer(case, preset, **(geogait_options or {}), random_state=random_state)
    seed, period = robot.gait, robot.cycle_period
    result = optimizer.run(robot, budget)
    log = result.log
    params = log.filter(like="param_").to_numpy()
    # after cycle c, the gait of the last cycle up to c that was not an unjudged trial
    kept = ~log["candidate"].to_numpy(dtype=bool)
    fixed = case.period_range is None
    trace = _Trace(robot, seed.with_order(1), None if fixed else period)
    trace.events += [(c, FourierGait.from_params(params[c], seed.n_joints),
                      None if fixed else float(log["cycle_period"].iloc[c])) for c in range(1, len(params)) if kept[c]]
    trace.events.append((budget, result.final_gait, None if fixed else result.cycle_period))
    # the steps as the run counts them (a period trial, a re-measured base and a change check are neither)
    by_model = np.diff(log["steps_by_model"].to_numpy(), prepend=0) > 0
    by_climb = np.diff(log["steps_by_climb"].to_numpy(), prepend=0) > 0
    trace.steps = [(c + 1, "model" if by_model[c] else "measured") for c in np.flatnonzero(by_model | by_climb)]
    trace.restarts = [event["cycle"] + 1 for event in result.changes]  # (detections, before the change too)
    return trace


def _run_method(case: BenchmarkCase, method: str, seed, budget: int, seed_value: float,
                geogait_options: dict | None = None) -> tuple[_Trace, int]:
    """One method's run; returns its trace and the cycles the robot ran."""
    # the method's own random numbers: a grandchild of the robot's seed (spawn() would change the seed)
    own = np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, 1))
    if method.startswith("geogait"):
        robot = _CountingRobot(case.make_robot(seed, explore=True, noise=True))
        trace = _geogait(case, robot, budget, method.removeprefix("geogait").removeprefix("-"),
                         int(own.generate_state(1)[0]), geogait_options)
        return trace, robot.cycles
    held = method.endswith("-held")
    robot = _CountingRobot(case.make_robot(seed, explore=False, noise=True))
    family = _Family(case, robot.gait, robot.cycle_period)
    trace = _Trace(robot, family.gait(family.seed_params), family.period(family.seed_params))
    watch = _Watch(trace, family) if method.endswith("-restart") else None
    objective = _Objective(case, robot, family, budget, held, seed_value, watch)
    rng = np.random.default_rng(own)
    start = None
    while True:
        try:
            BLACK_BOX[method.removesuffix("-held").removesuffix("-restart")](objective, trace, rng, start=start)
            break
        except _Restart as restart:
            start = restart.params
    trace.steps = [(used, "measured") for used in objective.runs]
    return trace, robot.cycles


# -- the sweep ----------------------------------------------------------------------------------
def benchmark_trials(trial_indices, seeds, *, case: str, methods: list, n_seeds: int, root_seed: int,
                     budget: int, checkpoints: list, seed_value: float, ceiling_value: float | None,
                     direction: list | None = None, geogait_options: dict | None = None) -> pd.DataFrame:
    """Trial function of :func:`~geogait.experiments.run_trials`: trial i is method ``i % M`` on
    paired seed ``i // M`` (the robot's seed is the seed's child, the same for every method)."""
    spec = CASES[case]
    if direction is not None:
        spec = dataclasses.replace(spec, direction=tuple(direction))
    children = np.random.SeedSequence(root_seed).spawn(n_seeds)
    rows = []
    for trial in trial_indices:
        seed_index, method = divmod(int(trial), len(methods))
        method = methods[method]
        start = time.perf_counter()
        trace, used = _run_method(spec, method, children[seed_index], budget, seed_value, geogait_options)
        elapsed = time.perf_counter() - start
        trial_rows = []
        for cycles in checkpoints:
            result = evaluate_gait(spec, *trace.at(cycles))
            trial_rows.append({"trial": int(trial), "case": case, "method": method, "seed": seed_index,
                               "cycles": cycles, "cycles_run": used, "seconds": elapsed, "period": result["period"],
                               "objective": result["objective"], "rotation": result["rotation"],
                               "improvement": result["objective"] / seed_value - 1,
                               "ceiling_fraction": result["objective"] / ceiling_value if ceiling_value else np.nan,
                               "score": result.get("score", np.nan), **trace.step_counts(cycles)})
        if spec.change_at is not None:
            recovery = after_change(trial_rows, spec.change_at)
            for row in trial_rows:
                row.update(recovery)
        rows += trial_rows
    return pd.DataFrame(rows)


#: Share of the post-change ceiling that counts as recovered.
RECOVERED = 0.9


def after_change(rows: Sequence[dict], change_at: int) -> dict:
    """A change case's trial judged after the change, from its checkpoints past ``change_at`` (``cycles`` and
    ``ceiling_fraction``: the held gait's share of the changed robot's ceiling).

    Returns
    -------
    dict
        ``offline_error``: the mean shortfall 1 − share of the held gait over those checkpoints (the moving-peaks
        benchmarks' offline error, sampled at the checkpoints; negative where a gait beats the ceiling), and
        ``recovery_cycles``: cycles after the change to the first checkpoint holding :data:`RECOVERED` of the
        ceiling (NaN: never within the run).
    """
    after = sorted((row["cycles"], row["ceiling_fraction"]) for row in rows if row["cycles"] > change_at)
    shares = np.array([share for _, share in after], dtype=float)
    reached = [cycles - change_at for cycles, share in after if share >= RECOVERED]
    return {"offline_error": float(np.mean(1 - shares)) if shares.size else np.nan,
            "recovery_cycles": float(reached[0]) if reached else np.nan}


#: Cycles between a change case's checkpoints.
CHANGE_GRID = 5
#: Cycles after the change at which a change case's table reports the held gaits.
SINCE_CHANGE = (10, 30, 60, 100)


def _case_schedule(case: BenchmarkCase, budget: int, checkpoints: Sequence[int]) -> tuple[int, list]:
    """A case's cycles and checkpoints: a change case runs ``change_at`` + ``budget`` cycles, judged every
    :data:`CHANGE_GRID` cycles (and at :data:`SINCE_CHANGE` after the change)."""
    if case.change_at is None:
        return budget, [c for c in (case.checkpoints or checkpoints) if c <= budget] or [budget]
    total = case.change_at + budget
    grid = {*range(0, total + 1, CHANGE_GRID), *(case.change_at + c for c in SINCE_CHANGE if c <= budget), total}
    return total, sorted(grid)


def run_robot_benchmark(cases: Sequence[str], methods: Sequence[str] = METHODS, *, n_seeds: int = 8,
                        budget: int = 100, checkpoints: Sequence[int] | None = None, seed: int = 0,
                        jobs: int = 1, scheduler=None, progress: bool = True, log=print,
                        geogait_options: dict | None = None) -> dict:
    """Run every method on every case over ``n_seeds`` paired seeds.

    Parameters
    ----------
    cases : sequence of str
        Names in :data:`CASES`; a case whose optional dependencies are missing is skipped with one
        line through ``log``.
    methods : sequence of str
        Names in :data:`METHODS`.
    n_seeds : int
    budget : int
        Cycles each method may make the robot run (on a change case: after the change).
    checkpoints : sequence of int, optional
        Cycles used at which each method's gait is evaluated clean; default every 10 up to the
        budget and 30, 60 (those within it).
    seed : int
        Root seed of the paired robot seeds.
    jobs, scheduler
        As :func:`~geogait.experiments.run_trials` (joblib processes or a Dask cluster).
    geogait_options : dict, optional
        :class:`~geogait.optimize.InSituOptimizer` parameters that every geogait method's run uses
        instead of its own (to compare optimiser settings on the same robots and seeds); recorded in
        the result's ``config``.

    Returns
    -------
    dict
        ``records`` (DataFrame, one row per case, method, seed and checkpoint), ``cases`` (per case:
        seed and ceiling objective, clean; description), ``skipped`` (case → reason), ``config``.
    """
    n_seeds = check_int(n_seeds, "n_seeds", _OWNER, minimum=1)
    budget = check_int(budget, "budget", _OWNER, minimum=2)
    for method in methods:
        if method not in METHODS:
            raise fail("methods", _OWNER, "names among " + ", ".join(METHODS), method)
    missing = {m: module for m in methods for prefix, module in _METHOD_REQUIRES.items()
               if m.startswith(prefix) and importlib.util.find_spec(module) is None}
    for method, module in missing.items():
        log(f"skipped method {method}: needs {module} (pip install 'geogait[baselines]')")
    methods = [m for m in methods if m not in missing]
    if geogait_options is not None:
        if not isinstance(geogait_options, dict):
            raise fail("geogait_options", _OWNER, "a dict of InSituOptimizer parameters", geogait_options)
        default().set_params(**geogait_options).validate()  # a bad name or value, before any run
    if checkpoints is None:
        checkpoints = sorted({*range(10, budget + 1, 10), *(c for c in (30, 60) if c <= budget), budget})
    checkpoints = [check_int(c, "checkpoints", _OWNER, minimum=0) for c in checkpoints]
    if max(checkpoints) > budget:
        raise fail("checkpoints", _OWNER, f"cycle counts within the budget ({budget})", max(checkpoints))
    names, skipped = available_cases(cases)
    for name, reason in skipped.items():
        log(f"skipped case {name}: {reason}")
    frames, described = [], {}
    for name in names:
        case = directed(CASES[name])
        # the built-in swimmers are principally kinematic: in their symmetric family nothing turns, and the held
        # variants would repeat the free runs exactly (a body with inertia may settle slowly, or not symmetrically)
        case_methods = [m for m in methods if not (case.family == "symmetric" and case.rotation_free_after_change
                                                   and m.endswith("-held"))
                        and not (case.change_at is None and m.endswith("-restart"))]  # (nothing to detect)
        probe = case.make_robot(None, explore=False, noise=False)
        for method in ("geogait-resistance", "geogait-hybrid"):
            if method in case_methods and _variant_optimizer(probe, "resistance") is None:
                log(f"skipped method {method} on {name}: its robot gives no chain geometry")
                case_methods.remove(method)
        seed_gait_ = probe.gait
        seed_result = evaluate_gait(case, seed_gait_)
        ceiling = None
        if case.ceiling is not None:
            reference = case.ceiling()
            ceiling = evaluate_gait(case, *(reference if isinstance(reference, tuple) else (reference,)))
        described[name] = {"description": case.description, "objective": case.objective,
                           "seed": seed_result, "ceiling": ceiling, "settle_cycles": case.settle_cycles,
                           "eval_settle_cycles": _eval_settle(case), "eval_cycles": case.eval_cycles,
                           "max_joint_angle": case.max_joint_angle, "rotation_limit": case.rotation_limit,
                           "family": case.family, "score": case.score_name or None,
                           "direction": list(case.direction), "change_at": case.change_at}
        case_budget, case_checkpoints = _case_schedule(case, budget, checkpoints)
        config = {"case": name, "methods": case_methods, "n_seeds": n_seeds, "root_seed": seed, "budget": case_budget,
                  "checkpoints": case_checkpoints, "seed_value": seed_result["objective"],
                  "ceiling_value": None if ceiling is None else ceiling["objective"],
                  "direction": list(case.direction), "geogait_options": geogait_options}
        sweep = run_trials(benchmark_trials, n_seeds * len(case_methods), seed=seed, jobs=jobs, scheduler=scheduler,
                           config=config, progress=progress, description=name)
        sweep.raise_on_failure()
        frames.append(sweep.frame)
    records = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    return {"records": records, "cases": described, "skipped": skipped,
            "config": {"cases": list(cases), "methods": list(methods), "n_seeds": n_seeds, "budget": budget,
                       "checkpoints": checkpoints, "seed": seed, "geogait_options": geogait_options}}


# -- reporting ----------------------------------------------------------------------------------
def _summary(records: pd.DataFrame, budgets: Sequence[int]) -> pd.DataFrame:
    records = records[records["cycles"].isin(budgets)].copy()
    records["abs_rotation"] = records["rotation"].abs()
    grouped = records.groupby(["case", "method", "cycles"], sort=False)
    summary = grouped.agg(objective=("objective", "median"), q25=("objective", lambda v: v.quantile(0.25)),
                          q75=("objective", lambda v: v.quantile(0.75)), improvement=("improvement", "median"),
                          ceiling=("ceiling_fraction", "median"), rotation=("abs_rotation", "median"),
                          score=("score", "median"), charged=("cycles_run", "max"), seeds=("seed", "nunique"),
                          **{c: (c, "median") for c in _STEP_COLUMNS if c in records})
    return summary.reset_index()


#: Steps per method (a manifest from before they were counted has none).
_STEP_COLUMNS = ("model_steps", "measured_steps")


def paired_comparison(result: dict, budgets: Sequence[int] = (30, 60, 100), method: str = "geogait",
                      rival: str | None = None) -> pd.DataFrame:
    """``method`` against the best black-box method (or ``rival``) at each checkpoint, paired by seed (module
    docstring).

    Parameters
    ----------
    result : dict
        :func:`run_robot_benchmark`'s result (or :func:`from_manifest`'s).
    budgets : sequence of int
        Checkpoints (cycles used) compared; those not recorded are left out.
    method : str
        The method compared (a geogait row).
    rival : str, optional
        The method it is compared with at every checkpoint (e.g. ``"geogait-climb"``: what the model adds); default
        the best black-box method there.

    Returns
    -------
    pandas.DataFrame
        One row per case and checkpoint with a black-box method keeping the rotation limit: ``case``,
        ``cycles``, ``method`` and its ``median`` and median |net rotation| per cycle (``rotation``), ``rival``
        and its ``rival_median`` (share of the ceiling, or improvement over the seed without one), ``ahead``
        (seeds where ``method``'s value is larger), ``seeds`` (paired), ``median_difference`` and ``p_value``
        (Wilcoxon signed-rank, two-sided; 1 when every pair ties).
    """
    records = result["records"]
    rows = []
    if records.empty:
        return pd.DataFrame(rows)
    black_box = {f"{name}{variant}" for name in BLACK_BOX for variant in ("", "-held", "-restart")}
    if rival is not None:
        black_box = {rival}
    summary = pd.concat([_summary(records[records["case"] == case], _judged_cycles(result["cases"][case], budgets))
                         for case in dict.fromkeys(records["case"])], ignore_index=True)
    for (case, cycles), block in summary.groupby(["case", "cycles"], sort=False):
        info = result["cases"][case]
        # the summary's median column, and the per-seed column it is the median of
        column, value = ("ceiling", "ceiling_fraction") if info["ceiling"] is not None else ("improvement",) * 2
        kept = block[block["method"].isin(black_box) & block[column].notna()
                     & ((block["rotation"] <= info["rotation_limit"]) | (rival is not None))]
        if kept.empty or method not in set(block["method"]):
            continue
        best = kept.loc[kept[column].idxmax()]
        at = records[(records["case"] == case) & (records["cycles"] == cycles)]
        ours = at[at["method"] == method].set_index("seed")[value]
        theirs = at[at["method"] == best["method"]].set_index("seed")[value]
        ours_row = block.loc[block["method"] == method].iloc[0]
        rows.append({"case": case, "cycles": int(cycles), "method": method, "median": float(ours_row[column]),
                     "rotation": float(ours_row["rotation"]),
                     "rival": best["method"], "rival_median": float(best[column]), **paired_test(ours, theirs)})
    return pd.DataFrame(rows)


#: Family-wise error rate of the verdict table (Holm's correction over its cells).
VERDICT_ALPHA = 0.05
#: What each verdict row compares geogait with: the best black-box method, and its climb alone.
VERSUS = {"best black-box": None, "climb alone": "geogait-climb"}


def verdicts(result: dict, budgets: Sequence[int] = (30, 60, 100)) -> pd.DataFrame:
    """The paired verdict table: geogait against the best black-box method and against its climb alone
    (``geogait-climb``), at every case's compared checkpoints (:func:`paired_comparison`), each cell *ahead* or
    *behind* where the two-sided Wilcoxon signed-rank test's p-value, Holm-corrected over every cell of the table,
    is below :data:`VERDICT_ALPHA` (the sign of the median paired difference says which), else *level*.

    Returns
    -------
    pandas.DataFrame
        :func:`paired_comparison`'s columns, ``versus`` (a key of :data:`VERSUS`), ``holm_p`` and ``verdict``.
    """
    frames = [paired_comparison(result, budgets, rival=rival).assign(versus=versus)
              for versus, rival in VERSUS.items()]
    table = pd.concat([f for f in frames if not f.empty], ignore_index=True) if any(not f.empty for f in frames) \
        else pd.DataFrame()
    if table.empty:
        return table
    table["holm_p"] = holm(table["p_value"].to_numpy())
    significant = table["holm_p"] < VERDICT_ALPHA
    table["verdict"] = np.where(significant & (table["median_difference"] > 0), "ahead",
                                np.where(significant & (table["median_difference"] < 0), "behind", "level"))
    return table


def holm(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values: the i-th smallest of m times (m − i + 1), made non-decreasing, at most 1."""
    p_values = np.asarray(p_values, dtype=float)
    order = np.argsort(p_values, kind="stable")
    scaled = p_values[order] * (p_values.size - np.arange(p_values.size))
    adjusted = np.empty_like(p_values)
    adjusted[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return adjusted


def verdict_lines(result: dict, budgets: Sequence[int] = (30, 60, 100)) -> list:
    """The verdict table (:func:`verdicts`) as markdown."""
    table = verdicts(result, budgets)
    if table.empty:
        return []
    lines = [f"geogait, paired by seed: a cell is ahead or behind where the two-sided Wilcoxon signed-rank test, "
             f"Holm-corrected over the table's {len(table)} cells, gives p < {VERDICT_ALPHA:g}; else level. Shares of "
             "the ceiling (improvement over the seed without one); the best black-box method is the one with the best "
             "median among those whose median gait keeps the rotation limit; geogait's median gait is marked where it "
             "turns beyond it.", "",
             "| case | cycles | versus | rival (median) | geogait (median) | geogait ahead in | median paired "
             "difference | p | Holm p | verdict |", "|---" * 10 + "|"]
    for row in table.itertuples():
        info = result["cases"][row.case]
        share = (lambda v: f"{100 * v:.1f} %") if info["ceiling"] is not None else (lambda v: f"{100 * v:+.1f} %")
        turns = f" (turns {row.rotation:.3f} rad per cycle)" if row.rotation > info["rotation_limit"] else ""
        lines.append(f"| {row.case} | {_cycles_label(info, row.cycles)} | {row.versus} | {row.rival} "
                     f"({share(row.rival_median)}) | {share(row.median)}{turns} | {row.ahead} of {row.seeds} | "
                     f"{100 * row.median_difference:+.1f} pt | {row.p_value:.2g} | {row.holm_p:.2g} | "
                     f"**{row.verdict}** |")
    return lines + [""]


def paired_test(ours: pd.Series, theirs: pd.Series) -> dict:
    """Two methods' values on the same seeds (series indexed by seed; seeds in only one are left out): ``ahead``
    (seeds where ``ours`` is larger), ``seeds`` (paired, without NaN), ``median_difference`` and the two-sided
    Wilcoxon signed-rank test's ``p_value`` (ties dropped; 1 when every pair ties). Values within 1e-9 tie: a
    manifest keeps ten decimals."""
    from scipy.stats import wilcoxon

    ours, theirs = ours.align(theirs, join="inner")
    difference = (ours - theirs).dropna().to_numpy(dtype=float)
    difference = np.where(np.abs(difference) <= 1e-9, 0.0, difference)
    nonzero = difference[difference != 0]
    return {"ahead": int(np.sum(difference > 0)), "seeds": int(difference.size),
            "median_difference": float(np.median(difference)) if difference.size else float("nan"),
            "p_value": float(wilcoxon(nonzero).pvalue) if nonzero.size else 1.0}


def _judged_cycles(info: dict, budgets: Sequence[int]) -> list:
    """The checkpoints a case is compared at: ``budgets``, or of a change case :data:`SINCE_CHANGE` after it."""
    change_at = info.get("change_at")
    return list(budgets) if change_at is None else [change_at + c for c in SINCE_CHANGE]


def _cycles_label(info: dict, cycles) -> str:
    change_at = info.get("change_at")
    return f"{cycles:.0f}" if change_at is None else f"+{cycles - change_at:.0f}"


def benchmark_table(result: dict, budgets: Sequence[int] = (30, 60, 100)) -> str:
    """Markdown table: per case and method, the median clean objective of the gait after each budget.

    Each cell is ``median share of the ceiling`` (or median improvement over the seed when no
    ceiling is known), the case's score where it has one, and the median |net rotation| per cycle
    (rad) of those gaits; the last column the median steps each method took within the last budget, from its model
    and on measured outcomes (a black-box method's candidates; geogait's climb). Above them, the paired verdict
    table (:func:`verdicts`).
    """
    records = result["records"]
    if records.empty:
        return "No case ran.\n"
    lines = verdict_lines(result, budgets)
    for case in dict.fromkeys(records["case"]):
        info = result["cases"][case]
        lines += _change_lines(result, case) if info.get("change_at") is not None else \
            _stationary_lines(result, case, budgets)
    return "\n".join(lines)


def _stationary_lines(result: dict, case: str, budgets: Sequence[int]) -> list:
    records = result["records"][result["records"]["case"] == case]
    budgets = [b for b in budgets if b in set(records["cycles"])]
    block = _summary(records, budgets)
    info = result["cases"][case]
    has_ceiling = info["ceiling"] is not None
    has_score = info["score"] is not None
    unit = "share of ceiling" if has_ceiling else ("improvement over seed")
    steps = all(c in block for c in _STEP_COLUMNS)
    lines = [f"**{case}** — {info['description']}; seed objective {info['seed']['objective']:.4g} per cycle"
              + (f", ceiling {info['ceiling']['objective']:.4g}" if has_ceiling else "")
              + (f", seed {info['score']} {info['seed']['score']:.1f}" if has_score else "") + ".", "",
              "| method | " + " | ".join(f"{b} cycles: {unit}" + (f" · {info['score']}" if has_score else "")
                                        + " · rotation" for b in budgets)
              + (f" | steps in {budgets[-1]} cycles: model · measured" if steps else "") + " |",
              "|---" * (len(budgets) + 1 + steps) + "|"]
    for method, rows in block.groupby("method", sort=False):
        cells = []
        for budget in budgets:
            row = rows[rows["cycles"] == budget]
            if row.empty:
                cells.append("—")
                continue
            row = row.iloc[0]
            value = row["ceiling"] if has_ceiling else row["improvement"]
            cell = f"{100 * value:.1f} %" if has_ceiling else f"{100 * value:+.1f} %"
            if has_score:
                cell += f" · {row['score']:.1f}"
            cells.append(cell + f" · {row['rotation']:.3f}")
        if steps:
            last = rows[rows["cycles"] == budgets[-1]]
            cells.append("—" if last.empty else f"{last['model_steps'].iloc[0]:.0f} · "
                         f"{last['measured_steps'].iloc[0]:.0f}")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def _change_lines(result: dict, case: str) -> list:
    """A change case's table: per method, the held gait's median share of the changed robot's ceiling at
    :data:`SINCE_CHANGE` cycles after the change, the cycles to :data:`RECOVERED` of it, the offline error,
    the rotation at the end and the steps taken after the change."""
    records = result["records"][result["records"]["case"] == case]
    info, change_at = result["cases"][case], result["cases"][case]["change_at"]
    end = int(records["cycles"].max())
    since = [c for c in SINCE_CHANGE if change_at + c <= end]
    lines = [f"**{case}** — {info['description']}; the changed robot's ceiling {info['ceiling']['objective']:.4g} "
             f"per cycle, the seed's {info['seed']['objective']:.4g}.", "",
             "| method | " + " | ".join(f"+{c}" for c in since) + f" | cycles to {100 * RECOVERED:.0f} % (seeds) | "
             f"offline error | rotation at +{end - change_at} | steps after the change: model · measured |",
             "|---" * (len(since) + 5) + "|"]
    for method, rows in records.groupby("method", sort=False):
        seeds = rows.groupby("seed")
        share = rows.groupby("cycles")["ceiling_fraction"].median()
        recovery = seeds["recovery_cycles"].first().fillna(np.inf)
        reached = int(np.isfinite(recovery).sum())
        median = float(np.median(recovery))
        steps = {kind: float(np.median(seeds.apply(lambda r, k=kind: _steps_between(r, k, change_at, end))))
                 for kind in _STEP_COLUMNS}
        cells = [f"{100 * share.get(change_at + c, np.nan):.1f} %" for c in since]
        recovered = f"{median:.0f}" if np.isfinite(median) else f"> {end - change_at}"
        cells += [f"{recovered} ({reached} of {len(recovery)})",
                  f"{100 * seeds['offline_error'].first().median():.1f} %",
                  f"{rows.loc[rows['cycles'] == end, 'rotation'].abs().median():.3f}",
                  f"{steps['model_steps']:.0f} · {steps['measured_steps']:.0f}"]
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return lines + ["", "Shares of the changed robot's ceiling; the offline error is the mean shortfall of the held "
                    f"gait from it over the checkpoints after the change (every {CHANGE_GRID} cycles).", ""]


def _steps_between(rows: pd.DataFrame, column: str, start: int, end: int) -> float:
    counts = rows.set_index("cycles")[column]
    return float(counts.get(end, np.nan) - counts.get(start, np.nan))


def plot_benchmark(result: dict, path) -> Path:
    """Clean objective of each method's gait against cycles used: median and interquartile band per
    method, one panel per case (share of the ceiling where known, else relative to the seed; a change case's
    gaits judged on the changed robot, the change marked).

    One colour per method; geogait solid, black-box methods dotted when free and dashed when held to
    the rotation limit.
    """
    records = result["records"]
    names = list(dict.fromkeys(records["case"]))
    columns = min(3, len(names))
    rows = -(-len(names) // columns)
    entries = records["method"].nunique()
    legend_columns = min(6, 3 * columns)  # (as many as a row of panels is wide for)
    legend_rows = -(-entries // legend_columns) + 2  # (and its two-line title)
    # (at least as wide as the two-line title, which one panel's width would cut)
    figure = plt.figure(figsize=(max(5.2 * columns, 7.5), 3.6 * rows + 0.3 * legend_rows + 0.8))
    grid = figure.add_gridspec(rows + 1, columns, height_ratios=[3.6] * rows + [0.3 * legend_rows])
    axes = np.array([figure.add_subplot(grid[r, c]) for r in range(rows) for c in range(columns)])
    legend_axis = figure.add_subplot(grid[rows, :])  # a row of its own, across every column
    legend_axis.axis("off")
    bases = list(dict.fromkeys(_base(m) for m in records["method"]))
    palette = plt.get_cmap("tab10" if len(bases) <= 10 else "tab20").colors
    colours = {base: palette[i % len(palette)] for i, base in enumerate(bases)}
    handles = {}
    for ax, case in zip(axes, names, strict=False):
        block = records[records["case"] == case]
        has_ceiling = result["cases"][case]["ceiling"] is not None
        column = "ceiling_fraction" if has_ceiling else "improvement"
        for method in dict.fromkeys(block["method"]):
            data = block[block["method"] == method].groupby("cycles")[column]
            median, q25, q75 = data.median(), data.quantile(0.25), data.quantile(0.75)
            style = "-" if method.startswith("geogait") else \
                {"-held": "--", "-restart": "-."}.get(method[len(_base(method)):], ":")
            colour = colours[_base(method)]
            (line,) = ax.plot(median.index, median.to_numpy(), style, color=colour,
                              lw=2.4 if method == "geogait" else 1.3, label=method)
            ax.fill_between(median.index, q25.to_numpy(), q75.to_numpy(), color=colour, alpha=0.1)
            handles.setdefault(method, line)
        ax.axhline(1.0 if has_ceiling else 0.0, color="0.3", lw=0.8)
        change_at = result["cases"][case].get("change_at")
        if change_at is not None:
            ax.axvline(change_at, color="crimson", lw=1.0, ls="-.")
            ax.annotate("change", (change_at, 1.0), xytext=(3, -12), textcoords="offset points", color="crimson",
                        fontsize=8, xycoords=("data", "axes fraction"))
        ax.set_title(case, fontsize=10)
        ax.set_xlabel("cycles used (all charged)")
        ax.set_ylabel(("share of the changed robot's ceiling" if change_at is not None else "share of the ceiling")
                      if has_ceiling else "improvement over the seed")
        ax.grid(alpha=0.3)
    for ax in axes[len(names):]:
        ax.axis("off")
    order = [m for m in METHODS if m in handles]
    legend_axis.legend([handles[m] for m in order], order, loc="center", ncol=legend_columns, fontsize=9,
                       title="geogait solid · black-box dotted: free,\ndashed: held to the rotation limit, "
                       "dash-dotted: with detect-and-restart")
    figure.suptitle("Each method's gait re-run clean: median and interquartile band over paired seeds\n"
                    "(free black-box gaits may turn: see the rotation in the table)", fontsize=10)
    return save_figure(figure, path)


def _base(method: str) -> str:
    """A method's name without its variant (``-held``, ``-restart``): one colour per base method."""
    return method.removesuffix("-held").removesuffix("-restart")


def manifest(result: dict, command: str, wall_time: float) -> dict:
    """JSON manifest: versions, configuration, command, per-case seed/ceiling and every record."""
    import importlib.metadata as metadata

    def version(name):
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    records = result["records"]
    return {"benchmark": "geogait robot benchmark", "command": command, "wall_time_s": round(wall_time, 1),
            "versions": {"geogait": __version__, "numpy": np.__version__, "python": platform.python_version(),
                         **{name: version(name) for name in ("cma", "optuna", "nevergrad", "bayesian-optimization",
                                                             "mujoco", "gymnasium", "dm_control", "pyelastica")}},
            "config": result["config"], "cases": result["cases"], "skipped": result["skipped"],
            "records": json.loads(records.to_json(orient="records")) if not records.empty else []}


_NUMERIC = ("cycles", "cycles_run", "seconds", "objective", "rotation", "improvement", "ceiling_fraction", "score",
            "model_steps", "measured_steps", "restarts", "offline_error", "recovery_cycles")


def _numeric(records: pd.DataFrame) -> pd.DataFrame:
    """Numeric record columns as floats (JSON nulls of a case without a ceiling or score become NaN)."""
    records = records.copy()
    for column in _NUMERIC:
        if column in records:
            records[column] = pd.to_numeric(records[column], errors="coerce")
    return records


def from_manifest(path) -> dict:
    """The result stored in a manifest written by :func:`manifest` (to redraw table and figure)."""
    try:
        data = json.loads(Path(path).read_text())
        return {"records": _numeric(pd.DataFrame(data["records"])), "cases": data["cases"], "skipped": data["skipped"],
                "config": data["config"], "command": data["command"]}
    except (OSError, ValueError, KeyError, TypeError) as error:  # (TypeError: JSON that is not an object)
        raise GeogaitError(f"{path} is not a robot benchmark manifest: {error}") from None


def _case_key(described: dict, key: str):
    """A case's recorded setting (a manifest from before ``eval_settle_cycles``: its settling cycles)."""
    if key == "eval_settle_cycles" and key not in described:
        return described.get("settle_cycles")
    return described.get(key)


def _comparable(old: dict, new: dict) -> bool:
    """Whether records of a case described as ``old`` and as ``new`` (manifest ``cases`` entries) can sit in one
    table: the same gait family and evaluation, and the seed gait's clean objective the same to 1e-6 (so neither
    the robot nor its evaluation changed in between; a setting an older manifest did not record is not compared)."""
    keys = ("family", "eval_settle_cycles") + (("eval_cycles",) if "eval_cycles" in old else ())
    if any(_case_key(old, k) != _case_key(new, k) for k in keys):
        return False
    before, after = (float((d.get("seed") or {}).get("objective", np.nan)) for d in (old, new))
    return not (np.isfinite(before) and np.isfinite(after)) or abs(after - before) <= 1e-6 * max(abs(before), 1e-12)


def merge_results(old: dict, new: dict, command: str, log: Callable = print) -> tuple[dict, str]:
    """``old``'s records with those of ``new``'s cases and methods replaced by ``new``'s.

    Both runs must share budget and root seed, and the number of seeds unless ``new`` runs only cases ``old`` does
    not have (seed s is the same child of the root seed whatever their number, so the seeds stay paired; the
    merged ``config`` then lists each case's seeds in ``seeds_per_case``); the returned command names both runs.
    A case whose gait family or evaluation (settling and measured cycles) differs between the
    runs, or whose seed gait evaluates otherwise (the robot changed), is replaced whole: its records are not
    comparable.
    """
    only_new = not set(new["records"]["case"] if not new["records"].empty else []) & set(old["records"]["case"])
    keys = ("budget", "seed") if only_new else ("n_seeds", "budget", "seed")
    if any(old["config"][k] != new["config"][k] for k in keys):
        raise GeogaitError("--merge: the runs differ in " + ", ".join(
            f"{k} ({old['config'][k]} vs {new['config'][k]})" for k in keys if old["config"][k] != new["config"][k]))
    records = old["records"]
    changed = [c for c, described in new["cases"].items() if c in old["cases"]
               and not _comparable(old["cases"][c], described)]
    for case in changed:
        log(f"--merge: case {case} searched, run or evaluated otherwise than in the manifest (gait family, "
            "evaluation or the seed's clean objective differ): all its records replaced")
    records = records[~records["case"].isin(changed)]
    if not new["records"].empty:
        replaced = records.set_index(["case", "method"]).index.isin(
            new["records"].set_index(["case", "method"]).index.unique())
        records = _numeric(pd.concat([records[~replaced], new["records"]], ignore_index=True))
        case_order = {c: i for i, c in enumerate(dict.fromkeys(records["case"]))}
        order = records["case"].map(case_order) * len(METHODS) + records["method"].map(METHODS.index)
        records = records.iloc[np.argsort(order.to_numpy(), kind="stable")].reset_index(drop=True)
    config = {**old["config"], "cases": list(dict.fromkeys(old["config"]["cases"] + new["config"]["cases"])),
              "methods": list(dict.fromkeys(old["config"]["methods"] + new["config"]["methods"]))}
    if old["config"]["n_seeds"] != new["config"]["n_seeds"] or "seeds_per_case" in old["config"]:
        seeds = old["config"].get("seeds_per_case") or {c: old["config"]["n_seeds"] for c in old["config"]["cases"]}
        config["seeds_per_case"] = {**seeds, **{c: new["config"]["n_seeds"] for c in new["config"]["cases"]}}
        config["n_seeds"] = max(config["seeds_per_case"].values())
    merged = {"records": records, "cases": {**old["cases"], **new["cases"]},
              "skipped": {**old["skipped"], **new["skipped"]}, "config": config}
    return merged, f"{old.get('command', '')} && {command}"


def write_outputs(result: dict, folder, command: str, wall_time: float | None, budgets=(30, 60, 100)) -> dict:
    """``robots.md`` (table), ``robots.json`` (manifest; not rewritten when ``wall_time`` is None, a
    redraw), ``robots.csv`` and ``robots.png`` in ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    table = benchmark_table(result, budgets)
    write_text(folder / "robots.md", f"<!-- {command} -->\n\n{table}")
    paths = {"table": folder / "robots.md"}
    if wall_time is not None:
        write_text(folder / "robots.json", json.dumps(manifest(result, command, wall_time), indent=1, allow_nan=False))
        paths["manifest"] = folder / "robots.json"
    if not result["records"].empty:
        if wall_time is not None:
            write_text(folder / "robots.csv", result["records"].to_csv(index=False))  # (atomically, as the rest)
            paths["csv"] = folder / "robots.csv"
        paths["figure"] = plot_benchmark(result, folder / "robots.png")
    return paths
