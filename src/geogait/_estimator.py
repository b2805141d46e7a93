"""The contract every geogait estimator follows (scikit-learn's, with persistence).

* Hyper-parameters are the keyword-only arguments of ``__init__``, stored unchanged as attributes:
  ``get_params`` / ``set_params`` / ``repr`` read the signature, so ``sklearn.base.clone`` works.
* Each class declares ``_parameter_constraints`` (one checker per hyper-parameter, the
  :func:`~geogait._validation.fail` template); :meth:`Estimator.validate` runs them all, and
  ``_check_param_combinations`` the rules that join several, before ``fit`` changes any state.
  ``set_params`` checks the new values before it sets any of them.
* Learned attributes end in ``_``; ``__sklearn_is_fitted__`` says whether ``_fitted_attribute``
  exists, and :func:`check_is_fitted` raises the one "not fitted yet" error.
* Persistence is ``get_state()`` → ``(metadata, arrays)`` (JSON metadata: format, version, class,
  hyper-parameters, plus ``_metadata()``; arrays from ``_state()``); ``save`` writes it atomically
  (no pickle) and ``load`` / :func:`estimator_from_state` rebuild through ``_set_state``.
"""

from __future__ import annotations

import contextlib
import inspect
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from ._files import read_state, write_state
from ._validation import GeogaitError, check_choice, check_float, check_int, check_magnitude, fail

__all__ = ["Boolean", "Estimator", "InstanceOf", "Integer", "Options", "Real", "check_is_fitted",
           "estimator_from_state", "read_estimator"]


