"""One path-following run as a library call (what ``geogait track`` runs): its settings, the adaptive,
frozen and true-connection controllers on the built-in swimmer or on a robot behind a driver, paired
trials on the sweep engine, the summary and the figures.

>>> settings = TrackSettings(path="line", cycles=2, warmup=2, controllers=("adaptive",), quick=True)
>>> outcome = run_track(settings.resolved())
>>> len(outcome.log), sorted(outcome.summary["adaptive"])[:2]
(2, ['cross_track_mean', 'cross_track_p95'])
"""

from __future__ import annotations

import contextlib
import dataclasses
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .._defaults import TRACKING_WARMUP_TURNS
from .._validation import MAX_MAGNITUDE, GeogaitError, GeogaitWarning
from ..control import (
    CONTROLLERS,
    EXPLORATION,
    PATH_KINDS,
    AdaptiveExploration,
    PathTracker,
    ReferencePath,
    check_plan_size,
)
from ..gaits import Perturbation
from ..plotting import plt, save_figure
from ..robots import ProcessRobot
from ..simulate import MAX_SENSOR_NOISE, DragRatioSchedule, SwimmerStream
from ._common import run_sweep
from .tracking import (
    TRACKING_MODELS,
    TURN_SPACING,
    controller_style,
    drag_change_metrics,
    error_stats,
    feasible_turn_limit,
    mark_change,
    per_trial_ratios,
    plot_reference,
    plot_steering_family,
    straight_gait,
    track_trials,
    tracking_model,
    tracking_path,
    trial_stats,
)

__all__ = ["BUILT_IN_PATHS", "TrackOutcome", "TrackSettings", "run_track"]

#: Built-in paths: the control module's curves and the experiment's waypoint rectangle.
BUILT_IN_PATHS = PATH_KINDS + ("waypoints",)
#: Largest size of a built-in path, in steps of the straight gait.
MAX_SCALE = 1e5
#: Tracking and warm-up cycles of a quick run.
QUICK = {"cycles": 12, "warmup": 5}
#: Largest number of tracking or warm-up cycles (beyond it, a typo rather than a run).
MAX_TRACK_CYCLES = 1_000_000


def _parameter(name: str) -> str:
    return f"'{name}' parameter of TrackSettings"


