"""A model refuses, before it allocates, a shape dimension whose arrays would not fit the machine."""

import pytest
from _limits import within_memory


@pytest.mark.parametrize(("model", "joints", "fragment"), [
    ("AdaptiveGaitModel(gait=seed_gait(99))", 99, "a window model of 99 joints (20 windows of 10000 regressors)"),
    ("AdaptiveGaitModel(gait=seed_gait(65))", 65, "at most 64 joints with 20 windows"),
    ("ShapeSpaceModel(degree=3)", 30, "at most 15 joints at degree 3"),
    ("symmetric_chain_model(12)", 12, "at most 11 joints at degree 4"),
    ("ResistanceModel.from_swimmer(PurcellSwimmer(90))", 89, "at most 81 links at that resolution"),
])
def test_a_model_too_large_for_the_machine_is_refused_naming_the_most_joints(model, joints, fragment):
    """Before: a driver declaring 100 joints had the window model ask for 15.5 GiB, a 200-link chain the resistance
    model 30.2 GiB."""
    code = ("import numpy as np\n"
            "from geogait import GeogaitError\n"
            "from geogait.gaits import seed_gait\n"
            "from geogait.models import AdaptiveGaitModel, ResistanceModel, ShapeSpaceModel\n"
            "from geogait.systems import PurcellSwimmer\n"
            "from geogait.optimize import symmetric_chain_model\n"
            f"model, d = {model}, {joints}\n"
            "phase = np.linspace(0, 2 * np.pi, 8, endpoint=False)\n"
            "try:\n"
            "    model.partial_fit(phase, np.zeros((8, d)), np.zeros((8, d)), np.zeros((8, 3)))\n"
            "except GeogaitError as error:\n"
            "    print(error)\n")
    result = within_memory(code)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "GiB of memory, more than the 4 GiB one run may use" in result.stdout and fragment in result.stdout, \
        result.stdout


def test_the_largest_accepted_models_fit():
    from geogait.gaits import seed_gait
    from geogait.models import AdaptiveGaitModel, ShapeSpaceModel

    assert AdaptiveGaitModel(gait=seed_gait(64)).memory_bytes(64) <= 4 * 2**30
    assert ShapeSpaceModel(degree=3).memory_bytes(15) <= 4 * 2**30 < ShapeSpaceModel(degree=3).memory_bytes(16)
