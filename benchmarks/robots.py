"""Robot benchmark: geogait against CMA-ES, TPE, COBYQA, nevergrad's NGOpt, GP Bayesian optimisation and random search.

Every method on the same robots, gait family, joint limits and measured objective, charged for every
cycle the robot runs, over paired seeds; each method's gait after 30, 60 and 100 cycles re-run clean
(see ``geogait.experiments.robot_benchmark``). Writes ``robots.md`` (table), ``robots.json``
(manifest with versions, configuration, this command and every record), ``robots.csv`` and
``robots.png`` (clean objective against cycles used, median and interquartile band per method).

Usage::

    python benchmarks/robots.py                       # every case, 8 seeds, 100 cycles (make bench-robots)
    python benchmarks/robots.py --quick               # built-in 3-link + MuJoCo case, 2 seeds, 20 cycles
    python benchmarks/robots.py --cases swimmer5 --seeds 12 --jobs 2 --out out/robots
    python benchmarks/robots.py --list-cases                                        # every case, change cases marked
    python benchmarks/robots.py --cases changes --seeds 8 --out out/changes         # robots that change mid-run
    python benchmarks/robots.py --cases elastica-snake --methods geogait --geogait-options '{"min_trust_radius": 0.075}'
    python benchmarks/robots.py --from-json docs/results/robots/robots.json --out out/redraw   # redraw only

A case whose optional dependency is missing (MuJoCo, Gymnasium) is skipped with one line.
"""

from __future__ import annotations

import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import shlex  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

from geogait._validation import GeogaitError  # noqa: E402
from geogait.experiments import robot_benchmark as bench  # noqa: E402

QUICK = {"cases": ["swimmer3", "mujoco-purcell5-unequal"], "seeds": 2, "budget": 20}


def _names(text: str) -> list[str]:
    return [name.strip() for name in text.split(",") if name.strip()]


def _case_names(text: str) -> list[str]:
    """Case names, the groups ``stationary``, ``undeclared`` and ``changes`` expanded."""
    declared = [n for n in bench.CASES if n not in bench.CHANGE_CASES + bench.UNDECLARED_CASES]
    groups = {"stationary": declared, "undeclared": list(bench.UNDECLARED_CASES), "changes": list(bench.CHANGE_CASES)}
    return [case for name in _names(text) for case in groups.get(name, [name])]


def _case_list() -> str:
    return "\n".join(f"{name}{' (change)' if name in bench.CHANGE_CASES else ''}: {case.description}"
                      for name, case in bench.CASES.items())


def _options(text: str | None) -> dict | None:
    if text is None:
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise GeogaitError(f"--geogait-options: expected a JSON object, got {text!r} ({error.msg})") from None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default="stationary", help="comma-separated case names, or the groups "
                        "'stationary' (default), 'undeclared' (each robot declaring only its joints, period and "
                        "objective) and 'changes' (the change cases); --list-cases names them")
    parser.add_argument("--list-cases", action="store_true", help="print every case (change cases marked) and exit")
    parser.add_argument("--methods", default=",".join(bench.METHODS), help="comma-separated method names")
    parser.add_argument("--seeds", type=int, default=8, help="paired seeds per case")
    parser.add_argument("--budget", type=int, default=100, help="cycles each method may run")
    parser.add_argument("--seed", type=int, default=0, help="root seed")
    parser.add_argument("--jobs", type=int, default=1, help="joblib processes (-1: every core)")
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address")
    parser.add_argument("--quick", action="store_true", help="swimmer3 + the MuJoCo case, 2 seeds, 20 cycles")
    parser.add_argument("--from-json", default=None, help="redraw table and figure from a manifest")
    parser.add_argument("--merge", default=None, help="a manifest whose records of the cases and methods run now "
                        "are replaced by this run's (the rest kept, both commands recorded)")
    parser.add_argument("--geogait-options", default=None, help="JSON object of InSituOptimizer parameters every "
                        "geogait method uses instead of its own, e.g. '{\"min_trust_radius\": 0.075}'")
    parser.add_argument("--out", default="benchmarks/results/robots", help="output folder")
    args = parser.parse_args(argv)
    arguments = sys.argv[1:] if argv is None else argv
    command = "python benchmarks/robots.py " + " ".join(shlex.quote(a) for a in arguments)
    if args.list_cases:
        print(_case_list())
        return 0
    try:
        if args.from_json:
            result = bench.from_manifest(args.from_json)
            command, wall = result["command"], None
        else:
            cases, seeds, budget = _case_names(args.cases), args.seeds, args.budget
            if args.quick:
                cases, seeds, budget = QUICK["cases"], QUICK["seeds"], QUICK["budget"]
            options = _options(args.geogait_options)
            if options is not None and args.merge:  # the manifest's geogait rows are its defaults' runs
                raise GeogaitError("--geogait-options cannot be merged into a manifest (--merge): its geogait rows "
                                   "would no longer be geogait's defaults; write to another --out instead.")
            start = time.perf_counter()
            result = bench.run_robot_benchmark(cases, _names(args.methods), n_seeds=seeds, budget=budget,
                                               seed=args.seed, jobs=args.jobs, scheduler=args.scheduler,
                                               geogait_options=options)
            wall = time.perf_counter() - start
            if args.merge:
                result, command = bench.merge_results(bench.from_manifest(args.merge), result, command)
        budgets = [b for b in (30, 60, 100) if b <= result["config"]["budget"]] or [result["config"]["budget"]]
        paths = bench.write_outputs(result, args.out, command, wall, budgets=budgets)
    except GeogaitError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(bench.benchmark_table(result, budgets))
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
