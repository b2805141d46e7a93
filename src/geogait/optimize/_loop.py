"""The per-cycle loop of an in-situ optimisation run over a robot: measure, learn, gate, step, save."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from .._validation import GeogaitWarning
from ..learn import shape_amplitude
from ..models import model_capabilities, model_fitted
from ..simulate import Trajectory
from ._change_steps import ChangeSteps
from ._climb import MeasuredClimb
from ._climb_steps import ClimbSteps
from ._measure import measure_cycle
from ._model_steps import ModelSteps
from ._parts import Climb
from ._records import RunRecords, _Oracle
from ._result import InSituResult
from ._safety_steps import SafetySteps
from ._state import (
    family_kind,
)


class CycleLoop(ModelSteps, ClimbSteps, ChangeSteps, SafetySteps, RunRecords):
    """One optimisation run: the per-cycle loop over a robot, with checkpoints."""

    def __init__(self, optimizer, parts, robot, spec, state, checkpoint, checkpoint_every, tag=None):
        self.optimizer, self.parts, self.robot, self.spec, self.state = optimizer, parts, robot, spec, state
        self.tag = tag
        self.checkpoint, self.checkpoint_every = checkpoint, checkpoint_every
        self.gate = parts.gate_kind
        self.capabilities = model_capabilities(state.model)  # (of every model the run makes: one class)
        if state.structure_switched:  # (a resumed run that had switched)
            self._switch_structure()
        self.truth = _Oracle(robot if spec.simulated else None, parts.objective.kind, self._evaluate)
        if not state.gaits:
            state.gaits = [state.gait]
            state.robot_gait = state.gait
            state.seed_value = self.truth(state.gait, state)[1]
            if parts.objective.direction is not None:
                direction = np.asarray(parts.objective.direction, dtype=float)
                state.direction, state.direction_fixed = direction / np.hypot(*direction), True

    def run(self, callback, record, stop=None) -> InSituResult:
        state, chunks = self.state, []
        if state.exploration is not None:  # the first cycle's, or the one a checkpoint had commanded
            if state.excitation_next is None:
                self._command_excitation()
            else:
                self.robot.set_excitation(*state.excitation_next)
        while state.n_cycles is None or state.cycle < state.n_cycles:
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
            stopped = stop is not None and bool(stop())
            if self.checkpoint is not None and (due or stopped):
                self._save()
            if stopped:
                break
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
                            changes=list(state.watch.events),
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
        change = None
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
                key, turned = (state.gait, state.period), float(measured.net[2])
                rated = value * state.rate(state.period)
                change = self._settle_probe(key, rated, turned) or self._watch(key, rated, turned)
                state.learn(chunk, self.gate)
                state.iteration_measured.append(value)
                state.iteration_excitation.append(measured.excitation)
                if change in (None, "hold"):  # (the probe and the Adaptation record what they measured themselves)
                    records = self._records()
                    records[0].setdefault(key, []).append(rated)
                    records[1].setdefault(key, []).append(turned)
                decide = change in (None, "probed")  # (not a cycle held for another look, or a change answered)
                seed = state.climb.base is None and state.gait == state.gaits[0]
                if decide and seed and state.cycles_in_iteration >= parts.gate.min_cycles:
                    self._check_structure()  # (before the gate: a wrong structure need not wait for Γ)
                if decide and not state.climb.active and state.cycles_in_iteration >= parts.gate.min_cycles \
                        and self._unexcited() and self.parts.climb is not None:  # (Γ cannot rise without exploration)
                    self._start_climb()
                if decide and self._gate_open():
                    self._fix_direction()
                    reverted = self._measured_reverts()
                if decide and self._gate_open() and not reverted:
                    kind, prediction_ok = self._decide()
        step = kind is not None
        row = self._row(ran, state.gamma if not (settling or rejected) else np.nan, step, rejected, settling,
                        prediction_ok, measured, value, reverted, ran_period)
        state.steps_by_model += kind == "model"
        state.steps_by_climb += kind == "climb"
        row.update(climb=kind == "climb", period_change=kind == "period", change_check=kind == "check",
                   change=change if change not in (None, "hold", "probe", "probed") else "",
                   settle_cycles=state.settle_cycles,
                   steps_by_model=state.steps_by_model, steps_by_climb=state.steps_by_climb,
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
        row.update(climb=False, period_change=False, change_check=False, change="", settle_cycles=state.settle_cycles,
                   steps_by_model=state.steps_by_model, steps_by_climb=state.steps_by_climb, candidate=False,
                   model_class_check=True)
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
                + (". It was sent an exploration: the robot must add what set_excitation sends to the shapes it "
                   "commands (a bridge driver: to each cycle's command)."
                   if state.exploration is not None else
                   ". Give the robot set_excitation (geogait then explores; a bridge driver: \"excitation\": true "
                   "in its hello) or a perturbation of its own."),
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
        if kind is None and state.climb.active:
            kind = self._climb_move()
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
        if "residual_share" not in self.capabilities or not model_fitted(model):
            return np.nan
        return float(model.residual_share_)

def new_climb(climb: Climb | None, scale: float) -> MeasuredClimb:
    """The measured climb's state for a run: σ within [min_sigma, max_sigma] (× shape_scale); a run without a
    climb carries an inactive one of the default radii."""
    climb = Climb() if climb is None else climb
    return MeasuredClimb(sigma=climb.sigma * scale, min_sigma=climb.min_sigma * scale,
                         max_sigma=climb.max_sigma * scale)
