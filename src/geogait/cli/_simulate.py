"""``geogait simulate``: a perturbed gait on a built-in Purcell swimmer, written to disk."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import typer

from .._files import output_set
from .._validation import GeogaitError
from ._app import app
from ._common import RUN_PANEL, claim_output, comma_list, console, one_of, progress_bar, write_manifest

#: Every file a simulation writes into its folder (replaced as one set with --overwrite).
RUN_FILES = ("trajectory.parquet", "trajectory.csv", "trajectory.png", "manifest.json")

#: The built-in swimmer's body frames (geogait.systems imports SciPy: spelled out for a fast help; tests/cli check it).
_BODY_FRAMES = ("middle", "center_of_mass", "tail")
#: The help's option groups.
_SWIMMER, _GAIT = "Swimmer", "Gait and sensors"

#: At most this many samples in one simulation (cycles × samples per cycle): about 1 GB of output.
MAX_SAMPLES = 10_000_000


@app.command()
def simulate(
    links: Annotated[int, typer.Option(
        rich_help_panel=_SWIMMER, help="Number of links N of the Purcell swimmer (one joint cannot move).",
                                       min=3)] = 3,
    cycles: Annotated[int, typer.Option(rich_help_panel=_GAIT, help="Number of gait cycles.", min=1)] = 40,
    drag_ratio: Annotated[str, typer.Option(rich_help_panel=_SWIMMER,
        help="Drag ratio k, or comma-separated ratios for an environment schedule (e.g. 2,3,4).")] = "2",
    cycles_per_environment: Annotated[int, typer.Option(
        rich_help_panel=_SWIMMER, help="Cycles per drag ratio of a schedule.", min=1)] = 40,
    samples_per_cycle: Annotated[int, typer.Option(
        rich_help_panel=_GAIT, help="Samples per gait cycle.", min=4, max=100_000)] = 100,
    amplitude: Annotated[float, typer.Option(
        rich_help_panel=_GAIT, help="Amplitude (rad) of the seed gait.", min=0, max=2 * np.pi)] = 1.0,
    perturbation: Annotated[float, typer.Option(
        rich_help_panel=_GAIT, help="Std (rad) of the shape perturbation δ.", min=0,
                                                max=2 * np.pi)] = 0.15,
    noise: Annotated[float, typer.Option(
        rich_help_panel=_GAIT, help="Sensor noise on ξ, as a fraction of its RMS.", min=0, max=100)] = 0.0,
    shape_noise: Annotated[float, typer.Option(
        rich_help_panel=_GAIT, help="Sensor noise on r, ṙ, as a fraction of RMS.", min=0,
                                               max=100)] = 0.0,
    body_frame: Annotated[Literal[_BODY_FRAMES], typer.Option(
        metavar=one_of(_BODY_FRAMES), rich_help_panel=_SWIMMER,
        help="Body frame whose velocity ξ is: the middle link's, the centre of mass's or the tail link's.")
    ] = "middle",
    seed: Annotated[int, typer.Option(rich_help_panel=RUN_PANEL, help="Root random seed.", min=0)] = 0,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", rich_help_panel=RUN_PANEL, help="Replace the simulation --out holds.")] = False,
    out: Annotated[Path, typer.Option(
        rich_help_panel=RUN_PANEL, help="Output folder (must be empty or new, unless --overwrite).")] = Path(
        "out/simulate"),
) -> None:
    """Simulate the seed gait with perturbations; write Parquet + CSV + a PNG."""
    from ..gaits import Perturbation, seed_gait
    from ..plotting import plot_path, plot_shape_space, plt, save_figure
    from ..simulate import DragRatioSchedule, SwimmerStream, Trajectory
    from ..systems import PurcellSwimmer

    started = time.perf_counter()
    ratios = comma_list(drag_ratio, "--drag-ratio")
    if cycles * samples_per_cycle > MAX_SAMPLES:
        raise GeogaitError(f"--cycles × --samples-per-cycle must be at most {MAX_SAMPLES:,} samples. Got "
                           f"{cycles} × {samples_per_cycle} = {cycles * samples_per_cycle:,} instead.")
    system = PurcellSwimmer(links, drag_ratio=ratios[0], body_frame=body_frame)  # checked before the folder is
    gait = seed_gait(system.n_joints, amplitude)
    schedule = DragRatioSchedule(system, ratios, cycles_per_environment) if len(ratios) > 1 else None
    stream = SwimmerStream(system, gait, samples_per_cycle=samples_per_cycle,
                           perturbation=Perturbation.from_std(perturbation), sensor_noise=noise,
                           shape_noise=shape_noise, environment=schedule, seed=seed)
    with claim_output(out, overwrite=overwrite) as lock:  # locked before any work; an earlier set kept until the end
        folder = lock.folder
        parts = []
        with progress_bar() as progress:
            task = progress.add_task("simulating", total=cycles, status="")
            for _ in range(cycles):
                parts.append(stream.next_cycle())
                progress.update(task, advance=1, status=f"k = {stream.current_system().drag_ratio:g}")
        run = Trajectory.concatenate(parts)
        config = dict(links=links, cycles=cycles, drag_ratios=ratios, cycles_per_environment=cycles_per_environment,
                      samples_per_cycle=samples_per_cycle, amplitude=amplitude, perturbation=perturbation,
                      noise=noise, shape_noise=shape_noise, body_frame=body_frame, seed=seed)
        net = run.pose[-1] - run.pose[0]
        with output_set(folder, last=("manifest.json",), members=RUN_FILES) as staged:  # replaced as one set
            run.to_parquet(staged / "trajectory.parquet")
            run.to_csv(staged / "trajectory.csv")
            fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
            plot_path(axes[0], run.pose)
            plot_shape_space(axes[1], run.shape, {"nominal gait": gait})
            save_figure(fig, staged / "trajectory.png")
            write_manifest(staged / "manifest.json", command="simulate", config=config, started=started,
                           results={"samples": run.n_samples,
                                    "net_translation": float((net[:2] ** 2).sum() ** 0.5)})
        console.print(f"wrote {run.n_samples} samples to {folder}/ (trajectory.parquet, .csv, .png)")
