"""Command-line interface: a thin layer over the library (``geogait --help``)."""

from . import _fit, _optimize, _simulate, _stream, _track  # noqa: F401  (registers the commands)
from ._app import app
from ._figures import accuracy, environments  # noqa: F401  (registers `geogait figure ...`)

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``geogait`` console script."""
    app()
