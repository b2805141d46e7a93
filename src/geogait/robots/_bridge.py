r"""A robot in any language: a driver process speaking JSON lines over its stdin / stdout.

Protocol ``geogait-robot``, version 1. One JSON object per line, UTF-8, each with a ``type``.

Driver → geogait, first line::

    {"type": "hello", "protocol": "geogait-robot", "version": 1, "n_joints": 2, "cycle_period": 1.0,
     "gait": {"order": 1, "params": [a_00, a_01, b_01, a_10, a_11, b_11]}}

An optional ``"front_back_symmetric": true`` declares a chain with front–back symmetry (the
optimiser then searches the rotation-free symmetric gait family). ``gait`` is the robot's current
nominal gait, a Fourier series per joint with the flat parameter
vector of :class:`~geogait.gaits.FourierGait` (per joint ``[a_0, a_1 … a_K, b_1 … b_K]``).

geogait → driver::

    {"type": "set_gait", "order": 1, "params": [...]}   # run this gait from the next cycle on
    {"type": "run_cycle"}                                 # run one whole cycle, send its samples
    {"type": "stop"}                                      # finish; the driver should exit

Driver → geogait, after ``run_cycle``: one line per sample, then the end of the cycle::

    {"type": "sample", "time": 0.01, "phase": 0.0628, "shape": [...], "shape_velocity": [...],
     "pose": [x, y, heading], "body_velocity": [vx, vy, omega], "commanded_shape": [...]}
    {"type": "cycle_end"}

``time`` in seconds, ``phase`` in [0, 2π) (the commanded phase), ``shape`` / ``shape_velocity`` the
measured joint angles (rad) and rates (rad/s), ``pose`` the world pose of the body frame and
``body_velocity`` ξ in that frame (per second). ``body_velocity`` may be left out: it is then
computed from consecutive poses (SE(2) logarithms). ``commanded_shape`` is optional (see
:mod:`geogait.robots`). At any time the driver may send ``{"type": "error", "message": "..."}``.
Lines of other types are ignored (room for extensions); anything the driver writes to stderr is
kept and shown when it fails.
"""

from __future__ import annotations

import collections
import contextlib
import json
import queue
import shlex
import subprocess
import threading

import numpy as np

from .._validation import GeogaitError, check_float, fail
from ..gaits import FourierGait
from ..se2 import body_velocity_from_poses
from ..simulate import Trajectory

__all__ = ["PROTOCOL", "PROTOCOL_VERSION", "ProcessRobot"]

PROTOCOL = "geogait-robot"
PROTOCOL_VERSION = 1
_MAX_SAMPLES = 1_000_000  # per cycle: a driver that never ends its cycle is an error, not a memory leak


