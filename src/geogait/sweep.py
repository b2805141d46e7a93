"""The sweep engine: a seeded trial runner (every experiment, the robot benchmark and ``geogait track --trials``
run on it; so can any study of yours).

A sweep runs ``n_trials`` independent trials. Trial ``i`` is driven by
``numpy.random.SeedSequence(seed).spawn(n_trials)[i]``, and trials run in fixed chunks of
``chunk_size`` consecutive indices, so a trial function may vectorise across the trials of a
chunk while the result stays bit-identical whether the chunks run in-process, on a joblib (loky)
pool or on a Dask cluster, with any number of workers.

The trial function contract::

    trial_function(trial_indices, seeds, **config) -> pandas.DataFrame

``trial_indices`` is an int array of shape ``(n,)`` (the chunk's trials), ``seeds`` the list of
their ``n`` seed sequences, and the returned long-format frame has a ``trial`` column holding
indices of the chunk. Results are bit-identical across back-ends provided the trial function is
deterministic given its seeds (multithreaded BLAS reductions may depend on the thread count).

With ``cache_dir`` every finished chunk is written atomically as ``chunk_00012.parquet`` (zero-padded
chunk index) beside a ``sweep.json`` manifest, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
import pyarrow as pa
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from threadpoolctl import threadpool_limits

from ._files import atomic_write, write_text
from ._validation import GeogaitError, check_int, fail

__all__ = ["run_trials", "SweepResult", "TrialFailure", "SweepFailedError"]

_OWNER = "run_trials"
_MANIFEST = "sweep.json"
_CACHE_FORMAT = 1
_FRAME_CONTRACT = "a callable returning a pandas.DataFrame with an int 'trial' column of its chunk"


@dataclass(frozen=True)
class TrialFailure:
    """One trial that raised instead of returning its rows.

    A chunk runs as one call of the trial function, so every trial of a failed chunk is reported
    with the chunk's exception.

    Attributes
    ----------
    trial : int
        Index of the trial in ``0 .. n_trials - 1``.
    chunk : int
        Index of the chunk the trial ran in.
    entropy : int
        Entropy of the trial's seed; ``SeedSequence(entropy, spawn_key=spawn_key)`` rebuilds it.
    spawn_key : tuple of int
        Spawn key of the trial's seed, ``(trial,)``.
    error_type : str
        Class name of the exception.
    message : str
        Message of the exception.
    traceback : str
        Formatted traceback, as raised in the worker.
    """

    trial: int
    chunk: int
    entropy: int
    spawn_key: tuple[int, ...]
    error_type: str
    message: str
    traceback: str


class SweepFailedError(RuntimeError):
    """Trials of a sweep failed; raised by :meth:`SweepResult.raise_on_failure`.

    Parameters
    ----------
    message : str
        Summary of the failures.
    failures : tuple of TrialFailure
        The failed trials, in trial order.
    """

    def __init__(self, message: str, failures: tuple[TrialFailure, ...]):
        super().__init__(message)
        self.failures = failures


@dataclass(frozen=True)
class SweepResult:
    """Outcome of :func:`run_trials`.

    Attributes
    ----------
    frame : pandas.DataFrame
        Rows of every successful trial, sorted by ``trial`` (stable within a trial).
    failures : tuple of TrialFailure
        Failed trials, in trial order; their rows are absent from ``frame``.
    n_trials, seed, chunk_size : int
        Settings of the sweep.
    n_workers : int
        Workers that ran the chunks not found in the cache: 1 in-process, the joblib pool size,
        or the Dask cluster's worker count; 0 when every chunk came from the cache.
    n_cached_chunks : int
        Chunks loaded from ``cache_dir`` instead of computed.
    wall_time_s : float
        Wall-clock duration of the sweep in seconds.
    """

    frame: pd.DataFrame
    failures: tuple[TrialFailure, ...]
    n_trials: int
    seed: int
    chunk_size: int
    n_workers: int
    n_cached_chunks: int
    wall_time_s: float

    def failures_to_pandas(self) -> pd.DataFrame:
        """Failed trials as a frame with one row per trial and the fields of TrialFailure.

        Returns
        -------
        pandas.DataFrame
            Columns ``trial, chunk, entropy, spawn_key, error_type, message, traceback``.
        """
        columns = [field.name for field in dataclasses.fields(TrialFailure)]
        return pd.DataFrame([dataclasses.asdict(f) for f in self.failures], columns=columns)

    def raise_on_failure(self) -> SweepResult:
        """Raise one error summarising the failed trials, if any.

        Returns
        -------
        SweepResult
            ``self``, when no trial failed.

        Raises
        ------
        SweepFailedError
            Listing the failed trials grouped by error, and the first traceback.
        """
        if self.failures:
            raise SweepFailedError(_failure_summary(self.failures, self.n_trials), self.failures)
        return self


def run_trials(
    trial_function: Callable[..., pd.DataFrame],
    n_trials: int,
    *,
    seed: int,
    chunk_size: int = 1,
    jobs: int = 1,
    scheduler=None,
    cache_dir: str | os.PathLike | None = None,
    config: Mapping | None = None,
    progress: bool = True,
    description: str = "trials",
) -> SweepResult:
    """Run ``n_trials`` seeded trials in fixed chunks, in-process, on joblib or on Dask.

    Parameters
    ----------
    trial_function : callable
        ``trial_function(trial_indices, seeds, **config) -> pandas.DataFrame``: ``trial_indices``
        is an int array of shape ``(n,)``, ``seeds`` a list of ``n`` ``SeedSequence``; the
        long-format frame has a ``trial`` column of those indices. Must be importable (defined at
        module level) when ``jobs != 1`` or ``scheduler`` is given.
    n_trials : int
        Number of trials, >= 1; trials are indexed ``0 .. n_trials - 1``.
    seed : int
        Root seed, >= 0. Trial ``i`` gets ``SeedSequence(seed).spawn(n_trials)[i]``.
    chunk_size : int, default=1
        Consecutive trials per call of ``trial_function``. Chunks are fixed by this number alone,
        never by the worker count.
    jobs : int, default=1
        1 runs in-process, ``k > 1`` on ``k`` joblib (loky) processes, -1 on all CPU cores.
        Must be 1 when ``scheduler`` is given.
    scheduler : str or distributed.Client, optional
        Address of a running Dask scheduler (``"tcp://host:8786"``) or a connected client; the
        chunks then run on that cluster. Needs ``pip install geogait[dask]``.
    cache_dir : str or path-like, optional
        Folder for resuming: finished chunks are saved there and reloaded by a rerun with the
        same ``n_trials``, ``seed``, ``chunk_size``, ``config`` and trial function; only missing,
        failed or unreadable chunks are computed again. A folder holding another sweep is refused.
    config : mapping of str to value, optional
        Keyword arguments of ``trial_function``. With ``cache_dir`` its values must be
        JSON-serialisable (numbers, strings, lists, dicts, numpy scalars or arrays).
    progress : bool, default=True
        Show a progress bar (trials done / total, elapsed, remaining) on stderr.
    description : str, default="trials"
        Label of the progress bar.

    Returns
    -------
    SweepResult
        Frame of the successful trials sorted by trial, the failures, timing and worker count.
        A failing chunk never stops the sweep; call ``result.raise_on_failure()`` to be strict.

    Raises
    ------
    GeogaitError
        On a bad parameter, or a ``cache_dir`` holding a different sweep (a ``ValueError``).
    ImportError
        When ``scheduler`` is given but Dask distributed is not installed.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> def draw(trial_indices, seeds, scale=1.0):
    ...     values = [scale * np.random.default_rng(s).random() for s in seeds]
    ...     return pd.DataFrame({"trial": trial_indices, "value": values})
    >>> result = run_trials(draw, 5, seed=0, chunk_size=2, config={"scale": 2.0}, progress=False)
    >>> result.frame["trial"].tolist(), result.failures
    ([0, 1, 2, 3, 4], ())
    """
    sweep = _check_sweep(trial_function, n_trials, seed, chunk_size, jobs, scheduler, cache_dir, config)
    _check_display(progress, description)
    started = time.perf_counter()
    chunks = _make_chunks(sweep.n_trials, sweep.seed, sweep.chunk_size)
    frames = {} if sweep.cache_dir is None else _load_cache(sweep, chunks)
    n_cached = len(frames)
    pending = [chunk for chunk in chunks if chunk.index not in frames]
    with _progress_bar(progress) as bar:
        done = sum(len(chunks[index].trials) for index in frames)
        task = bar.add_task(description, total=sweep.n_trials, completed=done)
        failures, n_workers = _execute(sweep, pending, frames, partial(bar.advance, task))
    return SweepResult(
        frame=_assemble(frames),
        failures=tuple(sorted(failures, key=lambda failure: failure.trial)),
        n_trials=sweep.n_trials,
        seed=sweep.seed,
        chunk_size=sweep.chunk_size,
        n_workers=n_workers,
        n_cached_chunks=n_cached,
        wall_time_s=time.perf_counter() - started,
    )


# --- settings -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Sweep:
    """Validated settings of one call of :func:`run_trials`."""

    trial_function: Callable[..., pd.DataFrame]
    n_trials: int
    seed: int
    chunk_size: int
    jobs: int
    scheduler: object
    cache_dir: Path | None
    config: dict

    def manifest(self) -> dict:
        """What ``sweep.json`` records; a rerun into the same folder must match it."""
        function = self.trial_function
        name = getattr(function, "__qualname__", type(function).__qualname__)
        return {
            "format": _CACHE_FORMAT,
            "n_trials": self.n_trials,
            "seed": self.seed,
            "chunk_size": self.chunk_size,
            "config_sha256": _config_hash(self.config),
            "trial_function": f"{getattr(function, '__module__', None)}:{name}",
        }


def _check_sweep(trial_function, n_trials, seed, chunk_size, jobs, scheduler, cache_dir, config) -> _Sweep:
    if not callable(trial_function):
        raise fail("trial_function", _OWNER, _FRAME_CONTRACT, trial_function)
    return _Sweep(
        trial_function=trial_function,
        n_trials=check_int(n_trials, "n_trials", _OWNER, minimum=1),
        seed=check_int(seed, "seed", _OWNER, minimum=0),
        chunk_size=check_int(chunk_size, "chunk_size", _OWNER, minimum=1),
        jobs=_check_jobs(jobs, scheduler),
        scheduler=_check_scheduler(scheduler),
        cache_dir=_check_cache_dir(cache_dir),
        config=_check_config(config),
    )


def _check_jobs(jobs, scheduler) -> int:
    if isinstance(jobs, bool) or not isinstance(jobs, int | np.integer) or not (jobs >= 1 or jobs == -1):
        raise fail("jobs", _OWNER, "an int >= 1, or -1 for all CPU cores", jobs)
    if scheduler is not None and jobs != 1:
        expected = "1 when 'scheduler' is given (the Dask cluster sets the parallelism)"
        raise fail("jobs", _OWNER, expected, jobs)
    return int(jobs)


def _check_scheduler(scheduler):
    if scheduler is None or (isinstance(scheduler, str) and scheduler.strip()):
        return scheduler
    if isinstance(scheduler, str) or not isinstance(scheduler, _distributed().Client):
        expected = "None, a Dask scheduler address such as 'tcp://host:8786', or a distributed.Client"
        raise fail("scheduler", _OWNER, expected, scheduler)
    return scheduler


def _check_cache_dir(cache_dir) -> Path | None:
    if cache_dir is None:
        return None
    if not isinstance(cache_dir, str | os.PathLike) or Path(cache_dir).is_file():
        raise fail("cache_dir", _OWNER, "None or the path of a folder", cache_dir)
    return Path(cache_dir)


def _check_config(config) -> dict:
    if config is None:
        return {}
    if not isinstance(config, Mapping) or not all(isinstance(key, str) for key in config):
        expected = "None or a mapping with str keys (keyword arguments of trial_function)"
        raise fail("config", _OWNER, expected, config)
    return dict(config)


def _check_display(progress, description) -> None:
    if not isinstance(progress, bool):
        raise fail("progress", _OWNER, "a bool", progress)
    if not isinstance(description, str):
        raise fail("description", _OWNER, "a str", description)


def _config_hash(config: dict) -> str:
    """SHA-256 of the canonical JSON of ``config`` (sorted keys, numpy values as plain ones)."""
    try:
        text = json.dumps(config, sort_keys=True, separators=(",", ":"), default=_json_value)
    except (TypeError, ValueError) as exc:
        expected = "JSON-serialisable when 'cache_dir' is given (numbers, strings, lists, dicts, "
        raise fail("config", _OWNER, expected + "numpy scalars or arrays)", str(exc)) from None
    return hashlib.sha256(text.encode()).hexdigest()


def _json_value(value):
    if isinstance(value, np.ndarray):
        return {"ndarray": value.tolist(), "dtype": value.dtype.str, "shape": list(value.shape)}
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


# --- chunks ---------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Chunk:
    """Consecutive trials that run as one call of the trial function."""

    index: int
    trials: np.ndarray
    seeds: tuple[np.random.SeedSequence, ...]


@dataclass(frozen=True)
class _Outcome:
    """What a worker sends back for one chunk: a frame, or ``(type, message, traceback)``."""

    index: int
    frame: pd.DataFrame | None
    error: tuple[str, str, str] | None


def _make_chunks(n_trials: int, seed: int, chunk_size: int) -> list[_Chunk]:
    seeds = np.random.SeedSequence(seed).spawn(n_trials)
    return [
        _Chunk(
            index,
            np.arange(start, min(start + chunk_size, n_trials)),
            tuple(seeds[start : start + chunk_size]),
        )
        for index, start in enumerate(range(0, n_trials, chunk_size))
    ]


def _run_chunk(trial_function, chunk: _Chunk, config: dict) -> _Outcome:
    """Run one chunk; any exception becomes the outcome's error instead of propagating.

    BLAS runs single-threaded inside a chunk: multithreaded reductions round differently with the
    thread count, which differs between the main process, joblib workers and Dask workers.
    """
    try:
        with threadpool_limits(limits=1):
            frame = trial_function(chunk.trials.copy(), list(chunk.seeds), **config)
        problem = _frame_problem(frame, chunk.trials)
        if problem is not None:
            raise fail("trial_function", _OWNER, _FRAME_CONTRACT, problem)
    except Exception as exc:
        return _Outcome(chunk.index, None, (type(exc).__name__, str(exc), traceback.format_exc()))
    return _Outcome(chunk.index, frame, None)


def _frame_problem(frame, trials: np.ndarray) -> str | None:
    """How ``frame`` breaks the trial-function contract for ``trials``, or None."""
    if not isinstance(frame, pd.DataFrame):
        return f"a {type(frame).__name__}"
    if "trial" not in frame.columns:
        return f"a frame with columns {list(frame.columns)}"
    if not pd.api.types.is_integer_dtype(frame["trial"]):
        return f"a 'trial' column of dtype {frame['trial'].dtype}"
    stray = np.setdiff1d(frame["trial"].to_numpy(), trials)
    return f"trials {stray.tolist()} outside the chunk" if stray.size else None


def _trial_failures(chunk: _Chunk, error: tuple[str, str, str]) -> list[TrialFailure]:
    return [
        TrialFailure(int(trial), chunk.index, int(seed.entropy), tuple(seed.spawn_key), *error)
        for trial, seed in zip(chunk.trials, chunk.seeds, strict=True)
    ]


def _assemble(frames: dict[int, pd.DataFrame]) -> pd.DataFrame:
    if not frames:
        return pd.DataFrame({"trial": np.array([], dtype=np.int64)})
    frame = pd.concat([frames[index] for index in sorted(frames)], ignore_index=True)
    return frame.sort_values("trial", kind="stable", ignore_index=True)


def _failure_summary(failures: tuple[TrialFailure, ...], n_trials: int) -> str:
    groups: dict[tuple[str, str], list[int]] = {}
    for failure in failures:
        groups.setdefault((failure.error_type, failure.message), []).append(failure.trial)
    lines = [f"{len(failures)} of {n_trials} trials failed:"]
    lines += [f"  {_trial_list(trials)}: {kind}: {text}" for (kind, text), trials in groups.items()]
    lines.append(f"Traceback of trial {failures[0].trial}:\n{failures[0].traceback.rstrip()}")
    return "\n".join(lines)


def _trial_list(trials: list[int], limit: int = 10) -> str:
    shown = ", ".join(map(str, trials[:limit]))
    more = f", ... ({len(trials) - limit} more)" if len(trials) > limit else ""
    return f"trial{'s' if len(trials) > 1 else ''} {shown}{more}"


# --- execution ------------------------------------------------------------------------------


def _execute(sweep: _Sweep, pending: list[_Chunk], frames: dict, advance) -> tuple[list, int]:
    """Run ``pending``, adding finished frames to ``frames``; return failures and worker count."""
    if not pending:
        return [], 0
    by_index = {chunk.index: chunk for chunk in pending}
    failures: list[TrialFailure] = []
    with _executor(sweep.jobs, sweep.scheduler) as (run, n_workers):
        for outcome in run(sweep.trial_function, pending, sweep.config):
            chunk = by_index[outcome.index]
            if outcome.error is not None:
                failures += _trial_failures(chunk, outcome.error)
            else:
                frames[chunk.index] = outcome.frame
                if sweep.cache_dir is not None:
                    _save_chunk(sweep.cache_dir, chunk.index, outcome.frame)
            advance(len(chunk.trials))
    return failures, n_workers


@contextmanager
def _executor(jobs: int, scheduler) -> Iterator[tuple[Callable, int]]:
    """Yield ``(run, n_workers)``; ``run(function, chunks, config)`` yields outcomes as done."""
    if scheduler is None:
        n_jobs = joblib.cpu_count() if jobs == -1 else jobs
        yield (_run_serial if n_jobs == 1 else partial(_run_joblib, n_jobs=n_jobs)), n_jobs
    elif isinstance(scheduler, str):
        try:
            client = _distributed().Client(scheduler, set_as_default=False)
        except OSError as error:  # (dask's connection timeout, a refused or unknown address)
            raise GeogaitError(f"Cannot reach the dask scheduler at {scheduler!r}: {error}. Start it first "
                               "(dask scheduler), or check the address.") from None
        with client:
            yield partial(_run_dask, client), len(client.nthreads())
    else:
        yield partial(_run_dask, scheduler), len(scheduler.nthreads())


def _run_serial(function, chunks: list[_Chunk], config: dict) -> Iterator[_Outcome]:
    return (_run_chunk(function, chunk, config) for chunk in chunks)


def _run_joblib(function, chunks: list[_Chunk], config: dict, *, n_jobs: int):
    parallel = joblib.Parallel(n_jobs=n_jobs, backend="loky", return_as="generator_unordered")
    return parallel(joblib.delayed(_run_chunk)(function, chunk, config) for chunk in chunks)


def _run_dask(client, function, chunks: list[_Chunk], config: dict) -> Iterator[_Outcome]:
    futures = [client.submit(_run_chunk, function, chunk, config, pure=False) for chunk in chunks]
    for future in _distributed().as_completed(futures, loop=client.loop):
        yield future.result()


def _distributed():
    """Import Dask distributed, an optional dependency, on first use."""
    try:
        import distributed
    except ImportError as exc:
        raise ImportError(
            "Running trials on a Dask cluster needs Dask distributed, an optional dependency of "
            "geogait: pip install geogait[dask]"
        ) from exc
    return distributed


def _progress_bar(enabled: bool) -> Progress:
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        disable=not enabled,
    )


# --- cache ----------------------------------------------------------------------------------


def _load_cache(sweep: _Sweep, chunks: list[_Chunk]) -> dict[int, pd.DataFrame]:
    """Claim ``sweep.cache_dir`` for this sweep and return the chunks already finished there."""
    _claim_folder(sweep.cache_dir, sweep.manifest())
    loaded = {chunk.index: _load_chunk(sweep.cache_dir, chunk) for chunk in chunks}
    return {index: frame for index, frame in loaded.items() if frame is not None}


def _claim_folder(folder: Path, manifest: dict) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / _MANIFEST
    if path.exists():
        cached = _read_manifest(path)
        if cached is None:
            raise _cache_error(folder, f"an unreadable {_MANIFEST}")
        diffs = [
            f"{key} {cached.get(key)!r} (cached) vs {value!r} (now)"
            for key, value in manifest.items()
            if cached.get(key) != value
        ]
        if diffs:
            raise _cache_error(folder, "a different sweep: " + "; ".join(diffs))
    elif any(folder.glob("chunk_*.parquet")):
        raise _cache_error(folder, f"chunk files but no {_MANIFEST}")
    else:
        write_text(path, json.dumps(manifest, indent=2) + "\n")


def _read_manifest(path: Path) -> dict | None:
    try:
        cached = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return cached if isinstance(cached, dict) else None


def _cache_error(folder: Path, found: str) -> GeogaitError:
    return GeogaitError(
        f"The 'cache_dir' parameter of {_OWNER} must be a new folder or one holding the same "
        f"sweep (n_trials, seed, chunk_size, config, trial function). Got {str(folder)!r}, "
        f"holding {found}, instead. Use another folder or delete this one; results of "
        "different sweeps are never mixed."
    )


def _chunk_path(folder: Path, index: int) -> Path:
    return folder / f"chunk_{index:05d}.parquet"


def _load_chunk(folder: Path, chunk: _Chunk) -> pd.DataFrame | None:
    """The cached frame of ``chunk``, or None when absent or unreadable (with a warning)."""
    path = _chunk_path(folder, chunk.index)
    if not path.exists():
        return None
    try:
        frame = pd.read_parquet(path)
        problem = _frame_problem(frame, chunk.trials)
    except (OSError, ValueError, pa.ArrowException) as exc:
        problem = f"{type(exc).__name__}: {exc}"
    if problem is None:
        return frame
    warnings.warn(
        f"Recomputing chunk {chunk.index}: its cache file {path} is unreadable ({problem}).",
        RuntimeWarning,
        stacklevel=4,
    )
    return None


def _save_chunk(folder: Path, index: int, frame: pd.DataFrame) -> None:
    atomic_write(_chunk_path(folder, index), lambda stream: frame.to_parquet(stream, index=False))
