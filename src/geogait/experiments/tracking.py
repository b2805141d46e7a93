r"""Steering and path following with the adaptive model, a frozen model and the true connection.

For each swimmer and scenario (a path, at drag ratio 2 throughout or switched 2 → 4 mid-path without
telling the controllers), every trial runs the three controllers of
:class:`~geogait.control.PathTracker` on the same seeded perturbations and sensor noise (paired
trials): 10 warm-up cycles on the straight gait (the ceiling gait, the optimum of
:func:`~geogait.optimize.cached_ceiling`), then ``n_cycles`` cycles of path following. The
controllers turn by at most 1 rad per cycle, cut to what the swimmer's joint limits allow
(:func:`feasible_turn_limit`: 0.5 rad for the 3-link, 1.0 for the 5-link swimmer), with steering
families spaced 0.1 rad and heading weight 0.5. By default the adaptive and frozen controllers learn
the connection over shape space (:func:`tracking_model`), the perturbations δ have std 0.05 rad, and
the adaptive model forgets its evidence by 100 when a cycle's prediction surprise raises the alarm
(covariance resetting, ``PathTracker(change_forgetting=100)``); ``model="window"``,
``perturbation=0.15`` and ``change_forgetting=1`` give the paper's window model without covariance resetting.

Paths are scaled by the swimmer's own step ℓ (true net translation per cycle of the straight gait at
drag ratio 2: 0.10 body lengths for the 3-link, 0.20 for the 5-link swimmer), so every swimmer gets
the same turning demand per cycle: a line started ``3 ℓ`` to its left, a circle of radius ``10 ℓ``
(0.1 rad per cycle), a figure-eight of size ``10 ℓ`` and a waypoint polyline (a 15 ℓ × 10 ℓ
rectangle with sharp corners). Errors are in body lengths (every swimmer has length 1).

Reported per swimmer, path, environment and controller: cross-track error |e| per cycle and heading
error |χ − ψ| per cycle (course of the cycle's chord against the path tangent), mean and 95th
percentile over cycles and trials, and per trial (:func:`trial_stats`): the adaptive / true ratio of
mean cross-track error of every trial, its worst trial and the share of trials within 1.5×. For the
drag change, each controller's mean error over fixed windows after the change (cycles 0–9 and 10–29
after it, :data:`DRAG_WINDOWS`), pooled and per trial; and the lenient older metrics: the cycles
until the adaptive controller's trial-mean error is back within 1.5× its level over the 10 cycles
before the change, and the cycles until it stays below the frozen model's.

A path of the user's own joins the built-in ones as the path ``"csv"`` (``TrackingConfig(path_file=...)``,
a waypoints CSV read by :meth:`~geogait.control.ReferencePath.from_csv`, in body lengths, not scaled).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pandas as pd

from .._defaults import TRACKING_WARMUP_TURNS
from .._docs import fill_doc
from .._validation import check_float, check_int, fail
from ..control import (
    CONTROLLERS,
    EXPLORATION,
    TURN_SPACING,
    AdaptiveExploration,
    ModelMotion,
    PathTracker,
    ReferencePath,
    TrueMotion,
    max_feasible_turn,
    max_step_family,
    steering_family,
)
from ..gaits import Perturbation
from ..models import AdaptiveGaitModel, ShapeSpaceModel
from ..optimize import cached_ceiling
from ..plotting import plt, save_figure
from ..simulate import DragRatioSchedule, SwimmerStream, cycle_displacement, simulate
from ..systems import PurcellSwimmer
from ._common import ExperimentResult, check_fraction, child_seeds, run_sweep
from ._config import SweepConfig

__all__ = ["TrackingConfig", "TrackingResult", "tracking_trials", "run_tracking", "tracking_summary",
           "tracking_path", "straight_gait", "plot_tracking", "plot_steering_family", "steering_families",
           "drag_change_metrics", "plot_reference", "RECOVERY_FACTOR", "feasible_turn_limit", "TURN_SPACING",
           "plot_exploration", "plot_exploration_curves", "tracking_model", "TRACKING_MODELS", "CONTROLLER_STYLE",
           "controller_style", "mark_change", "DRAG_WINDOWS", "drag_change_cycle", "CUSTOM_PATH", "trial_stats",
           "per_trial_ratios", "track_trials"]

_OWNER = "TrackingConfig"
PATHS = ("line", "circle", "figure8", "waypoints")
CUSTOM_PATH = "csv"
"""Name of the user's own path (``TrackingConfig.path_file``) in scenarios, frames and summaries."""
DRAG_WINDOWS = ((0, 10), (10, 30))
"""Windows of cycles after the drag change, ``[start, stop)`` counted from the change, over which each
controller's mean |cross-track error| is reported (``"cycles_0_9"``, ``"cycles_10_29"``)."""
CONTROLLER_STYLE = {
    "adaptive": {"color": "tab:red", "linestyle": "-", "marker": "o", "ms": 2.5, "mfc": "tab:red", "alpha": 1.0,
                 "zorder": 4},
    "frozen": {"color": "tab:blue", "linestyle": "--", "marker": "s", "ms": 5.0, "mfc": "none", "alpha": 0.9,
               "zorder": 3},
    "true": {"color": "0.15", "linestyle": ":", "marker": "x", "ms": 5.0, "mfc": "none", "alpha": 0.6,
             "zorder": 2},
}
"""One style per controller (colour, line, marker, size, fill, alpha, draw order), used by every
tracking figure (``path.png``, ``family.png``, ``tracking.png``): the true controller is drawn first and
lightest, the frozen one as hollow squares around the adaptive controller's small dots, so that no
controller's markers hide another's."""
RECOVERY_FACTOR = 1.5
"""Recovered: the adaptive trial-mean error is back within this factor of its pre-change level."""
PRE_CHANGE_CYCLES = 10
TRACKING_MODELS = ("window", "shape")


