"""``geogait optimize``: one in-situ gait optimisation of a built-in Purcell swimmer (the main job)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import textwrap
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
import typer

from .._defaults import MAX_JOINT_ANGLE, window_forgetting_factor
from .._files import OutputLock, describe_path_kind, dumps_json, json_ready, output_set, write_text
from .._validation import (
    MAX_BYTES,
    GeogaitError,
    chain_motion_bytes,
    check_bytes,
    check_float,
    check_gait_size,
    check_int,
    gait_fits,
)
from ._app import app, figure_app, help_from, signalled

if TYPE_CHECKING:
    from ..optimize import InSituOptimizer
from ._common import (
    EXPERIMENT_PANEL,
    RUN_PANEL,
    FromCsv,
    Jobs,
    Json,
    Out,
    Overwrite,
    Scheduler,
    Seed,
    claim_figure,
    claim_output,
    comma_list,
    configure,
    console,
    explain_nulls,
    listed,
    one_of,
    output_folder,
    print_results,
    progress_bar,
    results_table,
    write_manifest,
)

_METHODS = ("auto", "adaptive", "shape", "resistance", "batch")
#: The library's choices (geogait.optimize imports SciPy: spelled out here for a fast help; tests/cli check them).
_OBJECTIVES = ("progress", "efficiency", "forward", "budget")
_CLIMB_RULES = ("auto", "es", "cobyqa", "bayes")
_FAMILIES = ("auto", "free", "symmetric", "mirror")
_STEP_RULES = ("linear", "sqp")
_DIRECTION_FRAMES = ("world", "body")
#: --climb's values, as the Climb part's start spells them ("off": no climb).
_CLIMB = {"on": "stalled", "off": None, "contradicted": "contradicted", "first": "first"}
#: The help's option groups.
_ROBOT, _GAIT, _MODEL, _CLIMB_PANEL, _SAFETY, _RUN = ("Robot", "Gait family and objective", "Model and steps",
                                                      "Measured climb", "Safety limits", "Run and output")
RUN_FILE = "run.json"  # the settings of a run, read back by --resume
MAX_CYCLES = 10_000_000  # a cycle budget beyond is a typo, not a run
CHECKPOINT_FILE = "checkpoint.npz"
#: Every file a run writes into its folder (removed at the start of a run with --overwrite).
#: A file of this name in a run's folder ends the run after the cycle under way (as its budget would).
STOP_FILE = "STOP"
#: The outputs of a run, written as one set (after Ctrl-C or SIGTERM without the figures).
OUTPUT_FILES = ("cycles.csv", "gait.png", "progress.png", "path.png", "summary.json")
RUN_FILES = ("summary.json", RUN_FILE, CHECKPOINT_FILE, "cycles.csv", "gait.png", "progress.png", "path.png")
#: Settings that do not change what a run computes: left out of its identity (--cycles may extend a run).
_NOT_IDENTITY = ("cycles", "robot_timeout", "run_id")
#: Options a resume may be given (every other option is the run's own, read from run.json).
_RESUME_OPTIONS = ("cycles", "robot_timeout", "resume", "json_output")


def _help_values() -> dict:
    """The library's values the help texts of ``optimize`` and ``figure optimization`` show."""
    from ..experiments.optimization import OptimizationConfig, default_budget
    from ..optimize import Gate

    fig5 = OptimizationConfig()
    return {"budget_3": default_budget(3), "budget_5": default_budget(5),
            "trials": fig5.n_trials, "links": listed(fig5.links), "budgets": listed(fig5.budgets),
            "baseline_trials": fig5.baseline_trials, "baseline_iterations": fig5.baseline_iterations,
            "batch_cycles": Gate().cycles, "noise": fig5.sensor_noise, "seed": fig5.seed}


