r"""The special Euclidean group SE(2) and its Lie algebra se(2).

Poses are arrays ``(..., 3)`` = (x, y, heading); twists (body velocities) are arrays
``(..., 3)`` = (v_x, v_y, omega). Every function is vectorised over leading axes.

The exponential is exact (no Euler step on x, y, heading):

.. math::
    \exp(\hat\xi) = \bigl(V(\omega)\, v,\ \omega\bigr), \qquad
    V(\omega) = \frac{1}{\omega}\begin{bmatrix}\sin\omega & -(1-\cos\omega)\\
    1-\cos\omega & \sin\omega\end{bmatrix},

with Taylor series near :math:`\omega = 0`.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_array, check_choice, fail

__all__ = [
    "hat",
    "vee",
    "exp",
    "log",
    "compose",
    "inverse",
    "between",
    "adjoint",
    "bracket",
    "wrap_angle",
    "integrate_body_velocity",
    "displacement",
    "body_velocity_from_poses",
    "product_of_exponentials",
    "gauss_phases",
    "magnus_steps",
    "integrate_cycle",
]

#: |ω| below which exp and log use the series of sin(ω)/ω and (1 − cos ω)/ω (the compiled kernels too).
SERIES_THRESHOLD = 1e-4


def wrap_angle(angle):
    """Wrap angles to ``[-pi, pi)``.

    Parameters
    ----------
    angle : float or array-like
        Angle(s) in radians, any shape.

    Returns
    -------
    ndarray
        The same angles shifted by multiples of 2π into ``[-pi, pi)``.
    """
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def _elements(value, name: str, owner: str, shape: tuple = (3,)) -> np.ndarray:
    """``value`` as floats whose trailing axes are ``shape`` (a twist or pose: 3 entries; a matrix: 3 × 3), or an
    error naming it (a 4th entry was silently ignored, a 2-vector an IndexError)."""
    array = np.asarray(value, dtype=float)
    if array.shape[array.ndim - len(shape):] != shape:
        raise fail(name, owner, f"an array of shape (..., {', '.join(map(str, shape))})", f"shape {array.shape}")
    return array


def _durations(dt, steps_shape: tuple, owner: str) -> np.ndarray:
    """Step durations ``dt`` (finite, ≥ 0) broadcast to the steps' ``steps_shape`` (…, n)."""
    dt = check_array(dt, "dt", owner)
    if np.any(dt < 0):
        raise fail("dt", owner, "durations >= 0", f"{int(np.count_nonzero(dt < 0))} negative value(s)")
    try:
        return np.broadcast_to(dt, steps_shape)
    except ValueError:
        raise fail("dt", owner, f"a float or an array that broadcasts to the steps' shape {steps_shape}",
                   f"shape {dt.shape}") from None


def hat(twist) -> np.ndarray:
    """Twist ``(..., 3)`` to its 3x3 matrix in se(2), ``(..., 3, 3)``.

    Parameters
    ----------
    twist : array-like of shape (..., 3)
        (v_x, v_y, omega): linear velocity (body lengths per unit time) and angular velocity (radians per
        unit time), or any such twist already multiplied by a duration.
    """
    twist = _elements(twist, "twist", "hat")
    out = np.zeros(twist.shape[:-1] + (3, 3))
    out[..., 0, 1] = -twist[..., 2]
    out[..., 1, 0] = twist[..., 2]
    out[..., 0, 2] = twist[..., 0]
    out[..., 1, 2] = twist[..., 1]
    return out


def vee(matrix) -> np.ndarray:
    """Inverse of :func:`hat`: ``(..., 3, 3)`` se(2) matrix to twist ``(..., 3)``."""
    matrix = _elements(matrix, "matrix", "vee", (3, 3))
    return np.stack([matrix[..., 0, 2], matrix[..., 1, 2], matrix[..., 1, 0]], axis=-1)


