r"""Any MuJoCo model with hinge joints as a :class:`~geogait.robots.Robot`.

geogait commands a nominal gait θ(φ); :class:`MujocoRobot` turns it into joint commands, runs the
model's own physics (fluid, contact, inertia: whatever the model defines) at the model's timestep,
and returns one cycle of measured samples. At every physics step of a cycle of period ``T``

.. math::
    \phi = 2\pi t / T,\qquad r_{cmd} = \theta(\phi) + \delta,\qquad
    \dot r_{cmd} = \theta'(\phi)\,\frac{2\pi}{T} + \dot\delta

with (δ, δ̇) the exploration perturbation of eq. 8 (:class:`~geogait.gaits.Perturbation`, its time
in seconds as in :class:`~geogait.simulate.SwimmerStream`), integrated exactly at the physics step.
The default, ``Perturbation.from_std(0.15, frequency=2 / cycle_period)``, explores like the paper's
at any period: δ std 0.15 rad, two oscillations per cycle. The joints track ``r_cmd`` with

* ``control="pd"``: a PD law on ``motor`` actuators,
  :math:`u = k_p (r_{cmd} - r) + k_d (\dot r_{cmd} - \dot r)`, clipped to the actuator's
  ``ctrlrange`` (that clip is how saturation shows: the realised gait falls short of the commanded
  one and ``shape`` departs from ``commanded_shape``);
* ``control="position"``: ``ctrl = r_cmd`` on ``position`` actuators (the model's own servo);
* ``control="computed_torque"``: the torque of floating-base inverse dynamics on ``motor`` actuators,
  the one that gives the joints the acceleration
  :math:`a = \ddot r_{cmd} + k_p (r_{cmd} - r) + k_d (\dot r_{cmd} - \dot r)` while the base moves
  freely under the model's own forces, clipped to ``ctrlrange`` (:math:`\ddot r_{cmd}`: the gait's
  acceleration, and the exploration's mean over each held torque). With the model's dynamics fed forward
  the joints follow the gait far more closely than a PD law can at a coarse control interval.

**Planar motion.** The robot moves in the model's x-y plane: the pose of the chosen body is
``(x, y, heading)`` from its ``xpos`` and ``xmat`` (heading = atan2 of the body x-axis, unwrapped
so that it is continuous), and its body velocity ξ = (v_x, v_y, ω) is
``mujoco.mj_objectVelocity(..., flg_local=1)`` at the body frame's origin, in the body frame. The
body's z-axis must point along the world z-axis (checked at construction).

mujoco is an optional dependency (``pip install 'geogait[mujoco]'``), imported only when a model is
loaded, so ``import geogait.robots`` works without it.
"""

from __future__ import annotations

import copy
import importlib.util
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .._defaults import MAX_JOINT_ANGLE
from .._validation import GeogaitError, check_choice, check_float, check_int, fail
from ..gaits import FourierGait, Perturbation, check_excitation, excitation_at, seed_gait
from ..simulate import Trajectory
from ._simulated import SimulatedRobot

__all__ = ["MujocoRobot", "dm_control_swimmer", "gymnasium_swimmer", "load_mujoco_model", "mujoco_swimmer",
           "purcell_swimmer_xml", "MODELS_DIRECTORY"]

#: Folder of the MuJoCo models shipped with geogait (``purcell3.xml``, ``purcell5.xml``).
MODELS_DIRECTORY = Path(__file__).parent / "models"

_INSTALL = "pip install 'geogait[mujoco]'"
_CONTROLS = ("pd", "position", "computed_torque")
_STARTS = ("gait", "rest")
#: Tracking error (rad) at which the default PD gains reach the actuator's ctrl limit.
_DEFAULT_SATURATION_ERROR = 0.05
#: Largest natural frequency × torque-update interval of a joint's inertia under the default PD gains (the PD law is
#: explicit: it sees the state at the start of each update).
_MAX_GAIN_FREQUENCY = 0.4
#: Largest ν_max × ω × interval under the default PD gains, with ν_max the largest eigenvalue of the joints'
#: normalised mobility (coupling through the other links and the free base). A held, critically damped PD turns
#: unstable where ν_max ω T reaches 1 (its damping, explicit, overshoots).
_MAX_COUPLED_FREQUENCY = 0.7
#: Natural frequency × torque-update interval of the tracking-error dynamics under computed torque (decoupled by
#: the inverse dynamics: a double integrator held for each interval, whose explicit PD is stable below 1).
_COMPUTED_TORQUE_FREQUENCY = 0.5


def _mujoco():
    """The ``mujoco`` module, or an ImportError that says what to install."""
    try:
        import mujoco
    except ImportError as error:
        raise ImportError(f"geogait's MuJoCo robots need the optional dependency 'mujoco': {_INSTALL}") from error
    return mujoco


def load_mujoco_model(source):
    """A ``mujoco.MjModel`` from a path, an XML string, a named model or a model.

    Parameters
    ----------
    source : str, pathlib.Path or mujoco.MjModel
        ``"geogait:purcell3"`` / ``"geogait:purcell5"`` (shipped with geogait),
        ``"gymnasium:swimmer"`` (any ``NAME.xml`` of the installed Gymnasium's
        ``envs/mujoco/assets``), a path to an MJCF file, an MJCF string (starts with ``<``) or an
        ``MjModel`` (returned as is).

    Returns
    -------
    mujoco.MjModel
    """
    mujoco = _mujoco()
    owner = "load_mujoco_model"
    if isinstance(source, mujoco.MjModel):
        return source
    if not isinstance(source, str | Path):
        raise fail("source", owner, "a path, an MJCF string, 'geogait:NAME', 'gymnasium:NAME' or a mujoco.MjModel",
                   type(source).__name__)
    text = str(source)
    if isinstance(source, str) and text.lstrip().startswith("<"):
        return mujoco.MjModel.from_xml_string(text)
    if isinstance(source, str) and text.startswith("geogait:"):
        path = MODELS_DIRECTORY / f"{text.split(':', 1)[1]}.xml"
        if not path.is_file():
            names = sorted(f"geogait:{p.stem}" for p in MODELS_DIRECTORY.glob("*.xml"))
            raise fail("source", owner, "one of " + ", ".join(names), text)
        return mujoco.MjModel.from_xml_path(str(path))
    if isinstance(source, str) and text.startswith("gymnasium:"):
        spec = importlib.util.find_spec("gymnasium")
        if spec is None or spec.origin is None:
            raise ImportError(f"'{text}' needs the optional dependency 'gymnasium': {_INSTALL}")
        assets = Path(spec.origin).parent / "envs" / "mujoco" / "assets"
        path = assets / f"{text.split(':', 1)[1]}.xml"
        if not path.is_file():
            names = sorted(f"gymnasium:{p.stem}" for p in assets.glob("*.xml"))
            raise fail("source", owner, "one of " + ", ".join(names), text)
        return mujoco.MjModel.from_xml_path(str(path))
    path = Path(text)
    if not path.is_file():
        raise fail("source", owner, "an existing MJCF file, an MJCF string or a named model", text)
    return mujoco.MjModel.from_xml_path(str(path))


