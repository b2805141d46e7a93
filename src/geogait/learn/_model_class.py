r"""Is a robot's data inside geogait's model class? The verdict from the cycle period.

geogait models principally kinematic bodies, :math:`\xi = -A(r)\dot r`: the body velocity is linear in the
shape velocity, so a gait moves the body the same per cycle at any speed. Inertia (a body that coasts) and
rate-dependent forces break that: the net motion per cycle then changes with the cycle period. A log whose
cycles run at different periods can be tested directly: the mean net motion per cycle (progress |Δx, Δy| and
rotation Δθ, in the body frame at each cycle's start) of its short and its long cycles must agree within
their noise.

The test splits the complete cycles (each segment's first and last are dropped as partial) at the geometric
mean of the shortest and longest period, needs ``min_cycles`` in each group and periods ``min_period_ratio``
apart and the same realised gait in both (RMS shape about each cycle's mean within ``tolerance``: a robot that
cannot follow the faster cycles runs another gait, and the comparison would say nothing), and calls the data
**not principally kinematic** when the progress or the rotation of the two groups
differ by more than ``z`` standard errors (Welch) *and* by more than ``tolerance`` (relative for progress,
radians for rotation) — a difference that is both real and large. It calls them consistent with the model
class only when both differences are bounded below the tolerance with ``z`` standard errors to spare (an
equivalence test); otherwise, and when it cannot test (one period), it says it cannot tell: it never claims
more than the data show. A low held-out Γ cannot tell a body outside the model
class from noisy data or too little exploration, so it is reported beside the verdict, not as one.

Measured with this test (``tests/learn/test_model_class.py``): the ``kinematic-snake`` package's snake
(Coulomb friction, Froude number 1; ``studies/kinematic_snake_log.py``) at 1 s and 0.5 s moves 0.147 ± 0.004
and 0.118 ± 0.006 per cycle (4 standard errors apart): not principally kinematic. The built-in Purcell
swimmer with sensor noise 0.1 moves the same at both periods: consistent with the model class.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .. import se2
from .._validation import check_float, check_int, fail
from ..io import Log

__all__ = ["ModelClassVerdict", "model_class_verdict", "period_verdict", "shape_amplitude"]

_OWNER = "model_class_verdict"


@dataclass(frozen=True)
class ModelClassVerdict:
    """The outcome of :func:`model_class_verdict`.

    Attributes
    ----------
    principally_kinematic : bool or None
        False: the net motion per cycle changes with the cycle period (outside the model class). True:
        it agrees within the tolerance at the periods in the data. None: the data cannot tell (one period,
        too few cycles, another realised gait, or a difference within noise that the noise cannot bound).
    reason : str
        One sentence with the numbers.
    periods, progress, progress_se, rotation, rotation_se : tuple of float or None
        Short and long cycles' mean period, mean progress and rotation per cycle with their standard
        errors (None when the test could not run).
    n_cycles : tuple of int or None
    """

    principally_kinematic: bool | None
    reason: str
    periods: tuple | None = None
    progress: tuple | None = None
    progress_se: tuple | None = None
    rotation: tuple | None = None
    rotation_se: tuple | None = None
    n_cycles: tuple | None = None

    def to_dict(self) -> dict:
        return asdict(self)


def model_class_verdict(log: Log, cycle, *, z: float = 3.0, tolerance: float = 0.05, min_period_ratio: float = 1.25,
                        min_cycles: int = 3) -> ModelClassVerdict:
    """Whether the net motion per cycle of a log changes with the cycle period (module notes).

    Parameters
    ----------
    log : Log
    cycle : array-like of int, shape (n_samples,)
        Cycle number of every sample (:attr:`LogFit.cycle`: counted on the unwrapped phase, per segment).
    z : float > 0
        Standard errors a difference must exceed.
    tolerance : float >= 0
        Smallest difference that counts: a fraction of the progress per cycle, and radians of rotation.
    min_period_ratio : float > 1
        Longest over shortest period needed to test.
    min_cycles : int >= 2
        Complete cycles needed in each group.

    Returns
    -------
    ModelClassVerdict
    """
    settings = _settings(z, tolerance, min_period_ratio, min_cycles, _OWNER)
    cycle = np.asarray(cycle)
    if cycle.shape != (log.n_samples,) or not np.issubdtype(cycle.dtype, np.integer):
        raise fail("cycle", _OWNER, f"an int array of shape ({log.n_samples},): the cycle of every sample",
                   f"{cycle.dtype} array of shape {cycle.shape}")
    return _judge(*_complete_cycles(log, cycle), *settings, log.time_unit)


def period_verdict(period, net_motion, shape_amplitude, *, z: float = 3.0, tolerance: float = 0.05,
                   min_period_ratio: float = 1.25, min_cycles: int = 3, time_unit: str = "") -> ModelClassVerdict:
    """The test of :func:`model_class_verdict` on cycles already cut out: one row per complete cycle.

    The in-situ optimiser runs it on its own cycles (``InSituOptimizer(model_class_cycles=n)``: the seed gait
    at two periods).

    Parameters
    ----------
    period : array-like of shape (n_cycles,)
        Each cycle's duration.
    net_motion : array-like of shape (n_cycles, 3)
        Each cycle's net (x, y, heading) motion in the body frame at its start.
    shape_amplitude : array-like of shape (n_cycles,)
        Each cycle's realised gait size (:func:`shape_amplitude`).
    z, tolerance, min_period_ratio, min_cycles
        As in :func:`model_class_verdict`.
    time_unit : str
        Unit of ``period`` for the reason's text ("" for none).

    Returns
    -------
    ModelClassVerdict
    """
    owner = "period_verdict"
    settings = _settings(z, tolerance, min_period_ratio, min_cycles, owner)
    periods = np.asarray(period, dtype=float).reshape(-1)
    nets = np.asarray(net_motion, dtype=float)
    amplitudes = np.asarray(shape_amplitude, dtype=float)
    if nets.shape != (periods.size, 3) or amplitudes.shape != periods.shape:
        raise fail("net_motion", owner, f"arrays of shapes ({periods.size}, 3) and ({periods.size},) for "
                   f"{periods.size} periods", f"shapes {nets.shape} and {amplitudes.shape}")
    if not (np.all(np.isfinite(nets)) and np.all(np.isfinite(amplitudes)) and np.all(periods > 0)):
        raise fail("net_motion", owner, "finite motions and amplitudes, positive periods", "NaN, inf or a period <= 0")
    return _judge(periods, nets, amplitudes, *settings, time_unit)


def _settings(z, tolerance, min_period_ratio, min_cycles, owner: str) -> tuple:
    return (check_float(z, "z", owner, low=0, low_open=True), check_float(tolerance, "tolerance", owner, low=0),
            check_float(min_period_ratio, "min_period_ratio", owner, low=1, low_open=True),
            check_int(min_cycles, "min_cycles", owner, minimum=2))


def _judge(periods, nets, amplitudes, z, tolerance, min_period_ratio, min_cycles, time_unit) -> ModelClassVerdict:
    """The verdict from checked per-cycle arrays and settings (module notes)."""
    unit = f" {time_unit}" if time_unit else " (in the log's time unit)"
    if periods.size < 2 * min_cycles:
        return ModelClassVerdict(None, f"{periods.size} complete cycles: too few to compare periods")
    if periods.max() < min_period_ratio * periods.min():
        return ModelClassVerdict(None, f"every complete cycle lasts {periods.min():.3g}–{periods.max():.3g}{unit}: "
                                 "record cycles at another period (e.g. half the speed) to test whether the net "
                                 "motion per cycle depends on it")
    short = periods < np.sqrt(periods.min() * periods.max())
    groups = (short, ~short)
    if min(short.sum(), (~short).sum()) < min_cycles:
        return ModelClassVerdict(None, f"{short.sum()} short and {(~short).sum()} long cycles: fewer than "
                                 f"{min_cycles} in a group to compare")
    realised = [float(amplitudes[g].mean()) for g in groups]
    if abs(realised[0] - realised[1]) > tolerance * max(realised):
        return ModelClassVerdict(None, "the realised gait differs between the periods (RMS shape about its cycle "
                                 f"mean {realised[1]:.3g} at period {periods[~short].mean():.3g}{unit}, "
                                 f"{realised[0]:.3g} at {periods[short].mean():.3g}{unit}): the test needs the same "
                                 "gait at both (a robot that cannot follow the faster cycles? try a longer period)")
    progress = np.hypot(nets[:, 0], nets[:, 1])
    stats = {name: ([float(v[g].mean()) for g in groups], [_standard_error(v[g]) for g in groups])
             for name, v in (("progress", progress), ("rotation", nets[:, 2]))}
    verdict = dict(periods=tuple(float(periods[g].mean()) for g in groups),
                   progress=tuple(stats["progress"][0]), progress_se=tuple(stats["progress"][1]),
                   rotation=tuple(stats["rotation"][0]), rotation_se=tuple(stats["rotation"][1]),
                   n_cycles=tuple(int(g.sum()) for g in groups))
    scale = {"progress": tolerance * max(map(abs, stats["progress"][0])), "rotation": tolerance}
    differs, unresolved = [], []
    for name, (means, errors) in stats.items():
        gap, error = abs(means[0] - means[1]), float(np.hypot(*errors))
        if gap > z * error and gap > scale[name]:
            differs.append(f"{name} {means[1]:.4g} ± {errors[1]:.2g} per cycle at period "
                           f"{verdict['periods'][1]:.3g}{unit} but {means[0]:.4g} ± {errors[0]:.2g} at "
                           f"{verdict['periods'][0]:.3g}{unit} ({gap / error:.1f} standard errors)")
        elif gap + z * error > scale[name]:  # not shown to differ, nor shown to agree within the tolerance
            unresolved.append(f"{name} {means[1] - means[0]:+.2g} ± {error:.2g} per cycle")
    if differs:
        return ModelClassVerdict(False, "outside the model class: the net motion per cycle changes with the cycle "
                                 f"period ({'; '.join(differs)}); a principally kinematic body moves the same per "
                                 "cycle at any speed (inertia or rate-dependent forces?)", **verdict)
    if unresolved:
        return ModelClassVerdict(None, f"cannot tell: between periods {verdict['periods'][0]:.3g} and "
                                 f"{verdict['periods'][1]:.3g}{unit} the difference ({'; '.join(unresolved)}) is "
                                 f"within noise but not shown below {tolerance:g}; more cycles at each period would",
                                 **verdict)
    return ModelClassVerdict(True, f"the net motion per cycle agrees at periods {verdict['periods'][0]:.3g} and "
                             f"{verdict['periods'][1]:.3g}{unit} within {tolerance:g} ({z:g} standard errors), as "
                             "for a principally kinematic body", **verdict)


def _complete_cycles(log: Log, cycle: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Duration, net motion (body frame at its start) and realised gait size (RMS shape about the cycle's mean,
    joints averaged) of every cycle but each segment's first and last."""
    periods, nets, amplitudes = [], [], []
    for segment in np.unique(log.segment):
        mine = np.flatnonzero(log.segment == segment)
        time = log.time[mine]
        dt = np.append(np.diff(time), np.median(np.diff(time)) if time.size > 1 else 0.0)
        labels, velocity, shapes = cycle[mine], log.body_velocity[mine], log.shape[mine]
        for label in np.unique(labels)[1:-1]:
            rows = labels == label
            periods.append(float(dt[rows].sum()))
            nets.append(se2.displacement(velocity[rows], dt[rows]))
            amplitudes.append(shape_amplitude(shapes[rows]))
    return np.asarray(periods), np.asarray(nets).reshape(-1, 3), np.asarray(amplitudes)


def shape_amplitude(shape) -> float:
    """A cycle's realised gait size: RMS of its shape samples (n, d) about their mean, joints averaged."""
    shape = np.asarray(shape, dtype=float)
    return float(np.sqrt(((shape - shape.mean(axis=0)) ** 2).mean(axis=0)).mean())


def _standard_error(values: np.ndarray) -> float:
    return float(values.std(ddof=1) / np.sqrt(values.size))