@dataclass(frozen=True)
class TrackingConfig(SweepConfig):
    """Settings of the path-following experiment (the one place its defaults live).

    Parameters
    ----------
    links : tuple of int
        Swimmers (number of links).
    n_trials : int
        Paired trials per swimmer (each runs every scenario and controller).
    paths : tuple of str
        Paths followed at constant drag ratio (``line``, ``circle``, ``figure8``, ``waypoints``, and
        ``csv`` for ``path_file``).
    drag_paths : tuple of str
        Paths followed through the drag-ratio change (the same names).
    drag_ratios : tuple of float
        Drag ratio before and after the change.
    n_cycles : int
        Tracking cycles per run.
    change_cycle : int
        Tracking cycle at which the drag ratio changes.
    warmup_cycles, warmup_turns : int
        Straight-gait cycles, then turning cycles (the model's steering gaits, :class:`~geogait.control.PathTracker`),
        before tracking: the frozen model's whole training.
    sensor_noise, perturbation : float
        Measurement noise (fraction of RMS) and perturbation δ std (rad) of ``exploration="fixed"``.
    path_scale : float
        Circle radius, figure-eight size and rectangle height in steps ℓ of the straight gait.
    line_offset : float
        Initial offset from the line, in steps ℓ.
    turn_limit : float
        Largest |turn| per cycle (rad) of the steering family, cut per swimmer to what its joint limits
        allow (:func:`feasible_turn_limit`): 0.5 rad for the 3-link, 1.0 for the 5-link swimmer.
    heading_weight : float
        Heading weight of :class:`~geogait.control.PathTracker`.
    exploration : {"fixed", "adaptive"}
        ``"fixed"``: δ std ``perturbation`` throughout. ``"adaptive"``: sized every cycle by
        :class:`~geogait.control.AdaptiveExploration` from σ_high = ``exploration_high`` down to σ_low =
        ``exploration_low``, driven by the adaptive controller's prediction residual; the frozen and
        true controllers of the same trial replay the adaptive run's schedule, so all three run with
        the same perturbations in every cycle (without an adaptive controller each sizes its own).
    exploration_low, exploration_high : float
        σ_low and σ_high (rad) of the adaptive exploration.
    model : {"window", "shape"}
        Learning model of the adaptive and frozen controllers (:func:`tracking_model`): the local window
        model about the straight gait, or the connection over shape space.
    change_forgetting : float >= 1
        :class:`~geogait.control.PathTracker`'s covariance resetting at a surprise alarm (1: none).
    controllers : tuple of str
    seed : int
        Root seed; swimmer i uses ``seed + 1000 i``.
    chunk_size : int
        Trials per runner chunk.
    path_file : str, optional
        A waypoints CSV (columns x, y, body lengths; a last row equal to the first closes it), the path
        named ``"csv"`` in ``paths`` and ``drag_paths``.
    """

    links: tuple[int, ...] = (3, 5)
    n_trials: int = 20
    paths: tuple[str, ...] = PATHS
    drag_paths: tuple[str, ...] = ("line", "circle")
    drag_ratios: tuple[float, float] = (2.0, 4.0)
    n_cycles: int = 60
    change_cycle: int = 30
    warmup_cycles: int = 10
    warmup_turns: int = TRACKING_WARMUP_TURNS
    sensor_noise: float = 0.1
    perturbation: float = 0.05
    path_scale: float = 10.0
    line_offset: float = 3.0
    turn_limit: float = 1.0
    heading_weight: float = 0.5
    exploration: str = "fixed"
    exploration_low: float = 0.05
    exploration_high: float = 0.15
    model: str = "shape"
    change_forgetting: float = 100.0
    controllers: tuple[str, ...] = CONTROLLERS
    seed: int = 0
    chunk_size: int = 1
    path_file: str | None = None

    #: :meth:`quick`: 3-link only, 2 trials, line and circle (drag change on the circle), 16 cycles: seconds.
    QUICK = {"links": (3,), "n_trials": 2, "paths": ("line", "circle"), "drag_paths": ("circle",), "n_cycles": 16,
             "change_cycle": 8, "warmup_cycles": 6}

    def _check_fields(self) -> None:
        if not self.links:
            raise fail("links", _OWNER, "a non-empty tuple of link counts", self.links)
        for n_links in self.links:
            check_int(n_links, "links", _OWNER, minimum=3)  # (one joint cannot steer: the scallop theorem)
        check_int(self.n_trials, "n_trials", _OWNER, minimum=1)
        for name in ("paths", "drag_paths"):
            for path in getattr(self, name):
                if path not in PATHS + (CUSTOM_PATH,):
                    raise fail(name, _OWNER, "paths among " + ", ".join(PATHS + (CUSTOM_PATH,)), path)
                if path == CUSTOM_PATH and self.path_file is None:
                    raise fail(name, _OWNER, f"paths whose {CUSTOM_PATH!r} comes with a 'path_file'", path)
        if not self.paths and not self.drag_paths:
            raise fail("paths", _OWNER, "at least one path (in paths or drag_paths)", self.paths)
        if len(self.drag_ratios) != 2:
            raise fail("drag_ratios", _OWNER, "two drag ratios (before, after)", self.drag_ratios)
        for value in self.drag_ratios:
            check_float(value, "drag_ratios", _OWNER, low=1e-6, high=1e6)  # (the swimmer's own bounds)
        n_cycles = check_int(self.n_cycles, "n_cycles", _OWNER, minimum=2)
        change = check_int(self.change_cycle, "change_cycle", _OWNER, minimum=1)
        if change >= n_cycles:
            raise fail("change_cycle", _OWNER, f"below n_cycles = {n_cycles}", change)
        check_int(self.warmup_cycles, "warmup_cycles", _OWNER, minimum=1)
        check_int(self.warmup_turns, "warmup_turns", _OWNER, minimum=0)
        check_fraction(self.sensor_noise, "sensor_noise", _OWNER)
        check_fraction(self.perturbation, "perturbation", _OWNER)
        check_float(self.path_scale, "path_scale", _OWNER, low=0, low_open=True)
        check_float(self.line_offset, "line_offset", _OWNER)
        check_float(self.turn_limit, "turn_limit", _OWNER, low=TURN_SPACING, high=np.pi)
        check_float(self.heading_weight, "heading_weight", _OWNER, low=0)
        if self.exploration not in EXPLORATION:
            raise fail("exploration", _OWNER, "one of " + ", ".join(EXPLORATION), self.exploration)
        high = check_fraction(self.exploration_high, "exploration_high", _OWNER)
        check_float(self.exploration_low, "exploration_low", _OWNER, low=0, high=high, low_open=True)
        if self.model not in TRACKING_MODELS:
            raise fail("model", _OWNER, "one of " + ", ".join(TRACKING_MODELS), self.model)
        check_float(self.change_forgetting, "change_forgetting", _OWNER, low=1)
        if not self.controllers or any(c not in CONTROLLERS for c in self.controllers):
            raise fail("controllers", _OWNER, "controllers among " + ", ".join(CONTROLLERS), self.controllers)

    def scenarios(self) -> list[tuple[str, str]]:
        """(path, environment) pairs in run order; environment ``"constant"`` or ``"change"``."""
        return [(p, "constant") for p in self.paths] + [(p, "change") for p in self.drag_paths]


