"""Fuzz tests (issue 11): every input gives a correct result or a clear error naming the field.

Over the Python API (logs, models, swimmers, JSON), the stream protocol and every CLI command.
Derandomized hypothesis (the same examples on every run, no example database) with small example
counts, so the suite is deterministic and takes about half a minute on two cores.

Properties checked:

* the library raises only :class:`~geogait.GeogaitError` (a ``ValueError``) for bad input, and its
  message names the parameter ("The 'x' parameter of Y must be …") or the file;
* the CLI exits with 0, or with 1 and exactly one ``error: …`` line, never a traceback and never
  the "unexpected" (bug) message;
* every saved model loads and is finite; a model file that a run could not improve is left
  byte-for-byte as it was; every JSON written is strict JSON.
"""

import json
import math
import string

import numpy as np
import pytest
from _reference import GAIT
from _reference import Sink as _Sink
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import dumps_json
from geogait.cli import app
from geogait.gaits import seed_gait
from geogait.io import read_log
from geogait.learn import StreamLearner, run_stream
from geogait.models import AdaptiveGaitModel, load_model
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

FUZZ = settings(derandomize=True, database=None, deadline=None, print_blob=False,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])
BODY = ["body_velocity_x", "body_velocity_y", "body_velocity_theta"]
CLI_COLUMNS = ["--shape", "shape_0,shape_1", "--body-velocity", ",".join(BODY), "--phase", "phase",
               "--shape-velocity", "shape_velocity_0,shape_velocity_1"]
COLUMNS = dict(shape=["shape_0", "shape_1"], body_velocity=BODY, phase="phase",
               shape_velocity=["shape_velocity_0", "shape_velocity_1"])

# Numbers as a robot, a typo or a broken sensor produces them.
WILD = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                 st.sampled_from([0.0, -0.0, 1e300, -1e300, 1e200, 1e-320, 5e-324, 1e12, 1e13, 360.0, 1e5]),
                 st.integers(-10**20, 10**20))


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), GAIT, 8, seed=2, sensor_noise=0.05)  # 800 samples


@pytest.fixture(scope="module")
def fitted(run):
    return AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)


def names_a_field(error: BaseException) -> bool:
    text = str(error)
    return "parameter of" in text or "Cannot write" in text or "geogait model" in text or "Refusing" in text


def check_cli(result) -> str:
    """Exit 0, or 1 with exactly one 'error: …' line; never a traceback or the bug message."""
    assert "Traceback" not in result.output, result.output
    assert result.exit_code in (0, 1), (result.exit_code, result.output)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    if result.exit_code == 1:
        assert len(errors) == 1 and "unexpected" not in errors[0], result.stderr
        assert len(errors[0]) > len("error: ") + 10, errors[0]
        return errors[0]
    return ""


def strict(text: str):
    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")
    return json.loads(text, parse_constant=refuse)


def assert_finite_model(path) -> None:
    model = load_model(path)
    for array in (model.window_weights_, model.covariance_, model.psi_, model.phase_model_.bank_.weights):
        assert np.all(np.isfinite(array))


# -- Python API -------------------------------------------------------------------------------------
@FUZZ
@given(edits=st.lists(st.tuples(st.integers(0, 399), st.sampled_from(["time", "shape_0", "shape_velocity_1", *BODY,
                                                                      "phase"]), WILD), max_size=4),
       options=st.fixed_dictionaries({}, optional={"window": st.integers(-2, 40), "gap_factor": WILD,
                                                   "outlier_limit": st.one_of(st.none(), WILD),
                                                   "time_unit": st.sampled_from(["s", "ms", "us", "ns", "h", ""]),
                                                   "max_jitter": WILD, "drop_nan": st.booleans()}))
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_read_log_gives_a_finite_log_or_names_the_field(run, edits, options):
    frame = run.to_pandas().iloc[:400].copy()
    for row, column, value in edits:
        frame.loc[row, column] = value
    try:
        log = read_log(frame, **COLUMNS, **options)
    except GeogaitError as error:
        assert names_a_field(error), error
        return
    for array in (log.time, log.shape, log.shape_velocity, log.body_velocity, log.phase):
        assert np.all(np.isfinite(array))
    assert np.abs(log.body_velocity).max() <= 1e12 * 1e9  # rates per second of the largest unit


