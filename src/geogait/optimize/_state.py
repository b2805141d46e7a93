"""The state an in-situ optimisation run carries from cycle to cycle, and its checkpoint."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .. import models
from .._defaults import MAX_JOINT_ANGLE
from .._files import read_state
from .._validation import fail
from ..gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily
from ..models import model_capabilities, model_from_state
from ._adaptation import ChangeWatch
from ._climb import MeasuredClimb
from ._evolution import EvolutionSearch
from ._exploration import ExcitationSignal
from ._model_class import ModelClassCheck
from ._part import describe_params
from ._period import PeriodLineSearch
from ._search import MeasuredSearch

CHECKPOINT_FORMAT = "geogait-optimizer-checkpoint"
CHECKPOINT_VERSION = 1
TRACKING_FLOOR = 0.05  # shape_scale units: the automatic tracking limit never falls below this
#: shape_scale units: after a gait the robot could not follow, the trust radius halves down to this even below
#: min_trust_radius (a rejection is a measured fact, not a noisy ratio test); the default min_trust_radius.
REJECTION_FLOOR = 0.02
def read_checkpoint_metadata(path) -> dict:
    """The JSON metadata of an optimiser checkpoint (written by :meth:`InSituOptimizer.run`): its ``tag``
    (the run identity a caller stored), ``state`` (``cycle``: cycles run, …), ``params`` and
    ``checkpoint_every``; the file's format and version are checked first.

    Parameters
    ----------
    path : path-like
        The ``.npz`` checkpoint.

    Returns
    -------
    dict
    """
    return read_state(Path(path), "checkpoint", CHECKPOINT_FORMAT, CHECKPOINT_VERSION)[0]


def family_kind(family) -> str:
    """The name of a gait family object, as the optimiser's ``family`` parameter spells it."""
    return ("symmetric" if isinstance(family, SymmetricGaitFamily)
            else "mirror" if isinstance(family, MirrorGaitFamily) else "free")


