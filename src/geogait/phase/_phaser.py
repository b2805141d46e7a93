r"""Phase estimation of a multichannel oscillation: the Phaser algorithm, as geogait implements it.

After Revzen & Guckenheimer, "Estimating the phase of synchronized oscillators", Phys. Rev. E 78,
051907 (2008), whose five-step outline it keeps; three of the steps are done differently (marked
*differs* below): the per-channel correction follows Kralemann et al. (Phys. Rev. E 77, 066205,
2008), the channels are combined by a weighted circular mean rather than projected on their first
principal component, and phase zero is fixed once, at training. Every step is fitted on the
training data and then frozen:

1. **z-score** every channel with the training mean and standard deviation.
2. **Protophase** per channel from the analytic signal,
   :math:`\theta_c(t) = \arg\bigl(z_c(t) + i\,\mathcal{H}[z_c](t)\bigr)`, unwrapped in time.
3. **Per-channel correction** toward a uniformly advancing phase (*differs*: the paper fits its
   Fourier series in the protophase by regression; this one is computed from the protophase's
   distribution). A protophase advances non-uniformly over the cycle (a non-sinusoidal
   waveform), so its distribution over :math:`[0, 2\pi)` is not uniform. The phase-density
   correction of Kralemann et al. removes this: with :math:`S_k = \langle e^{-ik\theta}\rangle`
   (average over the training samples),

   .. math::
       \phi = \theta + 2\,\mathrm{Re}\sum_{k=1}^{K} \frac{S_k}{ik}\, e^{ik\theta}

   is (up to a constant) :math:`2\pi` times the cumulative distribution of :math:`\theta`, so
   the corrected phase is uniformly distributed: it advances at a constant rate through the
   cycle. Because it uses only the distribution over the cycle, not a fit against time, it is
   unaffected by the cycle frequency changing slowly within or between records.
4. **Combination** (*differs*: the paper projects on the first principal component). The
   corrected channel phases differ by constant offsets
   :math:`\Delta_c = \arg\langle e^{i(\phi_c - \phi_0)}\rangle`. The aligned phases are averaged on
   the circle with weights :math:`w_c \propto 1 / (1 - R_c)`, where :math:`R_c` is the mean
   resultant length of :math:`\phi_c - \Delta_c` about the unweighted mean (a consistent channel
   gets a large weight, a noisy one a small weight), and the mean is unwrapped in time (so no
   single channel can make it slip by a turn). A final correction of step 3 is fitted to the
   combined phase.
5. **Zero by a Poincaré section** (*differs*: fixed at training, not re-found in each record):
   phase 0 is where the section channel crosses the section level upwards. The crossing is
   found on the phase-averaged waveform of that channel (its Fourier series in the estimated
   phase), which is immune to the noise-induced chattering of crossings in raw data; if the
   averaged waveform crosses upwards more than once, the steepest crossing defines the section.

The fit also keeps the **limit cycle**: the phase-averaged z-scored channels :math:`W(\psi)`, a
Fourier series of order ``order`` per channel in the final phase (:attr:`Phaser.waveform_`,
:meth:`Phaser.waveform`), and each channel's residual spread about it. The nearest point of that
curve to a sample (:func:`nearest_phase`) is a phase from one sample alone, used at the edges of a
record (below) and by the causal :class:`~geogait.phase.OnlinePhaser`.

Edges. The FFT-based Hilbert transform treats a record as periodic, so the jump from its last
sample to its first perturbs the analytic signal near both ends, most when the record does not
hold a whole number of cycles, enough for ``transform(unwrap=True)`` to miscount cycles. Samples
within ``edge_cycles`` (half a cycle) of either end are left out when fitting, and when
transforming, the phase there is blended into the nearest-point phase (lifted to the interior's 2π
branch), with a weight falling linearly from 1 at the end sample to 0 at ``edge_cycles`` inside. A
record no longer than two edges gets the nearest-point phase throughout. ``edge_cycles=0`` turns
both off. Records are not padded: mirror padding measured worse (a reflection reverses
the analytic signal's direction of rotation at the seam).

Limits: records must be uniformly sampled (the estimator sees samples, not times), every
channel must oscillate once per cycle about its mean (a channel whose analytic signal does not
wind once around the origin per cycle, e.g. one dominated by its second harmonic, gives a poor
protophase; combined with good channels it gets a small weight), and the training data must
span at least ``min_cycles`` cycles (5 by default; on the synthetic tests 10 cycles already
reach the accuracy of 40). With fewer, :meth:`Phaser.fit` raises an error.

The transform is not causal (the analytic signal uses the whole record); for a live stream use
:class:`~geogait.phase.OnlinePhaser` (module :mod:`geogait.phase._online`).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import hilbert

from .._blocks import block_lstsq, row_blocks
from .._estimator import Estimator, Integer, Real
from .._validation import check_array, check_magnitude, fail
from ..gaits import fourier_basis

__all__ = ["Phaser"]

_OWNER = "Phaser"
#: Fitted arrays: real ones stored as they are, complex ones as ``name.real`` and ``name.imag``.
#: ``waveform_`` and ``residual_std_`` are new in format version 2 (rebuilt for version-1 files).
_REAL = ("mean_", "scale_", "offsets_", "weights_", "zero_", "n_cycles_", "samples_per_cycle_", "waveform_",
         "residual_std_")
#: z-score residuals below this fraction of a unit-variance channel count as this (noise-free training data).
_MIN_RESIDUAL_STD = 1e-2
_CHUNK = 2048  # samples per block of nearest_phase
_COMPLEX = ("channel_coefficients_", "final_coefficients_")


def _as_records(x, name: str, owner: str) -> tuple[list[np.ndarray], bool]:
    """Records as a list of ``(n_i, c)`` float arrays, and whether a single array was given."""
    single = not isinstance(x, list | tuple)
    items = [x] if single else list(x)
    if not items:
        raise fail(name, owner, "a non-empty list of arrays of shape (n_i, n_channels)", x)
    records = []
    for index, item in enumerate(items):
        label = name if single else f"{name}[{index}]"
        array = check_magnitude(check_array(item, label, owner), label, owner)
        if array.ndim == 1:
            array = array[:, None]
        if array.ndim != 2:
            raise fail(label, owner, "an array of shape (n_samples, n_channels)", f"shape {array.shape}")
        if array.shape[0] < 4:
            raise fail(label, owner, "a record of at least 4 samples", f"shape {array.shape}")
        records.append(array)
    widths = {r.shape[1] for r in records}
    if len(widths) > 1:
        raise fail(name, owner, "records with the same number of channels", sorted(widths))
    return records, single


def _protophase(z: np.ndarray) -> np.ndarray:
    """Unwrapped Hilbert protophase ``(n, c)`` of z-scored channels ``(n, c)``."""
    return np.unwrap(np.angle(hilbert(z, axis=0)), axis=0)


def _density_coefficients(theta: np.ndarray, order: int) -> np.ndarray:
    """S_k = <exp(-i k θ)> for k = 1..K over the samples of ``θ`` ``(m, ...)`` → ``(K, ...)``."""
    return np.stack([np.exp(-1j * k * theta).mean(axis=0) for k in range(1, order + 1)])


def _correct(theta: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    r"""φ = θ + 2 Re Σ_k S_k e^{ikθ} / (ik) for ``θ`` ``(n, ...)`` and ``S`` ``(K, ...)``."""
    series = np.zeros(theta.shape)
    for k, s_k in enumerate(coefficients, start=1):
        series += (s_k * np.exp(1j * k * theta) / (1j * k)).real
    return theta + 2 * series


class Phaser(Estimator):
    r"""Phase of a multichannel oscillation after Revzen & Guckenheimer 2008, scikit-learn style.

    Three of the paper's five steps are done differently (module notes): the per-channel
    correction (Kralemann et al. 2008), the combination (weighted circular mean) and the zero
    (fixed at training).

    Parameters
    ----------
    order : int >= 1
        Fourier order :math:`K` of the per-channel and final correction series.
    min_cycles : float > 0
        Least number of cycles (summed over records) :meth:`fit` accepts.
    section_channel : int
        Channel whose upward crossing of ``section_level`` defines phase zero.
    section_level : float, optional
        Level in the channel's data units; the channel's training mean by default.
    edge_cycles : float >= 0
        Samples within this many cycles of a record's ends are left out when fitting (Hilbert
        edge effects); when transforming, their phase is blended into the limit-cycle phase
        (module notes). 0 turns both off.

    Attributes
    ----------
    n_channels_ : int
    mean_, scale_ : ndarray of shape (n_channels,)
        z-score parameters.
    channel_coefficients_ : ndarray of shape (order, n_channels), complex
        :math:`S_k` of each channel's protophase.
    offsets_ : ndarray of shape (n_channels,)
        Alignment offsets :math:`\Delta_c` of the corrected channel phases.
    weights_ : ndarray of shape (n_channels,)
        Combination weights (sum 1).
    final_coefficients_ : ndarray of shape (order,), complex
        :math:`S_k` of the combined phase.
    zero_ : float
        Phase of the Poincaré section before re-zeroing.
    n_cycles_ : float
        Cycles in the training data.
    samples_per_cycle_ : float
        Mean samples per cycle of the training data (sets the default window of
        :class:`~geogait.phase.OnlinePhaser`).
    waveform_ : ndarray of shape (2 * order + 1, n_channels)
        Fourier coefficients (``fourier_basis`` order) of the z-scored channels against the phase:
        the limit cycle.
    residual_std_ : ndarray of shape (n_channels,)
        Spread of each z-scored channel about ``waveform_`` (at least 0.01).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(3000) * 0.01
    >>> phi = 2 * np.pi * t
    >>> x = np.stack([np.cos(phi), np.sin(phi) + 0.3 * np.cos(2 * phi)], axis=1)
    >>> phaser = Phaser().fit(x)

    Phase 0 is channel 0 (cos φ) crossing its mean upwards, at φ = 3π/2:

    >>> error = np.angle(np.exp(1j * (phaser.transform(x) - phi + 3 * np.pi / 2)))
    >>> bool(np.median(np.abs(error)) < 0.01)
    True
    """

    _parameter_constraints = {
        "order": Integer(minimum=1),
        "min_cycles": Real(low=0, low_open=True),
        "section_channel": Integer(minimum=0),
        "section_level": Real(none=True),
        "edge_cycles": Real(low=0),
    }
    _fitted_attribute = "final_coefficients_"
    _format = "geogait-phaser"
    _format_version = 2
    _readable_versions = (1, 2)

    def __init__(self, *, order: int = 10, min_cycles: float = 5.0, section_channel: int = 0,
                 section_level: float | None = None, edge_cycles: float = 0.5):
        self.order = order
        self.min_cycles = min_cycles
        self.section_channel = section_channel
        self.section_level = section_level
        self.edge_cycles = edge_cycles

    # -- fitting ------------------------------------------------------------------------------
    def fit(self, x, y=None) -> Phaser:
        """Fit on one record ``(n, n_channels)`` or a list of records ``(n_i, n_channels)``.

        Records are independent trials or segments (no continuity is assumed between them).
        ``y`` is ignored. Returns ``self``.

        Parameters
        ----------
        x : array-like of shape (n, n_channels), or a list of such arrays
            Periodic signals (e.g. joint angles), each record covering several cycles.
        y : None
            Ignored (scikit-learn convention).
        """
        self.validate()
        order, min_cycles, edge = self.order, self.min_cycles, self.edge_cycles
        records, _ = _as_records(x, "x", f"{_OWNER}.fit")
        with self._unchanged_on_error():  # (checks on the data come as it is fitted: a failure restores the fit)
            self.n_channels_ = records[0].shape[1]
            self._fit_scaling(records)
            theta = [_protophase(self._zscore(r)) for r in records]
            self._check_cycles(theta, min_cycles)
            self.samples_per_cycle_ = sum(len(r) for r in records) / self.n_cycles_
            keep = self._interior(theta, edge)
            self.channel_coefficients_ = _density_coefficients(_stack(theta, keep), order)
            phi = [_correct(t, self.channel_coefficients_) for t in theta]
            self._fit_combination(_stack(phi, keep))
            combined = [self._combine(p) for p in phi]
            self.final_coefficients_ = _density_coefficients(_stack(combined, keep), order)
            final = [_correct(c, self.final_coefficients_) for c in combined]
            self.zero_ = self._fit_zero(records, final, keep)
            self._fit_waveform(records, final, keep)
        return self

    def _fit_scaling(self, records: list[np.ndarray]) -> None:
        data = np.concatenate(records, axis=0)
        self.mean_ = data.mean(axis=0)
        self.scale_ = data.std(axis=0)
        flat = np.flatnonzero(self.scale_ <= 1e-12 * np.maximum(1.0, np.abs(self.mean_)))
        if flat.size:
            raise fail("x", f"{_OWNER}.fit", "oscillating channels (non-constant columns)",
                       f"constant channel(s) {flat.tolist()}")

    def _zscore(self, record: np.ndarray) -> np.ndarray:
        return (record - self.mean_) / self.scale_

    def _check_cycles(self, theta: list[np.ndarray], min_cycles: float) -> None:
        """Cycles spanned by the records (median over channels) must reach ``min_cycles``."""
        per_channel = sum((t[-1] - t[0]) * len(t) / (len(t) - 1) for t in theta) / (2 * np.pi)
        self.n_cycles_ = float(np.median(per_channel))
        if self.n_cycles_ < min_cycles:
            raise fail("x", f"{_OWNER}.fit", f"data spanning at least min_cycles = {min_cycles:g} cycles",
                       f"{self.n_cycles_:.2f} cycles")

    @staticmethod
    def _interior(theta: list[np.ndarray], edge_cycles: float) -> list[np.ndarray]:
        """Per record, a mask of the samples farther than ``edge_cycles`` from both ends."""
        masks = []
        for t in theta:
            advance = np.median(t - t[0], axis=1) / (2 * np.pi)
            total = advance[-1]
            mask = (advance >= edge_cycles) & (advance <= total - edge_cycles)
            masks.append(mask if mask.sum() >= max(4, 0.25 * len(t)) else np.ones(len(t), bool))
        return masks

    def _fit_combination(self, phi: np.ndarray) -> None:
        """Offsets Δ_c and weights w_c from corrected channel phases ``(m, c)``."""
        self.offsets_ = np.angle(np.exp(1j * (phi - phi[:, :1])).mean(axis=0))
        aligned = np.exp(1j * (phi - self.offsets_))
        mean = aligned.mean(axis=1, keepdims=True)
        resultant = np.abs((aligned * np.conj(mean) / np.maximum(np.abs(mean), 1e-12)).mean(axis=0))
        weights = 1.0 / np.maximum(1.0 - resultant, 1e-6)
        self.weights_ = weights / weights.sum()

    def _combine(self, phi: np.ndarray) -> np.ndarray:
        return combine_phases(phi, self.offsets_, self.weights_)

    def _fit_zero(self, records, final, keep) -> float:
        channel = self.section_channel
        if channel >= self.n_channels_:
            raise fail("section_channel", _OWNER, f"an int in [0, {self.n_channels_ - 1}]", channel)
        level = self.mean_[channel] if self.section_level is None else float(self.section_level)
        values = np.concatenate([r[m, channel] for r, m in zip(records, keep, strict=True)])
        phase = np.concatenate([f[m] for f, m in zip(final, keep, strict=True)])
        waveform, _ = block_lstsq(lambda rows: fourier_basis(phase[rows], self.order), values - level)
        grid = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
        curve = fourier_basis(grid, self.order) @ waveform
        up = np.flatnonzero((curve < 0) & (np.roll(curve, -1) >= 0))
        if up.size == 0:
            raise fail("section_level", _OWNER, f"a level that channel {channel} crosses in every cycle",
                       float(level))
        slope = np.roll(curve, -1)[up] - curve[up]
        best = up[np.argmax(slope)]
        fraction = -curve[best] / slope.max()
        return float((grid[best] + fraction * (grid[1] - grid[0])) % (2 * np.pi))

    def _fit_waveform(self, records, final, keep) -> None:
        """Phase-averaged z-scored channels against the (zeroed) phase, and their residual std."""
        z = np.concatenate([self._zscore(r[m]) for r, m in zip(records, keep, strict=True)])
        phase = np.concatenate([f[m] for f, m in zip(final, keep, strict=True)]) - self.zero_
        self.waveform_, _ = block_lstsq(lambda rows: fourier_basis(phase[rows], self.order), z)
        squares = sum(np.sum((z[rows] - fourier_basis(phase[rows], self.order) @ self.waveform_) ** 2, axis=0)
                      for rows in row_blocks(len(z)))
        residual = np.sqrt(squares / len(z))
        self.residual_std_ = np.maximum(residual, _MIN_RESIDUAL_STD)

    # -- use ----------------------------------------------------------------------------------
    def transform(self, x, *, unwrap: bool = False):
        """Phase of one record ``(n, n_channels)`` → ``(n,)``, or of a list of records → list.

        Parameters
        ----------
        x : array-like of shape (n, n_channels), or a list of such arrays
        unwrap : bool
            Return the continuous phase (growing by 2π per cycle) instead of ``[0, 2π)``.

        Returns
        -------
        ndarray of shape (n,), or a list of them
        """
        self._check_is_fitted()
        records, single = _as_records(x, "x", f"{_OWNER}.transform")
        if records[0].shape[1] != self.n_channels_:
            raise fail("x", f"{_OWNER}.transform", f"records with {self.n_channels_} channels",
                       f"{records[0].shape[1]} channels")
        phases = [self._phase(r, unwrap) for r in records]
        return phases[0] if single else phases

    def fit_transform(self, x, y=None, *, unwrap: bool = False):
        """:meth:`fit` then :meth:`transform` on the same records.

        Parameters
        ----------
        x : array-like of shape (n, n_channels), or a list of such arrays
            Records to fit on and to compute the phase of.
        y : None
            Ignored (scikit-learn convention).
        unwrap : bool, default False
            Return the continuous phase (growing by 2π per cycle) instead of ``[0, 2π)``.

        Returns
        -------
        ndarray of shape (n,), or a list of them
        """
        return self.fit(x).transform(x, unwrap=unwrap)

    def _phase(self, record: np.ndarray, unwrap: bool) -> np.ndarray:
        theta = _protophase(self._zscore(record))
        combined = self._combine(_correct(theta, self.channel_coefficients_))
        phase = self._mend_edges(record, _correct(combined, self.final_coefficients_) - self.zero_)
        return phase if unwrap else np.mod(phase, 2 * np.pi)

    def _mend_edges(self, record: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """Blend the first and last ``edge_cycles`` of ``phase`` ``(n,)`` into the limit-cycle phase.

        Over ``width`` samples at each end the weight of the nearest-point phase (lifted to the
        2π branch of the interior) falls linearly from 1 at the end sample to 0 inside; a record
        of at most two widths gets the nearest-point phase throughout.
        """
        if self.edge_cycles == 0:
            return phase
        n = len(phase)
        step = float(np.median(np.diff(phase)))
        width = n if step <= 0 else min(n, int(np.ceil(self.edge_cycles * 2 * np.pi / step)))
        def nearest(samples):
            return nearest_phase(self._zscore(samples), self.waveform_, self.residual_std_, self.order)

        if 2 * width >= n:
            return np.unwrap(nearest(record))
        inward = np.arange(1, width + 1) / width  # blend weight of the nearest-point phase, innermost first
        mended = phase.copy()
        head = np.unwrap(np.r_[phase[width], nearest(record[width - 1::-1])])[1:]  # samples width-1, ..., 0
        mended[width - 1::-1] = (1 - inward) * phase[width - 1::-1] + inward * head
        tail = np.unwrap(np.r_[phase[n - width - 1], nearest(record[n - width:])])[1:]  # samples n-width, ..., n-1
        mended[n - width:] = (1 - inward) * phase[n - width:] + inward * tail
        return mended

    def waveform(self, phase) -> np.ndarray:
        """The phase-averaged channels at ``phase``: the limit cycle the training data went round.

        Parameters
        ----------
        phase : array-like of shape (n,)
            Phase in radians (as :meth:`transform` returns it).

        Returns
        -------
        ndarray of shape (n, n_channels)
            Channel values in the data's units (training mean plus the Fourier series of order
            ``order`` fitted to the z-scored channels against the estimated phase).
        """
        self._check_is_fitted()
        phase = check_array(phase, "phase", f"{_OWNER}.waveform", ndim=1)
        return self.mean_ + self.scale_ * (fourier_basis(phase, self.order) @ self.waveform_)

    # -- persistence (Estimator.save / Phaser.load) ------------------------------------------
    @classmethod
    def _upgrade_state(cls, state: dict, metadata: dict) -> dict:
        """Version 1 files lack the waveform: rebuild it from the correction series (see
        :func:`_waveform_from_corrections`); its residual std is then 1 for every channel."""
        if metadata.get("format_version", 1) >= 2:
            return state
        state = dict(state)
        channel = state["channel_coefficients_.real"] + 1j * state["channel_coefficients_.imag"]
        final = state["final_coefficients_.real"] + 1j * state["final_coefficients_.imag"]
        state["waveform_"] = _waveform_from_corrections(channel, final, state["offsets_"], float(state["zero_"]),
                                                        int(metadata["params"]["order"]))
        state["residual_std_"] = np.ones(channel.shape[1])
        return state

    def _metadata(self) -> dict:
        return {"n_channels": int(self.n_channels_)}

    def _state(self) -> dict:
        state = {name: np.asarray(getattr(self, name), dtype=float) for name in _REAL}
        for name in _COMPLEX:
            value = np.asarray(getattr(self, name))
            state[f"{name}.real"], state[f"{name}.imag"] = value.real.copy(), value.imag.copy()
        return state

    def _set_state(self, state: dict, metadata: dict) -> None:
        for name in _REAL:
            value = np.asarray(state[name], dtype=float)
            setattr(self, name, float(value) if value.ndim == 0 else value)
        for name in _COMPLEX:
            setattr(self, name, state[f"{name}.real"] + 1j * state[f"{name}.imag"])
        self.n_channels_ = c = int(metadata["n_channels"])
        expected = {"mean_": (c,), "scale_": (c,), "offsets_": (c,), "weights_": (c,), "residual_std_": (c,),
                    "waveform_": (2 * self.order + 1, c),
                    "channel_coefficients_": (self.order, c), "final_coefficients_": (self.order,)}
        for name, shape in expected.items():
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"array {name!r} has shape {np.shape(getattr(self, name))}, expected {shape}")


def combine_phases(phi: np.ndarray, offsets: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted circular mean of corrected channel phases ``(n, c)`` aligned by ``offsets``, unwrapped
    along time (step 4 of the module docstring) → ``(n,)``.

    The mean itself is unwrapped, so the result is continuous whatever any one channel does (following
    one channel's phase plus the wrapped difference to the mean would jump by 2π wherever that channel
    strays half a turn from the mean, e.g. in a record's first samples).
    """
    return np.unwrap(np.angle(np.exp(1j * (phi - offsets)) @ weights), axis=0)


