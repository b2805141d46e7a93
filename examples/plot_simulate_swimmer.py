"""
Simulate a Purcell swimmer
==========================

Run the built-in 3-link Purcell swimmer through a few cycles of the seed gait and draw its path
and its shape-space loop. Body velocity ξ = −A(r) ṙ comes from resistive force theory.
"""

import matplotlib.pyplot as plt

from geogait.gaits import seed_gait
from geogait.plotting import plot_path, plot_shape_space
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

swimmer = PurcellSwimmer(3)
gait = seed_gait(swimmer.n_joints)
run = simulate(swimmer, gait, n_cycles=6, seed=0)

fig, (left, right) = plt.subplots(1, 2, figsize=(9, 4))
plot_path(left, run.pose)
plot_shape_space(right, run.shape, {"seed gait": gait})
fig.tight_layout()

# %%
# The body velocity is measured in the body frame; per cycle the swimmer moves this far:
print(f"{len(run.time)} samples, end pose (x, y, heading) = {run.pose[-1].round(3)}")
