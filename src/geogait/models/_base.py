"""What the three gait models share: phase windows, nominal gait, Fourier smoothing of window
coefficients along φ, prediction, the Γ score, and ``.npz`` persistence.

Time units. Data reach a model in the robot's units (seconds, say) with its ``phase_rate`` φ̇. The
regression itself runs in *cycle time* τ = t φ̇ / 2π: shape and body velocities are divided by
s = φ̇ / 2π on the way in and predictions multiplied by s on the way out. The local model is then
the same function of the data whatever the time unit (ξ = −A(r)ṙ is rate-independent), so a run
in seconds at any cycle period gives the same gaits as one in cycles; at φ̇ = 2π nothing changes.
"""

from __future__ import annotations

import functools
from typing import Protocol, runtime_checkable

import numpy as np

from .._blocks import row_blocks
from .._docs import fill_doc
from .._estimator import Boolean, Estimator, InstanceOf, Integer, Real, estimator_from_state
from .._files import read_state
from .._validation import MAX_MAGNITUDE, GeogaitError, check_array, fail
from ..gaits import FourierGait, fourier_basis
from ._displacement import predicted_displacement
from ._features import PhaseWindows, n_regressors, regressors, split_coefficients
from ._rls import schedule_rounds

__all__ = ["CAPABILITIES", "GaitModel", "GaitModelBase", "SampleModel", "PhaseWindowModel", "check_gait_model",
           "check_samples", "gamma", "load_model", "model_capabilities", "model_fitted", "model_from_state"]

FORMAT = "geogait-model"
_GROUP_BYTES = 8 << 20  # covariance bytes of the trials updated together (about the size of a cache)
FORMAT_VERSION = 2  # 2: weights in cycle time (module docstring); version-1 files are converted on load
_CYCLE_RATE = 2 * np.pi  # φ̇ in cycle time
#: Largest |phase| (rad) accepted: beyond it, φ mod 2π loses the precision that the windows need.
MAX_PHASE = 1e9

#: Constraints of the hyper-parameters the phase-window models share.
WINDOW_CONSTRAINTS = {
    "n_windows": Integer(minimum=1),
    "window_width": Real(low=0, high=2 * np.pi, low_open=True, none=True),
    "smoothing_order": Integer(minimum=0),
}
GAIT_MODEL_CONSTRAINTS = {
    **WINDOW_CONSTRAINTS,
    "gait": InstanceOf(FourierGait, "a FourierGait"),
    "phase_rate": Real(low=0, low_open=True),
    "interaction": Boolean(),
    "resolution": Integer(minimum=4),
}


@runtime_checkable
class GaitModel(Protocol):
    """What every gait model offers a closed loop (the optimiser, the path follower): its hyper-parameters and
    the net motion it predicts for a gait. Further capabilities, each a set of members, are listed in
    :data:`CAPABILITIES` and read by :func:`model_capabilities`."""

    def get_params(self, deep: bool = True) -> dict:
        """Hyper-parameters (scikit-learn's contract).

        Parameters
        ----------
        deep : bool
            Also those of nested estimators.
        """
        ...

    def predict_displacement(self, gait, jacobian: bool = False):
        """Net (x, y, heading) per cycle of ``gait`` (and its Jacobian in the gait's parameters).

        Parameters
        ----------
        gait : FourierGait
        jacobian : bool
            Also return the derivative with respect to the gait's flat parameters.
        """
        ...


#: A gait model's optional capabilities, each the members it needs (methods callable; learned attributes ending in
#: ``_`` properties of the class). ``online``: learns sample by sample and moves with the gait (the Γ gate);
#: ``online_gamma``: scores itself online (Γ); ``batch``: fits a block of cycles (the prior work's gate);
#: ``rotation_spread``: the standard error of its predicted net rotation (set from ``prior_prediction_``, the
#: a-priori prediction ``partial_fit`` leaves); ``residual_share``: how much of its prediction its structure leaves
#: to the data; ``forget``: covariance resetting (the path follower); ``save``: ``get_state`` for checkpoints;
#: ``memory``: the bytes it will take for d joints, so a run can refuse it before the robot moves.
CAPABILITIES = {
    "online": ("partial_fit", "rebase"),
    "online_gamma": ("partial_fit", "reset_gamma", "gamma_"),
    "batch": ("fit",),
    "rotation_spread": ("rotation_std",),
    "residual_share": ("residual_share_",),
    "forget": ("forget",),
    "save": ("get_state",),
    "memory": ("memory_bytes",),
}