def _is_real_sequence(value) -> bool:
    """A non-string sequence (or array) of real numbers, not booleans."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        return False
    return all(isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool | np.bool_)
               for v in np.asarray(value, dtype=object).ravel())


def _name(model, kind, index) -> str:
    return _mujoco().mj_id2name(model, kind, index) or f"#{index}"


class MujocoRobot(SimulatedRobot):
    """A MuJoCo model with hinge joints, driven cycle by cycle (implements :class:`~geogait.robots.Robot`).

    Parameters
    ----------
    model : str, pathlib.Path or mujoco.MjModel
        Anything :func:`load_mujoco_model` accepts. The robot owns a copy of an ``MjModel`` passed in.
    joints : sequence of str, optional
        Names of the hinge joints that form the shape r (in this order). Default: every hinge joint
        driven by an actuator, in the order of the actuators.
    body : str, optional
        Body whose frame gives the pose and body velocity. Default: the root body of the tree that
        holds the shape joints (the body carrying the free or planar base).
    gait : FourierGait, optional
        Initial nominal gait; default ``seed_gait(d, amplitude)`` with amplitude 1 rad or 80 % of
        the tightest joint range if that is smaller.
    cycle_period : float > 0
        Seconds per gait cycle T. Must be ``samples_per_cycle`` × an integer × the model's timestep.
    samples_per_cycle : int >= 4
        Samples recorded per cycle (the physics runs ``T / (samples_per_cycle · timestep)`` steps
        between samples).
    perturbation : Perturbation, optional
        Exploration δ of eq. 8, time in seconds; default ``Perturbation.from_std(0.15, frequency=2 /
        cycle_period)`` (δ std 0.15 rad, two oscillations per cycle). ``Perturbation(eta=0)`` for none.
    control : {"pd", "position", "computed_torque"}
        Joint tracking (module docstring): PD torque on ``motor`` actuators, the commanded shape as
        the ``ctrl`` of ``position`` actuators, or inverse-dynamics torque on ``motor`` actuators.
    kp, kd : float or array-like of shape (d,), optional
        ``control="pd"``: PD gains in ctrl units per rad and per rad/s. Default from the
        model: ``kp`` reaches the ctrl limit at a 0.05 rad error, capped so that the natural
        frequency of the joint's effective inertia 1 / (M⁻¹)_jj (every other degree of freedom
        free, at the initial pose) stays below ``0.4 / (timestep × control_interval)``, and below
        ``0.7 / (ν_max × timestep × control_interval)`` where the joints are coupled (ν_max: the largest
        eigenvalue of their normalised mobility D^-½ (M⁻¹)_JJ D^-½, D its diagonal; 1.64 on Gymnasium's
        swimmer, 2.5 on the Control Suite's; a held, critically damped PD turns unstable where ν_max ωT
        reaches 1); ``kd`` damps each joint critically. ``control="computed_torque"``: gains of the joints'
        commanded acceleration on their tracking error, in 1/s² and 1/s; default ω² and 2ω with
        ω = 0.5 / (timestep × control_interval) (critically damped error dynamics).
    control_interval : int >= 1
        Physics steps each torque is held for (``control="pd"`` or ``"computed_torque"``), counted from the
        start of each cycle: 1 computes it every step; an environment's ``frame_skip`` acts as its agent does
        (4 on Gymnasium's Swimmer-v5).
    seed : int or numpy.random.SeedSequence, optional
        Seed of the perturbation.
    start : {"gait", "rest"}
        Initial state: the joints on the commanded shape and velocity of phase 0 (``"gait"``), or every joint
        at the model's reference position and at rest (``"rest"``: a Gymnasium reset without its noise;
        the first cycle then drives the joints onto the gait).

    Attributes
    ----------
    model : mujoco.MjModel
    data : mujoco.MjData
    joint_names : tuple of str
    body_name : str
    steps_per_sample : int
        Physics steps between two samples.
    kp, kd : ndarray of shape (d,) or None
        Gains in use (None for position control).
    cycle : int
        Index of the cycle :meth:`next_cycle` runs next.

    Notes
    -----
    The joints start on the commanded shape and velocity of phase 0 (or, with ``start="rest"``, straight
    and still) and the base at rest at the model's reference pose. Samples are taken at the start of each
    sample interval, before the physics steps of that interval; ``time`` is ``cycle · T + n · T / samples_per_cycle``.

    Examples
    --------
    >>> robot = mujoco_swimmer(3, seed=0)
    >>> cycle = robot.next_cycle()
    >>> cycle.shape.shape, cycle.body_velocity.shape, float(cycle.time[1])
    ((100, 2), (100, 3), 0.01)
    """

    def __init__(self, model, *, joints=None, body: str | None = None, gait: FourierGait | None = None,
                 cycle_period: float = 1.0, samples_per_cycle: int = 100, perturbation: Perturbation | None = None,
                 control: str = "pd", kp=None, kd=None, control_interval: int = 1, seed=None, start: str = "gait"):
        mujoco = _mujoco()
        owner = "MujocoRobot"
        source = load_mujoco_model(model)
        self.model = copy.deepcopy(source) if source is model else source
        self.data = mujoco.MjData(self.model)
        self.control = check_choice(control, "control", owner, _CONTROLS)
        self.start = check_choice(start, "start", owner, _STARTS)
        self.control_interval = check_int(control_interval, "control_interval", owner, minimum=1)
        self.cycle_period = check_float(cycle_period, "cycle_period", owner, low=0, low_open=True)
        self.samples_per_cycle = check_int(samples_per_cycle, "samples_per_cycle", owner, minimum=4)
        self._joint_ids = self._resolve_joints(joints)
        d = len(self._joint_ids)
        self.joint_names = tuple(_name(self.model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in self._joint_ids)
        self._qpos = np.array([self.model.jnt_qposadr[j] for j in self._joint_ids])
        self._dof = np.array([self.model.jnt_dofadr[j] for j in self._joint_ids])
        self._actuators = self._resolve_actuators()
        self._body = self._resolve_body(body)
        self.body_name = _name(self.model, mujoco.mjtObj.mjOBJ_BODY, self._body)
        self.steps_per_sample = self._resolve_steps()
        if perturbation is not None and not isinstance(perturbation, Perturbation):
            raise fail("perturbation", owner, "a geogait.gaits.Perturbation", type(perturbation).__name__)
        self.perturbation = (Perturbation.from_std(0.15, frequency=2 / self.cycle_period) if perturbation is None
                             else perturbation)
        gait = self._default_gait(d) if gait is None else gait
        self._check_gait(gait, owner)
        self._gait = gait
        if seed is not None and not isinstance(seed, int | np.integer | np.random.SeedSequence):
            raise fail("seed", owner, "an int, a numpy.random.SeedSequence or None", seed)
        self._rng = np.random.default_rng(seed)
        steps_per_cycle = self.steps_per_sample * self.samples_per_cycle
        self._perturbation = self.perturbation.stream(self.cycle_period / steps_per_cycle, d, self._rng)
        self.kp, self.kd = self._resolve_gains(kp, kd)
        self.cycle = 0
        self._elapsed = 0.0  # seconds run before the current cycle (periods may change)
        self._excitation = None  # (δ, δ̇) on a phase grid for the next cycle, from set_excitation
        self._start(mujoco)

    # -- set-up -------------------------------------------------------------------------------
    def _resolve_joints(self, joints) -> list[int]:
        mujoco = _mujoco()
        model, owner = self.model, "MujocoRobot"
        hinge = mujoco.mjtJoint.mjJNT_HINGE
        names = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
        if joints is None:
            driven = [int(model.actuator_trnid[a, 0]) for a in range(model.nu)
                      if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT]
            ids = list(dict.fromkeys(j for j in driven if model.jnt_type[j] == hinge))
            if not ids:
                raise fail("joints", owner, "given: the model has no hinge joint driven by an actuator "
                           f"(joints: {', '.join(names) or 'none'})", None)
            return ids
        if isinstance(joints, str) or not isinstance(joints, Sequence) or not all(isinstance(j, str) for j in joints):
            raise fail("joints", owner, "a sequence of joint names", joints)
        ids = []
        for name in joints:
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if index < 0:
                raise fail("joints", owner, "names of joints of the model (" + ", ".join(names) + ")", name)
            if model.jnt_type[index] != hinge:
                kind = mujoco.mjtJoint(model.jnt_type[index]).name.removeprefix("mjJNT_").lower()
                raise fail("joints", owner, "names of hinge joints", f"{name!r}, a {kind} joint")
            ids.append(index)
        if not ids:
            raise fail("joints", owner, "a non-empty sequence of hinge joint names", joints)
        if len(set(ids)) != len(ids):
            raise fail("joints", owner, "distinct joint names", list(joints))
        return ids

    def _resolve_actuators(self) -> np.ndarray:
        """Per shape joint, the one actuator of the kind ``control`` needs."""
        mujoco = _mujoco()
        model, owner = self.model, "MujocoRobot"
        kinds = []
        for a in range(model.nu):
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
                kinds.append(None)
                continue
            gain, bias = model.actuator_gaintype[a], model.actuator_biastype[a]
            prm_gain, prm_bias = model.actuator_gainprm[a], model.actuator_biasprm[a]
            if (gain == mujoco.mjtGain.mjGAIN_FIXED and bias == mujoco.mjtBias.mjBIAS_NONE
                    and model.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_NONE):
                kinds.append("motor")
            elif (gain == mujoco.mjtGain.mjGAIN_FIXED and bias == mujoco.mjtBias.mjBIAS_AFFINE
                  and prm_bias[0] == 0 and prm_gain[0] > 0 and prm_bias[1] == -prm_gain[0]):
                kinds.append("position")
            else:
                kinds.append("other")
        wanted = "position" if self.control == "position" else "motor"
        chosen = []
        for joint, name in zip(self._joint_ids, self.joint_names, strict=True):
            mine = [a for a in range(model.nu)
                    if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and model.actuator_trnid[a, 0] == joint]
            usable = [a for a in mine if kinds[a] == wanted]
            if len(usable) != 1:
                found = ", ".join(f"{_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)} ({kinds[a]})" for a in mine)
                raise GeogaitError(
                    f"The 'joints' parameter of {owner} must name joints that each have exactly one {wanted} "
                    f"actuator (control={self.control!r}). Joint {name!r} has "
                    f"{len(usable)}{f'; its actuators: {found}' if found else ''}.")
            chosen.append(usable[0])
        return np.array(chosen)

    def _resolve_body(self, body) -> int:
        mujoco = _mujoco()
        model = self.model
        if body is None:
            return int(model.body_rootid[model.jnt_bodyid[self._joint_ids[0]]])
        if not isinstance(body, str):
            raise fail("body", "MujocoRobot", "a body name", body)
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
        if index < 0:
            names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)]
            raise fail("body", "MujocoRobot", "the name of a body of the model (" + ", ".join(names) + ")", body)
        if index == 0:
            raise fail("body", "MujocoRobot", "a moving body, not the world", body)
        return index

    def _resolve_steps(self) -> int:
        timestep = float(self.model.opt.timestep)
        ratio = self.cycle_period / (self.samples_per_cycle * timestep)
        steps = int(round(ratio))
        if steps < 1 or abs(ratio - steps) > 1e-9 * max(ratio, 1.0):
            unit = self.samples_per_cycle * timestep
            raise fail("cycle_period", "MujocoRobot",
                       f"a positive multiple of samples_per_cycle × the model's timestep "
                       f"({self.samples_per_cycle} × {timestep:g} s = {unit:g} s), e.g. {max(steps, 1) * unit:g}",
                       self.cycle_period)
        return steps

    @property
    def joint_ranges(self) -> np.ndarray:
        """(d, 2) ranges (rad) of the shape joints from the model; ±inf for unlimited joints.

        :class:`~geogait.optimize.InSituOptimizer` derives its joint limit from them
        (``max_joint_angle="auto"``).
        """
        return self._joint_ranges()

    @property
    def front_back_symmetric(self) -> bool:
        """Whether the front–back symmetric gait family is rotation-free on this model, read from its bodies.

        That family's gaits are unchanged by numbering the joints from the other end *and running time
        backwards*, so it is rotation-free only on a chain that reads the same from both ends **in a medium
        whose motion reverses with time** (a principally kinematic body: linear drag, negligible inertia).
        True when the shape joints join d + 1 bodies in one serial chain, numbered in order along it
        with one sign convention (joint j turns link j + 1 relative to link j), the chain reversed
        has the same joint spacing, link masses and rotational inertias, centres of mass mirrored, the
        same geoms (type, size, fluid coefficients) and the same passive actuator (drag) parameters
        per link, all to 1e-6, and the medium is resistive (:attr:`resistive_medium`). Then
        :class:`~geogait.optimize.InSituOptimizer`'s ``family="auto"`` searches that family:
        ``purcell_swimmer_xml`` with equal links is; unequal links, a head heavier than the tail,
        joints numbered out of order, or quadratic drag and inertia (Gymnasium's Swimmer-v5,
        ``drag="fluid"``: their gaits in that family turn) are not. Such chains are usually
        :attr:`mirror_symmetric`, whose half-wave symmetric family stays rotation-free with inertia.
        """
        if not hasattr(self, "_symmetric"):
            self._symmetric = self.resistive_medium and _reads_the_same_from_both_ends(self.model, self._joint_ids)
        return self._symmetric

    @property
    def mirror_symmetric(self) -> bool:
        """Whether the model reads the same in a mirror along its chain's axis, read from its bodies.

        True when the shape joints join d + 1 bodies in one serial chain, hinge about one common axis n,
        and, with every joint at zero (its spring reference, range and actuator control and force ranges
        symmetric about zero), the chain lies straight on a line L: every joint anchor, link centre of
        mass, geom centre and actuator site on L, every link geom, inertia frame and site frame with
        its axes along L, n or n × L (capsules, cylinders, spheres, boxes and ellipsoids), every site
        actuator acting along one axis of its site, any geom outside the chain a plane normal to n,
        and gravity and wind with no component across L (all to 1e-6). Then mirroring the body across
        the plane through L and n changes the sign of every joint angle and maps motions to motions,
        so the half-wave symmetric gait family is rotation-free
        (:class:`~geogait.optimize.InSituOptimizer`'s ``family="auto"``). True for
        ``purcell_swimmer_xml`` with any link lengths, for Gymnasium's Swimmer-v5 and for the Control Suite's
        swimmer. A geom of a link or of the static world that exerts no force (it cannot touch anything, wraps no
        tendon and has no fluid model of its own: a visual geom, or the suite's target) is left out of the test;
        a link's mass and inertia are tested.
        """
        if not hasattr(self, "_mirror"):
            self._mirror = _reads_the_same_in_a_mirror(self.model, self._joint_ids)
        return self._mirror

    @property
    def resistive_medium(self) -> bool:
        """Whether the chain moves in a resistive medium (forces linear in velocity), read from the model.

        True when every link of the chain carries passive linear dampers along its own x, y and rz axes — site
        actuators with zero gain and an affine bias −c v (how ``purcell_swimmer_xml(drag="rft")`` puts resistive
        force theory on every link) — and MuJoCo's quadratic fluid model is off (``density`` 0). Gymnasium's
        swimmer and ``drag="fluid"`` models are not: their drag is quadratic. A robot that declares a resistive
        chain gets :class:`~geogait.models.ResistanceModel` from :class:`~geogait.optimize.InSituOptimizer`'s
        default (``model=None``).
        """
        if not hasattr(self, "_resistive"):
            self._resistive = _carries_linear_drag(self.model, self._joint_ids)
        return self._resistive

    def chain_geometry(self) -> dict:
        """The robot as a chain of straight links, for :class:`~geogait.models.ResistanceModel`, read from its bodies.

        At the model's reference pose (the straight chain), link lengths are the spacing of the shape joints'
        anchors, and for the two end links the distance from their joint to the far end of their geoms (a
        capsule's or cylinder's segment, other geoms' bounding boxes). The robot's body must be a link of the
        chain; its frame is given relative to that link's centre, oriented from tail to head.

        Returns
        -------
        dict
            ``link_lengths`` (tail first: the link before joint 0), ``body_frame`` (the body's link index) and
            ``frame_offset`` (x, y, angle): keyword arguments of :class:`~geogait.models.ResistanceModel`
            and :class:`~geogait.systems.PurcellSwimmer`.

        Raises
        ------
        GeogaitError
            When the shape joints do not form one planar serial chain numbered in order with a common
            axis sign, or the body is not one of its links.
        """
        mujoco = _mujoco()
        model, joints = self.model, self._joint_ids
        chain = _chain_links(model, joints)
        if chain is None or len(set(chain[1])) != 1 or chain[1][0] != 1:
            raise GeogaitError("MujocoRobot.chain_geometry: the shape joints do not form one planar serial chain "
                               "numbered in order along it with +z axes (joint j turning link j + 1 relative to "
                               "link j), which a chain of links needs.")
        links = chain[0]
        if self._body not in links:
            raise GeogaitError(f"MujocoRobot.chain_geometry: the body {self.body_name!r} is not a link of the chain "
                               f"({', '.join(_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in links)}).")
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        anchors = np.array([data.xanchor[j][:2] for j in joints])
        ends = [_geom_extent(model, data, links[0]), _geom_extent(model, data, links[-1])]
        axis = anchors[-1] - anchors[0] if len(joints) > 1 else ends[1].mean(axis=0) - ends[0].mean(axis=0)
        axis = axis / np.linalg.norm(axis)
        along = anchors @ axis
        tail = along[0] - min(ends[0] @ axis)
        head = max(ends[1] @ axis) - along[-1]
        lengths = np.concatenate([[tail], np.diff(along), [head]])
        if np.any(lengths <= 0):
            raise GeogaitError(f"MujocoRobot.chain_geometry: link lengths {np.round(lengths, 6).tolist()} read from "
                               "the model are not all positive.")
        b = links.index(self._body)
        starts = np.concatenate([[along[0] - tail], along])
        centre = (starts[b] + lengths[b] / 2) * axis + (anchors[0] - along[0] * axis)  # the link's centre, world
        normal = np.array([-axis[1], axis[0]])
        offset = data.xpos[self._body][:2] - centre
        heading = float(np.arctan2(data.xmat[self._body, 3], data.xmat[self._body, 0]))
        angle = float(np.angle(np.exp(1j * (heading - np.arctan2(axis[1], axis[0])))))
        return {"link_lengths": tuple(float(x) for x in lengths), "body_frame": b,
                "frame_offset": (float(offset @ axis), float(offset @ normal), angle)}

    def _joint_ranges(self) -> np.ndarray:
        """(d, 2) joint ranges; ±inf for unlimited joints."""
        ranges = np.array([self.model.jnt_range[j] for j in self._joint_ids], dtype=float)
        limited = np.array([bool(self.model.jnt_limited[j]) for j in self._joint_ids])
        ranges[~limited] = (-np.inf, np.inf)
        return ranges

    def _default_gait(self, d: int) -> FourierGait:
        tightest = float(np.min(np.abs(self._joint_ranges())))
        return seed_gait(d, amplitude=min(1.0, 0.8 * tightest))

    def _check_gait(self, gait, owner: str) -> None:
        if not isinstance(gait, FourierGait) or gait.n_joints != len(self._joint_ids):
            raise fail("gait", owner, f"a FourierGait with {len(self._joint_ids)} joints "
                       f"({', '.join(self.joint_names)})", gait)

    def _resolve_gains(self, kp, kd):
        owner = "MujocoRobot"
        if self.control == "position":
            for value, name in ((kp, "kp"), (kd, "kd")):
                if value is not None:
                    raise fail(name, owner, "None with control='position' (the actuator holds its own gains)", value)
            return None, None
        d = len(self._joint_ids)
        if self.control == "computed_torque":
            omega = _COMPUTED_TORQUE_FREQUENCY / (float(self.model.opt.timestep) * self.control_interval)
            kp = np.full(d, omega**2) if kp is None else self._gain(kp, "kp", d)
            kd = np.full(d, 2 * omega) if kd is None else self._gain(kd, "kd", d)
            return kp, kd
        mujoco = _mujoco()
        limits = np.array([np.max(np.abs(self.model.actuator_ctrlrange[a])) if self.model.actuator_ctrllimited[a]
                           else np.inf for a in self._actuators])
        gear = self.model.actuator_gear[self._actuators, 0].copy()
        data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, data)
        # The joints' mobility W = (M⁻¹)_JJ with every other degree of freedom free; a joint's effective inertia
        # is 1 / W_jj, and the coupling between them raises the stiffest mode by ν_max = λ_max(D^-½ W D^-½).
        mobility = np.empty((d, d))
        unit, column = np.zeros((1, self.model.nv)), np.zeros((1, self.model.nv))
        for j, dof in enumerate(self._dof):
            unit[:] = 0
            unit[0, dof] = 1
            mujoco.mj_solveM(self.model, data, column, unit)
            mobility[:, j] = column[0, self._dof]
        inertia = 1 / np.diag(mobility)
        normalised = np.sqrt(inertia)[:, None] * mobility * np.sqrt(inertia)[None, :]
        coupling = float(np.linalg.eigvalsh((normalised + normalised.T) / 2).max())
        frequency = min(_MAX_GAIN_FREQUENCY, _MAX_COUPLED_FREQUENCY / coupling)
        omega = frequency / (float(self.model.opt.timestep) * self.control_interval)  # per torque update
        stable = inertia * omega**2 / np.abs(gear)
        default_kp = np.minimum(limits / _DEFAULT_SATURATION_ERROR, stable)
        kp = default_kp if kp is None else self._gain(kp, "kp", d)
        if kd is None:
            kd = 2 * np.sqrt(kp * np.abs(gear) * inertia) / np.abs(gear)
        else:
            kd = self._gain(kd, "kd", d)
        return kp, kd

    @staticmethod
    def _gain(value, name: str, d: int) -> np.ndarray:
        try:
            array = np.broadcast_to(np.asarray(value, dtype=float), (d,)).copy()
        except (TypeError, ValueError):
            raise fail(name, "MujocoRobot", f"a float or an array of shape ({d},), finite and >= 0", value) from None
        if not np.all(np.isfinite(array)) or np.any(array < 0):
            raise fail(name, "MujocoRobot", f"a float or an array of shape ({d},), finite and >= 0", value)
        return array

    def _start(self, mujoco) -> None:
        """Joints on the commanded shape of phase 0 (or at rest, ``start="rest"``), base at rest; check the body
        moves in the x-y plane."""
        if self.start == "gait":
            shape, rate = self._commands(np.zeros(1), self._perturbation.state[None])
            self.data.qpos[self._qpos] = shape[0]
            self.data.qvel[self._dof] = rate[0]
        mujoco.mj_forward(self.model, self.data)
        z_axis = self.data.xmat[self._body].reshape(3, 3)[:, 2]
        if z_axis[2] < 1 - 1e-9:
            raise fail("body", "MujocoRobot", "a body whose z-axis is the world z-axis (MujocoRobot models planar "
                       "motion in the x-y plane)", f"{self.body_name!r} with z-axis {z_axis.round(6).tolist()}")
        self._heading = float(np.arctan2(self.data.xmat[self._body, 3], self.data.xmat[self._body, 0]))

    # -- the Robot protocol -------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Shape dimension d."""
        return len(self._joint_ids)

    @property
    def gait(self) -> FourierGait:
        """Nominal gait of the next cycle."""
        return self._gait

    @property
    def timestep(self) -> float:
        """The model's physics timestep (s)."""
        return float(self.model.opt.timestep)

    @property
    def n_physics_steps(self) -> int:
        """Physics (environment) steps run so far: ``cycle · samples_per_cycle · steps_per_sample``."""
        return self.cycle * self.samples_per_cycle * self.steps_per_sample

    def set_cycle_period(self, cycle_period: float) -> None:
        """Run the following cycles at ``cycle_period`` seconds, the nearest the physics can time.

        A cycle is a whole number of samples of ``steps_per_sample`` physics steps, so the period
        becomes the nearest multiple of ``steps_per_sample × timestep`` (``cycle_period`` reads it
        back) and ``samples_per_cycle`` follows; the exploration perturbation keeps its spectrum in
        seconds. :class:`~geogait.optimize.InSituOptimizer` uses it with ``optimize_period=True``.
        """
        unit = self.steps_per_sample * self.timestep  # (one sample's time)
        samples = self._units_per_cycle(cycle_period, unit, 4, f"at least 4 samples of {unit:g} s ({4 * unit:g} s)")
        self.samples_per_cycle = samples
        self.cycle_period = samples * unit

    def set_excitation(self, shape, shape_velocity) -> None:
        """Run the next cycle with this excitation instead of the robot's own perturbation.

        ``shape`` and ``shape_velocity`` (M, d) are δ (rad) and δ̇ (rad/s) at phases 2πk / M; they
        are interpolated at every physics step and added to the commanded shape and rate (what
        :class:`~geogait.optimize.InSituOptimizer` sends when it owns the exploration). The
        robot's own perturbation stream does not advance during that cycle.
        """
        self._excitation = check_excitation(shape, shape_velocity, self.n_joints, "MujocoRobot.set_excitation")

    def _commands(self, phase: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Commanded shape and rate (rad, rad/s) at ``phase`` (n,) with perturbation ``state`` (n, d, 2)."""
        phase_rate = 2 * np.pi / self.cycle_period
        shape = self._gait.shape(phase) + state[..., 0]
        rate = self._gait.velocity(phase) * phase_rate + state[..., 1]
        return shape, rate

    def next_cycle(self) -> Trajectory:
        """Run one gait cycle of the physics and return its ``samples_per_cycle`` samples.

        Returns
        -------
        Trajectory
            ``time`` (s), ``phase``, ``cycle``, measured ``shape`` / ``shape_velocity`` (rad, rad/s),
            ``body_velocity`` (v_x, v_y, ω) in the body frame, world ``pose`` (x, y, heading) of the
            body, and ``commanded_shape`` (nominal gait + perturbation), each with n = samples_per_cycle.

        Raises
        ------
        GeogaitError
            When the physics became unstable during the cycle (MuJoCo then resets the model to rest and
            carries on, which would make the cycle's samples a different run's).
        """
        mujoco = _mujoco()
        if self.data is None:
            raise GeogaitError("This MujocoRobot was closed; build a new one to run more cycles.")
        model, data = self.model, self.data
        unstable = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
        k, n = self.steps_per_sample, self.samples_per_cycle
        steps = k * n
        d = self.n_joints
        phase = 2 * np.pi * np.arange(steps) / steps
        if self._excitation is not None:
            state = np.stack(excitation_at(phase, *self._excitation), axis=-1)
            self._excitation = None
        else:
            state = self._perturbation.run(self._rng.standard_normal((steps, d, 2)))
        command, command_rate = self._commands(phase, state)
        computed = self.control == "computed_torque"
        if computed:  # fed forward: the gait's acceleration, and the exploration's mean over each held torque
            base = np.setdiff1d(np.arange(model.nv), self._dof)  # (once per cycle, not at every update)
            command_acceleration = self._gait.acceleration(phase) * (2 * np.pi / self.cycle_period) ** 2
            ahead = np.arange(steps) + self.control_interval  # (not known beyond the cycle: its last interval)
            inside = ahead < steps
            command_acceleration[inside] += ((state[ahead[inside], :, 1] - state[inside, :, 1])
                                             / (self.control_interval * self.timestep))
        shape = np.empty((n, d))
        shape_velocity = np.empty((n, d))
        body_velocity = np.empty((n, 3))
        pose = np.empty((n, 3))
        twist = np.empty(6)
        qpos, dof, actuators, body = self._qpos, self._dof, self._actuators, self._body
        pd, interval = self.control == "pd", self.control_interval
        if pd or computed:
            low = np.where(model.actuator_ctrllimited[actuators], model.actuator_ctrlrange[actuators, 0], -np.inf)
            high = np.where(model.actuator_ctrllimited[actuators], model.actuator_ctrlrange[actuators, 1], np.inf)
        for step in range(steps):
            if step % k == 0:
                sample = step // k
                mujoco.mj_kinematics(model, data)
                mujoco.mj_comPos(model, data)
                mujoco.mj_comVel(model, data)
                mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, twist, 1)
                body_velocity[sample] = (twist[3], twist[4], twist[2])
                rotation = data.xmat[body]
                wrapped = np.arctan2(rotation[3], rotation[0])
                self._heading += (wrapped - self._heading + np.pi) % (2 * np.pi) - np.pi
                pose[sample] = (data.xpos[body, 0], data.xpos[body, 1], self._heading)
                shape[sample] = data.qpos[qpos]
                shape_velocity[sample] = data.qvel[dof]
            if not (pd or computed):
                data.ctrl[actuators] = command[step]
            elif step % interval == 0:  # held in between, as an environment's frame_skip holds it
                error, rate_error = command[step] - data.qpos[qpos], command_rate[step] - data.qvel[dof]
                if pd:
                    u = self.kp * error + self.kd * rate_error
                else:
                    u = _computed_torque(model, data, dof, actuators,
                                         command_acceleration[step] + self.kp * error + self.kd * rate_error, base)
                data.ctrl[actuators] = np.minimum(np.maximum(u, low), high)  # np.clip costs 4x more here
            mujoco.mj_step(model, data)
        if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > unstable:
            raise GeogaitError(
                f"MuJoCo's simulation became unstable in cycle {self.cycle} of this MujocoRobot (the physics reset "
                f"the model to rest): a gait too fast or too large for the model's timestep "
                f"({self.timestep:g} s) and PD gains. Command a smaller or slower gait, or lower kp / kd.")
        index = np.arange(n)
        trajectory = Trajectory(
            time=self._elapsed + index * (self.cycle_period / n), phase=2 * np.pi * index / n,
            cycle=np.full(n, self.cycle), shape=shape, shape_velocity=shape_velocity,
            body_velocity=body_velocity, pose=pose, commanded_shape=command[::k].copy())
        self.cycle += 1
        self._elapsed += self.cycle_period
        return trajectory

    # -- extras -------------------------------------------------------------------------------
    def robot_state(self) -> dict:
        """Everything that determines the following cycles, for a bit-identical restart.

        Returns
        -------
        dict
            ``physics`` (``mj_getState`` with ``mjSTATE_INTEGRATION``: time, qpos, qvel, act,
            warm start, ctrl, applied forces, mocap, ...), ``perturbation`` (δ, δ̇ per joint),
            ``gait`` (coefficients), ``rng`` (the generator's state, JSON values), ``cycle`` and
            ``heading`` (the unwrapped heading of the last sample), ``elapsed`` (seconds run) and
            ``cycle_period``.
        """
        mujoco = _mujoco()
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        physics = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, physics, spec)
        return {"physics": physics, **self._run_state(), "elapsed": float(self._elapsed),
                "cycle_period": float(self.cycle_period)}

    def restore_robot_state(self, state: dict) -> None:
        """Continue exactly where the robot that wrote ``state`` (:meth:`robot_state`) was."""
        mujoco = _mujoco()
        owner = "MujocoRobot.restore_robot_state"
        self._check_state_keys(state, owner, ("physics",))
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        physics = np.asarray(state["physics"], dtype=float)
        size = mujoco.mj_stateSize(self.model, spec)
        if physics.shape != (size,):
            raise fail("state", owner, f"a physics state of {size} values (this model)", f"{physics.size} values")
        perturbation, gait = self._checked_run_state(state, owner)
        if "cycle_period" in state:  # states saved before periods could change lack it
            self.set_cycle_period(float(state["cycle_period"]))
        mujoco.mj_setState(self.model, self.data, physics, spec)
        self._restore_run_state(state, perturbation, gait)
        self._elapsed = float(state.get("elapsed", self.cycle * self.cycle_period))

    def close(self) -> None:
        """Drop the simulation data (MuJoCo frees its buffers with it); later cycles raise an error."""
        self.data = None

    def __repr__(self):
        return (f"MujocoRobot(joints={list(self.joint_names)}, body={self.body_name!r}, control={self.control!r}, "
                f"cycle_period={self.cycle_period:g}, samples_per_cycle={self.samples_per_cycle}, "
                f"steps_per_sample={self.steps_per_sample})")


def _computed_torque(model, data, dofs, actuators, acceleration, base=None) -> np.ndarray:
    r"""The ``ctrl`` of the ``motor`` actuators ``actuators`` (one per degree of freedom of ``dofs``) that gives
    those joints the acceleration ``acceleration`` in the current state, every other degree of freedom (the base)
    moving freely: floating-base inverse dynamics.

    With M the joint-space inertia, h = bias − passive − other actuators' forces (Coriolis, gravity, fluid,
    springs, dampers, every actuator but these), split into joints j and the rest b,

    .. math::
        \ddot q_b = M_{bb}^{-1} (-h_b - M_{bj} a), \qquad
        \tau_j = M_{jb} \ddot q_b + M_{jj} a + h_j, \qquad \text{ctrl} = \tau_j / \text{gear}.

    Constraint forces (joint limits, contacts) are not predicted. Leaves ``data.ctrl`` of ``actuators`` at zero
    and the position- and velocity-dependent quantities of ``data`` computed for the current state.
    """
    mujoco = _mujoco()
    data.ctrl[actuators] = 0.0
    mujoco.mj_fwdPosition(model, data)
    mujoco.mj_fwdVelocity(model, data)
    mujoco.mj_fwdActuation(model, data)
    inertia = np.zeros((model.nv, model.nv))
    if hasattr(data, "qM"):  # MuJoCo 3
        mujoco.mj_fullM(model, inertia, data.qM)
    else:
        mujoco.mj_fullM(model, data, inertia)
    known = data.qfrc_bias - data.qfrc_passive - data.qfrc_actuator
    base = np.setdiff1d(np.arange(model.nv), dofs) if base is None else base  # (every dof but the joints')
    base_acceleration = np.linalg.solve(inertia[np.ix_(base, base)],
                                        -known[base] - inertia[np.ix_(base, dofs)] @ acceleration)
    torque = inertia[np.ix_(dofs, base)] @ base_acceleration + inertia[np.ix_(dofs, dofs)] @ acceleration + known[dofs]
    return torque / model.actuator_gear[actuators, 0]


def _chain_links(model, joints) -> tuple[list[int], list[int]] | None:
    """Bodies (d + 1) and the sign of each shape joint along the serial chain they form, or None."""
    edges = [(int(model.body_parentid[model.jnt_bodyid[j]]), int(model.jnt_bodyid[j])) for j in joints]
    bodies = {b for edge in edges for b in edge}
    if len(bodies) != len(joints) + 1:
        return None
    neighbours = {b: [] for b in bodies}
    for k, (parent, child) in enumerate(edges):
        neighbours[parent].append((child, k))
        neighbours[child].append((parent, k))
    ends = [b for b, n in neighbours.items() if len(n) == 1]
    if len(ends) != 2 or any(len(n) > 2 for n in neighbours.values()):
        return None
    order, used, body = [min(ends)], [], min(ends)
    while len(order) < len(bodies):
        body, k = next((b, k) for b, k in neighbours[body] if k not in used)
        order.append(body)
        used.append(k)
    if used != sorted(used) and used != sorted(used, reverse=True):
        return None  # shape coordinates numbered out of order along the chain
    if used[0] != 0:  # walk from the end where joint 0 is
        order, used = order[::-1], used[::-1]
    signs = []
    for i, k in enumerate(used):
        parent, child = edges[k]
        turns_next = child == order[i + 1]  # joint k turns link i + 1 relative to link i
        signs.append(np.sign(model.jnt_axis[joints[k]][2]) * (1 if turns_next else -1))
    return order, signs


def _carries_linear_drag(model, joints) -> bool:
    """Every chain link has passive linear dampers on its x, y and rz axes, and MuJoCo's fluid drag is off."""
    mujoco = _mujoco()
    chain = _chain_links(model, joints)
    if chain is None or model.opt.density != 0:
        return False
    axes = {body: set() for body in chain[0]}
    unit = np.eye(6)
    for a in range(model.nu):
        bias = model.actuator_biasprm[a]
        if (int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_SITE) or model.actuator_gainprm[a][0] != 0
                or int(model.actuator_biastype[a]) != int(mujoco.mjtBias.mjBIAS_AFFINE)
                or bias[0] != 0 or bias[1] != 0 or not bias[2] < 0):
            continue
        body = int(model.site_bodyid[model.actuator_trnid[a][0]])
        axis = next((k for k in (0, 1, 5) if np.allclose(model.actuator_gear[a], unit[k])), None)  # x, y, rz
        if body in axes and axis is not None:
            axes[body].add(axis)
    return all(found == {0, 1, 5} for found in axes.values())


def _geom_extent(model, data, body) -> np.ndarray:
    """World (x, y) points bounding a body's geoms: a capsule's or cylinder's segment ends, else its box corners."""
    mujoco = _mujoco()
    points = []
    for g in range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body]):
        rotation, centre = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
        if int(model.geom_type[g]) in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
            half = rotation[:, 2] * model.geom_size[g][1]
            points += [centre + half, centre - half]
        else:
            box_centre, half = model.geom_aabb[g][:3], model.geom_aabb[g][3:]
            signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
            points += list(centre + (box_centre + signs * half) @ rotation.T)
    if not points:
        raise GeogaitError(f"MujocoRobot.chain_geometry: the end link {_name(model, mujoco.mjtObj.mjOBJ_BODY, body)!r} "
                           "has no geom to measure its length from.")
    return np.array(points)[:, :2]


def _reads_the_same_from_both_ends(model, joints) -> bool:
    """See :attr:`MujocoRobot.front_back_symmetric`."""
    mujoco = _mujoco()
    chain = _chain_links(model, joints)
    if chain is None:
        return False
    links, signs = chain
    if len(set(signs)) != 1 or signs[0] == 0:
        return False
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)  # qpos0: the straight chain
    anchors = np.array([data.xanchor[j][:2] for j in joints])
    axis = anchors[-1] - anchors[0] if len(joints) > 1 else data.xipos[links[-1]][:2] - anchors[0]
    if not np.linalg.norm(axis) > 0:
        return False
    axis = axis / np.linalg.norm(axis)
    along = anchors @ axis
    centre = (along[0] + along[-1]) / 2  # the chain's midpoint: reversal mirrors positions about it

    def link(body, mirror):
        geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
        shapes = sorted((int(model.geom_type[g]), *np.round(model.geom_size[g], 9), *np.round(model.geom_fluid[g], 9))
                        for g in geoms)
        biases = sorted(tuple(np.round(model.actuator_biasprm[a][:3], 9)) for a in range(model.nu)
                        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_SITE
                        and model.site_bodyid[model.actuator_trnid[a, 0]] == body)
        com = (float(data.xipos[body][:2] @ axis) - centre) * mirror
        return np.array([model.body_mass[body], *np.sort(model.body_inertia[body]), com]), shapes, biases

    tolerance = 1e-6
    spacing = np.diff(along)
    if not np.allclose(spacing, spacing[::-1], rtol=tolerance, atol=tolerance):
        return False
    for front, back in zip(links, links[::-1], strict=True):
        (a, shapes_a, biases_a), (b, shapes_b, biases_b) = link(front, 1), link(back, -1)
        if not np.allclose(a, b, rtol=tolerance, atol=tolerance) or shapes_a != shapes_b or biases_a != biases_b:
            return False
    return True


def _reads_the_same_in_a_mirror(model, joints) -> bool:
    """See :attr:`MujocoRobot.mirror_symmetric`."""
    mujoco = _mujoco()
    chain = _chain_links(model, joints)
    if chain is None:
        return False
    links, tolerance = chain[0], 1e-6
    for j in joints:
        address = model.jnt_qposadr[j]
        low, high = model.jnt_range[j]
        if model.qpos_spring[address] != 0 or (model.jnt_limited[j] and abs(low + high) > tolerance):
            return False
    for a in range(model.nu):
        for limited, (low, high) in ((model.actuator_ctrllimited[a], model.actuator_ctrlrange[a]),
                                     (model.actuator_forcelimited[a], model.actuator_forcerange[a])):
            if limited and abs(low + high) > tolerance:
                return False
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[[model.jnt_qposadr[j] for j in joints]] = 0.0
    mujoco.mj_forward(model, data)
    normal = data.xaxis[joints[0]] / np.linalg.norm(data.xaxis[joints[0]])
    if any(np.linalg.norm(np.cross(data.xaxis[j], normal)) > tolerance for j in joints):
        return False
    points = np.array([*(data.xanchor[j] for j in joints), *(data.xipos[b] for b in links)])
    origin = points[0]
    spread = points - origin
    spread -= np.outer(spread @ normal, normal)
    along = spread[np.argmax(np.linalg.norm(spread, axis=1))]
    if not np.linalg.norm(along) > tolerance:
        return False
    along /= np.linalg.norm(along)
    across = np.cross(normal, along)

    def on_line(point) -> bool:
        return abs((point - origin) @ across) <= tolerance

    def aligned(frame) -> bool:  # every axis of a 3×3 frame along L, n or n × L
        return all(np.max(np.abs(np.stack([along, across, normal]) @ column)) >= 1 - tolerance for column in frame.T)

    kinds = mujoco.mjtGeom
    shapes = {int(kinds.mjGEOM_CAPSULE), int(kinds.mjGEOM_CYLINDER), int(kinds.mjGEOM_SPHERE), int(kinds.mjGEOM_BOX),
              int(kinds.mjGEOM_ELLIPSOID)}
    chain_bodies = set(links)
    inert = _force_free_geoms(model)
    for g in range(model.ngeom):
        body = int(model.geom_bodyid[g])
        if g in inert and (body in chain_bodies or model.body_weldid[body] == 0):
            continue  # a visual geom of a link (whose mass and inertia are checked below) or of the static world
        frame = data.geom_xmat[g].reshape(3, 3)
        if body in chain_bodies:
            if int(model.geom_type[g]) not in shapes or not on_line(data.geom_xpos[g]) or not aligned(frame):
                return False
        elif int(model.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_PLANE) or abs(frame[:, 2] @ normal) < 1 - tolerance:
            return False
    for b in links:
        if not on_line(data.xipos[b]) or not aligned(data.ximat[b].reshape(3, 3)):
            return False
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_SITE):
            continue
        site = model.actuator_trnid[a][0]
        if (not on_line(data.site_xpos[site]) or not aligned(data.site_xmat[site].reshape(3, 3))
                or np.count_nonzero(model.actuator_gear[a]) != 1):
            return False
    return abs(model.opt.gravity @ across) <= tolerance and abs(model.opt.wind @ across) <= tolerance


