r"""A connection model over shape space that keeps what earlier gaits taught.

The local gait models (:class:`AdaptiveGaitModel`, :class:`BatchGaitModel`) expand ξ around one
nominal gait; every gait change throws most of that information away. This model instead learns
the local connection itself, :math:`\xi = -A(r)\dot r` (paper eq. 1), as a smooth function of
shape, from every sample of every gait:

.. math:: \xi_k = \sum_{j=1}^{d}\sum_{l=1}^{m} W_{ljk}\, f_l(r/s)\, \dot r_j
   = W^T x, \qquad x = f(r/s) \otimes \dot r \in \mathbb{R}^{m d},

with :math:`f` the monomials of total degree ≤ D in the scaled shape :math:`r/s`
(:math:`m = \binom{d + D}{D}`), so each entry of :math:`-A(r)` is a polynomial of degree D.

Why this basis: (1) the model is *linear in ṙ with no constant term*, exactly the structure of a
principally kinematic system, so it is rate-independent (no phase rate or time unit enters) and
cannot learn a drift; (2) polynomials of total degree D are the Taylor expansion of the (analytic)
connection, so D = 1–2 already captures the curvature the optimiser needs over the ±2 rad a gait
spans, while D is the one knob that trades bias against the number of weights (``m d``: 20 / 60 /
360 for D = 2 and d = 2 / 4 / 8); (3) the regressor is linear in the weights, so recursive least
squares gives the exact least-squares fit of all data seen, with no phase windows and no nominal
gait: the model of a gait far from the current one is available without a rebase. A tensor-product
or spline basis has far more weights for the same smoothness in d = 8.

Symmetry (``symmetry``): a chain swimmer's connection obeys exact symmetries that halve or quarter
the weights. Reflecting the body about its x axis maps :math:`r \to -r` and
:math:`(\xi_x, \xi_y, \xi_\theta) \to (\xi_x, -\xi_y, -\xi_\theta)`, so :math:`A(-r) = -M A(r)`
with :math:`M = \mathrm{diag}(1, -1, -1)`: the x row of A is odd in r, the y and θ rows even
(``"mirror"``). Reversing the chain (link i ↔ link N−1−i, body frame at the middle, turned by π) maps
:math:`r \to -Pr` with P the reversal of the joint order; with the mirror this gives
:math:`A(Pr)\,P = \mathrm{diag}(-1, 1, -1)\,A(r)` (``"mirror+reversal"``). Each output k then has
its weights in a subspace :math:`W_{\cdot k} = B_k w_k` of the features (monomials of the right
parity; symmetric or antisymmetric pairs under the reversal), with orthonormal :math:`B_k`
(:func:`symmetry_blocks`). Outputs sharing a subspace share one filter; a degree-3 model of the
9-link swimmer has 1320 features for all three outputs without symmetry, 1024 (x) and 296 (y, θ)
with the mirror, and 512 / 148 / 148 with both.

Learning is one RLS filter (:class:`RLSBank` with a single "window") per trial and per block of
outputs with a common subspace, forgetting λ per sample, covariance symmetric and bounded by the
bank's trace clamp; a call's samples are taken as blocks (:meth:`RLSBank.update_sequence`), exactly
the sequential filter at a fraction of its cost. The net motion per cycle of a
candidate gait integrates :math:`\hat\xi(\phi) = W^T (f(\theta(\phi)/s) \otimes \theta'(\phi))`
with the project's fourth-order Magnus integrator; its Jacobian with respect to the gait's Fourier
parameters is exact (chain rule through the monomials and the Magnus steps).

Confidence Γ (eq. 6) is computed online from a-priori errors against a phase model ξ_T learned
alongside, exactly as for the local models.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np

from .. import _kernels
from .._docs import fill_doc
from .._estimator import Estimator, Integer, Options, Real
from .._validation import MAX_BYTES, GeogaitError, check_array, check_bytes, check_float, fail
from ..gaits import FourierGait
from ..se2 import SERIES_THRESHOLD, gauss_phases, integrate_cycle
from ._base import (
    FORMAT,
    FORMAT_VERSION,
    SampleModel,
    check_finite_banks,
    check_residual_variance,
    check_samples,
    check_smoothing_order,
    check_stored_sizes,
    unfitted_unchanged_on_error,
)
from ._displacement import phase_basis
from ._online_gamma import OnlineGamma
from ._phase import PhaseModel
from ._rls import RLSBank

__all__ = ["SYMMETRIES", "ShapeSpaceModel", "monomial_exponents", "monomials", "symmetry_blocks"]

#: Values of ``ShapeSpaceModel(symmetry=...)``.
SYMMETRIES = (None, "mirror", "mirror+reversal")
_MIRROR_SIGN = np.array([1, -1, -1])  # ξ(−r, −ṙ) = diag(1, −1, −1) ξ(r, ṙ)
_REVERSAL_SIGN = np.array([-1, 1, -1])  # ξ(Pr, Pṙ) = diag(−1, 1, −1) ξ(r, ṙ), mirror and reversal composed


def monomial_exponents(n_joints: int, degree: int) -> np.ndarray:
    """Exponents ``(m, d)`` of the monomials of total degree ≤ ``degree`` in ``n_joints`` = d variables, graded
    (degree 0 first)."""
    rows = [np.zeros(n_joints, dtype=np.int64)]
    for total in range(1, degree + 1):
        for combination in itertools.combinations_with_replacement(range(n_joints), total):
            rows.append(np.bincount(combination, minlength=n_joints))
    return np.array(rows)


@functools.lru_cache(maxsize=32)
def _lowering(key: bytes, m: int, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For exponents E ``(m, d)`` (bytes ``key``): index of :math:`E_l - e_i` ``(m, d)`` (0 where
    :math:`E_{li} = 0`), and per monomial a variable it contains and its total degree; raises
    ``KeyError`` naming a monomial whose divisor is missing."""
    exponents = np.frombuffer(key, dtype=np.int64).reshape(m, d)
    position = {tuple(row): l for l, row in enumerate(exponents)}
    lower = np.zeros((m, d), dtype=np.int64)
    for l, i in zip(*np.nonzero(exponents), strict=True):
        below = exponents[l].copy()
        below[i] -= 1
        lower[l, i] = position[tuple(below)]
    variable = np.argmax(exponents > 0, axis=1)
    return lower, variable, exponents.sum(axis=1)


