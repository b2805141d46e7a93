r"""Robot logs in: CSV, Parquet or a DataFrame → a :class:`Log` of the arrays the models need.

A log has a time column, shape columns r (joint angles) and either body-velocity columns
ξ = (v_x, v_y, ω) or pose columns g = (x, y, heading) (or both). Optional: shape-velocity
columns ṙ and a phase column. Column names come from keyword arguments or a mapping file
(:func:`load_column_mapping`); keyword arguments override the mapping.

Units: angles in radians (``degrees=True`` converts the shape, shape-velocity and heading
columns and the ω column of body velocity; the phase column is always radians), lengths in any
unit (body velocities come out in that unit per time unit), time in seconds or in the unit
declared by ``time_unit`` (``"ms"``, ``"us"``, ``"ns"``: time and the rate columns are converted to
seconds); pandas datetimes/timedeltas, and their ISO 8601 text in a CSV, become seconds; stamps that change
unit within the log (segments stepping 1000×, 10⁶× or 10⁹× apart) are an error. The model's RLS prior is
scaled for rates per second of a gait of about 0.01–100 cycles per second: :func:`~geogait.io.fit_log` warns when
the phase rate is outside that range and refuses rates outside 1 cycle per day – 1000 cycles per
second.

Plausibility: every value must lie within ±1e12, and a value further than ``outlier_limit``
(default 1000) robust standard deviations from its column's median (shapes, rates, body
velocities, steps of the x, y pose columns) is an error naming the column and row.

Derived quantities, computed independently in every segment:

* **Body velocity from poses** with SE(2) logarithms of consecutive relative poses, never finite
  differences of x, y, heading:

  .. math:: \xi_n = \frac{1}{t_{n+1} - t_n}\,\log\bigl(g_n^{-1} g_{n+1}\bigr)^\vee
     \qquad (\text{scheme} = \text{"forward"})

  the constant twist that carries :math:`g_n` to :math:`g_{n+1}` — the exact inverse of the
  zero-order-hold integration :math:`g_{n+1} = g_n \exp(\Delta t\,\hat\xi_n)` of
  :func:`geogait.se2.integrate_body_velocity` and of the simulators. The last sample of a
  segment has no successor and takes the twist of the step before it. ``scheme="central"``
  averages the twists of the steps before and after each sample (weighted by their durations),
  which centres ξ on the sample time like the Savitzky–Golay ṙ — better for continuous-time
  recordings, at a half-sample offset from the simulators' convention.
  The heading is unwrapped within each segment; a heading step over π/2 between consecutive
  samples is an error (undersampled, or a heading in degrees read as radians).
* **Pose smoothing** (``smooth_poses=True``, default): x, y and the unwrapped heading are
  smoothed with the same Savitzky–Golay filter (``window``, ``polyorder``, no derivative) before
  the logarithms. Motion-capture noise is amplified by 1/Δt in any difference; filtering poses
  and shapes alike keeps the low-pass applied to ξ and to ṙ the same, so ξ = −A(r) ṙ still holds
  between the filtered signals.
* **Shape velocity** by a Savitzky–Golay derivative (``scipy.signal.savgol_filter`` with
  ``deriv=1``, ``delta`` = the segment's median step) when no shape-velocity columns are given.
  A measured body velocity is then smoothed by the same filter (no derivative): the estimate of ṙ
  misses what the filter removes (the fast part of a perturbation, for one), and ξ must miss the
  same part for ξ = −A(r) ṙ to hold between them. Likewise a measured shape velocity is smoothed
  when ξ comes from smoothed poses. Only when both are measured is neither filtered.

Irregular time stamps:

* non-increasing time (a stamp equal to or earlier than the one before) → error naming the row;
* a step longer than ``gap_factor`` × the median step is a gap: the log is split into segments
  there, processed independently (no differentiation across a gap);
* within a segment, when a Savitzky–Golay filter is needed, the steps must be uniform: every step
  within ``max_jitter`` (relative) of the segment's median, else an error naming the row;
* NaN or infinite values in a used column → error naming rows and columns, unless
  ``drop_nan=True``, which drops those rows and starts a new segment after each dropped run.

Rows are numbered from 0 in data order (a CSV's first data line is row 0); :attr:`Log.row` keeps
the source row of every sample.
"""

from __future__ import annotations

import csv
import json
import tomllib
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
from scipy.signal import savgol_filter

from .. import _blocks, se2
from .._defaults import DEFAULT_OUTLIER_LIMIT, TIME_UNITS
from .._files import describe_path_kind, read_utf8
from .._validation import (
    MAX_BYTES,
    MAX_MAGNITUDE,
    GeogaitError,
    check_bytes,
    check_choice,
    check_float,
    check_int,
    fail,
)
from ..phase import cycle_index
from ..simulate import BODY_VELOCITY_COLUMNS, POSE_COLUMNS, Trajectory

__all__ = ["ColumnMapping", "Log", "load_column_mapping", "mapping_to_json", "read_log", "read_log_for_prediction",
           "resolve_mapping"]

_READ = "read_log"
_SCHEMES = ("forward", "central")