def _force_free_geoms(model) -> set:
    """The geoms that exert no force of their own: they cannot touch anything (contacts disabled, or contype and
    conaffinity 0 and in no explicit contact pair), wrap no tendon and have no ellipsoid fluid model. Their mass,
    if any, is in their body's inertia."""
    mujoco = _mujoco()
    contacts_off = bool(model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT))
    pairs = {*model.pair_geom1.tolist(), *model.pair_geom2.tolist()}
    wrapping = np.isin(model.wrap_type, [int(mujoco.mjtWrap.mjWRAP_SPHERE), int(mujoco.mjtWrap.mjWRAP_CYLINDER)])
    wrapped = set(model.wrap_objid[wrapping].tolist())
    return {g for g in range(model.ngeom)
            if (contacts_off or (model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0 and g not in pairs))
            and g not in wrapped and model.geom_fluid[g, 0] == 0}


# -- shipped models -----------------------------------------------------------------------------
def purcell_swimmer_xml(n_links: int = 3, *, drag: str = "rft", length: float = 1.0, link_lengths=None,
                        radius: float = 0.025,
                        drag_coefficient: float = 1.0, drag_ratio: float = 2.0, body_density: float | None = None,
                        fluid_density: float = 4000.0, viscosity: float = 0.0, timestep: float = 0.002,
                        armature: float = 1e-4, joint_range: float = MAX_JOINT_ANGLE, actuator: str = "motor",
                        ctrl_limit: float | None = None, position_gain: float | None = None) -> str:
    r"""MJCF of an N-link Purcell swimmer (the models shipped as ``geogait:purcell3`` / ``geogait:purcell5``).

    Capsule links along x (equal, or of the given ``link_lengths``), joined by hinge joints about z;
    ``joint{j}`` is the angle of link j+1 relative to link j, link 0 the tail at −x (geogait's
    :class:`~geogait.systems.PurcellSwimmer` conventions). The middle link (index
    ``(n_links - 1) // 2``) is the root body with a planar base (slide x, slide y, hinge z) and its
    frame at the link's centre, so ``body`` defaults to it, as ``body_frame="middle"`` of
    ``PurcellSwimmer`` for odd N. Gravity is off.

    ``drag="rft"`` (default): low Reynolds number. Each link carries resistive-force-theory drag at
    its centre, exactly the wrench of ``PurcellSwimmer``,

    .. math:: F = -c\,\mathrm{diag}(l,\ k l,\ k l^3/12)\,(u, v, \omega)^T

    in the link's own frame, built from three passive ``general`` actuators per link with a site
    transmission along the link's x, y and z-rotation axes and velocity bias ``-c l``, ``-c k l``,
    ``-c k l³/12`` (their ``ctrl`` does nothing). The links are light (density 1 kg/m³) so drag
    dominates inertia by orders of magnitude: the robot is principally kinematic, ξ = −A(r) ṙ with
    geogait's RFT connection in the limit, which the tests check against ``PurcellSwimmer``.

    ``drag="fluid"``: MuJoCo's own inertia-box fluid model (``density``/``viscosity`` options). Its
    viscous term is isotropic and cannot propel a Purcell swimmer; the propulsion comes from the
    per-axis quadratic drag ½ ρ s_j s_k |v_i| v_i of each link's inertia box. With light links the
    motion is rate-independent but **not linear in ṙ** (a quadratic-drag swimmer, like Gymnasium's).

    Parameters
    ----------
    n_links : int >= 2
    drag : {"rft", "fluid"}
    length : float > 0
        Total length (m) of equal links.
    link_lengths : array-like of shape (n_links,), optional
        Length of each link (m), tail (link 0) first; overrides ``length``. The links of
        :class:`~geogait.systems.PurcellSwimmer` with the same ``link_lengths`` (and
        ``body_frame="middle"``) are the same.
    radius : float > 0
        Capsule radius (m).
    drag_coefficient, drag_ratio : float > 0
        ``drag="rft"``: longitudinal drag c per unit length (N·s/m²) and lateral/longitudinal k.
    body_density : float > 0, optional
        kg/m³; default 1 for ``"rft"`` and 100 for ``"fluid"``.
    fluid_density, viscosity : float
        ``drag="fluid"``: MuJoCo's ``density`` (kg/m³, > 0) and ``viscosity`` (Pa·s, >= 0).
    timestep : float > 0
        Physics step (s); the integrator is ``implicitfast``, which treats the velocity-dependent
        drag implicitly.
    armature : float >= 0
        Rotor inertia added to each shape joint (kg m²).
    joint_range : float > 0
        Joint limit ±``joint_range`` (rad); 2π/3 by default, the design's r_max.
    actuator : {"motor", "position"}
        ``motor`` (gear 1, ctrlrange ±``ctrl_limit`` N·m) for PD control, or ``position`` servos
        (stiffness ``position_gain``, critically damped, force limited to ±``ctrl_limit``).
    ctrl_limit : float > 0, optional
        Torque limit of each joint (N·m); default 0.2 (``"rft"``) or 2 (``"fluid"``), several times
        what the seed gait needs at a 1 s period.
    position_gain : float > 0, optional
        Stiffness of the position servos (N·m/rad); default 10 × ``ctrl_limit``.

    Returns
    -------
    str
        MJCF text for :func:`load_mujoco_model` or ``mujoco.MjModel.from_xml_string``.
    """
    owner = "purcell_swimmer_xml"
    n = check_int(n_links, "n_links", owner, minimum=2)
    check_choice(drag, "drag", owner, ("rft", "fluid"))
    rft = drag == "rft"
    body_density = (1.0 if rft else 100.0) if body_density is None else body_density
    ctrl_limit = (0.2 if rft else 2.0) if ctrl_limit is None else ctrl_limit
    position_gain = 10 * ctrl_limit if position_gain is None else position_gain
    for value, name in ((length, "length"), (radius, "radius"), (drag_coefficient, "drag_coefficient"),
                        (drag_ratio, "drag_ratio"), (body_density, "body_density"), (fluid_density, "fluid_density"),
                        (timestep, "timestep"), (joint_range, "joint_range"), (ctrl_limit, "ctrl_limit"),
                        (position_gain, "position_gain")):
        check_float(value, name, owner, low=0, low_open=True)
    check_float(viscosity, "viscosity", owner, low=0)
    check_float(armature, "armature", owner, low=0)
    check_choice(actuator, "actuator", owner, ("motor", "position"))
    if link_lengths is None:
        links = np.full(n, length / n)
    else:
        links = np.asarray(link_lengths, dtype=float) if _is_real_sequence(link_lengths) else None
        if links is None or links.shape != (n,) or not np.all(np.isfinite(links)) or np.any(links <= 0):
            raise fail("link_lengths", owner, f"{n} positive finite lengths (one per link)", link_lengths)
    middle = (n - 1) // 2

    def g(value):
        return f"{value:.12g}"

    def capsule(start, stop):
        centre = (start + stop) / 2
        return (f'<geom type="capsule" fromto="{g(start)} 0 0 {g(stop)} 0 0" size="{g(radius)}" '
                f'density="{g(body_density)}"/>' + (f'<site name="centre{{i}}" pos="{g(centre)} 0 0"/>' if rft else ""))

    def joint(j, axis):
        return (f'<joint name="joint{j}" type="hinge" axis="0 0 {axis}" range="{g(-joint_range)} '
                f'{g(joint_range)}" limited="true" armature="{g(armature)}"/>')

    def chain(i, step, indent):
        """Links i, i + step, ... away from the middle link (step -1: towards link 0, the tail, at -x)."""
        if i < 0 or i >= n:
            return ""
        offset = (links[middle] / 2 if abs(i - middle) == 1 else links[i - step]) * step
        j, axis = (i, -1) if step < 0 else (i - 1, 1)  # the hinge between links j and j + 1
        pad = "  " * indent
        return (f'{pad}<body name="link{i}" pos="{g(offset)} 0 0">\n{pad}  {joint(j, axis)}\n'
                f'{pad}  {capsule(0, links[i] * step).format(i=i)}\n{chain(i + step, step, indent + 1)}{pad}</body>\n')

    if actuator == "motor":
        actuators = "".join(f'    <motor name="motor{j}" joint="joint{j}" gear="1" ctrlrange="{g(-ctrl_limit)} '
                            f'{g(ctrl_limit)}"/>\n' for j in range(n - 1))
    else:
        actuators = "".join(
            f'    <position name="servo{j}" joint="joint{j}" kp="{g(position_gain)}" dampratio="1" '
            f'ctrlrange="{g(-joint_range)} {g(joint_range)}" forcerange="{g(-ctrl_limit)} {g(ctrl_limit)}"/>\n'
            for j in range(n - 1))
    if rft:
        def resistance(link):
            return {"x": (drag_coefficient * link, "1 0 0 0 0 0"),
                    "y": (drag_coefficient * drag_ratio * link, "0 1 0 0 0 0"),
                    "rz": (drag_coefficient * drag_ratio * link**3 / 12, "0 0 0 0 0 1")}
        actuators += "".join(
            f'    <general name="drag{i}_{axis}" site="centre{i}" gear="{gear}" gainprm="0" biastype="affine" '
            f'biasprm="0 0 {g(-value)}"/>\n' for i in range(n) for axis, (value, gear) in resistance(links[i]).items())
        option = f'timestep="{g(timestep)}" integrator="implicitfast"'
        comment = f"low Reynolds number: RFT drag c = {g(drag_coefficient)}, k = {g(drag_ratio)} on every link"
    else:
        option = (f'timestep="{g(timestep)}" density="{g(fluid_density)}" viscosity="{g(viscosity)}" '
                  f'integrator="implicitfast"')
        comment = "MuJoCo inertia-box fluid: quadratic drag"
    root = capsule(-links[middle] / 2, links[middle] / 2).format(i=middle)
    return (f'<mujoco model="purcell{n}">\n'
            f'  <!-- generated by geogait.robots.purcell_swimmer_xml({n}, drag={drag!r}); {comment} -->\n'
            f'  <compiler angle="radian"/>\n'
            f'  <option {option}>\n    <flag gravity="disable"/>\n  </option>\n'
            f'  <default>\n    <geom contype="0" conaffinity="0" rgba="0.8 0.6 0.4 1"/>\n  </default>\n'
            f'  <worldbody>\n    <body name="link{middle}">\n'
            f'      <joint name="x" type="slide" axis="1 0 0"/>\n'
            f'      <joint name="y" type="slide" axis="0 1 0"/>\n'
            f'      <joint name="heading" type="hinge" axis="0 0 1"/>\n'
            f'      {root}\n'
            f'{chain(middle - 1, -1, 3)}{chain(middle + 1, 1, 3)}'
            f'    </body>\n  </worldbody>\n  <actuator>\n{actuators}  </actuator>\n</mujoco>\n')


