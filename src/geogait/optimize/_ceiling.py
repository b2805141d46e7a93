"""The ceiling: the best gait of the family, found with the *true* connection (model-based, like
sysplotter), against which in-situ optimisation is judged."""

from __future__ import annotations

import hashlib
import json
import numbers
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from .._defaults import FEASIBILITY_TOLERANCE, MAX_JOINT_ANGLE
from .._files import write_json
from .._validation import GeogaitError, check_choice, check_float, check_int, fail
from ..gaits import FourierGait, MirrorGaitFamily, SymmetricGaitFamily, seed_gait
from ..simulate import cycle_displacement
from ..systems import System
from ._objective import (
    default_objective,
    feasibility_constraint,
    joint_limit_constraints,
    objective,
    rms_speed,
)

#: The objectives a ceiling is defined for ("forward" needs a direction the system does not give).
CEILING_OBJECTIVES = ("progress", "efficiency", "budget")

__all__ = ["Ceiling", "cached_ceiling", "optimize_ceiling"]

#: Random draws tried per random start of a system with a feasible region before giving up on it.
FEASIBLE_DRAWS = 2000


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
        Number of multi-start runs made (fewer than asked when a system's feasible region left a
        random start without a feasible draw); ``values`` holds each start's result (-inf: the
        run ended infeasible).
    values : ndarray
    """

    gait: FourierGait
    value: float
    displacement: np.ndarray
    starts: int
    values: np.ndarray


def _solve(system, start: FourierGait, kind: str, limits, resolution: int, matrix=None, feasibility=None):
    """SLSQP from ``start``; ``matrix`` T maps free parameters q to Fourier parameters p = T q
    (a rotation-free family: no rotation constraint), identity when None; ``feasibility`` (from
    :func:`feasibility_constraint`) adds the system's feasible region as inequality rows."""
    to_fourier = np.eye(start.params.size) if matrix is None else matrix

    def evaluate(q):
        gait = start.with_params(to_fourier @ q)
        pose, jacobian = cycle_displacement(system, gait, resolution, jacobian=True)
        value, gradient = objective(kind, pose, jacobian, gait)
        return value, gradient @ to_fourier, pose, jacobian @ to_fourier

    cache = {}

    def cached(q):
        key = q.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = evaluate(q)
        return cache[key]

    limit_matrix, bound = limits
    limit_matrix = limit_matrix @ to_fourier
    constraints = [{"type": "ineq", "fun": lambda q: bound - limit_matrix @ q, "jac": lambda q: -limit_matrix}]
    if feasibility is not None:
        constraints.append({"type": "ineq", "fun": lambda q: feasibility(to_fourier @ q)[0],
                            "jac": lambda q: feasibility(to_fourier @ q)[1] @ to_fourier})
    if matrix is None:
        constraints.append({"type": "eq", "fun": lambda q: cached(q)[2][2], "jac": lambda q: cached(q)[3][2]})
    start_q = np.linalg.lstsq(to_fourier, start.params, rcond=None)[0]
    result = minimize(lambda q: -cached(q)[0], start_q, jac=lambda q: -cached(q)[1], method="SLSQP",
                      constraints=constraints, options={"maxiter": 300, "ftol": 1e-12})
    gait = start.with_params(to_fourier @ result.x)
    pose = cycle_displacement(system, gait, resolution)
    feasible = abs(pose[2]) < 1e-6 and np.all(limit_matrix @ result.x <= bound + 1e-9)
    if feasibility is not None:  # the grid rows hold (to SLSQP's tolerance), and the loop between them
        feasible = feasible and np.all(feasibility(gait.params)[0] >= -FEASIBILITY_TOLERANCE) and bool(
            np.all(system.feasible(gait.shape(np.linspace(0, 2 * np.pi, 4096, endpoint=False)))))
    return gait, (objective(kind, pose, np.zeros((3, gait.params.size)), gait)[0] if feasible else -np.inf), pose


