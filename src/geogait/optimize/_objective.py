r"""Gait objectives and constraints shared by the in-situ optimiser and the model-based ceiling.

* ``"progress"`` (default): straight-line progress per cycle, the length of the translation part
  of the net SE(2) motion :math:`\|t(p)\|`, to be maximised **subject to zero net rotation**
  :math:`\theta_{net}(p) = 0` (a rotating gait swims in circles and makes no lasting progress).
* ``"efficiency"``: progress per unit shape-space path length, :math:`\|t\| / L`,
  :math:`L = \oint \|\theta'(\phi)\|\,d\phi`, with the same rotation constraint.
* ``"forward"``: signed progress along a unit direction :math:`u`, :math:`u^T t` (same rotation
  constraint). Unlike :math:`\|t\|` it tells forward from backward, so a run can never turn
  round; :math:`u` is given in the frame of the pose (the body frame at the start of the cycle).
* ``"budget"``: progress per unit time when the cycle is run at a fixed RMS shape velocity (a budget
  on joint speed, or on power with the identity metric). At RMS joint speed 1 the period is
  :math:`T = 2\pi S` with :math:`S^2 = \frac{1}{2\pi}\oint\|\theta'(\phi)\|^2 d\phi
  = \frac12\sum_{j,k} k^2 (a_{jk}^2 + b_{jk}^2)` (exact for Fourier gaits), so the objective is
  :math:`\|t\| / (2\pi S)`, with the same rotation constraint.

Why Fourier order K ≥ 2 needs ``"budget"`` (or ``"efficiency"``): progress per cycle is maximised
by running the order-1 optimum K times per cycle, θ(Kφ), which moves K times as far per cycle and
nothing more. Both ``"budget"`` and ``"efficiency"`` are invariant under that repetition (‖t‖, S and
L all scale by K), so a higher order only wins by a better single loop (a repeated loop ties, and
:func:`~geogait.optimize.optimize_ceiling` breaks ties towards the least RMS shape speed, i.e. the
single loop). :func:`default_objective`
picks ``"progress"`` for K = 1 (the paper's) and ``"budget"`` for K ≥ 2.

Joint limits :math:`|\theta_j(\phi)| \le r_{max}` are linear in the Fourier coefficients at any
fixed phase, so they are imposed on a phase grid fine enough that the maximum between grid points
can exceed the grid maximum by at most a factor :math:`1/\cos(K\pi/n)`; the grid bound is
tightened by that factor, which makes the continuous limit hold exactly.
"""

from __future__ import annotations

import numpy as np

from .._estimator import Options
from .._validation import GeogaitError, check_choice, check_float, check_int, fail
from ..gaits import FourierGait, fourier_basis
from ..robots import RobotSpec, read_robot_spec
from ..systems import FeasibleSystem
from ._part import Part

__all__ = [
    "OBJECTIVES", "Objective", "default_objective", "feasibility_constraint", "objective", "path_length",
    "joint_limit_constraints", "rms_speed", "robot_feasibility",
]

OBJECTIVES = ("progress", "efficiency", "forward", "budget")
_PATH_NODES = 256
#: Phases per Fourier order of the grid on which a system's feasible region is imposed.
FEASIBILITY_PHASES = 256
#: The grid constraint is g(θ(φ_k)) ≥ this slack, so that the continuous loop (between grid phases)
#: keeps g ≥ 0 too; in radians for a distance-type g.
FEASIBILITY_SLACK = 2e-3


def path_length(gait: FourierGait, params=None, jacobian: bool = False):
    """Shape-space path length L = ∮‖θ'(φ)‖ dφ of a gait (and dL/dp).

    The integral is the mean over 256 equally spaced phases times 2π.

    Parameters
    ----------
    gait : FourierGait
        The gait (or, with ``params``, its Fourier family).
    params : array-like of shape (d (2K + 1),), optional
        Flat Fourier parameters p to use instead of the gait's own (:meth:`FourierGait.with_params`).
    jacobian : bool, default False
        Also return dL/dp.

    Returns
    -------
    length : float
        L in radians (of joint angle).
    gradient : ndarray of shape (d (2K + 1),)
        dL/dp; only when ``jacobian`` is true.
    """
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


