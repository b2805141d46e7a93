"""Named defaults shared across geogait (one place each, so that they cannot drift apart).

The design's choices (``DESIGN.md``): the joint limit r_max of a robot that declares none, and the
window model's forgetting factor for d joints (its memory, ≈ 10 d window updates, grows with the
number of weights it must learn).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_JOINT_ANGLE", "window_forgetting_factor"]

#: r_max (rad) of a robot or system that declares no joint ranges: 120°.
MAX_JOINT_ANGLE = 2 * np.pi / 3


def window_forgetting_factor(n_joints: int) -> float:
    """λ = 1 − 0.1 / d of the window model (:class:`~geogait.models.AdaptiveGaitModel`) for d joints."""
    return 1 - 0.1 / n_joints
