r"""Adapting to a change of the robot or its world that nobody announces: the :class:`Adaptation` part.

A black-box search keeps records; a model can notice that they are stale. The part watches the one gait the run
holds (the climb's base, the gait a revert goes back to, or the gait the model holds) each time it is measured
again:

**Notice.** A cycle of a gait that has a record from an earlier visit, or that has been held for four measured
cycles or more without a break, is compared with that record (a held gait at ``threshold`` + 1: it is tested at
every cycle, not once a check). Let
:math:`m` be the record's mean, :math:`n` its cycles and :math:`\sigma` the pooled cycle-to-cycle standard
deviation within the run's gaits (of :math:`\nu` degrees of freedom). The cycle is *out of band* when

.. math::  |v - m| > t_\nu \, \sigma \sqrt{1 + 1/n} \quad\text{and}\quad |v - m| > \text{min\_change}\,|m|,

with :math:`t_\nu` Student's quantile of the two-sided level that ``threshold`` standard deviations have for a
normal noise (3: p = 0.0027). Where the model's recent prediction residuals of climb candidates (below) are more
than the repeated cycles, their robust spread (1.4826 × the median absolute deviation; it holds the model's error
too, so it errs wide) stands for σ. An out-of-band cycle holds the gait one more cycle; a change is detected when the
two cycles' mean is out of band on the same side (:math:`\sqrt{1/2 + 1/n}` in place of :math:`\sqrt{1 + 1/n}`).
A held gait's last four cycles are tested too, their mean against the cycles before them: a change smaller than
a robot's cycle-to-cycle spread shows in that mean before it shows in any one cycle.
In a family that promises no net rotation (symmetric, mirror), every rotation measured is noise until a change:
a gait measured twice or more whose mean rotation is beyond the band of that noise at ``threshold`` + 1 (σ: the RMS
of every rotation recorded, those of dropped records too; one σ stricter, as it is tested at every such cycle) and
beyond the climb's rotation tolerance, at two cycles in a row of that gait, is a change too. While the climb
runs, the held gait is measured again after every ``check_every`` of its candidates: a check costs one cycle,
two when the first is out of band. The model's surprise brings a check forward: while the climb runs and the model is
confident (Γ over the climb's cycles at least the gate's Γ*), it predicts each candidate's objective before it is
measured; two residuals in a row beyond ``threshold`` robust
standard deviations of the recent ones (1.4826 × their median absolute deviation), on the same side, make the
check due at once.

**Forget.** On a detection the records made before it are dropped — every gait's measured mean, the climb's
history and its search, the revert's reference, the trust radius's ratio test — and the model forgets its
evidence (``model.forget(forget)``, a covariance reset that keeps its weights as the starting point).

**Widen.** A rotation detected holds every later climb's candidates to the climb's rotation tolerance (not to
what its base measures). With ``widen_family``, rotation detected in the symmetric family moves the run to the
mirror family where the robot declares mirror symmetry (the held gait projected into it: its offsets and even
harmonics dropped), else to the free family; rotation detected in the mirror family moves it to the free family.
The model is rebuilt for the wider family.

**Lead.** With ``lead="model"`` the paper's loop carries the recovery: the re-learning model steps when Γ opens
its gate and its prediction agrees with what is measured; where it does not, the climb starts again from the held
gait. With ``lead="climb"`` the climb starts again at once. With ``lead="auto"`` (default) the recovery starts as
the run did: the climb at once where the :class:`~geogait.optimize.Climb` starts first (``start="first"``), the
model where it steps first (a structured model, whose prediction holds far from its data). Either way a climb
after a change starts at a step length set by the change's size :math:`s = |\bar v - m| / |m|`:
:math:`\sigma + (\sigma_\text{first} - \sigma) \min(1, s)` (the :class:`~geogait.optimize.Climb`'s ``sigma``
and ``first_sigma``).

Every detection is a row of the run's log (column ``change``: its evidence) and an entry of
``InSituResult.changes`` (cycle, evidence, measured, reference, noise).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .._estimator import Integer, Options, Real
from ._part import Part

__all__ = ["Adaptation", "ChangeWatch"]

#: The evidence a detection names.
EVIDENCE = ("objective", "rotation")


class Adaptation(Part):
    """Notice a change of the robot or its world, forget the records it made stale, and lead the recovery
    (module :mod:`geogait.optimize._adaptation`).

    Parameters
    ----------
    threshold : float
        Standard deviations of the cycle-to-cycle noise (normal-equivalent; Student's t for the noise's degrees of
        freedom) beyond which a measured cycle of the held gait is out of its band.
    min_change : float
        Smallest relative change of the held gait's measured objective that counts (a change below it is not
        worth forgetting what was learned; it also bounds a noiseless robot's alarms).
    check_every : int
        Candidates of the climb between two checks of the held gait (sooner when the model is surprised).
    forget : float
        The factor by which the model discounts its evidence on a detection (``model.forget``: each direction of
        its covariance back towards the prior's, its weights kept as the starting point; 1: keep the evidence).
    widen_family : bool
        On rotation detected in a family that promises none, search the next wider family.
    lead : {"auto", "model", "climb"}
        Who takes the steps after a detection: the re-learning model where it predicts (the climb where it does
        not), the climb at once, or (``"auto"``) the one that took the run's first steps.
    """

    _parameter_constraints = {
        "threshold": Real(low=0, low_open=True),
        "min_change": Real(low=0),
        "check_every": Integer(minimum=1),
        "forget": Real(low=1),
        "widen_family": Options((True, False)),
        "lead": Options(("auto", "model", "climb")),
    }

    def __init__(self, *, threshold: float = 3.0, min_change: float = 0.05, check_every: int = 10,
                 forget: float = 1e6, widen_family: bool = True, lead: str = "auto"):
        self.threshold = threshold
        self.min_change = min_change
        self.check_every = check_every
        self.forget = forget
        self.widen_family = widen_family
        self.lead = lead

    def band(self, dof: int, strict: bool = False) -> float:
        """The out-of-band factor for a noise estimate of ``dof`` degrees of freedom (Student's quantile at the
        two-sided level of ``threshold`` normal standard deviations; infinite without any).

        Parameters
        ----------
        dof : int
        strict : bool
            At ``threshold`` + 1 (a test made at every cycle rather than once a check).

        Returns
        -------
        float
        """
        if dof < 1:
            return np.inf
        level = 2 * stats.norm.sf(self.threshold + strict)
        return float(stats.t.isf(level / 2, dof))

    def reopen_sigma(self, sigma: float, first_sigma: float, size: float) -> float:
        """The climb's step length after a change of relative size ``size`` (module docstring).

        Parameters
        ----------
        sigma, first_sigma : float
            The :class:`~geogait.optimize.Climb`'s step lengths after the model and at the start.
        size : float
            The change's relative size (0: none; 1 or more: as large as the objective itself).

        Returns
        -------
        float
        """
        return sigma + (first_sigma - sigma) * min(1.0, size)


@dataclass
class ChangeWatch:
    """The run state of an :class:`Adaptation`.

    Parameters
    ----------
    since_check : int
        Climb candidates measured since the held gait was last measured.
    suspect : list
        ``[reference length, iteration, cycles in it, strict]`` of a cycle that tripped the test (the gait's records
        after the reference are the cycles tested), awaiting the next cycle, judged at the same band (empty: none).
    reopen : float
        The step length of the next climb after a detection (NaN: the Climb's own).
    events : list of dict
        Every detection: ``cycle``, ``evidence``, ``measured``, ``reference``, ``noise``, ``family``.
    rotation_free : bool
        A rotation was detected: every later climb holds its candidates to the Climb's ``rotation_tolerance``, not
        to the rotation its base measures.
    turning : int
        Cycles in a row whose gait's mean rotation was out of its band (two make a detection).
    residuals, surprise : list of float, int
        The model's recent prediction residuals of climb candidates, and the side (±1, 0: none) of the last one
        beyond their band (two on one side make the held gait's check due).
    noise_ss, noise_dof : float, int
        The sum of squared deviations and degrees of freedom of the records the run has dropped (a hand-back, a
        climb's restart, a change): the noise estimate keeps them.
    rotation_ss, rotation_n : float, int
        The sum of squared rotations and their count in those records (the rotation noise of a family that
        promises none).
    """

    since_check: int = 0
    suspect: list = field(default_factory=list)
    reopen: float = np.nan
    events: list = field(default_factory=list)
    rotation_free: bool = False
    turning: int = 0
    residuals: list = field(default_factory=list)
    surprise: int = 0
    noise_ss: float = 0.0
    noise_dof: int = 0
    rotation_ss: float = 0.0
    rotation_n: int = 0

    def archive_rotations(self, *rotations: dict) -> None:
        """Keep the sum of squares of the rotations of ``rotations`` (records about to be dropped)."""
        for record in rotations:
            for cycles in record.values():
                cycles = np.asarray(cycles, dtype=float)
                self.rotation_ss, self.rotation_n = self.rotation_ss + float(np.sum(cycles ** 2)), \
                    self.rotation_n + cycles.size

    def archive(self, *records: dict) -> None:
        """Keep the cycle-to-cycle spread of ``records`` (about to be dropped) for later noise estimates."""
        sigma, dof = pooled_noise(*records)
        if dof:
            self.noise_ss, self.noise_dof = self.noise_ss + sigma ** 2 * dof, self.noise_dof + dof

    def noise(self, *records: dict) -> tuple[float, int]:
        """The pooled cycle-to-cycle standard deviation of ``records`` and of every record archived, and its
        degrees of freedom."""
        sigma, dof = pooled_noise(*records)
        total = dof + self.noise_dof
        if total == 0:
            return np.nan, 0
        squares = (sigma ** 2 * dof if dof else 0.0) + self.noise_ss
        return float(np.sqrt(squares / total)), total

    def to_json(self) -> dict:
        return {"since_check": self.since_check, "suspect": [float(v) for v in self.suspect],
                "reopen": None if np.isnan(self.reopen) else float(self.reopen), "events": self.events,
                "rotation_free": self.rotation_free, "turning": self.turning,
                "residuals": [float(r) for r in self.residuals], "surprise": self.surprise,
                "noise_ss": float(self.noise_ss), "noise_dof": int(self.noise_dof),
                "rotation_ss": float(self.rotation_ss), "rotation_n": int(self.rotation_n)}

    @classmethod
    def from_json(cls, data: dict | None) -> ChangeWatch:
        if data is None:  # (a checkpoint of a run without adaptation)
            return cls()
        # (older checkpoints' suspects led with the cycle's value and rotation)
        return cls(since_check=int(data["since_check"]), suspect=list(data["suspect"])[-4:],
                   reopen=np.nan if data["reopen"] is None else float(data["reopen"]), events=list(data["events"]),
                   rotation_free=bool(data["rotation_free"]), turning=int(data["turning"]),
                   residuals=[float(r) for r in data["residuals"]], surprise=int(data["surprise"]),
                   noise_ss=float(data["noise_ss"]), noise_dof=int(data["noise_dof"]),
                   rotation_ss=float(data["rotation_ss"]), rotation_n=int(data["rotation_n"]))


def pooled_noise(*records: dict) -> tuple[float, int]:
    """The pooled within-gait standard deviation of the records ({key: [value per cycle]}) and its degrees of
    freedom (0 when no gait was measured twice)."""
    groups = [np.asarray(v, dtype=float) for record in records for v in record.values() if len(v) >= 2]
    dof = sum(g.size - 1 for g in groups)
    if dof == 0:
        return np.nan, 0
    return float(np.sqrt(sum(np.sum((g - g.mean()) ** 2) for g in groups) / dof)), dof
