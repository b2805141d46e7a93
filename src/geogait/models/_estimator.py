"""Pieces every geogait estimator shares: scikit-learn's parameter protocol and the online Γ."""

from __future__ import annotations

import inspect

import numpy as np
from scipy.signal import lfilter

from .._validation import fail

__all__ = ["OnlineGamma", "Parameters"]


class Parameters:
    """``get_params`` / ``set_params`` / ``repr`` over the keyword-only arguments of ``__init__``."""

    @classmethod
    def _param_names(cls) -> list[str]:
        signature = inspect.signature(cls.__init__)
        return [p.name for p in signature.parameters.values() if p.kind == p.KEYWORD_ONLY]

    def get_params(self, deep: bool = True) -> dict:
        """Hyper-parameters, as given to ``__init__``."""
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params):
        """Set hyper-parameters (takes effect at the next ``fit``); returns ``self``."""
        for name, value in params.items():
            if name not in self._param_names():
                raise fail(name, type(self).__name__, "one of " + ", ".join(self._param_names()), name)
            setattr(self, name, value)
        return self

    def __repr__(self):
        params = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({params})"


class OnlineGamma:
    """The online confidence Γ (eq. 6) of a model learned sample by sample.

    Needs ``gamma_forgetting`` (λ_Γ), the accumulators ``psi_`` of shape batch + (2,) and
    ``_check_is_fitted``.
    """

    def _update_gamma(self, prior, baseline, body_velocity):
        """ψ ← λ_Γ ψ + ‖error‖ per sample for model and baseline (eq. 6), as a linear filter."""
        errors = np.stack([np.linalg.norm(prior - body_velocity, axis=-1),
                           np.linalg.norm(baseline - body_velocity, axis=-1)], axis=-2)  # batch+(2,n)
        lam = self.gamma_forgetting
        if errors.shape[-1] == 1:
            psi = lam * self.psi_[..., None] + errors
        else:
            psi, _ = lfilter([1.0], [1.0, -lam], errors, axis=-1, zi=lam * self.psi_[..., None])
        self.psi_ = psi[..., -1]
        with np.errstate(invalid="ignore", divide="ignore"):
            self.online_gamma_ = np.where(psi[..., 1, :] > 0, 1 - psi[..., 0, :] / psi[..., 1, :], 0.0)

    @property
    def gamma_(self):
        """Online Γ = 1 − ψ_D / ψ_T after the last sample (eq. 6)."""
        self._check_is_fitted()
        with np.errstate(invalid="ignore", divide="ignore"):
            value = np.where(self.psi_[..., 1] > 0, 1 - self.psi_[..., 0] / self.psi_[..., 1], 0.0)
        return float(value) if value.ndim == 0 else value

    def reset_gamma(self):
        """Restart the online Γ accumulators (e.g. at the start of an optimisation iteration); returns ``self``."""
        self._check_is_fitted()
        self.psi_ = np.zeros_like(self.psi_)
        return self
