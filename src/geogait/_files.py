"""Every file geogait writes goes through here.

* :func:`atomic_write` (and :func:`write_text`, :func:`write_json`, :func:`atomic_savez`): a
  temporary file in the target's folder, fsynced, then renamed over the target. A crash or
  ``kill -9`` at any moment leaves the previous file or the new one, never a truncated one. The
  new file keeps the mode of the file it replaces (a new file gets ``0o666`` minus the umask,
  like ``open``), and a symbolic link is written through: its target is replaced, the link stays.
  Temporary files left by a killed process (``.<name>.<pid>.<random>.tmp``) are removed by the
  next write of the same file.
* :func:`json_ready`: the one JSON sanitiser. NumPy values become Python ones; a NaN or infinity
  becomes ``null`` and the enclosing object gains ``"<key>_null_reason"`` saying which value it
  was, so every JSON file geogait writes is valid JSON (no ``NaN`` / ``Infinity`` tokens).
* :func:`write_state` / :func:`read_state`: the one container every saved artefact uses, an
  ``.npz`` holding a JSON metadata record (with a format name and version) and ``state/…``
  arrays, never pickled.
* :func:`check_writable`: can a file be written at a path (checked before long work starts).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import tempfile
import threading
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ._validation import MAX_MAGNITUDE, GeogaitError, fail

#: Longest line read from a driver or an input stream: one sample of a 200-joint robot is about 10 kB.
MAX_LINE_BYTES = 1 << 20

__all__ = ["MAX_LINE_BYTES", "OutputLock", "RepeatedKey", "atomic_savez", "atomic_write", "bounded_lines",
           "check_outputs", "check_writable", "default_summary_path", "describe_path_kind", "dumps_json", "json_ready",
           "output_set", "read_state", "unique_keys", "write_json", "write_state", "write_text"]

_UMASK_LOCK = threading.Lock()


def _umask() -> int:
    """The process umask, read without changing it where the system allows."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _resolve(path) -> Path:
    """The file a write to ``path`` must replace: symbolic links followed (even dangling ones)."""
    return Path(os.path.realpath(Path(path)))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


_CLEANED: set[Path] = set()


def _remove_stale_temporaries(target: Path) -> None:
    """Delete ``.<name>.<pid>.*.tmp`` files beside ``target`` whose writing process is gone.

    Once per target and process: later temporaries of this process are its own and cleaned up.
    """
    if target in _CLEANED:
        return
    _CLEANED.add(target)
    pattern = re.compile(re.escape(f".{target.name}.") + r"(\d+)\.[^.]+\.tmp$")
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return
    for entry in entries:
        match = pattern.match(entry.name)
        if match and int(match.group(1)) != os.getpid() and not _pid_alive(int(match.group(1))):
            try:
                os.unlink(entry.path)
            except OSError:
                pass


def atomic_write(path, write: Callable[[io.BufferedWriter], object]) -> Path:
    """Write a file atomically: ``write(stream)`` fills a temporary file that then replaces ``path``.

    Parameters
    ----------
    path : path-like
        The file to (re)place. A symbolic link is written through (its target is replaced); the
        parent folder must exist.
    write : callable
        Called with a binary stream open for writing.

    Returns
    -------
    Path
        ``path`` as given.

    Notes
    -----
    The temporary file lives in the target's folder, is fsynced, takes the mode of the file it
    replaces (or ``0o666`` minus the umask), and is renamed with :func:`os.replace`; the folder is
    fsynced after the rename where the system allows. Any error removes the temporary file and
    leaves the previous file untouched.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> atomic_write(target, lambda stream: stream.write(b"hello")).read_text()
    'hello'
    """
    given = Path(path)
    target = _resolve(given)
    if target.is_dir():
        raise IsADirectoryError(21, "Is a directory", str(given))
    try:
        mode = target.stat().st_mode & 0o7777
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    _remove_stale_temporaries(target)
    try:
        handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.{os.getpid()}.",
                                             suffix=".tmp")
    except OSError as error:  # name the file the caller asked for, not the temporary one
        raise type(error)(error.errno, error.strerror, str(given)) from None
    try:
        with os.fdopen(handle, "wb") as stream:
            os.fchmod(stream.fileno(), mode)
            write(stream)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except BaseException as error:
        Path(temporary).unlink(missing_ok=True)
        interrupt = _interrupt_behind(error)
        if interrupt is not None:  # (a signal mid-write, masked by a writer's cleanup error: the signal ends it)
            raise interrupt from None
        raise
    _fsync_folder(target.parent)
    return given


