"""Phase from data: the Phaser estimator (Revzen & Guckenheimer 2008), its causal per-sample form
for streams, and the nominal gait fitted against phase."""

from ._nominal import NominalGaitFit, cycle_index, fit_nominal_gait
from ._online import OnlinePhaser
from ._phaser import Phaser

__all__ = ["NominalGaitFit", "OnlinePhaser", "Phaser", "cycle_index", "fit_nominal_gait"]
