"""Phase from data: the Phaser estimator (after Revzen & Guckenheimer 2008, three of its five steps
done differently), its causal per-sample form for streams (OnlinePhaser: nearest point of the
learnt limit cycle, tracked by a line), and the nominal gait fitted against phase."""

from ._nominal import NominalGaitFit, cycle_index, fit_nominal_gait
from ._online import OnlinePhaser
from ._phaser import Phaser

__all__ = ["NominalGaitFit", "OnlinePhaser", "Phaser", "cycle_index", "fit_nominal_gait"]
