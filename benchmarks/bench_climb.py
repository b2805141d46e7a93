"""The measured climb: wall time of an in-situ optimisation run whose steps come from COBYQA on measured
outcomes, on the benchmark's wheeled kinematic snake (a robot with a feasible region, which COBYQA takes as a
known constraint at every replay of its run) and on the built-in 5-link swimmer (no region); and on that swimmer
with the Bayesian climb (a Gaussian process fitted afresh before every candidate)."""

from __future__ import annotations

import time

import numpy as np

from geogait.experiments import robot_benchmark as bench

CYCLES = 40


def _cycles_per_second(name: str, **options) -> float:
    case = bench.directed(bench.CASES[name])
    robot = case.make_robot(np.random.SeedSequence(0), explore=True, noise=True)
    optimizer = bench.case_optimizer(case, random_state=0, **options)
    start = time.perf_counter()
    optimizer.run(robot, CYCLES)
    return CYCLES / (time.perf_counter() - start)


def run():
    rows = []
    for name, label, options in (("wheeled-snake", "wheeled snake, feasible region", {}),
                                 ("swimmer5", "built-in 5-link", {"climb__rule": "cobyqa"}),
                                 ("swimmer5", "built-in 5-link, Bayesian climb", {"climb__rule": "bayes"})):
        value = max(_cycles_per_second(name, **options) for _ in range(2))
        rows.append(dict(benchmark="measured climb", case=f"{label}, {CYCLES} cycles (robot included)",
                         value=value, unit="cycles/s"))
    return rows