def rms_speed(gait: FourierGait, jacobian: bool = False):
    r"""RMS shape speed per unit phase, :math:`S = (\frac12\sum_{j,k} k^2 (a_{jk}^2 + b_{jk}^2))^{1/2}`
    (and dS/dp), exact for Fourier gaits.

    Parameters
    ----------
    gait : FourierGait
        The gait θ(φ).
    jacobian : bool, default False
        Also return dS/dp with respect to the flat Fourier parameters ``(d (2K + 1),)``.

    Returns
    -------
    speed : float
        S in radians per radian of phase.
    gradient : ndarray of shape (d (2K + 1),)
        dS/dp; only when ``jacobian`` is true.
    """
    order = gait.order
    k2 = np.concatenate([[0.0], np.arange(1, order + 1) ** 2, np.arange(1, order + 1) ** 2]).astype(float)
    weighted = gait.coefficients * k2  # (d, 2K+1)
    speed = np.sqrt(0.5 * np.sum(weighted * gait.coefficients))
    if not jacobian:
        return speed
    return speed, (0.5 * weighted / max(speed, 1e-15)).ravel()


class Objective(Part):
    """What a gait is judged by (module docstring), a part of :class:`~geogait.optimize.InSituOptimizer`.

    Parameters
    ----------
    kind : {"progress", "efficiency", "forward", "budget"}
        Straight-line progress per cycle, progress per shape-space path length, signed progress along
        ``direction``, or progress per unit time at a fixed RMS joint speed; all with zero net rotation.
    direction : array-like of 2 floats, optional
        Direction of ``"forward"``. Default: the mean motion of the seed gait's measured cycles, fixed at the
        first gate decision; a seed whose mean motion is within 2 standard errors of zero is refused.
    frame : {"world", "body"}
        ``direction`` is fixed in the world (a heading to follow) or in the body frame at the start of a cycle.
    """

    _parameter_constraints = {"kind": Options(OBJECTIVES), "frame": Options(("world", "body"))}

    def __init__(self, *, kind: str = "progress", direction=None, frame: str = "world"):
        self.kind = kind
        self.direction = direction
        self.frame = frame

    def _check_param_combinations(self) -> None:
        if self.direction is None:
            return
        try:
            direction = np.asarray(self.direction, dtype=float)
        except (TypeError, ValueError):
            direction = None
        if direction is None or direction.shape != (2,) or not np.all(np.isfinite(direction)) \
                or np.hypot(*direction) == 0:
            raise fail("direction", type(self).__name__, "a non-zero finite 2-vector or None", self.direction)

    def __call__(self, pose: np.ndarray, pose_jacobian: np.ndarray, gait: FourierGait, direction=None):
        """Value and gradient (:func:`objective`); ``direction`` is the unit direction in the pose's frame."""
        return objective(self.kind, pose, pose_jacobian, gait, direction)


def default_objective(order: int) -> str:
    """``"progress"`` for Fourier order 1 (the paper's), ``"budget"`` for K ≥ 2 (see module)."""
    return "progress" if order == 1 else "budget"