# -- column mapping -----------------------------------------------------------------------------
@dataclass(frozen=True)
class ColumnMapping:
    """Which column of a log holds what.

    Parameters
    ----------
    time : str
    shape : tuple of str
        One column per joint, in joint order.
    body_velocity : tuple of 3 str, optional
        (v_x, v_y, ω) in the body frame.
    pose : tuple of 3 str, optional
        (x, y, heading) in the world frame. At least one of ``body_velocity`` and ``pose``.
    shape_velocity : tuple of str, optional
        One per joint; computed by Savitzky–Golay when omitted.
    phase : str, optional
        Gait phase in radians; estimate it with :class:`~geogait.phase.Phaser` when omitted.
    degrees : bool
        Angles (shape, shape velocity, heading, ω) are in degrees.

    Examples
    --------
    >>> ColumnMapping(shape=["q1", "q2"], pose=["x", "y", "yaw"]).columns()
    ['time', 'q1', 'q2', 'x', 'y', 'yaw']
    """

    time: str = "time"
    shape: tuple[str, ...] = ()
    body_velocity: tuple[str, ...] | None = None
    pose: tuple[str, ...] | None = None
    shape_velocity: tuple[str, ...] | None = None
    phase: str | None = None
    degrees: bool = False

    def __post_init__(self):
        owner = "ColumnMapping"
        for name in ("time", "phase"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                raise fail(name, owner, "a column name (str)", value)
        for name in ("shape", "body_velocity", "pose", "shape_velocity"):
            object.__setattr__(self, name, _names(getattr(self, name), name, owner))
        if not self.shape:
            raise fail("shape", owner, "a non-empty list of column names", self.shape)
        for name in ("body_velocity", "pose"):
            value = getattr(self, name)
            if value is not None and len(value) != 3:
                raise fail(name, owner, "a list of 3 column names", list(value))
        if self.body_velocity is None and self.pose is None:
            raise fail("body_velocity", owner, "given, or 'pose' given", None)
        if self.shape_velocity is not None and len(self.shape_velocity) != len(self.shape):
            raise fail("shape_velocity", owner, f"a list of {len(self.shape)} column names (one per joint)",
                       list(self.shape_velocity))
        if not isinstance(self.degrees, bool | np.bool_):
            raise fail("degrees", owner, "a bool", self.degrees)
        used = self.columns()
        repeated = sorted({c for c in used if used.count(c) > 1})
        if repeated:
            raise fail("columns", owner, "distinct column names for distinct quantities",
                       f"{repeated} used twice")

    def columns(self) -> list[str]:
        """Every column the log must have, in a fixed order."""
        groups = [[self.time], self.shape, self.shape_velocity, self.body_velocity, self.pose,
                  [self.phase] if self.phase else None]
        return [c for group in groups if group for c in group]

    @classmethod
    def from_dict(cls, entries: dict, source: str = "mapping") -> ColumnMapping:
        """From a dict with the field names as keys; unknown keys are an error.

        Parameters
        ----------
        entries : dict
            Field name → value, e.g. ``{"shape": ["q1", "q2"], "pose": ["x", "y", "yaw"]}`` (as read from a
            JSON or TOML file).
        source : str, default "mapping"
            Name of where ``entries`` came from (e.g. the file), used in error messages.
        """
        if not isinstance(entries, dict):
            raise fail(source, "ColumnMapping.from_dict", "a table of column names", entries)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(entries) - known)
        if unknown:
            raise fail(source, "ColumnMapping.from_dict", f"a table with keys among {sorted(known)}",
                       f"unknown key(s) {unknown}")
        return cls(**entries)


def _names(value, name: str, owner: str) -> tuple[str, ...] | None:
    if value is None:
        return None
    if isinstance(value, str | bytes | dict) or not hasattr(value, "__iter__") or not all(isinstance(v, str)
                                                                                        for v in value):
        raise fail(name, owner, "a list of column names (str)", value)
    return tuple(value)


def load_column_mapping(path) -> ColumnMapping:
    """Read a :class:`ColumnMapping` from a JSON (``.json``) or TOML (``.toml``) file.

    The file is one flat table with the keys of :class:`ColumnMapping`, e.g. in TOML::

        time = "t"
        shape = ["joint1", "joint2"]
        pose = ["x", "y", "yaw"]
        degrees = true

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ColumnMapping
    """
    path = Path(path)
    owner = "load_column_mapping"
    if path.suffix.lower() not in (".json", ".toml"):
        raise fail("path", owner, "a .json or .toml file", str(path))
    if not path.is_file():
        raise fail("path", owner, "an existing file", f"{path} ({describe_path_kind(path) or 'does not exist'})")
    text = read_utf8(path, owner)
    try:
        entries = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as error:
        raise fail("path", owner, f"a valid {path.suffix[1:].upper()} file", f"{path}: {error}") from None
    return ColumnMapping.from_dict(entries, source="path")


