r"""Fourier-series gaits: one periodic joint-angle trajectory per shape dimension.

.. math::
    \theta_j(\phi) = a_{j0} + \sum_{k=1}^{K} a_{jk}\cos k\phi + b_{jk}\sin k\phi

The flat parameter vector (what optimisers see) stacks, joint by joint,
``[a_j0, a_j1..a_jK, b_j1..b_jK]``, so it has ``d * (2K + 1)`` entries.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._blocks import block_lstsq
from .._validation import check_array, check_float, check_int, fail

__all__ = ["FourierGait", "seed_gait"]


def fourier_basis(phase, order: int, derivative: int = 0) -> np.ndarray:
    """Basis ``[1, cos kφ, sin kφ]`` (or its ``derivative``-th φ-derivative), shape ``(..., 2K+1)``.

    Columns are ordered ``[1, cos φ .. cos Kφ, sin φ .. sin Kφ]``.

    Parameters
    ----------
    phase : float or array-like of shape (...,)
        Gait phase φ in radians.
    order : int
        Fourier order K (number of harmonics).
    derivative : int, default 0
        Order of the φ-derivative of the basis (0 gives the basis itself).
    """
    phase = np.asarray(phase, dtype=float)
    if not np.all(np.isfinite(phase)):  # (a NaN phase would make every shape NaN downstream)
        raise fail("phase", "fourier_basis", "finite (no NaN or inf)",
                   f"{int(phase.size - np.count_nonzero(np.isfinite(phase)))} non-finite value(s)")
    if isinstance(derivative, bool) or not isinstance(derivative, int | np.integer) or derivative < 0:
        raise fail("derivative", "fourier_basis", "an int >= 0 (the order of the φ-derivative)", derivative)
    k = np.arange(1, order + 1)
    angle = phase[..., None] * k
    cos, sin = np.cos(angle), np.sin(angle)
    # d/dφ: cos -> -k sin, sin -> k cos; pattern repeats every 4 derivatives.
    turns = [(cos, sin), (-sin, cos), (-cos, -sin), (sin, -cos)][derivative % 4]
    scale = k.astype(float) ** derivative
    constant = np.full(phase.shape + (1,), 1.0 if derivative == 0 else 0.0)
    return np.concatenate([constant, turns[0] * scale, turns[1] * scale], axis=-1)


@dataclass(frozen=True)
class FourierGait:
    """A periodic gait θ(φ) with a Fourier series of order ``order`` per joint.

    Parameters
    ----------
    coefficients : ndarray of shape (d, 2K + 1)
        Per joint ``[a_0, a_1..a_K, b_1..b_K]``.

    Examples
    --------
    >>> gait = FourierGait.from_params([0.0, 1.0, 0.0, 0.0, 0.0, 1.0], n_joints=2)
    >>> gait.shape(0.0).round(6)
    array([1., 0.])
    >>> gait.joint_limit().round(6)
    array([1., 1.])
    """

    coefficients: np.ndarray

    def __post_init__(self):
        coefficients = check_array(self.coefficients, "coefficients", "FourierGait", ndim=2)
        if coefficients.shape[1] % 2 != 1 or coefficients.shape[0] < 1:
            raise fail(
                "coefficients", "FourierGait", "an array of shape (d, 2K + 1) with d >= 1",
                f"shape {coefficients.shape}",
            )
        coefficients = coefficients.copy()
        coefficients.setflags(write=False)
        object.__setattr__(self, "coefficients", coefficients)

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_params(cls, params, n_joints: int) -> FourierGait:
        """Build from the flat parameter vector of length ``n_joints * (2K + 1)``.

        Parameters
        ----------
        params : array-like of shape (n_joints * (2K + 1),)
            Joint by joint ``[a_j0, a_j1..a_jK, b_j1..b_jK]`` (radians).
        n_joints : int
            Shape dimension d (≥ 1); K follows from the length of ``params``.
        """
        n_joints = check_int(n_joints, "n_joints", "FourierGait.from_params", minimum=1)
        params = check_array(params, "params", "FourierGait.from_params", ndim=1)
        if params.size % n_joints or (params.size // n_joints) % 2 != 1:
            raise fail(
                "params", "FourierGait.from_params",
                f"a vector of length n_joints * (2K + 1) with n_joints = {n_joints}",
                f"length {params.size}",
            )
        return cls(params.reshape(n_joints, -1))

    @classmethod
    def from_shapes(cls, phase, shape, order: int) -> FourierGait:
        """Least-squares Fourier fit of sampled shapes ``(n, d)`` against phases ``(n,)``.

        Parameters
        ----------
        phase : array-like of shape (n,)
            Gait phase φ of each sample, radians; must spread over the cycle enough to determine
            ``2 * order + 1`` coefficients.
        shape : array-like of shape (n, d)
            Joint angles θ(φ) at each sample, radians.
        order : int
            Fourier order K (≥ 0) of the fitted gait.
        """
        order = check_int(order, "order", "FourierGait.from_shapes", minimum=0)
        shape = check_array(shape, "shape", "FourierGait.from_shapes", ndim=2)
        phase = check_array(phase, "phase", "FourierGait.from_shapes", ndim=1)
        if phase.shape[0] != shape.shape[0]:
            raise fail("phase", "FourierGait.from_shapes", f"of length {shape.shape[0]}",
                       f"length {phase.shape[0]}")
        solution, singular = block_lstsq(lambda rows: fourier_basis(phase[rows], order), shape)
        # (numpy.linalg.matrix_rank's tolerance)
        if np.count_nonzero(singular > singular.max() * max(phase.size, 2 * order + 1) * np.finfo(float).eps) \
                < 2 * order + 1:
            raise fail("phase", "FourierGait.from_shapes",
                       f"spread enough over the cycle to fit order {order}", "too few phases")
        return cls(solution.T)

    def with_order(self, order: int) -> FourierGait:
        """The same gait written in a Fourier family of another order (extra terms zero; truncating
        drops the higher harmonics)."""
        order = check_int(order, "order", "FourierGait.with_order", minimum=0)
        keep = min(order, self.order)
        coefficients = np.zeros((self.n_joints, 2 * order + 1))
        coefficients[:, 0] = self.coefficients[:, 0]
        coefficients[:, 1:1 + keep] = self.coefficients[:, 1:1 + keep]
        coefficients[:, 1 + order:1 + order + keep] = self.coefficients[:, 1 + self.order:1 + self.order + keep]
        return FourierGait(coefficients)

    def highest_harmonic(self) -> int:
        """The order of its highest non-zero harmonic (0 for a constant gait): the lowest order that holds it
        whole (:meth:`with_order` below it drops harmonics)."""
        nonzero = np.flatnonzero(np.any(self.coefficients[:, 1:1 + self.order] != 0, axis=0)
                                 | np.any(self.coefficients[:, 1 + self.order:] != 0, axis=0))
        return int(nonzero[-1]) + 1 if nonzero.size else 0

    def with_params(self, params) -> FourierGait:
        """Same family, new flat parameter vector.

        Parameters
        ----------
        params : array-like of shape (d * (2K + 1),)
            Flat Fourier parameters (see :meth:`from_params`) for this gait's number of joints.
        """
        return FourierGait.from_params(params, self.n_joints)

    # -- properties ---------------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Shape dimension d."""
        return self.coefficients.shape[0]

    @property
    def order(self) -> int:
        """Fourier order K."""
        return (self.coefficients.shape[1] - 1) // 2

    @property
    def params(self) -> np.ndarray:
        """Flat parameter vector of length ``d * (2K + 1)`` (a copy)."""
        return self.coefficients.ravel().copy()

    # -- evaluation ---------------------------------------------------------------------------
    def basis(self, phase, derivative: int = 0) -> np.ndarray:
        """Fourier basis at ``phase`` ``(...,)`` → ``(..., 2K + 1)``; θ = basis @ coefficients.T.

        It is also ∂θ_j/∂(coefficients of joint j), since θ is linear in its parameters.

        Parameters
        ----------
        phase : float or array-like of shape (...,)
            Gait phase φ in radians.
        derivative : int, default 0
            Order of the φ-derivative of the basis.
        """
        return fourier_basis(phase, self.order, derivative)

    def shape(self, phase) -> np.ndarray:
        """θ(φ): phases ``(...,)`` → shapes ``(..., d)``.

        Parameters
        ----------
        phase : float or array-like of shape (...,)
            Gait phase φ in radians.
        """
        return self.basis(phase) @ self.coefficients.T

    def velocity(self, phase) -> np.ndarray:
        """θ'(φ) = dθ/dφ: phases ``(...,)`` → ``(..., d)`` (multiply by φ̇ for a time rate).

        Parameters
        ----------
        phase : float or array-like of shape (...,)
            Gait phase φ in radians.
        """
        return self.basis(phase, 1) @ self.coefficients.T

    def acceleration(self, phase) -> np.ndarray:
        """θ''(φ) = d²θ/dφ²: phases ``(...,)`` → ``(..., d)``.

        Parameters
        ----------
        phase : float or array-like of shape (...,)
            Gait phase φ in radians.
        """
        return self.basis(phase, 2) @ self.coefficients.T

    def joint_limit(self, resolution: int = 1024) -> np.ndarray:
        """max over φ of |θ_j(φ)| per joint, shape ``(d,)``.

        A dense grid brackets each maximum; Newton steps on θ'(φ) = 0 refine it, so the result
        is exact to rounding for smooth gaits (closed form for order 1: |a_0| + √(a_1² + b_1²)).

        Parameters
        ----------
        resolution : int, default 1024
            Number of equally spaced phases of the grid that brackets each maximum.
        """
        phase = np.linspace(0, 2 * np.pi, resolution, endpoint=False)
        values = np.abs(self.shape(phase))  # (n, d)
        best = phase[np.argmax(values, axis=0)]  # (d,)
        joints = np.arange(self.n_joints)
        for _ in range(4):
            slope = self.velocity(best)[joints, joints]
            curvature = self.acceleration(best)[joints, joints]
            step = np.where(np.abs(curvature) > 1e-12, slope / np.where(curvature == 0, 1, curvature), 0)
            best = best - np.clip(step, -np.pi / resolution, np.pi / resolution)
        refined = np.abs(self.shape(best)[joints, joints])
        return np.maximum(refined, values.max(axis=0))

    def __eq__(self, other):
        return isinstance(other, FourierGait) and np.array_equal(self.coefficients, other.coefficients)

    def __hash__(self):
        return hash(self.coefficients.tobytes())

    def __repr__(self):
        return f"FourierGait(n_joints={self.n_joints}, order={self.order}, params={self.params.round(4).tolist()})"


