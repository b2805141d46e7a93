"""Figure panels shared by the CLI and the experiments: one function per panel, each drawing on an
``Axes`` it is given and returning it."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # geogait writes files; it never needs a screen

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .gaits import FourierGait  # noqa: E402

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


def save_figure(fig, path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