def _v_coefficients(omega):
    """sin(w)/w and (1 - cos w)/w, accurate for all w."""
    omega = np.asarray(omega, dtype=float)
    small = np.abs(omega) < SERIES_THRESHOLD
    safe = np.where(small, 1.0, omega)
    w2 = omega * omega
    s = np.where(small, 1 - w2 / 6 + w2 * w2 / 120, np.sin(safe) / safe)
    c = np.where(small, omega / 2 - omega * w2 / 24, (1 - np.cos(safe)) / safe)
    return s, c


def exp(twist) -> np.ndarray:
    """Group exponential: twist ``(..., 3)`` (already multiplied by time) to pose ``(..., 3)``."""
    twist = _elements(twist, "twist", "exp")
    vx, vy, omega = twist[..., 0], twist[..., 1], twist[..., 2]
    s, c = _v_coefficients(omega)
    return np.stack([s * vx - c * vy, c * vx + s * vy, omega], axis=-1)


def log(pose) -> np.ndarray:
    """Group logarithm: pose ``(..., 3)`` to the twist ``(..., 3)`` with heading in ``[-pi, pi)``."""
    pose = _elements(pose, "pose", "log")
    omega = wrap_angle(pose[..., 2])
    s, c = _v_coefficients(omega)
    det = s * s + c * c
    x, y = pose[..., 0], pose[..., 1]
    return np.stack([(s * x + c * y) / det, (-c * x + s * y) / det, omega], axis=-1)


def _rotate(angle, vec_x, vec_y):
    cos, sin = np.cos(angle), np.sin(angle)
    return cos * vec_x - sin * vec_y, sin * vec_x + cos * vec_y


def compose(first, second) -> np.ndarray:
    """Group product ``first * second`` of poses ``(..., 3)`` (broadcasting)."""
    first = _elements(first, "first", "compose")
    second = _elements(second, "second", "compose")
    dx, dy = _rotate(first[..., 2], second[..., 0], second[..., 1])
    return np.stack(
        np.broadcast_arrays(first[..., 0] + dx, first[..., 1] + dy, first[..., 2] + second[..., 2]),
        axis=-1,
    )


def inverse(pose) -> np.ndarray:
    """Group inverse of poses ``(..., 3)``.

    Parameters
    ----------
    pose : array-like of shape (..., 3)
        (x, y, heading): position in body lengths, heading in radians.
    """
    pose = np.asarray(pose, dtype=float)
    x, y = _rotate(-pose[..., 2], -pose[..., 0], -pose[..., 1])
    return np.stack([x, y, -pose[..., 2]], axis=-1)


def between(first, second) -> np.ndarray:
    """Relative pose ``first^{-1} * second``: the motion from ``first`` to ``second`` in
    ``first``'s frame."""
    return compose(inverse(first), second)


