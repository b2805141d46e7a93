"""Optimiser settings judged on the robot benchmark's robots, side by side with the black-box methods.

Runs geogait with each named set of InSituOptimizer parameters (nested names, e.g. ``step__trust_radius``) on
the benchmark's cases, paired seeds and clean re-runs (``geogait.experiments.robot_benchmark``), and prints per
case the median clean objective after 30, 60 and 100 cycles for each setting, next to the stored black-box rows of
the same seeds (the best black-box method at each budget, from the results manifests), and each setting paired seed by
seed with the stored default (``robot_benchmark.paired_test``: seeds ahead, Wilcoxon signed-rank p). Writes one
JSON file with every record.

    python studies/optimizer_robots.py --cases elastica-snake,swimmer5 --seeds 8 --jobs 2 \\
        --variants '{"default": {}, "floor 0.075": {"step__min_trust_radius": 0.075}}' \\
        --out docs/results/optimizer-robots
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
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from geogait.experiments import robot_benchmark as bench  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MANIFESTS = (ROOT / "docs/results/robots/robots.json", ROOT / "docs/results/robots-elastica/robots.json")
BUDGETS = (30, 60, 100)


def _column(case: dict) -> str:
    return "ceiling_fraction" if case.get("ceiling") else "improvement"


def stored_runs(n_seeds: int) -> list[dict]:
    """The results manifests (each read once), their records cut to seeds < ``n_seeds``."""
    runs = []
    for path in MANIFESTS:
        if path.exists():
            stored = bench.from_manifest(path)
            stored["records"] = stored["records"][stored["records"]["seed"] < n_seeds]
            runs.append(stored)
    return runs


def stored_default(runs: list[dict]) -> pd.DataFrame:
    """geogait's default runs in the stored manifests: case, seed, cycles and values."""
    frames = [stored["records"][stored["records"]["method"] == "geogait"] for stored in runs]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _paired_line(name: str, ours: pd.DataFrame, stored: pd.DataFrame, column: str, budgets) -> str | None:
    """A setting's runs against the stored default on the same seeds, at each budget the default has."""
    cells = []
    for cycles in budgets:
        theirs = stored[stored["cycles"] == cycles].set_index("seed")[column] if len(stored) else pd.Series()
        test = bench.paired_test(ours[ours["cycles"] == cycles].set_index("seed")[column], theirs)
        cells.append(f"{test['ahead']} of {test['seeds']} (p {test['p_value']:.2g})" if test["seeds"] else "—")
    if all(cell == "—" for cell in cells):
        return None
    return f"  {name:<28} ahead of the stored default in " + " / ".join(cells)


def stored_reference(runs: list[dict], n_seeds: int, budget: int) -> pd.DataFrame:
    """Per case and budget of the stored runs with every one of ``n_seeds`` seeds: geogait's default median and the
    benchmark's rival (:func:`~geogait.experiments.robot_benchmark.paired_comparison`: the black-box method with
    the best median among those whose median gait keeps the case's rotation limit); ``kind`` "geogait" or
    "black-box"."""
    rows = []
    for stored in runs:
        if stored["config"]["budget"] != budget:
            continue
        seeds = stored["records"].groupby("case")["seed"].nunique()
        comparison = bench.paired_comparison(stored, BUDGETS)
        for row in comparison.itertuples():
            if seeds.get(row.case, 0) >= n_seeds:
                rows += [{"case": row.case, "cycles": row.cycles, "kind": "black-box", "method": row.rival,
                          "median": row.rival_median},
                         {"case": row.case, "cycles": row.cycles, "kind": "geogait", "method": "geogait",
                          "median": row.median}]
    return pd.DataFrame(rows).sort_values(["case", "cycles"], kind="stable") if rows else pd.DataFrame(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", required=True, help="comma-separated benchmark case names")
    parser.add_argument("--variants", required=True, help="JSON object: name -> InSituOptimizer parameters "
                        "(and optionally \"method\": the benchmark's geogait row they modify, default geogait)")
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--budget", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", default="studies/results/optimizer-robots")
    args = parser.parse_args(argv)
    variants = json.loads(args.variants)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    budgets = [c for c in BUDGETS if c <= args.budget] or [args.budget]
    frames, described = [], {}
    for name, options in variants.items():
        start = time.perf_counter()
        options = dict(options)
        method = options.pop("method", "geogait")  # a geogait row of the benchmark (geogait-hybrid, ...)
        result = bench.run_robot_benchmark(cases, [method], n_seeds=args.seeds, budget=args.budget,
                                           checkpoints=budgets, jobs=args.jobs, progress=False,
                                           geogait_options=options)
        print(f"{name}: {time.perf_counter() - start:.0f} s", flush=True)
        frames.append(result["records"].assign(variant=name))
        described.update(result["cases"])
    records = pd.concat(frames, ignore_index=True)
    runs = stored_runs(args.seeds)
    reference = stored_reference(runs, args.seeds, args.budget)
    default = stored_default(runs)
    lines = []
    for case in cases:
        if case not in described:
            continue
        column = _column(described[case])
        lines.append(f"{case} ({column}, median over {args.seeds} seeds at {' / '.join(map(str, budgets))} cycles)")
        frame = records[records["case"] == case]
        for name in variants:
            medians = frame[frame["variant"] == name].groupby("cycles")[column].median()
            worst = frame[frame["variant"] == name].groupby("cycles")[column].min()
            rotation = frame[frame["variant"] == name]["rotation"].abs().max()
            lines.append(f"  {name:<28} " + " / ".join(f"{medians[c]:+.3f}" for c in budgets)
                         + "   min " + " / ".join(f"{worst[c]:+.3f}" for c in budgets) + f"   |rot| ≤ {rotation:.3f}")
        stored = default[default["case"] == case] if len(default) else default
        for name in variants:
            paired = _paired_line(name, frame[frame["variant"] == name], stored, column, budgets)
            if paired is not None:
                lines.append(paired)
        for kind, label in (("geogait", "geogait default (stored)"), ("black-box", "best black-box (stored)")):
            rows = reference[(reference["case"] == case) & (reference["kind"] == kind)] if len(reference) else []
            if len(rows):
                lines.append(f"  {label:<28} " + " / ".join(f"{v:+.3f}" for v in rows["median"])
                             + ("   (" + ", ".join(rows["method"]) + ")" if kind == "black-box" else ""))
    print("\n".join(lines))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    arguments = sys.argv[1:] if argv is None else argv
    command = "python studies/optimizer_robots.py " + " ".join(map(shlex.quote, arguments))
    payload = {"command": command, "variants": variants,
               "seeds": args.seeds, "budget": args.budget, "table": lines,
               "records": json.loads(records.replace({np.nan: None}).to_json(orient="records"))}
    (out / "optimizer_robots.json").write_text(json.dumps(payload, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
