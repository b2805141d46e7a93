"""Path following: wall time of one tracking cycle of the adaptive controller (learn the cycle, re-predict
or re-solve the steering family, plan, solve the commanded steering gait, simulate the cycle)."""

from __future__ import annotations

import time

from geogait.control import PathTracker, ReferencePath
from geogait.experiments.tracking import feasible_turn_limit, straight_gait, tracking_model
from geogait.gaits import Perturbation
from geogait.simulate import SwimmerStream

WARMUP, SHORT, LONG = 5, 5, 20


def _seconds(n_links: int, model: str, cycles: int) -> float:
    system, gait, step = straight_gait(n_links)
    robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.05), sensor_noise=0.1, seed=0)
    tracker = PathTracker(warmup_cycles=WARMUP, turn_limit=feasible_turn_limit(n_links),
                          model=tracking_model(model), change_forgetting=100.0 if model == "shape" else 1.0)
    start = time.perf_counter()
    tracker.run(robot, ReferencePath.circle(10 * step), cycles)
    return time.perf_counter() - start


def run():
    rows = []
    for n_links in (3, 5):
        for model in ("window", "shape"):
            _seconds(n_links, model, 1)  # warm caches (the ceiling gait, lazy imports)
            # the difference of a long and a short run leaves out the warm-up and the first family solve
            per_cycle = min(_seconds(n_links, model, LONG) - _seconds(n_links, model, SHORT) for _ in range(2))
            rows.append(dict(benchmark="path following", case=f"{n_links}-link circle, {model} model, adaptive",
                             value=(LONG - SHORT) / per_cycle, unit="cycles/s",
                             target=">= 20" if n_links == 5 and model == "window" else ""))
    return rows
