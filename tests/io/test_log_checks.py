"""read_log and the files that go with a log check what they read (issue 11): implausible values named by column
and row, time units converted or warned about, a column mapping or stream config that is not UTF-8."""

import warnings

import numpy as np
import pytest
from _noisy_run import frame as frame
from _noisy_run import run as run
from _reference import BODY, COLUMNS
from typer.testing import CliRunner

from geogait import GeogaitError, GeogaitWarning
from geogait.cli import app
from geogait.io import read_log
from geogait.learn import fit_log


def test_read_log_outlier_limit_names_column_and_row(frame):
    bad = frame.copy()
    bad.loc[77, "shape_velocity_1"] = 1e6
    with pytest.raises(GeogaitError, match=r"'shape_velocity_1' parameter of read_log must be plausible.*row 77"):
        read_log(bad, **COLUMNS)
    assert read_log(bad, outlier_limit=None, **COLUMNS).shape_velocity[77, 1] == 1e6
    with pytest.raises(GeogaitError, match="'outlier_limit' parameter of read_log"):
        read_log(frame, outlier_limit=-1, **COLUMNS)


def test_time_unit_converts_and_implausible_rates_are_reported(frame):
    reference = fit_log(read_log(frame, **COLUMNS))
    in_ms = frame.copy()
    in_ms["time"] *= 1000
    for name in ("shape_velocity_0", "shape_velocity_1", *BODY):
        in_ms[name] /= 1000
    with pytest.warns(GeogaitWarning, match=r"0.001 cycles per time unit .*pass time_unit='ms'"):
        fit_log(read_log(in_ms, **COLUMNS))
    log = read_log(in_ms, time_unit="ms", **COLUMNS)
    assert log.time_unit == "s" and np.allclose(log.time, frame["time"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        converted = fit_log(log)
    assert converted.held_out_gamma() == pytest.approx(reference.held_out_gamma(), abs=1e-9)
    in_ns = frame.assign(time=frame["time"] * 1e9)
    with pytest.raises(GeogaitError, match=r"1e-09 cycles per s.*time_unit='ns'"):
        fit_log(read_log(in_ns, time_unit="s", **COLUMNS))
    with pytest.raises(GeogaitError, match="'time_unit' parameter of read_log must be one of 's', 'ms'"):
        read_log(frame, time_unit="minutes", **COLUMNS)


def test_a_mapping_or_stream_config_that_is_not_utf8_is_bad_input_not_a_bug(tmp_path):
    from geogait.io import load_column_mapping
    from geogait.learn import load_stream_model

    for name, load in (("mapping.json", load_column_mapping), ("config.json", load_stream_model)):
        path = tmp_path / name
        path.write_bytes(b"\xff\xfe{}")
        with pytest.raises(GeogaitError, match=r"'path' parameter of .* must be a UTF-8 text file. .*byte 0xff"):
            load(path)
    mapping = str(tmp_path / "mapping.json")
    result = CliRunner().invoke(app, ["fit", mapping, "--mapping", mapping, "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and "bug" not in result.stderr


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_a_log_too_large_for_memory_is_refused_naming_the_most_rows(frame, tmp_path, monkeypatch, kind):
    """Issue 58: reading and fitting a log takes memory in proportion to its values; a log that would take more than
    4 GiB is refused (a CSV as soon as the rows read so far say so, a Parquet file from its metadata) with the most
    rows of its width that fit, and ``geogait fit`` ends in one error line."""
    import geogait._blocks as blocks
    import geogait.io._logs as logs

    path = tmp_path / f"log.{kind}"
    frame.to_csv(path, index=False) if kind == "csv" else frame.to_parquet(path)
    read_log(path, **COLUMNS)  # (as it is: fits)
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 100)
    monkeypatch.setattr(logs, "LOG_BYTES_PER_VALUE", 2**32 // (250 * frame.shape[1]))  # 250 rows fit
    with pytest.raises(GeogaitError, match=rf"at least \d+ rows of {frame.shape[1]} columns.*GiB.*at most 250 rows"):
        read_log(path, **COLUMNS)
    result = CliRunner().invoke(app, ["fit", str(path), "--out", str(tmp_path / "fit"),
                                      *(f"--{k.replace('_', '-')}={','.join(v) if isinstance(v, list) else v}"
                                        for k, v in COLUMNS.items())])
    assert result.exit_code == 1 and result.output.count("error:") == 1 and "at most 250 rows" in result.output
    assert not (tmp_path / "fit").exists()