def straight_gait(n_links: int):
    """The swimmer (drag ratio 2), its straight gait (the ceiling gait) and that gait's step ℓ.

    Returns
    -------
    system : PurcellSwimmer
    gait : FourierGait
    step : float
        True net translation per cycle (body lengths).
    """
    system = PurcellSwimmer(check_int(n_links, "n_links", "straight_gait", minimum=2))
    gait = cached_ceiling(system).gait
    return system, gait, float(np.hypot(*cycle_displacement(system, gait)[:2]))


@lru_cache(maxsize=8)
def feasible_turn_limit(n_links: int, upper: float = 1.0) -> float:
    """Largest multiple of :data:`TURN_SPACING` up to ``upper`` that the straight swimmer (drag ratio
    2, true connection) turns per cycle in both directions with a steering gait within the joint
    limits; the tracker's families stop there (solves beyond the joint limits fail, slowly). The same
    rule as :class:`~geogait.control.PathTracker`'s default ``turn_limit=None``, here with the true
    connection so that every controller gets the same limit."""
    system, gait, _ = straight_gait(n_links)
    upper = check_float(upper, "upper", "feasible_turn_limit", low=TURN_SPACING, high=np.pi)
    pose = cycle_displacement(system, gait)
    return max_feasible_turn(TrueMotion(system), gait, direction=float(np.arctan2(pose[1], pose[0])), upper=upper)


def tracking_model(name: str, *, symmetric: bool = True):
    """The learning model of the tracking controllers by name: None for ``"window"`` (PathTracker's own
    :class:`~geogait.models.AdaptiveGaitModel` about the straight gait, λ 0.99 per window update) or, for
    ``"shape"``, a :class:`~geogait.models.ShapeSpaceModel` with λ 0.999 per sample (a memory of about 10
    cycles of 100 samples): of degree 3 with the mirror and front–back symmetries of the built-in
    swimmers (``"mirror+reversal"``) when ``symmetric``, else (a robot's symmetries are unknown) of
    degree 2 without constraints. Degree 3 without symmetry has 4× the weights and, learning only around
    the gaits it runs, extrapolates poorly to the steering gaits it has not run; degree 2 extrapolates
    less wildly."""
    if name not in TRACKING_MODELS:
        raise fail("model", "tracking_model", "one of " + ", ".join(TRACKING_MODELS), name)
    if name == "window":
        return None
    if symmetric:
        return ShapeSpaceModel(degree=3, symmetry="mirror+reversal", forgetting_factor=0.999)
    return ShapeSpaceModel(degree=2, forgetting_factor=0.999)


def tracking_path(kind: str, step: float, scale: float = 10.0) -> ReferencePath:
    """A built-in path scaled by the step ℓ: line, circle (radius ``scale ℓ``), figure-eight (size
    ``scale ℓ``) or waypoints (a ``1.5 scale ℓ × scale ℓ`` rectangle, counter-clockwise)."""
    size = scale * step
    if kind == "waypoints":
        corners = np.array([[0, 0], [1.5, 0], [1.5, 1], [0, 1], [0, 0.02]]) * size
        return ReferencePath.waypoints(corners, name="waypoints")
    return ReferencePath.named(kind, size)


