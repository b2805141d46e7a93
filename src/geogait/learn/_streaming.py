r"""Live streams: learn an :class:`~geogait.models.AdaptiveGaitModel` sample by sample.

The loop behind ``geogait stream`` and ``examples/robot_stream.py``. For every sample, in order:

1. **Phase**: the sample's own ``phase``, or — with a fitted :class:`~geogait.phase.Phaser` — the
   causal estimate of :class:`~geogait.phase.OnlinePhaser` (the sample's nearest point on the
   Phaser's limit cycle, tracked by a line fitted to the recent samples; no look-ahead, accurate
   at any period and under drifting rates: :mod:`geogait.phase._online`).
2. **Shape velocity**: the sample's own ``shape_velocity``, or the derivative of a polynomial
   fitted by least squares to the newest ``derivative_window`` shapes against their time stamps,
   evaluated at the newest sample (:class:`OnlineDifferentiator`: a one-sided, causal
   Savitzky–Golay filter that accepts irregular stamps). Measured relative RMS error of ṙ on the
   3-link swimmer (100 samples per cycle): window 5, order 2 (default): 0.006 on a smooth gait,
   0.044 with 0.1° encoder noise, 0.19 with the simulator's perturbations (whose ṙ is rough:
   white noise drives δ̈); the centred filter of :func:`~geogait.io.read_log` reaches
   0.000 / 0.010 / 0.14 on the same data but needs future samples. A model fitted on a log
   (centred ṙ) and then streamed (causal ṙ) sees slightly noisier ṙ than it was trained on.
   Beside a differentiated ṙ the body velocity is learned through the same fit (its value at the
   newest sample, not its slope), so that ξ = −A ṙ holds between the filtered signals as in
   :func:`~geogait.io.read_log` (held-out Γ on the 3-link swimmer with its perturbations, exact ξ:
   0.57 raw, 0.62 so filtered; a given ṙ leaves ξ as given).
3. **Predict, then learn**: ``model.partial_fit`` on the one sample. Its a-priori prediction
   ``model.prior_prediction_`` (the mean of the covering windows' filter predictions *before*
   the sample is learned) and the updated online Γ (eq. 6, ``model.gamma_``) are the output.
   Because the filters see each sample once, in order, the model after a stream equals the
   model from one batch ``partial_fit`` of the same samples: to rounding (~1e-13 relative after
   thousands of samples) on the compiled one-sample path (:mod:`geogait._kernels`, with
   numba), bit for bit in the RLS weights and covariances on the NumPy reference path.
4. **Checkpoint** every ``save_every`` learned samples, and at the end, with
   :meth:`~geogait.models.AdaptiveGaitModel.save` (temporary file + rename: a crash during a
   save leaves the previous file intact).

Warm-up: a sample without a usable phase (the OnlinePhaser has seen fewer than ``min_samples``
samples, one training cycle by default) or shape velocity (the first sample of a differentiated
stream) is neither predicted nor learned; its output says ``learned: false``. The same happens
after a gap: a time step longer than ``gap_factor`` times the median of the recent steps restarts
the differentiator and the phase tracker (no differentiation and no phase line across a gap).

Input records (:func:`run_stream`): JSON lines with the keys ``time``, ``phase``, ``shape``,
``shape_velocity``, ``body_velocity`` (lists for the vectors; unknown keys are errors), or CSV
with a header naming ``time``, ``phase``, ``shape_0``…, ``shape_velocity_0``…,
``body_velocity_x``, ``body_velocity_y``, ``body_velocity_theta`` (the columns of
:meth:`~geogait.simulate.Trajectory.to_pandas`; other columns are ignored and listed in
:attr:`CsvReader.ignored`). ``shape`` and ``body_velocity`` are required; ``time`` is required when
``shape_velocity`` is absent; ``phase`` is required without a Phaser and ignored with one.
Angles in radians. Blank lines are skipped. The first bad record stops the stream with an
error naming its line and field; everything learned before it is saved.

Stopping: SIGINT (Ctrl-C) and SIGTERM stop the loop at once while it waits for input; while a
sample is being learned or the model saved, they take effect after that (the model is never
saved half-updated), and a signal during the final save is ignored: the save completes. A
signal that arrives while an output line is being written may cut that line. SIGKILL cannot be
caught: the last checkpoint (``save_every``) survives intact, a temporary ``.<name>.<pid>.*.tmp``
file may be left beside it (the next save of that model removes it).
"""

from __future__ import annotations

import csv
import signal
import threading
from typing import TextIO

from .._validation import GeogaitError, fail
from ..io import STREAM_FORMATS, StreamSummary
from ._learner import StreamLearner

__all__ = ["run_stream"]


# -- the loop -----------------------------------------------------------------------------------
class _Stopped(Exception):
    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _StopOnSignal:
    """SIGINT/SIGTERM stop the loop between samples: raised at once while waiting for input,
    deferred to the end of the sample while learning or saving (so the model stays consistent)."""

    def __init__(self):
        self.busy = False
        self.pending: int | None = None
        self._previous: dict[int, object] = {}

    def __call__(self, signum, frame):
        if self.busy:
            self.pending = signum
        else:
            raise _Stopped(signum)

    def check(self) -> None:
        if self.pending is not None:
            raise _Stopped(self.pending)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self)
        return self

    def __exit__(self, *exc):
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        return False


def run_stream(learner: StreamLearner, source, sink: TextIO, *, fmt: str = "jsonl", reader=None) -> StreamSummary:
    """Read samples from ``source``, write one flushed output line per sample to ``sink``, learn.

    Ends at the end of the input, at the first bad record (``reason="error"``), on SIGINT or
    SIGTERM (in the main thread), or when ``sink`` is closed; in every case the learner saves
    what it learned (:meth:`StreamLearner.save`) before returning.

    Parameters
    ----------
    learner : StreamLearner
    source : iterable of str
        Input lines (e.g. ``sys.stdin``).
    sink : text stream
        Output: JSON lines, or CSV with a header, after ``fmt``.
    fmt : {"jsonl", "csv"}
    reader : iterable of StreamSample, optional
        Samples to use instead of parsing ``source`` (e.g. a :class:`CsvReader` the caller keeps
        to inspect :attr:`CsvReader.ignored`); by default a reader of ``fmt`` on ``source``.

    Returns
    -------
    StreamSummary
    """
    if fmt not in STREAM_FORMATS:
        raise fail("fmt", "run_stream", "'jsonl' or 'csv'", fmt)
    reader_type, writer_type = STREAM_FORMATS[fmt]
    reader = reader_type(source, learner.n_joints) if reader is None else reader
    reason, error = "eof", None
    with _StopOnSignal() as stop:
        try:
            writer = writer_type(sink)
            for sample in reader:
                stop.busy = True
                output = learner.step(sample)
                stop.busy = False
                writer.write(output)
                stop.check()
        except _Stopped as stopped:
            reason = str(stopped)
        except GeogaitError as bad:
            reason, error = "error", str(bad)
        except (UnicodeDecodeError, csv.Error) as bad:  # undecodable bytes, a broken CSV quote
            reason, error = "error", f"unreadable input after {learner.n_samples} sample(s): {bad}"
        except BrokenPipeError:
            reason = "output closed"
        finally:
            stop.busy = True
            try:
                learner.save()
            except (GeogaitError, OSError) as failure:
                message = f"could not save the model: {failure}"
                reason, error = "error", message if error is None else f"{error}; {message}"
    return StreamSummary(learner.n_samples, learner.n_learned, learner.gamma, reason, error, learner.last_saved,
                         learner.n_rejected, learner.first_rejection)
