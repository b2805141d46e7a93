"""Named defaults shared across geogait (one place each, so that they cannot drift apart).

The design's choices (``DESIGN.md``): the joint limit r_max of a robot that declares none, and the
window model's forgetting factor for d joints (its memory, ≈ 10 d window updates, grows with the
number of weights it must learn); the optimiser's settings for a model that holds far from its data
(the resistance model).
"""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULT_OUTLIER_LIMIT", "DEFAULT_TEST_FRACTION", "MAX_JOINT_ANGLE", "TIME_UNITS",
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


def window_forgetting_factor(n_joints: int) -> float:
    """λ = 1 − 0.1 / d of the window model (:class:`~geogait.models.AdaptiveGaitModel`) for d joints."""
    return 1 - 0.1 / n_joints
