"""Choices as enums, parsed in one place: a bad value is one line listing the valid ones.

As shapely's ``ParamEnum.get_value`` checks its choices (``_enum.py``), every
string choice of the model, the stages and the history file (a street's
status, a preview's colouring, a street pattern's angle space, a time
function's interpolation, ...) is parsed by :func:`parse_enum`, so the
message reads the same everywhere.
"""
from __future__ import annotations

from enum import Enum
from typing import Any, TypeVar

from osm_expand.errors import InputError, OptionError

__all__ = ["parse_enum"]

E = TypeVar("E", bound=Enum)


def parse_enum(kind: type[E], value: Any, what: str, *, error: type[InputError] = OptionError) -> E:
    """The member of ``kind`` whose value is ``value`` (a member itself is returned as it is).

    Parameters
    ----------
    kind : Enum subclass
        The choices (a ``StrEnum`` for the text choices of files and options).
    value : str or member
        What was given.
    what : str
        What the value is, as the message names it (an option or a key path).
    error : InputError subclass
        Raised for a value that is none of the choices (default :class:`~osm_expand.errors.OptionError`).

    Returns
    -------
    member of ``kind``

    Raises
    ------
    error
        ``"{what}: {value!r} is not one of {valid}"``, the valid values in their declared order.

    Examples
    --------
    >>> from enum import StrEnum
    >>> class Side(StrEnum):
    ...     LEFT = "left"
    ...     RIGHT = "right"
    >>> parse_enum(Side, "left", "side")
    <Side.LEFT: 'left'>
    >>> parse_enum(Side, "up", "side")
    Traceback (most recent call last):
    ...
    osm_expand.errors.OptionError: side: 'up' is not one of left, right
    """
    try:
        return kind(value)
    except ValueError:
        valid = ", ".join(str(m.value) for m in kind)
        raise error(f"{what}: {value!r} is not one of {valid}") from None
