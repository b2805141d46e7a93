"""Child seeds that do not disturb their parents (one rule for every seeded stream and sweep)."""

from __future__ import annotations

import numpy as np

__all__ = ["child_seed"]


def child_seed(sequence: np.random.SeedSequence, key: int) -> np.random.SeedSequence:
    """Child ``key`` of ``sequence``, built without mutating it.

    ``SeedSequence(s.entropy, spawn_key=s.spawn_key + (key,))`` is what ``s.spawn`` would hand out as
    its ``key``-th child, but calling it twice gives the same sequence (``spawn`` advances the
    parent's counter, so a second stream from the same seed would differ).
    """
    return np.random.SeedSequence(sequence.entropy, spawn_key=tuple(sequence.spawn_key) + (key,))