def _interrupt_behind(error: BaseException) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt (Ctrl-C, or SIGTERM as the CLI raises it) during whose handling ``error`` arose, e.g.
    zipfile's "Can't close the ZIP file while there is an open writing handle" after ``np.savez`` was
    interrupted; None when there is none, or when ``error`` is the interrupt itself."""
    if isinstance(error, KeyboardInterrupt):
        return None
    seen = set()
    context = error.__context__
    while context is not None and id(context) not in seen:
        if isinstance(context, KeyboardInterrupt):
            return context
        seen.add(id(context))
        context = context.__context__
    return None


def _fsync_folder(folder: Path) -> None:
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(handle)
    except OSError:
        pass
    finally:
        os.close(handle)


def write_text(path, text: str) -> Path:
    """Atomically write ``text`` (UTF-8) to ``path`` (see :func:`atomic_write`).

    Parameters
    ----------
    path : path-like
    text : str

    Returns
    -------
    Path
    """
    data = text.encode("utf-8")
    return atomic_write(path, lambda stream: stream.write(data))


def atomic_savez(path, arrays: dict[str, np.ndarray]) -> Path:
    """Atomically write ``arrays`` to the ``.npz`` file ``path`` (see :func:`atomic_write`).

    Parameters
    ----------
    path : path-like
    arrays : dict of str to ndarray

    Returns
    -------
    Path
    """
    return atomic_write(path, lambda stream: np.savez(stream, **arrays))


def check_writable(path, what: str = "output file") -> Path:
    """Raise a clear :class:`~geogait.GeogaitError` unless a file can be written at ``path``.

    Checks that the parent folder exists and accepts new files (by creating and removing a
    temporary file there, as :func:`atomic_write` will) and that ``path`` is not a folder.

    Parameters
    ----------
    path : path-like
    what : str
        What the file is, for the message ("model file", ...).

    Returns
    -------
    Path
    """
    given = Path(path)
    target = _resolve(given)
    if target.is_dir():
        raise GeogaitError(f"Cannot write the {what} {given}: it is a folder.")
    if not target.parent.is_dir():
        parent = next((folder for folder in target.parents if folder.exists()), None)
        if parent is not None and not parent.is_dir():  # (a path through a file: say which)
            raise GeogaitError(f"Cannot write the {what} {given}: {parent} is a file, not a folder.")
        raise GeogaitError(f"Cannot write the {what} {given}: its folder {target.parent} does not exist.")
    try:
        handle, probe = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp")
    except OSError as error:
        raise GeogaitError(f"Cannot write the {what} {given}: {error.strerror} ({target.parent}).") from None
    os.close(handle)
    os.unlink(probe)
    return given


# -- JSON ---------------------------------------------------------------------------------------
def _non_finite(value: float) -> str:
    return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")


def _clean(value, reasons: list[str], where: str):
    """Plain JSON value; non-finite floats → None, each noted in ``reasons``."""
    if isinstance(value, dict):
        return json_ready(value)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return [_clean(v, reasons, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        reasons.append(f"{where} was {_non_finite(value)}" if where else f"was {_non_finite(value)}")
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def json_ready(value):
    """A copy of ``value`` that :func:`json.dumps` writes as strict JSON.

    Dicts, lists, tuples, NumPy arrays and scalars and paths become plain JSON values. A NaN or
    infinite float becomes ``None`` and, inside a dict, the dict gains the key
    ``"<key>_null_reason"`` naming what it was (``"was nan"``, ``"[2] was -inf"`` for an element
    of a list).

    Parameters
    ----------
    value : dict, list, tuple, ndarray, scalar or Path

    Returns
    -------
    dict, list or scalar

    Examples
    --------
    >>> json_ready({"gamma": float("nan"), "prediction": [1.0, float("inf")]})
    {'gamma': None, 'gamma_null_reason': 'was nan', 'prediction': [1.0, None], 'prediction_null_reason': '[1] was inf'}
    """
    if not isinstance(value, dict):
        return _clean(value, [], "")
    out = {}
    for key, item in value.items():
        reasons: list[str] = []
        out[str(key)] = _clean(item, reasons, "")
        if reasons:
            out[f"{key}_null_reason"] = "; ".join(reasons)
    return out


class RepeatedKey(ValueError):
    """A JSON object gave ``key`` twice (raised by :func:`unique_keys`)."""

    def __init__(self, key):
        super().__init__(key)
        self.key = key


def unique_keys(pairs: list) -> dict:
    """``json.loads``' ``object_pairs_hook``: a key given twice in one object raises :class:`RepeatedKey` (JSON
    leaves it open; Python would keep the last value silently)."""
    record = dict(pairs)
    if len(record) != len(pairs):
        seen = set()
        for key, _ in pairs:  # (one pass: a line may hold many keys)
            if key in seen:
                raise RepeatedKey(key)
            seen.add(key)
    return record


def dumps_json(value, **options) -> str:
    """``json.dumps(json_ready(value))``, strict (never NaN/Infinity tokens).

    Plain finite values (the common case: every stream line) skip the sanitiser.

    Parameters
    ----------
    value
        Anything :func:`json_ready` accepts.
    **options
        Keywords of :func:`json.dumps` (``indent``, ...).

    Returns
    -------
    str
    """
    try:
        return json.dumps(value, allow_nan=False, **options)
    except (ValueError, TypeError):
        return json.dumps(json_ready(value), allow_nan=False, **options)


def write_json(path, value, *, indent: int | None = 2) -> Path:
    """Atomically write ``value`` (through :func:`json_ready`) as strict JSON with a final newline.

    Parameters
    ----------
    path : path-like
    value
        Anything :func:`json_ready` accepts.
    indent : int or None

    Returns
    -------
    Path
    """
    return write_text(path, dumps_json(value, indent=indent) + "\n")


# -- saved state --------------------------------------------------------------------------------
def write_state(path, metadata: dict, state: dict[str, np.ndarray], *, require_finite: bool = False) -> Path:
    """Atomically write ``metadata`` (JSON) and ``state`` arrays to ``path``.

    With ``require_finite`` (models and phasers), refuses with :class:`~geogait.GeogaitError`,
    writing nothing, when a floating-point array holds NaN, infinity or a value beyond ±1e12
    (:data:`~geogait._validation.MAX_MAGNITUDE`, what loading accepts): such a model never replaces a good
    file. Records that hold NaN on purpose (a log with "no value yet") pass False.
    """
    arrays = {f"state/{name}": np.asarray(value) for name, value in state.items()}
    floats = {name.removeprefix("state/"): value for name, value in arrays.items()
              if require_finite and np.issubdtype(value.dtype, np.inexact) and value.size}
    for what, bad in (("non-finite (NaN or inf in", [name for name, value in floats.items()
                                                     if not np.all(np.isfinite(value))]),
                      (f"beyond ±{MAX_MAGNITUDE:g} (in", [name for name, value in floats.items()
                                                         if not float(np.max(np.abs(value))) <= MAX_MAGNITUDE])):
        if bad:
            raise GeogaitError(f"Refusing to save {Path(path)}: the state went {what} {', '.join(bad)}); the "
                               "previous file, if any, is kept.")
    # json.dumps as written since format version 1: readers (optimiser checkpoints) rely on NaN round trips
    arrays["metadata"] = np.frombuffer(json.dumps(metadata).encode(), dtype=np.uint8)
    return atomic_savez(path, arrays)


#: Largest metadata record of a saved file (bytes) and largest uncompressed archive: a file that claims
#: more is refused before it is read into memory.
MAX_METADATA_BYTES = 16 << 20
MAX_ARCHIVE_BYTES = 8 << 30


def read_utf8(path: Path, owner: str) -> str:
    """The text of the file ``path``; a file that is not UTF-8 is an error naming ``owner``'s ``path``."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        byte = error.object[error.start]
        raise GeogaitError(f"The 'path' parameter of {owner} must be a UTF-8 text file. Got {str(path)!r} (byte "
                           f"{byte:#04x} at position {error.start} is not UTF-8) instead.") from None


