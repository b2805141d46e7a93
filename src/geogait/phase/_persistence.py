"""Saving and loading a fitted :class:`~geogait.phase.Phaser`: ``.npz`` arrays + JSON metadata.

The file holds the fitted arrays under ``state/<name>`` and a JSON document (format name,
format version, hyper-parameters, channel count) under ``metadata``, as the gait models do.
Complex arrays (the correction series :math:`S_k`) are stored as two real arrays,
``<name>.real`` and ``<name>.imag``; nothing is pickled, and :func:`load_phaser` reads with
``allow_pickle=False``. Writes are atomic: a temporary file in the same folder, fsynced, then
renamed over the target, so an interrupted save leaves the previous file intact.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._files import read_state, write_state
from .._validation import GeogaitError
from ._phaser import Phaser

__all__ = ["load_phaser", "save_phaser"]

FORMAT = "geogait-phaser"
FORMAT_VERSION = 1
_REAL = ("mean_", "scale_", "offsets_", "weights_", "zero_", "n_cycles_", "samples_per_cycle_")
_COMPLEX = ("channel_coefficients_", "final_coefficients_")


def save_phaser(phaser: Phaser, path) -> Path:
    """Write a fitted :class:`Phaser` to ``path`` (``.npz``), atomically.

    Parameters
    ----------
    phaser : Phaser
        Fitted.
    path : path-like

    Returns
    -------
    Path

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> t = 2 * np.pi * np.arange(1000) / 100
    >>> phaser = Phaser().fit(np.stack([np.cos(t), np.sin(t)], axis=1))
    >>> path = save_phaser(phaser, pathlib.Path(tempfile.mkdtemp()) / "phaser.npz")
    >>> x = np.stack([np.cos(t + 1), np.sin(t + 1)], axis=1)
    >>> bool(np.array_equal(load_phaser(path).transform(x), phaser.transform(x)))
    True
    """
    if not isinstance(phaser, Phaser):
        raise GeogaitError(f"save_phaser needs a Phaser, got a {type(phaser).__name__}.")
    phaser._check_is_fitted()
    state = {name: np.asarray(getattr(phaser, name), dtype=float) for name in _REAL}
    for name in _COMPLEX:
        value = np.asarray(getattr(phaser, name))
        state[f"{name}.real"], state[f"{name}.imag"] = value.real.copy(), value.imag.copy()
    metadata = {"format": FORMAT, "format_version": FORMAT_VERSION, "class": "Phaser",
                "params": _params(phaser), "n_channels": int(phaser.n_channels_)}
    return write_state(path, metadata, state, require_finite=True)


def _params(phaser: Phaser) -> dict:
    level = phaser.section_level
    return {"order": int(phaser.order), "min_cycles": float(phaser.min_cycles),
            "section_channel": int(phaser.section_channel),
            "section_level": None if level is None else float(level), "edge_cycles": float(phaser.edge_cycles)}


def load_phaser(path) -> Phaser:
    """Read a Phaser written by :func:`save_phaser` (or :meth:`Phaser.save`).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    Phaser
        Fitted, transforming exactly like the saved one.
    """
    metadata, state = read_state(path, "phaser", FORMAT, FORMAT_VERSION)
    phaser = Phaser(**metadata["params"])
    try:
        for name in _REAL:
            value = np.asarray(state[name], dtype=float)
            setattr(phaser, name, float(value) if value.ndim == 0 else value)
        for name in _COMPLEX:
            setattr(phaser, name, state[f"{name}.real"] + 1j * state[f"{name}.imag"])
        phaser.n_channels_ = int(metadata["n_channels"])
        _check_shapes(phaser)
    except (KeyError, ValueError, TypeError) as error:
        raise GeogaitError(f"{path} is inconsistent (corrupt phaser file): {error}") from None
    return phaser


def _check_shapes(phaser: Phaser) -> None:
    c, k = phaser.n_channels_, int(phaser.order)
    expected = {"mean_": (c,), "scale_": (c,), "offsets_": (c,), "weights_": (c,),
                "channel_coefficients_": (k, c), "final_coefficients_": (k,)}
    for name, shape in expected.items():
        if np.shape(getattr(phaser, name)) != shape:
            raise ValueError(f"array {name!r} has shape {np.shape(getattr(phaser, name))}, expected {shape}")