class ProcessRobot:
    """A :class:`~geogait.robots.Robot` behind a driver process (module docstring).

    Parameters
    ----------
    command : str or sequence of str
        The driver's command line (a string is split like a shell would, without a shell).
    timeout : float
        Seconds to wait for each line before the driver is declared hung and stopped.
    cwd : path-like, optional
        Working directory of the driver.

    Attributes
    ----------
    n_joints : int
    cycle_period : float
        From the driver's ``hello``.
    cycle : int
        Cycles run so far.
    front_back_symmetric : bool or None
        As declared by the driver (None: not said).
    """

    def __init__(self, command, *, timeout: float = 30.0, cwd=None):
        self.timeout = check_float(timeout, "timeout", "ProcessRobot", low=0, low_open=True)
        argv = shlex.split(command) if isinstance(command, str) else [str(c) for c in command]
        if not argv:
            raise fail("command", "ProcessRobot", "a non-empty command line", command)
        self.command = argv
        try:
            self._process = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, cwd=cwd, text=True, bufsize=1)
        except OSError as error:
            raise GeogaitError(f"could not start the robot driver {argv[0]!r}: {error.strerror or error}") from None
        self._lines: queue.Queue = queue.Queue()
        self._stderr: collections.deque = collections.deque(maxlen=20)
        self._pumps = [threading.Thread(target=self._pump, args=(pipe, lines), daemon=True)
                       for pipe, lines in ((self._process.stdout, self._lines), (self._process.stderr, self._stderr))]
        for pump in self._pumps:
            pump.start()
        self.line_number = 0
        self.cycle = 0
        try:
            self._handshake()
        except GeogaitError:
            self.close()
            raise

    # -- the Robot protocol -------------------------------------------------------------------
    @property
    def gait(self) -> FourierGait:
        """The gait the driver runs next."""
        return self._gait

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` from the next cycle boundary on."""
        if not isinstance(gait, FourierGait) or gait.n_joints != self.n_joints:
            raise fail("gait", "ProcessRobot.set_gait", f"a FourierGait with {self.n_joints} joints", gait)
        self._send({"type": "set_gait", "order": gait.order, "params": gait.params.tolist()})
        self._gait = gait

    def next_cycle(self) -> Trajectory:
        """Ask the driver to run one cycle and collect its samples."""
        self._send({"type": "run_cycle"})
        samples = []
        while True:
            message = self._receive()
            kind = message.get("type")
            if kind == "cycle_end":
                break
            if kind == "sample":
                samples.append(self._sample(message))
                if len(samples) > _MAX_SAMPLES:
                    raise self._failure(f"more than {_MAX_SAMPLES} samples in one cycle without 'cycle_end'")
        if len(samples) < 4:
            raise self._failure(f"a cycle of {len(samples)} sample(s); at least 4 are needed")
        trajectory = self._trajectory(samples)
        self.cycle += 1
        return trajectory

    def close(self) -> None:
        """Send ``stop`` and end the driver (terminated if it does not exit within a second)."""
        process = self._process
        if process.poll() is None:
            try:
                process.stdin.write(json.dumps({"type": "stop"}) + "\n")
                process.stdin.flush()
                process.stdin.close()
            except OSError:
                pass
            try:
                process.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                process.terminate()
                try:
                    process.wait(timeout=2.0)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        with contextlib.suppress(OSError):
            process.stdin.close()
        for pump, pipe in zip(self._pumps, (process.stdout, process.stderr), strict=True):
            pump.join(timeout=1.0)  # the driver is gone: its pipe reaches end of file
            if not pump.is_alive():  # (a grandchild may hold it open: then leave it to the daemon thread)
                pipe.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- messages -----------------------------------------------------------------------------
    @staticmethod
    def _pump(stream, sink):
        for line in stream:
            sink.put(line) if isinstance(sink, queue.Queue) else sink.append(line.rstrip())
        if isinstance(sink, queue.Queue):
            sink.put(None)  # end of file

    def _send(self, message: dict) -> None:
        try:
            self._process.stdin.write(json.dumps(message) + "\n")
            self._process.stdin.flush()
        except (OSError, ValueError):
            raise self._failure("the driver stopped reading its input") from None

    def _receive(self) -> dict:
        try:
            line = self._lines.get(timeout=self.timeout)
        except queue.Empty:
            self._process.kill()
            raise self._failure(f"no line from the driver within {self.timeout:g} s (hung); it was stopped") from None
        if line is None:
            try:
                code = self._process.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                code = None
            raise self._failure(f"the driver closed its output (exit code {code})")
        self.line_number += 1
        try:
            message = json.loads(line)
        except json.JSONDecodeError as error:
            raise self._failure(f"line {self.line_number} is not JSON ({error.msg}): {line.strip()[:80]!r}") from None
        if not isinstance(message, dict):
            raise self._failure(f"line {self.line_number} is not a JSON object: {line.strip()[:80]!r}")
        if message.get("type") == "error":
            raise self._failure(f"the driver reported an error: {message.get('message')}")
        return message

    def _failure(self, text: str) -> GeogaitError:
        tail = " | ".join(list(self._stderr)[-3:])
        return GeogaitError(f"robot driver {self.command[0]!r}: {text}" + (f" (stderr: {tail})" if tail else ""))

    def _field(self, message: dict, name: str, shape: tuple, optional: bool = False):
        value = message.get(name)
        if value is None and optional:
            return None
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            array = None
        if array is None or array.shape != shape or not np.all(np.isfinite(array)):
            expected = "a finite number" if shape == () else f"a list of {shape[0]} finite numbers"
            raise self._failure(f"line {self.line_number}: field '{name}' must be {expected}, got {value!r:.80}")
        return array

    def _handshake(self) -> None:
        hello = self._receive()
        if hello.get("type") != "hello" or hello.get("protocol") != PROTOCOL:
            raise self._failure(f"the first line must be a '{PROTOCOL}' hello, got {json.dumps(hello)[:80]}")
        if hello.get("version") != PROTOCOL_VERSION:
            raise self._failure(f"protocol version {hello.get('version')!r}; this geogait speaks {PROTOCOL_VERSION}")
        n_joints = hello.get("n_joints")
        if isinstance(n_joints, bool) or not isinstance(n_joints, int) or n_joints < 1:
            raise self._failure(f"'n_joints' must be a positive integer, got {n_joints!r}")
        self.n_joints = n_joints
        period = self._field(hello, "cycle_period", ())
        if period <= 0:
            raise self._failure(f"'cycle_period' must be positive (seconds), got {float(period)}")
        self.cycle_period = float(period)
        self._gait = self._read_gait(hello.get("gait"))
        symmetric = hello.get("front_back_symmetric")
        if symmetric is not None and not isinstance(symmetric, bool):
            raise self._failure(f"'front_back_symmetric' must be true or false, got {symmetric!r}")
        self.front_back_symmetric = symmetric

    def _read_gait(self, gait) -> FourierGait:
        if not isinstance(gait, dict) or not isinstance(gait.get("order"), int) or gait["order"] < 1:
            raise self._failure(f"'gait' must be {{'order': K >= 1, 'params': [...]}}, got {gait!r:.80}")
        params = self._field(gait, "params", (self.n_joints * (2 * gait["order"] + 1),))
        return FourierGait.from_params(params, self.n_joints)

    def _sample(self, message: dict) -> dict:
        d = self.n_joints
        return {"time": self._field(message, "time", ()), "phase": self._field(message, "phase", ()),
                "shape": self._field(message, "shape", (d,)),
                "shape_velocity": self._field(message, "shape_velocity", (d,)),
                "pose": self._field(message, "pose", (3,)),
                "body_velocity": self._field(message, "body_velocity", (3,), optional=True),
                "commanded_shape": self._field(message, "commanded_shape", (d,), optional=True)}

    def _trajectory(self, samples: list[dict]) -> Trajectory:
        columns = {name: [s[name] for s in samples] for name in samples[0]}
        for name in ("body_velocity", "commanded_shape"):
            present = [v is not None for v in columns[name]]
            if any(present) and not all(present):
                raise self._failure(f"cycle {self.cycle}: field '{name}' is in some samples but not all")
        time = np.array(columns["time"])
        if np.any(np.diff(time) <= 0):
            raise self._failure(f"cycle {self.cycle}: 'time' must increase strictly from sample to sample")
        phase = np.array(columns["phase"])
        if np.any((phase < 0) | (phase >= 2 * np.pi)):
            raise self._failure(f"cycle {self.cycle}: 'phase' must lie in [0, 2π)")
        pose = np.array(columns["pose"])
        body_velocity = np.array(columns["body_velocity"]) if columns["body_velocity"][0] is not None \
            else body_velocity_from_poses(time, pose)
        commanded = np.array(columns["commanded_shape"]) if columns["commanded_shape"][0] is not None else None
        return Trajectory(time=time, phase=phase, cycle=np.full(len(samples), self.cycle),
                          shape=np.array(columns["shape"]), shape_velocity=np.array(columns["shape_velocity"]),
                          body_velocity=body_velocity, pose=pose, commanded_shape=commanded)
