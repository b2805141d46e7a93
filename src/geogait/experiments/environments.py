r"""Experiment 2 (paper Fig. 3): adaptation to unannounced changes of the environment.

Protocol
--------
Each trial runs the seed gait with perturbations for ``cycles_per_environment`` cycles at each
drag ratio of ``drag_ratios`` (paper: 40 cycles each at k = 2, 3, 4), switching without telling
the models (:class:`~geogait.simulate.DragRatioSchedule`). Trials of a runner chunk are simulated
and learned together (one seed sequence per trial, leading trial axis in every model).

Models, all learning from the noisy measurements from cycle 0 on:

* **adaptive** RLS models with each λ of ``forgetting_factors`` (paper: 0.99 and 0.7), updated
  with every sample for the whole run;
* the **batch** model, least squares on the first environment only (its first
  ``cycles_per_environment`` cycles), never refit afterwards.

Prediction error
----------------
For cycle c ≥ 1 and each model, the error is the mean over the cycle's samples of
‖ξ̂ − ξ‖, where ξ̂ = ``model.predict`` of the cycle's measured shapes and shape velocities by the
model *as it stood at the start of cycle c* (a priori: no model has seen the cycle it predicts),
and ξ = −A_k(r) ṙ is the noise-free body velocity of the environment in force (known in
simulation; shapes are measured without noise). During the first environment the batch model
predicting cycle c is the least-squares fit on cycles 0 … c − 1 (a-priori cycle-by-cycle refit,
the same footing as the adaptive models); from the first switch on it is the frozen fit on the
whole first environment. Cycle 0 has no a-priori prediction and is not reported.
``error_measured`` is the same mean against the noisy measured ξ, which is all a robot sees: with
realistic sensor noise it is dominated by the noise floor, which is why ``error`` is the
figure's quantity.

Why no sensor noise by default
------------------------------
Fig. 3 asks how fast each model re-learns, and changing k from 2 to 3 moves ξ by only a few per cent
of ‖ξ‖. With Fig. 2's realistic 0.3 × RMS noise, the λ = 0.99 model's own estimation error is as
large as that change, so no model's error even doubles at a switch and every "recovery" is
immediate, while the λ = 0.7 model (a few effective samples per window for 1 + 2d + d² weights)
follows the noise throughout. Without noise the switches,
the adaptation and the λ trade-off the paper describes are all visible; ``--noise 0.3`` gives the
realistic-noise version (both in docs/results/paper-figures.md).

Recovery after a switch
-----------------------
With e_pre the model's mean error over the ``reference_cycles`` cycles before a switch, the
recovery time is the number of cycles of experience in the new environment after which the
model's a-priori error is first back within ``factor`` × e_pre (0 when the first cycle after the
switch already is; "never" when it is not before the next switch or the end). It is reported on
the median error curve across trials and per trial (median and fraction of trials recovered).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.patches import Patch

from .._docs import fill_doc
from .._validation import check_float, check_int, fail
from ..gaits import Perturbation
from ..models import AdaptiveGaitModel, BatchGaitModel
from ..plotting import plt, save_figure
from ..simulate import DragRatioSchedule, simulate
from ._common import (
    ExperimentResult,
    check_fraction,
    check_links,
    cycle_block,
    percentile_frame,
    run_sweep,
    swimmer_and_gait,
)
from ._config import SweepConfig, trial_function_options

__all__ = ["EnvironmentConfig", "EnvironmentResult", "environment_summary", "environment_trials",
           "plot_environments", "recovery_table", "run_environments"]

_OWNER = "EnvironmentConfig"
RECOVERY_FACTOR = 2.0
REFERENCE_CYCLES = 5
_ADAPTIVE_COLORS = ("tab:blue", "tab:orange", "tab:purple", "tab:brown", "tab:pink")


@dataclass(frozen=True)
class EnvironmentConfig(SweepConfig):
    """Settings of the changing-environment experiment (the one place its defaults live).

    Parameters
    ----------
    n_links : int
        Links of the Purcell swimmer.
    n_trials : int
        Independent trials (the paper does not give its count; 100 by default).
    drag_ratios : tuple of float
        Drag ratio k of each environment, in order (paper: 2, 3, 4).
    cycles_per_environment : int
        Cycles spent in each environment (paper: 40); also the batch model's training cycles.
    samples_per_cycle : int
    sensor_noise : float
        Std of the noise on measured ξ as a fraction of its RMS; 0 by default (see the module
        notes: with Fig. 2's 0.3 the change of drag ratio is buried in estimation noise).
    perturbation : float
        Stationary std (rad) of the shape perturbation δ of eq. 8.
    forgetting_factors : tuple of float
        λ_RLS of the adaptive models (paper: 0.99 and 0.7).
    n_windows : int
        Phase windows of every model.
    seed : int
        Root seed; trial i uses ``SeedSequence(seed).spawn(n_trials)[i]``.
    chunk_size : int
        Trials per runner chunk (vectorised together).
    """

    n_links: int = 3
    n_trials: int = 100
    drag_ratios: tuple[float, ...] = (2.0, 3.0, 4.0)
    cycles_per_environment: int = 40
    samples_per_cycle: int = 100
    sensor_noise: float = 0.0
    perturbation: float = 0.15
    forgetting_factors: tuple[float, ...] = (0.99, 0.7)
    n_windows: int = 20
    seed: int = 0
    chunk_size: int = 10

    #: :meth:`quick`: 8 trials, 15 cycles per environment, seconds.
    QUICK = {"n_trials": 8, "cycles_per_environment": 15, "chunk_size": 4}

    @property
    def n_cycles(self) -> int:
        """Cycles per trial."""
        return len(self.drag_ratios) * self.cycles_per_environment

    def _check_fields(self) -> None:
        check_links(self.n_links, "n_links", _OWNER)
        check_int(self.n_trials, "n_trials", _OWNER, minimum=1)
        if not isinstance(self.drag_ratios, tuple) or len(self.drag_ratios) < 2:
            raise fail("drag_ratios", _OWNER, "a tuple of at least two drag ratios", self.drag_ratios)
        for value in self.drag_ratios:
            check_float(value, "drag_ratios", _OWNER, low=1e-6, high=1e6)  # (the swimmer's own bounds)
        check_int(self.cycles_per_environment, "cycles_per_environment", _OWNER, minimum=REFERENCE_CYCLES + 1)
        check_int(self.samples_per_cycle, "samples_per_cycle", _OWNER, minimum=4)
        check_fraction(self.sensor_noise, "sensor_noise", _OWNER)
        check_fraction(self.perturbation, "perturbation", _OWNER)
        if not isinstance(self.forgetting_factors, tuple) or not self.forgetting_factors:
            raise fail("forgetting_factors", _OWNER, "a non-empty tuple of floats in (0, 1]", self.forgetting_factors)
        for value in self.forgetting_factors:
            check_float(value, "forgetting_factors", _OWNER, low=0, high=1, low_open=True)
        names = [adaptive_name(value) for value in self.forgetting_factors]
        if len(set(names)) < len(names):  # (the models are keyed by it: two would be one)
            raise fail("forgetting_factors", _OWNER, "factors that differ in their 6 significant digits (each names "
                       "its model)", self.forgetting_factors)
        check_int(self.n_windows, "n_windows", _OWNER, minimum=1)

    def trial_options(self) -> dict:
        """Keyword arguments of :func:`environment_trials`."""
        return trial_function_options(self)


def adaptive_name(forgetting_factor: float) -> str:
    """Model id of an adaptive model in the results, e.g. ``adaptive_0.99``."""
    return f"adaptive_{forgetting_factor:g}"


@fill_doc
def environment_trials(trial_indices, seeds, *, n_links: int, drag_ratios, cycles_per_environment: int,
                       samples_per_cycle: int, sensor_noise: float, perturbation: float, forgetting_factors,
                       n_windows: int) -> pd.DataFrame:
    """Runner trial function: one run through every environment per trial, trials vectorised.

    The keyword arguments are the fields of :class:`EnvironmentConfig` other than ``n_trials``, ``seed`` and
    ``chunk_size``.

    Parameters
    ----------
    trial_indices : int ndarray of shape (n,)
        Trial indices of the chunk.
    seeds : list of n numpy.random.SeedSequence
        One seed per trial.
    n_links : int
        Links of the Purcell swimmer; the seed gait is the paper's for that swimmer.
    drag_ratios : sequence of float
        Drag ratio k of each environment, in order (:class:`~geogait.simulate.DragRatioSchedule`).
    cycles_per_environment : int
        Cycles spent in each environment.
    %(simulation)s
    forgetting_factors : sequence of float
        λ_RLS of each adaptive model (one model per value).
    n_windows : int
        Phase windows of every model.

    Returns
    -------
    pandas.DataFrame
        One row per trial × model × cycle ≥ 1: ``trial, model, cycle, environment, drag_ratio,
        error, error_measured`` (see the module notes for the error's definition).
    """
    system, gait = swimmer_and_gait(n_links, "environment_trials")
    schedule = DragRatioSchedule(system, tuple(drag_ratios), cycles_per_environment)
    n_cycles = len(drag_ratios) * cycles_per_environment
    run = simulate(system, gait, n_cycles, samples_per_cycle=samples_per_cycle, sensor_noise=sensor_noise,
                   perturbation=Perturbation.from_std(perturbation), environment=schedule, seed=list(seeds))
    models = {adaptive_name(lam): AdaptiveGaitModel(gait=gait, n_windows=n_windows, forgetting_factor=lam)
              for lam in forgetting_factors}
    models["batch"] = BatchGaitModel(gait=gait, n_windows=n_windows)
    parts = []
    for cycle in range(n_cycles):
        phase, shape, shape_velocity, measured = cycle_block(run, cycle, cycle + 1, samples_per_cycle)
        truth = -np.einsum("...ij,...j->...i", schedule(cycle).connection(shape), shape_velocity)
        for name, model in models.items():
            if cycle > 0:
                predicted = model.predict(phase, shape, shape_velocity)
                parts.append(_rows(trial_indices, name, cycle, schedule, _mean_error(predicted, truth),
                                   _mean_error(predicted, measured)))
            if name != "batch" or cycle < cycles_per_environment:
                model.partial_fit(phase, shape, shape_velocity, measured)
    return pd.concat(parts, ignore_index=True)


def _mean_error(predicted: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Mean over samples of ‖predicted − target‖, shape (n_trials,)."""
    return np.linalg.norm(predicted - target, axis=-1).mean(axis=-1)


def _rows(trial_indices, model: str, cycle: int, schedule: DragRatioSchedule, error, error_measured):
    environment = schedule.environment(cycle)
    return pd.DataFrame({"trial": np.asarray(trial_indices), "model": model, "cycle": cycle,
                         "environment": environment + 1, "drag_ratio": schedule.drag_ratios[environment],
                         "error": error, "error_measured": error_measured})


@fill_doc
@dataclass(frozen=True)
class EnvironmentResult(ExperimentResult):
    """Result of :func:`run_environments` (or of a CSV read back with :meth:`from_csv`).

    ``frame`` has one row per trial × model × cycle, columns ``trial, model, cycle, environment,
    drag_ratio, error, error_measured`` (see :func:`environment_trials`).

    Parameters
    ----------
    %(result_fields)s
    """

    COLUMNS = ("trial", "model", "cycle", "environment", "drag_ratio", "error", "error_measured")

    def summary(self) -> dict:
        """Headline numbers; see :func:`environment_summary`."""
        return environment_summary(self.frame)

    def recovery(self) -> pd.DataFrame:
        """Per-trial recovery after every switch; see :func:`recovery_table`."""
        return recovery_table(self.frame)

    def plot(self, path):
        """Draw the figure to ``path``; see :func:`plot_environments`."""
        return plot_environments(self.frame, path)


@fill_doc
def run_environments(config: EnvironmentConfig | None = None, *, jobs: int = 1, scheduler=None,
                     progress: bool = True) -> EnvironmentResult:
    """Run the changing-environment experiment (Fig. 3).

    Parameters
    ----------
    config : EnvironmentConfig, optional
        Default ``EnvironmentConfig()``: 100 trials, 40 cycles each at k = 2, 3, 4.
    %(sweep)s

    Returns
    -------
    EnvironmentResult

    Examples
    --------
    >>> config = EnvironmentConfig.quick(n_trials=2, cycles_per_environment=6, chunk_size=2)
    >>> result = run_environments(config, progress=False)
    >>> sorted(result.frame.model.unique()), int(result.frame.cycle.max())
    (['adaptive_0.7', 'adaptive_0.99', 'batch'], 17)
    """
    config = (EnvironmentConfig() if config is None else config).validate()
    frame, wall_time, n_workers = run_sweep(
        environment_trials, config.n_trials, config.trial_options(), seed=config.seed,
        chunk_size=config.chunk_size, jobs=jobs, scheduler=scheduler, progress=progress,
        description="Fig. 3 changing environments (trials)")
    return EnvironmentResult(frame=frame, config=config, wall_time_s=wall_time, n_workers=n_workers)


# --- recovery and summary ---------------------------------------------------------------------


def _switches(frame: pd.DataFrame) -> pd.DataFrame:
    """First cycle of every environment after the first, with the drag ratios around it."""
    by_cycle = frame.groupby("cycle")[["environment", "drag_ratio"]].first().sort_index()
    changed = by_cycle["environment"].diff().fillna(0).to_numpy() != 0
    starts = by_cycle.index[changed]
    before = by_cycle["drag_ratio"].shift(1)[changed]
    return pd.DataFrame({"switch": np.arange(1, changed.sum() + 1), "switch_cycle": starts.to_numpy(),
                         "from_ratio": before.to_numpy(), "to_ratio": by_cycle["drag_ratio"][changed].to_numpy()})


def _recovery(errors: np.ndarray, cycles: np.ndarray, start: int, stop: int, factor: float,
              reference_cycles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Recovery of error curves ``(k, n_cycles)`` at the switch to cycle ``start`` (until ``stop``).

    Returns the pre-switch error (k,), the first post-switch error over it (k,), and the cycles
    of experience until back within ``factor`` × pre-switch error (k,; NaN for never).
    """
    at = np.searchsorted(cycles, start)
    until = np.searchsorted(cycles, stop)
    pre = errors[:, max(at - reference_cycles, 0):at].mean(axis=1)
    post = errors[:, at:until]
    within = post <= factor * pre[:, None]
    recovered = np.where(within.any(axis=1), within.argmax(axis=1), np.nan)
    return pre, post[:, 0] / pre, recovered


def recovery_table(frame: pd.DataFrame, *, factor: float = RECOVERY_FACTOR,
                   reference_cycles: int = REFERENCE_CYCLES) -> pd.DataFrame:
    """Recovery of every trial and model after every environment switch.

    Parameters
    ----------
    frame : pandas.DataFrame
        Long-format results (:attr:`EnvironmentResult.frame`).
    factor : float
        Recovered once the error is within ``factor`` × the pre-switch error.
    reference_cycles : int
        Cycles before the switch averaged into the pre-switch error.

    Returns
    -------
    pandas.DataFrame
        One row per model × trial × switch: ``model, trial, switch, switch_cycle, from_ratio,
        to_ratio, pre_switch_error, jump`` (first post-switch error / pre-switch error) and
        ``recovery_cycles`` (NaN: never within the environment).
    """
    wide = frame.pivot(index=["model", "trial"], columns="cycle", values="error").sort_index(axis=1)
    return _recovery_rows(wide, frame, factor, reference_cycles)


def _recovery_rows(wide: pd.DataFrame, frame: pd.DataFrame, factor: float, reference_cycles: int) -> pd.DataFrame:
    """Recovery rows of error curves ``wide`` (index: curves; columns: cycles)."""
    cycles = wide.columns.to_numpy()
    switches = _switches(frame)
    stops = list(switches["switch_cycle"].iloc[1:]) + [cycles[-1] + 1]
    parts = []
    for switch, stop in zip(switches.itertuples(index=False), stops, strict=True):
        pre, jump, recovered = _recovery(wide.to_numpy(), cycles, switch.switch_cycle, stop, factor,
                                         reference_cycles)
        part = wide.index.to_frame(index=False)
        parts.append(part.assign(**switch._asdict(), pre_switch_error=pre, jump=jump, recovery_cycles=recovered))
    return pd.concat(parts, ignore_index=True)


def _median_curves(frame: pd.DataFrame) -> pd.DataFrame:
    """Median error across trials per model (rows) and cycle (columns)."""
    return frame.groupby(["model", "cycle"])["error"].median().unstack("cycle").sort_index(axis=1)


def environment_summary(frame: pd.DataFrame, *, factor: float = RECOVERY_FACTOR,
                        reference_cycles: int = REFERENCE_CYCLES) -> dict:
    """Headline numbers of the changing-environment experiment.

    Parameters
    ----------
    frame : pandas.DataFrame
        Long-format results.
    factor, reference_cycles
        As in :func:`recovery_table`.

    Returns
    -------
    dict
        ``n_trials``, ``switches`` (cycle and drag ratios), ``settled_error[model][env]`` (median
        over trials of the mean error over the last ``reference_cycles`` cycles of each
        environment), ``recovery[model][switch]`` (on the median curve: pre-switch error, jump,
        recovery cycles or "never"; per trial: median recovery cycles or "never" and the
        fraction of trials that recovered), and a flat ``headline`` of recovery cycles.
    """
    switches = _switches(frame)
    median_rows = _recovery_rows(_median_curves(frame), frame, factor, reference_cycles)
    trial_rows = recovery_table(frame, factor=factor, reference_cycles=reference_cycles)
    recovery, headline = {}, {}
    for row in median_rows.itertuples(index=False):
        trials = trial_rows[(trial_rows["model"] == row.model) & (trial_rows["switch"] == row.switch)]
        per_trial = trials["recovery_cycles"].fillna(np.inf)
        entry = {"pre_switch_error": float(row.pre_switch_error), "jump": float(row.jump),
                 "recovery_cycles_median_curve": _cycles(row.recovery_cycles),
                 "recovery_cycles_median_trial": _cycles(per_trial.median()),
                 "fraction_of_trials_recovered": float(trials["recovery_cycles"].notna().mean())}
        recovery.setdefault(row.model, {})[f"switch_{row.switch}"] = entry
        headline[f"{row.model}_recovery_cycles_switch_{row.switch}"] = entry["recovery_cycles_median_curve"]
    return {"n_trials": int(frame["trial"].nunique()), "factor": factor, "reference_cycles": reference_cycles,
            "switches": switches.to_dict(orient="records"), "settled_error": _settled_errors(frame, reference_cycles),
            "recovery": recovery, "headline": headline}


def _settled_errors(frame: pd.DataFrame, reference_cycles: int) -> dict:
    """Median over trials of each trial's mean error over the last cycles of each environment."""
    last = frame.groupby("environment")["cycle"].transform("max")
    tail = frame[frame["cycle"] > last - reference_cycles]
    per_trial = tail.groupby(["model", "environment", "trial"])["error"].mean()
    medians = per_trial.groupby(["model", "environment"]).median()
    return {model: {f"env_{env}": float(value) for (_, env), value in part.items()}
            for model, part in medians.groupby(level="model")}


def _cycles(value):
    """Recovery cycles as an int, or "never" for NaN / inf."""
    return "never" if not np.isfinite(value) else int(round(float(value)))


# --- figure -----------------------------------------------------------------------------------


def _styles(models) -> dict[str, tuple[str, str]]:
    """(colour, label) per model id: paper colours, blue λ = 0.99, orange λ = 0.7, green batch."""
    adaptive = sorted((m for m in models if m != "batch"), key=lambda m: -float(m.split("_")[1]))
    colours = itertools.cycle(_ADAPTIVE_COLORS + ("tab:gray", "tab:olive", "tab:cyan", "tab:red"))  # (every model)
    styles = {m: (c, f"adaptive, λ = {m.split('_')[1]}") for m, c in zip(adaptive, colours, strict=False)}
    if "batch" in models:
        styles["batch"] = ("tab:green", "batch, fit on environment 1 only")
    return styles


def plot_error_bands(ax, frame: pd.DataFrame):
    """Panel: per-cycle median prediction error of every model, with 25–75 % and 5–95 % bands
    across trials, on a log scale."""
    table = percentile_frame(frame, ["model", "cycle"], "error")
    for model, (color, label) in _styles(frame["model"].unique()).items():
        part = table[table["model"] == model]
        x = part["cycle"].to_numpy()
        ax.fill_between(x, part["p5"], part["p95"], color=color, alpha=0.1, lw=0)
        ax.fill_between(x, part["p25"], part["p75"], color=color, alpha=0.22, lw=0)
        ax.plot(x, part["p50"], color=color, lw=1.5, label=f"{label} (median)")
    ax.set_yscale("log")
    ax.set_xlabel("gait cycle")
    ax.set_ylabel("a-priori prediction error ‖ξ̂ − ξ‖\n(mean per cycle, log scale)")
    ax.grid(alpha=0.3, which="both")
    return ax


def mark_switches(ax, frame: pd.DataFrame):
    """Panel overlay: dashed lines at the unannounced environment switches, environments named."""
    spans = frame.groupby("environment").agg(start=("cycle", "min"), stop=("cycle", "max"),
                                             ratio=("drag_ratio", "first"))
    for environment, span in spans.iterrows():
        if environment > spans.index.min():
            ax.axvline(span.start - 0.5, color="black", ls="--", lw=1)
        ax.text((span.start + span.stop) / 2, 1.01, f"env {environment}: drag ratio k = {span.ratio:g}",
                transform=ax.get_xaxis_transform(), ha="center", va="bottom", fontsize=9)
    return ax


def plot_environments(frame: pd.DataFrame, path):
    """Draw Fig. 3 from the long-format results ``frame`` to the PNG ``path`` (returned as a Path): log
    prediction error over time through the environment switches."""
    fig, ax = plt.subplots(figsize=(10, 5))
    plot_error_bands(ax, frame)
    mark_switches(ax, frame)
    handles, _ = ax.get_legend_handles_labels()
    handles += [plt.Line2D([], [], color="black", ls="--", lw=1, label="unannounced environment switch"),
                Patch(facecolor="0.5", alpha=0.35, label="bands: 25–75 % and 5–95 % of trials")]
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, ncols=3)
    n_trials = frame["trial"].nunique()
    ax.set_title(f"Adaptation to changing environments ({n_trials} trials)", pad=18)
    return save_figure(fig, path)
