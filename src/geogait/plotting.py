"""Every figure panel geogait draws outside the paper's experiments (the CLI's runs, log fits): one function
per panel, each drawing on an ``Axes`` it is given and returning it.

Importing geogait never changes the matplotlib backend: the CLI selects Agg (it only writes
files); in a notebook or script the user's backend is used.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from ._files import atomic_write
from .gaits import FourierGait
from .systems import height_function

__all__ = ["plot_body_velocity", "plot_gait_against_phase", "plot_height_function", "plot_joint_angles", "plot_path",
           "plot_phase", "plot_progress", "plot_shape_space", "plt", "save_figure", "write_fit_figures"]


def plot_path(ax, pose, *, label=None, color="k"):
    """Swimmer path in the plane: positions ``(n, 3)`` poses, start (open circle) and end (filled) marked and named."""
    pose = np.asarray(pose)
    ax.plot(pose[:, 0], pose[:, 1], color=color, lw=1.2, label=label)
    ax.plot(pose[0, 0], pose[0, 1], "o", mfc="white", mec=color, ms=7)
    ax.plot(pose[-1, 0], pose[-1, 1], "o", color=color, ms=7)
    for point, name in ((pose[0, :2], "start"), (pose[-1, :2], "end")):
        ax.annotate(name, xy=point, xytext=(6, 6), textcoords="offset points", fontsize=8, color=color)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (body lengths)")
    ax.set_ylabel("y (body lengths)")
    ax.set_title("Path in the plane")
    return ax


def plot_shape_space(ax, shape=None, gaits: dict[str, FourierGait] | None = None, joints=(0, 1)):
    """Measured shapes (grey points) and nominal gait loops in the plane of two joints."""
    i, j = joints
    if shape is not None:
        shape = np.asarray(shape)
        ax.plot(shape[:, i], shape[:, j], ".", color="0.7", ms=1.5, label="measured shape")
    phase = np.linspace(0, 2 * np.pi, 200)
    styles = [("k", "-"), ("C3", "-"), ("C0", "--"), ("C2", ":")]
    for k, (name, gait) in enumerate((gaits or {}).items()):  # (beyond four: the colour cycle, solid)
        color, line = styles[k] if k < len(styles) else (f"C{k}", "-")
        loop = gait.shape(phase)
        ax.plot(loop[:, i], loop[:, j], color=color, ls=line, lw=1.8, label=name)
        ax.plot(loop[0, i], loop[0, j], "o", color=color, ms=4)  # where the gait starts (φ = 0)
    ax.set_xlabel(f"joint angle $r_{i + 1}$ (rad)")
    ax.set_ylabel(f"joint angle $r_{j + 1}$ (rad)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("Shape space")
    return ax


def save_figure(fig, path) -> Path:
    """Write ``fig`` to ``path`` atomically (format from the suffix, 130 dpi), close it, return the path."""
    fig.tight_layout()
    path = Path(path)
    try:
        fmt = path.suffix.lstrip(".").lower() or "png"
        atomic_write(path, lambda stream: fig.savefig(stream, dpi=130, format=fmt))
    finally:
        plt.close(fig)
    return path


def plot_height_function(ax, system, direction, limit: float):
    """Filled contours of :func:`height_function` as the background of a shape-space panel."""
    axis, values = height_function(system, direction, limit)
    bound = np.abs(values).max()
    image = ax.contourf(axis, axis, values, levels=21, cmap="RdBu_r", vmin=-bound, vmax=bound, alpha=0.8)
    ax.figure.colorbar(image, ax=ax, label="height function along travel (1/rad²)", shrink=0.8)
    return ax


def plot_joint_angles(ax, gaits: dict[str, FourierGait]):
    """Joint angles θ_j(φ) over one cycle for each named gait: colour names the joint, line style the gait (a
    legend for each)."""
    from matplotlib.lines import Line2D

    phase = np.linspace(0, 2 * np.pi, 200)
    styles = ["-", "--", ":", "-."]
    n_joints = 0
    for index, gait in enumerate(gaits.values()):
        values = gait.shape(phase)
        n_joints = max(n_joints, gait.n_joints)
        for j in range(gait.n_joints):
            ax.plot(phase, values[:, j], color=f"C{j % 10}", ls=styles[index % len(styles)], lw=1.2)
    ax.set_xlabel(r"phase $\varphi$ (rad)")
    ax.set_ylabel(r"joint angle $\theta_j$ (rad)")
    ax.set_title("Joint angles over a cycle")
    gait_legend = ax.legend([Line2D([], [], color="k", ls=styles[i % len(styles)]) for i in range(len(gaits))],
                            list(gaits), title="gait", fontsize=8, title_fontsize=8, loc="upper left")
    ax.add_artist(gait_legend)
    ax.legend([Line2D([], [], color=f"C{j % 10}") for j in range(n_joints)],
              [rf"$\theta_{{{j + 1}}}$" for j in range(n_joints)], title="joint", fontsize=8, title_fontsize=8,
              loc="upper right", ncol=1 if n_joints <= 5 else 2)
    return ax


def plot_progress(ax, log, *, seed_value: float, ceiling_value: float | None = None):
    """Displacement per cycle over cycles: measured on every cycle; the gait the run holds so far (its true value
    where the robot has a truth), apart from the trials it ran and did not keep (a measured climb's candidates,
    period trials); model steps and rejections marked; Γ on a twin axis (only on cycles the model is scored on:
    not the first cycle after a change, so not a climb's one-cycle trials)."""
    ax.plot(log["cycle"], log["measured_objective"], ".", color="0.6", ms=4, label="measured (each cycle)")
    column = "true_objective" if "true_objective" in log else "measured_objective"
    trial = log["candidate"].astype(bool) if "candidate" in log else pd.Series(False, index=log.index)
    held = log[column].where(~trial).ffill()  # during a trial the run still holds the gait it kept last
    ax.plot(log["cycle"], held, "k-", lw=1.5,
            label="gait held (true)" if column == "true_objective" else "gait held (measured)")
    if trial.any():
        ax.plot(log.loc[trial, "cycle"], log.loc[trial, column], "o", mfc="none", mec="C1", ms=4,
                label="trial not kept (climb candidate, period)")
    steps = log[log["step"] & ~log["climb"].astype(bool)] if "climb" in log else log[log["step"]]
    if len(steps):
        ax.plot(steps["cycle"], steps[column], "k.", ms=6, label="model step taken")
    if "rejected" in log and log["rejected"].any():
        rejected = log[log["rejected"]]
        ax.plot(rejected["cycle"], rejected[column], "rx", ms=6, label="step rejected (tracking)")
    ax.axhline(seed_value, color="0.5", ls=":", label="seed gait")
    if ceiling_value is not None:
        ax.axhline(ceiling_value, color="C3", ls="--", label="ceiling (true connection)")
    ax.set_xlabel("cycle")
    ax.set_ylabel("displacement per cycle (body lengths)")
    scored = int(np.isfinite(log["gamma"].to_numpy(dtype=float)).sum())  # NaN on burn-in cycles and one-cycle trials
    if scored:
        twin = ax.twinx()
        twin.plot(log["cycle"], log["gamma"], ".", color="C0", ms=4, alpha=0.7)
        twin.set_ylabel("online Γ (blue)", color="C0")
        twin.set_ylim(0, 1)
    if scored < len(log) / 2:  # (a measured climb tries each gait for one cycle: Γ is scored on a gait's second)
        ax.text(0.5, 1.01, f"online Γ scored on {scored} of {len(log)} cycles: only on a gait's second cycle and "
                "later, and the measured climb runs each trial once", transform=ax.transAxes, fontsize=7,
                color="C0", ha="center", va="bottom")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title("In-situ optimisation", pad=14 if scored < len(log) / 2 else None)
    return ax


# -- figures of a log fit (geogait fit) -------------------------------------------------------------
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


def plot_body_velocity(axes, time, measured, predicted, baseline=None, time_unit: str | None = None):
    """One axis per component of ξ: measured, model prediction and phase-model baseline over time, in the log's
    length unit and ``time_unit`` (``"s"``; None: the log's own time unit).

    Lines break where consecutive points are not consecutive samples (NaN rows in the inputs).
    """
    per = "s" if time_unit == "s" else "time unit"
    units = (f"length/{per}", f"length/{per}", f"rad/{per}")
    for k, ax in enumerate(axes):
        ax.plot(time, measured[:, k], color="0.6", lw=1.0, label="measured")
        ax.plot(time, predicted[:, k], color="C0", lw=1.2, label=r"model $\hat{\xi}$")
        if baseline is not None:
            ax.plot(time, baseline[:, k], color="C3", lw=0.8, ls="--", label=r"phase model $\xi_T$")
        ax.set_ylabel(f"{_COMPONENTS[k]} ({units[k]})")
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[-1].set_xlabel(f"time ({'s' if time_unit == 's' else 'the log’s unit'}); length: the log’s pose unit")
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
    plot_body_velocity(axes, time, measured, predicted, baseline, time_unit=fit.log.time_unit)
    axes[0].set_title(f"Held-out body velocity (first {min(_SHOWN_CYCLES, np.unique(data['cycle']).size)} held-out "
                      f"cycles), Γ = {fit.held_out_gamma():.3f}")
    save_figure(fig, paths.setdefault("body_velocity_figure", folder / "body_velocity.png"))
    return paths
