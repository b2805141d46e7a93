r"""A local gait model from a robot log, and predictions on new logs (``geogait fit`` / ``predict``).

:func:`fit_log` runs the whole real-data path on a :class:`~geogait.io.Log`:

1. **Phase**: the log's phase column, or a :class:`~geogait.phase.Phaser` fitted on the shapes of
   all segments (one record each) and applied to them (whole records, not causal).
2. **Phase rate** φ̇ (rad per time unit, needed for θ̇ = θ'(φ)φ̇): the unwrapped phase advance
   of all segments divided by their duration. It is stored in the model's ``phase_rate``.
3. **Cycles** are counted on the unwrapped phase, per segment (a new cycle at every segment).
   In every segment the last ``test_fraction`` of its cycles (rounded) are **held out**; the
   rest are the training cycles. The Phaser and the cycle split use all shapes (shapes only,
   no body velocities); everything that sees body velocities sees the training cycles only.
4. **Nominal gait**: :func:`~geogait.phase.fit_nominal_gait` on the training cycles (order by
   cross-validation over whole cycles unless given).
5. **Evaluation model**: an :class:`~geogait.models.AdaptiveGaitModel` around that gait, learned
   from the training samples in time order; scored on the held-out cycles with Γ (eq. 5, against
   its own phase model), overall and per held-out cycle.
6. **Saved model**: with ``refit=True`` (default) the nominal gait (same order) and the model are
   fitted again on *all* samples, so nothing in the log is wasted; its held-out score is the
   evaluation model's (the refit has no held-out data left). With ``refit=False`` the saved
   model is the evaluation model.

A log needs at least ``MIN_TRAIN_CYCLES`` (5) training cycles plus one held-out cycle; a Phaser
needs 5 cycles too. Fewer raise an error naming the counts.

Γ here is measured against the log's own body velocities, so it is capped by their quality: noise
in poses (amplified by differentiation) and the low-pass of the Savitzky–Golay filters both count
as model error. On the simulated 3-link swimmer (tests/cli/test_cli_fit.py) a poses-only log with
realistic motion-capture noise scores 0.90 where the true phase and velocities score 0.986;
noise-free poses score 0.93 (the simulator's shape-velocity perturbation is rougher than any
filter of sampled shapes can follow).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._defaults import DEFAULT_TEST_FRACTION, TIME_UNITS
from .._estimator import check_is_fitted
from .._files import check_outputs, default_summary_path, output_set, write_json, write_text
from .._validation import GeogaitError, GeogaitWarning, check_float, check_int, fail, warn_if_degrees
from ..gaits import FourierGait
from ..io import PREDICTION_COLUMNS, ColumnMapping, Log, mapping_to_json
from ..models import AdaptiveGaitModel, gamma
from ..phase import NominalGaitFit, Phaser, fit_nominal_gait
from ..plotting import write_fit_figures
from ..simulate import BODY_VELOCITY_COLUMNS
from ._model_class import ModelClassVerdict, model_class_verdict

__all__ = ["LogFit", "LogPrediction", "fit_log", "predict_log"]

MIN_TRAIN_CYCLES = 5


# -- phase and cycles ---------------------------------------------------------------------------
def _unwrapped_phase(log: Log, phaser: Phaser | None, fit: bool) -> tuple[list[np.ndarray], Phaser | None]:
    """Per segment, the continuous phase; and the Phaser used (None when the log had a phase)."""
    parts = log.segments()
    if log.phase is not None:
        if phaser is not None:
            raise fail("phaser", "fit_log" if fit else "predict_log", "omitted for a log with a phase column "
                       "(use one or the other)", "a Phaser")
        return [np.unwrap(part.phase) for part in parts], None
    if phaser is None and not fit:
        raise fail("phaser", "predict_log", "a fitted Phaser (the log has no phase column), e.g. the "
                   "phaser.npz written by 'geogait fit'", None)
    phaser = Phaser() if phaser is None else phaser
    records = [part.shape for part in parts]
    if fit:
        phaser.fit(records)
    return phaser.transform(records, unwrap=True), phaser


def _phase_rate(log: Log, unwrapped: list[np.ndarray]) -> float:
    """Mean φ̇: total unwrapped advance over total duration of the segments (checked: see
    :func:`check_phase_rate`)."""
    advance = sum(float(u[-1] - u[0]) for u in unwrapped)
    duration = sum(float(part.time[-1] - part.time[0]) for part in log.segments())
    if duration <= 0 or advance <= 0:
        raise fail("phase", "fit_log", "a phase that advances over time (positive rate)",
                   f"an advance of {advance:.3g} rad in {duration:.3g} time units")
    return check_phase_rate(advance / duration, log.time_unit, "fit_log")


#: Gait frequencies (cycles per second) the model's defaults are made for; outside: a warning.
PLAUSIBLE_FREQUENCY = (0.01, 100.0)
#: Gait frequencies outside which a declared time unit must be wrong: an error.
POSSIBLE_FREQUENCY = (1 / 86400, 1000.0)


def check_phase_rate(rate: float, time_unit: str | None, owner: str) -> float:
    """Warn about (or, with a declared ``time_unit``, refuse) an implausible phase rate.

    Parameters
    ----------
    rate : float
        φ̇ in rad per time unit (per second when ``time_unit`` is ``"s"``).
    time_unit : str or None
        ``"s"`` when times were declared and converted to seconds; None when undeclared (assumed
        seconds, and only a warning is possible).
    owner : str
        For the message.

    Returns
    -------
    float
        ``rate``.
    """
    frequency = rate / (2 * np.pi)
    low, high = PLAUSIBLE_FREQUENCY
    if low <= frequency <= high:
        return rate
    # the unit whose reading of the same stamps gives the frequency closest to 1 cycle per second
    guesses = {unit: frequency / seconds for unit, seconds in TIME_UNITS.items()}
    best = min(guesses, key=lambda unit: abs(np.log10(guesses[unit])))
    hint = (f"if the time column is in {best}, pass time_unit={best!r} (--time-unit {best}), which gives "
            f"{guesses[best]:.3g} cycles/s" if best != "s" else "check the time column and the phase")
    unit = "s" if time_unit else "time unit (undeclared; seconds assumed)"
    message = (f"The phase rate found by {owner} is {frequency:.3g} cycles per {unit}, outside the "
               f"{low:g}–{high:g} cycles/s that locomotion and the model's defaults are made for; {hint}.")
    if time_unit is not None and not POSSIBLE_FREQUENCY[0] <= frequency <= POSSIBLE_FREQUENCY[1]:
        raise GeogaitError(message)
    warnings.warn(message, GeogaitWarning, stacklevel=3)
    return rate


def _cycles(unwrapped: list[np.ndarray]) -> np.ndarray:
    """Global cycle number ``(n,)``: wraps of the continuous phase, a new cycle at every segment.

    Numbers never decrease within a segment: phase jitter back across a wrap does not count twice.
    """
    cycles, start = [], 0
    for u in unwrapped:
        turns = np.floor(u / (2 * np.pi))
        local = (turns - turns[0]).astype(int)
        local = np.maximum.accumulate(np.maximum(local, 0))
        cycles.append(start + local)
        start += int(local[-1]) + 1
    return np.concatenate(cycles)


def _held_out(cycle: np.ndarray, segment: np.ndarray, fraction: float) -> np.ndarray:
    """Mask of the last ``fraction`` of each segment's cycles (rounded)."""
    test = np.zeros(cycle.shape, dtype=bool)
    for s in np.unique(segment):
        mine = segment == s
        first, last = int(cycle[mine].min()), int(cycle[mine].max())
        n_test = int(round(fraction * (last - first + 1)))
        test |= mine & (cycle > last - n_test)
    n_train, n_test = np.unique(cycle[~test]).size, np.unique(cycle[test]).size
    if n_train < MIN_TRAIN_CYCLES or n_test < 1:
        raise fail("log", "fit_log", f"a log spanning enough cycles for {MIN_TRAIN_CYCLES} training cycles and at "
                   f"least 1 held-out cycle at test_fraction = {fraction:g}",
                   f"{np.unique(cycle).size} cycle(s): {n_train} training, {n_test} held out")
    return test