@app.command(cls=help_from(_help_values))
def optimize(
    links: Annotated[int, typer.Option(min=3, max=200, rich_help_panel=_ROBOT, help=(
        "Links of the built-in Purcell swimmer (one that would need more than 4 GiB, or solver steps over a "
        "second, is refused, naming the most links that fit)."))] = 3,
    period: Annotated[float, typer.Option(
        min=1e-3, max=1e4, rich_help_panel=_ROBOT, help="Seconds per gait cycle of the built-in swimmer.")] = 1.0,
    noise: Annotated[float, typer.Option(min=0, rich_help_panel=_ROBOT, help=(
        "Sensor noise on the built-in swimmer's body velocity ξ, a fraction of its RMS."))] = 0.1,
    perturbation: Annotated[float, typer.Option(min=0, rich_help_panel=_ROBOT, help=(
        "Std (rad) of the random shape perturbation δ on the built-in swimmer's joints (what the model learns "
        "from)."))] = 0.15,
    robot: Annotated[str | None, typer.Option(metavar="COMMAND", rich_help_panel=_ROBOT, help=(
        "Optimise the robot behind this driver command (JSON-lines bridge, docs/robots.md)."))] = None,
    robot_timeout: Annotated[float, typer.Option(rich_help_panel=_ROBOT, help=(
        "Seconds to wait for each line of the --robot driver."))] = 30.0,
    objective: Annotated[Literal[_OBJECTIVES], typer.Option(metavar=one_of(_OBJECTIVES), rich_help_panel=_GAIT, help=(
        "Score of a gait, at zero net rotation: progress per cycle, efficiency (per shape-space path length), "
        "forward (progress along the seed gait's mean motion), budget (per second at a fixed RMS joint "
        "speed)."))] = "progress",
    direction_frame: Annotated[Literal[_DIRECTION_FRAMES], typer.Option(
        metavar=one_of(_DIRECTION_FRAMES), rich_help_panel=_GAIT, help=(
        "Frame of --objective forward: world (a fixed heading) or body (the robot's axis)."))] = "world",
    order: Annotated[int, typer.Option(rich_help_panel=_GAIT, help="Fourier order of the gaits searched.")] = 1,
    family: Annotated[Literal[_FAMILIES], typer.Option(metavar=one_of(_FAMILIES), rich_help_panel=_GAIT, help=(
        "Gaits searched: free (all of --order), symmetric (the same read from both ends), mirror (each "
        "half-cycle mirrors the other: θ(φ + π) = −θ(φ)); auto: symmetric on a front-back symmetric chain, else "
        "mirror on a mirror-symmetric body (neither then turns); a robot that declares no symmetry starts in "
        "mirror and widens to free once a gait turns it; else free."))] = "auto",
    method: Annotated[Literal[_METHODS], typer.Option(metavar=one_of(_METHODS), rich_help_panel=_MODEL, help=(
        "Model of ξ: adaptive (local, about the current gait), shape (over the whole shape space), resistance "
        "(a chain's drag coefficients), batch (refit every block of cycles, Bittner 2018); auto: resistance "
        "for a --robot chain in a resistive medium, else shape on the built-in swimmer, else adaptive."))
    ] = "auto",
    gamma_threshold: Annotated[float, typer.Option(rich_help_panel=_MODEL, help=(
        "Γ*: the model steps once its Γ reaches this (Γ = 1 − its error predicting ξ / the phase average's: "
        "1 exact, 0 no better)."))] = 0.5,
    forgetting_factor: Annotated[float | None, typer.Option(rich_help_panel=_MODEL, help=(
        "λ in (0, 1]: the weight older samples keep per update (--method adaptive or shape) [default: "
        "1 − 0.1/d for d joints]."))] = None,
    step_rule: Annotated[Literal[_STEP_RULES] | None, typer.Option(
        metavar=one_of(_STEP_RULES), rich_help_panel=_MODEL, help=(
        "The model's step: linear (on its linearisation) or sqp (sequential quadratic programming) [default: "
        "sqp for --method resistance, else linear]."))] = None,
    settle_cycles: Annotated[str, typer.Option(metavar="N|auto", rich_help_panel=_MODEL, help=(
        "Cycles after each gait change not measured: a count, or auto (measured at the first gait change: the "
        "cycles that differ from the ones after them beyond noise)."))] = "auto",
    model_class_cycles: Annotated[int, typer.Option(min=0, rich_help_panel=_MODEL, help=(
        "Test first whether the robot is principally kinematic (its motion set by its shape's path, not speed): "
        "the seed gait this many cycles (≥ 3) at its period and at twice it. 0: no test."))] = 0,
    climb: Annotated[Literal[tuple(_CLIMB)] | None, typer.Option(
        metavar=one_of(tuple(_CLIMB)), rich_help_panel=_CLIMB_PANEL, help=(
        "When to take steps from measured outcomes alone: first (until the model predicts them), on (once the "
        "model is contradicted, its promised gain twice not measured, or levels off), contradicted (only "
        "then), off [default: contradicted for --method resistance, else first]."))] = None,
    climb_rule: Annotated[Literal[_CLIMB_RULES] | None, typer.Option(
        metavar=one_of(_CLIMB_RULES), rich_help_panel=_CLIMB_PANEL, help=(
        "How the climb proposes gaits: cobyqa (SciPy's quadratic models), bayes (a Gaussian process), es (a "
        "(1+1) evolution strategy); auto: bayes where cobyqa's first design takes over 30 cycles, else cobyqa "
        "[default: es for --method resistance in a resistive medium, else auto]."))] = None,
    max_joint_angle: Annotated[float | None, typer.Option(metavar="RAD", rich_help_panel=_SAFETY, help=(
        "Joint limit (rad) of every gait [default: the robot's declared joint ranges, else 2π/3]."))] = None,
    max_joint_velocity: Annotated[float | None, typer.Option(metavar="RAD/S", rich_help_panel=_SAFETY, help=(
        "Joint speed limit (rad/s) of every gait [default: none]."))] = None,
    max_tracking_error: Annotated[str, typer.Option(metavar="RAD | auto | off", rich_help_panel=_SAFETY, help=(
        "Largest RMS realised − commanded joint angle (rad) of a kept gait: a number, off, or auto (twice the "
        "seed gait's)."))] = "auto",
    cycles: Annotated[int | None, typer.Option(rich_help_panel=_RUN, help=(
        "Cycle budget [default: {budget_3} for 3 links, else {budget_5}; with --robot none: the run goes on until "
        "Ctrl-C, SIGTERM or a file named STOP in --out]. With --resume: the new total."))] = None,
    seed: Annotated[int, typer.Option(min=0, rich_help_panel=_RUN, help=(
        "Random seed (exploration, climb, the built-in swimmer's noise)."))] = 0,
    checkpoint_every: Annotated[int, typer.Option(rich_help_panel=_RUN, help=(
        f"Cycles between checkpoints ({CHECKPOINT_FILE}, what --resume continues)."))] = 1,
    resume: Annotated[Path | None, typer.Option(metavar="DIR", rich_help_panel=_RUN, help=(
        f"Continue the run in this folder with its settings ({RUN_FILE}); only --cycles and --robot-timeout "
        "may be given with it."))] = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", rich_help_panel=_RUN, help=(
        "Replace the run in --out (once this run is under way)."))] = False,
    out: Annotated[Path, typer.Option(metavar="DIR", rich_help_panel=_RUN, help=(
        "Output folder (empty or new, unless --overwrite)."))] = Path("out/optimize"),
    json_output: Json = False,
    ctx: typer.Context = None,
) -> None:
    """Optimise a gait in situ on the built-in swimmer or a --robot.

    Cycle by cycle, geogait learns a model of the body velocity ξ from the shape r, steps to the gait the model
    predicts to be better, and keeps what measures better. It writes cycles.csv, gait.png, progress.png, path.png
    and the manifest summary.json, also for the cycles a failed run ran (after Ctrl-C or SIGTERM cycles.csv and
    summary.json: it ends at once); --resume DIR continues it.
    """
    started = time.perf_counter()
    if resume is not None:
        _refuse_options_with_resume(ctx)
        folder, settings = Path(resume), _read_settings(Path(resume))
        if cycles is not None:
            settings["cycles"] = cycles
        if _given(ctx, "robot_timeout"):
            settings["robot_timeout"] = robot_timeout
    else:
        if robot is None and _given(ctx, "robot_timeout"):
            raise GeogaitError("--robot-timeout is the wait for a --robot driver's lines; the built-in swimmer has "
                               "none (drop it, or give --robot).")
        swimmer_options = [f"--{name}" for name in _SWIMMER_ONLY if _given(ctx, name)]
        if robot is not None and swimmer_options:
            raise GeogaitError(f"{', '.join(swimmer_options)} set{'s' if len(swimmer_options) == 1 else ''} up the "
                               "built-in swimmer; a --robot driver runs its own robot (drop "
                               f"{'it' if len(swimmer_options) == 1 else 'them'}, or leave out --robot).")
        settings = dict(links=links, cycles=cycles, seed=seed, noise=noise, perturbation=perturbation,
                        period=period, gamma_threshold=gamma_threshold, forgetting_factor=forgetting_factor,
                        order=order, objective=objective, direction_frame=direction_frame,
                        max_joint_angle=max_joint_angle,
                        max_joint_velocity=max_joint_velocity, settle_cycles=settle_cycles,
                        max_tracking_error=max_tracking_error, method=method, family=family,
                        step_rule=step_rule, climb=climb, climb_rule=climb_rule,
                        model_class_cycles=model_class_cycles, robot=robot,
                        robot_timeout=robot_timeout, checkpoint_every=checkpoint_every)
        folder = out
    optimizer = _optimizer(settings)  # every option checked before anything starts or is written
    _check_memory(settings, optimizer)
    system, target = _target(settings)
    run_id = _run_id(settings)
    # the folder is locked for this run (a run still writing it is neither resumed nor overwritten)
    with OutputLock(folder) if resume is not None else claim_output(folder, overwrite=overwrite):
        if resume is not None:
            _check_resume(folder, settings, run_id)
        summary = _optimize(optimizer, system, target, settings, folder, run_id, resume is not None, started)
    print_results(summary, lambda: _results_table(summary), as_json=json_output)
    console.print(f"wrote {folder}/ (cycles.csv, summary.json, gait.png, progress.png, path.png, {CHECKPOINT_FILE})")
    if summary["ended_by"] == "the STOP file":
        budget = "" if settings["cycles"] is None else f" of {settings['cycles']}"
        typer.echo(f"note: {folder}/{STOP_FILE} ended the run after {summary['cycles_run']}{budget} cycles; continue "
                   f"with: geogait optimize --resume {folder} (which removes {STOP_FILE})", err=True)


