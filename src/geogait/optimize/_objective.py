r"""Gait objectives and constraints shared by the in-situ optimiser and the model-based ceiling.

* ``"progress"`` (default): straight-line progress per cycle, the length of the translation part
  of the net SE(2) motion :math:`\|t(p)\|`, to be maximised **subject to zero net rotation**
  :math:`\theta_{net}(p) = 0` (a rotating gait swims in circles and makes no lasting progress).
* ``"efficiency"``: progress per unit shape-space path length, :math:`\|t\| / L`,
  :math:`L = \oint \|\theta'(\phi)\|\,d\phi`, with the same rotation constraint.
* ``"forward"``: signed progress along a unit direction :math:`u`, :math:`u^T t` (same rotation
  constraint). Unlike :math:`\|t\|` it tells forward from backward, so a run can never turn
  round; :math:`u` is given in the frame of the pose (the body frame at the start of the cycle).

Joint limits :math:`|\theta_j(\phi)| \le r_{max}` are linear in the Fourier coefficients at any
fixed phase, so they are imposed on a phase grid fine enough that the maximum between grid points
can exceed the grid maximum by at most a factor :math:`1/\cos(K\pi/n)`; the grid bound is
tightened by that factor, which makes the continuous limit hold exactly.
"""

from __future__ import annotations

import numpy as np

from .._validation import check_choice, fail
from ..gaits import FourierGait, fourier_basis

__all__ = ["OBJECTIVES", "objective", "path_length", "joint_limit_constraints"]

OBJECTIVES = ("progress", "efficiency", "forward")
_PATH_NODES = 256


def path_length(gait: FourierGait, params=None, jacobian: bool = False):
    """Shape-space path length L = ∮‖θ'(φ)‖ dφ of a gait (and dL/dp)."""
    gait = gait if params is None else gait.with_params(params)
    phase = np.linspace(0, 2 * np.pi, _PATH_NODES, endpoint=False)
    velocity = gait.velocity(phase)  # (n, d)
    speed = np.linalg.norm(velocity, axis=-1)
    length = speed.mean() * 2 * np.pi
    if not jacobian:
        return length
    d_basis = gait.basis(phase, 1)  # (n, c)
    unit = velocity / np.maximum(speed, 1e-12)[:, None]
    gradient = np.einsum("nj,nc->jc", unit, d_basis).ravel() * 2 * np.pi / _PATH_NODES
    return length, gradient


def objective(kind: str, pose: np.ndarray, pose_jacobian: np.ndarray, gait: FourierGait, direction=None):
    """Objective value and gradient from net pose ``(3,)`` and its Jacobian ``(3, p)``.

    ``direction`` (unit 2-vector in the pose's frame) is required by ``"forward"`` only.
    """
    check_choice(kind, "objective", "geogait.optimize", OBJECTIVES)
    if kind == "forward":
        if direction is None:
            raise fail("direction", "geogait.optimize.objective", "a unit 2-vector for objective 'forward'", None)
        return direction @ pose[:2], direction @ pose_jacobian[:2]
    translation = np.hypot(pose[0], pose[1])
    gradient = (pose[0] * pose_jacobian[0] + pose[1] * pose_jacobian[1]) / max(translation, 1e-15)
    if kind == "progress":
        return translation, gradient
    length, d_length = path_length(gait, jacobian=True)
    return translation / length, gradient / length - translation * d_length / length**2


def joint_limit_constraints(n_joints: int, order: int, max_joint_angle: float, max_joint_speed: float | None = None):
    """Linear inequalities ``G p <= h`` equivalent to |θ_j(φ)| ≤ r_max for all φ (see module).

    With ``max_joint_speed`` (rad per unit phase, i.e. the joint-velocity limit times the cycle
    period / 2π) the rows |θ_j'(φ)| ≤ that bound are added the same way (θ' is a Fourier series of
    the same order, so the same grid tightening makes the continuous limit hold).
    """
    n_phases = max(64, 64 * order)
    phase = np.linspace(0, 2 * np.pi, n_phases, endpoint=False)
    tightening = np.cos(order * np.pi / n_phases)
    rows, bounds = [], []
    for derivative, limit in ((0, max_joint_angle), (1, max_joint_speed)):
        if limit is None:
            continue
        basis = fourier_basis(phase, order, derivative)  # (n, c)
        blocks = np.kron(np.eye(n_joints), basis)  # (d n, d c): row (j, φ) picks joint j's coefficients
        rows += [blocks, -blocks]
        bounds.append(np.full(2 * blocks.shape[0], limit * tightening))
    return np.vstack(rows), np.concatenate(bounds)
