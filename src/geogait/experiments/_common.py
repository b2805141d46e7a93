"""Pieces the modeling experiments (paper Fig. 2 and Fig. 3) share.

The swimmer set-up, per-trial child seeds, slicing cycles out of batched trajectories, percentile
tables, box statistics with whiskers at chosen percentiles, sweep execution through
:func:`~geogait.sweep.run_trials`, and a result base class with CSV round trips.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._docs import fill_doc
from .._files import describe_path_kind, write_text
from .._seeds import child_seed
from .._validation import GeogaitError, check_float, check_int, fail
from ..gaits import FourierGait, seed_gait
from ..simulate import Trajectory
from ..sweep import run_trials
from ..systems import PurcellSwimmer

__all__ = ["PERCENTILES", "ExperimentResult", "box_stats", "child_seeds", "cycle_block", "percentile_frame",
           "run_sweep", "swimmer_and_gait"]

PERCENTILES = (5, 25, 50, 75, 95)
"""Percentiles reported by every modeling figure: box edges at 25/75, whiskers at 5/95."""

# pandas >= 3 parses floats exactly by default and deprecates the option that older versions need.
#: Columns of experiment CSVs that hold integers (checked when a CSV is read back).
_INTEGER_COLUMNS = frozenset({"trial", "links", "cycle"})
_EXACT_FLOATS = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


def swimmer_and_gait(n_links: int, owner: str) -> tuple[PurcellSwimmer, FourierGait]:
    """The default Purcell swimmer with ``n_links`` links (drag ratio 2) and its seed gait.

    Parameters
    ----------
    n_links : int >= 2
    owner : str
        Name used in error messages.

    Returns
    -------
    system : PurcellSwimmer
    gait : FourierGait
        ``seed_gait(n_links - 1)``: first order, amplitude 1 rad, equal phase lags.
    """
    system = PurcellSwimmer(check_links(n_links, "n_links", owner))
    return system, seed_gait(system.n_joints)


def check_links(n_links, name: str, owner: str, minimum: int = 2) -> int:
    """A number of links a :class:`~geogait.systems.PurcellSwimmer` accepts (``minimum``, default 2, to
    ``PurcellSwimmer.MAX_LINKS``; 3 where the swimmer must move: with one joint it cannot)."""
    n = check_int(n_links, name, owner, minimum=minimum)
    if n > PurcellSwimmer.MAX_LINKS:
        raise fail(name, owner, f"an int in [{minimum}, {PurcellSwimmer.MAX_LINKS}]", n_links)
    return n


def child_seeds(seeds, key: int) -> list[np.random.SeedSequence]:
    """Child ``key`` of every trial seed, built without mutating the parents (:func:`geogait._seeds.child_seed`).

    Parameters
    ----------
    seeds : sequence of numpy.random.SeedSequence
    key : int >= 0

    Returns
    -------
    list of numpy.random.SeedSequence
    """
    return [child_seed(s, key) for s in seeds]


def cycle_block(run: Trajectory, start: int, stop: int, samples_per_cycle: int) -> tuple[np.ndarray, ...]:
    """Samples of cycles ``start <= cycle < stop`` of a batched trajectory, as model inputs.

    Parameters
    ----------
    run : Trajectory
        Batched trajectory (leading trial axis), ``samples_per_cycle`` samples per cycle.
    start, stop : int
        Cycle range.
    samples_per_cycle : int

    Returns
    -------
    phase : ndarray of shape (n_trials, n)
    shape, shape_velocity : ndarray of shape (n_trials, n, d)
    body_velocity : ndarray of shape (n_trials, n, 3)
        With ``n = (stop - start) * samples_per_cycle``.
    """
    part = slice(start * samples_per_cycle, stop * samples_per_cycle)
    return (run.phase[..., part], run.shape[..., part, :], run.shape_velocity[..., part, :],
            run.body_velocity[..., part, :])


def percentile_frame(frame: pd.DataFrame, by: list[str], value: str,
                     percentiles=PERCENTILES) -> pd.DataFrame:
    """Percentiles of ``value`` across trials for every group of ``by``.

    Parameters
    ----------
    frame : pandas.DataFrame
        Long-format results.
    by : list of str
        Grouping columns (e.g. ``["model", "cycles"]``).
    value : str
        Column to summarise.
    percentiles : sequence of float
        In [0, 100]; linear interpolation between order statistics (``numpy.percentile``).

    Returns
    -------
    pandas.DataFrame
        One row per group: the ``by`` columns, ``n`` (trials in the group) and ``p5``, ``p25``, ...
    """
    def summarise(values: pd.Series) -> pd.Series:
        levels = np.percentile(values.to_numpy(), percentiles)
        return pd.Series({"n": float(values.size)} | {f"p{p:g}": v for p, v in zip(percentiles, levels, strict=True)})

    table = frame.groupby(by, sort=True)[value].apply(summarise).unstack().reset_index()
    table["n"] = table["n"].astype(int)
    return table


def box_stats(values, label: str, percentiles=PERCENTILES) -> dict:
    """Statistics for ``matplotlib.axes.Axes.bxp``: box at the 2nd/4th, whiskers at the 1st/5th
    of five percentiles (5/25/50/75/95 by default), no fliers.

    Matplotlib's own ``boxplot`` puts whiskers at 1.5 IQR; the paper's boxes end at percentiles.

    Parameters
    ----------
    values : array-like of shape (n,)
    label : str
    percentiles : sequence of 5 floats, increasing

    Returns
    -------
    dict
        Keys ``whislo, q1, med, q3, whishi, fliers, label``.
    """
    low, q1, median, q3, high = np.percentile(np.asarray(values, dtype=float), percentiles)
    return {"whislo": low, "q1": q1, "med": median, "q3": q3, "whishi": high, "fliers": [], "label": label}


def run_sweep(trial_function, n_trials: int, options: dict, *, seed: int, chunk_size: int, jobs: int,
              scheduler, progress: bool, description: str) -> tuple[pd.DataFrame, float, int]:
    """Run a seeded sweep and fail loudly if any trial failed.

    Parameters
    ----------
    trial_function : callable
        Module-level ``f(trial_indices, seeds, **options) -> DataFrame``.
    n_trials : int
        Runner trials.
    options : dict
        Keyword arguments of ``trial_function``.
    seed, chunk_size, jobs, scheduler, progress, description
        As in :func:`~geogait.sweep.run_trials`.

    Returns
    -------
    frame : pandas.DataFrame
    wall_time_s : float
    n_workers : int

    Raises
    ------
    SweepFailedError
        Naming every failed trial and its seed.
    """
    result = run_trials(trial_function, n_trials, seed=seed, chunk_size=chunk_size, jobs=jobs,
                        scheduler=scheduler, config=options, progress=progress, description=description)
    result.raise_on_failure()
    return result.frame.reset_index(drop=True), result.wall_time_s, result.n_workers


def check_fraction(value, name: str, owner: str) -> float:
    """A float in [0, inf) used for noise and perturbation levels."""
    return check_float(value, name, owner, low=0)


@fill_doc
@dataclass(frozen=True)
class ExperimentResult:
    """Long-format results of one experiment, and how they were made.

    Subclasses set ``COLUMNS`` and add ``summary()`` and ``plot(path)``.

    Parameters
    ----------
    %(result_fields)s
    """

    COLUMNS = ()
    #: Prefix of further columns whose number varies (kept by :meth:`from_csv`); None: no such columns.
    VARIABLE_COLUMNS = None

    frame: pd.DataFrame
    config: object = None
    wall_time_s: float | None = None
    n_workers: int | None = None

    def to_pandas(self) -> pd.DataFrame:
        """A copy of the long-format frame."""
        return self.frame.copy()

    def to_csv(self, path) -> Path:
        """Write the frame as CSV (full float precision, atomically) and return the path."""
        path = Path(path)
        write_text(path, self.frame.to_csv(index=False))
        return path

    @classmethod
    def from_csv(cls, path):
        """Read a CSV written by :meth:`to_csv`; checks the columns.

        Raises
        ------
        GeogaitError
            When the file cannot be parsed, lacks a column this experiment writes, or holds values
            that do not form a result (text or NaN where numbers belong, ...).
        """
        path = Path(path)
        if not path.is_file():
            raise GeogaitError(f"The CSV file {path} {describe_path_kind(path) or 'does not exist'}.")
        try:
            frame = pd.read_csv(path, **_EXACT_FLOATS)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as error:
            reason = " ".join(str(error).split())[:200]
            raise GeogaitError(f"{path} is not a readable {cls.__name__} CSV ({reason}).") from None
        missing = [column for column in cls.COLUMNS if column not in frame.columns]
        if missing or frame.empty:
            raise GeogaitError(f"{path} is not {_article(cls.__name__)} {cls.__name__} CSV: expected columns "
                               f"{list(cls.COLUMNS)} and at least one row. Got columns {list(frame.columns)} and "
                               f"{len(frame)} rows instead.")
        for column in [c for c in cls.COLUMNS if c in _INTEGER_COLUMNS]:
            values = pd.to_numeric(frame[column], errors="coerce").to_numpy(float)
            bad = np.flatnonzero(~np.isfinite(values) | (values != np.round(values)))
            if bad.size:
                raise GeogaitError(f"{path} is not a valid {cls.__name__} CSV: column {column!r} must hold integers. "
                                   f"Got {str(frame[column].iloc[bad[0]])!r} in data row {bad[0]} instead.")
        extra = [c for c in frame.columns if cls.VARIABLE_COLUMNS and str(c).startswith(cls.VARIABLE_COLUMNS)]
        result = cls(frame=frame[list(cls.COLUMNS) + extra])
        try:  # the columns are right; do the values form a result?
            result.summary()
        except (KeyError, ValueError, TypeError, IndexError, ZeroDivisionError, AttributeError) as error:
            reason = " ".join(f"{type(error).__name__}: {error}".split())[:200]
            raise GeogaitError(f"{path} is not a valid {cls.__name__} CSV: its values do not form a result "
                               f"({reason}).") from None
        return result

    def config_dict(self) -> dict | None:
        """The configuration as a plain dict (None when read from a CSV)."""
        return None if self.config is None else dataclasses.asdict(self.config)


def _article(word: str) -> str:
    return "an" if word[:1].lower() in "aeiou" else "a"