def tracking_trials(trial_indices, seeds, *, n_links: int, scenarios, drag_ratios, n_cycles: int, change_cycle: int,
                    warmup_cycles: int, sensor_noise: float, perturbation: float, path_scale: float,
                    line_offset: float, turn_limit: float, heading_weight: float, controllers,
                    warmup_turns: int = TRACKING_WARMUP_TURNS, exploration: str = "fixed",
                    exploration_low: float = 0.05, exploration_high: float = 0.15,
                    model: str = "shape", change_forgetting: float = 100.0,
                    custom_path: ReferencePath | None = None) -> pd.DataFrame:
    """Runner trial function: every scenario and controller for each trial (paired seeds).

    Parameters
    ----------
    trial_indices : sequence of int
        Trial indices of the chunk.
    seeds : sequence of numpy.random.SeedSequence
        One seed per trial, shared by its controllers (paired comparison).
    n_links : int
        Links of the Purcell swimmer.
    scenarios : sequence of (path, environment)
        Paths to follow, each at ``"constant"`` drag or through the ``"change"``.
    drag_ratios, n_cycles, change_cycle, warmup_cycles, warmup_turns, sensor_noise, perturbation, path_scale,
    line_offset
        As in :class:`TrackingConfig`.
    turn_limit, heading_weight, controllers
        As in :class:`TrackingConfig` (the turn limit is cut by :func:`feasible_turn_limit`).
    exploration, exploration_low, exploration_high, model, change_forgetting
        As in :class:`TrackingConfig`.
    custom_path : ReferencePath, optional
        The path named ``"csv"`` in ``scenarios`` (not scaled, no offset).

    Returns
    -------
    pandas.DataFrame
        One row per trial × scenario × controller × cycle: ``trial``, ``links``, ``path``,
        ``environment``, ``controller``, ``cycle``, ``cross_track``, ``heading_error``, ``x``, ``y``,
        ``turn_command``, ``predicted_turn``, ``true_turn``, ``measured_turn``, ``gamma``,
        ``drag_ratio``, ``perturbation_std``, ``surprise``.
    """
    system, gait, step = straight_gait(n_links)
    limit = feasible_turn_limit(n_links, turn_limit)
    settings = dict(turn_limit=limit, heading_weight=heading_weight,  # turns spaced 0.1 rad (n_turns=None)
                    warmup_cycles=warmup_cycles, warmup_turns=warmup_turns, model=tracking_model(model),
                    change_forgetting=change_forgetting)
    columns = ["cycle", "cross_track", "heading_error", "x", "y", "turn_command", "predicted_turn", "true_turn",
               "measured_turn", "gamma", "drag_ratio", "perturbation_std", "surprise"]
    rule = AdaptiveExploration(low=exploration_low, high=exploration_high)
    start_std = perturbation if exploration == "fixed" else exploration_high
    order = sorted(controllers, key=lambda c: c != "adaptive")  # the adaptive run sizes the exploration
    frames = []
    for kind, environment in scenarios:
        # each scenario draws its trials from a key of its own, so a run of some scenarios repeats the
        # trials of the full run (keys 0-3 at constant drag, 4-7 through the change, in PATHS order)
        # (the user's path: keys 8 and 9)
        if kind == CUSTOM_PATH:
            if custom_path is None:
                raise fail("custom_path", "tracking_trials", f"a ReferencePath for the scenario {kind!r}", None)
            key, path, offset = 2 * len(PATHS) + (environment == "change"), custom_path, 0.0
        else:
            key = PATHS.index(kind) + (len(PATHS) if environment == "change" else 0)
            path = tracking_path(kind, step, path_scale)
            offset = line_offset * step if kind == "line" else 0.0
        for trial, seed in zip(trial_indices, child_seeds(seeds, key), strict=True):
            sizes = "fixed" if exploration == "fixed" else rule
            for controller in order:
                tracker = PathTracker(controller=controller, exploration=sizes, **settings)
                schedule = (DragRatioSchedule(system, tuple(drag_ratios), tracker.warmup_length + change_cycle)
                            if environment == "change" else None)
                robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(start_std),
                                      sensor_noise=sensor_noise, environment=schedule, seed=seed)
                result = tracker.run(robot, path, n_cycles, start_offset=offset)
                if controller == "adaptive" and exploration != "fixed":
                    sizes = result.perturbation_std  # replayed by the frozen and true controllers
                frames.append(result.log[columns].assign(trial=int(trial), links=n_links, path=kind,
                                                         environment=environment, controller=controller))
    return pd.concat(frames, ignore_index=True)


def track_trials(trial_indices, seeds, *, n_links: int, path: ReferencePath, n_cycles: int, drag_ratios,
                 change_cycle: int, warmup_cycles: int, sensor_noise: float, perturbation: float,
                 controllers, tracker_options: dict, start_offset: float = 0.0, exploration=None) -> pd.DataFrame:
    """Runner trial function of ``geogait track --trials``: every controller on each trial's seed.

    Parameters
    ----------
    trial_indices : sequence of int
    seeds : sequence of numpy.random.SeedSequence
        One per trial, shared by all its controllers (paired trials: the same warm-up, perturbations
        and noise).
    n_links : int
    path : ReferencePath
    n_cycles, change_cycle, warmup_cycles : int
        Tracking cycles, the tracking cycle of the drag change, warm-up cycles.
    drag_ratios : tuple of float
        One drag ratio, or two (before and after ``change_cycle``).
    sensor_noise, perturbation : float
        Noise (fraction of RMS) and starting δ std (rad).
    controllers : sequence of str
    tracker_options : dict
        Keyword arguments of :class:`~geogait.control.PathTracker` shared by every controller.
    start_offset : float
        Initial offset to the left of the path (body lengths).
    exploration : AdaptiveExploration, optional
        δ sized online by the adaptive controller and replayed by the others; fixed when None.

    Returns
    -------
    pandas.DataFrame
        The controllers' logs (:class:`~geogait.control.PathTracker`'s columns) with ``trial`` and
        ``controller``.
    """
    system, gait, _ = straight_gait(n_links)
    system = system.with_drag_ratio(drag_ratios[0])
    frames = []
    for trial, seed in zip(trial_indices, seeds, strict=True):
        sizes = "fixed" if exploration is None else exploration
        for controller in sorted(controllers, key=lambda c: c != "adaptive"):  # the adaptive run sizes δ
            tracker = PathTracker(controller=controller, exploration=sizes, warmup_cycles=warmup_cycles,
                                  **tracker_options)
            schedule = (DragRatioSchedule(system, tuple(drag_ratios), tracker.warmup_length + change_cycle)
                        if len(drag_ratios) == 2 else None)
            robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(perturbation),
                                  sensor_noise=sensor_noise, environment=schedule, seed=seed)
            result = tracker.run(robot, path, n_cycles, start_offset=start_offset)
            if controller == "adaptive" and exploration is not None:
                sizes = result.perturbation_std
            frames.append(result.log.assign(trial=int(trial), controller=controller))
    return pd.concat(frames, ignore_index=True)


@fill_doc
@dataclass(frozen=True)
class TrackingResult(ExperimentResult):
    """Long-format per-cycle logs of every trial (see :func:`tracking_trials`).

    Parameters
    ----------
    %(result_fields)s
    """

    COLUMNS = ("trial", "links", "path", "environment", "controller", "cycle", "cross_track", "heading_error", "x",
               "y", "turn_command", "predicted_turn", "true_turn", "measured_turn", "gamma", "drag_ratio",
               "perturbation_std", "surprise")

    def summary(self) -> dict:
        """Headline numbers (:func:`tracking_summary`)."""
        change = None if self.config is None else self.config.change_cycle
        return tracking_summary(self.frame, change_cycle=change)

    def plot(self, path, references: dict | None = None):
        """Draw the figure to ``path`` (:func:`plot_tracking`); ``references`` maps a path name to its
        :class:`~geogait.control.ReferencePath` (default: the built-ins, and ``path_file`` as ``"csv"``)."""
        if references is None and self.config is not None and self.config.path_file is not None:
            references = {CUSTOM_PATH: ReferencePath.from_csv(self.config.path_file)}
        change = None if self.config is None else self.config.change_cycle
        plot_tracking(self.frame, path, change_cycle=change, references=references)
        return path