@dataclass(frozen=True)
class TrackSettings:
    """Everything one ``geogait track`` run is given (the CLI's options, field by field).

    ``cycles``, ``warmup``, ``change_cycle``, ``controllers`` and ``offset`` left at None take their
    defaults in :meth:`resolved`: 60 tracking and 10 straight warm-up cycles (12 and 5 with ``quick``), then
    ``warmup_turns`` turning ones (:class:`~geogait.control.PathTracker`; 4 on the built-in swimmer, whose
    shape-space model is symmetric of degree 3, none with a ``robot``), the change
    at half the cycles, every controller (adaptive and frozen with a ``robot``), and an offset of 3 steps on
    the line. ``drag_ratios`` holds one ratio, or two (before and after ``change_cycle``). ``robot`` is a
    driver command (JSON-lines bridge); ``step`` is then the straight gait's step per cycle that sizes the
    built-in paths. ``trials`` > 1 runs paired trials on :func:`geogait.sweep.run_trials`.
    """

    links: int = 3
    path: str = "circle"
    drag_ratios: tuple[float, ...] = (2.0,)
    cycles: int | None = None
    change_cycle: int | None = None
    controllers: tuple[str, ...] | None = None
    warmup: int | None = None
    warmup_turns: int | None = None
    scale: float = 10.0
    offset: float | None = None
    seed: int = 0
    noise: float = 0.1
    perturbation: float = 0.05
    horizon: int = 4
    straight_horizon: int = 2
    turn_limit: float | None = None
    exploration: str = "fixed"
    exploration_low: float = 0.05
    exploration_high: float = 0.15
    model: str = "shape"
    change_forgetting: float = 100.0
    robot: str | None = None
    robot_timeout: float = 30.0
    step: float | None = None
    trials: int = 1
    jobs: int = 1
    scheduler: str | None = None
    quick: bool = False

    def resolved(self, name: Callable[[str], str] = _parameter) -> TrackSettings:
        """These settings checked, with every default filled in; an error names the setting by
        ``name(field)`` (the CLI passes its option names)."""
        names = self.controllers
        if names is None:
            names = tuple(c for c in CONTROLLERS if self.robot is None or c != "true")
        bad = [c for c in names if c not in CONTROLLERS]
        if bad or not names:
            raise GeogaitError(f"The {name('controllers')} must be a comma-separated list of {', '.join(CONTROLLERS)}."
                               f" Got {','.join(names)!r} instead.")
        ratios = tuple(self.drag_ratios)
        if not ratios or len(ratios) > 2 or not all(np.isfinite(v) and v > 0 for v in ratios):
            raise GeogaitError(f"The {name('drag_ratios')} must be one positive number or two, comma-separated "
                               f"(before and after the change, e.g. 2,4). Got {','.join(map(str, ratios))!r} "
                               "instead.")
        if self.trials == 1 and (self.jobs != 1 or self.scheduler is not None):
            raise GeogaitError(f"The {name('jobs')} and {name('scheduler')} spread the trials of {name('trials')} "
                               "N (N > 1) over workers; one trial runs in this process (add trials or drop them).")
        if self.robot is not None:
            self._check_robot(names, ratios, name)
        else:
            if self.step is not None:
                raise GeogaitError(f"The {name('step')} sizes the paths of a robot behind {name('robot')}; the "
                                   "built-in swimmer's step is its straight gait's (drop it, or give a robot).")
            if not (isinstance(self.links, int | np.integer) and self.links >= 3):
                raise GeogaitError(f"The {name('links')} must be a whole number >= 3 (a swimmer of two links, one "
                                   f"joint, cannot move: the scallop theorem). Got {self.links!r} instead.")
            straight_gait(self.links)
            if not (isinstance(self.seed, int | np.integer) and self.seed >= 0):
                raise GeogaitError(f"The {name('seed')} must be a whole number >= 0. Got {self.seed!r} instead.")
            if not (np.isfinite(self.noise) and 0 <= self.noise <= MAX_SENSOR_NOISE):
                raise GeogaitError(f"The {name('noise')} must be a fraction in [0, {MAX_SENSOR_NOISE:g}] of the "
                                   f"signal's RMS. Got {self.noise} instead.")
        if self.offset is not None and not abs(self.offset) <= MAX_MAGNITUDE:  # (NaN fails `<=` too)
            raise GeogaitError(f"The {name('offset')} must be a finite number of body lengths within "
                               f"±{MAX_MAGNITUDE:g}. Got {self.offset} instead.")
        if not (self.path in BUILT_IN_PATHS or self.path.endswith(".csv") or Path(self.path).exists()):
            raise GeogaitError(f"The {name('path')} must be one of {', '.join(BUILT_IN_PATHS)} or a waypoints CSV "
                               f"file (columns x, y). Got {self.path!r} instead.")
        if self.path not in BUILT_IN_PATHS:
            ReferencePath.from_csv(self.path)  # its errors name the file and row, before anything runs
        if not (np.isfinite(self.scale) and 0 < self.scale <= MAX_SCALE):
            raise GeogaitError(f"The {name('scale')} must be in (0, {MAX_SCALE:g}] steps. Got {self.scale} instead.")
        cycles = self.cycles if self.cycles is not None else (QUICK["cycles"] if self.quick else 60)
        warmup = self.warmup if self.warmup is not None else (QUICK["warmup"] if self.quick else 10)
        for field_name, value in (("cycles", cycles), ("warmup", warmup)):
            if not (isinstance(value, int | np.integer) and 1 <= value <= MAX_TRACK_CYCLES):
                raise GeogaitError(f"The {name(field_name)} must be a whole number of cycles in 1..{MAX_TRACK_CYCLES}. "
                                   f"Got {value!r} instead.")
        change = self.change_cycle if self.change_cycle is not None else cycles // 2
        turns = self.warmup_turns
        if turns is None:  # (a robot's own model need not hold over the turning range)
            turns = TRACKING_WARMUP_TURNS if self.robot is None else 0
        if not (isinstance(turns, int | np.integer) and turns >= 0):
            raise GeogaitError(f"The {name('warmup_turns')} must be a whole number of cycles >= 0. Got "
                               f"{turns!r} instead.")
        if len(ratios) == 2 and not 1 <= change < cycles:
            raise GeogaitError(f"The {name('change_cycle')} must be in [1, {cycles - 1}]. Got {change} instead.")
        if not (isinstance(self.horizon, int | np.integer) and self.horizon >= 1):
            raise GeogaitError(f"The {name('horizon')} must be a whole number of cycles >= 1. Got {self.horizon!r} "
                               "instead.")
        check_plan_size(int(self.horizon), PathTracker().n_first_turns, None, "geogait track", name("horizon"))
        if not (isinstance(self.straight_horizon, int | np.integer) and 1 <= self.straight_horizon <= self.horizon):
            raise GeogaitError(f"The {name('straight_horizon')} must be a whole number of cycles in 1..{self.horizon} "
                               f"(the horizon). Got {self.straight_horizon!r} instead.")
        if self.turn_limit is not None and not TURN_SPACING <= self.turn_limit <= np.pi:
            raise GeogaitError(f"The {name('turn_limit')} must be in [{TURN_SPACING:g}, π] rad. Got {self.turn_limit} "
                               "instead.")
        if self.exploration not in EXPLORATION:
            raise GeogaitError(f"The {name('exploration')} must be one of {', '.join(EXPLORATION)}. "
                               f"Got {self.exploration!r} instead.")
        if not self.perturbation >= 0:
            raise GeogaitError(f"The {name('perturbation')} must be a std >= 0 (rad). Got {self.perturbation} instead.")
        if self.exploration == "adaptive" and not self.exploration_high >= 0:
            raise GeogaitError(f"The {name('exploration_high')} must be a std >= 0 (rad). Got {self.exploration_high} "
                               "instead.")
        if self.exploration == "adaptive" and not 0 < self.exploration_low <= self.exploration_high:
            raise GeogaitError(f"The {name('exploration_low')} must be in (0, {name('exploration_high')} = "
                               f"{self.exploration_high:g}]. Got {self.exploration_low} instead.")
        if self.model not in TRACKING_MODELS:
            raise GeogaitError(f"The {name('model')} must be one of {', '.join(TRACKING_MODELS)}. Got {self.model!r} "
                               "instead.")
        if not self.change_forgetting >= 1:
            raise GeogaitError(f"The {name('change_forgetting')} must be a number >= 1. Got {self.change_forgetting} "
                               "instead.")
        return dataclasses.replace(self, controllers=names, drag_ratios=ratios, cycles=cycles, warmup=warmup,
                                   warmup_turns=int(turns),
                                   change_cycle=change)

    def _check_robot(self, names, ratios, name) -> None:
        """The settings that need the built-in swimmer, refused with a robot (nothing silently ignored)."""
        if self.trials > 1:
            raise GeogaitError(f"The {name('trials')} runs the built-in swimmer on paired seeds; a robot behind "
                               f"{name('robot')} runs once (drop it with a robot).")
        if "true" in names:
            raise GeogaitError(f"The 'true' controller needs the built-in swimmer's connection; with {name('robot')} "
                               "use controllers adaptive,frozen.")
        if len(ratios) == 2:
            raise GeogaitError(f"The {name('drag_ratios')} changes the built-in swimmer's environment; a robot's "
                               f"environment is its own (give one drag ratio with {name('robot')}).")
        if self.exploration != "fixed":
            raise GeogaitError("Adaptive exploration needs a robot whose δ size can be set between cycles; the "
                               f"JSON-lines bridge has no such message (use fixed {name('exploration')} with a robot).")
        if self.path in BUILT_IN_PATHS and self.step is None:
            raise GeogaitError(f"The built-in path {self.path!r} is sized in steps of the straight gait: give "
                               f"{name('step')} (the robot's step per cycle, pose units) with {name('robot')}, or a "
                               "waypoints CSV as the path.")
        if self.step is not None and not (np.isfinite(self.step) and self.step > 0):
            raise GeogaitError(f"The {name('step')} must be a positive number. Got {self.step} instead.")

    def manifest(self, step: float | None) -> dict:
        """The settings as a run records them: the built-in swimmer's only where they acted."""
        swimmer, fixed = self.robot is None, self.exploration == "fixed"
        return dict(links=self.links if swimmer else None, robot=self.robot, path=self.path,
                    drag_ratios=self.drag_ratios if swimmer else None, cycles=self.cycles,
                    change_cycle=self.change_cycle if len(self.drag_ratios) == 2 else None,
                    controllers=self.controllers, warmup=self.warmup, warmup_turns=self.warmup_turns,
                    scale=self.scale, step=step,
                    offset=self.start_offset(step), seed=self.seed if swimmer else None,
                    noise=self.noise if swimmer else None,
                    perturbation=self.perturbation if fixed and swimmer else None,
                    exploration=self.exploration, exploration_low=None if fixed else self.exploration_low,
                    exploration_high=None if fixed else self.exploration_high, horizon=self.horizon,
                    straight_horizon=self.straight_horizon,
                    turn_limit=self.steering_turn_limit(), model=self.model, change_forgetting=self.change_forgetting,
                    quick=self.quick, trials=self.trials, jobs=self.jobs if self.trials > 1 else None,
                    scheduler=self.scheduler if self.trials > 1 else None)

    def start_offset(self, step: float | None) -> float:
        """The offset to the left of the path at the start (body lengths): ``offset``, or 3 steps on the line."""
        if self.offset is not None:
            return self.offset
        return 3 * step if self.path == "line" and step else 0.0

    def steering_turn_limit(self) -> float | None:
        """The steering families' largest turn (rad per cycle): on the swimmer, ``turn_limit`` (or 1) cut to what
        its true connection turns within the joint limits, the same for every controller; with a robot,
        ``turn_limit``, or None for each controller's own warm-up model (PathTracker's rule)."""
        return feasible_turn_limit(self.links, self.turn_limit or 1.0) if self.robot is None else self.turn_limit

    def exploration_sizes(self):
        """PathTracker's ``exploration``: ``"fixed"``, or the adaptive rule between the two stds."""
        if self.exploration == "fixed":
            return "fixed"
        return AdaptiveExploration(low=self.exploration_low, high=self.exploration_high)


