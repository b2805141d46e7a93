r"""Smooth stochastic perturbations around a nominal gait (paper eq. 8).

Per joint, the second-order SDE

.. math:: d\dot\delta = -(\alpha\dot\delta + \beta\delta)\,dt + \eta\, dW

is a linear Gaussian system in the state ``s = (δ, δ̇)``: ``ds = F s dt + G dW`` with
``F = [[0, 1], [-β, -α]]``, ``G = [0, η]ᵀ``. It is sampled *exactly* on a grid of step ``dt``:
``s_{n+1} = e^{F dt} s_n + w_n``, ``w_n ~ N(0, Q)``, ``Q = ∫₀^dt e^{Fs} G Gᵀ e^{Fᵀs} ds``
(Van Loan's matrix exponential), so any step size is stable and unbiased.
Its stationary covariance is diagonal: ``Var δ = η² / (2αβ)``, ``Var δ̇ = η² / (2α)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from .._validation import check_float, check_int, fail

__all__ = ["Perturbation", "check_excitation", "excitation_at"]


@dataclass(frozen=True)
class Perturbation:
    """Parameters of eq. 8, shared by every joint.

    Parameters
    ----------
    alpha : float > 0
        Damping (attraction of δ̇), 1/time.
    beta : float > 0
        Stiffness (attraction of δ), 1/time².
    eta : float >= 0
        Noise amplitude, rad / time^{3/2}. ``eta = 0`` gives no perturbation.

    Notes
    -----
    Time is measured in gait cycles by the simulators (one cycle = one time unit).
    """

    alpha: float = 4 * np.pi * 0.7
    beta: float = (4 * np.pi) ** 2
    eta: float = 0.15 * np.sqrt(2 * (4 * np.pi * 0.7) * (4 * np.pi) ** 2)

    def __post_init__(self):
        check_float(self.alpha, "alpha", "Perturbation", low=0, low_open=True)
        check_float(self.beta, "beta", "Perturbation", low=0, low_open=True)
        check_float(self.eta, "eta", "Perturbation", low=0)

    @classmethod
    def from_std(cls, std: float, frequency: float = 2.0, damping_ratio: float = 0.7) -> Perturbation:
        """Perturbations with stationary standard deviation ``std`` (rad) of δ.

        ``frequency`` is the undamped natural frequency in oscillations per cycle
        (β = (2π f)², α = 2ζ√β) — 2 by default, so perturbations vary within a cycle but stay
        smooth; ``damping_ratio`` ζ.
        """
        std = check_float(std, "std", "Perturbation.from_std", low=0)
        frequency = check_float(frequency, "frequency", "Perturbation.from_std", low=0, low_open=True)
        damping_ratio = check_float(damping_ratio, "damping_ratio", "Perturbation.from_std",
                                    low=0, low_open=True)
        beta = (2 * np.pi * frequency) ** 2
        alpha = 2 * damping_ratio * np.sqrt(beta)
        return cls(alpha=alpha, beta=beta, eta=std * np.sqrt(2 * alpha * beta))

    @property
    def stationary_std(self) -> tuple[float, float]:
        """Stationary standard deviations of (δ, δ̇)."""
        return (self.eta / np.sqrt(2 * self.alpha * self.beta), self.eta / np.sqrt(2 * self.alpha))

    def discretize(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact transition ``e^{F dt}`` and Cholesky factor of the step noise covariance ``Q``."""
        dt = check_float(dt, "dt", "Perturbation.discretize", low=0, low_open=True)
        drift = np.array([[0.0, 1.0], [-self.beta, -self.alpha]])
        diffusion = np.array([[0.0, 0.0], [0.0, self.eta**2]])
        van_loan = expm(np.block([[-drift, diffusion], [np.zeros((2, 2)), drift.T]]) * dt)
        transition = van_loan[2:, 2:].T
        covariance = transition @ van_loan[:2, 2:]
        covariance = 0.5 * (covariance + covariance.T)
        if self.eta == 0:
            return transition, np.zeros((2, 2))
        return transition, np.linalg.cholesky(covariance)

    def sample(self, n_samples: int, dt: float, n_joints: int, rng: np.random.Generator,
               size=(), initial_state=None) -> tuple[np.ndarray, np.ndarray]:
        """Sample a whole perturbation path.

        Parameters
        ----------
        n_samples : int
            Number of time steps.
        dt : float
            Step (in cycles).
        n_joints : int
            Shape dimension d.
        rng : numpy.random.Generator
        size : tuple, optional
            Leading batch shape (e.g. ``(n_trials,)``).
        initial_state : ndarray of shape size + (d, 2), optional
            State at the first sample; a stationary draw by default.

        Returns
        -------
        delta, delta_rate : ndarray of shape size + (n_samples, d)
        """
        n_samples = check_int(n_samples, "n_samples", "Perturbation.sample", minimum=0)
        stream = self.stream(dt, n_joints, rng, size=size, initial_state=initial_state)
        states = stream.run(rng.standard_normal(stream.state.shape[:-2] + (n_samples, n_joints, 2)))
        return states[..., 0], states[..., 1]

    def stream(self, dt: float, n_joints: int, rng: np.random.Generator, size=(),
               initial_state=None) -> PerturbationStream:
        """A sample-by-sample integrator with the same law as :meth:`sample`.

        Only the initial state is drawn from ``rng``; the caller supplies the white noise to
        :meth:`PerturbationStream.run`, so many streams can draw from generators of their own.

        Parameters
        ----------
        dt : float > 0
            Step (in cycles).
        n_joints : int
            Shape dimension d (≥ 1).
        rng : numpy.random.Generator
            Draws the stationary initial state (unused when ``initial_state`` is given).
        size : tuple, optional
            Leading batch shape (e.g. ``(n_trials,)``).
        initial_state : ndarray of shape size + (d, 2), optional
            (δ, δ̇) per joint at the first sample; a stationary draw by default.
        """
        n_joints = check_int(n_joints, "n_joints", "Perturbation.stream", minimum=1)
        transition, noise_factor = self.discretize(dt)
        shape = tuple(np.atleast_1d(size)) if size != () else ()
        if initial_state is None:
            state = rng.standard_normal(shape + (n_joints, 2)) * np.array(self.stationary_std)
        else:
            state = np.array(initial_state, dtype=float)
            if state.shape != shape + (n_joints, 2):
                raise fail("initial_state", "Perturbation", f"an array of shape {shape + (n_joints, 2)}",
                           f"shape {state.shape}")
        return PerturbationStream(transition, noise_factor, state)


