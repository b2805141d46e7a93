"""``geogait optimize``: one in-situ gait optimisation of a built-in Purcell swimmer (the main job)."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from ..experiments.optimization import OptimizationConfig, OptimizationResult, run_optimization
from ..gaits import Perturbation, seed_gait
from ..models import AdaptiveGaitModel, BatchGaitModel
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
from ..simulate import SwimmerStream
from ..systems import PurcellSwimmer
from ._app import app, figure_app
from ._common import console, output_folder, progress_bar, write_manifest

DEFAULT_CYCLES = {3: 40, 5: 60, 9: 60}


@app.command()
def optimize(
    links: Annotated[int, typer.Option(help="Number of links N of the Purcell swimmer.")] = 3,
    cycles: Annotated[int | None, typer.Option(help="Cycle budget (default 40 for 3 links, else 60).")] = None,
    seed: Annotated[int, typer.Option(help="Random seed of perturbations and sensor noise.")] = 0,
    noise: Annotated[float, typer.Option(help="Sensor noise on ξ, fraction of its RMS.")] = 0.1,
    perturbation: Annotated[float, typer.Option(help="Std (rad) of the shape perturbation δ.")] = 0.15,
    gamma_threshold: Annotated[float, typer.Option(help="Γ* that gates a step.")] = 0.5,
    forgetting_factor: Annotated[float | None, typer.Option(
        help="λ of the RLS filters [default: 1 - 0.1/d for d joints].")] = None,
    order: Annotated[int, typer.Option(help="Fourier order of the optimised gait family.")] = 1,
    objective: Annotated[str, typer.Option(help=f"Objective: {', '.join(OBJECTIVES)}.")] = "progress",
    max_joint_angle: Annotated[float, typer.Option(help="Joint limit r_max (rad).")] = 2 * np.pi / 3,
    method: Annotated[str, typer.Option(help="adaptive (this paper) or batch (Bittner 2018).")] = "adaptive",
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("out/optimize"),
) -> None:
    """Optimise the seed gait in situ; write PNGs, the per-cycle CSV and a JSON summary."""
    started = time.perf_counter()
    system = PurcellSwimmer(links)
    cycles = cycles if cycles is not None else DEFAULT_CYCLES.get(links, 60)
    if method not in ("adaptive", "batch"):
        raise typer.BadParameter(f"expected 'adaptive' or 'batch', got {method!r}", param_hint="--method")
    model = BatchGaitModel() if method == "batch" else (
        None if forgetting_factor is None else AdaptiveGaitModel(forgetting_factor=forgetting_factor))
    optimizer = InSituOptimizer(model=model, gamma_threshold=gamma_threshold, order=order, objective=objective,
                                max_joint_angle=max_joint_angle).validate()
    with console.status("computing the ceiling with the true connection (cached after the first run)"):
        ceiling = cached_ceiling(system, order=order, objective_kind=objective, max_joint_angle=max_joint_angle)
    stream = SwimmerStream(system, seed_gait(system.n_joints), perturbation=Perturbation.from_std(perturbation),
                           sensor_noise=noise, seed=seed)
    with progress_bar() as progress:
        task = progress.add_task(f"{links}-link {method}", total=cycles, status="")

        def show(row):
            gamma = "  – " if np.isnan(row["gamma"]) else f"{row['gamma']:.2f}"  # – : burn-in cycle after a step
            status = (f"Γ {gamma}  {row['true_objective']:.4f}/cycle  "
                      f"{100 * row['ceiling_fraction']:.0f}% of ceiling  steps {row['iteration']}")
            progress.update(task, advance=1, status=status)

        result = optimizer.run(stream, cycles, ceiling=ceiling.value, callback=show, record=True)
    folder = output_folder(out)
    result.log.to_csv(folder / "cycles.csv", index=False)
    _figures(folder, system, result, ceiling)
    summary = _summary(result, ceiling)
    config = dict(links=links, cycles=cycles, seed=seed, noise=noise, perturbation=perturbation,
                  method=method, optimizer=optimizer.describe())
    write_manifest(folder / "summary.json", command="optimize", config=config, results=summary, started=started)
    console.print(json.dumps(summary, indent=1))
    console.print(f"wrote {folder}/ (cycles.csv, summary.json, gait.png, progress.png, path.png)")


def _summary(result, ceiling) -> dict:
    log = result.log
    first_90 = log.index[log["ceiling_fraction"] >= 0.9]
    return {
        "seed_displacement_per_cycle": float(log["true_objective"].iloc[0]),
        "final_displacement_per_cycle": float(log["true_objective"].iloc[-1]),
        "ceiling_displacement_per_cycle": ceiling.value,
        "final_improvement": float(log["improvement"].iloc[-1]),
        "final_ceiling_fraction": float(log["ceiling_fraction"].iloc[-1]),
        "first_cycle_at_90_percent_of_ceiling": int(log["cycle"][first_90[0]]) if len(first_90) else None,
        "steps": result.n_steps,
        "max_abs_rotation_of_commanded_gaits": float(np.abs(log["true_heading"]).max()),
        "final_gait_params": result.final_gait.params.tolist(),
    }


def _figures(folder, system, result, ceiling) -> None:
    gaits = {"seed": result.initial_gait, "final": result.final_gait, "ceiling": ceiling.gait}
    fig, ax = plt.subplots(figsize=(6.4, 5.4))
    if system.n_joints == 2:
        pose = ceiling.displacement
        limit = max(g.joint_limit().max() for g in gaits.values()) * 1.15
        plot_height_function(ax, system, pose[:2] / np.hypot(*pose[:2]), limit)
        plot_shape_space(ax, None, gaits)
    else:
        plot_joint_angles(ax, gaits)
    save_figure(fig, folder / "gait.png")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    seed_value = result.log["true_objective"].iloc[0]
    plot_progress(ax, result.log, seed_value=seed_value, ceiling_value=ceiling.value)
    save_figure(fig, folder / "progress.png")
    fig, ax = plt.subplots(figsize=(6, 5))
    plot_path(ax, result.trajectory.pose)
    save_figure(fig, folder / "path.png")


@figure_app.command("optimization")
def figure_optimization(
    trials: Annotated[int | None, typer.Option(help="In-situ trials per swimmer [default: 50].")] = None,
    links: Annotated[str | None, typer.Option(help="Swimmers, comma-separated [default: 3,5,9].")] = None,
    cycles: Annotated[str | None, typer.Option(help="Cycle budgets per swimmer [default: 40,60,60].")] = None,
    baseline_trials: Annotated[int | None, typer.Option(help="Batch-method trials per swimmer [default: 10].")] = None,
    baseline_iterations: Annotated[int | None, typer.Option(
        help="Batch iterations of 30 cycles [default: 30].")] = None,
    noise: Annotated[float | None, typer.Option(help="Sensor noise on ξ, fraction of RMS [default: 0.1].")] = None,
    seed: Annotated[int | None, typer.Option(help="Root random seed [default: 0].")] = None,
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
                       links=_ints(links, "--links"), budgets=_ints(cycles, "--cycles"))
        config = dataclasses.replace(base, **{k: v for k, v in changes.items() if v is not None})
        if links is not None and cycles is None:
            config = dataclasses.replace(config, budgets=tuple(DEFAULT_CYCLES.get(n, 60) for n in config.links))
        result = run_optimization(config, jobs=jobs, scheduler=scheduler)
        result.to_csv(folder / "optimization.csv")
    result.plot(folder / "optimization.png")
    summary = result.summary()
    write_manifest(folder / "optimization.json", command="figure optimization",
                   config=result.config_dict() or {"from_csv": str(from_csv)},
                   results={"wall_time_s_sweeps": result.wall_time_s, "workers": result.n_workers, **summary},
                   started=started)
    console.print(json.dumps(summary, indent=1, default=str))
    console.print(f"wrote {folder}/ (optimization.png, .csv, .json)")


def _ints(text: str | None, option: str) -> tuple[int, ...] | None:
    if text is None:
        return None
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated integers such as '3,5,9', got {text!r}",
                                 param_hint=option) from None