def objective(kind: str, pose: np.ndarray, pose_jacobian: np.ndarray, gait: FourierGait, direction=None):
    """Objective value and gradient from net pose ``(3,)`` and its Jacobian ``(3, p)``.

    ``direction`` (unit 2-vector in the pose's frame) is required by ``"forward"`` only.

    Parameters
    ----------
    kind : {"progress", "efficiency", "forward", "budget"}
        Which objective (see the module docstring).
    pose : ndarray of shape (3,)
        Net (x, y, heading) per cycle: body lengths and radians.
    pose_jacobian : ndarray of shape (3, p)
        Derivative of ``pose`` with respect to the p flat Fourier parameters.
    gait : FourierGait
        The gait whose pose is given; ``"budget"`` needs its RMS speed, ``"efficiency"`` its path length.
    direction : ndarray of shape (2,), optional
        Unit direction u of ``"forward"``.

    Returns
    -------
    value : float
    gradient : ndarray of shape (p,)
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
    if kind == "budget":
        speed, d_speed = rms_speed(gait, jacobian=True)
        scale = 2 * np.pi * speed
        return translation / scale, gradient / scale - translation * d_speed / (2 * np.pi * speed**2)
    length, d_length = path_length(gait, jacobian=True)
    return translation / length, gradient / length - translation * d_length / length**2


def joint_limit_constraints(n_joints: int, order: int, max_joint_angle: float | None,
                            max_joint_speed: float | None = None):
    """Linear inequalities ``G p <= h`` equivalent to |θ_j(φ)| ≤ r_max for all φ (see module).

    With ``max_joint_speed`` (rad per unit phase, i.e. the joint-velocity limit times the cycle
    period / 2π) the rows |θ_j'(φ)| ≤ that bound are added the same way (θ' is a Fourier series of
    the same order, so the same grid tightening makes the continuous limit hold).

    Parameters
    ----------
    n_joints : int
        Shape dimension d.
    order : int
        Fourier order K of the gait family.
    max_joint_angle : float or None
        r_max, radians; None: no angle rows (only the speed rows).
    max_joint_speed : float, optional
        Bound on |θ_j'(φ)|, radians per radian of phase; no speed rows when omitted.

    Returns
    -------
    G : ndarray of shape (m, d (2K + 1))
    h : ndarray of shape (m,)
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


def feasibility_constraint(system, n_joints: int, order: int):
    """The feasible region of ``system`` as rows on a phase grid, or None when it declares none.

    Parameters
    ----------
    system : System
        A :class:`~geogait.systems.FeasibleSystem` contributes rows; any other system none.
    n_joints : int
        Shape dimension d.
    order : int
        Fourier order K of the gait family.

    Returns
    -------
    callable or None
        ``f(params (d (2K + 1),)) -> (g (n,), dg/dp (n, d (2K + 1)))`` with
        g = feasibility(θ(φ_k)) − slack on ``FEASIBILITY_PHASES · K`` equally spaced phases.
    """
    if not isinstance(system, FeasibleSystem):
        return None
    return _region_rows(system.feasibility, n_joints, order)


def robot_feasibility(robot, n_joints: int, order: int, max_joint_angle: float | None = None):
    """The feasible region a robot declares, as :func:`feasibility_constraint`'s rows (None: none).

    A robot's own ``feasibility(shapes, jacobian=False)`` (e.g. a :class:`~geogait.systems.LinearRegion`, what
    :class:`~geogait.robots.ProcessRobot` offers when the driver's hello declares ``"shape_constraints"``) comes
    first; otherwise a simulator's system (``current_system()``) when it is a
    :class:`~geogait.systems.FeasibleSystem`. With ``max_joint_angle``, the ``joint_ranges`` the robot declares
    join the region wherever they are tighter than that symmetric limit.

    Parameters
    ----------
    robot : Robot
    n_joints : int
    order : int
    max_joint_angle : float, optional
        The symmetric joint limit r_max in force; None leaves the declared joint ranges out.

    Returns
    -------
    callable or None
    """
    if max_joint_angle is not None:
        max_joint_angle = check_float(max_joint_angle, "max_joint_angle", "robot_feasibility", low=0, low_open=True)
    return spec_feasibility(read_robot_spec(robot, "robot_feasibility"), n_joints, order, max_joint_angle)


