r"""Learn the resistance, not the connection: a structured gait model for chains in resistive media.

For a planar chain of straight links in a resistive medium (low-Reynolds-number swimmers, resistive
force theory for snakes on sand or in granular media) the connection is
:math:`A(r) = \omega_\xi^{-1}(r)\,\omega_r(r)`, both matrices sums of the links' drag
:math:`D_i = \mathrm{diag}(c_{\parallel,i} l_i,\ c_{\perp,i} l_i,\ c_{\perp,i} l_i^3/12)` transported by the
chain's geometry (:class:`~geogait.systems.PurcellSwimmer`). With the geometry known (link lengths, body
frame) the only unknowns are the drag coefficients, and only their ratios matter (A is unchanged
when every drag is scaled alike). :class:`ResistanceModel` learns them:

* **parameters** :math:`u`: the log lateral/longitudinal ratio shared by all links, and per-link log
  deviations of each link's longitudinal and lateral drag, with a Gaussian prior
  :math:`u \sim N(0, P_0)` — the ratio around ``drag_ratio`` (spread ``ratio_spread``), the per-link
  deviations around zero (spread ``link_variation``; 0 fits the shared ratio alone). The prior pulls
  the links towards shared coefficients and fixes the unobservable overall scale.
* **output error**: the predicted body velocity :math:`\hat\xi(u) = -A(r; u)\dot r` is fitted to the
  measured one over the last ``memory`` samples by Gauss–Newton (MAP, each output weighted by its
  residual variance), warm-started from the previous fit, with the analytic derivative
  :meth:`PurcellSwimmer.drag_sensitivity <geogait.systems.PurcellSwimmer.drag_sensitivity>`. Fitting the
  force balance instead (linear least squares) would be biased by the noise in ξ, which enters that
  regression as an error in the regressors.
* **uncertainty**: the parameters' covariance :math:`(J^T W J + P_0^{-1})^{-1}`, and from it the standard
  error of the predicted net rotation per cycle (:meth:`ResistanceModel.rotation_std`).
* **hybrid** (``residual_degree``): a polynomial connection (:class:`~geogait.models.ShapeSpaceModel`'s basis,
  with its symmetries and graded prior) is added to the resistive one and fitted *jointly* with the drag
  parameters, in the same Gauss–Newton problem: where the medium is not resistive (quadratic drag, dry
  friction, inertia) the data still shape the prediction, and its prior — a residual of about
  ``residual_prior`` times the data's connection, less per degree — keeps it near zero where the
  structure explains the data, so the drags explain first. How much the residual ends up carrying
  (``residual_share_``) tells whether the structure holds: where it does, the residual fits noise only.
  Above 0.15 on the seed gait the in-situ optimiser leans on the data
  (:class:`~geogait.optimize.InSituOptimizer`).

Because A follows from a handful of coefficients everywhere in shape space, the model knows the
objective's gradient far from the gaits it has seen — which a local polynomial fitted to a few
cycles does not.
"""

from __future__ import annotations

import numpy as np

from .._docs import fill_doc
from .._estimator import Estimator, Integer, Options, Real
from .._validation import MAX_BYTES, MAX_MAGNITUDE, chain_motion_bytes, check_array, check_bytes, check_float, fail
from ..gaits import FourierGait
from ..se2 import gauss_phases, integrate_cycle
from ..simulate import cycle_velocity
from ..systems import BODY_FRAMES, FunctionSystem, PurcellSwimmer
from ._base import (
    FORMAT,
    FORMAT_VERSION,
    SampleModel,
    check_residual_variance,
    check_samples,
    check_smoothing_order,
    unfitted_unchanged_on_error,
)
from ._online_gamma import OnlineGamma
from ._phase import PhaseModel
from ._shape_space import (
    SYMMETRIES,
    monomial_exponents,
    monomials,
    polynomial_cycle_velocity,
    polynomial_features,
    symmetry_blocks,
)

__all__ = ["ResistanceModel"]

#: Largest |log| of a drag multiplier a Gauss–Newton step may reach (drags within e^±12 of each other).
_LOG_DRAG_BOUND = 12.0


class _BodyFrame:
    """Constraint: one of PurcellSwimmer's body frames, or a link index."""

    def __call__(self, value, name: str, owner: str) -> None:
        if isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= 0:
            return
        if value not in BODY_FRAMES:
            raise fail(name, owner, f"one of {', '.join(map(repr, BODY_FRAMES))} or a link index >= 0", value)


