"""What the three gait models share: phase windows, nominal gait, Fourier smoothing of window
coefficients along φ, prediction, the Γ score, and ``.npz`` persistence.

Time units. Data reach a model in the robot's units (seconds, say) with its ``phase_rate`` φ̇. The
regression itself runs in *cycle time* τ = t φ̇ / 2π: shape and body velocities are divided by
s = φ̇ / 2π on the way in and predictions multiplied by s on the way out. The local model is then
the same function of the data whatever the time unit (ξ = −A(r)ṙ is rate-independent), so a run
in seconds at any cycle period gives the same gaits as one in cycles; at φ̇ = 2π nothing changes.
"""

from __future__ import annotations

import contextlib
import functools
from pathlib import Path

import numpy as np

from .._files import read_state, write_state
from .._validation import MAX_MAGNITUDE, GeogaitError, check_array, check_float, check_int, fail
from ..gaits import FourierGait, fourier_basis
from ._estimator import Parameters
from ._features import PhaseWindows, n_regressors, regressors, split_coefficients
from ._rls import schedule_rounds

__all__ = ["GaitModelBase", "gamma", "load_model", "model_from_state"]

FORMAT = "geogait-model"
_GROUP_BYTES = 8 << 20  # covariance bytes of the trials updated together (about the size of a cache)
FORMAT_VERSION = 2  # 2: weights in cycle time (module docstring); version-1 files are converted on load
_CYCLE_RATE = 2 * np.pi  # φ̇ in cycle time
#: Largest |phase| (rad) accepted: beyond it, φ mod 2π loses the precision that the windows need.
MAX_PHASE = 1e9


def gamma(error_model, error_baseline) -> np.ndarray:
    r"""Γ = 1 − Σ‖ξ_D − ξ‖ / Σ‖ξ_T − ξ‖ (eq. 5) from per-sample error norms ``(..., n)``."""
    return 1.0 - np.sum(error_model, axis=-1) / np.sum(error_baseline, axis=-1)