def describe_path_kind(path: Path) -> str | None:
    """Why ``path`` cannot be read as a file ("is a folder", "is a FIFO", ...); None for a regular file
    and for a path that does not exist."""
    import stat

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError as error:
        return f"cannot be read ({error.strerror})"
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "is a FIFO (named pipe), not a regular file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a regular file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a regular file"
    return "is not a regular file"


def _check_archive(path: Path, kind: str) -> None:
    """Refuse an archive whose members would not fit in memory (sizes come from the zip directory)."""
    try:
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
    except (zipfile.BadZipFile, OSError, ValueError):
        raise GeogaitError(f"{path} is not a readable geogait {kind} (corrupt or truncated file).") from None
    total = sum(info.file_size for info in infos)
    metadata = [info.file_size for info in infos if info.filename == "metadata.npy"]
    if total > MAX_ARCHIVE_BYTES or (metadata and metadata[0] > MAX_METADATA_BYTES):
        raise GeogaitError(f"{path} is not a readable geogait {kind}: it claims {total} bytes of arrays "
                           f"(at most {MAX_ARCHIVE_BYTES} read) or a metadata record over {MAX_METADATA_BYTES} bytes.")


def read_state(path, kind: str, file_format: str, version: int | tuple[int, ...], *,
               require_finite: bool = False) -> tuple[dict, dict]:
    """Read a file written by :func:`write_state`, checking its format name and version.

    ``version`` is the version this geogait writes, or a tuple of every version it reads.

    ``kind`` names the artefact in error messages ("model", "phaser"). Complex and object arrays are
    refused; with ``require_finite`` (models, phasers: :func:`write_state` never writes them
    otherwise) so are floating-point arrays holding NaN or infinity.
    """
    path = Path(path)
    odd = describe_path_kind(path)
    if odd is not None:
        raise GeogaitError(f"{kind.capitalize()} file {path} {odd}.")
    if not path.is_file():
        raise GeogaitError(f"{kind.capitalize()} file {path} does not exist.")
    if not zipfile.is_zipfile(path):
        raise GeogaitError(f"{path} is not a readable geogait {kind} (corrupt or truncated file, or another kind "
                           "of file: not an .npz archive).")
    _check_archive(path, kind)
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
        raw = arrays.pop("metadata")
        if raw.dtype != np.uint8 or raw.ndim != 1:
            raise ValueError("metadata is not a byte record")
        metadata = json.loads(raw.tobytes().decode())
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, KeyError, UnicodeDecodeError, RecursionError,
            MemoryError):
        raise GeogaitError(f"{path} is not a readable geogait {kind} (corrupt or truncated file, or an .npz "
                           "written by another program).") from None
    found = metadata.get("format") if isinstance(metadata, dict) else None
    if found != file_format:
        raise GeogaitError(f"{path} is not a geogait {kind} file (format {found!r}).")
    versions = version if isinstance(version, tuple) else (version,)
    found_version = metadata.get("format_version")
    if isinstance(found_version, bool) or found_version not in versions:
        raise GeogaitError(f"{path} has {kind} format version {found_version!r}; this geogait "
                           f"reads version {' or '.join(map(str, versions))}.")
    state = {k.removeprefix("state/"): v for k, v in arrays.items()}
    for name, value in state.items():
        if value.dtype.kind in "cOV":
            raise GeogaitError(f"{path} is not a readable geogait {kind}: array {name!r} holds {value.dtype} "
                               "values (real numbers expected).")
        if require_finite and value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            raise GeogaitError(f"{path} is not a usable geogait {kind}: array {name!r} holds NaN or infinity "
                               "(geogait never saves such a state; the file was changed or corrupted).")
    return metadata, state