def optimize_ceiling(system: System, *, order: int = 1, objective_kind: str | None = None,
                     max_joint_angle: float = MAX_JOINT_ANGLE, starts: int = 8, seed: int = 0,
                     resolution: int = 128, family: str = "free", start: FourierGait | None = None) -> Ceiling:
    r"""Maximise the objective over Fourier gaits of ``order`` with the true connection.

    SLSQP with exact gradients (:func:`~geogait.simulate.cycle_displacement` with
    ``jacobian=True``), the zero-net-rotation equality constraint and the joint limits as linear
    inequalities; multi-start from ``start`` (by default the paper's seed gait, or the system's own
    ``seed_gait`` when it declares a feasible region) and ``starts - 1`` random gaits within the
    limits. A :class:`~geogait.systems.FeasibleSystem` (e.g. the kinematic snake, whose connection
    is singular on a curve) adds its region as inequality rows on a phase grid,

    .. math:: g(\theta(\phi_k)) \ge s,\quad \phi_k = 2\pi k / (256 K),\ s = 2\cdot 10^{-3},

    with exact gradients ∂g/∂r · ∂θ/∂p; random starts are drawn until feasible (up to 2000 draws
    each: a start that finds none is dropped, and ``Ceiling.starts`` counts the starts run), and a
    result counts only if the loop is feasible at 4096 phases. Returns the best feasible result;
    among starts that tie to 1e-6 (``"budget"`` and
    ``"efficiency"`` do not change when a loop is repeated), the one with the least RMS shape speed.

    Parameters
    ----------
    system : System
    order : int
        Fourier order of the gait family.
    objective_kind : {"progress", "efficiency", "budget"}, optional
        Default :func:`~geogait.optimize.default_objective` of ``order``: progress per cycle for
        order 1, progress per unit time at a fixed RMS shape velocity (``"budget"``) for order ≥ 2
        (progress per cycle would be won by repeating the order-1 loop ``order`` times per cycle).
    max_joint_angle : float
        r_max (rad).
    starts : int
    seed : int
        Seed of the random starts.
    resolution : int
        Magnus steps per cycle (error ~1e-8 at 128).
    family : {"free", "symmetric", "mirror"}
        ``"symmetric"`` optimises inside the front–back symmetric family
        (:class:`~geogait.gaits.SymmetricGaitFamily` about the seed gait's φ₀), which is rotation-free
        by construction, with half the parameters; only for chains with that symmetry.
        ``"mirror"`` optimises over the half-wave symmetric gaits
        (:class:`~geogait.gaits.MirrorGaitFamily`: odd harmonics only), rotation-free on any planar
        chain; the start must be a member.
    start : FourierGait, optional
        First start, of ``d`` joints; it must lie within the joint limits (and the system's
        feasible region, if any). Its order is raised to ``order`` if lower.
    """
    n_joints = getattr(system, "n_joints", None)
    if not callable(getattr(system, "connection", None)) or not isinstance(n_joints, numbers.Integral):
        raise fail("system", "optimize_ceiling", "a geogait System (connection, n_joints)", type(system).__name__)
    order = check_int(order, "order", "optimize_ceiling", minimum=1)
    starts = check_int(starts, "starts", "optimize_ceiling", minimum=1)
    if seed is not None and not isinstance(seed, np.random.SeedSequence | np.random.Generator):
        check_int(seed, "seed", "optimize_ceiling", minimum=0)
    r_max = check_float(max_joint_angle, "max_joint_angle", "optimize_ceiling", low=0, high=np.pi, low_open=True)
    kind = default_objective(order) if objective_kind is None else objective_kind
    check_choice(kind, "objective_kind", "optimize_ceiling", CEILING_OBJECTIVES)
    check_choice(family, "family", "optimize_ceiling", ("free", "symmetric", "mirror"))
    d = system.n_joints
    limits = joint_limit_constraints(d, order, r_max)
    rng = np.random.default_rng(seed)
    feasibility = feasibility_constraint(system, d, order)
    seed_start = _first_start(system, start, d, order, r_max, feasibility)
    matrix = None
    if family == "symmetric":
        symmetric = SymmetricGaitFamily.from_gait(seed_start)
        distance = symmetric.residual(seed_start)
        if start is not None and distance > 1e-6:
            raise fail("start", "optimize_ceiling", "a front-back symmetric gait for family 'symmetric'",
                       f"a gait {distance:.3g} from the nearest symmetric one")
        matrix = symmetric.matrix
    elif family == "mirror":
        mirror = MirrorGaitFamily(d, order)
        if mirror.residual(seed_start) > 1e-9:
            raise fail("start", "optimize_ceiling", "a half-wave symmetric gait (no offsets or even harmonics) "
                       "for family 'mirror'", seed_start)
        matrix = mirror.matrix
    candidates = [seed_start]
    for _ in range(starts - 1):
        for _ in range(1 if feasibility is None else FEASIBLE_DRAWS):
            coefficients = 0.5 * rng.normal(size=(d, 2 * order + 1))
            # A feasible region may exclude loops about the origin: offsets then span the limits.
            coefficients[:, 0] *= 0.2 if feasibility is None else 2 * r_max
            if matrix is not None:  # project onto the family, then scale into the limits
                coefficients = (matrix @ np.linalg.lstsq(matrix, coefficients.ravel(), rcond=None)[0]).reshape(d, -1)
            scale = np.abs(coefficients).sum(axis=1).max() / (0.8 * r_max)
            candidate = FourierGait(coefficients / max(scale, 1.0))
            if feasibility is None or np.all(feasibility(candidate.params)[0] >= 0):
                candidates.append(candidate)
                break
    results = [_solve(system, begin, kind, limits, resolution, matrix, feasibility) for begin in candidates]
    values = np.array([value for _, value, _ in results])
    # "budget" and "efficiency" are invariant under repeating a loop (θ(φ) → θ(Kφ)); among starts that tie
    # (within 1e-6), keep the gait with the least RMS shape speed: the single loop, not its repetition.
    tied = np.nonzero(values >= values.max() - 1e-6 * abs(values.max()))[0]
    best = int(tied[np.argmin([rms_speed(results[i][0]) for i in tied])])
    gait, value, pose = results[best]
    if not np.isfinite(value):
        raise GeogaitError(f"optimize_ceiling found no feasible gait of {system.name} from its {len(candidates)} "
                           f"start(s) in family {family!r} (every one broke a constraint): try family='free', "
                           "more starts, or a feasible start.")
    return Ceiling(gait=gait, value=float(value), displacement=pose, starts=len(candidates), values=values)


