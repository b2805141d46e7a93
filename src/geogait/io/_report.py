"""Figures of ``geogait fit``: one function per panel, each drawing on the ``Axes`` it is given."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..gaits import FourierGait
from ..plotting import plot_shape_space, plt, save_figure

__all__ = ["plot_body_velocity", "plot_gait_against_phase", "plot_phase", "write_fit_figures"]

_COMPONENTS = ("$v_x$", "$v_y$", r"$\omega$")
_MAX_POINTS = 4000
_SHOWN_CYCLES = 5


def _every(n: int) -> slice:
    """A stride that keeps at most ``_MAX_POINTS`` of ``n`` points."""
    return slice(None, None, max(1, n // _MAX_POINTS))


def plot_phase(ax, time, phase, test=None):
    """Phase in [0, 2π) against time ``(n,)``; held-out samples (``test`` mask) in a second colour."""
    time, phase = np.asarray(time), np.asarray(phase)
    test = np.zeros(time.shape, bool) if test is None else np.asarray(test)
    for mask, colour, label in ((~test, "C0", "training cycles"), (test, "C3", "held-out cycles")):
        if mask.any():
            keep = np.flatnonzero(mask)[_every(int(mask.sum()))]
            ax.plot(time[keep], phase[keep], ".", ms=1.5, color=colour, label=label)
    ax.set_xlabel("time")
    ax.set_ylabel("phase φ (rad)")
    ax.set_ylim(0, 2 * np.pi)
    ax.set_title("Estimated phase")
    ax.legend(loc="upper right", fontsize=8, markerscale=6)
    return ax


def plot_gait_against_phase(ax, phase, shape, gait: FourierGait):
    """Measured joint angles (points) and the nominal gait θ_j(φ) (lines) against phase."""
    phase, shape = np.asarray(phase), np.asarray(shape)
    keep = _every(phase.size)
    grid = np.linspace(0, 2 * np.pi, 200)
    nominal = gait.shape(grid)
    for j in range(shape.shape[1]):
        ax.plot(phase[keep], shape[keep, j], ".", ms=1, color=f"C{j % 10}", alpha=0.3)
        ax.plot(grid, nominal[:, j], "-", lw=1.8, color=f"C{j % 10}", label=f"joint {j + 1}")
    ax.set_xlabel("phase φ (rad)")
    ax.set_ylabel("joint angle (rad)")
    ax.set_title(f"Nominal gait (order {gait.order}) and data")
    ax.legend(fontsize=8, ncol=max(1, shape.shape[1] // 4))
    return ax


def plot_body_velocity(axes, time, measured, predicted, baseline=None):
    """One axis per component of ξ: measured, model prediction and phase-model baseline over time.

    Lines break where consecutive points are not consecutive samples (NaN rows in the inputs).
    """
    for k, ax in enumerate(axes):
        ax.plot(time, measured[:, k], color="0.6", lw=1.0, label="measured")
        ax.plot(time, predicted[:, k], color="C0", lw=1.2, label="model ξ̂")
        if baseline is not None:
            ax.plot(time, baseline[:, k], color="C3", lw=0.8, ls="--", label="phase model ξ_T")
        ax.set_ylabel(_COMPONENTS[k])
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[-1].set_xlabel("time")
    return axes


def _broken(index: np.ndarray, *arrays: np.ndarray) -> list[np.ndarray]:
    """Insert a NaN row wherever ``index`` jumps, so plotted lines do not bridge the jump."""
    cuts = np.flatnonzero(np.diff(index) > 1) + 1
    return [np.insert(np.asarray(a, dtype=float), cuts, np.nan, axis=0) for a in arrays]


def write_fit_figures(fit, folder) -> dict[str, Path]:
    """phase.png, nominal_gait.png and body_velocity.png of a :class:`~geogait.io.LogFit`."""
    folder = Path(folder)
    paths = {}
    fig, ax = plt.subplots(figsize=(8, 3.2))
    plot_phase(ax, fit.log.time, fit.log.phase, fit.test)
    save_figure(fig, paths.setdefault("phase_figure", folder / "phase.png"))
    train = ~fit.test
    two = fit.log.n_joints >= 2
    fig, axes = plt.subplots(1, 2 if two else 1, figsize=(11 if two else 6, 4.2), squeeze=False)
    plot_gait_against_phase(axes[0, 0], fit.log.phase[train], fit.log.shape[train], fit.nominal.gait)
    if two:
        plot_shape_space(axes[0, 1], fit.log.shape[train][_every(int(train.sum()))], {"nominal gait": fit.nominal.gait})
    save_figure(fig, paths.setdefault("gait_figure", folder / "nominal_gait.png"))
    data = fit.held_out()
    shown = data["cycle"] < np.unique(data["cycle"])[:_SHOWN_CYCLES].max() + 1
    time, measured, predicted, baseline = _broken(data["index"][shown], data["time"][shown], data["measured"][shown],
                                                  data["predicted"][shown], data["baseline"][shown])
    fig, axes = plt.subplots(3, 1, figsize=(9, 6.5), sharex=True)
    plot_body_velocity(axes, time, measured, predicted, baseline)
    axes[0].set_title(f"Held-out body velocity (first {min(_SHOWN_CYCLES, np.unique(data['cycle']).size)} held-out "
                      f"cycles), Γ = {fit.held_out_gamma():.3f}")
    save_figure(fig, paths.setdefault("body_velocity_figure", folder / "body_velocity.png"))
    return paths