def monomials(shape, exponents: np.ndarray, derivative: bool = False):
    r"""Monomials :math:`f_l(r) = \prod_i r_i^{E_{li}}` of ``shape`` ``(..., d)`` → ``(..., m)``, with ``exponents``
    E ``(m, d)``.

    The exponents must be closed under lowering (with every monomial, each of its divisors
    :math:`E_l - e_i`, like :func:`monomial_exponents`): then degree by degree
    :math:`f_l = r_i f_{l - e_i}`, and with ``derivative`` also
    :math:`\partial f_l/\partial r_i = E_{li} f_{l - e_i}` ``(..., m, d)`` — exact, one gather each.
    """
    shape = np.asarray(shape, dtype=float)
    exponents = np.ascontiguousarray(exponents, dtype=np.int64)
    m, d = exponents.shape
    try:
        lower, variable, degree = _lowering(exponents.tobytes(), m, d)
    except KeyError as missing:
        raise fail("exponents", "monomials", "exponents closed under lowering (e.g. monomial_exponents)",
                   f"no divisor {missing.args[0]}") from None
    values = np.empty(shape.shape[:-1] + (m,))
    values[..., degree == 0] = 1.0
    for total in range(1, int(degree.max(initial=0)) + 1):
        level = np.flatnonzero(degree == total)
        parent = lower[level, variable[level]]
        values[..., level] = values[..., parent] * shape[..., variable[level]]
    if not derivative:
        return values
    return values, exponents * values[..., lower]


