"""Tests of the seeded trial runner (geogait.sweep)."""

import doctest
import shutil
import sys
import uuid
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pandas.testing import assert_frame_equal

from geogait import sweep as runner_module
from geogait.sweep import SweepFailedError, run_trials

# Trial functions live at module level so that joblib and Dask workers can import them.


def noisy_trial(trial_indices, seeds, *, n_samples=5, scale=1.0, shift=0.0):
    """Random walks, one per trial, drawn per trial and post-processed as one chunk array."""
    draws = np.stack([np.random.default_rng(seed).standard_normal(n_samples) for seed in seeds])
    walks = scale * np.cumsum(draws, axis=1) + np.asarray(shift)
    return pd.DataFrame(
        {
            "trial": np.repeat(trial_indices, n_samples),
            "sample": np.tile(np.arange(n_samples), len(trial_indices)),
            "value": walks.ravel(),
            "direction": np.where(walks.ravel() > 0, "up", "down"),
        }
    )


def fragile_trial(trial_indices, seeds, *, bad=(3,)):
    """noisy_trial, except that a chunk holding a trial listed in ``bad`` raises."""
    diverged = sorted(set(trial_indices.tolist()) & set(bad))
    if diverged:
        raise ValueError(f"trial {diverged[0]} diverged")
    return noisy_trial(trial_indices, seeds)


def counted_trial(trial_indices, seeds, *, calls_dir, stop_flag, interrupt=False):
    """noisy_trial that logs each call as a file; while ``stop_flag`` exists, trials >= 6 stop."""
    Path(calls_dir, f"{trial_indices[0]:03d}-{uuid.uuid4().hex}").touch()
    if Path(stop_flag).exists() and trial_indices.max() >= 6:
        raise KeyboardInterrupt if interrupt else RuntimeError("simulated crash")
    return noisy_trial(trial_indices, seeds)


def list_trial(trial_indices, seeds):
    """Breaks the contract: returns a list instead of a frame."""
    return [1, 2, 3]


def stray_trial(trial_indices, seeds):
    """Breaks the contract: reports a trial outside its chunk."""
    return pd.DataFrame({"trial": trial_indices + 100, "value": 0.0})


def sweep(trial_function=noisy_trial, n_trials=10, **kwargs):
    kwargs = {"seed": 7, "chunk_size": 3, "progress": False} | kwargs
    return run_trials(trial_function, n_trials, **kwargs)


def calls(folder: Path) -> list[int]:
    """First trial of each chunk computed, from the call log; clears the log."""
    started = sorted(int(path.name.split("-")[0]) for path in folder.iterdir())
    for path in folder.iterdir():
        path.unlink()
    return started


@pytest.fixture
def call_log(tmp_path):
    log = tmp_path / "calls"
    log.mkdir()
    flag = tmp_path / "stop"
    return log, flag, {"calls_dir": str(log), "stop_flag": str(flag)}


# --- determinism ------------------------------------------------------------------------------


def test_trial_i_gets_the_ith_spawned_seed():
    result = sweep(n_trials=6)
    seed = np.random.SeedSequence(7).spawn(6)[4]
    expected = np.cumsum(np.random.default_rng(seed).standard_normal(5))
    np.testing.assert_array_equal(result.frame.query("trial == 4")["value"], expected)
    assert result.frame["trial"].tolist() == np.repeat(np.arange(6), 5).tolist()
    assert (result.n_trials, result.seed, result.chunk_size) == (6, 7, 3)


def test_results_do_not_depend_on_chunk_size():
    reference = sweep(chunk_size=1).frame
    for chunk_size in (3, 10):
        assert_frame_equal(sweep(chunk_size=chunk_size).frame, reference, check_exact=True)


def test_joblib_workers_give_identical_frames():
    serial = sweep(n_trials=11, config={"scale": 0.5})
    parallel = sweep(n_trials=11, config={"scale": 0.5}, jobs=2)
    assert (serial.n_workers, parallel.n_workers) == (1, 2)
    assert_frame_equal(parallel.frame, serial.frame, check_exact=True)
    assert sweep(n_trials=11, config={"scale": 0.5}, jobs=-1).frame.equals(serial.frame)


def test_dask_cluster_gives_identical_frames_and_reports_failures():
    distributed = pytest.importorskip("distributed")
    serial = sweep(n_trials=11)
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    )
    with cluster, distributed.Client(cluster, set_as_default=False) as client:
        via_client = sweep(n_trials=11, scheduler=client)
        via_address = sweep(n_trials=11, scheduler=cluster.scheduler_address)
        failing = sweep(fragile_trial, n_trials=11, scheduler=client, chunk_size=1)
    assert via_client.n_workers == 2
    assert_frame_equal(via_client.frame, serial.frame, check_exact=True)
    assert_frame_equal(via_address.frame, serial.frame, check_exact=True)
    assert [failure.trial for failure in failing.failures] == [3]


def test_different_seeds_give_different_results():
    first, again, other = sweep(seed=1).frame, sweep(seed=1).frame, sweep(seed=2).frame
    assert_frame_equal(first, again, check_exact=True)
    assert not np.array_equal(first["value"], other["value"])