@FUZZ
@given(n=st.integers(0, 30), d=st.integers(1, 3), value=WILD, where=st.sampled_from(["shape", "rate", "body", "phase"]),
       transpose=st.booleans(), rate_width=st.integers(1, 3))
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_partial_fit_learns_finitely_or_names_the_field(n, d, value, where, transpose, rate_width):
    rng = np.random.default_rng(n * 7 + d)
    arrays = {"phase": rng.uniform(0, 2 * np.pi, n), "shape": rng.normal(size=(n, d)),
              "rate": rng.normal(size=(n, rate_width)), "body": rng.normal(size=(n, 3))}
    if n:
        arrays[where].reshape(-1)[0] = value
    if transpose:
        arrays["shape"] = arrays["shape"].T
    model = AdaptiveGaitModel(gait=None if n % 2 else seed_gait(d))
    try:
        model.partial_fit(arrays["phase"], arrays["shape"], arrays["rate"], arrays["body"])
    except GeogaitError as error:
        assert names_a_field(error), error
        assert not hasattr(model, "batch_shape_")
        return
    assert np.all(np.isfinite(model.window_weights_)) and np.all(np.isfinite(model.covariance_))
    assert math.isfinite(model.gamma_)


@FUZZ
@given(n_links=st.one_of(st.integers(-3, 12), st.sampled_from([10**6, 201])),
       lengths=st.one_of(st.none(), st.lists(WILD, min_size=1, max_size=5)),
       drag=WILD, ratio=WILD, frame=st.sampled_from(["middle", "tail", "center_of_mass", "head"]))
def test_swimmer_is_finite_or_names_the_field(n_links, lengths, drag, ratio, frame):
    try:
        swimmer = PurcellSwimmer(n_links, link_lengths=lengths, drag_coefficient=drag, drag_ratio=ratio,
                                 body_frame=frame)
    except GeogaitError as error:
        assert names_a_field(error), error
        return
    shapes = np.linspace(-1, 1, 3 * swimmer.n_joints).reshape(3, swimmer.n_joints)
    assert np.all(np.isfinite(swimmer.connection(shapes)))


JSON_VALUES = st.recursive(st.one_of(st.none(), st.booleans(), WILD, st.text(max_size=5)),
                           lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                   st.dictionaries(st.text(max_size=4), inner, max_size=3)),
                           max_leaves=12)


@FUZZ
@given(value=JSON_VALUES)
def test_json_sanitiser_always_writes_strict_json(value):
    strict(dumps_json(value))
    strict(dumps_json({"x": value, "arr": np.array([1.0, np.nan])}))


# -- the stream protocol -----------------------------------------------------------------------------
FIELDS = ["time", "phase", "shape", "shape_velocity", "body_velocity"]
MUTATION = st.one_of(
    st.tuples(st.just("value"), st.sampled_from(FIELDS), st.one_of(WILD, st.none(), st.text(max_size=3),
                                                                  st.lists(WILD, max_size=4))),
    st.tuples(st.just("element"), st.sampled_from(["shape", "shape_velocity", "body_velocity"]), WILD),
    st.tuples(st.just("drop"), st.sampled_from(FIELDS), st.none()),
    st.tuples(st.just("raw"), st.none(), st.sampled_from(["", "{", "[]", "null", "NaN", '{"shape": 1}',
                                                          '{"time": Infinity}', "\x00", "1e999"])),
)


def mutate(entry: dict, mutation) -> str:
    kind, field, value = mutation
    entry = dict(entry)
    if kind == "raw":
        return value
    if kind == "drop":
        entry.pop(field, None)
    elif kind == "value":
        entry[field] = value
    else:
        entry[field] = list(entry[field])
        entry[field][0] = value
    return json.dumps(entry)