def symmetry_blocks(exponents: np.ndarray, symmetry: str | None) -> list[tuple[np.ndarray, np.ndarray]]:
    r"""Outputs that share a weight subspace, and an orthonormal basis of it (module docstring).

    Features are :math:`x_{lj} = f_l(r)\,\dot r_j` at flat index :math:`l d + j`. Under the mirror
    :math:`x_{lj} \to (-1)^{|E_l| + 1} x_{lj}`, so output k keeps the features whose sign equals
    :math:`M_k`. The reversal permutes them, :math:`x_{lj}(Pr, P\dot r) = x_{\pi(l),\, d-1-j}(r, \dot r)`
    (π reverses the exponents), an involution Q; output k keeps Q's eigenspace of eigenvalue
    :math:`c_k`, spanned by :math:`(e_i + c_k e_{Q(i)})/\sqrt 2` and, for c_k = 1, the fixed points.

    Parameters
    ----------
    exponents : int ndarray of shape (m, d)
        Monomial exponents (:func:`monomial_exponents`).
    symmetry : {None, "mirror", "mirror+reversal"}

    Returns
    -------
    list of (outputs, basis)
        ``outputs``: int array of the outputs (0 = x, 1 = y, 2 = θ) of one block; ``basis``: ndarray
        of shape (m d, n_b) with orthonormal columns, :math:`W_{\cdot k} = B\, w_k`.
    """
    m, d = exponents.shape
    size = m * d
    if symmetry is None:
        return [(np.arange(3), np.eye(size))]
    degree = np.repeat(exponents.sum(axis=1), d)  # of feature l d + j
    feature_sign = np.where(degree % 2 == 1, 1, -1)  # (−1)^(|E_l| + 1)
    keys = _MIRROR_SIGN[:, None] if symmetry == "mirror" else np.stack([_MIRROR_SIGN, _REVERSAL_SIGN], axis=1)
    position = {tuple(row): i for i, row in enumerate(exponents)}
    reversed_monomial = np.array([position[tuple(row[::-1])] for row in exponents])
    partner = (reversed_monomial[:, None] * d + np.arange(d)[::-1]).ravel()  # Q(i)
    blocks = []
    for key in np.unique(keys, axis=0)[::-1]:
        outputs = np.flatnonzero((keys == key).all(axis=1))
        kept = np.flatnonzero(feature_sign == key[0])
        if symmetry == "mirror":
            basis = np.eye(size)[:, kept]
        else:
            first = kept[kept <= partner[kept]]  # one index per orbit {i, Q(i)}
            pair = first[first != partner[first]]
            fixed = first[first == partner[first]] if key[1] == 1 else first[:0]
            basis = np.zeros((size, len(pair) + len(fixed)))
            basis[pair, np.arange(len(pair))] = np.sqrt(0.5)
            basis[partner[pair], np.arange(len(pair))] = key[1] * np.sqrt(0.5)
            basis[fixed, len(pair) + np.arange(len(fixed))] = 1.0
        blocks.append((outputs, basis))
    return sorted(blocks, key=lambda block: block[0][0])


