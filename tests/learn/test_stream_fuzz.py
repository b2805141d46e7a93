"""Fuzz tests (issue 11) of the stream protocol: whatever the lines, the stream learner never saves garbage (see
tests/_fuzz.py)."""

import json
import math

import pytest
from _fuzz import FUZZ, WILD, assert_finite_model
from _fuzz import fitted as fitted
from _fuzz import run as run
from _reference import Sink as _Sink
from _reference import strict_json as strict
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.learn import StreamLearner, run_stream
from geogait.models import load_model

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
