"""Command-line interface: a thin layer over the library (``geogait --help``).

Importing it imports none of the library's numerical modules: each command imports what it uses when it
runs, so that ``geogait --help`` answers at once.
"""

import os
import sys

if "matplotlib" in sys.modules:  # the commands write files and never need a screen (the library leaves the backend)
    sys.modules["matplotlib"].use("Agg")
else:  # (read by matplotlib when a command imports it)
    os.environ["MPLBACKEND"] = "Agg"

from . import _figures, _fit, _optimize, _simulate, _stream, _track  # noqa: E402, F401  (registers the commands)
from ._app import app  # noqa: E402

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``geogait`` console script."""
    app()
