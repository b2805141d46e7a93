r"""Experiment 3 (paper Fig. 5): in-situ gait optimisation of the 3-, 5- and 9-link swimmers.

For each swimmer, ``n_trials`` seeded in-situ optimisations (:class:`~geogait.optimize.InSituOptimizer`,
budgets 40 / 60 / 60 cycles as in the paper; the paper's loop: steps from the model alone, with neither the
measured climb nor the revert to the best gait measured) and ``baseline_trials`` runs of the prior-work batch
method (30 perturbed cycles per iteration, batch refit, same step rule) with a budget of
``baseline_iterations`` iterations. Every run logs, per cycle, the *true* displacement per cycle of
the nominal gait being executed (oracle with the true connection), its net rotation and the online Γ.

Reported: 5/50/95 percentile bands of the relative improvement over the seed gait across trials,
final box plots (5/25/50/75/95), the ceiling (same gait family, objective and constraints optimised
with the true connection) and the batch baseline's median curve; panel A shows the 3-link gaits in
shape space over the height function.

Model (``model="auto"``): the shape-space connection model (:class:`~geogait.models.ShapeSpaceModel`)
of degree 4 with a prior that shrinks each higher degree 30× (``degree_shrinkage=30``) and the swimmers'
mirror and front–back symmetries built into its basis (``symmetry="mirror+reversal"``), forgetting factor
0.999 up to 5 links and 0.9999 beyond (3448 weights on 9 links need a longer memory). ``studies/ceiling.py``
compares it with the degree-3 model, the unconstrained shape-space model and the local window model
(:class:`~geogait.models.AdaptiveGaitModel`). The optimiser searches its default family: the rotation-free
symmetric family on these symmetric swimmers.

Why these defaults: sensor noise 0.1 of the signal RMS (with the 0.3 of the accuracy experiment the
3-link model's Γ saturates near 0.4 and never reaches Γ* = 1/2, so no step would ever be taken);
perturbation std 0.15 rad as everywhere else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._defaults import window_forgetting_factor
from .._docs import fill_doc
from .._validation import check_choice, check_float, check_int, fail
from ..gaits import FourierGait, Perturbation
from ..models import AdaptiveGaitModel, ShapeSpaceModel
from ..optimize import Gate, InSituOptimizer, cached_ceiling, paper_loop, prior_work, symmetric_chain_model
from ..plotting import plot_height_function, plot_shape_space, plt, save_figure
from ..simulate import SwimmerStream, cycle_displacement
from ._common import (
    PERCENTILES,
    ExperimentResult,
    box_stats,
    check_fraction,
    check_links,
    run_sweep,
    swimmer_and_gait,
)
from ._config import SweepConfig

__all__ = ["OptimizationConfig", "OptimizationResult", "default_budget", "optimization_trials", "run_optimization",
           "optimization_summary", "plot_optimization", "in_situ_model", "shape_method_model"]

_OWNER = "OptimizationConfig"
PAPER = {3: "≈ 50 % improvement in 40 cycles", 5: "(shown, no number in the text)",
         9: "top quartile > 80 % in 60 cycles; ≈ 10 cycles per link vs 900 cycles for the batch method"}


def default_budget(n_links: int) -> int:
    """The paper's cycle budget of an in-situ run: 40 cycles for the 3-link swimmer, 60 beyond."""
    return 40 if n_links <= 3 else 60


_LINKS = (3, 5, 9)
_BATCH_CYCLES = Gate().cycles  # cycles per batch-method iteration (Bittner 2018)