# -- output folders -----------------------------------------------------------------------------
LOCK_FILE = ".geogait.lock"
_STAGING = re.compile(r"^\.geogait-staging\.(\d+)\.[^.]+$")


def _same_inode(handle: int, path: Path) -> bool:
    """Whether the open file ``handle`` is the file at ``path`` (not one removed or replaced since)."""
    try:
        on_disk = os.stat(path)
    except FileNotFoundError:
        return False
    held = os.fstat(handle)
    return (held.st_dev, held.st_ino) == (on_disk.st_dev, on_disk.st_ino)


class OutputLock:
    """An exclusive lock on an output folder while one run writes it (``fcntl.flock`` on ``.geogait.lock``).

    The lock is held on an open file, so the system releases it when the process ends in any way (even
    ``kill -9``). A lock taken on a file that was removed meanwhile (by the run that held it, :meth:`release`)
    is not a lock on the folder: it is taken again on the file now there. The
    holder's process id is written into the file for the message another run gets.

    Parameters
    ----------
    folder : path-like
        An existing folder.

    Raises
    ------
    GeogaitError
        When another process holds the lock.
    """

    def __init__(self, folder):
        import fcntl

        self.folder = Path(folder)
        self._path = path = self.folder / LOCK_FILE
        self._handle = None
        for _ in range(100):  # (each retry follows a lock file removed under us: a race, not a loop)
            try:
                handle = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
            except OSError as error:
                raise GeogaitError(f"Cannot lock the output folder {self.folder}: {error.strerror}.") from None
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                try:
                    holder = os.pread(handle, 64, 0).decode("ascii", "replace").strip()
                except OSError:
                    holder = ""
                os.close(handle)
                who = f" (process {holder})" if holder.isdigit() else ""
                raise GeogaitError(f"The output folder {self.folder} is being written by another geogait "
                                   f"run{who}; wait for it to finish or choose another --out.") from None
            if _same_inode(handle, path):
                break
            os.close(handle)
        else:
            raise GeogaitError(f"Cannot lock the output folder {self.folder}: its lock file keeps being removed.")
        self._handle = handle
        os.ftruncate(handle, 0)
        os.pwrite(handle, f"{os.getpid()}\n".encode(), 0)

    def release(self) -> None:
        """Remove the lock file, still holding the lock, then give the lock back: a finished run leaves no trace of
        it in its folder. Another run that opened the removed file meanwhile takes the lock again on a new one
        (see above). The system releases the lock when the process ends in any other way."""
        if self._handle is None:
            return
        if _same_inode(self._handle, self._path):  # (only the file this lock holds: never another run's)
            with contextlib.suppress(OSError):  # (a lock file that cannot be removed is harmless: it stays)
                os.unlink(self._path)
        os.close(self._handle)  # closing the only descriptor releases the flock
        self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def folder_entries(folder) -> list[str]:
    """Names in ``folder`` other than geogait's own bookkeeping (lock file, staging folders, temporaries)."""
    names = []
    for name in sorted(os.listdir(folder)):
        if name == LOCK_FILE or _STAGING.match(name) or (name.startswith(".") and name.endswith(".tmp")):
            continue
        names.append(name)
    return names


