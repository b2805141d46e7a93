"""Phase from data: the Phaser estimator (Revzen & Guckenheimer 2008) and the nominal gait
fitted against phase."""

from ._nominal import NominalGaitFit, cycle_index, fit_nominal_gait
from ._phaser import Phaser

__all__ = ["NominalGaitFit", "Phaser", "cycle_index", "fit_nominal_gait"]
