"""Does the learned model point the right way on a robot outside its class? On a robot-benchmark case, the
gradient of the objective that geogait's default window model predicts at a gait, against central differences
of the clean measured objective, in the case's gait family.

    python studies/model_gradient.py elastica-snake --cycles 4 8 12 --out docs/results/model-gradient.json

For each gait (the seed, and the seed moved by a random step of ``--move`` in the family's parameters): the
true gradient by central differences of :func:`~geogait.experiments.robot_benchmark.evaluate_gait` (step
``--step``; 2 n clean runs for n family parameters), then the robot run with its own exploration at that gait
and an :class:`~geogait.models.AdaptiveGaitModel` (the optimiser's default outside the symmetric family, λ =
1 − 0.1 / d) learning every cycle; after each of ``--cycles`` cycles the model's predicted objective and its
gradient (eq. 3's displacement Jacobian, mapped into the family), compared by their cosine and their ratio of
lengths, and the predicted value against the clean measured one (per second where the case's objective is).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from geogait._defaults import window_forgetting_factor
from geogait.experiments.robot_benchmark import CASES, _Family, directed, evaluate_gait
from geogait.models import AdaptiveGaitModel
from geogait.optimize import objective


def true_gradient(case, family, params: np.ndarray, step: float) -> np.ndarray:
    """Central differences of the clean measured objective in the family's parameters."""
    gradient = np.zeros(params.size)
    for i in range(params.size):
        offset = np.zeros(params.size)
        offset[i] = step
        up = evaluate_gait(case, family.gait(params + offset))["objective"]
        down = evaluate_gait(case, family.gait(params - offset))["objective"]
        gradient[i] = (up - down) / (2 * step)
    return gradient


def model_gradients(case, family, params: np.ndarray, checkpoints, seed: int) -> list[dict]:
    """The default window model's predicted objective and gradient after each checkpoint's cycles of exploration."""
    gait = family.gait(params)
    robot = case.make_robot(np.random.SeedSequence(seed), explore=True, noise=True, gait=gait)
    model = AdaptiveGaitModel(gait=gait, forgetting_factor=window_forgetting_factor(gait.n_joints),
                              phase_rate=2 * np.pi / robot.cycle_period)
    direction = np.asarray(case.direction, dtype=float) / np.hypot(*case.direction)
    rows = []
    for cycle in range(1, max(checkpoints) + 1):
        chunk = robot.next_cycle()
        model.partial_fit(chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
        if cycle in checkpoints:
            pose, jacobian = model.predict_displacement(gait, jacobian=True)
            kind = case.objective if case.objective == "forward" else "progress"
            value, gradient = objective(kind, pose, jacobian, gait, direction)
            if case.period_range is not None:  # evaluate_gait's objective is then per second
                value, gradient = value / robot.cycle_period, gradient / robot.cycle_period
            rows.append({"cycles": cycle, "value": float(value), "gradient": (gradient @ family.matrix).tolist()})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--cycles", type=int, nargs="+", default=[4, 8, 12], help="checkpoints (cycles learned)")
    parser.add_argument("--step", type=float, default=0.1, help="central-difference step (family parameters)")
    parser.add_argument("--move", type=float, default=0.3, help="std of the random move to the second gait")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="JSON of every number")
    args = parser.parse_args(argv)
    case = CASES[args.case]
    if case.missing():
        print(f"skipped: case {args.case} needs {', '.join(case.missing())}")
        return 0
    case = directed(case)
    probe = case.make_robot(None, explore=False, noise=False)
    family = _Family(case, probe.gait, probe.cycle_period).family
    seed_params = family.params_of(probe.gait.with_order(1))
    rng = np.random.default_rng(args.seed)
    gaits = {"seed": seed_params, "moved": seed_params + rng.normal(scale=args.move, size=seed_params.size)}
    started, results = time.perf_counter(), []
    print(f"{args.case}: {type(family).__name__}, {family.n_params} parameters")
    print("gait   cycles  cosine  |model| / |true|  predicted / measured value")
    for name, params in gaits.items():
        true = true_gradient(case, family, params, args.step)
        measured = evaluate_gait(case, family.gait(params))["objective"]
        for row in model_gradients(case, family, params, sorted(set(args.cycles)), args.seed):
            model = np.asarray(row["gradient"])
            cosine = float(model @ true / (np.linalg.norm(model) * np.linalg.norm(true)))
            ratio = float(np.linalg.norm(model) / np.linalg.norm(true))
            print(f"{name:6s} {row['cycles']:6d}  {cosine:6.3f}  {ratio:16.2f}  {row['value'] / measured:27.2f}")
            results.append({"gait": name, "params": params.tolist(), "true_gradient": true.tolist(),
                            "measured_value": measured, **row, "cosine": cosine, "length_ratio": ratio})
    if args.out is not None:
        with open(args.out, "w") as handle:
            json.dump({"command": "python studies/model_gradient.py " + " ".join(argv or __import__("sys").argv[1:]),
                       "wall_time_s": round(time.perf_counter() - started, 1), "results": results}, handle, indent=1)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