@fill_doc
def run_tracking(config: TrackingConfig | None = None, *, jobs: int = 1, scheduler=None,
                 progress: bool = True) -> TrackingResult:
    """Run the path-following experiment for every swimmer of ``config``; see the module docstring.

    Parameters
    ----------
    config : TrackingConfig, optional
        Default ``TrackingConfig()``: 20 paired trials of the 3- and 5-link swimmers.
    %(sweep)s

    Returns
    -------
    TrackingResult
    """
    config = (config or TrackingConfig()).validate()
    frames, wall, workers = [], 0.0, 1
    custom = None if config.path_file is None else ReferencePath.from_csv(config.path_file)
    for index, n_links in enumerate(config.links):
        options = dict(n_links=n_links, scenarios=config.scenarios(), drag_ratios=config.drag_ratios,
                       n_cycles=config.n_cycles, change_cycle=config.change_cycle,
                       warmup_cycles=config.warmup_cycles, warmup_turns=config.warmup_turns,
                       sensor_noise=config.sensor_noise,
                       perturbation=config.perturbation, path_scale=config.path_scale,
                       line_offset=config.line_offset, turn_limit=config.turn_limit,
                       heading_weight=config.heading_weight, controllers=config.controllers,
                       exploration=config.exploration, exploration_low=config.exploration_low,
                       exploration_high=config.exploration_high,
                       model=config.model, change_forgetting=config.change_forgetting, custom_path=custom)
        frame, seconds, workers = run_sweep(tracking_trials, config.n_trials, options, seed=config.seed + 1000 * index,
                                            chunk_size=config.chunk_size, jobs=jobs, scheduler=scheduler,
                                            progress=progress, description=f"{n_links}-link tracking")
        frames.append(frame)
        wall += seconds
    frame = pd.concat(frames, ignore_index=True)[list(TrackingResult.COLUMNS)]
    return TrackingResult(frame=frame, config=config, wall_time_s=wall, n_workers=workers)


def error_stats(group: pd.DataFrame) -> dict:
    """Mean and 95th percentile of |cross-track| and |heading error| over the rows of ``group``."""
    out = {}
    for column in ("cross_track", "heading_error"):
        if column in group:
            values = np.abs(group[column].to_numpy())
            out |= {f"{column}_mean": float(values.mean()), f"{column}_p95": float(np.percentile(values, 95))}
    return out


def _mean_curve(group: pd.DataFrame) -> pd.Series:
    return group.assign(error=group["cross_track"].abs()).groupby("cycle")["error"].mean()


def _window_key(window) -> str:
    return f"cycles_{window[0]}_{window[1] - 1}"


def trial_stats(frame: pd.DataFrame, change_cycle: int | None = None) -> pd.DataFrame:
    """Error statistics of every trial and controller of a long-format tracking frame.

    Parameters
    ----------
    frame : pandas.DataFrame
        Columns ``trial``, ``controller``, ``cycle``, ``cross_track``, ``heading_error`` and any of
        ``links``, ``path``, ``environment`` (the groups kept apart).
    change_cycle : int, optional
        Tracking cycle of the drag change: adds each trial's mean |e| over the :data:`DRAG_WINDOWS`
        after it (``cycles_0_9_after``, ``cycles_10_29_after``; NaN where the run did not reach the
        window's first cycle; a window cut by the end of the run averages the cycles it has). For the
        rows of ``environment == "constant"`` the windows stay NaN.

    Returns
    -------
    pandas.DataFrame
        One row per group, trial and controller: the group columns, ``trial``, ``controller``,
        ``cycles``, ``cross_track_mean``, ``cross_track_p95``, ``heading_error_mean``,
        ``heading_error_p95`` and, with ``change_cycle``, the windows.
    """
    keys = [c for c in ("links", "path", "environment") if c in frame.columns] + ["trial", "controller"]
    rows = []
    for key, group in frame.groupby(keys, sort=True):
        row = dict(zip(keys, key, strict=True)) | {"cycles": len(group)} | error_stats(group)
        if change_cycle is not None:
            error = group["cross_track"].abs().to_numpy()
            after = group["cycle"].to_numpy() - change_cycle
            changed = row.get("environment", "change") == "change"
            for window in DRAG_WINDOWS:
                inside = (after >= window[0]) & (after < window[1])
                row[_window_key(window) + "_after"] = float(error[inside].mean()) if changed and inside.any() \
                    else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def per_trial_ratios(stats: pd.DataFrame, column: str = "cross_track_mean", numerator: str = "adaptive",
                     denominator: str = "true", factor: float = RECOVERY_FACTOR) -> dict:
    """The ratio ``numerator / denominator`` of ``column`` trial by trial (paired trials), its worst
    trial and the share of trials within ``factor``.

    Parameters
    ----------
    stats : pandas.DataFrame
        Rows of :func:`trial_stats` for one group (one swimmer, path and environment).
    column : str
    numerator, denominator : str
        Controllers.
    factor : float

    Returns
    -------
    dict
        ``ratios`` (list, trial order), ``trials`` (their indices), ``worst`` (largest ratio),
        ``worst_trial``, ``median``, ``share_within`` (fraction of trials with ratio <= ``factor``),
        ``factor``, ``share_below_one`` (fraction with ratio < 1); empty when a controller is missing.
    """
    table = stats.pivot_table(index="trial", columns="controller", values=column, aggfunc="first")
    if numerator not in table or denominator not in table:
        return {}
    ratios = (table[numerator] / table[denominator]).dropna()
    if not len(ratios):
        return {}
    worst = int(ratios.idxmax())
    return {"ratios": [float(v) for v in ratios], "trials": [int(t) for t in ratios.index],
            "worst": float(ratios.max()), "worst_trial": worst, "median": float(ratios.median()),
            "share_within": float(np.mean(ratios.to_numpy() <= factor)), "factor": factor,
            "share_below_one": float(np.mean(ratios.to_numpy() < 1))}


