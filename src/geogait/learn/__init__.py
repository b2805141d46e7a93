"""Learning from robot data: a local gait model fitted to a log (phase, nominal gait, model, held-out Γ) and
predictions with it (``geogait fit`` / ``predict``), and learning from a live stream one sample at a time
(``geogait stream``); whether the data are inside the model class at all (``model_class_verdict``). Reading the
data is :mod:`geogait.io`."""

from ._fit import LogFit, LogPrediction, fit_log, predict_log
from ._learner import OnlineDifferentiator, StreamLearner, load_stream_model
from ._model_class import ModelClassVerdict, model_class_verdict, period_verdict, shape_amplitude
from ._streaming import run_stream

__all__ = [
    "LogFit",
    "LogPrediction",
    "ModelClassVerdict",
    "OnlineDifferentiator",
    "StreamLearner",
    "fit_log",
    "load_stream_model",
    "model_class_verdict",
    "period_verdict",
    "predict_log",
    "run_stream",
    "shape_amplitude",
]