def _optimize(optimizer, system, target, settings, folder: Path, run_id: str, resumed: bool, started: float) -> dict:
    """The run itself, in a folder this process holds: run.json, the checkpoints, then the outputs as one set. A run
    that is interrupted or fails writes the outputs of the cycles its checkpoint holds before it ends."""
    from ..optimize import cached_ceiling

    ceiling = None
    if system is not None:
        with console.status("computing the ceiling with the true connection (cached after the first run)"):
            ceiling = cached_ceiling(system, order=settings["order"], objective_kind=_ceiling_kind(settings),
                                     max_joint_angle=settings["max_joint_angle"] or MAX_JOINT_ANGLE)
    run = dict(optimizer=optimizer, system=system, settings=settings, folder=folder, run_id=run_id, resumed=resumed,
               started=started, ceiling=ceiling)
    robot, under_way = None, [False]
    try:
        with target() as robot_driver:
            robot = robot_driver
            result, run["optimizer"] = _run(optimizer, robot_driver, settings, folder, ceiling, resumed, run_id,
                                            under_way)
            return _write_outputs(result, robot_driver, **run)
    except BaseException as stop:  # Ctrl-C, SIGTERM, a driver that died, a failed cycle: the cycles run are not lost
        if robot is not None and under_way[0]:  # (refused before a cycle ran, e.g. a changed hello: nothing new)
            _write_what_ran(target if system is not None else lambda: contextlib.nullcontext(_Stopped(robot)), run,
                            figures=not (isinstance(stop, KeyboardInterrupt) or signalled()))
        raise


def _write_outputs(result, robot, *, optimizer, system, settings, folder, run_id, resumed, started, ceiling,
                   figures: bool = True) -> dict:
    """cycles.csv, the figures and summary.json of ``result``, as one set; returns the summary. Without ``figures``
    the set is the CSV and summary.json alone (an earlier set's figures go with the rest of it)."""
    summary = result.summary(ceiling)
    summary["model_used"] = type(result.model).__name__  # (the default depends on what the robot declares)
    summary["cycles_run"] = len(result.log)
    budget = _budget(settings)
    summary["ended_by"] = ("the STOP file" if (folder / STOP_FILE).exists()
                           else "its budget" if budget is not None and len(result.log) >= budget
                           else "a signal or a failure (see the error)")
    config = dict(settings)
    if settings["robot"] is not None:
        quarantined = list(robot.quarantined)  # (a --robot run's robot is a ProcessRobot)
        summary["quarantined_cycles"] = len(quarantined)
        summary["quarantine_reasons"] = quarantined[:20]
        summary["robot"] = _declared(robot, result)
        for name in _SWIMMER_ONLY:  # the built-in swimmer's options say nothing about a robot's run
            config.pop(name, None)
    if summary["forward_direction"] is None:
        summary["forward_direction_null_reason"] = ("the objective is not forward" if settings["objective"] != "forward"
                                                    else "the run ended before its seed cycles set it")
    summary = explain_nulls(json_ready(summary))
    with output_set(folder, last=("summary.json",), members=OUTPUT_FILES) as staged:
        write_text(staged / "cycles.csv", result.log.to_csv(index=False))
        if figures:
            _figures(staged, system, result, ceiling)
        write_manifest(staged / "summary.json", command="optimize", config={**config, "run_id": run_id,
                       "optimizer": optimizer.describe(), "resumed": resumed}, results=summary, started=started)
    return summary


