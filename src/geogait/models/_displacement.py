r"""Model-predicted net motion per cycle of a nominal gait, and its gradient (drives the optimiser).

For a candidate gait :math:`\theta_p` near the model's nominal gait :math:`\theta_0`, the model's
body velocity along the candidate is eq. 3 with :math:`\delta = \theta_p(\phi) - \theta_0(\phi)`,
:math:`\dot\delta = (\theta_p'(\phi) - \theta_0'(\phi))\dot\phi`; it is integrated over one cycle
with the fourth-order Magnus method and exact SE(2) exponentials (as the oracle does), and
differentiated with respect to the gait's flat parameter vector ``p`` by the chain rule:

.. math:: \frac{\partial\xi}{\partial\delta_i} = B_i + \sum_j \partial A_{ij}\dot\delta_j,\qquad
   \frac{\partial\xi}{\partial\dot\delta_j} = A_j + \sum_i \partial A_{ij}\delta_i,

with :math:`\partial\delta_i/\partial p = ` the Fourier basis of joint i and
:math:`\partial\dot\delta_j/\partial p = \dot\phi\,` its φ-derivative.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .. import _kernels
from .._estimator import check_is_fitted
from .._validation import check_int, fail
from ..gaits import FourierGait, fourier_basis
from ..se2 import SERIES_THRESHOLD, gauss_phases, integrate_cycle
from ._features import regressors, split_coefficients

__all__ = ["ModelMotion", "predicted_displacement"]


def predicted_displacement(model, gait: FourierGait | None = None, *, resolution: int = 128,
                           jacobian: bool = False):
    """Net ``(x, y, heading)`` per cycle of ``gait`` predicted by a fitted gait model.

    Parameters
    ----------
    model : AdaptiveGaitModel or BatchGaitModel
        A fitted model (batched models give one answer per trial).
    gait : FourierGait, optional
        Candidate nominal gait (any Fourier order); the model's own ``gait_`` by default.
    resolution : int
        Magnus steps over the cycle.
    jacobian : bool
        Also return the derivative with respect to ``gait.params``.

    Returns
    -------
    pose : ndarray of shape batch + (3,)
    jacobian : ndarray of shape batch + (3, p)
        Only when ``jacobian`` is true.
    """
    check_is_fitted(model)
    gait = model.gait_ if gait is None else gait
    if not isinstance(gait, FourierGait) or gait.n_joints != model.n_joints_:
        raise fail("gait", "predicted_displacement", f"a FourierGait with {model.n_joints_} joints", gait)
    resolution = check_int(resolution, "resolution", "predicted_displacement", minimum=4)
    return displacement_from_terms(ModelTerms.of(model, resolution), gait, jacobian)


@functools.lru_cache(maxsize=16)
def phase_basis(resolution: int, order: int, derivative: int) -> np.ndarray:
    """``fourier_basis`` at the Gauss nodes of ``resolution`` steps (a pure function of its arguments, kept)."""
    basis = fourier_basis(gauss_phases(resolution)[0].reshape(-1), order, derivative)
    basis.setflags(write=False)
    return basis


@dataclass(frozen=True)
class ModelTerms:
    """What :func:`predicted_displacement` needs of a model, for every candidate gait: its nominal gait
    and smoothed window weights at the Gauss nodes. A model read by many candidates (a steering
    family, an optimiser's line search) computes them once; :meth:`current` checks they still hold."""

    resolution: int
    interaction: bool
    n_joints: int
    nominal: np.ndarray  # θ₀ at the nodes (2n, d)
    nominal_rate: np.ndarray  # θ₀' at the nodes (2n, d)
    weights: np.ndarray  # smoothed window weights batch + (2n, r, 3)
    window_weights: np.ndarray  # a copy of the model's window weights they came from
    gait: FourierGait
    smoothing: tuple

    @classmethod
    def of(cls, model, resolution: int) -> ModelTerms:
        """The terms of a fitted ``model`` at ``resolution`` Magnus steps."""
        nodes, _ = gauss_phases(resolution)
        phase = nodes.reshape(-1)
        own = model.gait_
        nominal = phase_basis(resolution, own.order, 0) @ own.coefficients.T  # = own.shape(phase)
        nominal_rate = phase_basis(resolution, own.order, 1) @ own.coefficients.T  # = own.velocity(phase)
        weights = model.smoothed_weights(np.broadcast_to(phase, model.batch_shape_ + phase.shape))  # batch+(2n, r, 3)
        return cls(resolution, model.interaction, model.n_joints_, nominal, nominal_rate, weights,
                   np.array(model.window_weights_), own, _smoothing(model))

    def current(self, model) -> bool:
        """Whether ``model`` still gives these terms (same gait, smoothing and window weights)."""
        return (model.gait_ == self.gait and model.interaction == self.interaction
                and _smoothing(model) == self.smoothing and np.array_equal(model.window_weights_, self.window_weights))


def _smoothing(model) -> tuple:
    return model.n_windows, model.window_width, model.smoothing_order, model.batch_shape_


def displacement_from_terms(terms: ModelTerms, gait: FourierGait, jacobian: bool = False, compiled: bool = False):
    """:func:`predicted_displacement` of ``gait`` from a model's :class:`ModelTerms` (same arithmetic).

    ``compiled`` runs one unbatched model through the compiled kernel where numba is installed (the
    steering solves of path following, thousands per cycle): the same arithmetic, agreeing to rounding,
    not bit for bit, so callers whose published results must not move (the optimiser, the paper's
    figures) keep the NumPy path."""
    resolution = terms.resolution
    basis, d_basis = phase_basis(resolution, gait.order, 0), phase_basis(resolution, gait.order, 1)  # (2n, c)
    kernel = _kernels.displacement_kernel() if compiled and terms.weights.ndim == 3 else None
    if kernel is not None:
        coefficients = gait.coefficients
        pose, pose_jacobian = np.empty(3), np.empty((3, coefficients.size))
        kernel(coefficients, basis, d_basis, terms.nominal, terms.nominal_rate, terms.weights, terms.interaction,
               2 * np.pi / resolution, SERIES_THRESHOLD, jacobian, pose, pose_jacobian)
        return (pose, pose_jacobian) if jacobian else pose
    nodes, step = gauss_phases(resolution)
    rate = 2 * np.pi  # the models regress in cycle time (see geogait.models._base)
    delta = basis @ gait.coefficients.T - terms.nominal  # θ(φ) − θ₀(φ)
    delta_rate = (d_basis @ gait.coefficients.T - terms.nominal_rate) * rate
    weights = terms.weights
    velocity = np.einsum("nr,...nrj->...nj", regressors(delta, delta_rate, terms.interaction), weights) / rate
    velocity = velocity.reshape(velocity.shape[:-2] + nodes.shape + (3,))
    if not jacobian:
        return integrate_cycle(velocity, step)
    parts = split_coefficients(weights, terms.n_joints)
    d_delta = parts["B"] + np.einsum("...nkij,nj->...nki", parts["dA"], delta_rate)  # batch+(2n, 3, d)
    d_rate = parts["A"] + np.einsum("...nkij,ni->...nkj", parts["dA"], delta)
    velocity_jacobian = (d_delta[..., None] * basis[:, None, None, :]
                         + d_rate[..., None] * rate * d_basis[:, None, None, :]) / rate  # batch+(2n, 3, d, c)
    velocity_jacobian = velocity_jacobian.reshape(velocity_jacobian.shape[:-4] + nodes.shape + (3, -1))
    return integrate_cycle(velocity, step, velocity_jacobian)


class ModelMotion:
    """Net motion per cycle of a gait as a fitted gait model predicts it (with its Jacobian).

    Parameters
    ----------
    model : AdaptiveGaitModel, BatchGaitModel or ShapeSpaceModel
        A fitted, unbatched model; it is read, never changed. A model of the connection over shape
        space (:class:`~geogait.models.ShapeSpaceModel`, any model without a nominal gait) predicts
        with its own ``predict_displacement`` and Magnus steps.
    resolution : int
        Magnus steps over the cycle (:func:`predicted_displacement`).
    """

    def __init__(self, model, resolution: int = 64):
        self.model = model
        self.resolution = resolution
        self._terms = None

    def __call__(self, gait: FourierGait, jacobian: bool = False):
        """``(Δx, Δy, Δθ)`` ``(3,)`` of one cycle of ``gait`` (and ``(3, p)`` Jacobian)."""
        if not hasattr(self.model, "gait_"):  # a connection over shape space: no nominal gait to expand about
            return self.model.predict_displacement(gait, jacobian=jacobian, compiled=True)
        if not isinstance(gait, FourierGait) or gait.n_joints != getattr(self.model, "n_joints_", None):
            return predicted_displacement(self.model, gait, resolution=self.resolution, jacobian=jacobian)  # its errors
        # what depends on the model alone (nominal gait and smoothed weights at the nodes) is computed once
        # for the many gaits a solve tries, and again only if the model changed since (same arithmetic)
        terms = self._terms
        if terms is None or terms.resolution != self.resolution or not terms.current(self.model):
            check_int(self.resolution, "resolution", "ModelMotion", minimum=4)
            terms = self._terms = ModelTerms.of(self.model, self.resolution)
        return displacement_from_terms(terms, gait, jacobian, compiled=True)
