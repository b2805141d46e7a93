"""What every principally kinematic system offers downstream: a local connection A(r)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .. import se2
from .._validation import check_array, check_int, fail

__all__ = ["System", "FeasibleSystem", "FunctionSystem", "check_shapes"]


@runtime_checkable
class System(Protocol):
    r"""A principally kinematic locomotor, :math:`\xi = -A(r)\dot r` (paper eq. 1).

    Attributes
    ----------
    name : str
    n_joints : int
        Shape dimension d.
    """

    name: str
    n_joints: int

    def connection(self, shapes) -> np.ndarray:
        """Local connection A for shapes ``(..., d)``, returned as ``(..., 3, d)``."""
        ...


@runtime_checkable
class FeasibleSystem(Protocol):
    r"""A :class:`System` that also declares a feasible shape region (e.g. away from a singular set).

    Downstream, :func:`~geogait.optimize.optimize_ceiling` keeps every gait it tries inside the
    region on its phase grid, :math:`g(\theta(\phi_k)) \ge 0`, as it does the joint limits, and starts
    from :meth:`seed_gait` (and only from feasible random gaits).

    Methods
    -------
    feasibility(shapes, jacobian=False)
        Smooth signed margin g(r) ``(...,)``, ≥ 0 where feasible (and ∂g/∂r ``(..., d)`` with
        ``jacobian``); radians for a distance.
    feasible(shapes)
        ``feasibility(shapes) >= 0`` as a bool array ``(...,)``.
    seed_gait(amplitude=..., order=1)
        A feasible starting gait of Fourier order ``order``.
    """

    name: str
    n_joints: int

    def connection(self, shapes) -> np.ndarray:
        """Local connection A ``(..., 3, d)``.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
            Joint angles, radians.
        """
        ...

    def feasibility(self, shapes, jacobian: bool = False):
        """Signed margin g(r) ``(...,)``, ≥ 0 where feasible.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
            Joint angles, radians.
        jacobian : bool, default False
            Also return ∂g/∂r ``(..., d)``.
        """
        ...

    def feasible(self, shapes) -> np.ndarray:
        """``feasibility(shapes) >= 0``, bool ``(...,)``.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
            Joint angles, radians.
        """
        ...

    def seed_gait(self, amplitude: float = ..., order: int = 1):
        """A feasible starting gait.

        Parameters
        ----------
        amplitude : float
            Size of the loop, radians (the system's default when omitted).
        order : int, default 1
            Fourier order of the returned gait.
        """
        ...


def check_shapes(shapes, n_joints: int, owner: str) -> np.ndarray:
    """Validate a batch of shapes ``(..., d)``: finite, last axis of length d."""
    return check_array(shapes, "shapes", owner, trailing=(n_joints,))


@dataclass(frozen=True)
class FunctionSystem:
    """Wrap a user-supplied connection function as a :class:`System`.

    Parameters
    ----------
    connection_function : callable
        ``f(shapes (..., d)) -> (..., 3, d)``; it must accept a batch of shapes.
    n_joints : int
        Shape dimension d.
    name : str

    Examples
    --------
    >>> import numpy as np
    >>> system = FunctionSystem(lambda r: np.zeros(r.shape[:-1] + (3, 2)), n_joints=2)
    >>> system.connection(np.zeros((5, 2))).shape
    (5, 3, 2)
    """

    connection_function: Callable[[np.ndarray], np.ndarray]
    n_joints: int
    name: str = "custom"

    def __post_init__(self):
        check_int(self.n_joints, "n_joints", "FunctionSystem", minimum=1)
        if not callable(self.connection_function):
            raise fail("connection_function", "FunctionSystem", "callable", self.connection_function)

    def connection(self, shapes) -> np.ndarray:
        """The user's connection at shapes ``(..., d)``, checked to be finite and ``(..., 3, d)``."""
        shapes = check_shapes(shapes, self.n_joints, f"{self.name}.connection")
        value = np.asarray(self.connection_function(shapes), dtype=float)
        expected = shapes.shape[:-1] + (3, self.n_joints)
        if value.shape != expected:
            raise fail("connection_function", "FunctionSystem", f"returning shape {expected}",
                       f"shape {value.shape}")
        if not np.all(np.isfinite(value)):
            raise fail("connection_function", "FunctionSystem", "returning finite values",
                       "non-finite values")
        return value


def height_function(system, direction, limit: float, resolution: int = 81):
    r"""Height function of a 2-joint system along a body-frame ``direction`` ``(2,)``: the constraint curvature.

    A small loop around a shape r moves the body, per unit of the area it encloses (counter-clockwise in
    (r₁, r₂)), by :math:`-(\partial_1 A_2 - \partial_2 A_1) + [A_1, A_2]` (sign of ξ = −Aṙ; the Lie bracket of the
    connection's columns is the second-order term the curl alone leaves out: at r = 0 of the 3-link swimmer it
    is more than half the total), projected on ``direction`` (Hatton & Choset 2015's constraint curvature).
    The tests check it against the simulated net motion of small loops.

    Parameters
    ----------
    system : System
        With two joints.
    direction : array-like of shape (2,)
        Body-frame direction of travel the translation is projected on.
    limit : float
        The grid spans [−limit, limit] on both joints (rad).
    resolution : int
        Grid points per axis.

    Returns
    -------
    axis : ndarray of shape (m,)
    values : ndarray of shape (m, m)
        Indexed [r2, r1]; central differences (step 1e-5) of the connection.
    """
    axis = np.linspace(-limit, limit, resolution)
    r1, r2 = np.meshgrid(axis, axis)
    shapes = np.stack([r1, r2], axis=-1)
    h = 1e-5
    d_by_r1 = (system.connection(shapes + [h, 0]) - system.connection(shapes - [h, 0])) / (2 * h)
    d_by_r2 = (system.connection(shapes + [0, h]) - system.connection(shapes - [0, h])) / (2 * h)
    connection = system.connection(shapes)
    curvature = -(d_by_r1[..., :, 1] - d_by_r2[..., :, 0]) + se2.bracket(connection[..., :, 0], connection[..., :, 1])
    return axis, curvature[..., :2] @ np.asarray(direction, dtype=float)
