"""The resistance model on the built-in swimmers: share of the ceiling against the error in the geometry it is given.

For each geometry error e, model (``resistance``: the drags learned on the given geometry; ``hybrid``: the same plus
a degree-2 symmetric polynomial residual fitted with the drags) and trial i, an in-situ optimisation of the LINKS-link
swimmer in Fig. 5's setting (sensor noise 0.1, the stream's perturbations, seed gait, stream seed i) with
``geogait.optimize.structured`` (SQP, trust radius 0.25 to 0.5, the measured climb only when
contradicted). The model is
told link lengths each exactly e wrong: length j times (1 + e s_j), signs s_j = ±1 drawn per trial (seed
1000 + i), so the chain's proportions and its total length are both off. Prints the median [25-75 %] share of
the rotation-free ceiling at each checkpoint and writes every trial to ``--out`` (JSON).

    python studies/resistance.py LINKS CYCLES TRIALS [--errors 0 0.05 0.1 0.2] [--models resistance hybrid]
                                 [--checkpoints 30 60] [--jobs 2] [--out FILE] [--climb-rule es|cobyqa]
"""

import argparse
import json
import sys
import time

import numpy as np
from joblib import Parallel, delayed

from geogait.gaits import seed_gait
from geogait.models import ResistanceModel
from geogait.optimize import cached_ceiling, structured
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

MODELS = {"resistance": {}, "hybrid": {"residual_degree": 2, "residual_symmetry": "mirror+reversal"}}


def wrong_lengths(swimmer, error, trial):
    signs = np.random.default_rng(1000 + trial).choice([-1.0, 1.0], swimmer.n_links)
    return tuple(np.asarray(swimmer.link_lengths) * (1 + error * signs))


def one(links, cycles, model, error, trial, ceiling, climb_rule=None):
    start = time.perf_counter()
    swimmer = PurcellSwimmer(links)
    stream = SwimmerStream(swimmer, seed_gait(links - 1), sensor_noise=0.1, seed=trial)
    estimator = ResistanceModel(link_lengths=wrong_lengths(swimmer, error, trial), **MODELS[model])
    optimizer = structured(estimator) if climb_rule is None else structured(estimator, climb__rule=climb_rule)
    log = optimizer.run(stream, cycles, ceiling=ceiling).log
    return {"model": model, "geometry_error": error, "trial": trial,
            "ceiling_fraction": log["ceiling_fraction"].round(6).tolist(),
            "largest_rotation": float(np.abs(log["true_heading"]).max()), "seconds": time.perf_counter() - start}


def main(links, cycles, trials, errors, models, checkpoints, jobs, out, climb_rule=None):
    ceiling = cached_ceiling(PurcellSwimmer(links)).value
    checkpoints = [c for c in checkpoints if c <= cycles]
    print(f"{links}-link, {cycles} cycles, {trials} trials; share of the ceiling, median [25-75 %]", flush=True)
    records = []
    for model in models:
        for error in errors:
            runs = Parallel(n_jobs=jobs)(delayed(one)(links, cycles, model, error, t, ceiling, climb_rule)
                                         for t in range(trials))
            records += runs
            fractions = np.array([r["ceiling_fraction"] for r in runs])
            cells = []
            for c in checkpoints:
                q = np.percentile(fractions[:, c - 1], [25, 50, 75])
                cells.append(f"@{c}: {q[1]:.3f} [{q[0]:.3f}-{q[2]:.3f}] min {fractions[:, c - 1].min():.3f}")
            print(f"{model:10s} error {error:4.2f}  " + "  ".join(cells)
                  + f" | {np.mean([r['seconds'] for r in runs]):.0f} s/trial", flush=True)
    if out:
        with open(out, "w") as file:
            json.dump({"command": "python " + " ".join(sys.argv), "links": links, "cycles": cycles,
                       "ceiling": ceiling, "records": records}, file, indent=1)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("links", type=int)
    parser.add_argument("cycles", type=int)
    parser.add_argument("trials", type=int)
    parser.add_argument("--errors", type=float, nargs="+", default=[0.0, 0.05, 0.1, 0.2])
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--checkpoints", type=int, nargs="+", default=[30, 60])
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default=None)
    parser.add_argument("--climb-rule", choices=["es", "cobyqa"], default=None,
                        help="the measured climb's rule (default: the optimiser's)")
    arguments = parser.parse_args()
    main(arguments.links, arguments.cycles, arguments.trials, arguments.errors, arguments.models,
         arguments.checkpoints, arguments.jobs, arguments.out, arguments.climb_rule)
