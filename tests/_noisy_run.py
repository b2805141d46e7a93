"""The noisy run that input-checking tests of several packages share (issue 11): 12 cycles of the reference
swimmer and gait with sensor noise 0.1 (1 200 samples, one cycle per time unit) and its table, as the
module-scoped fixtures ``run`` and ``frame``.

A test module takes them in with ``from _noisy_run import run as run`` (and ``frame as frame``; ``frame`` is the
table of the module's ``run``): the alias tells the linter that the names are there for pytest."""

import pytest
from _reference import GAIT

from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 12, seed=4, sensor_noise=0.1)  # 1 200 samples, 1 cycle per time unit


@pytest.fixture(scope="module")
def frame(run):
    return run.to_pandas()