def _write_what_ran(target, run: dict, figures: bool = True) -> None:
    """After an interrupted or failed run: the outputs of the cycles its checkpoint holds (read back on a fresh
    built-in swimmer, or on the stopped robot's declarations) and one line on how to continue it. A failure here is
    reported as a warning: the run's own error is the one to tell.

    After Ctrl-C or SIGTERM (``figures`` false) only cycles.csv and summary.json are written: a signal ends the
    process within 2 s, and drawing the figures alone takes 1.7 s on a loaded 2-core machine. A resumed run draws
    them (``--resume DIR --cycles N``, N the cycles run, runs no further cycle)."""
    from ..optimize import InSituOptimizer, read_checkpoint_metadata

    folder, checkpoint = run["folder"], run["folder"] / CHECKPOINT_FILE
    try:
        metadata = read_checkpoint_metadata(checkpoint) if checkpoint.is_file() else {}
        tag, state = metadata.get("tag") or {}, metadata.get("state") or {}
        done = state.get("cycle") if isinstance(state, dict) else None
        if not isinstance(tag, dict) or tag.get("run_id") != run["run_id"] or not isinstance(done, int) or done < 1:
            return  # (stopped before this run's first checkpoint: nothing of it to write)
        with target() as robot:
            result = InSituOptimizer.resume(checkpoint, robot, n_cycles=done)
            _write_outputs(result, robot, **run, figures=figures)
    except Exception as failure:  # (see the docstring)
        typer.echo(f"warning: the outputs of the cycles run could not be written: {failure}", err=True)
        return
    if figures:
        typer.echo(f"note: wrote cycles.csv, summary.json and the figures of the {done} cycles run to {folder}/; "
                   f"continue with: geogait optimize --resume {folder}", err=True)
    else:
        typer.echo(f"note: wrote cycles.csv and summary.json of the {done} cycles run to {folder}/ (its figures: "
                   f"geogait optimize --resume {folder} --cycles {done}); continue with: geogait optimize --resume "
                   f"{folder}", err=True)


class _Stopped:
    """A robot whose run stopped (its driver interrupted or dead), for reading the run's checkpoint back: what it
    declared, and no motion (commands are dropped: it runs no further cycle)."""

    def __init__(self, robot):
        self._robot = robot

    def __getattr__(self, name):
        return getattr(self._robot, name)

    def set_gait(self, gait) -> None:
        pass

    def set_excitation(self, shape, shape_velocity) -> None:
        pass

    def set_cycle_period(self, seconds) -> None:
        pass

    def next_cycle(self):
        raise GeogaitError("the robot of a stopped run runs no further cycle")


def _results_table(summary: dict):
    """The headline numbers of a run (summary.json holds them all)."""
    table = results_table("geogait optimize", "result", "value")

    def change(seed, final):
        relative = (final - seed) / abs(seed) if seed else None
        shown = "" if relative is None else f" ({relative:+.1%})" if abs(relative) < 0.1 else f" ({relative:+.0%})"
        return f"{seed:.4g} → {final:.4g}{shown}"

    table.add_row("cycles run", str(summary["cycles_run"]))
    table.add_row("measured objective per cycle, seed → final gait",
                  change(summary["seed_measured_objective"], summary["final_measured_objective"]))
    if summary.get("final_displacement_per_cycle") is not None:  # (the built-in swimmer: its true motion)
        table.add_row("true displacement per cycle, seed → final gait",
                      change(summary["seed_displacement_per_cycle"], summary["final_displacement_per_cycle"]))
    if summary.get("final_ceiling_fraction") is not None:
        table.add_row("final gait, share of the ceiling", f"{summary['final_ceiling_fraction']:.1%}")
        at_90 = summary.get("first_cycle_at_90_percent_of_ceiling")
        table.add_row("first cycle at 90 % of the ceiling", "not reached" if at_90 is None else str(at_90))
    table.add_row("steps taken, rejected, reverted to the best",
                  f"{summary['steps']}, {summary['rejected_steps']}, {summary['reverted_to_best']}")
    table.add_row("steps by the model, by the climb", f"{summary['steps_by_model']}, {summary['steps_by_climb']}")
    if summary.get("changes_detected"):
        table.add_row("changes detected (cycle: evidence)", ", ".join(f"{c['cycle']}: {c['evidence']}"
                                                                     for c in summary["changes_detected"]))
    table.add_row("model, gait family", f"{summary['model_used']}, {summary['gait_family']}")
    if "quarantined_cycles" in summary:
        table.add_row("cycles quarantined (implausible data)", str(summary["quarantined_cycles"]))
    return table


#: Options of the built-in swimmer: refused with --robot, and left out of a --robot run's summary.
_SWIMMER_ONLY = ("links", "noise", "perturbation", "period")


def _given(ctx, name: str) -> bool:
    """Whether the option ``name`` was given on the command line."""
    source = None if ctx is None else ctx.get_parameter_source(name)
    return source is not None and source.name == "COMMANDLINE"


def _declared(robot, result) -> dict:
    """What the robot (a :class:`~geogait.robots.ProcessRobot`) declared in its hello
    (:func:`~geogait.robots.read_robot_spec`) and what the run made of it (a --robot run's summary)."""
    from ..robots import read_robot_spec

    spec = read_robot_spec(robot, "geogait optimize")
    region = robot.shape_constraints  # (the hello's linear limits a · r <= b, as declared)
    declared = {"n_joints": spec.n_joints, "cycle_period_s": spec.cycle_period,
                "joint_ranges": None if spec.joint_ranges is None else spec.joint_ranges.tolist(),
                "shape_constraints": None if region is None
                else np.column_stack([region.normals, region.bounds]).tolist(),
                "seed_gait_params": result.initial_gait.params.tolist(),
                "max_joint_angle_used": result.max_joint_angle, "shape_scale_used": result.shape_scale,
                # (a bridge's hello may declare its chain without a resistive medium: the hello's, as declared)
                "chain": robot.chain, "resistive_medium": spec.resistive_chain is not None,
                "front_back_symmetric": spec.front_back_symmetric if spec.symmetry_declared else None,
                "mirror_symmetric": spec.mirror_symmetric if spec.symmetry_declared else None,
                "settle_cycles": spec.settle_cycles, "gait_family_used": result.family}
    for name, value in list(declared.items()):  # (why a field is null: the hello left it out)
        if value is None:
            declared[f"{name}_null_reason"] = ("the robot's hello declares no symmetry" if name.endswith("symmetric")
                                               else "the robot's hello declares none")
    return declared


def _run_id(settings: dict) -> str:
    """The identity of a run: a hash of the settings that decide what it computes (not its budget)."""
    kept = {k: v for k, v in settings.items() if k not in _NOT_IDENTITY}
    return hashlib.sha256(dumps_json(kept, sort_keys=True).encode()).hexdigest()[:16]


def _refuse_options_with_resume(ctx) -> None:
    """Options of a new run given with --resume: refused (the run's own settings are in its run.json)."""
    if ctx is None:
        return
    given = [param for param in ctx.command.params if param.name not in _RESUME_OPTIONS
             and ctx.get_parameter_source(param.name) is not None
             and ctx.get_parameter_source(param.name).name == "COMMANDLINE"]
    if given:
        names = ", ".join(param.opts[0] for param in given)
        raise GeogaitError(f"--resume continues a run with the settings in its {RUN_FILE}; {names} cannot be "
                           "changed (only --cycles and --robot-timeout may be given). Start a new run with "
                           "--out instead.")


