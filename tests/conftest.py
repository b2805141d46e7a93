import os

import numpy as np
import pytest
from hypothesis import settings

os.environ.setdefault("MPLBACKEND", "Agg")

# Property tests draw their examples from a seed fixed per test, so every run (and CI) checks the same
# examples; HYPOTHESIS_PROFILE=explore searches afresh.
settings.register_profile("seeded", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "seeded"))


@pytest.fixture
def rng():
    return np.random.default_rng(20261123)


def pytest_configure(config):
    """Compile the kernels once, before any worker or subprocess needs it: its disk cache is
    then only read while tests run in parallel."""
    if not hasattr(config, "workerinput"):
        from geogait import _kernels

        _kernels.warm_up()
        _kernels.displacement_kernel()
        _kernels.nearest_segment_kernel()
        _kernels.shape_space_kernel()