@dataclass
class TrackOutcome:
    """What :func:`run_track` returns.

    Attributes
    ----------
    settings : TrackSettings
        Resolved.
    reference : ReferencePath
    step : float or None
        The straight gait's step per cycle (body lengths; the robot's ``step`` setting).
    log : pandas.DataFrame
        Every controller's per-cycle log (:class:`~geogait.control.TrackingResult`); with paired trials,
        a ``trial`` column.
    summary : dict
        Per controller: mean and 95th percentile of |cross-track| and |heading error| (and, for one
        trial, Γ, quarantined cycles of a robot and early stops; for paired trials the worst trial); the
        adaptive / true ratio (with trials, per trial and the share within 1.5×); the drag change over fixed
        windows after it.
    results : dict of str to geogait.control.TrackingResult
        One trial: each controller's result (trajectories recorded). Empty for paired trials.
    trials : pandas.DataFrame or None
        Paired trials: one row per trial and controller (:func:`~geogait.experiments.tracking.trial_stats`).
    """

    settings: TrackSettings
    reference: ReferencePath
    step: float | None
    log: pd.DataFrame
    summary: dict
    results: dict = field(default_factory=dict)
    trials: pd.DataFrame | None = None

    def plot_paths(self, file) -> Path:
        """The path figure: the reference, each controller's path (the first trial's with paired trials) and
        |cross-track error| per cycle (the trials' mean), the drag change marked."""
        change = self.settings.change_cycle if len(self.settings.drag_ratios) == 2 else None
        if self.trials is None:
            return _plot_paths(file, self.reference, {n: r.log for n, r in self.results.items()},
                               {n: r.trajectory for n, r in self.results.items()},
                               {n: r.start for n, r in self.results.items()}, change)
        first = self.log[self.log["trial"] == self.log["trial"].min()]
        return _plot_paths(file, self.reference, dict(tuple(first.groupby("controller", sort=False))),
                           error_logs=dict(tuple(self.log.groupby("controller", sort=False))), change_cycle=change,
                           title=f"trial {int(first['trial'].iloc[0])} of {self.settings.trials}; errors: mean of "
                                 f"{self.settings.trials} trials")

    def plot_family(self, file) -> Path:
        """The steering families the controllers ended with (one trial)."""
        fig, ax = plt.subplots(figsize=(6, 4.5))
        label = self.settings.links if self.settings.robot is None else "robot"
        plot_steering_family(ax, {n: r.family for n, r in self.results.items()}, label)
        return save_figure(fig, file)