# -- fitting ------------------------------------------------------------------------------------
def _samples(log: Log, mask=slice(None)) -> tuple[np.ndarray, ...]:
    return log.phase[mask], log.shape[mask], log.shape_velocity[mask], log.body_velocity[mask]


@dataclass(frozen=True)
class LogFit:
    """Result of :func:`fit_log`.

    Attributes
    ----------
    log : Log
        The input log with its (estimated) phase.
    unwrapped_phase : ndarray of shape (n,)
        Continuous phase within each segment.
    cycle : ndarray of shape (n,), int
        Cycle of each sample (a new cycle at every segment).
    test : ndarray of shape (n,), bool
        Held-out samples.
    phase_rate : float
        φ̇ in rad per time unit (stored in both models).
    phaser : Phaser or None
        Fitted here, when the log had no phase column.
    nominal : NominalGaitFit
        Nominal gait fitted on the training cycles.
    evaluation_model : AdaptiveGaitModel
        Learned from the training cycles; the held-out scores are its.
    model : AdaptiveGaitModel
        The model to save: refit on all samples, or ``evaluation_model`` when ``refit`` is False.
    refit : bool
    """

    log: Log
    unwrapped_phase: np.ndarray
    cycle: np.ndarray
    test: np.ndarray
    phase_rate: float
    phaser: Phaser | None
    nominal: NominalGaitFit
    evaluation_model: AdaptiveGaitModel
    model: AdaptiveGaitModel
    refit: bool

    def held_out(self) -> dict[str, np.ndarray]:
        """Held-out samples' time, cycle, measured ξ, model prediction and phase-model baseline."""
        phase, shape, rate, body = _samples(self.log, self.test)
        return {"index": np.flatnonzero(self.test), "time": self.log.time[self.test], "cycle": self.cycle[self.test],
                "measured": body, "predicted": self.evaluation_model.predict(phase, shape, rate),
                "baseline": self.evaluation_model.phase_model_.predict(phase)}

    def held_out_gamma(self) -> float:
        """Γ (eq. 5) of the evaluation model on all held-out samples."""
        return float(self.evaluation_model.score(*_samples(self.log, self.test)))

    def held_out_gamma_per_cycle(self) -> list[dict]:
        """Per held-out cycle: cycle, segment, sample count and Γ."""
        data = self.held_out()
        return _per_cycle(data["predicted"], data["baseline"], data["measured"], data["cycle"],
                          self.log.segment[self.test])

    def model_class(self) -> ModelClassVerdict:
        """Whether the log's net motion per cycle changes with the cycle period
        (:func:`~geogait.learn.model_class_verdict`: outside the model class when it does)."""
        return model_class_verdict(self.log, self.cycle)

    def summary(self) -> dict:
        """Numbers of the report: Γ (held-out overall and per cycle, online), gait order, counts."""
        train = ~self.test
        nominal = self.nominal
        return {
            "n_samples": self.log.n_samples, "n_segments": self.log.n_segments,
            "n_cycles": int(np.unique(self.cycle).size),
            "n_train_cycles": int(np.unique(self.cycle[train]).size),
            "n_test_cycles": int(np.unique(self.cycle[self.test]).size),
            "n_train_samples": int(train.sum()), "n_test_samples": int(self.test.sum()),
            "phase_source": "phase column" if self.phaser is None else "Phaser (phaser.npz)",
            "phase_rate": self.phase_rate,
            "gait_order": nominal.order,
            "gait_order_held_out_rmse": {int(k): float(v) for k, v in
                                         zip(nominal.orders, nominal.held_out_rmse, strict=True)},
            "held_out_gamma": self.held_out_gamma(),
            "held_out_gamma_per_cycle": self.held_out_gamma_per_cycle(),
            "model_class": self.model_class().to_dict(),
            "online_gamma_end_of_training": float(self.evaluation_model.gamma_),
            "online_gamma_end": float(self.model.gamma_),
            "saved_model": (f"refit on all {self.log.n_samples} samples (training and held-out cycles); "
                            "held-out scores are those of the same model trained on the training cycles only")
            if self.refit else "trained on the training cycles only (the model that was scored)",
            "hyper_parameters": {k: v for k, v in self.model.get_params(deep=False).items() if k != "gait"},
            "segments": self._segments(),
        }

    def _segments(self) -> list[dict]:
        rows = []
        for part, s in zip(self.log.segments(), np.unique(self.log.segment), strict=True):
            mine = self.log.segment == s
            held = np.flatnonzero(self.test[mine])
            rows.append({"segment": int(s), "n_samples": part.n_samples, "first_row": int(part.row[0]),
                         "last_row": int(part.row[-1]), "t_start": float(part.time[0]), "t_end": float(part.time[-1]),
                         "n_cycles": int(np.unique(self.cycle[mine]).size),
                         "n_test_cycles": int(np.unique(self.cycle[mine & self.test]).size),
                         "first_test_row": int(part.row[held[0]]) if held.size else None})
        return rows

    #: Every file :meth:`save` writes into its folder; an earlier fit's that this one does not write is removed.
    OUTPUT_FILES = ("model.npz", "phaser.npz", "config.json", "mapping.json", "report.json", "phase.png",
                    "nominal_gait.png", "body_velocity.png")

    def save(self, folder, *, mapping: ColumnMapping | None = None, extra: dict | None = None) -> dict[str, Path]:
        """Write model.npz, [phaser.npz], config.json, [mapping.json], report.json and the figures.

        Parameters
        ----------
        folder : path-like
            Created if missing.
        mapping : ColumnMapping, optional
            Written as mapping.json (reuse it with ``geogait predict --mapping``).
        extra : dict, optional
            Added to report.json (e.g. the command line's options).

        Returns
        -------
        dict of name to Path
        """
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        with output_set(folder, last=("report.json",), members=self.OUTPUT_FILES) as staged:  # all of them, or none
            paths = {"model": self.model.save(staged / "model.npz")}
            if self.phaser is not None:
                paths["phaser"] = self.phaser.save(staged / "phaser.npz")
            paths["config"] = write_json(staged / "config.json", self.model.to_config())
            if mapping is not None:
                paths["mapping"] = write_text(staged / "mapping.json", mapping_to_json(mapping))
            paths.update(write_fit_figures(self, staged))
            paths["report"] = staged / "report.json"
            report = {**(extra or {}), "results": self.summary(), "files": {k: p.name for k, p in paths.items()}}
            write_json(paths["report"], report)
        return {k: folder / p.name for k, p in paths.items()}