def _remove_stale_staging(folder: Path) -> None:
    import shutil

    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        match = _STAGING.match(entry.name)
        if match and int(match.group(1)) != os.getpid() and not _pid_alive(int(match.group(1))):
            shutil.rmtree(entry.path, ignore_errors=True)


class output_set:  # noqa: N801  (used as a context manager, like open)
    """Write several files into ``folder`` as one set: all of them, or none.

    ``with output_set(folder) as staged:`` gives a staging folder inside ``folder``; write every file
    there (any writer of this module, or a plotting library), then on leaving the block each file
    replaces its namesake in ``folder`` by :func:`os.replace` (``last`` at the end, e.g. the summary
    that says the run is complete). If the block raises, or the process is interrupted, the staging
    folder is removed and ``folder`` is unchanged; staging folders of killed processes are removed by
    the next set written into the same folder. Each replaced file keeps its mode; links are written
    through, as by :func:`atomic_write`.

    Parameters
    ----------
    folder : path-like
        An existing folder.
    last : sequence of str
        Names moved into place after the others, in this order.
    members : sequence of str
        Every name the set may hold: those the block did not write are removed from ``folder`` when
        the set is committed (no file of an earlier set is left beside a newer one).
    """

    def __init__(self, folder, last=(), members=()):
        self.folder = Path(folder)
        self.last = tuple(last)
        self.members = tuple(members)
        self.staging: Path | None = None

    def __enter__(self) -> Path:
        _remove_stale_staging(self.folder)
        self.staging = Path(tempfile.mkdtemp(dir=self.folder, prefix=f".geogait-staging.{os.getpid()}."))
        return self.staging

    def __exit__(self, kind, error, trace):
        import shutil

        try:
            if kind is None:
                self._commit()
        finally:
            shutil.rmtree(self.staging, ignore_errors=True)
        return False

    def _commit(self) -> None:
        names = sorted(os.listdir(self.staging), key=lambda n: (n in self.last, self.last.index(n) if n in
                                                                self.last else 0, n))
        for name in names:  # flush everything first, then rename: a crash leaves whole files only
            staged = self.staging / name
            with open(staged, "rb+") as stream:
                os.fsync(stream.fileno())
        for name in names:
            staged = self.staging / name
            target = _resolve(self.folder / name)
            if target.is_dir():
                raise IsADirectoryError(21, "Is a directory", str(self.folder / name))
            try:
                os.chmod(staged, target.stat().st_mode & 0o7777)
            except FileNotFoundError:
                os.chmod(staged, 0o666 & ~_umask())
            os.replace(staged, target)
        for name in self.members:
            if name not in names:
                (self.folder / name).unlink(missing_ok=True)
        _fsync_folder(self.folder)