def mujoco_swimmer(n_links: int = 3, **options) -> MujocoRobot:
    """A ready :class:`MujocoRobot` on geogait's Purcell-like swimmer (:func:`purcell_swimmer_xml`).

    Parameters
    ----------
    n_links : int >= 2
        3 and 5 load the shipped ``geogait:purcell3`` / ``geogait:purcell5``; other counts are
        generated with the same defaults.
    **options
        Keywords of :class:`MujocoRobot` (``cycle_period`` 1 s, ``samples_per_cycle`` 100 and PD
        control unless given).

    Returns
    -------
    MujocoRobot
    """
    n_links = check_int(n_links, "n_links", "mujoco_swimmer", minimum=2)
    source = f"geogait:purcell{n_links}" if n_links in (3, 5) else purcell_swimmer_xml(n_links)
    return MujocoRobot(source, **options)


def gymnasium_swimmer(**options) -> MujocoRobot:
    """A ready :class:`MujocoRobot` on Gymnasium's ``swimmer.xml`` (needs ``gymnasium`` installed).

    The 3-link swimmer of Gymnasium's ``Swimmer-v5`` (viscous-and-dense fluid, 1 m capsule links,
    ``motor`` actuators with gear 150 and ctrlrange ±1, timestep 0.01 s), with the shape joints
    ``motor1_rot``, ``motor2_rot`` and the pose of the head link ``torso``.

    Parameters
    ----------
    **options
        Keywords of :class:`MujocoRobot`; ``cycle_period`` defaults to 2 s here (at 1 s the
        actuators saturate on the seed gait) and ``control_interval`` to 4: the PD torque is held for the
        environment's 4 physics steps (0.04 s), as a Swimmer-v5 agent's action is.

    Returns
    -------
    MujocoRobot
    """
    options.setdefault("cycle_period", 2.0)
    options.setdefault("control_interval", 4)
    return MujocoRobot("gymnasium:swimmer", **options)


