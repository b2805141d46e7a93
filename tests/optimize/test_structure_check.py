"""A structured model whose physics the data contradict leans on the data: the hybrid resistance model's residual
share (how much of its prediction the resistive structure leaves to the residual) against the limit, on a medium
with a forward drift no chain of drag coefficients makes and on the resistive swimmer itself."""

import numpy as np
import pandas as pd
import pytest

from geogait.gaits import seed_gait
from geogait.models import ResistanceModel
from geogait.optimize import Adaptation, Climb, Gate, InSituOptimizer, ModelStep, StructureCheck, structured
from geogait.simulate import SwimmerStream
from geogait.systems import FunctionSystem, PurcellSwimmer

SWIMMER = PurcellSwimmer(3)
RESIDUAL_SHARE_LIMIT = StructureCheck().limit


def drifting(shapes):
    """The swimmer's connection plus a smooth forward drift ∝ cos r: not resistive."""
    extra = np.zeros(np.shape(shapes)[:-1] + (3, 2))
    extra[..., 0, :] = 0.05 * np.cos(shapes)
    return SWIMMER.connection(shapes) + extra


def stream(system, seed=3):
    return SwimmerStream(system, seed_gait(2), sensor_noise=0.1, seed=seed)


def hybrid_optimizer(**params):
    return structured(ResistanceModel.from_swimmer(SWIMMER, residual_degree=2), **params)


def first_decision(log) -> int:
    return int(log.index[log["step"] | log["climb"]][0])


def test_a_hybrid_contradicted_by_its_data_climbs_first_and_one_that_holds_steps():
    with pytest.warns(UserWarning, match="StructureCheck's limit"):
        drift = hybrid_optimizer().run(stream(FunctionSystem(drifting, 2)), 10).log
    first = first_decision(drift)
    assert drift.loc[first, "climb"]  # the data-driven settings: the climb from the first decision
    assert drift.loc[:first, "residual_share"].max() > RESIDUAL_SHARE_LIMIT
    holds = hybrid_optimizer().run(stream(SWIMMER), 10).log
    assert not holds["climb"].any() and holds["step"].any()  # the structured settings: model steps
    assert holds["residual_share"].iloc[1:].max() < RESIDUAL_SHARE_LIMIT


def test_the_structure_is_checked_before_the_model_is_confident():
    """With a Γ threshold the model never reaches, a contradicted hybrid still leans on the data (and climbs)
    once it has its first measured cycles; one whose structure holds waits for Γ and takes no step."""
    drift = hybrid_optimizer(gate__gamma_threshold=0.999).run(stream(FunctionSystem(drifting, 2)), 6).log
    assert first_decision(drift) == Gate().min_cycles - 1
    assert drift["climb"].iloc[first_decision(drift)]
    holds = hybrid_optimizer(gate__gamma_threshold=0.999).run(stream(SWIMMER), 6).log
    assert not (holds["step"] | holds["climb"]).any()


def test_the_structured_preset_declares_the_check_only_for_a_model_that_reports_its_residual():
    assert hybrid_optimizer().checks == [Adaptation(), StructureCheck()]
    assert structured(ResistanceModel.from_swimmer(SWIMMER)).checks == [Adaptation()]


def test_the_check_switches_to_what_it_declares_and_keeps_what_it_does_not_name():
    step = ModelStep(rule="sqp", trust_radius=0.25, min_trust_radius=0.25, max_trust_radius=0.5,
                     rotation_tolerance=0.01)
    climb = Climb(start="contradicted", rule="es", sigma=0.5, rotation_tolerance=0.01)
    new_step, new_climb = StructureCheck().fallback(step, climb)
    assert new_step == ModelStep(rotation_tolerance=0.01)  # the data-driven rule and trust region, the rest kept
    assert new_climb == Climb(rotation_tolerance=0.01)
    assert StructureCheck().fallback(step, None)[1] is None  # a run without a climb gets none
    given = StructureCheck(step=ModelStep(trust_radius=0.05), climb=False)
    assert given.fallback(step, climb) == (ModelStep(trust_radius=0.05), None)


def test_a_run_that_leaned_on_the_data_resumes_bit_identically(tmp_path):
    path = tmp_path / "run.npz"
    system = FunctionSystem(drifting, 2)

    def stop(row):
        if row["cycle"] == 6:
            raise KeyboardInterrupt

    whole = hybrid_optimizer().run(stream(system), 12)
    assert first_decision(whole.log) < 6  # the settings changed before the interruption
    with pytest.raises(KeyboardInterrupt):
        hybrid_optimizer().run(stream(system), 12, checkpoint=path, callback=stop)
    resumed = InSituOptimizer.resume(path, stream(system))
    pd.testing.assert_frame_equal(resumed.log, whole.log, check_dtype=False)
    np.testing.assert_array_equal(resumed.final_gait.params, whole.final_gait.params)
