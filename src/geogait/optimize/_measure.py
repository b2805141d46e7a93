"""What one cycle of a robot tells about its gait, measured from the robot's own samples."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import se2
from ..gaits import FourierGait
from ..robots import check_cycle
from ..simulate import Trajectory, end_pose

__all__ = ["CycleMeasurement", "measure_cycle"]


@dataclass(frozen=True)
class CycleMeasurement:
    """What one cycle of a robot tells about its gait, from its own samples.

    Parameters
    ----------
    net : ndarray of shape (3,)
        Net motion (x, y, heading) over the cycle, in the body frame at its start.
    start : ndarray of shape (3,)
        World pose at the start of the cycle.
    tracking_error : float
        RMS realised − commanded shape over the cycle (shape units).
    excitation : float
        RMS commanded − nominal shape (the exploration the cycle carried), or realised − nominal
        for a robot that does not report ``commanded_shape`` (shape units).
    """

    net: np.ndarray
    start: np.ndarray
    tracking_error: float
    excitation: float = np.nan


def measure_cycle(chunk: Trajectory, gait: FourierGait, period: float, owner: str) -> CycleMeasurement:
    """Net SE(2) motion, start pose and tracking error of one cycle of robot samples.

    The end pose is the last sample's pose advanced by its measured body velocity over one sample
    interval (exact for a zero-order-hold robot such as ``SwimmerStream``). Without
    ``commanded_shape`` the tracking error is measured against the nominal gait θ(φ) itself.

    Parameters
    ----------
    chunk : Trajectory
        One cycle of a robot (``next_cycle()``), without a trial axis.
    gait : FourierGait
        The nominal gait the robot ran.
    period : float
        Seconds per cycle (the last sample's interval is ``period / n``).
    owner : str
        Name used in error messages (who asked).

    Returns
    -------
    CycleMeasurement
    """
    check_cycle(chunk, gait.n_joints, owner)
    end = end_pose(chunk, period)
    nominal = gait.shape(chunk.phase)
    commanded = chunk.commanded_shape if chunk.commanded_shape is not None else nominal
    error = float(np.sqrt(np.mean((chunk.shape - commanded) ** 2)))
    excited = commanded if chunk.commanded_shape is not None else chunk.shape
    return CycleMeasurement(net=se2.between(chunk.pose[0], end), start=np.array(chunk.pose[0], dtype=float),
                            tracking_error=error, excitation=float(np.sqrt(np.mean((excited - nominal) ** 2))))


def peak_phase_speed(gait: FourierGait) -> float:
    """Largest |θ_j'(φ)| of ``gait`` (shape units per radian of phase) on a 256-point phase grid."""
    return float(np.abs(gait.velocity(np.linspace(0, 2 * np.pi, 256, endpoint=False))).max())
