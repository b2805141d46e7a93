"""Simulated experiments: a commanded gait with perturbations driving a known system.

The commanded phase advances at a constant rate (one cycle per ``cycle_period``). At sample n

    r = θ(φ) + δ,   ṙ = θ'(φ) φ̇ + δ̇,   ξ = -A(r) ṙ,

with (δ, δ̇) the SDE of eq. 8; the pose follows g_{n+1} = g_n exp(Δt ξ_n). Optional Gaussian
sensor noise is added to the *measured* ξ (and r, ṙ) with standard deviation a fraction of the
RMS of the noise-free signal along the nominal gait, per component.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .. import se2
from .._seeds import child_seed
from .._validation import GeogaitError, check_float, check_int, fail
from ..gaits import FourierGait, Perturbation, check_excitation, excitation_at
from ..systems import PurcellSwimmer, System
from ._trajectory import Trajectory

#: Largest sensor noise, as a fraction of the signal's RMS (beyond it a sample is no longer a measurement).
MAX_SENSOR_NOISE = 100.0

__all__ = ["MAX_SENSOR_NOISE", "DragRatioSchedule", "SwimmerStream", "simulate", "simulate_rate"]


@dataclass(frozen=True)
class DragRatioSchedule:
    """Piecewise-constant environment: a Purcell swimmer whose drag ratio changes with the cycle.

    ``drag_ratios[i]`` holds for cycles ``[i * cycles_per_environment, (i + 1) * ...)``; the last
    value persists after the schedule ends. The paper's Fig. 3 uses (2, 3, 4) every 40 cycles.

    Parameters
    ----------
    system : PurcellSwimmer
        The swimmer whose drag ratio k changes (its other parameters stay).
    drag_ratios : sequence of float > 0
        k of each environment, in order.
    cycles_per_environment : int >= 1
        Cycles each environment lasts.
    """

    system: PurcellSwimmer
    drag_ratios: tuple[float, ...] = (2.0, 3.0, 4.0)
    cycles_per_environment: int = 40

    def __post_init__(self):
        if np.ndim(self.drag_ratios) != 1 or not np.size(self.drag_ratios):
            raise fail("drag_ratios", "DragRatioSchedule", "a non-empty sequence", self.drag_ratios)
        for value in self.drag_ratios:
            check_float(value, "drag_ratios", "DragRatioSchedule", low=0, low_open=True)
        check_int(self.cycles_per_environment, "cycles_per_environment", "DragRatioSchedule",
                  minimum=1)
        object.__setattr__(self, "drag_ratios", tuple(float(v) for v in self.drag_ratios))
        object.__setattr__(self, "_systems",
                           [self.system.with_drag_ratio(k) for k in self.drag_ratios])

    def environment(self, cycle: int) -> int:
        """Index of the environment in force during ``cycle``."""
        return min(cycle // self.cycles_per_environment, len(self.drag_ratios) - 1)

    def __call__(self, cycle: int) -> PurcellSwimmer:
        return self._systems[self.environment(cycle)]


def _trial_generators(seed, n_trials):
    """Per trial, independent generators for the perturbations and for the sensor noise."""
    seeds = seed if isinstance(seed, Sequence) and not isinstance(seed, str) else [seed]
    for value in seeds:
        if value is not None and not isinstance(value, np.random.SeedSequence):
            check_int(value, "seed", "SwimmerStream", minimum=0)
    if isinstance(seed, Sequence) and not isinstance(seed, str):
        sequences = [s if isinstance(s, np.random.SeedSequence) else np.random.SeedSequence(s)
                     for s in seed]
        if n_trials is not None and n_trials != len(sequences):
            raise fail("n_trials", "SwimmerStream", f"equal to len(seed) = {len(sequences)}", n_trials)
        batched = True
    else:
        root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        batched = n_trials is not None
        sequences = root.spawn(n_trials) if batched else [root]
    return ([np.random.default_rng(child_seed(s, 0)) for s in sequences],
            [np.random.default_rng(child_seed(s, 1)) for s in sequences], batched)


class SwimmerStream:
    """Sample-by-sample (or cycle-by-cycle) simulation; the gait may change between cycles.

    It implements :class:`geogait.robots.Robot` (with the extras ``current_system`` for the oracle
    and ``robot_state`` / ``restore_robot_state`` for bit-identical checkpoints); each sample's
    ``commanded_shape`` is θ(φ) + δ, its ``shape`` the same plus any shape sensor noise.

    Parameters
    ----------
    system : System
        The locomotor (ignored for cycles covered by ``environment``).
    gait : FourierGait
        Initial nominal gait.
    samples_per_cycle : int
    perturbation : Perturbation, optional
        SDE of eq. 8; default ``Perturbation()`` (δ std 0.15 rad). ``Perturbation(eta=0)`` for none.
    sensor_noise : float
        Std of the noise on measured ξ as a fraction of its RMS along the nominal gait.
    shape_noise : float
        Same for measured r and ṙ.
    environment : callable, optional
        ``cycle -> System`` (e.g. :class:`DragRatioSchedule`); overrides ``system``.
    seed : int, SeedSequence or sequence of SeedSequence, optional
        A sequence gives one trial per entry (the runner passes one child per trial).
    n_trials : int, optional
        Simulate this many independent trials at once (leading axis of every array).
    cycle_period : float
        Duration of a cycle; the SDE runs in these time units.
    """

    def __init__(self, system: System, gait: FourierGait, *, samples_per_cycle: int = 100,
                 perturbation: Perturbation | None = None, sensor_noise: float = 0.0,
                 shape_noise: float = 0.0, environment: Callable[[int], System] | None = None,
                 seed=None, n_trials: int | None = None, cycle_period: float = 1.0):
        owner = "SwimmerStream"
        if not isinstance(gait, FourierGait):
            raise fail("gait", owner, "a FourierGait", type(gait).__name__)
        if gait.n_joints != system.n_joints:
            raise fail("gait", owner, f"a gait with {system.n_joints} joints", gait.n_joints)
        self.samples_per_cycle = check_int(samples_per_cycle, "samples_per_cycle", owner, minimum=4)
        if self.samples_per_cycle > 100_000:
            raise fail("samples_per_cycle", owner, "an int in [4, 100000]", samples_per_cycle)
        self.sensor_noise = check_float(sensor_noise, "sensor_noise", owner, low=0, high=MAX_SENSOR_NOISE)
        self.shape_noise = check_float(shape_noise, "shape_noise", owner, low=0, high=MAX_SENSOR_NOISE)
        self.cycle_period = check_float(cycle_period, "cycle_period", owner, low=0, low_open=True)
        if n_trials is not None:
            check_int(n_trials, "n_trials", owner, minimum=1)
        if perturbation is not None and not isinstance(perturbation, Perturbation):
            raise fail("perturbation", owner, "a Perturbation (e.g. Perturbation.from_std(0.15)) or None",
                       type(perturbation).__name__)
        self.system = system
        self.environment = environment
        self.perturbation = Perturbation() if perturbation is None else perturbation
        self._perturbation_rngs, self._noise_rngs, self._batched = _trial_generators(seed, n_trials)
        self._gait = gait
        self._pending_gait: FourierGait | None = None
        self.dt = self.cycle_period / self.samples_per_cycle
        self.phase_rate = 2 * np.pi / self.cycle_period
        batch = (len(self._perturbation_rngs),)
        initial = np.stack([self.perturbation.stream(self.dt, gait.n_joints, rng).state
                            for rng in self._perturbation_rngs])
        self._perturbation = self.perturbation.stream(self.dt, gait.n_joints, None, size=batch,
                                                      initial_state=initial)
        self.pose = np.zeros(batch + (3,))
        self.cycle = 0
        self.position = 0  # sample index within the current cycle
        self._period_since = (0, 0.0)  # the cycle from which the period holds, and its start time
        self._rms_key = None
        self._excitation = self._pending_excitation = None  # set_excitation: (δ, δ̇) on a phase grid

    @property
    def n_joints(self) -> int:
        """Shape dimension d."""
        return self._gait.n_joints

    @property
    def gait(self) -> FourierGait:
        """Nominal gait of the current cycle."""
        return self._gait

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` from the next cycle boundary on (immediately if at a boundary)."""
        if not isinstance(gait, FourierGait) or gait.n_joints != self._gait.n_joints:
            raise fail("gait", "SwimmerStream.set_gait",
                       f"a FourierGait with {self._gait.n_joints} joints", gait)
        if self.position == 0:
            self._gait = gait
        else:
            self._pending_gait = gait

    def set_excitation(self, shape, shape_velocity) -> None:
        """Run the next cycle (this one, at a boundary) with this excitation instead of the SDE's.

        ``shape`` and ``shape_velocity`` (M, d) are δ and δ̇ (per second) at phases 2πk / M,
        interpolated at each sample's phase (what :class:`~geogait.optimize.InSituOptimizer` sends when
        it owns the exploration). The stream's own perturbation does not advance meanwhile.
        Single-trial streams only.
        """
        owner = "SwimmerStream.set_excitation"
        if self._batched:
            raise fail("self", owner, "a single-trial stream (n_trials=None)", "a batched stream")
        excitation = check_excitation(shape, shape_velocity, self.n_joints, owner)
        if self.position == 0:
            self._excitation = excitation
        else:
            self._pending_excitation = excitation

    @property
    def perturbation_std(self) -> float:
        """Stationary δ std (rad) of the perturbation in force."""
        return float(self.perturbation.stationary_std[0])

    def set_perturbation_std(self, std: float) -> None:
        """Run the following samples with δ std ``std`` (rad, ≥ 0): exploration sized online.

        Keeps the perturbation's spectrum (α, β of eq. 8) and scales η; the SDE state (δ, δ̇) and the
        random generators carry over, so δ stays continuous, relaxes to the new size with the time
        constant 2/α, and two streams with one seed and one schedule of sizes draw the same noise.
        """
        std = check_float(std, "std", "SwimmerStream.set_perturbation_std", low=0)
        if np.isclose(std, self.perturbation_std, rtol=1e-12, atol=0):
            return  # the size in force: nothing changes, to the last bit
        base = self.perturbation
        eta = std * np.sqrt(2 * base.alpha * base.beta)  # stationary std of δ: η / √(2αβ)
        self.perturbation = Perturbation(alpha=base.alpha, beta=base.beta, eta=eta)
        self._restart_perturbation()

    def set_cycle_period(self, seconds: float) -> None:
        """Run the following cycles at period ``seconds`` (the same samples per cycle; at a cycle
        boundary only): the shape path is the same, run faster or slower. The perturbation's SDE state
        and generators carry over; time goes on from where the last cycle ended."""
        owner = "SwimmerStream.set_cycle_period"
        seconds = check_float(seconds, "seconds", owner, low=0, low_open=True)
        if self.position != 0:
            raise fail("self", owner, "a stream at a cycle boundary", f"sample {self.position} of a cycle")
        if seconds == self.cycle_period:
            return
        start = (self.cycle - self._period_since[0]) * self.cycle_period + self._period_since[1]
        self._period_since = (self.cycle, start)
        self._apply_period(seconds)

    def _apply_period(self, seconds: float) -> None:
        self.cycle_period, self.dt, self.phase_rate = seconds, seconds / self.samples_per_cycle, 2 * np.pi / seconds
        self._restart_perturbation()

    def _restart_perturbation(self) -> None:
        """The SDE stream anew for the current δ size and time step, from the state it has reached."""
        state = self._perturbation.state
        self._perturbation = self.perturbation.stream(self.dt, self.n_joints, None, size=state.shape[:-2],
                                                      initial_state=state)

    def robot_state(self) -> dict:
        """Everything that determines the rest of the stream: generators, SDE state, δ std, pose, gait.

        JSON values and NumPy arrays (what an optimiser checkpoint stores);
        :meth:`restore_robot_state` puts a stream built with the same arguments back exactly.
        """
        state = {"cycle": self.cycle, "position": self.position,
                 "perturbation_rngs": [rng.bit_generator.state for rng in self._perturbation_rngs],
                 "noise_rngs": [rng.bit_generator.state for rng in self._noise_rngs],
                 "perturbation_state": self._perturbation.state.copy(), "perturbation_std": self.perturbation_std,
                 "pose": self.pose.copy(), "gait": self._gait.coefficients.copy(),
                 "cycle_period": self.cycle_period, "period_since": list(self._period_since)}
        if self._pending_gait is not None:
            state["pending_gait"] = self._pending_gait.coefficients.copy()
        for name, excitation in (("excitation", self._excitation), ("pending_excitation", self._pending_excitation)):
            if excitation is not None:
                state[f"{name}_shape"], state[f"{name}_shape_velocity"] = (v.copy() for v in excitation)
        return state

    def restore_robot_state(self, state: dict) -> None:
        """Inverse of :meth:`robot_state` (checks that the state fits this stream first)."""
        owner = "SwimmerStream.restore_robot_state"
        try:
            rngs = [list(state[k]) for k in ("perturbation_rngs", "noise_rngs")]
            arrays = {k: np.asarray(state[k], dtype=float) for k in ("perturbation_state", "pose", "gait")}
            cycle, position = check_int(state["cycle"], "cycle", owner, minimum=0), \
                check_int(state["position"], "position", owner, minimum=0)
        except (KeyError, TypeError) as error:
            raise fail("state", owner, "a dict from SwimmerStream.robot_state()", f"missing or bad {error}") from None
        if any(len(r) != len(self._perturbation_rngs) for r in rngs) or \
                arrays["perturbation_state"].shape != self._perturbation.state.shape or \
                arrays["pose"].shape != self.pose.shape or position >= self.samples_per_cycle:
            raise fail("state", owner, "the state of a stream with the same trials and joints", "another shape")
        gait = FourierGait(arrays["gait"])
        if gait.n_joints != self._gait.n_joints:
            raise fail("state", owner, f"a gait with {self._gait.n_joints} joints", gait.n_joints)
        period = check_float(state.get("cycle_period", self.cycle_period), "cycle_period", owner, low=0,
                             low_open=True)
        if state.get("perturbation_std") is not None:  # states saved before sizes could change lack it
            self.set_perturbation_std(state["perturbation_std"])  # checked before anything else changes
        if period != self.cycle_period:  # states saved before the period could change lack it
            self._apply_period(period)
        since = state.get("period_since", (0, 0.0))
        self._period_since = (int(since[0]), float(since[1]))
        for generator, saved in zip(self._perturbation_rngs + self._noise_rngs, rngs[0] + rngs[1], strict=True):
            generator.bit_generator.state = saved
        self._perturbation.state = arrays["perturbation_state"].copy()
        self.pose = arrays["pose"].copy()
        self.cycle, self.position, self._gait = cycle, position, gait
        self._pending_gait = FourierGait(np.asarray(state["pending_gait"], dtype=float)) \
            if state.get("pending_gait") is not None else None
        self._excitation, self._pending_excitation = (
            (np.asarray(state[f"{name}_shape"], dtype=float), np.asarray(state[f"{name}_shape_velocity"], dtype=float))
            if state.get(f"{name}_shape") is not None else None for name in ("excitation", "pending_excitation"))

    def chain_geometry(self) -> dict:
        """The swimmer's link lengths, body frame and frame offset: the geometry
        :class:`~geogait.models.ResistanceModel` takes as known (``ResistanceModel(**stream.chain_geometry())``).

        Raises :class:`~geogait.GeogaitError` when the stream's system is not a
        :class:`~geogait.systems.PurcellSwimmer`.
        """
        if not isinstance(self.system, PurcellSwimmer):
            raise GeogaitError(f"SwimmerStream.chain_geometry: the stream's system is a {type(self.system).__name__}, "
                               "not a chain of links (PurcellSwimmer).")
        return {"link_lengths": self.system.link_lengths, "body_frame": self.system.body_frame,
                "frame_offset": self.system.frame_offset}

    def current_system(self) -> System:
        """The system in force for the current cycle (after the environment schedule)."""
        return self.system if self.environment is None else self.environment(self.cycle)

    def next_sample(self) -> Trajectory:
        """The next single sample (arrays with a time axis of length 1)."""
        return self._generate(1)

    def next_cycle(self) -> Trajectory:
        """The rest of the current cycle (a whole cycle when called at a boundary)."""
        return self._generate(self.samples_per_cycle - self.position)

    def next_cycles(self, n_cycles: int) -> Trajectory:
        """``n_cycles`` whole cycles, joined along time."""
        n_cycles = check_int(n_cycles, "n_cycles", "SwimmerStream.next_cycles", minimum=1)
        return Trajectory.concatenate([self.next_cycle() for _ in range(n_cycles)])

    def _noise_scale(self, system: System) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-component RMS of ξ, r and ṙ along the nominal gait (cached per system and gait)."""
        key = (id(system), self._gait, self.cycle_period)
        if self._rms_key != key:
            phase = 2 * np.pi * np.arange(self.samples_per_cycle) / self.samples_per_cycle
            signals = _nominal_signals(system, self._gait, phase, self.phase_rate)
            rms = [np.sqrt(np.mean(v**2, axis=0)) for v in signals]
            self._rms_key, self._rms = key, rms
        return self._rms

    def _generate(self, m: int) -> Trajectory:
        system, gait = self.current_system(), self._gait
        d = gait.n_joints
        index = self.position + np.arange(m)
        phase = 2 * np.pi * index / self.samples_per_cycle
        time = (self.cycle - self._period_since[0] + index / self.samples_per_cycle) * self.cycle_period \
            + self._period_since[1]
        if self._excitation is not None:
            state = np.stack(excitation_at(phase, *self._excitation), axis=-1)[None]
        else:
            white = np.stack([rng.standard_normal((m, d, 2)) for rng in self._perturbation_rngs])
            state = self._perturbation.run(white)
        shape = gait.shape(phase) + state[..., 0]
        shape_velocity = gait.velocity(phase) * self.phase_rate + state[..., 1]
        body_velocity = -np.einsum("...ij,...j->...i", system.connection(shape), shape_velocity)
        pose = se2.integrate_body_velocity(body_velocity, self.dt, self.pose)
        self.pose = pose[..., -1, :]
        measured = self._measure(system, shape, shape_velocity, body_velocity, m)
        cycle = np.full(m, self.cycle)
        self._advance(m)
        batch = (len(self._perturbation_rngs),)
        arrays = dict(time=np.broadcast_to(time, batch + (m,)).copy(),
                      phase=np.broadcast_to(phase, batch + (m,)).copy(),
                      cycle=np.broadcast_to(cycle, batch + (m,)).copy(),
                      shape=measured[0], shape_velocity=measured[1], body_velocity=measured[2],
                      pose=pose[..., :-1, :], commanded_shape=shape)
        if not self._batched:
            arrays = {k: v[0] for k, v in arrays.items()}
        return Trajectory(**arrays)

    def _measure(self, system, shape, shape_velocity, body_velocity, m):
        """Add sensor noise; every sample draws 3 + 2d normals so any chunking gives equal data."""
        if self.sensor_noise == 0 and self.shape_noise == 0:
            return shape, shape_velocity, body_velocity
        d = shape.shape[-1]
        noise = np.stack([rng.standard_normal((m, 3 + 2 * d)) for rng in self._noise_rngs])
        body_rms, shape_rms, rate_rms = self._noise_scale(system)
        return (shape + self.shape_noise * shape_rms * noise[..., 3:3 + d],
                shape_velocity + self.shape_noise * rate_rms * noise[..., 3 + d:],
                body_velocity + self.sensor_noise * body_rms * noise[..., :3])

    def _advance(self, m: int) -> None:
        self.position += m
        if self.position == self.samples_per_cycle:
            self.position = 0
            self.cycle += 1
            if self._pending_gait is not None:
                self._gait, self._pending_gait = self._pending_gait, None
            self._excitation, self._pending_excitation = self._pending_excitation, None


def simulate(system: System, gait: FourierGait, n_cycles: int, **options) -> Trajectory:
    """Simulate ``n_cycles`` cycles of ``gait`` on ``system``.

    Parameters
    ----------
    system : System
    gait : FourierGait
    n_cycles : int
    **options
        Any keyword of :class:`SwimmerStream` (``samples_per_cycle``, ``perturbation``,
        ``sensor_noise``, ``shape_noise``, ``environment``, ``seed``, ``n_trials``,
        ``cycle_period``).

    Returns
    -------
    Trajectory
        Arrays of shape ``(n_cycles * samples_per_cycle, ...)``, with a leading trial axis when
        ``n_trials`` is given or ``seed`` is a sequence.

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, seed=0)
    >>> run.shape.shape, run.body_velocity.shape
    ((200, 2), (200, 3))
    """
    n_cycles = check_int(n_cycles, "n_cycles", "simulate", minimum=1)
    return SwimmerStream(system, gait, **options).next_cycles(n_cycles)


def simulate_rate(system: System, gait: FourierGait, n_cycles: float, *, samples_per_cycle: float = 100.0,
                  rate_ramp: tuple[float, float] = (1.0, 1.0), cycle_period: float = 1.0,
                  perturbation: Perturbation | None = None, sensor_noise: float = 0.0, shape_noise: float = 0.0,
                  seed=None) -> Trajectory:
    r"""Simulate ``gait`` on ``system`` at any (non-integer) samples per cycle and a drifting phase rate.

    :func:`simulate` always puts exactly ``samples_per_cycle`` (an int) samples in every cycle, at
    a constant phase rate. A robot does neither; this simulator samples uniformly in time with
    step :math:`\Delta t = T / s` (:math:`T` = ``cycle_period``, :math:`s` = ``samples_per_cycle``,
    any real) while the commanded phase rate ramps linearly in time from :math:`m_0 \omega_0` to
    :math:`m_1 \omega_0` (:math:`\omega_0 = 2\pi / T`, :math:`(m_0, m_1)` = ``rate_ramp``) over the
    duration :math:`D` that makes ``n_cycles`` cycles:

    .. math::
        \dot\phi(t) = \omega_0 \bigl(m_0 + (m_1 - m_0)\, t / D\bigr), \qquad
        \phi(t) = \omega_0 \bigl(m_0 t + (m_1 - m_0)\, t^2 / (2 D)\bigr), \qquad
        D = \frac{2 n T}{m_0 + m_1}.

    Shapes, rates and body velocities follow the model of :class:`SwimmerStream` (module notes),
    with :math:`\dot r = \theta'(\phi)\dot\phi + \dot\delta`; the perturbation SDE runs in time.

    Parameters
    ----------
    system : System
    gait : FourierGait
    n_cycles : float > 0
        Commanded cycles (need not be whole); samples are taken while :math:`\phi < 2\pi n`.
    samples_per_cycle : float
        Samples per cycle at the nominal rate (:math:`m = 1`), any real in [4, 100000].
    rate_ramp : (float, float)
        Phase-rate multipliers :math:`(m_0, m_1)` at the start and the end, each in [0.1, 10];
        every cycle must keep at least 4 samples (:math:`s / \max m \ge 4`). ``(0.8, 1.2)`` is a
        rate drifting by ±20 % about the nominal one.
    cycle_period : float > 0
        Nominal cycle duration :math:`T`.
    perturbation : Perturbation, optional
        SDE of eq. 8; default ``Perturbation()``. ``Perturbation(eta=0)`` for none.
    sensor_noise, shape_noise : float
        Noise on measured ξ, and on r and ṙ, as fractions of their RMS along the nominal gait at the
        nominal rate (as in :class:`SwimmerStream`).
    seed : int or SeedSequence, optional

    Returns
    -------
    Trajectory
        One trial; ``phase`` is the commanded phase wrapped to ``[0, 2π)`` and ``cycle`` its cycle
        index, so the continuous phase is ``phase + 2π cycle``.

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> run = simulate_rate(PurcellSwimmer(3), seed_gait(2), 3, samples_per_cycle=86.5, seed=0)
    >>> run.n_samples, int(run.cycle[-1])
    (260, 2)
    >>> drift = simulate_rate(PurcellSwimmer(3), seed_gait(2), 10, rate_ramp=(0.8, 1.2), seed=0)
    >>> steps = np.diff(drift.phase + 2 * np.pi * drift.cycle)  # phase per sample: 0.8 → 1.2 times nominal
    >>> round(float(steps[-1] / steps[0]), 2)
    1.5
    """
    owner = "simulate_rate"
    if not isinstance(gait, FourierGait):
        raise fail("gait", owner, "a FourierGait", type(gait).__name__)
    if gait.n_joints != system.n_joints:
        raise fail("gait", owner, f"a gait with {system.n_joints} joints", gait.n_joints)
    n_cycles = check_float(n_cycles, "n_cycles", owner, low=0, low_open=True)
    per_cycle = check_float(samples_per_cycle, "samples_per_cycle", owner, low=4, high=100_000)
    period = check_float(cycle_period, "cycle_period", owner, low=0, low_open=True)
    sensor_noise = check_float(sensor_noise, "sensor_noise", owner, low=0, high=MAX_SENSOR_NOISE)
    shape_noise = check_float(shape_noise, "shape_noise", owner, low=0, high=MAX_SENSOR_NOISE)
    if isinstance(rate_ramp, str) or not isinstance(rate_ramp, Sequence) or len(rate_ramp) != 2:
        raise fail("rate_ramp", owner, "a pair (start, end) of rate multipliers", rate_ramp)
    start, end = (check_float(m, "rate_ramp", owner, low=0.1, high=10) for m in rate_ramp)
    if per_cycle / max(start, end) < 4:
        raise fail("rate_ramp", owner, f"at most samples_per_cycle / 4 = {per_cycle / 4:g} (every cycle needs "
                   "at least 4 samples)", tuple(rate_ramp))
    perturbation = Perturbation() if perturbation is None else perturbation
    if not isinstance(perturbation, Perturbation):
        raise fail("perturbation", owner, "a Perturbation", type(perturbation).__name__)
    dt, omega = period / per_cycle, 2 * np.pi / period
    duration = 2 * n_cycles * period / (start + end)
    n_samples = int(np.ceil(duration / dt - 1e-9))
    if n_samples * gait.n_joints > 10**7:
        raise fail("n_cycles", owner, "small enough for at most 10^7 sample values",
                   f"{n_samples} samples of {gait.n_joints} joints")
    (perturbation_rng,), (noise_rng,), _ = _trial_generators(seed, None)
    time = np.arange(n_samples) * dt
    rate = omega * (start + (end - start) * time / duration)
    unwrapped = omega * (start * time + (end - start) * time**2 / (2 * duration))
    stream = perturbation.stream(dt, gait.n_joints, perturbation_rng)
    state = stream.run(perturbation_rng.standard_normal((n_samples, gait.n_joints, 2)))
    shape = gait.shape(unwrapped) + state[..., 0]
    shape_velocity = gait.velocity(unwrapped) * rate[:, None] + state[..., 1]
    body_velocity = -np.einsum("nij,nj->ni", system.connection(shape), shape_velocity)
    pose = se2.integrate_body_velocity(body_velocity, dt, np.zeros(3))[:-1]
    measured = (shape, shape_velocity, body_velocity)
    if sensor_noise or shape_noise:
        nominal = 2 * np.pi * np.arange(4096) / 4096
        rms = [np.sqrt(np.mean(v**2, axis=0)) for v in _nominal_signals(system, gait, nominal, omega)]
        noise = noise_rng.standard_normal((n_samples, 3 + 2 * gait.n_joints))
        d = gait.n_joints
        measured = (shape + shape_noise * rms[1] * noise[:, 3:3 + d],
                    shape_velocity + shape_noise * rms[2] * noise[:, 3 + d:],
                    body_velocity + sensor_noise * rms[0] * noise[:, :3])
    cycle = np.floor(unwrapped / (2 * np.pi))
    return Trajectory(time=time, phase=unwrapped - 2 * np.pi * cycle, cycle=cycle.astype(int),
                      shape=measured[0], shape_velocity=measured[1], body_velocity=measured[2], pose=pose,
                      commanded_shape=shape)


def _nominal_signals(system: System, gait: FourierGait, phase: np.ndarray, rate: float):
    """ξ, r and ṙ ``(n, ·)`` along the nominal gait at ``phase`` ``(n,)`` and a constant phase ``rate``."""
    shape = gait.shape(phase)
    velocity = gait.velocity(phase) * rate
    return -np.einsum("nij,nj->ni", system.connection(shape), velocity), shape, velocity
