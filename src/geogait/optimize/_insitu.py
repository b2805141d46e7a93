r"""In-situ gait optimisation (paper Fig. 4): perturbed cycles → adaptive model → confidence-gated
trust-region step → Taylor rebase (eq. 7) → repeat.

Step rule (documented choice for the zero-rotation constraint: a *constrained step*). With the
model's predicted net motion :math:`g(p)` at the current gait parameters :math:`p_0`, its objective
gradient :math:`\nabla f` and rotation row :math:`J_\omega`, the step solves the linearised problem

.. math:: \max_{\Delta} \nabla f^T\Delta \ \text{ s.t. }\ \omega_0 + J_\omega\Delta = 0,\
   \|\Delta\| \le R,\ G(p_0+\Delta) \le h \ \text{(joint limits)},

then corrects the predicted rotation with a few Newton steps on the model's own (nonlinear)
prediction, backtracks while the model does not predict an improvement, and is accepted only if
the predicted rotation is below ``rotation_tolerance`` and the joint limits hold exactly (a gait
the model sees rotating is first restored to zero rotation, even at a loss of progress). The trust
radius R follows the usual ratio test: when the next iteration's model (trained on the new gait)
confirms less than a quarter of the predicted gain, R halves; when it confirms more than three
quarters of a step that reached the boundary, R grows by half, within [``min_trust_radius``,
``max_trust_radius``].
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import minimize

from .._validation import check_choice, check_float, check_int, fail
from ..gaits import FourierGait
from ..models import AdaptiveGaitModel, BatchGaitModel, predicted_displacement
from ..simulate import Trajectory, cycle_displacement
from ._objective import OBJECTIVES, joint_limit_constraints, objective

__all__ = ["InSituOptimizer", "OptimizationResult"]


@dataclass
class OptimizationResult:
    """Outcome of :meth:`InSituOptimizer.run`.

    Attributes
    ----------
    log : pandas.DataFrame
        One row per cycle: ``cycle``, ``iteration``, ``gamma`` (online Γ over the iteration so far;
        NaN on the burn-in cycle after a step, which only trains the reset baseline), ``step`` (a step was taken after
        this cycle), ``trust_radius``, ``predicted_objective`` (the model's estimate for the gait of
        this cycle), ``true_x``, ``true_y``, ``true_heading``, ``true_progress`` and
        ``true_objective`` (oracle, when the stream exposes its system), ``improvement`` (relative
        to the seed), ``ceiling_fraction`` (when a ceiling value is given), and ``param_*``.
    initial_gait, final_gait : FourierGait
    gaits : list of FourierGait
        Every nominal gait commanded, in order.
    trajectory : Trajectory or None
        Every sample of the run (when ``record=True``).
    """

    log: pd.DataFrame
    initial_gait: FourierGait
    final_gait: FourierGait
    gaits: list = field(default_factory=list)
    trajectory: Trajectory | None = None

    @property
    def n_steps(self) -> int:
        return int(self.log["step"].sum())


class InSituOptimizer:
    """The paper's in-situ optimiser, or (``method="batch"``) the prior-work baseline.

    Parameters
    ----------
    method : {"adaptive", "batch"}
        ``"adaptive"``: RLS model updated every sample, a step as soon as the online Γ over the
        current iteration reaches ``gamma_threshold`` (paper). ``"batch"``: Bittner et al. 2018 —
        ``cycles_per_iteration`` perturbed cycles, batch least-squares refit, same step rule.
    gamma_threshold : float
        Γ* (default 1/2).
    forgetting_factor : float, optional
        λ_RLS of the adaptive model. Default ``1 - 0.1 / d`` for shape dimension d (0.95, 0.975 and
        0.9875 for the 3-, 5- and 9-link swimmers): the filters must remember more samples when
        they have more weights (1 + 2d + d² per window); tuned by the study in the issue notes.
    gamma_forgetting : float
        λ_Γ of the online Γ.
    order : int
        Fourier order of the gait family optimised (the seed is embedded in it).
    objective : {"progress", "efficiency"}
        Straight-line progress per cycle, or progress per shape-space path length; both with zero
        net rotation.
    max_joint_angle : float
        r_max (rad); every commanded gait satisfies |θ_j(φ)| ≤ r_max.
    trust_radius, min_trust_radius, max_trust_radius : float
        Initial, smallest and largest step length in parameter space (rad).
    rotation_tolerance : float
        Largest model-predicted |net rotation| per cycle of an accepted gait.
    min_cycles_per_iteration : int
        Cycles on a gait before Γ may trigger a step. After a step the baseline phase model starts
        afresh (``AdaptiveGaitModel.rebase(baseline="reset")``) and the first cycle on the new gait
        only trains it: Γ over the iteration counts from the second cycle on, so it compares the
        model with the new gait's own phase average and a stale constant term cannot pass the gate.
    cycles_per_iteration : int
        Cycles per iteration of the batch method.
    rebase : {"constant", "all", "none"}
        Taylor rebase terms (eq. 7 is ``"constant"``).
    covariance_inflation : float
        Factor on the RLS covariances at each rebase (see ``AdaptiveGaitModel.rebase``).
    constant_variance : float
        Variance added to the constant term's covariance at each rebase (``AdaptiveGaitModel.rebase``).
    min_gain : float
        Smallest predicted relative gain worth a step (a gait the model sees rotating is restored
        regardless). Near the optimum this stops the optimiser from re-randomising the gait every
        iteration for gains below the model's resolution.
    n_windows, window_width, smoothing_order : model hyper-parameters.
    """

    def __init__(self, *, method: str = "adaptive", gamma_threshold: float = 0.5,
                 forgetting_factor: float | None = None,
                 gamma_forgetting: float = 0.995, order: int = 1, objective: str = "progress",
                 max_joint_angle: float = 2 * np.pi / 3, trust_radius: float = 0.1, min_trust_radius: float = 0.02,
                 max_trust_radius: float = 0.15, rotation_tolerance: float = 1e-3, min_cycles_per_iteration: int = 2,
                 cycles_per_iteration: int = 30, rebase: str = "all", covariance_inflation: float = 1.0,
                 constant_variance: float = 0.0, min_gain: float = 0.005, interaction: bool = True,
                 n_windows: int = 20,
                 window_width: float | None = None, smoothing_order: int = 5):
        self.method = method
        self.gamma_threshold = gamma_threshold
        self.forgetting_factor = forgetting_factor
        self.gamma_forgetting = gamma_forgetting
        self.order = order
        self.objective = objective
        self.max_joint_angle = max_joint_angle
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
        self.interaction = interaction
        self.n_windows = n_windows
        self.window_width = window_width
        self.smoothing_order = smoothing_order

    # -- validation ---------------------------------------------------------------------------
    def _validate(self):
        owner = "InSituOptimizer"
        check_choice(self.method, "method", owner, ("adaptive", "batch"))
        check_float(self.gamma_threshold, "gamma_threshold", owner, high=1.0, high_open=True)
        check_int(self.order, "order", owner, minimum=1)
        check_choice(self.objective, "objective", owner, OBJECTIVES)
        check_float(self.max_joint_angle, "max_joint_angle", owner, low=0, high=np.pi, low_open=True)
        low = check_float(self.min_trust_radius, "min_trust_radius", owner, low=0, low_open=True)
        high = check_float(self.max_trust_radius, "max_trust_radius", owner, low=low)
        check_float(self.trust_radius, "trust_radius", owner, low=low, high=high)
        check_float(self.rotation_tolerance, "rotation_tolerance", owner, low=0, low_open=True)
        check_float(self.min_gain, "min_gain", owner, low=0)
        check_int(self.min_cycles_per_iteration, "min_cycles_per_iteration", owner, minimum=1)
        check_int(self.cycles_per_iteration, "cycles_per_iteration", owner, minimum=1)
        check_choice(self.rebase, "rebase", owner, ("constant", "all", "none"))

    def _new_model(self, gait):
        common = dict(gait=gait, n_windows=self.n_windows, window_width=self.window_width,
                      smoothing_order=self.smoothing_order, interaction=self.interaction)
        if self.method == "batch":
            return BatchGaitModel(**common)
        lam = 1 - 0.1 / gait.n_joints if self.forgetting_factor is None else self.forgetting_factor
        return AdaptiveGaitModel(forgetting_factor=lam, gamma_forgetting=self.gamma_forgetting, **common)

    # -- the loop -----------------------------------------------------------------------------
    def run(self, stream, n_cycles: int, *, ceiling: float | None = None,
            callback: Callable[[dict], None] | None = None, record: bool = False) -> OptimizationResult:
        """Optimise in situ for ``n_cycles`` cycles of ``stream``.

        Parameters
        ----------
        stream : SwimmerStream or any object with ``gait``, ``set_gait(gait)``, ``next_cycle()``
            A real robot driver offers the same three members. If it also has
            ``current_system()`` (simulators do), the log records the true displacement per cycle.
        n_cycles : int
        ceiling : float, optional
            Ceiling objective value; adds ``ceiling_fraction`` to the log.
        callback : callable, optional
            Called with each log row (a dict) as it is produced (live progress displays).
        record : bool
            Keep every sample (``result.trajectory``).
        """
        self._validate()
        n_cycles = check_int(n_cycles, "n_cycles", "InSituOptimizer.run", minimum=1)
        if not isinstance(stream.gait, FourierGait):
            raise fail("stream", "InSituOptimizer.run", "a stream whose 'gait' is a FourierGait", stream.gait)
        gait = stream.gait.with_order(self.order)
        limits = joint_limit_constraints(gait.n_joints, self.order, self.max_joint_angle)
        if gait.joint_limit().max() > self.max_joint_angle + 1e-12:
            raise fail("stream", "InSituOptimizer.run",
                       f"a seed gait within max_joint_angle = {self.max_joint_angle:.4g}",
                       f"a gait reaching {gait.joint_limit().max():.4g} rad")
        stream.set_gait(gait)
        state = _State(gait=gait, radius=self.trust_radius, model=self._new_model(gait),
                       batch_cycles=self.cycles_per_iteration)
        truth = _Oracle(stream, self.objective)
        seed_value = truth(gait)[1]
        rows, gaits, chunks = [], [gait], []
        for cycle in range(n_cycles):
            chunk = stream.next_cycle()
            if record:
                chunks.append(chunk)
            state.learn(chunk, self.method)
            gamma = state.gamma  # Γ over the iteration so far, the quantity the gate looks at
            step = self._ready(state) and self._step(state, limits)
            pose, value = truth(state.history_gait)
            row = self._row(cycle, state, gamma, step, pose, value, seed_value, ceiling)
            rows.append(row)
            if callback is not None:
                callback(row)
            if step:
                stream.set_gait(state.gait)
                gaits.append(state.gait)
        return OptimizationResult(log=pd.DataFrame(rows), initial_gait=gaits[0], final_gait=state.gait, gaits=gaits,
                                  trajectory=Trajectory.concatenate(chunks) if record else None)

    def _ready(self, state) -> bool:
        if self.method == "batch":
            return state.cycles_in_iteration >= self.cycles_per_iteration
        return state.cycles_in_iteration >= self.min_cycles_per_iteration and state.model.gamma_ >= self.gamma_threshold

    def _row(self, cycle, state, gamma, step, pose, value, seed_value, ceiling) -> dict:
        row = {"cycle": cycle, "iteration": state.iteration - int(step), "gamma": gamma, "step": bool(step),
               "trust_radius": state.radius, "predicted_objective": state.last_prediction,
               "true_x": pose[0], "true_y": pose[1], "true_heading": pose[2],
               "true_progress": float(np.hypot(pose[0], pose[1])), "true_objective": value,
               "improvement": value / seed_value - 1}
        if ceiling is not None:
            row["ceiling_fraction"] = value / ceiling
        row.update({f"param_{k}": v for k, v in enumerate(state.history_gait.params)})
        return row

    # -- one step -----------------------------------------------------------------------------
    def _predict(self, model, gait, jacobian=False):
        if not jacobian:
            pose = predicted_displacement(model, gait)
            return pose, objective(self.objective, pose, np.zeros((3, gait.params.size)), gait)[0]
        pose, pose_jacobian = predicted_displacement(model, gait, jacobian=True)
        return pose, pose_jacobian, *objective(self.objective, pose, pose_jacobian, gait)

    def _step(self, state, limits) -> bool:
        """Propose, check and (maybe) take a step; returns whether the gait changed.

        A predicted rotation beyond twice its standard error is real: the step brings it to zero.
        One within it cannot be told from noise: the step then keeps the predicted rotation where it
        is (J_ω Δ = 0) instead of chasing it, and is taken only for a predicted gain of at least
        ``min_gain``.
        """
        model, gait = state.model, state.gait
        pose, pose_jacobian, value, gradient = self._predict(model, gait, jacobian=True)
        state.update_radius(value, self.min_trust_radius, self.max_trust_radius)
        state.last_prediction = value
        resolution = 0.0 if self.method == "batch" else 2 * self._rotation_std(model, state)
        restores = abs(pose[2]) > max(self.rotation_tolerance, resolution)
        target = 0.0 if restores else pose[2]
        direction = _linear_step(gradient, pose[2] - target, pose_jacobian[2], state.radius, limits, gait.params)
        for _ in range(4):  # backtrack until the model predicts a feasible improvement
            candidate = self._correct_rotation(model, gait.with_params(gait.params + direction), target)
            if candidate is not None and np.all(limits[0] @ candidate.params <= limits[1] + 1e-12):
                new_pose, new_value = self._predict(model, candidate)
                on_target = abs(new_pose[2] - target) <= self.rotation_tolerance
                if on_target and (restores or new_value > value * (1 + self.min_gain)):
                    state.move(candidate, predicted=new_value, boundary=np.linalg.norm(direction) > 0.9 * state.radius,
                               rebase=self.rebase, inflation=(self.covariance_inflation, self.constant_variance),
                               method=self.method, new_model=self._new_model)
                    return True
            direction = direction / 2
        if restores:  # the model could not find a feasible restoring step: trust it less far
            state.radius = max(self.min_trust_radius, state.radius / 2)
        if self.method == "batch":  # prior work: another block of cycles on this gait before trying again
            state.cycles_in_iteration = 0
        return False

    @staticmethod
    def _rotation_std(model, state) -> float:
        """Standard error of the model's predicted net rotation of its own nominal gait.

        At δ = 0 the predicted rotation is ≈ Σ_m C_m,ω · 2π / (M φ̇) (the smoothed constant terms'
        mean over a cycle), so its variance is ≈ σ_ω² (2π / (M φ̇))² Σ_m P_m[0, 0], with σ_ω² the
        recent mean squared a-priori error of ω. Only a predicted rotation beyond twice this is
        treated as real and restored; smaller ones are within what the data can resolve.
        """
        if not np.isfinite(state.residual_variance):
            return np.inf
        p00 = model.covariance_[..., 0, 0]
        scale = 2 * np.pi / (p00.shape[-1] * model._phase_rate())
        return float(np.sqrt(state.residual_variance * p00.sum()) * scale)

    def _correct_rotation(self, model, gait, target: float):
        """Newton steps (minimum-norm) bringing the model's predicted net rotation to ``target``."""
        for _ in range(3):
            pose, pose_jacobian = predicted_displacement(model, gait, jacobian=True)
            miss = pose[2] - target
            if abs(miss) <= self.rotation_tolerance / 10:
                return gait
            row = pose_jacobian[2]
            if row @ row == 0:
                return None
            gait = gait.with_params(gait.params - miss * row / (row @ row))
        return gait