# -- the log ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Log:
    """Samples of a robot log, split into segments of uniform sampling.

    Attributes
    ----------
    time : ndarray of shape (n,)
    shape : ndarray of shape (n, d)
        r in radians.
    shape_velocity : ndarray of shape (n, d)
        ṙ in radians per time unit.
    body_velocity : ndarray of shape (n, 3)
        ξ = (v_x, v_y, ω) in the body frame.
    segment : ndarray of shape (n,), int
        Segment of each sample, 0, 1, ...; consecutive samples of one segment are one step
        apart, a new segment starts after a gap or dropped rows.
    row : ndarray of shape (n,), int
        Source row of each sample.
    pose : ndarray of shape (n, 3) or None
        (x, y, heading) as logged (heading unwrapped within segments), if the log had poses.
    phase : ndarray of shape (n,) or None
        Phase in ``[0, 2π)``, if known.
    time_unit : str or None
        ``"s"`` when :func:`read_log` converted time and rates to seconds (its ``time_unit``);
        None when they are in the log's own, undeclared unit.

    Examples
    --------
    A log without a phase column gets one from a :class:`~geogait.phase.Phaser` fitted on
    its shapes (every segment one record)::

        phaser = Phaser().fit([s.shape for s in log.segments()])
        log = log.with_phase(phaser.transform([s.shape for s in log.segments()]))
    """

    time: np.ndarray
    shape: np.ndarray
    shape_velocity: np.ndarray
    body_velocity: np.ndarray
    segment: np.ndarray
    row: np.ndarray
    pose: np.ndarray | None = None
    phase: np.ndarray | None = None
    time_unit: str | None = None

    @property
    def n_samples(self) -> int:
        return self.time.shape[0]

    @property
    def n_joints(self) -> int:
        return self.shape.shape[1]

    @property
    def n_segments(self) -> int:
        return int(np.unique(self.segment).size)

    def segments(self) -> list[Log]:
        """One :class:`Log` per segment (segment numbers kept)."""
        bounds = np.flatnonzero(np.diff(self.segment)) + 1
        slices = zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [self.n_samples]]), strict=True)
        return [self._take(slice(a, b)) for a, b in slices]

    def _take(self, index) -> Log:
        return Log(**{f.name: getattr(self, f.name) if not isinstance(getattr(self, f.name), np.ndarray)
                      else getattr(self, f.name)[index] for f in fields(self)})

    def with_phase(self, phase) -> Log:
        """The same log with ``phase``: an array ``(n,)`` or a list of per-segment arrays."""
        if isinstance(phase, list | tuple):
            phase = np.concatenate([np.asarray(p, dtype=float) for p in phase])
        phase = np.asarray(phase, dtype=float)
        if phase.shape != self.time.shape or not np.all(np.isfinite(phase)):
            raise fail("phase", "Log.with_phase", f"finite, of shape ({self.n_samples},)",
                       f"shape {phase.shape}")
        return replace(self, phase=np.mod(phase, 2 * np.pi))

    def to_trajectory(self) -> Trajectory:
        """The log as a :class:`~geogait.simulate.Trajectory` (needs a phase).

        ``cycle`` counts phase wraps and starts a new cycle at every segment. Without logged
        poses, ``pose`` integrates ``body_velocity`` (zero-order hold), each segment continuing
        from where the previous one ended (the motion during a gap is unknown).
        """
        if self.phase is None:
            raise fail("phase", "Log.to_trajectory", "known (use Log.with_phase, e.g. with a Phaser)", None)
        cycles, poses, start_cycle, start_pose = [], [], 0, np.zeros(3)
        for part in self.segments():
            wraps = cycle_index(part.phase)
            cycles.append(start_cycle + wraps)
            start_cycle += int(wraps[-1]) + 1
            pose = part.pose if part.pose is not None else _integrate(part, start_pose)
            poses.append(pose)
            start_pose = pose[-1]
        return Trajectory(time=self.time, phase=self.phase, cycle=np.concatenate(cycles),
                          shape=self.shape, shape_velocity=self.shape_velocity,
                          body_velocity=self.body_velocity, pose=np.concatenate(poses))

    def to_pandas(self) -> pd.DataFrame:
        """One row per sample: row, segment, time, [phase], shape_j, shape_velocity_j, ξ, [pose]."""
        columns: dict[str, np.ndarray] = {"row": self.row, "segment": self.segment, "time": self.time}
        if self.phase is not None:
            columns["phase"] = self.phase
        for name in ("shape", "shape_velocity"):
            for j in range(self.n_joints):
                columns[f"{name}_{j}"] = getattr(self, name)[:, j]
        columns.update(zip(BODY_VELOCITY_COLUMNS, self.body_velocity.T, strict=True))
        if self.pose is not None:
            columns.update(zip(POSE_COLUMNS, self.pose.T, strict=True))
        return pd.DataFrame(columns)


def _integrate(part: Log, start_pose: np.ndarray) -> np.ndarray:
    dt = np.diff(part.time)
    return se2.integrate_body_velocity(part.body_velocity[:-1], dt, start_pose)


# -- reading ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Options:
    drop_nan: bool
    gap_factor: float
    max_jitter: float
    window: int
    polyorder: int
    smooth_poses: bool
    scheme: str


