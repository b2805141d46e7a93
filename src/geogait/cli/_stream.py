"""``geogait stream``: learn a model from samples on stdin, one flushed output line per sample.

Thin layer over :func:`geogait.io.run_stream` (the loop, input formats, warm-up and signal
handling are documented in :mod:`geogait.learn._streaming`). Exit codes: 0 at the end of the input
(or when stdout is closed), 1 after a bad record or bad options, 130 after SIGINT (Ctrl-C), 143
after SIGTERM — in every case after saving what was learned.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path
from typing import Annotated, Literal

import typer

from .._defaults import DEFAULT_OUTLIER_LIMIT, TIME_UNITS
from .._files import bounded_lines, check_outputs
from ._app import app, in_cli_words
from ._common import RUN_PANEL, Overwrite, _is_fresh_run_manifest, one_of, refuse_existing, write_manifest

#: The help's option groups.
_INPUT = "Input"

#: Bytes per second a saved model reaches the disk (written, fsynced and renamed), the slower of two measurements
#: on a 2-core machine: 0.19 GB in 1.2 s (32 joints), 0.92 GB in 11.4 s (48 joints).
SAVE_RATE = 80e6
#: Longest save (seconds) that needs no note: every other command answers SIGTERM within 2 s.
QUIET_SAVE_SECONDS = 2.0

_EXIT = {"eof": 0, "output closed": 0, "error": 1, "SIGINT": 128 + signal.SIGINT, "SIGTERM": 128 + signal.SIGTERM}


def _target(source: Path, out: Path | None) -> Path:
    """Where the model is saved: --out, else the model itself, else the config's name with .npz."""
    if out is not None:
        return out
    return source if source.suffix.lower() == ".npz" else source.with_suffix(".npz")


@app.command()
def stream(
    model_or_config: Annotated[Path, typer.Argument(
        help="Saved model (.npz) to keep learning, or a JSON config (hyper-parameters + nominal gait) to start "
             "a fresh one; 'geogait fit' writes both.")],
    phaser: Annotated[Path | None, typer.Option(rich_help_panel=_INPUT,
        help="Saved Phaser: estimate each sample's phase online (input phases are then ignored).")] = None,
    fmt: Annotated[Literal["jsonl", "csv"], typer.Option(
        "--format", metavar=one_of(("jsonl", "csv")), rich_help_panel=_INPUT,
        help="Input: jsonl (one JSON object per line) or csv (header line first); the output uses the same "
             "format.")] = "jsonl",
    save_every: Annotated[int | None, typer.Option(rich_help_panel=RUN_PANEL,
        help="Also save after every N learned samples [default: only at the end].", min=1)] = None,
    out: Annotated[Path | None, typer.Option(rich_help_panel=RUN_PANEL,
        help="Where to save the model (default: the model file itself; for a config, <config>.npz). Another "
             "existing file is replaced only with --overwrite.")] = None,
    phase_window: Annotated[int | None, typer.Option(rich_help_panel=_INPUT,
        help="Memory of the online phase tracker in samples (time constant: a quarter of it) [default: two "
             "training cycles].", min=4)] = None,
    derivative_window: Annotated[int, typer.Option(rich_help_panel=_INPUT,
        help="Samples of the causal differentiator used when samples have no shape_velocity.", min=2,
        max=1000)] = 5,
    time_unit: Annotated[Literal[tuple(TIME_UNITS)] | None, typer.Option(rich_help_panel=_INPUT,
        metavar=one_of(TIME_UNITS), help="Unit of the time stamps and rates, converted to seconds; use the unit "
             "'geogait fit --time-unit' was given [default: the stream's own unit].")] = None,
    outlier_limit: Annotated[float, typer.Option(rich_help_panel=_INPUT,
        help="Quarantine samples further than this many robust standard deviations from the median of the last "
             "1000 accepted ones (0: off; values beyond ±1e12 are always quarantined).", min=0)
    ] = DEFAULT_OUTLIER_LIMIT,
    overwrite: Overwrite = False,
) -> None:
    """Learn from samples on stdin; write each sample's a-priori prediction and online Γ to stdout.

    Input keys (JSON) or columns (CSV): time, phase, shape (shape_0, ...), shape_velocity (shape_velocity_0, ...),
    body_velocity (body_velocity_x, _y, _theta).

    The model is saved atomically at the end of the input, on Ctrl-C or SIGTERM, and every --save-every samples.
    """
    from .._kernels import fast_path_note
    from ..io import CsvReader, JsonLinesReader
    from ..learn import StreamLearner, load_stream_model, run_stream
    from ..phase import Phaser

    started = time.perf_counter()
    if fmt not in ("jsonl", "csv"):
        raise typer.BadParameter(f"expected 'jsonl' or 'csv', got {fmt!r}", param_hint="--format")
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise typer.BadParameter(f"expected one of {', '.join(TIME_UNITS)}, got {time_unit!r}",
                                 param_hint="--time-unit")
    target = _target(model_or_config, out)
    # the saved model may be the output (learning goes on in it); a config or the phaser may not
    config = model_or_config if model_or_config.suffix.lower() == ".json" else None
    check_outputs({"--out": target}, [phaser, config], "stream")
    if not _same_path(target, model_or_config):  # (the model given is saved into: learning goes on in it)
        refuse_existing([target], overwrite=overwrite)
    if not _is_fresh_run_manifest(_manifest(target), "stream"):  # (an earlier stream's record is replaced)
        refuse_existing([_manifest(target)], overwrite=overwrite)
    model = load_stream_model(model_or_config)
    estimator = None if phaser is None else Phaser.load(phaser)
    learner = StreamLearner(model, phaser=estimator, phase_window=phase_window, derivative_window=derivative_window,
                            path=target, save_every=save_every, time_unit=time_unit,
                            outlier_limit=None if outlier_limit == 0 else outlier_limit)
    for note in (fast_path_note(), _save_note(model.saved_bytes(learner.n_joints))):
        if note is not None:
            typer.echo(note, err=True)
    reader = (CsvReader if fmt == "csv" else JsonLinesReader)(bounded_lines(sys.stdin), learner.n_joints)
    summary = run_stream(learner, sys.stdin, sys.stdout, fmt=fmt, reader=_noting(reader, estimator is not None))
    if summary.reason == "output closed":
        _silence_stdout()
    _report(summary)
    config = {"model_or_config": str(model_or_config), "phaser": None if phaser is None else str(phaser),
              "format": fmt, "save_every": save_every, "out": str(target), "phase_window": phase_window,
              "derivative_window": derivative_window, "time_unit": time_unit, "outlier_limit": outlier_limit,
              "overwrite": overwrite}
    results = {"n_samples": summary.n_samples, "n_learned": summary.n_learned, "n_rejected": summary.n_rejected,
               "first_rejection": summary.first_rejection, "online_gamma": summary.gamma, "reason": summary.reason,
               "error": summary.error, "saved": None if summary.saved is None else str(summary.saved)}
    try:
        write_manifest(_manifest(target), command="stream", config=config,
                       results=results, started=started)
    except OSError as failure:
        typer.echo(f"warning: could not write the stream manifest: {failure}", err=True)
    raise typer.Exit(code=_EXIT[summary.reason])


