r"""Experiment 1 (paper Fig. 2): model accuracy versus experience, adaptive versus batch.

Protocol
--------
``n_trials`` perturbed trials of ``n_cycles`` cycles (paper: 200 × 40) form ``n_trials / 2``
train/test pairs. One runner trial is one pair: from the pair's seed ``s`` the training trial is
simulated with child seed 0 and the held-out test trial with child seed 1 (see
:func:`~geogait.experiments._common.child_seeds`), so every pair is reproducible on its own and
vectorised with the other pairs of its chunk.

* The **adaptive model** (RLS, λ = ``forgetting_factor``) learns the training trial cycle by
  cycle through ``partial_fit``, from no history; at every checkpoint n ∈ {5, 10, …, n_cycles}
  it is scored as it stands — never refit.
* The **batch model** at checkpoint n is the least-squares fit on the first n training cycles.
  ``BatchGaitModel.partial_fit`` accumulates the normal equations, so adding the next 5 cycles
  gives exactly the refit on all n cycles without recomputing the first n − 5.
* **Held-out Γ** (eq. 5): ``model.score`` on the whole test trial, each model against the phase
  model ξ_T fitted alongside it on the same training data (forgetting λ for the adaptive model,
  equal weights for the batch model). Using the batch model's equal-weight phase model for both
  changes the adaptive medians by less than 0.01.
* **Online Γ** (eq. 6, λ_Γ = 0.995 per sample) of the adaptive model on its own training stream,
  a-priori (each sample predicted before it is learned), recorded ``online_points_per_cycle``
  times per cycle: the continuous curve of the figure.

Why sensor noise 0.3 by default
-------------------------------
Without sensor noise the simulated swimmer is exactly principally kinematic and the local model's
regressors span its connection to second order, so Γ ≈ 0.98 after 5 cycles for both models:
a setting no real robot offers. Gaussian noise of 0.3 × the RMS of each body-velocity component
(the order of magnitude of motion capture / IMU velocity noise at a few samples per cycle) makes
Γ a statement about how much of the perturbation response a model recovers from noisy data, as
in the paper. Perturbations keep the default std 0.15 rad, 100 samples per cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.patches import Patch

from .._docs import fill_doc
from .._validation import check_float, check_int, fail
from ..gaits import Perturbation
from ..models import AdaptiveGaitModel, BatchGaitModel
from ..plotting import plt, save_figure
from ..simulate import simulate
from ._common import (
    PERCENTILES,
    ExperimentResult,
    box_stats,
    check_fraction,
    check_links,
    child_seeds,
    cycle_block,
    percentile_frame,
    run_sweep,
    swimmer_and_gait,
)
from ._config import SweepConfig, trial_function_options

__all__ = ["AccuracyConfig", "AccuracyResult", "accuracy_summary", "accuracy_trials", "plot_accuracy",
           "run_accuracy"]

_OWNER = "AccuracyConfig"
MODELS = ("adaptive", "batch")
COLORS = {"adaptive": "tab:red", "batch": "tab:green"}
PAPER_GAMMA_AT_5 = 0.4


@dataclass(frozen=True)
class AccuracyConfig(SweepConfig):
    """Settings of the accuracy experiment (the one place its defaults live).

    Parameters
    ----------
    n_links : int
        Links of the Purcell swimmer (3, 5 or 9 in the paper).
    n_trials : int
        Simulated trials, even: ``n_trials / 2`` train/test pairs (paper: 200).
    n_cycles : int
        Cycles per trial (paper: 40); training checkpoints every ``checkpoint_every`` cycles.
    checkpoint_every : int
        Spacing of the checkpoints n (paper: 5); must divide ``n_cycles``.
    samples_per_cycle : int
    sensor_noise : float
        Std of the noise on measured ξ, as a fraction of its RMS (see the module notes).
    perturbation : float
        Stationary std (rad) of the shape perturbation δ of eq. 8.
    forgetting_factor : float
        λ_RLS of the adaptive model.
    n_windows : int
        Phase windows of both models.
    online_points_per_cycle : int
        How often per cycle the online Γ is recorded.
    seed : int
        Root seed; pair i uses ``SeedSequence(seed).spawn(n_trials / 2)[i]``.
    chunk_size : int
        Pairs per runner chunk (vectorised together). Part of the result's identity: results are
        bit-identical for any worker count at a fixed chunk size.
    """

    n_links: int = 3
    n_trials: int = 200
    n_cycles: int = 40
    checkpoint_every: int = 5
    samples_per_cycle: int = 100
    sensor_noise: float = 0.3
    perturbation: float = 0.15
    forgetting_factor: float = 0.99
    n_windows: int = 20
    online_points_per_cycle: int = 4
    seed: int = 0
    chunk_size: int = 10

    #: :meth:`quick`: 16 trials × 10 cycles, a few seconds.
    QUICK = {"n_trials": 16, "n_cycles": 10, "chunk_size": 4}

    @property
    def n_pairs(self) -> int:
        """Number of train/test pairs (runner trials)."""
        return self.n_trials // 2

    @property
    def checkpoints(self) -> np.ndarray:
        """Training cycles n at which both models are scored."""
        return np.arange(self.checkpoint_every, self.n_cycles + 1, self.checkpoint_every)

    def _check_fields(self) -> None:
        check_links(self.n_links, "n_links", _OWNER)
        if check_int(self.n_trials, "n_trials", _OWNER, minimum=2) % 2:
            raise fail("n_trials", _OWNER, "an even int >= 2 (trials form train/test pairs)", self.n_trials)
        every = check_int(self.checkpoint_every, "checkpoint_every", _OWNER, minimum=1)
        if check_int(self.n_cycles, "n_cycles", _OWNER, minimum=1) % every:
            raise fail("n_cycles", _OWNER, f"a multiple of checkpoint_every = {every}", self.n_cycles)
        spc = check_int(self.samples_per_cycle, "samples_per_cycle", _OWNER, minimum=4)
        points = check_int(self.online_points_per_cycle, "online_points_per_cycle", _OWNER, minimum=1)
        if points > spc:
            raise fail("online_points_per_cycle", _OWNER, f"at most samples_per_cycle = {spc}", points)
        check_fraction(self.sensor_noise, "sensor_noise", _OWNER)
        check_fraction(self.perturbation, "perturbation", _OWNER)
        check_float(self.forgetting_factor, "forgetting_factor", _OWNER, low=0, high=1, low_open=True)
        check_int(self.n_windows, "n_windows", _OWNER, minimum=1)

    def trial_options(self) -> dict:
        """Keyword arguments of :func:`accuracy_trials`."""
        return trial_function_options(self)


@fill_doc
def accuracy_trials(trial_indices, seeds, *, n_links: int, n_cycles: int, checkpoint_every: int,
                    samples_per_cycle: int, sensor_noise: float, perturbation: float, forgetting_factor: float,
                    n_windows: int, online_points_per_cycle: int) -> pd.DataFrame:
    """Runner trial function: train/test pairs, vectorised across the pairs of a chunk.

    The keyword arguments are the fields of :class:`AccuracyConfig` other than ``n_trials``, ``seed`` and
    ``chunk_size``.

    Parameters
    ----------
    trial_indices : int ndarray of shape (n,)
        Pair indices of the chunk.
    seeds : list of n numpy.random.SeedSequence
        Pair seeds; child 0 drives the training trial, child 1 the test trial.
    n_links : int
        Links of the Purcell swimmer (3, 5 or 9); the seed gait is the paper's for that swimmer.
    n_cycles : int
        Cycles per trial (training and test trials alike).
    checkpoint_every : int
        Checkpoint spacing: every this many cycles the batch model re-solves on all training cycles so far
        and both models are scored (held-out Γ) on the test trial.
    %(simulation)s
    forgetting_factor : float in (0, 1]
        λ_RLS of the adaptive model.
    n_windows : int
        Phase windows of both models.
    online_points_per_cycle : int
        How many times per training cycle the adaptive model's online Γ is recorded.

    Returns
    -------
    pandas.DataFrame
        Columns ``trial`` (pair index), ``model`` (``adaptive``/``batch``), ``metric``
        (``held_out`` Γ on the test trial, or ``online`` Γ of the adaptive model),
        ``cycles`` (training cycles seen) and ``gamma``.
    """
    system, gait = swimmer_and_gait(n_links, "accuracy_trials")
    options = dict(samples_per_cycle=samples_per_cycle, perturbation=Perturbation.from_std(perturbation),
                   sensor_noise=sensor_noise)
    train = simulate(system, gait, n_cycles, seed=child_seeds(seeds, 0), **options)
    test = cycle_block(simulate(system, gait, n_cycles, seed=child_seeds(seeds, 1), **options), 0, n_cycles,
                       samples_per_cycle)
    adaptive = AdaptiveGaitModel(gait=gait, n_windows=n_windows, forgetting_factor=forgetting_factor)
    batch = BatchGaitModel(gait=gait, n_windows=n_windows)
    online_at = (np.arange(1, online_points_per_cycle + 1) * samples_per_cycle) // online_points_per_cycle - 1
    parts = []
    for cycle in range(n_cycles):
        adaptive.partial_fit(*cycle_block(train, cycle, cycle + 1, samples_per_cycle))
        seen = cycle + (online_at + 1) / samples_per_cycle
        parts.append(_rows(trial_indices, "adaptive", "online", seen, adaptive.online_gamma_[:, online_at]))
        if (cycle + 1) % checkpoint_every == 0:
            batch.partial_fit(*cycle_block(train, cycle + 1 - checkpoint_every, cycle + 1, samples_per_cycle))
            for name, model in (("adaptive", adaptive), ("batch", batch)):
                parts.append(_rows(trial_indices, name, "held_out", [cycle + 1.0], model.score(*test)[:, None]))
    return pd.concat(parts, ignore_index=True)


def _rows(trial_indices, model: str, metric: str, cycles, gamma: np.ndarray) -> pd.DataFrame:
    """Long rows for ``gamma`` of shape (n_trials, n_points) at ``cycles`` (n_points,)."""
    n_trials, n_points = gamma.shape
    return pd.DataFrame({"trial": np.repeat(np.asarray(trial_indices), n_points), "model": model,
                         "metric": metric, "cycles": np.tile(np.asarray(cycles, dtype=float), n_trials),
                         "gamma": gamma.ravel()})


@fill_doc
@dataclass(frozen=True)
class AccuracyResult(ExperimentResult):
    """Result of :func:`run_accuracy` (or of a CSV read back with :meth:`from_csv`).

    ``frame`` has one row per pair × model × checkpoint, columns ``trial, model, metric, cycles,
    gamma`` (see :func:`accuracy_trials`).

    Parameters
    ----------
    %(result_fields)s
    """

    COLUMNS = ("trial", "model", "metric", "cycles", "gamma")

    def summary(self) -> dict:
        """Headline numbers; see :func:`accuracy_summary`."""
        return accuracy_summary(self.frame)

    def plot(self, path):
        """Draw the figure to ``path``; see :func:`plot_accuracy`."""
        return plot_accuracy(self.frame, path)


@fill_doc
def run_accuracy(config: AccuracyConfig | None = None, *, jobs: int = 1, scheduler=None,
                 progress: bool = True) -> AccuracyResult:
    """Run the accuracy experiment (Fig. 2).

    Parameters
    ----------
    config : AccuracyConfig, optional
        Default ``AccuracyConfig()``: the paper's 200 trials × 40 cycles, 3-link swimmer.
    %(sweep)s

    Returns
    -------
    AccuracyResult

    Examples
    --------
    >>> config = AccuracyConfig.quick(n_trials=4, n_cycles=5, chunk_size=2)
    >>> result = run_accuracy(config, progress=False)
    >>> sorted(result.frame.query("metric == 'held_out'").model.unique())
    ['adaptive', 'batch']
    """
    config = (AccuracyConfig() if config is None else config).validate()
    frame, wall_time, n_workers = run_sweep(
        accuracy_trials, config.n_pairs, config.trial_options(), seed=config.seed, chunk_size=config.chunk_size,
        jobs=jobs, scheduler=scheduler, progress=progress, description="Fig. 2 accuracy (train/test pairs)")
    return AccuracyResult(frame=frame, config=config, wall_time_s=wall_time, n_workers=n_workers)


# --- summary ----------------------------------------------------------------------------------


def accuracy_summary(frame: pd.DataFrame) -> dict:
    """Headline numbers of the accuracy experiment.

    Parameters
    ----------
    frame : pandas.DataFrame
        Long-format results (:attr:`AccuracyResult.frame`).

    Returns
    -------
    dict
        ``n_pairs``; ``held_out_gamma[model][n]`` = percentiles ``p5 … p95`` of held-out Γ after
        n training cycles; ``online_gamma_median[n]`` = median online Γ after n cycles; and
        ``headline``: medians of both models at the first and last checkpoint, the fraction of
        pairs with adaptive Γ > 0.4 (the paper's claim) at the first checkpoint, and the median
        paired difference adaptive − batch with the fraction of pairs where adaptive is better.
    """
    held = frame[frame["metric"] == "held_out"]
    table = percentile_frame(held, ["model", "cycles"], "gamma")
    percentile_columns = [f"p{p}" for p in PERCENTILES]
    gamma = {model: {_key(row.cycles): {c: float(getattr(row, c)) for c in percentile_columns}
                     for row in part.itertuples()} for model, part in table.groupby("model")}
    online = frame[frame["metric"] == "online"]
    checkpoints = np.sort(held["cycles"].unique())
    online_median = online.groupby("cycles")["gamma"].median()
    wide = held.pivot_table(index=["trial", "cycles"], columns="model", values="gamma")
    headline = {}
    for n in (checkpoints[0], checkpoints[-1]):
        at = wide.xs(n, level="cycles")
        difference = at["adaptive"] - at["batch"]
        headline |= {f"adaptive_median_gamma_at_{_key(n)}": float(at["adaptive"].median()),
                     f"batch_median_gamma_at_{_key(n)}": float(at["batch"].median()),
                     f"median_paired_difference_at_{_key(n)}": float(difference.median()),
                     f"fraction_adaptive_better_at_{_key(n)}": float((difference > 0).mean())}
    first = wide.xs(checkpoints[0], level="cycles")["adaptive"]
    headline[f"fraction_adaptive_above_{PAPER_GAMMA_AT_5}_at_{_key(checkpoints[0])}"] = float(
        (first > PAPER_GAMMA_AT_5).mean())
    return {"n_pairs": int(held["trial"].nunique()), "checkpoints": [float(n) for n in checkpoints],
            "held_out_gamma": gamma,
            "online_gamma_median": {_key(n): float(online_median.loc[n]) for n in checkpoints
                                    if n in online_median.index},
            "headline": headline}


def _key(cycles) -> str:
    """'5' for 5.0, '2.5' for 2.5."""
    return f"{float(cycles):g}"


# --- figure -----------------------------------------------------------------------------------


def plot_gamma_boxes(ax, frame: pd.DataFrame):
    """Panel: held-out Γ per checkpoint, adaptive and batch side by side; boxes 25–75 %,
    whiskers 5–95 %, line at the median."""
    held = frame[frame["metric"] == "held_out"]
    checkpoints = np.sort(held["cycles"].unique())
    spacing = np.min(np.diff(checkpoints)) if checkpoints.size > 1 else float(checkpoints[0])
    width = 0.36 * spacing
    for offset, model in zip((-0.5 * width, 0.5 * width), MODELS, strict=True):
        groups = held[held["model"] == model].groupby("cycles")["gamma"]
        stats = [box_stats(groups.get_group(n), f"{n:g}") for n in checkpoints]
        ax.bxp(stats, positions=checkpoints + offset, widths=0.9 * width, showfliers=False, patch_artist=True,
               boxprops=dict(facecolor=COLORS[model], alpha=0.55, edgecolor=COLORS[model]),
               medianprops=dict(color="black", lw=1.5), whiskerprops=dict(color=COLORS[model]),
               capprops=dict(color=COLORS[model]), manage_ticks=False)
    ax.set_xticks(checkpoints, [f"{n:g}" for n in checkpoints])
    ax.set_xlim(0, checkpoints[-1] + spacing * 0.6)
    return ax


def plot_online_gamma(ax, frame: pd.DataFrame):
    """Panel: the adaptive model's online Γ (eq. 6) over its training stream, median with 25–75 %
    and 5–95 % bands across trials, and its held-out medians for reference."""
    online = percentile_frame(frame[frame["metric"] == "online"], ["cycles"], "gamma")
    x = online["cycles"].to_numpy()
    color = COLORS["adaptive"]
    ax.fill_between(x, online["p5"], online["p95"], color=color, alpha=0.12, lw=0, label="online Γ, 5–95 %")
    ax.fill_between(x, online["p25"], online["p75"], color=color, alpha=0.25, lw=0, label="online Γ, 25–75 %")
    ax.plot(x, online["p50"], color=color, lw=1.4, label="online Γ, median")
    held = frame[(frame["metric"] == "held_out") & (frame["model"] == "adaptive")].groupby("cycles")["gamma"].median()
    ax.plot(held.index, held.to_numpy(), "D", color=color, ms=4, mec="black", mew=0.5,
            label="held-out Γ median (top panel)")
    ax.axhline(0, color="0.3", lw=0.6)
    ax.set_xlabel("training cycles experienced, n")
    ax.set_ylabel("online Γ (eq. 6, a priori)")
    ax.set_title("Adaptive model's online Γ on its own training stream (λ_Γ = 0.995 per sample)", fontsize=10)
    ax.legend(loc="lower right", fontsize=8, ncols=2)
    ax.grid(alpha=0.3)
    return ax


def plot_accuracy(frame: pd.DataFrame, path):
    """Draw Fig. 2 from the long-format results ``frame`` to the PNG ``path`` (returned as a Path):
    held-out Γ box plots of both models (top) and the adaptive model's online Γ (bottom)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 8), sharex=True, height_ratios=(3, 2))
    plot_gamma_boxes(top, frame)
    top.axhline(PAPER_GAMMA_AT_5, color="0.4", lw=0.8, ls=":")
    top.set_ylabel("held-out Γ (eq. 5)")
    n_pairs = frame["trial"].nunique()
    top.set_title(f"Accuracy vs experience: Γ on a held-out trial ({n_pairs} train/test pairs)")
    handles = [Patch(facecolor=COLORS["adaptive"], alpha=0.55, label="adaptive (RLS), fed cycle by cycle"),
               Patch(facecolor=COLORS["batch"], alpha=0.55, label="batch (least squares on the first n cycles)"),
               plt.Line2D([], [], color="0.4", ls=":", label="paper: adaptive Γ > 0.4 after 5 cycles")]
    top.legend(handles=handles, loc="lower right", fontsize=8, title="boxes 25–75 %, whiskers 5–95 %, line median",
               title_fontsize=8)
    top.grid(axis="y", alpha=0.3)
    plot_online_gamma(bottom, frame)
    return save_figure(fig, path)
