r"""A bank of recursive-least-squares filters, one per phase window (paper eq. 4).

Every window's covariance ``P`` depends on the regressors only, so one ``P`` serves the three
outputs: weights are ``(n, 3)``. With forgetting factor λ and a sample's regressor ``x`` and
target ``y``:

.. math::
    k = \frac{P x}{\lambda + x^T P x},\quad W \leftarrow W + k\,(y - W^T x)^T,\quad
    P \leftarrow \frac{P - (P x)(P x)^T / (\lambda + x^T P x)}{\lambda}.

The covariance update is written with the outer product of ``Px`` with itself, so a symmetric
``P`` stays exactly symmetric in floating point. Under poor excitation exponential forgetting
inflates ``P`` without bound ("wind-up"); we bound it by a **trace clamp**: whenever
``trace P`` exceeds its initial value ``n δ₀`` the whole matrix is scaled back to it. Scaling by a
positive number keeps ``P`` positive definite, every eigenvalue stays below ``n δ₀``, and with
λ = 1 (no forgetting) the clamp never acts, so the filter is exact recursive least squares.

Updates are vectorised: all (trial, window) filters advance together in "rounds" — round j feeds
every window its j-th covering sample of the batch, in time order — so a batch costs as many
NumPy steps as the largest number of samples a single window receives, not one per sample.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RLSBank", "schedule_rounds"]


def schedule_rounds(cover: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per (batch..., window), the indices of its covering samples in time order.

    Parameters
    ----------
    cover : bool ndarray of shape (..., n_samples, n_windows)

    Returns
    -------
    index : int ndarray of shape (..., n_windows, n_rounds)
    valid : bool ndarray of shape (..., n_windows, n_rounds)
    """
    counts = cover.sum(axis=-2)  # (..., M)
    rounds = int(counts.max()) if counts.size else 0
    order = np.argsort(~cover, axis=-2, kind="stable")[..., :rounds, :]  # covering samples first
    return np.swapaxes(order, -1, -2), np.arange(rounds) < counts[..., None]


class RLSBank:
    """State of ``batch + (n_windows,)`` RLS filters with ``n`` regressors and ``n_outputs`` targets.

    Attributes
    ----------
    weights : ndarray of shape batch + (n_windows, n, n_outputs)
    covariance : ndarray of shape batch + (n_windows, n, n)
    n_updates : int ndarray of shape batch + (n_windows,)
    """

    def __init__(self, batch: tuple, n_windows: int, n: int, n_outputs: int, forgetting_factor: float,
                 initial_covariance: float):
        self.forgetting_factor = forgetting_factor
        self.initial_covariance = initial_covariance
        self.max_trace = n * initial_covariance
        self.weights = np.zeros(batch + (n_windows, n, n_outputs))
        self.covariance = np.broadcast_to(initial_covariance * np.eye(n), batch + (n_windows, n, n)).copy()
        self.n_updates = np.zeros(batch + (n_windows,), dtype=np.int64)

    def update(self, x: np.ndarray, y: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """One round: every filter with ``valid`` True takes one sample.

        Parameters
        ----------
        x : ndarray of shape batch + (n_windows, n)
        y : ndarray of shape batch + (n_windows, n_outputs)
        valid : bool ndarray of shape batch + (n_windows,)

        Returns
        -------
        prior_prediction : ndarray of shape batch + (n_windows, n_outputs)
            ``Wᵀx`` before the update (the filters' a-priori prediction); zero where not valid.
        """
        if valid.all():
            prior, self.weights, self.covariance = self._step(self.weights, self.covariance, x, y)
        else:  # only a few windows cover the samples of this round: update just those
            where = np.nonzero(valid)
            prior = np.zeros(y.shape)
            prior[where], self.weights[where], self.covariance[where] = self._step(
                self.weights[where], self.covariance[where], x[where], y[where])
        self.n_updates += valid
        return prior

    def _step(self, weights, covariance, x, y):
        px = (covariance @ x[..., None])[..., 0]
        denominator = self.forgetting_factor + np.einsum("...i,...i->...", x, px)
        prior = np.einsum("...ij,...i->...j", weights, x)
        weights += (px / denominator[..., None])[..., :, None] * (y - prior)[..., None, :]
        covariance -= px[..., :, None] * px[..., None, :] * (1 / denominator)[..., None, None]
        covariance *= 1 / self.forgetting_factor
        trace = np.einsum("...ii->...", covariance)
        over = trace > self.max_trace
        if np.any(over):
            covariance[over] *= (self.max_trace / trace[over])[:, None, None]
        return prior, weights, covariance