def _check_resume(folder: Path, settings: dict, run_id: str) -> None:
    """The checkpoint in ``folder`` is the run its run.json describes, and --cycles does not undo cycles run."""
    from ..optimize import read_checkpoint_metadata

    checkpoint = folder / CHECKPOINT_FILE
    metadata = read_checkpoint_metadata(checkpoint)
    stored = settings.get("run_id")
    tag = metadata.get("tag") if isinstance(metadata.get("tag"), dict) else {}
    if stored is not None or tag:
        if stored != run_id:
            raise GeogaitError(f"--resume {folder}: {RUN_FILE} was changed after the run started (its settings do "
                               "not match its run_id); refusing to resume.")
        if tag.get("run_id") != run_id:
            raise GeogaitError(f"--resume {folder}: {CHECKPOINT_FILE} belongs to another run (run id "
                               f"{tag.get('run_id')!r}, {RUN_FILE} says {run_id!r}): the run described by "
                               f"{RUN_FILE} stopped before its first checkpoint. Start it again with --overwrite.")
    state = metadata.get("state") if isinstance(metadata.get("state"), dict) else {}
    done = state.get("cycle")
    if settings.get("cycles") is not None and isinstance(done, int) and settings["cycles"] < done:
        raise GeogaitError(f"--resume {folder}: --cycles {settings['cycles']} is fewer than the {done} cycles "
                           f"already run; give a total of at least {done}.")


def _settle_cycles(value) -> int | str:
    """--settle-cycles: ``"auto"`` or a count ≥ 0."""
    if value == "auto" or isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    try:
        count = int(value)
    except (TypeError, ValueError):
        count = -1
    if count < 0 or str(count) != str(value).strip():
        raise typer.BadParameter(f"expected a count of cycles (0 or more) or 'auto', got {value!r}",
                                 param_hint="--settle-cycles")
    return count


def _optimizer(settings, robot=None) -> InSituOptimizer:
    from ..gaits import seed_gait
    from ..optimize import (
        CLIMB_RULES,
    )
    from ..simulate import MAX_SENSOR_NOISE

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
    settings["settle_cycles"] = _settle_cycles(settings["settle_cycles"])
    if settings["cycles"] is not None:
        check_int(settings["cycles"], "cycles", "geogait optimize", minimum=1)
        if settings["cycles"] > MAX_CYCLES:
            raise typer.BadParameter(f"at most {MAX_CYCLES} cycles, got {settings['cycles']}", param_hint="--cycles")
    check_int(settings["checkpoint_every"], "checkpoint_every", "geogait optimize", minimum=1)
    if not (np.isfinite(settings["robot_timeout"]) and settings["robot_timeout"] > 0):
        raise typer.BadParameter(f"expected seconds > 0, got {settings['robot_timeout']}", param_hint="--robot-timeout")
    if 0 < settings.get("model_class_cycles", 0) < 3:
        raise typer.BadParameter(f"expected 0 (no test) or at least 3 cycles per period, got "
                                 f"{settings['model_class_cycles']}", param_hint="--model-class-cycles")
    _check_budget(settings)
    from ..robots import PERIOD_RANGE

    low, high = PERIOD_RANGE
    if not (np.isfinite(settings["period"]) and low <= settings["period"] <= high):
        raise typer.BadParameter(f"expected seconds in [{low:g}, {high:g}] (1000 cycles a second to one a day), got "
                                 f"{settings['period']:g}", param_hint="--period")
    if settings.get("model_class_cycles", 0) and settings["robot"] is not None:
        raise GeogaitError("--model-class-cycles runs the seed gait at two periods, and the JSON-lines bridge has no "
                           "message that changes a driver's period: run the test on the built-in swimmer, or in "
                           "Python on a robot with set_cycle_period (InSituOptimizer(model_class_cycles=3), e.g. "
                           "a MujocoRobot), or on a log of two periods (geogait fit).")
    forgetting = settings["forgetting_factor"]
    if settings["method"] in ("auto", "resistance", "batch") and forgetting is not None:
        raise GeogaitError(f"--forgetting-factor applies to --method adaptive or shape; --method "
                           f"{settings['method']} does not use it.")
    if forgetting is not None and not 0 < forgetting <= 1:
        raise typer.BadParameter(f"expected λ in (0, 1], got {forgetting}", param_hint="--forgetting-factor")
    if not (np.isfinite(settings["noise"]) and 0 <= settings["noise"] <= MAX_SENSOR_NOISE):
        raise typer.BadParameter(f"expected a fraction in [0, {MAX_SENSOR_NOISE:g}], got {settings['noise']}",
                                 param_hint="--noise")
    if not (np.isfinite(settings["perturbation"]) and 0 <= settings["perturbation"] <= 2 * np.pi):
        raise typer.BadParameter(f"expected a std in [0, 2π] rad, got {settings['perturbation']}",
                                 param_hint="--perturbation")
    limit = settings["max_joint_angle"]
    if settings["robot"] is None and limit is not None:
        seed_reach = float(seed_gait(settings["links"] - 1).joint_limit().max())
        if not seed_reach - 1e-9 <= limit <= np.pi:  # (the seed's largest angle is 1 up to rounding)
            raise typer.BadParameter(f"expected a joint limit in [{seed_reach:.4g}, π] rad for the built-in swimmer "
                                     "(at least its seed gait's largest joint angle; its links would pass through "
                                     f"each other beyond π), got {limit}", param_hint="--max-joint-angle")
    for name, choices in (("climb", _CLIMB), ("climb_rule", CLIMB_RULES)):
        value = settings.get(name)  # (absent from the run.json of a run that predates the option)
        if value is not None and value not in choices:
            raise GeogaitError(f"--{name.replace('_', '-')} must be one of {', '.join(choices)}; got {value!r}.")
    return _composed(settings, robot).validate()


