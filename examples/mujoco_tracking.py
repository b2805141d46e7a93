"""Path following on MuJoCo swimmers that geogait did not simulate.

The shipped low-Reynolds-number Purcell swimmers ``geogait:purcell3`` / ``geogait:purcell5``
(:func:`geogait.robots.mujoco_swimmer`, PD joint control, exploration δ std 0.05 rad) follow a circle
of radius 10 steps of their seed gait — the step measured in MuJoCo, no oracle — and a line started 3
steps to its left, with :class:`geogait.control.PathTracker`: the adaptive controller (shape-space
model of degree 2 without symmetry assumptions, ``tracking_model("shape", symmetric=False)``,
covariance resetting ×100 at a surprise alarm) and the frozen one
(the same model after the 10 warm-up cycles). There is no true-connection controller: MuJoCo is the
robot, and geogait does not know its connection.

Run::

    python examples/mujoco_tracking.py --quick                # 3-link circle, one seed, ~10 s
    python examples/mujoco_tracking.py --seeds 6 --out out/mujoco-tracking
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from geogait import se2
from geogait.control import PathTracker, ReferencePath, end_pose
from geogait.experiments.tracking import tracking_model
from geogait.gaits import Perturbation
from geogait.robots import mujoco_swimmer

WARMUP = 10


def robot(n_links: int, seed: int):
    swimmer = mujoco_swimmer(n_links, seed=seed, perturbation=Perturbation.from_std(0.05))
    swimmer.next_cycles(2)  # start-up: the body starts at rest
    return swimmer


def measured_step(n_links: int) -> float:
    """Net translation per cycle of the seed gait in MuJoCo (no exploration, after one settling cycle)."""
    swimmer = mujoco_swimmer(n_links, seed=0, perturbation=Perturbation.from_std(0.0))
    swimmer.next_cycles(2)
    chunk = swimmer.next_cycle()
    return float(np.hypot(*se2.between(chunk.pose[0], end_pose(chunk))[:2]))


def run(links, seeds: int, cycles: int) -> dict:
    results = {}
    for n_links in links:
        step = measured_step(n_links)
        for kind in ("circle", "line"):
            path = ReferencePath.circle(10 * step) if kind == "circle" else ReferencePath.line()
            offset = 3 * step if kind == "line" else 0.0
            errors = {"adaptive": [], "frozen": []}
            for seed in range(seeds):
                for controller in errors:
                    tracker = PathTracker(controller=controller, model=tracking_model("shape", symmetric=False),
                                          change_forgetting=100.0, warmup_cycles=WARMUP)
                    log = tracker.run(robot(n_links, seed), path, cycles, start_offset=offset).log
                    errors[controller].append(np.abs(log["cross_track"].to_numpy()))
            entry = {"step": step}
            for controller, runs in errors.items():
                every = np.concatenate(runs)
                entry[controller] = {"cross_track_mean": float(every.mean()),
                                     "cross_track_p95": float(np.percentile(every, 95))}
            results[f"{n_links}-link {kind}"] = entry
            print(f"{n_links}-link {kind}: step {step:.4f}; mean / p95 |e| adaptive "
                  f"{entry['adaptive']['cross_track_mean']:.4f} / {entry['adaptive']['cross_track_p95']:.4f}, "
                  f"frozen {entry['frozen']['cross_track_mean']:.4f} / {entry['frozen']['cross_track_p95']:.4f}")
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", default="3,5", help="swimmers, comma-separated (default 3,5)")
    parser.add_argument("--seeds", type=int, default=6, help="seeds per swimmer and path (default 6)")
    parser.add_argument("--cycles", type=int, default=40, help="tracking cycles (default 40)")
    parser.add_argument("--quick", action="store_true", help="3-link, one seed, 12 cycles")
    parser.add_argument("--out", type=Path, default=None, help="folder for results.json")
    args = parser.parse_args(argv)
    links = (3,) if args.quick else tuple(int(v) for v in args.links.split(","))
    started = time.perf_counter()
    results = run(links, 1 if args.quick else args.seeds, 12 if args.quick else args.cycles)
    wall = time.perf_counter() - started
    print(f"{wall:.0f} s")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        record = {"command": "python examples/mujoco_tracking.py", "args": {k: str(v) for k, v in vars(args).items()},
                  "wall_time_s": wall, "results": results}
        (args.out / "results.json").write_text(json.dumps(record, indent=1) + "\n")
    return results


if __name__ == "__main__":
    main()
