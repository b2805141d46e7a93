"""PyElastica snakes that differ from seed to seed: is a change of the optimiser better on snakes it was not chosen on?

The benchmark's snake repeats to the last digit, so geogait's runs on it follow one path whatever the seed, and
their median is that path's value. Here each paired seed k is a different snake: its backward and lateral friction
coefficients and its Young's modulus are scaled by factors drawn from ``default_rng([7, k])`` (friction × 0.8–1.25
each, modulus × 0.72–1.40, log-uniform). Every method runs on the same snake for a seed, from the same seed gait, and
is judged as on the benchmark: the gait it would hand over after 30, 60 and 100 cycles, re-run clean on that snake,
as an improvement of forward speed over the seed gait's.

Methods: the benchmark's (``geogait``, ``cobyqa-held``, ``cmaes-tuned-held`` …) and, for each entry of
``--variants`` (a JSON object: name → InSituOptimizer parameters, nested names such as ``step__trust_radius``),
``geogait-<name>``: geogait with those settings.

    python studies/snake_variants.py --seeds 12 --methods geogait,geogait-wide,cobyqa-held,cmaes-tuned-held \\
        --variants '{"wide": {"step__max_trust_radius": 0.3}}' --jobs 2 \\
        --out docs/results/optimizer-robots/snake-variants/snake_variants.json
"""

from __future__ import annotations

import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import shlex  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

BUDGETS = (30, 60, 100)


def snake_physics(k: int) -> dict:
    """Snake k's friction coefficients (forward, backward, lateral) and Young's modulus (Pa)."""
    rng = np.random.default_rng([7, k])
    backward, lateral, modulus = np.exp(rng.uniform(np.log(0.8), np.log(1.25), 3))
    return {"friction": [1.0, 1.5 * float(backward), 2.0 * float(lateral)],
            "youngs_modulus": 1e6 * float(modulus) ** 1.5}


def run(k: int, method: str, budget: int, checkpoints: tuple, options: dict | None) -> list[dict]:
    """One method on snake k (geogait with ``options`` when given), judged at each checkpoint."""
    from geogait.experiments import robot_benchmark as bench
    from geogait.gaits import Perturbation
    from geogait.robots import ElasticaSnake

    physics = snake_physics(k)

    def make_robot(seed, explore, noise, gait=None):
        return ElasticaSnake(gait=gait, seed=seed, friction=physics["friction"],
                             youngs_modulus=physics["youngs_modulus"],
                             perturbation=None if explore else Perturbation(eta=0))

    case = bench.directed(dataclasses.replace(bench.CASES["elastica-snake"], make_robot=make_robot))
    seed_value = bench.evaluate_gait(case, make_robot(None, explore=False, noise=False).gait)["objective"]
    start = time.perf_counter()
    paired_seed = np.random.SeedSequence(0, spawn_key=(k,))  # the benchmark's k-th paired seed
    trace, used = bench._run_method(case, "geogait" if options is not None else method, paired_seed, budget,
                                    seed_value, options)
    seconds = time.perf_counter() - start
    rows = []
    for cycles in checkpoints:
        result = bench.evaluate_gait(case, *trace.at(cycles))
        rows.append({"seed": k, "method": method, "cycles": cycles, "cycles_run": used, "seconds": seconds,
                     "improvement": result["objective"] / seed_value - 1, "rotation": result["rotation"],
                     "seed_objective": seed_value, **physics})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--methods", default="geogait,cobyqa-held,cmaes-tuned-held")
    parser.add_argument("--variants", type=json.loads, default={},
                        help="JSON object: name -> InSituOptimizer parameters, run as method geogait-<name>")
    parser.add_argument("--budget", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    methods = args.methods.split(",")
    options = {f"geogait-{name}": dict(settings) for name, settings in args.variants.items()}
    unknown = [m for m in methods if m.startswith("geogait-") and m not in options]
    if unknown:
        parser.error(f"--methods: {', '.join(unknown)} not among --variants ({', '.join(options) or 'none'})")
    checkpoints = tuple(c for c in BUDGETS if c <= args.budget) or (args.budget,)
    start = time.perf_counter()
    results = Parallel(n_jobs=args.jobs)(delayed(run)(k, method, args.budget, checkpoints, options.get(method))
                                         for k in range(args.seeds) for method in methods)
    records = [row for rows in results for row in rows]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "study": "PyElastica snakes that differ per seed",
        "command": "python studies/snake_variants.py " + shlex.join(sys.argv[1:] if argv is None else argv),
        "wall_time_s": round(time.perf_counter() - start, 1), "records": records}, indent=1) + "\n")
    frame = pd.DataFrame(records)
    improvement = frame.pivot_table(index=["method", "cycles"], columns="seed", values="improvement")
    print(f"median improvement over each snake's seed gait ({args.seeds} snakes), by cycles used:")
    print((100 * improvement.median(axis=1).unstack("cycles").reindex(methods)).round(1).to_string())
    if "geogait" in methods:
        for other in (m for m in methods if m != "geogait"):
            ahead = [int((improvement.loc[("geogait", c)] > improvement.loc[(other, c)]).sum()) for c in checkpoints]
            print(f"geogait ahead of {other} on " + " / ".join(map(str, ahead)) + f" of {args.seeds} snakes")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
