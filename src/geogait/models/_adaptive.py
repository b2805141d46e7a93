r"""The adaptive gait model: a bank of RLS filters over phase windows (paper §III, eqs. 3–7)."""

from __future__ import annotations

import numpy as np

from .. import _kernels
from .._docs import fill_doc
from .._estimator import Real
from .._validation import (
    MAX_BYTES,
    MAX_MAGNITUDE,
    check_array,
    check_bytes,
    check_choice,
    check_float,
    fail,
    warn_if_degrees,
)
from ..gaits import FourierGait
from ._base import (
    GAIT_MODEL_CONSTRAINTS,
    MAX_PHASE,
    GaitModelBase,
    check_finite_banks,
    check_residual_variance,
    unfitted_unchanged_on_error,
)
from ._features import n_regressors, regressors
from ._online_gamma import OnlineGamma
from ._phase import phase_baseline
from ._rls import RLSBank

__all__ = ["CONFIG_FORMAT", "AdaptiveGaitModel"]

_FLOAT64 = np.dtype(np.float64)  # native float64: the only dtype the compiled one-sample path takes
CONFIG_FORMAT = "geogait-model-config"
CONFIG_VERSION = 1


@fill_doc
class AdaptiveGaitModel(OnlineGamma, GaitModelBase):
    r"""Local model of ξ = −A(r)ṙ around a nominal gait, learned sample by sample.

    Each of ``n_windows`` phase windows holds an RLS filter (eq. 4) on the regressor
    ``[1, δ, δ̇, δ⊗δ̇]`` of eq. 3; window coefficients are smoothed along φ by a Fourier series for
    prediction. The model scores itself online with Γ (eq. 6) and can be re-centred on a new
    nominal gait by a Taylor rebase (eq. 7).

    Parameters
    ----------
    gait : FourierGait, optional
        Nominal gait θ(φ) the model expands around; estimated from the first data (Fourier order 1)
        when omitted.
    n_windows : int
        Number M of equally spaced phase windows.
    window_width : float, optional
        Window width Δφ (rad); default two window spacings, 4π / M (each sample updates 2 windows).
    forgetting_factor : float in (0, 1]
        λ_RLS. 1 is ordinary recursive least squares.
    initial_covariance : float in (0, 1e12]
        δ₀: P starts at δ₀·I; the trace clamp keeps trace P ≤ n δ₀.
    smoothing_order : int
        Fourier order of the smoothing of window coefficients along φ (≤ (M − 1) / 2).
    gamma_forgetting : float in (0, 1]
        λ_Γ of the online confidence Γ (eq. 6), per sample.
    phase_rate : float > 0
        φ̇ (rad per time unit) used for θ̇ = θ'(φ) φ̇; 2π means time is measured in cycles.
    interaction : bool
        Keep the bilinear δ ⊗ δ̇ block of eq. 3 (d² of the 1 + 2d + d² weights per window). Without it
        the model is linear in (δ, δ̇) and needs far fewer samples for many joints.
    resolution : int
        Magnus steps over the cycle of :meth:`predict_displacement` (as every gait model has).

    Attributes
    ----------
    gait_ : FourierGait
        Current nominal gait.
    windows_ : PhaseWindows
    window_weights_ : ndarray of shape batch + (M, 1 + 2d + d², 3)
        RLS weights per window (unsmoothed).
    covariance_ : ndarray of shape batch + (M, 1 + 2d + d², 1 + 2d + d²)
    phase_model_ : PhaseModel
        Baseline ξ_T learned alongside, with the same windows and forgetting.
    gamma_ : float or ndarray of shape batch
        Online Γ after the last sample (eq. 6).
    online_gamma_ : ndarray of shape batch + (n,)
        Online Γ after each sample of the last ``partial_fit`` call.
    prior_prediction_ : ndarray of shape batch + (n, 3)
        A-priori predictions ξ_D of the samples of the last ``partial_fit`` call.
    n_joints_ : int
    batch_shape_ : tuple
        Leading trial axes; ``()`` for a single model.

    Notes
    -----
    The online Γ compares *a-priori* errors, each sample being predicted before it is learned: ξ_D
    is the mean of the covering windows' filter predictions and ξ_T that of the phase model. These
    are exactly the filters' predictions at that instant, so online Γ does not depend on how the
    stream is split into ``partial_fit`` calls.

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import simulate
    >>> gait = seed_gait(2)
    >>> train = simulate(PurcellSwimmer(3), gait, n_cycles=10, seed=0)
    >>> test = simulate(PurcellSwimmer(3), gait, n_cycles=10, seed=1)
    >>> model = AdaptiveGaitModel(gait=gait).fit(train.phase, train.shape, train.shape_velocity,
    ...                                           train.body_velocity)
    >>> model.score(test.phase, test.shape, test.shape_velocity, test.body_velocity) > 0.9
    True
    """

    _parameter_constraints = {
        **GAIT_MODEL_CONSTRAINTS,
        "forgetting_factor": Real(low=0, high=1, low_open=True),
        "initial_covariance": Real(low=0, high=1e12, low_open=True),
        "gamma_forgetting": Real(low=0, high=1, low_open=True),
    }

    def __init__(self, *, gait: FourierGait | None = None, n_windows: int = 20,
                 window_width: float | None = None, forgetting_factor: float = 0.99,
                 initial_covariance: float = 100.0, smoothing_order: int = 5,
                 gamma_forgetting: float = 0.995, phase_rate: float = 2 * np.pi, interaction: bool = True,
                 resolution: int = 128):
        self.gait = gait
        self.n_windows = n_windows
        self.window_width = window_width
        self.forgetting_factor = forgetting_factor
        self.initial_covariance = initial_covariance
        self.smoothing_order = smoothing_order
        self.gamma_forgetting = gamma_forgetting
        self.phase_rate = phase_rate
        self.interaction = interaction
        self.resolution = resolution

    # -- fitting ------------------------------------------------------------------------------
    def _reset(self, batch: tuple, n_joints: int, gait: FourierGait):
        self.validate()
        self.windows_ = self._windows()
        self._set_gait(gait)
        self.n_joints_ = n_joints
        self.batch_shape_ = batch
        n = n_regressors(self.n_joints_, self.interaction)
        self._check_size(batch, n_joints, n)
        self.bank_ = RLSBank(self.batch_shape_, self.windows_.n_windows, n, 3, self.forgetting_factor,
                             self.initial_covariance)
        self.phase_model_ = phase_baseline(self, self.forgetting_factor)
        self.psi_ = np.zeros(self.batch_shape_ + (2,))
        self.n_samples_seen_ = 0

    def memory_bytes(self, n_joints: int) -> float:
        """Bytes this model takes for ``n_joints`` joints at its peak: its saved state and the updates' temporaries
        (1.2–1.6 × the covariances, measured at 20 and 30 joints)."""
        return 1.5 * self.saved_bytes(n_joints)

    def saved_bytes(self, n_joints: int) -> float:
        """Bytes of this model's saved file for ``n_joints`` joints: its M window covariances of n × n regressors
        (every other array is smaller by a factor n)."""
        return 8.0 * self.n_windows * n_regressors(n_joints, self.interaction) ** 2

    def _check_size(self, batch: tuple, n_joints: int, n: int) -> None:
        """Refuse window covariances beyond MAX_BYTES (for every batch element), naming the most joints that fit."""
        copies = float(np.prod(batch))
        largest = n_joints
        while largest > 1 and copies * self.memory_bytes(largest) > MAX_BYTES:
            largest -= 1
        check_bytes(copies * self.memory_bytes(n_joints), f"a window model of {n_joints} joints ({self.n_windows} "
                    f"windows of {n} regressors)", type(self).__name__,
                    f"at most {largest} joints with {self.n_windows} windows")

    @unfitted_unchanged_on_error
    def partial_fit(self, phase, shape, shape_velocity, body_velocity):
        """Learn from samples in time order (one sample or a batch; optional leading trial axes).

        Parameters
        ----------
        phase : array-like of shape batch + (n,) or batch
        shape, shape_velocity : array-like of shape batch + (n, d) or batch + (d,)
        body_velocity : array-like of shape batch + (n, 3) or batch + (3,)

        Returns
        -------
        self
        """
        if self._learn_one_compiled(phase, shape, shape_velocity, body_velocity):
            return self
        phase, shape, shape_velocity, body_velocity = self._check_measured_samples(
            phase, shape, shape_velocity, body_velocity, "AdaptiveGaitModel.partial_fit")
        if not self.__dict__.get("_warned_degrees", False):
            self._warned_degrees = warn_if_degrees(shape, "shape", "AdaptiveGaitModel.partial_fit")
        if not hasattr(self, "batch_shape_"):
            self._reset(phase.shape[:-1], shape.shape[-1], self._initial_gait(phase, shape))
        scale = self._time_scale()  # the filters work in cycle time (see geogait.models._base)
        if phase.shape == (1,):  # the real-time case: one sample, one model
            prior, baseline = self._learn_one(phase[0], shape[0], shape_velocity[0] / scale, body_velocity[0], scale)
        else:
            prior, baseline = self._learn(phase, shape, shape_velocity / scale, body_velocity, scale)
        check_finite_banks([self.bank_], "AdaptiveGaitModel.partial_fit", "shapes and rates far from the nominal gait")
        self._update_gamma(prior, baseline, body_velocity)
        self.prior_prediction_ = prior
        self.n_samples_seen_ += phase.shape[-1]
        return self

    def _learn_one_compiled(self, phase, shape, shape_velocity, body_velocity) -> bool:
        """The compiled one-sample path (:mod:`geogait._kernels`); False leaves the sample to the
        reference path (numba missing, a model not yet started or batched, input that is not one plain
        float64 sample, or one the reference checks must judge: non-finite, too large, degrees)."""
        kernel = _kernels.learn_one_kernel()
        if kernel is None or self.__dict__.get("batch_shape_", None) != ():
            return False
        if not (type(shape) is np.ndarray and type(shape_velocity) is np.ndarray and type(body_velocity) is np.ndarray
                and (type(phase) is float or type(phase) is np.float64)):
            return False
        if not (shape.shape == shape_velocity.shape == (self.n_joints_,) and body_velocity.shape == (3,)
                and shape.dtype == shape_velocity.dtype == body_velocity.dtype == _FLOAT64):
            return False
        bank, base = self.bank_, self.phase_model_.bank_
        nominal, nominal_rate = self._centre_nominal
        centres, half_width = self._cover
        psi = self.psi_  # a strided view after the reference path: copied (the kernel is compiled for one layout)
        psi = psi if psi.flags.c_contiguous else psi.copy()
        out = np.empty(9)
        status = kernel(phase, shape, shape_velocity, body_velocity, self._time_scale(), MAX_PHASE, MAX_MAGNITUDE,
                        not self.__dict__.get("_warned_degrees", False), centres, half_width, nominal, nominal_rate,
                        bool(self.interaction), bank.weights, bank.covariance, bank.n_updates,
                        float(bank.forgetting_factor), bank.max_trace, base.weights, base.covariance, base.n_updates,
                        float(base.forgetting_factor), base.max_trace, psi, float(self.gamma_forgetting), out)
        if status:
            return False
        self._single = True
        self.prior_prediction_ = out[None, :3]
        self.psi_ = out[3:5]
        self.online_gamma_ = out[5:6]
        self.n_samples_seen_ += 1
        self.phase_model_.n_samples_seen_ += 1
        return True

    def _learn_one(self, phase, shape, shape_velocity, body_velocity, scale):
        """One sample straight into its covering windows (same arithmetic as :meth:`_learn`).

        ``shape_velocity`` is in cycle time, ``body_velocity`` in the data's time; the a-priori
        prediction comes back in the data's time (``scale`` s = φ̇ / 2π)."""
        valid = self.windows_.cover(phase)
        nominal, nominal_rate = self._centre_nominal
        x = regressors(shape - nominal, shape_velocity - nominal_rate, self.interaction)  # (M, n)
        targets = np.broadcast_to(body_velocity / scale, (valid.size, 3))
        prior = self.bank_.update(x, targets, valid)[valid].mean(axis=0) * scale
        baseline = self.phase_model_.learn_one(valid, body_velocity)
        return prior[None], baseline[None]

    def _learn(self, phase, shape, shape_velocity, body_velocity, scale):
        """Time-ordered samples (any batch shape) through the window rounds; a-priori predictions
        (units as in :meth:`_learn_one`)."""
        nominal, nominal_rate = self._centre_nominal
        flat_shape = shape.reshape((-1,) + shape.shape[-2:])
        flat_rate = shape_velocity.reshape(flat_shape.shape)

        def window_regressors(sample, rows):  # regressors of window m's sample about θ(φ_m), eq. 4
            r = np.take_along_axis(flat_shape[rows], sample[..., None], axis=-2)
            r_dot = np.take_along_axis(flat_rate[rows], sample[..., None], axis=-2)
            return regressors(r - nominal, r_dot - nominal_rate, self.interaction)

        prior = self._run_rounds(self.bank_, phase, body_velocity / scale, window_regressors) * scale
        return prior, self.phase_model_.partial_fit_predict(phase, body_velocity)

    def _set_gait(self, gait: FourierGait) -> None:
        self.gait_ = gait
        self._centre_nominal = self._nominal(self.windows_.centres)  # θ(φ_m), θ̇(φ_m), reused every sample
        self._cover = (self.windows_.centres, self.windows_.width / 2 + 1e-12)  # the window test of PhaseWindows.cover

    @property
    def window_weights_(self) -> np.ndarray:
        return self.bank_.weights

    @property
    def covariance_(self) -> np.ndarray:
        return self.bank_.covariance

    def rotation_std(self, gait: FourierGait | None = None, residual_variance=np.inf) -> float:
        r"""Standard error of the predicted net rotation per cycle of the nominal gait, given the
        ``residual_variance`` σ²_ω of the measured ω (rad² per unit time²).

        At δ = 0 the predicted rotation is ≈ Σ_m C_m,ω · 2π / (M φ̇) (the smoothed constant terms'
        mean over a cycle), so its variance is ≈ σ²_ω (2π / (M φ̇))² Σ_m P_m[0, 0]. ``gait`` is
        accepted for the common signature of the gait models (:class:`ShapeSpaceModel` answers for
        any gait); this model answers for its own nominal gait.
        """
        residual_variance = check_residual_variance(residual_variance, "AdaptiveGaitModel.rotation_std")
        self._check_is_fitted()
        p00 = self.covariance_[..., 0, 0]
        scale = 2 * np.pi / (p00.shape[-1] * self.phase_rate)
        return float(np.sqrt(residual_variance * p00.sum()) * scale)

    def forget(self, factor: float):
        r"""Discount all evidence so far by ``factor``, at once (covariance resetting).

        RLS with forgetting weighs a sample ``i`` updates old by :math:`\lambda^i`; multiplying a
        window covariance by ``factor`` divides every past sample's weight by ``factor`` in one go, the
        weights unchanged: the next samples correct the model as if the old ones were
        ``log(factor) / (1 - λ)`` updates older. Each direction of the covariance is raised at most to
        the prior's (``initial_covariance``), and one already beyond it is kept, so the trace clamp
        cannot undo the reset where never-excited directions fill its budget
        (:meth:`RLSBank.forget <geogait.models._rls.RLSBank.forget>`). Used after an unannounced
        change of the environment, so a slow λ need not be traded for fast re-learning.

        Parameters
        ----------
        factor : float >= 1

        Returns
        -------
        self
        """
        self._check_is_fitted()
        self.bank_.forget(check_float(factor, "factor", "AdaptiveGaitModel.forget", low=1))
        return self

    # -- Taylor rebase (eq. 7) ----------------------------------------------------------------
    def rebase(self, new_gait: FourierGait, terms: str = "constant", covariance_inflation: float = 1.0,
               constant_variance: float = 0.0, baseline: str = "reset"):
        r"""Re-centre every window on a new nominal gait θ' (eq. 7).

        With Δθ = θ'(φ_m) − θ(φ_m) and Δθ̇ = θ̇'(φ_m) − θ̇(φ_m), the constant term becomes the old
        window model evaluated at the new nominal point:
        :math:`w'[0] = [1, Δθ, Δθ̇, Δθ ⊗ Δθ̇] \cdot w`.

        Parameters
        ----------
        new_gait : FourierGait
        terms : {"constant", "all", "none"}
            ``"constant"`` is the paper's eq. 7 (other weights kept). ``"all"`` is the exact
            re-expansion of the window polynomial about the new point: B gains ∂A·Δθ̇ and A gains
            Δθᵀ∂A too, so every window's predictions are unchanged by the rebase. ``"none"`` only
            moves the expansion point and keeps all weights (the ablation eq. 7 improves on).

        covariance_inflation : float >= 1
            Multiply every window covariance by this factor (then apply the trace clamp): the
            evidence gathered about the old gait counts for less, so the first samples of the new
            gait correct the extrapolated constant faster. 1 keeps P as the paper does.
        constant_variance : float >= 0
            Added to every window's covariance entry of the constant term (a Kalman random-walk
            step on the one coefficient the rebase extrapolates): the constant re-adapts to the new
            gait within about ``1 / constant_variance`` samples per window while B, A and ∂A keep
            their evidence. 0 keeps P as the paper does.
        baseline : {"reset", "reseed", "keep"}
            What happens to the phase model ξ_T, whose phase average belonged to the old gait.
            ``"reset"`` (default) starts it afresh, so Γ compares the model with the *new* gait's own
            phase average once that has been seen (discard about one cycle of Γ first:
            :meth:`reset_gamma`). ``"reseed"`` starts it from the rebased constant terms, worth one
            sample. ``"keep"`` leaves it at the old gait's average, which inflates Γ.

        Returns
        -------
        self
        """
        owner = "AdaptiveGaitModel.rebase"
        self._check_is_fitted()
        check_choice(terms, "terms", owner, ("constant", "all", "none"))
        if not isinstance(new_gait, FourierGait) or new_gait.n_joints != self.n_joints_:
            raise fail("new_gait", owner, f"a FourierGait with {self.n_joints_} joints", new_gait)
        inflation = check_float(covariance_inflation, "covariance_inflation", owner, low=1)
        variance = check_float(constant_variance, "constant_variance", owner, low=0)
        check_choice(baseline, "baseline", owner, ("reset", "reseed", "keep"))
        centres = self.windows_.centres
        old, old_rate = self._nominal(centres)
        new, new_rate = self._nominal(centres, new_gait)
        shift, shift_rate = new - old, new_rate - old_rate  # (M, d)
        weights = self.bank_.weights  # batch + (M, n, 3)
        d = self.n_joints_
        constant = np.einsum("mi,...mij->...mj", regressors(shift, shift_rate, self.interaction), weights)
        if terms == "all" and self.interaction:
            bilinear = weights[..., 1 + 2 * d:, :].reshape(weights.shape[:-2] + (d, d, 3))  # [i, j]: δ_i δ̇_j
            weights[..., 1:1 + d, :] += np.einsum("...mijk,mj->...mik", bilinear, shift_rate)
            weights[..., 1 + d:1 + 2 * d, :] += np.einsum("...mijk,mi->...mjk", bilinear, shift)
        if terms != "none":
            weights[..., 0, :] = constant
        if inflation > 1:
            self.bank_.inflate(inflation)
        if variance > 0:
            self.bank_.covariance[..., 0, 0] += variance
        self._set_gait(new_gait)
        bank = self.phase_model_.bank_
        if baseline == "reset":
            self.phase_model_.start(self.batch_shape_)
        elif baseline == "reseed":
            bank.weights[..., 0, :] = self.bank_.weights[..., 0, :]
            bank.covariance[...] = 1.0
        return self

    # -- configs: a fresh model's recipe as JSON ----------------------------------------------
    def to_config(self) -> dict:
        """A JSON-ready config that starts a fresh model with these hyper-parameters and nominal gait
        (``geogait fit`` writes it as ``config.json``; ``geogait stream`` and :meth:`from_config` read it).

        Returns
        -------
        dict with keys ``format``, ``format_version``, ``params`` and ``gait`` (coefficients ``(d, 2K+1)``).
        """
        gait = getattr(self, "gait_", None)
        gait = self.gait if gait is None else gait
        if gait is None:
            raise fail("gait", "AdaptiveGaitModel.to_config", "known (a fitted model, or one built with a gait)", None)
        params = {k: v for k, v in self.get_params(deep=False).items() if k != "gait"}
        return {"format": CONFIG_FORMAT, "format_version": CONFIG_VERSION, "params": params,
                "gait": gait.coefficients.tolist()}

    @classmethod
    def from_config(cls, config: dict, source: str = "config") -> AdaptiveGaitModel:
        """A fresh model from a config of :meth:`to_config`; ``source`` names it in errors.

        Only ``gait`` is required; ``params`` holds any hyper-parameters, and ``format`` /
        ``format_version`` are checked when present. Unknown keys are errors. The hyper-parameters
        are validated here, not at the first sample.
        """
        owner = f"the model config {source}"
        if not isinstance(config, dict):
            raise fail("config", owner, "a JSON object", type(config).__name__)
        unknown = sorted(set(config) - {"format", "format_version", "params", "gait"})
        if unknown:
            raise fail("config", owner, "an object with keys among format, format_version, params, gait",
                       f"unknown key(s) {unknown}")
        if config.get("format", CONFIG_FORMAT) != CONFIG_FORMAT or config.get("format_version", 1) != 1:
            raise fail("format", owner, f"{CONFIG_FORMAT!r} version {CONFIG_VERSION}",
                       f"{config.get('format')!r} version {config.get('format_version')}")
        if "gait" not in config:
            raise fail("gait", owner, "given: the nominal gait's Fourier coefficients, a list of d lists "
                       "[a_0, a_1..a_K, b_1..b_K]", None)
        gait = FourierGait(check_array(config["gait"], "gait", owner, ndim=2))
        params = config.get("params", {})
        if not isinstance(params, dict):
            raise fail("params", owner, "an object of AdaptiveGaitModel hyper-parameters", params)
        return cls(gait=gait).set_params(**params).validate()

    # -- persistence --------------------------------------------------------------------------
    def _state(self) -> dict:
        state = {**self.bank_.state(), **self._gamma_state(), "gait": self.gait_.coefficients,
                 "n_samples_seen": self.n_samples_seen_,
                 **self._baseline_state()}
        if self.gait is not None:
            state["initial_gait"] = self.gait.coefficients
        return state

    def _set_state(self, state, metadata):
        batch, d = tuple(metadata["batch_shape"]), int(metadata["n_joints"])
        gait = FourierGait(state["gait"])
        if gait.n_joints != d:
            raise ValueError(f"gait has {gait.n_joints} joints, metadata says {d}")
        self.gait = FourierGait(state["initial_gait"]) if "initial_gait" in state else None
        self._reset(batch, d, gait)
        self.bank_.assign(state)
        self._set_gamma_state(state)
        self.n_samples_seen_ = int(state["n_samples_seen"])
        self._set_baseline_state(state)
