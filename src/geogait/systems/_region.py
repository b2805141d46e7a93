r"""A feasible shape region of the user's on any system (a joint that must stay bent one way, a
self-collision, a singular set the user knows), and linear shape limits a robot declares.

The user gives a smooth margin :math:`g(r)`, positive inside the region (radians for a distance);
:class:`RegionSystem` makes the system a :class:`~geogait.systems.FeasibleSystem`, so that
:func:`~geogait.optimize.optimize_ceiling`, the trust-region step rules and
:class:`~geogait.optimize.InSituOptimizer` (on a simulator) keep every gait inside it on their phase
grids, as they keep the joint limits. Its gradient is the user's, or central differences.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable

import numpy as np

from .._validation import MAX_MAGNITUDE, GeogaitError, check_array, check_float, check_int, fail, not_real
from ..gaits import FourierGait
from ._base import check_shapes

__all__ = ["LinearRegion", "RegionSystem"]

_STEP = 1e-6  # central differences of the margin (error ~1e-10 for a smooth g of unit scale)
_CHECK_PHASES = 1024  # the seed gait is checked on this many phases


class RegionSystem:
    r"""A system restricted to the shapes where a margin function is non-negative (module docstring).

    Parameters
    ----------
    system : System
        Any system (its connection is used unchanged).
    feasibility : callable
        ``g(shapes (..., d)) -> (...,)``, ≥ 0 inside the region, smooth across its boundary.
    seed : FourierGait
        A gait inside the region (checked on 1024 phases): where the ceiling and the optimiser start.
    gradient : callable, optional
        ``∂g/∂r (shapes (..., d)) -> (..., d)``; central differences (step 1e-6) by default.
    name : str, optional
        Default: the system's name with " (region)".

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> from geogait.systems import PurcellSwimmer
    >>> bent_right = RegionSystem(PurcellSwimmer(3), lambda r: 0.8 - r[..., 0], seed=seed_gait(2, amplitude=0.7))
    >>> bool(bent_right.feasible([0.5, 1.5])), bool(bent_right.feasible([0.9, 0.0]))
    (True, False)
    """

    def __init__(self, system, feasibility: Callable, *, seed: FourierGait, gradient: Callable | None = None,
                 name: str | None = None):
        owner = "RegionSystem"
        if not callable(getattr(system, "connection", None)) or not hasattr(system, "n_joints"):
            raise fail("system", owner, "a System (connection(shapes), n_joints)", type(system).__name__)
        for parameter, value in (("feasibility", feasibility), ("gradient", gradient)):
            if (value is not None or parameter == "feasibility") and not callable(value):
                raise fail(parameter, owner, "a callable of shapes (..., d)", value)
        self.system, self.n_joints = system, int(system.n_joints)
        self.name = name or f"{getattr(system, 'name', 'system')} (region)"
        self._margin, self._gradient = feasibility, gradient
        if not isinstance(seed, FourierGait) or seed.n_joints != self.n_joints:
            raise fail("seed", owner, f"a FourierGait with {self.n_joints} joints", seed)
        lowest = float(self.feasibility(seed.shape(np.linspace(0, 2 * np.pi, _CHECK_PHASES, endpoint=False))).min())
        if lowest < 0:
            raise fail("seed", owner, "a gait inside the region (feasibility ≥ 0 at every phase)",
                       f"a gait whose feasibility falls to {lowest:.4g}")
        self._seed = seed
        probe = np.random.default_rng(0).uniform(-np.pi, np.pi, (64, self.n_joints))
        digest = hashlib.sha256(np.ascontiguousarray(self.feasibility(probe)).tobytes())
        digest.update(seed.coefficients.tobytes())
        self._digest = digest.hexdigest()[:16]  # in the repr: the ceiling cache keys on it

    def __repr__(self) -> str:
        return f"RegionSystem({self.system!r}, name={self.name!r}, sha256={self._digest})"

    def connection(self, shapes) -> np.ndarray:
        """The system's connection ``(..., 3, d)``, unchanged.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
        """
        return self.system.connection(shapes)

    def feasibility(self, shapes, jacobian: bool = False):
        """The user's margin g(r) ``(...,)`` (and ∂g/∂r ``(..., d)`` with ``jacobian``), checked.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
        jacobian : bool, default False
        """
        shapes = check_shapes(shapes, self.n_joints, f"{self.name}.feasibility")
        value = self._evaluate(self._margin, shapes, shapes.shape[:-1], "feasibility")
        if not jacobian:
            return value
        if self._gradient is not None:
            return value, self._evaluate(self._gradient, shapes, shapes.shape, "gradient")
        steps = np.eye(self.n_joints) * _STEP
        gradient = np.stack([(self._evaluate(self._margin, shapes + e, shapes.shape[:-1], "feasibility")
                              - self._evaluate(self._margin, shapes - e, shapes.shape[:-1], "feasibility"))
                             / (2 * _STEP) for e in steps], axis=-1)
        return value, gradient

    def feasible(self, shapes) -> np.ndarray:
        """``feasibility(shapes) >= 0`` as bool ``(...,)``.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
        """
        return self.feasibility(shapes) >= 0

    def seed_gait(self, amplitude: float | None = None, order: int = 1) -> FourierGait:
        """The seed, in Fourier order ``order``; with ``amplitude``, its oscillation about its offsets
        rescaled so that the largest joint amplitude is ``amplitude`` (it must stay inside the region).

        Parameters
        ----------
        amplitude : float, optional
        order : int, default 1
        """
        order = check_int(order, "order", f"{self.name}.seed_gait", minimum=1)
        if order < self._seed.highest_harmonic():
            raise fail("order", f"{self.name}.seed_gait", f"at least the seed's order {self._seed.order} (its higher "
                       "harmonics would be dropped)", order)
        gait = self._seed.with_order(order)
        if amplitude is not None:
            amplitude = check_float(amplitude, "amplitude", f"{self.name}.seed_gait", low=0, low_open=True)
            coefficients = gait.coefficients.copy()
            largest = float(np.max(gait.joint_limit() - np.abs(coefficients[:, 0])))
            if largest == 0:  # (a constant seed: nothing to scale)
                raise fail("amplitude", f"{self.name}.seed_gait", "a positive amplitude of an oscillating seed",
                           amplitude)
            coefficients[:, 1:] *= amplitude / largest
            gait = FourierGait(coefficients)
            shapes = gait.shape(np.linspace(0, 2 * np.pi, _CHECK_PHASES, endpoint=False))
            if np.any(self.feasibility(shapes) < 0):
                raise fail("amplitude", f"{self.name}.seed_gait", "an amplitude that keeps the seed inside the region",
                           amplitude)
        return gait

    def _evaluate(self, function, shapes, expected, what):
        value = function(shapes)
        odd = not_real(value)
        if odd is not None:  # (NumPy would drop an imaginary part or read True as 1)
            raise GeogaitError(f"The '{what}' callable of {self.name} must return real numbers. Got {odd} instead.")
        value = np.asarray(value, dtype=float)
        if value.shape != expected:
            raise GeogaitError(f"The '{what}' callable of {self.name} must return an array of shape {expected} for "
                               f"shapes of shape {shapes.shape}. Got shape {value.shape} instead.")
        if not np.all(np.isfinite(value)):
            raise GeogaitError(f"The '{what}' callable of {self.name} must return finite values. Got NaN or inf.")
        if value.size and np.abs(value).max() > MAX_MAGNITUDE:
            raise GeogaitError(f"The '{what}' callable of {self.name} must return values within ±{MAX_MAGNITUDE:g}. "
                               f"Got {float(np.abs(value).max()):g}.")
        return value


class LinearRegion:
    r"""Shapes within linear limits :math:`a_i \cdot r \le b_i`: the region a robot declares without a
    simulator (joints that may not bend far against each other, :math:`|r_0 - r_1| \le c`; a self-collision
    half-plane).

    The margin is the least signed distance to a face, :math:`g(r) = \min_i (b_i - a_i\cdot r) / |a_i|` (in the
    shape's units: radians for joint angles), with the gradient of the nearest face. A robot offers it as its
    ``feasibility`` (the bridge's hello field ``"shape_constraints"``), and
    :class:`~geogait.optimize.InSituOptimizer` and :class:`~geogait.control.PathTracker` keep every gait they
    command inside it on their phase grids, as they keep the joint limits.

    Parameters
    ----------
    normals : array-like of shape (m, d)
        The rows :math:`a_i`, none zero.
    bounds : array-like of shape (m,)
        The :math:`b_i`.

    Examples
    --------
    >>> bent_apart = LinearRegion([[1.0, -1.0], [-1.0, 1.0]], [1.2, 1.2])  # |r0 - r1| <= 1.2
    >>> bool(bent_apart.feasible([0.5, -0.5])), bool(bent_apart.feasible([0.8, -0.8]))
    (True, False)
    >>> round(float(bent_apart.feasibility([0.0, 0.0])), 4)  # 1.2 / sqrt(2)
    0.8485
    """

    def __init__(self, normals, bounds):
        owner = "LinearRegion"
        normals = check_array(normals, "normals", owner, ndim=2, limit=MAX_MAGNITUDE)
        bounds = check_array(bounds, "bounds", owner, ndim=1, limit=MAX_MAGNITUDE)
        if normals.shape[0] < 1 or bounds.shape != (normals.shape[0],):
            raise fail("normals", owner, "an (m, d) array with m >= 1 and bounds of shape (m,)",
                       f"shapes {normals.shape} and {bounds.shape}")
        lengths = np.linalg.norm(normals, axis=1)
        if not np.all(lengths > 0):  # (finite: check_array)
            raise fail("normals", owner, "rows none of which is zero", normals.tolist())
        self.normals, self.bounds, self._lengths = normals, bounds, lengths

    @classmethod
    def from_rows(cls, rows) -> LinearRegion:
        """From rows ``[a_0, …, a_{d-1}, b]`` (the bridge hello's ``"shape_constraints"``)."""
        rows = check_array(rows, "rows", "LinearRegion.from_rows", limit=MAX_MAGNITUDE)
        if rows.ndim != 2 or rows.shape[1] < 2:
            raise fail("rows", "LinearRegion.from_rows", "rows [a_0, ..., a_(d-1), b]", f"shape {rows.shape}")
        return cls(rows[:, :-1], rows[:, -1])

    @property
    def n_joints(self) -> int:
        return self.normals.shape[1]

    def __repr__(self) -> str:
        return f"LinearRegion(normals={self.normals.tolist()}, bounds={self.bounds.tolist()})"

    def feasibility(self, shapes, jacobian: bool = False):
        """Signed margin g(r) ``(...,)``, ≥ 0 inside (and ∂g/∂r ``(..., d)`` with ``jacobian``).

        Parameters
        ----------
        shapes : array-like of shape (..., d)
        jacobian : bool, default False
        """
        shapes = check_shapes(shapes, self.n_joints, "LinearRegion.feasibility")
        distance = (self.bounds - shapes @ self.normals.T) / self._lengths  # (..., m)
        nearest = np.argmin(distance, axis=-1)
        margin = np.take_along_axis(distance, nearest[..., None], axis=-1)[..., 0]
        if not jacobian:
            return margin
        return margin, -(self.normals / self._lengths[:, None])[nearest]

    def feasible(self, shapes) -> np.ndarray:
        """``feasibility(shapes) >= 0`` as a bool array ``(...,)``."""
        return self.feasibility(shapes) >= 0