def _first_start(system, start, d: int, order: int, r_max: float, feasibility) -> FourierGait:
    """The given start (checked) or the default: the system's feasible seed, else the paper's."""
    owner = "optimize_ceiling"
    if start is None:
        if feasibility is not None:
            start = system.seed_gait(order=order)
        else:
            return seed_gait(d, amplitude=min(1.0, 0.9 * r_max), order=order)
    elif not isinstance(start, FourierGait) or start.n_joints != d or start.order > order:
        raise fail("start", owner, f"a FourierGait with {d} joints and order <= {order}", start)
    start = start.with_order(order) if start.order < order else start
    if np.any(start.joint_limit() > r_max):
        raise fail("start", owner, f"a gait within the joint limit {r_max:g} rad",
                   f"a gait reaching {start.joint_limit().max():.4g} rad")
    if feasibility is not None and np.any(feasibility(start.params)[0] < -FEASIBILITY_TOLERANCE):
        raise fail("start", owner, f"a gait inside the feasible region of {system.name} (pass a feasible start)",
                   f"a gait with feasibility down to {feasibility(start.params)[0].min():.4g}")
    return start


def _cache_folder() -> Path:
    root = os.environ.get("GEOGAIT_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.join(os.path.expanduser("~"), ".cache")), "geogait")
    return Path(root)


def cached_ceiling(system: System, **options) -> Ceiling:
    """:func:`optimize_ceiling`, remembered on disk (``$GEOGAIT_CACHE`` or ``~/.cache/geogait``).

    The key is the system's ``repr`` (all its parameters) and the options, so any change recomputes.
    A missing or unreadable cache file is recomputed and rewritten (atomically). A system whose ``repr``
    does not show its parameters (one naming an object by its address, e.g. a ``FunctionSystem`` of a
    lambda, whose address a later one may reuse) is not cached: it is computed every time.
    """
    if re.search(r" at 0x[0-9a-fA-F]+", repr(system)):
        return optimize_ceiling(system, **options)
    key = hashlib.sha256(json.dumps([repr(system), sorted(options.items())], default=str).encode()).hexdigest()[:16]
    path = _cache_folder() / f"ceiling-{key}.json"
    try:
        record = json.loads(path.read_text())
        if not isinstance(record["value"], float | int):
            raise ValueError("not a ceiling")
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