def spec_feasibility(spec: RobotSpec, n_joints: int, order: int, max_joint_angle: float | None = None):
    """:func:`robot_feasibility` from what the robot declares (its :class:`~geogait.robots.RobotSpec`)."""
    n_joints = check_int(n_joints, "n_joints", "robot_feasibility", minimum=1)
    order = check_int(order, "order", "robot_feasibility", minimum=1)
    if spec.region is not None:
        region = _region_rows(spec.region, n_joints, order)
    else:
        region = None if spec.system is None else feasibility_constraint(spec.system, n_joints, order)
    ranges = None if max_joint_angle is None else _range_rows(spec.joint_ranges, max_joint_angle, order)
    return _all_rows(region, ranges)


def _range_rows(ranges, max_joint_angle: float, order: int):
    """The declared joint ranges low_j ≤ θ_j(φ) ≤ high_j as rows, where they cut into the symmetric limit
    |θ_j| ≤ r_max (None where they do not: the limit already keeps them): :func:`joint_limit_constraints`'s rows
    about each range's centre, |θ_j − c_j| ≤ w_j, so that the continuous loop keeps them too."""
    if ranges is None or np.all((ranges[:, 0] <= -max_joint_angle) & (ranges[:, 1] >= max_joint_angle)):
        return None
    ranges = np.clip(ranges, -max_joint_angle, max_joint_angle)  # (an unbounded side: the limit keeps it)
    centre, half = ranges.mean(axis=1), np.diff(ranges, axis=1)[:, 0] / 2
    matrix, bound = joint_limit_constraints(len(ranges), order, 1.0)  # rows (±, joint, phase): |θ_j| ≤ 1
    room = bound * np.tile(np.repeat(half, matrix.shape[0] // (2 * len(ranges))), 2)
    middle = FourierGait(np.column_stack([centre, np.zeros((len(ranges), 2 * order))])).params

    def rows(params):
        return room - matrix @ (np.asarray(params, dtype=float) - middle), -matrix

    return rows


def _all_rows(*parts):
    """Feasibility rows that hold where every part's hold (None: no part)."""
    parts = [part for part in parts if part is not None]
    if len(parts) <= 1:
        return parts[0] if parts else None

    def rows(params):
        answers = [part(params) for part in parts]
        return np.concatenate([a[0] for a in answers]), np.vstack([a[1] for a in answers])

    return rows


def _describe(answer) -> str:
    if isinstance(answer, tuple) and len(answer) == 2:
        shapes = tuple(np.shape(part) for part in answer)
        finite = all(np.all(np.isfinite(np.asarray(part, dtype=float))) for part in answer)
        return f"arrays of shapes {shapes[0]} and {shapes[1]}" + ("" if finite else " holding NaN or inf")
    return f"a {type(answer).__name__}"


def _region_rows(feasibility, n_joints: int, order: int):
    phase = np.linspace(0, 2 * np.pi, FEASIBILITY_PHASES * order, endpoint=False)
    basis = fourier_basis(phase, order)  # (n, c)

    def rows(params):
        shapes = basis @ np.reshape(params, (n_joints, -1)).T  # (n, d)
        answer = feasibility(shapes, jacobian=True)
        value, gradient = (answer if isinstance(answer, tuple) and len(answer) == 2 else (None, None))
        value, gradient = np.asarray(value, dtype=float), np.asarray(gradient, dtype=float)
        if value.shape != (len(phase),) or gradient.shape != shapes.shape \
                or not (np.all(np.isfinite(value)) and np.all(np.isfinite(gradient))):
            raise GeogaitError(f"A feasibility(shapes, jacobian=True) must return finite (value, gradient) arrays "
                               f"of shapes ({len(phase)},) and {shapes.shape} for shapes of shape {shapes.shape}. "
                               f"Got {_describe(answer)} instead.")
        return value - FEASIBILITY_SLACK, (gradient[:, :, None] * basis[:, None, :]).reshape(len(phase), -1)

    return rows
