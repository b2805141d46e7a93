r"""The 3-link wheeled kinematic snake (Ostrowski; Hatton & Choset).

Three links joined by two revolute joints, each link carrying a passive wheel axle that cannot slip
sideways. As in :class:`~geogait.systems.PurcellSwimmer`, the shape ``r_j`` is the angle of link
j+1 relative to link j, and the body frame is the centre of the middle link, oriented along it.
Link i's wheel sits at fraction :math:`w_i` of its length from the link's rear end (the end nearer
link 0). In the body frame the rear link points along :math:`\beta_0 = -r_0`, the front link along
:math:`\beta_2 = r_1`, and the wheels sit at

.. math:: p_0 = (-H, 0) - c_0 e(\beta_0),\quad p_1 = (a, 0),\quad p_2 = (H, 0) + c_2 e(\beta_2)

with :math:`H = l_1/2`, :math:`a = (w_1 - \tfrac12) l_1`, :math:`c_0 = (1 - w_0) l_0`,
:math:`c_2 = w_2 l_2` and :math:`e(\beta) = (\cos\beta, \sin\beta)`. No lateral slip of wheel i,
:math:`n_i\cdot(v + \omega\times p_i + \dot p_i) = 0` with :math:`n_i = e(\beta_i + \pi/2)`, gives
three rows :math:`\Omega(r)\,\xi = -B\dot r`:

.. math::
   \Omega = \begin{pmatrix} \sin r_0 & \cos r_0 & -(H\cos r_0 + c_0) \\
                            0 & 1 & a \\
                            -\sin r_1 & \cos r_1 & H\cos r_1 + c_2 \end{pmatrix},\qquad
   B = \begin{pmatrix} c_0 & 0 \\ 0 & 0 \\ 0 & c_2 \end{pmatrix},

so :math:`\xi = -A(r)\dot r` with :math:`A = \Omega^{-1} B` (the sign of paper eq. 1). In closed
form, with :math:`d_f = H - a` and :math:`d_b = H + a` (middle wheel to front and rear joint),

.. math::
   A = \frac{1}{D(r)}\begin{pmatrix} c_0 (d_f\cos r_1 + c_2) & c_2 (d_b\cos r_0 + c_0) \\
                                     -a\,c_0 \sin r_1 & -a\,c_2 \sin r_0 \\
                                     c_0 \sin r_1 & c_2 \sin r_0 \end{pmatrix},\qquad
   D = \det\Omega = \sin r_0\,(d_f\cos r_1 + c_2) - \sin r_1\,(d_b\cos r_0 + c_0).

The connection is singular on :math:`D(r) = 0`, where the three axle lines meet in one point (or
are parallel) and the constraints no longer fix the body velocity. For equal links with centred
wheels, :math:`D = H(1 + \cos r_0)(1 + \cos r_1)(\tan\frac{r_0}{2} - \tan\frac{r_1}{2})`, so the
singular set inside :math:`(-\pi, \pi)^2` is the line :math:`r_0 = r_1` (the snake bent into one
arc). Near it the progress per cycle is unbounded.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .._validation import check_array, check_float, check_int, fail
from ..gaits import FourierGait
from ._base import check_shapes

__all__ = ["KinematicSnake"]

#: Samples of the singular curve per parametrisation (by r₀ and by r₁): spacing 2π/4096 ≈ 1.5e-3
#: rad; the nearest sample is then refined onto the curve (:meth:`KinematicSnake.singular_distance`).
_CURVE_SAMPLES = 4096


@dataclass(frozen=True)
class KinematicSnake:
    """Three-link wheeled kinematic snake (a :class:`~geogait.systems.System` with a feasible region).

    Parameters
    ----------
    link_lengths : array-like of shape (3,), optional
        Positive link lengths, rear to front; equal links of total length 1 by default.
    wheel_positions : array-like of shape (3,), default (0.5, 0.5, 0.5)
        Wheel (axle) position on each link as a fraction in [0, 1] of its length from the link's
        rear end; 0.5 puts the wheels at the link centres. The rear link's wheel must not sit on
        the rear joint (fraction 1) nor the front link's on the front joint (fraction 0): such a
        link would be unconstrained.
    margin : float in [0, π), default 0.2
        Least distance (radians, Euclidean in shape space) a gait must keep from the singular set
        ``D(r) = 0``; :meth:`feasible` and :meth:`feasibility` use it, and so does
        :func:`~geogait.optimize.optimize_ceiling`.

    Notes
    -----
    The closed-form connection and its singular set are derived in the module docstring.

    Examples
    --------
    >>> snake = KinematicSnake()
    >>> bool(snake.singular([0.3, 0.3])), bool(snake.feasible([0.6, -0.6]))
    (True, True)
    >>> round(float(snake.singular_distance([0.5, 0.0])), 4)  # |r0 - r1| / sqrt(2)
    0.3536
    """

    link_lengths: tuple[float, ...] | None = None
    wheel_positions: tuple[float, ...] = (0.5, 0.5, 0.5)
    margin: float = 0.2
    _curve: np.ndarray = field(init=False, repr=False, compare=False)
    _curve_tree: cKDTree = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        owner = "KinematicSnake"
        if self.link_lengths is None:
            lengths = np.full(3, 1.0 / 3)
        else:
            lengths = check_array(self.link_lengths, "link_lengths", owner, ndim=1)
            if lengths.shape != (3,) or np.any(lengths < 1e-6) or np.any(lengths > 1e6):
                raise fail("link_lengths", owner, "3 lengths in [1e-6, 1e6] (rear, middle, front), as a swimmer's",
                           self.link_lengths)
        wheels = check_array(self.wheel_positions, "wheel_positions", owner, ndim=1)
        if wheels.shape != (3,) or np.any(wheels < 0) or np.any(wheels > 1):
            raise fail("wheel_positions", owner, "3 fractions in [0, 1] (rear, middle, front)", self.wheel_positions)
        if wheels[0] == 1 or wheels[2] == 0:
            raise fail("wheel_positions", owner, "fractions with the rear wheel off the rear joint (< 1) and the "
                       "front wheel off the front joint (> 0)", self.wheel_positions)
        check_float(self.margin, "margin", owner, low=0, high=np.pi, high_open=True)
        object.__setattr__(self, "link_lengths", tuple(float(x) for x in lengths))
        object.__setattr__(self, "wheel_positions", tuple(float(x) for x in wheels))
        object.__setattr__(self, "margin", float(self.margin))
        object.__setattr__(self, "_curve", self._singular_curve())
        object.__setattr__(self, "_curve_tree", cKDTree(self._curve))

    n_joints = 2

    @property
    def name(self) -> str:
        return "kinematic-snake"

    def _geometry(self):
        """(H, a, c0, c2): half middle length, middle wheel offset, rear and front wheel arms."""
        l0, l1, l2 = self.link_lengths
        w0, w1, w2 = self.wheel_positions
        return l1 / 2, (w1 - 0.5) * l1, (1 - w0) * l0, w2 * l2

    def _determinant(self, r0, r1):
        half, a, c0, c2 = self._geometry()
        return np.sin(r0) * ((half - a) * np.cos(r1) + c2) - np.sin(r1) * ((half + a) * np.cos(r0) + c0)

    def connection(self, shapes) -> np.ndarray:
        """Local connection A(r): shapes ``(..., 2)`` → ``(..., 3, 2)``, with ξ = -A ṙ (eq. 1).

        Closed form of the module docstring; on the singular set (D = 0) the entries are ±inf or NaN.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles (r₀, r₁), radians.
        """
        shapes = check_shapes(shapes, 2, "KinematicSnake.connection")
        half, a, c0, c2 = self._geometry()
        r0, r1 = shapes[..., 0], shapes[..., 1]
        s0, k0, s1, k1 = np.sin(r0), np.cos(r0), np.sin(r1), np.cos(r1)
        columns = np.stack([
            np.stack([c0 * ((half - a) * k1 + c2), -a * c0 * s1, c0 * s1], axis=-1),
            np.stack([c2 * ((half + a) * k0 + c0), -a * c2 * s0, c2 * s0], axis=-1)], axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return columns / self._determinant(r0, r1)[..., None, None]

    def constraint_determinant(self, shapes) -> np.ndarray:
        """D(r) = det Ω(r), shapes ``(..., 2)`` → ``(...,)``; the connection is singular where D = 0.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles, radians.
        """
        shapes = check_shapes(shapes, 2, "KinematicSnake.constraint_determinant")
        return self._determinant(shapes[..., 0], shapes[..., 1])

    def singular(self, shapes, tolerance: float = 1e-9) -> np.ndarray:
        """Whether shapes ``(..., 2)`` lie on the singular set, |D(r)| ≤ ``tolerance`` · L → ``(...,)``.

        L is the snake's largest length (link or wheel arm), the scale of D.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles, radians.
        tolerance : float >= 0
            Relative to L.
        """
        tolerance = check_float(tolerance, "tolerance", "KinematicSnake.singular", low=0)
        _, _, c0, c2 = self._geometry()
        return np.abs(self.constraint_determinant(shapes)) <= tolerance * max(c0, c2, max(self.link_lengths))

    def _singular_curve(self) -> np.ndarray:
        """Points ``(m, 2)`` of D = 0 in [-π, π]², solved for r₁ given r₀ and for r₀ given r₁.

        Each is α cos x + β sin x = γ, so x = atan2(β, α) ± arccos(γ / √(α² + β²)).
        """
        half, a, c0, c2 = self._geometry()
        t = np.linspace(-np.pi, np.pi, _CURVE_SAMPLES)
        st, ct = np.sin(t), np.cos(t)
        points = []
        for alpha, beta, gamma, given_first in (
                (st * (half - a), -((half + a) * ct + c0), -st * c2, True),  # r1 given r0 = t
                (-st * (half + a), (half - a) * ct + c2, st * c0, False)):  # r0 given r1 = t
            rho = np.hypot(alpha, beta)
            ok = rho > 1e-12
            ratio = np.where(ok, gamma / np.where(ok, rho, 1.0), 2.0)
            ok &= np.abs(ratio) <= 1
            for sign in (1, -1):
                x = np.arctan2(beta, alpha) + sign * np.arccos(np.clip(ratio, -1, 1))
                x = (x + np.pi) % (2 * np.pi) - np.pi
                pair = np.stack([t, x] if given_first else [x, t], axis=-1)
                points.append(pair[ok])
        curve = np.concatenate(points)
        for axis in (0, 1):  # a branch on an edge of the square lies on both edges (-π and π)
            edge = curve[np.abs(np.abs(curve[:, axis]) - np.pi) < 1e-9]
            curve = np.concatenate([curve, edge * np.where(np.arange(2) == axis, -1, 1)])
        return curve

    def _determinant_gradient(self, r0, r1):
        """∂D/∂r ``(..., 2)``."""
        half, a, c0, c2 = self._geometry()
        s0, k0, s1, k1 = np.sin(r0), np.cos(r0), np.sin(r1), np.cos(r1)
        return np.stack([k0 * ((half - a) * k1 + c2) + (half + a) * s0 * s1,
                         -(half - a) * s0 * s1 - k1 * ((half + a) * k0 + c0)], axis=-1)

    def _nearest(self, shapes):
        """Distance ``(...,)`` to the singular set and the unit direction away from it.

        The nearest of the sampled points is refined into the foot point on D = 0 by alternating a
        Newton step onto the curve and a step along its tangent (four rounds: to rounding).
        """
        flat = shapes.reshape(-1, 2)
        _, index = self._curve_tree.query(flat)
        foot = self._curve[index]
        for _ in range(4):
            gradient = self._determinant_gradient(foot[:, 0], foot[:, 1])
            norm2 = np.maximum(np.einsum("nk,nk->n", gradient, gradient), 1e-300)
            foot = foot - (self._determinant(foot[:, 0], foot[:, 1]) / norm2)[:, None] * gradient
            tangent = np.stack([-gradient[:, 1], gradient[:, 0]], axis=-1) / np.sqrt(norm2)[:, None]
            foot = foot + np.einsum("nk,nk->n", flat - foot, tangent)[:, None] * tangent
        gradient = self._determinant_gradient(foot[:, 0], foot[:, 1])
        norm2 = np.maximum(np.einsum("nk,nk->n", gradient, gradient), 1e-300)
        foot = foot - (self._determinant(foot[:, 0], foot[:, 1]) / norm2)[:, None] * gradient
        away = flat - foot
        distance = np.hypot(away[:, 0], away[:, 1])
        direction = away / np.maximum(distance, 1e-15)[:, None]
        return distance.reshape(shapes.shape[:-1]), direction.reshape(shapes.shape)

    def singular_distance(self, shapes) -> np.ndarray:
        """Euclidean distance (rad) from shapes ``(..., 2)`` to the singular set D = 0 → ``(...,)``.

        The set is sampled once (spacing ≈ 1.5e-3 rad along either joint); the nearest sample is
        refined into the foot point on D = 0 by Newton and tangent steps, which makes the distance
        exact to rounding (for equal links with centred wheels it is
        :math:`\\min(|r_0 - r_1|/\\sqrt 2,\\ \\pi - \\max_j |r_j|)`). Shapes are taken in
        [-π, π]² without wrapping.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles, radians.
        """
        shapes = check_shapes(shapes, 2, "KinematicSnake.singular_distance")
        return self._nearest(shapes)[0]

    def feasibility(self, shapes, jacobian: bool = False):
        """Signed feasibility g(r) = distance to the singular set − margin, ≥ 0 where feasible.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles, radians.
        jacobian : bool, default False
            Also return ∂g/∂r ``(..., 2)`` (the unit vector from the nearest singular point).

        Returns
        -------
        g : ndarray of shape (...,)
        gradient : ndarray of shape (..., 2), only when ``jacobian``
        """
        shapes = check_shapes(shapes, 2, "KinematicSnake.feasibility")
        distance, direction = self._nearest(shapes)
        return (distance - self.margin, direction) if jacobian else distance - self.margin

    def feasible(self, shapes) -> np.ndarray:
        """Whether shapes ``(..., 2)`` keep at least ``margin`` from the singular set → bool ``(...,)``.

        Parameters
        ----------
        shapes : array-like of shape (..., 2)
            Joint angles, radians.
        """
        return self.feasibility(shapes) >= 0

    def seed_gait(self, amplitude: float | None = None, order: int = 1) -> FourierGait:
        r"""A feasible starting gait: a circle of radius ``amplitude`` about (c, −c).

        .. math:: r_0 = c + a\cos\phi,\quad r_1 = -c + a\sin\phi,\qquad
           c = 0.6 + \max(0, m - 0.4),\quad a = \min(0.5,\ 0.8(\sqrt2\,c - m))

        with m the margin: the circle keeps √2 c − a ≥ m from the line r₀ = r₁, the equal-link
        snake's singular set (the paper's :func:`~geogait.gaits.seed_gait`, a circle about the
        origin, crosses it twice per cycle). Other geometries may need a start of their own.

        Parameters
        ----------
        amplitude : float in (0, c], optional
            Radius a, radians; by default the largest of the formula above.
        order : int, default 1
            Fourier order of the returned gait (extra coefficients zero).
        """
        centre = 0.6 + max(0.0, self.margin - 0.4)
        if amplitude is None:
            amplitude = min(0.5, 0.8 * (np.sqrt(2) * centre - self.margin))
        amplitude = check_float(amplitude, "amplitude", "KinematicSnake.seed_gait", low=0, high=centre,
                                low_open=True)
        order = check_int(order, "order", "KinematicSnake.seed_gait", minimum=1)
        coefficients = np.zeros((2, 2 * order + 1))
        coefficients[:, 0] = [centre, -centre]
        coefficients[0, 1] = amplitude
        coefficients[1, order + 1] = amplitude
        gait = FourierGait(coefficients)
        # (the circle keeps off r0 = r1 but not off the singular edges |r_j| = pi that a large margin moves it to)
        if self.feasibility(gait.shape(np.linspace(0, 2 * np.pi, 512, endpoint=False))).min() < 0:
            raise fail("margin", "KinematicSnake.seed_gait", "a margin whose seed circle stays in the feasible region "
                       "(it leaves it near |r_j| = pi; give optimize_ceiling a start of your own)", self.margin)
        return gait
