"""In-situ gait optimisation of MuJoCo swimmers that geogait did not simulate.

For each model (geogait's low-Reynolds-number 3- and 5-link Purcell swimmers ``geogait:purcell3`` /
``geogait:purcell5`` and Gymnasium's quadratic-drag ``swimmer.xml``), driven by PD joint control
through :class:`geogait.robots.MujocoRobot`:

1. **model quality**: an :class:`~geogait.models.AdaptiveGaitModel` (phase rate 2π / period) learns
   20 perturbed cycles of the seed gait; its Γ on 10 held-out cycles of another seed;
2. **optimisation**: :class:`~geogait.optimize.InSituOptimizer` with the ``"forward"`` objective
   (signed progress along the body-fixed direction the seed first moved) for ``--cycles`` cycles,
   after two warm-up cycles;
3. **measured result**: the seed, the final gait and the gaits after 25 and 50 cycles run again
   without exploration (one settling cycle, then one measured cycle); displacement per cycle from
   MuJoCo's own poses, no oracle;
4. **checks**: physics (environment) steps used (warm-up included), whether any cycle moved
   backwards along the direction, tracking rejections.

``--saturation`` adds the feasibility demonstration: the 3-link swimmer with a 0.05 N·m torque limit,
optimised with and without ``Safety(max_tracking_error=...)``.

Run::

    python examples/mujoco_swimmer.py --quick                 # 3-link, 15 cycles, ~5 s
    python examples/mujoco_swimmer.py --cycles 100 --saturation --out out/mujoco
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
from geogait.optimize import InSituOptimizer, Objective, Safety
from geogait.robots import MujocoRobot, gymnasium_swimmer, mujoco_swimmer, purcell_swimmer_xml

ROBOTS = {
    "purcell3": lambda **options: mujoco_swimmer(3, **options),
    "purcell5": lambda **options: mujoco_swimmer(5, **options),
    "gymnasium": lambda **options: gymnasium_swimmer(**options),
}


def held_out_gamma(make, seed: int, train_cycles: int = 20, test_cycles: int = 10) -> float:
    """Γ (eq. 5) on held-out cycles of a model learned on perturbed cycles of the seed gait."""
    robot = make(seed=seed)
    train = robot.next_cycles(train_cycles)
    test = make(seed=seed + 1).next_cycles(test_cycles)
    model = AdaptiveGaitModel(gait=robot.gait, phase_rate=2 * np.pi / robot.cycle_period)
    model.fit(train.phase, train.shape, train.shape_velocity, train.body_velocity)
    return float(model.score(test.phase, test.shape, test.shape_velocity, test.body_velocity))


def clean_cycle(make, gait) -> dict:
    """Net motion per cycle of ``gait`` without exploration (after one settling cycle)."""
    robot = make(gait=gait, perturbation=Perturbation(eta=0))
    robot.next_cycle()
    cycle = robot.next_cycle()
    end = se2.compose(cycle.pose[-1], se2.exp(cycle.body_velocity[-1] * robot.cycle_period / robot.samples_per_cycle))
    net = se2.between(cycle.pose[0], end)
    return {"progress": float(np.hypot(net[0], net[1])), "rotation": float(net[2]),
            "tracking_error": float(np.sqrt(np.mean((cycle.shape - cycle.commanded_shape) ** 2)))}


def optimise(make, n_cycles: int, seed: int, warmup: int = 2, **options) -> dict:
    """One in-situ optimisation run and its measured outcome.

    The robot first runs ``warmup`` cycles of the seed gait: it starts at rest, and a body with
    momentum (Gymnasium's heavy swimmer) moves differently until it is up to speed, while the
    ``"forward"`` objective takes its direction from the first cycle it measures. The direction is
    body-fixed (``Objective(frame="body")``): a swimmer whose heading wanders under exploration is
    judged by progress along its own axis, not along a world heading it cannot steer back to.
    """
    robot = make(seed=seed)
    if warmup:
        robot.next_cycles(warmup)
    optimizer = InSituOptimizer(objective=Objective(kind="forward", frame="body"), **options)
    started = time.perf_counter()
    result = optimizer.run(robot, n_cycles)
    seconds = time.perf_counter() - started
    log = result.log
    # Every cycle's measured net motion (body frame at its start) along the direction of the first.
    net = np.stack([log.measured_x, log.measured_y], axis=1)
    along = net @ (net[0] / np.linalg.norm(net[0]))
    seed, final = clean_cycle(make, result.initial_gait), clean_cycle(make, result.final_gait)
    # The gait running after 25 and 50 cycles (log row k holds the gait of cycle k), run cleanly.
    columns = [f"param_{k}" for k in range(result.final_gait.params.size)]
    on_the_way = {str(k): clean_cycle(make, result.final_gait.with_params(log.loc[k, columns].to_numpy(float)))
                  ["progress"] / seed["progress"] - 1 for k in (25, 50) if k < n_cycles}
    return {
        "cycles": n_cycles, "physics_steps": robot.n_physics_steps, "seconds": round(seconds, 2),
        "gait_steps": result.n_steps, "rejected": result.n_rejected,
        "prediction_check_failures": int((log.prediction_ok == 0).sum()),
        "tracking_error_last10": float(log.tracking_error.iloc[-10:].mean()),
        "seed_progress": seed["progress"], "final_progress": final["progress"],
        "improvement": final["progress"] / seed["progress"] - 1, "improvement_after": on_the_way,
        "final_rotation_per_cycle": final["rotation"], "final_tracking_error": final["tracking_error"],
        "min_progress_along_direction": float(along.min()), "never_reversed": bool(np.all(along > 0)),
        "measured_objective_first5": float(log.measured_objective.iloc[:5].mean()),
        "measured_objective_last10": float(log.measured_objective.iloc[-10:].mean()),
        "final_joint_limit": float(result.final_gait.joint_limit().max()),
        "final_params": [round(float(v), 4) for v in result.final_gait.params],
    }


def saturation(n_cycles: int, seed: int) -> dict:
    """3-link swimmer with a 0.05 N·m torque limit: the tracking check against no check."""
    def make(**options):
        return MujocoRobot(purcell_swimmer_xml(3, ctrl_limit=0.05), **options)

    rows = {}
    for label, limit in (("no_check", None), ("max_tracking_error_0.1", 0.1)):
        rows[label] = optimise(make, n_cycles, seed, safety=Safety(max_tracking_error=limit))
    return rows


def main(argv: list[str] | None = None) -> dict:
    """Command line: see the module docstring. Returns the summary it prints."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="3-link swimmer, 15 cycles")
    parser.add_argument("--cycles", type=int, default=100, help="optimisation cycles per model")
    parser.add_argument("--models", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    parser.add_argument("--saturation", action="store_true", help="add the saturated-actuator demonstration")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="write summary.json here")
    args = parser.parse_args(argv)
    models, cycles = (["purcell3"], 15) if args.quick else (args.models, args.cycles)
    summary = {}
    for name in models:
        make = ROBOTS[name]
        summary[name] = {"held_out_gamma": held_out_gamma(make, args.seed), **optimise(make, cycles, args.seed)}
        row = summary[name]
        print(f"{name:10s} Γ {row['held_out_gamma']:.3f}  progress/cycle {row['seed_progress']:.4f} → "
              f"{row['final_progress']:.4f} ({100 * row['improvement']:+.1f} %) in {cycles} cycles "
              f"({', '.join(f'{100 * v:+.0f} % after {k}' for k, v in row['improvement_after'].items()) or '-'}), "
              f"{row['physics_steps']} physics steps, {row['gait_steps']} steps, {row['rejected']} rejected, "
              f"never reversed: {row['never_reversed']}", flush=True)
    if args.saturation:
        summary["saturation"] = saturation(min(cycles, 40), args.seed)
        for label, row in summary["saturation"].items():
            print(f"saturated  {label:24s} {row['rejected']} rejected, prediction check failed "
                  f"{row['prediction_check_failures']}×, tracking error of the last 10 cycles "
                  f"{row['tracking_error_last10']:.3f} rad, final commanded max |θ| "
                  f"{row['final_joint_limit']:.2f} rad", flush=True)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


if __name__ == "__main__":
    main()