def test_progress_bar_works_without_a_terminal(capsys):
    result = sweep(progress=True, description="toy sweep")
    assert len(result.frame) == 50
    assert capsys.readouterr().out == ""


def test_docstring_example_runs():
    outcome = doctest.testmod(runner_module)
    assert outcome.attempted > 0 and outcome.failed == 0


# --- failures ---------------------------------------------------------------------------------


@pytest.mark.parametrize("jobs", [1, 2])
def test_failing_trial_is_reported_and_the_others_return(jobs):
    result = sweep(fragile_trial, n_trials=6, chunk_size=1, jobs=jobs)
    (failure,) = result.failures
    assert (failure.trial, failure.chunk, failure.entropy, failure.spawn_key) == (3, 3, 7, (3,))
    assert (failure.error_type, failure.message) == ("ValueError", "trial 3 diverged")
    assert "fragile_trial" in failure.traceback
    assert sorted(set(result.frame["trial"])) == [0, 1, 2, 4, 5]
    expected = sweep(n_trials=6, chunk_size=1).frame.query("trial != 3").reset_index(drop=True)
    assert_frame_equal(result.frame, expected, check_exact=True)


def test_failed_chunk_reports_each_of_its_trials():
    result = sweep(fragile_trial, n_trials=8, chunk_size=3, config={"bad": [4, 7]})
    assert [failure.trial for failure in result.failures] == [3, 4, 5, 6, 7]
    assert {failure.message for failure in result.failures} == {"trial 4 diverged", "trial 7 diverged"}
    assert sorted(set(result.frame["trial"])) == [0, 1, 2]
    table = result.failures_to_pandas()
    assert table["trial"].tolist() == [3, 4, 5, 6, 7]
    assert list(table.columns[:4]) == ["trial", "chunk", "entropy", "spawn_key"]


def test_raise_on_failure_summarises_the_failures():
    assert sweep().raise_on_failure().failures == ()
    result = sweep(fragile_trial, n_trials=6, chunk_size=1)
    with pytest.raises(SweepFailedError, match=r"1 of 6 trials failed:\n  trial 3: ValueError") as info:
        result.raise_on_failure()
    assert info.value.failures == result.failures
    assert "Traceback" in str(info.value)


def test_all_trials_failing_gives_an_empty_frame():
    result = sweep(fragile_trial, n_trials=2, chunk_size=2, config={"bad": [0]})
    assert len(result.failures) == 2
    assert result.frame.empty and list(result.frame.columns) == ["trial"]


@pytest.mark.parametrize(
    ("trial_function", "problem"), [(list_trial, "Got 'a list'"), (stray_trial, "outside the chunk")]
)
def test_frame_breaking_the_contract_is_a_failure(trial_function, problem):
    result = sweep(trial_function, n_trials=2, chunk_size=1)
    assert [failure.trial for failure in result.failures] == [0, 1]
    assert result.failures[0].error_type == "GeogaitError"
    assert "'trial_function' parameter of run_trials" in result.failures[0].message
    assert problem in result.failures[0].message


# --- resume -----------------------------------------------------------------------------------


@pytest.mark.parametrize("interrupt", [False, True])
def test_resume_computes_only_unfinished_chunks(tmp_path, call_log, interrupt):
    log, flag, config = call_log
    config = config | {"interrupt": interrupt}
    cache = tmp_path / "cache"
    flag.touch()
    if interrupt:
        with pytest.raises(KeyboardInterrupt):
            sweep(counted_trial, chunk_size=2, cache_dir=cache, config=config)
    else:
        crashed = sweep(counted_trial, chunk_size=2, cache_dir=cache, config=config)
        assert [failure.trial for failure in crashed.failures] == [6, 7, 8, 9]
    assert calls(log) == ([0, 2, 4, 6] if interrupt else [0, 2, 4, 6, 8])
    flag.unlink()
    resumed = sweep(counted_trial, chunk_size=2, cache_dir=cache, config=config)
    assert calls(log) == [6, 8]
    assert resumed.n_cached_chunks == 3 and resumed.failures == ()
    assert_frame_equal(resumed.frame, sweep(chunk_size=2).frame, check_exact=True)
    assert sorted(path.name for path in cache.iterdir()) == [
        f"chunk_{index:05d}.parquet" for index in range(5)
    ] + ["sweep.json"]


def test_finished_sweep_is_loaded_whole_from_the_cache(tmp_path, call_log):
    log, _, config = call_log
    first = sweep(counted_trial, cache_dir=tmp_path / "cache", config=config, jobs=2)
    assert calls(log) == [0, 3, 6, 9]
    (tmp_path / "cache" / "chunk_00002.parquet").unlink()
    second = sweep(counted_trial, cache_dir=tmp_path / "cache", config=config)
    assert calls(log) == [6]
    third = sweep(counted_trial, cache_dir=tmp_path / "cache", config=config, jobs=2)
    assert calls(log) == [] and (third.n_cached_chunks, third.n_workers) == (4, 0)
    for result in (second, third):
        assert_frame_equal(result.frame, first.frame, check_exact=True)