@fill_doc
class ShapeSpaceModel(OnlineGamma, SampleModel, Estimator):
    r"""Polynomial connection model :math:`\hat\xi = W^T (f(r/s) \otimes \dot r)`, learned by RLS (module).

    Parameters
    ----------
    degree : int >= 0
        Total degree D of the polynomial entries of A(r).
    symmetry : {None, "mirror", "mirror+reversal"}
        Exact symmetries of the connection built into the basis (module docstring): ``"mirror"``
        (A_x odd, A_y and A_θ even in r: any planar chain whose body frame lies on a link's axis or
        on the chain's symmetry axis), ``"mirror+reversal"`` (also the front–back reversal: chains
        with lengths and drags symmetric about the middle, body frame at the middle, e.g.
        ``PurcellSwimmer(body_frame="middle")``). ``None``: no constraint.
    shape_scale : float in [1e-6, 1e6]
        s: the monomials are of r / s (conditioning only; s ≈ the largest joint angle is best).
    forgetting_factor : float in (0, 1]
        λ per sample; memory ≈ 1 / (1 − λ) samples. 1 keeps everything (exact least squares).
    initial_covariance : float in (0, 1e12]
        δ₀: P starts at δ₀·I (a ridge prior 1/δ₀ on W); the trace clamp keeps trace P ≤ trace P₀.
    degree_shrinkage : float > 0
        b: the prior variance of the weights of degree-q monomials is δ₀ b^{−q}, a ridge penalty
        that grows by b per degree (b = 1: the same for all). With b > 1 a high degree can be afforded:
        its weights stay near zero until the data demand them (the Taylor coefficients of an analytic
        connection shrink with degree in the same way).
    %(online_gamma_params)s

    Attributes
    ----------
    exponents_ : ndarray of shape (m, d)
    blocks_ : list of (outputs, basis)
        Outputs sharing a weight subspace and its orthonormal basis ``(m d, n_b)``
        (:func:`symmetry_blocks`); one block of all outputs without symmetry.
    weights_ : ndarray of shape batch + (m, d, 3)
        :math:`W_{ljk}`; :meth:`connection` gives A(r).
    covariances_ : list of ndarray of shape batch + (n_b, n_b)
        RLS covariance of each block's weights :math:`w_k` (``covariances_[0]`` is the full
        ``(m d, m d)`` covariance shared by all outputs without symmetry).
    phase_model_ : PhaseModel
    gamma_ : float or ndarray of shape batch
        Online Γ after the last sample (eq. 6).
    prior_prediction_ : ndarray of shape batch + (n, 3)
        A-priori predictions of the samples of the last ``partial_fit`` call.
    n_joints_ : int
    batch_shape_ : tuple
    n_samples_seen_ : int

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import simulate, cycle_displacement
    >>> swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    >>> run = simulate(swimmer, gait, n_cycles=10, seed=0)
    >>> model = ShapeSpaceModel(degree=3).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    >>> error = model.predict_displacement(gait) - cycle_displacement(swimmer, gait)
    >>> bool(np.abs(error).max() < 3e-3)  # net motion ≈ 0.05 per cycle
    True
    """

    _format = FORMAT
    _format_version = FORMAT_VERSION
    _parameter_constraints = {
        "degree": Integer(minimum=0),
        "symmetry": Options(SYMMETRIES),
        "shape_scale": Real(low=1e-6, high=1e6),
        "forgetting_factor": Real(low=0, high=1, low_open=True),
        "initial_covariance": Real(low=0, high=1e12, low_open=True),
        "degree_shrinkage": Real(low=0, low_open=True),
        "gamma_forgetting": Real(low=0, high=1, low_open=True),
        "n_windows": Integer(minimum=1),
        "smoothing_order": Integer(minimum=0),
        "baseline_forgetting": Real(low=0, high=1, low_open=True),
        "resolution": Integer(minimum=4),
    }

    def __init__(self, *, degree: int = 2, symmetry: str | None = None, shape_scale: float = 1.0,
                 forgetting_factor: float = 0.999, initial_covariance: float = 100.0, degree_shrinkage: float = 1.0,
                 gamma_forgetting: float = 0.995, n_windows: int = 20, smoothing_order: int = 5,
                 baseline_forgetting: float = 0.99, resolution: int = 128):
        self.degree = degree
        self.symmetry = symmetry
        self.shape_scale = shape_scale
        self.forgetting_factor = forgetting_factor
        self.initial_covariance = initial_covariance
        self.degree_shrinkage = degree_shrinkage
        self.gamma_forgetting = gamma_forgetting
        self.n_windows = n_windows
        self.smoothing_order = smoothing_order
        self.baseline_forgetting = baseline_forgetting
        self.resolution = resolution

    # -- validation ---------------------------------------------------------------------------
    def _check_samples(self, phase, *arrays, names, owner):
        *out, self._single = check_samples(self, phase, *arrays, names=names, owner=owner)
        return out

    # -- fitting ------------------------------------------------------------------------------
    def memory_bytes(self, n_joints: int) -> float:
        """Bytes this model takes for ``n_joints`` joints at its peak: (m d)² floats for m monomials of degree ≤ D,
        times what the covariance, its symmetry basis and the updates' temporaries take together (measured at
        8 joints: 1.4 with symmetry, 3.4 without)."""
        weights = math.comb(n_joints + self.degree, self.degree) * n_joints
        return (1.5 if self.symmetry else 3.5) * 8.0 * weights**2

    def _check_size(self, batch: tuple, n_joints: int) -> None:
        """Refuse a covariance beyond MAX_BYTES (for every batch element), naming the most joints that fit."""
        copies = float(np.prod(batch))
        largest = n_joints
        while largest > 1 and copies * self.memory_bytes(largest) > MAX_BYTES:
            largest -= 1
        features = math.comb(n_joints + self.degree, self.degree) * n_joints
        check_bytes(copies * self.memory_bytes(n_joints), f"a shape-space model of degree {self.degree} in "
                    f"{n_joints} joints ({features} weights per output)", type(self).__name__,
                    f"at most {largest} joints at degree {self.degree}")

    def _check_param_combinations(self) -> None:
        check_smoothing_order(self.smoothing_order, self.n_windows, type(self).__name__)

    def _reset(self, batch: tuple, n_joints: int):
        self.validate()
        self._check_size(batch, n_joints)
        exponents = monomial_exponents(n_joints, self.degree)
        blocks = symmetry_blocks(exponents, self.symmetry)
        empty = [int(k) for outputs, basis in blocks if basis.shape[1] == 0 for k in outputs]
        if empty:  # (checked before anything changes: a failed fit leaves the model as it was)
            raise fail("degree", type(self).__name__, f"at least 1 with symmetry {self.symmetry!r} (at degree "
                       f"{self.degree} it leaves output {', '.join('xyθ'[k] for k in empty)} without any weight)",
                       self.degree)
        self.exponents_ = exponents
        self.n_joints_ = n_joints
        self.batch_shape_ = batch
        self.blocks_ = blocks
        self._gathers = [_gather(basis) for _, basis in self.blocks_]
        self.banks_ = [RLSBank(batch, 1, basis.shape[1], len(outputs), self.forgetting_factor, self._prior(basis))
                       for outputs, basis in self.blocks_]
        self.phase_model_ = PhaseModel(n_windows=self.n_windows, forgetting_factor=self.baseline_forgetting,
                                       smoothing_order=self.smoothing_order).start(batch)
        self.psi_ = np.zeros(batch + (2,))
        self.n_samples_seen_ = 0
        self._flat = None

    def _prior(self, basis: np.ndarray) -> np.ndarray:
        """Prior variance δ₀ b^{−q} of each column of a block's ``basis`` (every column combines monomials
        of one degree q: the mirror and reversal keep the degree)."""
        degree = np.repeat(self.exponents_.sum(axis=1), self.n_joints_)  # of feature l d + j
        magnitude = np.abs(basis)
        return self.initial_covariance * self.degree_shrinkage ** -(degree @ magnitude / magnitude.sum(axis=0))

    def _features(self, shape, shape_velocity) -> np.ndarray:
        """Regressors x = f(r/s) ⊗ ṙ, ``(..., m d)`` (row-major: entry l d + j is f_l ṙ_j)."""
        return polynomial_features(shape, shape_velocity, self.exponents_, self.shape_scale)

    @unfitted_unchanged_on_error
    def partial_fit(self, phase, shape, shape_velocity, body_velocity):
        """Learn time-ordered samples (optionally with leading trial axes), one RLS update each; returns ``self``.

        Parameters
        ----------
        phase : array-like of shape batch + (n,)
        shape, shape_velocity : array-like of shape batch + (n, d)
        body_velocity : array-like of shape batch + (n, 3)
        """
        phase, shape, shape_velocity, body_velocity = self._check_measured_samples(
            phase, shape, shape_velocity, body_velocity, f"{type(self).__name__}.partial_fit")
        if not hasattr(self, "batch_shape_"):
            self._reset(phase.shape[:-1], shape.shape[-1])
        x = self._features(shape, shape_velocity)  # batch + (n, m d)
        prior = np.empty(body_velocity.shape)
        for (outputs, _), gather, bank in zip(self.blocks_, self._gathers, self.banks_, strict=True):
            z = _project(x, gather)  # block regressors Bᵀx, batch + (n, n_b)
            y = body_velocity[..., outputs]
            # one filter takes every sample in time order: exact sequential RLS, computed in blocks
            try:
                prior[..., outputs] = bank.update_sequence(z[..., None, :, :], y[..., None, :, :])[..., 0, :, :]
            except np.linalg.LinAlgError:
                raise GeogaitError(self._too_large(shape, x)) from None
        check_finite_banks(self.banks_, f"{type(self).__name__}.partial_fit",
                           f"|shape / shape_scale| reaches {np.abs(shape).max() / self.shape_scale:.3g} at degree "
                           f"{self.degree}; give shape_scale about the shapes' range")
        baseline = self.phase_model_.partial_fit_predict(phase, body_velocity)
        self._update_gamma(prior, baseline, body_velocity)
        self.prior_prediction_ = prior
        self.n_samples_seen_ += phase.shape[-1]
        self._flat = None
        return self

    def _too_large(self, shape, features) -> str:
        reach = np.abs(shape).max() / self.shape_scale
        return (f"The samples of {type(self).__name__}.partial_fit are too large for the model: |shape / shape_scale| "
                f"reaches {reach:.3g} and its regressors (monomials of degree {self.degree} times the shape "
                f"velocities) {np.abs(features).max():.3g}, beyond the precision the filter needs. Give shape_scale "
                "about the shapes' range, and rates in a time unit of about a cycle (the model is no longer usable: "
                "fit a fresh one).")

    def forget(self, factor: float):
        """Discount all evidence so far by ``factor`` at once (:meth:`AdaptiveGaitModel.forget
        <geogait.models.AdaptiveGaitModel.forget>`): every block covariance's informed directions times
        ``factor``, none beyond the prior. Returns ``self``."""
        self._check_is_fitted()
        factor = check_float(factor, "factor", f"{type(self).__name__}.forget", low=1)
        for bank in self.banks_:
            bank.forget(factor)
        return self

    def rebase(self, gait: FourierGait | None = None, *, baseline: str = "reset", **options):
        """A new nominal gait: the connection model needs no re-centring (it has no nominal gait).

        Only the phase model ξ_T, whose phase average belonged to the old gait, starts afresh
        (``baseline="reset"``) or is kept (``"keep"``); other keyword options of the local models'
        rebase (``terms``, ``covariance_inflation`` ...) are accepted and ignored. Returns ``self``.
        """
        self._check_is_fitted()
        if baseline not in ("reset", "keep"):
            raise fail("baseline", f"{type(self).__name__}.rebase", "one of 'reset', 'keep'", baseline)
        if baseline == "reset":
            self.phase_model_.start(self.batch_shape_)
        return self

    def rotation_std(self, gait: FourierGait, residual_variance) -> np.ndarray:
        r"""Standard error of the predicted net rotation per cycle of ``gait``, given the ``residual_variance``
        σ²_ω of the measured ω (rad² per unit time², scalar or batch).

        The heading of the Magnus integration is exactly linear in the weights (the ω-component
        of an se(2) bracket vanishes): :math:`\hat\theta_{net} = g^T W_{\cdot\omega}` with
        :math:`g = \frac h2 \sum_{n,\pm} f(\theta/s) \otimes \theta'` over the Gauss nodes. With the
        RLS covariance P and the residual variance σ²_ω of ω the standard error is
        :math:`\sigma_\omega \sqrt{g^T P g}`; with a symmetry, :math:`W_{\cdot\omega} = B w` and the
        block's covariance P of w give :math:`\sigma_\omega \sqrt{(B^T g)^T P\, B^T g}`.
        """
        residual_variance = check_residual_variance(residual_variance, f"{type(self).__name__}.rotation_std")
        self._check_is_fitted()
        nodes, step = gauss_phases(self.resolution)
        g = self._features(gait.shape(nodes), gait.velocity(nodes)).sum(axis=(0, 1)) * step / 2
        block = next(b for b, (outputs, _) in enumerate(self.blocks_) if 2 in outputs)
        g = _project(g, self._gathers[block])
        spread = np.einsum("i,...ij,j->...", g, self.covariances_[block], g)
        return np.sqrt(residual_variance * spread)

    def _flat_weights(self) -> np.ndarray:
        """Full weights ``batch + (m d, 3)``: column k is :math:`B w_k` of its block (kept until the
        next update: the optimiser predicts many gaits between two cycles)."""
        if self._flat is None:
            self._flat = np.zeros(self.batch_shape_ + (len(self.exponents_) * self.n_joints_, 3))
            for (outputs, basis), bank in zip(self.blocks_, self.banks_, strict=True):
                self._flat[..., outputs] = basis @ bank.weights[..., 0, :, :]
        return self._flat

    @property
    def weights_(self) -> np.ndarray:
        self._check_is_fitted()
        return self._flat_weights().reshape(self.batch_shape_ + (len(self.exponents_), self.n_joints_, 3))

    @property
    def covariances_(self) -> list[np.ndarray]:
        self._check_is_fitted()
        return [bank.covariance[..., 0, :, :] for bank in self.banks_]

    # -- persistence --------------------------------------------------------------------------
    def _metadata(self) -> dict:
        return {"n_joints": self.n_joints_, "batch_shape": list(self.batch_shape_)}

    def _state(self) -> dict:
        arrays = {**self._gamma_state(), "n_samples_seen": self.n_samples_seen_, **self._baseline_state()}
        for b, bank in enumerate(self.banks_):
            arrays.update(bank.state(_block_prefix(b)))
        return arrays

    @classmethod
    def _check_stored(cls, metadata: dict, state: dict) -> None:
        """Windows of the baseline, batch shape, and the monomial count the degree claims against the arrays."""
        import math

        check_stored_sizes(metadata, state)
        degree, d = metadata["params"].get("degree", 2), metadata.get("n_joints")
        if isinstance(degree, bool) or not isinstance(degree, int) or degree < 0 or not isinstance(d, int):
            raise ValueError(f"the metadata's degree and n_joints must be integers, got {degree!r:.20}, {d!r:.20}")
        stored = sum(np.shape(v)[-2] for k, v in state.items() if k.endswith("weights") and
                     not k.startswith("phase_model/") and np.ndim(v) >= 2)
        if degree > 1000 or math.comb(d + degree, d) * d > 2 * stored + 8:
            raise ValueError(f"degree {degree} in {d} joints claims more monomials than the {stored} stored "
                             "feature rows")

    def _set_state(self, state: dict, metadata: dict) -> None:
        self._reset(tuple(metadata["batch_shape"]), int(metadata["n_joints"]))
        for b, bank in enumerate(self.banks_):
            bank.assign(state, _block_prefix(b))
        self._flat = None
        self._set_gamma_state(state)
        self._set_baseline_state(state)
        self.n_samples_seen_ = int(state["n_samples_seen"])

    # -- prediction ---------------------------------------------------------------------------
    def connection(self, shape) -> np.ndarray:
        """The learned local connection A(r) at ``shape`` ``(..., d)`` (rad) → batch + (..., 3, d), ξ = −A ṙ."""
        self._check_is_fitted()
        shape = check_array(shape, "shape", f"{type(self).__name__}.connection", trailing=(self.n_joints_,))
        f = monomials(shape / self.shape_scale, self.exponents_)
        batch = "".join("abcdefg"[:len(self.batch_shape_)])
        return -np.einsum(f"...l,{batch}ljk->{batch}...kj", f, self.weights_)

    def predict(self, phase, shape, shape_velocity) -> np.ndarray:
        """Predicted body velocity ξ̂ = Wᵀ(f(r/s) ⊗ ṙ) of samples ``shape``, ``shape_velocity`` batch + (n, d)
        (rad, rad per unit time) → batch + (n, 3); ``phase`` is accepted for the common interface and only
        checked."""
        self._check_is_fitted()
        _, shape, shape_velocity = self._check_samples(phase, shape, shape_velocity, names=("shape", "shape_velocity"),
                                                       owner=f"{type(self).__name__}.predict")
        prediction = np.einsum("...ni,...ij->...nj", self._features(shape, shape_velocity), self._flat_weights())
        return prediction[..., 0, :] if self._single else prediction

    def predict_displacement(self, gait: FourierGait, *, jacobian: bool = False, compiled: bool = False):
        r"""Net ``(x, y, heading)`` per cycle of ``gait`` under the learned connection.

        Integrates :math:`\hat\xi(\phi) = \sum_{l,j} W_{lj\cdot} f_l(\theta(\phi)/s)\,\theta_j'(\phi)` over one
        cycle with the fourth-order Magnus method. With ``jacobian``, also the exact derivative
        with respect to ``gait.params``: with basis :math:`b_c(\phi)` of joint i's coefficients,

        .. math:: \frac{\partial\hat\xi_k}{\partial c_{ic}} = U_{ki}\, b_c + V_{ki}\, b_c',\quad
           U_{ki} = \sum_{l,j} W_{ljk}\, \frac{\partial f_l}{\partial r_i}\frac{\theta_j'}{s},\quad
           V_{ki} = \sum_l W_{lik} f_l.

        Parameters
        ----------
        gait : FourierGait
        jacobian : bool, default False
        compiled : bool, default False
            Run an unbatched model through the compiled kernel where numba is installed (the same
            arithmetic, agreeing to rounding, not bit for bit: the path-following solves use it; the
            optimiser keeps the NumPy path, so its results do not move).

        Returns
        -------
        pose : ndarray of shape batch + (3,)
        jacobian : ndarray of shape batch + (3, p), only when ``jacobian``.
        """
        self._check_is_fitted()
        if not isinstance(gait, FourierGait) or gait.n_joints != self.n_joints_:
            raise fail("gait", f"{type(self).__name__}.predict_displacement",
                       f"a FourierGait with {self.n_joints_} joints", gait)
        kernel = _kernels.shape_space_kernel() if compiled and not self.batch_shape_ else None
        if kernel is not None:
            return self._compiled_displacement(kernel, gait, jacobian)
        return integrate_cycle(*self._cycle_velocity(gait, jacobian))

    def _cycle_velocity(self, gait: FourierGait, jacobian: bool):
        """Predicted ξ at the Magnus nodes of one cycle of ``gait`` and the step (and ∂ξ/∂params):
        :func:`~geogait.se2.integrate_cycle`'s arguments."""
        return polynomial_cycle_velocity(self.weights_, self.exponents_, self.shape_scale, gait, self.resolution,
                                         jacobian)


    def _compiled_displacement(self, kernel, gait: FourierGait, jacobian: bool):
        """:meth:`predict_displacement` of an unbatched model by the compiled kernel
        (:func:`geogait._kernels._shape_space_displacement`)."""
        exponents = np.ascontiguousarray(self.exponents_, dtype=np.int64)
        m, d = exponents.shape
        lower, variable, degree, order = _kernel_lowering(exponents.tobytes(), m, d)
        basis, d_basis = phase_basis(self.resolution, gait.order, 0), phase_basis(self.resolution, gait.order, 1)
        coefficients = gait.coefficients.T
        pose, pose_jacobian = np.empty(3), np.empty((3, gait.params.size))
        kernel(basis @ coefficients, d_basis @ coefficients, self.weights_, lower, variable, degree, order,
               exponents, float(self.shape_scale), basis, d_basis, 2 * np.pi / self.resolution, SERIES_THRESHOLD,
               jacobian, pose, pose_jacobian)
        return (pose, pose_jacobian) if jacobian else pose


