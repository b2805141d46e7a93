"""Connection evaluations per second and simulation speed (issue 2)."""

import numpy as np
from run import best_time

from geogait.gaits import seed_gait
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


def run():
    rows = []
    shapes_rng = np.random.default_rng(0)
    for links in (3, 5, 9):
        swimmer = PurcellSwimmer(links)
        shapes = shapes_rng.uniform(-1, 1, size=(10_000, links - 1))
        seconds = best_time(lambda s=swimmer, x=shapes: s.connection(x))
        rows.append(dict(benchmark="connection", case=f"{links}-link, batch of 10^4 shapes",
                         value=10_000 / seconds, unit="shapes/s"))
    swimmer, gait = PurcellSwimmer(9), seed_gait(8)
    seconds = best_time(lambda: simulate(swimmer, gait, 40, samples_per_cycle=100, seed=0), repeats=3)
    rows.append(dict(benchmark="simulate", case="9-link, 40 cycles x 100 samples", value=seconds, unit="s",
                     target="< 0.5 s"))
    seconds = best_time(lambda: simulate(swimmer, gait, 40, samples_per_cycle=100, seed=0, n_trials=50),
                        repeats=1)
    rows.append(dict(benchmark="simulate", case="9-link, 50 trials x 40 cycles x 100 samples", value=seconds,
                     unit="s"))
    return rows