def model_capabilities(model) -> frozenset:
    """The :data:`CAPABILITIES` ``model`` offers (a model's class decides them: an unfitted model has them too).

    Parameters
    ----------
    model : GaitModel

    Returns
    -------
    frozenset of str
    """
    offered = {name for name, members in CAPABILITIES.items() if _first_missing(model, members) is None}
    if "save" in offered and not getattr(model, "can_save", lambda: True)():  # (an estimator with no state to save)
        offered.remove("save")
    return frozenset(offered)


def check_gait_model(model, members, owner: str, parameter: str = "model", prefix: str = "a") -> None:
    """The gait-model contract, checked in one place: raise the standard error when ``model`` lacks any of
    ``members`` (methods must be callable; names ending in ``_``, learned attributes such as ``gamma_``,
    must be properties of its class, so an unfitted model passes).

    What geogait's consumers need: :class:`~geogait.optimize.InSituOptimizer` ``get_params``,
    ``predict_displacement`` and ``partial_fit`` + ``rebase`` (online gate) or ``fit`` (``"cycles"``
    gate), with ``reset_gamma`` + ``gamma_`` for the online Γ; :class:`~geogait.control.PathTracker`
    ``get_params``, ``partial_fit``, ``predict_displacement`` and ``forget`` (covariance resetting).

    Parameters
    ----------
    model : object
    members : sequence of str
    owner : str
        Who asks (named in the error).
    parameter : str
        The parameter the model came in.
    prefix : str
        What the expected value is said to be before "gait model" (e.g. "None or an unfitted").
    """
    member = _first_missing(model, members)
    if member is not None:
        named = [m if m.endswith("_") else f"{m}()" for m in (*members, member)]
        raise fail(parameter, owner, f"{prefix} gait model with {', '.join(named[:-1])} (e.g. AdaptiveGaitModel, "
                   "ShapeSpaceModel)", f"a {type(model).__name__} without {named[-1]}")


def clone_for_gait(model, gait, phase_rate: float):
    """An unfitted model with ``model``'s hyper-parameters, given the nominal ``gait`` and ``phase_rate``
    (rad/s) where it takes them: what a closed loop learns afresh about a new gait or period (the in-situ
    optimiser, the path follower).

    Parameters
    ----------
    model : estimator
        The template (fitted or not; only its ``get_params(deep=False)`` are read).
    gait : FourierGait
    phase_rate : float

    Returns
    -------
    estimator
        A new instance of ``type(model)``.
    """
    params = model.get_params(deep=False)
    params.update({k: v for k, v in (("gait", gait), ("phase_rate", phase_rate)) if k in params})
    return type(model)(**params)


def model_fitted(model) -> bool:
    """Whether ``model`` holds learned state: its ``__sklearn_is_fitted__()`` where it offers one (scikit-learn's
    protocol), else True (a model that needs no fit)."""
    fitted = getattr(model, "__sklearn_is_fitted__", None)
    return bool(fitted()) if callable(fitted) else True


def has_gait_model_members(model, members) -> bool:
    """Whether ``model`` offers all of ``members`` (:func:`check_gait_model`'s test, without the error)."""
    return _first_missing(model, members) is None


def _first_missing(model, members) -> str | None:
    """The first of ``members`` that ``model`` lacks (methods callable, learned attributes on the class)."""
    return next((m for m in members if not (hasattr(type(model), m) if m.endswith("_")
                                            else callable(getattr(model, m, None)))), None)