def polynomial_features(shape, shape_velocity, exponents: np.ndarray, shape_scale: float) -> np.ndarray:
    """Regressors x = f(r/s) ⊗ ṙ ``(..., m d)`` of the polynomial connection (entry l d + j is f_l ṙ_j)."""
    f = monomials(shape / shape_scale, exponents)
    return (f[..., :, None] * shape_velocity[..., None, :]).reshape(f.shape[:-1] + (-1,))


def polynomial_cycle_velocity(weights: np.ndarray, exponents: np.ndarray, shape_scale: float, gait: FourierGait,
                              resolution: int, jacobian: bool = False):
    r"""ξ̂ = Wᵀ(f(θ/s) ⊗ θ') of a polynomial connection with weights ``batch + (m, d, 3)`` at the Magnus nodes of one
    cycle of ``gait``, and the step (and the exact ∂ξ̂/∂params): :func:`~geogait.se2.integrate_cycle`'s arguments.

    With basis :math:`b_c(\phi)` of joint i's coefficients,
    :math:`\partial\hat\xi_k/\partial c_{ic} = U_{ki} b_c + V_{ki} b_c'`,
    :math:`U_{ki} = \sum_{l,j} W_{ljk}\,\partial f_l/\partial r_i\,\theta_j'/s`, :math:`V_{ki} = \sum_l W_{lik} f_l`.
    """
    nodes, step = gauss_phases(resolution)
    shape, rate = gait.shape(nodes), gait.velocity(nodes)  # (n, 2, d)
    if not jacobian:
        f = monomials(shape / shape_scale, exponents)
        return np.einsum("npl,npj,...ljk->...npk", f, rate, weights, optimize=True), step
    f, df = monomials(shape / shape_scale, exponents, derivative=True)  # (n,2,m), (n,2,m,d)
    along = np.einsum("npj,...ljk->...nplk", rate, weights, optimize=True)  # Σ_j W_ljk θ_j': contract once, reuse
    velocity = np.einsum("npl,...nplk->...npk", f, along, optimize=True)
    u = np.einsum("npli,...nplk->...npki", df, along, optimize=True) / shape_scale  # batch+(n,2,3,d)
    v = np.einsum("npl,...lik->...npki", f, weights, optimize=True)
    basis, d_basis = gait.basis(nodes), gait.basis(nodes, 1)  # (n, 2, c)
    velocity_jacobian = u[..., None] * basis[:, :, None, None, :] + v[..., None] * d_basis[:, :, None, None, :]
    return velocity, step, velocity_jacobian.reshape(velocity_jacobian.shape[:-2] + (-1,))


