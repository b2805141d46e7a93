"""The help of ``geogait``: fast to show (no numerical module imported for it)."""

import json
import subprocess
import sys

import pytest

#: Modules that take seconds to import and that no help text needs.
HEAVY = ("matplotlib.pyplot", "scipy.signal", "scipy.stats", "pandas", "geogait.optimize", "geogait.experiments")


def imported_after(code: str) -> list[str]:
    """The HEAVY modules a fresh interpreter holds after running ``code`` (at exit, whatever the exit code)."""
    probe = ("import atexit, json, sys\n"
             f"atexit.register(lambda: print(json.dumps([m for m in {HEAVY!r} if m in sys.modules])))\n{code}")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_importing_the_cli_imports_no_numerical_module():
    assert imported_after("import geogait.cli") == []


@pytest.mark.parametrize("args", [["--help"], ["figure", "--help"]])
def test_the_top_level_help_imports_no_numerical_module(args):
    assert imported_after(f"import sys; sys.argv = ['geogait', *{args!r}]\nfrom geogait.cli import main; main()") == []