def read_log(source, mapping=None, *, time: str | None = None, shape=None, body_velocity=None,
             pose=None, shape_velocity=None, phase: str | None = None, degrees: bool | None = None,
             drop_nan: bool = False, gap_factor: float = 1.5, max_jitter: float = 0.1, window: int = 11,
             polyorder: int = 3, smooth_poses: bool = True, scheme: str = "forward", time_unit: str | None = None,
             outlier_limit: float | None = DEFAULT_OUTLIER_LIMIT) -> Log:
    """Read a robot log into a :class:`Log`.

    Parameters
    ----------
    source : str, Path or pandas.DataFrame
        A ``.csv`` or ``.parquet`` / ``.pq`` file, or a table.
    mapping : ColumnMapping, str or Path, optional
        Column mapping, or the path of a mapping file (:func:`load_column_mapping`).
    time, shape, body_velocity, pose, shape_velocity, phase, degrees
        Fields of :class:`ColumnMapping`; each one given overrides the mapping's. ``time``
        defaults to ``"time"``, ``degrees`` to False.
    drop_nan : bool
        Drop rows with NaN/inf in a used column (and split segments there) instead of failing.
    gap_factor : float > 1
        A time step longer than this many median steps splits the log into segments.
    max_jitter : float >= 0
        Largest relative deviation of a step from its segment's median step when a
        Savitzky–Golay filter is applied.
    window : int
        Savitzky–Golay window length (odd, samples) for ṙ and pose smoothing; every segment
        needs at least this many samples.
    polyorder : int
        Savitzky–Golay polynomial order (< window).
    smooth_poses : bool
        Smooth poses before computing body velocities (see the module notes).
    scheme : {"forward", "central"}
        Sample assignment of the pose-derived body velocity (:func:`geogait.se2.body_velocity_from_poses`).
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column and of every rate column (shape velocity, body velocity): all are
        converted to seconds. None (default) keeps them in the log's own unit.
    outlier_limit : float > 0, optional
        Plausibility bound: a value further than ``outlier_limit`` robust standard deviations
        (1.4826 × the median absolute deviation) from its column's median is an error naming the
        column and row. It is applied to the shape, shape-velocity and body-velocity columns and to
        the steps of the x, y columns of poses; None switches it off. Every value must also lie
        within ±1e12 (:data:`geogait._validation.MAX_MAGNITUDE`).

    Returns
    -------
    Log

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> t = np.arange(200) * 0.01
    >>> frame = pd.DataFrame({"t": t, "q": np.sin(2 * np.pi * t), "vx": 0.1, "vy": 0.0, "w": 0.0})
    >>> log = read_log(frame, time="t", shape=["q"], body_velocity=["vx", "vy", "w"])
    >>> log.shape.shape, round(float(log.shape_velocity[100, 0]), 3)
    ((200, 1), 6.283)
    """
    columns = resolve_columns(mapping, dict(time=time, shape=shape, body_velocity=body_velocity, pose=pose,
                                             shape_velocity=shape_velocity, phase=phase, degrees=degrees))
    options = _check_options(drop_nan, gap_factor, max_jitter, window, polyorder, smooth_poses, scheme)
    scale = _time_scale(time_unit)
    limit = None if outlier_limit is None else check_float(outlier_limit, "outlier_limit", _READ, low=0,
                                                           low_open=True)
    frame = _read_clock_text(load_frame(source), columns.time)
    if scale != 1.0 and columns.time in frame.columns and _is_clock(frame[columns.time]):
        raise fail("time_unit", _READ, "left out, or 's', for a column of date-times or time deltas (they are read in "
                   "seconds)", time_unit)
    data = _numeric_columns(frame, columns)
    keep = _finite_rows(data, columns, options.drop_nan)
    rows = np.flatnonzero(keep)
    if rows.size < 2:
        raise fail("source", _READ, "a log with at least 2 usable rows", f"{rows.size} usable row(s)")
    data = {name: values[keep] for name, values in data.items()}
    _check_magnitudes(data, columns, rows)
    if scale != 1.0:
        data = _to_seconds(data, columns, scale)
    stamps = data[columns.time]
    _check_increasing(stamps, rows, columns.time)
    segment = _segments(stamps, rows, options.gap_factor)
    _check_one_time_unit(stamps, rows, segment, columns.time)
    _check_outliers(data, columns, rows, segment, limit)
    log = _build(data, columns, options, stamps, segment, rows)
    return log if time_unit is None else replace(log, time_unit="s")


def _time_scale(time_unit: str | None) -> float:
    """Seconds per time unit (1 when the unit is not given)."""
    if time_unit is None:
        return 1.0
    return TIME_UNITS[check_choice(time_unit, "time_unit", _READ, tuple(TIME_UNITS))]


def _to_seconds(data: dict[str, np.ndarray], columns: ColumnMapping, scale: float) -> dict[str, np.ndarray]:
    """Time in seconds, rates per second (``scale`` seconds per unit)."""
    data = dict(data)
    data[columns.time] = data[columns.time] * scale
    for name in (columns.shape_velocity or ()) + (columns.body_velocity or ()):
        data[name] = data[name] / scale
    return data


def robust_outliers(values: np.ndarray, limit: float, floor: float = 0.0) -> np.ndarray:
    """Mask of the values further than ``limit`` robust standard deviations from the median.

    The robust standard deviation is 1.4826 × the median absolute deviation (the standard
    deviation for Gaussian data), at least ``floor``; when that is zero (a column that is constant
    but for a few values) nothing can be judged and nothing is an outlier.

    Parameters
    ----------
    values : ndarray of shape (n,)
    limit : float > 0
    floor : float >= 0

    Returns
    -------
    ndarray of shape (n,), bool
    """
    median = np.median(values)
    deviation = np.abs(values - median)
    spread = max(1.4826 * float(np.median(deviation)), floor)
    if spread == 0:
        return np.zeros(values.shape, dtype=bool)
    return deviation > limit * spread


def _check_magnitudes(data: dict[str, np.ndarray], columns: ColumnMapping, rows: np.ndarray) -> None:
    """Every used value but time within ±MAX_MAGNITUDE."""
    for name, values in data.items():
        if name == columns.time:  # only its steps matter (epoch stamps in ns are ~1e18)
            continue
        big = np.flatnonzero(np.abs(values) > MAX_MAGNITUDE)
        if big.size:
            raise fail(name, _READ, f"plausible values, within ±{MAX_MAGNITUDE:g}",
                       f"{values[big[0]]:g} at row {rows[big[0]]}")