@settings(FUZZ, max_examples=30)
@given(mutations=st.lists(st.tuples(st.integers(0, 299), MUTATION), max_size=3), save_every=st.sampled_from([None,
                                                                                                            97, 100]))
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_stream_protocol_never_saves_garbage(run, fitted, tmp_path_factory, mutations, save_every):
    folder = tmp_path_factory.mktemp("stream")
    path = fitted.save(folder / "m.npz")
    before = path.read_bytes()
    edits = dict(mutations)
    text = []
    for s in range(300):
        entry = {"time": float(run.time[s]), "phase": float(run.phase[s]), "shape": run.shape[s].tolist(),
                 "shape_velocity": run.shape_velocity[s].tolist(), "body_velocity": run.body_velocity[s].tolist()}
        text.append((mutate(entry, edits[s]) if s in edits else json.dumps(entry)) + "\n")
    sink = _Sink()
    learner = StreamLearner(load_model(path), path=path, save_every=save_every)
    summary = run_stream(learner, text, sink)
    outputs = [strict(line) for line in sink.text.splitlines()]
    assert len(outputs) == summary.n_samples
    if summary.reason == "error":
        assert "input line" in summary.error, summary.error
    else:
        assert summary.reason == "eof" and summary.n_samples == 300 - sum(1 for t in text if not t.strip())
    assert all(math.isfinite(o["gamma"]) for o in outputs if o["gamma"] is not None)
    if summary.n_learned:
        assert summary.saved == path
        assert_finite_model(path)
        assert load_model(path).n_samples_seen_ == fitted.n_samples_seen_ + summary.n_learned
    else:
        assert path.read_bytes() == before


# -- every CLI command -----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def files(run, fitted, tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    run.to_pandas().to_csv(folder / "log.csv", index=False)
    fitted.save(folder / "model.npz")
    (folder / "config.json").write_text(json.dumps(fitted.to_config()))
    (folder / "a_file").write_text("x")
    return folder


CLI_VALUES = st.one_of(st.sampled_from(["0", "-1", "1", "2", "nan", "inf", "-inf", "1e300", "", "x", "2,", ",",
                                        "3,x", "1e-320", "10000000", "0.5", "ms", "jsonl", "csv"]),
                       st.text(alphabet=string.printable, max_size=6))


@settings(FUZZ, max_examples=20)
@given(option=st.sampled_from(["--links", "--cycles", "--drag-ratio", "--cycles-per-environment",
                               "--samples-per-cycle", "--amplitude", "--perturbation", "--noise", "--shape-noise",
                               "--body-frame", "--seed"]), value=CLI_VALUES)
@pytest.mark.slow
def test_cli_simulate(files, tmp_path_factory, option, value):
    out = tmp_path_factory.mktemp("sim")
    args = ["simulate", "--cycles", "2", "--samples-per-cycle", "20", option, value, "--out", str(out)]
    if option in ("--cycles", "--samples-per-cycle") and value in ("10000000", "1e300", "2"):
        args[2:6] = ["--cycles", "1", "--samples-per-cycle", "20"]  # keep the fuzz fast: 10⁷ samples is refused anyway
    if not check_cli(CliRunner().invoke(app, args)):
        strict((out / "manifest.json").read_text())


LOG_EDITS = st.lists(st.tuples(st.integers(0, 799), st.sampled_from(["time", "shape_0", "phase", *BODY]),
                               st.one_of(WILD, st.sampled_from(["abc", "", "1,2"]))), min_size=1, max_size=3)


@settings(FUZZ, max_examples=12)
@given(edits=LOG_EDITS, option=st.sampled_from([[], ["--smoothing-window", "4"], ["--time-unit", "ms"],
                                                ["--outlier-limit", "0"], ["--gait-order", "0"], ["--windows", "1"],
                                                ["--forgetting-factor", "2"], ["--test-fraction", "0.95"]]))
