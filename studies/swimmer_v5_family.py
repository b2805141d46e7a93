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

``--control computed_torque`` runs the same with the joints on floating-base inverse dynamics at the same 25 Hz
(:class:`~geogait.robots.MujocoRobot`), which follow each gait to millimetres where the benchmark's PD law
realises a smaller, distorted one: what the family can do when the commanded gait is the realised one.

    python studies/swimmer_v5_family.py --orders 1 3 --starts 3 --control computed_torque \
        --out docs/results/swimmer-v5-family/swimmer_v5_family_computed_torque.json

``--objective return`` searches the episode return itself instead, with the start phase (where in its cycle the gait
begins from the reset state) one more coordinate: each evaluation is a 40 s episode, what no method can afford in 100
cycles on a robot, so this bounds what the family holds for the return, not what a method finds. The stored gait is
the found one begun at its best phase (phase 0 of its stored series), with its steady speed beside it.

    python studies/swimmer_v5_family.py --orders 1 3 5 --objective return --starts 4 --max-evaluations 250 \
        --warm-start docs/results/swimmer-v5-family/swimmer_v5_family_warm.json --initial-radius 0.2 --jobs 2 \
        --out docs/results/swimmer-v5-family/swimmer_v5_family_return.json

``--warm-start FILE`` searches each order from the best gait of an earlier output instead (lifted to the order,
at its period; ``--initial-radius`` smaller than the default 0.4 keeps the search near it), and
``--start-phases K`` scores each order's best gait by the episode return from K start phases (the same gait
begun at another point of its cycle): the start, not the gait, decides the first cycle's transient.

    python studies/swimmer_v5_family.py --orders 5 7 --warm-start \
        docs/results/swimmer-v5-family/swimmer_v5_family.json --initial-radius 0.15 --max-evaluations 2500 \
        --start-phases 12 --jobs 2 --out docs/results/swimmer-v5-family/swimmer_v5_family_warm.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from functools import partial
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from scipy.optimize import minimize

from geogait.experiments.robot_benchmark import CASES, _Family, _gymnasium_robot, evaluate_gait, swimmer_v5_return
from geogait.gaits import FourierGait

ROTATION_LIMIT = 0.02


def _case(control: str):
    return dataclasses.replace(CASES["gymnasium-swimmer"], make_robot=partial(_gymnasium_robot, control=control))


def _family(order: int, control: str):
    """The benchmark's (half-wave) family of order ``order``; its last coordinate is r_max · log(T / T0)."""
    case = _case(control)
    probe = case.make_robot(None, explore=False, noise=False)
    return case, _Family(case, probe.gait, probe.cycle_period, order)


def _value(case, family, x) -> float:
    result = evaluate_gait(case, family.gait(x), family.period(x))
    return result["objective"] - 10 * max(0.0, abs(result["rotation"]) - ROTATION_LIMIT)


def starts_of(order: int, starts: int, seed: int) -> list[np.ndarray]:
    """The seed gait's parameters and ``starts - 1`` random ones within the joint range, at the seed's period."""
    case, family = _family(order, "pd")
    origin, r_max = family.seed_params, case.max_joint_angle
    rng = np.random.default_rng(seed)
    return [origin] + [np.append(rng.uniform(-r_max, r_max, origin.size - 1), 0.0) for _ in range(starts - 1)]


def warm_start(order: int, path: Path) -> np.ndarray:
    """The best gait (by episode return) of the study's output ``path``, as parameters of the order-``order``
    family: its Fourier series lifted to ``order`` (or cut to it), at its period."""
    best = max(json.loads(path.read_text())["runs"], key=lambda run: run["episode_return"])
    case, family = _family(order, "pd")
    gait = FourierGait.from_params(best["params"], n_joints=family.family.n_joints).with_order(order)
    return np.append(family.family.params_of(gait, tolerance=1e-8),
                     case.max_joint_angle * np.log(best["period"] / family.seed_period))


def begun_at(gait: FourierGait, shift: float) -> FourierGait:
    """``gait`` begun ``shift`` rad later in its cycle: θ'(φ) = θ(φ + shift), the same family and order."""
    grid = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    return FourierGait.from_shapes(grid, gait.shape((grid + shift) % (2 * np.pi)), gait.order)


def start_phase_returns(gait: FourierGait, period: float, phases: int, control: str) -> list[float]:
    """Episode returns of ``gait`` begun at ``phases`` evenly spaced points of its cycle (0 first)."""
    return [swimmer_v5_return(begun_at(gait, shift), period, control=control)
            for shift in np.linspace(0, 2 * np.pi, phases, endpoint=False)]