def fit_log(log: Log, *, forgetting_factor: float | None = None, n_windows: int | None = None,
            gait_order: int | None = None, max_gait_order: int = 6, test_fraction: float = DEFAULT_TEST_FRACTION,
            refit: bool = True, phaser: Phaser | None = None) -> LogFit:
    """Fit the nominal gait and an adaptive gait model to a log; score it on held-out cycles.

    Parameters
    ----------
    log : Log
        From :func:`read_log`; estimated phase when it has no phase column.
    forgetting_factor : float in (0, 1], optional
        λ of the model's RLS filters (default: AdaptiveGaitModel's).
    n_windows : int, optional
        Phase windows of the model (default: AdaptiveGaitModel's).
    gait_order : int, optional
        Fourier order of the nominal gait; by cross-validated held-out error when omitted.
    max_gait_order : int
        Largest order tried by the cross-validation.
    test_fraction : float in (0, 0.9]
        Fraction of each segment's cycles held out (the last ones).
    refit : bool
        Refit the saved model on all samples after scoring (see the module notes).
    phaser : Phaser, optional
        An unfitted Phaser with non-default settings (fitted here on the log).

    Returns
    -------
    LogFit

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> from geogait.io import read_log
    >>> from geogait.simulate import simulate
    >>> from geogait.systems import PurcellSwimmer
    >>> run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=20, seed=0)
    >>> log = read_log(run.to_pandas(), shape=["shape_0", "shape_1"], phase="phase",
    ...                shape_velocity=["shape_velocity_0", "shape_velocity_1"],
    ...                body_velocity=["body_velocity_x", "body_velocity_y", "body_velocity_theta"])
    >>> fit = fit_log(log)
    >>> fit.nominal.order, round(fit.phase_rate, 4), round(fit.held_out_gamma(), 2)
    (1, 6.2832, 0.99)
    """
    fraction = check_float(test_fraction, "test_fraction", "fit_log", low=0, high=0.9, low_open=True)
    if not isinstance(log, Log):
        raise fail("log", "fit_log", "a Log (see read_log)", type(log).__name__)
    # every argument before the phaser is fitted: a refused call changes nothing the caller holds
    hyper = {k: v for k, v in dict(forgetting_factor=forgetting_factor, n_windows=n_windows).items() if v is not None}
    AdaptiveGaitModel(**hyper).validate()
    check_int(max_gait_order, "max_gait_order", "fit_log", minimum=1)
    if gait_order is not None:
        check_int(gait_order, "gait_order", "fit_log", minimum=0)
    if not isinstance(refit, bool | np.bool_):
        raise fail("refit", "fit_log", "True or False", refit)
    if phaser is not None and (not isinstance(phaser, Phaser) or phaser.__sklearn_is_fitted__()):
        raise fail("phaser", "fit_log", "an unfitted Phaser (fit_log fits it on the log)",
                   "a fitted Phaser" if isinstance(phaser, Phaser) else type(phaser).__name__)
    unwrapped, phaser = _unwrapped_phase(log, phaser, fit=True)
    rate = _phase_rate(log, unwrapped)
    log = log.with_phase(unwrapped)
    cycle = _cycles(unwrapped)
    test = _held_out(cycle, log.segment, fraction)
    _warn_if_still(log.body_velocity[test], "held-out sample", "fit_log")
    train = ~test
    nominal = fit_nominal_gait(log.phase[train], log.shape[train], order=gait_order, max_order=max_gait_order,
                               groups=cycle[train])
    hyper["phase_rate"] = rate
    evaluation = AdaptiveGaitModel(gait=nominal.gait, **hyper).fit(*_samples(log, train))
    model = evaluation
    if refit:
        gait = FourierGait.from_shapes(log.phase, log.shape, nominal.order)
        model = AdaptiveGaitModel(gait=gait, **hyper).fit(*_samples(log))
    return LogFit(log=log, unwrapped_phase=np.concatenate(unwrapped), cycle=cycle, test=test, phase_rate=rate,
                  phaser=phaser, nominal=nominal, evaluation_model=evaluation, model=model, refit=bool(refit))


