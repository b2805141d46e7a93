"""The one container every saved artefact uses: an ``.npz`` holding a JSON metadata record (with a
format name and version) and ``state/…`` arrays, never pickled, always written atomically."""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ._validation import GeogaitError

__all__ = ["atomic_savez", "read_state", "write_state"]


def atomic_savez(path, arrays: dict[str, np.ndarray]) -> Path:
    """Write ``arrays`` to the ``.npz`` file ``path`` through a temporary file and a rename.

    The temporary file lives in the same folder and is fsynced before ``os.replace``, so a crash
    or a kill at any moment leaves either the previous file or the new one, never a truncated one.
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


def write_state(path, metadata: dict, state: dict[str, np.ndarray]) -> Path:
    """Atomically write ``metadata`` (JSON) and ``state`` arrays to ``path``."""
    arrays = {f"state/{name}": np.asarray(value) for name, value in state.items()}
    arrays["metadata"] = np.frombuffer(json.dumps(metadata).encode(), dtype=np.uint8)
    return atomic_savez(path, arrays)


def read_state(path, kind: str, file_format: str, version: int | tuple[int, ...]) -> tuple[dict, dict]:
    """Read a file written by :func:`write_state`, checking its format name and version.

    ``version`` is the version this geogait writes, or a tuple of every version it reads.

    ``kind`` names the artefact in error messages ("model", "phaser").
    """
    path = Path(path)
    if not path.is_file():
        raise GeogaitError(f"{kind.capitalize()} file {path} does not exist.")
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
        metadata = json.loads(arrays.pop("metadata").tobytes().decode())
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, KeyError, UnicodeDecodeError) as error:
        raise GeogaitError(f"{path} is not a readable geogait {kind} (corrupt or truncated file): {error}") from None
    found = metadata.get("format") if isinstance(metadata, dict) else None
    if found != file_format:
        raise GeogaitError(f"{path} is not a geogait {kind} file (format {found!r}).")
    versions = version if isinstance(version, tuple) else (version,)
    if metadata.get("format_version") not in versions:
        raise GeogaitError(f"{path} has {kind} format version {metadata.get('format_version')}; this geogait "
                           f"reads version {' or '.join(map(str, versions))}.")
    return metadata, {k.removeprefix("state/"): v for k, v in arrays.items()}
