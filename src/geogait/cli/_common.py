"""Small helpers shared by the CLI commands: output folders, JSON manifests, progress bars."""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

import geogait

console = Console(stderr=True)


def output_folder(path: Path) -> Path:
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def write_manifest(path: Path, *, command: str, config: dict, results: dict, started: float) -> Path:
    """JSON record of a run: config, seed, versions, wall time and headline numbers."""
    manifest = {
        "command": command,
        "geogait_version": geogait.__version__,
        "numpy_version": np.__version__,
        "python_version": platform.python_version(),
        "config": config,
        "wall_time_s": round(time.perf_counter() - started, 3),
        "results": results,
    }
    path.write_text(json.dumps(_plain(manifest), indent=2) + "\n")
    return path


def progress_bar() -> Progress:
    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), TextColumn("{task.fields[status]}"), console=console,
                    transient=False)
