"""The figures the commands write: what a reader needs to read them (legends, units, marks)."""

import numpy as np
import pandas as pd
import pytest

from geogait.gaits import seed_gait
from geogait.plotting import plot_body_velocity, plot_joint_angles, plot_path, plot_progress, plt


@pytest.fixture
def ax():
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


def progress_log(gamma) -> pd.DataFrame:
    return pd.DataFrame({"cycle": range(6), "measured_objective": [1.0, 1.1, 1.2, 1.3, 1.4, 1.5],
                         "true_objective": [1.0, 1.1, 1.2, 1.3, 1.4, 1.5], "gamma": gamma, "step": False,
                         "climb": False, "candidate": False, "rejected": False})


def test_progress_without_online_gamma_has_no_empty_gamma_axis_and_says_why(ax):
    plot_progress(ax, progress_log(np.nan), seed_value=1.0)
    assert len(ax.figure.axes) == 1  # (no twin axis for Γ)
    assert any("online Γ scored on 0 of 6 cycles" in text.get_text() for text in ax.texts)


def test_progress_with_online_gamma_draws_it_on_its_own_axis(ax):
    plot_progress(ax, progress_log([0.2, 0.4, 0.5, 0.6, 0.7, 0.8]), seed_value=1.0)
    assert len(ax.figure.axes) == 2 and len(ax.texts) == 0
    assert ax.figure.axes[1].get_ylabel() == "online Γ (blue)"


def test_joint_angles_have_a_legend_of_joints_and_one_of_gaits(ax):
    plot_joint_angles(ax, {"seed": seed_gait(4), "final": seed_gait(4, 0.8), "ceiling": seed_gait(4, 1.2)})
    assert len(ax.get_lines()) == 12
    legends = [child for child in ax.get_children() if isinstance(child, type(ax.get_legend()))]
    titles = {legend.get_title().get_text(): [t.get_text() for t in legend.get_texts()] for legend in legends}
    assert titles == {"gait": ["seed", "final", "ceiling"], "joint": [f"$\\theta_{{{j}}}$" for j in range(1, 5)]}
    assert ax.get_ylabel() == r"joint angle $\theta_j$ (rad)"


def test_a_path_names_its_start_and_its_end(ax):
    pose = np.column_stack([np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)])
    plot_path(ax, pose)
    marks = {text.get_text(): text.xy for text in ax.texts}
    np.testing.assert_allclose(marks["start"], [0, 0])
    np.testing.assert_allclose(marks["end"], [1, 0])


@pytest.mark.parametrize(("unit", "per"), [("s", "s"), (None, "time unit")])
def test_body_velocity_axes_carry_units(unit, per):
    fig, axes = plt.subplots(3, 1)
    time, values = np.linspace(0, 1, 20), np.zeros((20, 3))
    plot_body_velocity(axes, time, values, values, values, time_unit=unit)
    assert [a.get_ylabel() for a in axes] == [f"$v_x$ (length/{per})", f"$v_y$ (length/{per})",
                                             rf"$\omega$ (rad/{per})"]
    assert axes[-1].get_xlabel().startswith("time (s)" if unit == "s" else "time (the log’s unit)")
    plt.close(fig)


def test_every_gait_given_to_the_shape_space_plot_is_drawn_with_its_start():
    """A 5th gait was dropped from the figure, and only the first gait's start was marked."""
    from geogait.plotting import plot_shape_space

    fig, ax = plt.subplots()
    plot_shape_space(ax, None, {f"gait {k}": seed_gait(2, amplitude=0.2 * (k + 1)) for k in range(5)})
    assert ax.get_legend_handles_labels()[1] == [f"gait {k}" for k in range(5)]
    assert sum(line.get_marker() == "o" for line in ax.lines) == 5
    plt.close(fig)
