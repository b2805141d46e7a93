"""``geogait figure accuracy`` and ``geogait figure environments``: the paper's Fig. 2 and Fig. 3.

Each command runs its experiment (or, with ``--from-csv``, reads earlier results back) and writes
``<name>.png``, ``<name>.csv`` (long format: one row per trial × model × checkpoint) and
the manifest ``<name>.json`` (config, seed, versions, run time, headline numbers) into ``--out``.
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from .._files import output_set
from ._app import figure_app, help_from
from ._common import (
    EXPERIMENT_PANEL,
    RUN_PANEL,
    FromCsv,
    Jobs,
    Out,
    Overwrite,
    Scheduler,
    Seed,
    claim_figure,
    comma_list,
    configure,
    console,
    listed,
    output_folder,
    write_manifest,
)


def _help_values() -> dict:
    """The experiments' defaults the help texts show."""
    from ..experiments.accuracy import AccuracyConfig
    from ..experiments.environments import EnvironmentConfig

    accuracy, environments = AccuracyConfig(), EnvironmentConfig()
    return {"links": accuracy.n_links, "seed": accuracy.seed, "samples_per_cycle": accuracy.samples_per_cycle,
            "perturbation": accuracy.perturbation, "chunk_size": accuracy.chunk_size, "cycles": accuracy.n_cycles,
            "accuracy_noise": accuracy.sensor_noise, "environments_noise": environments.sensor_noise,
            "cycles_per_environment": environments.cycles_per_environment,
            "drag_ratios": listed(environments.drag_ratios),
            "forgetting_factors": listed(environments.forgetting_factors)}

Trials = Annotated[int | None, typer.Option(
    rich_help_panel=EXPERIMENT_PANEL, help="Number of trials (default: see the experiment's docs).", min=1)]
Links = Annotated[int | None, typer.Option(
    rich_help_panel=EXPERIMENT_PANEL, help="Links of the Purcell swimmer [default: {links}].")]
Quick = Annotated[bool, typer.Option("--quick", rich_help_panel=RUN_PANEL,
                                     help="Few trials and cycles: finishes in seconds.")]
SamplesPerCycle = Annotated[int | None, typer.Option(
    rich_help_panel=EXPERIMENT_PANEL, help="Samples per gait cycle [default: {samples_per_cycle}].",
                                                     min=4, max=100_000)]
Perturbation = Annotated[float | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
    help="Std (rad) of the shape perturbation δ [default: {perturbation}].")]
ChunkSize = Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
    help="Trials vectorised per chunk; results are identical for any --jobs at a fixed chunk size "
         "[default: {chunk_size}].")]


def _figure(name: str, experiment: tuple, table: Callable[[dict], Table], own: Callable[[], dict], *,
            perturbation: Perturbation = None,
            samples_per_cycle: SamplesPerCycle = None,
            chunk_size: ChunkSize = None,
            seed: Seed = None,
            jobs: Jobs = 1,
            scheduler: Scheduler = None,
            quick: Quick = False,
            out: Out = Path("out/figures"),
            from_csv: FromCsv = None,
            overwrite: Overwrite = False) -> None:
    """``figure <name>``: run the ``experiment`` ``(config class, result class, run function)`` (or redraw it from
    ``--from-csv``), write its files and print ``table(summary)``.

    ``own()`` gives the command's own options as :func:`configure` takes them (read for a fresh run only); the
    keyword-only parameters are the options every figure command here ends with (:func:`_figure_options`).
    """
    config_class, result_class, run = experiment
    started = time.perf_counter()
    config = None if from_csv is not None else configure(
        config_class.quick() if quick else config_class(), **own(), perturbation=("--perturbation", perturbation),
        samples_per_cycle=("--samples-per-cycle", samples_per_cycle), chunk_size=("--chunk-size", chunk_size),
        seed=("--seed", seed))
    command = f"figure {name}"
    claimed = claim_figure(out, name, from_csv, command, overwrite=overwrite)
    folder = output_folder(out)
    result, extra = _run_or_redraw(result_class, from_csv, lambda: run(config, jobs=jobs, scheduler=scheduler),
                                   {"jobs": jobs, "scheduler": scheduler, "quick": quick})
    summary, written = _write(result, folder, name, command, started, extra, claimed)
    console.print(table(summary))
    console.print(f"wrote {', '.join(written)} to {folder}/ in {time.perf_counter() - started:.1f} s")


def _figure_options(command):
    """``command`` with :func:`_figure`'s keyword-only options after its own, for ``command`` to hand on as
    ``**options``: typer reads a command's options from its signature, so they are declared once, there."""
    own = [p for p in inspect.signature(command, eval_str=True).parameters.values() if p.kind is not p.VAR_KEYWORD]
    shared = [p for p in inspect.signature(_figure, eval_str=True).parameters.values() if p.kind is p.KEYWORD_ONLY]
    command.__signature__ = inspect.Signature(own + shared)
    return command


def _run_or_redraw(result_class, from_csv, run, extra: dict):
    """The results read back from ``--from-csv``, or a fresh run; and the manifest's extra config."""
    if from_csv is not None:
        return result_class.from_csv(from_csv), {"from_csv": str(from_csv)}
    return run(), extra