@dataclass(frozen=True)
class OptimizationConfig(SweepConfig):
    """Settings of the optimisation experiment (the one place its defaults live).

    Parameters
    ----------
    links : tuple of int
        Swimmers (number of links).
    n_trials : int
        In-situ optimisation trials per swimmer (paper: 50).
    budgets : tuple of int
        Cycle budget per swimmer, aligned with ``links`` (paper: 40, 60, 60).
    baseline_trials : int
        Batch-method trials per swimmer (0 to skip).
    baseline_iterations : int
        Batch-method iterations (30 cycles each; paper's prior work: 30 iterations = 900 cycles).
    sensor_noise, perturbation : float
        Measurement noise (fraction of RMS) and perturbation std (rad).
    gamma_threshold : float
        Γ*.
    model : {"auto", "adaptive", "shape"}
        Model of the in-situ runs: ``"auto"`` is the symmetric shape-space model, ``"shape"`` the
        shape-space model without symmetry, ``"adaptive"`` the window model (module docstring).
    seed : int
        Root seed; swimmer i uses ``seed + 1000 i`` so adding a swimmer leaves the others unchanged.
    chunk_size : int
        Trials per runner chunk.
    """

    links: tuple[int, ...] = _LINKS
    n_trials: int = 50
    budgets: tuple[int, ...] = tuple(map(default_budget, _LINKS))
    baseline_trials: int = 10
    baseline_iterations: int = 30
    sensor_noise: float = 0.1
    perturbation: float = 0.15
    gamma_threshold: float = 0.5
    model: str = "auto"
    seed: int = 0
    chunk_size: int = 1

    #: :meth:`quick`: 3-link only, 4 trials × 12 cycles, one short batch run: a few seconds.
    QUICK = {"links": (3,), "budgets": (12,), "n_trials": 4, "baseline_trials": 1, "baseline_iterations": 2}

    def _check_fields(self) -> None:
        for name in ("links", "budgets"):
            if not isinstance(getattr(self, name), tuple | list):
                raise fail(name, _OWNER, "a tuple (one entry per swimmer)", getattr(self, name))
        if len(self.links) != len(self.budgets) or not self.links:
            raise fail("budgets", _OWNER, f"one budget per swimmer in links = {self.links}", self.budgets)
        for n_links in self.links:
            check_links(n_links, "links", _OWNER, minimum=3)  # (one joint cannot move: nothing to optimise)
        for budget in self.budgets:
            check_int(budget, "budgets", _OWNER, minimum=1)
        check_int(self.n_trials, "n_trials", _OWNER, minimum=1)
        check_int(self.baseline_trials, "baseline_trials", _OWNER, minimum=0)
        check_int(self.baseline_iterations, "baseline_iterations", _OWNER, minimum=1)
        check_fraction(self.sensor_noise, "sensor_noise", _OWNER)
        check_fraction(self.perturbation, "perturbation", _OWNER)
        check_float(self.gamma_threshold, "gamma_threshold", _OWNER, high=1, high_open=True)
        check_choice(self.model, "model", _OWNER, ("auto", "adaptive", "shape"))


def in_situ_model(name: str, n_links: int):
    """The model of an in-situ run: ``"adaptive"``, ``"shape"`` or ``"auto"`` (module docstring)."""
    if name == "auto":
        return symmetric_chain_model(n_links - 1)
    if name == "shape":
        return ShapeSpaceModel(degree=3)
    return AdaptiveGaitModel(forgetting_factor=window_forgetting_factor(n_links - 1))


def shape_method_model(n_links: int, *, robot: bool = False, forgetting_factor: float | None = None):
    """The model of ``geogait optimize --method shape``: Fig. 5's symmetric shape-space model on the built-in
    swimmer; for a robot, whose symmetries are not known, degree 3 without symmetry (degree 4 without it
    would be 4 × the weights). ``forgetting_factor`` overrides λ (``--forgetting-factor``)."""
    model = ShapeSpaceModel(degree=3) if robot else in_situ_model("auto", n_links)
    return model if forgetting_factor is None else model.set_params(forgetting_factor=forgetting_factor)


def paper_optimizer(method: str, model: str, n_links: int, gamma_threshold: float) -> InSituOptimizer:
    """The paper's optimiser in the paper's setting (:func:`~geogait.optimize.paper_loop`): the simulated swimmer
    explores (eq. 8) and the optimiser does not command it; steps come from the model alone. ``method="batch"``:
    the prior work (:func:`~geogait.optimize.prior_work`) in the same setting."""
    if method == "batch":
        return prior_work(exploration=None)
    return paper_loop(model=in_situ_model(model, n_links), gate__gamma_threshold=gamma_threshold)


