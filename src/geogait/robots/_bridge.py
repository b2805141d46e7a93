r"""A robot in any language: a driver process speaking JSON lines over its stdin / stdout.

Protocol ``geogait-robot``, version 2 (version 1 drivers still work). One JSON object per line,
UTF-8, each with a ``type``.

Driver → geogait, first line::

    {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
     "gait": {"order": 1, "params": [a_00, a_01, b_01, a_10, a_11, b_11]}}

Optional hello fields: ``"front_back_symmetric": true`` declares a chain with front–back symmetry
whose motion reverses with time (the optimiser then searches the rotation-free symmetric gait family);
``"mirror_symmetric": true`` a body and medium that read the same in a mirror along the body's axis
(then, on a robot without that front–back symmetry, the rotation-free half-wave symmetric family);
``"joint_ranges": [[low,
high], ...]`` (one pair per joint, shape units, low < 0 < high) the joint limits the optimiser
derives its own from; ``"shape_constraints": [[a_0, ..., a_(d-1), b], ...]`` linear shape limits
a · r ≤ b (e.g. ``[1, -1, 0.9]`` and ``[-1, 1, 0.9]`` for joints that may not bend more than 0.9 rad
against each other) that every commanded gait keeps on its phase grid, as it keeps the joint limits
(:class:`~geogait.systems.LinearRegion`); ``"chain": {"link_lengths": [...], "body_frame": "middle",
"frame_offset": [x, y, angle], "resistive": true}`` the robot as a chain of straight links, which
:class:`~geogait.models.ResistanceModel` takes as known (:meth:`ProcessRobot.chain_geometry`): n_joints + 1
lengths, tail first; ``body_frame`` one of :class:`~geogait.systems.PurcellSwimmer`'s frames or a link
index (default ``"middle"``); ``frame_offset`` optional; ``"shape_map": [[...], ...]`` optional, for a body
driven through fewer shape coordinates than its chain has joints (a continuum's modes): N − 1 rows of
n_joints numbers for N links, each joint's angle as a linear function of the shape
(``ResistanceModel(shape_map=...)``); ``resistive`` (default false) says the medium's
drag is linear in velocity, which makes that model the optimiser's default;
and, version 2 only, ``"excitation": true`` says the driver runs the
exploration geogait sends with each cycle (below), so geogait, not the driver, sizes it. ``gait`` is
the robot's current
nominal gait, a Fourier series per joint with the flat parameter
vector of :class:`~geogait.gaits.FourierGait` (per joint ``[a_0, a_1 … a_K, b_1 … b_K]``).

geogait → driver::

    {"type": "set_gait", "order": 1, "params": [...]}   # run this gait from the next cycle on
    {"type": "run_cycle"}                                 # run one whole cycle, send its samples
    {"type": "stop"}                                      # finish; the driver should exit

To a driver that declared ``"excitation": true``, ``run_cycle`` carries the cycle's exploration::

    {"type": "run_cycle", "excitation": {"shape": [[δ_0 ... δ_d-1], ...], "shape_velocity": [[...], ...]}}

δ (shape units) and δ̇ (shape units per second) at M uniform phases 2πk / M of the cycle: the
driver adds them, interpolated at its own phases, to the commanded shape and rate of that cycle
only (and reports the sum as ``commanded_shape``), instead of any perturbation of its own.

Driver → geogait, after ``run_cycle``: one line per sample, then the end of the cycle::

    {"type": "sample", "time": 0.01, "phase": 0.0628, "shape": [...], "shape_velocity": [...],
     "pose": [x, y, heading], "body_velocity": [vx, vy, omega], "commanded_shape": [...]}
    {"type": "cycle_end"}

``time`` in seconds, ``phase`` in [0, 2π) (the commanded phase), ``shape`` / ``shape_velocity`` the
measured joint angles (rad) and rates (rad/s), ``pose`` the world pose of the body frame and
``body_velocity`` ξ in that frame (per second). ``body_velocity`` may be left out: it is then
computed from consecutive poses (SE(2) logarithms). ``commanded_shape`` is optional (see
:mod:`geogait.robots`). At any time the driver may send ``{"type": "error", "message": "..."}``.
A second ``hello`` is an error (a driver that restarted would otherwise be read as the one that said
hello first); lines of other types are ignored (room for extensions); anything the driver writes to stderr is
kept and shown when it fails.

What geogait checks (a driver is trusted with nothing):

* every line is strict UTF-8 JSON of at most :data:`MAX_LINE_BYTES` bytes, with no key given twice in one
  object; numbers are JSON numbers (not strings or booleans), ``version`` and ``n_joints`` integers;
  ``cycle_period`` lies in [1e-3, 86 400] s; error messages and stderr lines are cut to :data:`MAX_TEXT`
  characters;
* every cycle against the hello and the gait it was sent: its first time stamp is after the last accepted
  cycle's last (one clock for the whole run, from the hello on, not one per cycle), its samples span about one
  ``cycle_period`` (within a factor 2), the commanded phase sweeps the cycle (no gap over a
  quarter cycle), every joint the gait moves sweeps at least 1 % of the gait's range, the
  commanded shapes (when sent) follow the gait sent rather than an earlier one (RMS distance
  more than 1.5× smaller to an earlier gait: a driver ignoring ``set_gait``), and no pose jumps
  further than 20× what the body velocity and the cycle's other steps allow (also across the
  cycle boundary), and the body velocities agree with the poses
  (:func:`~geogait.simulate.velocity_pose_disagreement`: no unit mismatch, no sample's body velocity
  moving the body 20× further from its poses than the cycle's steps, and the last one's, which sets the
  cycle's end pose, within 5× of how closely the other samples match their poses). An implausible cycle is
  **quarantined**: not returned to the optimiser, logged (``quarantined``, a ``warning``), and run again;
  :data:`MAX_QUARANTINED` in a row (or that many following an earlier gait since the last
  ``set_gait``) end the run with an error naming the reason.
"""