@pytest.mark.slow
def test_cli_fit_and_predict(run, files, tmp_path_factory, edits, option):
    folder = tmp_path_factory.mktemp("fit")
    frame = run.to_pandas().astype(object)
    for row, column, value in edits:
        frame.loc[row, column] = value
    frame.to_csv(folder / "log.csv", index=False)
    result = CliRunner().invoke(app, ["fit", str(folder / "log.csv"), *CLI_COLUMNS, *option, "--out",
                                      str(folder / "out")])
    if not check_cli(result):
        assert_finite_model(folder / "out" / "model.npz")
        strict((folder / "out" / "report.json").read_text())
    result = CliRunner().invoke(app, ["predict", str(files / "model.npz"), str(folder / "log.csv"), *CLI_COLUMNS,
                                      *(option if option[:1] == ["--time-unit"] else []),
                                      "--out", str(folder / "p.csv")])
    if not check_cli(result):
        strict((folder / "p.json").read_text())


@settings(FUZZ, max_examples=30)
@given(lines=st.lists(st.one_of(st.text(max_size=30), st.sampled_from(['{"shape": [1e300, 0], "phase": 1}',
                                                                         "time,phase\n1,2"])), max_size=4),
       option=st.sampled_from([[], ["--format", "csv"], ["--format", "xml"], ["--save-every", "0"],
                               ["--time-unit", "weeks"], ["--outlier-limit", "-1"], ["--derivative-window", "1"]]))
def test_cli_stream(files, tmp_path_factory, lines, option):
    folder = tmp_path_factory.mktemp("stream")
    model = folder / "model.npz"
    model.write_bytes((files / "model.npz").read_bytes())
    before = model.read_bytes()
    result = CliRunner().invoke(app, ["stream", str(model), *option], input="\n".join(lines))
    check_cli(result)
    for line in result.stdout.splitlines() if "--format" not in option else []:
        strict(line)
    assert_finite_model(model)
    if "learned" not in result.stdout:
        assert model.read_bytes() == before


@settings(FUZZ, max_examples=30)
@given(command=st.sampled_from(["accuracy", "environments", "optimization"]),
       content=st.sampled_from([b"", b"\x00\xff", b"trial,value\n0,1\n", b"a,b\n1,2,3\n", "columns"]),
       fill=st.sampled_from(["x", "nan", "1e300", "-1", "3", ""]),
       option=st.sampled_from([[], ["--trials", "0"], ["--links", "1"], ["--seed", "x"], ["--jobs", "x"]]))
def test_cli_figures_from_bad_csv(tmp_path_factory, command, content, fill, option):
    from geogait.experiments import AccuracyResult, EnvironmentResult, OptimizationResult

    folder = tmp_path_factory.mktemp("fig")
    if content == "columns":  # the right header, values that do not form a result
        columns = {"accuracy": AccuracyResult, "environments": EnvironmentResult,
                   "optimization": OptimizationResult}[command].COLUMNS
        content = (",".join(columns) + "\n" + (",".join([fill] * len(columns)) + "\n") * 3).encode()
    (folder / "in.csv").write_bytes(content)
    result = CliRunner().invoke(app, ["figure", command, "--from-csv", str(folder / "in.csv"), *option,
                                      "--out", str(folder)])
    assert check_cli(result)


@settings(FUZZ, max_examples=20)
@given(option=st.sampled_from(["--links", "--cycles", "--seed", "--noise", "--gamma-threshold", "--order",
                               "--objective", "--method", "--max-joint-angle"]),
       value=st.sampled_from(["x", "", "nan", "1e300"]))
def test_cli_optimize_rejects_unparseable_options(files, option, value):
    result = CliRunner().invoke(app, ["optimize", option, value, "--out", str(files / "a_file")])
    assert check_cli(result)


MAPPING_VALUES = st.one_of(st.none(), st.integers(), st.text(max_size=4), st.lists(st.text(max_size=3), max_size=4),
                           st.lists(st.integers(), max_size=3), st.booleans(), st.dictionaries(st.text(max_size=2),
                                                                                                st.integers(),
                                                                                                max_size=2))