def seed_gait(n_joints: int, amplitude: float = 1.0, order: int = 1) -> FourierGait:
    r"""The paper's seed gait: first order, equal phase lags.

    .. math:: \theta_j(\phi) = a\cos(\phi - j\Delta), \quad \Delta = 2\pi / \max(d, 4)

    so Δ = π/2 for the 3- and 5-link swimmers and π/4 for the 9-link swimmer. ``order`` > 1
    embeds the same gait in a higher-order family (extra coefficients zero).

    Parameters
    ----------
    n_joints : int
        Shape dimension d (≥ 1).
    amplitude : float > 0, default 1.0
        Joint amplitude a in radians.
    order : int, default 1
        Fourier order K (≥ 1) of the returned gait.
    """
    n_joints = check_int(n_joints, "n_joints", "seed_gait", minimum=1)
    amplitude = check_float(amplitude, "amplitude", "seed_gait", low=0, low_open=True)
    order = check_int(order, "order", "seed_gait", minimum=1)
    lag = 2 * np.pi / max(n_joints, 4)
    joints = np.arange(n_joints)
    coefficients = np.zeros((n_joints, 2 * order + 1))
    coefficients[:, 1] = amplitude * np.cos(joints * lag)
    coefficients[:, order + 1] = amplitude * np.sin(joints * lag)
    return FourierGait(coefficients)
