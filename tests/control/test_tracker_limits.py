"""``geogait track`` with the longest accepted horizon: stopped by SIGTERM at once; a longer one refused."""

import signal
import sys

import pytest
from _limits import seconds_to_stop
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait.cli import app
from geogait.control import PathTracker


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_track_with_a_long_horizon_stops_on_a_signal(tmp_path, sig):
    """Before: --horizon 3000 ran for more than 20 minutes inside the compiled kernel, deaf to SIGTERM."""
    argv = [sys.executable, "-c", "from geogait.cli import main; main()", "track", "--quick", "--horizon", "8000",
            "--out", str(tmp_path / "t")]
    seconds, code, stderr = seconds_to_stop(argv, after=30, sig=sig)
    assert seconds < 10, (seconds, stderr[-1000:])  # (2 s asked; generous for a loaded test machine)
    assert code == 128 + sig or code == 1, stderr[-1000:]
    assert "error: " in stderr and "Traceback" not in stderr, stderr[-1000:]


def test_a_horizon_whose_plans_would_not_fit_is_refused_naming_the_longest(tmp_path):
    result = CliRunner().invoke(app, ["track", "--quick", "--horizon", "9000", "--out", str(tmp_path / "t")])
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "the --horizon can be at most 8114" in errors[0], result.stderr
    with pytest.raises(GeogaitError, match="the horizon can be at most"):
        PathTracker(horizon=10**6).validate()
