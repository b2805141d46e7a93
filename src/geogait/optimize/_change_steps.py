"""What the :class:`~geogait.optimize.Adaptation` part does in a run: test the held gait's cycles against its
record, and on a change forget the stale records, widen the family and hand the recovery to the model or the
climb (module :mod:`geogait.optimize._adaptation`)."""

from __future__ import annotations

import numpy as np

from ..gaits import FreeGaitFamily, MirrorGaitFamily
from ..models import model_capabilities, model_fitted
from ._models import run_model
from ._state import family_kind

#: Fewest measured cycles of a gait whose mean net rotation is tested (the held gait's, at a check or a hold).
ROTATION_CYCLES = 2
#: Measured cycles of a gait held without a break after which each further cycle is tested against them.
HELD_CYCLES = 4
#: The model's most recent prediction residuals of climb candidates that scale its surprise.
SURPRISE_HISTORY = 20


class ChangeSteps:
    """Methods of :class:`~geogait.optimize._loop.CycleLoop` (a mixin: it reads the loop's ``parts``, ``state``
    and ``robot``)."""

    def _records(self) -> tuple[dict, dict]:
        """The measured records of the steps now taken: the climb's (clean cycles) or the model's."""
        state = self.state
        if state.climb.active:
            return state.climb.measured, state.climb.rotations
        return state.measured, state.rotations

    def _watch(self, key, value: float, rotation: float) -> str | None:
        """Test a measured cycle of ``key`` before it is recorded: ``"hold"`` when it is out of band and needs a
        second cycle, the evidence of a change when one is detected (and answered), else None."""
        adaptation, state = self.parts.adaptation, self.state
        if adaptation is None:
            return None
        watch = state.watch
        values, rotations = self._records()
        self._model_surprised(key, value)
        if watch.suspect and watch.suspect[1] == state.iteration and state.cycles_in_iteration == watch.suspect[2] + 1:
            n_ref, strict = int(watch.suspect[0]), bool(watch.suspect[3])
            watch.suspect = []
            reference, since = values[key][:n_ref], values[key][n_ref:]  # (since: the cycles that tripped the test)
            found = self._out_of_band([*since, value], reference, values, key, strict=strict)
            if found is not None and found[0] == self._side(float(np.mean(since)), reference):
                return self._respond("objective", key, [*since, value], [*rotations[key][n_ref:], rotation],
                                     reference, found[1])
            return None
        watch.suspect = []
        revisit = state.cycles_in_iteration == 0 and bool(values.get(key))
        held = state.cycles_in_iteration >= HELD_CYCLES and len(values.get(key, ())) >= HELD_CYCLES
        if revisit or held:
            watch.since_check = 0 if revisit else watch.since_check
            strict = held and not revisit  # (a held gait is tested at every cycle, not once a check)
            # the cycle against the gait's record; a held gait's last HELD_CYCLES cycles too, against the cycles
            # before them (a change within a robot's cycle-to-cycle spread shows in their mean, not in one cycle)
            recent = [[]]
            if strict and len(values[key]) >= 2 * HELD_CYCLES - 1:
                recent.append(values[key][len(values[key]) - (HELD_CYCLES - 1):])
            for tested in recent:
                reference = values[key][:len(values[key]) - len(tested)]
                if self._out_of_band([*tested, value], reference, values, key, strict=strict) is not None:
                    watch.suspect = [len(reference), state.iteration, state.cycles_in_iteration, strict]
                    return "hold"
        turning = self._rotation_appears(key, rotation, rotations)
        if turning is None:
            return None
        watch.turning = watch.turning + 1 if turning else 0
        if watch.turning == 1:  # (held a cycle more: two tests in a row, as the objective's)
            return "hold"
        if watch.turning >= 2:
            post = rotations[key] + [rotation]
            return self._respond("rotation", key, [value], [rotation], values.get(key, [value]), np.nan, post)
        return None

    def _model_surprised(self, key, value: float) -> None:
        """While climbing, with the model confident (Γ over the climb's cycles at least the gate's Γ*): the model's
        a-priori prediction of each candidate's objective against what it measured.
        Two residuals in a row beyond ``threshold`` robust standard deviations of the recent ones (their median
        absolute deviation, over at least :data:`SURPRISE_HISTORY` // 2 of them), on the same side, make the held
        gait's check due at once: the model notices, the held gait's measurement confirms."""
        state, watch = self.state, self.state.watch
        # (the first surprise of a change drops Γ: a second is judged by the confidence the first was)
        confident = self.gate != "gamma" or state.gamma >= self.parts.gate.gamma_threshold or watch.surprise != 0
        if not state.climb.active or key == state.climb.base or not model_fitted(state.model) or not confident:
            return
        residual = value - self._predict(key[0])[1] * state.rate(key[1])
        history = np.asarray(watch.residuals, dtype=float)
        watch.residuals = [*watch.residuals, residual][-SURPRISE_HISTORY:]
        if history.size < SURPRISE_HISTORY // 2:
            return
        centre = float(np.median(history))
        scale = 1.4826 * float(np.median(np.abs(history - centre)))
        side = int(np.sign(residual - centre)) if abs(residual - centre) > self.parts.adaptation.threshold * scale \
            else 0
        if side and side == watch.surprise:
            watch.since_check = self.parts.adaptation.check_every  # (due at the next decision)
        watch.surprise = side

    @staticmethod
    def _side(value: float, reference) -> int:
        return 1 if value > float(np.mean(reference)) else -1

    def _out_of_band(self, new: list, reference: list, values: dict, key, strict: bool = False) \
            -> tuple[int, float] | None:
        """(side, noise) when the mean of ``new`` is out of ``reference``'s band (module docstring; ``strict``: at
        ``threshold`` + 1), else None."""
        adaptation, state = self.parts.adaptation, self.state
        other = state.measured if values is state.climb.measured else state.climb.measured
        sigma, dof = state.watch.noise({**values, key: list(reference)}, other)
        residuals = np.asarray(state.watch.residuals, dtype=float)
        if residuals.size - 1 > dof:  # (a climb measures each candidate once: the model's residuals say more)
            sigma = 1.4826 * float(np.median(np.abs(residuals - np.median(residuals))))
            dof = residuals.size - 1
        mean, shift = float(np.mean(reference)), float(np.mean(new)) - float(np.mean(reference))
        band = adaptation.band(dof, strict) * sigma * np.sqrt(1 / len(new) + 1 / len(reference))
        if not (abs(shift) > band and abs(shift) > adaptation.min_change * abs(mean)):
            return None
        return (1 if shift > 0 else -1), sigma

    def _rotation_appears(self, key, rotation: float, rotations: dict) -> bool | None:
        """In a family that promises no net rotation: whether the gait's mean measured rotation over its cycles
        (this one included) is beyond its noise band and the rotation tolerance; None (not tested) for a gait of
        fewer than :data:`ROTATION_CYCLES` cycles (a climb's candidate: one cycle, which may still turn as the body
        settles) or in a family that promises none."""
        cycles = np.append(rotations.get(key, []), rotation)
        if cycles.size < ROTATION_CYCLES or not self._promises_no_rotation():
            return None
        return self._turns({**rotations, key: list(cycles)}, cycles)

    def _promises_no_rotation(self) -> bool:
        """The family searched turns the body it was chosen for by nothing, and the part may widen it."""
        return not isinstance(self.state.family, FreeGaitFamily) and self.parts.adaptation.widen_family

    def _turns(self, rotations: dict, cycles) -> bool:
        """In a family that promises no net rotation (and ``widen_family``): the mean of ``cycles`` (measured net
        rotations of one gait) is beyond its noise band and the rotation tolerance. Every gait of such a family
        turns the body it was chosen for by exactly nothing, so every rotation recorded (``rotations``, and those of
        records the run has dropped) is noise: the band's σ is their root mean square."""
        state, adaptation = self.state, self.parts.adaptation
        if not self._promises_no_rotation():
            return False
        cycles = np.asarray(cycles, dtype=float)
        recorded = np.concatenate([np.asarray(v, dtype=float) for v in rotations.values()] or [np.zeros(0)])
        dof = recorded.size + state.watch.rotation_n
        sigma = float(np.sqrt((np.sum(recorded ** 2) + state.watch.rotation_ss) / dof)) if dof else np.nan
        limit = self.parts.climb.rotation_tolerance if self.parts.climb is not None \
            else self.parts.step.rotation_tolerance
        mean = abs(float(cycles.mean()))
        band = adaptation.band(dof, strict=True)  # (tested at every cycle, not once a check)
        return bool(mean > band * sigma / np.sqrt(cycles.size) and mean > limit)

    def _respond(self, evidence: str, key, values: list, rotations: list, reference, noise: float,
                 post_rotations: list | None = None) -> str:
        """A change was detected on ``key`` (its cycles since: ``values``, ``rotations``): log it, forget the
        records made before it, widen the family on rotation, and hand the steps to the model or the climb;
        returns the evidence."""
        parts, state, adaptation = self.parts, self.state, self.parts.adaptation
        watch = state.watch
        measured, before = float(np.mean(values)), float(np.mean(reference))
        size = abs(measured - before) / abs(before) if before and evidence == "objective" else 1.0
        if evidence == "objective" and self._turns(self._records()[1], rotations):
            evidence = "objective+rotation"  # (the body turns since the change: its family no longer holds)
        family = family_kind(state.family)
        held = self._widen(key) if "rotation" in evidence else key
        widened = family_kind(state.family) != family
        watch.rotation_free = watch.rotation_free or "rotation" in evidence
        watch.events.append({"cycle": int(state.cycle), "evidence": evidence, "measured": measured,
                             "reference": before, "noise": None if np.isnan(noise) else float(noise),
                             "rotation": float(np.mean(post_rotations if post_rotations else rotations)),
                             "family": family_kind(state.family)})
        watch.since_check, watch.suspect, watch.turning = 0, [], 0
        watch.residuals, watch.surprise = [], 0  # (the model's residuals before the change are no scale after it)
        if not widened and "forget" in self.capabilities and adaptation.forget > 1:
            state.model.forget(adaptation.forget)
        watch.archive(state.measured, state.climb.measured)
        watch.archive_rotations(state.rotations, state.climb.rotations)
        state.measured, state.rotations = {}, {}
        state.radius = parts.step.trust_radius * state.scale
        state.distrust = state.prediction_failures = state.stall = 0
        state.promised, state.previous_gait = None, None
        state.tracking_follows = True
        # (the changed robot may settle differently: measured again where it is not declared)
        state.settle_due = parts.safety.settle_cycles == "auto" and self.spec.settle_cycles is None
        climb = parts.climb
        if climb is not None:
            watch.reopen = adaptation.reopen_sigma(climb.sigma, climb.first_sigma, size) * state.scale
        lead = adaptation.lead
        if lead == "auto":  # (as the run started)
            lead = "climb" if climb is not None and climb.start == "first" else "model"
        model_leads = lead == "model" and not self._model_excluded()  # (unexcited cycles start the climb anyway)
        if model_leads or climb is None:
            state.climb.active, state.climb.candidate, state.climb.search = False, None, None
            state.climb.base = held  # (the model leads: no first climb)
            state.climb.measured, state.climb.rotations = {}, {}
            if held != key:
                self._change_gait(*held)
            else:  # the model's records start with its next (explored) cycles
                state.iteration += 1
                state.restart_iteration()
                if "online_gamma" in self.capabilities and not widened:
                    state.model.reset_gamma()
            state.gamma = np.nan
            return evidence
        self._start_climb(base=held)
        if held != key:  # (the gait projected into the wider family: measured next)
            self._change_gait(*held)
        else:
            state.climb.measured[key], state.climb.rotations[key] = list(values), list(rotations)
        return evidence

    def _widen(self, key) -> tuple:
        """Search a family that holds a rotation-free gait for the changed body: from the symmetric family the
        mirror family where the robot declares mirror symmetry (the held gait projected into it: its offsets and
        even harmonics dropped), else the free family; from the mirror family the free family. The model is
        rebuilt for it. Returns the (gait, period) held from now on (``key`` itself when already free)."""
        state, parts = self.state, self.parts
        family = state.family
        if isinstance(family, FreeGaitFamily):
            return key
        gait, period = key
        if not isinstance(family, MirrorGaitFamily) and self.spec.mirror_symmetric:
            state.family = MirrorGaitFamily(gait.n_joints, family.order)
            gait = state.family.gait(state.family.params_of(gait, tolerance=np.inf))
        else:
            state.family = FreeGaitFamily(gait.n_joints, family.order)
        state.model = run_model(parts.model, gait, period, state.family, state.scale)
        self.capabilities = model_capabilities(state.model)  # (the default model differs between families)
        return gait, period

    def _check_due(self) -> bool:
        """While climbing: the held gait is due to be measured again (``check_every`` candidates since)."""
        adaptation = self.parts.adaptation
        return adaptation is not None and self.state.watch.since_check >= adaptation.check_every
