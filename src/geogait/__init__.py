"""geogait: adaptive, data-driven gait modeling and in-situ gait optimisation of principally
kinematic locomotors (body velocity xi = -A(r) r_dot)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("geogait")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

from ._estimator import check_is_fitted
from ._validation import GeogaitError, GeogaitWarning

__all__ = ["GeogaitError", "GeogaitWarning", "__version__", "check_is_fitted"]