def _drag_windows(frame: pd.DataFrame, change_cycle: int) -> dict:
    """Mean |e| per controller over each window after the change: pooled over trials, and per trial
    the adaptive / true and adaptive / frozen ratios."""
    stats = trial_stats(frame.assign(environment="change"), change_cycle)
    out = {}
    for window in DRAG_WINDOWS:
        column = _window_key(window) + "_after"
        entry = {}
        for controller, part in stats.groupby("controller"):
            values = part[column].dropna()
            entry[controller] = float(values.mean()) if len(values) else None
            if not len(values):
                entry[f"{controller}_null_reason"] = (f"the run ended before cycle {change_cycle + window[0]}, "
                                                      "the window's first after the change")
        for other in ("true", "frozen"):
            ratios = per_trial_ratios(stats.dropna(subset=[column]), column, "adaptive", other)
            if ratios:
                entry[f"adaptive_over_{other}_per_trial"] = ratios
        out[column] = entry
    return out


def drag_change_metrics(frame: pd.DataFrame, change_cycle: int) -> dict:
    """Recovery of the adaptive controller after the drag change (one swimmer and path).

    Returns
    -------
    dict
        ``pre_change_level`` (adaptive trial-mean |e| over the 10 cycles before the change),
        ``cycles_to_recover`` (cycles from the change until the 3-cycle running mean of the adaptive
        trial-mean |e|, once it has left the band of 1.5× that level, is back within it; 0 if it never
        left, None if it never came back), ``cycles_until_below_frozen``
        (first c such that the adaptive mean |e| over cycles ``change + c`` to the end is below the
        frozen model's over the same cycles; None if never), and per controller the mean |e| over
        the 10 cycles after the change and over the rest; ``windows``: per window of
        :data:`DRAG_WINDOWS` (``cycles_0_9_after``, ``cycles_10_29_after``) each controller's mean |e|
        pooled over trials, and per trial the ratios adaptive / true and adaptive / frozen
        (:func:`per_trial_ratios`: worst trial, share within 1.5×). Every None comes with a ``<key>_null_reason``;
        a run that ended before the change has ``change_reached`` False and no recovery numbers.
    """
    curves = {c: _mean_curve(g) for c, g in frame.groupby("controller")}
    out = {}
    last = int(max(curve.index.max() for curve in curves.values())) if curves else -1
    out["change_reached"] = last >= change_cycle
    if last < change_cycle:
        reason = f"the run ended at cycle {last}, before the change at cycle {change_cycle}"
        for key in ("cycles_to_recover", "cycles_until_below_frozen",
                    *(f"{c}_mean_first_10_after" for c in curves), *(f"{c}_mean_after_10" for c in curves)):
            out[key], out[f"{key}_null_reason"] = None, reason
        return out
    if "adaptive" in curves:
        adaptive = curves["adaptive"]
        before = adaptive[(adaptive.index >= change_cycle - PRE_CHANGE_CYCLES) & (adaptive.index < change_cycle)]
        level = float(before.mean())
        after = adaptive[adaptive.index >= change_cycle].rolling(3, min_periods=1).mean()
        high = after.to_numpy() > RECOVERY_FACTOR * level
        out["pre_change_level"] = level
        if not high.any():  # the change never took the error out of the band
            out["cycles_to_recover"] = 0
        else:
            first = int(np.argmax(high))
            back = np.flatnonzero(~high[first:])
            out["cycles_to_recover"] = int(after.index[first + back[0]] - change_cycle) if back.size else None
            if not back.size:
                out["cycles_to_recover_null_reason"] = (f"the error had not come back within {RECOVERY_FACTOR}× the "
                                                        "pre-change level by the end of the run")
        if "frozen" in curves:
            frozen = curves["frozen"]
            below = None
            last = int(adaptive.index.max())
            for c in range(0, last - change_cycle + 1):
                window = (adaptive.index >= change_cycle + c)
                if adaptive[window].mean() < frozen[frozen.index >= change_cycle + c].mean():
                    below = c
                    break
            out["cycles_until_below_frozen"] = below
            if below is None:
                out["cycles_until_below_frozen_null_reason"] = "the adaptive error never fell below the frozen one's"
    out["windows"] = _drag_windows(frame, change_cycle)
    for controller, curve in curves.items():
        soon = curve[(curve.index >= change_cycle) & (curve.index < change_cycle + 10)]
        late = curve[curve.index >= change_cycle + 10]
        out[f"{controller}_mean_first_10_after"] = float(soon.mean())
        out[f"{controller}_mean_after_10"] = float(late.mean()) if len(late) else None
        if not len(late):
            out[f"{controller}_mean_after_10_null_reason"] = "fewer than 10 cycles after the change"
    return out


def drag_change_cycle(frame: pd.DataFrame) -> int:
    """The cycle at which the drag ratio changes in the ``frame``'s "change" runs, read from its ``drag_ratio``
    column (a frame read back from CSV has no config); half the run where no ratio changes."""
    changed = frame[frame["environment"] == "change"]
    if not changed.empty:
        first = changed.loc[changed["cycle"] == changed["cycle"].min(), "drag_ratio"].iloc[0]
        later = changed.loc[~np.isclose(changed["drag_ratio"], first), "cycle"]
        if not later.empty:
            return int(later.min())
    return int(frame["cycle"].max() + 1) // 2


