"""
Learn a gait model and score it
===============================

An :class:`~geogait.models.AdaptiveGaitModel` learns the local connection of the 3-link swimmer from 20
perturbed cycles of the seed gait. It then predicts the body velocity ξ of 3 cycles it has not seen.
Γ (eq. 5 of the paper) scores the prediction against the phase model's: 1 is perfect, 0 is no better
than the average ξ at each phase.
"""

import matplotlib.pyplot as plt

from geogait.gaits import Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.plotting import plot_body_velocity
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

swimmer = PurcellSwimmer(3)
gait = seed_gait(swimmer.n_joints)
train = simulate(swimmer, gait, n_cycles=20, perturbation=Perturbation.from_std(0.15), sensor_noise=0.1, seed=0)
model = AdaptiveGaitModel(gait=gait).fit(train.phase, train.shape, train.shape_velocity, train.body_velocity)

test = simulate(swimmer, gait, n_cycles=3, perturbation=Perturbation.from_std(0.15), sensor_noise=0.1, seed=1)
gamma = model.score(test.phase, test.shape, test.shape_velocity, test.body_velocity)
predicted = model.predict(test.phase, test.shape, test.shape_velocity)

fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 6))
plot_body_velocity(axes, test.time, test.body_velocity, predicted)
axes[0].set_title(f"Held-out cycles: Γ = {gamma:.2f}")
axes[-1].set_xlabel("time (s)")
fig.tight_layout()
