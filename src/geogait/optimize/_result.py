"""The outcome of an in-situ optimisation run: its per-cycle log, gaits and headline numbers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..gaits import FourierGait
from ..learn import ModelClassVerdict
from ..simulate import Trajectory

__all__ = ["InSituResult"]


@dataclass
class InSituResult:
    """Outcome of :meth:`InSituOptimizer.run`.

    Attributes
    ----------
    log : pandas.DataFrame
        One row per cycle: ``cycle``, ``iteration``, ``settling`` (a settle cycle after a gait
        change, not learned from), ``gamma`` (online Γ over the iteration so far; NaN on settle
        cycles and on the burn-in cycle after a step, which only trains the reset baseline),
        ``step`` (a step was taken after this cycle), ``rejected`` (this cycle's gait was rejected
        for poor tracking and the previous one commanded again), ``reverted`` (measured worse than
        the best gait so far, which was commanded again), ``prediction_ok`` (the prediction
        check at a gate decision; NaN when none was made), ``trust_radius``,
        ``predicted_objective`` (the model's estimate for the gait of this cycle at the last step
        decision); measured from the robot: ``measured_x``, ``measured_y``, ``measured_heading``
        (net motion of the cycle in the body frame at its start), ``measured_progress`` (its
        length), ``measured_objective``, ``measured_speed`` (progress per second),
        ``tracking_error`` (RMS realised − commanded shape, rad), ``tracking_limit`` (the limit the model's
        steps are held to after this cycle, rad; NaN when none), ``world_x``, ``world_y``,
        ``world_heading`` (pose at the start of the cycle), ``cycle_period`` (s), ``climb`` (the step
        after this cycle came from the measured climb), ``period_change`` (a period trial started or
        ended after it), ``candidate`` (this cycle ran a climb candidate or period trial that was
        not kept: not a result); with a simulator's truth ``true_x``,
        ``true_y``, ``true_heading``, ``true_progress``, ``true_objective``; ``improvement``
        (relative to the seed: true values where there is a truth, else the measured objective over
        the mean measured objective of the seed's cycles so far), ``ceiling_fraction`` (when a
        ceiling is given), ``model_class_check`` (with ``model_class_cycles``: a cycle of the
        model-class test, which is also ``settling``), and ``param_*``.
    initial_gait, final_gait : FourierGait
    gaits : list of FourierGait
        Every nominal gait commanded, in order (rejected ones included).
    trajectory : Trajectory or None
        Every sample of the run (when ``record=True``; after a resume only the resumed part).
    max_joint_angle, shape_scale : float or None
        The joint limit and unit of shape the run used (resolved from the robot for ``"auto"``).
    direction : ndarray of shape (2,) or None
        The unit direction of ``"forward"`` the run used (in its ``direction_frame``).
    cycle_period : float or None
        The period (s) to run ``final_gait`` at (the robot's, unless ``optimize_period``).
    family : str or None
        The gait family searched (``"free"``, ``"symmetric"`` or ``"mirror"``: what ``family="auto"``
        chose from what the robot declares).
    model : object or None
        The model as the run left it (learned from every learned cycle; with the ``"cycles"`` gate
        the last fit): what the next step would have used. Inspect it against a simulator's truth,
        or save it.
    model_class : ModelClassVerdict or None
        The run's model-class test (``model_class_cycles``; None without one, or when the run ended
        before it did): ``principally_kinematic`` False when the robot was found outside the model
        class (the model then took no step).
    changes : list of dict
        Every change of the robot or its world the run's :class:`~geogait.optimize.Adaptation` detected:
        ``cycle``, ``evidence`` (``"objective"`` or ``"rotation"``), the held gait's ``measured`` objective after
        it and its ``reference`` before, the cycle-to-cycle ``noise``, the measured ``rotation`` and the gait
        ``family`` searched from then on.
    """

    log: pd.DataFrame
    initial_gait: FourierGait
    final_gait: FourierGait
    gaits: list = field(default_factory=list)
    trajectory: Trajectory | None = None
    model: object | None = None
    max_joint_angle: float | None = None
    shape_scale: float | None = None
    direction: np.ndarray | None = None
    cycle_period: float | None = None
    family: str | None = None
    model_class: ModelClassVerdict | None = None
    changes: list = field(default_factory=list)

    @property
    def n_steps(self) -> int:
        return int(self.log["step"].sum())

    @property
    def n_rejected(self) -> int:
        return int(self.log["rejected"].sum())

    def summary(self, ceiling=None) -> dict:
        """Headline numbers of the run (what ``geogait optimize`` writes to ``summary.json``).

        Measured values average the learned cycles (no settle or rejected cycles) of the seed's
        iteration and of the last one; with a simulator's truth also the true displacement per cycle
        of the seed and final gaits (``final_gait``, not the last cycle's, which may be a trial the run did not
        keep) and the largest |net rotation| of any commanded gait; with a ``ceiling``
        (:class:`~geogait.optimize.Ceiling`) its value, the final gait's share of it and the first cycle at 90 %
        (trials not kept do not count). Non-finite values become ``None`` (valid JSON).
        """
        log = self.log
        # the result is the last gait that was not a trial left unjudged or not kept (a climb's candidate)
        kept = ~log["candidate"].astype(bool) if "candidate" in log else pd.Series(True, log.index)
        measured = log[~log["settling"] & ~log["rejected"] & kept]
        seed_rows = measured["iteration"] == 0
        final_rows = measured["iteration"] == measured["iteration"].iloc[-1]
        seed = measured.loc[seed_rows, "measured_objective"].mean()
        final = measured.loc[final_rows, "measured_objective"].mean()
        # per second: the same ratio at a fixed period, the objective's own with optimize_period
        periods = measured["cycle_period"] if "cycle_period" in measured else pd.Series(1.0, measured.index)
        seed_rate = (measured["measured_objective"] / periods)[seed_rows].mean()
        final_rate = (measured["measured_objective"] / periods)[final_rows].mean()
        summary = {
            "seed_measured_objective": _finite(seed),
            "final_measured_objective": _finite(final),
            "final_measured_improvement": _finite(final_rate / seed_rate - 1),
            "seed_cycle_period": _finite(periods[seed_rows].mean()),
            "final_cycle_period": _finite(periods[final_rows].mean()),
            "steps": self.n_steps,
            "rejected_steps": self.n_rejected,
            "reverted_to_best": int(self.log["reverted"].sum()) if "reverted" in self.log else 0,
            "steps_by_model": int(log["steps_by_model"].iloc[-1]) if "steps_by_model" in log else None,
            "steps_by_climb": int(log["steps_by_climb"].iloc[-1]) if "steps_by_climb" in log else None,
            "changes_detected": self.changes,
            "max_tracking_error_rad": _finite(log["tracking_error"].max()),
            "max_joint_angle": _finite(self.max_joint_angle),
            "shape_scale": _finite(self.shape_scale),
            "gait_family": self.family,
            "forward_direction": None if self.direction is None else [float(v) for v in self.direction],
            "final_gait_params": self.final_gait.params.tolist(),
        }
        if self.model_class is not None:
            summary["model_class"] = self.model_class.to_dict()
        # the truth of the final gait (not of the last cycle's, which may be a trial not kept)
        params = log.filter(regex=r"^param_\d+$").to_numpy()
        final_gait_rows = log[np.all(params == self.final_gait.params, axis=1)]
        if self.cycle_period is not None and "cycle_period" in log:
            final_gait_rows = final_gait_rows[final_gait_rows["cycle_period"] == self.cycle_period]

        def final_truth(column):
            return _finite(final_gait_rows[column].iloc[-1]) if len(final_gait_rows) else None

        not_run = "the final gait was chosen at the last decision and has not run yet"

        if "true_objective" in log:
            summary.update({
                "seed_displacement_per_cycle": _finite(log["true_objective"].iloc[0]),
                "final_displacement_per_cycle": final_truth("true_objective"),
                "final_improvement": final_truth("improvement"),
                "max_abs_rotation_of_commanded_gaits": _finite(np.abs(log["true_heading"]).max()),
            })
            if not len(final_gait_rows):
                summary.update(final_displacement_per_cycle_null_reason=not_run, final_improvement_null_reason=not_run)
        if ceiling is not None:
            first_90 = log.index[(log["ceiling_fraction"] >= 0.9) & kept]
            summary.update({
                "ceiling_displacement_per_cycle": ceiling.value,
                "final_ceiling_fraction": final_truth("ceiling_fraction"),
                "first_cycle_at_90_percent_of_ceiling": int(log["cycle"][first_90[0]]) if len(first_90) else None,
            })
            if not len(final_gait_rows):
                summary["final_ceiling_fraction_null_reason"] = not_run
            if not len(first_90):
                summary["first_cycle_at_90_percent_of_ceiling_null_reason"] = "no gait kept reached 90 % of the ceiling"
        return summary


def _finite(value):
    return None if value is None or not np.isfinite(value) else float(value)
