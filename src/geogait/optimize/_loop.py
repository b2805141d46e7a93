"""The per-cycle loop of an in-situ optimisation run over a robot: measure, learn, gate, step, save."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from .. import __version__
from .._files import write_state
from .._validation import GeogaitError, GeogaitWarning
from ..gaits import FreeGaitFamily
from ..learn import shape_amplitude
from ..models import model_capabilities
from ..simulate import Trajectory, TrueMotion
from ._bayes import BayesianSearch
from ._climb import MeasuredClimb, climb_rule_for
from ._measure import measure_cycle, peak_phase_speed
from ._models import run_model
from ._objective import joint_limit_constraints
from ._parts import Climb
from ._result import InSituResult
from ._search import QuadraticSearch, onto_joint_limit
from ._state import (
    CHECKPOINT_FORMAT,
    CHECKPOINT_VERSION,
    REJECTION_FLOOR,
    TRACKING_FLOOR,
    family_kind,
    params_to_json,
)
from ._steps import StepProblem, take_step


class CycleLoop:
    """One optimisation run: the per-cycle loop over a robot, with checkpoints."""

    def __init__(self, optimizer, parts, robot, state, checkpoint, checkpoint_every, tag=None):
        self.optimizer, self.parts, self.robot, self.state, self.tag = optimizer, parts, robot, state, tag
        self.checkpoint, self.checkpoint_every = checkpoint, checkpoint_every
        self.gate = parts.gate_kind
        self.capabilities = model_capabilities(state.model)  # (of every model the run makes: one class)
        if state.structure_switched:  # (a resumed run that had switched)
            self._switch_structure()
        self.truth = _Oracle(robot, parts.objective.kind, self._evaluate)
        if not state.gaits:
            state.gaits = [state.gait]
            state.robot_gait = state.gait
            state.seed_value = self.truth(state.gait, state)[1]
            if parts.objective.direction is not None:
                direction = np.asarray(parts.objective.direction, dtype=float)
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
            # (and after a run's first cycle: a run that replaces another holds a checkpoint of its own at once)
            due = state.cycle % self.checkpoint_every == 0 or state.cycle in (1, state.n_cycles)
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
                            shape_scale=state.scale, direction=state.direction, family=family_kind(state.family),
                            model_class=None if state.check is None else state.check.verdict,
                            trajectory=Trajectory.concatenate(chunks) if record and chunks else None)

    def _cycle(self, chunk) -> dict:
        parts, state = self.parts, self.state
        ran, ran_period = state.robot_gait, state.robot_period
        measured = measure_cycle(chunk, ran, ran_period, "InSituOptimizer.run")
        if state.check is not None and not state.check.done:
            return self._check_cycle(chunk, measured, ran, ran_period)
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
            value = self._evaluate(measured.net, np.zeros((3, ran.params.size)), ran)[0]
            state.iteration_tracking.append(measured.tracking_error)
            if state.iteration == 0:
                state.seed_measured.append(value)
            if state.tracking_follows:  # (the seed's cycles so far, or the base's a climb handed back)
                self._follow_tracking()
            rejected = self._tracking_rejects(measured, value)
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
                seed = state.climb.base is None and state.gait == state.gaits[0]
                if seed and state.cycles_in_iteration >= parts.gate.min_cycles:
                    self._check_structure()  # (before the gate: a wrong structure need not wait for Γ)
                if not state.climb.active and state.cycles_in_iteration >= parts.gate.min_cycles \
                        and self._unexcited() and self.parts.climb is not None:  # (Γ cannot rise without exploration)
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
        if state.check is not None:
            row["model_class_check"] = False
        if "residual_share" in self.capabilities:
            row["residual_share"] = self._residual_share() if not (settling or rejected) else np.nan
        if step or rejected or reverted:
            state.gaits.append(state.gait)
        state.robot_gait = state.gait
        self.robot.set_gait(state.gait)
        self._command_period()
        self._command_excitation()
        return row

    def _check_cycle(self, chunk, measured, gait, period) -> dict:
        """A cycle of the model-class test (:mod:`geogait.optimize._model_class`): recorded, neither learned from
        nor measured for the objective; the robot then runs the test's next period."""
        state, check = self.state, self.state.check
        verdict = check.record(period, measured.net, shape_amplitude(chunk.shape))
        if verdict is not None and verdict.principally_kinematic is False:
            warnings.warn(f"InSituOptimizer: {verdict.reason}. The model's gate stays shut: "
                          + ("steps come from the measured climb only." if self.parts.climb is not None
                             else "no step is taken (climb=False)."), GeogaitWarning, stacklevel=5)
        state.world_heading = float(measured.start[2])
        row = self._row(gait, np.nan, False, False, True, np.nan, measured, np.nan, False, period)
        row.update(climb=False, period_change=False, candidate=False, model_class_check=True)
        following = check.next_period()
        if following != state.robot_period:
            self.robot.set_cycle_period(following)
            state.robot_period = float(self.robot.cycle_period)
        self._command_excitation()
        return row

    def _model_excluded(self) -> bool:
        """The model-class test found the robot outside the model class: no model steps."""
        return self.state.check is not None and self.state.check.outside

    def _command_excitation(self) -> None:
        """Send the next cycle's excitation when the optimiser owns the exploration (none while climbing or
        testing the model class)."""
        state = self.state
        if state.exploration is None:
            return
        delta, rate = state.exploration.next_cycle(state.robot_period)
        testing = state.check is not None and not state.check.done
        if state.climb.active or testing:  # measured outcomes: clean cycles, as a black-box method runs them
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
                + (" (the measured climb does)" if self.parts.climb is not None else "")
                + ". Give the robot set_excitation (geogait then explores) or a perturbation of its own.",
                GeogaitWarning, stacklevel=4)
            state.warned_no_excitation = True
        return True

    def _decide(self) -> tuple[str | None, float]:
        """The gate is open: a period trial, a model step or a climb step (or none).

        Returns the kind of change made (``"period"``, ``"model"``, ``"climb"`` or None) and the
        prediction check's outcome (NaN when none was made).
        """
        state = self.state
        if self.gate == "cycles":
            state.fit_iteration()
        climb = self.parts.climb
        climbs_first = climb is not None and climb.start == "first" and state.climb.base is None
        # a first climb searches the period as one of its coordinates from its start: no trial before it
        if state.period_search is not None and not state.climb.active and not climbs_first and self._period_move():
            return "period", np.nan
        kind, prediction_ok = None, np.nan
        if climbs_first:  # nothing known yet: twice the model's step
            self._start_climb(sigma=climb.first_sigma * state.scale)
        elif not state.climb.active and (self._model_excluded() or self._unexcited()):
            if climb is not None:  # (a model outside its class, or one that cannot learn, takes no step)
                self._start_climb()
        elif not state.climb.active:
            prediction_ok = float(self._prediction_agrees())
            state.prediction_failures = 0 if prediction_ok else state.prediction_failures + 1
            levelled = state.stall >= 3 and climb is not None and climb.start != "contradicted"
            if levelled:  # the model has levelled off: climb on from here
                self._start_climb()
            elif prediction_ok and self._step():
                kind = "model"
            if prediction_ok and not state.climb.active:  # no step, or one promising under 1 %: level
                before, promised = state.promised[:2] if kind == "model" else (0.0, 0.0)
                small = kind is None or abs(promised - before) < 0.01 * abs(before)
                state.stall = state.stall + 1 if small else 0
            if kind is None and climb is not None and (state.distrust >= 2 or state.prediction_failures >= 2):
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

    def _check_structure(self) -> None:
        """The run's :class:`~geogait.optimize.StructureCheck`, on the seed gait (period trials aside), before the
        climb, at every measured cycle once there are the gate's ``min_cycles`` of them (whether or not Γ opens the
        gate): a structured model whose residual carries more than the check's limit of its prediction
        (``residual_share_``) hands the run to the check's step and climb, once, and says so."""
        check, state = self.parts.structure, self.state
        if check is None or state.structure_switched or not self._residual_share() > check.limit:
            return
        state.structure_switched = True
        self._switch_structure()
        state.radius = self.parts.step.trust_radius * state.scale
        state.climb = new_climb(self.parts.climb, state.scale)
        warnings.warn(f"InSituOptimizer: the structured model leaves {self._residual_share():.0%} of its prediction "
                      f"to its data (over the StructureCheck's limit {check.limit:g}): the run continues with "
                      f"{self.parts.step!r} and {self.parts.climb!r}.", GeogaitWarning, stacklevel=5)

    def _switch_structure(self) -> None:
        """The run's parts after its StructureCheck found the structure contradicted."""
        step, climb = self.parts.structure.fallback(self.parts.step, self.parts.climb)
        self.parts = replace(self.parts, step=step, climb=climb)

    def _residual_share(self) -> float:
        """The model's ``residual_share_`` (NaN for a model without one, or not fitted yet)."""
        model = self.state.model
        if "residual_share" not in self.capabilities or not getattr(model, "__sklearn_is_fitted__", lambda: True)():
            return np.nan
        return float(model.residual_share_)

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
                state.model = run_model(self.parts.model, state.gait, realised, state.family, state.scale)
        state.robot_period = state.period

    def _start_climb(self, base: tuple | None = None, sigma: float | None = None) -> None:
        """Hand the steps to the measured climb, from the best gait measured so far (measured again:
        the climb's cycles carry no exploration when the optimiser owns it), at step ``sigma`` (default
        the largest trust radius). A period trial in progress is dropped: while climbing, the period is
        one of the climb's coordinates."""
        state = self.state
        best = self._best_key() if base is None else base
        state.climb.start(best, self.parts.climb.sigma * state.scale if sigma is None else sigma)
        if self.parts.climb.rule != "es":
            state.climb.search = self._new_search(best, state.climb.sigma)
        if state.period_search is not None:
            state.period_search.trial_from = None

    def _new_search(self, base: tuple, radius: float) -> QuadraticSearch | BayesianSearch:
        """The climb rule's search from ``base`` = (gait, period) at trust radius (half-width) ``radius`` down
        to the smallest trust radius."""
        state = self.state
        origin = state.family.params_of(base[0], tolerance=1e-8)
        if state.period_search is not None:
            origin = np.append(origin, 0.0)
        settings = dict(origin=origin, radius=radius, period=base[1],
                        final_radius=self.parts.climb.min_sigma * state.scale)
        if climb_rule_for(self.parts.climb.rule, origin.size, self.parts.safety.settle_cycles) == "bayes":
            return BayesianSearch(**settings, seed=int(state.rng.integers(2**31 - 1)))
        return QuadraticSearch(**settings)

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
        state, parts, climb = self.state, self.parts, self.state.climb
        key = (state.gait, state.period)
        measured = climb.measured
        if np.isnan(climb.rotation_limit) and climb.base in measured:  # the start base, measured as the climb
            rotation = abs(float(np.mean(climb.rotations[climb.base])))  # measures (clean, when it can)
            climb.rotation_limit = max(rotation, parts.climb.rotation_tolerance)
        if climb.candidate is not None:
            if climb.candidate == key and climb.base in measured:
                if climb.search is not None:
                    climb.search.tell(climb.pending, np.mean(measured[key]), np.mean(climb.rotations[key]))
                kept = climb.judge(float(np.mean(measured[key])), float(np.mean(measured[climb.base])),
                                   self._rotation_holds(key, climb.base),
                                   tests_model=climb.search is None or not climb.search.designing)
                if kept:
                    self._follow_tracking()
                # back to model steps (unless outside its class), from the best gait, on a fresh record
                if climb.model_trusted_again and not self._model_excluded():
                    climb.active = False
                    state.distrust = state.prediction_failures = state.stall = 0
                    state.radius = parts.step.trust_radius * state.scale
                    state.measured, state.rotations = {}, {}
                    self._change_gait(*climb.base)
                    state.previous_gait = None  # (the base was accepted: never refused back to a failed candidate)
                    state.tracking_follows = True  # the model's steps are held to what the base tracks
                    return True
            climb.candidate = None  # a candidate left early (rejected) is not judged
        remeasure = climb.search is None and key != climb.base and climb.failures >= 3  # (COBYQA: its own model)
        if climb.base not in measured or remeasure:
            climb.failures = 0  # measure the base (again: it may have been lucky)
            self._change_gait(*climb.base)
            return True
        return self._climb_candidate()

    def _climb_candidate(self) -> bool:
        """Command the climb's next candidate: σ from the base in its next direction, shortened until it
        keeps the joint limits and the feasible region."""
        state, climb = self.state, self.state.climb
        if climb.search is not None:
            return self._search_candidate()
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
            if self._runnable(gait, period):
                break
        else:
            climb.sigma = max(climb.min_sigma, climb.sigma / 2)
            return False
        return self._command_candidate(gait, period)

    def _known_feasibility(self, point) -> np.ndarray:
        """The feasible region's tightest row at a search point's gait (scaled onto the joint limit),
        feasible where ≤ 0: COBYQA's known constraint."""
        state = self.state
        gait = onto_joint_limit(state.family, point[:state.family.n_params], state.max_joint_angle)
        return np.array([-state.feasibility(gait.params)[0].min()])

    def _runnable(self, gait, period) -> bool:
        """``gait`` at ``period`` keeps the joint angle limit (its largest angle over the cycle, exactly: a gait
        scaled onto the limit runs), the joint speed limit and the feasible region."""
        parts, state = self.parts, self.state
        if gait.joint_limit().max() > state.max_joint_angle * (1 + 1e-9):
            return False
        if parts.limits.max_joint_velocity is not None:
            speed = parts.limits.max_joint_velocity * period / (2 * np.pi)
            rows, bounds = joint_limit_constraints(gait.n_joints, parts.order, None, speed)  # speed rows only
            if np.any(rows @ gait.params > bounds + 1e-12):
                return False
        return state.feasibility is None or bool(state.feasibility(gait.params)[0].min() >= 0)

    def _command_candidate(self, gait, period) -> bool:
        state, climb = self.state, self.state.climb
        base_gait, base_period = climb.base
        climb.predicted_gain = (self._predict(gait)[1] * state.rate(period)
                                - self._predict(base_gait)[1] * state.rate(base_period))
        climb.candidate = (gait, period)
        self._change_gait(gait, period)
        return True

    def _search_candidate(self) -> bool:
        """Command the search's next point (:class:`QuadraticSearch`, :class:`BayesianSearch`), scaled back onto
        the joint limit when beyond it; one that breaks another limit (joint speed, the feasible region) is
        answered with the worst value measured, unrun. A converged search starts afresh from the base."""
        state, climb = self.state, self.state.climb
        n = state.family.n_params
        for _ in range(100):
            search = climb.search
            if not search.values:  # its origin is the base, as the climb measured it
                search.tell(search.origin, np.mean(climb.measured[climb.base]),
                            np.mean(climb.rotations[climb.base]))
            box = None
            if state.period_search is not None:
                low, high = (state.scale * np.log(t / search.period)
                             for t in (state.period_search.low, state.period_search.high))
                box = [(-np.inf, np.inf)] * n + [(low, high)]
            rotation = climb.rotation_limit if isinstance(state.family, FreeGaitFamily) else None
            known = None if state.feasibility is None else self._known_feasibility
            point = search.next(box, known, rotation)
            if point is None:  # converged at its smallest radius: afresh from the base
                climb.search = self._new_search(climb.base, climb.max_sigma / 4)
                continue
            gait = onto_joint_limit(state.family, point[:n], state.max_joint_angle)
            period = search.period if state.period_search is None else \
                float(search.period * np.exp(point[n] / state.scale))
            if self._runnable(gait, period):
                climb.pending = point
                return self._command_candidate(gait, period)
            search.refuse(point)
        return False

    def _rotation_holds(self, key, base) -> bool:
        """The candidate's mean measured net rotation is within the climb's rotation limit (the start
        base's, fixed) beyond twice its standard error.

        In a rotation-free family every commanded gait turns a principally kinematic body by exactly
        zero, so what a single cycle measures is mostly noise: there the limit is at least twice the RMS
        rotation of every clean cycle the climb has measured (a gait that turns stands out of that
        spread; one within it cannot be told from noise).
        """
        climb = self.state.climb
        rotations = np.asarray(climb.rotations.get(key, []))
        if rotations.size == 0:
            return True
        error = float(np.std(rotations, ddof=1) / np.sqrt(rotations.size)) if rotations.size > 1 else 0.0
        limit = climb.rotation_limit
        if not isinstance(self.state.family, FreeGaitFamily):
            measured = np.concatenate([np.asarray(v, dtype=float) for v in climb.rotations.values()])
            limit = max(limit, 2 * float(np.sqrt(np.mean(measured ** 2))))
        return abs(float(rotations.mean())) <= limit + 2 * error

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
            if kept:  # the automatic tracking limit follows the period
                self._follow_tracking()
                return False
            self._change_gait(state.gait, origin)
            return True
        if not search.turn:
            return False
        shortest = 0.0  # the period at which the gait's fastest joint reaches max_joint_velocity
        if self.parts.limits.max_joint_velocity is not None:
            shortest = peak_phase_speed(state.gait) * 2 * np.pi / self.parts.limits.max_joint_velocity
        period = search.propose(state.period, shortest)
        if period is None:
            search.turn = False
            return False
        search.trial_from = state.period
        self._change_gait(state.gait, period)
        return True

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

    def _tracking_rejects(self, measured, value: float) -> bool:
        """Reject the current gait (back to the previous one) if the robot could not follow it; a model step
        whose cycle (``value``, the measured objective) also fell short of its promise is a broken promise."""
        parts, state = self.parts, self.state
        search = state.period_search
        trial = search is not None and search.trial_from is not None
        if (trial or state.climb.active) and parts.safety.max_tracking_error == "auto":
            return False  # (judged by their measured outcome: the automatic limit then follows the gait kept)
        limit = state.tracking_limit if parts.safety.max_tracking_error == "auto" else parts.safety.max_tracking_error
        if limit is None or state.previous_gait is None or not measured.tracking_error > limit:
            return False
        if state.promised is not None and state.climb.candidate != (state.gait, state.period) and not trial:
            if parts.step.breaks(*state.promised[:2], value):  # a model step the robot could not run, gain unmeasured
                state.distrust += 1
        state.promised = None
        state.radius = max(min(parts.step.min_trust_radius, REJECTION_FLOOR) * state.scale, state.radius / 2)
        previous = (state.previous_gait, state.previous_period)
        if state.climb.candidate == (state.gait, state.period):  # a candidate the robot cannot follow
            if state.climb.search is not None:
                state.climb.search.refuse(state.climb.pending)
            state.climb.judge(-np.inf, 0.0, rotation_holds=False)
            previous = state.climb.base  # (the gait before it may be another failed candidate)
        self._change_gait(*previous)
        if trial:  # a period the robot cannot follow
            search.judge(-np.inf, 0.0)
            search.turn = False
        state.previous_gait = None  # the gait we fall back to was accepted; nothing further back to try
        return True

    def _tracking_limit(self) -> float:
        """The tracking limit the model's steps are held to now (NaN: none)."""
        limit = self.parts.safety.max_tracking_error
        return self.state.tracking_limit if limit == "auto" else np.nan if limit is None else float(limit)

    def _follow_tracking(self) -> None:
        """The automatic tracking limit: twice what the current gait's measured cycles track — the seed's, then
        each gait kept for its measured outcome (a climb's candidate, a period trial, the base a climb hands back
        to the model), so that the model's steps from it are held to what it does, not to what the seed did."""
        state = self.state
        if self.parts.safety.max_tracking_error == "auto" and state.iteration_tracking:
            state.tracking_limit = max(TRACKING_FLOOR * state.scale, 2 * float(np.mean(state.iteration_tracking)))

    def _measured_reverts(self) -> bool:
        """Measured outcomes over the model: go back to the best gait measured so far when the current
        one is worse beyond noise.

        Each gait's learned cycles give its mean measured objective; σ is the pooled cycle-to-cycle
        standard deviation within gaits. When the current gait's mean falls below the best other
        gait's by more than 2 σ √(1/n + 1/n_best), the model's steps have led the robot downhill,
        whatever the model predicts: the best gait is commanded again (its further cycles refine its
        mean, so a lucky best is corrected) and the trust radius halves.
        """
        state, parts = self.state, self.parts
        if state.iteration == 0 or parts.safety.revert_tolerance is None or state.climb.active:
            return False  # (the climb judges its own candidates)
        current = (state.gait, state.period)
        counts = {g: len(v) for g, v in state.measured.items() if len(v) >= 2}
        if current not in counts or len(counts) < 2:
            return False
        means = {g: float(np.mean(state.measured[g])) for g in counts}
        dof = sum(n - 1 for n in counts.values())
        sigma = np.sqrt(sum(np.var(state.measured[g], ddof=1) * (n - 1) for g, n in counts.items()) / dof)
        best = max((g for g in counts if g != current), key=means.get)
        margin = parts.safety.revert_tolerance * sigma * np.sqrt(1 / counts[current] + 1 / counts[best])
        if not means[current] < means[best] - margin:
            return False
        state.promised = None
        state.radius = max(parts.step.min_trust_radius * state.scale, state.radius / 2)
        search = state.period_search
        if search is not None and search.trial_from is not None:  # the trial lost beyond noise
            search.judge(-np.inf, 0.0)
            search.turn = False
        self._change_gait(*best)
        if not (search is not None and best[0] == current[0]):  # the model led downhill: a broken promise
            state.distrust += 1
        state.previous_gait = None
        return True

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
        elif self.gate == "cycles" or not getattr(state.model, "__sklearn_is_fitted__", lambda: True)():
            # (not fitted yet: a fresh model whose first cycles were all settling or rejected)
            state.model = run_model(parts.model, gait, state.period, state.family, state.scale)
        else:
            state.model.rebase(gait, terms=parts.step.rebase, covariance_inflation=parts.step.covariance_inflation,
                               constant_variance=parts.step.constant_variance)
            state.model.reset_gamma()
        state.previous_gait, state.gait = state.gait, gait
        state.previous_period, state.period = state.period, period
        state.iteration += 1
        state.restart_iteration()
        state.settle_left = parts.safety.settle_cycles
        state.tracking_follows = False


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
               "tracking_limit": self._tracking_limit(), "excitation": measured.excitation,
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
        if "save" in self.capabilities and getattr(model, "__sklearn_is_fitted__", lambda: True)():
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
                   "params": params_to_json(self.optimizer), "state": metadata,
                   "model": None if model_metadata is None else {"metadata": model_metadata},
                   "robot_state": robot_state, "checkpoint_every": self.checkpoint_every, "tag": self.tag}
        write_state(self.checkpoint, payload, arrays)


class _Oracle:
    """True (x, y, heading) and objective per cycle of a gait, when the robot exposes its system."""

    def __init__(self, robot, objective_name, evaluate):
        self.system = getattr(robot, "current_system", None)
        self.available = self.system is not None
        self.objective, self.evaluate = objective_name, evaluate
        self.cache = {}

    def __call__(self, gait, state):
        if self.system is None:
            return np.full(3, np.nan), np.nan
        system = self.system()
        key = (id(system), gait)
        if key not in self.cache:
            self.cache[key] = TrueMotion(system, resolution=128)(gait)
        pose = self.cache[key]
        if self.objective == "forward" and state.direction is None:
            return pose, np.nan
        return pose, self.evaluate(pose, np.zeros((3, gait.params.size)), gait)[0]


def new_climb(climb: Climb | None, scale: float) -> MeasuredClimb:
    """The measured climb's state for a run: σ within [min_sigma, max_sigma] (× shape_scale); a run without a
    climb carries an inactive one of the default radii."""
    climb = Climb() if climb is None else climb
    return MeasuredClimb(sigma=climb.sigma * scale, min_sigma=climb.min_sigma * scale,
                         max_sigma=climb.max_sigma * scale)
