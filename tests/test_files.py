"""How geogait writes its outputs (``geogait._files``): atomically (the old file kept on failure, no temporary left,
the stale ones of dead processes removed), keeping the mode and writing through links, into folders checked
first, as strict JSON whose nulls say why (issue 11); sets of outputs replaced all or nothing, the lock on an
output folder, JSON keys that appear twice (issue 21); whatever the value, strict JSON (fuzz, see tests/_fuzz.py)."""

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest
from _fuzz import FUZZ, WILD
from _noisy_run import run as run
from _reference import GAIT, strict_json
from _reference import Sink as _Sink
from _reference import strict_json as strict
from hypothesis import given
from hypothesis import strategies as st

from geogait import GeogaitError
from geogait._files import (
    OutputLock,
    atomic_write,
    check_writable,
    dumps_json,
    json_ready,
    output_set,
    write_json,
    write_text,
)
from geogait.cli._common import write_manifest
from geogait.io._records import StreamOutput, _JsonLinesWriter
from geogait.models import AdaptiveGaitModel, load_model


def test_json_outputs_have_null_and_a_reason_instead_of_nan(tmp_path):
    value = {"gamma": float("nan"), "series": np.array([1.0, np.inf]), "nested": {"x": -np.inf}, "n": np.int64(3)}
    assert json_ready(value) == {"gamma": None, "gamma_null_reason": "was nan", "series": [1.0, None],
                                 "series_null_reason": "[1] was inf", "nested": {"x": None,
                                                                                  "x_null_reason": "was -inf"},
                                 "n": 3}
    path = write_manifest(tmp_path / "m.json", command="test", config={"a": np.nan}, results=value, started=0.0)
    manifest = strict_json(path.read_text())
    assert manifest["config"] == {"a": None, "a_null_reason": "was nan"} and manifest["geogait_version"]
    sink = _Sink()
    _JsonLinesWriter(sink).write(StreamOutput(0, 1.0, 0.5, np.array([np.nan, 0.0, 1.0]), float("inf"), True))
    line = strict_json(sink.text)
    assert line["gamma"] is None and line["gamma_null_reason"] == "was inf"
    assert line["prediction"] == [None, 0.0, 1.0] and line["prediction_null_reason"] == "[0] was nan"


def test_saving_keeps_the_mode_and_writes_through_links(run, tmp_path):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase[:300], run.shape[:300], run.shape_velocity[:300],
                                             run.body_velocity[:300])
    path = model.save(tmp_path / "m.npz")
    path.chmod(0o640)
    model.save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    link = tmp_path / "link.npz"
    link.symlink_to(path)
    model.partial_fit(run.phase[300:400], run.shape[300:400], run.shape_velocity[300:400],
                      run.body_velocity[300:400])
    model.save(link)
    assert link.is_symlink() and load_model(path).n_samples_seen_ == 400
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    previous = os.umask(0o027)
    try:
        fresh = write_json(tmp_path / "new.json", {"a": 1})
    finally:
        os.umask(previous)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o640


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = write_json(tmp_path / "a.json", {"a": 1})

    def explode(stream):
        stream.write(b"partial")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        atomic_write(path, explode)
    assert strict_json(path.read_text()) == {"a": 1} and sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_stale_temporary_files_of_dead_processes_are_removed(tmp_path):
    stale = tmp_path / ".m.npz.999999999.abc123.tmp"  # no such pid
    alive = tmp_path / f".m.npz.{os.getppid()}.def456.tmp"  # a live process may still be writing it
    other = tmp_path / ".other.npz.999999999.x.tmp"
    for path in (stale, alive, other):
        path.write_bytes(b"half")
    write_json(tmp_path / "m.npz", {"a": 1})
    assert not stale.exists() and alive.exists() and other.exists()


def test_check_writable(tmp_path):
    assert check_writable(tmp_path / "x.npz") == tmp_path / "x.npz" and not (tmp_path / "x.npz").exists()
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(GeogaitError, match="its folder .*missing does not exist"):
        check_writable(tmp_path / "missing" / "x.npz")
    (tmp_path / "notes.txt").write_text("a file")  # a path through a file is said as such
    with pytest.raises(GeogaitError, match=r"notes.txt is a file, not a folder"):
        check_writable(tmp_path / "notes.txt" / "sub" / "x.npz", "model file")


def test_files_module_is_the_only_atomic_writer():
    source = Path(__file__).resolve().parents[1] / "src" / "geogait"
    writers = [path.relative_to(source).as_posix() for path in source.rglob("*.py")
               if "os.replace(" in path.read_text() or "mkstemp(" in path.read_text()]
    assert writers == ["_files.py"]


