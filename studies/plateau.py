"""Why the 9-link in-situ optimiser levels off at 75 % of the ceiling (issue 10): where its model runs out.

Runs ``TRIALS`` in-situ optimisations of Fig. 5's 9-link setting (symmetric family, the degree-4
symmetric shape-space model with ``degree_shrinkage=30``, λ = 0.9999, linear steps; noise 0.1,
stream seed i for trial i) for ``CYCLES`` cycles, then holds the model the run left
(``InSituResult.model``) against the true connection (``PerfectInformationModel``) at the final
gait p. Per trial it prints

* the true and predicted objective at p and the model's objective gradient against the true one
  (norms, cosine; in the family's parameters);
* the true gain (share of the ceiling) of one model step and of one perfect-information step of
  radius ``--radius`` from p;
* a **frozen-model walk**: ``--walk`` further model steps of that radius with no new data, each
  judged by the truth: the best true fraction on the way, after how many steps, and what the
  model believed at the end;
* how far p is from the ceiling gait along the perfect-information SQP path (R ≤ 0.5);
* the **local floor**: the gradient error and cosine of a fresh model of the same kind (λ = 1) fitted
  to ``--refit`` noise-free cycles of p alone (perturbation 0.15 rad) — what the basis can do at p
  with ample data and no memory of other gaits.

    python studies/plateau.py [TRIALS] [CYCLES] [--radius 0.15] [--walk 10] [--refit 30]
"""

import argparse

import numpy as np

from geogait.gaits import SymmetricGaitFamily, seed_gait
from geogait.models import PerfectInformationModel, ShapeSpaceModel
from geogait.optimize import InSituOptimizer, StepProblem, cached_ceiling, joint_limit_constraints, take_step
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

LINKS = 9


def fig5_model(forgetting_factor=0.9999):
    return ShapeSpaceModel(degree=4, symmetry="mirror+reversal", degree_shrinkage=30,
                           forgetting_factor=forgetting_factor)


def gradient_error(problem, true_slope, params):
    """Norm of the error of ``problem``'s objective gradient at ``params`` and its cosine with ``true_slope``."""
    slope = problem.evaluate(params)[1]
    cosine = slope @ true_slope / np.linalg.norm(slope) / np.linalg.norm(true_slope)
    return np.linalg.norm(slope - true_slope), cosine


def value(problem, params):
    return problem.evaluate(params, jacobian=False)[0]


def analyse(result, ceiling, radius, walk, refit):
    system = PurcellSwimmer(LINKS)
    family = SymmetricGaitFamily.from_gait(result.initial_gait)  # the family the run searched
    limits = joint_limit_constraints(LINKS - 1, 1, 2 * np.pi / 3)
    learned = StepProblem(result.model.predict_displacement, family, limits=limits)
    truth = StepProblem(PerfectInformationModel(system=system).predict_displacement, family, limits=limits)
    p = family.params_of(result.final_gait, tolerance=1e-8)
    true, true_gradient, _, _ = truth.evaluate(p)
    error, cosine = gradient_error(learned, true_gradient, p)
    row = {"true": true / ceiling, "predicted": value(learned, p) / ceiling,
           "true_gradient_norm": np.linalg.norm(true_gradient), "gradient_error": error, "cosine": cosine}
    local = fig5_model(forgetting_factor=1.0)
    stream = SwimmerStream(system, result.final_gait, sensor_noise=0.0, seed=0)
    for _ in range(refit):
        cycle = stream.next_cycle()
        local.partial_fit(cycle.phase, cycle.shape, cycle.shape_velocity, cycle.body_velocity)
    row["local_error"], row["local_cosine"] = gradient_error(
        StepProblem(local.predict_displacement, family, limits=limits), true_gradient, p)
    for name, problem in (("model_step_gain", learned), ("perfect_step_gain", truth)):
        step = take_step("linear", problem, p, radius, min_gain=0)
        row[name] = (value(truth, step.params) - true) / ceiling if step.accepted else 0.0
    walked, fractions = p, []
    for _ in range(walk):
        step = take_step("linear", learned, walked, radius, min_gain=0)
        if not step.accepted:
            break
        walked = step.params
        fractions.append(value(truth, walked) / ceiling)
    best = int(np.argmax(fractions)) if fractions else -1
    row.update(walk_best=fractions[best] if fractions else row["true"], walk_best_step=best + 1,
               walk_end=fractions[-1] if fractions else row["true"],
               walk_believed=value(learned, walked) / ceiling)
    path, length, radius_sqp = p, 0.0, 0.5
    while value(truth, path) < 0.995 * ceiling:
        step = take_step("sqp", truth, path, radius_sqp, min_gain=0)
        if not step.accepted:
            break
        length += np.linalg.norm(step.params - path)
        path = step.params
    row["path_to_ceiling"] = length
    return row


def main(trials, cycles, radius, walk, refit):
    ceiling = cached_ceiling(PurcellSwimmer(LINKS)).value
    rows = []
    print(f"{LINKS}-link, {cycles} cycles, {trials} trials, step radius {radius}")
    for seed in range(trials):
        stream = SwimmerStream(PurcellSwimmer(LINKS), seed_gait(LINKS - 1), sensor_noise=0.1, seed=seed)
        result = InSituOptimizer(model=fig5_model(), family="symmetric").run(stream, cycles, ceiling=ceiling)
        row = analyse(result, ceiling, radius, walk, refit)
        rows.append(row)
        print(f"seed {seed}: true {row['true']:.3f} predicted {row['predicted']:.3f} | true gradient "
              f"{row['true_gradient_norm']:.3f}, error {row['gradient_error']:.3f}, cosine {row['cosine']:.2f} "
              f"(local floor {row['local_error']:.3f}, {row['local_cosine']:.2f}) | "
              f"one step: model {row['model_step_gain']:+.4f}, perfect {row['perfect_step_gain']:+.4f} | "
              f"frozen walk: best {row['walk_best']:.3f} after {row['walk_best_step']}, end {row['walk_end']:.3f} "
              f"(believed {row['walk_believed']:.3f}) | perfect path to the ceiling {row['path_to_ceiling']:.2f}",
              flush=True)
    print("median: " + ", ".join(f"{key} {np.median([r[key] for r in rows]):.3f}" for key in rows[0]))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trials", type=int, nargs="?", default=8)
    parser.add_argument("cycles", type=int, nargs="?", default=60)
    parser.add_argument("--radius", type=float, default=0.15)
    parser.add_argument("--walk", type=int, default=10)
    parser.add_argument("--refit", type=int, default=30)
    arguments = parser.parse_args()
    main(arguments.trials, arguments.cycles, arguments.radius, arguments.walk, arguments.refit)