from __future__ import annotations

import collections
import contextlib
import json
import queue
import shlex
import subprocess
import threading
import warnings

import numpy as np

from .._defaults import FEASIBILITY_TOLERANCE
from .._files import MAX_LINE_BYTES, RepeatedKey, unique_keys
from .._validation import MAX_MAGNITUDE, GeogaitError, GeogaitWarning, check_float, check_gait_size, fail
from ..gaits import FourierGait, check_excitation
from ..se2 import body_velocity_from_poses
from ..simulate import Trajectory, velocity_pose_disagreement
from ..systems import BODY_FRAMES, LinearRegion

__all__ = ["PERIOD_RANGE", "PROTOCOL", "PROTOCOL_VERSION", "PROTOCOL_VERSIONS", "ProcessRobot"]


PROTOCOL = "geogait-robot"
PROTOCOL_VERSION = 2
#: Protocol versions this geogait speaks (a driver's hello names one).
PROTOCOL_VERSIONS = (1, 2)
_MAX_SAMPLES = 1_000_000  # per cycle: a driver that never ends its cycle is an error, not a memory leak
#: Longest driver text (error message, stderr line) shown, in characters.
MAX_TEXT = 300
#: Implausible cycles in a row that end a run.
MAX_QUARANTINED = 3
#: Range of a hello's cycle_period (seconds): 1000 cycles/s to one cycle a day.
PERIOD_RANGE = (1e-3, 86_400.0)
# phases at which the hello's seed gait is checked against the ranges and region the hello declares
_HELLO_GAIT_PHASES = 1024


class _Fault(str):
    """A line the reader could not take (too long, not UTF-8): reported as the error of that line."""


