"""Simulation: trajectories and sample streams of a gait on a system, and the per-cycle oracle."""

from ._oracle import TrueMotion, cycle_displacement, cycle_velocity
from ._stream import MAX_SENSOR_NOISE, DragRatioSchedule, SwimmerStream, simulate, simulate_rate
from ._trajectory import BODY_VELOCITY_COLUMNS, POSE_COLUMNS, Trajectory, end_pose, velocity_pose_disagreement

__all__ = ["BODY_VELOCITY_COLUMNS", "MAX_SENSOR_NOISE", "POSE_COLUMNS", "DragRatioSchedule", "SwimmerStream",
           "Trajectory", "TrueMotion", "cycle_displacement", "cycle_velocity", "end_pose", "simulate", "simulate_rate",
           "velocity_pose_disagreement"]
