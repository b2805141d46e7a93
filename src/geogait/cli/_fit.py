"""``geogait fit`` and ``geogait predict``: a local gait model from a robot log, and its predictions.

Thin layer: options → :func:`geogait.io.read_log` / :func:`geogait.io.fit_log` /
:func:`geogait.io.predict_log`. Bad logs and options end with the library's message on stderr
and exit code 1.
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import typer

from .._defaults import DEFAULT_OUTLIER_LIMIT, DEFAULT_TEST_FRACTION, TIME_UNITS
from .._files import check_outputs, default_summary_path, describe_path_kind
from .._validation import GeogaitError
from ._app import app
from ._common import RUN_PANEL, Overwrite, comma_list, locked_folder, one_of, refuse_existing, versions

#: The help's option groups.
_COLUMNS, _READING, _MODEL = "Log columns", "Reading the log", "Model"

Columns = Annotated[str | None, typer.Option(rich_help_panel=_COLUMNS,
                                             help="Shape (joint angle) columns, comma-separated.")]
Mapping = Annotated[Path | None, typer.Option(
    rich_help_panel=_COLUMNS, help="Column mapping file (.json or .toml); options override it.")]
Time = Annotated[str | None, typer.Option(rich_help_panel=_COLUMNS, help="Time column (default: time).")]
Phase = Annotated[str | None, typer.Option(
    rich_help_panel=_COLUMNS, help="Phase column (rad); estimated with a Phaser when omitted.")]
Degrees = Annotated[bool | None, typer.Option("--degrees/--radians", rich_help_panel=_COLUMNS,
                                              help="Angles of the log in degrees (default: radians).")]
SmoothingWindow = Annotated[int | None, typer.Option(rich_help_panel=_READING,
    help="Savitzky–Golay window (samples) for shape velocities and pose smoothing (default: read_log's, 11).")]
DropNan = Annotated[bool, typer.Option(
    "--drop-nan", rich_help_panel=_READING, help="Drop rows with NaN (splitting segments there) instead of failing.")]
TimeUnit = Annotated[Literal[tuple(TIME_UNITS)] | None, typer.Option(rich_help_panel=_READING,
    metavar=one_of(TIME_UNITS), help="Unit of the time column and of rate columns, converted to seconds [default: "
                                     "the log's own unit, assumed to be seconds when checking the phase rate].")]
OutlierLimit = Annotated[float, typer.Option(rich_help_panel=_READING,
    help="Plausibility bound in robust standard deviations (1.4826 × MAD) from each column's median; "
         "0 switches it off.", min=0)]


def _names(text: str | None, option: str) -> list[str] | None:
    """'a,b,c' → ['a', 'b', 'c']; None stays None."""
    names = comma_list(text, option, str)
    return None if names is None else list(names)


def _log_options(smoothing_window: int | None, time_unit: str | None, outlier_limit: float) -> dict:
    """read_log's keywords for the options that were given (read_log's defaults otherwise)."""
    if smoothing_window is not None and not (smoothing_window >= 3 and smoothing_window % 2 == 1):
        raise typer.BadParameter(f"expected an odd number of samples >= 3, got {smoothing_window}",
                                 param_hint="--smoothing-window")
    options = {} if smoothing_window is None else {"window": smoothing_window}
    if time_unit is not None:
        if time_unit not in TIME_UNITS:
            raise typer.BadParameter(f"expected one of {', '.join(TIME_UNITS)}, got {time_unit!r}",
                                     param_hint="--time-unit")
        options["time_unit"] = time_unit
    options["outlier_limit"] = None if outlier_limit == 0 else outlier_limit
    return options


def _gait_order(text: str) -> int | None:
    if text == "auto":
        return None
    try:
        return int(text)
    except ValueError:
        raise typer.BadParameter(f"expected 'auto' or an integer, got {text!r}", param_hint="--gait-order") from None


@app.command()
def fit(
    log: Annotated[Path, typer.Argument(help="Log file: .csv, .parquet or .pq.")],
    mapping: Mapping = None,
    time_column: Annotated[str | None, typer.Option(
        "--time", rich_help_panel=_COLUMNS, help="Time column (default: time).")] = None,
    shape: Columns = None,
    pose: Annotated[str | None, typer.Option(
        rich_help_panel=_COLUMNS, help="Pose columns x,y,heading (world frame).")] = None,
    body_velocity: Annotated[str | None, typer.Option(
        rich_help_panel=_COLUMNS, help="Body-velocity columns v_x,v_y,omega.")] = None,
    shape_velocity: Annotated[str | None, typer.Option(rich_help_panel=_COLUMNS,
        help="Shape-velocity columns; Savitzky–Golay derivative of the shapes when omitted.")] = None,
    phase: Phase = None,
    degrees: Degrees = None,
    smoothing_window: SmoothingWindow = None,
    drop_nan: DropNan = False,
    time_unit: TimeUnit = None,
    outlier_limit: OutlierLimit = DEFAULT_OUTLIER_LIMIT,
    forgetting_factor: Annotated[float | None, typer.Option(rich_help_panel=_MODEL,
        help="λ of the model's RLS filters (default: AdaptiveGaitModel's, 0.99).")] = None,
    windows: Annotated[int | None, typer.Option(rich_help_panel=_MODEL,
        help="Phase windows M of the model (default: AdaptiveGaitModel's, 20).")] = None,
    gait_order: Annotated[str, typer.Option(rich_help_panel=_MODEL,
        help="Fourier order of the nominal gait, or 'auto' (cross-validated held-out error).")] = "auto",
    test_fraction: Annotated[float, typer.Option(rich_help_panel=_MODEL,
        help="Fraction of each segment's cycles held out (the last).")] = DEFAULT_TEST_FRACTION,
    refit: Annotated[bool, typer.Option(rich_help_panel=_MODEL,
        help="Save a model refit on all data after scoring (else the scored training-cycles model).")] = True,
    out: Annotated[Path, typer.Option(rich_help_panel=RUN_PANEL, help="Output folder.")] = ...,
    overwrite: Overwrite = False,
) -> None:
    """Fit a local gait model to a log; write model.npz, phaser.npz, config.json, the manifest report.json and PNGs.

    Γ is scored on the held-out last cycles of every segment (report.json: Γ overall and per cycle, online Γ,
    gait order, phase rate). phaser.npz is written when the phase is estimated (no --phase column).
    """
    from ..io import read_log, resolve_mapping
    from ..learn import LogFit, fit_log

    started = time.perf_counter()
    order = _gait_order(gait_order)
    log_options = _log_options(smoothing_window, time_unit, outlier_limit)
    names = {"shape": _names(shape, "--shape"), "pose": _names(pose, "--pose"),
             "body_velocity": _names(body_velocity, "--body-velocity"),
             "shape_velocity": _names(shape_velocity, "--shape-velocity")}
    _check_log(log)  # (before the columns are judged against what the log must hold)
    columns = resolve_mapping(mapping, time=time_column, phase=phase, degrees=degrees, **names)
    # (the folder's files are replaced as one set: none of them may be an input, e.g. its own mapping.json)
    check_outputs({"--out": out}, [log, mapping], "fit")
    for name in LogFit.OUTPUT_FILES:
        check_outputs({"--out": Path(out) / name}, [log, mapping], "fit")
    with locked_folder(out):  # (a second run into the folder is refused until this one has written it)
        refuse_existing([Path(out) / name for name in LogFit.OUTPUT_FILES], overwrite=overwrite)
        data = read_log(log, columns, drop_nan=drop_nan, **log_options)
        result = fit_log(data, forgetting_factor=forgetting_factor, n_windows=windows, gait_order=order,
                         test_fraction=test_fraction, refit=refit)
        options = {"log": str(log), "smoothing_window": smoothing_window, "drop_nan": drop_nan,
                   "time_unit": time_unit, "outlier_limit": outlier_limit,
                   "forgetting_factor": forgetting_factor, "windows": windows, "gait_order": gait_order,
                   "test_fraction": test_fraction, "refit": refit}
        paths = result.save(out, mapping=columns, extra={"command": "fit", **versions(), "options": options,
                                                         "wall_time_s": round(time.perf_counter() - started, 3)})
    summary = result.summary()
    typer.echo(f"held-out Γ {_gamma_text(summary['held_out_gamma'])} over {summary['n_test_cycles']} cycles "
               f"({summary['n_train_cycles']} training); online Γ {summary['online_gamma_end']:.3f}; "
               f"gait order {summary['gait_order']}; phase rate {summary['phase_rate']:.4g} rad per time unit",
               err=True)
    verdict = summary["model_class"]
    if verdict["principally_kinematic"] is False:
        typer.echo(f"warning: {verdict['reason']}", err=True)
    typer.echo(f"wrote {', '.join(sorted(p.name for p in paths.values()))} to {out}/", err=True)


@app.command()
def predict(
    model: Annotated[Path, typer.Argument(help="Saved model (.npz), e.g. from 'geogait fit'.")],
    log: Annotated[Path, typer.Argument(help="Log file: .csv, .parquet or .pq.")],
    phaser: Annotated[Path | None, typer.Option(rich_help_panel=_MODEL,
        help="Saved Phaser (phaser.npz of 'geogait fit'), for logs without a phase column.")] = None,
    out: Annotated[Path, typer.Option(rich_help_panel=RUN_PANEL,
        help="Predictions CSV, a name ending in .csv (never one of the inputs).")] = Path("predictions.csv"),
    summary: Annotated[Path | None, typer.Option(rich_help_panel=RUN_PANEL,
        help="The manifest: Γ and the settings, JSON [default: --out with suffix .json; <name>.summary.json for an "
             "--out ending in .json].")
    ] = None,
    mapping: Mapping = None,
    time_column: Annotated[str | None, typer.Option(
        "--time", rich_help_panel=_COLUMNS, help="Time column (default: time).")] = None,
    shape: Columns = None,
    pose: Annotated[str | None, typer.Option(
        rich_help_panel=_COLUMNS, help="Pose columns x,y,heading, for measured ξ.")] = None,
    body_velocity: Annotated[str | None, typer.Option(
        rich_help_panel=_COLUMNS, help="Measured body-velocity columns.")] = None,
    shape_velocity: Annotated[str | None, typer.Option(
        rich_help_panel=_COLUMNS, help="Shape-velocity columns.")] = None,
    phase: Phase = None,
    degrees: Degrees = None,
    measured: Annotated[bool, typer.Option(rich_help_panel=_COLUMNS,
        help="Read measured ξ (body-velocity or pose columns) when the mapping names them, for Γ.")] = True,
    smoothing_window: SmoothingWindow = None,
    drop_nan: DropNan = False,
    time_unit: TimeUnit = None,
    outlier_limit: OutlierLimit = DEFAULT_OUTLIER_LIMIT,
    overwrite: Overwrite = False,
) -> None:
    """Predict the body velocity of every sample of a log; write a CSV and Γ (if ξ was measured)."""
    from ..io import read_log_for_prediction
    from ..learn import predict_log
    from ..models import AdaptiveGaitModel
    from ..phase import Phaser

    started = time.perf_counter()
    _check_log(log)
    summary_path = default_summary_path(out) if summary is None else summary
    inputs = (model, log, phaser, mapping)
    check_outputs({"--out": out, "--summary": summary_path}, inputs, "predict")
    if out.suffix.lower() != ".csv":
        raise GeogaitError(f"--out is the predictions CSV file: give a name ending in .csv. Got {str(out)!r} "
                           "instead (the Γ summary goes to --summary).")
    log_options = _log_options(smoothing_window, time_unit, outlier_limit)
    with contextlib.ExitStack() as locks:  # (each folder written into, once; a second run is refused meanwhile)
        for folder in dict.fromkeys(Path(os.path.realpath(path)).parent for path in (out, summary_path)):
            locks.enter_context(locked_folder(folder))
        refuse_existing([out, summary_path], overwrite=overwrite)
        fitted = AdaptiveGaitModel.load(model)
        estimator = None if phaser is None else Phaser.load(phaser)
        data, has_measured = read_log_for_prediction(
            log, mapping, measured=measured, time=time_column, shape=_names(shape, "--shape"),
            pose=_names(pose, "--pose"), body_velocity=_names(body_velocity, "--body-velocity"),
            shape_velocity=_names(shape_velocity, "--shape-velocity"), phase=phase, degrees=degrees,
            drop_nan=drop_nan, **log_options)
        result = predict_log(fitted, data, phaser=estimator, measured=has_measured)
        options = {"time_unit": time_unit, "outlier_limit": outlier_limit, "smoothing_window": smoothing_window,
                   "drop_nan": drop_nan, "measured": measured}
        paths = result.save(out, summary_path=summary_path, protect=inputs,
                            extra={"command": "predict", **versions(), "model": str(model), "log": str(log),
                                   "phaser": None if phaser is None else str(phaser), "options": options,
                                   "wall_time_s": round(time.perf_counter() - started, 3)})
    value = result.gamma()
    typer.echo(f"Γ {_gamma_text(value)} over {data.n_samples} samples" if value is not None
               else f"predicted {data.n_samples} samples (no measured body velocity: no Γ)", err=True)
    typer.echo(f"wrote {paths[0]} and {paths[1]}", err=True)


def _gamma_text(value: float) -> str:
    """Γ as printed: three decimals, or 'undefined' (NaN: a log in which the robot stood still)."""
    return "undefined" if np.isnan(value) else f"{value:.3f}"


def _check_log(log: Path) -> None:
    """The LOG argument names a readable file (said before any column option is judged)."""
    if not Path(log).is_file():
        raise GeogaitError(f"The LOG argument must be an existing log file. Got {str(log)!r} "
                           f"({describe_path_kind(Path(log)) or 'does not exist'}) instead.")
