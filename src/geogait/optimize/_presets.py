"""Presets: named functions that return explicit, printable in-situ optimisers.

Every preset spells out every part, so ``print(preset())`` shows what will run, and takes further parameters as
:meth:`~geogait.optimize.InSituOptimizer.set_params` does (nested names such as ``step__trust_radius``).

=========================  ===================================================================================
preset                     what it is
=========================  ===================================================================================
:func:`default`            the library's defaults: the measured climb first, the model once it predicts
:func:`paper_loop`         the paper's loop (Fig. 5): Γ-gated steps from the model alone, no climb, no revert
:func:`prior_work`         Bittner et al. 2018: a batch model refitted every 30 cycles, steps from it alone
:func:`structured`         a physics model (resistive-force theory) with its wider trust region
:func:`for_robot`          :func:`structured` for a robot that declares a chain in a resistive medium, else
                           :func:`default`
=========================  ===================================================================================
"""

from __future__ import annotations

from .. import models
from .._docs import fill_doc
from ..robots import read_robot_spec
from ._adaptation import Adaptation
from ._checks import ModelClassTest, StructureCheck
from ._exploration import Exploration
from ._insitu import InSituOptimizer
from ._objective import Objective
from ._parts import (
    DATA_DRIVEN_CLIMB,
    DATA_DRIVEN_STEP,
    STRUCTURED_CLIMB,
    STRUCTURED_STEP,
    Climb,
    Gate,
    Limits,
    ModelStep,
    PeriodSearch,
    Safety,
)

__all__ = ["default", "for_robot", "from_flat_params", "paper_loop", "prior_work", "structured"]

@fill_doc
def default(**params) -> InSituOptimizer:
    """The library's defaults with every part spelled out.

    Parameters
    ----------
    %(preset)s
    """
    optimizer = InSituOptimizer(gate=Gate(), step=ModelStep(), climb=Climb(), safety=Safety(), limits=Limits(),
                                objective=Objective(), checks=[Adaptation()])
    return optimizer.set_params(**params)


@fill_doc
def paper_loop(**params) -> InSituOptimizer:
    """The paper's loop (Fig. 5): Γ-gated trust-region steps from the model alone — no measured climb, no revert
    to the best gait measured, no change watched for (the RLS model's forgetting is the paper's adaptation), no
    settling cycles, and no exploration commanded (the robot perturbs itself, as the paper's swimmer).

    Parameters
    ----------
    %(preset)s
    """
    return default(climb=False, safety=Safety(settle_cycles=0, revert_tolerance=None), exploration=None,
                   checks=[]).set_params(**params)


@fill_doc
def prior_work(**params) -> InSituOptimizer:
    """The prior work (Bittner et al. 2018): a batch model fitted to every block of 30 cycles, a step from it
    after each block; no measured climb, no revert, no change watched for.

    Parameters
    ----------
    %(preset)s
    """
    return default(model=models.BatchGaitModel(), gate=Gate(kind="cycles"), climb=False,
                   safety=Safety(settle_cycles=0, revert_tolerance=None), checks=[]).set_params(**params)


@fill_doc
def structured(model, **params) -> InSituOptimizer:
    """A structured model's optimiser: SQP steps in a wider trust region, the climb only when contradicted; a
    model that reports how much of its prediction it leaves to the data (``residual_share_``, the hybrid
    :class:`~geogait.models.ResistanceModel`) also gets a :class:`StructureCheck`.

    Parameters
    ----------
    model : estimator
        The structured model (e.g. ``ResistanceModel(**robot.chain_geometry())``).
    %(preset)s
    """
    hybrid = model is not None and model.get_params().get("residual_degree") is not None
    checks = [Adaptation()] + ([StructureCheck()] if hybrid else [])
    return default(model=model, step=ModelStep(**STRUCTURED_STEP), climb=Climb(**STRUCTURED_CLIMB),
                   checks=checks).set_params(**params)


@fill_doc
def for_robot(robot, **params) -> InSituOptimizer:
    """The optimiser for what ``robot`` declares: :func:`structured` on its chain geometry for a robot that
    declares a chain in a resistive medium (and no ``model`` given), else :func:`default`.

    Parameters
    ----------
    robot : Robot
    %(preset)s
    """
    spec = read_robot_spec(robot)
    if "model" not in params and spec.resistive_chain is not None:
        return structured(models.ResistanceModel(**spec.resistive_chain), **params)
    return default(**params)


