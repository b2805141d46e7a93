"""``geogait simulate``: what it writes, its options checked, sizes and scales bounded, and an earlier simulation
kept unless told to replace it (issue 11)."""

import json

import numpy as np
import pandas as pd
import pytest
from _cli import one_error_line
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait.cli import app
from geogait.gaits import seed_gait
from geogait.systems import PurcellSwimmer


def test_simulate_writes_trajectory_png_and_manifest(tmp_path):
    result = CliRunner().invoke(app, ["simulate", "--links", "5", "--cycles", "3", "--drag-ratio", "2,3",
                                      "--cycles-per-environment", "2", "--noise", "0.1", "--seed", "3",
                                      "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    frame = pd.read_parquet(tmp_path / "trajectory.parquet")
    assert len(frame) == 300 and "shape_3" in frame and "body_velocity_y" in frame
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "trajectory.csv"), frame, check_exact=False, rtol=1e-12)
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["config"]["drag_ratios"] == [2.0, 3.0] and manifest["results"]["samples"] == 300


def test_simulate_rejects_bad_options(tmp_path):
    result = CliRunner().invoke(app, ["simulate", "--links", "1", "--out", str(tmp_path)])
    assert result.exit_code == 1 and "error: --links must be" in result.stderr
    result = CliRunner().invoke(app, ["simulate", "--drag-ratio", "2,x", "--out", str(tmp_path)])
    assert result.exit_code != 0 and "comma-separated" in result.output


def test_version_is_printed():
    import geogait
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout.strip() == f"geogait {geogait.__version__}"


def test_simulate_keeps_an_earlier_simulation_unless_told_to_replace_it(tmp_path):
    out = tmp_path / "sim"
    arguments = ["simulate", "--cycles", "1", "--samples-per-cycle", "20", "--out", str(out)]
    assert CliRunner().invoke(app, arguments).exit_code == 0
    before = (out / "trajectory.csv").read_bytes()
    one_error_line(CliRunner().invoke(app, [*arguments[:-2], "--seed", "3", "--out", str(out)]),
                   "is not empty", "--overwrite")
    assert (out / "trajectory.csv").read_bytes() == before
    replaced = CliRunner().invoke(app, [*arguments[:-2], "--seed", "3", "--overwrite", "--out", str(out)])
    assert replaced.exit_code == 0, replaced.output
    assert (out / "trajectory.csv").read_bytes() != before
    assert json.loads((out / "manifest.json").read_text())["config"]["seed"] == 3


def test_sizes_and_scales_are_bounded(tmp_path):
    one_error_line(CliRunner().invoke(app, ["simulate", "--samples-per-cycle", str(10**7), "--out", str(tmp_path)]),
                   "--samples-per-cycle must be")
    one_error_line(CliRunner().invoke(app, ["simulate", "--samples-per-cycle", "100000", "--cycles", "1000",
                                            "--out", str(tmp_path)]), "at most 10,000,000 samples")
    assert not (tmp_path / "trajectory.csv").exists()
    for kwargs, message in (({"n_links": 10**6}, r"'n_links' .* an int in \[2, 200\]"),
                            ({"drag_coefficient": 1e-320}, r"'drag_coefficient' .* in \[1e-06, 1e\+06\]"),
                            ({"link_lengths": [1e200, 1, 1]}, r"'link_lengths' .* lengths in \[1e-06"),
                            ({"link_lengths": [1e-200, 1, 1]}, r"'link_lengths' .* lengths in \[1e-06"),
                            ({"drag_ratio": 1e300}, r"'drag_ratio'")):
        with pytest.raises(GeogaitError, match=message):
            PurcellSwimmer(**kwargs)


def test_more_entry_points_name_the_field(tmp_path):
    from geogait.phase import Phaser
    from geogait.simulate import cycle_displacement

    with pytest.raises(GeogaitError, match=r"'x' parameter of Phaser.fit must be plausible values, within ±1e\+12"):
        Phaser().fit(np.full((1000, 2), 1e300))
    with pytest.raises(GeogaitError, match=r"'gait' parameter of cycle_displacement must be a FourierGait with 2 "
                                           r"joints \(the system's\). Got '3 joints'"):
        cycle_displacement(PurcellSwimmer(3), seed_gait(3))
    for option, value in (("--noise", "1e300"), ("--amplitude", "1e6"), ("--seed", "-1")):
        one_error_line(CliRunner().invoke(app, ["simulate", option, value, "--out", str(tmp_path)]),
                       f"{option} must be")