def _check_outliers(data: dict[str, np.ndarray], columns: ColumnMapping, rows: np.ndarray, segment: np.ndarray,
                    limit: float | None) -> None:
    """With ``limit``, no robust outliers among the values, nor among the pose steps within a segment (a robot
    put back elsewhere between two recordings is not a jump)."""
    if limit is None:
        return
    checked = {name: (data[name], np.arange(len(rows))) for name in columns.shape + (columns.shape_velocity or ())
               + (columns.body_velocity or ())}
    if columns.pose is not None:
        within = np.flatnonzero(np.diff(segment) == 0)  # step i: from sample i to i + 1
        for name in columns.pose[:2]:
            checked[f"step of {name}"] = (np.diff(data[name])[within], within + 1)
    for name, (values, where) in checked.items():
        if values.size < 8:
            continue
        bad = np.flatnonzero(robust_outliers(values, limit))
        if bad.size:
            i = bad[0]
            row = rows[where[i]]
            raise fail(name.removeprefix("step of "), _READ,
                       f"plausible: within outlier_limit = {limit:g} robust standard deviations of the column's "
                       f"median{' step' if name.startswith('step of ') else ''} (raise or disable outlier_limit if "
                       "the data are right)",
                       f"{'a step of ' if name.startswith('step of ') else ''}{values[i]:g} at row {row} "
                       f"(the first of {bad.size} such value(s); median {np.median(values):.4g})")


def resolve_columns(mapping, overrides: dict) -> ColumnMapping:
    if mapping is None:
        base: dict = {}
    elif isinstance(mapping, ColumnMapping):
        base = {f.name: getattr(mapping, f.name) for f in fields(mapping)}
    elif isinstance(mapping, str | Path):
        loaded = load_column_mapping(mapping)
        base = {f.name: getattr(loaded, f.name) for f in fields(loaded)}
    else:
        raise fail("mapping", _READ, "a ColumnMapping or the path of a mapping file", type(mapping).__name__)
    base.update({k: v for k, v in overrides.items() if v is not None})
    if not base.get("shape"):
        raise fail("shape", _READ, "the list of shape columns (argument or mapping)", base.get("shape"))
    if base.get("body_velocity") is None and base.get("pose") is None:
        raise fail("pose", _READ, "given (or 'body_velocity' given) as an argument or in the mapping", None)
    return ColumnMapping(**base)


def _check_options(drop_nan, gap_factor, max_jitter, window, polyorder, smooth_poses, scheme) -> _Options:
    for name, value in (("drop_nan", drop_nan), ("smooth_poses", smooth_poses)):
        if not isinstance(value, bool | np.bool_):
            raise fail(name, _READ, "a bool", value)
    window = check_int(window, "window", _READ, minimum=3)
    if window % 2 == 0:
        raise fail("window", _READ, "an odd int >= 3", window)
    polyorder = check_int(polyorder, "polyorder", _READ, minimum=1)
    if polyorder >= window:
        raise fail("polyorder", _READ, f"an int < window = {window}", polyorder)
    return _Options(drop_nan=bool(drop_nan),
                    gap_factor=check_float(gap_factor, "gap_factor", _READ, low=1, low_open=True),
                    max_jitter=check_float(max_jitter, "max_jitter", _READ, low=0),
                    window=window, polyorder=polyorder, smooth_poses=bool(smooth_poses),
                    scheme=check_choice(scheme, "scheme", _READ, _SCHEMES))


#: Memory a log takes per value (row × column) while it is read and fitted: the table, its float columns, the
#: smoothed and differentiated arrays and the phaser's (measured: 0.69 GB peak for ``geogait fit`` of 1 000 000 rows of
#: 15 columns).
LOG_BYTES_PER_VALUE = 48


def _check_log_size(n_rows: int, n_columns: int, where: str) -> None:
    """Refuse a log whose reading and fitting would take more than :data:`~geogait._validation.MAX_BYTES`."""
    largest = int(MAX_BYTES // (LOG_BYTES_PER_VALUE * max(n_columns, 1)))
    check_bytes(float(n_rows) * n_columns * LOG_BYTES_PER_VALUE, f"a log of at least {n_rows} rows of {n_columns} "
                f"columns ({where})", _READ, f"at most {largest} rows of {n_columns} columns: split the log, or "
                "keep only the columns it maps")


def load_frame(source) -> pd.DataFrame:
    if isinstance(source, pd.DataFrame):
        _check_log_size(*source.shape, "a DataFrame")
        return source
    if not isinstance(source, str | Path):
        raise fail("source", _READ, "a CSV/Parquet path or a pandas DataFrame", type(source).__name__)
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise fail("source", _READ, "a file ending in .csv, .parquet or .pq", str(path))
    if not path.is_file():
        raise fail("source", _READ, "an existing file", f"{path} ({describe_path_kind(path) or 'does not exist'})")
    kind = "CSV" if suffix == ".csv" else "Parquet"
    try:
        return _read_csv(path) if suffix == ".csv" else _read_parquet(path)
    except GeogaitError:  # (a log too large: not a parser's complaint)
        raise
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, pa.ArrowException,
            ValueError) as error:
        reason = " ".join(str(error).split())[:200]
        raise GeogaitError(f"The 'source' parameter of {_READ} must be a readable {kind} file. Got {str(path)!r} "
                           f"({reason}) instead.") from None


