"""What many test files share: the reference swimmer and gait, model arguments from a run, stream
records, a motion-capture-style log of a run, the column names of a run's table, a sink for stream
outputs and the strict-JSON and "no null without a reason" checks of JSON outputs (one copy each; the
runs themselves stay per file, where their seeds and lengths are part of what a test checks)."""

import json

import numpy as np
import pandas as pd

from geogait import se2
from geogait.gaits import seed_gait
from geogait.systems import PurcellSwimmer

#: The 3-link Purcell swimmer (drag ratio 2) and its seed gait, the reference of most tests.
SWIMMER, GAIT = PurcellSwimmer(3), seed_gait(2)
#: read_log column arguments of :func:`mocap_log`'s table.
MOCAP_COLUMNS = dict(time="t", shape=["q0", "q1"], pose=["x", "y", "yaw"])
#: The body velocity columns of a run's table (:meth:`~geogait.simulate.Trajectory.to_pandas`).
BODY = ["body_velocity_x", "body_velocity_y", "body_velocity_theta"]
#: read_log column arguments of a 3-link run's table, and the ``geogait fit`` / ``predict`` options that name them.
COLUMNS = dict(shape=["shape_0", "shape_1"], body_velocity=BODY, phase="phase",
               shape_velocity=["shape_velocity_0", "shape_velocity_1"])
CLI_COLUMNS = ["--shape", "shape_0,shape_1", "--body-velocity", ",".join(BODY), "--phase", "phase",
               "--shape-velocity", "shape_velocity_0,shape_velocity_1"]


def fit_args(run, stop=None):
    """``(phase, shape, shape_velocity, body_velocity)`` of a run's first ``stop`` samples."""
    return run.phase[:stop], run.shape[:stop], run.shape_velocity[:stop], run.body_velocity[:stop]


def record(run, s, *, phase=True, rate=True, **changes):
    """Sample ``s`` of a run as a stream record (JSON object), optional keys dropped, fields replaced."""
    entry = {"time": float(run.time[s]), "shape": run.shape[s].tolist(), "body_velocity": run.body_velocity[s].tolist()}
    if phase:
        entry["phase"] = float(run.phase[s])
    if rate:
        entry["shape_velocity"] = run.shape_velocity[s].tolist()
    return {**entry, **changes}


def lines(run, start=0, stop=None, changes=None, **options):
    """JSON lines of samples ``start:stop``; ``changes`` maps a sample index to replaced fields."""
    stop = run.n_samples if stop is None else stop
    changes = changes or {}
    return "".join(json.dumps(record(run, s, **options, **changes.get(s, {}))) + "\n" for s in range(start, stop))


def mocap_log(run, *, position=0.0, heading=0.0, encoder=0.0, seed=1) -> pd.DataFrame:
    """Poses and joint angles only (no ξ, no phase, no ṙ), heading wrapped to [−π, π) like a motion-capture
    system, with Gaussian noise: ``position`` (body lengths), ``heading`` and ``encoder`` (rad) std."""
    rng = np.random.default_rng(seed)
    n = run.n_samples
    shape = run.shape + rng.normal(0, encoder, (n, 2))
    xy = run.pose[:, :2] + rng.normal(0, position, (n, 2))
    yaw = se2.wrap_angle(run.pose[:, 2] + rng.normal(0, heading, n))
    return pd.DataFrame({"t": run.time, "q0": shape[:, 0], "q1": shape[:, 1], "x": xy[:, 0], "y": xy[:, 1],
                         "yaw": yaw})


def strict_json(text: str):
    """json.loads that refuses NaN / Infinity tokens."""
    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


def nulls_without_reason(value, where="") -> list[str]:
    """Where ``value`` (nested dicts and lists of JSON) holds a null without a ``{key}_null_reason``
    beside it, as paths (``.results.drag_change.cycles_to_recover``): every null of an output says why."""
    if isinstance(value, list):
        return [n for i, v in enumerate(value) for n in nulls_without_reason(v, f"{where}[{i}]")]
    if not isinstance(value, dict):
        return []
    missing = [f"{where}.{k}" for k, v in value.items() if v is None and f"{k}_null_reason" not in value]
    return missing + [n for k, v in value.items() for n in nulls_without_reason(v, f"{where}.{k}")]


class Sink:
    """A text sink that remembers what was written (the output of :func:`~geogait.learn.run_stream`)."""

    def __init__(self):
        self.text = ""

    def write(self, text):
        self.text += text

    def flush(self):
        pass
