"""Study behind the in-situ optimiser's defaults (issue 5).

Runs seeded in-situ optimisations for every combination of the given InSituOptimizer parameters and
prints, per combination: the median and minimum final fraction of the ceiling, the median over
trials of the largest |net rotation| of any commanded gait, the median first cycle at 90 % of the
ceiling (999: never), the share of trials at 90 % of the ceiling within 30 cycles and the wall time.

    python studies/optimizer.py LINKS CYCLES NOISE TRIALS '{"forgetting_factor": [0.95, 0.97]}'
"""

import itertools
import json
import sys
import time

import numpy as np
from joblib import Parallel, delayed

from geogait.gaits import seed_gait
from geogait.optimize import InSituOptimizer, cached_ceiling, from_flat_params
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def one(links, cycles, noise, params, seed, ceiling):
    stream = SwimmerStream(PurcellSwimmer(links), seed_gait(links - 1), sensor_noise=noise, seed=seed)
    log = InSituOptimizer(**from_flat_params(params)).run(stream, cycles, ceiling=ceiling).log  # (a grid of flat names)
    fraction = log["ceiling_fraction"].to_numpy()
    first = np.argmax(fraction >= 0.9) if (fraction >= 0.9).any() else 999
    return fraction[-1], np.abs(log["true_heading"]).max(), first


def main(links, cycles, noise, trials, grid):
    ceiling = cached_ceiling(PurcellSwimmer(links)).value
    for values in itertools.product(*grid.values()):
        params = dict(zip(grid, values, strict=True))
        start = time.perf_counter()
        runs = Parallel(n_jobs=2)(delayed(one)(links, cycles, noise, params, s, ceiling) for s in range(trials))
        result = np.array(runs)
        print(params, f"final median {np.median(result[:, 0]):.3f} min {result[:, 0].min():.3f} | "
              f"max |rotation| median {np.median(result[:, 1]):.3f} | first cycle at 90 % median "
              f"{np.median(result[:, 2]):.1f} | within 30 cycles {np.mean(result[:, 2] < 30):.2f} | "
              f"{time.perf_counter() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), json.loads(sys.argv[5]))
