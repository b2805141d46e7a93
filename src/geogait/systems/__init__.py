"""Simulated principally kinematic locomotors: the Purcell swimmer, the wheeled kinematic snake and user
connections."""

from ._base import FeasibleSystem, FunctionSystem, System, height_function
from ._purcell import BODY_FRAMES, PurcellSwimmer
from ._snake import KinematicSnake

__all__ = [
    "BODY_FRAMES", "FeasibleSystem", "FunctionSystem", "KinematicSnake", "PurcellSwimmer", "System", "height_function",
]
