"""The phase model ξ_T: phase-averaged body velocity of the data seen (the Γ baseline, eq. 5)."""

from __future__ import annotations

import numpy as np

from .._docs import fill_doc
from .._estimator import Real
from ._base import WINDOW_CONSTRAINTS, PhaseWindowModel
from ._rls import RLSBank

__all__ = ["PhaseModel", "phase_baseline"]


@fill_doc
class PhaseModel(PhaseWindowModel):
    """Body velocity as a function of phase only: the exponentially weighted mean of ξ per phase
    window, smoothed along φ by a Fourier series.

    It is estimated on its own (not borrowed from a gait model's constant term), with the same
    windows and, online, the same forgetting as the gait model it serves as baseline for.

    Parameters
    ----------
    n_windows : int
    window_width : float, optional
        Default two window spacings, 4π / n_windows.
    forgetting_factor : float in (0, 1]
        1 gives the plain phase average of all data seen.
    smoothing_order : int
        Fourier order of the smoothing along φ.

    Examples
    --------
    >>> import numpy as np
    >>> phase = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    >>> xi = np.stack([np.cos(phase), np.sin(2 * phase), 0 * phase], axis=-1)
    >>> model = PhaseModel(n_windows=24).fit(phase, xi)
    >>> bool(np.abs(model.predict(phase) - xi).max() < 0.05)
    True
    """

    _parameter_constraints = {**WINDOW_CONSTRAINTS, "forgetting_factor": Real(low=0, high=1, low_open=True)}

    def __init__(self, *, n_windows: int = 20, window_width: float | None = None,
                 forgetting_factor: float = 1.0, smoothing_order: int = 5):
        self.n_windows = n_windows
        self.window_width = window_width
        self.forgetting_factor = forgetting_factor
        self.smoothing_order = smoothing_order

    def start(self, batch_shape: tuple = ()):
        """Start afresh, with no data seen, for trials of ``batch_shape``; returns ``self``.

        The gait models restart their baseline this way when the gait changes (the old gait's
        phase average no longer applies).
        """
        self.validate()
        self.windows_ = self._windows()
        self.bank_ = RLSBank(tuple(batch_shape), self.windows_.n_windows, 1, 3, self.forgetting_factor,
                             initial_covariance=1e6)
        self.batch_shape_ = tuple(batch_shape)
        self.n_samples_seen_ = 0
        return self

    def fit(self, phase, body_velocity):
        """Forget everything, then :meth:`partial_fit`. Returns ``self``; on an error the model is unchanged.

        Parameters
        ----------
        %(phase_samples)s
        """
        with self._unchanged_on_error():
            for name in ("batch_shape_", "bank_"):
                self.__dict__.pop(name, None)
            return self.partial_fit(phase, body_velocity)

    def partial_fit(self, phase, body_velocity):
        """Update with time-ordered samples ``phase`` batch + (n,), ``body_velocity`` batch + (n, 3)."""
        self.partial_fit_predict(phase, body_velocity)
        return self

    def partial_fit_predict(self, phase, body_velocity) -> np.ndarray:
        """Update and return each sample's a-priori prediction (before that sample was learned).

        Parameters
        ----------
        %(phase_samples)s

        Returns
        -------
        ndarray of shape batch + (n, 3)
        """
        phase, body_velocity = self._check_samples(phase, body_velocity, names=("body_velocity",),
                                                   owner="PhaseModel.partial_fit")
        if not hasattr(self, "batch_shape_"):
            self.start(phase.shape[:-1])
        prior = self._run_rounds(self.bank_, phase, body_velocity, lambda sample, rows: np.ones(sample.shape + (1,)))
        self.n_samples_seen_ += phase.shape[-1]
        return prior

    def learn_one(self, valid, body_velocity) -> np.ndarray:
        """One sample of an unbatched model: ``valid`` ``(M,)`` are its covering windows; returns the
        a-priori prediction ``(3,)`` (the fast path of :meth:`partial_fit_predict`).

        Parameters
        ----------
        valid : bool ndarray of shape (M,)
            Which of the M windows cover the sample's phase (:meth:`PhaseWindows.cover`).
        body_velocity : array-like of shape (3,)
            The sample's body velocity ξ = (v_x, v_y, ω).
        """
        ones = np.ones((valid.size, 1))
        prior = self.bank_.update(ones, np.broadcast_to(body_velocity, (valid.size, 3)), valid)[valid].mean(axis=0)
        self.n_samples_seen_ += 1
        return prior

    @property
    def window_weights_(self) -> np.ndarray:
        return self.bank_.weights

    def predict(self, phase) -> np.ndarray:
        """Phase-averaged body velocity at ``phase`` batch + (n,) → batch + (n, 3)."""
        self._check_is_fitted()
        phase = self._check_samples(phase, names=(), owner="PhaseModel.predict")[0]
        value = np.einsum("...nm,...mj->...nj", self._smoother(phase), self.bank_.weights[..., 0, :])
        return value[..., 0, :] if self._single else value

    def _state(self) -> dict:
        return {**self.bank_.state(), "n_samples_seen": self.n_samples_seen_}

    def _set_state(self, state, metadata):
        self.start(tuple(metadata["batch_shape"]))
        self.bank_.assign(state)
        self.n_samples_seen_ = int(state["n_samples_seen"])



def phase_baseline(model, forgetting_factor: float) -> PhaseModel:
    """The phase model ξ_T learned alongside a gait model: its windows and smoothing, the given
    forgetting, started for its batch shape."""
    return PhaseModel(n_windows=model.n_windows, window_width=model.windows_.width, forgetting_factor=forgetting_factor,
                      smoothing_order=model.smoothing_order).start(model.batch_shape_)
