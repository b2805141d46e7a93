r"""PyElastica's continuum snake as a :class:`~geogait.robots.Robot`, actuated by rest curvature.

The body is the Cosserat rod of PyElastica's classic continuum snake (``examples/ContinuumSnakeCase``,
after Zhang et al., Nat. Commun. 2021): a rod of length 0.35 m and density 1000 kg/m³, Young's
modulus 1 MPa, Poisson ratio 0.5, lying on a plane under gravity with anisotropic kinetic friction
(forward : backward : lateral = 1 : 1.5 : 2, set by a Froude number 0.1) and PyElastica's analytical
linear damping (2e-3), held in the ground plane by default (``planar``: no rolling or lifting). What
differs is the actuation, which is geogait's: instead of the example's travelling wave of muscle
torques, the rod's **rest curvature** follows a commanded modal shape at every physics step,

.. math::
    \phi = 2\pi t / T,\qquad r_{cmd} = \theta(\phi) + \delta,\qquad \kappa^0(s) = B(s)\, r_{cmd}

with θ the nominal gait, δ the exploration perturbation of eq. 8
(:class:`~geogait.gaits.Perturbation`, time in seconds, integrated exactly at the physics step as
in :class:`~geogait.robots.MujocoRobot`) and B the modal basis of
:class:`~geogait.robots.CurvatureModes`. The rod's elasticity pulls it towards that rest shape
against friction and inertia, so the **realised** shape lags and falls short of the commanded one;
both are logged.

**Measurement** (:mod:`geogait.robots.continuum`, numpy only). PyElastica's rod moves in its x–z
plane with y up; geogait's plane is (x, y) = (z, x) of PyElastica (a proper rotation seen from
above), so the rod, laid along PyElastica's z-axis, starts at heading 0. At every sample the node
positions and velocities give the pose (centre of mass, mean tangent angle), the body velocity ξ,
and the shape: the discrete curvature profile projected on the modes (least squares), with its
exact rate.

**Speed.** The defaults are 20 elements, a 1 s period and a timestep of 0.25 ms: 4000 steps per cycle,
after numba's one-time compilation. The stable timestep of the
explicit integrator is set by the rod's shear–rotation mode, :math:`\Delta t \lesssim 0.85\, r /
\sqrt{G/\rho}` (r radius, G shear modulus): the classic example's slender rod (r = 0.011 L) needs
0.1 ms, so the default radius is 0.03 L (aspect ratio 33), which allows 0.25 ms and also lets the
rest curvature be tracked closely. The friction coefficients are fixed in N/N (by default the
classic Froude number 0.1 at a 1 s period, μ = 0.36), so the same robot runs at any cycle period.

pyelastica is an optional dependency (``pip install 'geogait[elastica]'``), imported only when a
snake is built, so ``import geogait.robots`` works without it.
"""

from __future__ import annotations

import numpy as np

from .._defaults import MAX_JOINT_ANGLE
from .._validation import GeogaitError, check_array, check_choice, check_float, check_int, fail
from ..gaits import FourierGait, Perturbation, check_excitation, excitation_at
from ..simulate import Trajectory
from ._simulated import SimulatedRobot
from .continuum import CurvatureModes, body_pose, body_velocity, curvature_profile, curvature_rate

__all__ = ["ElasticaSnake", "elastica_snake", "snake_seed_gait"]

_INSTALL = "pip install 'geogait[elastica]'"
_GRAVITY = 9.80665
#: Largest timestep × √(G/ρ) / radius of the default integrator that PyElastica runs stably (measured
#: 0.74 stable, 0.98 unstable over radii 0.011–0.03 L); the check leaves a margin below it.
_STABILITY = 0.8
#: Stretch (or squash) of an element beyond which the rod is broken: a resolved run of the benchmark's snake
#: stays within 1.05× of rest, a broken one reaches 8–140× within a cycle.
_BROKEN_STRETCH = 1.5