# -- prediction ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class LogPrediction:
    """Result of :func:`predict_log`.

    Attributes
    ----------
    log : Log
        With the phase used.
    cycle : ndarray of shape (n,)
    prediction : ndarray of shape (n, 3)
        ξ̂ of the model.
    baseline : ndarray of shape (n, 3)
        The model's phase model ξ_T (the Γ baseline).
    measured : bool
        Whether ``log.body_velocity`` was measured (else it is zero and there is no Γ).
    phase_source : str
    """

    log: Log
    cycle: np.ndarray
    prediction: np.ndarray
    baseline: np.ndarray
    measured: bool
    phase_source: str

    def gamma(self) -> float | None:
        """Γ (eq. 5) over all samples, or None without measured body velocities."""
        if not self.measured:
            return None
        body = self.log.body_velocity
        return float(gamma(np.linalg.norm(self.prediction - body, axis=-1),
                           np.linalg.norm(self.baseline - body, axis=-1)))

    def to_pandas(self) -> pd.DataFrame:
        """row, segment, time, phase, cycle, predicted ξ, [measured ξ]."""
        columns = {"row": self.log.row, "segment": self.log.segment, "time": self.log.time, "phase": self.log.phase,
                   "cycle": self.cycle}
        columns.update(zip(PREDICTION_COLUMNS, self.prediction.T, strict=True))
        if self.measured:
            columns.update(zip(BODY_VELOCITY_COLUMNS, self.log.body_velocity.T, strict=True))
        return pd.DataFrame(columns)

    def summary(self) -> dict:
        """Γ overall and per cycle (None without measured ξ), counts and the phase source."""
        per_cycle = (_per_cycle(self.prediction, self.baseline, self.log.body_velocity, self.cycle, self.log.segment)
                     if self.measured else None)
        return {"gamma": self.gamma(), "gamma_per_cycle": per_cycle, "n_samples": self.log.n_samples,
                "n_segments": self.log.n_segments, "n_cycles": int(np.unique(self.cycle).size),
                "measured_body_velocity": self.measured, "phase_source": self.phase_source}

    def save(self, path, extra: dict | None = None, *, summary_path=None,
             protect: tuple = ()) -> tuple[Path, Path]:
        """Write the predictions as CSV to ``path`` and the Γ summary as JSON to ``summary_path``.

        Parameters
        ----------
        path : path-like
            Predictions CSV; its folder is created if missing.
        extra : dict, optional
            Added to the summary (e.g. the command line's options).
        summary_path : path-like, optional
            Default: ``path`` with suffix ``.json``, or ``<stem>.summary.json`` when ``path``
            itself ends in ``.json``.
        protect : tuple of path-like
            Files that must not be overwritten (the inputs); naming one of them as ``path`` or
            ``summary_path`` is an error, raised before anything is written.

        Returns
        -------
        (Path, Path)
            The CSV and the summary.
        """
        path = Path(path)
        summary_path = default_summary_path(path) if summary_path is None else Path(summary_path)
        check_outputs({"out": path, "summary": summary_path}, protect, "LogPrediction.save")
        path.parent.mkdir(parents=True, exist_ok=True)
        summary_path.parent.mkdir(parents=True, exist_ok=True)
        frame = self.to_pandas()
        write_text(path, frame.to_csv(index=False))
        write_json(summary_path, {**(extra or {}), "results": self.summary()})
        return path, summary_path


