r"""The measured climb's second rule: COBYQA on measured outcomes, one robot cycle at a time.

COBYQA (Ragonneau & Zhang, *COBYQA — Constrained Optimization BY Quadratic Approximations*, 2022;
``scipy.optimize.minimize(method="COBYQA")``, SciPy ≥ 1.14) is a derivative-free trust-region SQP
method in the line of Powell's NEWUOA and BOBYQA: it interpolates a quadratic model of the objective
from the values it has seen (minimum Frobenius norm of the Hessian's change while it has fewer than
(n+1)(n+2)/2 of them), steps to the model's optimum inside a trust region, and moves the region by the
ratio of measured to predicted decrease. On a smooth objective measured with little noise it needs far
fewer evaluations than an evolution strategy: it learns the curvature that a (1+1) strategy only
samples.

SciPy runs COBYQA as a callback loop; the in-situ optimiser needs it one measured candidate at a time,
across checkpoints. So the search *is* its history: :meth:`QuadraticSearch.ask` runs COBYQA afresh from
the same origin and answers every point it asks for from the values recorded so far (COBYQA is
deterministic), and stops it at the first point not measured yet — the next candidate. A replay of
k values costs k COBYQA iterations (milliseconds), far less than a robot's cycle.

Coordinates: the family's free parameters q, and with ``optimize_period`` one more,
``shape_scale · log(T / T₀)`` (within the period range: COBYQA keeps bounds exactly). A point beyond
the joint limit is run scaled back onto it (:func:`onto_joint_limit`, the gait's amplitude shrunk until
its largest joint angle is r_max), as a black-box method runs it: COBYQA then sees a continuous
objective, flat beyond the limit, and steps onto the limit as freely as anywhere. (Passed as COBYQA's
constraints instead — each joint's largest angle, known without running the robot — the limits held its
steps back near them, where optima of these families lie: on the robot benchmark PyElastica's snake
gained +106 / +144 % forward speed at 60 / 100 cycles with the limits as constraints and +125 / +161 %
scaled, Gymnasium's swimmer +49 / +54 % and +51 / +59 % (+56 / +61 % once a candidate the robot cannot
follow falls back to the climb's base), the 9-link swimmer 85.6 / 88.6 % of its ceiling
and 87.9 / 92.6 %.) A
feasible region is a known constraint, and in the free family the measured net rotation per cycle is a
constraint |c| ≤ the climb's rotation limit. A point outside the feasible region or the joint speed
limit is not run: it is answered with the worst value measured so far (and no rotation), so the search
turns back without costing a cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import NonlinearConstraint, minimize

__all__ = ["SEARCHES", "MeasuredSearch", "QuadraticSearch", "onto_joint_limit"]


def onto_joint_limit(family, params, max_joint_angle: float):
    """The gait of ``params`` in ``family``, its amplitude scaled back (all parameters by one factor) until its
    largest joint angle over the cycle is just inside ``max_joint_angle``; unchanged when already within it.

    The families' gaits are linear in their parameters, so the scaled gait keeps the shape of the one asked
    for. Returns a :class:`~geogait.gaits.FourierGait`.
    """
    params = np.asarray(params, dtype=float)
    reach = float(family.gait(params).joint_limit().max())
    scale = min(1.0, max_joint_angle * (1 - 1e-6) / reach) if reach > 0 else 1.0
    return family.gait(params * scale)


class _Ask(Exception):
    """COBYQA asked for a point whose value is not measured yet."""

    def __init__(self, point):
        super().__init__()
        self.point = np.array(point, dtype=float, copy=True)


#: Every search by its ``rule`` name (its checkpoint's "rule"): subclasses of :class:`MeasuredSearch` add themselves.
SEARCHES: dict = {}


@dataclass
class MeasuredSearch:
    """An ask/tell search on measured outcomes, the measured climb's rule: :meth:`ask` proposes the next point,
    :meth:`tell` records what the robot measured there. It keeps every point told, in order, with its measured
    objective and net rotation per cycle; a checkpoint of that history (and of a subclass's ``_checkpointed``
    fields) resumes the search exactly.

    A subclass names its ``rule`` (it is then found by that name in :data:`SEARCHES`) and implements
    :meth:`ask`; the climb reads three more class attributes: ``designing``, ``onto_joint_limit`` and
    ``remeasure_after``.

    Parameters
    ----------
    origin : ndarray of shape (n,)
        Start point (the climb's base) in the search's coordinates.
    radius, final_radius : float
        The search's initial and final step radius.
    period : float
        The origin's cycle period (with ``optimize_period`` the last coordinate is
        ``shape_scale · log(T / period)``).
    points, values, rotations : list
        Every point told, in order, with its measured objective (to maximise) and net rotation per cycle.
    """

    origin: np.ndarray
    radius: float
    final_radius: float
    period: float
    points: list = field(default_factory=list)
    values: list = field(default_factory=list)
    rotations: list = field(default_factory=list)

    rule = None  # the search's name, recorded in a checkpoint
    _checkpointed = ()  # further fields a checkpoint keeps (JSON values)
    #: The last value told belongs to a design of probes, not to a step of the search's own (the climb then does
    #: not count the model's predictions of it).
    designing = False
    #: A point beyond the joint limit is run scaled back onto it (True) or refused (False: :meth:`refuse`).
    onto_joint_limit = True
    #: Failed candidates in a row after which the climb measures its base again (None: never; a search that models
    #: every measured value corrects a lucky base itself).
    remeasure_after = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.rule is not None:
            SEARCHES[cls.rule] = cls

    def __post_init__(self):
        self.origin = np.asarray(self.origin, dtype=float)

    def ask(self, bounds=None, known=None, rotation_limit: float | None = None,
            rng: np.random.Generator | None = None) -> np.ndarray | None:
        """The next point to measure, or None when there is none (a search that has converged says so in
        :attr:`converged`; else the climb runs no candidate this cycle).

        Parameters
        ----------
        bounds : sequence of (low, high), optional
            Bounds on each coordinate (None or ±inf: unbounded).
        known : callable, optional
            Constraints computed without a measurement, ``known(x) -> (m,)``, feasible where ≤ 0.
        rotation_limit : float, optional
            Largest |net rotation| per cycle (a constraint on the measured rotations).
        rng : numpy.random.Generator, optional
            The run's generator, for a search that draws (its draws then resume exactly with the run's).
        """
        raise NotImplementedError(f"{type(self).__name__} proposes no points: a search implements ask")

    @property
    def converged(self) -> bool:
        """The search asks for nothing more (the climb then starts a fresh one from its base)."""
        return False

    def tell(self, point, value: float, rotation: float, kept: bool | None = None) -> None:
        """Record the measured ``value`` and net ``rotation`` of ``point`` (the one :meth:`ask` returned), and
        whether the climb ``kept`` it as its base (None: a point that was no candidate, the origin)."""
        self.points.append(np.asarray(point, dtype=float))
        self.values.append(float(value))
        self.rotations.append(float(rotation))

    def refuse(self, point) -> None:
        """Answer ``point`` unrun (beyond a limit it cannot be scaled to): no better than the worst value
        measured, and no rotation, so the search turns back."""
        self.tell(point, min(self.values), 0.0)

    def recentre(self, origin, period: float) -> None:
        """The climb's base moved to ``origin`` (coordinates at its own ``period``): a search that steps from
        the base follows it; one that models its own history ignores it."""

    def to_checkpoint(self, prefix: str) -> tuple[dict, dict]:
        """(metadata, arrays) of the search; arrays are named under ``prefix``."""
        metadata = {"rule": self.rule, "radius": self.radius, "final_radius": self.final_radius,
                    "period": self.period, **{name: getattr(self, name) for name in self._checkpointed}}
        arrays = {f"{prefix}/origin": self.origin,
                  f"{prefix}/points": np.reshape(np.asarray(self.points, dtype=float), (-1, self.origin.size)),
                  f"{prefix}/values": np.asarray(self.values, dtype=float),
                  f"{prefix}/rotations": np.asarray(self.rotations, dtype=float)}
        return metadata, arrays

    @classmethod
    def from_checkpoint(cls, metadata: dict, arrays: dict, prefix: str) -> MeasuredSearch:
        """The search of :meth:`to_checkpoint`'s ``metadata`` and ``arrays`` (of the class its rule names)."""
        if cls is MeasuredSearch:  # (checkpoints before the rule was recorded: COBYQA's)
            return SEARCHES.get(metadata.get("rule"), QuadraticSearch).from_checkpoint(metadata, arrays, prefix)
        return cls(origin=arrays[f"{prefix}/origin"], radius=metadata["radius"],
                   final_radius=metadata["final_radius"], period=metadata["period"],
                   points=list(arrays[f"{prefix}/points"]), values=arrays[f"{prefix}/values"].tolist(),
                   rotations=arrays[f"{prefix}/rotations"].tolist(),
                   **{name: metadata[name] for name in cls._checkpointed})