def tracking_summary(frame: pd.DataFrame, change_cycle: int | None = None) -> dict:
    """Headline numbers per swimmer, path and environment of the long-format ``frame``: error statistics
    per controller, the adaptive / true ratio of mean cross-track error pooled and per trial (its worst
    trial, the share of trials within 1.5×) and the goals; drag-change windows and recovery after
    ``change_cycle`` (default: where the frame's drag ratio changes, :func:`drag_change_cycle`)."""
    if change_cycle is None:
        change_cycle = drag_change_cycle(frame)
    summary = {}
    for (n_links, kind, environment), group in frame.groupby(["links", "path", "environment"], sort=False):
        entry = {c: error_stats(g) for c, g in group.groupby("controller")}
        if "adaptive" in entry and "true" in entry:
            ratio = entry["adaptive"]["cross_track_mean"] / entry["true"]["cross_track_mean"]
            entry["adaptive_over_true_cross_track"] = ratio
            entry["goal_within_1.5x_true"] = bool(ratio <= 1.5)
            per_trial = per_trial_ratios(trial_stats(group))
            entry["adaptive_over_true_per_trial"] = per_trial
            entry["adaptive_over_true_worst_trial"] = per_trial["worst"]
            entry["share_trials_within_1.5x_true"] = per_trial["share_within"]
        adaptive = group[group["controller"] == "adaptive"]
        if len(adaptive):
            entry["adaptive_gamma_final_median"] = float(
                adaptive[adaptive["cycle"] == adaptive["cycle"].max()]["gamma"].median())
        if environment == "change":
            metrics = drag_change_metrics(group, change_cycle)
            entry["drag_change"] = metrics
            if "cycles_until_below_frozen" in metrics:
                below = metrics["cycles_until_below_frozen"]
                entry["goal_below_frozen_within_10"] = bool(below is not None and below <= 10)
        summary[f"{int(n_links)}-link {kind} {environment}"] = entry
    return summary


def controller_style(controller: str) -> dict:
    """Matplotlib keywords of a controller's line and markers (:data:`CONTROLLER_STYLE`)."""
    style = CONTROLLER_STYLE.get(controller, {"color": "C2", "linestyle": "-", "marker": ".", "ms": 3.0,
                                              "mfc": "C2", "alpha": 1.0, "zorder": 3})
    return dict(style)


def plot_reference(ax, reference: ReferencePath, positions=None):
    """The reference path as a wide grey band. A closed path is drawn whole; an open one is cut to 1
    body length around ``positions`` ``(n, 2)`` (a line 100 body lengths long would hide the robot)."""
    points = reference.resampled(int(np.clip(reference.length / 0.01, 600, 20_000)))  # bounded, however long
    if reference.closed:
        points = np.vstack([points, points[:1]])
    elif positions is not None and len(positions):
        low, high = np.min(positions, axis=0) - 1.0, np.max(positions, axis=0) + 1.0
        points = np.where(np.all((points >= low) & (points <= high), axis=1)[:, None], points, np.nan)
    ax.plot(points[:, 0], points[:, 1], color="0.6", lw=4, alpha=0.5, label="reference", zorder=1)
    return ax


def plot_paths(ax, frame: pd.DataFrame, n_links: int, kind: str, environment: str, trial: int,
               reference: ReferencePath | None = None):
    """One trial's boundary positions (cycle markers) of each controller over the reference path
    (default: the built-in path ``kind``; none drawn for the user's ``"csv"`` path without ``reference``)."""
    _, _, step = straight_gait(n_links)
    group = frame[(frame["links"] == n_links) & (frame["path"] == kind) & (frame["environment"] == environment)
                  & (frame["trial"] == trial)]
    if reference is None and kind in PATHS:
        reference = tracking_path(kind, step)
    if reference is not None:
        plot_reference(ax, reference, group[["x", "y"]].to_numpy())
    for controller, part in group.groupby("controller"):
        style = controller_style(controller)
        ax.plot(part["x"], part["y"], lw=1, label=controller, **style)
    ax.set_aspect("equal", adjustable="datalim")
    name = f"{kind} ({reference.name})" if kind == CUSTOM_PATH and reference is not None else kind
    title = f"{n_links}-link {name}" + (" (k 2→4)" if environment == "change" else "")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (body lengths)", fontsize=8)
    ax.set_ylabel("y (body lengths)", fontsize=8)
    ax.legend(fontsize=6, loc="best")
    return ax


def plot_error_curves(ax, frame: pd.DataFrame, n_links: int, kind: str, change_cycle: int | None):
    """Trial-mean |cross-track error| per cycle of each controller through the drag change."""
    group = frame[(frame["links"] == n_links) & (frame["path"] == kind) & (frame["environment"] == "change")]
    for controller, part in group.groupby("controller"):
        style = controller_style(controller) | {"marker": None}
        curve = _mean_curve(part)
        ax.plot(curve.index, curve.to_numpy(), lw=1.4, label=controller, **style)
    if change_cycle is not None:
        mark_change(ax, change_cycle)
    ax.set_xlabel("tracking cycle", fontsize=8)
    ax.set_ylabel("mean |cross-track| (body lengths)", fontsize=8)
    ax.set_title(f"{n_links}-link {kind}, drag change ({group['trial'].nunique()} trials)", fontsize=9)
    ax.legend(fontsize=6)
    return ax


def mark_change(ax, change_cycle: float, label: str = "k 2→4"):
    """A vertical line at the drag change, labelled at the top of the axes."""
    ax.axvline(change_cycle, color="0.3", lw=1.0, ls="-", zorder=0)
    ax.text(change_cycle, 0.97, f" {label}", fontsize=7, va="top", transform=ax.get_xaxis_transform())
    return ax


def plot_tracking(frame: pd.DataFrame, path, change_cycle: int | None = None, references: dict | None = None):
    """Draw the whole figure from the long-format ``frame`` to ``path``: per swimmer a row of path panels
    (trial 0) and drag-change error curves after ``change_cycle`` (default: half the run); ``references``
    maps a path name to the :class:`~geogait.control.ReferencePath` drawn under it (the user's ``"csv"``)."""
    links = sorted(frame["links"].unique())
    scenarios = frame[["path", "environment"]].drop_duplicates().itertuples(index=False)
    constant = [p for p, e in scenarios if e == "constant"]
    changed = list(dict.fromkeys(frame[frame["environment"] == "change"]["path"]))
    columns = len(constant) + len(changed)
    if change_cycle is None:
        change_cycle = drag_change_cycle(frame)
    fig, axes = plt.subplots(len(links), columns, figsize=(3.3 * columns, 3.2 * len(links)), squeeze=False)
    trial = int(frame["trial"].min())
    for row, n_links in zip(axes, links, strict=True):
        for ax, kind in zip(row, constant, strict=False):
            plot_paths(ax, frame, int(n_links), kind, "constant", trial, (references or {}).get(kind))
        for ax, kind in zip(row[len(constant):], changed, strict=True):
            plot_error_curves(ax, frame, int(n_links), kind, change_cycle)
    save_figure(fig, path)
    return path