def predict_log(model: AdaptiveGaitModel, log: Log, *, phaser: Phaser | None = None,
                measured: bool = True) -> LogPrediction:
    """Predict the body velocity of every sample of a log with a fitted model.

    Parameters
    ----------
    model : AdaptiveGaitModel
        Fitted (e.g. ``geogait fit``'s model.npz); not changed.
    log : Log
    phaser : Phaser, optional
        Fitted; required when the log has no phase column (applied to whole segments).
    measured : bool
        Whether ``log.body_velocity`` holds measurements (False: no Γ).

    Returns
    -------
    LogPrediction
    """
    if not isinstance(model, AdaptiveGaitModel):
        raise fail("model", "predict_log", "an AdaptiveGaitModel", type(model).__name__)
    check_is_fitted(model)
    if model.n_joints_ != log.n_joints:
        raise fail("log", "predict_log", f"a log with {model.n_joints_} shape columns (the model's joints)",
                   f"{log.n_joints} shape columns")
    unwrapped, used = _unwrapped_phase(log, phaser, fit=False)
    _warn_on_rate_mismatch(log, unwrapped, float(model.phase_rate))
    warn_if_degrees(log.shape, "shape", "predict_log")  # (as the model warns when fit on such a log)
    if measured:
        _warn_if_still(log.body_velocity, "sample", "predict_log")
    log = log.with_phase(unwrapped)
    prediction = model.predict(log.phase, log.shape, log.shape_velocity)
    baseline = model.phase_model_.predict(log.phase)
    return LogPrediction(log=log, cycle=_cycles(unwrapped), prediction=prediction, baseline=baseline,
                         measured=bool(measured), phase_source="phase column" if used is None else "Phaser")