def optimization_trials(trial_indices, seeds, *, n_links: int, n_cycles: int, method: str, sensor_noise: float,
                        perturbation: float, gamma_threshold: float, ceiling: float,
                        model: str = "auto") -> pd.DataFrame:
    """Runner trial function: one in-situ (or batch-method) optimisation per trial.

    Parameters
    ----------
    trial_indices : sequence of int
        Trial indices of the chunk.
    seeds : sequence of numpy.random.SeedSequence
        One seed per trial (drives the simulated swimmer's perturbations and noise).
    n_links : int
        Links of the Purcell swimmer; the run starts from the paper's seed gait.
    n_cycles : int
        Cycle budget of each run.
    method : {"adaptive", "batch"}
        ``"batch"`` runs the prior-work batch method (:class:`~geogait.models.BatchGaitModel`); anything
        else the in-situ optimiser with the model chosen by ``model``.
    sensor_noise : float
        Std of the noise on measured ξ, as a fraction of its RMS.
    perturbation : float
        Stationary std (rad) of the shape perturbation δ of eq. 8.
    gamma_threshold : float
        Γ*: the optimiser steps only when the model's online Γ exceeds it.
    ceiling : float
        Ceiling objective value (the best gait with the true connection), for the log's ``ceiling_fraction``.
    model : {"auto", "adaptive", "shape"}, default "auto"
        Model of the in-situ runs (see :class:`OptimizationConfig`).

    Returns
    -------
    pandas.DataFrame
        One row per trial × cycle: ``trial``, ``links``, ``method``, ``cycle``, ``gamma``, ``step``,
        ``true_objective``, ``true_heading``, ``improvement``, ``ceiling_fraction`` and ``param_0`` …
        ``param_{p-1}`` (the nominal gait's flat parameter vector, one number per column).
    """
    system, gait = swimmer_and_gait(n_links, "optimization_trials")
    frames = []
    for trial, seed in zip(trial_indices, seeds, strict=True):
        stream = SwimmerStream(system, gait, perturbation=Perturbation.from_std(perturbation),
                               sensor_noise=sensor_noise, seed=seed)
        log = paper_optimizer(method, model, n_links, gamma_threshold).run(stream, n_cycles, ceiling=ceiling).log
        params = [c for c in log.columns if c.startswith("param_")]
        log = log[["cycle", "gamma", "step", "true_objective", "true_heading", "improvement", "ceiling_fraction",
                   *params]]
        frames.append(log.assign(trial=int(trial), links=n_links, method=method))
    return pd.concat(frames, ignore_index=True)


@dataclass(frozen=True)
class OptimizationResult(ExperimentResult):
    """Long-format per-cycle logs of every trial (see :func:`optimization_trials`).

    Parameters
    ----------
    frame : pandas.DataFrame
        Long-format results, with the columns of ``COLUMNS`` and ``param_0`` … ``param_{p-1}``.
    config : OptimizationConfig or None
        The configuration that produced ``frame``; None for results read back from a CSV.
    wall_time_s : float or None
        Wall-clock time of the sweep, seconds.
    n_workers : int or None
        Number of workers that ran the sweep.
    """

    COLUMNS = ("trial", "links", "method", "cycle", "gamma", "step", "true_objective", "true_heading",
               "improvement", "ceiling_fraction")
    VARIABLE_COLUMNS = "param_"  # param_0 … param_{p-1}; empty where a swimmer has fewer parameters

    def summary(self) -> dict:
        """Headline numbers per swimmer (:func:`optimization_summary`)."""
        return optimization_summary(self.frame)

    def plot(self, path):
        """Draw the figure to ``path`` (:func:`plot_optimization`)."""
        plot_optimization(self.frame, path)
        return path


