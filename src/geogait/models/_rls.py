r"""A bank of recursive-least-squares filters, one per phase window (paper eq. 4).

Every window's covariance ``P`` depends on the regressors only, so one ``P`` serves the three
outputs: weights are ``(n, 3)``. With forgetting factor λ and a sample's regressor ``x`` and
target ``y``:

.. math::
    k = \frac{P x}{\lambda + x^T P x},\quad W \leftarrow W + k\,(y - W^T x)^T,\quad
    P \leftarrow \frac{P - (P x)(P x)^T / (\lambda + x^T P x)}{\lambda}.

The covariance update is written with the outer product of ``Px/√(λ + xᵀPx)`` with itself, so a
symmetric ``P`` stays exactly symmetric in floating point. Under poor excitation exponential forgetting
inflates ``P`` without bound ("wind-up"); we bound it by a **trace clamp**: whenever
``trace P`` exceeds its initial value (``n δ₀``; the sum of the prior variances for a diagonal prior)
the whole matrix is scaled back to it. Scaling by a positive number keeps ``P`` positive definite,
every eigenvalue stays below that trace, and with
λ = 1 (no forgetting) the clamp never acts, so the filter is exact recursive least squares.

Updates are vectorised: all (trial, window) filters advance together in "rounds" — round j feeds
every window its j-th covering sample of the batch, in time order — so a batch costs as many
NumPy steps as the largest number of samples a single window receives, not one per sample.

A filter that takes every sample of a sequence (:meth:`RLSBank.update_sequence`, the shape-space model's
single filter) takes them as one block, with the same result. m sequential updates are a Kalman filter
of a constant state with prior ``(W₀, P₀)`` and observation variances ``λ¹ … λᵐ`` (:math:`P_i = λ^{-i} Q_i`,
:math:`Q_i^{-1} = P_0^{-1} + \sum_{k \le i} λ^{-k} x_k x_k^T`). With the Cholesky factor C of the innovation
covariance :math:`S = \mathrm{diag}(λ^k) + X P_0 X^T`, :math:`G = C^{-1} X P_0` and
:math:`E = C^{-1}(Y - X W_0)`, the state after the first i samples is

.. math:: W_i = W_0 + G_{1:i}^T E_{1:i}, \qquad Q_i = P_0 - G_{1:i}^T G_{1:i},

and the a-priori error of sample i is :math:`C_{ii} E_i` (the LDLᵀ form of sequential processing). So one
factorisation and two matrix products replace m rank-one updates of P, and
the trace :math:`λ^{-i}(\mathrm{tr} P_0 - \sum_{k \le i} \lVert G_k \rVert^2)` after every sample is known in
advance: a block stops at the first sample where the clamp would act, is clamped there, and the next
block starts after it — exactly the sequential filter, clamp included.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RLSBank", "schedule_rounds"]

_CHUNK_BYTES = 1 << 20  # covariance bytes updated per NumPy step: keeps the working set in cache
_BLOCK = 128  # most samples per block of update_sequence (a b × b Cholesky factor per filter)


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

    Parameters
    ----------
    batch : tuple of int
        Leading trial axes; ``()`` for a single bank.
    n_windows : int
        Number M of phase windows (one filter per window and trial).
    n : int
        Number of regressors per filter.
    n_outputs : int
        Number of targets sharing each filter's covariance (3 for a body velocity).
    forgetting_factor : float in (0, 1]
        λ of eq. 4; 1 is ordinary recursive least squares.
    initial_covariance : float > 0 or ndarray of shape (n,)
        δ₀: every covariance starts at δ₀·I, and the trace clamp keeps trace P ≤ n δ₀; a vector is
        a prior variance per regressor, P₀ = diag(δ₀) (a ridge penalty 1/δ₀ᵢ on weight i), clamped at
        trace P ≤ Σᵢ δ₀ᵢ.

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
        prior = np.broadcast_to(np.asarray(initial_covariance, dtype=float), (n,))
        self.max_trace = float(prior.sum())
        self.weights = np.zeros(batch + (n_windows, n, n_outputs))
        self.covariance = np.broadcast_to(np.diag(prior), batch + (n_windows, n, n)).copy()
        self.n_updates = np.zeros(batch + (n_windows,), dtype=np.int64)

    def rows(self, part: slice) -> RLSBank:
        """A bank over rows ``part`` of the flattened batch, sharing (viewing) this bank's arrays."""
        view = object.__new__(RLSBank)
        view.forgetting_factor, view.initial_covariance = self.forgetting_factor, self.initial_covariance
        view.max_trace = self.max_trace
        for name in ("weights", "covariance", "n_updates"):
            array = getattr(self, name)
            flat = array.reshape((-1,) + array.shape[len(array.shape) - (array.ndim - len(self.batch_shape)):])
            setattr(view, name, flat[part])
        return view

    @property
    def batch_shape(self) -> tuple:
        return self.n_updates.shape[:-1]

    def state(self, prefix: str = "") -> dict:
        """The bank's arrays, named ``prefix + name`` (what a model file stores)."""
        return {prefix + name: getattr(self, name) for name in ("weights", "covariance", "n_updates")}

    def assign(self, state: dict, prefix: str = "") -> None:
        """Copy saved arrays (:meth:`state`) into this bank, checking their shapes (``ValueError``).

        Parameters
        ----------
        state : dict of str to ndarray
            Holds ``prefix + "weights"``, ``prefix + "covariance"`` and ``prefix + "n_updates"``.
        prefix : str, default ""
            Prefix the arrays were saved under (see :meth:`state`).
        """
        for name in ("weights", "covariance", "n_updates"):
            saved = np.asarray(state[prefix + name])
            current = getattr(self, name)
            if saved.shape != current.shape:
                raise ValueError(f"array {prefix + name!r} has shape {saved.shape}, expected {current.shape}")
            setattr(self, name, saved.astype(current.dtype, copy=True))

    def inflate(self, factor: float) -> None:
        """Multiply every covariance by ``factor`` (≥ 1), then re-apply the trace clamp."""
        self.covariance *= factor
        self._clamp_trace()

    def forget(self, factor: float) -> None:
        r"""Discount the evidence in every covariance by ``factor`` (≥ 1), no direction beyond the prior.

        In the prior's coordinates, :math:`\tilde P = P_0^{-1/2} P P_0^{-1/2} = V\,\mathrm{diag}(\mu)\,V^T`,
        each eigenvalue becomes :math:`\max(\mu, \min(f\mu, 1))`: a direction the samples informed
        gets ``factor`` times its variance, up to the prior's; a direction already at or beyond the
        prior (never excited, grown by forgetting) keeps its own. Multiplying all of P by ``factor``
        and re-applying the trace clamp (:meth:`inflate`) does not do this once the unexcited
        directions hold the clamp's whole budget — as they do under steady forgetting with many
        regressors — the clamp then scales the product straight back, and nothing is forgotten.
        """
        n = self.covariance.shape[-1]
        root = np.sqrt(np.broadcast_to(np.asarray(self.initial_covariance, dtype=float), (n,)))
        scale = root[:, None] * root[None, :]
        eigenvalues, vectors = np.linalg.eigh(self.covariance / scale)
        eigenvalues = np.maximum(eigenvalues, np.minimum(factor * eigenvalues, 1.0))
        forgotten = np.einsum("...ik,...k,...jk->...ij", vectors, eigenvalues, vectors) * scale
        self.covariance[...] = (forgotten + np.swapaxes(forgotten, -1, -2)) / 2
        self._clamp_trace()

    def _clamp_trace(self) -> None:
        """Scale every covariance whose trace exceeds the clamp back onto it."""
        trace = np.einsum("...ii->...", self.covariance)
        over = trace > self.max_trace
        self.covariance[over] *= (self.max_trace / trace[over])[..., None, None]

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
        n, outputs = self.weights.shape[-2:]
        if valid.all():  # every filter updates: work on flat views, in place
            prior = self._steps(self.weights.reshape(-1, n, outputs), self.covariance.reshape(-1, n, n),
                                x.reshape(-1, n), y.reshape(-1, outputs))
            prior = prior.reshape(y.shape)
        else:  # only some windows cover this round's samples: update just those
            where = np.nonzero(valid)
            weights, covariance = self.weights[where], self.covariance[where]
            prior = np.zeros(y.shape)
            prior[where] = self._steps(weights, covariance, x[where], y[where])
            self.weights[where], self.covariance[where] = weights, covariance
        self.n_updates += valid
        return prior

    def update_sequence(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Every filter takes the samples ``x[..., i, :]``, ``y[..., i, :]`` in order i = 0, 1, … (module docstring).

        Equal to one :meth:`update` per sample with every filter valid (trace clamp included), computed in
        blocks.

        Parameters
        ----------
        x : ndarray of shape batch + (n_windows, m, n)
        y : ndarray of shape batch + (n_windows, m, n_outputs)

        Returns
        -------
        prior_prediction : ndarray of shape batch + (n_windows, m, n_outputs)
            Each sample's a-priori prediction ``Wᵀx`` (before its own update).
        """
        n, outputs = self.weights.shape[-2:]
        m = x.shape[-2]
        x, y = x.reshape(-1, m, n), y.reshape(-1, m, outputs)
        weights, covariance = self.weights.reshape(-1, n, outputs), self.covariance.reshape(-1, n, n)
        prior = np.empty(y.shape)
        lam = self.forgetting_factor
        longest = _BLOCK if lam == 1 else int(min(_BLOCK, max(1, np.log(1e-8) / np.log(lam))))  # λ^block ≥ 1e-8
        start = 0
        while start < m:
            stop = min(m, start + longest)
            start += self._block(weights, covariance, x[:, start:stop], y[:, start:stop], prior[:, start:stop])
        self.weights, self.covariance = weights.reshape(self.weights.shape), covariance.reshape(self.covariance.shape)
        self.n_updates += m
        return prior.reshape(self.weights.shape[:-2] + (m, outputs))

    def _block(self, weights, covariance, x, y, prior) -> int:
        """Take the samples of flat stacks ``x`` ``(k, b, n)`` up to the first clamp; returns how many were taken."""
        lam = self.forgetting_factor
        b = x.shape[1]
        decay = lam ** np.arange(1, b + 1)
        xp = x @ covariance  # (k, b, n): X P₀ (P₀ symmetric)
        innovation = xp @ np.swapaxes(x, -1, -2)
        innovation[:, np.arange(b), np.arange(b)] += decay
        factor = np.linalg.cholesky(innovation)  # (k, b, b) lower
        gain = np.linalg.solve(factor, xp)  # G = C⁻¹ X P₀
        error = np.linalg.solve(factor, y - x @ weights)  # E = C⁻¹ (Y − X W₀)
        trace = (np.einsum("kii->k", covariance)[:, None] - np.cumsum(np.einsum("kbn,kbn->kb", gain, gain), axis=1))
        over = trace / decay > self.max_trace
        taken = int(np.argmax(over.any(axis=0))) + 1 if over.any() else b
        gain, error = gain[:, :taken], error[:, :taken]
        prior[:, :taken] = y[:, :taken] - np.diagonal(factor, axis1=-2, axis2=-1)[:, :taken, None] * error
        weights += np.swapaxes(gain, -1, -2) @ error
        covariance -= np.swapaxes(gain, -1, -2) @ gain  # GᵀG by BLAS syrk: exactly symmetric, so P stays so
        covariance *= 1 / decay[taken - 1]
        trace = np.einsum("kii->k", covariance)
        clamp = trace > self.max_trace
        if np.any(clamp):
            covariance[clamp] *= (self.max_trace / trace[clamp])[:, None, None]
        return taken

    def _steps(self, weights, covariance, x, y):
        """Update flat stacks ``(k, n, ...)`` in place, in cache-sized chunks (temporaries stay small)."""
        n = covariance.shape[-1]
        chunk = max(1, _CHUNK_BYTES // (8 * n * n))
        prior = np.empty(y.shape)
        for start in range(0, covariance.shape[0], chunk):
            part = slice(start, start + chunk)
            prior[part] = self._step(weights[part], covariance[part], x[part], y[part])
        return prior

    def _step(self, weights, covariance, x, y):
        lam = self.forgetting_factor
        px = (covariance @ x[..., None])[..., 0]
        denominator = lam + np.einsum("...i,...i->...", x, px)
        prior = np.einsum("...ij,...i->...j", weights, x)
        weights += (px / denominator[..., None])[..., :, None] * (y - prior)[..., None, :]
        # (Px)(Px)ᵀ/den written as s sᵀ with s = Px/√den: products commute, so P stays exactly symmetric.
        scaled = px * (1 / np.sqrt(denominator))[..., None]
        covariance -= scaled[..., :, None] * scaled[..., None, :]
        covariance *= 1 / lam
        trace = np.einsum("...ii->...", covariance)
        over = trace > self.max_trace
        if np.any(over):
            covariance[over] *= (self.max_trace / trace[over])[:, None, None]
        return prior
