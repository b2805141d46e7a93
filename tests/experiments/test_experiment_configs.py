"""Experiment settings, a robot benchmark manifest and the phase grid refuse a bad argument in one error naming it
(issue 11)."""

import pytest

from geogait import GeogaitError


def test_small_api_gaps_are_clear_errors(tmp_path):
    """Each of these raised a TypeError or ZeroDivisionError, failed every trial of a sweep, or returned a grid
    spanning 7.5 rad: now one error naming the argument."""
    from geogait.experiments import EnvironmentConfig, OptimizationConfig, TrackingConfig
    from geogait.experiments.robot_benchmark import from_manifest
    from geogait.se2 import gauss_phases

    for make, match in ((lambda: OptimizationConfig(links=3).validate(), "'links' parameter .* a tuple"),
                        (lambda: EnvironmentConfig(drag_ratios=(2.0, 1e7)).validate(), "'drag_ratios'"),
                        (lambda: TrackingConfig(drag_ratios=(2.0, 1e7)).validate(), "'drag_ratios'"),
                        (lambda: gauss_phases(0), "'resolution' parameter of gauss_phases"),
                        (lambda: gauss_phases(2.5), "'resolution' parameter of gauss_phases")):
        with pytest.raises(GeogaitError, match=match):
            make()
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(GeogaitError, match="is not a robot benchmark manifest"):
        from_manifest(tmp_path / "list.json")
