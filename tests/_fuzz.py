"""What the fuzz tests (issue 11) share: every input gives a correct result or a clear error naming the field.

The fuzz tests, over the Python API (logs, models, swimmers, JSON), the stream protocol, every CLI command, the
model loader, resume and the robot bridge, are in the packages they test (``test_*_fuzz.py``, and
``test_json_sanitiser_always_writes_strict_json`` in tests/test_files.py, the bridge's in
tests/robots/test_bridge_checks.py). Derandomized hypothesis (the same examples on every run, no example database)
with small example counts, so they are deterministic and take about half a minute on two cores.

Properties checked:

* the library raises only :class:`~geogait.GeogaitError` (a ``ValueError``) for bad input, and its
  message names the parameter ("The 'x' parameter of Y must be …") or the file;
* the CLI exits with 0, or with 1 and exactly one ``error: …`` line, never a traceback and never
  the "unexpected" (bug) message;
* every saved model loads and is finite; a model file that a run could not improve is left
  byte-for-byte as it was; every JSON written is strict JSON.

Here: their settings (``FUZZ``), the wild numbers they draw (``WILD``), those checks, and the run and model they
perturb as the module-scoped fixtures ``run`` and ``fitted``, which a test module takes in with
``from _fuzz import run as run`` (and ``fitted as fitted``; the alias tells the linter the names are there for
pytest).
"""

import numpy as np
import pytest
from _reference import GAIT
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from geogait.models import AdaptiveGaitModel, load_model
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

FUZZ = settings(derandomize=True, database=None, deadline=None, print_blob=False,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])

# Numbers as a robot, a typo or a broken sensor produces them.
WILD = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                 st.sampled_from([0.0, -0.0, 1e300, -1e300, 1e200, 1e-320, 5e-324, 1e12, 1e13, 360.0, 1e5]),
                 st.integers(-10**20, 10**20))


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 8, seed=2, sensor_noise=0.05)  # 800 samples


@pytest.fixture(scope="module")
def fitted(run):
    return AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)


def names_a_field(error: BaseException) -> bool:
    text = str(error)
    return "parameter of" in text or "Cannot write" in text or "geogait model" in text or "Refusing" in text


def check_cli(result) -> str:
    """Exit 0, or 1 with exactly one 'error: …' line; never a traceback or the bug message."""
    assert "Traceback" not in result.output, result.output
    assert result.exit_code in (0, 1), (result.exit_code, result.output)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    if result.exit_code == 1:
        assert len(errors) == 1 and "unexpected" not in errors[0], result.stderr
        assert len(errors[0]) > len("error: ") + 10, errors[0]
        return errors[0]
    return ""


def assert_finite_model(path) -> None:
    model = load_model(path)
    for array in (model.window_weights_, model.covariance_, model.psi_, model.phase_model_.bank_.weights):
        assert np.all(np.isfinite(array))
