"""Named defaults shared across geogait (one place each, so that they cannot drift apart).

The design's choices (``DESIGN.md``): the joint limit r_max of a robot that declares none, and the
window model's forgetting factor for d joints (its memory, ≈ 10 d window updates, grows with the
number of weights it must learn); the optimiser's settings for a model that holds far from its data
(the resistance model).
"""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULT_OUTLIER_LIMIT", "DEFAULT_TEST_FRACTION", "MAX_JOINT_ANGLE", "STRUCTURED_MODEL_STEPS", "TIME_UNITS",
           "TRACKING_WARMUP_TURNS", "window_forgetting_factor"]

#: r_max (rad) of a robot or system that declares no joint ranges: 120°.
MAX_JOINT_ANGLE = 2 * np.pi / 3
#: How far below zero a feasible-region row may fall and still hold (the SLSQP tolerance of the solves that put
#: gaits on the region's boundary: the ceiling's gait must be accepted as a seed by the optimiser and tracker).
FEASIBILITY_TOLERANCE = 1e-9

#: Turning warm-up cycles of path following on the built-in swimmers (``PathTracker(warmup_turns=...)`` in the tracking
#: experiment and ``geogait track``): their shape-space model, symmetric and of degree 3, holds over the turning range.
TRACKING_WARMUP_TURNS = 4

#: Seconds per unit of a log's or stream's ``time_unit``.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Plausibility bound of a log's or stream's samples, in robust standard deviations from the median.
DEFAULT_OUTLIER_LIMIT = 1000.0
#: Fraction of each log segment's cycles held out to score a fit (the last ones).
DEFAULT_TEST_FRACTION = 0.25


#: InSituOptimizer settings for :class:`~geogait.models.ResistanceModel`: SQP on its nonlinear prediction over a
#: trust region of 0.25 to 0.5 (it holds far from the data: the 9-link optimum lies along a curved ridge that only
#: large SQP steps follow; a radius the ratio test had halved to 0.06 on a noisy cycle left one 9-link run of 8
#: at 81 % of the ceiling, no step promising 0.5 %), and the measured climb only where measured outcomes contradict
#: the model, not where it levels off (at its optimum, single noisy cycles would lead an accurate model astray: 9-link
#: 0.957 of the ceiling at 60 cycles with the climb, 1.000 without). Where the structure is wrong, contradictions
#: hand the steps to measured outcomes: on Gymnasium's swimmer (quadratic drag) they come as tracking rejections
#: of the model's steps that also measure short of their promise (its predictions of the gaits it runs agree), which
#: count as broken promises (+51 % forward speed at 100 cycles, +24 % before they counted; the data-driven
#: default's +60 %). The climb that repairs a contradicted structured model is the local evolution strategy, not
#: COBYQA: COBYQA starts with 2n + 1 probes at a large radius, the cycles a local repair near the model's optimum
#: needs (9 links told link lengths 10 % wrong, hybrid model: 0.939 of the ceiling at 60 cycles against 0.752), while
#: it is the better rule for a search from the seed with no model to trust (the data-driven default).
STRUCTURED_MODEL_STEPS = {"step_rule": "sqp", "trust_radius": 0.25, "min_trust_radius": 0.25, "max_trust_radius": 0.5,
                          "climb": "contradicted", "climb_rule": "es"}


def window_forgetting_factor(n_joints: int) -> float:
    """λ = 1 − 0.1 / d of the window model (:class:`~geogait.models.AdaptiveGaitModel`) for d joints."""
    return 1 - 0.1 / n_joints
