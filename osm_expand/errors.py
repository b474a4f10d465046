"""Errors that mean "the input is at fault" (exit code 2), not a bug.

One base, :class:`InputError`, and a named subclass for each kind of
failure, as osmnx's ``_errors.py`` and shapely's ``errors.py`` do: a caller
that cares which input was wrong catches the subclass, one that does not
catches :class:`InputError` (which every raise site used before the named
ones existed, so old ``except InputError`` code keeps working). The command
line prints any of them as one line naming the file and the problem and
exits 2 (:mod:`osm_expand.cli`); the message is the same whatever the class.

The kinds:

- :class:`UnreadableInputError`: an input file that cannot be read or is not
  what it claims (missing, empty, not OSM, broken coordinates, a bad
  GeoJSON or urbanenvironment file read back, a bad towns table).
- :class:`OptionError`: an option's value out of range or contradicting
  another option (``--area``, ``--at``, ``--bbox``, a growth pattern's
  name, an enum value).
- :class:`HistoryError`: a history (``--history NAME|FILE``) that cannot be
  found, read or understood.
- :class:`NoRoomError`: no site of the map holds a district of the asked
  size.
- :class:`OutputError`: an output that cannot be written (a folder missing
  or read-only, the input itself named as the output, a full disk).
"""
from __future__ import annotations

__all__ = ["HistoryError", "InputError", "NoRoomError", "OptionError", "OutputError", "UnreadableInputError"]


class InputError(Exception):
    """Unreadable, invalid or unusable input; the message is one line naming the file (the base of all below)."""


class UnreadableInputError(InputError):
    """An input file that cannot be read, or whose content is not what its name says."""


class OptionError(InputError):
    """An option's value that is out of range, malformed, or contradicts another option."""


class HistoryError(InputError):
    """A history that cannot be found, read, or understood (unknown name, bad TOML, a bad key or value)."""


class NoRoomError(InputError):
    """No site of the map holds a district of the asked size (the message says what size would fit)."""


class OutputError(InputError):
    """An output that cannot be written: a missing or read-only folder, the input itself, a full disk."""
