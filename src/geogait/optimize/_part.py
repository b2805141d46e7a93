"""The base of every optimiser part: an estimator of hyper-parameters only, described as JSON values."""

from __future__ import annotations

import numpy as np

from .._estimator import Estimator

__all__ = ["Part", "describe_params"]


def describe_params(value):
    """JSON values of a parameter: a part (or model) as its class name and parameters, arrays as lists."""
    if isinstance(value, Estimator):
        return {"class": type(value).__name__,
                "params": {k: describe_params(v) for k, v in value.get_params(deep=False).items() if k != "gait"}}
    if isinstance(value, tuple | list):
        return [describe_params(v) for v in value]
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    return value


class Part(Estimator):
    """An optimiser part: hyper-parameters only; its run state is made by the loop from them."""

    _fitted_attribute = "_never_fitted_"

    def describe(self) -> dict:
        """The part as JSON values: its class name and parameters."""
        return describe_params(self)

    def __eq__(self, other) -> bool:
        """Parts are equal when they are of one class with equal parameters."""
        return type(other) is type(self) and describe_params(other) == describe_params(self)

    __hash__ = None  # (mutable through set_params)