def adjoint(pose) -> np.ndarray:
    r"""Adjoint matrix ``(..., 3, 3)`` of poses ``(..., 3)``: :math:`\mathrm{Ad}_g \xi =
    (g\hat\xi g^{-1})^\vee`, i.e. ``[[R, (y, -x)^T], [0, 0, 1]]``.

    Parameters
    ----------
    pose : array-like of shape (..., 3)
        (x, y, heading) of g: position in body lengths, heading in radians.
    """
    pose = np.asarray(pose, dtype=float)
    cos, sin = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    out = np.zeros(pose.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = cos, -sin, pose[..., 1]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = sin, cos, -pose[..., 0]
    out[..., 2, 2] = 1.0
    return out


def bracket(first, second) -> np.ndarray:
    """Lie bracket ``[first, second]`` of twists ``(..., 3)``."""
    a = np.asarray(first, dtype=float)
    b = np.asarray(second, dtype=float)
    vx = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    vy = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out = np.zeros(vx.shape + (3,))  # vx and vy have the broadcast shape of a and b
    out[..., 0], out[..., 1] = vx, vy
    return out


def integrate_body_velocity(body_velocity, dt, initial_pose=None) -> np.ndarray:
    r"""Poses from a body-velocity time series held constant over each step.

    :math:`g_{n+1} = g_n \exp(\Delta t\, \hat\xi_n)` — exact for a zero-order-hold signal.
    Vectorised over time: the heading is a cumulative sum (rotations commute in SE(2)) and the
    translation a cumulative sum of rotated exact steps, so no Python loop runs over samples.

    Parameters
    ----------
    body_velocity : array-like of shape (..., n_samples, 3)
    dt : float or array-like of shape (..., n_samples)
        Duration of each step.
    initial_pose : array-like of shape (..., 3), optional
        Pose at the first sample; identity by default.

    Returns
    -------
    poses : ndarray of shape (..., n_samples + 1, 3)
        Pose before the first step followed by the pose after each step.
    """
    xi = check_array(body_velocity, "body_velocity", "integrate_body_velocity", trailing=(None, 3))
    steps = xi * _durations(dt, xi.shape[:-1], "integrate_body_velocity")[..., None]
    if initial_pose is None:
        initial_pose = np.zeros(xi.shape[:-2] + (3,))
    initial_pose = check_array(initial_pose, "initial_pose", "integrate_body_velocity", trailing=(3,))
    try:
        initial_pose = np.broadcast_to(initial_pose, xi.shape[:-2] + (3,))
    except ValueError:
        raise fail("initial_pose", "integrate_body_velocity", f"a pose that broadcasts to {xi.shape[:-2] + (3,)}",
                   f"shape {initial_pose.shape}") from None
    local = exp(steps)  # each step's motion in the frame at the start of the step
    heading_before = initial_pose[..., None, 2] + np.concatenate(
        [np.zeros(xi.shape[:-2] + (1,)), np.cumsum(steps[..., 2], axis=-1)], axis=-1
    )
    dx, dy = _rotate(heading_before[..., :-1], local[..., 0], local[..., 1])
    zero = np.zeros(xi.shape[:-2] + (1,))
    x = initial_pose[..., None, 0] + np.concatenate([zero, np.cumsum(dx, axis=-1)], axis=-1)
    y = initial_pose[..., None, 1] + np.concatenate([zero, np.cumsum(dy, axis=-1)], axis=-1)
    return np.stack([x, y, heading_before], axis=-1)


def displacement(body_velocity, dt) -> np.ndarray:
    """Net pose ``(..., 3)`` reached from the identity by :func:`integrate_body_velocity`.

    Parameters
    ----------
    body_velocity : array-like of shape (..., n_samples, 3)
        Body velocity (v_x, v_y, omega) held constant over each step.
    dt : float or array-like of shape (..., n_samples)
        Duration of each step (seconds, or the time unit of ``body_velocity``).
    """
    xi = check_array(body_velocity, "body_velocity", "displacement", trailing=(None, 3))
    return product_of_exponentials(xi * _durations(dt, xi.shape[:-1], "displacement")[..., None])


def body_velocity_from_poses(time, pose, *, scheme: str = "forward") -> np.ndarray:
    r"""Body velocity from world poses of one uniformly or irregularly sampled segment.

    .. math:: \xi_{n+1/2} = \log\bigl(g_n^{-1} g_{n+1}\bigr)^\vee / (t_{n+1} - t_n)

    ``"forward"`` assigns :math:`\xi_{n+1/2}` to sample n (exact inverse of
    :func:`integrate_body_velocity`; the last sample repeats the previous twist);
    ``"central"`` assigns the duration-weighted mean of :math:`\xi_{n-1/2}` and
    :math:`\xi_{n+1/2}` (one-sided at the ends).

    Parameters
    ----------
    time : array-like of shape (n,), strictly increasing, n >= 2
    pose : array-like of shape (n, 3)
        (x, y, heading); the heading may be wrapped (each step is taken modulo 2π).
    scheme : {"forward", "central"}

    Returns
    -------
    ndarray of shape (n, 3)

    Examples
    --------
    >>> import numpy as np
    >>> xi = np.tile([0.3, 0.1, 2.0], (50, 1))
    >>> poses = integrate_body_velocity(xi, 0.05)
    >>> recovered = body_velocity_from_poses(0.05 * np.arange(51), poses)
    >>> bool(np.allclose(recovered, [0.3, 0.1, 2.0]))
    True
    """
    owner = "body_velocity_from_poses"
    scheme = check_choice(scheme, "scheme", owner, ("forward", "central"))
    time = check_array(time, "time", owner, ndim=1)
    pose = check_array(pose, "pose", owner, trailing=(None, 3), ndim=2)
    if time.size < 2 or pose.shape != time.shape + (3,):
        raise fail("pose", owner, "an array of shape (n, 3) with n = len(time) >= 2", f"shape {pose.shape}")
    dt = np.diff(time)
    if np.any(dt <= 0):
        raise fail("time", owner, "strictly increasing",
                   f"a step of {dt.min():g} at index {int(np.argmin(dt))}")
    steps = log(between(pose[:-1], pose[1:])) / dt[:, None]
    if scheme == "forward":
        return np.concatenate([steps, steps[-1:]], axis=0)
    weights = dt[:-1, None], dt[1:, None]
    inner = (steps[:-1] * weights[0] + steps[1:] * weights[1]) / (weights[0] + weights[1])
    return np.concatenate([steps[:1], inner, steps[-1:]], axis=0)


def _v_derivatives(omega):
    """d/dω of sin(w)/w and (1 - cos w)/w."""
    omega = np.asarray(omega, dtype=float)
    small = np.abs(omega) < SERIES_THRESHOLD
    safe = np.where(small, 1.0, omega)
    w2 = omega * omega
    ds = np.where(small, -omega / 3 + omega * w2 / 30, (safe * np.cos(safe) - np.sin(safe)) / safe**2)
    dc = np.where(small, 0.5 - w2 / 8, (safe * np.sin(safe) - 1 + np.cos(safe)) / safe**2)
    return ds, dc


def product_of_exponentials(steps, step_jacobian=None):
    r"""Net pose :math:`\prod_n \exp(\hat\Omega_n)` of twists ``(..., n, 3)`` and, optionally, its
    Jacobian with respect to parameters ``p`` given :math:`\partial\Omega_n/\partial p`.

    The heading is :math:`\sum_n \omega_n` and the translation
    :math:`\sum_n R(\theta_{<n}) V(\omega_n) v_n` with :math:`\theta_{<n} = \sum_{k<n}\omega_k`;
    both are differentiated exactly (chain rule, no finite differences).

    Parameters
    ----------
    steps : array-like of shape (..., n, 3)
    step_jacobian : array-like of shape (..., n, 3, p), optional

    Returns
    -------
    pose : ndarray of shape (..., 3)
    jacobian : ndarray of shape (..., 3, p)
        Only when ``step_jacobian`` is given.
    """
    steps = np.asarray(steps, dtype=float)
    vx, vy, omega = steps[..., 0], steps[..., 1], steps[..., 2]
    s, c = _v_coefficients(omega)
    ux, uy = s * vx - c * vy, c * vx + s * vy  # V(ω) v: each step's motion in its start frame
    before = np.cumsum(omega, axis=-1) - omega  # θ_{<n}
    cos, sin = np.cos(before), np.sin(before)
    pose = np.stack([np.sum(cos * ux - sin * uy, -1), np.sum(sin * ux + cos * uy, -1), np.sum(omega, -1)], -1)
    if step_jacobian is None:
        return pose
    dstep = np.asarray(step_jacobian, dtype=float)
    dvx, dvy, domega = dstep[..., 0, :], dstep[..., 1, :], dstep[..., 2, :]
    ds, dc = _v_derivatives(omega)
    dux = (ds * vx - dc * vy)[..., None] * domega + s[..., None] * dvx - c[..., None] * dvy
    duy = (dc * vx + ds * vy)[..., None] * domega + c[..., None] * dvx + s[..., None] * dvy
    dbefore = np.cumsum(domega, axis=-2) - domega
    rx, ry = (cos * ux - sin * uy)[..., None], (sin * ux + cos * uy)[..., None]  # R(θ_<n) u_n
    dx = np.sum(cos[..., None] * dux - sin[..., None] * duy - ry * dbefore, axis=-2)
    dy = np.sum(sin[..., None] * dux + cos[..., None] * duy + rx * dbefore, axis=-2)
    return pose, np.stack([dx, dy, np.sum(domega, axis=-2)], axis=-2)


# -- fourth-order Magnus integration over one cycle ------------------------------------------------
_GAUSS = 0.5 + np.array([-1.0, 1.0]) * np.sqrt(3) / 6


def gauss_phases(resolution: int) -> tuple[np.ndarray, float]:
    """The two Gauss–Legendre nodes of each of ``resolution`` equal phase steps over [0, 2π), ``(n, 2)``,
    and the step."""
    if isinstance(resolution, bool) or not isinstance(resolution, int | np.integer) or resolution < 1:
        raise fail("resolution", "gauss_phases", "an int >= 1 (phase steps per cycle)", resolution)
    step = 2 * np.pi / resolution
    starts = np.arange(resolution) * step
    return starts[:, None] + step * _GAUSS, step


def magnus_steps(velocity_at_nodes: np.ndarray, step: float) -> np.ndarray:
    r"""Fourth-order Magnus twist per step from body velocities at the two Gauss nodes ``(..., n, 2, 3)``.

    :math:`\Omega = \tfrac h2(\xi_1 + \xi_2) + \tfrac{\sqrt3}{12}h^2[\xi_1, \xi_2]`; returns ``(..., n, 3)``.

    Parameters
    ----------
    velocity_at_nodes : ndarray of shape (..., n, 2, 3)
        Body velocity per unit phase, ξ₁ and ξ₂, at the two Gauss nodes of each step (see :func:`gauss_phases`).
    step : float
        Phase step h in radians (``2π / n``).
    """
    first, second = velocity_at_nodes[..., 0, :], velocity_at_nodes[..., 1, :]
    return step / 2 * (first + second) + np.sqrt(3) / 12 * step**2 * bracket(first, second)


def _magnus_step_jacobian(velocity_at_nodes: np.ndarray, velocity_jacobian: np.ndarray, step: float) -> np.ndarray:
    """Derivative of :func:`magnus_steps` given ∂ξ/∂p at the nodes ``(..., n, 2, 3, p)`` → ``(..., n, 3, p)``.

    The bracket is bilinear: d[ξ₁, ξ₂] = [dξ₁, ξ₂] + [ξ₁, dξ₂].
    """
    first, second = velocity_at_nodes[..., 0, None, :], velocity_at_nodes[..., 1, None, :]  # (..., n, 1, 3)
    d_first = np.swapaxes(velocity_jacobian[..., 0, :, :], -1, -2)  # (..., n, p, 3)
    d_second = np.swapaxes(velocity_jacobian[..., 1, :, :], -1, -2)
    d_bracket = bracket(d_first, second) + bracket(first, d_second)
    d_steps = step / 2 * (d_first + d_second) + np.sqrt(3) / 12 * step**2 * d_bracket
    return np.swapaxes(d_steps, -1, -2)


def integrate_cycle(velocity, step, velocity_jacobian=None):
    """Net motion over a cycle from body velocities per unit phase at the Gauss nodes of
    :func:`gauss_phases` ``(..., n, 2, 3)`` by :func:`magnus_steps` and exact exponentials (and its
    Jacobian when ``velocity_jacobian`` ``(..., n, 2, 3, p)`` is given).

    Parameters
    ----------
    velocity : ndarray of shape (..., n, 2, 3)
        Body velocity per unit phase at the two Gauss nodes of each of the n phase steps.
    step : float
        Phase step in radians, as returned by :func:`gauss_phases`.
    velocity_jacobian : ndarray of shape (..., n, 2, 3, p), optional
        Derivative of ``velocity`` with respect to p parameters.

    Returns
    -------
    pose : ndarray of shape (..., 3)
        Net displacement over the cycle.
    jacobian : ndarray of shape (..., 3, p)
        Only when ``velocity_jacobian`` is given.
    """
    steps = magnus_steps(velocity, step)
    if velocity_jacobian is None:
        return product_of_exponentials(steps)
    return product_of_exponentials(steps, _magnus_step_jacobian(velocity, velocity_jacobian, step))
