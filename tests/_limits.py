"""Run a piece of geogait in a subprocess held to the memory a user's machine gives it, or stop it with a signal."""

import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Address space a subprocess may take: the 4 GiB no accepted input may exceed (with room for the interpreter).
MEMORY_LIMIT = 5 << 30
SOURCE = str(Path(__file__).parents[1] / "src")


def _environment() -> dict:
    return {**os.environ, "PYTHONPATH": SOURCE + os.pathsep + os.environ.get("PYTHONPATH", ""), "MPLBACKEND": "Agg"}


def within_memory(code: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``code`` in a Python subprocess whose address space is held to :data:`MEMORY_LIMIT`."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit, env=_environment())


def interruptible() -> None:
    """Give a child process Ctrl-C back: a test worker (pytest-xdist) may run with SIGINT ignored, which children
    inherit, and Python then installs no KeyboardInterrupt handler (as a shell's background job)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def seconds_to_stop(argv: list[str], after: float, sig=signal.SIGTERM, limit: float = 60, once: Path | None = None,
                    env: dict | None = None) -> tuple[float, int, str]:
    """Start ``argv`` (with ``env`` added to its environment), send ``sig`` ``after`` seconds (after the file ``once``
    appeared, when given: a stage the run reached), and return (seconds it took to exit, exit code, stderr)."""
    with tempfile.TemporaryFile("w+") as stderr:  # (a pipe nobody reads would block a chatty process)
        process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=stderr, text=True,
                                   env={**_environment(), **(env or {})}, preexec_fn=interruptible)
        started = time.monotonic()
        while once is not None and not once.exists() and process.poll() is None and time.monotonic() < started + limit:
            time.sleep(0.05)
        try:
            process.wait(timeout=after)
            raise AssertionError(f"{argv} ended before the signal (exit code {process.returncode}): nothing tested")
        except subprocess.TimeoutExpired:
            pass
        process.send_signal(sig)
        sent = time.monotonic()
        try:
            process.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        seconds = time.monotonic() - sent
        stderr.seek(0)
        return seconds, process.returncode, stderr.read()