def _preset(settings, robot) -> InSituOptimizer:
    """The preset ``--method`` names, with its model for this swimmer or robot (``robot``: None until a driver is
    connected, when its joints and chain are known)."""
    from ..experiments.optimization import shape_method_model
    from ..models import AdaptiveGaitModel, ResistanceModel
    from ..optimize import (
        default,
        for_robot,
        prior_work,
        structured,
    )
    from ..systems import PurcellSwimmer

    method, links, forgetting = settings["method"], settings["links"], settings["forgetting_factor"]
    n_joints = robot.n_joints if robot is not None else links - 1
    if method == "batch":
        return prior_work()
    if method == "resistance":
        if robot is not None:
            return structured(ResistanceModel(**robot.chain_geometry()))
        swimmer = None if settings["robot"] is not None else ResistanceModel.from_swimmer(PurcellSwimmer(links))
        return structured(swimmer)
    if method == "shape":
        return default(model=shape_method_model(links, robot=settings["robot"] is not None,
                                                forgetting_factor=forgetting))
    if method == "adaptive" and (forgetting is not None or settings["robot"] is None or robot is not None):
        return default(model=AdaptiveGaitModel(forgetting_factor=forgetting if forgetting is not None
                                               else window_forgetting_factor(n_joints)))
    if method == "auto" and robot is not None:
        return for_robot(robot)
    return default()


def _composed(settings, robot=None) -> InSituOptimizer:
    """The optimiser a run's settings make: the preset ``--method`` names, then each option on its part."""
    from ..optimize import (
        Climb,
        Exploration,
        ModelClassTest,
    )

    optimizer = _preset(settings, robot)
    tracking = settings["max_tracking_error"]
    params = {"gate__gamma_threshold": settings["gamma_threshold"], "order": settings["order"],
              "objective__kind": settings["objective"],
              "objective__frame": settings.get("direction_frame", "world"),
              "limits__max_joint_angle": "auto" if settings["max_joint_angle"] is None else settings["max_joint_angle"],
              "limits__max_joint_velocity": settings["max_joint_velocity"],
              "safety__settle_cycles": settings["settle_cycles"],
              "safety__max_tracking_error": None if tracking == "off" else
              tracking if tracking == "auto" else float(tracking),
              "family": settings.get("family", "auto"), "random_state": settings.get("seed") or 0,
              # the built-in swimmer: --perturbation sizes the exploration geogait commands
              "exploration": "auto" if settings["robot"] is not None else Exploration(std=settings["perturbation"])}
    if settings.get("step_rule") is not None:
        params["step__rule"] = settings["step_rule"]
    climb = settings.get("climb")
    if climb == "off":
        params["climb"] = False
    elif climb is not None:
        params["climb"] = optimizer.climb if isinstance(optimizer.climb, Climb) else Climb()
        params["climb__start"] = _CLIMB[climb]
    if settings.get("climb_rule") is not None:
        params.setdefault("climb", optimizer.climb if isinstance(optimizer.climb, Climb) else Climb())
        params["climb__rule"] = settings["climb_rule"]
    if settings.get("model_class_cycles", 0):
        params["checks"] = [*optimizer.checks, ModelClassTest(cycles=settings["model_class_cycles"])]
    return optimizer.set_params(**params)


def _budget(settings) -> int | None:
    """The run's cycle budget: --cycles, else the swimmer's default; a --robot run without --cycles has none (it goes
    on until it is stopped)."""
    from ..experiments.optimization import default_budget

    if settings["cycles"] is not None or settings["robot"] is not None:
        return settings["cycles"]
    return default_budget(settings["links"])


def _check_budget(settings) -> None:
    """A budget that holds no measured cycle is refused before the robot moves (``smallest_budget``)."""
    from ..optimize import (
        smallest_budget,
    )

    settle, test = settings["settle_cycles"], settings.get("model_class_cycles", 0)
    settle = 0 if settle == "auto" else settle  # (measured: none at the start)
    smallest, budget = smallest_budget(settle, test), _budget(settings)
    if budget is None or budget >= smallest:
        return
    spent = [f"--settle-cycles {settle}"] * bool(settle) + [f"--model-class-cycles {test}"] * bool(test)
    given = f"--cycles {budget}" if settings["cycles"] is not None else f"the default budget of {budget} cycles"
    raise GeogaitError(f"{given} holds no measured cycle: with {' and '.join(spent)} the first {smallest - 1} "
                       f"cycles are not measured; give --cycles {smallest} or more, or fewer "
                       f"{' or '.join(option.split()[0] for option in spent)}.")


def _ceiling_kind(settings) -> str:
    return "progress" if settings["objective"] == "forward" else settings["objective"]


def _target(settings):
    """(system or None, context manager giving the robot): the built-in swimmer or a driver process."""
    from ..gaits import Perturbation, seed_gait
    from ..robots import ProcessRobot
    from ..simulate import SwimmerStream
    from ..systems import PurcellSwimmer

    if settings["robot"] is not None:
        return None, lambda: ProcessRobot(settings["robot"], timeout=settings["robot_timeout"])
    system = PurcellSwimmer(settings["links"])
    check_float(settings["period"], "period", "geogait optimize", low=0, low_open=True)
    perturbation = Perturbation.from_std(settings["perturbation"], frequency=2.0 / settings["period"])
    stream = SwimmerStream(system, seed_gait(system.n_joints), perturbation=perturbation,
                           sensor_noise=settings["noise"], seed=settings["seed"], cycle_period=settings["period"])
    return system, lambda: contextlib.nullcontext(stream)