def _linear_step(gradient, rotation, rotation_row, radius, limits, params):
    """Solve the linearised trust-region subproblem (module docstring) with SLSQP."""
    matrix, bound = limits
    slack = bound - matrix @ params
    constraints = [
        {"type": "eq", "fun": lambda d: rotation + rotation_row @ d, "jac": lambda d: rotation_row},
        {"type": "ineq", "fun": lambda d: radius**2 - d @ d, "jac": lambda d: -2 * d},
        {"type": "ineq", "fun": lambda d: slack - matrix @ d, "jac": lambda d: -matrix},
    ]
    scale = max(np.linalg.norm(gradient), 1e-12)
    result = minimize(lambda d: -gradient @ d / scale, np.zeros_like(params), jac=lambda d: -gradient / scale,
                      method="SLSQP", constraints=constraints, options={"maxiter": 100, "ftol": 1e-10})
    step = result.x
    norm = np.linalg.norm(step)
    return step if norm <= radius else step * radius / norm


@dataclass
class _State:
    """Mutable state of one optimisation run."""

    gait: FourierGait
    radius: float
    model: object
    iteration: int = 0
    cycles_in_iteration: int = 0
    last_prediction: float = np.nan
    promised: tuple | None = None  # (value before the step, predicted value after, at the boundary)
    history_gait: FourierGait | None = None
    iteration_data: list = field(default_factory=list)
    residual_variance: float = np.nan  # recent mean squared a-priori error of ω
    batch_cycles: int = 30

    gamma: float = np.nan  # online Γ over the iteration after the last cycle (NaN on a burn-in cycle)

    def learn(self, chunk, method):
        self.history_gait = self.gait
        self.cycles_in_iteration += 1
        args = (chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
        if method == "batch":  # the iteration's cycles, fitted from scratch once the iteration is complete
            self.iteration_data.append(args)
            if self.cycles_in_iteration >= self.batch_cycles:
                self.model.fit(*(np.concatenate(parts) for parts in zip(*self.iteration_data, strict=True)))
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

    def update_radius(self, value_now, low, high):
        """Ratio test: compare the gain the last step promised with what the new model sees."""
        if self.promised is None:
            return
        before, promised, boundary = self.promised
        ratio = (value_now - before) / (promised - before) if promised != before else 1.0
        if ratio < 0.25:
            self.radius = max(low, self.radius / 2)
        elif ratio > 0.75 and boundary:
            self.radius = min(high, self.radius * 1.5)
        self.promised = None

    def move(self, gait, *, predicted, boundary, rebase, inflation, method, new_model):
        self.promised = (self.last_prediction, predicted, boundary)
        if method == "batch":
            self.model = new_model(gait)
            self.iteration_data = []
        else:
            self.model.rebase(gait, terms=rebase, covariance_inflation=inflation[0], constant_variance=inflation[1])
            self.model.reset_gamma()
        self.gait = gait
        self.iteration += 1
        self.cycles_in_iteration = 0


class _Oracle:
    """True (x, y, heading) and objective per cycle of a gait, when the stream exposes its system."""

    def __init__(self, stream, kind):
        self.system = getattr(stream, "current_system", None)
        self.kind = kind
        self.cache = {}

    def __call__(self, gait):
        if self.system is None:
            return np.full(3, np.nan), np.nan
        system = self.system()
        key = (id(system), gait)
        if key not in self.cache:
            pose = cycle_displacement(system, gait, resolution=128)
            self.cache[key] = (pose, objective(self.kind, pose, np.zeros((3, gait.params.size)), gait)[0])
        return self.cache[key]
