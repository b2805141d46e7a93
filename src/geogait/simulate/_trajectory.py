"""The result object of every simulation (and of every ingested log): arrays over time."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pandas as pd

from .. import se2
from .._files import atomic_write, write_text
from .._validation import fail

__all__ = ["Trajectory", "end_pose", "velocity_pose_disagreement"]

#: Column names of body velocity and world pose in every table geogait writes or reads by default.
BODY_VELOCITY_COLUMNS = ("body_velocity_x", "body_velocity_y", "body_velocity_theta")
POSE_COLUMNS = ("x", "y", "heading")


@dataclass(frozen=True)
class Trajectory:
    """Samples of a locomotor over time, optionally with a leading trial axis.

    Attributes
    ----------
    time : ndarray of shape (..., n)
    phase : ndarray of shape (..., n)
        Commanded gait phase in ``[0, 2π)``.
    cycle : ndarray of shape (..., n)
        Index of the gait cycle each sample belongs to.
    shape : ndarray of shape (..., n, d)
        Measured shape r.
    shape_velocity : ndarray of shape (..., n, d)
        Measured shape velocity ṙ (per unit time).
    body_velocity : ndarray of shape (..., n, 3)
        Measured body velocity ξ = (v_x, v_y, ω).
    pose : ndarray of shape (..., n, 3)
        World pose g = (x, y, heading) at each sample (from the noise-free body velocity).
    commanded_shape : ndarray of shape (..., n, d), optional
        Shape the locomotor was commanded to take (nominal gait plus exploration perturbation);
        the realised ``shape`` may differ when actuators lag or saturate.
    """

    time: np.ndarray
    phase: np.ndarray
    cycle: np.ndarray
    shape: np.ndarray
    shape_velocity: np.ndarray
    body_velocity: np.ndarray
    pose: np.ndarray
    commanded_shape: np.ndarray | None = None

    def _arrays(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}

    @property
    def n_joints(self) -> int:
        return self.shape.shape[-1]

    @property
    def n_samples(self) -> int:
        return self.time.shape[-1]

    def trial(self, index: int) -> Trajectory:
        """One trial of a batched trajectory.

        Parameters
        ----------
        index : int
            Index along the leading (trial) axis of every array.
        """
        return Trajectory(**{name: value[index] for name, value in self._arrays().items()})

    def cycles(self, start: int, stop: int) -> Trajectory:
        """Samples of cycles ``start <= cycle < stop`` (unbatched trajectories only)."""
        if self.time.ndim != 1:
            raise fail("trajectory", "Trajectory.cycles", "unbatched (select a trial first)",
                       f"time of shape {self.time.shape}")
        keep = (self.cycle >= start) & (self.cycle < stop)
        return Trajectory(**{name: value[keep] for name, value in self._arrays().items()})

    @classmethod
    def concatenate(cls, parts: list[Trajectory]) -> Trajectory:
        """Join trajectories along time.

        Parameters
        ----------
        parts : list of Trajectory
            Non-empty, in time order, with equal batch shapes; optional arrays missing from any part are dropped.
        """
        if not parts:
            raise fail("parts", "Trajectory.concatenate", "a non-empty list of Trajectory", parts)
        names = [f.name for f in fields(cls) if all(getattr(p, f.name) is not None for p in parts)]
        return cls(**{name: np.concatenate([getattr(p, name) for p in parts], axis=parts[0].time.ndim - 1)
                      for name in names})

    def to_pandas(self) -> pd.DataFrame:
        """Long table: one row per sample (and a ``trial`` column when batched)."""
        batch = self.time.shape[:-1]
        columns: dict[str, np.ndarray] = {}
        if batch:
            columns["trial"] = np.repeat(np.arange(int(np.prod(batch))), self.n_samples)
        columns["time"] = self.time.ravel()
        columns["phase"] = self.phase.ravel()
        columns["cycle"] = self.cycle.ravel()
        for name in ("shape", "shape_velocity", "commanded_shape"):
            if getattr(self, name) is None:
                continue
            values = getattr(self, name).reshape(-1, self.n_joints)
            for j in range(self.n_joints):
                columns[f"{name}_{j}"] = values[:, j]
        for name, array in (("body_velocity", self.body_velocity), ("pose", self.pose)):
            names = BODY_VELOCITY_COLUMNS if name == "body_velocity" else POSE_COLUMNS
            for k, column in enumerate(names):
                columns[column] = array.reshape(-1, 3)[:, k]
        return pd.DataFrame(columns)

    @classmethod
    def from_pandas(cls, frame: pd.DataFrame) -> Trajectory:
        """Inverse of :meth:`to_pandas` for an unbatched table.

        Parameters
        ----------
        frame : pandas.DataFrame
            One row per sample with the columns of :meth:`to_pandas` (``time``, ``phase``, ``cycle``,
            ``shape_j``, ``shape_velocity_j``, body velocity and pose; ``commanded_shape_j`` optional).
        """
        required = ["time", "phase", "cycle", *BODY_VELOCITY_COLUMNS, *POSE_COLUMNS]
        missing = [c for c in required + ["shape_0", "shape_velocity_0"] if c not in frame]
        if missing:
            raise fail("frame", "Trajectory.from_pandas", "a table with the columns of to_pandas()",
                       f"missing {missing}")
        d = sum(1 for c in frame.columns if c.startswith("shape_") and c[6:].isdigit())
        return cls(
            time=frame["time"].to_numpy(float),
            phase=frame["phase"].to_numpy(float),
            cycle=frame["cycle"].to_numpy(int),
            shape=frame[[f"shape_{j}" for j in range(d)]].to_numpy(float),
            shape_velocity=frame[[f"shape_velocity_{j}" for j in range(d)]].to_numpy(float),
            body_velocity=frame[list(BODY_VELOCITY_COLUMNS)].to_numpy(float),
            pose=frame[list(POSE_COLUMNS)].to_numpy(float),
            commanded_shape=frame[[f"commanded_shape_{j}" for j in range(d)]].to_numpy(float)
            if "commanded_shape_0" in frame else None,
        )

    def to_parquet(self, path) -> Path:
        """Write :meth:`to_pandas` as Parquet; returns the path."""
        return atomic_write(path, lambda stream: self.to_pandas().to_parquet(stream, index=False))

    def to_csv(self, path) -> Path:
        """Write :meth:`to_pandas` as CSV; returns the path."""
        return write_text(path, self.to_pandas().to_csv(index=False))


def end_pose(cycle: Trajectory, period: float | None = None) -> np.ndarray:
    r"""Pose ``(3,)`` at the end of one cycle of samples (a robot's ``next_cycle()``): the last sampled pose
    moved by the last measured step. The in-situ optimiser and the path follower measure every cycle's
    net motion up to it.

    The samples hold the pose *before* each step, so the boundary pose after the last step is
    :math:`g_{end} = g_{n-1}\exp(\Delta t\,\hat\xi_{n-1})`, with the measured body velocity
    :math:`\xi_{n-1}` and the sample interval :math:`\Delta t` — exact for a zero-order-hold
    simulation without sensor noise, and off by (sensor noise × Δt) otherwise.

    Parameters
    ----------
    cycle : Trajectory
        One cycle of n ≥ 2 unbatched samples with poses.
    period : float, optional
        Seconds per cycle: Δt = period / n (the robot's sample clock). Without it, Δt is the last
        time-stamp difference.

    Returns
    -------
    ndarray of shape (3,)
    """
    pose = np.asarray(cycle.pose, dtype=float)
    if pose.ndim != 2 or pose.shape[0] < 2:
        raise fail("robot", "end_pose", "cycles of at least 2 unbatched samples with poses", f"pose {pose.shape}")
    time = np.asarray(cycle.time, dtype=float)
    dt = time[-1] - time[-2] if period is None else period / pose.shape[0]
    return se2.compose(pose[-1], se2.exp(np.asarray(cycle.body_velocity, dtype=float)[-1] * dt))


#: Ratio beyond which a cycle's body velocities and poses are read as in different units (either way).
UNIT_MISMATCH = 10.0
#: How far beyond the cycle's typical steps one sample's body velocity may move the body away from its poses.
GLITCH = 20.0
#: How far beyond the cycle's other samples' disagreement with their poses (and the change between consecutive
#: steps) the last sample's may be: it alone sets the end pose. Clean cycles of the built-in swimmers stay below 2.5
#: (tests/simulate: sensor noise 0 to 0.3, 20 to 200 samples per cycle).
END_GLITCH = 5.0


def velocity_pose_disagreement(cycle: Trajectory, period: float | None = None) -> str | None:
    r"""Why one cycle's measured body velocities cannot be the motion its poses record (None: they agree).

    Two checks, each robust to sensor noise on either measurement:

    * **glitch**: each sample's step ξ_k Δt_k against the pose step it should match; the last sample's,
      which sets the cycle's end pose (:func:`end_pose`), against the step before it. A difference more
      than :data:`GLITCH` × (the cycle's 90th-percentile pose step + velocity step) is a glitch, and so is
      a last sample's more than :data:`END_GLITCH` × how closely the cycle's other samples match their poses
      (90th percentile, plus that of the change between consecutive pose steps): it alone sets the end pose;
    * **unit mismatch**: over each quarter of the cycle, the motion the body velocities integrate to
      (Σ ξ_k Δt_k) and the motion the poses record (Σ g_k⁻¹ g_(k+1)), translation and heading apart: an
      RMS ratio beyond :data:`UNIT_MISMATCH` either way (velocities in mm/s with poses in m, degrees with
      radians) is named with its factor.

    Parameters
    ----------
    cycle : Trajectory
        One cycle of n ≥ 4 unbatched samples with poses and body velocities.
    period : float, optional
        Seconds per cycle: the last sample's interval is ``period / n``, as :func:`end_pose` takes it.

    Returns
    -------
    str or None
        The disagreement in words (for a quarantine), or None.
    """
    pose, velocity = np.asarray(cycle.pose, dtype=float), np.asarray(cycle.body_velocity, dtype=float)
    time = np.asarray(cycle.time, dtype=float)
    if pose.ndim != 2 or pose.shape[0] < 4 or velocity.shape != pose.shape:
        raise fail("cycle", "velocity_pose_disagreement", "one cycle of at least 4 unbatched samples with poses and "
                   "body velocities", f"pose {pose.shape}, body_velocity {velocity.shape}")
    n = pose.shape[0]
    dt = np.append(np.diff(time), time[-1] - time[-2] if period is None else period / n)
    recorded = se2.between(pose[:-1], pose[1:])
    recorded[:, 2] = se2.wrap_angle(recorded[:, 2])
    moved = velocity * dt[:, None]
    return _glitch(recorded, moved, dt) or _unit_mismatch(recorded, moved[:-1])  # (one glitch skews a quarter)


def _magnitudes(steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation and heading sizes of body-frame steps ``(..., 3)``."""
    return np.hypot(steps[..., 0], steps[..., 1]), np.abs(steps[..., 2])


def _unit_mismatch(recorded: np.ndarray, moved: np.ndarray) -> str | None:
    quarters = np.array_split(np.arange(len(recorded)), 4)
    sums = [np.array([steps[q].sum(axis=0) for q in quarters]) for steps in (recorded, moved)]
    # pose noise σ moves a quarter by about √2 σ, and changes consecutive steps by about √6 σ
    for part, (poses, velocities, change) in enumerate(zip(_magnitudes(sums[0]), _magnitudes(sums[1]),
                                                           _magnitudes(np.diff(recorded, axis=0)), strict=True)):
        by_poses, by_velocities = np.sqrt(np.mean(poses ** 2)), np.sqrt(np.mean(velocities ** 2))
        noise = np.sqrt(np.mean(change ** 2))
        if by_velocities > UNIT_MISMATCH * (by_poses + noise) or by_poses > UNIT_MISMATCH * (by_velocities + noise):
            what = ("translation", "heading")[part]
            factor = f"{by_velocities / by_poses:.3g}×" if by_poses > 0 else "infinitely"
            return (f"its body velocities move the body {factor} as far as its poses do ({what}, RMS per quarter "
                    f"cycle {by_velocities:.3g} against {by_poses:.3g}): body velocities and poses in different "
                    "units?")
    return None


def _glitch(recorded: np.ndarray, moved: np.ndarray, dt: np.ndarray) -> str | None:
    expected = np.vstack([recorded, recorded[-1] * dt[-1] / dt[-2]])  # (the last step: as long as the one before)
    for part, (off, steps, velocities, change) in enumerate(zip(
            _magnitudes(moved - expected), _magnitudes(recorded), _magnitudes(moved[:-1]),
            _magnitudes(np.diff(recorded, axis=0)), strict=True)):
        what = ("translation", "heading")[part]
        typical = np.percentile(steps, 90) + np.percentile(velocities, 90)
        k = int(np.argmax(off))
        if off[k] > GLITCH * typical + 1e-12:
            where = " (the last sample's: it sets the cycle's end pose)" if k == len(off) - 1 else ""
            return (f"the body velocity at sample {k}{where} moves the body {off[k]:.4g} ({what}) away from what its "
                    f"poses record, where the cycle's other steps allow about {typical:.3g}")
        # the end pose rests on the last sample alone: held to how well the cycle's other samples agree
        agreement = np.percentile(off[:-1], 90) + np.percentile(change, 90)
        if off[-1] > END_GLITCH * agreement + 1e-9 * typical + 1e-15:
            return (f"the body velocity at sample {len(off) - 1} (the last sample's: it sets the cycle's end pose) "
                    f"moves the body {off[-1]:.4g} ({what}) away from what its poses record, where the cycle's other "
                    f"samples agree with their poses to about {agreement:.3g}")
    return None