@functools.lru_cache(maxsize=32)
def _kernel_lowering(key: bytes, m: int, d: int) -> tuple:
    """:func:`_lowering` as int64 arrays, with the monomials in order of degree (what the kernel walks)."""
    lower, variable, degree = (np.ascontiguousarray(a, dtype=np.int64) for a in _lowering(key, m, d))
    return lower, variable, degree, np.argsort(degree, kind="stable")


def _gather(basis: np.ndarray) -> tuple | None:
    """Rows and values of the (one or two) nonzero entries of each column of a :func:`symmetry_blocks` basis
    (a monomial, or a reversal pair); None for the identity (no symmetry)."""
    if basis.shape[0] == basis.shape[1]:
        return None
    used = basis != 0
    columns = np.arange(basis.shape[1])
    first = np.argmax(used, axis=0)
    last = basis.shape[0] - 1 - np.argmax(used[::-1], axis=0)
    return first, basis[first, columns], last, np.where(last != first, basis[last, columns], 0.0)


def _project(x: np.ndarray, gather: tuple | None) -> np.ndarray:
    """``x @ basis`` by a gather (:func:`_gather`) instead of a dense product: 10× less work at 9 links."""
    if gather is None:
        return x
    first, first_value, last, last_value = gather
    return x[..., first] * first_value + x[..., last] * last_value


def _block_prefix(block: int) -> str:
    """Saved-array prefix of block ``block`` (none for the first, so files without symmetry keep their names)."""
    return f"block{block}/" if block else ""