def dm_control_swimmer(n_links: int = 6, **options) -> MujocoRobot:
    """A ready :class:`MujocoRobot` on the DeepMind Control Suite's swimmer (needs ``dm_control`` installed).

    The suite's N-link swimmer (``dm_control.suite.swimmer``, as its ``swimmer6`` and ``swimmer15`` tasks build it):
    0.1 m links, joints of ±60°, ``motor`` actuators with gear 5·10⁻⁴ and ctrlrange ±1, MuJoCo's inertia-based
    fluid model (density 3000), contacts off, timestep 0.002 s; the shape joints ``joint_0`` … and the pose of
    the ``head`` body. Its target, a sphere off the body's axis that exerts no force (contacts are off), does not
    break its mirror symmetry (:attr:`MujocoRobot.mirror_symmetric`).

    Parameters
    ----------
    n_links : int >= 3
        Links of the swimmer (the suite's tasks: 6 and 15).
    **options
        Keywords of :class:`MujocoRobot`; ``cycle_period`` defaults to 4 s here (its motors saturate on the
        seed gait at shorter periods).

    Returns
    -------
    MujocoRobot
    """
    mujoco = _mujoco()
    n_links = check_int(n_links, "n_links", "dm_control_swimmer", minimum=3)
    try:
        with warnings.catch_warnings():  # importing the suite looks for a display (GLFW) it does not need here
            warnings.simplefilter("ignore")
            from dm_control.suite import swimmer
    except ImportError as error:
        raise ImportError("dm_control_swimmer needs the optional dependency 'dm_control': "
                          "pip install 'geogait[dmcontrol]'") from error
    xml, assets = swimmer.get_model_and_assets(n_links)
    options.setdefault("cycle_period", 4.0)
    options.setdefault("body", "head")
    return MujocoRobot(mujoco.MjModel.from_xml_string(xml, assets), **options)