def _cut(text, limit: int = MAX_TEXT) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit] + f"… ({len(text)} characters)"


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _plausible(values) -> bool:
    """JSON numbers (nested lists of them), each finite and within the documented ±MAX_MAGNITUDE."""
    try:
        array = np.asarray(values, dtype=float)
    except (OverflowError, TypeError, ValueError):  # (an integer beyond the float range, a ragged list)
        return False
    return bool(np.all(np.abs(array) <= MAX_MAGNITUDE))  # (NaN fails <=)


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
    check_cycles : bool
        Check every cycle against the hello and the gait sent, quarantining implausible ones (module
        docstring); False returns every cycle as the driver sent it.

    Attributes
    ----------
    n_joints : int
    cycle_period : float
        From the driver's ``hello``.
    cycle : int
        Cycles run so far.
    front_back_symmetric, mirror_symmetric : bool or None
        As declared by the driver (None: not said).
    joint_ranges : ndarray of shape (d, 2) or None
        As declared by the driver (None: not said).
    shape_constraints : LinearRegion or None
        The linear shape limits the driver declared (None: not said).
    feasibility : callable or None
        ``shape_constraints.feasibility``: the region the optimiser and the path follower keep every commanded
        gait in (:func:`~geogait.optimize.robot_feasibility`); None without constraints.
    chain : dict or None
        The chain geometry the driver declared (None: not said): :meth:`chain_geometry`'s keyword arguments.
    resistive_medium : bool
        The driver's chain declared ``"resistive": true``.
    accepts_excitation : bool
        The driver runs the exploration sent with each cycle (``set_excitation``; version 2).
    cycles_run : int
        Cycles the driver ran, quarantined ones included.
    quarantined : list of str
        One line per quarantined cycle: its number (counting every cycle run) and the reason.
    """

    def __init__(self, command, *, timeout: float = 30.0, cwd=None, check_cycles: bool = True):
        self.timeout = check_float(timeout, "timeout", "ProcessRobot", low=0, low_open=True)
        if isinstance(command, str):
            try:
                argv = shlex.split(command)
            except ValueError as error:  # an unbalanced quote
                raise fail("command", "ProcessRobot", f"a command line a shell could split ({error})",
                           command) from None
        else:
            argv = [str(c) for c in command]
        if not argv:
            raise fail("command", "ProcessRobot", "a non-empty command line", command)
        self.command = argv
        self.check_cycles = bool(check_cycles)
        self.quarantined: list[str] = []
        self.cycles_run = 0
        self._broken_off: str | None = None  # why a cycle broke off part-way (the driver is then out of step)
        try:
            self._process = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, cwd=cwd)
        except OSError as error:
            raise GeogaitError(f"could not start the robot driver {self._name()}: {error.strerror or error}") from None
        self._lines: queue.Queue = queue.Queue()
        self._stderr: collections.deque = collections.deque(maxlen=20)
        self._pumps = [threading.Thread(target=self._pump, args=(pipe, lines), daemon=True)
                       for pipe, lines in ((self._process.stdout, self._lines), (self._process.stderr, self._stderr))]
        for pump in self._pumps:
            pump.start()
        self.line_number = 0
        self.cycle = 0
        self._earlier: list[FourierGait] = []  # gaits commanded before the current one (newest last)
        self._ignored = 0
        self._last_pose = None
        self._last_time = -np.inf  # the latest sample time of the run (one clock for the whole run)
        self._excitation = None  # sent with the next run_cycle
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
        if gait != self._gait:
            self._ignored = 0  # cycles since this change that followed an earlier gait
            self._earlier = [g for g in self._earlier if g != self._gait][-1:] + [self._gait]
            if self._hello_gait not in self._earlier and self._hello_gait != gait:
                self._earlier.insert(0, self._hello_gait)
        self._gait = gait

    def set_excitation(self, shape, shape_velocity) -> None:
        """Send this exploration with the next ``run_cycle`` (drivers that declared ``"excitation": true``).

        Parameters
        ----------
        shape, shape_velocity : array-like of shape (M, d)
            δ (shape units) and δ̇ (per second) at phases 2πk / M (module docstring).
        """
        owner = "ProcessRobot.set_excitation"
        if not self.accepts_excitation:
            raise fail("self", owner, "a driver whose hello declares \"excitation\": true (protocol version 2)",
                       f"driver {self._name()}")
        self._excitation = check_excitation(shape, shape_velocity, self.n_joints, owner)

    def chain_geometry(self) -> dict:
        """The robot as a chain of straight links, as its driver's hello declared it (``"chain"``).

        Returns
        -------
        dict
            ``link_lengths``, ``body_frame``, ``frame_offset`` and, when declared, ``shape_map``: keyword
            arguments of :class:`~geogait.models.ResistanceModel` (``ResistanceModel(**robot.chain_geometry())``).

        Raises
        ------
        GeogaitError
            When the hello declared no chain.
        """
        if self.chain is None:
            raise GeogaitError(f"the robot driver {self._name()} declares no chain geometry (add \"chain\": "
                               "{\"link_lengths\": [...], \"body_frame\": ..., \"frame_offset\": [...]} to its hello)")
        return {**self.chain, "link_lengths": tuple(self.chain["link_lengths"])}

    def next_cycle(self) -> Trajectory:
        """Ask the driver to run one cycle and collect its samples; implausible cycles are quarantined
        (logged in :attr:`quarantined`, warned about, run again; see the module docstring)."""
        if self._broken_off is not None:  # (its remaining samples would be read as the next cycle's)
            raise GeogaitError(f"robot driver {self._name()}: an earlier cycle broke off part-way "
                               f"({self._broken_off}); the driver and geogait are no longer in step: start the "
                               "driver again")
        in_a_row = 0
        while True:
            try:
                trajectory = self._run_cycle()
            except GeogaitError as error:
                self._broken_off = _cut(str(error), 200)
                raise
            self.cycles_run += 1
            reason = self._implausible(trajectory) if self.check_cycles else None
            self._last_pose = trajectory.pose[-1]
            if reason is None:  # (a quarantined cycle's clock is not trusted: time stamps in another unit)
                self._last_time = float(trajectory.time[-1])
                trajectory.cycle[:] = self.cycle
                self.cycle += 1
                self._excitation = None
                return trajectory
            in_a_row += 1
            self.quarantined.append(f"cycle {self.cycles_run - 1}: {reason}")
            self._ignored += "set_gait ignored?" in reason
            if in_a_row >= MAX_QUARANTINED or self._ignored >= MAX_QUARANTINED:
                what = "in a row" if in_a_row >= MAX_QUARANTINED else "since the last set_gait"
                raise self._failure(f"{MAX_QUARANTINED} implausible cycles {what}; the last: {reason}")
            warnings.warn(f"robot driver {self._name()}: cycle {self.cycles_run - 1} quarantined (not learned, run "
                          f"again): {reason}", GeogaitWarning, stacklevel=2)

    def _run_cycle(self) -> Trajectory:
        message = {"type": "run_cycle"}
        if self._excitation is not None:  # (a quarantined cycle is run again with the same exploration)
            message["excitation"] = {"shape": self._excitation[0].tolist(),
                                     "shape_velocity": self._excitation[1].tolist()}
        self._send(message)
        samples = []
        while True:
            message = self._receive()
            kind = message.get("type")
            if kind == "cycle_end":
                break
            if kind == "hello":  # (the driver restarted, or says something else than it first did)
                raise self._failure(f"line {self.line_number}: a second 'hello' in the middle of the run; its "
                                    "settings cannot change once it has started (restart the run)")
            if kind == "sample":
                samples.append(self._sample(message))
                if len(samples) > _MAX_SAMPLES:
                    raise self._failure(f"more than {_MAX_SAMPLES} samples in one cycle without 'cycle_end'")
        if len(samples) < 4:
            raise self._failure(f"a cycle of {len(samples)} sample(s); at least 4 are needed")
        return self._trajectory(samples)

    # -- plausibility of a cycle ----------------------------------------------------------------
    def _implausible(self, cycle: Trajectory) -> str | None:
        """Why ``cycle`` cannot be what the driver was told to run (None: plausible)."""
        n = cycle.time.size
        if not cycle.time[0] > self._last_time:
            return (f"its first time stamp ({float(cycle.time[0])!r} s) is not after the last accepted cycle's last "
                    f"({self._last_time!r} s): time stamps must increase through the whole run (one clock since the "
                    "hello, not one per cycle)")
        span = (cycle.time[-1] - cycle.time[0]) * n / (n - 1)
        if not self.cycle_period / 2 <= span <= 2 * self.cycle_period:
            return (f"its {n} samples span {span:.4g} s, but the hello's cycle_period is {self.cycle_period:.4g} s "
                    "(time stamps in another unit, or a wrong period)")
        phase = np.sort(cycle.phase)
        gaps = np.diff(np.concatenate([phase, phase[:1] + 2 * np.pi]))
        if gaps.max() > np.pi / 2 + 1e-9:
            return (f"the commanded phase covers only {2 * np.pi - gaps.max():.3g} of the 2π rad of a cycle "
                    "(phase stuck or not sweeping the cycle)")
        sent = self._gait.shape(cycle.phase)
        moving = np.ptp(sent, axis=0) > 1e-9
        still = moving & (np.ptp(cycle.shape, axis=0) < 0.01 * np.ptp(sent, axis=0))
        if still.any():
            return (f"joint(s) {np.flatnonzero(still).tolist()} never moved (less than 1% of the range the gait sent "
                    "sweeps)")
        followed = cycle.commanded_shape  # (measured shapes may leave a gait that saturates: the optimiser judges that)
        error = np.sqrt(np.mean((followed - sent) ** 2)) if followed is not None else 0.0
        for earlier in self._earlier if followed is not None else ():
            other = np.sqrt(np.mean((followed - earlier.shape(cycle.phase)) ** 2))
            if error > 1.5 * other + 1e-12:
                return (f"the commanded shapes follow an earlier gait (RMS {other:.3g} rad), not the one sent "
                        f"(RMS {error:.3g} rad): set_gait ignored?")
        return self._pose_jump(cycle) or velocity_pose_disagreement(cycle, self.cycle_period)

    def _pose_jump(self, cycle: Trajectory) -> str | None:
        """A pose step far beyond what the body velocity and the other steps of the cycle allow."""
        position = cycle.pose[:, :2]
        if self._last_pose is not None:
            position = np.vstack([self._last_pose[:2], position])
        step = np.hypot(*np.diff(position, axis=0).T)
        dt = np.diff(cycle.time)
        moved = np.hypot(cycle.body_velocity[:-1, 0], cycle.body_velocity[:-1, 1]) * dt
        limit = 20 * (np.percentile(step, 90) + np.percentile(moved, 90)) + 1e-9 * (1 + np.abs(position).max())
        k = int(np.argmax(step))
        if step[k] > limit:
            where = ("from the end of the previous cycle to its first sample" if self._last_pose is not None and k == 0
                     else f"at sample {k - (self._last_pose is not None) + 1}")
            return (f"the pose jumps by {step[k]:.4g} {where}, where the body velocity and the cycle's other steps "
                    f"allow about {limit / 20:.3g}")
        return None

    def close(self) -> None:
        """Send ``stop`` and end the driver (terminated if it does not exit within a second)."""
        process = self._process
        if process.poll() is None:
            try:
                process.stdin.write((json.dumps({"type": "stop"}) + "\n").encode())
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
        """Read the driver's lines: bounded in length, strictly decoded; never raises (a fault is queued)."""
        if not isinstance(sink, queue.Queue):
            return ProcessRobot._pump_stderr(stream, sink)
        try:
            while True:
                line = stream.readline(MAX_LINE_BYTES + 1)
                if not line:
                    break
                if len(line) > MAX_LINE_BYTES:
                    sink.put(_Fault(f"is longer than {MAX_LINE_BYTES} bytes (no line end); the driver was stopped"))
                    return
                try:
                    sink.put(line.decode("utf-8"))
                except UnicodeDecodeError as error:
                    sink.put(_Fault(f"is not UTF-8 (byte 0x{line[error.start]:02x} at position {error.start})"))
                    return
        except (OSError, ValueError) as error:
            sink.put(_Fault(f"could not be read ({error})"))
            return
        sink.put(None)  # end of file

    @staticmethod
    def _pump_stderr(stream, sink):
        """Keep the driver's last stderr lines, each cut to :data:`MAX_TEXT` characters."""
        continued = False
        try:
            while True:
                chunk = stream.readline(4 * MAX_TEXT)
                if not chunk:
                    return
                if not continued:
                    sink.append(_cut(chunk.decode("utf-8", "replace").rstrip()))
                elif sink and not sink[-1].endswith("…"):
                    sink[-1] += "…"
                continued = not chunk.endswith(b"\n")
        except (OSError, ValueError):
            return

    def _name(self) -> str:
        """The driver's command line, cut for messages."""
        return repr(_cut(shlex.join(self.command), 80))

    def _send(self, message: dict) -> None:
        try:
            self._process.stdin.write((json.dumps(message) + "\n").encode())
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
        if isinstance(line, _Fault):
            self._process.kill()
            raise self._failure(f"line {self.line_number} {line}")
        try:
            message = json.loads(line, object_pairs_hook=unique_keys)
        except RepeatedKey as repeated:
            raise self._failure(f"line {self.line_number}: key {_cut(repr(repeated.key), 40)} appears more than "
                                "once in one JSON object (which one was meant?)") from None
        except (json.JSONDecodeError, RecursionError) as error:
            reason = getattr(error, "msg", "nested too deeply")
            raise self._failure(f"line {self.line_number} is not JSON ({reason}): {_cut(line, 80)!r}") from None
        if not isinstance(message, dict):
            raise self._failure(f"line {self.line_number} is not a JSON object: {_cut(line, 80)!r}")
        if message.get("type") == "error":
            raise self._failure(f"the driver reported an error: {_cut(message.get('message'))}")
        return message

    def _failure(self, text: str) -> GeogaitError:
        tail = " | ".join(list(self._stderr)[-3:])
        return GeogaitError(f"robot driver {self._name()}: {text}" + (f" (stderr: {tail})" if tail else ""))

    def _field(self, message: dict, name: str, shape: tuple, optional: bool = False, limit: float = MAX_MAGNITUDE):
        value = message.get(name)
        if value is None and optional:
            return None
        if shape == ():
            numbers = _is_number(value)
        else:
            numbers = isinstance(value, list) and len(value) == shape[0] and all(map(_is_number, value))
        array = None
        if numbers:
            try:
                array = np.asarray(value, dtype=float)
            except OverflowError:  # an integer beyond the float range
                array = None
        if array is None or not np.all(np.abs(array) <= limit) or not np.all(np.isfinite(array)):  # (NaN fails <=)
            expected = "a finite number" if shape == () else f"a list of {shape[0]} finite numbers"
            within = f" within ±{limit:g}" if np.isfinite(limit) else ""
            raise self._failure(f"line {self.line_number}: field '{name}' must be {expected} (JSON numbers{within}), "
                                f"got {_cut(repr(value), 80)}")
        return array

    def _handshake(self) -> None:
        hello = self._receive()
        if hello.get("type") != "hello" or hello.get("protocol") != PROTOCOL:
            wrong = [f"{key!r}: {value!r}" for key, value in (("type", "hello"), ("protocol", PROTOCOL))
                     if hello.get(key) != value]
            raise self._failure(f"the first line must be a '{PROTOCOL}' hello (with {', '.join(wrong)}), got "
                                f"{_cut(json.dumps(hello), 80)}")
        version = hello.get("version")
        if type(version) is not int or version not in PROTOCOL_VERSIONS:
            spoken = " or ".join(map(str, PROTOCOL_VERSIONS))
            raise self._failure(f"protocol version {_cut(repr(version), 40)} (must be the integer {spoken}); "
                                f"this geogait speaks {spoken}")
        self.protocol_version = version
        n_joints = hello.get("n_joints")
        if isinstance(n_joints, bool) or not isinstance(n_joints, int) or not 1 <= n_joints <= 10_000:
            raise self._failure(f"'n_joints' must be an integer in 1..10000, got {_cut(repr(n_joints), 40)}")
        self.n_joints = n_joints
        period = self._field(hello, "cycle_period", (), limit=np.inf)  # (its range is checked next)
        low, high = PERIOD_RANGE
        if not low <= period <= high:
            raise self._failure(f"'cycle_period' must be in [{low:g}, {high:g}] seconds, got {float(period):g}")
        self.cycle_period = float(period)
        self._gait = self._hello_gait = self._read_gait(hello.get("gait"))
        for name in ("front_back_symmetric", "mirror_symmetric"):
            symmetric = hello.get(name)
            if symmetric is not None and not isinstance(symmetric, bool):
                raise self._failure(f"'{name}' must be true or false, got {_cut(repr(symmetric), 40)}")
            setattr(self, name, symmetric)
        excitation = hello.get("excitation", False)
        if not isinstance(excitation, bool) or (excitation and version < 2):
            raise self._failure(f"'excitation' must be true or false (and true only in protocol version 2), got "
                                f"{_cut(repr(excitation), 40)} in version {version}")
        self.accepts_excitation = excitation
        self.joint_ranges = None
        if hello.get("joint_ranges") is not None:
            ranges = hello["joint_ranges"]
            values = None
            if isinstance(ranges, list) and len(ranges) == self.n_joints and all(
                    isinstance(row, list) and len(row) == 2 and all(map(_is_number, row)) for row in ranges) \
                    and _plausible(ranges):
                values = np.array(ranges, dtype=float)
            if values is None or np.any(values[:, 0] >= 0) or np.any(values[:, 1] <= 0):
                raise self._failure(f"'joint_ranges' must be {self.n_joints} pairs [low, high] with low < 0 < high, "
                                    f"numbers within ±{MAX_MAGNITUDE:g}, got {_cut(repr(ranges), 80)}")
            self.joint_ranges = values
        self.chain, self.resistive_medium = (None, False) if hello.get("chain") is None \
            else self._read_chain(hello["chain"])
        self.shape_constraints = None if hello.get("shape_constraints") is None \
            else self._read_constraints(hello["shape_constraints"])
        self.feasibility = None if self.shape_constraints is None else self.shape_constraints.feasibility
        self._check_hello_gait()

    def _check_hello_gait(self) -> None:
        """The hello's seed gait lies within the joint ranges and the region the same hello declares: a driver whose
        seed leaves them is refused here, naming its fields, not later as a seed the optimiser cannot start from."""
        shapes = self._hello_gait.shape(np.linspace(0, 2 * np.pi, _HELLO_GAIT_PHASES, endpoint=False))  # (n, d)
        if self.joint_ranges is not None:
            low, high = shapes.min(axis=0), shapes.max(axis=0)
            outside = np.flatnonzero((low < self.joint_ranges[:, 0] - FEASIBILITY_TOLERANCE)
                                     | (high > self.joint_ranges[:, 1] + FEASIBILITY_TOLERANCE))
            if outside.size:
                j = int(outside[0])
                raise self._failure(f"the hello's 'gait' moves joint {j} over [{low[j]:.4g}, {high[j]:.4g}] rad, "
                                    f"outside its 'joint_ranges' [{self.joint_ranges[j, 0]:.4g}, "
                                    f"{self.joint_ranges[j, 1]:.4g}]; the seed gait must lie within them")
        if self.shape_constraints is not None:
            margin = self.shape_constraints.feasibility(shapes)
            if margin.min() < -FEASIBILITY_TOLERANCE:
                at = int(np.argmin(margin))
                raise self._failure(f"the hello's 'gait' leaves the region its 'shape_constraints' declare (by "
                                    f"{-margin[at]:.4g} at phase {2 * np.pi * at / _HELLO_GAIT_PHASES:.3g} rad); "
                                    "the seed gait must lie inside it")

    def _read_constraints(self, rows) -> LinearRegion:
        """The hello's ``shape_constraints``: rows [a_0 … a_(d-1), b], a · r ≤ b, a not all zero."""
        d = self.n_joints
        if isinstance(rows, list) and 1 <= len(rows) <= 10_000 and all(
                isinstance(row, list) and len(row) == d + 1 and all(map(_is_number, row)) for row in rows) \
                and _plausible(rows):
            values = np.array(rows, dtype=float)
            if np.all(np.abs(values[:, :d]).max(axis=1) > 0):
                return LinearRegion.from_rows(values)
        raise self._failure(f"'shape_constraints' must be a list of rows [a_0, ..., a_{d - 1}, b] of numbers within "
                            f"±{MAX_MAGNITUDE:g} (a · shape <= b, shape units; a not all zero), got "
                            f"{_cut(repr(rows), 80)}")

    def _read_chain(self, chain) -> tuple[dict, bool]:
        """The hello's ``chain`` (positive link lengths, a body frame, an optional frame offset, an optional shape
        map) and whether it declares a resistive medium."""
        d = self.n_joints
        mapped = isinstance(chain, dict) and chain.get("shape_map") is not None
        lengths = chain.get("link_lengths") if isinstance(chain, dict) else None
        n_links = len(lengths) if mapped and isinstance(lengths, list) else d + 1
        expected = (f"'chain' must be {{'link_lengths': {d + 1} positive numbers (or N >= 2 with a 'shape_map' of "
                    f"N - 1 rows of {d} numbers: each joint's angle from the {d} shape coordinates), 'body_frame': "
                    f"one of {', '.join(BODY_FRAMES)} or a link index in 0..{n_links - 1}, 'frame_offset': [x, y, "
                    f"angle] or null, 'resistive': true or false}}, every number within ±{MAX_MAGNITUDE:g}, got "
                    f"{_cut(repr(chain), 120)}")
        if not isinstance(chain, dict) or set(chain) - {"link_lengths", "body_frame", "frame_offset", "resistive",
                                                        "shape_map"}:
            raise self._failure(expected)
        frame, offset, shape_map = chain.get("body_frame", "middle"), chain.get("frame_offset"), chain.get("shape_map")
        if not isinstance(chain.get("resistive", False), bool):
            raise self._failure(expected)
        if not (isinstance(lengths, list) and len(lengths) == n_links and n_links >= 2
                and all(map(_is_number, lengths)) and _plausible(lengths) and all(v > 0 for v in lengths)):
            raise self._failure(expected)
        if not (frame in BODY_FRAMES or type(frame) is int and 0 <= frame < n_links):
            raise self._failure(expected)
        if offset is not None and not (isinstance(offset, list) and len(offset) == 3 and all(map(_is_number, offset))
                                       and _plausible(offset)):
            raise self._failure(expected)
        if mapped and not (isinstance(shape_map, list) and len(shape_map) == n_links - 1 and _plausible(shape_map)
                           and all(isinstance(row, list) and len(row) == d and all(map(_is_number, row))
                                   for row in shape_map)):
            raise self._failure(expected)
        geometry = {"link_lengths": [float(v) for v in lengths], "body_frame": frame,
                    "frame_offset": None if offset is None else tuple(float(v) for v in offset)}
        if mapped:
            geometry["shape_map"] = tuple(tuple(float(v) for v in row) for row in shape_map)
        return geometry, chain.get("resistive", False)

    def _read_gait(self, gait) -> FourierGait:
        order = gait.get("order") if isinstance(gait, dict) else None
        if type(order) is not int or not 1 <= order <= 1000:
            raise self._failure(f"'gait' must be {{'order': K in 1..1000, 'params': [...]}}, "
                                f"got {_cut(repr(gait), 80)}")
        try:  # (before its parameters are read: 10,000 joints at order 1000 would not fit an optimisation)
            check_gait_size(self.n_joints, order, "the hello's 'gait'", "order", speed_limit=False)
        except GeogaitError as error:
            raise self._failure(str(error)) from None
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
