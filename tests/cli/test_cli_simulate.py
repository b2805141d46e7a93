import json

import pandas as pd
from typer.testing import CliRunner

from geogait.cli import app


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
