r"""The N-link Purcell swimmer under resistive force theory (RFT).

A chain of N straight links joined by N - 1 revolute joints; the shape ``r_j`` is the angle of
link j+1 relative to link j. Each link of length ``l`` moving with body velocity
``(u, v, ω)`` in its own frame feels, exactly for a straight link under RFT, the drag wrench

.. math:: F = -c\,\mathrm{diag}(l,\ k l,\ k l^3/12)\,(u, v, \omega)^T

(longitudinal drag ``c`` per unit length, lateral ``k c``). With the link twists written
:math:`\xi_i = T_i \xi + J_i \dot r`, where :math:`T_i = \mathrm{Ad}_{h_i^{-1}}` maps the body
velocity into link i's frame and :math:`J_i` is link i's shape Jacobian, zero net force and torque
on the body, :math:`\sum_i T_i^T D_i \xi_i = 0`, gives

.. math:: \xi = -A(r)\dot r,\quad A = \omega_\xi^{-1}\omega_r,\quad
   \omega_\xi = \sum_i T_i^T D_i T_i,\quad \omega_r = \sum_i T_i^T D_i J_i.

The dissipated power is :math:`\dot r^T M(r) \dot r` with
:math:`M = \sum_i (J_i - T_i A)^T D_i (J_i - T_i A)`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .._validation import check_array, check_choice, check_float, check_int, fail
from ._base import check_shapes

__all__ = ["PurcellSwimmer", "BODY_FRAMES"]

BODY_FRAMES = ("middle", "center_of_mass", "tail")
#: Most links accepted: the connection's cost grows with N², and no swimmer studied has more.
MAX_LINKS = 200
#: Most floats one array of a batched connection may hold (8 MB): a larger batch is evaluated in parts of its shapes,
#: between which SIGTERM and Ctrl-C are handled. Same bits: the link and frame angles, products over the whole batch
#: whose rounding depends on its size, are taken for the whole batch first; the rest is per shape. And faster: at 38
#: links the ceiling's (128, 2, 37, 37) batch took 6.3 s in one call on a loaded 2-core machine, 0.6 s in parts of
#: 0.02 s; a 12-link cycle of 100 000 samples (``simulate``) held a signal off for 6 s.
_CHUNK_FLOATS = 1 << 20
#: Accepted range of link lengths, drag coefficient and drag ratio (beyond it the RFT matrices
#: overflow or become singular in floating point: l³ and c·k·l³ must stay representable).
SCALE_RANGE = (1e-6, 1e6)
#: Largest ratio of the longest to the shortest link.
MAX_LENGTH_RATIO = 1e4


@dataclass(frozen=True)
class PurcellSwimmer:
    r"""N-link Purcell swimmer (a :class:`~geogait.systems.System`).

    Parameters
    ----------
    n_links : int in [2, 200]
    link_lengths : array-like of shape (n_links,), optional
        Positive lengths in [1e-6, 1e6], within a factor 1e4 of each other; equal links of total
        length 1 by default.
    drag_coefficient : float in [1e-6, 1e6]
        Longitudinal drag per unit length ``c``.
    drag_ratio : float in [1e-6, 1e6]
        Lateral over longitudinal drag ``k`` (classically 2; ``k = 1`` cannot swim).
    body_frame : {"middle", "center_of_mass", "tail"} or int
        ``"middle"``: centre and orientation of the middle link (for even N: the middle joint,
        oriented along the mean of the two middle links). ``"center_of_mass"``: length-weighted
        centroid of the link centres, oriented along the length-weighted mean link angle.
        ``"tail"``: centre and orientation of the first link. An int i in [0, n_links): centre and
        orientation of link i (links numbered from the tail).
    frame_offset : (x, y, angle), optional
        Pose of the frame the body velocity is given in, relative to ``body_frame`` (in its axes: x along
        the link, towards the head): a robot whose body frame sits off the link's centre or points
        backwards. ξ and A are transformed by :math:`\mathrm{Ad}_{o^{-1}}`. None: the body frame itself.
    link_drag_scale : array-like of shape (n_links, 2), optional
        Per-link multipliers (positive, in [1e-6, 1e6]) of the longitudinal drag ``c`` and the lateral
        drag ``k c`` (the rotational drag ``k c l³/12`` scales with the lateral one): links of different
        surface or medium. All ones by default.

    Examples
    --------
    >>> swimmer = PurcellSwimmer(3)
    >>> (swimmer.connection([0.0, 0.0]) * 54).round(6)  # y-row 1/18, θ-row ±7/27
    array([[  0.,   0.],
           [  3.,   3.],
           [-14.,  14.]])
    """

    #: Most links accepted (the module constant, for callers that check a link count first).
    MAX_LINKS = MAX_LINKS

    n_links: int = 3
    link_lengths: tuple[float, ...] | None = None
    drag_coefficient: float = 1.0
    drag_ratio: float = 2.0
    body_frame: str | int = "middle"
    frame_offset: tuple[float, float, float] | None = None
    link_drag_scale: tuple[tuple[float, float], ...] | None = None
    _geometry: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        owner = "PurcellSwimmer"
        n = check_int(self.n_links, "n_links", owner, minimum=2)
        if n > MAX_LINKS:
            raise fail("n_links", owner, f"an int in [2, {MAX_LINKS}]", self.n_links)
        if self.link_lengths is None:
            lengths = np.full(n, 1.0 / n)
        else:
            lengths = check_array(self.link_lengths, "link_lengths", owner, ndim=1)
            if lengths.shape != (n,) or np.any(lengths <= 0):
                raise fail("link_lengths", owner, f"{n} positive lengths (one per link)",
                           self.link_lengths)
            if lengths.min() < SCALE_RANGE[0] or lengths.max() > SCALE_RANGE[1]:
                raise fail("link_lengths", owner, f"lengths in [{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}] (rescale "
                           "the length unit)", self.link_lengths)
            if lengths.max() / lengths.min() > MAX_LENGTH_RATIO:
                raise fail("link_lengths", owner, f"lengths within a factor {MAX_LENGTH_RATIO:g} of each other",
                           self.link_lengths)
        for name in ("drag_coefficient", "drag_ratio"):
            check_float(getattr(self, name), name, owner, low=SCALE_RANGE[0], high=SCALE_RANGE[1])
        if isinstance(self.body_frame, int | np.integer) and not isinstance(self.body_frame, bool):
            if not 0 <= self.body_frame < n:
                raise fail("body_frame", owner, f"one of {', '.join(BODY_FRAMES)} or a link index in [0, {n})",
                           self.body_frame)
            object.__setattr__(self, "body_frame", int(self.body_frame))
        else:
            check_choice(self.body_frame, "body_frame", owner, BODY_FRAMES)
        if self.frame_offset is not None:
            offset = check_array(self.frame_offset, "frame_offset", owner, ndim=1)
            if offset.shape != (3,):
                raise fail("frame_offset", owner, "(x, y, angle) of the frame on the body frame", self.frame_offset)
            object.__setattr__(self, "frame_offset", tuple(float(x) for x in offset))
        if self.link_drag_scale is not None:
            scale = check_array(self.link_drag_scale, "link_drag_scale", owner, ndim=2)
            if scale.shape != (n, 2) or scale.min() < SCALE_RANGE[0] or scale.max() > SCALE_RANGE[1]:
                raise fail("link_drag_scale", owner, f"an array of shape ({n}, 2) with entries in "
                           f"[{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}] (longitudinal, lateral per link)",
                           self.link_drag_scale)
            object.__setattr__(self, "link_drag_scale", tuple(tuple(float(x) for x in row) for row in scale))
        object.__setattr__(self, "link_lengths", tuple(float(x) for x in lengths))
        object.__setattr__(self, "_geometry", _chain_geometry(lengths, self.body_frame))

    @property
    def n_joints(self) -> int:
        """Shape dimension d = N - 1."""
        return self.n_links - 1

    @property
    def name(self) -> str:
        return f"purcell-{self.n_links}"

    def with_drag_ratio(self, drag_ratio: float) -> PurcellSwimmer:
        """The same swimmer in a fluid of another drag ratio.

        Parameters
        ----------
        drag_ratio : float in [1e-6, 1e6]
            Lateral over longitudinal drag ``k`` of the new fluid (checked like the constructor's).
        """
        return replace(self, drag_ratio=drag_ratio)

    def connection(self, shapes) -> np.ndarray:
        """Local connection A(r): shapes ``(..., d)`` → ``(..., 3, d)``, with ξ = -A ṙ (eq. 1)."""
        shapes = check_shapes(shapes, self.n_joints, "PurcellSwimmer.connection")
        angles = self._angles(shapes)  # (of the whole batch: see _CHUNK_FLOATS)
        count, d = int(np.prod(shapes.shape[:-1])), self.n_joints
        rows = max(1, _CHUNK_FLOATS // (self.n_links * 3 * max(d, 3)))  # (shapes per part: J_i or T_i of each)
        if count <= rows:
            return self._connection(shapes, angles)
        flat, angle, frame_angle = shapes.reshape(count, d), angles[0].reshape(count, -1), angles[1].reshape(count)
        parts = [slice(first, first + rows) for first in range(0, count, rows)]
        parts = [self._connection(flat[part], (angle[part], frame_angle[part])) for part in parts]
        return np.concatenate(parts).reshape(shapes.shape[:-1] + (3, d))

    def _connection(self, shapes, angles) -> np.ndarray:
        transform, jacobian, drag = self._link_terms(shapes, angles)
        return self._to_frame(_solve_connection(transform, jacobian, drag))

    def _angles(self, shapes) -> tuple[np.ndarray, np.ndarray]:
        """Link angles ``(..., N)`` in link 0's frame and the body frame's angle ``(...,)``."""
        angle = shapes @ self._geometry["incidence"].T
        return angle, angle @ self._geometry["frame_angle"]

    def _to_frame(self, body):
        """Ad_{o⁻¹} applied along axis -2 of ``body`` (..., 3, k): body-frame twists into the offset frame."""
        if self.frame_offset is None:
            return body
        return _adjoint_of_inverse(*self.frame_offset) @ body

    def metric(self, shapes) -> np.ndarray:
        """Dissipation metric M(r) ``(..., d, d)``: power = ṙᵀ M ṙ at ξ = -A ṙ.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
            Joint angles r, radians.
        """
        shapes = check_shapes(shapes, self.n_joints, "PurcellSwimmer.metric")
        transform, jacobian, drag = self._link_terms(shapes)
        connection = _solve_connection(transform, jacobian, drag)
        link_rate = jacobian - transform @ connection[..., None, :, :]  # (..., N, 3, d)
        return _link_sum(link_rate * drag[..., :, None], link_rate)

    def _link_terms(self, shapes, angles=None):
        """T_i ``(..., N, 3, 3)``, J_i ``(..., N, 3, d)`` and diagonal drags ``(N, 3)`` (``angles``: those of
        :meth:`_angles`, when known)."""
        geo = self._geometry
        n, d = self.n_links, self.n_joints
        batch = shapes.shape[:-1]
        angle, frame_angle = self._angles(shapes) if angles is None else angles
        cos, sin = np.cos(angle), np.sin(angle)
        unit = np.stack([cos, sin], axis=-2)  # (..., 2, N)
        perp = np.stack([-sin, cos], axis=-2)  # ∂e(β)/∂β
        position = np.swapaxes(unit @ geo["centres"].T, -1, -2)  # (..., N, 2)
        frame_position = unit @ geo["frame_point"]  # (..., 2)
        # ∂p/∂r in link 0's frame, then rotated into each moving frame (body Jacobians).
        link_dpos = np.moveaxis((perp @ geo["link_weights"]).reshape(batch + (2, n, d)), -3, -2)
        frame_dpos = perp @ geo["frame_weights"]  # (..., 2, d)
        link_jac = np.concatenate(
            [_rotate_back(link_dpos, cos[..., None], sin[..., None]),
             np.broadcast_to(geo["incidence"][:, None, :], batch + (n, 1, d))], axis=-2)
        cos_b, sin_b = np.cos(frame_angle), np.sin(frame_angle)
        frame_jac = np.concatenate(
            [_rotate_back(frame_dpos, cos_b[..., None], sin_b[..., None]),
             np.broadcast_to(geo["frame_angle"] @ geo["incidence"], batch + (1, d))], axis=-2)
        # Link pose relative to the body frame, h_i^b = h_b^{-1} h_i, and T_i = Ad_{(h_i^b)^{-1}}.
        rel = _rotate_back(np.swapaxes(position - frame_position[..., None, :], -1, -2),
                           cos_b[..., None], sin_b[..., None])  # (..., 2, N)
        transform = _adjoint_of_inverse(rel[..., 0, :], rel[..., 1, :], angle - frame_angle[..., None])
        jacobian = link_jac - transform @ frame_jac[..., None, :, :]
        return transform, jacobian, self._link_drag()

    def _link_drag(self) -> np.ndarray:
        """Diagonal RFT drag of each link ``(N, 3)``: c (l, k l, k l³/12), times the per-link scales."""
        lengths = np.asarray(self.link_lengths)
        c, k = self.drag_coefficient, self.drag_ratio
        drag = c * np.stack([lengths, k * lengths, k * lengths**3 / 12], axis=-1)
        if self.link_drag_scale is not None:
            drag = drag * np.asarray(self.link_drag_scale)[:, [0, 1, 1]]
        return drag

    def drag_sensitivity(self, shapes, shape_velocity) -> tuple[np.ndarray, np.ndarray]:
        r"""Body velocity ξ = −A(r)ṙ and its derivative with respect to each link's log drag.

        With link twists :math:`v_i = J_i\dot r + T_i\xi` (what each link feels), a change of link i's
        drag :math:`D_i` moves the connection by
        :math:`\partial A = \omega_\xi^{-1} T_i^T\,\partial D_i\,(J_i - T_i A)`, so

        .. math:: \frac{\partial\xi}{\partial\log D_{i,\parallel}} = -\omega_\xi^{-1} T_{i,x}^T D_{i,x} v_{i,x},
           \qquad \frac{\partial\xi}{\partial\log D_{i,\perp}}
           = -\omega_\xi^{-1} \sum_{k\in\{y,\omega\}} T_{i,k}^T D_{i,k} v_{i,k}.

        ξ is unchanged when every drag is scaled alike (the derivatives sum to zero): the motion sees
        only ratios of drags.

        Parameters
        ----------
        shapes, shape_velocity : array-like of shape (..., d)
            Joint angles r (rad) and their rates ṙ (rad per unit time).

        Returns
        -------
        body_velocity : ndarray of shape (..., 3)
        sensitivity : ndarray of shape (..., 3, N, 2)
            ∂ξ / ∂(log longitudinal, log lateral drag) of each link.
        """
        owner = "PurcellSwimmer.drag_sensitivity"
        shapes = check_shapes(shapes, self.n_joints, owner)
        shape_velocity = check_shapes(shape_velocity, self.n_joints, owner)
        transform, jacobian, drag = self._link_terms(shapes)
        weighted = transform * drag[..., :, None]
        resistance = _link_sum(weighted, transform)  # ω_ξ
        connection = np.linalg.solve(resistance, _link_sum(weighted, jacobian))
        body_velocity = -np.einsum("...kj,...j->...k", connection, shape_velocity)
        twist = (np.einsum("...ikj,...j->...ik", jacobian, shape_velocity)
                 + np.einsum("...ikl,...l->...ik", transform, body_velocity))  # v_i (..., N, 3)
        rows = transform * (drag * twist)[..., :, None]  # row k of link i: T_ik D_ik v_ik (..., N, 3, 3)
        per_link = np.stack([rows[..., 0, :], rows[..., 1, :] + rows[..., 2, :]], axis=-1)  # (..., N, 3, 2)
        sensitivity = -np.einsum("...kl,...ilm->...kim", np.linalg.inv(resistance), per_link)
        flat = sensitivity.reshape(sensitivity.shape[:-2] + (-1,))
        return (self._to_frame(body_velocity[..., None])[..., 0],
                self._to_frame(flat).reshape(sensitivity.shape))


def _rotate_back(vectors, cos, sin):
    """Rᵀ v for planar vectors stored along axis -2 (x then y); cos/sin broadcast on the rest."""
    x, y = vectors[..., 0, :], vectors[..., 1, :]
    return np.stack([cos * x + sin * y, -sin * x + cos * y], axis=-2)


def _link_sum(left, right):
    """Σ_i left_iᵀ right_i over links: one matmul over the stacked (link, row) axis."""
    n, rows = left.shape[-3:-1]
    flat_left = left.reshape(left.shape[:-3] + (n * rows, left.shape[-1]))
    flat_right = right.reshape(right.shape[:-3] + (n * rows, right.shape[-1]))
    return np.swapaxes(flat_left, -1, -2) @ flat_right


def _solve_connection(transform, jacobian, drag):
    weighted = transform * drag[..., :, None]  # D_i T_i (D diagonal)
    return np.linalg.solve(_link_sum(weighted, transform), _link_sum(weighted, jacobian))


def _adjoint_of_inverse(x, y, angle):
    """Adjoint ``(..., 3, 3)`` of the inverse of poses (x, y, angle)."""
    cos, sin = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0], out[..., 0, 1] = cos, sin
    out[..., 1, 0], out[..., 1, 1] = -sin, cos
    # g⁻¹ = (-Rᵀp, -angle) and Ad_g = [[R, (p_y, -p_x)ᵀ], [0, 1]].
    out[..., 0, 2] = sin * x - cos * y
    out[..., 1, 2] = cos * x + sin * y
    out[..., 2, 2] = 1.0
    return out


def _chain_geometry(lengths: np.ndarray, body_frame: str | int) -> dict:
    """Constant matrices describing the chain in the frame of link 0.

    ``incidence`` S (N, d): link angle β_i = Σ_j S_ij r_j. ``centres`` C (N, N): centre of link i
    is Σ_k C_ik e(β_k). The body frame sits at Σ_k a_k e(β_k) with angle Σ_k b_k β_k.
    """
    n = lengths.size
    incidence = np.tril(np.ones((n, n - 1)), -1)
    centres = np.zeros((n, n))
    for i in range(1, n):
        centres[i] = centres[i - 1]
        centres[i, i - 1] += lengths[i - 1] / 2
        centres[i, i] += lengths[i] / 2
    if isinstance(body_frame, int):
        point, angle = centres[body_frame], np.eye(n)[body_frame]
    elif body_frame == "middle" and n % 2:
        point, angle = centres[n // 2], np.eye(n)[n // 2]
    elif body_frame == "middle":
        m = n // 2
        point = centres[m - 1] + np.eye(n)[m - 1] * lengths[m - 1] / 2
        angle = (np.eye(n)[m - 1] + np.eye(n)[m]) / 2
    elif body_frame == "center_of_mass":
        weights = lengths / lengths.sum()
        point, angle = weights @ centres, weights
    else:  # tail
        point, angle = centres[0], np.eye(n)[0]
    # ∂(centre of link i)/∂r_j = Σ_k C_ik e⊥(β_k) S_kj: weights (N_k, N_i * d) for one matmul.
    link_weights = (centres[:, :, None] * incidence[None, :, :]).transpose(1, 0, 2).reshape(n, -1)
    return {"incidence": incidence, "centres": centres, "frame_point": point, "frame_angle": angle,
            "link_weights": link_weights, "frame_weights": point[:, None] * incidence}
