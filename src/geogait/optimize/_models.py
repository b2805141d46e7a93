"""The models of an in-situ run: the default for the family searched, a fresh copy of the user's per gait and
period, and the gate a model allows."""

from __future__ import annotations

import numpy as np

from .. import models
from .._defaults import window_forgetting_factor
from ..gaits import FourierGait, SymmetricGaitFamily
from ..models import CAPABILITIES, AdaptiveGaitModel, clone_for_gait, model_capabilities

__all__ = ["gate_kind", "gate_members", "model_template", "run_model", "symmetric_chain_model"]


def symmetric_chain_model(n_joints: int, shape_scale: float = 1.0):
    """The default model where the optimiser searches the rotation-free symmetric family.

    :class:`~geogait.models.ShapeSpaceModel` of degree 4 with the chain's mirror and front–back
    symmetries in its basis and each higher degree shrunk 30× (paper Fig. 5's model), forgetting
    factor 0.999 up to 4 joints and 0.9999 beyond (more weights need a longer memory). On the
    built-in 5- and 9-link swimmers it reaches 95–96 % and 73–75 % of the ceiling in 30–60 cycles,
    against 85–91 % and 59–64 % for the local window model (``make bench-robots``).

    Parameters
    ----------
    n_joints : int
        Shape dimension d.
    shape_scale : float
        The model's unit of shape (the optimiser passes its own ``shape_scale``).

    Returns
    -------
    ShapeSpaceModel
    """
    return models.ShapeSpaceModel(degree=4, degree_shrinkage=30.0, symmetry="mirror+reversal",
                                  forgetting_factor=0.999 if n_joints <= 4 else 0.9999, shape_scale=shape_scale)


def model_template(model):
    """The ``model`` parameter, or the window model standing for the defaults (both default models offer the
    same protocol: online Γ, partial_fit, rebase, saving)."""
    return model if model is not None else AdaptiveGaitModel()


def gate_kind(gate: str | None, model) -> str:
    """The gate a run uses: ``gate``, or ``"gamma"`` for a model with online Γ and ``"cycles"`` otherwise."""
    if gate is not None:
        return gate
    return "gamma" if "online_gamma" in model_capabilities(model_template(model)) else "cycles"


def gate_members(kind: str) -> tuple:
    """What a model needs of the :class:`~geogait.models.GaitModel` protocol for a gate of ``kind``."""
    if kind == "gamma":
        return tuple(dict.fromkeys(CAPABILITIES["online"] + CAPABILITIES["online_gamma"]))
    return CAPABILITIES["batch"]


def run_model(model, gait: FourierGait, period: float, family=None, scale: float = 1.0):
    """A fresh model for ``gait`` at ``period`` seconds per cycle: a clone of ``model``, or the default for the
    family searched (:func:`symmetric_chain_model` in the symmetric family, the window model elsewhere)."""
    if model is not None:
        return clone_for_gait(model, gait, 2 * np.pi / period)
    if isinstance(family, SymmetricGaitFamily):
        return symmetric_chain_model(gait.n_joints, shape_scale=scale)
    return AdaptiveGaitModel(gait=gait, forgetting_factor=window_forgetting_factor(gait.n_joints),
                             phase_rate=2 * np.pi / period)