def _save_note(n_bytes: float) -> str | None:
    """What a model whose file takes ``n_bytes`` asks of whoever stops the stream, where its save is long."""
    seconds = n_bytes / SAVE_RATE
    if seconds <= QUIET_SAVE_SECONDS:
        return None
    return (f"note: saving this model ({n_bytes / 1e9:.2g} GB) takes about {seconds:.0f} s, also after Ctrl-C or "
            "SIGTERM; allow that long before a kill (a kill during the save keeps the previous file).")


def _manifest(target: Path) -> Path:
    return target.with_name(f"{target.stem}.stream.json")


def _same_path(a: Path, b: Path) -> bool:
    return os.path.realpath(a) == os.path.realpath(b)


def _silence_stdout() -> None:
    """Point stdout at /dev/null so Python's final flush into a closed pipe raises nothing."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _noting(reader, with_phaser: bool):
    """The reader's samples; notes on stderr about ignored CSV columns and input phases, once."""
    noted = False
    for sample in reader:
        if not noted:
            noted = True
            ignored = getattr(reader, "ignored", [])
            if ignored:
                typer.echo(f"note: ignoring input columns {ignored}", err=True)
            if with_phaser and sample.phase is not None:
                typer.echo("note: the phase is estimated by the Phaser; input phases are ignored", err=True)
        yield sample


def _report(summary) -> None:
    if summary.n_rejected:
        typer.echo(f"warning: {summary.n_rejected} implausible sample(s) quarantined (not learned); the first: "
                   f"{summary.first_rejection}", err=True)
    if summary.error is not None:
        typer.echo(f"error: {in_cli_words(summary.error, {})}", err=True)
    elif summary.reason not in ("eof",):
        typer.echo(f"stopped ({summary.reason})", err=True)
    gamma = "n/a" if summary.gamma is None else f"{summary.gamma:.3f}"
    if summary.saved:
        saved = f"saved the model to {summary.saved}"
    elif summary.n_learned:
        saved = "the model was not saved"
    else:
        saved = "nothing learned: no model written"
    typer.echo(f"{summary.n_learned} of {summary.n_samples} samples learned; online Γ {gamma}; {saved}", err=True)
