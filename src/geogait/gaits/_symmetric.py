r"""Front–back symmetric gaits: a rotation-free family with half the parameters.

A chain whose links are symmetric front to back (the Purcell swimmers with equal links, or any
link lengths that read the same from both ends) looks the same when its joints are numbered from
the other end and every joint angle changes sign. Gaits that are unchanged by that relabelling
combined with a time reversal about a phase :math:`\phi_0`,

.. math:: \theta_{d-1-j}(\phi) = -\theta_j(2\phi_0 - \phi), \qquad j = 0, \dots, d-1,

have **exactly zero net rotation per cycle** on a principally kinematic chain (one whose motion
reverses with time): the relabelled chain, run backwards, turns by the same angle and, run
backwards, by minus it. With inertia or quadratic drag time reversal fails and so does this; the
half-wave symmetric :class:`MirrorGaitFamily` needs no time reversal. For a Fourier gait of order K
the relation is linear in the coefficients. With :math:`c_k = \cos 2k\phi_0`, :math:`s_k = \sin 2k\phi_0` and
:math:`R_k = \begin{pmatrix} c_k & s_k \\ s_k & -c_k\end{pmatrix}` (the coefficients of
:math:`\theta(2\phi_0 - \phi)` are those of :math:`\theta(\phi)` mapped by :math:`R_k`),

.. math:: a_{d-1-j,0} = -a_{j0}, \qquad
   (a_{d-1-j,k}, b_{d-1-j,k}) = -R_k\,(a_{jk}, b_{jk}),

and for odd d the middle joint m = (d − 1)/2 is odd about φ₀:
:math:`\theta_m(\phi) = \sum_k t_k \sin k(\phi - \phi_0)`. The free parameters are the
coefficients of the first ⌊d/2⌋ joints and, for odd d, the K middle-joint amplitudes t_k:
``⌊d/2⌋ (2K + 1) + (d mod 2) K`` of the ``d (2K + 1)`` Fourier coefficients. The map to the
full Fourier parameters is linear, ``p = T q``, so its Jacobian is the constant matrix T.

The paper's seed gait :math:`\theta_j = a\cos(\phi - j\Delta)` is a member for
:math:`\phi_0 = ((d-1)\Delta + \pi)/2`; every gait with the symmetry about some φ₀ is a member of
the family of any other φ₀ after a phase shift, so :meth:`SymmetricGaitFamily.from_gait` picks the
φ₀ that contains a given gait.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from .._docs import fill_doc
from .._validation import check_array, check_float, check_int, fail
from ._fourier import FourierGait

__all__ = ["FreeGaitFamily", "MirrorGaitFamily", "SymmetricGaitFamily", "shift_phase"]


def shift_phase(gait: FourierGait, shift: float) -> FourierGait:
    r"""The same loop started ``shift`` later: :math:`\theta^{s}(\phi) = \theta(\phi + s)`.

    Per harmonic the coefficients rotate:
    :math:`(a_k, b_k) \mapsto (a_k\cos ks + b_k\sin ks,\ b_k\cos ks - a_k\sin ks)`.

    Parameters
    ----------
    gait : FourierGait
        The gait to shift.
    shift : float
        Phase shift s in radians.
    """
    if not isinstance(gait, FourierGait):
        raise fail("gait", "shift_phase", "a FourierGait", type(gait).__name__)
    shift = check_float(shift, "shift", "shift_phase")
    order = gait.order
    k = np.arange(1, order + 1)
    cos, sin = np.cos(k * shift), np.sin(k * shift)
    a, b = gait.coefficients[:, 1:1 + order], gait.coefficients[:, 1 + order:]
    coefficients = gait.coefficients.copy()
    coefficients[:, 1:1 + order] = a * cos + b * sin
    coefficients[:, 1 + order:] = b * cos - a * sin
    return FourierGait(coefficients)


def _family_matrix(n_joints: int, order: int, center: float) -> np.ndarray:
    """The constant map T ``(d (2K+1), n_params)`` from free to Fourier parameters (module docstring)."""
    width = 2 * order + 1
    half = n_joints // 2
    n_params = half * width + (n_joints % 2) * order
    matrix = np.zeros((n_joints, width, n_params))
    k = np.arange(1, order + 1)
    cos, sin = np.cos(2 * k * center), np.sin(2 * k * center)
    for j in range(half):
        columns = slice(j * width, (j + 1) * width)
        matrix[j, :, columns] = np.eye(width)
        mirror = matrix[n_joints - 1 - j]
        mirror[0, j * width] = -1.0
        a_cols, b_cols = j * width + k, j * width + order + k  # free a_jk, b_jk
        mirror[k, a_cols], mirror[k, b_cols] = -cos, -sin
        mirror[order + k, a_cols], mirror[order + k, b_cols] = -sin, cos
    if n_joints % 2:
        middle, first = matrix[half], half * width
        middle[k, first + k - 1] = -np.sin(k * center)
        middle[order + k, first + k - 1] = np.cos(k * center)
    return matrix.reshape(n_joints * width, n_params)


class _SubspaceFamily:
    """What a family that is a linear subspace ``p = T q`` of the Fourier parameters offers, from its
    ``matrix`` T; a subclass says how to solve for q (:meth:`_solve`) and what a member is (:meth:`_member`)."""

    def _check_size(self, minimum_joints: int) -> None:
        owner = type(self).__name__
        check_int(self.n_joints, "n_joints", owner, minimum=minimum_joints)
        check_int(self.order, "order", owner, minimum=1)

    def _hold(self, matrix: np.ndarray) -> None:
        """Keep ``matrix`` as the family's T, read-only: the family is frozen, and T with it."""
        matrix.setflags(write=False)
        object.__setattr__(self, "matrix", matrix)

    @property
    def n_params(self) -> int:
        """Number of free parameters q."""
        return self.matrix.shape[1]

    def fourier_params(self, params) -> np.ndarray:
        """Flat Fourier parameters ``p = T q`` ``(d (2K+1),)`` of free parameters ``q``.

        Parameters
        ----------
        params : array-like of shape (n_params,)
            Free parameters q of the family.
        """
        owner = f"{type(self).__name__}.fourier_params"
        params = check_array(params, "params", owner, ndim=1)
        if params.size != self.n_params:
            raise fail("params", owner, f"a vector of length {self.n_params}", f"length {params.size}")
        return self._map(params)

    def _map(self, params: np.ndarray) -> np.ndarray:
        return self.matrix @ params

    def gait(self, params) -> FourierGait:
        """The member with free parameters ``params`` ``(n_params,)``."""
        return FourierGait.from_params(self.fourier_params(params), self.n_joints)

    def residual(self, gait: FourierGait) -> float:
        """Distance (Euclidean, in Fourier coefficients) from ``gait`` to the family."""
        params = self._fourier_of(gait, f"{type(self).__name__}.residual")
        return float(np.linalg.norm(self.matrix @ self._solve(params) - params))

    def params_of(self, gait: FourierGait, tolerance: float = 1e-9) -> np.ndarray:
        """Free parameters of a member ``gait``; raises if it is farther than ``tolerance`` from the family."""
        owner = f"{type(self).__name__}.params_of"
        params = self._fourier_of(gait, owner)
        solution = self._solve(params)
        miss = float(np.linalg.norm(self.matrix @ solution - params))
        if miss > tolerance:
            raise fail("gait", owner, f"{self._member()}, at distance <= {tolerance:g}",
                       f"a gait at distance {miss:.3g}")
        return solution

    def _solve(self, params: np.ndarray) -> np.ndarray:
        """The free parameters whose Fourier parameters are nearest ``params`` (least squares)."""
        solution, *_ = np.linalg.lstsq(self.matrix, params, rcond=None)
        return solution

    def _member(self) -> str:
        return "a member of the family"

    def _fourier_of(self, gait, owner) -> np.ndarray:
        if not isinstance(gait, FourierGait) or gait.n_joints != self.n_joints or gait.order > self.order:
            raise fail("gait", owner, f"a FourierGait with {self.n_joints} joints and order <= {self.order}", gait)
        return gait.with_order(self.order).params


