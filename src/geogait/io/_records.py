"""The records of a live stream (:mod:`geogait.io._streaming`): input samples, output lines and the
summary, the JSON-lines and CSV readers that validate every record, and the matching writers."""

from __future__ import annotations

import csv
import json
import math
import textwrap
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from .._files import RepeatedKey, dumps_json, unique_keys
from .._validation import fail
from ..simulate import BODY_VELOCITY_COLUMNS

__all__ = ["PREDICTION_COLUMNS", "CsvReader", "JsonLinesReader", "StreamOutput", "StreamSample", "StreamSummary",
           "STREAM_FORMATS"]

PREDICTION_COLUMNS = ("predicted_body_velocity_x", "predicted_body_velocity_y", "predicted_body_velocity_theta")
_KEYS = ("time", "phase", "shape", "shape_velocity", "body_velocity")
_KEY_SET = frozenset(_KEYS)
_FLOAT = {float}


# -- records ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StreamSample:
    """One input record.

    Attributes
    ----------
    line : int
        Line of the input it came from (1-based), for error messages.
    shape : ndarray of shape (d,)
    body_velocity : ndarray of shape (3,)
    time, phase : float or None
    shape_velocity : ndarray of shape (d,) or None
    """

    line: int
    shape: np.ndarray
    body_velocity: np.ndarray
    time: float | None = None
    phase: float | None = None
    shape_velocity: np.ndarray | None = None


