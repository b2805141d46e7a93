"""``geogait track``: follow a path with steering gaits (adaptive, frozen and true-connection
controllers), and ``geogait figure tracking``: the seeded multi-trial experiment."""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import typer

from .._files import json_ready, output_set, write_text
from .._validation import GeogaitError
from ._app import app, figure_app
from ._common import (
    EXPERIMENT_PANEL,
    RUN_PANEL,
    FromCsv,
    Jobs,
    Json,
    Out,
    Overwrite,
    Scheduler,
    claim_figure,
    claim_output,
    configure,
    console,
    explain_nulls,
    one_of,
    output_folder,
    print_results,
    progress_bar,
    results_table,
    write_manifest,
)

#: The built-in paths and the steering options' choices (spelled out for a fast help; tests/cli check them).
_PATHS = ("line", "circle", "figure8", "waypoints")
_EXPLORATION, _MODELS = ("fixed", "adaptive"), ("window", "shape")
#: The help's option groups.
_PATH, _CONTROL, _EXPLORE, _ROBOT = "Path", "Controllers", "Exploration", "Swimmer or robot"

#: Every file ``geogait track`` writes (replaced together, as one set); ``trials.csv`` with ``--trials`` > 1,
#: ``family.png`` with one trial.
TRACK_FILES = ("cycles.csv", "path.png", "family.png", "trials.csv", "summary.json")