def _run(optimizer, robot, settings, folder, ceiling, resumed, run_id, started: list):
    """The optimiser's run (or its resumption) on ``robot``; ``started[0]`` turns true once its first cycle ran."""
    from ..optimize import InSituOptimizer

    cycles = _budget(settings)
    name = f"robot {settings['robot']!r}" if settings["robot"] else f"{settings['links']}-link"
    with progress_bar() as progress:
        task = progress.add_task(f"{name} {settings['method']}", total=cycles, status="")

        def show(row):
            if not started[0]:  # under way (its checkpoint follows at once): only now is an earlier run replaced
                # (summary.json first: no earlier summary is left beside a part of this run; a resume rewrites
                # the outputs of the run it continues at its end)
                for file in RUN_FILES[:1] if resumed else RUN_FILES:
                    (folder / file).unlink(missing_ok=True)
                _write_settings(folder, settings, run_id)  # (a resume's new --cycles: the total it continues to)
                started[0] = True
            # –: a burn-in or settle cycle; <0: the model predicts worse than its phase average (see cycles.csv)
            gamma = "  – " if np.isnan(row["gamma"]) else " <0 " if row["gamma"] < 0 else f"{row['gamma']:.2f}"
            value = row.get("true_objective", row["measured_objective"])
            share = f"  {100 * row['ceiling_fraction']:.0f}% of ceiling" if "ceiling_fraction" in row else ""
            trial = "  (a trial)" if row.get("candidate", False) else ""
            steps = f"  steps model/climb {row['steps_by_model']}/{row['steps_by_climb']}"
            change = f"  change detected ({row['change']})" if row.get("change") else ""
            status = f"Γ {gamma}{steps}{change}  this cycle {value:.4f}{share}{trial}"
            progress.update(task, completed=row["cycle"] + 1, status=status)

        checkpoint = folder / CHECKPOINT_FILE
        (folder / STOP_FILE).unlink(missing_ok=True)  # (a STOP left by the run this one continues or replaces)
        if settings["robot"] is not None:  # a driver's joints, chain and medium are known once it is connected
            optimizer = _optimizer(settings, robot)
        hello = _hello(robot) if settings["robot"] is not None else None
        check_gait_size(robot.n_joints, settings["order"], "geogait optimize", "--order",
                        speed_limit=settings["max_joint_velocity"] is not None)
        if resumed:
            _check_resumed_hello(checkpoint, hello)
            return InSituOptimizer.resume(checkpoint, robot, callback=show, record=True, n_cycles=cycles,
                                          stop=folder / STOP_FILE), optimizer
        tag = {"run_id": run_id, **({} if hello is None else {"hello": hello})}
        return optimizer.run(robot, cycles, ceiling=None if ceiling is None else ceiling.value, callback=show,
                             record=True, checkpoint=checkpoint, checkpoint_every=settings["checkpoint_every"],
                             checkpoint_tag=tag, stop=folder / STOP_FILE), optimizer


def _check_memory(settings: dict, optimizer) -> None:
    """The built-in swimmer's gait family and model fit in memory and solver steps short enough for SIGTERM, checked
    before its ceiling is computed (a robot's joints are known once its driver says hello: checked then)."""
    from ..models import AdaptiveGaitModel, model_capabilities
    from ..optimize import symmetric_chain_model

    if settings["robot"] is not None:
        return
    speed = settings["max_joint_velocity"] is not None
    if gait_fits(settings["links"] - 1, 1, speed):  # (else the number of links is what to change)
        check_gait_size(settings["links"] - 1, settings["order"], "geogait optimize", "--order", speed_limit=speed)

    def run_bytes(links: int) -> float:  # the ceiling's chain motion, or the model run_model picks for the swimmer
        symmetric = settings.get("family", "auto") in ("auto", "symmetric") and links >= 3
        model = _preset({**settings, "links": links}, None).model  # (the swimmer's own: a resistance model's chain)
        model = model or (symmetric_chain_model(links - 1) if symmetric else AdaptiveGaitModel())
        return max(model.memory_bytes(links - 1) if "memory" in model_capabilities(model) else 0.0,
                   chain_motion_bytes(links - 1))

    def fits(links: int) -> bool:
        return run_bytes(links) <= MAX_BYTES and gait_fits(links - 1, 1, speed)

    largest = settings["links"]
    while largest > 3 and not fits(largest):
        largest -= 1
    hint = f"at most --links {largest} with --method {settings['method']} and --family {settings.get('family', 'auto')}"
    check_bytes(run_bytes(settings["links"]), f"the {settings['links']}-link swimmer's ceiling and model",
                "geogait optimize", hint)
    if not fits(settings["links"]):
        raise GeogaitError(f"geogait optimize: the {settings['links']}-link swimmer's joint limits would block each "
                           "solver step for more than a second (SIGTERM and Ctrl-C wait for it); " + hint + ".")


def _hello(robot) -> dict:
    """What a --robot driver's hello declares that the run's gaits were chosen for (kept in its checkpoint)."""
    ranges, region = robot.joint_ranges, robot.shape_constraints
    return {"n_joints": int(robot.n_joints), "cycle_period": float(robot.cycle_period),
            "joint_ranges": None if ranges is None else np.asarray(ranges, dtype=float).tolist(),
            "shape_constraints": None if region is None
            else np.column_stack([region.normals, region.bounds]).tolist()}


def _check_resumed_hello(checkpoint: Path, hello: dict | None) -> None:
    """A resumed --robot run's driver declares what it declared when the run started: the held gait was kept within
    those joint limits and that region, and its speeds were set for that period."""
    from ..optimize import read_checkpoint_metadata

    tag = read_checkpoint_metadata(checkpoint).get("tag")
    then = tag.get("hello") if isinstance(tag, dict) else None
    if hello is None or not isinstance(then, dict):  # (the built-in swimmer; a checkpoint that predates the hello)
        return
    unit = {"cycle_period": " s"}
    changed = [f"{name}: {'none' if then.get(name) is None else then.get(name)}{unit.get(name, '')} then, "
               f"{'none' if value is None else value}{unit.get(name, '')} now"
               for name, value in hello.items() if then.get(name) != value]
    if changed:
        what = textwrap.shorten("; ".join(changed), 300, placeholder=" …")
        raise GeogaitError(f"--resume {checkpoint.parent}: the robot driver's hello changed since the run started "
                           f"({what}); its gaits were chosen for the earlier one. Restore the driver's settings, or "
                           "start a new run with --out.")


def _write_settings(folder: Path, settings: dict, run_id: str) -> None:
    write_text(folder / RUN_FILE, dumps_json({**settings, "run_id": run_id}, indent=1) + "\n")



#: The settings a run.json must hold, with the JSON types each may take (None: null allowed).
_SETTING_TYPES = {"links": (int,), "cycles": (int, None), "seed": (int,), "noise": (int, float),
                  "perturbation": (int, float), "period": (int, float), "gamma_threshold": (int, float),
                  "forgetting_factor": (int, float, None), "order": (int,), "objective": (str,),
                  "max_joint_angle": (int, float, None), "max_joint_velocity": (int, float, None),
                  "settle_cycles": (int, str), "max_tracking_error": (str,), "method": (str,), "family": (str,),
                  "step_rule": (str, None), "robot": (str, None), "robot_timeout": (int, float),
                  "checkpoint_every": (int,)}
