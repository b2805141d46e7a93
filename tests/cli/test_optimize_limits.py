"""``geogait optimize`` refuses a swimmer, an order or a model the machine cannot hold, naming the largest."""

import sys

import pytest
from _limits import seconds_to_stop, within_memory


@pytest.mark.parametrize(("options", "fragment"), [
    (["--links", "200"], "at most --links 12 with --method auto"),
    (["--links", "200", "--method", "resistance"], "at most --links 38 with --method resistance"),
    (["--links", "90", "--method", "adaptive"], "at most --links 38 with --method adaptive"),
    (["--order", "100000"], "at most --order 21 with 2 joints"),
    (["--order", "22"], "at most --order 21 with 2 joints"),
    (["--order", "14", "--max-joint-velocity", "10"], "at most --order 13 with 2 joints"),
])
def test_a_run_beyond_the_memory_or_signal_limit_is_refused_before_it_starts(tmp_path, options, fragment):
    """Before: --links 200 (the stated maximum) asked for 30 GiB, --order 100000 for 4.66 TiB, and --order 180 held
    SIGTERM off for minutes inside one SLSQP step."""
    code = ("from typer.testing import CliRunner\n"
            "from geogait.cli import app\n"
            f"result = CliRunner().invoke(app, ['optimize', *{options!r}, '--cycles', '2', '--out', "
            f"{str(tmp_path / 'run')!r}])\n"
            "print(result.exit_code)\n"
            "print(result.stderr)\n")
    result = within_memory(code)
    assert result.returncode == 0, result.stderr[-2000:]
    code, *stderr = result.stdout.splitlines()
    errors = [line for line in stderr if line.startswith("error: ")]
    assert code == "1" and len(errors) == 1, result.stdout
    assert ("GiB of memory, more than the 4 GiB one run may use" in errors[0]
            or "(SIGTERM and Ctrl-C wait for it" in errors[0]) and fragment in errors[0], errors[0]
    assert not (tmp_path / "run").exists()


def test_optimize_at_the_largest_accepted_order_stops_on_sigterm(tmp_path):
    """Before: --order 180 sat in one SLSQP step for minutes after SIGTERM (killed at 60 s)."""
    argv = [sys.executable, "-c", "from geogait.cli import main; main()", "optimize", "--order", "21", "--cycles",
            "50", "--out", str(tmp_path / "run")]
    seconds, code, stderr = seconds_to_stop(argv, after=30)
    assert seconds < 15, (seconds, stderr[-1000:])  # (2 s asked; generous for a loaded test machine)
    assert "error: terminated (SIGTERM)" in stderr and "Traceback" not in stderr, stderr[-1000:]
