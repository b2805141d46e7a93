"""File writing shared by every saved artefact: nothing a user saved is ever left half-written."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["atomic_savez"]


def atomic_savez(path, arrays: dict[str, np.ndarray]) -> Path:
    """Write ``arrays`` to the ``.npz`` file ``path`` through a temporary file and a rename.

    The temporary file lives in the same folder and is fsynced before ``os.replace``, so a crash
    or a kill at any moment leaves either the previous file or the new one, never a truncated one.

    Parameters
    ----------
    path : path-like
    arrays : dict of str to ndarray

    Returns
    -------
    Path
    """
    path = Path(path)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **arrays)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return path
