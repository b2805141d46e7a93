"""``geogait optimize``: one in-situ gait optimisation of a built-in Purcell swimmer (the main job)."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._files import dumps_json, write_text
from .._validation import GeogaitError, check_float, check_int
from ..experiments.optimization import (
    OptimizationConfig,
    OptimizationResult,
    default_budget,
    in_situ_model,
    run_optimization,
)
from ..gaits import Perturbation, seed_gait
from ..models import AdaptiveGaitModel, BatchGaitModel, ShapeSpaceModel
from ..optimize import OBJECTIVES, InSituOptimizer, cached_ceiling
from ..plotting import (
    plot_height_function,
    plot_joint_angles,
    plot_path,
    plot_progress,
    plot_shape_space,
    plt,
    save_figure,
)
from ..robots import ProcessRobot
from ..simulate import SwimmerStream
from ..systems import PurcellSwimmer
from ._app import app, figure_app
from ._common import comma_list, console, listed, output_folder, progress_bar, write_manifest

_FIG5 = OptimizationConfig()  # the experiment's defaults, shown in the help
_METHODS = ("adaptive", "shape", "batch")
RUN_FILE = "run.json"  # the settings of a run, read back by --resume
CHECKPOINT_FILE = "checkpoint.npz"


@app.command()
def optimize(
    links: Annotated[int, typer.Option(min=2, max=200, help="Number of links N of the built-in Purcell swimmer.")] = 3,
    cycles: Annotated[int | None, typer.Option(
        help=f"Cycle budget [default: {default_budget(3)} for 3 links, else {default_budget(5)}; 100 with --robot]. "
             "With --resume: the new total.",
    )] = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed of perturbations and sensor noise.")] = 0,
    noise: Annotated[float, typer.Option(min=0, help="Sensor noise on ξ, fraction of its RMS.")] = 0.1,
    perturbation: Annotated[float, typer.Option(min=0, help="Std (rad) of the shape perturbation δ.")] = 0.15,
    period: Annotated[float, typer.Option(help="Seconds per cycle of the built-in swimmer.")] = 1.0,
    gamma_threshold: Annotated[float, typer.Option(help="Γ* that gates a step.")] = 0.5,
    forgetting_factor: Annotated[float | None, typer.Option(
        help="λ of the RLS filters [default: 1 - 0.1/d for d joints].")] = None,
    order: Annotated[int, typer.Option(help="Fourier order of the optimised gait family.")] = 1,
    objective: Annotated[str, typer.Option(
        help=f"Objective: {', '.join(OBJECTIVES)} (forward: along the seed's initial heading).")] = "progress",
    max_joint_angle: Annotated[float, typer.Option(help="Joint limit r_max (rad).")] = 2 * np.pi / 3,
    max_joint_velocity: Annotated[float | None, typer.Option(help="Joint speed limit (rad/s) [default: none].")] = None,
    settle_cycles: Annotated[int, typer.Option(help="Cycles after a gait change not learned from.")] = 0,
    max_tracking_error: Annotated[str, typer.Option(
        help="Largest RMS realised - commanded shape (rad) of an accepted gait: a number, auto or off.")] = "auto",
    method: Annotated[str, typer.Option(
        help="Model: adaptive (this paper's RLS window model), shape (connection over shape space: Fig. 5's, "
             "degree 4 with the swimmer's mirror and front-back symmetries; for --robot degree 3 without) or "
             "batch (Bittner 2018).",
    )] = "adaptive",
    family: Annotated[str, typer.Option(
        help="Gait family: auto (rotation-free symmetric family on front-back symmetric chains), free or "
             "symmetric.")] = "auto",
    step_rule: Annotated[str, typer.Option(help="Step rule: linear (linearised, constrained) or sqp.")] = "linear",
    robot: Annotated[str | None, typer.Option(
        help="Optimise the robot behind this driver command (JSON-lines bridge) instead of the swimmer.")] = None,
    robot_timeout: Annotated[float, typer.Option(help="Seconds to wait for each line of the driver.")] = 30.0,
    checkpoint_every: Annotated[int, typer.Option(help="Write OUT/checkpoint.npz every this many cycles.")] = 1,
    resume: Annotated[Path | None, typer.Option(
        help="Continue the run whose folder this is (its settings; other options ignored except --cycles).")] = None,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("out/optimize"),
) -> None:
    """Optimise a gait in situ (built-in swimmer or --robot); write PNGs, per-cycle CSV, JSON summary."""
    started = time.perf_counter()
    if resume is not None:
        folder, settings = Path(resume), _read_settings(Path(resume))
        if cycles is not None:
            settings["cycles"] = cycles
    else:
        settings = dict(links=links, cycles=cycles, seed=seed, noise=noise, perturbation=perturbation,
                        period=period, gamma_threshold=gamma_threshold, forgetting_factor=forgetting_factor,
                        order=order, objective=objective, max_joint_angle=max_joint_angle,
                        max_joint_velocity=max_joint_velocity, settle_cycles=settle_cycles,
                        max_tracking_error=max_tracking_error, method=method, family=family,
                        step_rule=step_rule, robot=robot,
                        robot_timeout=robot_timeout, checkpoint_every=checkpoint_every)
        folder = out
    optimizer = _optimizer(settings)  # every option checked before anything starts or is written
    folder = output_folder(folder)
    system, target = _target(settings)
    ceiling = None
    if system is not None:
        with console.status("computing the ceiling with the true connection (cached after the first run)"):
            ceiling = cached_ceiling(system, order=settings["order"], objective_kind=_ceiling_kind(settings),
                                     max_joint_angle=settings["max_joint_angle"])
    with target() as robot_driver:
        if resume is None:
            _write_settings(folder, settings)
        result = _run(optimizer, robot_driver, settings, folder, ceiling, resume is not None)
    write_text(folder / "cycles.csv", result.log.to_csv(index=False))
    _figures(folder, system, result, ceiling)
    summary = result.summary(ceiling)
    write_manifest(folder / "summary.json", command="optimize", config={**settings,
                   "optimizer": optimizer.describe(), "resumed": resume is not None}, results=summary,
                   started=started)
    console.print(dumps_json(summary, indent=1))
    console.print(f"wrote {folder}/ (cycles.csv, summary.json, gait.png, progress.png, path.png, {CHECKPOINT_FILE})")


def _optimizer(settings) -> InSituOptimizer:
    if settings["method"] not in _METHODS:
        raise typer.BadParameter(f"expected one of {', '.join(_METHODS)}, got {settings['method']!r}",
                                 param_hint="--method")
    tracking = settings["max_tracking_error"]
    if tracking not in ("auto", "off"):
        try:
            tracking = float(tracking)
        except ValueError:
            raise typer.BadParameter(f"expected a number, 'auto' or 'off', got {tracking!r}",
                                     param_hint="--max-tracking-error") from None
    if settings["cycles"] is not None:
        check_int(settings["cycles"], "cycles", "geogait optimize", minimum=1)
    check_int(settings["checkpoint_every"], "checkpoint_every", "geogait optimize", minimum=1)
    forgetting = settings["forgetting_factor"]
    model = {"batch": lambda: BatchGaitModel(),
             "shape": lambda: _shape_model(settings["links"], settings["robot"] is not None, forgetting),
             "adaptive": lambda: None if forgetting is None else AdaptiveGaitModel(forgetting_factor=forgetting),
             }[settings["method"]]()
    return InSituOptimizer(model=model, gamma_threshold=settings["gamma_threshold"], order=settings["order"],
                           objective=settings["objective"], max_joint_angle=settings["max_joint_angle"],
                           max_joint_velocity=settings["max_joint_velocity"],
                           settle_cycles=settings["settle_cycles"], family=settings.get("family", "auto"),
                           step_rule=settings.get("step_rule", "linear"),
                           max_tracking_error=None if tracking == "off" else tracking).validate()


def _shape_model(links: int, robot: bool, forgetting: float | None) -> ShapeSpaceModel:
    """Fig. 5's model on the built-in swimmer; for a robot, whose symmetries are not known, degree 3 without
    symmetry (degree 4 without it would be 4 × the weights)."""
    model = ShapeSpaceModel(degree=3) if robot else in_situ_model("auto", links)
    return model if forgetting is None else model.set_params(forgetting_factor=forgetting)


def _ceiling_kind(settings) -> str:
    return "progress" if settings["objective"] == "forward" else settings["objective"]


def _target(settings):
    """(system or None, context manager giving the robot): the built-in swimmer or a driver process."""
    if settings["robot"] is not None:
        return None, lambda: ProcessRobot(settings["robot"], timeout=settings["robot_timeout"])
    system = PurcellSwimmer(settings["links"])
    check_float(settings["period"], "period", "geogait optimize", low=0, low_open=True)
    perturbation = Perturbation.from_std(settings["perturbation"], frequency=2.0 / settings["period"])
    stream = SwimmerStream(system, seed_gait(system.n_joints), perturbation=perturbation,
                           sensor_noise=settings["noise"], seed=settings["seed"], cycle_period=settings["period"])
    return system, lambda: contextlib.nullcontext(stream)


def _run(optimizer, robot, settings, folder, ceiling, resumed):
    cycles = settings["cycles"]
    if cycles is None:
        cycles = 100 if settings["robot"] is not None else default_budget(settings["links"])
    name = f"robot {settings['robot']!r}" if settings["robot"] else f"{settings['links']}-link"
    with progress_bar() as progress:
        task = progress.add_task(f"{name} {settings['method']}", total=cycles, status="")

        def show(row):
            gamma = "  – " if np.isnan(row["gamma"]) else f"{row['gamma']:.2f}"  # – : burn-in or settle cycle
            value = row.get("true_objective", row["measured_objective"])
            share = f"  {100 * row['ceiling_fraction']:.0f}% of ceiling" if "ceiling_fraction" in row else ""
            status = f"Γ {gamma}  {value:.4f}/cycle{share}  steps {row['iteration']}"
            progress.update(task, completed=row["cycle"] + 1, status=status)

        checkpoint = folder / CHECKPOINT_FILE
        if resumed:
            return InSituOptimizer.resume(checkpoint, robot, callback=show, record=True, n_cycles=cycles)
        return optimizer.run(robot, cycles, ceiling=None if ceiling is None else ceiling.value, callback=show,
                             record=True, checkpoint=checkpoint, checkpoint_every=settings["checkpoint_every"])


def _write_settings(folder: Path, settings: dict) -> None:
    write_text(folder / RUN_FILE, dumps_json(settings, indent=1) + "\n")


def _read_settings(folder: Path) -> dict:
    path = folder / RUN_FILE
    if not path.is_file() or not (folder / CHECKPOINT_FILE).is_file():
        raise GeogaitError(f"--resume {folder}: not the folder of an optimisation run "
                           f"(needs {RUN_FILE} and {CHECKPOINT_FILE}).")
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise GeogaitError(f"{path} is not valid JSON: {error}") from None


def _figures(folder, system, result, ceiling) -> None:
    gaits = {"seed": result.initial_gait, "final": result.final_gait}
    if ceiling is not None:
        gaits["ceiling"] = ceiling.gait
    fig, ax = plt.subplots(figsize=(6.4, 5.4))
    if system is not None and system.n_joints == 2:
        pose = ceiling.displacement
        limit = max(g.joint_limit().max() for g in gaits.values()) * 1.15
        plot_height_function(ax, system, pose[:2] / np.hypot(*pose[:2]), limit)
        plot_shape_space(ax, None, gaits)
    else:
        plot_joint_angles(ax, gaits)
    save_figure(fig, folder / "gait.png")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    log = result.log
    seed_value = log["true_objective"].iloc[0] if "true_objective" in log else \
        log.loc[log["iteration"] == 0, "measured_objective"].mean()
    plot_progress(ax, log, seed_value=seed_value, ceiling_value=None if ceiling is None else ceiling.value)
    save_figure(fig, folder / "progress.png")
    fig, ax = plt.subplots(figsize=(6, 5))
    # A resumed run recorded only its last part: draw the cycle-start poses of the whole log then.
    whole = result.trajectory is not None and result.trajectory.n_samples >= len(log) * 4 \
        and int(result.trajectory.cycle[0]) == 0
    plot_path(ax, result.trajectory.pose if whole else log[["world_x", "world_y", "world_heading"]].to_numpy())
    save_figure(fig, folder / "path.png")


@figure_app.command("optimization")
def figure_optimization(
    trials: Annotated[int | None, typer.Option(
        min=1, help=f"In-situ trials per swimmer [default: {_FIG5.n_trials}].")] = None,
    links: Annotated[str | None, typer.Option(
        help=f"Swimmers, comma-separated [default: {listed(_FIG5.links)}].")] = None,
    cycles: Annotated[str | None, typer.Option(
        help=f"Cycle budgets per swimmer [default: {listed(_FIG5.budgets)}].")] = None,
    baseline_trials: Annotated[int | None, typer.Option(
        min=0, help=f"Batch-method trials per swimmer [default: {_FIG5.baseline_trials}].")] = None,
    baseline_iterations: Annotated[int | None, typer.Option(
        min=1, help=f"Batch iterations of {InSituOptimizer().cycles_per_iteration} cycles "
             f"[default: {_FIG5.baseline_iterations}].")] = None,
    noise: Annotated[float | None, typer.Option(
        min=0, help=f"Sensor noise on ξ, fraction of RMS [default: {_FIG5.sensor_noise}].")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help=f"Root random seed [default: {_FIG5.seed}].")] = None,
    jobs: Annotated[int, typer.Option(help="joblib worker processes (-1: all cores).")] = 1,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address (needs geogait[dask]).")] = None,
    quick: Annotated[bool, typer.Option(help="3-link only, a few short trials: seconds.")] = False,
    from_csv: Annotated[Path | None, typer.Option(help="Redraw from this CSV instead of running.")] = None,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("out/figure-optimization"),
) -> None:
    """Paper Fig. 5: in-situ optimisation of the 3-, 5-, 9-link swimmers, ceiling and batch baseline."""
    started = time.perf_counter()
    folder = output_folder(out)
    if from_csv is not None:
        result = OptimizationResult.from_csv(from_csv)
    else:
        base = OptimizationConfig.quick() if quick else OptimizationConfig()
        changes = dict(n_trials=trials, baseline_trials=baseline_trials, baseline_iterations=baseline_iterations,
                       sensor_noise=noise, seed=seed,
                       links=comma_list(links, "--links", int), budgets=comma_list(cycles, "--cycles", int))
        config = dataclasses.replace(base, **{k: v for k, v in changes.items() if v is not None})
        if links is not None and cycles is None:
            config = dataclasses.replace(config, budgets=tuple(map(default_budget, config.links)))
        result = run_optimization(config, jobs=jobs, scheduler=scheduler)
        result.to_csv(folder / "optimization.csv")
    result.plot(folder / "optimization.png")
    summary = result.summary()
    manifest = write_manifest(folder / "optimization.json", command="figure optimization",
                              config=result.config_dict() or {"from_csv": str(from_csv)},
                              results={"wall_time_s_sweeps": result.wall_time_s, "workers": result.n_workers,
                                       **summary}, started=started)
    console.print(dumps_json(summary, indent=1, default=str))
    written = ["optimization.png", *([] if from_csv is not None else ["optimization.csv"]), manifest.name]
    console.print(f"wrote {folder}/ ({', '.join(written)})")

