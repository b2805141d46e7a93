"""Study behind issue 10's defaults: gait family, step rule and model, in the same seeded runs.

For each configuration, ``TRIALS`` in-situ optimisations of the ``LINKS``-link swimmer (sensor noise
0.1 × RMS, perturbation 0.15 rad, seed gait, ``CYCLES`` cycles; trial i uses stream seed i in every
configuration). Prints per configuration: the median [25–75 %] true fraction of the (free-family,
zero-rotation) ceiling after each checkpoint cycle, the share of trials at 90 % within 30 cycles,
the median over trials of the largest |net rotation| of any commanded gait, and — for runs whose
gaits rotate — the final fraction "with rotation removed": the mean progress per cycle over 10
repetitions of the final gait, :math:`\\|t\\|\\,\\sin(5\\omega) / (10 \\sin(\\omega/2))`, which is
what a rotating gait actually gains along a straight line (equal to ‖t‖ at ω = 0).

    python studies/ceiling.py LINKS CYCLES TRIALS [CONFIG ...] [--jobs 1] [--checkpoints 30 40 60 200]
                              [--perturbation 0.15]

``--perturbation`` sets the std (rad) of the exploration perturbations δ from the first sample on
(``SwimmerStream.set_perturbation_std``: the stream's default spectrum, std 0.15, scaled).

CONFIG names: free-linear (the previous default), symmetric-linear, symmetric-sqp, shape-linear,
shape-sqp (ShapeSpaceModel, degree 3 below 9 links, 2 at 9), mirror-linear, mirror-sqp
(ShapeSpaceModel of degree 3 with the swimmer's mirror and reversal symmetries built in,
``symmetry="mirror+reversal"``), resistance-linear, resistance-sqp (:class:`~geogait.models.ResistanceModel`: the
swimmer's geometry given, its drags learned; with the structured preset (``geogait.optimize.structured``): trust radius
0.25 to 0.5, the measured climb only when contradicted), hybrid-linear, hybrid-sqp (the same with a degree-2
symmetric residual),
perfect-linear, perfect-sqp (true connection, trust radius up to
0.5); NAME@R sets the largest trust radius R (e.g. symmetric-sqp@0.5); each suffix ``,KEY=VALUE``
sets an ``InSituOptimizer`` option KEY, or a hyper-parameter NAME of the model when KEY is
``model.NAME`` (models named in the config only), e.g.
``mirror-sqp@0.5,model.forgetting_factor=0.9999,gamma_threshold=0.3``.
"""

import argparse
import time

import numpy as np
from joblib import Parallel, delayed

from geogait.gaits import seed_gait
from geogait.models import PerfectInformationModel, ResistanceModel, ShapeSpaceModel
from geogait.optimize import InSituOptimizer, cached_ceiling, from_flat_params
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

CONFIGS = ("free-linear", "symmetric-linear", "symmetric-sqp", "shape-linear", "shape-sqp", "mirror-linear",
           "mirror-sqp", "resistance-linear", "resistance-sqp", "hybrid-linear", "hybrid-sqp", "perfect-linear",
           "perfect-sqp")


#: The structured preset's step and climb settings by their flat names.
STRUCTURED_FLAT = {"step_rule": "sqp", "trust_radius": 0.25, "min_trust_radius": 0.25, "max_trust_radius": 0.5,
                   "climb": "contradicted", "climb_rule": "es"}


def optimizer(config, links):
    name, *settings = config.split(",")
    name, _, radius = name.partition("@")
    model, rule = name.split("-")
    options = {"step_rule": rule, "family": "free" if model == "free" else "symmetric"}
    if radius:
        options["max_trust_radius"] = float(radius)
    if model == "shape":
        options["model"] = ShapeSpaceModel(degree=3 if links < 9 else 2)
    if model == "mirror":
        options["model"] = ShapeSpaceModel(degree=3, symmetry="mirror+reversal")
    if model in ("resistance", "hybrid"):  # the chain's geometry known, its drags learned (and a residual)
        residual = {"residual_degree": 2, "residual_symmetry": "mirror+reversal"} if model == "hybrid" else {}
        options = {**STRUCTURED_FLAT, **options,
                   "model": ResistanceModel.from_swimmer(PurcellSwimmer(links), **residual)}
    if model == "perfect":
        options.update(model=PerfectInformationModel(system=PurcellSwimmer(links)), max_trust_radius=0.5)
    for setting in settings:
        key, _, value = setting.partition("=")
        value = {"none": None, "false": False, "true": True}[value] if value in ("none", "false", "true") \
            else int(value) if value.isdigit() else float(value)
        if key.startswith("model."):
            options["model"].set_params(**{key.removeprefix("model."): value})
        else:
            options[key] = value
    return InSituOptimizer(**from_flat_params(options))  # (settings by their flat names)


def one(links, cycles, name, seed, ceiling, perturbation):
    start = time.perf_counter()
    stream = SwimmerStream(PurcellSwimmer(links), seed_gait(links - 1), sensor_noise=0.1, seed=seed)
    if perturbation is not None:  # the stream's spectrum kept, its size scaled
        stream.set_perturbation_std(perturbation)
    log = optimizer(name, links).run(stream, cycles, ceiling=ceiling).log
    fraction = log["ceiling_fraction"].to_numpy()
    omega = log["true_heading"].to_numpy()[-1]
    repeated = np.sin(5 * omega) / (10 * np.sin(omega / 2)) if abs(omega) > 1e-12 else 1.0
    first = int(np.argmax(fraction >= 0.9)) if (fraction >= 0.9).any() else 999
    return fraction, float(np.abs(log["true_heading"]).max()), first, fraction[-1] * repeated, \
        time.perf_counter() - start


def main(links, cycles, trials, names, jobs, checkpoints, perturbation=None):
    ceiling = cached_ceiling(PurcellSwimmer(links)).value
    checkpoints = [c for c in checkpoints if c <= cycles]
    print(f"{links}-link, {cycles} cycles, {trials} trials; fraction of the ceiling median [25-75 %] at cycles "
          f"{checkpoints}", flush=True)
    for name in names:
        start = time.perf_counter()
        runs = Parallel(n_jobs=jobs)(delayed(one)(links, cycles, name, s, ceiling, perturbation) for s in range(trials))
        fractions = np.array([r[0] for r in runs])
        cells = []
        for c in checkpoints:
            q = np.percentile(fractions[:, c - 1], [25, 50, 75])
            cells.append(f"@{c}: {q[1]:.3f} [{q[0]:.3f}-{q[2]:.3f}]")
        rotation = np.median([r[1] for r in runs])
        within = np.mean([r[2] < 30 for r in runs])
        removed = np.median([r[3] for r in runs])
        print(f"{name:17s} " + "  ".join(cells) + f" | ≥90 % by 30: {within:.2f} | max|rot| median {rotation:.1e}"
              f" | final, rotation removed {removed:.3f} | {np.mean([r[4] for r in runs]):.1f} s/trial, "
              f"{time.perf_counter() - start:.0f} s", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("links", type=int)
    parser.add_argument("cycles", type=int)
    parser.add_argument("trials", type=int)
    parser.add_argument("configs", nargs="*", default=list(CONFIGS))
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--checkpoints", type=int, nargs="+", default=[30, 40, 60, 200])
    parser.add_argument("--perturbation", type=float, default=None)
    arguments = parser.parse_args()
    main(arguments.links, arguments.cycles, arguments.trials, arguments.configs, arguments.jobs,
         arguments.checkpoints, arguments.perturbation)