@dataclass
class QuadraticSearch(MeasuredSearch):
    """COBYQA's run from ``origin``, as the values measured so far (module docstring); parameters as
    :class:`MeasuredSearch` (``radius``, ``final_radius``: COBYQA's initial and final trust-region radius)."""

    _known_values: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _converged: bool = field(default=False, init=False, repr=False, compare=False)

    rule = "cobyqa"

    @property
    def designing(self) -> bool:
        """The last value told belongs to COBYQA's initial design (its first 2n + 1 points: the origin
        and ±radius along each coordinate), not to a step of its own model."""
        return len(self.values) <= 2 * self.origin.size + 1

    @property
    def converged(self) -> bool:
        """COBYQA stopped at its final radius."""
        return self._converged

    def ask(self, bounds=None, known=None, rotation_limit: float | None = None, rng=None) -> np.ndarray | None:
        """The next point to measure, or None when COBYQA has converged (its final radius); arguments as
        :meth:`MeasuredSearch.ask` (``rng`` unused: COBYQA draws nothing). ``known`` must be the same function at
        every call: its values are kept per point, since every replay asks for the same points again (on a robot
        with a feasible region the replays otherwise spend most of a run's time in it)."""
        index = {}  # distinct points in the order COBYQA asks for them: the k-th is the k-th recorded

        def recorded(x):
            key = np.asarray(x, dtype=float).tobytes()
            if key not in index:
                if len(index) >= len(self.values):
                    raise _Ask(x)
                index[key] = len(index)
            return index[key]

        constraints = []
        if known is not None:
            def remembered(x):
                key = np.asarray(x, dtype=float).tobytes()
                if key not in self._known_values:
                    self._known_values[key] = np.asarray(known(x), dtype=float)
                return self._known_values[key].copy()

            constraints.append(NonlinearConstraint(remembered, -np.inf, 0.0))
        if rotation_limit is not None:
            constraints.append(NonlinearConstraint(
                lambda x: (self.rotations[recorded(x)] / rotation_limit) ** 2, -np.inf, 1.0))
        try:
            minimize(lambda x: -self.values[recorded(x)], self.origin, method="COBYQA", bounds=bounds,
                     constraints=constraints,
                     options={"initial_tr_radius": self.radius, "final_tr_radius": self.final_radius,
                              "maxfev": 10**6, "disp": False})
        except _Ask as ask:
            return ask.point
        self._converged = True
        return None
