"""Fuzz tests (issue 11) of every CLI command, and of ``geogait optimize --resume`` with an edited run.json:
exit 0, or 1 with one ``error: …`` line (see tests/_fuzz.py)."""

import json
import string

import pytest
from _fuzz import FUZZ, WILD, assert_finite_model, check_cli
from _fuzz import fitted as fitted
from _fuzz import run as run
from _reference import BODY, CLI_COLUMNS
from _reference import strict_json as strict
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from geogait.cli import app


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
