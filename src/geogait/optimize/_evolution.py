r"""The measured climb's evolution strategy: a (1+1) strategy with mirrored sampling, as an ask/tell search.

From the climb's base (the best gait it has kept) a candidate is asked at distance σ in a random direction, or,
after a failure, in the opposite direction (mirrored sampling: Brockhoff, Auger, Hansen, Arnold & Hohm, PPSN 2010).
σ grows by ``growth`` when the climb keeps the candidate and shrinks by ``shrink`` when it does not: with 1.5 and
0.85 a success rate near 2/7 keeps it steady. A candidate the robot may not run (beyond a joint limit, outside the
feasible region) is asked again at half the length, up to ``shortenings`` times; then σ halves and no candidate is
run that cycle. The strategy steps from the base, so the climb tells it where the base moved (:meth:`recentre`), and
after three failures in a row the climb measures the base again (a base measured lucky is corrected).

Its directions are drawn from the run's generator, so a resumed run draws what the original would have.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._search import MeasuredSearch

__all__ = ["EvolutionSearch"]


@dataclass
class EvolutionSearch(MeasuredSearch):
    """The mirrored (1+1) evolution strategy from ``origin`` (module docstring); parameters as
    :class:`~geogait.optimize._search.MeasuredSearch` (``radius``: the first σ; ``final_radius``: the smallest),
    and

    max_radius : float
        The largest σ.
    growth, shrink : float
        σ's factor after a kept and after a failed candidate.
    shortenings : int
        Halvings of a candidate's length before the strategy gives up a direction.
    remeasure_after : int
        Failed candidates in a row after which the climb measures the base again.
    sigma : float
        The step length now (NaN: ``radius``).
    mirror : bool
        The next candidate is the mirror image of the last, failed one.
    direction : ndarray or None
        Unit direction of the last candidate.
    shortened : int or None
        Times the open direction's candidate was refused (None: none open, the next ask opens one).
    spent : bool
        The last direction was refused ``shortenings`` times: no candidate this cycle.
    """

    max_radius: float = np.inf
    growth: float = 1.5
    shrink: float = 0.85
    shortenings: int = 6
    remeasure_after: int = 3
    sigma: float = np.nan
    mirror: bool = False
    direction: np.ndarray | None = None
    shortened: int | None = None
    spent: bool = False
    _asked: int = field(default=0, init=False, repr=False, compare=False)  # (refusals before the last ask)

    rule = "es"
    onto_joint_limit = False
    _checkpointed = ("max_radius", "growth", "shrink", "shortenings", "remeasure_after", "sigma", "mirror",
                     "shortened", "spent")

    def __post_init__(self):
        super().__post_init__()
        if np.isnan(self.sigma):
            self.sigma = float(self.radius)

    def ask(self, bounds=None, known=None, rotation_limit: float | None = None, rng=None) -> np.ndarray | None:
        """The next candidate: σ (halved once per refusal) from the base along the open direction, or a fresh one
        (the mirror of the last failed direction, or a random unit direction drawn from ``rng``); None after
        ``shortenings`` refusals. The limits are the climb's to check (:meth:`refuse`). A candidate asked and not
        refused closes its direction: the next ask opens a fresh one."""
        if self.spent:
            self.spent = False
            return None
        if self.shortened is None:
            if self.mirror and self.direction is not None:
                self.direction = -self.direction
            else:
                draw = rng.standard_normal(self.origin.size)
                self.direction = draw / np.linalg.norm(draw)
            self.shortened = 0
        self._asked, self.shortened = self.shortened, None
        return self.origin + self.sigma * 0.5 ** self._asked * self.direction

    def refuse(self, point) -> None:
        """``point`` (the last asked) may not run: the direction stays open at half the length; after
        ``shortenings`` refusals σ halves and the direction is given up."""
        refused = self._asked + 1
        if refused == self.shortenings:
            self.sigma = max(self.final_radius, self.sigma / 2)
            self.spent = True
        else:
            self.shortened = refused

    def tell(self, point, value: float, rotation: float, kept: bool | None = None) -> None:
        super().tell(point, value, rotation, kept)
        if kept is None:
            return
        if kept:
            self.sigma, self.mirror = min(self.max_radius, self.growth * self.sigma), False
        else:
            self.mirror = not self.mirror  # mirror once after a fresh direction fails
            self.sigma = max(self.final_radius, self.shrink * self.sigma)

    def recentre(self, origin, period: float) -> None:
        self.origin, self.period = np.asarray(origin, dtype=float), float(period)

    def to_checkpoint(self, prefix: str) -> tuple[dict, dict]:
        metadata, arrays = super().to_checkpoint(prefix)
        if self.direction is not None:
            arrays[f"{prefix}/direction"] = self.direction
        return metadata, arrays

    @classmethod
    def from_checkpoint(cls, metadata: dict, arrays: dict, prefix: str) -> EvolutionSearch:
        search = super().from_checkpoint(metadata, arrays, prefix)
        search.direction = arrays.get(f"{prefix}/direction")
        return search
