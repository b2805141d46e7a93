"""Command-line interface: a thin layer over the library (``geogait --help``)."""

import matplotlib

matplotlib.use("Agg")  # the commands write files and never need a screen (the library leaves the backend alone)

from . import _fit, _optimize, _simulate, _stream, _track  # noqa: E402, F401  (registers the commands)
from ._app import app  # noqa: E402
from ._figures import accuracy, environments  # noqa: F401, E402  (registers `geogait figure ...`)

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``geogait`` console script."""
    app()