class GaitModelBase(Parameters):
    """Shared machinery; subclasses define ``_fit_samples`` and their learned state."""

    _estimated_gait_order = 1

    # -- validation ---------------------------------------------------------------------------
    def _windows(self) -> PhaseWindows:
        owner = type(self).__name__
        n_windows = check_int(self.n_windows, "n_windows", owner, minimum=1)
        width = 4 * np.pi / n_windows if self.window_width is None else self.window_width
        width = check_float(width, "window_width", owner, low=0, high=2 * np.pi, low_open=True)
        if width < 2 * np.pi / n_windows - 1e-12:
            raise fail("window_width", owner, f">= the window spacing 2π/{n_windows}", width)
        order = check_int(self.smoothing_order, "smoothing_order", owner, minimum=0)
        if 2 * order + 1 > n_windows:
            raise fail("smoothing_order", owner, f"at most (n_windows - 1) / 2 = {(n_windows - 1) // 2}", order)
        return PhaseWindows(n_windows, width)

    def _check_samples(self, phase, *arrays, names, owner):
        """Validate time-ordered samples; returns arrays with a time axis (batch + (n, ...))."""
        phase = np.asarray(check_array(phase, "phase", owner, limit=MAX_PHASE))
        single = phase.ndim == 0 or (hasattr(self, "batch_shape_") and phase.ndim == len(self.batch_shape_))
        if single:
            phase = phase[..., None]
        if phase.shape[-1] == 0:
            raise fail("phase", owner, "at least one sample (n >= 1)", f"shape {phase.shape}")
        out = [phase]
        for array, name in zip(arrays, names, strict=True):
            width = 3 if name == "body_velocity" else None
            value = check_array(array, name, owner, trailing=(width,), limit=MAX_MAGNITUDE)
            if single:
                value = value[..., None, :]
            if value.shape[:-1] != phase.shape:
                columns = "3" if width else "d"
                hint = (" (transposed? samples go along the first axis)"
                        if value.ndim >= 2 and value.shape[-1] == phase.shape[-1] else "")
                raise fail(name, owner, f"an array of shape {phase.shape} + ({columns},) matching 'phase'{hint}",
                           f"shape {value.shape}")
            out.append(value)
        widths = {name: value.shape[-1] for value, name in zip(out[1:], names, strict=True) if name != "body_velocity"}
        d = getattr(self, "n_joints_", None)
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
        batch = getattr(self, "batch_shape_", None)
        if batch is not None and phase.shape[:-1] != batch:
            raise fail("phase", owner, f"batched like the data seen so far, shape {batch} + (n,)",
                       f"shape {phase.shape}")
        self._single = single
        return out

    def _check_is_fitted(self):
        if not hasattr(self, "batch_shape_"):
            raise GeogaitError(f"This {type(self).__name__} is not fitted yet. Call 'fit' or 'partial_fit' first.")

    # -- nominal gait and windows -------------------------------------------------------------
    def _initial_gait(self, phase, shape) -> FourierGait:
        owner = type(self).__name__
        if self.gait is not None:
            if not isinstance(self.gait, FourierGait):
                raise fail("gait", owner, "a FourierGait or None", type(self.gait).__name__)
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

    def _phase_rate(self) -> float:
        return check_float(self.phase_rate, "phase_rate", type(self).__name__, low=0, low_open=True)

    def _time_scale(self) -> float:
        """s = φ̇ / 2π: velocities per unit of the data's time = s × velocities per cycle."""
        return self._phase_rate() / _CYCLE_RATE

    def _sample_regressors(self, phase, shape, shape_velocity, gait=None):
        """Regressors about the nominal gait at each sample's own phase, ``(..., n, 1+2d+d²)``."""
        nominal, nominal_rate = self._nominal(phase, gait)
        return regressors(shape - nominal, shape_velocity - nominal_rate, self.interaction)

    def _run_rounds(self, bank, phase, targets, make_regressors) -> np.ndarray:
        """Feed time-ordered samples to the window filters of ``bank``, window by window in time
        order (vectorised across windows and trials); returns each sample's a-priori prediction,
        the mean over the windows that cover it, shape batch + (n, n_outputs).

        ``make_regressors(sample, rows)`` gives the regressors ``(b, M, r)`` of the samples
        ``sample`` ``(b, M)`` of trials ``rows`` (a slice of the flattened batch). Trials go through
        in groups whose covariances fit in cache (each group runs all its rounds before the next).
        """
        batch, n = phase.shape[:-1], phase.shape[-1]
        phase = phase.reshape(-1, n)
        targets = targets.reshape(phase.shape + targets.shape[-1:])
        group = max(1, _GROUP_BYTES * phase.shape[0] // bank.covariance.nbytes)
        prior = np.concatenate([
            self._rounds(bank.rows(slice(a, a + group)), phase[a:a + group], targets[a:a + group],
                         lambda sample, a=a: make_regressors(sample, slice(a, a + group)))
            for a in range(0, phase.shape[0], group)])
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

    def _weights_at(self, phase) -> np.ndarray:
        """Fourier-smoothed weights ``batch + (n, 1+2d+d², 3)`` at phases ``batch + (n,)``."""
        return np.einsum("...nm,...mij->...nij", self._smoother(phase), self.window_weights_)

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
        x = self._sample_regressors(phase, shape, shape_velocity / scale)
        single = self._single
        prediction = np.einsum("...ni,...nij->...nj", x, self._weights_at(phase)) * scale
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
        parts = split_coefficients(self._weights_at(phase), self.n_joints_)
        scale = self._time_scale()  # C and B are velocities (cycle time inside); A and ∂A are rate-free
        return {**parts, "C": parts["C"] * scale, "B": parts["B"] * scale}

    def score(self, phase, shape, shape_velocity, body_velocity, baseline=None):
        """Γ on held-out samples (eq. 5) against the phase model of the training data.

        Parameters
        ----------
        phase : array-like of shape batch + (n,)
        shape, shape_velocity : array-like of shape batch + (n, d)
        body_velocity : array-like of shape batch + (n, 3)
        baseline : PhaseModel, optional
            Phase model ξ_T; by default the one fitted alongside this model on its training data.

        Returns
        -------
        float, or ndarray of shape batch for batched models
        """
        self._check_is_fitted()
        phase, shape, shape_velocity, body_velocity = self._check_samples(
            phase, shape, shape_velocity, body_velocity, names=("shape", "shape_velocity", "body_velocity"),
            owner=f"{type(self).__name__}.score")
        baseline = self.phase_model_ if baseline is None else baseline
        model_error = np.linalg.norm(self.predict(phase, shape, shape_velocity) - body_velocity, axis=-1)
        baseline_error = np.linalg.norm(baseline.predict(phase) - body_velocity, axis=-1)
        value = gamma(model_error, baseline_error)
        return float(value) if np.ndim(value) == 0 else value

    # -- persistence --------------------------------------------------------------------------
    def _metadata(self) -> dict:
        params = {k: v for k, v in self.get_params().items() if k != "gait"}
        return {"format": FORMAT, "format_version": FORMAT_VERSION, "class": type(self).__name__,
                "params": params, "n_joints": self.n_joints_, "batch_shape": list(self.batch_shape_)}

    def _new_baseline(self, forgetting_factor: float):
        """The phase model ξ_T learned alongside: same windows and smoothing, given forgetting."""
        from ._phase import PhaseModel

        baseline = PhaseModel(n_windows=self.n_windows, window_width=self.windows_.width,
                              forgetting_factor=forgetting_factor, smoothing_order=self.smoothing_order)
        baseline._reset(self.batch_shape_)
        return baseline

    @contextlib.contextmanager
    def _unchanged_on_error(self):
        """Restore every attribute when the block raises: a failed ``fit`` leaves the model as it was."""
        saved = dict(self.__dict__)
        try:
            yield
        except BaseException:
            self.__dict__.clear()
            self.__dict__.update(saved)
            raise

    def _forget(self) -> None:
        """Drop the learned state so the next ``partial_fit`` starts from scratch (``fit``)."""
        for name in ("batch_shape_", "n_joints_"):
            self.__dict__.pop(name, None)

    def _baseline_state(self) -> dict:
        """The phase model's arrays, prefixed for storage beside the gait model's own."""
        return {f"phase_model/{k}": v for k, v in self.phase_model_._state().items()}

    def _set_baseline_state(self, state: dict) -> None:
        """Inverse of :meth:`_baseline_state`."""
        own = {k.removeprefix("phase_model/"): v for k, v in state.items() if k.startswith("phase_model/")}
        self.phase_model_._set_state(own, {"batch_shape": list(self.batch_shape_)})

    def predict_displacement(self, gait: FourierGait | None = None, *, jacobian: bool = False):
        """Net ``(x, y, heading)`` per cycle of ``gait`` predicted by the model (and its Jacobian).

        The interface the in-situ optimiser uses; see :func:`geogait.models.predicted_displacement`.
        """
        from ._displacement import predicted_displacement

        return predicted_displacement(self, gait, jacobian=jacobian)

    def get_state(self) -> tuple[dict, dict]:
        """Learned state as ``(metadata, arrays)``: JSON-ready metadata and NumPy arrays.

        What :meth:`save` writes; :func:`model_from_state` is the inverse (checkpoints embed it).
        """
        self._check_is_fitted()
        return self._metadata(), dict(self._state())

    def save(self, path) -> Path:
        """Write the model to ``path`` (``.npz``: arrays + JSON metadata; no pickle), atomically.

        The file is written to a temporary name in the same folder and renamed over ``path``, so
        an interrupted save never leaves a truncated model behind; a model holding NaN or infinity
        is refused (:class:`~geogait.GeogaitError`) and an existing file is kept.
        """
        self._check_is_fitted()
        path = Path(path)
        return write_state(path, self._metadata(), self._state(), require_finite=True)

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
    """Rebuild a gait model from :meth:`GaitModelBase.get_state` output (checks class and arrays)."""
    from ._adaptive import AdaptiveGaitModel
    from ._batch import BatchGaitModel
    from ._phase import PhaseModel
    from ._shape_space import ShapeSpaceModel

    classes = {c.__name__: c for c in (AdaptiveGaitModel, BatchGaitModel, PhaseModel, ShapeSpaceModel)}
    if metadata.get("class") not in classes:
        raise GeogaitError(f"unknown model class {metadata.get('class')!r}.")
    model = classes[metadata["class"]](**metadata["params"])
    try:
        if metadata.get("format_version", FORMAT_VERSION) == 1:
            state = _from_version_1(state, metadata, model)
        model._set_state(state, metadata)
    except (KeyError, ValueError, IndexError) as error:
        raise GeogaitError(f"inconsistent model state (corrupt model file): {error}") from None
    return model



def _from_version_1(state: dict, metadata: dict, model) -> dict:
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