def _write(result, folder: Path, name: str, command: str, started: float, extra: dict,
           claimed: tuple) -> tuple[dict, list[str]]:
    """Write PNG, CSV (for fresh runs) and the JSON manifest as one set (``claimed``: :func:`claim_figure`'s
    members and manifest name); return the summary and the file names. A redraw (``--from-csv``) writes no CSV.
    """
    members, manifest = claimed
    summary = result.summary()
    written = [f"{name}.png", *([f"{name}.csv"] if result.config is not None else []), manifest]
    config = (result.config_dict() or {}) | extra
    results = {"summary": summary, "sweep_wall_time_s": result.wall_time_s, "n_workers": result.n_workers}
    with output_set(folder, last=(manifest,), members=members) as staged:
        result.plot(staged / f"{name}.png")
        if result.config is not None:
            result.to_csv(staged / f"{name}.csv")
        write_manifest(staged / manifest, command=command, config=config, results=results, started=started)
    return summary, written


@figure_app.command("accuracy", cls=help_from(_help_values))
@_figure_options
def accuracy(
    trials: Trials = None,
    links: Links = None,
    cycles: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Cycles per trial; checkpoints every 5 [default: {cycles}].")] = None,
    noise: Annotated[float | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Sensor noise on ξ as a fraction of its RMS [default: {accuracy_noise}].")] = None,
    **options,
) -> None:
    """Fig. 2: held-out Γ of the adaptive and the batch model after n training cycles.

    Defaults: 200 trials (100 train/test pairs) × 40 cycles of the 3-link swimmer, sensor noise 0.3
    of RMS. --quick: 16 trials × 10 cycles.
    """
    from ..experiments.accuracy import AccuracyConfig, AccuracyResult, run_accuracy

    _figure("accuracy", (AccuracyConfig, AccuracyResult, run_accuracy), _accuracy_table,
            lambda: {"n_trials": ("--trials", trials), "n_links": ("--links", links), "n_cycles": ("--cycles", cycles),
                     "sensor_noise": ("--noise", noise)}, **options)


def _accuracy_table(summary: dict) -> Table:
    table = Table(title=f"Held-out Γ, median [25–75 %], {summary['n_pairs']} pairs")
    for column in ("training cycles", "adaptive", "batch", "adaptive online Γ"):
        table.add_column(column, justify="right")
    gamma = summary["held_out_gamma"]
    for n in gamma["adaptive"]:
        cells = [f"{g[n]['p50']:.3f} [{g[n]['p25']:.3f}–{g[n]['p75']:.3f}]"
                 for g in (gamma["adaptive"], gamma["batch"])]
        online = summary["online_gamma_median"].get(n)
        table.add_row(n, *cells, "" if online is None else f"{online:.3f}")
    return table


@figure_app.command("environments", cls=help_from(_help_values))
@_figure_options
def environments(
    trials: Trials = None,
    links: Links = None,
    cycles_per_environment: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Cycles in each environment [default: {cycles_per_environment}].")] = None,
    drag_ratios: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Comma-separated drag ratio of each environment [default: {drag_ratios}].")] = None,
    forgetting_factors: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Comma-separated λ of the adaptive models [default: {forgetting_factors}].")] = None,
    noise: Annotated[float | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Sensor noise on ξ as a fraction of its RMS [default: {environments_noise}].")] = None,
    **options,
) -> None:
    """Fig. 3: a-priori prediction error through unannounced drag-ratio changes.

    Defaults: 100 trials, 40 cycles each at drag ratio 2, 3, 4, adaptive λ = 0.99 and 0.7, batch
    fit on environment 1 only, no sensor noise. --quick: 8 trials, 15 cycles per environment.
    """
    from ..experiments.environments import EnvironmentConfig, EnvironmentResult, run_environments

    _figure("environments", (EnvironmentConfig, EnvironmentResult, run_environments), _environment_table,
            lambda: {"n_trials": ("--trials", trials), "n_links": ("--links", links),
                     "cycles_per_environment": ("--cycles-per-environment", cycles_per_environment),
                     "drag_ratios": ("--drag-ratios", comma_list(drag_ratios, "--drag-ratios")),
                     "forgetting_factors": ("--forgetting-factors", comma_list(forgetting_factors,
                                                                               "--forgetting-factors")),
                     "sensor_noise": ("--noise", noise)}, **options)


def _environment_table(summary: dict) -> Table:
    switches = summary["switches"]
    table = Table(title=f"Cycles to get back within {summary['factor']:g}× the pre-switch error "
                        f"(median curve; median trial), {summary['n_trials']} trials")
    table.add_column("model")
    for switch in switches:
        table.add_column(f"k {switch['from_ratio']:g} → {switch['to_ratio']:g}", justify="right")
    table.add_column("settled error per environment", justify="right")
    for model, entries in summary["recovery"].items():
        cells = [f"{e['recovery_cycles_median_curve']}; {e['recovery_cycles_median_trial']}" for e in entries.values()]
        settled = ", ".join(f"{v:.3g}" for v in summary["settled_error"][model].values())
        table.add_row(model, *cells, settled)
    return table
