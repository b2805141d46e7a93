r"""Trust-region step rules on a model's predicted displacement, as standalone functions.

Both rules see the gait only through a *predictor* — ``predict(gait, jacobian=True)`` returning the
predicted net ``(x, y, heading)`` per cycle and its ``(3, p)`` Jacobian, e.g. a model's
``predict_displacement`` or the oracle — and search in the free parameters q of a gait family
(:class:`~geogait.gaits.FreeGaitFamily`, or the rotation-free
:class:`~geogait.gaits.SymmetricGaitFamily` and :class:`~geogait.gaits.MirrorGaitFamily`, where
p = T q). With objective f(q) (see
:mod:`geogait.optimize._objective`), predicted rotation c(q), trust radius R and joint limits
G T q ≤ h:

* :func:`linear_step` (the optimiser's rule so far): maximise the *linearised* objective,

  .. math:: \max_\Delta \nabla f^T\Delta \ \text{s.t.}\ c_0 + \nabla c^T\Delta = c^*,\
     \|\Delta\| \le R,\ G T (q_0 + \Delta) \le h,

  then Newton steps (minimum norm) bring the predicted rotation to its target c*, and the step
  halves (at most 4 times) until the predictor promises a gain. A linear model always steps to
  the boundary, and along a curved ridge (the 9-link swimmer's optimum) it zig-zags.
* :func:`sqp_step`: maximise the predictor's own *nonlinear* objective inside the trust region,

  .. math:: \max_\Delta f(q_0 + \Delta) \ \text{s.t.}\ c(q_0 + \Delta) = c^*,\
     \|\Delta\| \le R,\ G T (q_0 + \Delta) \le h,

  by sequential quadratic programming (SLSQP: a BFGS quasi-Newton Hessian of the Lagrangian built
  from the predictor's exact gradients), from Δ = 0. It follows the curvature the model knows,
  stops inside the region at a predicted optimum, and falls back to the same backtracking as the
  linear rule when the solver does not return a feasible gain.

In a rotation-free family (``rotation=False``) the rotation constraint is dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .._docs import fill_doc
from .._validation import check_choice, check_float, fail
from ..gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily
from ._objective import OBJECTIVES, objective

__all__ = ["STEP_RULES", "Step", "StepProblem", "linear_step", "sqp_step", "take_step"]

STEP_RULES = ("linear", "sqp")


@dataclass(frozen=True)
class Step:
    """Outcome of a step rule.

    Attributes
    ----------
    accepted : bool
        A feasible step with the predicted gain (or a restoring step) was found.
    params : ndarray of shape (n_params,)
        New free parameters (the old ones when not accepted).
    gait : FourierGait
    value_before, predicted_value : float
        Predicted objective at the old and the new gait.
    predicted_pose : ndarray of shape (3,)
        Predicted net motion of the new gait.
    length : float
        ‖Δ‖ in free parameters.
    boundary : bool
        The step reached 90 % of the trust radius (the ratio test may grow the radius).
    """

    accepted: bool
    params: np.ndarray
    gait: FourierGait
    value_before: float
    predicted_value: float
    predicted_pose: np.ndarray
    length: float
    boundary: bool


@dataclass
class StepProblem:
    """What a step rule needs: a predictor, a gait family, the objective and the constraints.

    Parameters
    ----------
    predict : callable
        ``predict(gait, jacobian=True)`` → ``(pose (3,), jacobian (3, d (2K+1)))``; with
        ``jacobian=False`` only the pose.
    family : FreeGaitFamily, SymmetricGaitFamily or MirrorGaitFamily
    objective : {"progress", "efficiency", "forward", "budget"}
    limits : tuple (G, h), optional
        Joint limits ``G p ≤ h`` on the Fourier parameters
        (:func:`~geogait.optimize.joint_limit_constraints`).
    rotation : bool, optional
        Constrain the predicted net rotation; default: only for a free family.
    rotation_tolerance : float
        Largest |predicted rotation − target| of an accepted step.
    direction : array-like of 2 floats, optional
        Direction of the ``"forward"`` objective (in the frame of the predicted pose).
    feasibility : callable, optional
        A system's feasible region as rows on a phase grid, ``f(p) -> (g (m,), dg/dp (m, d (2K+1)))``
        of the Fourier parameters p, feasible where g ≥ 0
        (:func:`~geogait.optimize.feasibility_constraint`); the linear step imposes its
        linearisation, the SQP step the rows themselves, and every accepted step satisfies them.
    """

    predict: Callable
    family: FreeGaitFamily | SymmetricGaitFamily | MirrorGaitFamily
    objective: str = "progress"
    limits: tuple | None = None
    rotation: bool | None = None
    rotation_tolerance: float = 1e-3
    direction: np.ndarray | None = None
    feasibility: Callable | None = None

    def __post_init__(self):
        owner = "StepProblem"
        if not callable(self.predict):
            raise fail("predict", owner, "callable as predict(gait, jacobian=...)", self.predict)
        if self.feasibility is not None and not callable(self.feasibility):
            raise fail("feasibility", owner, "callable as feasibility(params) -> (g, dg/dp)", self.feasibility)
        if not isinstance(self.family, FreeGaitFamily | SymmetricGaitFamily | MirrorGaitFamily):
            raise fail("family", owner, "a FreeGaitFamily, SymmetricGaitFamily or MirrorGaitFamily", self.family)
        check_choice(self.objective, "objective", owner, OBJECTIVES)
        check_float(self.rotation_tolerance, "rotation_tolerance", owner, low=0, low_open=True)
        if self.rotation is None:
            self.rotation = isinstance(self.family, FreeGaitFamily)
        matrix = self.family.matrix
        self.metric = matrix.T @ matrix  # ‖T Δq‖² = Δqᵀ (TᵀT) Δq: trust radius measured in Fourier parameters
        if self.limits is None:
            self._limit_matrix, self._limit_bound = np.zeros((0, matrix.shape[1])), np.zeros(0)
        else:
            self._limit_matrix, self._limit_bound = self.limits[0] @ matrix, np.asarray(self.limits[1], float)
        self._cache = {}

    def evaluate(self, params, jacobian: bool = True):
        """Predicted ``(value, gradient (n,), pose (3,), pose_jacobian (3, n))`` at free parameters ``params``
        (without ``jacobian``: value and pose only). The last point is cached."""
        params = np.asarray(params, dtype=float)
        key = (params.tobytes(), jacobian)
        if key in self._cache:
            return self._cache[key]
        gait = self.family.gait(params)
        if jacobian:
            pose, pose_jacobian = self.predict(gait, jacobian=True)
            value, gradient = objective(self.objective, pose, pose_jacobian, gait, self.direction)
            result = (float(value), gradient @ self.family.matrix, pose, pose_jacobian @ self.family.matrix)
        else:
            pose = self.predict(gait, jacobian=False)
            zero = np.zeros((3, gait.params.size))
            result = (float(objective(self.objective, pose, zero, gait, self.direction)[0]), pose)
        self._cache = {key: result}
        return result

    def length(self, direction) -> float:
        """‖T Δq‖ of a step ``direction`` Δq ``(n_params,)``: its length in Fourier parameters (what the trust
        radius bounds)."""
        return float(np.sqrt(direction @ self.metric @ direction))

    def slack(self, params) -> np.ndarray:
        """h − G T q of free parameters ``params`` ``(n_params,)`` (joint limits hold where ≥ 0)."""
        return self._limit_bound - self._limit_matrix @ params

    def region(self, params):
        """Feasible-region rows ``(g (m,), dg/dq (m, n_params))`` at free parameters ``params`` (m = 0
        without ``feasibility``)."""
        matrix = self.family.matrix
        if self.feasibility is None:
            return np.zeros(0), np.zeros((0, matrix.shape[1]))
        value, jacobian = self.feasibility(matrix @ np.asarray(params, dtype=float))
        return np.asarray(value, dtype=float), np.asarray(jacobian, dtype=float) @ matrix

    def feasible(self, params) -> bool:
        """Whether free parameters ``params`` satisfy the joint limits (to 1e-12) and the feasible region."""
        return bool(np.all(self.slack(params) >= -1e-12) and np.all(self.region(params)[0] >= -1e-12))

    def correct_rotation(self, params, target: float):
        """Minimum-norm Newton steps from free parameters ``params`` on the predicted rotation towards ``target``
        (rad per cycle); the corrected parameters, or None if stuck."""
        if not self.rotation:
            return params
        for _ in range(3):
            _, _, pose, pose_jacobian = self.evaluate(params)
            miss = pose[2] - target
            if abs(miss) <= self.rotation_tolerance / 10:
                return params
            row = pose_jacobian[2]
            if row @ row == 0:
                return None
            params = params - miss * row / (row @ row)
        return params


def _result(problem, params, accepted, before, value, pose, length, radius) -> Step:
    return Step(accepted=accepted, params=np.asarray(params, dtype=float), gait=problem.family.gait(params),
                value_before=before, predicted_value=value, predicted_pose=np.asarray(pose, dtype=float),
                length=float(length), boundary=bool(length > 0.9 * radius))


def _backtrack(problem, params, direction, radius, before, target, min_gain, restore) -> Step:
    """Halve ``direction`` (≤ 4 times) until the corrected candidate is feasible and gains."""
    for _ in range(4):
        candidate = problem.correct_rotation(params + direction, target)
        if candidate is not None and problem.feasible(candidate):
            value, pose = problem.evaluate(candidate, jacobian=False)
            on_target = not problem.rotation or abs(pose[2] - target) <= problem.rotation_tolerance
            if on_target and (restore or value > before * (1 + min_gain)):
                return _result(problem, candidate, True, before, value, pose,
                               problem.length(candidate - params), radius)
        direction = direction / 2
    value, pose = problem.evaluate(params, jacobian=False)
    return _result(problem, params, False, before, value, pose, 0.0, radius)


def _check(params, radius, owner):
    params = np.asarray(params, dtype=float)
    radius = check_float(radius, "radius", owner, low=0, low_open=True)
    return params, radius


@fill_doc
def linear_step(problem: StepProblem, params, radius: float, *, rotation_target: float = 0.0,
                min_gain: float = 0.005, restore: bool = False) -> Step:
    """The linearised trust-region step (module docstring).

    Parameters
    ----------
    %(step)s

    Returns
    -------
    Step
    """
    params, radius = _check(params, radius, "linear_step")
    before, gradient, pose, pose_jacobian = problem.evaluate(params)
    slack = problem.slack(params)
    matrix, metric = problem._limit_matrix, problem.metric
    constraints = [
        {"type": "ineq", "fun": lambda d: radius**2 - d @ metric @ d, "jac": lambda d: -2 * metric @ d},
        {"type": "ineq", "fun": lambda d: slack - matrix @ d, "jac": lambda d: -matrix},
    ]
    if problem.feasibility is not None:
        region, region_jacobian = problem.region(params)
        constraints.append({"type": "ineq", "fun": lambda d: region + region_jacobian @ d,
                            "jac": lambda d: region_jacobian})
    if problem.rotation:
        row, miss = pose_jacobian[2], pose[2] - rotation_target
        constraints.append({"type": "eq", "fun": lambda d: miss + row @ d, "jac": lambda d: row})
    scale = max(np.linalg.norm(gradient), 1e-12)
    result = minimize(lambda d: -gradient @ d / scale, np.zeros_like(params), jac=lambda d: -gradient / scale,
                      method="SLSQP", constraints=constraints, options={"maxiter": 100, "ftol": 1e-10})
    direction = result.x
    norm = problem.length(direction)
    direction = direction if norm <= radius else direction * radius / norm
    return _backtrack(problem, params, direction, radius, before, rotation_target, min_gain, restore)


@fill_doc
def sqp_step(problem: StepProblem, params, radius: float, *, rotation_target: float = 0.0,
             min_gain: float = 0.005, restore: bool = False, max_iterations: int = 60) -> Step:
    """Maximise the predictor's nonlinear objective inside the trust region by SQP (module docstring).

    Parameters
    ----------
    %(step)s
    max_iterations : int
        Iterations of the SQP solver (each costs about one prediction with Jacobian).

    Returns
    -------
    Step
    """
    params, radius = _check(params, radius, "sqp_step")
    before, *_ = problem.evaluate(params)
    scale = max(abs(before), 1e-12)
    matrix, slack, metric = problem._limit_matrix, problem.slack(params), problem.metric

    def value(d):
        return -problem.evaluate(params + d)[0] / scale

    def gradient(d):
        return -problem.evaluate(params + d)[1] / scale

    constraints = [
        {"type": "ineq", "fun": lambda d: (radius**2 - d @ metric @ d) / radius,
         "jac": lambda d: -2 * metric @ d / radius},
        {"type": "ineq", "fun": lambda d: slack - matrix @ d, "jac": lambda d: -matrix},
    ]
    if problem.feasibility is not None:
        constraints.append({"type": "ineq", "fun": lambda d: problem.region(params + d)[0],
                            "jac": lambda d: problem.region(params + d)[1]})
    if problem.rotation:
        constraints.append({"type": "eq", "fun": lambda d: (problem.evaluate(params + d)[2][2] - rotation_target),
                            "jac": lambda d: problem.evaluate(params + d)[3][2]})
    with np.errstate(all="ignore"):
        result = minimize(value, np.zeros_like(params), jac=gradient, method="SLSQP", constraints=constraints,
                          options={"maxiter": max_iterations, "ftol": 1e-10})
    direction = result.x if np.all(np.isfinite(result.x)) else np.zeros_like(params)
    norm = problem.length(direction)
    direction = direction if norm <= radius else direction * radius / norm
    if norm > 0:
        step = _backtrack(problem, params, direction, radius, before, rotation_target, min_gain, restore)
        if step.accepted:
            return step
    return linear_step(problem, params, radius, rotation_target=rotation_target, min_gain=min_gain, restore=restore)


def take_step(rule: str, problem: StepProblem, params, radius: float, **options) -> Step:
    """:func:`linear_step` or :func:`sqp_step` by name.

    Parameters
    ----------
    rule : {"linear", "sqp"}
        The step rule (:data:`STEP_RULES`).
    problem, params, radius
        As for :func:`linear_step`.
    **options
        ``rotation_target``, ``min_gain``, ``restore`` (and ``max_iterations`` for SQP).

    Returns
    -------
    Step
    """
    check_choice(rule, "step_rule", "take_step", STEP_RULES)
    return (linear_step if rule == "linear" else sqp_step)(problem, params, radius, **options)