def default_summary_path(out) -> Path:
    """Where the Γ summary of predictions written to ``out`` goes by default (never ``out`` itself).

    Parameters
    ----------
    out : path-like
        The predictions file.

    Returns
    -------
    Path
        ``out`` with suffix ``.json``, or ``<stem>.summary.json`` when ``out`` ends in ``.json``.
    """
    out = Path(out)
    return out.with_name(f"{out.stem}.summary.json") if out.suffix.lower() == ".json" else out.with_suffix(".json")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and a.samefile(b)
    except OSError:
        return False


def check_outputs(outputs: dict, inputs, owner: str) -> None:
    """Refuse outputs that are the same file as an input or as each other (before writing anything).

    Parameters
    ----------
    outputs : dict of str to path-like
        Name (for the message) → path.
    inputs : iterable of path-like or None
    owner : str
    """
    resolved = {name: Path(os.path.realpath(p)) for name, p in outputs.items()}
    for name, path in resolved.items():
        for given in inputs:
            if given is None:
                continue
            source = Path(os.path.realpath(given))
            if source == path or _same_file(source, path):
                raise fail(name, owner, "a file other than the inputs (it would be overwritten)",
                           f"{str(outputs[name])!r}, which is the input {str(given)!r}")
    names = list(resolved)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if resolved[a] == resolved[b]:
                raise fail(b, owner, f"a file other than '{a}'", str(outputs[b]))


def bounded_lines(stream, limit: int = MAX_LINE_BYTES):
    """The lines of a text ``stream``, each read no further than ``limit`` characters: a longer one raises
    :class:`~geogait.GeogaitError` naming it (a line that never ends is not held in memory).

    Parameters
    ----------
    stream : text stream
        With ``readline(size)`` (``sys.stdin``, an open file).
    limit : int
        Characters per line, its line end not counted.

    Yields
    ------
    str
    """
    number = 0
    while line := stream.readline(limit + 1):
        number += 1
        if len(line) > limit and not (len(line) == limit + 1 and line.endswith("\n")):
            raise GeogaitError(f"input line {number} is longer than {limit} characters (a line without its end, or "
                               "not the input meant?)")
        yield line
