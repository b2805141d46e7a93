r"""Steering gaits: the gait nearest a reference gait whose net motion per cycle matches a command.

With :math:`g(p) = (\Delta x, \Delta y, \Delta\theta)` the net SE(2) motion per cycle of the gait with
flat Fourier parameters :math:`p` — predicted by a gait model (:class:`ModelMotion`, eq. 3
integrated over a cycle) or exact with the true connection (:class:`TrueMotion`, the ceiling) — and
:math:`M` the rows of the command in the travel frame (step along the reference direction of travel
:math:`\alpha`, lateral step, turn), a steering gait solves

.. math:: \min_p \|p - p^*\|^2 \quad\text{s.t.}\quad M g(p) = c,\qquad |\theta_j(\phi)| \le r_{max}\ \forall\phi,

with :math:`p^*` the current optimum (the straight gait). Without active joint limits this is a
least-distance problem with nonlinear equality constraints, solved by sequential quadratic
programming in closed form (Gauss–Newton on the constraint, exact Jacobians):

.. math:: p_{k+1} = p^* + J^T (J J^T)^{-1}\bigl(c - M g(p_k) - J (p^* - p_k)\bigr),\qquad J = M\,\partial g/\partial p,

warm-started from a nearby solution; when the result breaks a joint limit, SLSQP solves the problem
with the linear joint-limit inequalities of :func:`geogait.optimize.joint_limit_constraints`.
Sweeping the commanded turn gives a one-parameter **steering family** (turning rate vs step size).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .._defaults import MAX_JOINT_ANGLE
from .._validation import check_array, check_float, check_int, fail
from ..gaits import FourierGait
from ..models import ModelMotion
from ..optimize import joint_limit_constraints

__all__ = ["ModelMotion", "SteeringSolution", "SteeringFamily", "travel_rows",
           "solve_steering_gait", "steering_family", "max_step_family", "max_feasible_turn", "TURN_SPACING"]

DEFAULT_MAX_JOINT_ANGLE = MAX_JOINT_ANGLE
TURN_SPACING = 0.1
"""Spacing of a steering family's turns (rad per cycle) where none is given."""