@fill_doc
def run_optimization(config: OptimizationConfig | None = None, *, jobs: int = 1, scheduler=None,
                     progress: bool = True) -> OptimizationResult:
    """Run Experiment 3 for every swimmer of ``config``; see the module docstring.

    Parameters
    ----------
    config : OptimizationConfig, optional
        Default ``OptimizationConfig()``: the paper's 3-, 5- and 9-link studies.
    %(sweep)s

    Returns
    -------
    OptimizationResult
    """
    config = (config or OptimizationConfig()).validate()
    frames, wall, workers = [], 0.0, 1
    for index, (n_links, budget) in enumerate(zip(config.links, config.budgets, strict=True)):
        system, _ = swimmer_and_gait(n_links, "run_optimization")
        ceiling = cached_ceiling(system).value
        runs = [("adaptive", config.n_trials, budget),
                ("batch", config.baseline_trials, _BATCH_CYCLES * config.baseline_iterations)]
        for offset, (method, n_trials, cycles) in enumerate(runs):
            if n_trials == 0:
                continue
            options = dict(n_links=n_links, n_cycles=cycles, method=method, sensor_noise=config.sensor_noise,
                           perturbation=config.perturbation, gamma_threshold=config.gamma_threshold, ceiling=ceiling,
                           model=config.model)
            frame, seconds, workers = run_sweep(optimization_trials, n_trials, options,
                                                seed=config.seed + 1000 * index + offset, chunk_size=config.chunk_size,
                                                jobs=jobs, scheduler=scheduler, progress=progress,
                                                description=f"{n_links}-link {method}")
            frames.append(frame)
            wall += seconds
    frame = pd.concat(frames, ignore_index=True)
    frame = frame[list(OptimizationResult.COLUMNS) + _param_columns(frame)]
    return OptimizationResult(frame=frame, config=config, wall_time_s=wall, n_workers=workers)


def _param_columns(frame: pd.DataFrame) -> list[str]:
    """``param_0`` … in numeric order (the widest swimmer's count)."""
    return sorted((c for c in frame.columns if c.startswith("param_")), key=lambda c: int(c.removeprefix("param_")))


def _ceiling_improvement(n_links: int) -> float:
    system, gait = swimmer_and_gait(n_links, "optimization")
    seed_value = float(np.hypot(*cycle_displacement(system, gait)[:2]))
    return cached_ceiling(system).value / seed_value - 1


def _cycles_to_reach(frame: pd.DataFrame, level: float) -> float:
    """Cycles of experience until the median-over-trials improvement first reaches ``level`` (inf: never)."""
    median = frame.groupby("cycle")["improvement"].median()
    reached = median.index[median.to_numpy() >= level - 1e-12]
    return float(reached[0]) + 1 if len(reached) else np.inf


def optimization_summary(frame: pd.DataFrame) -> dict:
    """Headline numbers per swimmer, next to the paper's.

    Parameters
    ----------
    frame : pandas.DataFrame
        Per-cycle logs of :func:`optimization_trials` (``OptimizationResult.frame``).

    Returns
    -------
    dict
        One entry per swimmer (``"3-link"`` …): improvement percentiles, ceiling fraction, rotation and,
        when batch runs are present, the batch method's cycles to the same improvement.
    """
    summary = {}
    for n_links, group in frame.groupby("links"):
        adaptive = group[group["method"] == "adaptive"]
        last = adaptive[adaptive["cycle"] == adaptive["cycle"].max()]
        improvement = last["improvement"].to_numpy()
        fraction = last["ceiling_fraction"].to_numpy()
        within_30 = adaptive[adaptive["cycle"] < 30].groupby("trial")["ceiling_fraction"].max() >= 0.9
        entry = {
            "budget_cycles": int(adaptive["cycle"].max()) + 1,
            "trials": int(last["trial"].nunique()),
            "improvement_percentiles": dict(zip([f"p{p}" for p in PERCENTILES],
                                                np.percentile(improvement, PERCENTILES).round(4).tolist(),
                                                strict=True)),
            "median_ceiling_fraction": float(np.median(fraction)),
            "ceiling_improvement": _ceiling_improvement(int(n_links)),
            "share_of_trials_at_90pct_ceiling_within_30_cycles": float(within_30.mean()),
            "max_abs_rotation_of_commanded_gaits": {
                "median_over_trials": float(adaptive.groupby("trial")["true_heading"].apply(
                    lambda h: np.abs(h).max()).median()),
                "max": float(np.abs(adaptive["true_heading"]).max())},
            "paper": PAPER.get(int(n_links), ""),
        }
        batch = group[group["method"] == "batch"]
        if len(batch):
            target = float(np.median(improvement))
            needed = _cycles_to_reach(batch, target)
            adaptive_needed = _cycles_to_reach(adaptive, target)
            entry["batch"] = {"cycles_budget": int(batch["cycle"].max()) + 1,
                              "cycles_to_reach_adaptive_median_final_improvement": needed,
                              "adaptive_cycles_to_reach_it": adaptive_needed,
                              "ratio": needed / adaptive_needed if np.isfinite(needed) else np.inf,
                              "final_median_improvement": float(batch[batch["cycle"] == batch["cycle"].max()]
                                                                ["improvement"].median())}
        summary[f"{int(n_links)}-link"] = entry
    return summary


