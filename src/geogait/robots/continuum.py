r"""Continuum bodies as geogait locomotors: a body frame and a few modal shape coordinates.

A soft body (a snake, an eel, a Cosserat rod) is measured as a chain of **nodes** in the plane,
``positions`` of shape (..., n, 2), joined by n − 1 **elements** (edges
:math:`e_i = x_{i+1} - x_i`, lengths :math:`l_i`, tangent angles :math:`\vartheta_i`, unwrapped
along the body). geogait needs three things from it, all computed here with numpy only.

**Body frame** (:func:`body_pose`, :func:`body_velocity`). Its origin is the centre of mass
:math:`c = \sum_k m_k x_k / \sum_k m_k` (nodal masses, equal by default); its heading is the
*mean tangent angle*

.. math:: h = \sum_i w_i \vartheta_i, \qquad \sum_i w_i = 1

(weights equal by default: for a uniformly discretised, nearly inextensible body this is the
arc-length average of the tangent angle). A rigid rotation by α adds α to every ϑ_i and so to
h; a translation changes nothing; unlike the head–tail chord it stays defined for a body curled
into a ring. The body velocity ξ = (v_x, v_y, ω) is the centre-of-mass velocity rotated into the
body frame and the exact rate of the heading,

.. math:: \omega = \dot h = \sum_i w_i \dot\vartheta_i, \qquad
          \dot\vartheta_i = \frac{e_i \times \dot e_i}{|e_i|^2},

so ξ integrates to the poses (no finite differences).

**Curvature** (:func:`curvature_profile`, :func:`curvature_rate`). At each interior node the
discrete curvature is the turning angle between the adjacent elements over the Voronoi length,
:math:`\kappa_i = (\vartheta_i - \vartheta_{i-1}) / D_i`, :math:`D_i = (l_{i-1} + l_i) / 2`;
its rate follows from the node velocities exactly. :func:`rod_from_curvature` is the inverse: the
nodes of a body with given element lengths and curvatures.

**Modal shape coordinates** (:class:`CurvatureModes`). A few fixed modes ψ_j over the normalised
arc length σ = s / L turn the curvature profile into d shape coordinates q (geogait's "joint
angles") and back,

.. math:: \kappa(s) = \sum_{j} q_j\, b_j(s), \qquad q = \arg\min_q \|B q - \kappa\|_2
          = B^{+} \kappa,

with :math:`B_{ij} = b_j(s_i)` at the interior nodes. ``kind="fourier"`` (default): sine and
cosine waves of wavenumber k = 1, 2, … per body length, in the order sin 2πσ, cos 2πσ, sin 4πσ,
cos 4πσ, …, each scaled by 2πk / L so that **q_j is the amplitude (rad) of the tangent-angle
wave** that mode j bends into the body. A travelling wave of one wavelength per body is then the
first two coordinates running a circle, q = a (cos φ, sin φ): geogait's seed gait. ``kind=
"legendre"``: Legendre polynomials :math:`P_j(2\sigma - 1) / L` (mode 0 is a constant curvature:
a turn of q_0 rad over the body), for profiles that are not waves. The modal command q of a
controller becomes the rest curvature :math:`B q` of a simulated rod (or the set-points of a
real one); realised → modes → commanded is exact when κ lies in the span of the modes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_array, check_choice, check_float, check_int, fail

__all__ = ["CurvatureModes", "body_pose", "body_velocity", "curvature_profile", "curvature_rate",
           "rod_from_curvature", "tangent_angles"]

_KINDS = ("fourier", "legendre")


def _positions(positions, name: str, owner: str, min_nodes: int) -> np.ndarray:
    array = check_array(positions, name, owner, trailing=(None, 2), min_ndim=2)
    if array.shape[-2] < min_nodes:
        raise fail(name, owner, f"an array of shape (..., n, 2) with n >= {min_nodes} nodes",
                   f"shape {array.shape}")
    return array


def _velocities(velocities, positions: np.ndarray, owner: str) -> np.ndarray:
    array = check_array(velocities, "velocities", owner, trailing=(None, 2), min_ndim=2)
    if array.shape != positions.shape:
        raise fail("velocities", owner, f"an array of the positions' shape {positions.shape}", f"shape {array.shape}")
    return array


def _weights(values, size: int, name: str, owner: str) -> np.ndarray:
    if values is None:
        return np.full(size, 1.0 / size)
    array = check_array(values, name, owner, ndim=1)
    if array.shape != (size,) or np.any(array < 0) or array.sum() <= 0:
        raise fail(name, owner, f"an array of shape ({size},) of non-negative values with a positive sum", values)
    return array / array.sum()


def _edges(positions: np.ndarray, owner: str) -> np.ndarray:
    edges = np.diff(positions, axis=-2)
    if np.any(np.hypot(edges[..., 0], edges[..., 1]) == 0):
        raise fail("positions", owner, "nodes with distinct neighbours (no element of zero length)",
                   "coincident consecutive nodes")
    return edges


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def tangent_angles(positions) -> np.ndarray:
    """Angle of each element (from the x-axis), continuous along the body.

    Parameters
    ----------
    positions : array-like of shape (..., n, 2)
        Node positions, n >= 2.

    Returns
    -------
    ndarray of shape (..., n - 1)
        ϑ_i, the first in (−π, π], the others unwrapped (consecutive elements turn by less than π).
    """
    positions = _positions(positions, "positions", "tangent_angles", 2)
    edges = _edges(positions, "tangent_angles")
    return np.unwrap(np.arctan2(edges[..., 1], edges[..., 0]), axis=-1)


def body_pose(positions, *, masses=None, weights=None, reference_heading: float | None = None) -> np.ndarray:
    r"""World pose (x, y, heading) of the body frame: centre of mass and mean tangent angle.

    Parameters
    ----------
    positions : array-like of shape (n, 2) or (n_samples, n, 2)
        Node positions, n >= 2. For a sequence, the heading is continuous along the samples.
    masses : array-like of shape (n,), optional
        Nodal masses for the centre of mass; equal by default.
    weights : array-like of shape (n - 1,), optional
        Element weights w_i of the heading :math:`h = \sum_i w_i \vartheta_i` (normalised to sum 1);
        equal by default. Use the element rest lengths for a non-uniform discretisation.
    reference_heading : float, optional
        The heading of the previous sample: the (first) heading is shifted by a multiple of 2π to
        lie within π of it, so that headings stay continuous across calls.

    Returns
    -------
    ndarray of shape (3,) or (n_samples, 3)
        (x, y, heading).

    Examples
    --------
    >>> body_pose([[0.0, 0.0], [0.0, 1.0], [0.0, 2.0]]).round(6)
    array([0.      , 1.      , 1.570796])
    """
    owner = "body_pose"
    positions = _positions(positions, "positions", owner, 2)
    if positions.ndim > 3:
        raise fail("positions", owner, "an array of shape (n, 2) or (n_samples, n, 2)", f"shape {positions.shape}")
    n = positions.shape[-2]
    mass = _weights(masses, n, "masses", owner)
    weight = _weights(weights, n - 1, "weights", owner)
    edges = _edges(positions, owner)
    heading = np.unwrap(np.arctan2(edges[..., 1], edges[..., 0]), axis=-1) @ weight
    if positions.ndim == 3:
        heading = np.unwrap(heading)
    if reference_heading is not None:
        reference = check_float(reference_heading, "reference_heading", owner)
        first = heading if heading.ndim == 0 else heading[0]
        heading = heading - 2 * np.pi * np.round((first - reference) / (2 * np.pi))
    centre = np.einsum("...ni,n->...i", positions, mass)
    return np.concatenate([centre, np.asarray(heading)[..., None]], axis=-1)


def body_velocity(positions, velocities, *, masses=None, weights=None) -> np.ndarray:
    r"""Body velocity ξ = (v_x, v_y, ω) of the body frame of :func:`body_pose`, in that frame.

    .. math:: (v_x, v_y) = R(-h)\,\dot c, \qquad \omega = \sum_i w_i\,
              \frac{e_i \times \dot e_i}{|e_i|^2}

    Parameters
    ----------
    positions, velocities : array-like of shape (..., n, 2)
        Node positions and velocities (world frame), n >= 2.
    masses, weights : array-like, optional
        As in :func:`body_pose`.

    Returns
    -------
    ndarray of shape (..., 3)

    Examples
    --------
    >>> x = [[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]]
    >>> body_velocity(x, [[0.0, -1.0], [0.0, 0.0], [0.0, 1.0]]).round(6)   # spinning in place
    array([0., 0., 1.])
    """
    owner = "body_velocity"
    positions = _positions(positions, "positions", owner, 2)
    velocities = _velocities(velocities, positions, owner)
    n = positions.shape[-2]
    mass = _weights(masses, n, "masses", owner)
    weight = _weights(weights, n - 1, "weights", owner)
    edges = _edges(positions, owner)
    edge_rates = np.diff(velocities, axis=-2)
    heading = np.unwrap(np.arctan2(edges[..., 1], edges[..., 0]), axis=-1) @ weight
    omega = (_cross(edges, edge_rates) / np.sum(edges**2, axis=-1)) @ weight
    centre_rate = np.einsum("...ni,n->...i", velocities, mass)
    cos, sin = np.cos(heading), np.sin(heading)
    forward = cos * centre_rate[..., 0] + sin * centre_rate[..., 1]
    lateral = -sin * centre_rate[..., 0] + cos * centre_rate[..., 1]
    return np.stack([forward, lateral, omega], axis=-1)


def curvature_profile(positions) -> tuple[np.ndarray, np.ndarray]:
    r"""Arc length and discrete curvature at the interior nodes.

    .. math:: \kappa_i = \frac{\vartheta_i - \vartheta_{i-1}}{D_i}, \qquad D_i = \frac{l_{i-1} + l_i}{2}

    (signed: positive where the body turns counter-clockwise as s grows). A circular arc of radius R
    cut into chords of arc length Δs gives :math:`\kappa_i = (\Delta s / R) / (2R\sin(\Delta s / 2R))
    = (1 + O(\Delta s^2 / R^2)) / R`.

    Parameters
    ----------
    positions : array-like of shape (..., n, 2)
        Node positions, n >= 3.

    Returns
    -------
    arc_length : ndarray of shape (..., n - 2)
        Arc length s_i of each interior node from the first node (sum of element lengths).
    curvature : ndarray of shape (..., n - 2)
        κ_i (1 / length unit).
    """
    owner = "curvature_profile"
    positions = _positions(positions, "positions", owner, 3)
    edges = _edges(positions, owner)
    lengths = np.hypot(edges[..., 0], edges[..., 1])
    turning = np.arctan2(_cross(edges[..., :-1, :], edges[..., 1:, :]),
                         np.sum(edges[..., :-1, :] * edges[..., 1:, :], axis=-1))
    voronoi = 0.5 * (lengths[..., :-1] + lengths[..., 1:])
    return np.cumsum(lengths, axis=-1)[..., :-1], turning / voronoi


def curvature_rate(positions, velocities) -> np.ndarray:
    r"""Exact time derivative of :func:`curvature_profile`'s curvature, from the node velocities.

    .. math:: \dot\kappa_i = \frac{\dot\vartheta_i - \dot\vartheta_{i-1}}{D_i}
              - \kappa_i \frac{\dot D_i}{D_i}, \qquad \dot\vartheta_i = \frac{e_i\times\dot e_i}{|e_i|^2},
              \quad \dot l_i = \frac{e_i\cdot\dot e_i}{|e_i|}

    Parameters
    ----------
    positions, velocities : array-like of shape (..., n, 2)
        Node positions and velocities, n >= 3.

    Returns
    -------
    ndarray of shape (..., n - 2)
        κ̇_i (1 / (length unit · time unit)).
    """
    owner = "curvature_rate"
    positions = _positions(positions, "positions", owner, 3)
    velocities = _velocities(velocities, positions, owner)
    _, curvature = curvature_profile(positions)
    edges = _edges(positions, owner)
    rates = np.diff(velocities, axis=-2)
    squared = np.sum(edges**2, axis=-1)
    lengths = np.sqrt(squared)
    angle_rate = _cross(edges, rates) / squared
    length_rate = np.sum(edges * rates, axis=-1) / lengths
    voronoi = 0.5 * (lengths[..., :-1] + lengths[..., 1:])
    voronoi_rate = 0.5 * (length_rate[..., :-1] + length_rate[..., 1:])
    return np.diff(angle_rate, axis=-1) / voronoi - curvature * voronoi_rate / voronoi


def rod_from_curvature(curvature, element_lengths, *, origin=(0.0, 0.0), heading: float = 0.0) -> np.ndarray:
    """Node positions of a body with the given element lengths and interior curvatures.

    The inverse of :func:`curvature_profile`: element i has length ``element_lengths[i]``, the first
    element points along ``heading`` and at interior node i the body turns by κ_i D_i.

    Parameters
    ----------
    curvature : array-like of shape (n - 2,)
        Curvature at the interior nodes.
    element_lengths : array-like of shape (n - 1,)
        Positive element lengths.
    origin : array-like of shape (2,)
        Position of the first node.
    heading : float
        Angle of the first element (rad).

    Returns
    -------
    ndarray of shape (n, 2)

    Examples
    --------
    >>> rod_from_curvature([0.0], [1.0, 1.0]).round(6)
    array([[0., 0.],
           [1., 0.],
           [2., 0.]])
    """
    owner = "rod_from_curvature"
    lengths = check_array(element_lengths, "element_lengths", owner, ndim=1)
    if lengths.size < 2 or np.any(lengths <= 0):
        raise fail("element_lengths", owner, "an array of shape (n - 1,) of positive lengths with n >= 3",
                   element_lengths)
    curvature = check_array(curvature, "curvature", owner, ndim=1)
    if curvature.shape != (lengths.size - 1,):
        raise fail("curvature", owner, f"an array of shape ({lengths.size - 1},) (one per interior node)",
                   f"shape {curvature.shape}")
    origin = check_array(origin, "origin", owner, ndim=1)
    if origin.shape != (2,):
        raise fail("origin", owner, "an array of shape (2,)", f"shape {origin.shape}")
    heading = check_float(heading, "heading", owner)
    voronoi = 0.5 * (lengths[:-1] + lengths[1:])
    angles = heading + np.concatenate([[0.0], np.cumsum(curvature * voronoi)])
    steps = lengths[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return origin + np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])


@dataclass(frozen=True)
class CurvatureModes:
    r"""A fixed modal basis of curvature profiles over a body of length L (module docstring).

    Parameters
    ----------
    n_modes : int >= 1
        Number of modal coordinates d.
    kind : {"fourier", "legendre"}
        ``"fourier"``: :math:`b_j(s) = \frac{2\pi k}{L}\sin 2\pi k\sigma` (j even) or
        :math:`\frac{2\pi k}{L}\cos 2\pi k\sigma` (j odd), k = ⌊j/2⌋ + 1, σ = s / L: q_j is the
        amplitude of the tangent-angle wave of mode j (rad). ``"legendre"``:
        :math:`b_j(s) = P_j(2\sigma - 1) / L`.
    length : float > 0
        Body length L (the modes' arc-length scale).

    Examples
    --------
    >>> modes = CurvatureModes(2, length=1.0)
    >>> s = np.linspace(0.05, 0.95, 19)
    >>> modes.project(modes.curvature([0.3, -0.2], s), s).round(6)
    array([ 0.3, -0.2])
    """

    n_modes: int = 4
    kind: str = "fourier"
    length: float = 1.0

    def __post_init__(self):
        check_int(self.n_modes, "n_modes", "CurvatureModes", minimum=1)
        check_choice(self.kind, "kind", "CurvatureModes", _KINDS)
        check_float(self.length, "length", "CurvatureModes", low=0, low_open=True)

    def _arc_length(self, arc_length, owner: str) -> np.ndarray:
        return check_array(arc_length, "arc_length", owner, ndim=1)

    def basis(self, arc_length) -> np.ndarray:
        """Curvature of each unit mode at the given arc lengths.

        Parameters
        ----------
        arc_length : array-like of shape (m,)
            Arc lengths s (same unit as ``length``).

        Returns
        -------
        ndarray of shape (m, n_modes)
            B with :math:`\\kappa = B q`.
        """
        s = self._arc_length(arc_length, "CurvatureModes.basis")
        sigma = s / self.length
        columns = []
        for j in range(self.n_modes):
            if self.kind == "fourier":
                k = j // 2 + 1
                wave = np.sin if j % 2 == 0 else np.cos
                columns.append(2 * np.pi * k / self.length * wave(2 * np.pi * k * sigma))
            else:
                unit = np.zeros(j + 1)
                unit[j] = 1.0
                columns.append(np.polynomial.legendre.legval(2 * sigma - 1, unit) / self.length)
        return np.stack(columns, axis=-1)

    def projector(self, arc_length) -> np.ndarray:
        """Least-squares projector P = B⁺ from curvatures at ``arc_length`` to modal coordinates.

        Parameters
        ----------
        arc_length : array-like of shape (m,)
            Arc lengths of the curvature samples; ``m >= n_modes`` points that resolve every mode.

        Returns
        -------
        ndarray of shape (n_modes, m)
        """
        owner = "CurvatureModes.projector"
        basis = self.basis(arc_length)
        if basis.shape[0] < self.n_modes or np.linalg.matrix_rank(basis) < self.n_modes:
            raise fail("arc_length", owner, f"points that resolve all {self.n_modes} modes "
                       f"(at least {self.n_modes}, spread over the body)", f"{basis.shape[0]} points")
        return np.linalg.pinv(basis)

    def project(self, curvature, arc_length) -> np.ndarray:
        """Modal coordinates q of curvature profiles (least squares).

        Parameters
        ----------
        curvature : array-like of shape (..., m)
            κ at ``arc_length``.
        arc_length : array-like of shape (m,)

        Returns
        -------
        ndarray of shape (..., n_modes)
        """
        projector = self.projector(arc_length)
        curvature = check_array(curvature, "curvature", "CurvatureModes.project", trailing=(projector.shape[1],))
        return curvature @ projector.T

    def curvature(self, modes, arc_length) -> np.ndarray:
        """Curvature profile κ = B q of modal coordinates (a rod's rest curvature from a command).

        Parameters
        ----------
        modes : array-like of shape (..., n_modes)
        arc_length : array-like of shape (m,)

        Returns
        -------
        ndarray of shape (..., m)
        """
        modes = check_array(modes, "modes", "CurvatureModes.curvature", trailing=(self.n_modes,))
        return modes @ self.basis(arc_length).T