def plot_exploration_curves(ax, frames: dict, n_links: int, kind: str, change_cycle: int):
    """Trial-mean |cross-track error| per cycle through the drag change of the adaptive (solid) and frozen
    (dashed) controllers, one colour per exploration setting in ``frames`` (label → long-format frame),
    and the trial-mean δ std of each setting (thin, right axis); the y range leaves out cycles 0–4."""
    sizes, top = ax.twinx(), 0.0
    for index, (label, frame) in enumerate(frames.items()):
        group = frame[(frame["links"] == n_links) & (frame["path"] == kind) & (frame["environment"] == "change")]
        color = f"C{index}"
        for controller, style in (("adaptive", "-"), ("frozen", "--")):
            curve = _mean_curve(group[group["controller"] == controller])
            ax.plot(curve.index, curve.to_numpy(), style, color=color, lw=1.3, label=f"{label}: {controller}")
            top = max(top, float(curve[curve.index >= 5].max()))
        std = group[group["controller"] == "adaptive"].groupby("cycle")["perturbation_std"].mean()
        sizes.plot(std.index, std.to_numpy(), color=color, lw=0.7, alpha=0.6)
    mark_change(ax, change_cycle)
    ax.set_ylim(0, 1.3 * top)  # the initial offset's transient (cycles 0-4) runs off the top
    sizes.set_ylim(0, 0.6)
    sizes.set_ylabel("δ std (rad), thin lines", fontsize=7)
    ax.set_xlabel("tracking cycle", fontsize=8)
    ax.set_ylabel("mean |cross-track| (body lengths)", fontsize=8)
    ax.set_title(f"{n_links}-link {kind}, k 2→4 at cycle {change_cycle}", fontsize=9)
    ax.legend(fontsize=6, loc="upper left")
    return ax


def plot_exploration(frames: dict, path, change_cycle: int = 30):
    """Drag-change error curves of several exploration settings (``frames``: label → long-format frame
    of :func:`run_tracking`), one panel per swimmer and path (:func:`plot_exploration_curves`)."""
    first = next(iter(frames.values()))
    links = sorted(first["links"].unique())
    kinds = list(dict.fromkeys(first[first["environment"] == "change"]["path"]))
    fig, axes = plt.subplots(len(links), len(kinds), figsize=(5 * len(kinds), 3.6 * len(links)), squeeze=False)
    for row, n_links in zip(axes, links, strict=True):
        for ax, kind in zip(row, kinds, strict=True):
            plot_exploration_curves(ax, frames, int(n_links), kind, change_cycle)
    save_figure(fig, path)
    return path


def steering_families(n_links: int, *, turns=None, warmup_cycles: int = 10, sensor_noise: float = 0.1,
                      perturbation: float = 0.15, seed: int = 0) -> dict:
    """Steering families of one swimmer for the family plot.

    Returns
    -------
    dict
        ``"true"`` (nearest-gait family, true connection, k = 2), ``"model"`` (the same from an adaptive
        model fitted on ``warmup_cycles`` perturbed, noisy cycles of the straight gait), ``"true k=4"``
        and ``"max step"`` (optimal steering gaits, true connection): each a
        :class:`~geogait.control.SteeringFamily`.
    """
    system, gait, _ = straight_gait(n_links)
    turns = np.linspace(-0.4, 0.4, 17) if turns is None else np.asarray(turns, dtype=float)
    pose = cycle_displacement(system, gait)
    direction = float(np.arctan2(pose[1], pose[0]))
    run = simulate(system, gait, warmup_cycles, perturbation=Perturbation.from_std(perturbation),
                   sensor_noise=sensor_noise, seed=seed)
    model = AdaptiveGaitModel(gait=gait, forgetting_factor=0.99).fit(run.phase, run.shape, run.shape_velocity,
                                                                      run.body_velocity)
    return {"true": steering_family(TrueMotion(system), gait, turns, direction=direction),
            "model": steering_family(ModelMotion(model), gait, turns, direction=direction),
            "true k=4": steering_family(TrueMotion(system.with_drag_ratio(4.0)), gait, turns, direction=direction),
            "max step": max_step_family(TrueMotion(system), gait, turns, direction=direction)}


def plot_steering_family(ax, families: dict, n_links: int | str):
    """Turning rate against step per cycle of each family (feasible members).

    ``families`` maps a name to a :class:`~geogait.control.SteeringFamily`: a controller name
    (``adaptive``, ``frozen``, ``true``: drawn in its :data:`CONTROLLER_STYLE`, as in every tracking
    figure), ``model`` (the adaptive model, in the adaptive controller's colour), ``true k=4`` or
    ``max step``."""
    labels = {"true": "nearest gait, true connection", "model": "nearest gait, adaptive model",
              "adaptive": "adaptive controller's model", "frozen": "frozen controller's model",
              "true k=4": "nearest gait, true, drag ratio 4", "max step": "largest step (optimal steering)"}
    extra = {"true k=4": {"color": "0.55", "linestyle": ":", "marker": "^"},
             "max step": {"color": "tab:green", "linestyle": "-", "marker": "d"}}
    for name, family in families.items():
        style = controller_style("adaptive" if name == "model" else name) if name not in extra else extra[name]
        style = {k: v for k, v in style.items() if k in ("color", "linestyle", "marker", "mfc", "zorder", "alpha")}
        ok = family.feasible
        ax.plot(family.steps[ok], family.poses[ok, 2], ms=3, lw=1.2, label=labels.get(name, name), **style)
    ax.axhline(0, color="0.8", lw=0.6)
    ax.set_xlabel("step along travel per cycle (body lengths)")
    ax.set_ylabel("turn per cycle (rad)")
    ax.set_title(f"{n_links}-link steering families", fontsize=9)
    ax.legend(fontsize=7)
    return ax