def travel_rows(direction: float) -> np.ndarray:
    """Rows ``(3, 3)`` mapping body-frame motion ``(Δx, Δy, Δθ)`` to (step along ``direction``,
    lateral step to its left, turn)."""
    cos, sin = np.cos(direction), np.sin(direction)
    return np.array([[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class SteeringSolution:
    """Outcome of :func:`solve_steering_gait`.

    Attributes
    ----------
    gait : FourierGait
        The steering gait.
    pose : ndarray of shape (3,)
        Its net motion per cycle ``(Δx, Δy, Δθ)`` (body frame) under the motion used to solve.
    residual : float
        Largest violation of the commanded components.
    converged : bool
        Residual below the tolerance and joint limits met.
    """

    gait: FourierGait
    pose: np.ndarray
    residual: float
    converged: bool


def _check_target(target, owner) -> np.ndarray:
    """(step, lateral, turn) with NaN for free components; at least one given, none infinite."""
    expected = "an array of 3 finite numbers or NaN (step, lateral, turn), at least one not NaN"
    try:
        target = np.asarray(target, dtype=float)
    except (TypeError, ValueError):
        raise fail("target", owner, expected, target) from None
    if target.shape != (3,) or np.any(np.isinf(target)) or np.all(np.isnan(target)):
        raise fail("target", owner, expected, target)
    return target


def solve_steering_gait(motion, reference: FourierGait, target, *, direction: float = 0.0,
                        start: FourierGait | None = None, max_joint_angle: float = DEFAULT_MAX_JOINT_ANGLE,
                        tolerance: float = 1e-7, max_iterations: int = 20, feasibility=None) -> SteeringSolution:
    r"""The gait nearest ``reference`` whose motion per cycle matches ``target`` (module docstring).

    Parameters
    ----------
    motion : callable
        ``motion(gait, jacobian=True) -> (pose (3,), jacobian (3, p))``: :class:`ModelMotion` or
        :class:`TrueMotion`.
    reference : FourierGait
        :math:`p^*`, the gait the steering gait should stay near (the straight optimum).
    target : array-like of shape (3,)
        Commanded (step along ``direction``, lateral step, turn) per cycle; NaN leaves a component
        free. ``[nan, nan, ω]`` asks only for a turning rate ω (rad per cycle).
    direction : float
        Travel direction α (rad) in the body frame that defines "step" and "lateral".
    start : FourierGait, optional
        Warm start (default ``reference``).
    max_joint_angle : float
        r_max (rad).
    tolerance : float
        On the commanded components (iterations also stop only once a step is below 1e-8 rad, so the
        solution is stationary: :math:`p - p^*` lies in the row space of :math:`J`).
    max_iterations : int
        Gauss–Newton iterations (then SLSQP iterations when a joint limit is active).
    feasibility : callable, optional
        A feasible shape region as rows on a phase grid (:func:`geogait.optimize.feasibility_constraint`
        of a :class:`~geogait.systems.FeasibleSystem`): the solution keeps it, as it keeps the joint
        limits (SLSQP inequalities; a Gauss–Newton solution outside it goes to SLSQP).

    Returns
    -------
    SteeringSolution

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import TrueMotion
    >>> motion = TrueMotion(PurcellSwimmer(3))
    >>> solution = solve_steering_gait(motion, seed_gait(2), [np.nan, np.nan, 0.05])
    >>> solution.converged, round(float(solution.pose[2]), 6)
    (True, 0.05)
    """
    owner = "solve_steering_gait"
    raw = _check_target(target, owner)
    if not isinstance(reference, FourierGait):
        raise fail("reference", owner, "a FourierGait", type(reference).__name__)
    start = reference if start is None else start
    if not isinstance(start, FourierGait) or start.coefficients.shape != reference.coefficients.shape:
        raise fail("start", owner, f"a FourierGait shaped like the reference {reference.coefficients.shape}", start)
    r_max = check_float(max_joint_angle, "max_joint_angle", owner, low=0, high=np.pi, low_open=True)
    tolerance = check_float(tolerance, "tolerance", owner, low=0, low_open=True)
    max_iterations = check_int(max_iterations, "max_iterations", owner, minimum=1)
    keep = np.isfinite(raw)
    rows = travel_rows(float(direction))[keep]
    goal = raw[keep]
    anchor = reference.params
    params = start.params
    region = _Region(feasibility)
    if start.joint_limit().max() > r_max - 1e-6 or region.active(params):  # a limit is active at the warm start
        return _solve_with_limits(motion, reference, rows, goal, r_max, params, tolerance, max_iterations, region)
    for _ in range(max_iterations):
        pose, jacobian = motion(reference.with_params(params), jacobian=True)
        residual = rows @ pose - goal
        matrix = rows @ jacobian
        gram = matrix @ matrix.T
        if not np.all(np.isfinite(gram)) or np.linalg.cond(gram) > 1e12:
            break
        update = anchor + matrix.T @ np.linalg.solve(gram, -residual - matrix @ (anchor - params))
        change = update - params
        norm = np.linalg.norm(change)
        if np.max(np.abs(residual), initial=0.0) <= tolerance and norm <= 1e-8:  # feasible and stationary
            break
        params = params + (change if norm <= 0.5 else change * 0.5 / norm)  # at most 0.5 rad per iteration
    pose = motion(reference.with_params(params))
    residual = float(np.max(np.abs(rows @ pose - goal), initial=0.0))
    if _within_limits(reference.with_params(params), r_max) and region.holds(params) and residual <= tolerance:
        return SteeringSolution(reference.with_params(params), pose, residual, True)
    return _solve_with_limits(motion, reference, rows, goal, r_max, params, tolerance, max_iterations, region)


class _Region:
    """A feasible region's rows (or none) for the steering solves: the SLSQP inequality and the checks."""

    def __init__(self, feasibility):
        if feasibility is not None and not callable(feasibility):
            raise fail("feasibility", "solve_steering_gait", "None or rows from feasibility_constraint", feasibility)
        self.rows = feasibility

    def active(self, params) -> bool:
        return self.rows is not None and float(self.rows(params)[0].min()) <= 1e-6

    def holds(self, params, slack: float = 1e-9) -> bool:
        return self.rows is None or float(self.rows(params)[0].min()) >= -slack

    def constraints(self) -> list:
        if self.rows is None:
            return []
        return [{"type": "ineq", "fun": lambda x: self.rows(x)[0], "jac": lambda x: self.rows(x)[1]}]


def _within_limits(gait: FourierGait, r_max: float) -> bool:
    return bool(gait.joint_limit().max() <= r_max + 1e-9)


def _limit_inequalities(reference: FourierGait, r_max: float):
    r"""Joint limits as SLSQP inequalities ``(fun, jac)`` with ``fun(p) >= 0``.

    Order 1 in closed form, :math:`r_{max} - |a_{j0}| - \sqrt{a_{j1}^2 + b_{j1}^2} \ge 0` (written
    as two smooth rows per joint, ±a_j0); higher orders through the linear phase-grid constraints of
    :func:`geogait.optimize.joint_limit_constraints`.
    """
    d = reference.n_joints
    if reference.order != 1:
        matrix, bound = joint_limit_constraints(d, reference.order, r_max)
        return (lambda x: bound - matrix @ x), (lambda x: -matrix)

    def split(x):
        c = x.reshape(d, 3)
        return c[:, 0], np.sqrt(c[:, 1] ** 2 + c[:, 2] ** 2 + 1e-24), c

    def fun(x):
        offset, radius, _ = split(x)
        return np.concatenate([r_max - offset - radius, r_max + offset - radius])

    def jac(x):
        offset, radius, c = split(x)
        upper, lower = np.zeros((d, d, 3)), np.zeros((d, d, 3))
        joints = np.arange(d)
        upper[joints, joints, 0], lower[joints, joints, 0] = -1.0, 1.0
        for block in (upper, lower):
            block[joints, joints, 1] = -c[:, 1] / radius
            block[joints, joints, 2] = -c[:, 2] / radius
        return np.concatenate([upper.reshape(d, -1), lower.reshape(d, -1)])

    return fun, jac


def _solve_with_limits(motion, reference, rows, goal, r_max, params, tolerance, max_iterations, region):
    """SLSQP with the joint-limit (and region) inequalities, from the given point pulled inside the limits."""
    excess = reference.with_params(params).joint_limit().max() / r_max
    if excess > 1:  # joint limits are |θ_j| <= r_max: shrink towards zero offset and amplitude
        params = params / (excess * (1 + 1e-6))
    limit_fun, limit_jac = _limit_inequalities(reference, r_max)
    cache = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = motion(reference.with_params(x), jacobian=True)
        return cache[key]

    anchor = reference.params
    constraints = [
        {"type": "eq", "fun": lambda x: rows @ evaluate(x)[0] - goal, "jac": lambda x: rows @ evaluate(x)[1]},
        {"type": "ineq", "fun": limit_fun, "jac": limit_jac},
        *region.constraints(),
    ]
    iterates = [params]

    def stationary(x):
        # the Gauss–Newton branch's test (feasible, last step below 1e-8 rad): SLSQP's own test on the
        # objective can miss at machine precision and then spends its remaining iterations in line searches
        step, iterates[0] = np.linalg.norm(x - iterates[0]), x.copy()
        if (step <= 1e-8 and np.max(np.abs(rows @ evaluate(x)[0] - goal), initial=0.0) <= tolerance
                and np.all(limit_fun(x) >= -1e-9) and region.holds(x)):
            raise StopIteration

    result = minimize(lambda x: float((x - anchor) @ (x - anchor)), params, jac=lambda x: 2 * (x - anchor),
                      method="SLSQP", constraints=constraints, callback=stationary,
                      options={"maxiter": max(30, 3 * max_iterations), "ftol": 1e-10})
    params = result.x
    pose = motion(reference.with_params(params))
    residual = float(np.max(np.abs(rows @ pose - goal), initial=0.0))
    return SteeringSolution(reference.with_params(params), pose, residual,
                            _within_limits(reference.with_params(params), r_max) and region.holds(params, 1e-6)
                            and residual <= max(tolerance, 1e-6))


@dataclass(frozen=True)
class SteeringFamily:
    """A one-parameter family of steering gaits, one per commanded turning rate.

    Attributes
    ----------
    turns : ndarray of shape (n,)
        Commanded turn per cycle (rad), increasing.
    gaits : tuple of FourierGait
    poses : ndarray of shape (n, 3)
        Net motion per cycle ``(Δx, Δy, Δθ)`` of each gait under the motion used to solve.
    feasible : ndarray of bool, shape (n,)
        The command was met within the joint limits.
    direction : float
        Travel direction α in the body frame (rad).
    """

    turns: np.ndarray
    gaits: tuple
    poses: np.ndarray
    feasible: np.ndarray
    direction: float = 0.0

    @property
    def steps(self) -> np.ndarray:
        """Step along the travel direction per cycle of each member (body lengths)."""
        return self.poses[:, :2] @ np.array([np.cos(self.direction), np.sin(self.direction)])

    @property
    def turn_range(self) -> tuple[float, float]:
        """Smallest and largest feasible turn (the contiguous feasible run around zero turn)."""
        _, turns = self._abscissa()
        return float(turns[0]), float(turns[-1])

    def usable(self) -> np.ndarray:
        """Boolean mask ``(n_members,)`` of the members a controller may use: the feasible ones in the
        contiguous run containing the member nearest zero turn."""
        ok = np.asarray(self.feasible, bool).copy()
        centre = int(np.argmin(np.abs(self.turns)))
        if not ok[centre]:
            raise fail("family", "SteeringFamily", "feasible at zero turn", "an infeasible straight gait")
        left = centre
        while left > 0 and ok[left - 1]:
            left -= 1
        right = centre
        while right < ok.size - 1 and ok[right + 1]:
            right += 1
        usable = np.zeros_like(ok)
        usable[left:right + 1] = True
        return usable

    def _abscissa(self) -> tuple[np.ndarray, np.ndarray]:
        """Usable members and their turns (the motion's own Δθ, increasing; the commanded turns
        where a re-prediction made them non-monotonic)."""
        ok = self.usable()
        turns = self.poses[ok, 2]
        if turns.size > 1 and np.any(np.diff(turns) <= 0):
            turns = self.turns[ok]
        return ok, turns

    def interpolate(self, turn) -> np.ndarray:
        """Motion ``(..., 3)`` per cycle at turns ``(...)``: Δx, Δy linear between members, Δθ = turn
        (clipped to :attr:`turn_range`)."""
        ok, turns = self._abscissa()
        poses = self.poses[ok]
        turn = np.clip(np.asarray(turn, dtype=float), turns[0], turns[-1])
        x = np.interp(turn, turns, poses[:, 0])
        y = np.interp(turn, turns, poses[:, 1])
        return np.stack([x, y, turn], axis=-1)

    def start_for(self, turn: float) -> FourierGait:
        """Warm start for ``turn``: parameters interpolated linearly between the neighbouring members."""
        ok, turns = self._abscissa()
        params = np.stack([g.params for g, use in zip(self.gaits, ok, strict=True) if use])
        turn = float(np.clip(turn, turns[0], turns[-1]))
        values = np.array([np.interp(turn, turns, params[:, k]) for k in range(params.shape[1])])
        return self.gaits[int(np.flatnonzero(ok)[0])].with_params(values)

    def repredicted(self, motion) -> SteeringFamily:
        """The same gaits with their motion per cycle predicted anew (e.g. by a model that has learned
        since the family was solved); feasibility is kept."""
        poses = np.stack([motion(gait) for gait in self.gaits])
        return SteeringFamily(turns=self.turns, gaits=self.gaits, poses=poses, feasible=self.feasible,
                              direction=self.direction)


def steering_family(motion, reference: FourierGait, turns, *, direction: float = 0.0, step: float | None = None,
                    previous: SteeringFamily | None = None, max_joint_angle: float = DEFAULT_MAX_JOINT_ANGLE,
                    max_iterations: int = 20, contiguous: bool = False, feasibility=None) -> SteeringFamily:
    """Steering gaits for each commanded turn (nearest ``reference``, module docstring).

    Parameters
    ----------
    motion : callable
        :class:`ModelMotion` or :class:`TrueMotion`.
    reference : FourierGait
    turns : array-like of shape (n,)
        Turning rates (rad per cycle), increasing.
    direction : float
        Travel direction α (rad, body frame).
    step : float, optional
        Also command this step along ``direction`` (default: step left free, the nearest gait).
    previous : SteeringFamily, optional
        Warm start member by member (continuation when the motion changes a little, e.g. a model
        learning cycle by cycle); otherwise each member starts from its solved neighbour nearer zero.
    max_joint_angle : float
    max_iterations : int
    contiguous : bool
        Solve outwards from zero turn only up to the first infeasible member on each side; the
        members beyond it (which :meth:`SteeringFamily.interpolate` never uses) are marked
        infeasible and copy that member's gait and motion. Saves the slow failing solves when the
        joint limits cut the family short.
    feasibility : callable, optional
        A feasible shape region every member keeps (:func:`solve_steering_gait`).

    Returns
    -------
    SteeringFamily
    """
    turns = _increasing_turns(turns, "steering_family")
    gaits, poses, feasible = [None] * turns.size, np.zeros((turns.size, 3)), np.zeros(turns.size, bool)
    order = np.argsort(np.abs(turns), kind="stable")
    use_previous = previous is not None and np.array_equal(previous.turns, turns)
    for index in order:
        inner = index + (1 if turns[index] < 0 else -1)  # the neighbour nearer zero turn
        if contiguous and turns[index] != 0 and 0 <= inner < turns.size and not feasible[inner]:
            gaits[index], poses[index] = gaits[inner], poses[inner]
            continue
        if use_previous:
            start = previous.gaits[index]
        else:
            solved = [k for k in range(turns.size) if gaits[k] is not None and feasible[k]]
            start = gaits[min(solved, key=lambda k: abs(turns[k] - turns[index]))] if solved else reference
        target = [np.nan if step is None else step, np.nan, turns[index]]
        solution = solve_steering_gait(motion, reference, target, direction=direction, start=start,
                                       max_joint_angle=max_joint_angle, max_iterations=max_iterations,
                                       feasibility=feasibility)
        gaits[index], poses[index], feasible[index] = solution.gait, solution.pose, solution.converged
    return SteeringFamily(turns=turns, gaits=tuple(gaits), poses=poses, feasible=feasible, direction=float(direction))


def max_feasible_turn(motion, reference: FourierGait, *, direction: float = 0.0, upper: float = 1.0,
                      spacing: float = TURN_SPACING, max_joint_angle: float = DEFAULT_MAX_JOINT_ANGLE,
                      feasibility=None) -> float:
    """Largest multiple of ``spacing`` up to ``upper`` that ``motion`` turns per cycle in both directions
    with a steering gait within the joint limits (a contiguous family, solved outwards from zero turn).

    Parameters
    ----------
    motion : callable
        :class:`ModelMotion` or :class:`TrueMotion`.
    reference : FourierGait
        The straight gait the steering gaits stay near.
    direction : float
        Travel direction α (rad, body frame).
    upper : float
        Largest turn (rad per cycle) asked for, at least ``spacing``.
    spacing : float
        Spacing of the turns tried (rad per cycle).
    max_joint_angle : float
        r_max (rad) of every steering gait.
    feasibility : callable, optional
        A feasible shape region every steering gait keeps (:func:`solve_steering_gait`).

    Returns
    -------
    float
        0 when the joint limits leave not even ``±spacing``.
    """
    owner = "max_feasible_turn"
    spacing = check_float(spacing, "spacing", owner, low=0, high=np.pi, low_open=True)
    upper = check_float(upper, "upper", owner, low=spacing, high=np.pi)
    n = int(np.floor(upper / spacing + 1e-9))
    family = steering_family(motion, reference, spacing * np.arange(-n, n + 1), direction=direction,
                             max_joint_angle=max_joint_angle, contiguous=True, feasibility=feasibility)
    if not family.feasible[n]:
        return 0.0
    low, high = family.turn_range
    return float(spacing * np.floor(min(-low, high) / spacing + 1e-9))


def _increasing_turns(turns, owner: str) -> np.ndarray:
    """``turns`` as a non-empty, strictly increasing float array (rad per cycle), or the standard error."""
    turns = np.asarray(check_array(turns, "turns", owner, ndim=1), dtype=float)
    if turns.size < 1 or np.any(np.diff(turns) <= 0):
        raise fail("turns", owner, "a non-empty increasing array", turns)
    return turns


def max_step_family(motion, start: FourierGait, turns, *, direction: float = 0.0,
                    max_joint_angle: float = DEFAULT_MAX_JOINT_ANGLE) -> SteeringFamily:
    r"""Optimal steering gaits: for each turn, the largest step along ``direction`` within the joint limits.

    .. math:: \max_p\ [\cos\alpha, \sin\alpha]\,t(p)\quad\text{s.t.}\quad \Delta\theta(p) = \omega,\
       |\theta_j(\phi)| \le r_{max}

    (SLSQP, exact Jacobians, continuation outward from ``start``). With :class:`TrueMotion` this is
    the ceiling of the steering family: no gait of the family turns by ω per cycle with a larger step.

    Parameters
    ----------
    motion : callable
    start : FourierGait
        The straight optimum (the zero-turn member's warm start).
    turns : array-like of shape (n,)
        Increasing turning rates (rad per cycle).
    direction : float
    max_joint_angle : float

    Returns
    -------
    SteeringFamily
    """
    turns = _increasing_turns(turns, "max_step_family")
    r_max = check_float(max_joint_angle, "max_joint_angle", "max_step_family", low=0, high=np.pi, low_open=True)
    limit_fun, limit_jac = _limit_inequalities(start, r_max)
    heading = np.array([np.cos(direction), np.sin(direction), 0.0])
    gaits, poses, feasible = [None] * turns.size, np.zeros((turns.size, 3)), np.zeros(turns.size, bool)
    for index in np.argsort(np.abs(turns), kind="stable"):
        solved = [k for k in range(turns.size) if gaits[k] is not None and feasible[k]]
        initial = gaits[min(solved, key=lambda k: abs(turns[k] - turns[index]))] if solved else start
        cache = {}

        def evaluate(x, cache=cache):
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = motion(start.with_params(x), jacobian=True)
            return cache[key]

        turn = turns[index]
        constraints = [{"type": "eq", "fun": lambda x, t=turn: evaluate(x)[0][2] - t,
                        "jac": lambda x: evaluate(x)[1][2:3]},
                       {"type": "ineq", "fun": limit_fun, "jac": limit_jac}]
        result = minimize(lambda x: -float(heading @ evaluate(x)[0]), initial.params,
                          jac=lambda x: -heading @ evaluate(x)[1], method="SLSQP", constraints=constraints,
                          options={"maxiter": 200, "ftol": 1e-10})
        gait = start.with_params(result.x)
        pose = motion(gait)
        gaits[index], poses[index] = gait, pose
        feasible[index] = bool(abs(pose[2] - turn) <= 1e-6 and _within_limits(gait, r_max))
    return SteeringFamily(turns=turns, gaits=tuple(gaits), poses=poses, feasible=feasible, direction=float(direction))