def _read_csv(path: Path) -> pd.DataFrame:
    """The CSV file ``path`` as a table whose columns carry the header's names as written: pandas renames a
    repeated name (``shape_0``, ``shape_0.1``), which would hide it from the check of the used columns."""
    # (in blocks of rows: a signal is handled between them, and a log too large is refused before it is all read)
    frames, n_rows = [], 0
    for frame in pd.read_csv(path, chunksize=_blocks.BLOCK_ROWS):
        n_rows += len(frame)
        _check_log_size(n_rows, frame.shape[1], str(path))
        frames.append(frame)
    frame = pd.concat(frames, ignore_index=True)
    with open(path, encoding="utf-8-sig", newline="") as stream:
        header = next(csv.reader(stream), [])
    if len(set(header)) < len(header) and len(header) == frame.shape[1]:
        frame.columns = header
    return frame


def _read_parquet(path: Path) -> pd.DataFrame:
    """The Parquet file ``path`` as :func:`pandas.read_parquet` reads it, in blocks of rows (a signal is handled
    between them)."""
    import pyarrow.parquet as pq

    with pq.ParquetFile(path) as file:
        _check_log_size(file.metadata.num_rows, file.metadata.num_columns, str(path))
        frames = [pa.Table.from_batches([batch]).to_pandas() for batch in file.iter_batches(_blocks.BLOCK_ROWS)]
        if not frames:
            return file.read().to_pandas()
    # (each block's default index starts at 0: numbered again; an index the file stores is kept)
    return frames[0] if len(frames) == 1 else pd.concat(frames, ignore_index=isinstance(frames[0].index,
                                                                                        pd.RangeIndex))


def _numeric_columns(frame: pd.DataFrame, columns: ColumnMapping) -> dict[str, np.ndarray]:
    """Every used column as a float array; missing or non-numeric columns are errors."""
    wanted = columns.columns()
    missing = [c for c in wanted if c not in frame.columns]
    if missing:
        raise GeogaitError(f"The 'source' parameter of {_READ} must be a table with the columns {wanted}. "
                           f"Got a table without {missing} instead; its columns are "
                           f"{[str(c) for c in frame.columns]}.")
    repeated = [c for c in wanted if (frame.columns == c).sum() > 1]
    if repeated:
        raise fail("source", _READ, "a table whose used columns appear once each",
                   f"the column(s) {[str(c) for c in repeated]} more than once")
    return {name: _as_float(frame[name], name, is_time=name == columns.time) for name in wanted}


def _as_float(series: pd.Series, name: str, is_time: bool) -> np.ndarray:
    types = pd.api.types
    if is_time and _is_clock(series):
        stamped = series.dropna()  # (a missing first stamp must not void the others)
        delta = series - (stamped.iloc[0] if len(stamped) else series.iloc[0])
        return delta.dt.total_seconds().to_numpy(float)
    if pd.api.types.is_bool_dtype(series):
        raise fail(name, _READ, "a numeric column", "a column of booleans")
    if types.is_complex_dtype(series):
        raise fail(name, _READ, "a numeric column of real numbers", "a column of complex numbers")
    if series.dtype == object:
        odd = [i for i, value in enumerate(series) if isinstance(value, bool | complex | np.bool_ | np.complexfloating)]
        if odd:
            raise fail(name, _READ, "a numeric column of real numbers",
                       f"boolean or complex value(s) {[series.iloc[i] for i in odd[:3]]} in row(s) {odd[:10]}")
    converted = pd.to_numeric(series, errors="coerce")
    bad = np.flatnonzero(converted.isna().to_numpy() & series.notna().to_numpy())
    if bad.size:
        examples = [series.iloc[i] for i in bad[:3]]
        raise fail(name, _READ, "a numeric column",
                   f"non-numeric value(s) {examples} in row(s) {bad[:10].tolist()}")
    return converted.to_numpy(float)


def _read_clock_text(frame: pd.DataFrame, name: str) -> pd.DataFrame:
    """``frame`` with its time column ``name`` read as date-times or time deltas when it holds their text (a CSV
    keeps ISO 8601 stamps such as ``2026-01-01T00:00:00.010`` as text), else as it is."""
    if (frame.columns == name).sum() != 1 or not pd.api.types.is_string_dtype(frame[name]):  # (text or objects)
        return frame
    text = frame[name].dropna()
    if not len(text) or not all(isinstance(value, str) for value in text) or \
            pd.to_numeric(text, errors="coerce").notna().any():  # (numbers among them: not a clock column)
        return frame
    for parse in (lambda text: pd.to_datetime(text, format="ISO8601", utc=True), pd.to_timedelta):
        try:
            return frame.assign(**{name: parse(frame[name])})
        except (ValueError, TypeError, OverflowError):
            continue
    return frame


def _is_clock(series: pd.Series) -> bool:
    """A column of date-times or time deltas: its stamps carry their own unit."""
    return pd.api.types.is_datetime64_any_dtype(series) or pd.api.types.is_timedelta64_dtype(series)