def nearest_phase(z: np.ndarray, waveform: np.ndarray, residual_std: np.ndarray, order: int) -> np.ndarray:
    r"""Phase ``(n,)`` in ``[0, 2π)`` of the nearest point of the limit cycle to z-scored samples ``(n, c)``.

    .. math::
        \hat\psi = \arg\min_\psi \sum_c \bigl(z_c - W_c(\psi)\bigr)^2 / \sigma_c^2,

    :math:`W` the Fourier series ``waveform`` ``(2K+1, c)``, :math:`\sigma` = ``residual_std``
    ``(c,)``: on a grid of ``max(256, 32 K)`` phases, refined by the parabola through the best grid
    point and its two neighbours.
    """
    return nearest_on_curve(z, *limit_cycle_grid(waveform, residual_std, order))


def limit_cycle_grid(waveform: np.ndarray, residual_std: np.ndarray, order: int):
    """The grid ``(G,)``, the curve on it ``(G, c)`` and the channel precisions ``(c,)`` of :func:`nearest_phase`."""
    n_grid = max(256, 32 * order)
    grid = 2 * np.pi * np.arange(n_grid) / n_grid
    return grid, fourier_basis(grid, order) @ waveform, 1.0 / np.asarray(residual_std) ** 2


def nearest_on_curve(z: np.ndarray, grid: np.ndarray, curve: np.ndarray, precision: np.ndarray) -> np.ndarray:
    out = np.empty(len(z))
    for start in range(0, len(z), _CHUNK):  # bound the (chunk, n_grid, c) distances
        block = z[start:start + _CHUNK]
        distance = ((block[:, None, :] - curve) ** 2 * precision).sum(axis=-1)
        best = np.argmin(distance, axis=1)
        rows = np.arange(len(block))
        before, here, after = (distance[rows, (best + k) % grid.size] for k in (-1, 0, 1))
        curvature = before - 2 * here + after
        safe = np.where(curvature > 0, curvature, 1.0)
        shift = np.where(curvature > 0, 0.5 * (before - after) / safe, 0.0)
        out[start:start + _CHUNK] = grid[best] + shift * grid[1]
    return np.mod(out, 2 * np.pi)


