"""The ceiling: the best gait of the family, found with the *true* connection (model-based, like
sysplotter), against which in-situ optimisation is judged."""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from .._files import write_json
from .._validation import check_float, check_int
from ..gaits import FourierGait, seed_gait
from ..simulate import cycle_displacement
from ..systems import System
from ._objective import joint_limit_constraints, objective

__all__ = ["Ceiling", "cached_ceiling", "optimize_ceiling"]


@dataclass(frozen=True)
class Ceiling:
    """Best gait found by :func:`optimize_ceiling`.

    Attributes
    ----------
    gait : FourierGait
    value : float
        Objective at ``gait`` (progress per cycle, or progress per path length).
    displacement : ndarray of shape (3,)
        Net (x, y, heading) per cycle of ``gait``.
    starts : int
        Number of multi-start runs; ``values`` holds each start's result.
    values : ndarray
    """

    gait: FourierGait
    value: float
    displacement: np.ndarray
    starts: int
    values: np.ndarray


def _solve(system, start: FourierGait, kind: str, limits, resolution: int):
    def evaluate(params):
        pose, jacobian = cycle_displacement(system, start.with_params(params), resolution, jacobian=True)
        value, gradient = objective(kind, pose, jacobian, start.with_params(params))
        return value, gradient, pose, jacobian

    cache = {}

    def cached(params):
        key = params.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = evaluate(params)
        return cache[key]

    matrix, bound = limits
    constraints = [
        {"type": "eq", "fun": lambda p: cached(p)[2][2], "jac": lambda p: cached(p)[3][2]},
        {"type": "ineq", "fun": lambda p: bound - matrix @ p, "jac": lambda p: -matrix},
    ]
    result = minimize(lambda p: -cached(p)[0], start.params, jac=lambda p: -cached(p)[1], method="SLSQP",
                      constraints=constraints, options={"maxiter": 300, "ftol": 1e-12})
    gait = start.with_params(result.x)
    pose = cycle_displacement(system, gait, resolution)
    feasible = abs(pose[2]) < 1e-6 and np.all(matrix @ result.x <= bound + 1e-9)
    return gait, (objective(kind, pose, np.zeros((3, result.x.size)), gait)[0] if feasible else -np.inf), pose


def optimize_ceiling(system: System, *, order: int = 1, objective_kind: str = "progress",
                     max_joint_angle: float = 2 * np.pi / 3, starts: int = 8, seed: int = 0,
                     resolution: int = 128) -> Ceiling:
    """Maximise the objective over Fourier gaits of ``order`` with the true connection.

    SLSQP with exact gradients (:func:`~geogait.simulate.cycle_displacement` with
    ``jacobian=True``), the zero-net-rotation equality constraint and the joint limits as linear
    inequalities; multi-start from the paper's seed gait and ``starts - 1`` random gaits within the
    limits. Returns the best feasible result.

    Parameters
    ----------
    system : System
    order : int
        Fourier order of the gait family.
    objective_kind : {"progress", "efficiency"}
    max_joint_angle : float
        r_max (rad).
    starts : int
    seed : int
        Seed of the random starts.
    resolution : int
        Magnus steps per cycle (error ~1e-8 at 128).
    """
    order = check_int(order, "order", "optimize_ceiling", minimum=1)
    starts = check_int(starts, "starts", "optimize_ceiling", minimum=1)
    r_max = check_float(max_joint_angle, "max_joint_angle", "optimize_ceiling", low=0, high=np.pi, low_open=True)
    d = system.n_joints
    limits = joint_limit_constraints(d, order, r_max)
    rng = np.random.default_rng(seed)
    candidates = [seed_gait(d, amplitude=min(1.0, 0.9 * r_max), order=order)]
    for _ in range(starts - 1):
        coefficients = 0.5 * rng.normal(size=(d, 2 * order + 1))
        coefficients[:, 0] *= 0.2
        scale = np.abs(coefficients).sum(axis=1).max() / (0.8 * r_max)
        candidates.append(FourierGait(coefficients / max(scale, 1.0)))
    results = [_solve(system, start, objective_kind, limits, resolution) for start in candidates]
    values = np.array([value for _, value, _ in results])
    best = int(np.argmax(values))
    gait, value, pose = results[best]
    return Ceiling(gait=gait, value=float(value), displacement=pose, starts=starts, values=values)


def _cache_folder() -> Path:
    root = os.environ.get("GEOGAIT_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.join(os.path.expanduser("~"), ".cache")), "geogait")
    return Path(root)


def cached_ceiling(system: System, **options) -> Ceiling:
    """:func:`optimize_ceiling`, remembered on disk (``$GEOGAIT_CACHE`` or ``~/.cache/geogait``).

    The key is the system's ``repr`` (all its parameters) and the options, so any change recomputes.
    A missing or unreadable cache file is recomputed and rewritten (atomically).
    """
    key = hashlib.sha256(json.dumps([repr(system), sorted(options.items())], default=str).encode()).hexdigest()[:16]
    path = _cache_folder() / f"ceiling-{key}.json"
    try:
        record = json.loads(path.read_text())
        return Ceiling(gait=FourierGait(np.array(record["gait"])), value=record["value"],
                       displacement=np.array(record["displacement"]), starts=record["starts"],
                       values=np.array(record["values"]))
    except (OSError, ValueError, KeyError, TypeError):
        pass
    ceiling = optimize_ceiling(system, **options)
    record = {"system": repr(system), "options": {k: str(v) for k, v in options.items()},
              "gait": ceiling.gait.coefficients.tolist(), "value": ceiling.value,
              "displacement": ceiling.displacement.tolist(), "starts": ceiling.starts,
              "values": ceiling.values.tolist()}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_json(path, record, indent=None)
    except OSError:
        pass  # a read-only home only costs recomputation next time
    return ceiling