def run_track(settings: TrackSettings, *, callback: Callable[[str, dict | None], None] | None = None,
              progress: bool = False) -> TrackOutcome:
    """Follow the path with every controller (paired trials on the sweep engine for ``trials`` > 1).

    Each controller runs on its own copy of the simulated swimmer with the same seed (same perturbations
    and noise), or its own driver process of ``robot``: the adaptive model keeps learning, the frozen one
    stops after the warm-up, and the true controller (swimmer only) uses the true connection of the
    environment in force.

    Parameters
    ----------
    settings : TrackSettings
        Resolved (:meth:`TrackSettings.resolved`).
    callback : callable, optional
        One trial: called as ``callback(controller, None)`` once its robot is up and ``callback(controller,
        row)`` with each log row (live progress displays).
    progress : bool
        Paired trials: the sweep engine's progress bar.

    Returns
    -------
    TrackOutcome
    """
    s = settings
    if s.robot is None:
        system, gait, step = straight_gait(s.links)
    else:
        system, gait, step = None, None, s.step
    reference = _reference_path(s.path, step, s.scale)
    if s.trials > 1:
        return _paired_trials(s, reference, step, progress)
    results, quarantined = {}, {}
    sizes = s.exploration_sizes()
    for name in sorted(s.controllers, key=lambda n: n != "adaptive"):  # the adaptive run sizes the exploration
        tracker = PathTracker(controller=name, exploration=sizes, warmup_cycles=s.warmup,
                              warmup_turns=s.warmup_turns, horizon=s.horizon, straight_horizon=s.straight_horizon,
                              model=tracking_model(s.model, symmetric=s.robot is None),
                              change_forgetting=s.change_forgetting, turn_limit=s.steering_turn_limit())
        with _robot(s, system, gait, tracker.warmup_length) as device:  # a driver that cannot start fails here
            if callback is not None:
                callback(name, None)
            show = None if callback is None else (lambda row, name=name: callback(name, row))
            results[name] = tracker.run(device, reference, s.cycles, start_offset=s.start_offset(step), callback=show,
                                        record=True)
            quarantined[name] = list(getattr(device, "quarantined", []))
        if name == "adaptive" and s.exploration != "fixed":
            sizes = results[name].perturbation_std  # the others replay it: the same perturbations
    log = pd.concat([r.log for r in results.values()], ignore_index=True)
    summary = {}
    for name, result in results.items():
        summary[name] = result.summary() | {"final_gamma": float(result.log["gamma"].iloc[-1])}
        if name != "adaptive":
            summary[name]["final_gamma_null_reason"] = f"the {name} controller does not learn: no online Γ"
        if s.robot is not None:
            summary[name]["quarantined_cycles"] = len(quarantined[name])
            summary[name]["quarantine_reasons"] = quarantined[name][:20]
        ran = len(result.log)
        summary[name]["stopped_early"] = ran < s.cycles
        if ran < s.cycles:
            summary[name]["stop_reason"] = (f"the {name} controller reached the end of the path after {ran} of "
                                            f"{s.cycles} cycles")
            warnings.warn(summary[name]["stop_reason"] + "; the summary covers the cycles run", GeogaitWarning,
                          stacklevel=2)
    means = [summary.get(n, {}).get("cross_track_mean") for n in ("adaptive", "true")]
    if None not in means and means[1] > 0:
        summary["adaptive_over_true_cross_track"] = means[0] / means[1]
    if len(s.drag_ratios) == 2:
        summary["drag_change"] = drag_change_metrics(log.assign(trial=0), s.change_cycle)
    summary |= {"step_per_cycle": step, "path_length": reference.length, "path_closed": reference.closed}
    return TrackOutcome(s, reference, step, log, summary, results=results)


