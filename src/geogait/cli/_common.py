"""Small helpers shared by the CLI commands: output folders, comma lists, JSON manifests, progress bars."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

import geogait

from .._files import OutputLock, dumps_json, folder_entries, write_json
from .._validation import GeogaitError
from ._app import in_cli_words

console = Console(stderr=True)

_KINDS: dict[type, tuple[str, str]] = {float: ("numbers", "2,3,4"), int: ("integers", "3,5,9"),
                                       str: ("names", "q1,q2")}


def output_folder(path: Path) -> Path:
    """Create the output folder ``path`` (and its parents) now, before any long work; return it.

    Raises a :class:`~geogait.GeogaitError` when ``path`` is a file or cannot be created.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise GeogaitError(f"The output folder {path} is a file; give a folder with --out.")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise GeogaitError(f"Cannot create the output folder {path}: {error.strerror}.") from None
    return path


def configure(base, **changes):
    """``base`` (an experiment's config dataclass) with every option that was given, validated before anything
    runs: ``changes`` maps a field to ``(option, value)``, and a value of None was not given. A value the config
    refuses is reported as the option's, not the field's."""
    given = {field: value for field, (_, value) in changes.items() if value is not None}
    try:
        return dataclasses.replace(base, **given).validate()
    except GeogaitError as error:
        said = in_cli_words(str(error), {field: option for field, (option, _) in changes.items()})
        if said == str(error):
            raise
        raise GeogaitError(said) from None


@contextlib.contextmanager
def locked_folder(path: Path):
    """Create the output folder ``path`` (and its parents) and lock it for this run (a context manager giving the
    held :class:`~geogait._files.OutputLock`): a second run writing into it is refused until this one ends.

    A folder this call created (and each parent it created) is removed again when the run fails before writing
    anything into it; the lock file goes when the run ends. Raises a :class:`~geogait.GeogaitError` when the
    folder is another run's (locked), a file, or cannot be created.
    """
    created = [level for level in (Path(path), *Path(path).parents) if not level.exists()]  # (innermost first)
    folder = output_folder(path)
    lock = OutputLock(folder)
    try:
        yield lock
    except BaseException:
        if created and not folder_entries(folder):  # (nothing of this run in it: leave no trace)
            lock.release()
            with contextlib.suppress(OSError):  # (a level holding anything else stays)
                for level in created:
                    level.rmdir()
        raise
    finally:
        lock.release()


@contextlib.contextmanager
def claim_output(path: Path, *, overwrite: bool):
    """Create the output folder ``path``, lock it for this run and check that it may be written (a context
    manager giving the held :class:`~geogait._files.OutputLock`, see :func:`locked_folder`).

    A folder holding anything (other than geogait's lock file) is refused unless ``overwrite``. Nothing in it
    is removed here: a command replaces an earlier run's files only once its own run is under way (every
    option checked, the robot started), so a run refused at its start leaves the earlier one whole. Raises a
    :class:`~geogait.GeogaitError` when the folder is another run's (locked), not empty, a file, or cannot be
    created.
    """
    with locked_folder(path) as lock:
        existing = folder_entries(lock.folder)
        if existing and not overwrite:
            shown = ", ".join(existing[:4]) + (", …" if len(existing) > 4 else "")
            raise GeogaitError(f"The output folder {lock.folder} is not empty ({shown}); give --overwrite to "
                               "replace the run it holds, or choose another --out.")
        yield lock


#: The help's group of the options that say where and how a command writes (every command has one).
RUN_PANEL = "Run and output"
#: The help's group of a ``figure`` command's experiment settings.
EXPERIMENT_PANEL = "Experiment"
#: The --overwrite option of commands that write named files (fit, predict, the figures).
Overwrite = Annotated[bool, typer.Option("--overwrite", rich_help_panel=RUN_PANEL,
                                         help="Replace the files an earlier run wrote there (refused without it).")]


#: The options of the ``figure`` commands that say how their sweep runs and where it writes (--out's default is
#: each command's own; --seed's help shows the command's ``{seed}``, see :func:`~geogait.cli._app.help_from`).
Seed = Annotated[int | None, typer.Option(rich_help_panel=RUN_PANEL, help="Root random seed [default: {seed}].", min=0)]
Jobs = Annotated[int, typer.Option(rich_help_panel=RUN_PANEL, help="joblib worker processes (-1: all cores).")]
Scheduler = Annotated[str | None, typer.Option(
    rich_help_panel=RUN_PANEL, help="Address of a Dask scheduler to run the trials on "
                                    "(needs geogait[dask]; then --jobs must be 1).")]
Out = Annotated[Path, typer.Option(rich_help_panel=RUN_PANEL, help="Output folder.")]
FromCsv = Annotated[Path | None, typer.Option(
    rich_help_panel=RUN_PANEL, help="Redraw the figure from this CSV instead of running.")]


#: The --json option of the commands that print their results (a table otherwise).
Json = Annotated[bool, typer.Option("--json", rich_help_panel=RUN_PANEL, help=(
    "Print the results on stdout as one JSON document, for programs (a table otherwise)."))]


def print_results(results: dict, table: Callable[[], Table], *, as_json: bool) -> None:
    """A run's results on stdout: the rich ``table()`` for a reader, or with ``as_json`` ``results`` as one strict
    JSON document (UTF-8, written as is: no terminal wrapping, no escapes)."""
    if as_json:
        sys.stdout.write(dumps_json(results, indent=1, ensure_ascii=False) + "\n")
        sys.stdout.flush()
    else:
        Console().print(table())


