"""Docstring parts that several public callables share, written once (scipy's ``doccer`` idea).

A docstring line holding only ``%(name)s`` is replaced by the part ``name``, indented like that line;
:func:`fill_doc` does it for a function, or for every method of a class.
"""

from __future__ import annotations

import inspect
import textwrap

__all__ = ["fill_doc"]

PARTS = {
    "samples": """\
phase : array-like of shape batch + (n,)
    Gait phase φ of each sample, radians, in time order.
shape : array-like of shape batch + (n, d)
    Joint angles r of each sample, radians.
shape_velocity : array-like of shape batch + (n, d)
    Joint angular velocities ṙ, radians per unit of the data's time (seconds, or cycles).
body_velocity : array-like of shape batch + (n, 3)
    Measured body velocity ξ = (v_x, v_y, ω): body lengths and radians per unit of time.""",
    "phase_samples": """\
phase : array-like of shape batch + (n,)
    Gait phase φ of each sample, radians, in time order.
body_velocity : array-like of shape batch + (n, 3)
    Measured body velocity ξ = (v_x, v_y, ω): body lengths and radians per unit of time.""",
    "result_fields": """\
frame : pandas.DataFrame
    Long-format results, with the columns of ``COLUMNS``.
config : dataclass or None
    The experiment's configuration that produced ``frame``; None for results read back from a CSV.
wall_time_s : float or None
    Wall-clock time of the sweep, seconds.
n_workers : int or None
    Number of workers that ran the sweep.""",
    "simulation": """\
samples_per_cycle : int
    Simulated samples per gait cycle.
sensor_noise : float
    Std of the noise on measured ξ, as a fraction of its RMS.
perturbation : float
    Stationary std (rad) of the shape perturbation δ of eq. 8.""",
    "online_gamma_params": """\
gamma_forgetting : float in (0, 1]
    λ_Γ of the online Γ (eq. 6).
n_windows, smoothing_order : int
    Phase windows and smoothing of the phase model ξ_T (the Γ baseline).
baseline_forgetting : float in (0, 1]
    Forgetting of the phase model, per window update.
resolution : int
    Magnus steps per cycle in :meth:`predict_displacement`.""",
    "step": """\
problem : StepProblem
    The predictor, family, objective, rotation row and joint limits of this step.
params : array-like of shape (n_params,)
    Current free parameters q₀ (within the joint limits).
radius : float
    Trust radius R (rad): bound on ‖T Δq‖, the step's Euclidean length in Fourier parameters
    (the same distance between gaits in every family).
rotation_target : float
    c*: 0 restores zero rotation; the current predicted rotation keeps it (when it is within
    the model's resolution).
min_gain : float
    Smallest predicted relative gain accepted.
restore : bool
    Accept a feasible step on the rotation target even without a gain.""",
    "subspace_attributes": """\
Attributes
----------
matrix : ndarray of shape (d (2K + 1), n_params)
    ∂(Fourier parameters)/∂(free parameters), constant.""",
    "sweep": """\
jobs : int
    joblib workers (1 in-process, -1 all cores).
scheduler : str or distributed.Client, optional
    Run on a Dask cluster instead.
progress : bool
    Show a progress bar on stderr.""",
    "preset": """**params
    Further parameters, as :meth:`~geogait.optimize.InSituOptimizer.set_params` takes them.

Returns
-------
InSituOptimizer""",
}


def _filled(doc: str | None) -> str | None:
    if not doc or "%(" not in doc:
        return doc
    lines = []
    for line in doc.split("\n"):
        token = line.strip()
        if token.startswith("%(") and token.endswith(")s") and token[2:-2] in PARTS:
            indent = line[:len(line) - len(line.lstrip())]
            lines.append(textwrap.indent(PARTS[token[2:-2]], indent))
        else:
            lines.append(line)
    return "\n".join(lines)


def fill_doc(obj):
    """Fill the shared parts into ``obj``'s docstring (a function) or its methods' (a class); returns ``obj``."""
    if inspect.isclass(obj):
        for member in vars(obj).values():
            function = member.__func__ if isinstance(member, classmethod | staticmethod) else member
            while inspect.isfunction(function):  # (and the function a decorator wraps: documentation tools read it)
                function.__doc__ = _filled(function.__doc__)
                function = getattr(function, "__wrapped__", None)
    obj.__doc__ = _filled(obj.__doc__)
    return obj