def gamma(error_model, error_baseline) -> np.ndarray:
    r"""Γ = 1 − Σ‖ξ_D − ξ‖ / Σ‖ξ_T − ξ‖ (eq. 5) from per-sample error norms ``(..., n)``.

    Parameters
    ----------
    error_model : array-like of shape (..., n)
        ‖ξ_D − ξ‖ per sample: error norms of the gait model's predictions.
    error_baseline : array-like of shape (..., n)
        ‖ξ_T − ξ‖ per sample: error norms of the phase model's (baseline) predictions.

    Returns
    -------
    ndarray of shape (...)
        Γ, the sums running over the last (sample) axis: 1 is a perfect model, 0 no better than the
        baseline, negative worse; NaN where both sums are zero (a body that never moved: Γ is undefined,
        and the caller says so).
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        return 1.0 - np.sum(error_model, axis=-1) / np.sum(error_baseline, axis=-1)


def check_smoothing_order(smoothing_order: int, n_windows: int, owner: str) -> None:
    """The Fourier smoothing along φ needs at least 2 K + 1 windows."""
    if 2 * smoothing_order + 1 > n_windows:
        raise fail("smoothing_order", owner, f"at most (n_windows - 1) / 2 = {(n_windows - 1) // 2}", smoothing_order)


def check_residual_variance(value, owner: str):
    """σ²_ω of ``rotation_std``: a variance >= 0 (scalar or batch; inf where nothing is known yet)."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise fail("residual_variance", owner, "a variance >= 0 (inf: not known yet)", value) from None
    if not np.all(array >= 0):  # (NaN fails too)
        raise fail("residual_variance", owner, "a variance >= 0 (inf: not known yet)", value)
    return array


def unfitted_unchanged_on_error(partial_fit):
    """Wrap a gait model's ``partial_fit``: its first call (on a model not fitted yet) leaves the model unfitted, as
    it was, when it raises part-way (a hyper-parameter only the data can judge, a model that breaks down)."""
    @functools.wraps(partial_fit)
    def wrapper(self, *args, **kwargs):
        if hasattr(self, "batch_shape_"):
            return partial_fit(self, *args, **kwargs)
        with self._unchanged_on_error():
            return partial_fit(self, *args, **kwargs)
    return wrapper

