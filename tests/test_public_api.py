"""Every public name of every subpackage is documented (python-control's rule)."""

import importlib
import inspect

import pytest

PACKAGES = ["geogait.se2", "geogait.systems", "geogait.gaits", "geogait.simulate", "geogait.models",
            "geogait.optimize", "geogait.experiments", "geogait.io", "geogait.phase", "geogait.control"]


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