def _elastica():
    """The ``elastica`` module (pyelastica), or an ImportError that says what to install."""
    try:
        import elastica
    except ImportError as error:
        raise ImportError(
            f"geogait's ElasticaSnake needs the optional dependency 'pyelastica': {_INSTALL}") from error
    return elastica


def _blend(start: FourierGait, end: FourierGait, weight: float) -> FourierGait:
    """The gait whose shape is (1 − weight) × ``start``'s + weight × ``end``'s (shape is linear in the
    coefficients, written in the higher of the two orders)."""
    order = max(start.order, end.order)
    return FourierGait((1 - weight) * start.with_order(order).coefficients
                       + weight * end.with_order(order).coefficients)


def snake_seed_gait(n_modes: int = 4, amplitude: float = 1.0) -> FourierGait:
    r"""A travelling curvature wave, one wavelength per body, running from head to tail.

    On the ``"fourier"`` modes of :class:`~geogait.robots.CurvatureModes`, q_0 = a cos φ and
    q_1 = a sin φ (the other modes zero) bend the body into
    :math:`\kappa(s, \phi) = (2\pi a / L) \sin(2\pi s / L + \phi)`: a wave that moves towards the
    tail (s = 0) as φ grows and drives the snake head first (forward, +x of its body frame).

    Parameters
    ----------
    n_modes : int >= 2
    amplitude : float > 0
        Tangent-angle amplitude a (rad).

    Returns
    -------
    FourierGait
        Order 1, shape (n_modes, 3).
    """
    n_modes = check_int(n_modes, "n_modes", "snake_seed_gait", minimum=2)
    amplitude = check_float(amplitude, "amplitude", "snake_seed_gait", low=0, low_open=True)
    coefficients = np.zeros((n_modes, 3))
    coefficients[0, 1] = amplitude
    coefficients[1, 2] = amplitude
    return FourierGait(coefficients)


