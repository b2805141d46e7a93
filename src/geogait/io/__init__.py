"""Robot logs and streams in: CSV/Parquet/DataFrame ingestion, body velocity from poses, column
mappings; fitting a model to a log, predicting with it; learning from a live stream."""

from ._fit import (
    LogFit,
    LogPrediction,
    fit_log,
    mapping_to_json,
    predict_log,
    read_log_for_prediction,
    resolve_mapping,
)
from ._learner import OnlineDifferentiator, StreamLearner, load_stream_model
from ._logs import ColumnMapping, Log, load_column_mapping, read_log
from ._records import CsvReader, JsonLinesReader, StreamOutput, StreamSample, StreamSummary
from ._streaming import run_stream

__all__ = [
    "ColumnMapping",
    "CsvReader",
    "JsonLinesReader",
    "Log",
    "LogFit",
    "LogPrediction",
    "OnlineDifferentiator",
    "StreamLearner",
    "StreamOutput",
    "StreamSample",
    "StreamSummary",
    "fit_log",
    "load_column_mapping",
    "load_stream_model",
    "mapping_to_json",
    "predict_log",
    "read_log",
    "read_log_for_prediction",
    "resolve_mapping",
    "run_stream",
]