@FUZZ
@given(entries=st.dictionaries(st.sampled_from(["time", "shape", "pose", "body_velocity", "shape_velocity", "phase",
                                                "degrees", "other"]), MAPPING_VALUES, max_size=5))
def test_column_mappings_are_checked(tmp_path_factory, run, entries):
    from geogait.io import load_column_mapping

    path = tmp_path_factory.mktemp("map") / "mapping.json"
    path.write_text(json.dumps(entries))
    try:
        mapping = load_column_mapping(path)
        read_log(run.to_pandas(), mapping)
    except GeogaitError as error:
        assert names_a_field(error), error


# -- issue 21: the model loader, resume and the robot bridge ------------------------------------------------------
LOADER_EDITS = st.lists(st.one_of(
    st.tuples(st.just("param"), st.sampled_from(["n_windows", "smoothing_order", "forgetting_factor", "phase_rate",
                                                 "window_width", "interaction", "initial_covariance"]),
              st.one_of(WILD, st.none(), st.booleans(), st.text(max_size=3), st.lists(st.integers(), max_size=2))),
    st.tuples(st.just("meta"), st.sampled_from(["n_joints", "batch_shape", "class", "format_version"]),
              st.one_of(WILD, st.none(), st.booleans(), st.text(max_size=3), st.lists(WILD, max_size=3))),
    st.tuples(st.just("array"), st.sampled_from(["weights", "covariance", "gait", "n_updates", "psi",
                                                 "phase_model/weights", "n_samples_seen"]),
              st.sampled_from(["nan", "inf", "complex", "empty", "scalar", "transpose", "huge", "int", "drop"]))),
    min_size=1, max_size=3)


def _edited_array(value: np.ndarray, how: str):
    value = np.asarray(value)
    return {"nan": lambda: np.full(value.shape, np.nan), "inf": lambda: np.full(value.shape, -np.inf),
            "complex": lambda: value.astype(complex), "empty": lambda: np.zeros((0,)), "scalar": lambda: np.float64(3),
            "transpose": lambda: value.T.copy(), "huge": lambda: np.full(value.shape, 1e300),
            "int": lambda: value.astype(np.int64)}[how]()


@settings(FUZZ, max_examples=60)
@given(edits=LOADER_EDITS)
@pytest.mark.filterwarnings("ignore::geogait.GeogaitWarning")
def test_model_loader_gives_a_usable_model_or_a_clear_error(fitted, run, tmp_path_factory, edits):
    import time

    from geogait._files import write_state

    metadata, state = fitted.get_state()
    metadata, state = json.loads(json.dumps(metadata)), dict(state)
    for kind, name, value in edits:
        if kind == "param":
            metadata["params"][name] = value
        elif kind == "meta":
            metadata[name] = value
        elif value == "drop":
            state.pop(name, None)
        elif name in state:
            state[name] = _edited_array(state[name], value)
    path = tmp_path_factory.mktemp("loader") / "m.npz"
    write_state(path, metadata, state)
    started = time.perf_counter()
    try:
        model = load_model(path)
    except GeogaitError as error:
        assert "m.npz" in str(error), error
    else:
        prediction = model.predict(run.phase[:50], run.shape[:50], run.shape_velocity[:50])
        assert prediction.shape == (50, 3) and np.all(np.isfinite(prediction))
    assert time.perf_counter() - started < 5


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("resume") / "run"
    result = CliRunner().invoke(app, ["optimize", "--cycles", "2", "--out", str(folder)])
    assert result.exit_code == 0, result.output
    return folder


RESUME_EDITS = st.one_of(
    st.tuples(st.just("setting"), st.sampled_from(["links", "seed", "noise", "method", "robot", "order",
                                                   "run_id", "checkpoint_every", "max_tracking_error"]),
              st.one_of(WILD, st.none(), st.booleans(), st.text(max_size=3), st.lists(st.integers(), max_size=2))),
    st.tuples(st.just("drop"), st.sampled_from(["links", "seed", "run_id", "method"]), st.none()),
    st.tuples(st.just("option"), st.sampled_from(["--links", "--seed", "--noise", "--method", "--out", "--order"]),
              st.sampled_from(["5", "0", "batch", "elsewhere"])),
    st.tuples(st.just("cycles"), st.none(), st.integers(-2, 2)),
    st.tuples(st.just("raw"), st.none(), st.sampled_from(["{}", "", "[]", "null", '{"links": 3}', "{" * 5000])),
)