class ElasticaSnake(SimulatedRobot):
    """PyElastica's continuum snake on rest-curvature control (implements :class:`~geogait.robots.Robot`).

    Parameters
    ----------
    n_modes : int >= 2
        Shape dimension d: modal coordinates of the curvature (:class:`~geogait.robots.CurvatureModes`).
    modes : {"fourier", "legendre"}
        Modal basis. The default seed gait needs ``"fourier"``; with ``"legendre"`` pass ``gait``.
    gait : FourierGait, optional
        Initial nominal gait; default :func:`snake_seed_gait` (n_modes, 1.0 rad).
    cycle_period : float > 0
        Seconds per gait cycle T; a multiple of ``samples_per_cycle`` × ``timestep``.
    samples_per_cycle : int >= 4
    timestep : float > 0
        Physics step (s); at most 0.8 r / √(G/ρ) (module docstring), checked.
    n_elements : int >= 8
        Elements of the rod (the curvature is measured at its n_elements − 1 interior nodes).
    length, radius, density, youngs_modulus, poisson_ratio : float
        The rod (m, m, kg/m³, Pa, —); shear modulus E / (1 + ν). Default radius 0.03 L.
    friction : array-like of 3 floats, optional
        Kinetic friction coefficients (forward, backward, lateral); default μ (1, 1.5, 2) with
        μ = L / (g · 0.1 · 1 s²), the classic example's Froude number 0.1 at a 1 s period.
    damping : float >= 0
        PyElastica's ``AnalyticalLinearDamper`` damping constant (1/s).
    perturbation : Perturbation, optional
        Exploration δ (time in seconds); default ``Perturbation.from_std(0.15 a, frequency=2 / T)``
        with a the seed gait's largest modal amplitude (15 % of it, two oscillations per cycle).
        ``Perturbation(eta=0)`` for none.
    max_joint_angle : float > 0
        Largest modal amplitude a gait may command (rad of tangent-angle wave); gives
        ``joint_ranges``. The default 2π/3 is :class:`~geogait.optimize.InSituOptimizer`'s default
        r_max (a one-wavelength wave of that amplitude does not yet cross itself; the rod has no
        self-contact).
    warmup_cycles : int >= 0
        Cycles run (not returned) before cycle 0, with the commanded shape ramped up from the straight
        rod over the first of them.
    switch_cycles : int >= 0
        Cycles over which the commanded shape moves, linearly in time, from the gait it ran to one that
        :meth:`set_gait` gives, so that the command stays continuous. An instant switch between two large
        gaits jumps the rest curvature faster than the explicit integrator follows, and the rod breaks
        (elements stretched to tens of times their rest length). 0 switches at the next cycle's start.
    planar : bool
        Hold the rod in the ground plane (default): every node keeps its height and every element
        turns about the vertical only (PyElastica's ``GeneralConstraint``). Without it the rod is free
        in 3-D, as in the classic example, and under large curvature commands (0.25 rad exploration)
        it can roll over and lift off the ground, after which a planar body frame and curvature
        mean nothing.
    seed : int or numpy.random.SeedSequence, optional
        Seed of the perturbation.

    Attributes
    ----------
    modes : CurvatureModes
    arc_length : ndarray of shape (n_elements - 1,)
        Rest arc length of the interior nodes (where curvature is commanded and measured).
    joint_ranges : ndarray of shape (d, 2)
        ±``max_joint_angle`` per mode.
    steps_per_sample : int
    cycle : int
        Index of the cycle :meth:`next_cycle` runs next.
    rod, simulator
        The PyElastica ``CosseratRod`` and its system collection.

    Examples
    --------
    >>> snake = ElasticaSnake(seed=0)          # doctest: +SKIP
    >>> cycle = snake.next_cycle()             # doctest: +SKIP
    >>> cycle.shape.shape, cycle.pose.shape    # doctest: +SKIP
    ((100, 4), (100, 3))
    """

    def __init__(self, *, n_modes: int = 4, modes: str = "fourier", gait: FourierGait | None = None,
                 cycle_period: float = 1.0, samples_per_cycle: int = 100, timestep: float = 2.5e-4,
                 n_elements: int = 20, length: float = 0.35, radius: float | None = None, density: float = 1000.0,
                 youngs_modulus: float = 1e6, poisson_ratio: float = 0.5, friction=None, damping: float = 2e-3,
                 perturbation: Perturbation | None = None, max_joint_angle: float = MAX_JOINT_ANGLE,
                 warmup_cycles: int = 1, switch_cycles: int = 1, planar: bool = True, seed=None):
        owner = "ElasticaSnake"
        d = check_int(n_modes, "n_modes", owner, minimum=2)
        kind = check_choice(modes, "modes", owner, ("fourier", "legendre"))
        self.cycle_period = check_float(cycle_period, "cycle_period", owner, low=0, low_open=True)
        self.samples_per_cycle = check_int(samples_per_cycle, "samples_per_cycle", owner, minimum=4)
        self.timestep = check_float(timestep, "timestep", owner, low=0, low_open=True)
        self.n_elements = check_int(n_elements, "n_elements", owner, minimum=8)
        self.length = check_float(length, "length", owner, low=0, low_open=True)
        self.radius = check_float(0.03 * self.length if radius is None else radius, "radius", owner,
                                  low=0, low_open=True)
        self.density = check_float(density, "density", owner, low=0, low_open=True)
        self.youngs_modulus = check_float(youngs_modulus, "youngs_modulus", owner, low=0, low_open=True)
        self.poisson_ratio = check_float(poisson_ratio, "poisson_ratio", owner, low=0, high=0.5)
        self.damping = check_float(damping, "damping", owner, low=0)
        self.max_joint_angle = check_float(max_joint_angle, "max_joint_angle", owner, low=0, low_open=True)
        self.warmup_cycles = check_int(warmup_cycles, "warmup_cycles", owner, minimum=0)
        self.switch_cycles = check_int(switch_cycles, "switch_cycles", owner, minimum=0)
        if not isinstance(planar, bool | np.bool_):
            raise fail("planar", owner, "a bool", planar)
        self.planar = bool(planar)
        if friction is None:
            mu = self.length / (_GRAVITY * 0.1 * 1.0**2)
            self.friction = np.array([mu, 1.5 * mu, 2.0 * mu])
        else:
            self.friction = check_array(friction, "friction", owner, ndim=1)
            if self.friction.shape != (3,) or np.any(self.friction < 0):
                raise fail("friction", owner, "3 non-negative coefficients (forward, backward, lateral)", friction)
        self.steps_per_sample = self._resolve_steps()
        self._check_stability()
        self.modes = CurvatureModes(d, kind, self.length)
        spacing = self.length / self.n_elements
        self.arc_length = spacing * np.arange(1, self.n_elements)
        self._basis = self.modes.basis(self.arc_length)
        self._projector = self.modes.projector(self.arc_length)
        self.joint_ranges = np.tile([-self.max_joint_angle, self.max_joint_angle], (d, 1))
        if gait is None:
            if kind != "fourier":
                raise fail("gait", owner, "given when modes='legendre' (the seed gait is a Fourier-mode wave)", None)
            gait = snake_seed_gait(d)
        self._check_gait(gait, owner)
        self._gait = gait
        if perturbation is not None and not isinstance(perturbation, Perturbation):
            raise fail("perturbation", owner, "a geogait.gaits.Perturbation", type(perturbation).__name__)
        amplitude = float(gait.joint_limit().max())
        self.perturbation = (Perturbation.from_std(0.15 * amplitude, frequency=2 / self.cycle_period)
                             if perturbation is None else perturbation)
        if seed is not None and not isinstance(seed, int | np.integer | np.random.SeedSequence):
            raise fail("seed", owner, "an int, a numpy.random.SeedSequence or None", seed)
        self._rng = np.random.default_rng(seed)
        self._perturbation = self.perturbation.stream(self.timestep, d, self._rng)
        self.cycle = 0
        self._cycle_start = 0.0  # time stamp of the next cycle's first sample (s, from the end of the warm-up)
        self._closed = False
        self._ran = False  # whether the rod has been commanded (a switch blends only from a gait it ran)
        self._switch = None  # (the gait the command moves from, cycles of the switch run)
        self._build()
        self._heading = 0.0
        self._warm_up()

    # -- set-up -------------------------------------------------------------------------------
    def _resolve_steps(self) -> int:
        ratio = self.cycle_period / (self.samples_per_cycle * self.timestep)
        steps = int(round(ratio))
        if steps < 1 or abs(ratio - steps) > 1e-9 * max(ratio, 1.0):
            unit = self.samples_per_cycle * self.timestep
            raise fail("cycle_period", "ElasticaSnake",
                       f"a positive multiple of samples_per_cycle × timestep ({self.samples_per_cycle} × "
                       f"{self.timestep:g} s = {unit:g} s), e.g. {max(steps, 1) * unit:g}", self.cycle_period)
        return steps

    @property
    def shear_modulus(self) -> float:
        """G = E / (1 + ν) (Pa)."""
        return self.youngs_modulus / (1 + self.poisson_ratio)

    @property
    def max_timestep(self) -> float:
        """Largest timestep accepted: 0.8 r / √(G/ρ) (s)."""
        return _STABILITY * self.radius / np.sqrt(self.shear_modulus / self.density)

    def _check_stability(self) -> None:
        if self.timestep > self.max_timestep:
            raise fail("timestep", "ElasticaSnake",
                       f"at most {self.max_timestep:.3g} s for this rod (0.8 radius / √(G/ρ): the explicit "
                       "integrator is unstable beyond it; thicken the rod or lower the moduli)", self.timestep)

    def _check_gait(self, gait, owner: str) -> None:
        d = self.modes.n_modes
        if not isinstance(gait, FourierGait) or gait.n_joints != d:
            raise fail("gait", owner, f"a FourierGait with {d} modal coordinates", gait)
        if gait.joint_limit().max() > self.max_joint_angle + 1e-12:
            raise fail("gait", owner, f"a gait within max_joint_angle = {self.max_joint_angle:g} rad",
                       f"a gait reaching {gait.joint_limit().max():.4g} rad")

    def _build(self) -> None:
        ea = _elastica()

        class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping, ea.Contact):
            pass

        simulator = Simulator()
        up = np.array([0.0, 1.0, 0.0])
        rod = ea.CosseratRod.straight_rod(
            self.n_elements, np.zeros(3), np.array([0.0, 0.0, 1.0]), up, self.length, self.radius, self.density,
            youngs_modulus=self.youngs_modulus, shear_modulus=self.shear_modulus)
        simulator.append(rod)
        if self.planar:  # nodes stay on the ground, elements turn about the vertical only (no roll, no lift)
            simulator.constrain(rod).using(
                ea.GeneralConstraint, constrained_position_idx=tuple(range(self.n_elements + 1)),
                constrained_director_idx=tuple(range(self.n_elements)),
                translational_constraint_selector=np.array([False, True, False]),
                rotational_constraint_selector=np.array([True, False, True]))
        simulator.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=-_GRAVITY * up)
        ground = ea.Plane(plane_origin=-self.radius * up, plane_normal=up)
        simulator.append(ground)
        simulator.detect_contact_between(rod, ground).using(
            ea.RodPlaneContactWithAnisotropicFriction, k=1.0, nu=1e-6, slip_velocity_tol=1e-8,
            static_mu_array=np.zeros(3), kinetic_mu_array=self.friction.copy())
        if self.damping > 0:
            simulator.dampen(rod).using(ea.AnalyticalLinearDamper, damping_constant=self.damping,
                                        time_step=self.timestep)
        simulator.finalize()
        self.rod, self.simulator = rod, simulator
        self._stepper = ea.PositionVerlet()
        self._time = np.float64(0.0)
        self._excitation = None  # set_excitation: (δ, δ̇) on a phase grid for the next cycle
        self._masses = np.asarray(rod.mass, dtype=float).copy()

    def _warm_up(self) -> None:
        """From the straight rod, ramp the commanded shape up over the first warm-up cycle."""
        steps = self.steps_per_sample * self.samples_per_cycle
        for cycle in range(self.warmup_cycles):
            _, command = self._cycle_commands()
            ramp = np.minimum(1.0, (cycle * steps + np.arange(steps)) / steps)
            self._run(command * ramp[:, None], record=False)
            self._ran = True
        self._heading = float(body_pose(self._nodes()[0])[2])

    # -- the Robot protocol -------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Shape dimension d (number of modes)."""
        return self.modes.n_modes

    @property
    def gait(self) -> FourierGait:
        """Nominal gait of the next cycle."""
        return self._gait

    @property
    def mirror_symmetric(self) -> bool:
        """True: the body and the ground read the same in a mirror along the body's axis.

        The rod is straight and uniform at rest, its modal coordinates bend it through the rest
        curvature (negating them mirrors the commanded shape), friction is measured along and across
        its own tangent, and gravity is normal to the ground. So
        :class:`~geogait.optimize.InSituOptimizer`'s ``family="auto"`` searches the half-wave
        symmetric gaits (:class:`~geogait.gaits.MirrorGaitFamily`), which do not turn the snake.
        """
        return True

    def chain_geometry(self) -> dict:
        """The rod as a chain of its elements, for :class:`~geogait.models.ResistanceModel`.

        ``ResistanceModel(**snake.chain_geometry())``: the elements as equal links, the body frame at the centre
        of mass along the mean element angle (the pose this robot measures: :func:`~geogait.robots.continuum.
        body_pose`), and the shape map from the modal coordinates to each interior node's turning angle,
        the modal curvature there times the element length (:func:`~geogait.robots.continuum.curvature_profile`:
        κ_i = turning angle / element length on the undeformed rod). Only the geometry: the ground's Coulomb
        friction is not a resistive medium (``resistive_medium`` is not declared, so the default model stays
        the data-driven one), which the hybrid resistance model's residual share tells.

        Returns
        -------
        dict
            ``link_lengths`` (n_elements × length / n_elements), ``body_frame`` ``"center_of_mass"``,
            ``frame_offset`` None and ``shape_map`` ``(n_elements − 1, d)`` (nested tuples).
        """
        spacing = self.length / self.n_elements
        return {"link_lengths": (spacing,) * self.n_elements, "body_frame": "center_of_mass", "frame_offset": None,
                "shape_map": tuple(map(tuple, self._basis * spacing))}

    @property
    def n_physics_steps(self) -> int:
        """Physics steps per cycle: ``samples_per_cycle · steps_per_sample``."""
        return self.samples_per_cycle * self.steps_per_sample

    def set_cycle_period(self, cycle_period: float) -> None:
        """Run the following cycles at ``cycle_period`` seconds, the nearest the physics can time.

        A cycle is ``samples_per_cycle`` samples of a whole number of physics steps, so the period becomes
        the nearest multiple of ``samples_per_cycle × timestep`` (``cycle_period`` reads it back). The
        friction is the robot's, not re-scaled with the period: running faster raises the Froude number,
        as on a real snake. :class:`~geogait.optimize.InSituOptimizer` uses it with ``optimize_period=True``
        and for its model-class test (``model_class_cycles``).
        """
        unit = self.samples_per_cycle * self.timestep  # (a cycle of one physics step per sample)
        steps = self._units_per_cycle(cycle_period, unit, 1, f"at least one physics step per sample ({unit:g} s)")
        self.steps_per_sample = steps
        self.cycle_period = steps * unit

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` from the next cycle on; the command reaches it over ``switch_cycles`` cycles."""
        self._check_gait(gait, "ElasticaSnake.set_gait")
        if gait == self._gait:
            return
        start = self._switch_point() if self._ran and self.switch_cycles else None
        self._switch = None if start is None else (start, 0)
        self._gait = gait

    def _switch_point(self) -> FourierGait:
        """The gait the next cycle's command starts from (part way through a switch, the blend of its two)."""
        if self._switch is None:
            return self._gait
        start, done = self._switch
        return _blend(start, self._gait, done / self.switch_cycles)

    def set_excitation(self, shape, shape_velocity) -> None:
        """Run the next cycle with this excitation instead of the snake's own perturbation.

        Parameters
        ----------
        shape, shape_velocity : array-like of shape (M, d)
            Modal δ and δ̇ at phases 2πk / M (the rest curvature follows the commanded shape, so
            δ̇ is checked but not used).
        """
        self._excitation = check_excitation(shape, shape_velocity, self.n_joints, "ElasticaSnake.set_excitation")

    def _cycle_commands(self) -> tuple[np.ndarray, np.ndarray]:
        steps = self.n_physics_steps
        phase = 2 * np.pi * np.arange(steps) / steps
        if self._excitation is not None:
            delta, self._excitation = excitation_at(phase, *self._excitation)[0], None
        else:
            delta = self._perturbation.run(self._rng.standard_normal((steps, self.n_joints, 2)))[..., 0]
        if self._switch is None:
            return phase, self._gait.shape(phase) + delta
        start, done = self._switch
        weight = ((done + phase / (2 * np.pi)) / self.switch_cycles)[:, None]
        return phase, (1 - weight) * start.shape(phase) + weight * self._gait.shape(phase) + delta

    def _nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Node positions and velocities in geogait's plane, (n + 1, 2) each."""
        position, velocity = self.rod.position_collection, self.rod.velocity_collection
        return position[[2, 0]].T.copy(), velocity[[2, 0]].T.copy()

    def _run(self, command: np.ndarray, record: bool):
        """Step the physics with rest curvature B · command[step]; node samples if ``record``."""
        rest = command @ self._basis.T
        k, n = self.steps_per_sample, self.samples_per_cycle
        nodes = np.empty((n, self.n_elements + 1, 2)) if record else None
        rates = np.empty_like(nodes) if record else None
        rest_kappa, step, simulator, dt = self.rod.rest_kappa, self._stepper.step, self.simulator, self.timestep
        time = self._time
        for index in range(command.shape[0]):
            if record and index % k == 0:
                nodes[index // k], rates[index // k] = self._nodes()
            rest_kappa[0, :] = rest[index]
            time = step(simulator, time, dt)
        self._time = time
        self._check_rod()
        return nodes, rates

    def _check_rod(self) -> None:
        """Refuse a rod the integrator lost: non-finite, an element stretched or squashed beyond
        :data:`_BROKEN_STRETCH` of its rest length, or an element's frame turned against its tangent. A broken
        rod stays finite and goes on returning numbers, which no measurement may take."""
        rod = self.rod
        if not np.all(np.isfinite(rod.position_collection)):
            problem = "a non-finite rod state"
        else:
            stretch = np.asarray(rod.dilatation, dtype=float)
            aligned = np.einsum("in,in->n", rod.director_collection[2], rod.tangents)
            if np.any(np.abs(np.log(stretch)) > np.log(_BROKEN_STRETCH)):
                problem = f"an element at {stretch.max():.3g}× (or {stretch.min():.3g}×) its rest length"
            elif np.any(aligned < 0):
                problem = "an element's frame turned against its tangent"
            else:
                return
        raise GeogaitError(
            f"The ElasticaSnake simulation broke in cycle {self.cycle} ({problem}): lower the 'timestep' "
            f"({self.timestep:g} s), raise 'switch_cycles' ({self.switch_cycles}) or command a smaller curvature.")

    def next_cycle(self) -> Trajectory:
        """Run one gait cycle of the physics and return its ``samples_per_cycle`` samples.

        Returns
        -------
        Trajectory
            ``time`` (s), ``phase``, ``cycle``, measured modal ``shape`` and ``shape_velocity``
            (rad, rad/s), ``body_velocity`` (v_x, v_y, ω) in the body frame, world ``pose``
            (x, y, heading) of the body frame, and ``commanded_shape`` (nominal gait + perturbation).
        """
        if self._closed:
            raise GeogaitError("This ElasticaSnake was closed; build a new one to run more cycles.")
        phase, command = self._cycle_commands()
        nodes, rates = self._run(command, record=True)
        self._ran = True
        if self._switch is not None:
            start, done = self._switch
            self._switch = None if done + 1 == self.switch_cycles else (start, done + 1)
        k, n = self.steps_per_sample, self.samples_per_cycle
        pose = body_pose(nodes, masses=self._masses, reference_heading=self._heading)
        self._heading = float(pose[-1, 2])
        _, curvature = curvature_profile(nodes)
        shape = curvature @ self._projector.T
        shape_velocity = curvature_rate(nodes, rates) @ self._projector.T
        index = np.arange(n)
        trajectory = Trajectory(
            time=self._cycle_start + index * (self.cycle_period / n), phase=phase[::k].copy(),
            cycle=np.full(n, self.cycle), shape=shape, shape_velocity=shape_velocity,
            body_velocity=body_velocity(nodes, rates, masses=self._masses), pose=pose,
            commanded_shape=command[::k].copy())
        self.cycle += 1
        self._cycle_start += self.cycle_period
        return trajectory

    # -- extras -------------------------------------------------------------------------------
    _ROD_STATE = ("position_collection", "velocity_collection", "director_collection", "omega_collection")

    def robot_state(self) -> dict:
        """Everything that determines the following cycles, for a bit-identical restart.

        Returns
        -------
        dict
            The rod's ``position_collection``, ``velocity_collection``, ``director_collection``,
            ``omega_collection`` (the position-Verlet state), ``time``, ``perturbation`` (δ, δ̇ per
            mode), ``gait`` (coefficients), ``rng`` (the generator's state, JSON values), ``cycle``,
            ``heading`` (the unwrapped heading of the last sample), ``cycle_period``, ``cycle_start``
            (the next cycle's first time stamp), ``ran`` (the rod has been commanded) and the switch under
            way: ``switch_from`` (the coefficients it moves from, or None) and ``switch_done`` (its cycles run).
        """
        state = {name: np.array(getattr(self.rod, name)) for name in self._ROD_STATE}
        start, done = (None, 0) if self._switch is None else (np.array(self._switch[0].coefficients), self._switch[1])
        state.update({"time": float(self._time), **self._run_state(), "cycle_period": float(self.cycle_period),
                      "cycle_start": float(self._cycle_start), "ran": self._ran, "switch_from": start,
                      "switch_done": int(done)})
        return state

    def restore_robot_state(self, state: dict) -> None:
        """Continue exactly where the snake that wrote ``state`` (:meth:`robot_state`) was."""
        owner = "ElasticaSnake.restore_robot_state"
        self._check_state_keys(state, owner, (*self._ROD_STATE, "time"))
        arrays = {}
        for name in self._ROD_STATE:
            array = np.asarray(state[name], dtype=float)
            if array.shape != getattr(self.rod, name).shape:
                raise fail("state", owner, f"a {name} of shape {getattr(self.rod, name).shape} (this rod)",
                           f"shape {array.shape}")
            arrays[name] = array
        perturbation, gait = self._checked_run_state(state, owner)
        switch = self._checked_switch(state, owner)
        for name, array in arrays.items():
            getattr(self.rod, name)[...] = array
        self._time = np.float64(state["time"])
        self._restore_run_state(state, perturbation, gait)
        self._switch, self._ran = switch, bool(state.get("ran", True))
        if "cycle_period" in state:  # (states from before the period could change: the snake's own)
            self.set_cycle_period(float(state["cycle_period"]))
        self._cycle_start = float(state.get("cycle_start", self.cycle * self.cycle_period))

    def _checked_switch(self, state: dict, owner: str):
        """The switch under way in ``state`` (None in states from before switches were blended), checked."""
        if state.get("switch_from") is None:
            return None
        start = FourierGait(np.asarray(state["switch_from"], dtype=float))
        self._check_gait(start, owner)
        done = state.get("switch_done")
        if isinstance(done, bool) or not isinstance(done, int | np.integer) or not 0 <= done < self.switch_cycles:
            raise fail("state", owner, f"a switch_done from 0 to switch_cycles − 1 = {self.switch_cycles - 1}", done)
        return start, int(done)

    def close(self) -> None:
        """Drop the simulation; later cycles raise an error."""
        self._closed = True
        self.rod = self.simulator = None

    def __repr__(self):
        return (f"ElasticaSnake(n_modes={self.n_joints}, modes={self.modes.kind!r}, "
                f"cycle_period={self.cycle_period:g}, samples_per_cycle={self.samples_per_cycle}, "
                f"timestep={self.timestep:g}, n_elements={self.n_elements})")


def elastica_snake(**options) -> ElasticaSnake:
    """A ready :class:`ElasticaSnake` (the defaults: 4 Fourier modes, 1 s period, 20 elements).

    Parameters
    ----------
    **options
        Keywords of :class:`ElasticaSnake`.

    Returns
    -------
    ElasticaSnake
    """
    return ElasticaSnake(**options)
