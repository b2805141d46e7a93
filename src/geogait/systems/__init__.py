"""Simulated principally kinematic locomotors: the Purcell swimmer and user connections."""

from ._base import FunctionSystem, System, height_function
from ._purcell import BODY_FRAMES, PurcellSwimmer

__all__ = ["BODY_FRAMES", "FunctionSystem", "PurcellSwimmer", "System", "height_function"]
