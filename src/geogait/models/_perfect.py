r"""Perfect information: the true connection of a simulated system in place of a learned model.

With it, an optimisation study measures the step rule alone (how many steps, how close to the
ceiling) with no model error; the difference to a run with a learned model is the model's share.
"""

from __future__ import annotations

import numpy as np

from .._docs import fill_doc
from .._estimator import Estimator, InstanceOf, Integer
from .._validation import check_array, fail
from ..gaits import FourierGait
from ..simulate import TrueMotion
from ..systems import System

__all__ = ["PerfectInformationModel"]


@fill_doc
class PerfectInformationModel(Estimator):
    r"""The model interface of the gait models, answered exactly by a known :class:`~geogait.systems.System`.

    ``partial_fit`` only records the data's shape dimension (there is nothing to learn),
    :meth:`predict` is :math:`\xi = -A(r)\dot r` and :meth:`predict_displacement` is the oracle
    :func:`~geogait.simulate.cycle_displacement`; Γ is 1 by definition and ``rebase`` does nothing.

    Parameters
    ----------
    system : System
        The true system (a simulator's).
    resolution : int
        Magnus steps per cycle of the oracle.

    Attributes
    ----------
    n_joints_ : int
    batch_shape_ : tuple
    gamma_ : float
        Always 1.0.
    prior_prediction_ : ndarray of shape (..., 3)
        −A(r)ṙ of the samples of the last ``partial_fit`` call.

    Examples
    --------
    >>> from geogait.systems import PurcellSwimmer
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import cycle_displacement
    >>> model = PerfectInformationModel(system=PurcellSwimmer(3))
    >>> bool(np.allclose(model.predict_displacement(seed_gait(2)),
    ...                  cycle_displacement(PurcellSwimmer(3), seed_gait(2), resolution=128)))
    True
    """

    _parameter_constraints = {
        "system": InstanceOf(System, "a System (an object with n_joints and connection)", none=False),
        "resolution": Integer(minimum=4),
    }

    def __init__(self, *, system: System | None = None, resolution: int = 128):
        self.system = system
        self.resolution = resolution

    def _check_system(self) -> System:
        self.validate()
        return self.system

    def fit(self, phase, shape, shape_velocity, body_velocity):
        """Same as :meth:`partial_fit` (nothing is learned). Returns ``self``.

        Parameters
        ----------
        %(samples)s
        """
        return self.partial_fit(phase, shape, shape_velocity, body_velocity)

    def partial_fit(self, phase, shape, shape_velocity, body_velocity):
        """Check the samples against the system; nothing is learned. Returns ``self``.

        ``prior_prediction_`` is set to −A(r)ṙ of the samples.

        Parameters
        ----------
        %(samples)s
        """
        system = self._check_system()
        owner = f"{type(self).__name__}.partial_fit"
        phase = check_array(phase, "phase", owner)
        for value, name, width in ((shape, "shape", system.n_joints), (shape_velocity, "shape_velocity",
                                                                       system.n_joints),
                                   (body_velocity, "body_velocity", 3)):
            value = check_array(value, name, owner, trailing=(width,))
            if value.shape[:-1] != phase.shape:
                raise fail(name, owner, f"an array of shape {phase.shape + (width,)} matching 'phase'",
                           f"shape {value.shape}")
        self.n_joints_ = system.n_joints
        self.batch_shape_ = ()
        self.prior_prediction_ = self.predict(phase, shape, shape_velocity)
        return self

    def predict(self, phase, shape, shape_velocity) -> np.ndarray:
        """ξ = −A(r)ṙ of samples ``(..., d)`` → ``(..., 3)`` (``phase`` only for the common interface).

        Parameters
        ----------
        phase : array-like
            Ignored: the connection depends on the shape only.
        shape : array-like of shape (..., d)
            Joint angles r, radians.
        shape_velocity : array-like of shape (..., d)
            Joint angular velocities ṙ, radians per unit time; ξ comes back in the same time unit.
        """
        system = self._check_system()
        owner = f"{type(self).__name__}.predict"
        shape = check_array(shape, "shape", owner, trailing=(system.n_joints,))
        shape_velocity = check_array(shape_velocity, "shape_velocity", owner, trailing=(system.n_joints,))
        return -np.einsum("...kj,...j->...k", system.connection(shape), shape_velocity)

    def score(self, phase, shape, shape_velocity, body_velocity, baseline=None) -> float:
        """Γ = 1: the model is the truth (not computed from noisy data).

        Parameters
        ----------
        phase, shape, shape_velocity, body_velocity : array-like
            Held-out samples, as for :meth:`partial_fit`; ignored (not even checked).
        baseline : PhaseModel, optional
            Ignored: there is no phase-model baseline to compare with.
        """
        return 1.0

    def predict_displacement(self, gait: FourierGait, *, jacobian: bool = False):
        """Exact net ``(x, y, heading)`` per cycle of ``gait`` (and its ``(3, p)`` Jacobian).

        Parameters
        ----------
        gait : FourierGait
            The gait, with the system's number of joints.
        jacobian : bool, default False
            Also return the ``(3, p)`` derivative with respect to the gait's ``p`` flat Fourier parameters.
        """
        system = self._check_system()
        if not isinstance(gait, FourierGait) or gait.n_joints != system.n_joints:
            raise fail("gait", f"{type(self).__name__}.predict_displacement",
                       f"a FourierGait with {system.n_joints} joints", gait)
        return TrueMotion(system, self.resolution)(gait, jacobian=jacobian)

    def rebase(self, gait: FourierGait | None = None, **options):
        """Nothing to re-centre; options are accepted and ignored. Returns ``self``.

        Parameters
        ----------
        gait : FourierGait, optional
            The new nominal gait; ignored, since the system's connection holds for every gait.
        """
        return self

    def __sklearn_is_fitted__(self) -> bool:
        return True  # stateless: the system is the model

    @property
    def gamma_(self) -> float:
        """1.0: perfect information."""
        return 1.0

    def reset_gamma(self):
        """Nothing to reset. Returns ``self``."""
        return self