def _finite_rows(data: dict[str, np.ndarray], columns: ColumnMapping, drop_nan: bool) -> np.ndarray:
    """Rows without NaN/inf in any used column; NaN rows are an error unless ``drop_nan``."""
    bad = {name: ~np.isfinite(values) for name, values in data.items()}
    keep = ~np.any(np.stack(list(bad.values())), axis=0)
    if not keep.all() and not drop_nan:
        rows = np.flatnonzero(~keep)
        names = [name for name, mask in bad.items() if mask.any()]
        raise fail("source", _READ, "a log without NaN or infinite values in the used columns (or pass "
                   "drop_nan=True to drop those rows and split segments there)",
                   f"{rows.size} such row(s) {rows[:10].tolist()} in column(s) {names}")
    return keep


def _check_increasing(stamps: np.ndarray, rows: np.ndarray, name: str) -> None:
    step = np.diff(stamps)
    for kind, bad in (("duplicated", step == 0), ("decreasing (non-monotonic)", step < 0)):
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise fail(name, _READ, "strictly increasing time stamps",
                       f"{kind} time stamp {stamps[i + 1]:g} at row {rows[i + 1]} "
                       f"(row {rows[i]} has {stamps[i]:g})")


#: Factors between seconds and the other time units: segments whose steps differ by one of them changed unit.
_UNIT_FACTORS = {1e3: "milliseconds", 1e6: "microseconds", 1e9: "nanoseconds"}


def _check_one_time_unit(stamps: np.ndarray, rows: np.ndarray, segment: np.ndarray, name: str) -> None:
    """Refuse a log whose segments step 1000×, 10⁶× or 10⁹× apart (to 2 %): stamps in seconds, then milliseconds?
    (The jump between the units splits the log into segments; each alone looks regular.)"""
    steps = [(int(rows[mine][0]), float(np.median(np.diff(stamps[mine]))))
             for mine in (segment == s for s in np.unique(segment)) if mine.sum() >= 3]
    for row, step in steps[1:]:
        ratio = step / steps[0][1]
        factor = next((f for f in _UNIT_FACTORS for r in (ratio, 1 / ratio) if abs(r / f - 1) <= 0.02), None)
        if factor is not None:
            change = f"seconds, then {_UNIT_FACTORS[factor]}" if ratio > 1 else f"{_UNIT_FACTORS[factor]}, then seconds"
            raise GeogaitError(f"The '{name}' parameter of {_READ} must be time stamps in one unit throughout. Got "
                               f"steps of {steps[0][1]:.4g} until row {row} and {step:.4g} from it ({ratio:.4g}×: "
                               f"{change}?) instead.")


def _segments(stamps: np.ndarray, rows: np.ndarray, gap_factor: float) -> np.ndarray:
    """Segment number ``(n,)``: a new segment after a gap or after dropped rows."""
    step = np.diff(stamps)
    contiguous = np.diff(rows) == 1
    typical = np.median(step[contiguous]) if contiguous.any() else np.median(step)
    breaks = (step > gap_factor * typical) | ~contiguous
    return np.concatenate([[0], np.cumsum(breaks)]).astype(int)


def _build(data, columns: ColumnMapping, options: _Options, stamps, segment, rows) -> Log:
    scale = np.pi / 180 if columns.degrees else 1.0
    shape = np.stack([data[c] for c in columns.shape], axis=1) * scale
    _check_not_constant(shape, columns.shape)
    from_poses = columns.body_velocity is None
    estimated_rate = columns.shape_velocity is None
    needs_filter = estimated_rate or (from_poses and options.smooth_poses)
    bounds = _bounds(segment)
    for a, b in bounds:
        if needs_filter:
            _check_uniform(stamps[a:b], rows[a:b], options, columns.time)
        elif from_poses and b - a < 2:
            raise fail("source", _READ, "segments of at least 2 samples to difference poses",
                       f"a segment of 1 sample at row {rows[a]}")
    pose = None
    if columns.pose is not None:
        pose = np.stack([data[c] for c in columns.pose], axis=1)
        pose[:, 2] *= scale
        pose = np.concatenate([_unwrap_heading(pose[a:b], rows[a:b], columns.pose[2]) for a, b in bounds])
    if columns.body_velocity is not None:
        body = np.stack([data[c] for c in columns.body_velocity], axis=1)
        body[:, 2] *= scale
        if estimated_rate:  # the low-pass that ṙ's estimate carries, applied to ξ too (module docstring)
            body = _filtered(stamps, body, bounds, options, 0)
    else:
        body = np.concatenate([_pose_velocity(stamps[a:b], pose[a:b], options) for a, b in bounds])
    if columns.shape_velocity is not None:
        rate = np.stack([data[c] for c in columns.shape_velocity], axis=1) * scale
        if from_poses and options.smooth_poses:  # the low-pass ξ carries from the smoothed poses, applied to ṙ
            rate = _filtered(stamps, rate, bounds, options, 0)
    else:
        rate = _filtered(stamps, shape, bounds, options, 1)
    phase = None if columns.phase is None else np.mod(data[columns.phase], 2 * np.pi)
    return Log(time=stamps, shape=shape, shape_velocity=rate, body_velocity=body, segment=segment,
               row=rows, pose=pose, phase=phase)


