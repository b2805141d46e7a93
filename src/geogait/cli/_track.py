"""``geogait track``: follow a path with steering gaits (adaptive, frozen and true-connection
controllers), and ``geogait figure tracking``: the seeded multi-trial experiment."""

from __future__ import annotations

import contextlib
import dataclasses
import time
import warnings
from pathlib import Path
from typing import Annotated

import numpy as np
import pandas as pd
import typer

from .._files import dumps_json, json_ready, output_set, write_text
from .._validation import GeogaitError, GeogaitWarning
from ..control import (
    CONTROLLERS,
    EXPLORATION,
    PATH_KINDS,
    AdaptiveExploration,
    PathTracker,
    ReferencePath,
)
from ..experiments.tracking import (
    CUSTOM_PATH,
    PATHS,
    TRACKING_MODELS,
    TURN_SPACING,
    TrackingConfig,
    TrackingResult,
    controller_style,
    drag_change_metrics,
    feasible_turn_limit,
    mark_change,
    per_trial_ratios,
    plot_reference,
    plot_steering_family,
    run_tracking,
    steering_families,
    straight_gait,
    track_trials,
    tracking_model,
    tracking_path,
    trial_stats,
)
from ..gaits import Perturbation
from ..plotting import plt, save_figure
from ..robots import ProcessRobot
from ..simulate import DragRatioSchedule, SwimmerStream
from ..sweep import run_trials
from ._app import app, figure_app
from ._common import claim_output, console, explain_nulls, output_folder, progress_bar, write_manifest

QUICK = {"cycles": 12, "warmup": 5}
#: Every file ``geogait track`` writes (replaced together, as one set); ``trials.csv`` with ``--trials`` > 1,
#: ``family.png`` with one trial.
TRACK_FILES = ("cycles.csv", "path.png", "family.png", "trials.csv", "summary.json")
#: Built-in paths of ``--path``: the control module's curves and the experiment's waypoint rectangle.
BUILT_IN_PATHS = PATH_KINDS + ("waypoints",)
MAX_SCALE = 1e5  # --scale: built-in paths of at most 1e5 steps


def _names(text: str, option: str, choices) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    bad = [n for n in names if n not in choices]
    if bad or not names:
        raise GeogaitError(f"The '{option}' option must be a comma-separated list of {', '.join(choices)}. "
                           f"Got {text!r} instead.")
    return names


