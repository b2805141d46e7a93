r"""The nominal gait of a log: a Fourier series of shape against (estimated) phase.

.. math::
    \hat\theta_j(\phi) = a_{j0} + \sum_{k=1}^{K} a_{jk}\cos k\phi + b_{jk}\sin k\phi
    = \arg\min \sum_n \lVert r_n - \theta(\phi_n) \rVert^2

(least squares, :meth:`FourierGait.from_shapes`). The order :math:`K` is the user's, or the one
chosen by cross-validation over whole cycles: folds are contiguous blocks of cycles, so a
held-out fold never shares a cycle (and hardly any correlated perturbation) with the data it is
scored against. The smallest order whose mean held-out RMSE is within one standard error of the
best is chosen (the "one-standard-error rule"), which keeps random fold-to-fold variation from
selecting needless harmonics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_array, check_int, fail
from ..gaits import FourierGait

__all__ = ["NominalGaitFit", "fit_nominal_gait"]

_OWNER = "fit_nominal_gait"


@dataclass(frozen=True)
class NominalGaitFit:
    """Result of :func:`fit_nominal_gait`.

    Attributes
    ----------
    gait : FourierGait
        Fitted on all samples with the chosen order.
    order : int
        Chosen (or given) Fourier order K.
    orders : ndarray of shape (m,)
        Orders that were cross-validated.
    held_out_rmse : ndarray of shape (m,)
        Mean over folds of the held-out RMS shape error (rad), per order.
    held_out_stderr : ndarray of shape (m,)
        Standard error of that mean over folds.
    """

    gait: FourierGait
    order: int
    orders: np.ndarray
    held_out_rmse: np.ndarray
    held_out_stderr: np.ndarray


def cycle_index(phase) -> np.ndarray:
    """Cycle number ``(n,)`` of each sample: +1 at every wrap of ``phase`` ``(n,)`` (a drop > π)."""
    phase = np.asarray(phase, dtype=float)
    return np.concatenate([[0], np.cumsum(np.diff(phase) < -np.pi)]).astype(int)


def fit_nominal_gait(phase, shape, *, order: int | None = None, max_order: int = 6, n_folds: int = 5,
                     groups=None) -> NominalGaitFit:
    """Fit the nominal gait θ(φ) of measured shapes against their phase.

    Parameters
    ----------
    phase : array-like of shape (n,)
        Phase of each sample in radians (e.g. from :class:`~geogait.phase.Phaser`).
    shape : array-like of shape (n, d)
        Measured shapes r.
    order : int, optional
        Fourier order; chosen by cross-validation over ``1..max_order`` when omitted.
    max_order : int
        Largest order tried.
    n_folds : int >= 2
        Folds of contiguous cycles for the held-out error.
    groups : array-like of shape (n,), optional
        Cycle label of each sample; by default counted from the wraps of ``phase``
        (:func:`cycle_index`). Pass it when the phase was concatenated from several segments,
        e.g. ``log.to_trajectory().cycle`` for a :class:`~geogait.io.Log`.

    Returns
    -------
    NominalGaitFit

    Examples
    --------
    >>> import numpy as np
    >>> from geogait.gaits import seed_gait
    >>> phase = np.tile(np.linspace(0, 2 * np.pi, 50, endpoint=False), 10)
    >>> noise = np.random.default_rng(0).normal(0, 0.05, (500, 2))
    >>> fit = fit_nominal_gait(phase, seed_gait(2).shape(phase) + noise)
    >>> fit.order, bool(np.abs(fit.gait.coefficients - seed_gait(2).coefficients).max() < 0.02)
    (1, True)
    """
    phase = check_array(phase, "phase", _OWNER, ndim=1)
    shape = check_array(shape, "shape", _OWNER, ndim=2)
    if shape.shape[0] != phase.shape[0]:
        raise fail("shape", _OWNER, f"an array of shape (n, d) with n = len(phase) = {phase.size}",
                   f"shape {shape.shape}")
    folds = _folds(phase, groups, check_int(n_folds, "n_folds", _OWNER, minimum=2))
    if order is None:
        orders = np.arange(1, check_int(max_order, "max_order", _OWNER, minimum=1) + 1)
    else:
        orders = np.array([check_int(order, "order", _OWNER, minimum=0)])
    scores = np.array([[_held_out_rmse(phase, shape, folds == f, k) for f in range(n_folds)]
                       for k in orders])
    mean = scores.mean(axis=1)
    stderr = scores.std(axis=1, ddof=1) / np.sqrt(n_folds)
    best = int(np.argmin(mean))
    chosen = int(orders[np.flatnonzero(mean <= mean[best] + stderr[best])[0]])
    return NominalGaitFit(gait=FourierGait.from_shapes(phase, shape, chosen), order=chosen,
                          orders=orders, held_out_rmse=mean, held_out_stderr=stderr)


def _folds(phase: np.ndarray, groups, n_folds: int) -> np.ndarray:
    """Fold number ``(n,)`` of each sample: contiguous blocks of cycles."""
    if groups is None:
        groups = cycle_index(phase)
    else:
        groups = check_array(groups, "groups", _OWNER, ndim=1)
        if groups.shape != phase.shape:
            raise fail("groups", _OWNER, f"an array of shape ({phase.size},)", f"shape {groups.shape}")
    labels, inverse = np.unique(groups, return_inverse=True)
    if labels.size < n_folds:
        raise fail("phase", _OWNER, f"data spanning at least n_folds = {n_folds} cycles",
                   f"{labels.size} cycle(s)")
    block = np.concatenate([np.full(len(part), i) for i, part in
                            enumerate(np.array_split(np.arange(labels.size), n_folds))])
    return block[inverse]


def _held_out_rmse(phase: np.ndarray, shape: np.ndarray, test: np.ndarray, order: int) -> float:
    try:
        gait = FourierGait.from_shapes(phase[~test], shape[~test], order)
    except ValueError:
        raise fail("order", _OWNER, "low enough for every training fold to determine the series",
                   order) from None
    return float(np.sqrt(np.mean((gait.shape(phase[test]) - shape[test]) ** 2)))
