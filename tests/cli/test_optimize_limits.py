"""``geogait optimize`` refuses a swimmer, an order or a model the machine cannot hold, naming the largest."""

import sys

import pytest
from _limits import seconds_to_stop, within_memory

from geogait._files import LOCK_FILE
from geogait._validation import MAX_SOLVE_SECONDS, gait_fits, gait_solve_seconds


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


#: The CLI, reporting at its very end (the first atexit handler runs last) how many objects its exit froze.
_REPORTING_FREEZE = ("import atexit, gc, sys\n"
                     "atexit.register(lambda: print('objects frozen at exit:', gc.get_freeze_count(),\n"
                     "                              file=sys.stderr))\n"
                     "from geogait.cli import main\n"
                     "main()\n")


def test_optimize_at_the_largest_accepted_order_stops_on_sigterm(tmp_path):
    """Before: --order 180 sat in one SLSQP step for minutes after SIGTERM (killed at 60 s); --order 21 then took 5 s on
    a loaded 2-core machine (the figures drawn after the signal, then the interpreter's last garbage collections).

    Each run computes its ceiling afresh (a cache of its own): the signal comes in its SLSQP steps, on the joint-limit
    rows of the order's gait family, as large as the optimiser's steps on the robot. The largest order adds less than
    the 2 s the issue allows to what a stop takes at order 1 on this machine at this moment (its load in both)."""
    largest = max(order for order in range(1, 100) if gait_fits(2, order, speed_limit=False))
    assert gait_solve_seconds(2, largest, speed_limit=False) <= MAX_SOLVE_SECONDS  # (validation's bound on a step)

    def stop(order: int) -> tuple[float, int, str]:
        folder = tmp_path / f"order-{order}"
        argv = [sys.executable, "-c", _REPORTING_FREEZE, "optimize", "--order", str(order), "--cycles", "1000",
                "--out", str(folder)]
        return seconds_to_stop(argv, after=5, once=folder / LOCK_FILE,  # (the folder is locked before the ceiling)
                               env={"GEOGAIT_CACHE": str(tmp_path / f"cache-{order}")})

    baseline, code, stderr = stop(1)
    assert code == 1 and "error: terminated (SIGTERM)" in stderr, stderr[-1000:]
    seconds, code, stderr = stop(largest)
    assert code == 1 and "error: terminated (SIGTERM)" in stderr and "Traceback" not in stderr, stderr[-1000:]
    assert seconds < baseline + 2 and seconds < 15, (seconds, baseline, stderr[-1000:])  # (15: a sanity bound)
    # the exit skipped the interpreter's last full collections (1.4–1.9 s of the 5 s): what it held was frozen
    assert int(stderr.split("objects frozen at exit: ")[1].split()[0]) > 100_000, stderr[-1000:]
