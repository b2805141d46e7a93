r"""Regressors and phase windows of the local gait model (paper eqs. 3–4).

In phase window m, centred on the nominal shape :math:`\theta^m = \theta(\phi^m)`, a sample
:math:`(r, \dot r)` becomes the perturbations :math:`\delta^m = r - \theta^m`,
:math:`\dot\delta^m = \dot r - \dot\theta^m` and the regressor

.. math:: x = [1,\ \delta^m,\ \dot\delta^m,\ \mathrm{vec}(\delta^m \otimes \dot\delta^m)]
   \in \mathbb{R}^{1 + 2d + d^2},

so :math:`\xi_k \approx C_k + B_k\delta + A_k\dot\delta + \delta^T \partial A_k \dot\delta` (eq. 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_float, check_int, fail

__all__ = ["PhaseWindows", "regressors", "n_regressors", "split_coefficients"]


def n_regressors(n_joints: int, interaction: bool = True) -> int:
    """1 + 2d + d² (or 1 + 2d without the bilinear term).

    Parameters
    ----------
    n_joints : int
        Shape dimension d.
    interaction : bool, default True
        Count the bilinear δ ⊗ δ̇ block of eq. 3.
    """
    return 1 + 2 * n_joints + (n_joints**2 if interaction else 0)


def regressors(delta, delta_rate, interaction: bool = True) -> np.ndarray:
    """Regressor ``[1, δ, δ̇, vec(δ ⊗ δ̇)]`` for perturbations ``(..., d)`` → ``(..., 1 + 2d + d²)``.

    ``vec`` is row-major: entry ``1 + 2d + i d + j`` is ``δ_i δ̇_j``. ``interaction=False`` drops the
    bilinear block (the model is then linear in δ and δ̇, with ``1 + 2d`` weights per window).

    Parameters
    ----------
    delta : array-like of shape (..., d)
        Shape perturbation δ = r − θ(φ_m), radians.
    delta_rate : array-like of shape (..., d)
        Shape-velocity perturbation δ̇ = ṙ − θ̇(φ_m), radians per unit time.
    interaction : bool, default True
        Append the bilinear block vec(δ ⊗ δ̇).
    """
    delta = np.asarray(delta, dtype=float)
    delta_rate = np.asarray(delta_rate, dtype=float)
    parts = [np.ones(delta.shape[:-1] + (1,)), delta, delta_rate]
    if interaction:
        parts.append((delta[..., :, None] * delta_rate[..., None, :]).reshape(delta.shape[:-1] + (-1,)))
    return np.concatenate(parts, axis=-1)


def split_coefficients(weights: np.ndarray, n_joints: int) -> dict[str, np.ndarray]:
    """Name the rows of weights ``(..., 1 + 2d + d², 3)`` as in eq. 3.

    Returns ``C (..., 3)``, ``B (..., 3, d)``, ``A (..., 3, d)`` and ``dA (..., 3, d, d)`` with
    ``dA[k, i, j]`` the coefficient of ``δ_i δ̇_j`` in output k — the estimate of
    ``-∂A_kj/∂r_i`` (the fitted ``A`` estimates ``-A(θ)`` of ξ = -A ṙ).

    Parameters
    ----------
    weights : ndarray of shape (..., 1 + 2d + d², 3) or (..., 1 + 2d, 3)
        Regression weights, one column per output (v_x, v_y, ω); without the bilinear rows ``dA`` is zero.
    n_joints : int
        Shape dimension d.
    """
    d = n_joints
    w = np.swapaxes(weights, -1, -2)  # (..., 3, n)
    bilinear = w[..., 1 + 2 * d:]
    return {
        "C": w[..., 0],
        "B": w[..., 1:1 + d],
        "A": w[..., 1 + d:1 + 2 * d],
        "dA": bilinear.reshape(w.shape[:-1] + (d, d)) if bilinear.shape[-1] else np.zeros(w.shape[:-1] + (d, d)),
    }


@dataclass(frozen=True)
class PhaseWindows:
    """``n_windows`` equally spaced windows of width ``width`` on the phase circle S¹.

    Window m is centred on ``φ_m = 2π m / n_windows`` and covers ``|φ - φ_m| ≤ width / 2``
    (distance measured around the circle). Windows overlap when ``width > 2π / n_windows``.

    Examples
    --------
    >>> windows = PhaseWindows(4, width=np.pi)
    >>> windows.cover([0.0, np.pi / 4]).astype(int)
    array([[1, 1, 0, 1],
           [1, 1, 0, 0]])
    """

    n_windows: int
    width: float

    def __post_init__(self):
        check_int(self.n_windows, "n_windows", "PhaseWindows", minimum=1)
        check_float(self.width, "width", "PhaseWindows", low=0, high=2 * np.pi, low_open=True)
        if self.width < 2 * np.pi / self.n_windows - 1e-12:
            raise fail("width", "PhaseWindows", f">= the window spacing 2π/{self.n_windows} so every phase "
                       "is covered", self.width)

    @property
    def centres(self) -> np.ndarray:
        """Window centres ``(n_windows,)`` in ``[0, 2π)``."""
        return 2 * np.pi * np.arange(self.n_windows) / self.n_windows

    def distance(self, phase) -> np.ndarray:
        """Signed circular distance ``φ - φ_m`` in ``[-π, π)``, shape ``(..., n_windows)``.

        Parameters
        ----------
        phase : float or array-like of shape (...,)
            Gait phase φ in radians (any real value; taken modulo 2π).
        """
        phase = np.asarray(phase, dtype=float)
        return (phase[..., None] - self.centres + np.pi) % (2 * np.pi) - np.pi

    def cover(self, phase) -> np.ndarray:
        """Boolean ``(..., n_windows)``: which windows cover each phase (at least one always does)."""
        return np.abs(self.distance(phase)) <= self.width / 2 + 1e-12