@pytest.mark.parametrize("damage", ["truncate", "empty", "other chunk"])
def test_corrupt_chunk_file_is_recomputed_with_a_warning(tmp_path, call_log, damage):
    log, _, config = call_log
    cache = tmp_path / "cache"
    first = sweep(counted_trial, cache_dir=cache, config=config)
    calls(log)
    target = cache / "chunk_00001.parquet"
    if damage == "other chunk":
        shutil.copyfile(cache / "chunk_00000.parquet", target)
    else:
        target.write_bytes(target.read_bytes()[: len(target.read_bytes()) // 2 * (damage == "truncate")])
    with pytest.warns(RuntimeWarning, match="Recomputing chunk 1"):
        second = sweep(counted_trial, cache_dir=cache, config=config)
    assert calls(log) == [3]
    assert_frame_equal(second.frame, first.frame, check_exact=True)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"seed": 8}, "seed"),
        ({"n_trials": 12}, "n_trials"),
        ({"chunk_size": 2}, "chunk_size"),
        ({"config": {"scale": 2.0}}, "config_sha256"),
        ({"config": {"shift": np.arange(5.0) + 1}}, "config_sha256"),
        ({"trial_function": fragile_trial}, "trial_function"),
    ],
)
def test_different_sweep_in_the_same_cache_dir_raises(tmp_path, change, field):
    sweep(cache_dir=tmp_path, config={"shift": np.arange(5.0)})
    kwargs = {"cache_dir": tmp_path, "config": {"shift": np.arange(5.0)}} | change
    with pytest.raises(ValueError, match=rf"'cache_dir' parameter .* different sweep: {field}"):
        sweep(**kwargs)


def test_numpy_config_values_match_plain_ones_in_the_cache(tmp_path):
    numpy_config = {"scale": np.float64(2.0), "n_samples": np.int64(3), "shift": np.zeros(3)}
    first = sweep(cache_dir=tmp_path, config=numpy_config)
    second = sweep(cache_dir=tmp_path, config={"scale": 2.0, "n_samples": 3, "shift": np.zeros(3)})
    assert second.n_cached_chunks == 4
    assert_frame_equal(second.frame, first.frame, check_exact=True)


def test_unusable_cache_dir_raises(tmp_path):
    with pytest.raises(ValueError, match="'config' parameter of run_trials must be JSON"):
        sweep(cache_dir=tmp_path / "a", config={"scale": {1.0, 2.0}})
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "chunk_00000.parquet").touch()
    with pytest.raises(ValueError, match="chunk files but no sweep.json"):
        sweep(cache_dir=tmp_path / "b")
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "sweep.json").write_text("{not json")
    with pytest.raises(ValueError, match="unreadable sweep.json"):
        sweep(cache_dir=tmp_path / "c")
    (tmp_path / "file").touch()
    with pytest.raises(ValueError, match="'cache_dir' parameter of run_trials must be None or"):
        sweep(cache_dir=tmp_path / "file")


# --- validation -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"trial_function": "noisy_trial"}, "trial_function"),
        ({"n_trials": 0}, "n_trials"),
        ({"n_trials": 2.0}, "n_trials"),
        ({"n_trials": True}, "n_trials"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"seed": None}, "seed"),
        ({"chunk_size": 0}, "chunk_size"),
        ({"jobs": 0}, "jobs"),
        ({"jobs": -2}, "jobs"),
        ({"jobs": 2, "scheduler": "tcp://127.0.0.1:8786"}, "jobs"),
        ({"scheduler": ""}, "scheduler"),
        ({"scheduler": 8786}, "scheduler"),
        ({"cache_dir": 3}, "cache_dir"),
        ({"config": [("scale", 1.0)]}, "config"),
        ({"config": {1: 2.0}}, "config"),
        ({"progress": "yes"}, "progress"),
        ({"description": 5}, "description"),
    ],
)
def test_bad_parameters_raise_with_their_name(kwargs, name):
    with pytest.raises(ValueError, match=rf"^The '{name}' parameter of run_trials must be"):
        sweep(**kwargs)


def test_missing_dask_asks_to_install_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"pip install geogait\[dask\]"):
        sweep(scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(ImportError, match=r"pip install geogait\[dask\]"):
        sweep(scheduler=object())


def test_an_unreachable_scheduler_is_said_in_one_clear_error(monkeypatch):
    """Dask's connection error (after its timeout) becomes a GeogaitError naming the address, not an OSError."""
    class Unreachable:
        @staticmethod
        def Client(address, **kwargs):  # noqa: N802 (dask's name)
            raise OSError(f"Timed out trying to connect to {address} after 30 s")

    monkeypatch.setattr(runner_module, "_distributed", lambda: Unreachable)
    from geogait import GeogaitError
    with pytest.raises(GeogaitError, match=r"Cannot reach the dask scheduler at 'tcp://127.0.0.1:1': Timed out"):
        sweep(scheduler="tcp://127.0.0.1:1")