def _paired_trials(s: TrackSettings, reference: ReferencePath, step: float, progress: bool) -> TrackOutcome:
    """``trials`` > 1: every controller on each trial's seed (:func:`~geogait.experiments.tracking.track_trials`)."""
    sizes = s.exploration_sizes()
    options = dict(n_links=s.links, path=reference, n_cycles=s.cycles, drag_ratios=s.drag_ratios,
                   change_cycle=s.change_cycle, warmup_cycles=s.warmup, sensor_noise=s.noise,
                   perturbation=s.perturbation if s.exploration == "fixed" else s.exploration_high,
                   controllers=s.controllers,
                   tracker_options=dict(horizon=s.horizon, straight_horizon=s.straight_horizon,
                                        model=tracking_model(s.model), warmup_turns=s.warmup_turns,
                                        change_forgetting=s.change_forgetting, turn_limit=s.steering_turn_limit()),
                   start_offset=s.start_offset(step), exploration=None if sizes == "fixed" else sizes)
    log, wall, workers = run_sweep(track_trials, s.trials, options, seed=s.seed, chunk_size=1, jobs=s.jobs,
                                   scheduler=s.scheduler, progress=progress, description=f"{s.links}-link tracking")
    change = s.change_cycle if len(s.drag_ratios) == 2 else None
    stats = trial_stats(log, change)
    summary = {}
    for name, part in stats.groupby("controller", sort=False):
        summary[name] = error_stats(log[log["controller"] == name]) | {
            "trial_cross_track_mean_worst": float(part["cross_track_mean"].max()),
            "trials_stopped_early": int((part["cycles"] < s.cycles).sum())}
    ratios = per_trial_ratios(stats)
    if ratios:
        summary["adaptive_over_true_cross_track"] = (summary["adaptive"]["cross_track_mean"]
                                                     / summary["true"]["cross_track_mean"])
        summary["adaptive_over_true_per_trial"] = ratios
        summary["adaptive_over_true_worst_trial"] = ratios["worst"]
        summary["share_trials_within_1.5x_true"] = ratios["share_within"]
    if change is not None:
        summary["drag_change"] = drag_change_metrics(log, change)
    summary |= {"trials": s.trials, "step_per_cycle": step, "path_length": reference.length,
                "path_closed": reference.closed, "wall_time_s_sweep": wall, "workers": workers}
    return TrackOutcome(s, reference, step, log, summary, trials=stats)