class PerturbationStream:
    """Exact SDE integrator; ``state[..., j, :] = (δ_j, δ̇_j)`` at the current sample.

    Usually built by :meth:`Perturbation.stream`.

    Parameters
    ----------
    transition : ndarray of shape (2, 2)
        Exact one-step transition ``e^{F dt}`` of the state (δ, δ̇).
    noise_factor : ndarray of shape (2, 2)
        Cholesky factor of the one-step noise covariance ``Q`` (zeros for ``eta = 0``).
    state : ndarray of shape batch + (d, 2)
        (δ, δ̇) per joint at the current sample, radians and radians per cycle.
    """

    def __init__(self, transition: np.ndarray, noise_factor: np.ndarray, state: np.ndarray):
        self.transition = transition
        self.noise_factor = noise_factor
        self.state = state

    def run(self, white_noise: np.ndarray) -> np.ndarray:
        """Emit ``m`` samples and advance ``m`` steps.

        Parameters
        ----------
        white_noise : ndarray of shape batch + (m, d, 2)
            Independent standard normal draws, one pair per joint and step.

        Returns
        -------
        states : ndarray of shape batch + (m, d, 2)
            The state at each of the ``m`` samples (before each step).
        """
        noise = white_noise @ self.noise_factor.T
        out = np.empty_like(noise)
        state = self.state
        for n in range(noise.shape[-3]):  # the recursion is sequential in time only
            out[..., n, :, :] = state
            state = state @ self.transition.T + noise[..., n, :, :]
        self.state = state
        return out


def check_excitation(shape, shape_velocity, n_joints: int, owner: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate an excitation sent to a robot: δ and δ̇ on M ≥ 4 uniform phases of one cycle.

    Parameters
    ----------
    shape, shape_velocity : array-like of shape (M, d)
        δ (shape units) and δ̇ (shape units per second) at phases 2πk / M, k = 0 … M − 1.
    n_joints : int
        d.
    owner : str
        Who asks (named in errors).

    Returns
    -------
    shape, shape_velocity : ndarray of shape (M, d)
    """
    arrays = []
    for name, value in (("shape", shape), ("shape_velocity", shape_velocity)):
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise fail(name, owner, f"an array of shape (M, {n_joints}) of floats", type(value).__name__) from None
        if array.ndim != 2 or array.shape[1] != n_joints or array.shape[0] < 4:
            raise fail(name, owner, f"an array of shape (M, {n_joints}) with M >= 4 phases", f"shape {array.shape}")
        if not np.all(np.isfinite(array)):
            raise fail(name, owner, "finite values", "NaN or inf")
        arrays.append(array)
    if arrays[0].shape != arrays[1].shape:
        raise fail("shape_velocity", owner, f"the shape of 'shape' {arrays[0].shape}", f"shape {arrays[1].shape}")
    return arrays[0], arrays[1]


def excitation_at(phase, shape: np.ndarray, shape_velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """δ and δ̇ of an excitation given on M uniform phases, linearly interpolated (periodically) at ``phase``.

    Robots that accept an excitation (``set_excitation``) evaluate it at the phases of their own
    samples or physics steps.

    Parameters
    ----------
    phase : array-like of shape (n,)
    shape, shape_velocity : ndarray of shape (M, d)
        As checked by :func:`check_excitation`.

    Returns
    -------
    delta, delta_rate : ndarray of shape (n, d)
    """
    m = shape.shape[0]
    grid = 2 * np.pi * np.arange(m + 1) / m
    wrapped = np.mod(np.asarray(phase, dtype=float), 2 * np.pi)
    out = []
    for values in (shape, shape_velocity):
        closed = np.vstack([values, values[:1]])
        out.append(np.stack([np.interp(wrapped, grid, closed[:, j]) for j in range(values.shape[1])], axis=-1))
    return out[0], out[1]
