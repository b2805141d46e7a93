"""Every public name of every subpackage is documented (python-control's rule)."""

import importlib
import inspect

import pytest

PACKAGES = ["geogait.se2", "geogait.systems", "geogait.gaits", "geogait.simulate", "geogait.models",
            "geogait.optimize", "geogait.experiments", "geogait.io", "geogait.phase", "geogait.control",
            "geogait.robots"]


@pytest.mark.parametrize("name", PACKAGES)
def test_public_names_have_docstrings(name):
    module = importlib.import_module(name)
    assert module.__doc__, f"{name} has no module docstring"
    missing = []
    for public in module.__all__:
        value = getattr(module, public)
        if (inspect.isclass(value) or inspect.isfunction(value)) and not inspect.getdoc(value):
            missing.append(public)
        if inspect.isclass(value):
            for method_name, method in vars(value).items():
                if (not method_name.startswith("_") and inspect.isfunction(method)
                        and not inspect.getdoc(method)):
                    missing.append(f"{public}.{method_name}")
    assert not missing, f"undocumented public names in {name}: {missing}"


def test_importing_the_library_leaves_the_matplotlib_backend_alone():
    """Only the CLI selects Agg; a notebook's or script's own backend survives ``import geogait.*``."""
    import os
    import subprocess
    import sys

    code = ("import matplotlib; matplotlib.use('svg'); import geogait.experiments, geogait.plotting, geogait.io, "
            "geogait.control; print(matplotlib.get_backend())")
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == "svg"


def _documented_callables():
    """(qualified name, callable, docstring) of every public function, class and public method."""
    for package in PACKAGES:
        module = importlib.import_module(package)
        for public in module.__all__:
            value = getattr(module, public)
            if inspect.isfunction(value):
                yield f"{package}.{public}", value, inspect.getdoc(value) or ""
            elif inspect.isclass(value):
                doc = inspect.getdoc(value) or ""
                init = value.__dict__.get("__init__")
                if inspect.isfunction(init):  # hyper-parameters live in the class docstring (numpy style)
                    yield f"{package}.{public}", init, doc + "\n" + (inspect.getdoc(init) or "")
                for name, method in vars(value).items():
                    if isinstance(method, classmethod | staticmethod):
                        method = method.__func__
                    if not name.startswith("_") and inspect.isfunction(method):
                        yield f"{package}.{public}.{name}", method, inspect.getdoc(method) or ""


def test_every_parameter_is_documented():
    """python-control's rule: a public callable's docstring names each of its parameters."""
    import re

    missing = []
    for name, function, doc in _documented_callables():
        for parameter in inspect.signature(function).parameters.values():
            if parameter.name in ("self", "cls") or parameter.kind in (parameter.VAR_POSITIONAL,
                                                                       parameter.VAR_KEYWORD):
                continue
            if not re.search(rf"(?<![\w.]){re.escape(parameter.name)}(?!\w)", doc):
                missing.append(f"{name}({parameter.name})")
    assert not missing, f"{len(missing)} undocumented parameters: {missing}"


def test_the_benchmark_runner_answers_help_and_a_bad_name_without_writing(tmp_path):
    """`run.py --help` used to run nothing and overwrite the last results with an empty record."""
    import subprocess
    import sys
    from pathlib import Path

    runner = Path(__file__).resolve().parents[1] / "benchmarks" / "run.py"
    results = runner.parent / "results" / "benchmarks.json"
    before = results.read_bytes() if results.exists() else None
    shown = subprocess.run([sys.executable, str(runner), "--help"], capture_output=True, text=True, timeout=60)
    assert shown.returncode == 0 and "modules: " in shown.stdout and "models" in shown.stdout
    missing = subprocess.run([sys.executable, str(runner), "nosuch"], capture_output=True, text=True, timeout=60)
    assert missing.returncode == 1 and "no benchmark module matches nosuch" in missing.stderr
    assert (results.read_bytes() if results.exists() else None) == before
