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

from .. import se2
from .._validation import check_int
from ..gaits import FourierGait
from ..systems import System

__all__ = ["cycle_displacement", "gauss_phases", "magnus_steps"]

_GAUSS = 0.5 + np.array([-1.0, 1.0]) * np.sqrt(3) / 6


def gauss_phases(resolution: int) -> tuple[np.ndarray, float]:
    """The two Gauss–Legendre nodes of each of ``resolution`` equal phase steps, ``(n, 2)``."""
    step = 2 * np.pi / resolution
    starts = np.arange(resolution) * step
    return starts[:, None] + step * _GAUSS, step


def magnus_steps(velocity_at_nodes: np.ndarray, step: float) -> np.ndarray:
    """Fourth-order Magnus twist per step from body velocities at the two Gauss nodes.

    ``velocity_at_nodes`` has shape ``(..., n, 2, 3)``; returns ``(..., n, 3)``.
    """
    first, second = velocity_at_nodes[..., 0, :], velocity_at_nodes[..., 1, :]
    return step / 2 * (first + second) + np.sqrt(3) / 12 * step**2 * se2.bracket(first, second)


def cycle_displacement(system: System, gait: FourierGait, resolution: int = 256) -> np.ndarray:
    """Net SE(2) motion ``(x, y, heading)`` over one cycle of ``gait`` on ``system``.

    Independent of how fast the cycle is executed (principally kinematic systems are
    rate-independent).

    Parameters
    ----------
    system : System
    gait : FourierGait
    resolution : int
        Number of Magnus steps.

    Returns
    -------
    ndarray of shape (3,)
    """
    resolution = check_int(resolution, "resolution", "cycle_displacement", minimum=4)
    phases, step = gauss_phases(resolution)
    connection = system.connection(gait.shape(phases))  # (n, 2, 3, d)
    velocity = -np.einsum("...ij,...j->...i", connection, gait.velocity(phases))
    return se2.displacement(magnus_steps(velocity, step), 1.0)
