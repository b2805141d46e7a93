"""
Body velocity from motion capture
=================================

A motion-capture system measures the body's world pose, not its velocity.
:func:`geogait.se2.body_velocity_from_poses` differentiates poses on SE(2): each step is the logarithm
of one pose relative to the previous, over its duration. Here the poses of a simulated swimmer, with
0.2 mm of noise, give back its body velocity.
"""

import matplotlib.pyplot as plt
import numpy as np

from geogait import se2
from geogait.gaits import seed_gait
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, samples_per_cycle=100, seed=0)
rng = np.random.default_rng(0)
measured_pose = run.pose + rng.normal(0.0, 2e-4, run.pose.shape)
body_velocity = se2.body_velocity_from_poses(run.time, measured_pose, scheme="central")

fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 6))
for k, (ax, name) in enumerate(zip(axes, ("$v_x$", "$v_y$", r"$\omega$"), strict=True)):
    ax.plot(run.time, run.body_velocity[:, k], color="0.6", lw=2, label="true")
    ax.plot(run.time, body_velocity[:, k], color="C0", lw=1, label="from noisy poses")
    ax.set_ylabel(name)
axes[0].legend(loc="upper right", fontsize=8)
axes[-1].set_xlabel("time (s)")
fig.tight_layout()