def _bounds(segment: np.ndarray) -> list[tuple[int, int]]:
    edges = np.concatenate([[0], np.flatnonzero(np.diff(segment)) + 1, [segment.size]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _check_not_constant(shape: np.ndarray, names: tuple[str, ...]) -> None:
    flat = [name for name, column in zip(names, shape.T, strict=True) if np.ptp(column) == 0]
    if flat:
        raise fail("shape", _READ, "shape columns that vary (a gait moves every joint)",
                   f"constant column(s) {flat}")


def _check_uniform(stamps: np.ndarray, rows: np.ndarray, options: _Options, name: str) -> None:
    """Savitzky–Golay needs ``window`` uniformly spaced samples per segment."""
    if stamps.size < options.window:
        raise fail("window", _READ, f"at most the length of every segment (segment of rows {rows[0]}-"
                   f"{rows[-1]} has {stamps.size} samples; lower window or drop those rows)", options.window)
    step = np.diff(stamps)
    deviation = np.abs(step / np.median(step) - 1)
    if deviation.max() > options.max_jitter:
        i = int(np.argmax(deviation))
        raise fail(name, _READ, f"uniformly sampled within a segment (steps within max_jitter = "
                   f"{options.max_jitter:g} of the median {np.median(step):g})",
                   f"a step of {step[i]:g} before row {rows[i + 1]}")


def _unwrap_heading(pose: np.ndarray, rows: np.ndarray, name: str) -> np.ndarray:
    step = se2.wrap_angle(np.diff(pose[:, 2]))
    if step.size and np.abs(step).max() > np.pi / 2:
        i = int(np.argmax(np.abs(step)))
        raise fail(name, _READ, "a heading that turns less than 90 degrees between samples (check "
                   "'degrees')", f"a turn of {step[i]:.3g} rad before row {rows[i + 1]}")
    unwrapped = pose.copy()
    unwrapped[:, 2] = pose[0, 2] + np.concatenate([[0.0], np.cumsum(step)])
    return unwrapped


def _pose_velocity(stamps: np.ndarray, pose: np.ndarray, options: _Options) -> np.ndarray:
    smoothed = _savgol(stamps, pose, options, 0) if options.smooth_poses else pose
    return se2.body_velocity_from_poses(stamps, smoothed, scheme=options.scheme)


def _filtered(stamps: np.ndarray, values: np.ndarray, bounds: list, options: _Options, deriv: int) -> np.ndarray:
    """``values`` through the Savitzky–Golay filter (``deriv``), each segment on its own."""
    return np.concatenate([_savgol(stamps[a:b], values[a:b], options, deriv) for a, b in bounds])


def _savgol(stamps: np.ndarray, values: np.ndarray, options: _Options, deriv: int) -> np.ndarray:
    delta = float(np.median(np.diff(stamps)))
    return savgol_filter(values, options.window, options.polyorder, deriv=deriv, delta=delta, axis=0)


_PLACEHOLDER = ("__geogait_unmeasured_vx", "__geogait_unmeasured_vy", "__geogait_unmeasured_w")


# -- columns ------------------------------------------------------------------------------------
def resolve_mapping(mapping=None, **columns) -> ColumnMapping:
    """The :class:`ColumnMapping` that :func:`read_log` uses for ``mapping`` and keyword overrides.

    Parameters
    ----------
    mapping : ColumnMapping, str or Path, optional
    **columns
        ``time``, ``shape``, ``body_velocity``, ``pose``, ``shape_velocity``, ``phase``, ``degrees``;
        None leaves the mapping's value.

    Returns
    -------
    ColumnMapping
    """
    return resolve_columns(mapping, columns)


def read_log_for_prediction(source, mapping=None, *, measured: bool = True, **arguments) -> tuple[Log, bool]:
    """Read a log that may lack body velocities and poses (to predict them).

    Parameters
    ----------
    source, mapping
        As for :func:`read_log`.
    measured : bool
        Read the measured body velocity (from body-velocity or pose columns) when the mapping
        names any; False ignores them.
    **arguments
        The column fields of :class:`ColumnMapping` (``time``, ``shape``, ... ; None leaves the
        mapping's) and any other keyword of :func:`read_log` (``window``, ``drop_nan``, ...).

    Returns
    -------
    log : Log
        Its ``body_velocity`` is zero when nothing was measured.
    has_measured : bool
    """
    names = {f.name for f in fields(ColumnMapping)}
    columns = {k: v for k, v in arguments.items() if k in names and v is not None}
    options = {k: v for k, v in arguments.items() if k not in names}
    base = {} if mapping is None else _mapping_fields(mapping)
    base.update(columns)
    if not measured:
        base["pose"] = base["body_velocity"] = None
    if base.get("pose") is not None or base.get("body_velocity") is not None:
        return read_log(source, ColumnMapping(**base), **options), True
    frame = load_frame(source).copy()
    for name in _PLACEHOLDER:
        frame[name] = 0.0
    base["body_velocity"] = _PLACEHOLDER
    return read_log(frame, ColumnMapping(**base), **options), False


def _mapping_fields(mapping) -> dict:
    if isinstance(mapping, str | Path):
        mapping = load_column_mapping(mapping)
    if not isinstance(mapping, ColumnMapping):
        raise fail("mapping", "read_log_for_prediction", "a ColumnMapping or the path of a mapping file",
                   type(mapping).__name__)
    return {f.name: getattr(mapping, f.name) for f in fields(mapping)}


def mapping_to_json(mapping: ColumnMapping) -> str:
    """JSON text of a mapping, readable by :func:`~geogait.io.load_column_mapping`."""
    return json.dumps(asdict(mapping), indent=2) + "\n"