def _links(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        message = f"The '--links' option must be comma-separated integers such as 3,5. Got {text!r} instead."
        raise GeogaitError(message) from None


def _ratios(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if not values or len(values) > 2 or not all(np.isfinite(v) and v > 0 for v in values):
        raise GeogaitError("The '--drag-ratio' option must be one positive number or two, comma-separated "
                           f"(before and after the change, e.g. 2,4). Got {text!r} instead.")
    return values


def _path(text: str, step: float, scale: float) -> ReferencePath:
    if text in BUILT_IN_PATHS:
        return tracking_path(text, step, scale)
    if text.endswith(".csv") or Path(text).exists():
        return ReferencePath.from_csv(text)
    raise GeogaitError(f"The '--path' option must be one of {', '.join(BUILT_IN_PATHS)} or a waypoints CSV file "
                       f"(columns x, y). Got {text!r} instead.")


def _figure_paths(text: str, option: str) -> tuple[tuple[str, ...], str | None]:
    """``--path`` / ``--drag-path`` of ``figure tracking``: built-in names and at most one waypoints CSV."""
    names, files = [], []
    for item in (v.strip() for v in text.split(",") if v.strip()):
        if item in PATHS:
            names.append(item)
        elif item.endswith(".csv") or Path(item).exists():
            files.append(item)
            names.append(CUSTOM_PATH)
        else:
            raise GeogaitError(f"The '{option}' option must be a comma-separated list of {', '.join(PATHS)} and at "
                               f"most one waypoints CSV file (columns x, y). Got {item!r} instead.")
    if len(set(files)) > 1:
        raise GeogaitError(f"The '{option}' option takes at most one waypoints CSV file. Got {', '.join(files)}.")
    return tuple(dict.fromkeys(names)), (files[0] if files else None)


def _check_robot_options(names, ratios, path: str, step: float | None, exploration: str) -> None:
    """The options that need the built-in swimmer, refused with --robot (nothing silently ignored)."""
    if "true" in names:
        raise GeogaitError("The 'true' controller needs the built-in swimmer's connection; with '--robot' use "
                           "'--controllers adaptive,frozen'.")
    if len(ratios) == 2:
        raise GeogaitError("The '--drag-ratio' option changes the built-in swimmer's environment; a robot's "
                           "environment is its own (drop '--drag-ratio' with '--robot').")
    if exploration != "fixed":
        raise GeogaitError("'--exploration adaptive' needs a robot whose δ size can be set between cycles; the "
                           "JSON-lines bridge has no such message (use '--exploration fixed' with '--robot').")
    if path in BUILT_IN_PATHS and step is None:
        raise GeogaitError(f"The built-in path {path!r} is sized in steps of the straight gait: give '--step' (the "
                           "robot's step per cycle, pose units) with '--robot', or a waypoints CSV as '--path'.")
    if step is not None and not (np.isfinite(step) and step > 0):
        raise GeogaitError(f"The '--step' option must be a positive number. Got {step} instead.")


def _json(value, reason: str = "not available for this run"):
    """Strict JSON values: NaN and inf become null with a reason, and so does every other null."""
    return explain_nulls(json_ready(value), reason)


@app.command()
def track(
    links: Annotated[int, typer.Option(help="Number of links N of the Purcell swimmer.")] = 3,
    path: Annotated[str, typer.Option(help="line, circle, figure8, waypoints (the 1.5 × 1 rectangle of the "
                                           "docs figure, in --scale steps), or a waypoints CSV (columns x, y; "
                                           "body lengths; a last row equal to the first closes the path).")
                    ] = "circle",
    drag_ratio: Annotated[str, typer.Option(
        help="Drag ratio k, or two (e.g. 2,4): changed unannounced at --change-cycle.")] = "2",
    cycles: Annotated[int | None, typer.Option(help="Tracking cycles [default: 60; 12 with --quick].")] = None,
    change_cycle: Annotated[int | None, typer.Option(
        help="Tracking cycle of the drag-ratio change [default: half of --cycles].")] = None,
    controllers: Annotated[str | None, typer.Option(
        help="Comma-separated controllers to run: adaptive, frozen, true [default: all three; adaptive,frozen "
             "with --robot].")] = None,
    warmup: Annotated[int | None, typer.Option(
        help="Straight-gait cycles before tracking [default: 10; 5 with --quick].")] = None,
    scale: Annotated[float, typer.Option(help="Built-in paths' size in steps of the straight gait.")] = 10.0,
    offset: Annotated[float | None, typer.Option(
        help="Initial offset to the left of the path (body lengths) [default: 3 steps on the line, else 0].")] = None,
    seed: Annotated[int, typer.Option(help="Random seed of perturbations and sensor noise (built-in swimmer).")] = 0,
    noise: Annotated[float, typer.Option(help="Sensor noise on ξ, fraction of its RMS.")] = 0.1,
    perturbation: Annotated[float, typer.Option(
        help="Std (rad) of the shape perturbation δ (--exploration fixed).")] = 0.05,
    horizon: Annotated[int, typer.Option(help="Cycles predicted per decision.")] = 4,
    turn_limit: Annotated[float | None, typer.Option(
        help="Largest turn per cycle (rad) of the steering family [default: 1 rad, cut to what the joint limits "
             "allow].")] = None,
    exploration: Annotated[str, typer.Option(
        help="fixed: δ std --perturbation throughout; adaptive: sized every cycle between --exploration-low and "
             "--exploration-high from the adaptive controller's prediction residual (the other controllers replay "
             "its schedule).")] = "fixed",
    exploration_low: Annotated[float, typer.Option(
        help="Smallest δ std (rad) of --exploration adaptive.")] = 0.05,
    exploration_high: Annotated[float, typer.Option(
        help="Largest δ std (rad) of --exploration adaptive (warm-up and after an alarm).")] = 0.15,
    model: Annotated[str, typer.Option(
        help="Learning model of the adaptive and frozen controllers: window (local model about the straight "
             "gait) or shape (connection over shape space, degree 3).")] = "shape",
    change_forgetting: Annotated[float, typer.Option(
        help="At a surprise alarm the adaptive model forgets its evidence by this factor (1: never).")] = 100.0,
    robot: Annotated[str | None, typer.Option(
        help="Follow the path with the robot behind this driver command (JSON-lines bridge) instead of the "
             "swimmer; each controller gets a fresh driver process. Its current gait is the straight gait.")] = None,
    robot_timeout: Annotated[float, typer.Option(help="Seconds to wait for each line of the driver.")] = 30.0,
    step: Annotated[float | None, typer.Option(
        help="With --robot: the straight gait's step per cycle (pose units) that sizes the built-in paths "
             "(--scale steps); not needed for a waypoints CSV.")] = None,
    trials: Annotated[int, typer.Option(
        min=1, help="Paired trials (built-in swimmer): trial i runs every controller on the seed "
                    "SeedSequence(--seed).spawn(N)[i]; with N > 1 the trials run on the sweep runner (--jobs, "
                    "--scheduler), cycles.csv gets a trial column, trials.csv one row per trial and controller, "
                    "and summary.json the per-trial ratios (no live display, no family.png).")] = 1,
    jobs: Annotated[int, typer.Option(help="joblib worker processes for --trials N > 1 (-1: all cores).")] = 1,
    scheduler: Annotated[str | None, typer.Option(
        help="Dask scheduler address for --trials N > 1 (needs geogait[dask]).")] = None,
    quick: Annotated[bool, typer.Option(help="A short run: 5 warm-up and 12 tracking cycles.")] = False,
    overwrite: Annotated[bool, typer.Option(
        help="Replace the run in a non-empty --out folder (its files are replaced together when this run ends).")
    ] = False,
    out: Annotated[Path, typer.Option(help="Output folder (must be empty or new, unless --overwrite).")] = Path(
        "out/track"),
) -> None:
    """Follow a path with steering gaits; write path.png, family.png, cycles.csv and summary.json
    (with --trials N > 1: path.png, cycles.csv, trials.csv and summary.json, per-trial ratios included).

    Each controller runs on its own copy of the simulated swimmer with the same seed (same perturbations
    and noise), or its own driver process of --robot: the adaptive model keeps learning, the frozen one
    stops after the warm-up, and the true controller (swimmer only) uses the true connection of the
    environment in force.
    """
    started = time.perf_counter()
    ratios = _ratios(drag_ratio)
    names = _names(controllers or ",".join(c for c in CONTROLLERS if robot is None or c != "true"),
                   "--controllers", CONTROLLERS)
    if trials == 1 and (jobs != 1 or scheduler is not None):
        raise GeogaitError("The '--jobs' and '--scheduler' options spread the trials of '--trials N' (N > 1) over "
                           "workers; one trial runs in this process (add '--trials N' or drop them).")
    if robot is not None:
        if trials > 1:
            raise GeogaitError("The '--trials' option runs the built-in swimmer on paired seeds; a robot behind "
                               "'--robot' runs once (drop '--trials' with '--robot').")
        _check_robot_options(names, ratios, path, step, exploration)
        system, gait = None, None
    else:
        system, gait, step = straight_gait(links)
    if not (np.isfinite(scale) and 0 < scale <= MAX_SCALE):
        raise GeogaitError(f"The '--scale' option must be in (0, {MAX_SCALE:g}] steps. Got {scale} instead.")
    reference = _path(path, step, scale)
    n_cycles = cycles if cycles is not None else (QUICK["cycles"] if quick else 60)
    warmup_cycles = warmup if warmup is not None else (QUICK["warmup"] if quick else 10)
    change = change_cycle if change_cycle is not None else n_cycles // 2
    start_offset = offset if offset is not None else (3 * step if path == "line" and step else 0.0)
    if len(ratios) == 2 and not 1 <= change < n_cycles:
        raise GeogaitError(f"The '--change-cycle' option must be in [1, {n_cycles - 1}]. Got {change} instead.")
    if turn_limit is not None and not TURN_SPACING <= turn_limit <= np.pi:
        raise GeogaitError(f"The '--turn-limit' option must be in [{TURN_SPACING:g}, π] rad. Got {turn_limit} instead.")
    if exploration not in EXPLORATION:
        raise GeogaitError(f"The '--exploration' option must be one of {', '.join(EXPLORATION)}. "
                           f"Got {exploration!r} instead.")
    if not perturbation >= 0:
        raise GeogaitError(f"The '--perturbation' option must be a std >= 0 (rad). Got {perturbation} instead.")
    if exploration == "adaptive" and not exploration_high >= 0:
        raise GeogaitError(f"The '--exploration-high' option must be a std >= 0 (rad). Got {exploration_high} instead.")
    if exploration == "adaptive" and not 0 < exploration_low <= exploration_high:
        raise GeogaitError(f"The '--exploration-low' option must be in (0, --exploration-high = {exploration_high:g}]. "
                           f"Got {exploration_low} instead.")
    if model not in TRACKING_MODELS:
        raise GeogaitError(f"The '--model' option must be one of {', '.join(TRACKING_MODELS)}. Got {model!r} instead.")
    if not change_forgetting >= 1:
        raise GeogaitError(f"The '--change-forgetting' option must be a number >= 1. Got {change_forgetting} instead.")
    # the swimmer's limit comes from its true connection (the same for every controller); a robot's from
    # each controller's own warm-up model (PathTracker's turn_limit=None rule) unless given
    # (PathTracker's n_turns=None spaces the family's turns 0.1 rad up to the limit)
    limit = feasible_turn_limit(links, turn_limit or 1.0) if robot is None else turn_limit
    settings = dict(warmup_cycles=warmup_cycles, horizon=horizon, model=tracking_model(model, symmetric=robot is None),
                    change_forgetting=change_forgetting, turn_limit=limit)
    sizes = "fixed" if exploration == "fixed" else AdaptiveExploration(low=exploration_low, high=exploration_high)
    start_std = perturbation if exploration == "fixed" else exploration_high
    def target():  # a fresh robot for every controller
        if robot is not None:
            return ProcessRobot(robot, timeout=robot_timeout)
        system_k = system.with_drag_ratio(ratios[0])
        schedule = (DragRatioSchedule(system_k, ratios, warmup_cycles + change) if len(ratios) == 2 else None)
        return contextlib.nullcontext(SwimmerStream(system_k, gait, perturbation=Perturbation.from_std(start_std),
                                                    sensor_noise=noise, environment=schedule, seed=seed))

    swimmer = robot is None  # the options of the built-in swimmer, recorded only where they acted
    config = dict(links=links if swimmer else None, robot=robot, path=path, drag_ratios=ratios if swimmer else None,
                  cycles=n_cycles, change_cycle=change if len(ratios) == 2 else None, controllers=names,
                  warmup=warmup_cycles, scale=scale, step=step, offset=start_offset, seed=seed if swimmer else None,
                  noise=noise if swimmer else None,
                  perturbation=perturbation if exploration == "fixed" and swimmer else None,
                  exploration=exploration,
                  exploration_low=exploration_low if exploration == "adaptive" else None,
                  exploration_high=exploration_high if exploration == "adaptive" else None, horizon=horizon,
                  turn_limit=limit, model=model, change_forgetting=change_forgetting, quick=quick, trials=trials,
                  jobs=jobs if trials > 1 else None, scheduler=scheduler if trials > 1 else None)
    if trials > 1:
        options = dict(n_links=links, path=reference, n_cycles=n_cycles, drag_ratios=ratios, change_cycle=change,
                       warmup_cycles=warmup_cycles, sensor_noise=noise, perturbation=start_std, controllers=names,
                       tracker_options=dict(horizon=horizon, model=tracking_model(model),
                                            change_forgetting=change_forgetting, turn_limit=limit),
                       start_offset=start_offset, exploration=None if sizes == "fixed" else sizes)
        _track_trials(out, overwrite, options, trials, seed, jobs, scheduler, reference, config, started, step)
        return
    label = "robot" if robot is not None else f"{links}-link"
    # checked and locked before any work; replaced as one set at the end
    with claim_output(out, overwrite=overwrite):
        folder = Path(out)
        results, quarantined = {}, {}
        progress = progress_bar()
        try:
            for name in sorted(names, key=lambda n: n != "adaptive"):  # the adaptive run sizes the exploration
                tracker = PathTracker(controller=name, exploration=sizes, **settings)
                with target() as device:  # a driver that cannot start fails here, before any progress display
                    progress.start()
                    task = progress.add_task(f"{label} {name:8s}", total=n_cycles, status="warming up")

                    def show(row, task=task):
                        gamma = "" if np.isnan(row["gamma"]) else f"  Γ {row['gamma']:.2f}"
                        gamma += "" if exploration == "fixed" else f"  δ {row['perturbation_std']:.3f}"
                        drag = "" if np.isnan(row["drag_ratio"]) else f"  k {row['drag_ratio']:g}"
                        progress.update(task, advance=1, status=f"e {row['cross_track']:+.3f} BL  heading "
                                        f"{row['heading_error']:+.2f} rad  turn {row['turn_command']:+.3f}"
                                        f"{gamma}{drag}")

                    results[name] = tracker.run(device, reference, n_cycles, start_offset=start_offset, callback=show,
                                                record=True)
                    quarantined[name] = list(getattr(device, "quarantined", []))
                if name == "adaptive" and exploration != "fixed":
                    sizes = results[name].perturbation_std  # the others replay it: the same perturbations
        finally:
            if progress.live.is_started:
                progress.stop()
        log = pd.concat([r.log for r in results.values()], ignore_index=True)
        summary = {}
        for name, result in results.items():
            summary[name] = result.summary() | {"final_gamma": float(result.log["gamma"].iloc[-1])}
            if name != "adaptive":
                summary[name]["final_gamma_null_reason"] = f"the {name} controller does not learn: no online Γ"
            if robot is not None:
                summary[name]["quarantined_cycles"] = len(quarantined[name])
                summary[name]["quarantine_reasons"] = quarantined[name][:20]
            ran = len(result.log)
            summary[name]["stopped_early"] = ran < n_cycles
            if ran < n_cycles:
                summary[name]["stop_reason"] = (f"the {name} controller reached the end of the path after {ran} of "
                                                f"{n_cycles} cycles")
                warnings.warn(summary[name]["stop_reason"] + "; the summary covers the cycles run", GeogaitWarning,
                              stacklevel=1)
        means = [summary.get(n, {}).get("cross_track_mean") for n in ("adaptive", "true")]
        if None not in means and means[1] > 0:
            summary["adaptive_over_true_cross_track"] = means[0] / means[1]
        if len(ratios) == 2:
            summary["drag_change"] = drag_change_metrics(log.assign(trial=0), change)
        summary["step_per_cycle"] = step
        summary["path_length"] = reference.length
        summary["path_closed"] = reference.closed
        with output_set(folder, members=TRACK_FILES, last=("summary.json",)) as staged:
            write_text(staged / "cycles.csv", log.to_csv(index=False))
            _plot_paths(staged / "path.png", reference, {n: r.log for n, r in results.items()},
                        {n: r.trajectory for n, r in results.items()}, {n: r.start for n, r in results.items()},
                        change if len(ratios) == 2 else None)
            fig, ax = plt.subplots(figsize=(6, 4.5))
            plot_steering_family(ax, {n: r.family for n, r in results.items()}, links if robot is None else "robot")
            save_figure(fig, staged / "family.png")
            write_manifest(staged / "summary.json", command="track", config=_json(config, "not used by this run"),
                           results=_json(summary), started=started)
        console.print(dumps_json(_json(summary), indent=1))
        console.print(f"wrote {folder}/ (cycles.csv, summary.json, path.png, family.png)")


def _track_trials(out, overwrite, options, trials, seed, jobs, scheduler, reference, config, started, step) -> None:
    """``geogait track --trials N``: the paired trials on the sweep runner, per-trial results written."""
    with claim_output(out, overwrite=overwrite):
        folder = Path(out)
        sweep = run_trials(track_trials, trials, seed=seed, chunk_size=1, jobs=jobs, scheduler=scheduler,
                           config=options, progress=True, description=f"{options['n_links']}-link tracking")
        sweep.raise_on_failure()
        log, wall, workers = sweep.frame.reset_index(drop=True), sweep.wall_time_s, sweep.n_workers
        change = config["change_cycle"]
        stats = trial_stats(log, change)
        summary = {}
        for name, part in stats.groupby("controller", sort=False):
            rows = log[log["controller"] == name]
            summary[name] = {"cross_track_mean": float(rows["cross_track"].abs().mean()),
                             "cross_track_p95": float(np.percentile(rows["cross_track"].abs(), 95)),
                             "heading_error_mean": float(rows["heading_error"].abs().mean()),
                             "heading_error_p95": float(np.percentile(rows["heading_error"].abs(), 95)),
                             "trial_cross_track_mean_worst": float(part["cross_track_mean"].max()),
                             "trials_stopped_early": int((part["cycles"] < config["cycles"]).sum())}
        ratios = per_trial_ratios(stats)
        if ratios:
            summary["adaptive_over_true_cross_track"] = (summary["adaptive"]["cross_track_mean"]
                                                         / summary["true"]["cross_track_mean"])
            summary["adaptive_over_true_per_trial"] = ratios
            summary["adaptive_over_true_worst_trial"] = ratios["worst"]
            summary["share_trials_within_1.5x_true"] = ratios["share_within"]
        if change is not None:
            summary["drag_change"] = drag_change_metrics(log, change)
        summary |= {"trials": trials, "step_per_cycle": step, "path_length": reference.length,
                    "path_closed": reference.closed, "wall_time_s_sweep": wall, "workers": workers}
        with output_set(folder, members=TRACK_FILES, last=("summary.json",)) as staged:
            write_text(staged / "cycles.csv", log.to_csv(index=False))
            write_text(staged / "trials.csv", stats.to_csv(index=False))
            first = log[log["trial"] == log["trial"].min()]
            _plot_paths(staged / "path.png", reference, {n: g for n, g in first.groupby("controller", sort=False)},
                        error_logs={n: g for n, g in log.groupby("controller", sort=False)}, change_cycle=change,
                        title=f"trial {int(first['trial'].iloc[0])} of {trials}; errors: mean of {trials} trials")
            write_manifest(staged / "summary.json", command="track", config=_json(config, "not used by this run"),
                           results=_json(summary), started=started)
        console.print(dumps_json(_json(summary), indent=1))
        console.print(f"wrote {folder}/ (cycles.csv, trials.csv, summary.json, path.png)")


def _plot_paths(file, reference: ReferencePath, logs: dict, trajectories: dict | None = None,
                starts: dict | None = None, change_cycle: int | None = None, error_logs: dict | None = None,
                title: str = "") -> None:
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
    save_figure(fig, file)


@figure_app.command("tracking")
def figure_tracking(
    trials: Annotated[int | None, typer.Option(help="Paired trials per swimmer [default: 20].")] = None,
    links: Annotated[str | None, typer.Option(help="Swimmers, comma-separated [default: 3,5].")] = None,
    cycles: Annotated[int | None, typer.Option(help="Tracking cycles per run [default: 60].")] = None,
    noise: Annotated[float | None, typer.Option(help="Sensor noise on ξ, fraction of RMS [default: 0.1].")] = None,
    perturbation: Annotated[float | None, typer.Option(
        help="Perturbation std (rad) of --exploration fixed [default: 0.05].")] = None,
    exploration: Annotated[str | None, typer.Option(
        help="fixed or adaptive (δ std sized every cycle from --exploration-low up to --exploration-high) "
             "[default: fixed].")] = None,
    exploration_low: Annotated[float | None, typer.Option(
        help="Smallest δ std (rad) of --exploration adaptive [default: 0.05].")] = None,
    exploration_high: Annotated[float | None, typer.Option(
        help="Largest δ std (rad) of --exploration adaptive [default: 0.15].")] = None,
    model: Annotated[str | None, typer.Option(
        help="window or shape: learning model of the adaptive and frozen controllers [default: shape].")] = None,
    change_forgetting: Annotated[float | None, typer.Option(
        help="At a surprise alarm the adaptive model forgets its evidence by this factor (1: never) "
             "[default: 100].")] = None,
    drag_only: Annotated[bool, typer.Option(
        help="Only the paths through the drag change (line and circle), with the same trials as in the "
             "full run.")] = False,
    path: Annotated[str | None, typer.Option(
        help="Paths at constant drag: comma-separated line, circle, figure8, waypoints and at most one waypoints "
             "CSV (columns x, y, body lengths, not scaled; a last row equal to the first closes it) [default: all "
             "four built-ins].")] = None,
    drag_path: Annotated[str | None, typer.Option(
        help="Paths through the drag change, the same names (the CSV must be the one of --path if both name "
             "one) [default: line,circle].")] = None,
    seed: Annotated[int | None, typer.Option(help="Root random seed [default: 0].")] = None,
    jobs: Annotated[int, typer.Option(help="joblib worker processes (-1: all cores).")] = 1,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address (needs geogait[dask]).")] = None,
    quick: Annotated[bool, typer.Option(help="3-link, 2 trials, 2 paths, 16 cycles: seconds.")] = False,
    from_csv: Annotated[Path | None, typer.Option(help="Redraw from this CSV instead of running.")] = None,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("out/figure-tracking"),
) -> None:
    """Path following with adaptive, frozen and true-connection controllers; drag change 2 → 4.

    Writes tracking.png, steering-family.png, tracking.csv (every cycle), tracking-trials.csv (one row
    per swimmer, path, environment, trial and controller, with the drag-change windows) and
    tracking.json (pooled and per-trial statistics).
    """
    started = time.perf_counter()
    paths, file = _figure_paths(path, "--path") if path is not None else (None, None)
    drag_paths, drag_file = _figure_paths(drag_path, "--drag-path") if drag_path is not None else (None, None)
    if file and drag_file and Path(file).resolve() != Path(drag_file).resolve():
        raise GeogaitError(f"The '--path' and '--drag-path' options take one waypoints CSV between them. Got {file} "
                           f"and {drag_file}.")
    if drag_only and path is not None:
        raise GeogaitError("The '--drag-only' option runs no path at constant drag; give the paths through the "
                           "change with '--drag-path' instead of '--path'.")
    path_file = file or drag_file
    references = None if path_file is None else {CUSTOM_PATH: ReferencePath.from_csv(path_file)}
    folder = output_folder(out)
    if from_csv is not None:
        result = TrackingResult.from_csv(from_csv)
    else:
        base = TrackingConfig.quick() if quick else TrackingConfig()
        changes = dict(n_trials=trials, n_cycles=cycles, sensor_noise=noise, perturbation=perturbation, seed=seed,
                       links=None if links is None else _links(links), exploration=exploration,
                       exploration_low=exploration_low, exploration_high=exploration_high, model=model,
                       change_forgetting=change_forgetting, paths=() if drag_only else paths,
                       drag_paths=drag_paths, path_file=path_file)
        config = dataclasses.replace(base, **{k: v for k, v in changes.items() if v is not None})
        if cycles is not None:
            config = dataclasses.replace(config, change_cycle=config.n_cycles // 2)
        result = run_tracking(config, jobs=jobs, scheduler=scheduler)
        result.to_csv(folder / "tracking.csv")
    result.plot(folder / "tracking.png", references)
    families = sorted(result.frame["links"].unique())
    fig, axes = plt.subplots(1, len(families), figsize=(6 * len(families), 4.5), squeeze=False)
    for ax, n_links in zip(axes[0], families, strict=True):
        plot_steering_family(ax, steering_families(int(n_links)), int(n_links))
    save_figure(fig, folder / "steering-family.png")
    change = result.config.change_cycle if result.config is not None else int(result.frame["cycle"].max() + 1) // 2
    write_text(folder / "tracking-trials.csv", trial_stats(result.frame, change).to_csv(index=False))
    summary = result.summary()
    write_manifest(folder / "tracking.json", command="figure tracking",
                   config=result.config_dict() or {"from_csv": str(from_csv)},
                   results=_json({"wall_time_s_sweeps": result.wall_time_s, "workers": result.n_workers,
                                  **summary}), started=started)
    console.print(dumps_json(_json(summary), indent=1))
    console.print(f"wrote {folder}/ (tracking.png, steering-family.png, tracking.csv, tracking-trials.csv, "
                  "tracking.json)")
