"""The prior-work baseline (Bittner et al. 2018): ordinary least squares per phase window."""

from __future__ import annotations

import numpy as np

from .._docs import fill_doc
from .._estimator import Real
from ..gaits import FourierGait
from ._base import GAIT_MODEL_CONSTRAINTS, GaitModelBase, unfitted_unchanged_on_error
from ._features import n_regressors, regressors
from ._phase import phase_baseline

__all__ = ["BatchGaitModel"]

_CHUNK = 512  # samples per normal-equation accumulation step (bounds memory for 9-link batches)


@fill_doc
class BatchGaitModel(GaitModelBase):
    """Same windows, regressors and smoothing as :class:`AdaptiveGaitModel`, but every window is an
    ordinary least-squares fit over all samples seen, with equal weights.

    ``partial_fit`` accumulates the normal equations XᵀX, Xᵀξ per window and re-solves, which is
    the same least-squares solution as refitting on all samples; ``fit`` starts from scratch.
    Rank-deficient windows (too little data) get the minimum-norm solution (pseudo-inverse with
    relative cut-off ``rcond``).

    Parameters
    ----------
    gait : FourierGait, optional
    n_windows : int
    window_width : float, optional
    smoothing_order : int
    phase_rate : float
    rcond : float
        Relative singular-value cut-off of the pseudo-inverse.
    interaction : bool
        Keep the bilinear δ ⊗ δ̇ block of the regressor.
    resolution : int
        Magnus steps over the cycle of :meth:`predict_displacement` (as every gait model has).

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import simulate
    >>> run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=10, seed=0)
    >>> model = BatchGaitModel(gait=seed_gait(2)).fit(run.phase, run.shape, run.shape_velocity,
    ...                                               run.body_velocity)
    >>> model.window_weights_.shape
    (20, 9, 3)
    """

    _parameter_constraints = {**GAIT_MODEL_CONSTRAINTS, "rcond": Real(low=0)}

    def __init__(self, *, gait: FourierGait | None = None, n_windows: int = 20,
                 window_width: float | None = None, smoothing_order: int = 5,
                 phase_rate: float = 2 * np.pi, rcond: float = 1e-10, interaction: bool = True,
                 resolution: int = 128):
        self.gait = gait
        self.n_windows = n_windows
        self.window_width = window_width
        self.smoothing_order = smoothing_order
        self.phase_rate = phase_rate
        self.rcond = rcond
        self.interaction = interaction
        self.resolution = resolution

    def _reset(self, batch: tuple, n_joints: int, gait: FourierGait):
        self.validate()
        self.windows_ = self._windows()
        n = n_regressors(n_joints, self.interaction)
        self.gait_, self.n_joints_, self.batch_shape_ = gait, n_joints, batch
        self.gram_ = np.zeros(batch + (self.windows_.n_windows, n, n))
        self.moment_ = np.zeros(batch + (self.windows_.n_windows, n, 3))
        self.window_weights_ = np.zeros(batch + (self.windows_.n_windows, n, 3))
        self.phase_model_ = phase_baseline(self, 1.0)
        self.n_samples_seen_ = 0

    @unfitted_unchanged_on_error
    def partial_fit(self, phase, shape, shape_velocity, body_velocity):
        """Add samples (batch + (n,) arrays) to the normal equations and re-solve. Returns ``self``.

        Parameters
        ----------
        %(samples)s
        """
        phase, shape, shape_velocity, body_velocity = self._check_measured_samples(
            phase, shape, shape_velocity, body_velocity, "BatchGaitModel.partial_fit")
        if not hasattr(self, "batch_shape_"):
            self._reset(phase.shape[:-1], shape.shape[-1], self._initial_gait(phase, shape))
        nominal, nominal_rate = self._nominal(self.windows_.centres)  # (M, d)
        scale = self._time_scale()  # least squares in cycle time (see geogait.models._base)
        for start in range(0, phase.shape[-1], _CHUNK):
            part = slice(start, start + _CHUNK)
            cover = self.windows_.cover(phase[..., part]).astype(float)  # batch + (c, M)
            rate = shape_velocity[..., part, None, :] / scale
            x = regressors(shape[..., part, None, :] - nominal, rate - nominal_rate, self.interaction)
            x = np.moveaxis(x * cover[..., None], -3, -2)  # batch + (M, c, n), zero outside a window
            self.gram_ += np.swapaxes(x, -1, -2) @ x
            self.moment_ += np.swapaxes(x, -1, -2) @ body_velocity[..., None, part, :] / scale
        self.window_weights_ = np.linalg.pinv(self.gram_, rcond=self.rcond, hermitian=True) @ self.moment_
        self.phase_model_.partial_fit(phase, body_velocity)
        self.n_samples_seen_ += phase.shape[-1]
        return self

    def _state(self) -> dict:
        state = {"gram": self.gram_, "moment": self.moment_, "gait": self.gait_.coefficients,
                 "n_samples_seen": self.n_samples_seen_,
                 **self._baseline_state()}
        if self.gait is not None:  # (the hyper-parameter, which a refit of the loaded model uses again)
            state["initial_gait"] = self.gait.coefficients
        return state

    def _set_state(self, state, metadata):
        batch, d = tuple(metadata["batch_shape"]), int(metadata["n_joints"])
        self.gait = FourierGait(state["initial_gait"]) if "initial_gait" in state else None
        self._reset(batch, d, FourierGait(state["gait"]))
        for name in ("gram", "moment"):
            saved, current = np.asarray(state[name], dtype=float), getattr(self, f"{name}_")
            if saved.shape != current.shape:
                raise ValueError(f"array {name!r} has shape {saved.shape}, expected {current.shape}")
            setattr(self, f"{name}_", saved)
        self.window_weights_ = np.linalg.pinv(self.gram_, rcond=self.rcond, hermitian=True) @ self.moment_
        self.n_samples_seen_ = int(state["n_samples_seen"])
        self._set_baseline_state(state)
