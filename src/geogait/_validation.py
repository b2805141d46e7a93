"""Input checks shared by every module, with one error template.

Messages follow scikit-learn's: "The 'x' parameter of Y must be ... Got ... instead."
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


class GeogaitError(ValueError):
    """Base class for geogait's input errors (a ``ValueError``)."""


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def fail(name: str, owner: str, expected: str, got) -> GeogaitError:
    """Build the standard error for parameter ``name`` of ``owner``."""
    return GeogaitError(
        f"The '{name}' parameter of {owner} must be {expected}. Got {_short(got)} instead."
    )


def check_int(value, name: str, owner: str, *, minimum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise fail(name, owner, f"an int{'' if minimum is None else f' >= {minimum}'}", value)
    if minimum is not None and value < minimum:
        raise fail(name, owner, f"an int >= {minimum}", value)
    return int(value)


def check_float(
    value,
    name: str,
    owner: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """A finite real number in the interval given by ``low``/``high`` (closed unless ``*_open``)."""
    lo = "-inf" if low is None else f"{low:g}"
    hi = "inf" if high is None else f"{high:g}"
    interval = f"{'(' if low_open or low is None else '['}{lo}, {hi}{')' if high_open or high is None else ']'}"
    expected = f"a finite float in {interval}"
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise fail(name, owner, expected, value)
    value = float(value)
    if not np.isfinite(value):
        raise fail(name, owner, expected, value)
    if low is not None and (value < low or (low_open and value == low)):
        raise fail(name, owner, expected, value)
    if high is not None and (value > high or (high_open and value == high)):
        raise fail(name, owner, expected, value)
    return value


def not_real(value) -> str | None:
    """What makes ``value`` other than real numbers (complex numbers, booleans, text), or None: NumPy would
    cast each silently (dropping an imaginary part, reading True as 1)."""
    dtype, items = getattr(value, "dtype", None), None
    if not isinstance(dtype, np.dtype):  # a list, a scalar: as NumPy reads it (a ragged one fails later)
        try:
            dtype = np.asarray(value).dtype
            items = np.asarray(value, dtype=object).flat  # (a mixed list: NumPy reads [1, True] as [1, 1])
        except (TypeError, ValueError):
            return None
    elif dtype.kind == "O":
        items = np.asarray(value).flat
    if dtype.kind == "c":
        return "complex numbers"
    if dtype.kind == "b":
        return "booleans (True/False), not numbers"
    if dtype.kind in "USV":
        return f"text ({dtype}), not numbers"
    if items is not None and any(isinstance(item, str | bytes | complex | bool | np.bool_ | np.complexfloating)
                                 for item in items):
        return "text, booleans or complex numbers among its values"
    return None


def check_array(
    value,
    name: str,
    owner: str,
    *,
    trailing: Sequence[int | None] = (),
    min_ndim: int | None = None,
    ndim: int | None = None,
    limit: float | None = None,
) -> np.ndarray:
    """A finite float array whose last axes match ``trailing`` (``None`` = any length).

    With ``limit``, every value must also lie within ``±limit`` (see :func:`check_magnitude`).

    ``shape`` names in messages read like ``(..., 3)``.
    """
    if value is None:
        raise fail(name, owner, "an array of real numbers", None)
    what = not_real(value)
    if what is not None:  # (float() would drop an imaginary part, read True as 1 or "1.5" as a number)
        raise fail(name, owner, "an array of real numbers", what)
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise fail(name, owner, "an array of real numbers", value) from None
    spec = "(..., " + ", ".join("n" if t is None else str(t) for t in trailing) + ")"
    if ndim is not None and array.ndim != ndim:
        raise fail(name, owner, f"an array with {ndim} dimension(s)", f"shape {array.shape}")
    need = max(len(trailing), min_ndim or 0)
    if array.ndim < need:
        raise fail(name, owner, f"an array of shape {spec}", f"shape {array.shape}")
    for axis, size in enumerate(trailing):
        actual = array.shape[array.ndim - len(trailing) + axis]
        if size is not None and actual != size:
            transposed = len(trailing) == 1 and array.ndim == 2 and array.shape[-2] == size
            hint = " (transposed? samples go along the first axis)" if transposed else ""
            raise fail(name, owner, f"an array of shape {spec}{hint}", f"shape {array.shape}")
    if limit is not None:  # one reduction checks finiteness and magnitude together (NaN fails `<=`)
        if array.size and not float(np.max(np.abs(array))) <= limit:
            if np.all(np.isfinite(array)):
                check_magnitude(array, name, owner, limit)
        else:
            return array
    if not np.all(np.isfinite(array)):
        bad = int(np.size(array) - np.count_nonzero(np.isfinite(array)))
        raise fail(name, owner, "finite (no NaN or inf)", f"{bad} non-finite value(s)")
    return array


def check_callback(callback, record, owner: str) -> None:
    """A run's ``callback`` (a callable or None) and ``record`` (True or False), checked before it starts."""
    if callback is not None and not callable(callback):
        raise fail("callback", owner, "a callable (called with each log row) or None", type(callback).__name__)
    if not isinstance(record, bool | np.bool_):
        raise fail("record", owner, "True or False", record)


def check_choice(value, name: str, owner: str, choices: Sequence[str]) -> str:
    if value not in choices:
        raise fail(name, owner, "one of " + ", ".join(repr(c) for c in choices), value)
    return value


#: Largest magnitude accepted for any sample value (angles, rates, velocities, poses, time steps):
#: far beyond any physical reading in any unit, and small enough that the products the models form
#: (regressors δ ⊗ δ̇, covariance updates) stay far from overflow.
MAX_MAGNITUDE = 1e12


def check_magnitude(array: np.ndarray, name: str, owner: str, limit: float = MAX_MAGNITUDE) -> np.ndarray:
    """Raise the standard error when a finite ``array`` holds a value beyond ``±limit``.

    Parameters
    ----------
    array : ndarray
        Finite.
    name, owner : str
        For the message.
    limit : float

    Returns
    -------
    ndarray
        ``array``.
    """
    if array.size and np.abs(array).max() > limit:
        index = np.unravel_index(int(np.argmax(np.abs(array))), array.shape)
        raise fail(name, owner, f"plausible values, within ±{limit:g}",
                   f"{float(array[index]):g} at index {tuple(int(i) for i in index)}")
    return array


class GeogaitWarning(UserWarning):
    """Warnings about implausible but accepted input (degrees given as radians, time units)."""


def warn_if_degrees(shape: np.ndarray, name: str, owner: str) -> bool:
    """Warn when joint angles reach beyond a full turn (2π): degrees given as radians?

    Parameters
    ----------
    shape : ndarray
        Joint angles, finite.
    name, owner : str
        For the message.

    Returns
    -------
    bool
        Whether it warned.
    """
    import warnings

    if shape.size and np.abs(shape).max() > 2 * np.pi:
        warnings.warn(f"The '{name}' values of {owner} reach {float(np.abs(shape).max()):.4g}, more than a full "
                      "turn (2π): geogait expects radians; were they given in degrees?", GeogaitWarning,
                      stacklevel=3)
        return True
    return False


#: Most memory (bytes) one model, constraint set or plan may ask for: what a 16 GB machine spares one run.
MAX_BYTES = 4 * 2**30


def check_bytes(n_bytes: float, what: str, owner: str, largest: str) -> None:
    """Raise when ``what`` would take more than :data:`MAX_BYTES`, before it is allocated.

    Parameters
    ----------
    n_bytes : float
        The estimate.
    what : str
        What would take it ("a window model of 99 joints").
    owner : str
        Who asked (for the message).
    largest : str
        The largest supported value, in words ("at most 70 joints").
    """
    if n_bytes > MAX_BYTES:
        raise GeogaitError(f"{owner}: {what} would take {n_bytes / 2**30:.4g} GiB of memory, more than the "
                           f"{MAX_BYTES / 2**30:g} GiB one run may use; {largest}.")


#: Longest a single solver step may block (seconds): SIGTERM and Ctrl-C wait for it. A signal may take 2 s in all;
#: what follows it takes at most 0.5 s (an interrupted optimize's CSV and summary, the exit), and the longest compiled
#: call of SLSQP at the largest sizes accepted was 0.7 s (measured on a loaded 2-core machine: the 38-link swimmer's
#: ceiling, 4736 rows over 111 parameters; 0.4 s at --order 21, 0.24 s at --order 13 with speed rows).
MAX_SOLVE_SECONDS = 1.0
#: Rate of SciPy's SLSQP on m inequality rows over n parameters, in m² n per second (measured on a loaded 2-core
#: machine: 8192 rows over 66 parameters, d = 2 and K = 16 with speed rows, 1.72 s between two callbacks).
_SOLVE_RATE = 2.5e9


def _joint_rows(n_joints: int, order: int, speed_limit: bool) -> float:
    """Rows of the optimiser's joint limits: angle (and speed) on 64 K phases per joint, two signs each."""
    return (2 if speed_limit else 1) * 2 * 64 * order * n_joints


def gait_bytes(n_joints: int, order: int, speed_limit: bool = True) -> float:
    """Bytes the optimiser's joint-limit rows take for a gait family of d joints and Fourier order K: the rows
    over d (2K + 1) gait parameters, about 8 such arrays alive in a step (measured: 9.3 MB at d = 2, K = 8 with
    speed rows)."""
    return 8 * 8.0 * _joint_rows(n_joints, order, speed_limit) * n_joints * (2 * order + 1)


def gait_solve_seconds(n_joints: int, order: int, speed_limit: bool = True) -> float:
    """Seconds one SLSQP step on those rows blocks (m² n at :data:`_SOLVE_RATE`)."""
    return _joint_rows(n_joints, order, speed_limit) ** 2 * n_joints * (2 * order + 1) / _SOLVE_RATE


def gait_fits(n_joints: int, order: int, speed_limit: bool = True) -> bool:
    """Whether a gait family's optimisation fits :data:`MAX_BYTES` and steps of :data:`MAX_SOLVE_SECONDS`."""
    return (gait_bytes(n_joints, order, speed_limit) <= MAX_BYTES
            and gait_solve_seconds(n_joints, order, speed_limit) <= MAX_SOLVE_SECONDS)


def chain_motion_bytes(n_joints: int, resolution: int = 128) -> float:
    """Bytes the derivative of a chain's cycle velocity with respect to its gait takes (the ceiling's and the
    resistance model's ``cycle_velocity(jacobian=True)``): the connection of d + 1 links at 2R Magnus nodes,
    perturbed in each of d joints, whose largest array holds 2R · d · 2 · d (d + 1) floats, and one copy of it
    (d = 199 asked for 30.2 GiB)."""
    return 2 * 8.0 * 2 * resolution * n_joints * 2 * n_joints * (n_joints + 1)


def check_gait_size(n_joints: int, order: int, owner: str, name: str = "order", speed_limit: bool = True) -> None:
    """Refuse a gait family of ``n_joints`` joints and Fourier ``order`` whose optimisation would not fit in
    :data:`MAX_BYTES` or would block SIGTERM and Ctrl-C for more than :data:`MAX_SOLVE_SECONDS` per solver step
    (:func:`gait_fits`), naming the largest supported order (or number of joints).

    Parameters
    ----------
    n_joints, order : int
    owner : str
        Who asked (for the message).
    name : str
        The order's name for the message (an option, a hello field).
    speed_limit : bool
        Whether joint speed limits add their rows (as many as the angle limits).
    """
    if gait_fits(n_joints, order, speed_limit):
        return
    largest = 0
    while gait_fits(n_joints, largest + 1, speed_limit):
        largest += 1
    joints = 1
    while gait_fits(joints + 1, 1, speed_limit):
        joints += 1
    hint = (f"at most {name} {largest} with {n_joints} joints" if largest >= 1
            else f"at most {joints} joints, even at {name} 1")
    size, seconds = gait_bytes(n_joints, order, speed_limit), gait_solve_seconds(n_joints, order, speed_limit)
    if size > MAX_BYTES:
        check_bytes(size, f"a gait family of {n_joints} joints and {name} {order}", owner, hint)
    raise GeogaitError(f"{owner}: a gait family of {n_joints} joints and {name} {order} would block each solver step "
                       f"for about {seconds:.3g} s (SIGTERM and Ctrl-C wait for it; at most {MAX_SOLVE_SECONDS:g} s "
                       f"is allowed); {hint}.")
