"""
Optimise a gait in situ
=======================

The in-situ optimiser improves the 3-link swimmer's gait while it swims. The simulated swimmer
stands in for a robot: the optimiser sees only its measured cycles. The ceiling is the best gait that
the true connection allows, which the optimiser never sees.
"""

import matplotlib.pyplot as plt

from geogait.gaits import seed_gait
from geogait.optimize import InSituOptimizer, optimize_ceiling
from geogait.plotting import plot_progress, plot_shape_space
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer

swimmer = PurcellSwimmer(3)
gait = seed_gait(swimmer.n_joints)
ceiling = optimize_ceiling(swimmer)
robot = SwimmerStream(swimmer, gait, sensor_noise=0.1, seed=0)
result = InSituOptimizer(random_state=0).run(robot, 30, ceiling=ceiling.value)

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
plot_progress(left, result.log, seed_value=result.log["true_objective"].iloc[0], ceiling_value=ceiling.value)
plot_shape_space(right, gaits={"seed": gait, "optimised": result.final_gait, "ceiling": ceiling.gait})
fig.tight_layout()

# %%
# After 30 cycles the gait the run kept reaches this share of the ceiling:
print(f"{result.log['ceiling_fraction'].iloc[-1]:.1%} of the ceiling")