#: The flat parameters an optimiser had before it was composed from parts, with their defaults then.
_FLAT_DEFAULTS = {
    "model": None, "gate": None, "gamma_threshold": 0.5, "order": 1, "objective": "progress", "direction": None,
    "direction_frame": "world", "family": "auto", "step_rule": "linear", "max_joint_angle": "auto",
    "max_joint_velocity": None, "trust_radius": 0.1, "min_trust_radius": 0.02, "max_trust_radius": 0.15,
    "rotation_tolerance": 1e-3, "min_cycles_per_iteration": 2, "cycles_per_iteration": 30, "rebase": "all",
    "covariance_inflation": 1.0, "constant_variance": 0.0, "min_gain": 0.005, "settle_cycles": 0,
    "max_tracking_error": "auto", "prediction_tolerance": 0.5, "shape_scale": "auto", "revert_tolerance": 2.0,
    "optimize_period": False, "period_range": None, "climb": "first", "climb_rule": "es", "exploration": "auto",
    "model_class_cycles": 0, "random_state": 0}
_CLIMB_STARTS = {True: "stalled", "first": "first", "contradicted": "contradicted"}


def from_flat_params(flat: dict) -> dict:
    """The parameters of an optimiser saved with the flat parameters that came before the parts (old
    checkpoints): the same run, composed.

    Parameters
    ----------
    flat : dict
        Flat parameter values (a missing one takes its default then; the climb rule of a checkpoint that
        predates the choice is the evolution strategy).

    Returns
    -------
    dict
        :class:`InSituOptimizer` parameters.
    """
    unknown = set(flat) - set(_FLAT_DEFAULTS)
    if unknown:
        raise ValueError(f"unknown optimiser parameters {sorted(unknown)}")
    f = {**_FLAT_DEFAULTS, **flat}
    low, high = f["min_trust_radius"], f["max_trust_radius"]
    step = ModelStep(rule=f["step_rule"], trust_radius=f["trust_radius"], min_trust_radius=low,
                     max_trust_radius=high, rotation_tolerance=f["rotation_tolerance"], min_gain=f["min_gain"],
                     rebase=f["rebase"], covariance_inflation=f["covariance_inflation"],
                     constant_variance=f["constant_variance"])
    climb = False if not f["climb"] else Climb(
        start=_CLIMB_STARTS[f["climb"]], rule=f["climb_rule"], sigma=high, first_sigma=2 * high, min_sigma=low,
        max_sigma=4 * high, rotation_tolerance=f["rotation_tolerance"])
    exploration = f["exploration"] if f["exploration"] in ("auto", None) else Exploration(std=f["exploration"])
    checks = [ModelClassTest(cycles=f["model_class_cycles"])] if f["model_class_cycles"] else []
    structure = _flat_structure_check(f, step, climb)
    return {"model": f["model"],
            "gate": Gate(kind=f["gate"], gamma_threshold=f["gamma_threshold"], min_cycles=f["min_cycles_per_iteration"],
                         cycles=f["cycles_per_iteration"], prediction_tolerance=f["prediction_tolerance"]),
            "step": step, "climb": climb,
            "safety": Safety(settle_cycles=f["settle_cycles"], max_tracking_error=f["max_tracking_error"],
                             revert_tolerance=f["revert_tolerance"]),
            "limits": Limits(max_joint_angle=f["max_joint_angle"], max_joint_velocity=f["max_joint_velocity"],
                             shape_scale=f["shape_scale"]),
            "objective": Objective(kind=f["objective"], direction=f["direction"], frame=f["direction_frame"]),
            "family": f["family"], "order": f["order"],
            "period": PeriodSearch(period_range=f["period_range"]) if f["optimize_period"] else None,
            "exploration": exploration, "checks": checks + structure, "random_state": f["random_state"]}


def _flat_structure_check(f: dict, step: ModelStep, climb) -> list:
    """The structure check the flat optimiser made implicitly for a model with a residual share: each of the
    step rule, the trust region and the climb still at the structured settings went back to the data-driven
    ones."""
    if "residual_share" not in models.model_capabilities(f["model"]):
        return []
    step_changes = {}
    if f["step_rule"] == STRUCTURED_STEP["rule"]:
        step_changes["rule"] = DATA_DRIVEN_STEP["rule"]
    trust = ("trust_radius", "min_trust_radius", "max_trust_radius")
    if all(f[name] == STRUCTURED_STEP[name] for name in trust):
        step_changes.update({name: DATA_DRIVEN_STEP[name] for name in trust})
    at_structured = f["climb"] == "contradicted" and f["climb_rule"] == "es"
    if not step_changes and not at_structured:
        return []
    new_step = ModelStep(**{**step.get_params(), **step_changes})
    high, low = new_step.max_trust_radius, new_step.min_trust_radius
    radii = {"sigma": high, "first_sigma": 2 * high, "min_sigma": low, "max_sigma": 4 * high}
    if at_structured:
        new_climb = Climb(**{**DATA_DRIVEN_CLIMB, **radii, "rotation_tolerance": f["rotation_tolerance"]})
    else:
        new_climb = False if climb is False else Climb(**{**climb.get_params(), **radii})
    return [StructureCheck(step=new_step, climb=new_climb)]