@dataclass
class RunState:
    """Everything a run carries from cycle to cycle (and saves in its checkpoint)."""

    gait: FourierGait
    radius: float
    model: object
    n_cycles: int | None
    ceiling: float | None
    period: float
    cycle: int = 0
    iteration: int = 0
    cycles_in_iteration: int = 0
    settle_left: int = 0
    last_prediction: float = np.nan
    promised: tuple | None = None  # (value before the step, predicted value after, at the boundary)
    previous_gait: FourierGait | None = None
    robot_gait: FourierGait | None = None  # gait the robot runs next
    iteration_data: list = field(default_factory=list)  # the "cycles" gate's samples of this iteration
    iteration_measured: list = field(default_factory=list)  # measured objective of this iteration's cycles
    residual_variance: float = np.nan  # recent mean squared a-priori error of ω
    gamma: float = np.nan
    direction: np.ndarray | None = None
    world_heading: float = 0.0
    tracking_limit: float = np.nan
    tracking_follows: bool = True  # the automatic tracking limit follows the current gait's measured cycles
    seed_measured: list = field(default_factory=list)
    seed_value: float = np.nan  # true objective of the seed (oracle), NaN without one
    rows: list = field(default_factory=list)
    gaits: list = field(default_factory=list)
    family: object = None  # FreeGaitFamily, SymmetricGaitFamily or MirrorGaitFamily searched
    measured: dict = field(default_factory=dict)  # gait -> measured objective of each of its learned cycles
    feasibility: object = None  # the system's feasible region as step constraints (None: none declared)
    seed_nets: list = field(default_factory=list)  # the seed's measured motion per cycle, direction frame
    direction_fixed: bool = False  # "forward" fixed (given, or from all the seed's cycles at the first gate)
    max_joint_angle: float = MAX_JOINT_ANGLE  # r_max in force (resolved from the robot for "auto")
    scale: float = 1.0  # the robot's unit of shape (shape_scale)
    robot_period: float = np.nan  # period the robot runs next (s)
    previous_period: float = np.nan
    seed_period: float = np.nan
    period_search: PeriodLineSearch | None = None  # optimize_period's line search (None: period fixed)
    iteration_tracking: list = field(default_factory=list)  # tracking errors of this iteration's measured cycles
    climb: MeasuredClimb | None = None  # steps from measured outcomes (the climb parameter)
    rng: np.random.Generator | None = None  # the climb's directions
    distrust: int = 0  # ratio tests failed in a row at the smallest trust radius
    prediction_failures: int = 0  # prediction checks failed in a row
    stall: int = 0  # gate decisions in a row whose model step was declined or promised under 1 %
    rotations: dict = field(default_factory=dict)  # (gait, period) -> measured net rotation of each learned cycle
    exploration: ExcitationSignal | None = None  # the optimiser's own excitation (None: the robot's)
    excitation_next: tuple | None = None  # (δ, δ̇) commanded for the next cycle (re-sent on resume)
    iteration_excitation: list = field(default_factory=list)  # excitation RMS of this iteration's cycles
    warned_no_excitation: bool = False
    structure_switched: bool = False  # the StructureCheck found the structure contradicted: its step and climb run
    check: ModelClassCheck | None = None  # the model-class test (model_class_cycles; None: none)
    watch: ChangeWatch = field(default_factory=ChangeWatch)  # the Adaptation's (changes detected, checks due)
    steps_by_model: int = 0
    steps_by_climb: int = 0
    settle_cycles: int = 0  # settling cycles after a gait change in force: declared, or measured ("auto")
    settle_due: bool = False  # ("auto") the next gait change measures its settling
    settle_probe: list | None = None  # ("auto") the measured values of the gait change being probed

    def rate(self, period: float) -> float:
        """Factor from an objective per cycle to the one compared across gaits: 1/T when the period is
        optimised (a rate), else 1."""
        return 1.0 / period if self.period_search is not None else 1.0

    def restart_iteration(self):
        self.cycles_in_iteration = 0
        self.iteration_data = []
        self.iteration_measured = []
        self.iteration_excitation = []
        self.iteration_tracking = []

    def learn(self, chunk, gate):
        self.cycles_in_iteration += 1
        args = (chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
        if gate == "cycles":
            self.iteration_data.append(args)
            return
        self.model.partial_fit(*args)
        if "rotation_spread" in model_capabilities(self.model):  # (its ω error sizes the rotation's spread)
            error = float(np.mean((self.model.prior_prediction_[..., 2] - chunk.body_velocity[..., 2]) ** 2))
            previous = self.residual_variance
            self.residual_variance = error if np.isnan(previous) else 0.8 * previous + 0.2 * error
        if self.iteration > 0 and self.cycles_in_iteration == 1 and not self.climb.active:
            self.model.reset_gamma()  # the fresh baseline has now seen the new gait once
            self.gamma = np.nan
        else:
            self.gamma = float(self.model.gamma_)

    def fit_iteration(self):
        """The ``"cycles"`` gate: fit the model on this iteration's cycles from scratch."""
        self.model.fit(*(np.concatenate(parts) for parts in zip(*self.iteration_data, strict=True)))

    def rotation_std(self) -> float:
        """Standard error of the model's predicted net rotation of the current gait (the model's
        ``rotation_std``, with σ²_ω the recent mean squared a-priori error of ω): only a predicted rotation
        beyond twice this is treated as real and restored. A model without ``rotation_std`` (the batch
        model, a model of your own) reports 0: every predicted rotation is real."""
        if "rotation_spread" not in model_capabilities(self.model):
            return 0.0
        if not np.isfinite(self.residual_variance):
            return np.inf
        return float(self.model.rotation_std(self.gait, self.residual_variance))

    def update_radius(self, value_now, step) -> None:
        """Ratio test (the :class:`~geogait.optimize.ModelStep` ``step``'s constants): compare the gain the last
        step promised with what the new model sees."""
        if self.promised is None:
            return
        low, high = step.min_trust_radius * self.scale, step.max_trust_radius * self.scale
        before, promised, boundary = self.promised
        ratio = (value_now - before) / (promised - before) if promised != before else 1.0
        # a promise worth checking broken at the smallest radius: the model misleads
        at_floor = self.radius <= low * (1 + 1e-12)
        self.distrust = self.distrust + 1 if at_floor and step.breaks(before, promised, value_now) else 0
        if ratio < step.broken_promise:  # (a radius a rejection took below low stays there)
            self.radius = max(min(low, self.radius), self.radius / 2)
        elif ratio > step.kept_promise and boundary:
            self.radius = min(high, self.radius * step.radius_growth)
        self.promised = None

    # -- checkpoint ---------------------------------------------------------------------------
    _SCALARS = ("radius", "n_cycles", "ceiling", "period", "cycle", "iteration", "cycles_in_iteration",
                "settle_left", "last_prediction", "residual_variance", "gamma", "world_heading", "tracking_limit",
                "seed_value")
    _PERIOD_SCALARS = ("robot_period", "previous_period", "seed_period")  # newer than the checkpoint format
    _COUNTERS = ("distrust", "prediction_failures", "stall")
    _STEP_COUNTERS = ("steps_by_model", "steps_by_climb")  # newer than the checkpoint format

    def to_checkpoint(self) -> tuple[dict, dict]:
        metadata = {name: _json_float(getattr(self, name)) for name in self._SCALARS + self._PERIOD_SCALARS}
        metadata["period_search"] = None if self.period_search is None else self.period_search.to_json()
        metadata.update({name: int(getattr(self, name)) for name in self._COUNTERS + self._STEP_COUNTERS})
        metadata["watch"] = self.watch.to_json()
        probe = None if self.settle_probe is None else [[float(v), float(r)] for v, r in self.settle_probe]
        metadata["settle"] = {"cycles": int(self.settle_cycles), "due": bool(self.settle_due), "probe": probe}
        metadata["tracking_follows"] = bool(self.tracking_follows)
        metadata["rng"] = self.rng.bit_generator.state
        climb = self.climb
        metadata["climb"] = {"sigma": climb.sigma, "min_sigma": climb.min_sigma, "max_sigma": climb.max_sigma,
                             "active": climb.active, "failures": climb.failures,
                             "agreements": climb.agreements, "predicted_gain": _json_float(climb.predicted_gain),
                             "rotation_limit": _json_float(climb.rotation_limit),
                             "base_period": None if climb.base is None else climb.base[1],
                             "candidate_period": None if climb.candidate is None else climb.candidate[1]}
        metadata["promised"] = None if self.promised is None else [float(v) for v in self.promised]
        family = self.family
        metadata["family"] = {"kind": family_kind(family),
                              "n_joints": family.n_joints, "order": family.order,
                              "center": float(getattr(family, "center", 0.0))}
        arrays = {"gait": self.gait.coefficients, "robot_gait": self.robot_gait.coefficients,
                  "iteration_measured": np.asarray(self.iteration_measured, dtype=float),
                  "seed_measured": np.asarray(self.seed_measured, dtype=float),
                  "gaits": np.stack([g.coefficients for g in self.gaits])}
        arrays.update(_pack_records("measured", self.measured, self.rotations))
        arrays.update(_pack_records("climb/measured", self.climb.measured, self.climb.rotations))
        for name, value in (("climb/base", self.climb.base), ("climb/candidate", self.climb.candidate)):
            if value is not None:
                arrays[name] = value[0].coefficients
        metadata["climb"]["search"] = None
        if self.climb.search is not None:
            metadata["climb"]["search"], search_arrays = self.climb.search.to_checkpoint("climb/search")
            arrays.update(search_arrays)
        if self.climb.pending is not None:
            arrays["climb/pending"] = self.climb.pending
        if self.previous_gait is not None:
            arrays["previous_gait"] = self.previous_gait.coefficients
        if self.direction is not None:
            arrays["direction"] = self.direction
        if self.seed_nets:
            arrays["seed_nets"] = np.asarray(self.seed_nets, dtype=float)
        arrays["iteration_tracking"] = np.asarray(self.iteration_tracking, dtype=float)
        arrays["iteration_excitation"] = np.asarray(self.iteration_excitation, dtype=float)
        metadata["warned_no_excitation"] = bool(self.warned_no_excitation)
        metadata["structure_switched"] = bool(self.structure_switched)
        if self.exploration is not None:
            metadata["exploration_std"] = self.exploration.std
            metadata["exploration_frequency"] = self.exploration.frequency
            arrays["exploration/state"] = self.exploration.state
            arrays["exploration/next_shape"], arrays["exploration/next_shape_velocity"] = self.excitation_next
        metadata["direction_fixed"] = bool(self.direction_fixed)
        metadata["model_class"] = None
        if self.check is not None:
            metadata["model_class"], check_arrays = self.check.to_checkpoint()
            arrays.update(check_arrays)
        for k, parts in enumerate(self.iteration_data):
            for name, value in zip(("phase", "shape", "shape_velocity", "body_velocity"), parts, strict=True):
                arrays[f"iteration_data/{k}/{name}"] = value
        frame = pd.DataFrame(self.rows)
        for column in frame.columns:
            values = frame[column].to_numpy()
            arrays[f"log/{column}"] = values.astype(str) if values.dtype == object else values  # (no pickles)
        metadata["log_columns"] = list(frame.columns)
        metadata["iteration_data"] = len(self.iteration_data)
        return metadata, arrays

    @classmethod
    def from_checkpoint(cls, metadata: dict, arrays: dict) -> RunState:
        scalars = metadata["state"]
        state = cls(gait=FourierGait(arrays["gait"]), radius=0.0, model=None, n_cycles=1, ceiling=None,
                    period=1.0)
        for name in cls._SCALARS:
            value = scalars[name]
            setattr(state, name, np.nan if value is None and name not in ("ceiling", "n_cycles") else value)
        for name in cls._PERIOD_SCALARS:  # checkpoints before the period could change: the one period
            value = scalars.get(name, state.period)
            setattr(state, name, np.nan if value is None else value)
        search = scalars.get("period_search")
        state.period_search = None if search is None else PeriodLineSearch.from_json(search)
        for name in cls._COUNTERS:
            setattr(state, name, int(scalars.get(name, 0)))
        state.watch = ChangeWatch.from_json(scalars.get("watch"))
        settle = scalars.get("settle")  # (checkpoints before "auto": the declared count, set by resume)
        if settle is not None:
            state.settle_cycles, state.settle_due = int(settle["cycles"]), bool(settle["due"])
            state.settle_probe = None if settle["probe"] is None else [tuple(p) for p in settle["probe"]]
        # (older checkpoints: the limit followed the seed's cycles only)
        state.tracking_follows = bool(scalars.get("tracking_follows", state.iteration == 0))
        state.rng = np.random.default_rng()
        if scalars.get("rng") is not None:
            state.rng.bit_generator.state = scalars["rng"]
        climb = scalars.get("climb")
        if climb is not None:
            state.climb = MeasuredClimb(
                sigma=climb["sigma"], min_sigma=climb["min_sigma"], max_sigma=climb["max_sigma"],
                active=climb["active"], failures=climb["failures"],
                agreements=climb["agreements"],
                predicted_gain=np.nan if climb["predicted_gain"] is None else climb["predicted_gain"],
                rotation_limit=np.nan if climb.get("rotation_limit") is None else climb["rotation_limit"],
                base=None if climb["base_period"] is None
                else (FourierGait(arrays["climb/base"]), climb["base_period"]),
                candidate=None if climb["candidate_period"] is None
                else (FourierGait(arrays["climb/candidate"]), climb["candidate_period"]),
                pending=arrays.get("climb/pending"))
            if climb.get("search") is not None:
                state.climb.search = MeasuredSearch.from_checkpoint(climb["search"], arrays, "climb/search")
        state.n_cycles = None if state.n_cycles is None else int(state.n_cycles)  # (None: a run without a budget)
        state.cycle = int(state.cycle)
        promised = scalars["promised"]
        state.promised = None if promised is None else (*promised[:2], bool(promised[2]))
        state.robot_gait = FourierGait(arrays["robot_gait"])
        family = scalars.get("family") or {"kind": "free", "n_joints": state.gait.n_joints, "order": state.gait.order}
        state.family = {"symmetric": lambda: SymmetricGaitFamily(family["n_joints"], family["order"], family["center"]),
                        "mirror": lambda: MirrorGaitFamily(family["n_joints"], family["order"]),
                        "free": lambda: FreeGaitFamily(family["n_joints"], family["order"])}[family["kind"]]()
        if climb is not None and climb.get("search") is None and state.climb.active:
            state.climb.search = _evolution_of_old(state, climb, arrays)
        state.previous_gait = FourierGait(arrays["previous_gait"]) if "previous_gait" in arrays else None
        state.direction = arrays.get("direction")
        # checkpoints before the averaged direction fixed it at the first measured cycle
        state.direction_fixed = bool(scalars.get("direction_fixed", state.direction is not None))
        state.seed_nets = list(arrays["seed_nets"]) if "seed_nets" in arrays else []
        tracking = arrays.get("iteration_tracking")
        trial = state.period_search is not None and state.period_search.trial_from is not None
        if tracking is None and trial:  # earlier checkpoints: a period trial's in progress (else possibly stale)
            tracking = arrays.get("trial_tracking")
        elif tracking is None and int(state.iteration) == 0:  # earlier checkpoints: the seed's cycles
            tracking = arrays.get("seed_tracking")
        state.iteration_tracking = [] if tracking is None else tracking.tolist()
        state.iteration_excitation = arrays["iteration_excitation"].tolist() if "iteration_excitation" in arrays else []
        state.warned_no_excitation = bool(scalars.get("warned_no_excitation", False))
        state.structure_switched = bool(scalars.get("structure_switched", False))
        if scalars.get("model_class") is not None:
            state.check = ModelClassCheck.from_checkpoint(scalars["model_class"], arrays)
        if scalars.get("exploration_std") is not None:
            state.exploration = ExcitationSignal(scalars["exploration_std"], state.gait.n_joints, state.rng,
                                                 scalars.get("exploration_frequency", 2.0),
                                                 initial_state=np.array(arrays["exploration/state"], dtype=float))
            state.excitation_next = (np.array(arrays["exploration/next_shape"], dtype=float),
                                     np.array(arrays["exploration/next_shape_velocity"], dtype=float))
        state.iteration_measured = arrays["iteration_measured"].tolist()
        state.seed_measured = arrays["seed_measured"].tolist()
        state.gaits = [FourierGait(c) for c in arrays["gaits"]]
        state.measured, state.rotations = _unpack_records("measured", arrays, state.period)
        if state.climb is not None:
            state.climb.measured, state.climb.rotations = _unpack_records("climb/measured", arrays, state.period)
        names = ("phase", "shape", "shape_velocity", "body_velocity")
        state.iteration_data = [tuple(arrays[f"iteration_data/{k}/{n}"] for n in names)
                                for k in range(scalars["iteration_data"])]
        columns = scalars["log_columns"]
        state.rows = pd.DataFrame({c: arrays[f"log/{c}"].tolist() if arrays[f"log/{c}"].dtype.kind == "U"
                                   else arrays[f"log/{c}"] for c in columns}).to_dict("records")
        # (checkpoints before the counts: the steps of the log so far)
        model_steps = sum(bool(r["step"] and not r["climb"] and not r.get("period_change", False)
                               and not r["rejected"] and not r["reverted"]) for r in state.rows)
        counted = {"steps_by_model": model_steps, "steps_by_climb": sum(bool(r["climb"]) for r in state.rows)}
        for name in cls._STEP_COUNTERS:
            setattr(state, name, int(scalars.get(name, counted[name])))
        if metadata["model"] is not None:
            state.model = model_from_state(metadata["model"]["metadata"], prefixed_arrays(arrays, "model/"))
        return state


def _pack_records(prefix: str, values: dict, rotations: dict) -> dict:
    """Arrays of a record {(gait, period): [value per cycle]} and its rotations (a checkpoint's)."""
    if not values:
        return {}
    return {f"{prefix}/gaits": np.stack([g.coefficients for g, _ in values]),
            f"{prefix}/periods": np.array([period for _, period in values], dtype=float),
            f"{prefix}/counts": np.array([len(v) for v in values.values()]),
            f"{prefix}/values": np.concatenate([np.asarray(v, dtype=float) for v in values.values()]),
            f"{prefix}/rotations": np.concatenate([np.asarray(rotations[k], dtype=float) for k in values])}


def _unpack_records(prefix: str, arrays: dict, period: float) -> tuple[dict, dict]:
    """Inverse of :func:`_pack_records`; older checkpoints lack periods (the one period) and rotations."""
    if f"{prefix}/gaits" not in arrays:
        return {}, {}
    split = np.cumsum(arrays[f"{prefix}/counts"])[:-1]
    values = np.split(arrays[f"{prefix}/values"], split)
    periods = arrays.get(f"{prefix}/periods", np.full(len(values), period))
    keys = [(FourierGait(c), float(t)) for c, t in zip(arrays[f"{prefix}/gaits"], periods, strict=True)]
    rotations = (np.split(arrays[f"{prefix}/rotations"], split) if f"{prefix}/rotations" in arrays
                 else [np.zeros(0)] * len(values))
    return ({k: v.tolist() for k, v in zip(keys, values, strict=True)},
            {k: r.tolist() for k, r in zip(keys, rotations, strict=True)})


def _json_float(value):
    if isinstance(value, float | np.floating) and not np.isfinite(value):
        return None
    return value.item() if isinstance(value, np.generic) else value


def prefixed_arrays(arrays: dict, prefix: str) -> dict:
    return {k.removeprefix(prefix): v for k, v in arrays.items() if k.startswith(prefix)}


def checkpoint_path(checkpoint, owner):
    if checkpoint is None:
        return None
    path = Path(checkpoint)
    if path.is_dir() or not path.parent.is_dir():
        raise fail("checkpoint", owner, "a file path in an existing folder", str(path))
    return path


def params_to_json(optimizer) -> dict:
    """Hyper-parameters as JSON values: parts and the model as their class name and parameters."""
    return {name: describe_params(value) for name, value in optimizer.get_params(deep=False).items()}


def _evolution_of_old(state: RunState, climb: dict, arrays: dict) -> EvolutionSearch:
    """The evolution strategy of a checkpoint written before it was a search of its own (its step length,
    mirror and direction then stood in the climb's record)."""
    base, period = state.climb.base

    def coordinates(key):  # (at the base's period)
        point = state.family.params_of(key[0], tolerance=1e-8)
        return point if state.period_search is None else np.append(point, state.scale * np.log(key[1] / period))

    origin = coordinates(state.climb.base)
    if state.climb.candidate is not None:  # (the point of the candidate being measured, for the search's record)
        state.climb.pending = coordinates(state.climb.candidate)
    return EvolutionSearch(origin=origin, radius=climb["sigma"], final_radius=climb["min_sigma"], period=period,
                           max_radius=climb["max_sigma"], sigma=climb["sigma"], mirror=bool(climb["mirror"]),
                           direction=arrays.get("climb/direction"))


def params_from_json(params: dict) -> dict:
    """The optimiser's parameters from :func:`params_to_json`'s values, or from a checkpoint of the flat
    parameters that came before the parts (:func:`~geogait.optimize._presets.from_flat_params`)."""
    if "trust_radius" in params:
        from ._presets import from_flat_params  # (the presets build optimisers: imported when read)

        return from_flat_params({**params, "model": _built(params.get("model"))})
    return {name: _built(value) for name, value in params.items()}


def _built(value):
    """A part or model from its JSON description (lists of them too); other values as they are."""
    if isinstance(value, list):
        return [_built(v) for v in value]
    if not (isinstance(value, dict) and set(value) == {"class", "params"}):
        return value
    from . import _adaptation, _checks, _climb, _exploration, _objective, _parts  # (the part classes, by name)

    classes = {name: getattr(module, name) for module in (_parts, _checks, _objective, _exploration, _adaptation,
                                                          _climb)
               for name in module.__all__ if isinstance(getattr(module, name), type)}
    rules = [_climb.SearchRule]  # (with the rules users wrote, of classes imported by now)
    for rule in rules:
        rules.extend(rule.__subclasses__())
    classes.update({rule.__name__: rule for rule in rules})
    name = value["class"]
    if name in models.__all__:
        return getattr(models, name)(**value["params"])
    if name not in classes:
        raise ValueError(f"unknown part or model class {name!r}")
    return classes[name](**{k: _built(v) for k, v in value["params"].items()})