@fill_doc
@dataclass(frozen=True)
class SymmetricGaitFamily(_SubspaceFamily):
    r"""Fourier gaits with :math:`\theta_{d-1-j}(\phi) = -\theta_j(2\phi_0 - \phi)` (module docstring).

    Zero net rotation per cycle on every front–back symmetric chain, by construction.

    Parameters
    ----------
    n_joints : int
        Shape dimension d (≥ 2).
    order : int
        Fourier order K (≥ 1).
    center : float
        Symmetry phase φ₀ (rad); only φ₀ mod π matters.

    %(subspace_attributes)s

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> family = SymmetricGaitFamily.from_gait(seed_gait(2))
    >>> family.n_params, round(family.center, 6)
    (3, 2.356194)
    >>> q = family.params_of(seed_gait(2))
    >>> bool(np.allclose(family.gait(q).coefficients, seed_gait(2).coefficients))
    True
    """

    n_joints: int
    order: int = 1
    center: float = 0.0
    matrix: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        self._check_size(minimum_joints=2)
        center = float(np.mod(check_float(self.center, "center", "SymmetricGaitFamily"), np.pi))
        object.__setattr__(self, "center", center)
        self._hold(_family_matrix(self.n_joints, self.order, center))

    @property
    def n_params(self) -> int:
        """Number of free parameters, ``⌊d/2⌋ (2K + 1) + (d mod 2) K``."""
        return self.matrix.shape[1]

    def _member(self) -> str:
        return f"a member of the family (symmetric about φ₀ = {self.center:.6g})"

    @classmethod
    def from_gait(cls, gait: FourierGait, order: int | None = None) -> SymmetricGaitFamily:
        """The family (of ``order``, default the gait's) whose φ₀ brings ``gait`` closest to it.

        A grid over φ₀ ∈ [0, π) brackets the best φ₀, a bounded scalar search refines it; for a
        member about any φ₀ the result contains ``gait`` to rounding (check with :meth:`residual`).
        """
        if not isinstance(gait, FourierGait) or gait.n_joints < 2:
            raise fail("gait", "SymmetricGaitFamily.from_gait", "a FourierGait with at least 2 joints", gait)
        order = gait.order if order is None else check_int(order, "order", "SymmetricGaitFamily.from_gait",
                                                             minimum=max(1, gait.order))
        target = gait.with_order(order)

        def distance(center):
            return cls(gait.n_joints, order, center).residual(target)

        grid = np.linspace(0, np.pi, 8 * order * gait.n_joints + 16, endpoint=False)
        values = np.array([distance(c) for c in grid])
        best = grid[np.argmin(values)]
        step = grid[1] - grid[0]
        result = minimize_scalar(distance, bounds=(best - step, best + step), method="bounded",
                                 options={"xatol": 1e-12})
        center, value = (result.x, result.fun) if result.fun <= values.min() else (best, values.min())
        # again as an offset from there: the search's tolerance grows with |φ₀| (√eps |φ₀| ≈ 1e-8), an
        # offset's with the offset, so members come out members to rounding, not to 1e-8
        refined = minimize_scalar(lambda offset: distance(center + offset), bounds=(-1e-6, 1e-6), method="bounded",
                                  options={"xatol": 1e-15})
        if refined.fun < value:
            center = center + refined.x
        return cls(gait.n_joints, order, float(center))


