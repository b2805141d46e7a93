"""Streaming throughput (issue 6): ``geogait stream`` as a real subprocess fed JSON lines through a
pipe, and the same loop in process (:func:`geogait.io.run_stream` on in-memory text), for the 3-
and 9-link swimmers; the in-process loop also with online phase estimation (OnlinePhaser).

The subprocess rows time the whole command (start-up, N samples, final atomic save); the
start-up cost alone is measured by piping an empty input, and "steady state" is
N / (t(N) − t(empty)). The start-up includes loading the compiled one-sample kernel (numba's
on-disk cache; StreamLearner loads it before the first sample).
"""

import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from run import best_time

from geogait import _kernels
from geogait.gaits import seed_gait
from geogait.learn import StreamLearner, run_stream
from geogait.models import AdaptiveGaitModel
from geogait.phase import Phaser
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

N_SAMPLES = 5000
N_PIPE = 50_000  # through the pipe: enough that t(N) − t(empty) is not lost in the start-up's jitter
SCRIPT = Path(sys.executable).with_name("geogait")
COMMAND = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-c", "from geogait.cli import main; main()"]


def _json_lines(run, phase: bool = True) -> str:
    keys = ("time", "phase", "shape", "shape_velocity", "body_velocity") if phase else (
        "time", "shape", "shape_velocity", "body_velocity")
    rows = []
    for s in range(run.n_samples):
        values = {"time": float(run.time[s]), "phase": float(run.phase[s]), "shape": run.shape[s].tolist(),
                  "shape_velocity": run.shape_velocity[s].tolist(), "body_velocity": run.body_velocity[s].tolist()}
        rows.append(json.dumps({k: values[k] for k in keys}))
    return "\n".join(rows) + "\n"


def _subprocess_seconds(config: Path, text: str, folder: Path, repeats: int = 2) -> float:
    """Best wall time of ``geogait stream config`` on ``text`` (fresh model each time)."""
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        done = subprocess.run([*COMMAND, "stream", str(config), "--out", str(folder / "model.npz")], input=text,
                              text=True, capture_output=True, env=os.environ.copy(), check=False)
        best = min(best, time.perf_counter() - started)
        if done.returncode != 0:
            raise RuntimeError(done.stderr)
    return best


def _pipeline_seconds(config: Path, lines: Path, folder: Path, repeats: int = 2) -> float:
    """Best wall time of ``cat lines | geogait stream config | (this process reading)``: a producer that
    writes as fast as the pipe takes (``subprocess.run(input=...)`` above writes 512 bytes per wake-up,
    which on a loaded machine can be slower than the stream itself)."""
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        with subprocess.Popen(["cat", str(lines)], stdout=subprocess.PIPE) as producer:
            done = subprocess.run([*COMMAND, "stream", str(config), "--out", str(folder / "model.npz")],
                                  stdin=producer.stdout, capture_output=True, env=os.environ.copy(), check=False)
        best = min(best, time.perf_counter() - started)
        if done.returncode != 0:
            raise RuntimeError(done.stderr)
    return best


def _in_process(gait, text: str, phaser=None) -> float:
    def once():
        learner = StreamLearner(AdaptiveGaitModel(gait=gait), phaser=phaser)
        run_stream(learner, io.StringIO(text), io.StringIO())

    return best_time(once, repeats=2, min_time=0.0)


def run():
    rows = []
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for links in (3, 9):
            gait = seed_gait(links - 1)
            long = simulate(PurcellSwimmer(links), gait, N_PIPE // 100, seed=0, sensor_noise=0.1)
            trajectory = long.cycles(0, N_SAMPLES // 100)
            config = folder / f"config{links}.json"
            config.write_text(json.dumps(AdaptiveGaitModel(gait=gait).to_config()))
            text = _json_lines(trajectory)
            empty = _subprocess_seconds(config, "", folder, repeats=3)
            full = _subprocess_seconds(config, _json_lines(long), folder)
            case = f"{links}-link, {N_PIPE} JSON lines through a pipe"
            rows.append(dict(benchmark="geogait stream", case=f"{case}, incl. start-up", value=N_PIPE / full,
                             unit="samples/s"))
            rows.append(dict(benchmark="geogait stream", case=f"{case}, steady state", value=N_PIPE / (full - empty),
                             unit="samples/s", target=">= 20 000" if links == 3 else ""))
            rows.append(dict(benchmark="geogait stream", case=f"{links}-link, start-up (empty input)", value=empty,
                             unit="s"))
            source = folder / f"lines{links}.jsonl"
            source.write_text(_json_lines(long))
            piped = _pipeline_seconds(config, source, folder)
            rows.append(dict(benchmark="geogait stream", case=f"{links}-link, cat | geogait stream, steady state",
                             value=N_PIPE / (piped - empty), unit="samples/s",
                             target=">= 20 000" if links == 3 else ""))
            seconds = _in_process(gait, text)
            rows.append(dict(benchmark="stream loop in process", case=f"{links}-link, parse + learn + write",
                             value=N_SAMPLES / seconds, unit="samples/s"))
            _kernels.ENABLED = False  # the model's NumPy reference path, side by side
            try:
                seconds = _in_process(gait, text)
            finally:
                _kernels.ENABLED = True
            rows.append(dict(benchmark="stream loop in process",
                             case=f"{links}-link, parse + learn + write, NumPy reference model path",
                             value=N_SAMPLES / seconds, unit="samples/s"))
            phaser = Phaser().fit(trajectory.shape)
            seconds = _in_process(gait, _json_lines(trajectory, phase=False), phaser)
            rows.append(dict(benchmark="stream loop in process",
                             case=f"{links}-link, with OnlinePhaser (2-cycle window)", value=N_SAMPLES / seconds,
                             unit="samples/s"))
    return rows
