"""How far a gait family goes on Gymnasium's Swimmer-v5 model: long COBYQA runs on the clean evaluation.

    python studies/swimmer_v5_family.py --orders 1 3 5 --out docs/results/swimmer-v5-family/swimmer_v5_family.json

The robot benchmark's Swimmer-v5 case (PD-tracked joints within their declared range ±1.745 rad, period free
in 0.5-4 s) searched in the half-wave symmetric family of each Fourier order: from the seed gait and
``--starts`` - 1 random starts, SciPy's COBYQA maximises the clean forward speed per second
(:func:`~geogait.experiments.robot_benchmark.evaluate_gait`, one settling and two measured cycles; a gait
turning more than 0.02 rad per cycle is penalised), with every point beyond the joint limit run scaled back
onto it, as every benchmark method runs it. Each start's best gait is then scored by the episode return
(:func:`~geogait.experiments.robot_benchmark.swimmer_v5_return`, 1000 steps from the reset state). These are
thousands of clean evaluations: what the family can do, not what any method reaches in 100 cycles.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from geogait.experiments.robot_benchmark import CASES, _Family, evaluate_gait, swimmer_v5_return

ROTATION_LIMIT = 0.02


def family_runs(order: int, starts: int, max_evaluations: int, seed: int) -> list[dict]:
    """The best gait of COBYQA from the seed and ``starts - 1`` random starts in the order-``order`` family."""
    case = CASES["gymnasium-swimmer"]
    probe = case.make_robot(None, explore=False, noise=False)
    family = _Family(case, probe.gait, probe.cycle_period, order)  # the benchmark's (half-wave) family, order K
    origin, r_max = family.seed_params, case.max_joint_angle  # (last coordinate: r_max · log(T / T0))

    def gait_period(x):
        return family.gait(x), family.period(x)

    def value(x):
        result = evaluate_gait(case, *gait_period(x))
        return result["objective"] - 10 * max(0.0, abs(result["rotation"]) - ROTATION_LIMIT)

    seed_value = value(origin)
    rng = np.random.default_rng(seed)
    runs = []
    for start in [origin] + [np.append(rng.uniform(-r_max, r_max, origin.size - 1), 0.0) for _ in range(starts - 1)]:
        found = minimize(lambda x: -value(x), start, method="COBYQA",
                         options={"initial_tr_radius": 0.4, "final_tr_radius": 1e-3, "maxfev": max_evaluations})
        gait, period = gait_period(found.x)
        runs.append({"order": order, "evaluations": int(found.nfev), "improvement": -found.fun / seed_value - 1,
                     "episode_return": swimmer_v5_return(gait, period), "period": period,
                     "largest_joint_angle": float(gait.joint_limit().max()), "params": gait.params.tolist()})
        print(f"order {order}: {runs[-1]['improvement']:+.3f} speed, return {runs[-1]['episode_return']:.1f} "
              f"at {period:.2f} s ({found.nfev} evaluations)", flush=True)
    return runs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orders", type=int, nargs="+", default=[1, 3, 5])
    parser.add_argument("--starts", type=int, default=6)
    parser.add_argument("--max-evaluations", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    runs = [run for order in args.orders for run in family_runs(order, args.starts, args.max_evaluations, args.seed)]
    best = {order: max((r for r in runs if r["order"] == order), key=lambda r: r["episode_return"])
            for order in args.orders}
    for order, run in best.items():
        print(f"order {order}: best episode return {run['episode_return']:.1f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"command": "python studies/swimmer_v5_family.py " + " ".join(argv or []),
                                    "wall_time_s": round(time.perf_counter() - started, 1), "runs": runs},
                                   indent=1, allow_nan=False))


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
