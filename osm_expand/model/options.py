"""Helpers for the frozen options dataclasses every stage takes."""
from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import MISSING
from typing import Any

from osm_expand.errors import InputError

__all__ = ["field_default", "is_real_number", "require_positive"]


def field_default(cls: type, name: str) -> Any:
    """The default of field ``name`` of the dataclass ``cls`` (its factory called), without making one.

    >>> from dataclasses import dataclass, field
    >>> @dataclass(frozen=True)
    ... class Options:
    ...     width: float = 3.5
    ...     lanes: tuple = field(default_factory=lambda: (1, 2))
    >>> field_default(Options, "width"), field_default(Options, "lanes")
    (3.5, (1, 2))
    """
    f = cls.__dataclass_fields__[name]  # type: ignore[attr-defined]  # cls is an options dataclass
    return f.default_factory() if f.default_factory is not MISSING else f.default


def require_positive(opts: object, names: Sequence[str]) -> None:
    """Raise :class:`~osm_expand.errors.InputError` (one line, exit 2 at the CLI) unless every field
    ``names`` of ``opts`` is positive: a zero spacing or radius would make an empty or endless lattice."""
    for name in names:
        value = getattr(opts, name)
        if not value > 0:
            raise InputError(f"{type(opts).__name__}.{name} must be positive, got {value}")


def is_real_number(value: object) -> bool:
    """A real number (Python's or numpy's), not a bool: ``True`` is an int to Python, not a number of metres
    or degrees to a user, and a history file's ``true`` must not read as 1."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)

