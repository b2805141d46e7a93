"""Step rules with perfect information (issue 10): steps from the seed gait to 90 % of the ceiling.

The true connection stands in for the learned model (``PerfectInformationModel``), so the count
measures the step rule alone. Each step: the rule proposes a step inside the trust radius R, the
new gait's true objective is evaluated; R follows the ratio test (×1.5 up to ``max_radius`` when
a step at the boundary delivers > 3/4 of its promise, ×½ below 1/4). Prints, per swimmer, family,
rule and radius, the steps to 90 % / 95 % of the ceiling (of the same family's objective, zero
rotation) and the fraction after ``--steps`` steps.

    python studies/steps.py [--links 3 5 9] [--steps 40] [--min-gain 0.005]

``--min-gain`` is the smallest predicted relative gain of an accepted step (the optimiser's
``min_gain``); with perfect information 0 is safe, and it decides whether the 9-link runs stall.
"""

import argparse
import time

import numpy as np

from geogait.gaits import FreeGaitFamily, SymmetricGaitFamily, seed_gait
from geogait.models import PerfectInformationModel
from geogait.optimize import cached_ceiling, joint_limit_constraints
from geogait.optimize._steps import StepProblem, take_step
from geogait.simulate import cycle_displacement
from geogait.systems import PurcellSwimmer


def run(links, family_name, rule, radius, max_radius, n_steps, ceiling, min_gain=0.005):
    system = PurcellSwimmer(links)
    seed = seed_gait(links - 1)
    family = SymmetricGaitFamily.from_gait(seed) if family_name == "symmetric" else FreeGaitFamily(links - 1)
    model = PerfectInformationModel(system=system)
    limits = joint_limit_constraints(links - 1, 1, 2 * np.pi / 3)
    problem = StepProblem(model.predict_displacement, family, limits=limits)
    params = family.params_of(seed)
    fractions = []
    for _ in range(n_steps):
        step = take_step(rule, problem, params, radius, min_gain=min_gain)
        if step.accepted:
            pose = cycle_displacement(system, step.gait, resolution=128)
            actual = np.hypot(pose[0], pose[1])
            promised = step.predicted_value - step.value_before
            ratio = (actual - step.value_before) / promised if promised else 1.0
            if ratio < 0.25:
                radius /= 2
            elif ratio > 0.75 and step.boundary:
                radius = min(max_radius, radius * 1.5)
            params = step.params
        true = cycle_displacement(system, family.gait(params), resolution=128)
        fractions.append(np.hypot(true[0], true[1]) / ceiling if abs(true[2]) < 1e-3 else np.nan)
    return np.array(fractions)


def first(fractions, level):
    hit = np.nonzero(fractions >= level)[0]
    return int(hit[0]) + 1 if hit.size else None


def main(links_list, n_steps, min_gain=0.005):
    print("links family     rule   R0/Rmax     →90%  →95%  final  time")
    for links in links_list:
        ceiling = cached_ceiling(PurcellSwimmer(links)).value
        for family in ("free", "symmetric"):
            for rule, radius, max_radius in (("linear", 0.1, 0.15), ("linear", 0.1, 0.5), ("sqp", 0.1, 0.15),
                                             ("sqp", 0.1, 0.5)):
                start = time.perf_counter()
                fractions = run(links, family, rule, radius, max_radius, n_steps, ceiling, min_gain=min_gain)
                print(f"{links:5d} {family:10s} {rule:6s} {radius:.2f}/{max_radius:.2f}  {first(fractions, 0.9)!s:>5} "
                      f"{first(fractions, 0.95)!s:>5}  {fractions[-1]:.3f}  {time.perf_counter() - start:.0f} s",
                      flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", type=int, nargs="+", default=[3, 5, 9])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--min-gain", type=float, default=0.005)
    arguments = parser.parse_args()
    main(arguments.links, arguments.steps, arguments.min_gain)
