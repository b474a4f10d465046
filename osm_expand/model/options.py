"""Helpers for the frozen options dataclasses every stage takes."""
from __future__ import annotations

from dataclasses import MISSING
from typing import Any

__all__ = ["field_default"]


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
