"""Fuzz tests (issue 11) of reading logs: read_log gives a finite log or names the field; column mappings are
checked (see tests/_fuzz.py)."""

import json

import numpy as np
import pytest
from _fuzz import FUZZ, WILD, names_a_field
from _fuzz import run as run
from _reference import BODY, COLUMNS
from hypothesis import given
from hypothesis import strategies as st

from geogait import GeogaitError
from geogait.io import read_log


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