class PhaseWindowModel(Estimator):
    """What every phase-window model shares: windows, sample checks, the RLS rounds across windows,
    Fourier smoothing along φ and the model file format."""

    _format = FORMAT
    _format_version = FORMAT_VERSION
    _readable_versions = (1, FORMAT_VERSION)
    _parameter_constraints = WINDOW_CONSTRAINTS

    # -- validation ---------------------------------------------------------------------------
    def _check_param_combinations(self) -> None:
        self._windows()

    def _windows(self) -> PhaseWindows:
        owner = type(self).__name__
        n_windows = self.n_windows
        width = 4 * np.pi / n_windows if self.window_width is None else float(self.window_width)
        if width < 2 * np.pi / n_windows - 1e-12:
            raise fail("window_width", owner, f">= the window spacing 2π/{n_windows}", width)
        check_smoothing_order(self.smoothing_order, n_windows, owner)
        return PhaseWindows(n_windows, width)

    def _check_samples(self, phase, *arrays, names, owner):
        """:func:`check_samples` for this model; remembers whether one sample came without a time axis."""
        *out, self._single = check_samples(self, phase, *arrays, names=names, owner=owner)
        return out

    def _run_rounds(self, bank, phase, targets, make_regressors) -> np.ndarray:
        """Feed time-ordered samples to the window filters of ``bank``, window by window in time
        order (vectorised across windows and trials); returns each sample's a-priori prediction,
        the mean over the windows that cover it, shape batch + (n, n_outputs).

        ``make_regressors(sample, rows)`` gives the regressors ``(b, M, r)`` of the samples
        ``sample`` ``(b, M)`` of trials ``rows`` (a slice of the flattened batch). Trials go through
        in groups whose covariances fit in cache (each group runs all its rounds before the next), and a long
        record in blocks of samples (:func:`~geogait._blocks.row_blocks`: each window still takes its samples in
        time order, and a signal is handled between blocks).
        """
        batch, n = phase.shape[:-1], phase.shape[-1]
        phase = phase.reshape(-1, n)
        targets = targets.reshape(phase.shape + targets.shape[-1:])
        group = max(1, _GROUP_BYTES * phase.shape[0] // bank.covariance.nbytes)
        prior = np.concatenate([
            np.concatenate([self._rounds(bank.rows(trials), phase[trials, block], targets[trials, block],
                                         lambda sample, trials=trials, block=block:
                                         make_regressors(sample + block.start, trials))
                            for block in row_blocks(n)], axis=1)
            for trials in (slice(a, a + group) for a in range(0, phase.shape[0], group))])
        return prior.reshape(batch + prior.shape[-2:])

    def _rounds(self, bank, phase, targets, make_regressors) -> np.ndarray:
        """:meth:`_run_rounds` on flat arrays ``phase (b, n)``, ``targets (b, n, k)``."""
        cover = self.windows_.cover(phase)
        b, n = phase.shape
        if n == 1:  # one sample per trial (the real-time case): no scheduling needed
            valid = cover[:, 0, :]
            sample = np.zeros(valid.shape, dtype=np.intp)
            prior = bank.update(make_regressors(sample), np.broadcast_to(targets, valid.shape + targets.shape[-1:]),
                                valid)
            return (prior.sum(axis=-2) / valid.sum(axis=-1)[..., None])[:, None, :]
        index, valid = schedule_rounds(cover)
        prior_sum = np.zeros((b * n, targets.shape[-1]))
        offsets = np.arange(b)[:, None] * n
        for r in range(index.shape[-1]):
            sample = index[..., r]  # (b, M)
            y = np.take_along_axis(targets, sample[..., None], axis=-2)
            prior = bank.update(make_regressors(sample), y, valid[..., r])
            np.add.at(prior_sum, (sample + offsets)[valid[..., r]], prior[valid[..., r]])
        return prior_sum.reshape(b, n, -1) / cover.sum(axis=-1)[..., None]

    # -- smoothing along φ --------------------------------------------------------------------
    def _smoother(self, phase) -> np.ndarray:
        """Linear map from window values to their Fourier fit at ``phase``: ``(..., n_windows)``."""
        return fourier_basis(phase, self.smoothing_order) @ _fourier_fit(self.windows_.n_windows, self.smoothing_order)

    def smoothed_weights(self, phase) -> np.ndarray:
        """Fourier-smoothed window weights ``batch + (n, 1+2d+d², 3)`` at phases ``batch + (n,)``, in cycle
        time (the regression's own units; :meth:`coefficients` gives them in the data's units)."""
        return np.einsum("...nm,...mij->...nij", self._smoother(phase), self.window_weights_)

    # -- persistence --------------------------------------------------------------------------
    def _metadata(self) -> dict:
        return {"n_joints": getattr(self, "n_joints_", None), "batch_shape": list(self.batch_shape_)}

    @classmethod
    def _upgrade_state(cls, state: dict, metadata: dict) -> dict:
        return _from_version_1(state, metadata) if metadata.get("format_version") == 1 else state

    @classmethod
    def _check_stored(cls, metadata: dict, state: dict) -> None:
        """The batch shape, window count and shape dimension of the metadata against the stored arrays."""
        check_stored_sizes(metadata, state)


@fill_doc
class SampleModel:
    """``fit`` from scratch and the held-out ``score`` (eq. 5) of the gait models learned from samples:
    models with ``partial_fit``, ``predict``, ``phase_model_`` and ``_check_samples``."""

    def fit(self, phase, shape, shape_velocity, body_velocity):
        """Forget everything, then :meth:`partial_fit` (for the batch model: least squares on exactly these
        samples). Returns ``self``; on an error the model is unchanged.

        Parameters
        ----------
        %(samples)s
        """
        with self._unchanged_on_error():
            for name in ("batch_shape_", "n_joints_"):
                self.__dict__.pop(name, None)
            return self.partial_fit(phase, shape, shape_velocity, body_velocity)

    def _check_measured_samples(self, phase, shape, shape_velocity, body_velocity, owner: str):
        """Samples with their measured ξ (what ``partial_fit`` and ``score`` take), by :meth:`_check_samples`."""
        return self._check_samples(phase, shape, shape_velocity, body_velocity,
                                   names=("shape", "shape_velocity", "body_velocity"), owner=owner)

    def _baseline_state(self) -> dict:
        """The phase model's arrays, prefixed for storage beside the gait model's own."""
        return {f"phase_model/{k}": v for k, v in self.phase_model_.get_state()[1].items()}

    def _set_baseline_state(self, state: dict) -> None:
        """Inverse of :meth:`_baseline_state` (on a model whose ``phase_model_`` was just started)."""
        own = {k.removeprefix("phase_model/"): v for k, v in state.items() if k.startswith("phase_model/")}
        self.phase_model_ = estimator_from_state(self.phase_model_.get_state()[0], own)

    def score(self, phase, shape, shape_velocity, body_velocity, baseline=None):
        """Γ on held-out samples (eq. 5) against the phase model of the training data.

        Parameters
        ----------
        %(samples)s
        baseline : PhaseModel, optional
            Phase model ξ_T; by default the one fitted alongside this model on its training data.

        Returns
        -------
        float, or ndarray of shape batch for batched models
        """
        self._check_is_fitted()
        phase, shape, shape_velocity, body_velocity = self._check_measured_samples(
            phase, shape, shape_velocity, body_velocity, f"{type(self).__name__}.score")
        baseline = self.phase_model_ if baseline is None else baseline
        model_error = np.linalg.norm(self.predict(phase, shape, shape_velocity) - body_velocity, axis=-1)
        baseline_error = np.linalg.norm(baseline.predict(phase) - body_velocity, axis=-1)
        value = gamma(model_error, baseline_error)
        return float(value) if np.ndim(value) == 0 else value


@fill_doc
class GaitModelBase(SampleModel, PhaseWindowModel):
    """The gait models' shared API: nominal gait, prediction (eq. 3), coefficients, Γ score (eq. 5),
    the phase-model baseline and predicted net motion per cycle."""

    _parameter_constraints = GAIT_MODEL_CONSTRAINTS
    _array_params = ("gait",)
    _estimated_gait_order = 1

    # -- nominal gait and windows -------------------------------------------------------------
    def _initial_gait(self, phase, shape) -> FourierGait:
        self.validate()  # before the gait is estimated from the data
        owner = type(self).__name__
        if self.gait is not None:
            if self.gait.n_joints != shape.shape[-1]:
                raise fail("gait", owner, f"a gait with {shape.shape[-1]} joints like 'shape'", self.gait.n_joints)
            return self.gait
        flat_phase, flat_shape = phase.reshape(-1), shape.reshape(-1, shape.shape[-1])
        if np.unique(np.round(flat_phase, 6)).size < 4 * self._estimated_gait_order + 2:
            raise fail("gait", owner, "given, or data spread over a cycle to estimate it from",
                       f"None with {flat_phase.size} sample(s)")
        return FourierGait.from_shapes(flat_phase, flat_shape, self._estimated_gait_order)

    def _nominal(self, phase, gait=None):
        """θ(φ) and θ̇(φ) = θ'(φ) · 2π (in cycle time) of the model's nominal gait."""
        gait = self.gait_ if gait is None else gait
        return gait.shape(phase), gait.velocity(phase) * _CYCLE_RATE

    def _time_scale(self) -> float:
        """s = φ̇ / 2π: velocities per unit of the data's time = s × velocities per cycle."""
        return float(self.phase_rate) / _CYCLE_RATE

    def _sample_regressors(self, phase, shape, shape_velocity, gait=None):
        """Regressors about the nominal gait at each sample's own phase, ``(..., n, 1+2d+d²)``."""
        nominal, nominal_rate = self._nominal(phase, gait)
        return regressors(shape - nominal, shape_velocity - nominal_rate, self.interaction)

    # -- public API shared by the gait models -------------------------------------------------
    def predict(self, phase, shape, shape_velocity) -> np.ndarray:
        r"""Predicted body velocity ξ̂ = C + Bδ + Aδ̇ + δᵀ∂Aδ̇ (eq. 3) with smoothed coefficients.

        Parameters
        ----------
        phase : array-like of shape batch + (n,)
        shape, shape_velocity : array-like of shape batch + (n, d)

        Returns
        -------
        ndarray of shape batch + (n, 3)
        """
        self._check_is_fitted()
        phase, shape, shape_velocity = self._check_samples(
            phase, shape, shape_velocity, names=("shape", "shape_velocity"), owner=f"{type(self).__name__}.predict")
        scale = self._time_scale()
        single = self._single
        prediction = np.concatenate([  # (in blocks of samples: a signal is handled between them)
            np.einsum("...ni,...nij->...nj", self._sample_regressors(phase[..., rows], shape[..., rows, :],
                                                                     shape_velocity[..., rows, :] / scale),
                      self.smoothed_weights(phase[..., rows]))
            for rows in row_blocks(phase.shape[-1])], axis=-2) * scale
        return prediction[..., 0, :] if single else prediction

    def coefficients(self, phase) -> dict[str, np.ndarray]:
        """Smoothed model coefficients at ``phase`` in the paper's names (eq. 3).

        Returns
        -------
        dict with ``C`` batch + (n, 3), ``B`` and ``A`` batch + (n, 3, d), ``dA`` batch + (n, 3, d, d).
        ``A`` estimates −A(θ(φ)) of ξ = −A(r)ṙ and ``dA[..., k, i, j]`` estimates −∂A_kj/∂r_i.
        """
        self._check_is_fitted()
        phase = check_array(phase, "phase", f"{type(self).__name__}.coefficients")
        phase = np.broadcast_to(phase, self.batch_shape_ + phase.shape[len(self.batch_shape_):]) \
            if phase.ndim >= len(self.batch_shape_) else phase
        parts = split_coefficients(self.smoothed_weights(phase), self.n_joints_)
        scale = self._time_scale()  # C and B are velocities (cycle time inside); A and ∂A are rate-free
        return {**parts, "C": parts["C"] * scale, "B": parts["B"] * scale}

    def predict_displacement(self, gait: FourierGait | None = None, *, jacobian: bool = False):
        """Net ``(x, y, heading)`` per cycle of ``gait`` predicted by the model (and its Jacobian).

        The interface the in-situ optimiser uses; see :func:`geogait.models.predicted_displacement`.
        """
        return predicted_displacement(self, gait, resolution=self.resolution, jacobian=jacobian)

    @classmethod
    def _check_stored(cls, metadata: dict, state: dict) -> None:
        check_stored_sizes(metadata, state)
        own = "weights" if "weights" in state else "moment"
        if own not in state or metadata.get("n_joints") is None:
            raise ValueError(f"the array {own!r} or the metadata's n_joints is missing")
        params = metadata["params"]
        expected = tuple(metadata["batch_shape"]) + (
            params["n_windows"], n_regressors(metadata["n_joints"], bool(params.get("interaction", True))), 3)
        if np.shape(state[own]) != expected:
            raise ValueError(f"the metadata claim arrays of shape {expected}, but {own!r} has shape "
                             f"{np.shape(state[own])}")

    @classmethod
    def load(cls, path, n_joints: int | None = None):
        """Read a model written by :meth:`save`; checks format, class and shape dimension."""
        model = load_model(path, n_joints=n_joints)
        if not isinstance(model, cls):
            raise GeogaitError(f"{path} holds a {type(model).__name__}, not a {cls.__name__}.")
        return model


@functools.lru_cache(maxsize=32)
def _fourier_fit(n_windows: int, order: int) -> np.ndarray:
    """Least-squares map from values at the equally spaced window centres to Fourier coefficients."""
    centres = 2 * np.pi * np.arange(n_windows) / n_windows
    fit = np.linalg.pinv(fourier_basis(centres, order))
    fit.setflags(write=False)
    return fit


def check_samples(model, phase, *arrays, names, owner):
    """Validate time-ordered samples for ``model`` (its ``n_joints_`` and ``batch_shape_`` once fitted).

    Parameters
    ----------
    model : estimator
        The model the samples are for.
    phase : array-like of shape batch + (n,), or batch for one sample
    *arrays : array-like of shape batch + (n, width)
        Named by ``names``; ``body_velocity`` has width 3, the others the shape dimension d.
    names : tuple of str
    owner : str
        The caller, for messages.

    Returns
    -------
    list
        ``phase`` and the arrays with a time axis (batch + (n, ...)), then whether one sample came
        without one.
    """
    phase = np.asarray(check_array(phase, "phase", owner, limit=MAX_PHASE))
    single = phase.ndim == 0 or (hasattr(model, "batch_shape_") and phase.ndim == len(model.batch_shape_))
    if single:
        phase = phase[..., None]
    if phase.shape[-1] == 0:
        raise fail("phase", owner, "at least one sample (n >= 1)", f"shape {phase.shape}")
    if 0 in phase.shape[:-1]:
        raise fail("phase", owner, "at least one trial along each leading axis", f"shape {phase.shape}")
    out = [phase]
    for array, name in zip(arrays, names, strict=True):
        width = 3 if name == "body_velocity" else None
        value = check_array(array, name, owner, trailing=(width,), limit=MAX_MAGNITUDE)
        if single:
            value = value[..., None, :]
        if value.shape[-1] == 0:
            raise fail(name, owner, "an array with at least one column (a shape of one joint or more)",
                       f"shape {value.shape}")
        if value.shape[:-1] != phase.shape:
            columns = "3" if width else "d"
            hint = (" (transposed? samples go along the first axis)"
                    if value.ndim >= 2 and value.shape[-1] == phase.shape[-1] else "")
            raise fail(name, owner, f"an array of shape {phase.shape} + ({columns},) matching 'phase'{hint}",
                       f"shape {value.shape}")
        out.append(value)
    widths = {name: value.shape[-1] for value, name in zip(out[1:], names, strict=True) if name != "body_velocity"}
    d = getattr(model, "n_joints_", None)
    if d is None and len(set(widths.values())) > 1:
        first = next(iter(widths))
        for name, width in widths.items():
            if width != widths[first]:
                raise fail(name, owner, f"an array of shape (..., {widths[first]}) like '{first}'",
                           f"shape {out[1 + names.index(name)].shape}")
    for value, name in zip(out[1:], names, strict=True):
        if name != "body_velocity" and d is not None and value.shape[-1] != d:
            raise fail(name, owner, f"an array of shape (..., {d}) (the model's shape dimension)",
                       f"shape {value.shape}")
    batch = getattr(model, "batch_shape_", None)
    if batch is not None and phase.shape[:-1] != batch:
        raise fail("phase", owner, f"batched like the data seen so far, shape {batch} + (n,)",
                   f"shape {phase.shape}")
    return [*out, single]


def check_finite_banks(banks, owner: str, hint: str) -> None:
    """Raise a clear :class:`~geogait.GeogaitError` when an update left a filter bank non-finite (values too
    large for the model's parameters): the model is not silently NaN-propagated."""
    for bank in banks:
        if not (np.all(np.isfinite(bank.weights)) and np.all(np.isfinite(bank.covariance))):
            raise GeogaitError(f"{owner}: the model state went non-finite ({hint}); the samples are too large for "
                               "its parameters. This model can no longer be used: fit a fresh one.")


def _count(value, name: str, minimum: int = 0, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum or (maximum and value > maximum):
        bound = f"<= {maximum}" if maximum else ""
        raise ValueError(f"the metadata's {name} must be an integer >= {minimum} {bound}, got {value!r:.40}")
    return value


def check_stored_sizes(metadata: dict, state: dict) -> None:
    """Raise ``ValueError`` unless the sizes ``metadata`` claim (batch shape, windows, joints) are those of
    the stored arrays: checked before a model allocates anything from them (a small file claiming 6e7
    windows is refused at once, not after gigabytes)."""
    batch = metadata.get("batch_shape")
    if not isinstance(batch, list) or len(batch) > 8:
        raise ValueError(f"the metadata's batch_shape must be a list of at most 8 sizes, got {batch!r:.40}")
    batch = tuple(_count(b, "batch_shape") for b in batch)
    params = metadata["params"]
    key = "phase_model/weights" if "phase_model/weights" in state else "weights"
    if key not in state:
        raise ValueError(f"the array {key!r} is missing")
    weights = np.asarray(state[key])
    if "n_windows" in params:
        expected = batch + (_count(params["n_windows"], "n_windows", 1),)
        if weights.shape[:len(expected)] != expected:
            raise ValueError(f"the metadata claim batch shape {batch} and {expected[-1]} windows, but the array "
                             f"{key!r} has shape {weights.shape}")
    n_joints = metadata.get("n_joints")
    if n_joints is not None:
        n_joints = _count(n_joints, "n_joints", 1, 10_000)
        if "gait" in state and np.shape(state["gait"])[:1] != (n_joints,):
            raise ValueError(f"the metadata claim {n_joints} joints, but the stored gait has shape "
                             f"{np.shape(state['gait'])}")


def load_model(path, n_joints: int | None = None):
    """Load any geogait gait model saved with ``save``.

    Parameters
    ----------
    path : path-like
    n_joints : int, optional
        If given, the shape dimension the caller expects; a mismatch raises a clear error.
    """
    metadata, state = read_state(path, "model", FORMAT, (1, FORMAT_VERSION))
    if n_joints is not None and metadata.get("n_joints") != n_joints:
        raise GeogaitError(f"{path} holds a model of shape dimension {metadata.get('n_joints')}, "
                           f"but data of shape dimension {n_joints} was given.")
    try:
        return model_from_state(metadata, state)
    except GeogaitError as error:
        raise GeogaitError(f"{path}: {error}") from None


def model_from_state(metadata: dict, state: dict):
    """Rebuild a gait model from :meth:`GaitModelBase.get_state` output (checks class and arrays).

    Parameters
    ----------
    metadata : dict
        JSON-ready metadata (format, version, class name, hyper-parameters, shapes), the first item of
        ``get_state()``.
    state : dict of str to ndarray
        The learned arrays, the second item of ``get_state()``.
    """
    return estimator_from_state(metadata, state, FORMAT)


def _from_version_1(state: dict, metadata: dict) -> dict:
    """Convert a version-1 model (regression in the data's own time unit) to cycle time.

    With s = φ̇ / 2π the cycle-time regressors are x' = S x, S = diag(1, 1_d, 1/s, 1/s) on the
    blocks [1, δ, δ̇, δ⊗δ̇], and the targets ξ / s; so weights w' = S⁻¹ w / s, covariances
    P' = S⁻¹ P S⁻¹, Gram matrices G' = S G S and moments m' = S m / s.
    """
    scale = float(metadata["params"].get("phase_rate", _CYCLE_RATE)) / _CYCLE_RATE
    if metadata["class"] == "PhaseModel" or scale == 1.0:
        return state
    d = int(metadata["n_joints"])
    inverse = np.ones(n_regressors(d, metadata["params"].get("interaction", True)))
    inverse[1 + d:] = scale  # S⁻¹
    state = dict(state)
    if "weights" in state:
        state["weights"] = state["weights"] * inverse[:, None] / scale
        state["covariance"] = state["covariance"] * np.multiply.outer(inverse, inverse)
    if "gram" in state:
        state["gram"] = state["gram"] / np.multiply.outer(inverse, inverse)
        state["moment"] = state["moment"] / inverse[:, None] / scale
    return state