def results_table(title: str, *columns: str) -> Table:
    """An empty results table: the first column names a row, the others hold numbers (right-aligned)."""
    table = Table(title=title, title_justify="left")
    table.add_column(columns[0])
    for column in columns[1:]:
        table.add_column(column, justify="right")
    return table


def refuse_existing(paths, *, overwrite: bool) -> None:
    """Refuse, before any work, to replace the files ``paths`` of an earlier run unless ``overwrite``.

    Raises a :class:`~geogait.GeogaitError` naming the first file that exists.
    """
    if overwrite:
        return
    # (a folder in a file's place is not an earlier run's file: the write's own check names it)
    existing = [Path(path) for path in paths if Path(path).exists() and not Path(path).is_dir()]
    if existing:
        more = f" (and {len(existing) - 1} more of the files this run writes)" if len(existing) > 1 else ""
        raise GeogaitError(f"{existing[0]} exists{more}; give --overwrite to replace it, or choose another --out.")


def claim_figure(out: Path, name: str, from_csv, command: str, *, overwrite: bool, extra=()) -> tuple[tuple, str]:
    """Check a ``figure`` command's files in ``out`` before any work: ``<name>.csv``, ``<name>.json``,
    ``<name>.redraw.json``, ``<name>.png`` and ``extra``; returns ``(members, manifest)`` for the
    :class:`~geogait._files.output_set` that writes them and the name its manifest takes.

    A redraw of the folder's own run (``from_csv`` is ``out/<name>.csv``) may always write its figures: it
    replaces no file of the run (``members`` empty) and its manifest goes beside the run's
    (``<name>.redraw.json``). Anything else — a fresh run, or a redraw of another run's CSV — is refused where
    any of these files exists, unless ``overwrite``; its set then replaces them all, so the folder never holds
    the files of two runs.
    """
    out = Path(out)
    files = (f"{name}.csv", f"{name}.json", f"{name}.redraw.json", f"{name}.png", *extra)
    if from_csv is not None and Path(from_csv).resolve() == (out / f"{name}.csv").resolve():
        fresh = _is_fresh_run_manifest(out / f"{name}.json", command)
        return (), f"{name}.redraw.json" if fresh else f"{name}.json"
    refuse_existing([out / file for file in files], overwrite=overwrite)
    return files, f"{name}.json"


def explain_nulls(value, reason: str = "not available for this run"):
    """``value`` (JSON-ready, see :func:`~geogait._files.json_ready`) with a ``"<key>_null_reason"`` beside every
    null that has none yet (the JSON rule of docs/robot-data.md), recursively."""
    if isinstance(value, list):
        return [explain_nulls(v, reason) for v in value]
    if not isinstance(value, dict):
        return value
    out = {}
    for key, item in value.items():
        out[key] = explain_nulls(item, reason)
        if item is None and not str(key).endswith("_null_reason") and f"{key}_null_reason" not in value:
            out[f"{key}_null_reason"] = reason
    return out


def one_of(values) -> str:
    """The metavar of an option with the choices ``values``: "a | b | c" (wrapped at the spaces in the help)."""
    return " | ".join(values)


def listed(values) -> str:
    """The comma-separated text of ``values`` (the inverse of :func:`comma_list`, for help defaults)."""
    return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in values)


def comma_list(text: str | None, option: str, kind: Callable = float) -> tuple | None:
    """Parse a comma-separated option value ('2,3,4') into a tuple of ``kind``; None stays None.

    Parameters
    ----------
    text : str or None
    option : str
        The option's name (``"--links"``), for the message.
    kind : {float, int, str}

    Returns
    -------
    tuple or None

    Raises
    ------
    typer.BadParameter
        For an empty item or an item that is not a ``kind``; floats must be finite.
    """
    if text is None:
        return None
    what, example = _KINDS[kind]
    items = [item.strip() for item in text.split(",")]
    try:
        if not all(items):
            raise ValueError
        values = tuple(kind(item) for item in items)
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated {what} such as '{example}', got {text!r}",
                                 param_hint=option) from None
    if kind is float and not all(np.isfinite(values)):
        raise typer.BadParameter(f"expected finite numbers, got {text!r}", param_hint=option)
    return values


def versions() -> dict:
    """Package and interpreter versions, recorded in every manifest."""
    return {"geogait_version": geogait.__version__, "numpy_version": np.__version__,
            "python_version": platform.python_version()}


def _is_fresh_run_manifest(path: Path, command: str) -> bool:
    """Whether ``path`` holds the manifest of a run of ``command`` (not of a redraw from CSV)."""
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    config = record.get("config") if isinstance(record, dict) else None
    return record.get("command") == command and isinstance(config, dict) and "from_csv" not in config


def write_manifest(path: Path, *, command: str, config: dict, results: dict, started: float) -> Path:
    """The manifest of a run, the JSON file that records it: config, seed, versions, wall time and headline numbers
    (strict JSON). (Where a redraw's manifest goes, beside the run's, is :func:`claim_figure`'s.)

    Returns
    -------
    Path
        Where the manifest was written.
    """
    manifest = {"command": command, **versions(), "config": config,
                "wall_time_s": round(time.perf_counter() - started, 3), "results": results}
    return write_json(path, manifest)


def progress_bar() -> Progress:
    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), TextColumn("{task.fields[status]}"), console=console,
                    transient=False)