def _waveform_from_corrections(channel: np.ndarray, final: np.ndarray, offsets: np.ndarray, zero: float,
                               order: int, n_grid: int = 4096) -> np.ndarray:
    r"""Fourier coefficients ``(2K+1, c)`` of the z-scored channels against the phase, from the fitted
    correction series alone (no training data): invert the final correction (phase → combined
    phase), add each channel's offset, invert its correction (→ protophase :math:`\theta_c`) and
    take :math:`\sqrt 2 \cos\theta_c` (a unit-variance sinusoid's analytic amplitude is
    :math:`\sqrt 2`). Exact for sinusoidal channels; the amplitude of a non-sinusoidal one is not
    stored, so its waveform is approximate.
    """
    grid = 2 * np.pi * np.arange(n_grid) / n_grid
    combined = grid + zero + _inverse_correction(grid + zero, final)
    channel_phase = combined[:, None] + offsets
    protophase = channel_phase + _inverse_correction(channel_phase, channel)
    coefficients, *_ = np.linalg.lstsq(fourier_basis(grid, order), np.sqrt(2) * np.cos(protophase), rcond=None)
    return coefficients


def _inverse_correction(phi: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    r"""Deviation :math:`\theta - \phi` of the protophase whose correction (``coefficients`` ``(K, ...)``)
    is ``phi`` ``(n, ...)``: the correction is a monotone map of the circle, so its inverse is read off
    a fine grid by periodic interpolation of the (periodic) deviation."""
    grid = 2 * np.pi * np.arange(4096) / 4096
    shape = (grid.size,) + coefficients.shape[1:]
    theta = np.broadcast_to(grid.reshape((-1,) + (1,) * (len(shape) - 1)), shape)
    corrected = _correct(theta, coefficients)
    phi = np.broadcast_to(phi, phi.shape[:1] + shape[1:])
    out = np.empty(phi.shape)
    for index in np.ndindex(shape[1:]):
        column = (slice(None),) + index
        out[column] = np.interp(phi[column], corrected[column], theta[column] - corrected[column],
                                period=2 * np.pi)
    return out


def _stack(arrays: list[np.ndarray], masks: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([a[m] for a, m in zip(arrays, masks, strict=True)], axis=0)

