"""What the :class:`~geogait.optimize.Adaptation` part does in a run: test the held gait's cycles against its
record, and on a change forget the stale records, widen the family and hand the recovery to the model or the
climb (module :mod:`geogait.optimize._adaptation`)."""

from __future__ import annotations

import numpy as np

from ..gaits import FreeGaitFamily, MirrorGaitFamily
from ..models import model_capabilities
from ._adaptation import pooled_noise
from ._models import run_model
from ._state import family_kind

#: Fewest cycles of a gait whose mean net rotation is tested against zero.
ROTATION_CYCLES = 3
#: Measured cycles of a gait held without a break after which each further cycle is tested against them.
HELD_CYCLES = 4


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
        if watch.suspect and watch.suspect[3] == state.iteration and state.cycles_in_iteration == watch.suspect[4] + 1:
            first, first_rotation, n_ref = watch.suspect[:3]
            watch.suspect = []
            reference = values[key][:int(n_ref)]
            found = self._out_of_band([first, value], reference, values, key)
            if found is not None and found[0] == self._side(first, reference):
                return self._respond("objective", key, [first, value], [first_rotation, rotation], reference,
                                     found[1])
            return None
        watch.suspect = []
        revisit = state.cycles_in_iteration == 0 and bool(values.get(key))
        held = state.cycles_in_iteration >= HELD_CYCLES and len(values.get(key, ())) >= HELD_CYCLES
        if revisit or held:
            watch.since_check = 0 if revisit else watch.since_check
            found = self._out_of_band([value], values[key], values, key)
            if found is not None:
                watch.suspect = [value, rotation, len(values[key]), state.iteration, state.cycles_in_iteration]
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

    @staticmethod
    def _side(value: float, reference) -> int:
        return 1 if value > float(np.mean(reference)) else -1

    def _out_of_band(self, new: list, reference: list, values: dict, key) -> tuple[int, float] | None:
        """(side, noise) when the mean of ``new`` is out of ``reference``'s band (module docstring), else None."""
        adaptation, state = self.parts.adaptation, self.state
        other = state.measured if values is state.climb.measured else state.climb.measured
        sigma, dof = pooled_noise({**values, key: list(reference)}, other)
        mean, shift = float(np.mean(reference)), float(np.mean(new)) - float(np.mean(reference))
        band = adaptation.band(dof) * sigma * np.sqrt(1 / len(new) + 1 / len(reference))
        if not (abs(shift) > band and abs(shift) > adaptation.min_change * abs(mean)):
            return None
        return (1 if shift > 0 else -1), sigma

    def _rotation_appears(self, key, rotation: float, rotations: dict) -> bool | None:
        """In a family that promises no net rotation: whether the gait's mean measured rotation over its cycles
        (this one included) is beyond its noise band and the rotation tolerance; None (not tested) for a gait of
        fewer than :data:`ROTATION_CYCLES` cycles or a family that promises none."""
        cycles = np.append(self._records()[1].get(key, []), rotation)
        if cycles.size < ROTATION_CYCLES or isinstance(self.state.family, FreeGaitFamily) \
                or not self.parts.adaptation.widen_family:
            return None
        return self._turns({**rotations, key: list(cycles)}, cycles)

    def _turns(self, rotations: dict, cycles) -> bool:
        """In a family that promises no net rotation (and ``widen_family``): the mean of ``cycles`` (measured net
        rotations of one gait) is beyond its noise band and the rotation tolerance. Every gait of such a family
        turns the body it was chosen for by exactly nothing, so every rotation recorded (``rotations``) is noise:
        the band's σ is their root mean square."""
        state, adaptation = self.state, self.parts.adaptation
        if isinstance(state.family, FreeGaitFamily) or not adaptation.widen_family:
            return False
        cycles = np.asarray(cycles, dtype=float)
        recorded = np.concatenate([np.asarray(v, dtype=float) for v in rotations.values()] or [np.zeros(0)])
        sigma, dof = float(np.sqrt(np.mean(recorded ** 2))) if recorded.size else np.nan, recorded.size
        limit = self.parts.climb.rotation_tolerance if self.parts.climb is not None \
            else self.parts.step.rotation_tolerance
        mean = abs(float(cycles.mean()))
        return bool(mean > adaptation.band(dof) * sigma / np.sqrt(cycles.size) and mean > limit)

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
        if "rotation" in evidence:
            held = self._widen(key)
        else:
            held = key
        widened = family_kind(state.family) != family
        watch.rotation_free = watch.rotation_free or "rotation" in evidence
        watch.events.append({"cycle": int(state.cycle), "evidence": evidence, "measured": measured,
                             "reference": before, "noise": None if np.isnan(noise) else float(noise),
                             "rotation": float(np.mean(post_rotations if post_rotations else rotations)),
                             "family": family_kind(state.family)})
        watch.since_check, watch.suspect, watch.turning = 0, [], 0
        if not widened and "forget" in self.capabilities and adaptation.forget > 1:
            state.model.forget(adaptation.forget)
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
        model_leads = adaptation.lead == "model" and not self._model_excluded() and state.exploration is not None
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