#: Settings added since the first runs: absent from an older run.json (then their defaults), else of these types.
_LATER_SETTING_TYPES = {"direction_frame": (str,), "climb": (str, None), "climb_rule": (str, None),
                        "model_class_cycles": (int,)}


def _read_settings(folder: Path) -> dict:
    path = folder / RUN_FILE
    if not folder.is_dir():
        what = "is a file, not a run's folder" if folder.is_file() else describe_path_kind(folder) or "does not exist"
        raise GeogaitError(f"--resume {folder}: {what}.")
    if not path.is_file() or not (folder / CHECKPOINT_FILE).is_file():
        raise GeogaitError(f"--resume {folder}: not the folder of an optimisation run with a checkpoint "
                           f"(needs {RUN_FILE} and {CHECKPOINT_FILE}; a run stopped before its first checkpoint "
                           "cannot be resumed).")
    try:
        settings = json.loads(path.read_bytes().decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as error:
        raise GeogaitError(f"{path} is not valid JSON: {error}") from None
    if not isinstance(settings, dict):
        raise GeogaitError(f"{path} is not the settings record of a run (a JSON object expected).")
    for name, kinds in {**_SETTING_TYPES, **{k: v for k, v in _LATER_SETTING_TYPES.items() if k in settings}}.items():
        value = settings.get(name, ...)
        ok = value is not ... and ((value is None and None in kinds) or (
            not isinstance(value, bool) and isinstance(value, tuple(k for k in kinds if k is not None))))
        if not ok:
            expected = " or ".join({int: "an integer", float: "a number", str: "a string", None: "null"}[k]
                                   for k in kinds)
            got = "missing" if value is ... else f"{value!r:.40}"
            raise GeogaitError(f"{path} is not the settings record of a run: '{name}' must be {expected}, "
                               f"got {got}.")
    return settings


def _figures(folder, system, result, ceiling) -> None:
    from ..plotting import (
        plot_height_function,
        plot_joint_angles,
        plot_path,
        plot_progress,
        plot_shape_space,
        plt,
        save_figure,
    )

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


def _fig5_table(summary: dict):
    """Fig. 5's headline numbers per swimmer (optimization.json holds them all)."""
    table = results_table("Improvement of the displacement per cycle over the seed gait", "swimmer", "trials",
                          "cycles", "median [25–75 %]", "share of the ceiling", "batch method")
    for swimmer, numbers in summary.items():
        if not isinstance(numbers, dict) or "improvement_percentiles" not in numbers:
            continue
        spread = numbers["improvement_percentiles"]
        batch = numbers.get("batch") or {}
        table.add_row(swimmer, str(numbers["trials"]), str(numbers["budget_cycles"]),
                      f"{spread['p50']:+.0%} [{spread['p25']:+.0%}, {spread['p75']:+.0%}]",
                      f"{numbers['median_ceiling_fraction']:.0%}",
                      "" if batch.get("final_median_improvement") is None
                      else f"{batch['final_median_improvement']:+.0%} in {batch['cycles_budget']} cycles")
    return table


@figure_app.command("optimization", cls=help_from(_help_values))
def figure_optimization(
    trials: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        min=1, help="In-situ trials per swimmer [default: {trials}].")] = None,
    links: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Swimmers, comma-separated [default: {links}].")] = None,
    cycles: Annotated[str | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        help="Cycle budgets per swimmer [default: {budgets}].")] = None,
    baseline_trials: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        min=0, help="Batch-method trials per swimmer [default: {baseline_trials}].")] = None,
    baseline_iterations: Annotated[int | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        min=1, help="Batch iterations of {batch_cycles} cycles [default: {baseline_iterations}].")] = None,
    noise: Annotated[float | None, typer.Option(rich_help_panel=EXPERIMENT_PANEL,
        min=0, help="Sensor noise on ξ, fraction of RMS [default: {noise}].")] = None,
    seed: Seed = None,
    jobs: Jobs = 1,
    scheduler: Scheduler = None,
    quick: Annotated[bool, typer.Option(
        "--quick", rich_help_panel=RUN_PANEL, help="3-link only, a few short trials: seconds.")] = False,
    from_csv: FromCsv = None,
    out: Out = Path("out/figure-optimization"),
    overwrite: Overwrite = False,
    json_output: Json = False,
) -> None:
    """Paper Fig. 5: in-situ optimisation of the 3-, 5-, 9-link swimmers, ceiling and batch baseline."""
    from ..experiments.optimization import OptimizationConfig, OptimizationResult, default_budget, run_optimization

    started = time.perf_counter()
    members, manifest = claim_figure(out, "optimization", from_csv, "figure optimization", overwrite=overwrite)
    if from_csv is not None:
        result = OptimizationResult.from_csv(from_csv)
    else:
        base = OptimizationConfig.quick() if quick else OptimizationConfig()
        swimmers = comma_list(links, "--links", int)
        budgets = comma_list(cycles, "--cycles", int)
        if swimmers is not None and budgets is None:  # each swimmer's own budget
            budgets = tuple(map(default_budget, swimmers))
        config = configure(base, n_trials=("--trials", trials), baseline_trials=("--baseline-trials", baseline_trials),
                           baseline_iterations=("--baseline-iterations", baseline_iterations),
                           sensor_noise=("--noise", noise), seed=("--seed", seed), links=("--links", swimmers),
                           budgets=("--cycles", budgets))
        folder = output_folder(out)  # (before the run: a file in its place is refused now)
        result = run_optimization(config, jobs=jobs, scheduler=scheduler)
    folder = output_folder(out)
    summary = result.summary()
    with output_set(folder, last=(manifest,), members=members) as staged:  # one set: no two runs' files mixed
        if from_csv is None:
            result.to_csv(staged / "optimization.csv")
        result.plot(staged / "optimization.png")
        write_manifest(staged / manifest, command="figure optimization",
                       config=result.config_dict() or {"from_csv": str(from_csv)},
                       results={"wall_time_s_sweeps": result.wall_time_s, "workers": result.n_workers, **summary},
                       started=started)
    print_results(summary, lambda: _fig5_table(summary), as_json=json_output)
    written = ["optimization.png", *([] if from_csv is not None else ["optimization.csv"]), manifest]
    console.print(f"wrote {folder}/ ({', '.join(written)})")

