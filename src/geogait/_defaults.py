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
#: trust region of 0.25 to 0.5, because a structured model's prediction holds far from the data and long chains have
#: optima along curved ridges that only large SQP steps follow. The measured climb starts only where measured
#: outcomes contradict the model, not where it levels off: at the model's optimum, single noisy cycles would lead an
#: accurate model astray. Where the structure is wrong (quadratic drag, dry friction), broken promises and tracking
#: rejections of the model's steps count as contradictions and hand the steps to measured outcomes. That climb is the
#: local evolution strategy, not COBYQA: COBYQA starts with 2n + 1 probes at a large radius, which spends the cycles a
#: local repair near the model's optimum needs.
STRUCTURED_MODEL_STEPS = {"step_rule": "sqp", "trust_radius": 0.25, "min_trust_radius": 0.25, "max_trust_radius": 0.5,
                          "climb": "contradicted", "climb_rule": "es"}


def window_forgetting_factor(n_joints: int) -> float:
    """λ = 1 − 0.1 / d of the window model (:class:`~geogait.models.AdaptiveGaitModel`) for d joints."""
    return 1 - 0.1 / n_joints