class _FrameOffset:
    """Constraint: None or a finite (x, y, angle) of real numbers within ±1e12 (no boolean or complex cast)."""

    def __call__(self, value, name: str, owner: str) -> None:
        if value is not None and check_array(value, name, owner, limit=MAX_MAGNITUDE).shape != (3,):
            raise fail(name, owner, "None or a finite (x, y, angle)", value)


class _ShapeMap:
    """Constraint: None or a finite 2-D array (the chain's joints × the robot's shape coordinates), real numbers
    within ±1e12."""

    def __call__(self, value, name: str, owner: str) -> None:
        if value is None:
            return
        matrix = check_array(value, name, owner, limit=MAX_MAGNITUDE)
        if matrix.ndim != 2 or 0 in matrix.shape:
            raise fail(name, owner, "None or a finite 2-D array (the chain's joints × the robot's shape coordinates)",
                       value)


class _LinkLengths:
    """Constraint: None or at least two positive, finite link lengths (real numbers within ±1e12)."""

    def __call__(self, value, name: str, owner: str) -> None:
        if value is None:
            return
        lengths = check_array(value, name, owner, limit=MAX_MAGNITUDE)
        if lengths.ndim != 1 or lengths.size < 2 or np.any(lengths <= 0):
            raise fail(name, owner, "a sequence of at least 2 positive link lengths", value)


