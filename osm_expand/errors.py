"""Errors that mean "the input is at fault" (exit code 2), not a bug."""
from __future__ import annotations


class InputError(Exception):
    """Unreadable, invalid or unusable input; the message is one line naming the file."""
