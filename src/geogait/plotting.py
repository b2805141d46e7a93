"""Figure panels shared by the CLI and the experiments: one function per panel, each drawing on an
``Axes`` it is given and returning it.

Importing geogait never changes the matplotlib backend: the CLI selects Agg (it only writes
files); in a notebook or script the user's backend is used.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ._files import atomic_write
from .gaits import FourierGait
from .systems import height_function

__all__ = ["plt", "plot_path", "plot_shape_space", "save_figure"]


def plot_path(ax, pose, *, label=None, color="k"):
    """Swimmer path in the plane: positions ``(n, 3)`` poses, start and end marked."""
    pose = np.asarray(pose)
    ax.plot(pose[:, 0], pose[:, 1], color=color, lw=1.2, label=label)
    ax.plot(pose[0, 0], pose[0, 1], "o", color=color, ms=4)
    ax.annotate("", xy=pose[-1, :2], xytext=pose[max(len(pose) - 20, 0), :2],
                arrowprops=dict(arrowstyle="->", color=color))
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
    styles = ["k-", "C3-", "C0--", "C2:"]
    for (name, gait), style in zip((gaits or {}).items(), styles, strict=False):
        loop = gait.shape(phase)
        ax.plot(loop[:, i], loop[:, j], style, lw=1.8, label=name)
        ax.plot(loop[0, i], loop[0, j], style[:2].replace("-", "o").replace(":", "o"), ms=4)
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
    """Joint angles θ_j(φ) over one cycle for each named gait (solid: first gait, dashed: others)."""
    phase = np.linspace(0, 2 * np.pi, 200)
    for index, (name, gait) in enumerate(gaits.items()):
        values = gait.shape(phase)
        for j in range(gait.n_joints):
            ax.plot(phase, values[:, j], color=f"C{j % 10}", ls=["-", "--", ":"][index % 3], lw=1.2,
                    label=f"{name}" if j == 0 else None)
    ax.set_xlabel("phase φ (rad)")
    ax.set_ylabel("joint angle θ_j (rad)")
    ax.set_title("Joint angles over a cycle (colour: joint)")
    ax.legend(fontsize=8)
    return ax


def plot_progress(ax, log, *, seed_value: float, ceiling_value: float | None = None):
    """Displacement per cycle over cycles — measured on every cycle, the nominal gait's true value
    where the robot has a truth — steps and rejections marked, Γ on a twin axis."""
    ax.plot(log["cycle"], log["measured_objective"], ".", color="0.6", ms=4, label="measured (each cycle)")
    column = "true_objective" if "true_objective" in log else "measured_objective"
    if column == "true_objective":
        ax.plot(log["cycle"], log[column], "k-", lw=1.5, label="nominal gait (true)")
    steps = log[log["step"]]
    ax.plot(steps["cycle"], steps[column], "k.", ms=6, label="step taken")
    if "rejected" in log and log["rejected"].any():
        rejected = log[log["rejected"]]
        ax.plot(rejected["cycle"], rejected[column], "rx", ms=6, label="step rejected (tracking)")
    ax.axhline(seed_value, color="0.5", ls=":", label="seed gait")
    if ceiling_value is not None:
        ax.axhline(ceiling_value, color="C3", ls="--", label="ceiling (true connection)")
    ax.set_xlabel("cycle")
    ax.set_ylabel("displacement per cycle (body lengths)")
    twin = ax.twinx()
    twin.plot(log["cycle"], log["gamma"], ".", color="C0", ms=4, alpha=0.7)  # NaN on burn-in cycles
    twin.set_ylabel("online Γ (blue)", color="C0")
    twin.set_ylim(0, 1)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title("In-situ optimisation")
    return ax
