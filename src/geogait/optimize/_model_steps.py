"""The model's side of a run (the :class:`~geogait.optimize.Gate` and :class:`~geogait.optimize.ModelStep` parts
at work): the gate, the prediction check, the trust-region step, the objective's direction and the rebase."""

from __future__ import annotations

import numpy as np

from .._validation import GeogaitError
from ..models import model_fitted
from ._models import run_model
from ._objective import joint_limit_constraints
from ._steps import StepProblem, take_step


class ModelSteps:
    """Methods of :class:`~geogait.optimize._loop.CycleLoop` (a mixin: it reads the loop's ``parts``, ``state``
    and ``robot``)."""

    def _gate_open(self) -> bool:
        state, gate = self.state, self.parts.gate
        if state.climb.active:  # measured outcomes need measured cycles, not a model's confidence:
            # one clean cycle (no exploration: the optimiser owns it) or the usual number
            needed = 1 if state.exploration is not None else gate.min_cycles
            return state.cycles_in_iteration >= needed
        climb = self.parts.climb
        if climb is not None and climb.start == "first" and state.climb.base is None:  # the climb needs no model
            return state.cycles_in_iteration >= gate.min_cycles
        if self.gate == "cycles":
            return state.cycles_in_iteration >= gate.cycles
        return (state.cycles_in_iteration >= gate.min_cycles
                and np.isfinite(state.gamma) and state.gamma >= gate.gamma_threshold)

    def _prediction_agrees(self) -> bool:
        """Model's predicted objective of the current gait vs the mean measured one (module docstring)."""
        tolerance = self.parts.gate.prediction_tolerance
        if tolerance is None:
            return True
        predicted = self._predict(self.state.gait)[1]
        measured = float(np.mean(self.state.iteration_measured))
        return bool(abs(predicted - measured) <= tolerance * abs(measured))

    # -- the model's step ---------------------------------------------------------------------

    def _set_direction(self, measured):
        """The direction of ``"forward"`` (default): the mean motion of the seed's measured cycles.

        Until the first gate decision it is the running mean of the seed's cycles so far (in the
        ``direction_frame``); :meth:`_fix_direction` then fixes it from all of them.
        """
        state = self.state
        if self.parts.objective.kind != "forward" or state.direction_fixed:
            return
        net = measured.net[:2]
        if self.parts.objective.frame == "world":
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
        if self.parts.objective.kind != "forward" or state.direction_fixed:
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

    # -- the model's step ---------------------------------------------------------------------
    def _direction(self) -> np.ndarray | None:
        """Unit direction of ``"forward"`` in the body frame at the start of the latest cycle."""
        objective, state = self.parts.objective, self.state
        if objective.kind != "forward":
            return None
        u = state.direction
        if objective.frame == "world":
            c, s = np.cos(state.world_heading), np.sin(state.world_heading)
            u = np.array([c * u[0] + s * u[1], -s * u[0] + c * u[1]])
        return u

    def _evaluate(self, pose, pose_jacobian, gait):
        return self.parts.objective(pose, pose_jacobian, gait, self._direction())

    def _predict(self, gait, jacobian=False):
        model = self.state.model
        if not jacobian:
            pose = model.predict_displacement(gait)
            return pose, self._evaluate(pose, np.zeros((3, gait.params.size)), gait)[0]
        pose, pose_jacobian = model.predict_displacement(gait, jacobian=True)
        return pose, pose_jacobian, *self._evaluate(pose, pose_jacobian, gait)

    def _limits(self):
        parts, state = self.parts, self.state
        speed = None if parts.limits.max_joint_velocity is None \
            else parts.limits.max_joint_velocity * state.period / (2 * np.pi)
        return joint_limit_constraints(state.gait.n_joints, parts.order, state.max_joint_angle, speed)

    def _step(self) -> bool:
        """Propose, check and (maybe) take a step; returns whether the gait changed.

        A predicted rotation beyond twice its standard error is real: the step brings it to zero.
        One within it cannot be told from noise: the step then keeps the predicted rotation where it
        is (J_ω Δ = 0) instead of chasing it, and is taken only for a predicted gain of at least
        ``min_gain``.
        """
        step_part, state = self.parts.step, self.state
        gait, family = state.gait, state.family
        problem = StepProblem(state.model.predict_displacement, family, objective=self.parts.objective.kind,
                              limits=self._limits(), rotation_tolerance=step_part.rotation_tolerance,
                              direction=self._direction(), feasibility=state.feasibility)
        params = family.params_of(gait, tolerance=1e-8)
        value, _, pose, _ = problem.evaluate(params)
        state.update_radius(value, step_part)
        state.last_prediction = value
        if self.parts.climb is not None and state.distrust >= 2:  # promised gains unconfirmed at the smallest radius
            return False
        restores = False
        target = 0.0
        if problem.rotation:
            resolution = 2 * state.rotation_std()
            restores = abs(pose[2]) > max(step_part.rotation_tolerance, resolution)
            target = 0.0 if restores else pose[2]
        step = take_step(step_part.rule, problem, params, state.radius, rotation_target=target,
                         min_gain=step_part.min_gain, restore=restores)
        if step.accepted:
            state.promised = (value, step.predicted_value, step.boundary)
            self._change_gait(step.gait)
            return True
        if restores:  # the model could not find a feasible restoring step: trust it less far
            state.radius = max(step_part.min_trust_radius * state.scale, state.radius / 2)
        return False

    def _change_gait(self, gait, period=None) -> None:
        """Re-centre the model on ``gait`` (a fresh model at a new ``period``) and start a new iteration."""
        parts, state = self.parts, self.state
        period = state.period if period is None else float(period)
        if period != state.period:  # another period: what was learned need not hold (dynamics)
            state.promised = None
            state.model = run_model(parts.model, gait, period, state.family, state.scale)
        elif self.gate == "cycles" or not model_fitted(state.model):
            # (not fitted yet: a fresh model whose first cycles were all settling or rejected)
            state.model = run_model(parts.model, gait, state.period, state.family, state.scale)
        else:
            state.model.rebase(gait, terms=parts.step.rebase, covariance_inflation=parts.step.covariance_inflation,
                               constant_variance=parts.step.constant_variance)
            if not state.climb.active:  # (while climbing, Γ runs over all the climb's cycles: one per candidate)
                state.model.reset_gamma()
        moved = (gait, period) != (state.gait, state.period)
        state.previous_gait, state.gait = state.gait, gait
        state.previous_period, state.period = state.period, period
        state.iteration += 1
        state.restart_iteration()
        state.settle_left = state.settle_cycles
        if state.settle_probe is not None:  # (a probe left before its end: the next change probes)
            state.settle_due, state.settle_probe = True, None
        if state.settle_due and moved:  # ("auto") this change's first cycles measure how long a change settles
            state.settle_due, state.settle_probe, state.settle_left = False, [], 0
        state.tracking_follows = False
