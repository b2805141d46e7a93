r"""Ground-truth net motion per cycle of a gait on a known system (the "oracle").

Over one cycle the body velocity per unit phase is :math:`\xi(\phi) = -A(\theta(\phi))\,\theta'(\phi)`
and the net motion solves :math:`dg/d\phi = g\,\hat\xi(\phi)`, :math:`g(0) = e`. It is integrated
with the fourth-order Magnus method on SE(2): on each of ``n`` phase steps of size ``h``, with the
two Gauss nodes :math:`\xi_{1,2}`,

.. math:: \Omega = \tfrac{h}{2}(\xi_1 + \xi_2) + \tfrac{\sqrt3}{12}h^2[\xi_1, \xi_2],
   \qquad g \leftarrow g\exp(\hat\Omega),

each step's exponential exact. Error falls as ``n⁻⁴``: the default 256 steps reach ~1e-9 on the
Purcell swimmers with gaits of order 1 and amplitude 1 (see the tests).
"""

from __future__ import annotations

import numpy as np

from .._validation import check_int, fail
from ..gaits import FourierGait
from ..se2 import gauss_phases, integrate_cycle
from ..systems import System

__all__ = ["TrueMotion", "cycle_displacement", "cycle_velocity"]


def cycle_displacement(system: System, gait: FourierGait, resolution: int = 256, jacobian: bool = False):
    """Net SE(2) motion ``(x, y, heading)`` over one cycle of ``gait`` on ``system``.

    Independent of how fast the cycle is executed (principally kinematic systems are
    rate-independent).

    Parameters
    ----------
    system : System
    gait : FourierGait
    resolution : int
        Number of Magnus steps.
    jacobian : bool
        Also return ∂(x, y, heading)/∂(gait.params), shape ``(3, p)``. The chain rule runs through
        the Magnus steps and exponentials exactly; ∂A/∂r comes from central differences of the
        connection (step 1e-6, error ~1e-10), so the result matches finite differences of the
        displacement to ~1e-8 relative.

    Returns
    -------
    ndarray of shape (3,), and ndarray of shape (3, p) when ``jacobian``.
    """
    resolution = _check(system, gait, resolution, "cycle_displacement")
    return integrate_cycle(*_cycle_velocity(system, gait, resolution, jacobian))


def _check(system: System, gait: FourierGait, resolution, owner: str) -> int:
    resolution = check_int(resolution, "resolution", owner, minimum=4)
    if not isinstance(gait, FourierGait) or gait.n_joints != system.n_joints:
        raise fail("gait", owner, f"a FourierGait with {system.n_joints} joints (the system's)",
                   gait if not isinstance(gait, FourierGait) else f"{gait.n_joints} joints")
    return resolution


def cycle_velocity(system: System, gait: FourierGait, resolution: int = 256, jacobian: bool = False):
    """Body velocity ξ = −A(θ)θ' (eq. 1) at the Magnus nodes of one cycle of ``gait`` on ``system``: what
    :func:`cycle_displacement` integrates. A sum of connections integrates the sum of these (the
    resistance model's hybrid adds a learned residual this way).

    Parameters
    ----------
    system : System
    gait : FourierGait
    resolution : int
        Number of Magnus steps (two Gauss nodes each).
    jacobian : bool
        Also return ∂ξ/∂(gait.params) at the nodes (∂A/∂r by central differences, as in
        :func:`cycle_displacement`).

    Returns
    -------
    velocity : ndarray of shape (resolution, 2, 3)
    step : float
        The Magnus step in phase (2π / resolution).
    jacobian : ndarray of shape (resolution, 2, 3, p)
        Only when ``jacobian``. ``(velocity, step[, jacobian])`` are the arguments of
        :func:`~geogait.se2.integrate_cycle`.
    """
    return _cycle_velocity(system, gait, _check(system, gait, resolution, "cycle_velocity"), jacobian)


def _cycle_velocity(system: System, gait: FourierGait, resolution: int, jacobian: bool = False):
    phases, step = gauss_phases(resolution)
    shape, rate = gait.shape(phases), gait.velocity(phases)
    connection = system.connection(shape)  # (n, 2, 3, d)
    velocity = -np.einsum("...ij,...j->...i", connection, rate)
    if not jacobian:
        return velocity, step
    d = gait.n_joints
    h = 1e-6
    offsets = h * np.eye(d)
    d_connection = (system.connection(shape[..., None, :] + offsets)
                    - system.connection(shape[..., None, :] - offsets)) / (2 * h)  # (n, 2, i, 3, d)
    d_velocity_d_shape = -np.einsum("...ikj,...j->...ki", d_connection, rate)  # (n, 2, 3, i)
    basis, d_basis = gait.basis(phases), gait.basis(phases, 1)  # (n, 2, c)
    velocity_jacobian = (d_velocity_d_shape[..., :, :, None] * basis[..., None, None, :]
                         - connection[..., :, :, None] * d_basis[..., None, None, :])  # (n, 2, 3, d, c)
    return velocity, step, velocity_jacobian.reshape(velocity_jacobian.shape[:-2] + (-1,))


class TrueMotion:
    """Net motion per cycle with the true connection of a known system: :func:`cycle_displacement` at one
    resolution, the one true-motion helper of the closed loops (the in-situ optimiser's truth columns, the path
    follower's ``"true"`` controller and steering families, :class:`~geogait.models.PerfectInformationModel`).

    Parameters
    ----------
    system : System
    resolution : int
        Magnus steps over the cycle (64 steps are accurate to ~1e-7 on the Purcell swimmers; each caller keeps
        its own: 64 for steering, 128 for the optimiser's truth and the perfect-information model).
    """

    def __init__(self, system, resolution: int = 64):
        self.system = system
        self.resolution = resolution

    def __call__(self, gait: FourierGait, jacobian: bool = False):
        """``(Δx, Δy, Δθ)`` ``(3,)`` of one cycle of ``gait`` (and ``(3, p)`` Jacobian)."""
        return cycle_displacement(self.system, gait, resolution=self.resolution, jacobian=jacobian)
