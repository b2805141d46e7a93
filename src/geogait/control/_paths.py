r"""Reference paths in the plane and the errors of a pose with respect to them.

A path is a dense polyline with cumulative arc length :math:`s`. A position :math:`q` is projected
onto the nearest point of the polyline within a window of arc length (so a path that crosses itself,
like the figure-eight, is followed branch by branch), which gives

* the **cross-track error** :math:`e = (q - c(s^*)) \cdot n(s^*)`, the signed distance to the
  nearest point, positive to the left of the direction of travel (:math:`n` the left normal);
* the path **tangent heading** :math:`\psi(s^*)`, against which a course (direction of travel)
  gives the heading error :math:`\mathrm{wrap}(\chi - \psi)`.

Closed forms for checks: a line through the origin along :math:`x` has :math:`e = y`; a circle of
radius :math:`R` about :math:`c`, run counter-clockwise, has :math:`e = R - \|q - c\|`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._files import describe_path_kind
from .._kernels import nearest_segment_kernel
from .._validation import MAX_MAGNITUDE, GeogaitError, check_array, check_float, check_int, fail
from ..se2 import wrap_angle

__all__ = ["ReferencePath", "PATH_KINDS"]

PATH_KINDS = ("line", "circle", "figure8")
_SPACING = 0.02  # body lengths between polyline vertices of the built-in curves (sagitta < 1e-4 at radius 0.5)
_MAX_VERTICES = 200_000  # of a built-in curve: beyond, the vertices spread out (sagitta < 1.3e-4 at radius 1e6)
_COMPILED_FROM = 16  # positions from which a projection runs compiled (below, NumPy's call overhead is smaller)
_KERNEL_TESTS = 4_000_000  # position-segment tests per compiled call: about 10 ms
#: Largest size (radius, length, |coordinate|) of a path, body lengths.
MAX_PATH_SIZE = 1e6


@dataclass(frozen=True)
class ReferencePath:
    """A planar path to follow: a polyline with arc length, open or closed.

    Build one with :meth:`line`, :meth:`circle`, :meth:`figure8`, :meth:`waypoints` or
    :meth:`from_csv`; all lengths are in body lengths.

    Parameters
    ----------
    points : ndarray of shape (n, 2)
        Vertices in order of travel (a closed path does not repeat its first vertex).
    closed : bool
        The last vertex connects back to the first.
    name : str

    Examples
    --------
    >>> path = ReferencePath.circle(radius=2.0)
    >>> s, error, heading = path.project([[0.0, 1.0]])
    >>> round(float(error[0]), 3)   # 1 body length inside the circle, to the left of travel
    1.0
    """

    points: np.ndarray
    closed: bool = False
    name: str = "path"

    def __post_init__(self):
        # (any finite length: a circle of the largest radius reaches twice it; waypoints are held to MAX_PATH_SIZE)
        points = check_array(self.points, "points", "ReferencePath", trailing=(2,), ndim=2, limit=MAX_MAGNITUDE)
        if not isinstance(self.closed, bool | np.bool_):
            raise fail("closed", "ReferencePath", "True or False", self.closed)
        if points.shape[0] < 2:
            raise fail("points", "ReferencePath", "at least 2 vertices", f"shape {points.shape}")
        vertices = np.vstack([points, points[:1]]) if self.closed else points
        lengths = np.linalg.norm(np.diff(vertices, axis=0), axis=1)
        if np.any(lengths <= 1e-12):
            first = int(np.argmax(lengths <= 1e-12))
            repeat = (f"vertex {(first + 1) % points.shape[0]} repeating vertex {first}" if first + 1 < len(points)
                      or not self.closed else f"the last vertex {first} repeating the first (a closed path does "
                      "not repeat its first vertex)")
            raise fail("points", "ReferencePath", "vertices without repeats (every segment of positive length)",
                       f"{int(np.sum(lengths <= 1e-12))} zero-length segment(s), the first {repeat} (0-based)")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "_vertices", vertices)
        object.__setattr__(self, "_starts", np.concatenate([[0.0], np.cumsum(lengths)[:-1]]))
        object.__setattr__(self, "_lengths", lengths)

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def line(cls, length: float = 100.0) -> ReferencePath:
        """The x axis from the origin, ``length`` body lengths long (travel along +x)."""
        length = check_float(length, "length", "ReferencePath.line", low=0, high=MAX_PATH_SIZE, low_open=True)
        return cls(np.array([[0.0, 0.0], [length, 0.0]]), name="line")

    @classmethod
    def circle(cls, radius: float = 1.0) -> ReferencePath:
        """A counter-clockwise circle of ``radius`` about (0, radius): it starts at the origin along +x."""
        radius = check_float(radius, "radius", "ReferencePath.circle", low=0, high=MAX_PATH_SIZE, low_open=True)
        n = min(_MAX_VERTICES, max(64, int(np.ceil(2 * np.pi * radius / _SPACING))))
        angle = 2 * np.pi * np.arange(n) / n
        return cls(np.column_stack([radius * np.sin(angle), radius * (1 - np.cos(angle))]), closed=True,
                   name="circle")

    @classmethod
    def figure8(cls, size: float = 1.0) -> ReferencePath:
        r"""A figure-eight (lemniscate of Gerono turned on its side) through the origin along +x.

        :math:`c(t) = (a\sin t,\ \tfrac{a}{2}\sin 2t)`, :math:`t \in [0, 2\pi)`, ``a = size``, rotated
        so that it leaves the origin along +x: two lobes of length ``size``, radius of curvature
        ``size`` at their tips, crossing itself at the origin at right angles.
        """
        size = check_float(size, "size", "ReferencePath.figure8", low=0, high=MAX_PATH_SIZE, low_open=True)
        n = min(_MAX_VERTICES, max(128, int(np.ceil(7 * size / _SPACING))))
        t = 2 * np.pi * np.arange(n) / n
        points = np.column_stack([size * np.sin(t), size / 2 * np.sin(2 * t)])
        heading = np.arctan2(points[1, 1], points[1, 0])
        cos, sin = np.cos(-heading), np.sin(-heading)
        return cls(points @ np.array([[cos, sin], [-sin, cos]]), closed=True, name="figure8")

    @classmethod
    def waypoints(cls, points, *, closed: bool = False, name: str = "waypoints") -> ReferencePath:
        """The polyline through ``points`` ``(n, 2)`` (body lengths; straight segments, sharp corners kept),
        back to the first point when ``closed``; ``name`` labels it in logs and plots."""
        points = check_array(points, "points", "ReferencePath.waypoints", trailing=(2,), limit=MAX_PATH_SIZE)
        return cls(points, closed=closed, name=name)

    @classmethod
    def from_csv(cls, path) -> ReferencePath:
        """Waypoints from the CSV file ``path`` with columns ``x`` and ``y`` (body lengths), one row per waypoint.

        A last row equal to the first closes the path: the polyline runs back to the first waypoint
        and on around it, lap after lap (``closed=True``, the repeated row dropped).

        Raises
        ------
        GeogaitError
            When the file is missing, lacks a column, has fewer than two rows (three distinct ones for
            a closed path), non-numeric or non-finite values, or a row that repeats the one before it
            (a zero-length segment); the message names the file and the data row (1-based, the
            header not counted).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> file = pathlib.Path(tempfile.mkdtemp()) / "square.csv"
        >>> _ = file.write_text("x,y\\n0,0\\n1,0\\n1,1\\n0,1\\n0,0\\n")
        >>> square = ReferencePath.from_csv(file)
        >>> square.closed, square.points.shape, square.length
        (True, (4, 2), 4.0)
        """
        path = Path(path)
        if not path.is_file():
            raise GeogaitError(f"The waypoints file {path} {describe_path_kind(path) or 'does not exist'}.")
        try:
            frame = pd.read_csv(path)
        except (ValueError, pd.errors.ParserError) as error:
            raise GeogaitError(f"The waypoints file {path} is not a readable CSV ({error}).") from None
        missing = [column for column in ("x", "y") if column not in frame.columns]
        if missing:
            raise GeogaitError(f"The waypoints file {path} must have columns 'x' and 'y'. "
                               f"Got columns {list(frame.columns)} instead.")
        values = pd.DataFrame({c: pd.to_numeric(frame[c], errors="coerce") for c in ("x", "y")}).to_numpy()
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
        if bad.size:
            raise GeogaitError(f"The waypoints file {path} must have finite numbers in 'x' and 'y'. "
                               f"Got a bad value in data row {int(bad[0]) + 1} instead.")
        if values.shape[0] < 2:
            raise GeogaitError(f"The waypoints file {path} must have at least 2 waypoints. Got {values.shape[0]}.")
        steps = np.linalg.norm(np.diff(values, axis=0), axis=1)
        repeats = np.flatnonzero(steps <= 1e-12)
        if repeats.size:
            row = int(repeats[0]) + 2  # data rows are 1-based: rows row - 1 and row are equal
            raise GeogaitError(f"The waypoints file {path} must not repeat a waypoint in consecutive rows (a "
                               f"zero-length segment). Got data row {row} equal to row {row - 1} "
                               f"({values[row - 1, 0]:g}, {values[row - 1, 1]:g}) instead"
                               + (f"; {repeats.size} such rows in all." if repeats.size > 1 else "."))
        closed = values.shape[0] > 2 and np.linalg.norm(values[-1] - values[0]) <= 1e-12
        if closed:
            values = values[:-1]
            if values.shape[0] < 3:
                raise GeogaitError(f"The waypoints file {path} closes its path (the last row repeats the first) "
                                   f"and must then have at least 3 distinct waypoints. Got {values.shape[0]}.")
        return cls.waypoints(values, closed=bool(closed), name=path.stem)

    @classmethod
    def named(cls, kind: str, scale: float = 1.0) -> ReferencePath:
        """A built-in path by name ``kind``: ``"line"``, ``"circle"`` (radius ``scale``) or ``"figure8"``
        (size ``scale``), body lengths."""
        if kind == "line":
            return cls.line()
        if kind == "circle":
            return cls.circle(scale)
        if kind == "figure8":
            return cls.figure8(scale)
        raise fail("path", "ReferencePath.named", "one of " + ", ".join(PATH_KINDS) + " or a CSV file", kind)

    # -- geometry -----------------------------------------------------------------------------
    @property
    def length(self) -> float:
        """Total arc length (of one lap for a closed path)."""
        return float(self._lengths.sum())

    @property
    def start_heading(self) -> float:
        """Tangent heading at the start of the path (rad)."""
        step = self._vertices[1] - self._vertices[0]
        return float(np.arctan2(step[1], step[0]))

    def point(self, s) -> np.ndarray:
        """Positions ``(..., 2)`` at arc lengths ``s`` ``(...)`` (wrapped for a closed path, clamped
        for an open one)."""
        index, fraction = self._locate(check_array(s, "s", "ReferencePath.point"))
        start = self._vertices[index]
        return start + fraction[..., None] * (self._vertices[index + 1] - start)

    def heading(self, s) -> np.ndarray:
        """Tangent headings (rad) at arc lengths ``s``."""
        index, _ = self._locate(check_array(s, "s", "ReferencePath.heading"))
        step = self._vertices[index + 1] - self._vertices[index]
        return np.arctan2(step[..., 1], step[..., 0])

    def _locate(self, s):
        s = np.mod(s, self.length) if self.closed else np.clip(s, 0, self.length)
        index = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, self._lengths.size - 1)
        return index, np.clip((s - self._starts[index]) / self._lengths[index], 0, 1)

    def project(self, position, near=None, window: float | None = None):
        r"""Nearest path point of each position: arc length, signed cross-track error, tangent heading.

        Parameters
        ----------
        position : array-like of shape (..., 2)
        near : array-like of shape (...) or float, optional
            Arc length near which to search (the previous projection); the whole path when omitted.
        window : float, optional
            Half-width (body lengths of arc) of the search around ``near``; default 1.

        Returns
        -------
        s : ndarray of shape (...)
            Arc length of the nearest point (unwrapped near ``near`` for a closed path, so it keeps
            growing lap after lap).
        cross_track : ndarray of shape (...)
            Signed distance to the nearest point, positive to the left of the direction of travel
            (beyond a corner of a polyline: the distance to the corner, signed by the side of the
            segment's line it lies on).
        heading : ndarray of shape (...)
            Tangent heading ψ at the nearest point.
        """
        position = check_array(position, "position", "ReferencePath.project", trailing=(2,))
        batch = position.shape[:-1]
        if near is None:
            candidates = np.arange(self._lengths.size)
            offsets = np.zeros(candidates.shape)
        else:
            window = 1.0 if window is None else check_float(window, "window", "ReferencePath.project", low=0,
                                                            low_open=True)
            near = np.asarray(near, dtype=float)  # a scalar shares one candidate list among all positions
            # the window's worth of the shortest segments, but never more than the path holds in the window's laps
            # (one segment 1e-10 long asked for 2e10 candidates)
            laps = int(np.ceil(2 * window / self.length)) + 1 if self.closed else 1
            count = int(min(np.ceil(2 * window / self._lengths.min()), laps * self._lengths.size)) + 2
            first = np.searchsorted(self._starts, self._wrap(near - window), side="right") - 1
            raw = first[..., None] + np.arange(count)
            if self.closed:
                candidates = raw % self._lengths.size
                laps = np.floor((near - window) / self.length)[..., None] + (raw >= self._lengths.size)
                offsets = laps * self.length
            else:
                candidates = np.clip(raw, 0, self._lengths.size - 1)
                offsets = np.zeros(candidates.shape)
        start = self._vertices[candidates]  # (..., k, 2)
        step = self._vertices[candidates + 1] - start
        length = self._lengths[candidates]
        kernel = nearest_segment_kernel() if candidates.ndim == 1 and position.size > 2 * _COMPILED_FROM else None
        if kernel is not None:  # candidates shared by many positions (a planner's horizon): compiled, same bits
            flat = np.ascontiguousarray(position.reshape(-1, 2))
            x, y = flat[:, 0].copy(), flat[:, 1].copy()
            segments = start[:, 0].copy(), start[:, 1].copy(), step[:, 0].copy(), step[:, 1].copy(), length
            best, along = np.empty(flat.shape[0], dtype=np.int64), np.empty(flat.shape[0])
            chunk = max(1, _KERNEL_TESTS // length.size)  # (between calls SIGTERM and Ctrl-C are handled)
            for first in range(0, flat.shape[0], chunk):
                part = slice(first, first + chunk)
                kernel(x[part], y[part], *segments, best[part], along[part])
            best, along = best.reshape(batch + (1,)), along.reshape(batch)
        else:
            ex = position[..., 0, None] - start[..., 0]
            ey = position[..., 1, None] - start[..., 1]
            fraction = np.clip((ex * step[..., 0] + ey * step[..., 1]) / length**2, 0, 1)
            ex -= fraction * step[..., 0]
            ey -= fraction * step[..., 1]
            best = np.argmin(ex * ex + ey * ey, axis=-1)[..., None]

        def pick(values):
            return np.take_along_axis(np.broadcast_to(values, batch + values.shape[-1:]), best, axis=-1)[..., 0]

        segment = pick(candidates)
        along = along if kernel is not None else pick(fraction)
        s = pick(offsets) + self._starts[segment] + along * self._lengths[segment]
        if near is None and self.closed:
            s = np.mod(s, self.length)
        tangent = (self._vertices[segment + 1] - self._vertices[segment]) / self._lengths[segment][..., None]
        offset = position - (self._vertices[segment] + along[..., None] * tangent * self._lengths[segment][..., None])
        side = tangent[..., 0] * offset[..., 1] - tangent[..., 1] * offset[..., 0]
        # the distance itself (beyond a corner of a polyline the offset is not normal to the segment)
        cross_track = np.where(side < 0, -1.0, 1.0) * np.hypot(offset[..., 0], offset[..., 1])
        return s, cross_track, np.arctan2(tangent[..., 1], tangent[..., 0])

    def _wrap(self, s):
        return np.mod(s, self.length) if self.closed else np.clip(s, 0, self.length)

    def course_error(self, course, heading) -> np.ndarray:
        """Heading error wrap(χ − ψ) of a course χ against the tangent heading ψ (rad)."""
        return wrap_angle(np.asarray(course, dtype=float) - np.asarray(heading, dtype=float))

    def at_end(self, s) -> np.ndarray:
        """Whether arc length ``s`` has reached the end of an open path (never for a closed one)."""
        return np.zeros(np.shape(s), bool) if self.closed else np.asarray(s) >= self.length - 1e-9

    def resampled(self, n_points: int = 400) -> np.ndarray:
        """``(n_points, 2)`` positions evenly spaced in arc length (for plots)."""
        n_points = check_int(n_points, "n_points", "ReferencePath.resampled", minimum=2)
        return self.point(np.linspace(0, self.length, n_points))
