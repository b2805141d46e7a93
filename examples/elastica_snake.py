"""In-situ gait optimisation of PyElastica's continuum snake (a Cosserat rod geogait did not simulate).

:class:`geogait.robots.ElasticaSnake` runs the classic PyElastica continuum snake (rod on a plane with
anisotropic friction) with its rest curvature set every physics step from geogait's commanded modal
shape: 4 curvature modes (sine and cosine waves of one and two wavelengths per body), a first-order
Fourier gait in each (12 parameters), seed: a travelling wave of 1 rad tangent-angle amplitude.

1. **speed**: wall-clock seconds per simulated cycle;
2. **model quality**: an :class:`~geogait.models.AdaptiveGaitModel` learns 20 perturbed cycles of the
   seed gait; its Γ on 10 held-out cycles of another seed; RMS tracking error (realised − commanded
   modal shape);
3. **optimisation**: :class:`~geogait.optimize.InSituOptimizer` with the ``"forward"`` objective in
   the body frame for ``--cycles`` cycles, limits from the snake's declared ``max_joint_angle``;
4. **measured result**: the seed and final gaits re-run without exploration (one settling cycle, then
   one measured cycle): forward progress per second and net rotation per cycle from the rod's own
   node positions (centre of mass, mean tangent angle).

Needs ``pip install 'geogait[elastica]'``. The first run compiles PyElastica's numba kernels (about
half a minute, cached afterwards).

Run::

    python examples/elastica_snake.py --quick                 # 16 optimisation cycles, ~15 s
    python examples/elastica_snake.py --cycles 60 --out out/elastica
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from geogait import se2
from geogait.gaits import Perturbation
from geogait.models import AdaptiveGaitModel
from geogait.optimize import InSituOptimizer, Limits, Objective
from geogait.robots import elastica_snake


def seconds_per_cycle(n_cycles: int = 5) -> float:
    """Wall-clock seconds of one exploring cycle (after construction and warm-up)."""
    snake = elastica_snake(seed=0)
    started = time.perf_counter()
    snake.next_cycles(n_cycles)
    return (time.perf_counter() - started) / n_cycles


def held_out_gamma(seed: int, train_cycles: int = 20, test_cycles: int = 10) -> dict:
    """Γ (eq. 5) on held-out cycles of a model learned on perturbed cycles of the seed gait."""
    snake = elastica_snake(seed=seed)
    train = snake.next_cycles(train_cycles)
    test = elastica_snake(seed=seed + 1).next_cycles(test_cycles)
    model = AdaptiveGaitModel(gait=snake.gait, phase_rate=2 * np.pi / snake.cycle_period)
    model.fit(train.phase, train.shape, train.shape_velocity, train.body_velocity)
    gamma = model.score(test.phase, test.shape, test.shape_velocity, test.body_velocity)
    tracking = np.sqrt(np.mean((train.shape - train.commanded_shape) ** 2))
    return {"held_out_gamma": float(gamma), "tracking_error_exploring": float(tracking)}


def clean_run(gait) -> dict:
    """Forward progress per second and rotation per cycle of ``gait`` without exploration."""
    snake = elastica_snake(gait=gait, perturbation=Perturbation(eta=0))
    snake.next_cycle()
    first, second = snake.next_cycle(), snake.next_cycle()
    net = se2.between(first.pose[0], second.pose[0])  # one whole cycle, in the body frame at its start
    return {"forward_speed": float(net[0] / snake.cycle_period), "lateral_speed": float(net[1] / snake.cycle_period),
            "rotation_per_cycle": float(net[2]),
            "tracking_error": float(np.sqrt(np.mean((first.shape - first.commanded_shape) ** 2)))}


def optimise(n_cycles: int, seed: int) -> dict:
    """One in-situ optimisation run on the snake and its clean re-runs."""
    snake = elastica_snake(seed=seed)
    optimizer = InSituOptimizer(limits=Limits(max_joint_angle=snake.max_joint_angle),
                                objective=Objective(kind="forward", frame="body"))
    started = time.perf_counter()
    result = optimizer.run(snake, n_cycles)
    seconds = time.perf_counter() - started
    log = result.log
    seed_run, final_run = clean_run(result.initial_gait), clean_run(result.final_gait)
    return {
        "cycles": n_cycles, "seconds": round(seconds, 1), "gait_steps": int(result.n_steps),
        "rejected": int(result.n_rejected), "seed": seed_run, "final": final_run,
        "improvement": final_run["forward_speed"] / seed_run["forward_speed"] - 1,
        "measured_objective_first5": float(log.measured_objective.iloc[:5].mean()),
        "measured_objective_last5": float(log.measured_objective.iloc[-5:].mean()),
        "final_joint_limit": float(result.final_gait.joint_limit().max()),
        "final_params": [round(float(v), 4) for v in result.final_gait.params],
    }


def main(argv: list[str] | None = None) -> dict:
    """Command line: see the module docstring. Returns the summary it prints."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="16 optimisation cycles, a 4 + 2 cycle Γ check")
    parser.add_argument("--cycles", type=int, default=60, help="optimisation cycles")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="write summary.json here")
    args = parser.parse_args(argv)
    cycles = 16 if args.quick else args.cycles
    summary = {"seconds_per_cycle": seconds_per_cycle(2 if args.quick else 10)}
    summary.update(held_out_gamma(args.seed, *((4, 2) if args.quick else (20, 10))))
    print(f"{summary['seconds_per_cycle']:.3f} s per cycle; held-out Γ {summary['held_out_gamma']:.3f}; "
          f"tracking error {summary['tracking_error_exploring']:.3f} rad (exploring)", flush=True)
    summary["optimisation"] = row = optimise(cycles, args.seed)
    print(f"forward speed {row['seed']['forward_speed']:.4f} → {row['final']['forward_speed']:.4f} m/s "
          f"({100 * row['improvement']:+.1f} %) in {cycles} cycles, {row['gait_steps']} steps, {row['rejected']} "
          f"rejected; final rotation {row['final']['rotation_per_cycle']:+.4f} rad/cycle", flush=True)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


if __name__ == "__main__":
    main()
