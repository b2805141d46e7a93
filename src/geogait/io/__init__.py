"""Robot data in and out: CSV/Parquet/DataFrame logs with their column mappings and body velocity from
poses, and the records of a live stream (its readers, samples and output lines). Learning from them —
fitting a model to a log, predicting with it, learning from a live stream — is :mod:`geogait.learn` (its
names stay importable from here)."""

from ._logs import (
    ColumnMapping,
    Log,
    load_column_mapping,
    mapping_to_json,
    read_log,
    read_log_for_prediction,
    resolve_mapping,
)
from ._records import (
    PREDICTION_COLUMNS,
    STREAM_FORMATS,
    CsvReader,
    JsonLinesReader,
    StreamOutput,
    StreamSample,
    StreamSummary,
)

__all__ = [
    "PREDICTION_COLUMNS",
    "STREAM_FORMATS",
    "ColumnMapping",
    "CsvReader",
    "JsonLinesReader",
    "Log",
    "StreamOutput",
    "StreamSample",
    "StreamSummary",
    "load_column_mapping",
    "mapping_to_json",
    "read_log",
    "read_log_for_prediction",
    "resolve_mapping",
]

#: Learning names that lived here before :mod:`geogait.learn` (kept importable: ``from geogait.io import fit_log``).
_LEARNING = ("LogFit", "LogPrediction", "OnlineDifferentiator", "StreamLearner", "fit_log", "load_stream_model",
             "predict_log", "run_stream")


def __getattr__(name):
    if name in _LEARNING:  # imported on first use: geogait.learn reads its data through this package
        from .. import learn

        return getattr(learn, name)
    raise AttributeError(f"module 'geogait.io' has no attribute {name!r}")