def _links(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        message = f"The '--links' option must be comma-separated integers such as 3,5. Got {text!r} instead."
        raise GeogaitError(message) from None


def _ratios(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise GeogaitError("The '--drag-ratio' option must be one positive number or two, comma-separated "
                           f"(before and after the change, e.g. 2,4). Got {text!r} instead.") from None


def _figure_paths(text: str, option: str) -> tuple[tuple[str, ...], str | None]:
    """``--path`` / ``--drag-path`` of ``figure tracking``: built-in names and at most one waypoints CSV."""
    from ..experiments.tracking import CUSTOM_PATH, PATHS

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


def _json(value, reason: str = "not available for this run"):
    """Strict JSON values: NaN and inf become null with a reason, and so does every other null."""
    return explain_nulls(json_ready(value), reason)


@app.command()
def track(
    links: Annotated[int, typer.Option(rich_help_panel=_ROBOT, help="Links of the built-in Purcell swimmer.")] = 3,
    noise: Annotated[float, typer.Option(
        rich_help_panel=_ROBOT, help="Sensor noise on the built-in swimmer's ξ, a fraction of its RMS.")] = 0.1,
    robot: Annotated[str | None, typer.Option(
        metavar="COMMAND", rich_help_panel=_ROBOT,
        help="Follow the path with the robot behind this driver command (JSON-lines bridge), a fresh driver process "
             "per controller; its current gait is the straight gait.")] = None,
    robot_timeout: Annotated[float, typer.Option(
        rich_help_panel=_ROBOT, help="Seconds to wait for each line of the --robot driver.")] = 30.0,
    step: Annotated[float | None, typer.Option(
        rich_help_panel=_ROBOT, help="With --robot: the straight gait's step per cycle (pose units), which sizes "
                                     "the built-in paths (not needed for a waypoints CSV).")] = None,
    path: Annotated[str, typer.Option(
        metavar=one_of((*_PATHS, "FILE.csv")), rich_help_panel=_PATH,
        help="A built-in path (waypoints: a 1.5 × 1 rectangle), or a waypoints CSV (columns x, y in body lengths; a "
             "last row equal to the first closes the path).")] = "circle",
    scale: Annotated[float, typer.Option(
        rich_help_panel=_PATH, help="Size of the built-in paths in steps of the straight gait.")] = 10.0,
    offset: Annotated[float | None, typer.Option(
        rich_help_panel=_PATH, help="Start this far left of the path (body lengths) [default: 3 steps on the "
                                    "line, else 0].")] = None,
    cycles: Annotated[int | None, typer.Option(
        rich_help_panel=_PATH, help="Tracking cycles [default: 60; 12 with --quick].")] = None,
    drag_ratio: Annotated[str, typer.Option(
        rich_help_panel=_PATH, help="Drag ratio k, or two (e.g. 2,4): k changes unannounced at "
                                    "--change-cycle.")] = "2",
    change_cycle: Annotated[int | None, typer.Option(
        rich_help_panel=_PATH, help="Tracking cycle of the drag-ratio change [default: half of --cycles].")] = None,
    controllers: Annotated[str | None, typer.Option(
        rich_help_panel=_CONTROL,
        help="Comma-separated: adaptive (keeps learning), frozen (stops learning after the warm-up), true (the "
             "true connection, built-in swimmer only) [default: all three; adaptive,frozen with --robot].")] = None,
    model: Annotated[Literal[_MODELS], typer.Option(
        metavar=one_of(_MODELS), rich_help_panel=_CONTROL,
        help="Model of the adaptive and frozen controllers: window (local, about the straight gait) or shape "
             "(over the shape space, degree 3).")] = "shape",
    warmup: Annotated[int | None, typer.Option(
        rich_help_panel=_CONTROL, help="Straight-gait cycles before tracking [default: 10; 5 with --quick].")] = None,
    warmup_turns: Annotated[int | None, typer.Option(
        rich_help_panel=_CONTROL, help="Turning cycles after the straight ones (at ±½ and ±1 × the turn limit) "
                                       "[default: 4; 0 with --robot].")] = None,
    horizon: Annotated[int, typer.Option(
        rich_help_panel=_CONTROL, help="Cycles predicted per decision where the path bends ahead.")] = 4,
    straight_horizon: Annotated[int, typer.Option(
        rich_help_panel=_CONTROL, help="Cycles predicted where the path ahead is straight (≤ --horizon).")] = 2,
    turn_limit: Annotated[float | None, typer.Option(
        rich_help_panel=_CONTROL, help="Largest turn per cycle (rad) [default: 1, cut to what the joint limits "
                                       "allow].")] = None,
    change_forgetting: Annotated[float, typer.Option(
        rich_help_panel=_CONTROL, help="When its prediction error jumps (a surprise alarm), the adaptive model "
                                       "divides the weight of its evidence by this (1: never).")] = 100.0,
    exploration: Annotated[Literal[_EXPLORATION], typer.Option(
        metavar=one_of(_EXPLORATION), rich_help_panel=_EXPLORE,
        help="Std of the shape perturbation δ: fixed (--perturbation) or adaptive (each cycle between "
             "--exploration-low and --exploration-high, from the adaptive controller's prediction error).")
    ] = "fixed",
    perturbation: Annotated[float, typer.Option(
        rich_help_panel=_EXPLORE, help="Std (rad) of δ with --exploration fixed.")] = 0.05,
    exploration_low: Annotated[float, typer.Option(
        rich_help_panel=_EXPLORE, help="Smallest std (rad) of δ with --exploration adaptive.")] = 0.05,
    exploration_high: Annotated[float, typer.Option(
        rich_help_panel=_EXPLORE, help="Largest std (rad) of δ with --exploration adaptive (warm-up, after an "
                                       "alarm).")] = 0.15,
    seed: Annotated[int, typer.Option(
        rich_help_panel=RUN_PANEL, help="Random seed of the built-in swimmer's perturbations and noise.")] = 0,
    trials: Annotated[int, typer.Option(
        min=1, rich_help_panel=RUN_PANEL,
        help="Paired trials on the built-in swimmer (trial i: seed SeedSequence(--seed).spawn(N)[i]); with N > 1: "
             "trials.csv (one row per trial and controller) and per-trial ratios, no live display, no "
             "family.png.")] = 1,
    jobs: Annotated[int, typer.Option(
        rich_help_panel=RUN_PANEL, help="joblib worker processes for --trials N > 1 (-1: all cores).")] = 1,
    scheduler: Annotated[str | None, typer.Option(
        rich_help_panel=RUN_PANEL, help="Dask scheduler address for --trials N > 1 (needs geogait[dask]).")] = None,
    quick: Annotated[bool, typer.Option(
        "--quick", rich_help_panel=RUN_PANEL, help="A short run: 5 warm-up and 12 tracking cycles.")] = False,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", rich_help_panel=RUN_PANEL, help="Replace the run in --out (when this run ends).")] = False,
    out: Annotated[Path, typer.Option(
        metavar="DIR", rich_help_panel=RUN_PANEL, help="Output folder (empty or new, unless --overwrite).")
    ] = Path("out/track"),
    json_output: Json = False,
) -> None:
    """Follow a path with steering gaits; write path.png, family.png, cycles.csv and the manifest summary.json.

    With --trials N > 1: path.png, cycles.csv, trials.csv and summary.json, per-trial ratios included.

    Each controller runs on its own copy of the simulated swimmer with the same seed (same perturbations
    and noise), or its own driver process of --robot: the adaptive model keeps learning, the frozen one
    stops after the warm-up, and the true controller (swimmer only) uses the true connection of the
    environment in force.
    """
    from ..experiments.track import TrackSettings, run_track

    started = time.perf_counter()
    settings = TrackSettings(
        links=links, path=path, drag_ratios=_ratios(drag_ratio), cycles=cycles, change_cycle=change_cycle,
        controllers=None if controllers is None else tuple(v.strip() for v in controllers.split(",") if v.strip()),
        warmup=warmup, warmup_turns=warmup_turns, scale=scale, offset=offset, seed=seed, noise=noise,
        perturbation=perturbation, horizon=horizon, straight_horizon=straight_horizon,
        turn_limit=turn_limit, exploration=exploration, exploration_low=exploration_low,
        exploration_high=exploration_high, model=model, change_forgetting=change_forgetting, robot=robot,
        robot_timeout=robot_timeout, step=step, trials=trials, jobs=jobs, scheduler=scheduler, quick=quick,
    ).resolved(_option)
    with claim_output(out, overwrite=overwrite):  # checked and locked before any work; replaced as one set
        if trials > 1:
            outcome = run_track(settings, progress=True)
        else:
            with _live_progress(settings) as show:
                outcome = run_track(settings, callback=show)
        written = ("cycles.csv", "summary.json", "path.png") + (("trials.csv",) if trials > 1 else ("family.png",))
        with output_set(Path(out), members=TRACK_FILES, last=("summary.json",)) as staged:
            write_text(staged / "cycles.csv", outcome.log.to_csv(index=False))
            if outcome.trials is not None:
                write_text(staged / "trials.csv", outcome.trials.to_csv(index=False))
            else:
                outcome.plot_family(staged / "family.png")
            outcome.plot_paths(staged / "path.png")
            write_manifest(staged / "summary.json", command="track",
                           config=_json(settings.manifest(outcome.step), "not used by this run"),
                           results=_json(outcome.summary), started=started)
        print_results(_json(outcome.summary), lambda: _results_table(outcome.summary), as_json=json_output)
        console.print(f"wrote {out}/ ({', '.join(written)})")


def _results_table(summary: dict):
    """Each controller's tracking errors (summary.json holds every number)."""
    table = results_table("Tracking error per controller", "controller", "cycles", "cross-track mean (BL)",
                          "cross-track p95", "heading mean (rad)", "heading p95", "final Γ")
    for name, numbers in summary.items():
        if isinstance(numbers, dict) and "cross_track_mean" in numbers:
            cells = [numbers.get(key) for key in ("cross_track_mean", "cross_track_p95", "heading_error_mean",
                                                    "heading_error_p95", "final_gamma")]
            table.add_row(name + (" (stopped early)" if numbers.get("stopped_early") else ""),
                          str(numbers.get("cycles", "")), *("–" if v is None else f"{v:.3g}" for v in cells))
    if not table.rows:  # (--trials N > 1: the pooled statistics)
        return _flat_table("geogait track", summary)
    return table


def _flat_table(title: str, summary: dict):
    """Every number of a nested summary, one row each, named by its path ("adaptive › cross_track_mean")."""
    table = results_table(title, "result", "value")

    def add(prefix, value):
        if isinstance(value, dict):
            for key, item in value.items():
                if not str(key).endswith("_null_reason"):
                    add(f"{prefix} › {key}" if prefix else str(key), item)
        elif isinstance(value, bool) or not isinstance(value, int | float):
            table.add_row(prefix, "–" if value is None else str(value))
        else:
            table.add_row(prefix, f"{value:.4g}")

    add("", summary)
    return table


def _option(field: str) -> str:
    """How an error names a TrackSettings field: as the option that set it."""
    return f"'--{_OPTION_NAMES.get(field, field).replace('_', '-')}' option"


_OPTION_NAMES = {"drag_ratios": "drag_ratio"}


@contextlib.contextmanager
def _live_progress(settings):
    """One progress bar per controller, added once its robot is up (a driver that cannot start fails first)."""
    label = "robot" if settings.robot is not None else f"{settings.links}-link"
    progress, tasks = progress_bar(), {}

    def show(name, row):
        if row is None:
            progress.start()
            tasks[name] = progress.add_task(f"{label} {name:8s}", total=settings.cycles, status="warming up")
            return
        gamma = "" if np.isnan(row["gamma"]) else f"  Γ {row['gamma']:.2f}"
        gamma += "" if settings.exploration == "fixed" else f"  δ {row['perturbation_std']:.3f}"
        drag = "" if np.isnan(row["drag_ratio"]) else f"  k {row['drag_ratio']:g}"
        progress.update(tasks[name], advance=1, status=f"e {row['cross_track']:+.3f} BL  heading "
                        f"{row['heading_error']:+.2f} rad  turn {row['turn_command']:+.3f}{gamma}{drag}")

    try:
        yield show
    finally:
        if progress.live.is_started:
            progress.stop()


@figure_app.command("tracking")
def figure_tracking(
    trials: Annotated[int | None, typer.Option(
        rich_help_panel=EXPERIMENT_PANEL, help="Paired trials per swimmer [default: 20].")] = None,
    links: Annotated[str | None, typer.Option(
        rich_help_panel=EXPERIMENT_PANEL, help="Swimmers, comma-separated [default: 3,5].")] = None,
    cycles: Annotated[int | None, typer.Option(
        rich_help_panel=EXPERIMENT_PANEL, help="Tracking cycles per run [default: 60].")] = None,
    noise: Annotated[float | None, typer.Option(
        rich_help_panel=EXPERIMENT_PANEL, help="Sensor noise on ξ, fraction of RMS [default: 0.1].")] = None,
    perturbation: Annotated[float | None, typer.Option(rich_help_panel=_EXPLORE,
        help="Perturbation std (rad) of --exploration fixed [default: 0.05].")] = None,
    exploration: Annotated[Literal[_EXPLORATION] | None, typer.Option(
        metavar=one_of(_EXPLORATION), rich_help_panel=_EXPLORE,
        help="Std of the shape perturbation δ: fixed (--perturbation) or adaptive (each cycle between "
             "--exploration-low and --exploration-high) [default: fixed].")] = None,
    exploration_low: Annotated[float | None, typer.Option(rich_help_panel=_EXPLORE,
        help="Smallest δ std (rad) of --exploration adaptive [default: 0.05].")] = None,
    exploration_high: Annotated[float | None, typer.Option(rich_help_panel=_EXPLORE,
        help="Largest δ std (rad) of --exploration adaptive [default: 0.15].")] = None,
    model: Annotated[Literal[_MODELS] | None, typer.Option(
        metavar=one_of(_MODELS), rich_help_panel=EXPERIMENT_PANEL,
        help="Model of the adaptive and frozen controllers: window (local) or shape (over the shape space) "
             "[default: shape].")] = None,
    change_forgetting: Annotated[float | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="When its prediction error jumps (a surprise alarm), the adaptive model divides the weight of its "
             "evidence by this (1: never) [default: 100].")] = None,
    warmup_turns: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Turning warm-up cycles after the straight ones (the model's steering gaits for ±½ and ±1 × the turn "
             "limit; 0: none) [default: 4].")] = None,
    drag_only: Annotated[bool, typer.Option("--drag-only", rich_help_panel=EXPERIMENT_PANEL,
        help="Only the paths through the drag change (line and circle), with the same trials as in the "
             "full run.")] = False,
    path: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Paths at constant drag: comma-separated line, circle, figure8, waypoints and at most one waypoints "
             "CSV (columns x, y, body lengths, not scaled; a last row equal to the first closes it) [default: all "
             "four built-ins].")] = None,
    drag_path: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Paths through the drag change, the same names (the CSV must be the one of --path if both name "
             "one) [default: line,circle].")] = None,
    seed: Annotated[int | None, typer.Option(rich_help_panel=RUN_PANEL, help="Root random seed [default: 0].")] = None,
    jobs: Jobs = 1,
    scheduler: Scheduler = None,
    quick: Annotated[bool, typer.Option(
        "--quick", rich_help_panel=RUN_PANEL, help="3-link, 2 trials, 2 paths, 16 cycles: seconds.")] = False,
    from_csv: FromCsv = None,
    out: Out = Path("out/figure-tracking"),
    overwrite: Overwrite = False,
    json_output: Json = False,
) -> None:
    """Path following with adaptive, frozen and true-connection controllers; drag change 2 → 4.

    Writes tracking.png, steering-family.png, tracking.csv (every cycle), tracking-trials.csv (one row
    per swimmer, path, environment, trial and controller, with the drag-change windows) and
    the manifest tracking.json (pooled and per-trial statistics).
    """
    from ..control import ReferencePath
    from ..experiments.tracking import (
        CUSTOM_PATH,
        TrackingConfig,
        TrackingResult,
        drag_change_cycle,
        plot_steering_family,
        run_tracking,
        steering_families,
        trial_stats,
    )
    from ..plotting import plt, save_figure

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
    members, manifest = claim_figure(out, "tracking", from_csv, "figure tracking", overwrite=overwrite,
                                     extra=("tracking-trials.csv", "steering-family.png"))
    if from_csv is not None:
        result = TrackingResult.from_csv(from_csv)
    else:
        base = TrackingConfig.quick() if quick else TrackingConfig()
        config = configure(
            base, n_trials=("--trials", trials), n_cycles=("--cycles", cycles), sensor_noise=("--noise", noise),
            perturbation=("--perturbation", perturbation), seed=("--seed", seed),
            links=("--links", None if links is None else _links(links)), exploration=("--exploration", exploration),
            exploration_low=("--exploration-low", exploration_low),
            exploration_high=("--exploration-high", exploration_high), model=("--model", model),
            change_forgetting=("--change-forgetting", change_forgetting), warmup_turns=("--warmup-turns", warmup_turns),
            paths=("--path", () if drag_only else paths), drag_paths=("--drag-path", drag_paths),
            path_file=("--path", path_file), change_cycle=("--cycles", None if cycles is None else cycles // 2))
        output_folder(out)  # (before the run: a file in its place is refused now)
        result = run_tracking(config, jobs=jobs, scheduler=scheduler)
    folder = output_folder(out)
    summary = result.summary()
    change = result.config.change_cycle if result.config is not None else drag_change_cycle(result.frame)
    with output_set(folder, last=(manifest,), members=members) as staged:  # one set: no two runs' files mixed
        if from_csv is None:
            result.to_csv(staged / "tracking.csv")
        result.plot(staged / "tracking.png", references)
        families = sorted(result.frame["links"].unique())
        fig, axes = plt.subplots(1, len(families), figsize=(6 * len(families), 4.5), squeeze=False)
        for ax, n_links in zip(axes[0], families, strict=True):
            plot_steering_family(ax, steering_families(int(n_links)), int(n_links))
        save_figure(fig, staged / "steering-family.png")
        write_text(staged / "tracking-trials.csv", trial_stats(result.frame, change).to_csv(index=False))
        write_manifest(staged / manifest, command="figure tracking",
                       config=result.config_dict() or {"from_csv": str(from_csv)},
                       results=_json({"wall_time_s_sweeps": result.wall_time_s, "workers": result.n_workers,
                                      **summary}), started=started)
    print_results(_json(summary), lambda: _flat_table("geogait figure tracking", summary), as_json=json_output)
    written = ["tracking.png", "steering-family.png", *([] if from_csv is not None else ["tracking.csv"]),
               "tracking-trials.csv", manifest]
    console.print(f"wrote {folder}/ ({', '.join(written)})")
