"""Values made once for the very same objects of the model: the model's identity cache (issue 22).

The year loop makes a new City every year, but most of what it holds is
shared with last year's, object for object: the water, the land, the
buildings until the build-out adds some, the blocks until the streets
change. What is derived from those objects (their union, their polygons
and tree, the rings a raster is drawn from) is made once per object and
asked for again many times a year. Objects of the model never change once
made, so the object's identity is the key; no hashing of the content.

The sources are held by the memo (strong references), so a dead object's
address can never be taken for it while the value is kept; each memo keeps
only its last few entries, so what the years left behind is let go.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any


class IdentityMemo:
    """``make()`` once for the very same ``sources`` (compared by identity) and ``tag``.

    Parameters
    ----------
    kept : int
        Entries kept, the most recently used; the oldest goes first. A few
        are enough: a year asks for this year's objects and perhaps last year's.
    """

    def __init__(self, kept: int = 8):
        self.kept = kept
        self._store: dict[tuple[tuple[int, ...], Hashable], tuple[tuple[Any, ...], Any]] = {}

    def get(self, sources: tuple[Any, ...], tag: Hashable, make: Callable[[], Any]) -> Any:
        """The value of ``make()`` for ``sources`` and ``tag``, made on the first call only."""
        key = (tuple(id(s) for s in sources), tag)
        hit = self._store.get(key)
        if hit is not None and all(a is b for a, b in zip(hit[0], sources)):
            self._store[key] = self._store.pop(key)  # the most recently used last
            return hit[1]
        value = make()
        while len(self._store) >= self.kept:
            self._store.pop(next(iter(self._store)))
        self._store[key] = (sources, value)  # keeps the sources alive, so their ids are not reused
        return value

    def clear(self) -> None:
        self._store.clear()

    def __len__(self) -> int:
        return len(self._store)
