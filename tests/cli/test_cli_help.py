"""The help of ``geogait``: fast to show (no numerical module imported for it), its defaults shown whole."""

import json
import re
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from geogait.cli import app

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


def test_the_choices_optimize_offers_are_the_librarys():
    """The CLI spells the optimiser's choices out (importing them would import SciPy for the help)."""
    from geogait.cli import _optimize
    from geogait.optimize import CLIMB_RULES, Climb, InSituOptimizer, ModelStep, Objective

    for option, part, parameter in (("_OBJECTIVES", Objective, "kind"), ("_DIRECTION_FRAMES", Objective, "frame"),
                                    ("_FAMILIES", InSituOptimizer, "family"), ("_STEP_RULES", ModelStep, "rule")):
        assert set(getattr(_optimize, option)) == set(part._parameter_constraints[parameter].choices), option
    assert set(_optimize._CLIMB_RULES) == set(CLIMB_RULES)  # (the rules by name; a SearchRule is the library's own)
    assert set(_optimize._CLIMB.values()) - {None} == set(Climb._parameter_constraints["start"].choices)


def test_the_choices_of_simulate_and_track_are_the_librarys():
    from geogait.cli import _simulate, _track
    from geogait.control import EXPLORATION
    from geogait.experiments.tracking import PATHS, TRACKING_MODELS
    from geogait.systems import BODY_FRAMES

    assert _simulate._BODY_FRAMES == BODY_FRAMES and _track._PATHS == PATHS
    assert set(_track._EXPLORATION) == set(EXPLORATION) and set(_track._MODELS) == set(TRACKING_MODELS)


@pytest.mark.parametrize("command", [["optimize"], ["track"], ["simulate"], ["fit"], ["predict"], ["stream"],
                                     ["figure", "optimization"], ["figure", "tracking"], ["figure", "accuracy"],
                                     ["figure", "environments"]])
def test_every_option_is_in_a_group(command):
    """The help shows options in named groups (typer's rich_help_panel), --help alone in the default one."""
    import typer

    from geogait.cli import app

    group = typer.main.get_command(app)
    for name in command:
        group = group.commands[name]
    options = [p for p in group.params if p.param_type_name == "option" and p.name != "help"]
    assert options and [p.name for p in options if p.rich_help_panel is None] == []


@pytest.mark.parametrize("command", [["simulate"], ["fit"], ["predict"], ["stream"], ["optimize"],
                                     ["figure", "accuracy"], ["figure", "environments"], ["figure", "optimization"]])
def test_help_shows_defaults_without_stray_periods(command):
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert not re.search(r" \.(\s|$)", result.stdout), result.stdout  # rich ate a "[default: …]"
    if command[0] == "figure" and command[1] != "optimization":
        assert "[default: 3]" in result.stdout and "geogait[dask]" in result.stdout
