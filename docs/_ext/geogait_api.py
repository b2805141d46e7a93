"""Writes the API reference's sources before a build: one page per public module, one per class or function.

Every page follows the module's ``__all__``, so a name added to the package appears in the reference
without editing the docs. A name that a module re-exports from another public module is documented once,
in the module that defines it, and listed as "also importable from" where it is re-exported.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
from pathlib import Path

from docutils import nodes
from sphinx.pycode import ModuleAnalyzer
from sphinx.transforms import SphinxTransform

#: Public modules, in the order data flows through them.
MODULES = {
    "geogait": "The package: its error and warning classes, its version",
    "geogait.se2": "SE(2) geometry: exponentials, logarithms, body velocities from poses",
    "geogait.systems": "Simulated locomotors: Purcell swimmers, the kinematic snake, connections on a grid",
    "geogait.gaits": "Gaits: Fourier series per joint, gait families, exploration perturbations",
    "geogait.simulate": "Trajectories, simulation and the simulated robot stream",
    "geogait.robots": "The Robot protocol, the JSON-lines bridge, MuJoCo and PyElastica robots",
    "geogait.robots.continuum": "Continuum bodies: curvature modes, rods from curvature, their pose and velocity",
    "geogait.io": "Robot logs and streams: readers, column mappings, stream output",
    "geogait.phase": "Gait phase from data: nominal gait fits and phase estimators",
    "geogait.models": "Gait models: the adaptive RLS bank, batch, shape-space and resistance models",
    "geogait.learn": "Learning from logs and live streams; the model-class verdict",
    "geogait.optimize": "In-situ gait optimisation",
    "geogait.control": "Steering and path following",
    "geogait.experiments": "The paper's experiments, on the sweep engine",
    "geogait.sweep": "The sweep engine: paired trials on processes or a cluster",
    "geogait.plotting": "Figures of gaits, models, paths and runs",
}


def _home(obj, name: str, module: str) -> str:
    """The public module that documents ``obj``: the one whose package defines it, else ``module``."""
    defined = getattr(obj, "__module__", None) or ""
    homes = [candidate for candidate in MODULES
             if (defined == candidate or defined.startswith(candidate + ".")) and name in _public(candidate)]
    return max(homes, key=len) if homes else module  # (the innermost: geogait.robots.continuum, not geogait.robots)


def _public(module: str) -> list[str]:
    return list(importlib.import_module(module).__all__)


def _kind(obj) -> str | None:
    if inspect.ismodule(obj):
        return None  # (a module re-exported for convenience, e.g. pyplot, is not ours to document)
    if inspect.isclass(obj):
        return "class"
    if callable(obj):
        return "function"
    return "data"


def _title(text: str, underline: str = "=") -> str:
    return f"{text}\n{underline * len(text)}\n"


def _object_page(module: str, name: str, kind: str) -> str:
    directive = {"class": "autoclass", "function": "autofunction"}[kind]
    # (inherited members, but not those of built-in bases: an exception's add_note, a named tuple's count)
    options = "   :members:\n   :inherited-members: BaseException, tuple, list, dict\n" if kind == "class" else ""
    return f"{_title(name)}\n.. currentmodule:: {module}\n\n.. {directive}:: {name}\n{options}"


@functools.lru_cache
def _comments(module: str) -> dict[str, list[str]]:
    """The ``#:`` comments above module-level names, in ``module`` and its submodules (where constants live)."""
    package = importlib.import_module(module)
    names = [module] + [f"{module}.{info.name}" for info in pkgutil.iter_modules(getattr(package, "__path__", []))]
    found: dict[str, list[str]] = {}
    for name in names:
        for (scope, attribute), lines in ModuleAnalyzer.for_module(name).find_attr_docs().items():
            if scope == "":
                found.setdefault(attribute, list(lines))
    return found


def _constant(module: str, name: str) -> str:
    """A ``py:data`` entry: the constant's value when short, and its ``#:`` comment.

    (autodoc would show the docstring of the value's type, e.g. ``tuple``'s, for a constant whose comment
    sits in a submodule.)
    """
    value = repr(getattr(importlib.import_module(module), name))
    option = f"   :value: {value}\n" if len(value) <= 100 else ""
    lines = _comments(module).get(name, [])
    body = "".join(f"   {line}\n" if line.strip() else "\n" for line in lines)
    return f".. py:data:: {name}\n{option}\n{body}"


def _alias(module: str, name: str, home: str) -> str:
    """A re-exported name: an entry of its own (references to ``module.name`` resolve) pointing to its page."""
    obj = getattr(importlib.import_module(module), name)
    directive = "py:class" if inspect.isclass(obj) else "py:function"
    return (f".. {directive}:: {name}\n   :canonical: {home}.{name}\n   :no-contents-entry:\n\n"
            f"   The same object as :py:obj:`{home}.{name}`, documented in :mod:`{home}`.\n")


def _module_page(module: str, entries: dict, elsewhere: list[tuple[str, str]]) -> str:
    parts = [_title(module), f".. automodule:: {module}\n   :no-members:\n", f".. currentmodule:: {module}\n"]
    for kind, heading in (("class", "Classes"), ("function", "Functions")):
        names = entries[kind]
        if names:
            rows = "\n".join(f"   {name}" for name in names)
            table = f".. autosummary::\n   :toctree: generated\n   :nosignatures:\n\n{rows}\n"
            parts.append(f"{_title(heading, '-')}\n{table}")
    if entries["data"]:
        rows = "\n".join(_constant(module, name) for name in entries["data"])
        parts.append(f"{_title('Constants', '-')}\n{rows}")
    if elsewhere:
        rows = "\n".join(_alias(module, name, home) for name, home in elsewhere)
        parts.append(f"{_title('Also importable from here', '-')}\n{rows}")
    return "\n".join(parts)


def write_api_pages(app, config=None) -> None:
    """Write docs/api/<module>.rst for every public module (Sphinx's ``config-inited``, before files are found)."""
    folder = Path(app.srcdir) / "api"
    generated = folder / "generated"
    generated.mkdir(parents=True, exist_ok=True)
    for module in MODULES:
        namespace = importlib.import_module(module)
        entries = {"class": [], "function": [], "data": []}
        elsewhere = []
        for name in namespace.__all__:
            obj = getattr(namespace, name)
            kind = _kind(obj)
            if kind is None:
                continue
            home = _home(obj, name, module) if kind != "data" else module
            if home != module:
                elsewhere.append((name, home))
            else:
                entries[kind].append(name)
        _write(folder / f"{module}.rst", _module_page(module, entries, elsewhere))
        for kind in ("class", "function"):
            for name in entries[kind]:
                _write(generated / f"{module}.{name}.rst", _object_page(module, name, kind))


def _write(path: Path, text: str) -> None:
    """Write only when changed, so that Sphinx rebuilds only what changed."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


class LiteralBars(SphinxTransform):
    """``|x|`` in a docstring is an absolute value or a norm, not a substitution: left as written.

    Runs just before docutils' Substitutions transform, which would report each as undefined.
    """

    default_priority = 215

    def apply(self, **kwargs) -> None:
        defined = set(self.document.substitution_defs) | {"today", "version", "release", "translation progress"}
        for node in list(self.document.findall(nodes.substitution_reference)):
            if node["refname"] not in defined:
                node.replace_self(nodes.Text(f"|{node.astext()}|"))


def setup(app):
    app.connect("config-inited", write_api_pages)
    app.add_transform(LiteralBars)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
