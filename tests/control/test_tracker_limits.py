"""``geogait track`` with the longest accepted horizon: stopped by SIGTERM at once; a longer one refused."""

import signal
import sys

import pytest
from _limits import seconds_to_stop
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import LOCK_FILE
from geogait.cli import app
from geogait.control import PathTracker


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_track_with_the_longest_horizon_stops_on_a_signal(tmp_path, sig):
    """Before: --horizon 3000 ran for more than 20 minutes inside the compiled kernel, deaf to SIGTERM; --horizon 8114
    then took 4.2–4.8 s on a loaded 2-core machine (the interpreter's last garbage collections). The longest horizon
    adds less than the 2 s the issue allows to what a stop takes at the default horizon on this machine now."""
    def stop(horizon: int) -> tuple[float, int, str]:
        folder = tmp_path / f"horizon-{horizon}"
        argv = [sys.executable, "-c", "from geogait.cli import main; main()", "track", "--quick", "--cycles", "1000",
                "--horizon", str(horizon), "--out", str(folder)]
        return seconds_to_stop(argv, after=10, sig=sig, once=folder / LOCK_FILE)  # (locked before any work)

    baseline, code, stderr = stop(4)
    assert code == 1 and "error: " in stderr, stderr[-1000:]
    seconds, code, stderr = stop(8114)  # (the longest accepted: see below)
    assert code == 1 and "error: " in stderr and "Traceback" not in stderr, stderr[-1000:]
    assert seconds < baseline + 2 and seconds < 10, (seconds, baseline, stderr[-1000:])  # (10: a sanity bound)


def test_a_horizon_whose_plans_would_not_fit_is_refused_naming_the_longest(tmp_path):
    result = CliRunner().invoke(app, ["track", "--quick", "--horizon", "9000", "--out", str(tmp_path / "t")])
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "the --horizon can be at most 8114" in errors[0], result.stderr
    with pytest.raises(GeogaitError, match="the horizon can be at most"):
        PathTracker(horizon=10**6).validate()
