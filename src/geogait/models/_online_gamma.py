"""The online confidence Γ of the models learned sample by sample (the adaptive and shape-space models)."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

__all__ = ["OnlineGamma"]


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

    def _gamma_state(self) -> dict:
        return {"psi": self.psi_}

    def _set_gamma_state(self, state: dict) -> None:
        psi = np.asarray(state["psi"], dtype=float)
        if psi.shape != self.psi_.shape:
            raise ValueError(f"array 'psi' has shape {psi.shape}, expected {self.psi_.shape}")
        self.psi_ = psi

    def reset_gamma(self):
        """Restart the online Γ accumulators (e.g. at the start of an optimisation iteration); returns ``self``."""
        self._check_is_fitted()
        self.psi_ = np.zeros_like(self.psi_)
        return self
