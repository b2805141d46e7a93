"""What the :class:`~geogait.optimize.Safety` part does in a run: reject gaits the robot cannot follow, and
revert to the best gait measured when the model leads downhill; with a :class:`~geogait.optimize.PeriodSearch`,
the period trials."""

from __future__ import annotations

import numpy as np

from ._adaptation import pooled_noise
from ._measure import peak_phase_speed
from ._models import run_model
from ._state import (
    REJECTION_FLOOR,
    TRACKING_FLOOR,
)

#: Cycles of the gait change that ``settle_cycles="auto"`` probes.
PROBE_CYCLES = 3


class SafetySteps:
    """Methods of :class:`~geogait.optimize._loop.CycleLoop` (a mixin: it reads the loop's ``parts``, ``state``
    and ``robot``)."""

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
        if state.climb.candidate == (state.gait, state.period):  # a candidate the robot cannot follow: it failed
            state.climb.judge(-np.inf, 0.0, rotation_holds=False)
            climbing = state.climb.search  # (told the worst value measured, as a point it may not run)
            climbing.tell(state.climb.pending, min(climbing.values), 0.0, kept=False)
            previous = state.climb.base  # (the gait before it may be another failed candidate)
        self._change_gait(*previous)
        if trial:  # a period the robot cannot follow
            search.judge(-np.inf, 0.0)
            search.turn = False
        state.previous_gait = None  # the gait we fall back to was accepted; nothing further back to try
        return True

    def _settle_probe(self, key, value: float, rotation: float) -> str | None:
        """``Safety(settle_cycles="auto")``: a cycle of the gait change being probed. Returns ``"probe"`` for its
        first two cycles (held, not recorded), ``"probed"`` for its third, after which the settling count is set and
        the settled cycles recorded; None when no probe is under way."""
        state = self.state
        if state.settle_probe is None:
            return None
        state.settle_probe.append((value, rotation))
        if len(state.settle_probe) < PROBE_CYCLES:
            return "probe"
        values, rotations = (list(v) for v in zip(*state.settle_probe, strict=True))
        # the noise of settled cycles: every gait's first cycle left out (the start's, or one after a change)
        settled = [{k: v[1:] for k, v in record.items()} for record in (state.measured, state.climb.measured)]
        noise, dof = pooled_noise(*settled, {"probe": values[1:]})
        state.settle_cycles = self.parts.safety.settle_count(values, noise, dof)
        state.settle_probe = None
        records = self._records()
        records[0].setdefault(key, []).extend(values[state.settle_cycles:])
        records[1].setdefault(key, []).extend(rotations[state.settle_cycles:])
        return "probed"

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
