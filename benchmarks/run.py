"""Run every ``bench_*.py`` in this folder, print one table and write ``results/benchmarks.json``.

Each module exposes ``run() -> list[dict]`` with keys ``benchmark``, ``case``, ``value``, ``unit`` and
optionally ``target`` (a human-readable goal). Timings are best-of-repeats wall clock on one core
(OMP/BLAS threads pinned to 1 so numbers are comparable to the issue targets).

Usage: ``python benchmarks/run.py [substring ...]`` runs only modules whose name contains one.
"""

from __future__ import annotations

import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import importlib.util  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

HERE = Path(__file__).parent


def best_time(function, repeats: int = 5, min_time: float = 0.2) -> float:
    """Smallest wall time of ``function()`` over ``repeats`` runs (each run looped to ``min_time``)."""
    function()  # warm up caches and lazy imports
    best = np.inf
    for _ in range(repeats):
        loops, start = 0, time.perf_counter()
        while True:
            function()
            loops += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_time:
                break
        best = min(best, elapsed / loops)
    return best


def main(selection: list[str]) -> None:
    modules = sorted(HERE.glob("bench_*.py"))
    if any(s.startswith("-") for s in selection):  # (--help, or an option it does not have)
        print(__doc__.strip())
        print("\nmodules: " + " ".join(path.stem.removeprefix("bench_") for path in modules))
        raise SystemExit(0 if set(selection) <= {"-h", "--help"} else 2)
    chosen = [path for path in modules if not selection or any(s in path.stem for s in selection)]
    if not chosen:  # (nothing to run: keep the last results rather than write an empty record)
        raise SystemExit(f"error: no benchmark module matches {' '.join(selection)}; modules: "
                         + " ".join(path.stem.removeprefix("bench_") for path in modules))
    sys.path.insert(0, str(HERE))
    rows = []
    for path in chosen:
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        rows.extend(module.run())
    table = Table(title="geogait benchmarks (one core)")
    for column in ("benchmark", "case", "value", "unit", "target"):
        table.add_column(column, justify="right" if column == "value" else "left")
    for row in rows:
        table.add_row(row["benchmark"], row["case"], f"{row['value']:,.4g}", row["unit"], row.get("target", ""))
    Console().print(table)
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    record = {"machine": platform.platform(), "python": platform.python_version(), "numpy": np.__version__,
              "cpu_count": os.cpu_count(), "rows": rows}
    (results / "benchmarks.json").write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {results / 'benchmarks.json'}")


if __name__ == "__main__":
    main(sys.argv[1:])