@fill_doc
class ResistanceModel(OnlineGamma, SampleModel, Estimator):
    r"""The connection of a chain in a resistive medium, learned as its drag coefficients (module docstring).

    Parameters
    ----------
    link_lengths : sequence of float
        The chain's link lengths, tail first (N links, N − 1 joints): the geometry the model takes as
        known (:class:`~geogait.systems.PurcellSwimmer`'s, a MuJoCo chain's). Required.
    body_frame : {"middle", "center_of_mass", "tail"} or int
        Where the robot's body velocity is measured (as :class:`~geogait.systems.PurcellSwimmer`: a named
        frame or a link index).
    frame_offset : (x, y, angle), optional
        The robot's frame relative to ``body_frame`` (:class:`~geogait.systems.PurcellSwimmer`). A MuJoCo
        chain gives all three: ``ResistanceModel(**robot.chain_geometry())``
        (:meth:`MujocoRobot.chain_geometry <geogait.robots.MujocoRobot.chain_geometry>`).
    shape_map : array-like of shape (N − 1, d), optional
        The chain's joint angles as a linear function of the robot's d shape coordinates,
        :math:`r_{chain} = M r`, so that :math:`A(r) = A_{chain}(M r)\, M`: a continuum body's modal
        coordinates on its discretisation (:meth:`ElasticaSnake.chain_geometry
        <geogait.robots.ElasticaSnake.chain_geometry>`: its elements as links, each interior node's
        turning angle the modal curvature there times the element length). None (default): the robot's
        shape is the chain's joint angles.
    drag_ratio : float in [1e-3, 1e3]
        Prior mean of the lateral over longitudinal drag ratio k (2 for slender bodies at low Reynolds
        number; larger on granular media).
    ratio_spread : float in (0, 10]
        Prior standard deviation of log k.
    link_variation : float in [0, 10]
        Prior standard deviation of each link's log longitudinal and log lateral drag about the shared
        values; 0 learns the shared ratio alone (one parameter).
    memory : int >= 16
        Most recent samples the output error is fitted to.
    iterations : int >= 1
        Most Gauss–Newton iterations per :meth:`partial_fit` (warm-started; fewer once the cost stops falling).
    residual_degree : int, optional
        The hybrid: a polynomial connection of this total degree in r/s added to the resistive one and
        fitted with it (None: the resistive structure alone).
    residual_symmetry : {None, "mirror", "mirror+reversal"}
        Symmetry of the residual's basis (:func:`~geogait.models.symmetry_blocks`).
    residual_prior : float in (0, 1e3]
        Prior standard deviation of the residual's degree-0 weights, relative to the data's connection
        scale :math:`\sqrt{\overline{|\xi|^2} / \overline{|\dot r|^2}}` (measured on the first samples).
    residual_shrinkage : float > 0
        Each higher degree q of the residual has prior variance b^−q times the degree-0 one.
    shape_scale : float in [1e-6, 1e6]
        The residual's unit of shape.
    %(online_gamma_params)s

    Attributes
    ----------
    log_drag_ : ndarray of shape (N, 2)
        Fitted log longitudinal and log lateral drag per unit length of each link, relative to a
        longitudinal drag of 1 (only differences are observable; the prior fixes the mean).
    parameters_ : ndarray of shape (n_parameters,)
        u: the log ratio's deviation from log ``drag_ratio``, then the per-link deviations; for the hybrid
        then the residual's weights, output by output in its symmetry basis.
    parameter_covariance_ : ndarray of shape (n_parameters, n_parameters)
        Posterior covariance of u.
    noise_std_ : ndarray of shape (3,)
        RMS output error of each body-velocity component over the memory after the last fit.
    system_ : PurcellSwimmer
        The fitted chain (its ``connection`` is the model's resistive A(r); with a ``shape_map`` M, A(r) is
        ``system_.connection(M r) @ M``).
    residual_weights_ : ndarray of shape (m, d, 3) or None
        The hybrid's residual connection: :math:`\hat\xi_{res} = W^T (f(r/s) \otimes \dot r)` (None without).
    residual_scale_ : float
        The data's connection scale the residual prior is relative to.
    residual_share_ : float
        How much of the hybrid's prediction its structure leaves to the data: over the samples in memory,
        the largest ratio, among the body velocity's three components, of the residual's RMS to the
        resistive part's (NaN without a residual). Near zero where the medium is resistive; a
        sizeable share means the physics does not hold (the in-situ optimiser then leans on the data).
    phase_model_ : PhaseModel
    gamma_ : float
        Online Γ after the last sample (eq. 6).
    prior_prediction_ : ndarray of shape (n, 3)
        A-priori predictions of the samples of the last ``partial_fit`` call.
    n_joints_ : int
    batch_shape_ : tuple
        Always ``()``: one robot per model.
    n_samples_seen_ : int

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import simulate
    >>> swimmer, gait = PurcellSwimmer(5, drag_ratio=3.0), seed_gait(4)
    >>> run = simulate(swimmer, gait, n_cycles=4, seed=0)
    >>> model = ResistanceModel(link_lengths=swimmer.link_lengths)
    >>> model = model.fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    >>> ratio = np.exp(model.log_drag_[:, 1] - model.log_drag_[:, 0])
    >>> bool(np.all(np.abs(ratio - 3.0) < 0.3))
    True
    """

    _format = FORMAT
    _format_version = FORMAT_VERSION
    _parameter_constraints = {
        "link_lengths": _LinkLengths(),
        "body_frame": _BodyFrame(),
        "frame_offset": _FrameOffset(),
        "shape_map": _ShapeMap(),
        "drag_ratio": Real(low=1e-3, high=1e3),
        "ratio_spread": Real(low=0, high=10, low_open=True),
        "link_variation": Real(low=0, high=10),
        "memory": Integer(minimum=16),
        "iterations": Integer(minimum=1),
        "residual_degree": Integer(minimum=0, none=True),
        "residual_symmetry": Options(SYMMETRIES),
        "residual_prior": Real(low=0, high=1e3, low_open=True),
        "residual_shrinkage": Real(low=0, low_open=True),
        "shape_scale": Real(low=1e-6, high=1e6),
        "gamma_forgetting": Real(low=0, high=1, low_open=True),
        "n_windows": Integer(minimum=1),
        "smoothing_order": Integer(minimum=0),
        "baseline_forgetting": Real(low=0, high=1, low_open=True),
        "resolution": Integer(minimum=4),
    }

    def __init__(self, *, link_lengths=None, body_frame: str | int = "middle", frame_offset=None, shape_map=None,
                 drag_ratio: float = 2.0,
                 ratio_spread: float = 1.0, link_variation: float = 0.3, memory: int = 4096, iterations: int = 3,
                 residual_degree: int | None = None, residual_symmetry: str | None = None,
                 residual_prior: float = 0.1, residual_shrinkage: float = 30.0, shape_scale: float = 1.0,
                 gamma_forgetting: float = 0.995,
                 n_windows: int = 20, smoothing_order: int = 5, baseline_forgetting: float = 0.99,
                 resolution: int = 128):
        self.link_lengths = link_lengths
        self.body_frame = body_frame
        self.frame_offset = frame_offset
        self.shape_map = shape_map
        self.drag_ratio = drag_ratio
        self.ratio_spread = ratio_spread
        self.link_variation = link_variation
        self.memory = memory
        self.iterations = iterations
        self.residual_degree = residual_degree
        self.residual_symmetry = residual_symmetry
        self.residual_prior = residual_prior
        self.residual_shrinkage = residual_shrinkage
        self.shape_scale = shape_scale
        self.gamma_forgetting = gamma_forgetting
        self.n_windows = n_windows
        self.smoothing_order = smoothing_order
        self.baseline_forgetting = baseline_forgetting
        self.resolution = resolution

    @classmethod
    def from_swimmer(cls, swimmer: PurcellSwimmer, **params) -> ResistanceModel:
        """A model of ``swimmer``'s geometry (link lengths and body frame; its drags are not told)."""
        if not isinstance(swimmer, PurcellSwimmer):
            raise fail("swimmer", "ResistanceModel.from_swimmer", "a PurcellSwimmer", swimmer)
        return cls(link_lengths=swimmer.link_lengths, body_frame=swimmer.body_frame,
                   frame_offset=swimmer.frame_offset, **params)

    # -- validation ---------------------------------------------------------------------------
    def _check_param_combinations(self) -> None:
        check_smoothing_order(self.smoothing_order, self.n_windows, type(self).__name__)
        if self.link_lengths is None:
            raise fail("link_lengths", type(self).__name__, "the chain's link lengths (the model's known geometry; "
                       "e.g. ResistanceModel.from_swimmer(swimmer))", None)
        if isinstance(self.body_frame, int | np.integer) and self.body_frame >= len(self.link_lengths):
            raise fail("body_frame", type(self).__name__, f"a link index below {len(self.link_lengths)} (the links "
                       "given)", self.body_frame)
        if self.shape_map is not None and np.shape(self.shape_map)[0] != len(self.link_lengths) - 1:
            raise fail("shape_map", type(self).__name__, f"{len(self.link_lengths) - 1} rows (one per joint of the "
                       f"{len(self.link_lengths)} links given)", f"shape {np.shape(self.shape_map)}")

    def _check_samples(self, phase, *arrays, names, owner):
        *out, self._single = check_samples(self, phase, *arrays, names=names, owner=owner)
        if out[0].ndim != 1:
            raise fail("phase", owner, "samples of one robot, shape (n,) (the resistance model has no trial axes)",
                       f"shape {out[0].shape}")
        return out

    # -- the parametrisation --------------------------------------------------------------------
    @property
    def _n_links(self) -> int:
        return len(self.link_lengths)

    @property
    def _robot_joints(self) -> int:
        """d: the robot's shape coordinates (the chain's joints without a shape map)."""
        return self._n_links - 1 if self.shape_map is None else np.shape(self.shape_map)[1]

    def _on_chain(self, *arrays):
        """Robot shape coordinates (and rates) ``(..., d)`` → the chain's joint angles ``(..., N − 1)``."""
        if self.shape_map is None:
            return arrays
        transpose = np.asarray(self.shape_map, dtype=float).T
        return tuple(a @ transpose for a in arrays)

    def _design(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """θ = θ₀ + G u (θ: log drag multipliers, link-major (N, 2) flattened) and the prior variance of u."""
        n = self._n_links
        theta0 = np.tile([0.0, np.log(self.drag_ratio)], n)
        shared = np.tile([0.0, 1.0], n)[:, None]  # the common log ratio moves every lateral drag
        if self.link_variation == 0:
            return theta0, shared, np.array([self.ratio_spread**2])
        design = np.hstack([shared, np.eye(2 * n)])
        return theta0, design, np.concatenate([[self.ratio_spread**2], np.full(2 * n, self.link_variation**2)])

    def _chain(self, parameters: np.ndarray) -> PurcellSwimmer:
        theta0, design, _ = self._design()
        log_drag = (theta0 + design @ parameters[:design.shape[1]]).reshape(-1, 2)
        return PurcellSwimmer(self._n_links, link_lengths=self.link_lengths, body_frame=self.body_frame,
                              frame_offset=self.frame_offset, drag_ratio=1.0,
                              link_drag_scale=np.exp(log_drag - log_drag[:, 0].mean()))

    def _residual_structure(self, n_joints: int) -> tuple[np.ndarray, list]:
        """Monomial exponents and, per output k, the basis ``(m d, n_k)`` of its residual weights."""
        exponents = monomial_exponents(n_joints, self.residual_degree)
        per_output = [None] * 3
        for outputs, basis in symmetry_blocks(exponents, self.residual_symmetry):
            for k in outputs:
                per_output[k] = basis
        return exponents, per_output

    def _residual_prior(self, scale: float) -> np.ndarray:
        """Prior variance of every residual weight: (prior · scale)² b^{−q} by the degree q of its column."""
        degree = np.repeat(self._exponents.sum(axis=1), self.n_joints_)
        variances = []
        for basis in self._bases:
            magnitude = np.abs(basis)
            q = degree @ magnitude / magnitude.sum(axis=0)
            variances.append((self.residual_prior * scale) ** 2 * self.residual_shrinkage ** -q)
        return np.concatenate(variances)

    def _residual_jacobian(self, shape, shape_velocity) -> np.ndarray:
        """∂ξ̂_res/∂(residual weights) ``(n, 3, n_v)``: output k's regressors in its own slot (ξ̂_res is linear)."""
        features = polynomial_features(shape, shape_velocity, self._exponents, self.shape_scale)
        sizes = [b.shape[1] for b in self._bases]
        jacobian = np.zeros(features.shape[:-1] + (3, sum(sizes)))
        start = 0
        for k, basis in enumerate(self._bases):
            jacobian[..., k, start:start + sizes[k]] = features @ basis
            start += sizes[k]
        return jacobian

    # -- fitting ------------------------------------------------------------------------------
    def memory_bytes(self, n_joints: int) -> float:
        """Bytes this model's predicted cycle takes at its peak with its derivative (the chain's connection perturbed
        in each joint at every Magnus node).

        Parameters
        ----------
        n_joints : int
            The robot's joints (this model's chain fixes its own).
        """
        return chain_motion_bytes(self._n_links - 1, self.resolution)

    def _reset(self, n_joints: int):
        self.validate()
        if n_joints != self._robot_joints:
            given = f"link_lengths gives {self._n_links} links" if self.shape_map is None else \
                f"shape_map has {self._robot_joints} columns"
            raise fail("shape", f"{type(self).__name__}.partial_fit", f"{self._robot_joints} joints ({given})",
                       f"{n_joints} joints")
        chain = self._n_links - 1
        largest = chain
        while largest > 1 and chain_motion_bytes(largest, self.resolution) > MAX_BYTES:
            largest -= 1
        check_bytes(self.memory_bytes(n_joints), f"a resistance model of a {self._n_links}-link chain at resolution "
                    f"{self.resolution}", type(self).__name__, f"at most {largest + 1} links at that resolution")
        _, design, prior = self._design()
        self.n_joints_ = n_joints
        self.batch_shape_ = ()
        self.residual_scale_ = 1.0
        self._exponents, self._bases = (None, []) if self.residual_degree is None else \
            self._residual_structure(n_joints)
        if self.residual_degree is not None:
            empty = [k for k, basis in enumerate(self._bases) if basis.shape[1] == 0]
            if empty:
                raise fail("residual_degree", type(self).__name__, f"at least 1 with symmetry "
                           f"{self.residual_symmetry!r} (it leaves output {', '.join('xyθ'[k] for k in empty)} "
                           "without any weight)", self.residual_degree)
            prior = np.concatenate([prior, self._residual_prior(1.0)])
        self.parameters_ = np.zeros(prior.size)
        self.parameter_covariance_ = np.diag(prior)
        self.noise_std_ = np.full(3, np.nan)
        self._memory = np.zeros((0, 2 * n_joints + 3))
        self.phase_model_ = PhaseModel(n_windows=self.n_windows, forgetting_factor=self.baseline_forgetting,
                                       smoothing_order=self.smoothing_order).start(())
        self.psi_ = np.zeros(2)
        self.n_samples_seen_ = 0
        self._system = None

    @unfitted_unchanged_on_error
    def partial_fit(self, phase, shape, shape_velocity, body_velocity):
        """Predict the new samples (for Γ), add them to the memory and refit the drag coefficients.

        Parameters
        ----------
        %(samples)s

        Returns
        -------
        self
        """
        phase, shape, shape_velocity, body_velocity = self._check_measured_samples(
            phase, shape, shape_velocity, body_velocity, f"{type(self).__name__}.partial_fit")
        if not hasattr(self, "batch_shape_"):
            self._reset(shape.shape[-1])
            if self.residual_degree is not None:  # the residual prior relative to this robot's connection scale
                rate = np.mean(np.sum(shape_velocity**2, axis=-1))
                self.residual_scale_ = float(np.sqrt(np.mean(np.sum(body_velocity**2, axis=-1)) / rate)) \
                    if rate > 0 else 1.0
        elif shape.shape[-1] != self.n_joints_:
            raise fail("shape", f"{type(self).__name__}.partial_fit", f"{self.n_joints_} joints",
                       f"{shape.shape[-1]} joints")
        prior = self._predict(shape, shape_velocity)
        samples = np.concatenate([shape, shape_velocity, body_velocity], axis=-1)
        self._memory = np.concatenate([self._memory, samples])[-self.memory:]
        self._fit()
        baseline = self.phase_model_.partial_fit_predict(phase, body_velocity)
        self._update_gamma(prior, baseline, body_velocity)
        self.prior_prediction_ = prior
        self.n_samples_seen_ += phase.shape[-1]
        return self

    def _prior_variance(self) -> np.ndarray:
        prior = self._design()[2]
        return prior if self.residual_degree is None else \
            np.concatenate([prior, self._residual_prior(self.residual_scale_)])

    def _model(self, parameters, chain_shape, chain_velocity, residual_jacobian):
        """Predicted ξ ``(n, 3)`` and its Jacobian ``(n, 3, n_parameters)`` at ``parameters``, from the samples'
        shapes and rates on the chain (:meth:`_on_chain`)."""
        _, design, _ = self._design()
        velocity, sensitivity = self._chain(parameters).drag_sensitivity(chain_shape, chain_velocity)
        jacobian = sensitivity.reshape(sensitivity.shape[:-2] + (-1,)) @ design
        if residual_jacobian is None:
            return velocity, jacobian
        residual = np.einsum("nkv,v->nk", residual_jacobian, parameters[design.shape[1]:])
        return velocity + residual, np.concatenate([jacobian, residual_jacobian], axis=-1)

    def _fit(self):
        """Gauss–Newton (MAP) on the output error over the memory, from the current parameters (drags and,
        for the hybrid, the residual's weights together)."""
        d = self.n_joints_
        shape, shape_velocity, measured = np.split(self._memory, [d, 2 * d], axis=-1)
        _, design, _ = self._design()
        precision = 1.0 / self._prior_variance()
        residual_jacobian = None if self.residual_degree is None else self._residual_jacobian(shape, shape_velocity)
        shape, shape_velocity = self._on_chain(shape, shape_velocity)  # (once: every iteration reuses them)
        parameters = self.parameters_
        scale = np.sqrt(np.mean(measured**2, axis=0)) + 1e-300

        def weights(residual):  # each output by its residual variance (iteratively reweighted)
            return 1.0 / np.maximum(np.sqrt(np.mean(residual**2, axis=0)), 1e-6 * scale) ** 2

        def cost(predicted, u):
            return float(np.sum((measured - predicted) ** 2 * weight) + u @ (precision * u))

        predicted, jacobian = self._model(parameters, shape, shape_velocity, residual_jacobian)
        for _ in range(self.iterations):
            weight = weights(measured - predicted)
            current = cost(predicted, parameters)
            weighted = jacobian * weight[:, None]
            information = np.einsum("nki,nkj->ij", weighted, jacobian) + np.diag(precision)
            gradient = np.einsum("nki,nk->i", weighted, measured - predicted) - precision * parameters
            step = np.linalg.solve(information, gradient)
            for _ in range(8):  # backtrack until the MAP cost falls (the model is nonlinear in the drags)
                trial = parameters + step
                if np.abs(design @ trial[:design.shape[1]]).max() <= _LOG_DRAG_BOUND:
                    trial_predicted, trial_jacobian = self._model(trial, shape, shape_velocity, residual_jacobian)
                    trial_cost = cost(trial_predicted, trial)
                    if trial_cost <= current:
                        break
                step = step / 2
            else:
                break
            converged = current - trial_cost <= 1e-12 * current
            parameters, predicted, jacobian, current = trial, trial_predicted, trial_jacobian, trial_cost
            if converged:
                break
        residual = measured - predicted
        self.noise_std_ = np.sqrt(np.mean(residual**2, axis=0))
        weighted = jacobian * weights(residual)[:, None]
        self.parameters_ = parameters
        self.parameter_covariance_ = np.linalg.inv(np.einsum("nki,nkj->ij", weighted, jacobian) + np.diag(precision))
        self._system = None

    def forget(self, factor: float):
        """Discount the evidence so far by ``factor`` at once: keep the newest 1 / ``factor`` of the memory
        (a fresh change of medium is then learned from fewer, newer samples). Returns ``self``."""
        self._check_is_fitted()
        factor = check_float(factor, "factor", f"{type(self).__name__}.forget", low=1)
        keep = int(np.ceil(len(self._memory) / factor))
        self._memory = self._memory[len(self._memory) - keep:]
        return self

    def rebase(self, gait: FourierGait | None = None, *, baseline: str = "reset", **options):
        """A new nominal gait: the drag coefficients hold everywhere in shape space and need no re-centring.

        The phase model ξ_T starts afresh (``baseline="reset"``) or is kept (``"keep"``); other options of
        the local models' rebase are accepted and ignored. Returns ``self``.
        """
        self._check_is_fitted()
        if baseline not in ("reset", "keep"):
            raise fail("baseline", f"{type(self).__name__}.rebase", "one of 'reset', 'keep'", baseline)
        if baseline == "reset":
            self.phase_model_.start(())
        return self

    # -- prediction ---------------------------------------------------------------------------
    @property
    def system_(self) -> PurcellSwimmer:
        self._check_is_fitted()
        if self._system is None:
            self._system = self._chain(self.parameters_)
        return self._system

    @property
    def log_drag_(self) -> np.ndarray:
        self._check_is_fitted()
        return np.log(np.asarray(self.system_.link_drag_scale))

    @property
    def residual_weights_(self) -> np.ndarray | None:
        self._check_is_fitted()
        if self.residual_degree is None:
            return None
        weights = np.zeros((len(self._exponents) * self.n_joints_, 3))
        start = self._design()[1].shape[1]
        for k, basis in enumerate(self._bases):
            weights[:, k] = basis @ self.parameters_[start:start + basis.shape[1]]
            start += basis.shape[1]
        return weights.reshape(len(self._exponents), self.n_joints_, 3)

    @property
    def residual_share_(self) -> float:
        self._check_is_fitted()
        if self.residual_degree is None or not len(self._memory):
            return float("nan")
        shape, shape_velocity, _ = np.split(self._memory, [self.n_joints_, 2 * self.n_joints_], axis=-1)
        resistive = self.system_.drag_sensitivity(*self._on_chain(shape, shape_velocity))[0]
        residual = polynomial_features(shape, shape_velocity, self._exponents, self.shape_scale) \
            @ self.residual_weights_.reshape(-1, 3)
        return float(np.max(np.sqrt(np.sum(residual**2, axis=0) / np.maximum(np.sum(resistive**2, axis=0), 1e-300))))

    def _predict(self, shape, shape_velocity) -> np.ndarray:
        prediction = self.system_.drag_sensitivity(*self._on_chain(shape, shape_velocity))[0]
        if self.residual_degree is not None:
            features = polynomial_features(shape, shape_velocity, self._exponents, self.shape_scale)
            prediction = prediction + features @ self.residual_weights_.reshape(-1, 3)
        return prediction

    def connection(self, shape) -> np.ndarray:
        """The model's connection A(r) at ``shape`` ``(..., d)`` (rad) → ``(..., 3, d)``, ξ = −A ṙ (resistive part
        plus, for the hybrid, the residual)."""
        self._check_is_fitted()
        shape = check_array(shape, "shape", f"{type(self).__name__}.connection", trailing=(self.n_joints_,))
        connection = self._resistive_connection(shape)
        if self.residual_degree is not None:
            f = monomials(shape / self.shape_scale, self._exponents)
            connection = connection - np.einsum("...l,ljk->...kj", f, self.residual_weights_)
        return connection

    def _resistive_connection(self, shape) -> np.ndarray:
        """The fitted chain's connection over the robot's shape coordinates, A_chain(M r) M."""
        connection = self.system_.connection(*self._on_chain(shape))
        return connection if self.shape_map is None else connection @ np.asarray(self.shape_map, dtype=float)

    def _robot_system(self):
        """The fitted chain as a system over the robot's shape coordinates."""
        if self.shape_map is None:
            return self.system_
        return FunctionSystem(self._resistive_connection, self.n_joints_, name="ResistanceModel")

    def predict(self, phase, shape, shape_velocity) -> np.ndarray:
        """Predicted body velocity ξ̂ = −A(r)ṙ of samples ``(n, d)`` → ``(n, 3)`` (``phase`` only checked).

        Parameters
        ----------
        phase : array-like of shape (n,)
        shape, shape_velocity : array-like of shape (n, d)
            Joint angles (rad) and rates (rad per unit time).
        """
        self._check_is_fitted()
        phase, shape, shape_velocity = self._check_samples(phase, shape, shape_velocity,
                                                           names=("shape", "shape_velocity"),
                                                           owner=f"{type(self).__name__}.predict")
        prediction = self._predict(shape, shape_velocity)
        return prediction[0] if self._single else prediction

    def predict_displacement(self, gait: FourierGait, *, jacobian: bool = False, compiled: bool = False):
        """Net ``(x, y, heading)`` per cycle of ``gait`` under the fitted connection (and its ``(3, p)``
        derivative with respect to ``gait.params``): the resistive and residual body velocities summed at
        the Magnus nodes, then integrated (fourth-order Magnus, exact exponentials).

        Parameters
        ----------
        gait : FourierGait
        jacobian : bool, default False
        compiled : bool, default False
            Accepted for the common interface of the shape-space models (the path tracker asks for it); the
            resistance model has one path.
        """
        self._check_is_fitted()
        if not isinstance(gait, FourierGait) or gait.n_joints != self.n_joints_:
            raise fail("gait", f"{type(self).__name__}.predict_displacement",
                       f"a FourierGait with {self.n_joints_} joints", gait)
        parts = cycle_velocity(self._robot_system(), gait, self.resolution, jacobian)
        if self.residual_degree is not None:
            residual = polynomial_cycle_velocity(self.residual_weights_, self._exponents, self.shape_scale, gait,
                                                 self.resolution, jacobian)
            parts = (parts[0] + residual[0], parts[1], *((parts[2] + residual[2],) if jacobian else ()))
        return integrate_cycle(*parts)

    def rotation_std(self, gait: FourierGait, residual_variance=None) -> float:
        r"""Standard error of the predicted net rotation per cycle of ``gait``.

        The heading of the Magnus integration is exactly linear in the ω-component of ξ, so its
        derivative with respect to the parameters is
        :math:`g = \frac h2\sum_{\text{nodes}} \partial\xi_\omega/\partial p` and its standard error
        :math:`\sqrt{g^T C g}` with the parameters' covariance C, which already carries the measured noise
        (``residual_variance``, the optimiser's σ²_ω, is accepted for the common interface and not needed).
        """
        if residual_variance is not None:
            check_residual_variance(residual_variance, f"{type(self).__name__}.rotation_std")
        self._check_is_fitted()
        nodes, step = gauss_phases(self.resolution)
        shape, rate = gait.shape(nodes), gait.velocity(nodes)
        _, sensitivity = self.system_.drag_sensitivity(*self._on_chain(shape, rate))
        _, design, _ = self._design()
        g = (sensitivity[..., 2, :, :].reshape(nodes.shape + (-1,)) @ design).sum(axis=(0, 1)) * step / 2
        if self.residual_degree is not None:
            g = np.concatenate([g, self._residual_jacobian(shape, rate)[..., 2, :].sum(axis=(0, 1)) * step / 2])
        return float(np.sqrt(g @ self.parameter_covariance_ @ g))

    # -- persistence --------------------------------------------------------------------------
    def get_state(self) -> tuple[dict, dict]:
        metadata, arrays = super().get_state()
        if self.shape_map is not None:  # (JSON: nested lists)
            metadata["params"]["shape_map"] = np.asarray(self.shape_map, dtype=float).tolist()
        return metadata, arrays

    def _metadata(self) -> dict:
        return {"n_joints": self.n_joints_, "batch_shape": []}

    def _state(self) -> dict:
        return {**self._gamma_state(), "n_samples_seen": self.n_samples_seen_, "parameters": self.parameters_,
                "parameter_covariance": self.parameter_covariance_, "noise_std": self.noise_std_,
                "memory": self._memory, "residual_scale": self.residual_scale_, **self._baseline_state()}

    def _set_state(self, state: dict, metadata: dict) -> None:
        self.link_lengths = tuple(self.link_lengths)  # (as given; JSON kept it as a list)
        self._reset(int(metadata["n_joints"]))
        parameters = np.asarray(state["parameters"], dtype=float)
        if parameters.shape != self.parameters_.shape:
            raise ValueError(f"array 'parameters' has shape {parameters.shape}, expected {self.parameters_.shape}")
        self.parameters_ = parameters
        self.parameter_covariance_ = np.asarray(state["parameter_covariance"], dtype=float).reshape(
            2 * parameters.shape[:1])
        self.noise_std_ = np.asarray(state["noise_std"], dtype=float).reshape(3)
        self._memory = np.asarray(state["memory"], dtype=float).reshape(-1, 2 * self.n_joints_ + 3)
        self._set_gamma_state(state)
        self._set_baseline_state(state)
        self.n_samples_seen_ = int(state["n_samples_seen"])
        self.residual_scale_ = float(state["residual_scale"])
        self._system = None