def _warn_if_still(body_velocity: np.ndarray, where: str, owner: str) -> None:
    """Warn when the measured body velocity Γ is scored on is zero throughout (Γ is then NaN or meaningless)."""
    if not np.any(body_velocity):
        warnings.warn(f"The measured body velocity of the log given to {owner} is zero at every {where}: the robot "
                      "stood still, so Γ says nothing about its motion (null where the model and the phase-model "
                      "baseline both predict the standstill exactly).", GeogaitWarning, stacklevel=3)


def _warn_on_rate_mismatch(log: Log, unwrapped: list[np.ndarray], expected: float) -> None:
    """Warn when the log's phase rate is 10× off the model's: time stamps in another unit than the fit's?"""
    advance = sum(float(u[-1] - u[0]) for u in unwrapped)
    duration = sum(float(part.time[-1] - part.time[0]) for part in log.segments())
    if duration <= 0 or advance <= 0:
        return
    ratio = advance / duration / expected
    if not 0.1 <= ratio <= 10:
        warnings.warn(f"The log's phase advances at {advance / duration:.4g} rad per time unit, {ratio:.3g} times the "
                      f"model's phase_rate {expected:.4g}: are its time stamps in another unit than the fitted log's "
                      "(time_unit, --time-unit s|ms|us|ns)?", GeogaitWarning, stacklevel=3)


def _per_cycle(predicted, baseline, measured, cycle, segment) -> list[dict]:
    model_error = np.linalg.norm(predicted - measured, axis=-1)
    baseline_error = np.linalg.norm(baseline - measured, axis=-1)
    rows = []
    for c in np.unique(cycle):
        mine = cycle == c
        rows.append({"cycle": int(c), "segment": int(segment[mine][0]), "n_samples": int(mine.sum()),
                     "gamma": float(gamma(model_error[mine], baseline_error[mine]))})
    return rows