def test_a_lock_taken_on_a_removed_lock_file_is_taken_again_on_the_new_one(tmp_path):
    """A run removes its lock file when it ends (OutputLock.release); a run that had opened that
    file before must not hold a lock nobody else can see: it locks the file now there, or is refused."""
    from geogait._files import LOCK_FILE, _same_inode

    first = OutputLock(tmp_path)
    opened_before = os.open(tmp_path / LOCK_FILE, os.O_RDWR)  # another run, between its open and its flock
    first.release()
    assert not (tmp_path / LOCK_FILE).exists() and not _same_inode(opened_before, tmp_path / LOCK_FILE)
    os.close(opened_before)
    with OutputLock(tmp_path):
        assert (tmp_path / LOCK_FILE).exists()
        with pytest.raises(GeogaitError, match="being written by another geogait run"):
            OutputLock(tmp_path)
    with OutputLock(tmp_path):  # released: free again
        pass


def test_an_output_set_is_all_or_nothing(tmp_path):
    write_text(tmp_path / "a.csv", "old a")
    write_text(tmp_path / "summary.json", "old summary")
    with pytest.raises(RuntimeError), output_set(tmp_path, last=("summary.json",)) as staged:
        write_text(staged / "a.csv", "new a")
        raise RuntimeError("the plot failed")
    assert (tmp_path / "a.csv").read_text() == "old a" and sorted(os.listdir(tmp_path)) == ["a.csv", "summary.json"]
    with output_set(tmp_path, last=("summary.json",)) as staged:
        write_text(staged / "a.csv", "new a")
        write_text(staged / "summary.json", "new summary")
    assert (tmp_path / "a.csv").read_text() == "new a" and (tmp_path / "summary.json").read_text() == "new summary"
    assert sorted(os.listdir(tmp_path)) == ["a.csv", "summary.json"]


def test_an_output_set_removes_the_members_it_no_longer_holds(tmp_path):
    for name in ("model.npz", "phaser.npz", "mine.txt"):
        write_text(tmp_path / name, "old")
    with output_set(tmp_path, members=("model.npz", "phaser.npz")) as staged:
        write_text(staged / "model.npz", "new")
    assert sorted(os.listdir(tmp_path)) == ["mine.txt", "model.npz"]  # no phaser of an earlier fit beside the model


def test_a_repeated_key_is_found_at_any_depth_and_in_one_pass():
    from geogait._files import RepeatedKey, unique_keys

    hello = '{"type": "hello", "gait": {"order": 1, "params": [0, 1], "order": 2}}'
    with pytest.raises(RepeatedKey) as repeated:
        json.loads(hello, object_pairs_hook=unique_keys)
    assert repeated.value.key == "order"
    many = "{" + ", ".join(f'"k{i}": {i}' for i in range(100_000)) + ', "k0": 0}'  # (a search per key: minutes)
    with pytest.raises(RepeatedKey, match="k0"):
        json.loads(many, object_pairs_hook=unique_keys)
    assert json.loads('{"a": {"a": 1}, "b": [{"a": 2}]}', object_pairs_hook=unique_keys) == {"a": {"a": 1},
                                                                                             "b": [{"a": 2}]}


JSON_VALUES = st.recursive(st.one_of(st.none(), st.booleans(), WILD, st.text(max_size=5)),
                           lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                   st.dictionaries(st.text(max_size=4), inner, max_size=3)),
                           max_leaves=12)


@FUZZ
@given(value=JSON_VALUES)
def test_json_sanitiser_always_writes_strict_json(value):
    strict(dumps_json(value))
    strict(dumps_json({"x": value, "arr": np.array([1.0, np.nan])}))


def test_a_signal_mid_write_ends_as_the_signal_with_the_old_file_kept(tmp_path):
    """A SIGTERM (raised as KeyboardInterrupt by the CLI) while np.savez held a member open surfaced as zipfile's
    "Can't close the ZIP file while there is an open writing handle" ValueError, raised while the interrupt was
    handled: the CLI printed that instead of "error: terminated"."""
    target = tmp_path / "checkpoint.npz"
    target.write_bytes(b"earlier")

    def interrupted(stream):
        stream.write(b"part of an archive")
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:  # (what zipfile's cleanup does)
            raise ValueError("Can't close the ZIP file while there is an open writing handle on it") from None

    def failing(stream):
        stream.write(b"part of an archive")
        raise OSError(28, "No space left on device")

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, interrupted)
    with pytest.raises(OSError, match="No space left"):  # an error with no signal behind it stays itself
        atomic_write(target, failing)
    assert target.read_bytes() == b"earlier"
    assert [p.name for p in tmp_path.iterdir()] == ["checkpoint.npz"]  # (no temporary file left)