@dataclass(frozen=True)
class StreamOutput:
    """The result of one sample: its a-priori prediction and the online Γ after learning it.

    Attributes
    ----------
    index : int
        Sample index, from 0.
    time, phase : float or None
        The sample's time stamp and the phase used (None while warming up).
    prediction : ndarray of shape (3,) or None
        A-priori ξ̂ (before the sample was learned); None when the sample was not learned.
    gamma : float or None
        Online Γ after the sample (None before anything was learned).
    learned : bool
    rejected : str or None
        Why the sample was quarantined (implausible values, see :class:`StreamLearner`); None otherwise.
    """

    index: int
    time: float | None
    phase: float | None
    prediction: np.ndarray | None
    gamma: float | None
    learned: bool
    rejected: str | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict (floats are written exactly by :func:`json.dumps`; ``rejected`` only when set)."""
        record = {"index": self.index, "time": self.time, "phase": self.phase,
                  "prediction": None if self.prediction is None else self.prediction.tolist(),
                  "gamma": self.gamma, "learned": self.learned}
        if self.rejected is not None:
            record["rejected"] = self.rejected
        return record


@dataclass(frozen=True)
class StreamSummary:
    """How a stream ended.

    Attributes
    ----------
    n_samples : int
        Records read and processed.
    n_learned : int
        Samples learned (not warming up).
    gamma : float or None
        Online Γ at the end.
    reason : {"eof", "error", "SIGINT", "SIGTERM", "output closed"}
    error : str or None
        The error message when ``reason == "error"``.
    saved : Path or None
        Where the model was last written during the stream or at its end (None if nothing was
        learned, or if the model could not be saved: see ``error``).
    n_rejected : int
        Samples quarantined as implausible (neither predicted nor learned).
    first_rejection : str or None
        Line and reason of the first of them.
    """

    n_samples: int
    n_learned: int
    gamma: float | None
    reason: str
    error: str | None
    saved: Path | None
    n_rejected: int = 0
    first_rejection: str | None = None


# -- readers and writers ------------------------------------------------------------------------
def _vector(value, name: str, line: int, size: int, required: bool) -> np.ndarray | None:
    # the common case first: a list of ``size`` finite floats (the sum of finite floats is finite unless it
    # overflows, which leaves the exact checks below to decide)
    if type(value) is list and len(value) == size and {*map(type, value)} == _FLOAT and math.isfinite(sum(value)):
        return np.array(value)
    if value is None:
        if required:
            raise fail(name, f"input line {line}", f"given: a list of {size} numbers", None)
        return None
    if not isinstance(value, list) or len(value) != size or not all(type(v) in (int, float) for v in value):
        raise fail(name, f"input line {line}", f"a list of {size} numbers", value)
    if not all(_finite(v) for v in value):
        raise fail(name, f"input line {line}", f"a list of {size} finite numbers", value)
    return np.array(value, dtype=float)


def _finite(value: int | float) -> bool:
    """A finite JSON number (an integer beyond a float's range is not: math.isfinite would overflow on it)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _scalar(value, name: str, line: int) -> float | None:
    if value is None:
        return None
    if type(value) not in (int, float) or not _finite(value):
        raise fail(name, f"input line {line}", "a finite number", value)
    return float(value)


class JsonLinesReader:
    """Samples from JSON lines (one object per line; see the module notes).

    Parameters
    ----------
    source : iterable of str
        Lines, e.g. ``sys.stdin``.
    n_joints : int
    """

    def __init__(self, source, n_joints: int):
        self.source = source
        self.n_joints = n_joints

    def __iter__(self) -> Iterator[StreamSample]:
        for line, text in enumerate(self.source, start=1):
            if text.strip():
                yield self.parse(text, line)

    def parse(self, text: str, line: int) -> StreamSample:
        """One record; errors name ``line`` and the field.

        Parameters
        ----------
        text : str
            One JSON object with keys among ``time``, ``phase``, ``shape``, ``shape_velocity`` and
            ``body_velocity`` (``shape`` and ``body_velocity`` required).
        line : int
            Its line number in the input (1-based), for error messages.
        """
        try:
            record = json.loads(text, object_pairs_hook=unique_keys)
        except RepeatedKey as repeated:
            raise fail("record", f"input line {line}", "a JSON object giving each key once",
                       f"key {repeated.key!r} more than once") from None
        except json.JSONDecodeError as error:
            raise fail("record", f"input line {line}", "a JSON object",
                       f"invalid JSON ({error.msg} at column {error.colno})") from None
        except RecursionError:
            raise fail("record", f"input line {line}", "a JSON object", "JSON nested too deeply to read") from None
        if type(record) is dict and record.keys() <= _KEY_SET:
            sample = self._plain(record, line)
            if sample is not None:
                return sample
        if not isinstance(record, dict):
            raise fail("record", f"input line {line}", "a JSON object", record)
        unknown = sorted(set(record) - _KEY_SET)
        if unknown:
            raise fail("record", f"input line {line}", f"an object with keys among {list(_KEYS)}",
                       f"unknown key(s) {unknown}")
        d = self.n_joints
        return StreamSample(line=line, shape=_vector(record.get("shape"), "shape", line, d, True),
                            body_velocity=_vector(record.get("body_velocity"), "body_velocity", line, 3, True),
                            time=_scalar(record.get("time"), "time", line),
                            phase=_scalar(record.get("phase"), "phase", line),
                            shape_velocity=_vector(record.get("shape_velocity"), "shape_velocity", line, d, False))


    def _plain(self, record: dict, line: int) -> StreamSample | None:
        """The common record at a third of the cost: vectors of the right lengths and every number a finite
        float (one array holds them all); None leaves any other record to the checks of :meth:`parse`."""
        d = self.n_joints
        shape, velocity, rate = record.get("shape"), record.get("body_velocity"), record.get("shape_velocity")
        if not (type(shape) is list and type(velocity) is list and len(shape) == d and len(velocity) == 3):
            return None
        if rate is None:
            values = shape + velocity
        elif type(rate) is list and len(rate) == d:
            values = shape + velocity + rate
        else:
            return None
        time, phase = record.get("time"), record.get("phase")
        scalars = [v for v in (time, phase) if v is not None]
        values += scalars
        # finite floats only (a sum of finite floats is finite unless it overflows: then the exact checks run)
        if {*map(type, values)} != _FLOAT or not math.isfinite(sum(values)):
            return None
        array = np.array(values)
        return StreamSample(line=line, shape=array[:d], body_velocity=array[d:d + 3], time=time, phase=phase,
                            shape_velocity=None if rate is None else array[d + 3:2 * d + 3])


class CsvReader:
    """Samples from CSV rows under a header line (see the module notes).

    Parameters
    ----------
    source : iterable of str
        Lines of CSV text, e.g. ``sys.stdin`` or an open file; the first is the header.
    n_joints : int
        Shape dimension d: the columns ``shape_0 .. shape_{d-1}`` (and optionally
        ``shape_velocity_0 ..``) are read.

    Attributes
    ----------
    ignored : list of str
        Header columns that are not read (known after the header).
    """

    def __init__(self, source, n_joints: int):
        self.source = source
        self.n_joints = n_joints
        self.ignored: list[str] = []

    def __iter__(self) -> Iterator[StreamSample]:
        reader = csv.reader(self.source)
        header = next(reader, None)
        if header is None:
            return
        columns = self._columns([name.strip() for name in header])
        for row in reader:
            if row and any(cell.strip() for cell in row):
                yield self._sample(row, reader.line_num, columns, len(header))

    def _columns(self, header: list[str]) -> dict[str, list[int] | None]:
        d = self.n_joints
        groups = {"time": ["time"], "phase": ["phase"], "shape": [f"shape_{j}" for j in range(d)],
                  "shape_velocity": [f"shape_velocity_{j}" for j in range(d)],
                  "body_velocity": list(BODY_VELOCITY_COLUMNS)}
        index = {name: i for i, name in enumerate(header)}
        repeated = [name for names in groups.values() for name in names if header.count(name) > 1]
        if repeated:  # (the index keeps the last: which one the producer meant is unknown)
            raise fail("header", "input line 1", "a CSV header naming each column once",
                       f"the column(s) {repeated} more than once")
        found: dict[str, list[int] | None] = {}
        for key, names in groups.items():
            present = [name for name in names if name in index]
            required = key in ("shape", "body_velocity")
            if (required and len(present) < len(names)) or 0 < len(present) < len(names):
                given = textwrap.shorten(",".join(header), 200, placeholder=" …")
                raise fail("header", "input line 1", f"a CSV header with the columns {names} (stream reads these "
                           "names; rename the log's columns)",
                           f"a header without {[n for n in names if n not in index]}: {given}")
            found[key] = [index[name] for name in names] if present else None
        used = {i for columns in found.values() if columns for i in columns}
        self.ignored = [name for i, name in enumerate(header) if i not in used]
        return found

    def _sample(self, row: list[str], line: int, columns: dict, width: int) -> StreamSample:
        if len(row) != width:
            raise fail("row", f"input line {line}", f"{width} comma-separated values like the header",
                       f"{len(row)} values")
        values = {key: None if idx is None else self._cells(row, idx, key, line) for key, idx in columns.items()}
        for key in ("shape", "body_velocity"):
            if values[key] is None:
                raise fail(key, f"input line {line}", "given (no empty cells)", None)
        return StreamSample(line=line, shape=values["shape"], body_velocity=values["body_velocity"],
                            time=None if values["time"] is None else float(values["time"][0]),
                            phase=None if values["phase"] is None else float(values["phase"][0]),
                            shape_velocity=values["shape_velocity"])

    @staticmethod
    def _cells(row: list[str], idx: list[int], key: str, line: int) -> np.ndarray | None:
        cells = [row[i].strip() for i in idx]
        if not any(cells):
            return None
        try:
            array = np.array([float(cell) for cell in cells])
        except ValueError:
            raise fail(key, f"input line {line}", f"{len(cells)} number(s)", cells) from None
        if not all(cells) or not np.all(np.isfinite(array)):
            raise fail(key, f"input line {line}", f"{len(cells)} finite number(s), none empty", cells)
        return array


class _JsonLinesWriter:
    def __init__(self, sink: TextIO):
        self.sink = sink

    def write(self, output: StreamOutput) -> None:
        self.sink.write(_learned_line(output) or dumps_json(output.to_dict()) + "\n")
        self.sink.flush()


def _learned_line(output: StreamOutput) -> str | None:
    """The JSON line of a learned sample with finite values, written directly: the same text as
    ``json.dumps(output.to_dict())`` (floats by ``float.__repr__``, as :mod:`json` writes them) at a third of
    the cost; None for any other output (it goes through :func:`dumps_json`)."""
    if not output.learned or output.rejected is not None:
        return None
    x, y, theta = output.prediction.tolist()
    try:  # None (no time stamp) or a value that is not a float: the general path
        if not math.isfinite(output.time + output.phase + output.gamma + x + y + theta):
            return None  # (an overflowing sum of finite values only costs the general path)
        time, phase, gamma, x, y, theta = map(float.__repr__, (output.time, output.phase, output.gamma, x, y, theta))
    except TypeError:
        return None
    return (f'{{"index": {output.index:d}, "time": {time}, "phase": {phase}, "prediction": [{x}, {y}, {theta}], '
            f'"gamma": {gamma}, "learned": true}}\n')


class _CsvWriter:
    def __init__(self, sink: TextIO):
        self.sink = sink
        self.sink.write(",".join(["index", "time", "phase", *PREDICTION_COLUMNS, "gamma", "learned"]) + "\n")
        self.sink.flush()

    def write(self, output: StreamOutput) -> None:
        prediction = [None] * 3 if output.prediction is None else output.prediction.tolist()
        cells = [output.index, output.time, output.phase, *prediction, output.gamma, int(output.learned)]
        self.sink.write(",".join("" if c is None else repr(c) for c in cells) + "\n")
        self.sink.flush()


#: Reader and writer of each stream format.
STREAM_FORMATS = {"jsonl": (JsonLinesReader, _JsonLinesWriter), "csv": (CsvReader, _CsvWriter)}


