"""What the experiments' configs share: a small variant, validation, and the trial function's options."""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Self

from .._validation import check_int

__all__ = ["SweepConfig", "trial_function_options"]


class SweepConfig:
    """What the experiments' configs share: a small variant (:meth:`quick`) and :meth:`validate`.

    A config (a frozen dataclass) sets ``QUICK`` and checks its own fields in ``_check_fields()``; every config
    has the fields ``seed`` and ``chunk_size`` of its sweep.
    """

    #: The fields :meth:`quick` changes (each experiment's own).
    QUICK: ClassVar[dict] = {}

    @classmethod
    def quick(cls, **changes) -> Self:
        """A small configuration that runs in seconds: ``QUICK``, then ``changes``."""
        return cls(**(cls.QUICK | changes))

    def validate(self) -> Self:
        """Check every field; returns ``self``.

        Raises
        ------
        GeogaitError
            Naming the bad field and what was expected.
        """
        self._check_fields()
        owner = type(self).__name__
        check_int(self.seed, "seed", owner, minimum=0)
        check_int(self.chunk_size, "chunk_size", owner, minimum=1)
        return self

    def _check_fields(self) -> None:
        """Check the configuration's own fields (each experiment's config defines them)."""
        raise NotImplementedError(f"{type(self).__name__} checks no fields: a config implements _check_fields")


def trial_function_options(config) -> dict:
    """The keyword arguments of an experiment's trial function: the fields of ``config`` but those that say how
    the sweep runs (``n_trials``, ``seed``, ``chunk_size``)."""
    skip = {"n_trials", "seed", "chunk_size"}
    return {k: v for k, v in dataclasses.asdict(config).items() if k not in skip}
