"""The measured climb's moves in a run (the :class:`~geogait.optimize.Climb` part at work): start it, propose
and judge its candidates, hand the steps back to the model."""

from __future__ import annotations

import numpy as np

from ..gaits import FreeGaitFamily
from ._climb import search_rule
from ._objective import joint_limit_constraints
from ._search import MeasuredSearch, onto_joint_limit


class ClimbSteps:
    """Methods of :class:`~geogait.optimize._loop.CycleLoop` (a mixin: it reads the loop's ``parts``, ``state``
    and ``robot``)."""

    def _start_climb(self, base: tuple | None = None, sigma: float | None = None) -> None:
        """Hand the steps to the measured climb, from the best gait measured so far (measured again:
        the climb's cycles carry no exploration when the optimiser owns it), at step ``sigma`` (default
        the Climb's ``sigma``). A period trial in progress is dropped: while climbing, the period is
        one of the climb's coordinates."""
        state = self.state
        best = self._best_key() if base is None else base
        if sigma is None and np.isfinite(state.watch.reopen):  # the first climb after a change: sized by it
            sigma, state.watch.reopen = state.watch.reopen, np.nan
        state.watch.archive(state.climb.measured)  # (the noise it measured outlives the records)
        state.watch.archive_rotations(state.climb.rotations)
        state.climb.start(best, self.parts.climb.sigma * state.scale if sigma is None else sigma)
        state.climb.search = self._new_search(best, state.climb.sigma)
        if state.period_search is not None:
            state.period_search.trial_from = None

    def _new_search(self, base: tuple, radius: float) -> MeasuredSearch:
        """The climb rule's search (:func:`~geogait.optimize._climb.search_rule`) from ``base`` = (gait, period)
        at step radius ``radius``, within the climb's radii."""
        state, climb = self.state, self.state.climb
        origin = self._coordinates(base)
        rule = search_rule(self.parts.climb.rule, origin.size, state.settle_cycles)
        return rule.search(origin, radius=radius, final_radius=climb.min_sigma, max_radius=climb.max_sigma,
                           period=base[1], rng=state.rng)

    def _coordinates(self, key: tuple) -> np.ndarray:
        """The search coordinates of ``key`` = (gait, period) at its own period: the family's free parameters,
        and with a period search a log-period coordinate of 0."""
        state = self.state
        origin = state.family.params_of(key[0], tolerance=1e-8)
        return origin if state.period_search is None else np.append(origin, 0.0)

    def _best_key(self) -> tuple:
        """The (gait, period) with the best mean measured objective (of those measured twice or more)."""
        state = self.state
        current = (state.gait, state.period)
        keys = [k for k, v in state.measured.items() if len(v) >= 2 or k == current]
        return max(keys, key=lambda k: float(np.mean(state.measured[k]))) if keys else current

    def _climb_move(self) -> str | None:
        """The climb's turn at a gate decision (:class:`MeasuredClimb`): judge the candidate just measured,
        go back to the base to measure it again after three failures or for the
        :class:`~geogait.optimize.Adaptation`'s check, or command the next candidate; returns ``"climb"`` or
        ``"check"`` when the gait changed, else None."""
        state, parts, climb = self.state, self.parts, self.state.climb
        key = (state.gait, state.period)
        measured = climb.measured
        if np.isnan(climb.rotation_limit) and climb.base in measured:  # the start base, measured as the climb
            rotation = abs(float(np.mean(climb.rotations[climb.base])))  # measures (clean, when it can)
            if state.watch.rotation_free:  # (a change made the body turn: back to none)
                rotation = 0.0
            climb.rotation_limit = max(rotation, parts.climb.rotation_tolerance)
        if climb.candidate is not None:
            if climb.candidate == key and climb.base in measured:
                designing = climb.search.designing  # (of the value about to be told)
                kept = climb.judge(float(np.mean(measured[key])), float(np.mean(measured[climb.base])),
                                   self._rotation_holds(key, climb.base), tests_model=not designing)
                climb.search.tell(climb.pending, np.mean(measured[key]), np.mean(climb.rotations[key]), kept)
                state.watch.since_check += 1
                if kept:
                    climb.search.recentre(self._coordinates(climb.base), climb.base[1])
                    self._follow_tracking()
                # back to model steps (unless outside its class), from the best gait, on a fresh record
                if climb.model_trusted_again and not self._model_excluded():
                    climb.active = False
                    state.distrust = state.prediction_failures = state.stall = 0
                    state.radius = parts.step.trust_radius * state.scale
                    state.watch.archive(state.measured)
                    state.watch.archive_rotations(state.rotations)
                    state.measured, state.rotations = {}, {}
                    self._change_gait(*climb.base)
                    state.previous_gait = None  # (the base was accepted: never refused back to a failed candidate)
                    state.tracking_follows = True  # the model's steps are held to what the base tracks
                    return "climb"
            climb.candidate = None  # a candidate left early (rejected) is not judged
        if self._check_due() and key != climb.base:
            state.watch.since_check = 0
            self._change_gait(*climb.base)
            return "check"
        after = climb.search.remeasure_after
        remeasure = after is not None and key != climb.base and climb.failures >= after
        if climb.base not in measured or remeasure:
            climb.failures = 0  # measure the base (again: it may have been lucky)
            self._change_gait(*climb.base)
            return "climb"
        return "climb" if self._climb_candidate() else None

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

    def _climb_candidate(self) -> bool:
        """Command the search's next point (:class:`~geogait.optimize._climb.SearchRule`); one beyond the joint
        limit is scaled back onto it where the search asks so, and one that breaks a limit it cannot be scaled to
        (joint speed, the feasible region) is refused, unrun. A converged search starts afresh from the base;
        returns False when the search proposes nothing to run this cycle."""
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
            point = search.ask(box, known, rotation, rng=state.rng)
            if point is None:
                if not search.converged:
                    return False
                climb.search = self._new_search(climb.base, climb.max_sigma / 4)  # afresh from the base
                continue
            gait = (onto_joint_limit(state.family, point[:n], state.max_joint_angle) if search.onto_joint_limit
                    else state.family.gait(point[:n]))
            period = search.period
            if state.period_search is not None:
                period = float(np.clip(search.period * np.exp(point[n] / state.scale),
                                       state.period_search.low, state.period_search.high))
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