def plot_bands(ax, frame: pd.DataFrame, n_links: int):
    """Panel B–D: 5/50/95 % bands of improvement over cycles, final box, ceiling, batch median."""
    group = frame[frame["links"] == n_links]
    adaptive = group[group["method"] == "adaptive"]
    table = adaptive.groupby("cycle")["improvement"].quantile([0.05, 0.5, 0.95]).unstack()
    cycles = table.index.to_numpy() + 1
    ax.fill_between(cycles, 100 * table[0.05], 100 * table[0.95], color="tab:red", alpha=0.2, label="adaptive 5–95 %")
    ax.plot(cycles, 100 * table[0.5], color="tab:red", lw=1.8, label="adaptive median")
    batch = group[group["method"] == "batch"]
    if len(batch):
        median = batch.groupby("cycle")["improvement"].median()
        ax.plot(median.index + 1, 100 * median.to_numpy(), color="tab:green", lw=1.5, label="batch method median")
    ax.axhline(100 * _ceiling_improvement(n_links), color="k", ls="--", lw=1, label="ceiling (true connection)")
    final = adaptive[adaptive["cycle"] == adaptive["cycle"].max()]["improvement"].to_numpy() * 100
    budget = cycles.max()
    ax.bxp([box_stats(final, "")], positions=[budget * 1.3], widths=[budget * 0.25], showfliers=False,
           manage_ticks=False)
    ax.set_xscale("log")  # the batch method needs an order of magnitude more cycles
    ax.set_xlim(1, max(budget * 1.6, batch["cycle"].max() + 1 if len(batch) else 0))
    ax.set_xlabel("cycles of experience (log scale)")
    ax.set_ylabel("improvement over seed gait (%)")
    ax.set_title(f"{n_links}-link swimmer ({final.size} trials; box: final 5/25/50/75/95 %)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    return ax


def plot_gaits(ax, frame: pd.DataFrame):
    """Panel A: the 3-link seed gait, the median trial's final gait and the ceiling gait."""
    system, seed = swimmer_and_gait(3, "plot_gaits")
    ceiling = cached_ceiling(system)
    gaits = {"seed": seed, "ceiling": ceiling.gait}
    final = frame[(frame["links"] == 3) & (frame["method"] == "adaptive")]
    final = final[final["cycle"] == final["cycle"].max()]
    median_trial = final.iloc[(final["improvement"] - final["improvement"].median()).abs().argmin()]
    params = median_trial[_param_columns(frame)].dropna().to_numpy(float)
    gaits["optimised (median trial)"] = FourierGait.from_params(params, 2)
    limit = max(g.joint_limit().max() for g in gaits.values()) * 1.15
    direction = ceiling.displacement[:2] / np.hypot(*ceiling.displacement[:2])
    plot_height_function(ax, system, direction, limit)
    plot_shape_space(ax, None, gaits)
    ax.set_title("3-link gaits over the height function", fontsize=9)
    return ax


def plot_optimization(frame: pd.DataFrame, path):
    """The whole figure: panel A (if 3-link results) and one band panel per swimmer.

    Parameters
    ----------
    frame : pandas.DataFrame
        Per-cycle logs of :func:`optimization_trials` (``OptimizationResult.frame``).
    path : path-like
        Where the figure is saved; returned.
    """
    links = sorted(frame["links"].unique())
    panels = len(links) + (3 in links)
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.4))
    axes = np.atleast_1d(axes)
    if 3 in links:
        plot_gaits(axes[0], frame)
    for ax, n_links in zip(axes[int(3 in links):], links, strict=True):
        plot_bands(ax, frame, int(n_links))
    save_figure(fig, path)
    return path