def _mirror_matrix(n_joints: int, order: int) -> np.ndarray:
    """The constant map T ``(d (2K+1), n_params)`` selecting the odd harmonics' a_k, b_k of every joint."""
    width = 2 * order + 1
    odd = np.arange(1, order + 1, 2)
    rows = np.concatenate([odd, order + odd])  # a_k then b_k of the odd k, within one joint's coefficients
    matrix = np.zeros((n_joints, width, n_joints * rows.size))
    for j in range(n_joints):
        matrix[j, rows, j * rows.size + np.arange(rows.size)] = 1.0
    return matrix.reshape(n_joints * width, -1)


@fill_doc
@dataclass(frozen=True)
class MirrorGaitFamily(_SubspaceFamily):
    r"""Half-wave symmetric Fourier gaits, :math:`\theta(\phi + \pi) = -\theta(\phi)`: rotation-free on
    every planar body whose physics is unchanged by a mirror reflection.

    Reflecting a planar body across its own long axis changes the sign of every shape coordinate that
    bends it (joint angles of a chain of any link lengths, curvature modes of a continuum) and maps a
    body velocity :math:`(v_x, v_y, \omega)` to :math:`(v_x, -v_y, -\omega)` in a frame on that axis.
    When the medium does the same (viscous drag, resistive force theory, anisotropic friction measured
    along the body's tangent), the mirror image of a motion is a motion. A gait whose second half
    cycle is the mirror image of its first, :math:`\theta(\phi + \pi) = -\theta(\phi)`, therefore
    turns the body by :math:`\Delta\theta` in the first half and by :math:`-\Delta\theta` in the
    second: **exactly zero net rotation per cycle**, whatever the link lengths, and for a body with
    inertia on its periodic steady state too. Unlike :class:`SymmetricGaitFamily` it needs no
    front–back symmetry. A Fourier gait has the symmetry exactly when its offsets and even harmonics
    vanish, so the free parameters are :math:`a_{jk}, b_{jk}` of the odd k:
    ``d · 2 ⌈K / 2⌉`` of the ``d (2K + 1)`` Fourier coefficients (the paper's seed gait is a member).
    The map to Fourier parameters is a constant selection, ``p = T q``.

    Parameters
    ----------
    n_joints : int
        Shape dimension d (≥ 1).
    order : int
        Fourier order K (≥ 1).

    %(subspace_attributes)s

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> family = MirrorGaitFamily(2)
    >>> family.n_params, family.residual(seed_gait(2))
    (4, 0.0)
    >>> gait = family.gait(family.params_of(seed_gait(2)))
    >>> bool(np.allclose(gait.shape(np.pi + 0.3), -gait.shape(0.3)))
    True
    """

    n_joints: int
    order: int = 1
    matrix: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        self._check_size(minimum_joints=1)
        self._hold(_mirror_matrix(self.n_joints, self.order))

    @property
    def n_params(self) -> int:
        """Number of free parameters, ``d · 2 ⌈K / 2⌉``."""
        return self.matrix.shape[1]

    def _solve(self, params: np.ndarray) -> np.ndarray:
        return self.matrix.T @ params  # T selects coordinates: its pseudo-inverse is Tᵀ, exactly

    def _member(self) -> str:
        return "a half-wave symmetric gait (no offsets or even harmonics)"


@dataclass(frozen=True)
class FreeGaitFamily(_SubspaceFamily):
    """All Fourier gaits of ``order`` on ``n_joints`` joints, with the interface of
    :class:`SymmetricGaitFamily` (free parameters = Fourier parameters, ``matrix`` = identity; every gait of
    this shape dimension and order ≤ K is a member, at distance 0).

    Examples
    --------
    >>> family = FreeGaitFamily(2, 1)
    >>> family.n_params, family.gait([0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).shape(0.0).round(6).tolist()
    (6, [1.0, 0.0])
    """

    n_joints: int
    order: int = 1
    matrix: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        self._check_size(minimum_joints=1)
        self._hold(np.eye(self.n_joints * (2 * self.order + 1)))

    @property
    def n_params(self) -> int:
        """d (2K + 1)."""
        return self.matrix.shape[1]

    def _map(self, params: np.ndarray) -> np.ndarray:
        return params.copy()  # the parameters themselves

    def _solve(self, params: np.ndarray) -> np.ndarray:
        return params.copy()
