"""Which robots geogait's model class covers: on every robot of the benchmark, the held-out Γ of a log fit at the
robot's own period and the model-class verdict from the same gait at that period and at twice it (half the speed:
faster cycles can exceed what a robot's joints follow)
(:func:`geogait.learn.model_class_verdict`); optionally a log of your own (e.g. the kinematic-snake package's,
from ``studies/kinematic_snake_log.py``).

    python studies/model_class.py --cycles 20 --in-run 8 --out docs/results/model-class/model-class.json \
        --log kinematic-snake=tests/data/kinematic_snake_froude1.csv

Γ comes from each robot with its own exploration (the benchmark's robots, seed 0) and the benchmark's sensor
noise; the verdict from its seed gait run clean (no exploration, no noise) at both periods, where the test
resolves a 5 % difference (with exploration the cycle-to-cycle spread needs hundreds of cycles for that). The
first 2 cycles at each period are dropped (settling). With ``--in-run N`` also the in-situ optimiser's own test
(``InSituOptimizer(checks=[ModelClassTest(cycles=3)])``: the seed gait clean at the robot's period and at
twice it, within a run with its exploration and noise) on seeds 0 … N−1. Robots whose extras are missing are
skipped with one line.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import pandas as pd

from geogait.experiments.robot_benchmark import CASES, available_cases, case_optimizer
from geogait.io import read_log
from geogait.learn import fit_log
from geogait.optimize import ModelClassTest, smallest_budget
from geogait.simulate import Trajectory

COLUMNS = ("body_velocity_x", "body_velocity_y", "body_velocity_theta")


def record(robot, cycles: int, settle: int = 2) -> pd.DataFrame:
    """``cycles`` cycles of the robot at its current period, the first ``settle`` dropped, as a table."""
    chunks = [robot.next_cycle() for _ in range(cycles)][settle:]
    return Trajectory.concatenate(chunks).to_pandas()


def columns(frame: pd.DataFrame) -> dict:
    joints = sorted(c for c in frame.columns if c.startswith("shape_") and not c.startswith("shape_velocity"))
    return dict(shape=joints, phase="phase", shape_velocity=[c.replace("shape_", "shape_velocity_") for c in joints],
                body_velocity=list(COLUMNS))


def measure(first: pd.DataFrame, second: pd.DataFrame | None) -> dict:
    """Held-out Γ of the first period's log; the verdict of both periods as two log segments."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (curvature units exceed a turn: the radians check is for joints)
        gamma = fit_log(read_log(first, **columns(first))).held_out_gamma()
        if second is None:
            return {"held_out_gamma": gamma, "principally_kinematic": None, "reason": "one period only"}
        second = second.assign(time=second["time"] - second["time"].iloc[0] + first["time"].iloc[-1] + 100.0)
        both = pd.concat([first, second], ignore_index=True)
        verdict = fit_log(read_log(both, **columns(both))).model_class()
    return {"held_out_gamma": gamma, **verdict.to_dict()}


def robot_row(name: str, cycles: int) -> dict:
    """Γ from the robot with its exploration and sensor noise; the verdict from its seed gait run clean (no
    exploration, no noise) at its period and at twice it, where a difference of 5 % is resolved."""
    case = CASES[name]
    explored = record(case.make_robot(0, True, True), cycles)
    robot = case.make_robot(0, False, False)
    period = float(robot.cycle_period)
    first = record(robot, cycles)
    robot.set_cycle_period(2 * period)
    second = record(robot, cycles)
    gamma = measure(explored, None)["held_out_gamma"]
    return {"system": name, "description": case.description, "period": period, **measure(first, second),
            "held_out_gamma": gamma}


def in_run_rows(name: str, seeds: int, cycles: int = 3) -> list[dict]:
    """The in-situ optimiser's own test (``ModelClassTest``) on the robot with its exploration and noise, as
    the robot benchmark runs it (its settling cycles, objective and period range), one row per seed."""
    case, rows = CASES[name], []
    for seed in range(seeds):
        optimizer = case_optimizer(case, checks=[ModelClassTest(cycles=cycles)], random_state=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (the verdict is recorded, not printed)
            # (the test's plan, and the one measured cycle a run holds at least)
            result = optimizer.run(case.make_robot(seed, True, True), smallest_budget(case.settle_cycles, cycles))
        rows.append({"system": name, "seed": seed, **result.model_class.to_dict()})
    return rows


def log_row(name: str, path: str) -> dict:
    frame = pd.read_csv(path)
    gap = frame["time"].diff() > 5 * frame["time"].diff().median()
    segment = gap.cumsum()
    parts = [frame[segment == s] for s in segment.unique()]
    return {"system": name, "description": f"log {path}", **measure(parts[0], parts[1] if len(parts) > 1 else None)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--cycles", type=int, default=20, help="cycles per period (2 of them settle)")
    parser.add_argument("--log", action="append", default=[], help="NAME=CSV: a log of two periods (two segments)")
    parser.add_argument("--in-run", type=int, default=0,
                        help="seeds of the optimiser's own test (ModelClassTest(cycles=3)) per robot (0: none)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    names, skipped = available_cases(args.cases.split(","))
    for name, why in skipped.items():
        print(f"skipped {name}: {why}")
    rows = []
    for name in names:
        started = time.perf_counter()
        rows.append(robot_row(name, args.cycles))
        print(f"{name}: Γ {rows[-1]['held_out_gamma']:.3f}, principally kinematic: {rows[-1]['principally_kinematic']} "
              f"({time.perf_counter() - started:.0f} s) — {rows[-1]['reason']}", flush=True)
    for item in args.log:
        name, path = item.split("=", 1)
        rows.append(log_row(name, path))
        print(f"{name}: Γ {rows[-1]['held_out_gamma']:.3f}, principally kinematic: {rows[-1]['principally_kinematic']}"
              f" — {rows[-1]['reason']}")
    in_run = []
    for name in names if args.in_run else ():
        in_run += in_run_rows(name, args.in_run)
        verdicts = [row["principally_kinematic"] for row in in_run if row["system"] == name]
        print(f"{name}, the optimiser's test over {args.in_run} seeds: {verdicts}", flush=True)
    with open(args.out, "w") as file:
        json.dump({"command": "python studies/model_class.py " + " ".join(f"--{k.replace('_', '-')} {v}" for k, v in
                                                                        vars(args).items() if k != "log")
                   + "".join(f" --log {v}" for v in args.log), "rows": rows, "in_run": in_run}, file, indent=1)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
