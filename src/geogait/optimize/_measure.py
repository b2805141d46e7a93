"""What one cycle of a robot tells about its gait, measured from the robot's own samples."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import se2
from .._validation import fail
from ..gaits import FourierGait
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
    if not isinstance(chunk, Trajectory):
        raise fail("robot", owner, "a next_cycle() returning a geogait.simulate.Trajectory", type(chunk).__name__)
    n, d = chunk.time.shape[-1], gait.n_joints
    if chunk.time.ndim != 1 or n < 4:
        raise fail("robot", owner, "cycles of at least 4 samples without a trial axis",
                   f"time of shape {chunk.time.shape}")
    expected = {"phase": (n,), "shape": (n, d), "shape_velocity": (n, d), "body_velocity": (n, 3), "pose": (n, 3)}
    for name, shape in expected.items():
        value = np.asarray(getattr(chunk, name))
        if value.shape != shape:
            raise fail(f"cycle.{name}", owner, f"an array of shape {shape}", f"shape {value.shape}")
        if not np.all(np.isfinite(value)):
            raise fail(f"cycle.{name}", owner, "finite values", "NaN or inf")
    if not np.all(np.isfinite(chunk.time)) or np.any(np.diff(chunk.time) <= 0):
        raise fail("cycle.time", owner, "strictly increasing finite time stamps (seconds)", chunk.time[:5])
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