# -- parameter constraints -----------------------------------------------------------------------
@dataclass(frozen=True)
class Real:
    """A finite float in an interval (closed unless ``*_open``); ``none`` also accepts ``None``."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    none: bool = False

    def __call__(self, value, name: str, owner: str) -> None:
        if value is None and self.none:
            return
        check_float(value, name, owner, low=self.low, high=self.high, low_open=self.low_open,
                    high_open=self.high_open)


@dataclass(frozen=True)
class Integer:
    """An int ``>= minimum``; ``none`` also accepts ``None``."""

    minimum: int | None = None
    none: bool = False

    def __call__(self, value, name: str, owner: str) -> None:
        if value is None and self.none:
            return
        check_int(value, name, owner, minimum=self.minimum)


@dataclass(frozen=True)
class Options:
    """One of a fixed set of values."""

    choices: tuple

    def __call__(self, value, name: str, owner: str) -> None:
        check_choice(value, name, owner, self.choices)


@dataclass(frozen=True)
class Boolean:
    """``True`` or ``False`` (NumPy booleans too)."""

    def __call__(self, value, name: str, owner: str) -> None:
        if not isinstance(value, bool | np.bool_):
            raise fail(name, owner, "a bool", value)


@dataclass(frozen=True)
class InstanceOf:
    """An instance of ``kind`` (``description`` names it in the message); ``None`` allowed by default."""

    kind: type | tuple
    description: str
    none: bool = True

    def __call__(self, value, name: str, owner: str) -> None:
        if value is None and self.none:
            return
        if not isinstance(value, self.kind):
            raise fail(name, owner, self.description + (" or None" if self.none else ""), value)


# -- the base --------------------------------------------------------------------------------------
class Estimator:
    """Parameter protocol, checks, fitted state and persistence shared by every estimator."""

    #: Checker per hyper-parameter name (see :class:`Real`, :class:`Integer`, ...).
    _parameter_constraints: ClassVar[dict] = {}
    #: The attribute whose presence means "fitted".
    _fitted_attribute: ClassVar[str] = "batch_shape_"
    #: File format name and the version written; ``_readable_versions`` every version read.
    _format: ClassVar[str | None] = None
    _format_version: ClassVar[int] = 1
    _readable_versions: ClassVar[tuple[int, ...] | None] = None
    #: Hyper-parameters kept in the arrays (``_state``) rather than the JSON metadata.
    _array_params: ClassVar[tuple[str, ...]] = ()
    _classes: ClassVar[dict[str, dict[str, type]]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls._format is not None and "__init__" in cls.__dict__:  # a concrete, saveable estimator
            Estimator._classes.setdefault(cls._format, {})[cls.__name__] = cls

    # -- hyper-parameters ----------------------------------------------------------------------
    @classmethod
    def _param_names(cls) -> list[str]:
        signature = inspect.signature(cls.__init__)
        return [p.name for p in signature.parameters.values() if p.kind == p.KEYWORD_ONLY]

    def get_params(self, deep: bool = True) -> dict:
        """Hyper-parameters, as given to ``__init__`` (with ``deep``, also those of nested estimators
        as ``name__parameter``)."""
        params = {name: getattr(self, name) for name in self._param_names()}
        if deep:
            for name, value in list(params.items()):
                if hasattr(value, "get_params") and not isinstance(value, type):
                    params.update({f"{name}__{k}": v for k, v in value.get_params(deep=True).items()})
        return params

    def set_params(self, **params):
        """Set hyper-parameters, each checked first (nothing changes if one is invalid); returns ``self``.

        Nested estimators' parameters are named ``name__parameter``. New values take effect at the
        next ``fit``.
        """
        owner = type(self).__name__
        names = self._param_names()
        own, nested = {}, {}
        for key, value in params.items():
            name, _, sub = key.partition("__")
            if name not in names:
                raise fail(name, owner, "one of " + ", ".join(names), name)
            if sub:
                nested.setdefault(name, {})[sub] = value
            else:
                own[name] = value
        for name, value in own.items():
            if name in self._parameter_constraints:
                self._parameter_constraints[name](value, name, owner)
        for name, values in nested.items():
            target = own.get(name, getattr(self, name))
            if not hasattr(target, "set_params"):
                raise fail(name, owner, "an estimator (for nested parameters " + ", ".join(values) + ")", target)
            target.set_params(**values)
        for name, value in own.items():
            setattr(self, name, value)
        return self

    def validate(self):
        """Check every hyper-parameter (raises naming the first bad one; changes nothing); returns ``self``."""
        owner = type(self).__name__
        for name, check in self._parameter_constraints.items():
            check(getattr(self, name), name, owner)
        self._check_param_combinations()
        return self

    def _check_param_combinations(self) -> None:
        """Rules that join several hyper-parameters (none by default)."""

    def __repr__(self):
        defaults = {p.name: p.default for p in inspect.signature(type(self).__init__).parameters.values()}
        changed = {k: v for k, v in self.get_params(deep=False).items() if not _same(v, defaults.get(k))}
        return f"{type(self).__name__}(" + ", ".join(f"{k}={v!r}" for k, v in changed.items()) + ")"

    @contextlib.contextmanager
    def _unchanged_on_error(self):
        """Restore every attribute when the block raises: a failed ``fit`` leaves the estimator as it was."""
        saved = dict(self.__dict__)
        try:
            yield
        except BaseException:
            self.__dict__.clear()
            self.__dict__.update(saved)
            raise

    # -- fitted state --------------------------------------------------------------------------
    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, self._fitted_attribute)

    def __sklearn_tags__(self):
        """scikit-learn's tags (read by scikit-learn ≥ 1.6, e.g. in ``sklearn.utils.validation.check_is_fitted``):
        no estimator type of its own (several arrays in, not ``X, y``), and fitted only where there is a ``fit``."""
        from sklearn.utils import Tags, TargetTags

        return Tags(estimator_type=None, target_tags=TargetTags(required=False),
                    requires_fit=callable(getattr(self, "fit", None)))

    def _check_is_fitted(self) -> None:
        check_is_fitted(self)

    # -- persistence ---------------------------------------------------------------------------
    def _metadata(self) -> dict:
        """Extra JSON metadata beside format, version, class and hyper-parameters."""
        return {}

    def _state(self) -> dict:
        """The arrays to save (every saveable class defines it)."""
        return {}

    def _set_state(self, state: dict, metadata: dict) -> None:
        """Restore from :meth:`_state`'s arrays and :meth:`get_state`'s metadata (every saveable class defines it)."""

    @classmethod
    def _upgrade_state(cls, state: dict, metadata: dict) -> dict:
        """Convert the arrays of an older format version (none to convert by default)."""
        return state

    @classmethod
    def _check_stored(cls, metadata: dict, state: dict) -> None:
        """Check the sizes the metadata claim against the stored arrays, before anything is allocated from
        them (raise ``ValueError`` naming the mismatch; nothing to check by default)."""

    @classmethod
    def can_save(cls) -> bool:
        """Whether a fitted instance can be saved (and an optimiser run with it checkpointed)."""
        return cls._format is not None

    def get_state(self) -> tuple[dict, dict]:
        """Learned state as ``(metadata, arrays)``: JSON-ready metadata and NumPy arrays.

        What :meth:`save` writes, and what :meth:`load` and checkpoints rebuild the estimator from.
        """
        self._check_is_fitted()
        if not self.can_save():
            raise GeogaitError(f"A {type(self).__name__} cannot be saved (it holds no learned state of its own).")
        params = {k: v for k, v in self.get_params(deep=False).items() if k not in self._array_params}
        metadata = {"format": self._format, "format_version": self._format_version, "class": type(self).__name__,
                    "params": params, **self._metadata()}
        return metadata, dict(self._state())

    def save(self, path) -> Path:
        """Write the fitted estimator to ``path`` (``.npz``: arrays + JSON metadata; no pickle), atomically.

        The file is written to a temporary name in the same folder and renamed over ``path``, so an
        interrupted save never leaves a truncated file behind; a state holding NaN or infinity is
        refused (:class:`~geogait.GeogaitError`) and an existing file is kept.
        """
        metadata, arrays = self.get_state()
        return write_state(Path(path), metadata, arrays, require_finite=True)

    @classmethod
    def load(cls, path):
        """Read an estimator written by :meth:`save`; checks format, version and class."""
        estimator = read_estimator(path, cls._format, cls._readable_versions or (cls._format_version,),
                                   kind=_kind(cls._format))
        if not isinstance(estimator, cls):
            raise GeogaitError(f"{path} holds a {type(estimator).__name__}, not a {cls.__name__}.")
        return estimator


def check_is_fitted(estimator) -> None:
    """Raise the standard error unless ``estimator`` is fitted (``__sklearn_is_fitted__``)."""
    if not estimator.__sklearn_is_fitted__():
        calls = " or ".join(f"'{name}'" for name in ("fit", "partial_fit") if callable(getattr(estimator, name, None)))
        raise GeogaitError(f"This {type(estimator).__name__} is not fitted yet. Call {calls} first.")


def estimator_from_state(metadata: dict, state: dict, file_format: str | None = None):
    """Rebuild an estimator from :meth:`Estimator.get_state` output (checks class and arrays)."""
    file_format = metadata.get("format") if file_format is None else file_format
    classes = Estimator._classes.get(file_format, {})
    if metadata.get("class") not in classes:
        raise GeogaitError(f"unknown {_kind(file_format)} class {metadata.get('class')!r}.")
    cls = classes[metadata["class"]]
    for name, value in state.items():  # what save guarantees, checked on the way back in
        value = np.asarray(value)
        if value.dtype.kind in "cOV" or (value.dtype.kind == "f" and not np.all(np.isfinite(value))):
            what = "NaN or infinity" if value.dtype.kind == "f" else f"{value.dtype} values"
            raise GeogaitError(f"the {_kind(file_format)} array {name!r} holds {what}; geogait never saves such a "
                               "state (the file was changed or corrupted).")
        if value.dtype.kind == "f":  # (nor values beyond the bound every input is held to)
            check_magnitude(value, name, f"the saved {_kind(file_format)}")
    if not isinstance(metadata.get("params"), dict):
        raise GeogaitError(f"inconsistent {_kind(file_format)} state (corrupt file): no hyper-parameters.")
    try:
        cls._check_stored(metadata, state)
        estimator = cls(**metadata["params"])
        estimator._set_state(cls._upgrade_state(state, metadata), metadata)
    except (KeyError, ValueError, IndexError, TypeError) as error:
        raise GeogaitError(f"inconsistent {_kind(file_format)} state (corrupt file): {error}") from None
    return estimator


def read_estimator(path, file_format: str, versions: tuple[int, ...], kind: str):
    """Read a file written by :meth:`Estimator.save` (format ``file_format``, one of ``versions``)."""
    metadata, state = read_state(path, kind, file_format, versions)
    try:
        return estimator_from_state(metadata, state, file_format)
    except GeogaitError as error:
        raise GeogaitError(f"{path}: {error}") from None


def _kind(file_format: str | None) -> str:
    return (file_format or "estimator").removeprefix("geogait-")


def _same(a, b) -> bool:
    """Whether a hyper-parameter equals its default (for a short ``repr``)."""
    if a is b:
        return True
    try:
        return bool(np.all(a == b)) and type(a) is type(b)
    except (TypeError, ValueError):
        return False