def _reference_path(text: str, step: float, scale: float) -> ReferencePath:
    return tracking_path(text, step, scale) if text in BUILT_IN_PATHS else ReferencePath.from_csv(text)


def _robot(s: TrackSettings, system, gait, warmup_length: int):
    """A fresh robot for one controller: a driver process, or the swimmer at the run's seed and drag ratios."""
    if s.robot is not None:
        return ProcessRobot(s.robot, timeout=s.robot_timeout)
    start = system.with_drag_ratio(s.drag_ratios[0])
    schedule = DragRatioSchedule(start, s.drag_ratios, warmup_length + s.change_cycle) if len(s.drag_ratios) == 2 \
        else None
    std = s.perturbation if s.exploration == "fixed" else s.exploration_high
    return contextlib.nullcontext(SwimmerStream(start, gait, perturbation=Perturbation.from_std(std),
                                                sensor_noise=s.noise, environment=schedule, seed=s.seed))


def _plot_paths(file, reference: ReferencePath, logs: dict, trajectories: dict | None = None,
                starts: dict | None = None, change_cycle: int | None = None, error_logs: dict | None = None,
                title: str = "") -> Path:
    """Left: the reference path, each controller's sampled path and its cycle-boundary markers (the
    true controller underneath); right: |cross-track error| per cycle (trial mean of ``error_logs``,
    default ``logs``), the drag change marked."""
    fig, (ax, errors) = plt.subplots(1, 2, figsize=(11.5, 5.0), gridspec_kw={"width_ratios": [1.25, 1]})
    plot_reference(ax, reference, np.concatenate([log[["x", "y"]].to_numpy() for log in logs.values()]))
    for name, log in logs.items():
        style = controller_style(name)
        trajectory = (trajectories or {}).get(name)
        if trajectory is not None:
            pose = trajectory.pose
            ax.plot(pose[:, 0], pose[:, 1], color=style["color"], lw=0.6, alpha=0.6 * style["alpha"],
                    zorder=style["zorder"])
        ax.plot(log["x"], log["y"], ls="none", label=f"{name} (cycle ends)",
                **{k: v for k, v in style.items() if k != "linestyle"})
        if change_cycle is not None:
            at = log[log["cycle"] == change_cycle]
            ax.plot(at["x"], at["y"], "*", color=style["color"], ms=11, mec="k", mew=0.5, zorder=6,
                    label="drag change" if name == next(iter(logs)) else None)
        if starts and name in starts:
            ax.plot(*starts[name][:2], "^", color=style["color"], ms=6, zorder=style["zorder"])
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (body lengths)")
    ax.set_ylabel("y (body lengths)")
    ax.set_title("Body-frame path and cycle boundaries" + (f"\n({title})" if title else ""), fontsize=10)
    ax.legend(fontsize=8)
    for name, log in (error_logs or logs).items():
        curve = log.assign(error=log["cross_track"].abs()).groupby("cycle")["error"].mean()
        style = controller_style(name)
        errors.plot(curve.index, curve.to_numpy(), color=style["color"], ls=style["linestyle"], lw=1.3,
                    zorder=style["zorder"], label=name)
    if change_cycle is not None:
        mark_change(errors, change_cycle, "drag change")
    errors.set_xlabel("tracking cycle")
    errors.set_ylabel("|cross-track error| (body lengths)")
    errors.set_title("Cross-track error per cycle", fontsize=10)
    errors.legend(fontsize=8)
    return save_figure(fig, file)
