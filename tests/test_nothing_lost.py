"""Regression tests for issue 21 (nothing lost, round 3): runs, resume, the robot bridge, model files and track.

CLI tests assert the printed message and the exit code (one ``error: …`` line, exit 1), never
``result.exception``.
"""

import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import one_error_line
from _reference import GAIT
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import OutputLock, output_set, read_state, write_state, write_text
from geogait.cli import app
from geogait.control import ReferencePath
from geogait.experiments.tracking import drag_change_metrics, plot_reference
from geogait.gaits import FourierGait, seed_gait
from geogait.models import AdaptiveGaitModel, ShapeSpaceModel, load_model
from geogait.optimize import InSituOptimizer
from geogait.plotting import plt
from geogait.robots import ProcessRobot
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

GEOGAIT = [sys.executable, "-c", "from geogait.cli import main; main()"]
FAULT_DRIVER = [sys.executable, str(Path(__file__).with_name("_fault_driver.py"))]
RUN = ["optimize", "--links", "3", "--cycles", "2"]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and p.name != ".geogait.lock"}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished 2-cycle optimisation run (seed 0) in its folder."""
    folder = tmp_path_factory.mktemp("runs") / "a"
    result = invoke(*RUN, "--out", folder)
    assert result.exit_code == 0, result.output
    return folder


def copy_of(folder: Path, tmp_path: Path) -> Path:
    target = tmp_path / folder.name
    shutil.copytree(folder, target)
    return target


# -- run identity, --overwrite, the lock, resume conflicts -------------------------------------------------------------
def test_run_identity_is_in_run_json_the_checkpoint_and_the_summary(finished):
    run_id = json.loads((finished / "run.json").read_text())["run_id"]
    metadata, _ = read_state(finished / "checkpoint.npz", "checkpoint", "geogait-optimizer-checkpoint", 1)
    assert metadata["tag"] == {"run_id": run_id} and len(run_id) == 16
    assert json.loads((finished / "summary.json").read_text())["config"]["run_id"] == run_id


def test_a_non_empty_out_is_refused_without_overwrite(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    before = snapshot(folder)
    one_error_line(invoke(*RUN, "--seed", "3", "--out", folder), "not empty", "--overwrite")
    assert snapshot(folder) == before  # nothing replaced
    assert invoke(*RUN, "--seed", "3", "--overwrite", "--out", folder).exit_code == 0
    assert json.loads((folder / "run.json").read_text())["seed"] == 3


def test_a_folder_another_run_writes_is_refused(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    before = snapshot(folder)
    with OutputLock(folder):  # as a run in another process holds it
        one_error_line(invoke(*RUN, "--overwrite", "--out", folder), "being written by another geogait run")
        one_error_line(invoke("optimize", "--resume", folder, "--cycles", "3"), "being written by another geogait run")
    assert snapshot(folder) == before


@pytest.mark.parametrize(("options", "names"), [
    (["--out", "elsewhere", "--links", "5", "--method", "batch"], "--links, --method, --out"),
    (["--seed", "4"], "--seed"),
    (["--overwrite"], "--overwrite"),
])
def test_resume_refuses_options_it_would_ignore(finished, options, names):
    one_error_line(invoke("optimize", "--resume", finished, *options), "--resume continues a run", names)


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


def test_resume_refuses_fewer_cycles_than_already_run(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    one_error_line(invoke("optimize", "--resume", folder, "--cycles", "1"), "fewer than the 2 cycles already run")
    result = invoke("optimize", "--resume", folder, "--cycles", "3")
    assert result.exit_code == 0, result.output
    assert len(pd.read_csv(folder / "cycles.csv")) == 3
    # the new total is the run's: a later --resume without --cycles continues to it, not to the first total
    assert json.loads((folder / "run.json").read_text())["cycles"] == 3
    result = invoke("optimize", "--resume", folder)
    assert result.exit_code == 0, result.output
    assert len(pd.read_csv(folder / "cycles.csv")) == 3


def test_resume_refuses_a_checkpoint_of_another_run(finished, tmp_path):
    folder = copy_of(finished, tmp_path)
    other = tmp_path / "other"
    assert invoke(*RUN, "--seed", "5", "--out", other).exit_code == 0
    shutil.copy(other / "checkpoint.npz", folder / "checkpoint.npz")  # B's checkpoint beside A's run.json
    one_error_line(invoke("optimize", "--resume", folder), "belongs to another run")
    settings = json.loads((other / "run.json").read_text())
    settings["noise"] = 0.3  # settings edited after the run started
    write_text(other / "run.json", json.dumps(settings))
    one_error_line(invoke("optimize", "--resume", other), "was changed after the run started")


def test_a_run_refused_at_its_start_leaves_the_run_it_would_replace_whole(finished, tmp_path):
    """--overwrite replaces the earlier run only once the new one is under way: a run refused by a check that can
    only be made at its start (a driver that cannot start, a joint limit the seed gait breaks) keeps it."""
    folder = copy_of(finished, tmp_path)
    before = {path.name: path.read_bytes() for path in folder.iterdir() if path.is_file()}
    one_error_line(invoke("optimize", "--robot", "false", "--overwrite", "--out", folder), "robot driver")
    one_error_line(invoke("optimize", "--max-joint-angle", "0.5", "--overwrite", "--out", folder),
                   "--max-joint-angle", "[1, π]", "seed gait's largest joint angle")
    one_error_line(invoke("optimize", "--max-joint-angle", "3.5", "--overwrite", "--out", folder),
                   "--max-joint-angle", "[1, π]")
    assert {path.name: path.read_bytes() for path in folder.iterdir() if path.is_file()} == before
    fresh = tmp_path / "fresh" / "run"  # folders the refused run created are not left behind
    one_error_line(invoke("optimize", "--robot", "false", "--out", fresh), "robot driver")
    assert not (tmp_path / "fresh").exists()


def test_fit_predict_and_the_figures_keep_an_earlier_runs_files_unless_told_to_replace_them(tmp_path):
    """Each is refused before any work, naming the file and --overwrite, and leaves the earlier files as they were."""
    run = simulate(PurcellSwimmer(3), GAIT, 12, seed=0, samples_per_cycle=100)
    pd.DataFrame({"time": run.time, "shape_0": run.shape[:, 0], "shape_1": run.shape[:, 1], "x": run.pose[:, 0],
                  "y": run.pose[:, 1], "heading": run.pose[:, 2]}).to_csv(tmp_path / "log.csv", index=False)
    fit = ["fit", str(tmp_path / "log.csv"), "--shape", "shape_0,shape_1", "--pose", "x,y,heading",
           "--out", str(tmp_path / "fit")]
    predict = ["predict", str(tmp_path / "fit" / "model.npz"), str(tmp_path / "log.csv"), "--phaser",
               str(tmp_path / "fit" / "phaser.npz"), "--shape", "shape_0,shape_1", "--out", str(tmp_path / "p.csv")]
    for command in (fit, predict):
        assert invoke(*command).exit_code == 0
    (tmp_path / "figures").mkdir()
    for name in ("accuracy", "environments"):
        (tmp_path / "figures" / f"{name}.csv").write_text("a full run's results")
    write_text(tmp_path / "optimization.json", "{}")
    write_text(tmp_path / "tracking.png", "")
    saved = {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()}
    figures = str(tmp_path / "figures")
    for command, name in ((fit, "model.npz"), (predict, "p.csv"),
                          (["figure", "accuracy", "--quick", "--out", figures], "accuracy.csv"),
                          (["figure", "environments", "--quick", "--out", figures], "environments.csv"),
                          (["figure", "optimization", "--quick", "--out", str(tmp_path)], "optimization.json"),
                          (["figure", "tracking", "--quick", "--out", str(tmp_path)], "tracking.png")):
        one_error_line(invoke(*command), f"{name} exists", "give --overwrite to replace it")
    assert {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()} == saved
    assert invoke(*predict, "--overwrite").exit_code == 0


def test_a_figure_redraws_its_own_run_freely_and_another_runs_only_with_overwrite(tmp_path):
    """A redraw of the folder's own CSV adds its figure and a manifest beside the run's; a redraw of another run's
    CSV would leave the folder holding two runs' files: refused, and with --overwrite the earlier run's data go."""
    a, b = tmp_path / "a", tmp_path / "b"
    for folder, seed in ((a, "0"), (b, "5")):
        assert invoke("figure", "accuracy", "--quick", "--trials", "2", "--cycles", "5", "--seed", seed,
                      "--out", folder).exit_code == 0
    data = (a / "accuracy.csv").read_bytes()
    assert invoke("figure", "accuracy", "--from-csv", a / "accuracy.csv", "--out", a).exit_code == 0
    assert (a / "accuracy.csv").read_bytes() == data and (a / "accuracy.redraw.json").exists()
    one_error_line(invoke("figure", "accuracy", "--from-csv", b / "accuracy.csv", "--out", a),
                   "accuracy.csv exists", "--overwrite")
    assert invoke("figure", "accuracy", "--from-csv", b / "accuracy.csv", "--out", a, "--overwrite").exit_code == 0
    assert sorted(path.name for path in a.iterdir()) == ["accuracy.json", "accuracy.png"]
    assert json.loads((a / "accuracy.json").read_text())["config"]["from_csv"] == str(b / "accuracy.csv")


def test_a_run_that_replaced_another_and_died_is_resumed_as_itself(finished, tmp_path):
    """Once a run is under way its run.json replaces the earlier run's, the earlier summary and checkpoint are gone,
    and its own checkpoint follows its first cycle (whatever --checkpoint-every): failing later, it writes its own
    summary of the cycles that checkpoint holds, and is resumed as itself, never as the run it replaced."""
    folder = copy_of(finished, tmp_path)
    driver = shlex.join([sys.executable, str(Path(__file__).with_name("_fault_driver.py")),
                         json.dumps({"fault": "huge_error", "cycle": 2, "magnitude": 10})])  # fails in its 3rd cycle
    one_error_line(invoke("optimize", "--robot", driver, "--checkpoint-every", "5", "--overwrite", "--out", folder),
                   "EEEEEEEEEE")
    run = json.loads((folder / "run.json").read_text())
    summary = json.loads((folder / "summary.json").read_text())
    assert run["robot"] == driver and summary["config"]["run_id"] == run["run_id"]
    assert summary["results"]["cycles_run"] == 1
    from geogait.optimize import read_checkpoint_metadata

    metadata = read_checkpoint_metadata(folder / "checkpoint.npz")
    assert metadata["tag"]["run_id"] == run["run_id"] and metadata["state"]["cycle"] == 1


@pytest.mark.parametrize(("content", "fragment"), [("{}", "'links' must be an integer, got missing"),
                                                   ('{"links": "3"}', "'links' must be an integer"),
                                                   ("[1, 2]", "a JSON object expected"),
                                                   ("[" * 100_000, "not valid JSON")])
def test_a_broken_run_json_is_a_clear_error(finished, tmp_path, content, fragment):
    folder = copy_of(finished, tmp_path)
    (folder / "run.json").write_text(content)
    one_error_line(invoke("optimize", "--resume", folder), fragment)


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


def test_a_failing_track_run_leaves_the_earlier_run_whole(tmp_path, monkeypatch):
    folder = tmp_path / "t"
    options = ["track", "--quick", "--cycles", "2", "--warmup", "2", "--controllers", "adaptive", "--path", "line"]
    assert invoke(*options, "--out", folder).exit_code == 0
    before = snapshot(folder)
    one_error_line(invoke(*options, "--seed", "2", "--out", folder), "not empty")  # checked before the run
    from geogait.experiments import track

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device", "path.png")

    monkeypatch.setattr(track, "_plot_paths", broken)
    one_error_line(invoke(*options, "--seed", "2", "--overwrite", "--out", folder), "No space left on device")
    assert snapshot(folder) == before
    assert [p.name for p in folder.iterdir() if p.name.startswith(".geogait-staging")] == []


def test_track_checks_its_output_folder_before_running(tmp_path):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    started = time.perf_counter()
    one_error_line(invoke("track", "--out", a_file), "is a file")
    assert time.perf_counter() - started < 5  # refused before the (minutes long) default run


@pytest.mark.slow
def test_two_runs_into_one_folder_at_once_cannot_both_write_it(tmp_path):
    folder = tmp_path / "run"
    first = subprocess.Popen(GEOGAIT + ["optimize", "--cycles", "100000", "--out", str(folder)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not (folder / "checkpoint.npz").exists():
            time.sleep(0.05)
        second = subprocess.run(GEOGAIT + ["optimize", "--cycles", "2", "--seed", "1", "--overwrite", "--out",
                                           str(folder)], capture_output=True, text=True, timeout=120)
        assert second.returncode == 1
        assert f"being written by another geogait run (process {first.pid})" in second.stderr.strip().splitlines()[-1]
        assert first.poll() is None and json.loads((folder / "run.json").read_text())["seed"] == 0
    finally:
        first.send_signal(signal.SIGTERM)
        first.wait(timeout=60)


@pytest.mark.slow
def test_sigterm_ends_a_run_like_ctrl_c(tmp_path):
    folder = tmp_path / "run"
    process = subprocess.Popen(GEOGAIT + ["optimize", "--cycles", "100000", "--out", str(folder)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not (folder / "checkpoint.npz").exists():
        time.sleep(0.05)
    time.sleep(1.0)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1, stderr
    assert stderr.strip().splitlines()[-1] == "error: terminated (SIGTERM); files already written are complete"
    assert [p.name for p in folder.iterdir() if p.name.endswith(".tmp") or "staging" in p.name] == []
    read_state(folder / "checkpoint.npz", "checkpoint", "geogait-optimizer-checkpoint", 1)  # whole


# -- model files ----------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def samples():
    return simulate(PurcellSwimmer(3), GAIT, 4, seed=1)


@pytest.fixture(scope="module")
def model_state(samples):
    model = AdaptiveGaitModel(gait=GAIT).fit(samples.phase, samples.shape, samples.shape_velocity,
                                             samples.body_velocity)
    return model.get_state()


def _write(path, metadata, state, **changes):
    metadata = json.loads(json.dumps(metadata))
    state = dict(state)
    for key, value in changes.items():
        if key in state:
            state[key] = value
        elif key in metadata["params"]:
            metadata["params"][key] = value
        else:
            metadata[key] = value
    write_state(path, metadata, state)
    return path


@pytest.mark.parametrize(("change", "fragment"), [
    ({"weights": "nan"}, "holds NaN or infinity"),
    ({"covariance": "inf"}, "holds NaN or infinity"),
    ({"psi": "complex"}, "complex128"),
    ({"n_windows": 60_000_000}, "60000000 windows"),
    ({"batch_shape": [10**9]}, "batch shape (1000000000,)"),
    ({"n_joints": 100_000}, "n_joints must be an integer"),
    ({"n_joints": 7}, "claim 7 joints"),
])
def test_model_files_are_checked_before_anything_is_allocated(model_state, tmp_path, change, fragment):
    metadata, state = model_state
    (key, value), = change.items()
    if value in ("nan", "inf", "complex"):
        array = np.array(state[key], dtype=complex if value == "complex" else float)
        if value != "complex":
            array.flat[3] = np.nan if value == "nan" else np.inf
        value = array
    path = _write(tmp_path / "bad.npz", metadata, state, **{key: value})
    started = time.perf_counter()
    with pytest.raises(GeogaitError, match="bad.npz") as error:
        load_model(path)
    assert fragment in str(error.value) and time.perf_counter() - started < 2


def test_deeply_nested_metadata_is_a_clear_error(model_state, tmp_path):
    metadata, state = model_state
    arrays = {f"state/{k}": np.asarray(v) for k, v in state.items()}
    arrays["metadata"] = np.frombuffer(json.dumps(metadata).replace('"params"', '"x": ' + "[" * 100_000 + "]" * 100_000
                                                                    + ', "params"').encode(), np.uint8)
    np.savez(tmp_path / "deep.npz", **arrays)
    with pytest.raises(GeogaitError, match="not a readable geogait model"):
        load_model(tmp_path / "deep.npz")


def test_predict_with_a_nan_model_is_one_error_line(model_state, samples, tmp_path):
    metadata, state = model_state
    weights = np.array(state["weights"])
    weights[0, 0, 0] = np.nan
    path = _write(tmp_path / "nan.npz", metadata, state, weights=weights)
    log = tmp_path / "log.csv"
    samples.to_pandas().to_csv(log, index=False)
    result = invoke("predict", path, log, "--shape", "shape_0,shape_1", "--phase", "phase", "--shape-velocity",
                    "shape_velocity_0,shape_velocity_1", "--out", tmp_path / "p.csv")
    one_error_line(result, "NaN or infinity")
    assert not (tmp_path / "p.csv").exists()


@pytest.mark.parametrize("path, fragment", [("folder", "is a folder"), ("fifo", "FIFO"), ("/dev/zero", "device")])
def test_paths_that_are_not_files_say_what_they_are(tmp_path, path, fragment):
    if path == "folder":
        path = tmp_path
    elif path == "fifo":
        path = tmp_path / "pipe.npz"
        os.mkfifo(path)
    with pytest.raises(GeogaitError, match=fragment):
        load_model(path)
    with pytest.raises(GeogaitError, match=fragment):
        ReferencePath.from_csv(path)


@pytest.mark.parametrize(("model", "message"), [
    (lambda: AdaptiveGaitModel(initial_covariance=1e300), "'initial_covariance' parameter"),
    (lambda: ShapeSpaceModel(shape_scale=1e-300), "'shape_scale' parameter"),
])
def test_hyper_parameters_that_overflow_the_state_are_refused(samples, model, message):
    with pytest.raises(GeogaitError, match=message):
        model().fit(samples.phase, samples.shape, samples.shape_velocity, samples.body_velocity)


@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_shapes_too_large_for_the_model_are_a_clear_error(samples):
    scale = 1e11  # inside the documented ±1e12
    with pytest.raises(GeogaitError, match="shape_scale"):
        ShapeSpaceModel().fit(samples.phase, samples.shape * scale, samples.shape_velocity, samples.body_velocity)
    # at their scale the same shapes are learned
    model = ShapeSpaceModel(shape_scale=1e3).fit(samples.phase, samples.shape * 1e3, samples.shape_velocity,
                                                 samples.body_velocity)
    assert all(np.all(np.isfinite(v)) for v in model.get_state()[1].values())


# -- the robot bridge -------------------------------------------------------------------------------------------------
def fault_robot(**config):
    return ProcessRobot(FAULT_DRIVER + [json.dumps(config)], timeout=20)


@pytest.mark.parametrize(("config", "fragment"), [
    ({"hello": {"cycle_period": 1e300}}, "'cycle_period' must be in [0.001, 86400] seconds, got 1e+300"),
    ({"hello": {"cycle_period": 1e-300}}, "'cycle_period' must be in"),
    ({"hello": {"version": 1.0}}, "protocol version 1.0 (must be the integer 1 or 2)"),
    ({"hello": {"version": True}}, "protocol version True"),
    ({"hello": {"n_joints": 2.0}}, "'n_joints' must be an integer"),
    ({"hello": {"gait": {"order": True, "params": [0, 1, 0, 0, 0, 1]}}}, "'gait' must be"),
    ({"fault": "string_numbers", "cycle": 1}, "field 'time' must be a finite number (JSON numbers within ±1e+12), "
                                              "got '"),
    ({"fault": "huge_numbers", "cycle": 1}, "field 'pose' must be a list of 3 finite numbers (JSON numbers within "
                                            "±1e+12)"),
    ({"fault": "bool_numbers", "cycle": 1}, "field 'shape' must be a list of 2 finite numbers"),
    ({"fault": "second_hello", "cycle": 1}, "a second 'hello' in the middle of the run"),
    ({"fault": "bad_utf8", "cycle": 1}, "is not UTF-8 (byte 0xff"),
    ({"fault": "endless_line", "cycle": 1}, "longer than 1048576 bytes"),
    ({"fault": "deep_json", "cycle": 1}, "is not JSON (nested too deeply)"),
    ({"fault": "repeated_key", "cycle": 1}, "key 'time' appears more than once in one JSON object"),
    ({"fault": "clock_per_cycle", "cycle": 1, "cycles": 9},
     "3 implausible cycles in a row; the last: its first time stamp (0.0 s) is not after the last accepted cycle's "
     "last (0.975 s)"),
    ({"fault": "phase_stuck", "cycle": 1, "cycles": 9}, "3 implausible cycles in a row; the last: the commanded phase"),
    ({"fault": "time_scale", "cycle": 0, "cycles": 9}, "span 1000 s, but the hello's cycle_period is 1 s"),
    ({"fault": "frozen_joints", "cycle": 0, "cycles": 9}, "joint(s) [0, 1] never moved (less than 1%"),
])
def test_a_driver_is_trusted_with_nothing(config, fragment):
    started = time.perf_counter()
    with pytest.raises(GeogaitError) as error, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with fault_robot(**config) as robot:
            for _ in range(5):
                robot.next_cycle()
    message = str(error.value)
    assert fragment in message and "_fault_driver.py" in message  # the whole command, not argv[0]
    assert len(message) < 1000 and time.perf_counter() - started < 15  # no full timeout, no megabyte "line"


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


def test_after_a_cycle_broke_off_the_robot_refuses_to_go_on():
    """The rest of a broken cycle's samples are still in the pipe: read on, they would be taken for the next cycle
    (39 samples starting mid-cycle, plausible enough to pass), and every later cycle would be one behind."""
    with fault_robot(fault="string_numbers", cycle=1) as robot:
        robot.next_cycle()
        with pytest.raises(GeogaitError, match="field 'time' must be a finite number"):
            robot.next_cycle()
        with pytest.raises(GeogaitError, match="an earlier cycle broke off part-way .* no longer in step"):
            robot.next_cycle()


@pytest.mark.parametrize("fault", ["huge_error", "huge_stderr"])
def test_long_driver_texts_are_cut(fault):
    with pytest.raises(GeogaitError) as error:
        with fault_robot(fault=fault, cycle=0, magnitude=500_000) as robot:
            robot.next_cycle()
    assert len(str(error.value)) < 1000 and ("EEEE" in str(error.value) or "SSSS" in str(error.value))


@pytest.mark.parametrize(("config", "fragment"), [({"fault": "pose_jump", "cycle": 2}, "the pose jumps by 1000"),
                                                  ({"fault": "phase_stuck", "cycle": 1}, "commanded phase covers"),
                                                  ({"fault": "time_scale", "cycle": 1}, "span 1000 s"),
                                                  ({"fault": "time_scale", "cycle": 1, "magnitude": 0.001},
                                                   "its first time stamp (0.001 s) is not after")])
def test_an_implausible_cycle_is_quarantined_and_logged(config, fragment):
    with pytest.warns(match="quarantined"), fault_robot(**config) as robot:
        cycles = [robot.next_cycle() for _ in range(4)]
    assert len(robot.quarantined) >= 1 and fragment in robot.quarantined[0]
    assert [int(c.cycle[0]) for c in cycles] == [0, 1, 2, 3] and robot.cycles_run == 4 + len(robot.quarantined)


def test_a_driver_that_ignores_set_gait_does_not_get_a_summary_of_a_gait_it_never_ran():
    with warnings.catch_warnings(), fault_robot(fault="ignore_set_gait") as robot:
        warnings.simplefilter("ignore")
        robot.next_cycle()
        robot.set_gait(FourierGait(robot.gait.coefficients * 1.5))
        with pytest.raises(GeogaitError, match="implausible cycles (in a row|since the last set_gait).*ignored"):
            for _ in range(8):
                robot.next_cycle()
    assert any("follow an earlier gait" in reason for reason in robot.quarantined)


def test_a_quote_left_open_in_robot_is_a_clear_error(tmp_path):
    with pytest.raises(GeogaitError, match="a command line a shell could split"):
        ProcessRobot("python -m 'geogait.robots.driver")
    one_error_line(invoke("optimize", "--robot", "python -c 'oops", "--out", tmp_path / "x"), "shell could split")


@pytest.mark.slow
def test_the_reference_driver_is_plausible_through_a_whole_run():
    with ProcessRobot([sys.executable, "-m", "geogait.robots.driver", "--period", "2"]) as robot:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = InSituOptimizer().run(robot, 20)
    assert robot.quarantined == [] and result.n_steps >= 2


# -- track ------------------------------------------------------------------------------------------------------------
def nulls_without_reason(value, where="") -> list[str]:
    if isinstance(value, list):
        return [n for i, v in enumerate(value) for n in nulls_without_reason(v, f"{where}[{i}]")]
    if not isinstance(value, dict):
        return []
    missing = [f"{where}.{k}" for k, v in value.items() if v is None and f"{k}_null_reason" not in value]
    return missing + [n for k, v in value.items() for n in nulls_without_reason(v, f"{where}.{k}")]


def test_a_track_run_that_ends_before_the_budget_says_so(tmp_path):
    waypoints = tmp_path / "short.csv"
    waypoints.write_text("x,y\n0,0\n0.1,0\n")  # ends after about a cycle
    out = tmp_path / "t"
    result = invoke("track", "--quick", "--cycles", "8", "--change-cycle", "6", "--drag-ratio", "2,4", "--path",
                    waypoints, "--controllers", "adaptive,frozen", "--out", out)
    assert result.exit_code == 0, result.output
    assert "warning: the adaptive controller reached the end of the path" in result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["results"]["adaptive"]["stopped_early"] is True
    change = summary["results"]["drag_change"]
    assert change["change_reached"] is False and change["cycles_to_recover"] is None  # not 0
    assert "before the change" in change["cycles_to_recover_null_reason"]
    assert nulls_without_reason(summary) == []


def test_drag_change_metrics_give_every_null_a_reason():
    frame = pd.DataFrame({"controller": ["adaptive"] * 12, "trial": 0, "cycle": np.arange(12),
                          "cross_track": [0.1] * 6 + [1.0] * 6})
    metrics = drag_change_metrics(frame, 6)
    assert metrics["change_reached"] and metrics["cycles_to_recover"] is None
    assert nulls_without_reason(metrics) == []


def test_paths_and_plots_are_bounded(tmp_path):
    far = ReferencePath.waypoints([[0, 0], [1e6, 0]])
    fig, ax = plt.subplots()
    started = time.perf_counter()
    plot_reference(ax, far, np.array([[0.0, 0.0], [0.5, 0.1]]))
    plt.close(fig)
    assert time.perf_counter() - started < 5
    assert ReferencePath.circle(1e6).points.shape[0] <= 200_000
    with pytest.raises(GeogaitError, match="'radius' parameter"):
        ReferencePath.circle(1e9)
    with pytest.raises(GeogaitError, match="'points' parameter"):
        ReferencePath.waypoints([[0, 0], [1e13, 0]])
    one_error_line(invoke("track", "--scale", "1e9", "--out", tmp_path / "x"), "--scale")


def test_every_gait_given_to_the_shape_space_plot_is_drawn_with_its_start():
    """A 5th gait was dropped from the figure, and only the first gait's start was marked."""
    from geogait.plotting import plot_shape_space

    fig, ax = plt.subplots()
    plot_shape_space(ax, None, {f"gait {k}": seed_gait(2, amplitude=0.2 * (k + 1)) for k in range(5)})
    assert ax.get_legend_handles_labels()[1] == [f"gait {k}" for k in range(5)]
    assert sum(line.get_marker() == "o" for line in ax.lines) == 5
    plt.close(fig)