def family_run(order: int, start: np.ndarray, max_evaluations: int, control: str = "pd",
               initial_radius: float = 0.4, objective: str = "speed") -> dict:
    """COBYQA from ``start`` in the order-``order`` family, the joints tracked by ``control``, on the steady
    speed per second or (``objective="return"``) the episode return with the start phase a coordinate (the last
    of ``start``); its best gait."""
    case, family = _family(order, control)
    seed_value = _value(case, family, family.seed_params)
    if objective == "return":
        def episode(z):
            return swimmer_v5_return(begun_at(family.gait(z[:-1]), z[-1]), family.period(z[:-1]), control=control)

        found = minimize(lambda z: -episode(z), start, method="COBYQA",
                         options={"initial_tr_radius": initial_radius, "final_tr_radius": 1e-3,
                                  "maxfev": max_evaluations})
        gait, period = begun_at(family.gait(found.x[:-1]), found.x[-1]), family.period(found.x[:-1])
        steady = evaluate_gait(case, gait, period)["objective"]
        episode_return = -found.fun
    else:
        found = minimize(lambda x: -_value(case, family, x), start, method="COBYQA",
                         options={"initial_tr_radius": initial_radius, "final_tr_radius": 1e-3,
                                  "maxfev": max_evaluations})
        gait, period = family.gait(found.x), family.period(found.x)
        steady, episode_return = -found.fun, swimmer_v5_return(gait, period, control=control)
    run = {"order": order, "control": control, "objective": objective, "evaluations": int(found.nfev),
           "improvement": steady / seed_value - 1, "episode_return": episode_return, "period": period,
           "largest_joint_angle": float(gait.joint_limit().max()), "params": gait.params.tolist()}
    print(f"order {order}: {run['improvement']:+.3f} speed, return {run['episode_return']:.1f} "
          f"at {period:.2f} s ({found.nfev} evaluations)", flush=True)
    return run


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orders", type=int, nargs="+", default=[1, 3, 5])
    parser.add_argument("--starts", type=int, default=6)
    parser.add_argument("--max-evaluations", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--control", choices=("pd", "computed_torque"), default="pd")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--warm-start", type=Path, help="start each order from this output's best gait")
    parser.add_argument("--initial-radius", type=float, default=0.4)
    parser.add_argument("--start-phases", type=int, default=0, help="score each order's best from K start phases")
    parser.add_argument("--objective", choices=("speed", "return"), default="speed",
                        help="what COBYQA maximises: the steady speed per second, or the episode return (the start "
                             "phase one more coordinate)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    if args.warm_start is not None:
        tasks = [(order, warm_start(order, args.warm_start)) for order in args.orders]
    else:
        tasks = [(order, start) for order in args.orders for start in starts_of(order, args.starts, args.seed)]
    if args.objective == "return":  # the start phase: 0 for each start, or --starts phases from a warm start
        phases = np.linspace(0, np.pi, args.starts if args.warm_start is not None else 1, endpoint=False)
        tasks = [(order, np.append(start, phase)) for order, start in tasks for phase in phases]
    runs = Parallel(n_jobs=args.jobs)(delayed(family_run)(order, start, args.max_evaluations, args.control,
                                                          args.initial_radius, args.objective)
                                      for order, start in tasks)
    best = {order: max((r for r in runs if r["order"] == order), key=lambda r: r["episode_return"])
            for order in args.orders}
    if args.start_phases:
        gaits = {order: FourierGait.from_params(run["params"], n_joints=_family(order, "pd")[1].family.n_joints)
                 for order, run in best.items()}
        phased = Parallel(n_jobs=args.jobs)(delayed(start_phase_returns)(gaits[order], run["period"],
                                                                         args.start_phases, args.control)
                                            for order, run in best.items())
        for run, returns in zip(best.values(), phased, strict=True):
            run["start_phase_returns"] = returns
    for order, run in best.items():
        spread = (f" (from {args.start_phases} start phases: {min(run['start_phase_returns']):.1f}-"
                  f"{max(run['start_phase_returns']):.1f})" if args.start_phases else "")
        print(f"order {order}: best episode return {run['episode_return']:.1f}{spread}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"command": "python studies/swimmer_v5_family.py " + " ".join(argv or []),
                                    "wall_time_s": round(time.perf_counter() - started, 1), "runs": runs},
                                   indent=1, allow_nan=False))


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