@settings(FUZZ, max_examples=25)
@given(edit=RESUME_EDITS)
def test_resume_continues_its_own_run_or_refuses_in_one_line(finished_run, tmp_path_factory, edit):
    import shutil

    folder = tmp_path_factory.mktemp("resume-edit") / "run"
    shutil.copytree(finished_run, folder)
    kind, name, value = edit
    settings_path = folder / "run.json"
    record = json.loads(settings_path.read_text())
    options = []
    if kind == "setting":
        record[name] = value
    elif kind == "drop":
        record.pop(name)
    elif kind == "option":
        options = [name, value]
    elif kind == "cycles":
        options = ["--cycles", str(value)]
    if kind == "raw":
        settings_path.write_text(value)
    else:
        settings_path.write_text(json.dumps(record))
    before = (folder / "checkpoint.npz").read_bytes()
    result = CliRunner().invoke(app, ["optimize", "--resume", str(folder), *options])
    error = check_cli(result)
    unchanged = kind == "setting" and json.loads((finished_run / "run.json").read_text()).get(name) == value \
        and type(value) is type(json.loads((finished_run / "run.json").read_text()).get(name))
    if kind in ("setting", "drop", "option", "raw") and not unchanged:
        assert result.exit_code == 1, (edit, result.output)  # never continues a run its run.json does not describe
    if result.exit_code == 1:
        assert error and (folder / "checkpoint.npz").read_bytes() == before


FAULTS = ["none", "phase_stuck", "time_scale", "pose_jump", "frozen_joints", "ignore_set_gait", "string_numbers",
          "bool_numbers", "bad_utf8", "endless_line", "huge_error", "huge_stderr", "deep_json"]
HELLOS = st.one_of(st.just({}), st.fixed_dictionaries({}, optional={
    "version": st.sampled_from([1.0, True, "1", 2, None]),
    "cycle_period": st.one_of(WILD, st.sampled_from(["1", True, None])),
    "n_joints": st.sampled_from([2.0, "2", True, 0, 3, -1]),
    "protocol": st.sampled_from(["geogait-robot ", None, 1])}))


@settings(FUZZ, max_examples=16)
@given(fault=st.sampled_from(FAULTS), cycle=st.integers(0, 3), cycles=st.sampled_from([1, 9]),
       magnitude=st.sampled_from([10.0, 1000.0, 1e6]), hello=HELLOS)
@pytest.mark.slow
def test_bridge_takes_a_plausible_cycle_or_quarantines_or_stops_in_one_line(fault, cycle, cycles, magnitude, hello):
    """A fault-injecting driver (tests/_fault_driver.py): every injected fault is quarantined or ends the run with a
    clear, bounded error; nothing else escapes, nothing hangs."""
    import sys
    import time
    import warnings
    from pathlib import Path

    from geogait.optimize import InSituOptimizer
    from geogait.robots import ProcessRobot

    driver = [sys.executable, str(Path(__file__).with_name("_fault_driver.py")),
              json.dumps({"fault": fault, "cycle": cycle, "cycles": cycles, "magnitude": magnitude, "hello": hello})]
    started = time.perf_counter()
    robot = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with ProcessRobot(driver, timeout=20) as robot:
                InSituOptimizer().run(robot, 5)
    except GeogaitError as error:
        assert str(error).startswith("robot driver '") and len(str(error)) < 1200, error
    else:
        injected = fault != "none" and (fault == "ignore_set_gait" or cycle < 5)
        if injected and fault not in ("ignore_set_gait", "time_scale") and not hello:
            assert robot.quarantined, (fault, cycle)  # an injected fault is never learned from silently
    assert time.perf_counter() - started < 40
