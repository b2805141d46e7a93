"""What many test files share: the reference swimmer and gait, model arguments from a run, stream
records, a motion-capture-style log of a run and the "no null without a reason" check of JSON
outputs (one copy each; the runs themselves stay per file, where their seeds and lengths are part of
what a test checks)."""

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


def nulls_without_reason(value) -> list:
    """Keys of ``value`` (nested dicts and lists of JSON) that are null without a ``{key}_null_reason``
    beside them: every null of a tracking output says why."""
    if isinstance(value, list):
        return [n for v in value for n in nulls_without_reason(v)]
    if not isinstance(value, dict):
        return []
    return [k for k, v in value.items() if v is None and f"{k}_null_reason" not in value] + \
        [n for v in value.values() for n in nulls_without_reason(v)]
