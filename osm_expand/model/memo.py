"""Values made once for the very same objects of the model: the model's identity cache (issue 22), and
once for inputs of the very same content (:class:`ContentMemo`).

The year loop makes a new City every year, but most of what it holds is
shared with last year's, object for object: the water, the land, the
buildings until the build-out adds some, the blocks until the streets
change. What is derived from those objects (their union, their polygons
and tree, the rings a raster is drawn from) is made once per object and
asked for again many times a year. Objects of the model never change once
made, so :class:`IdentityMemo` keys by the objects' identity, with no
hashing of the content; it holds its sources (strong references), so a
dead object's address can never be taken for it while the value is kept.

:class:`ContentMemo` is for values made from objects that are new but may
hold the same coordinates: it keys by a digest of the content (the WKB of
geometries, the bytes, dtype and shape of numeric arrays). Each memo keeps
only its last few entries, so what the years left behind is let go.
"""
from __future__ import annotations

import hashlib
from collections.abc import Callable, Hashable, Sequence
from dataclasses import replace
from typing import Any, TypeVar

import numpy as np
import shapely

_D = TypeVar("_D")


def replace_keeping(obj: _D, cached: tuple[str, ...], **changes: Any) -> _D:
    """``dataclasses.replace(obj, **changes)`` with the values of ``obj``'s cached properties ``cached`` that
    it has measured already carried over, not measured again: for changes that leave what they depend on as it
    was (the caller's to know). A frozen dataclass's replacement is a new object, so its ``cached_property`` values
    would be measured again: a lot's frontage 7,000 times in Campo Grande's 30 years, a placed lot's polygon
    every year."""
    out = replace(obj, **changes)  # type: ignore[type-var]
    for name in cached:
        if name in obj.__dict__:
            out.__dict__[name] = obj.__dict__[name]
    return out


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


class ContentMemo:
    """``make()`` once for inputs of the very same content: geometries compared by their WKB (every
    coordinate to the bit, in order) and plain values by ``repr``.

    For a value made afresh from objects that are new each year but may hold
    what last year's held: a year whose district failed tries the same sites
    again on a town whose streets a major road or the build-out changed
    elsewhere, and the region around a site (a union of the land near it, the
    free land cut from a disc) is then the same. A GEOS operation is a pure
    function of its inputs' coordinates and their order, so the value kept is
    the very value ``make()`` would give, to the bit; only the hashing of the
    inputs is paid again (a few ms where a union took tens).

    Parameters
    ----------
    kept : int
        Entries kept, the most recently used; the oldest goes first.
    """

    def __init__(self, kept: int = 32):
        self.kept = kept
        self._store: dict[bytes, Any] = {}

    @staticmethod
    def key(*parts: Any) -> bytes:
        """A digest of ``parts``: each a geometry, a sequence or 1-d array of geometries, a numeric array, or a
        plain value (bool, int, float, str, bytes, None); anything else is refused (its ``repr`` need not
        show all of it).

        A numeric array is told by its dtype before its elements are looked at, and hashed with its dtype
        and shape: an empty one (``np.empty((0, 3))``) is not an empty sequence of geometries (``[]``),
        which an element test alone would take it for. An object array must be 1-d (a 0-d one has no
        elements to test)."""
        h = hashlib.blake2b(digest_size=32)
        for part in parts:
            if isinstance(part, np.ndarray) and part.dtype != object:
                h.update(b"A" + repr((part.dtype.str, part.shape)).encode() + b";")
                h.update(np.ascontiguousarray(part).tobytes())
                continue
            if isinstance(part, np.ndarray) and part.ndim != 1:
                raise TypeError(f"ContentMemo.key: an object array must be 1-d, got shape {part.shape}")
            if isinstance(part, shapely.Geometry):
                part = [part]
            if isinstance(part, (list, tuple, np.ndarray)) and all(isinstance(g, shapely.Geometry) for g in part):
                wkb = shapely.to_wkb(np.asarray(part, dtype=object)).tolist() if len(part) else []
                h.update(b"G%d;" % len(wkb))
                for w in wkb:
                    h.update(b"%d;" % len(w))
                    h.update(w)
            elif isinstance(part, (bool, int, float, str, bytes, type(None))):
                h.update(b"V" + repr(part).encode() + b";")
            else:
                raise TypeError(f"ContentMemo.key: cannot hash a {type(part).__name__} by its content")
        return h.digest()

    def get(self, key: bytes, make: Callable[..., Any], *args: Any) -> Any:
        """The value of ``make(*args)`` for ``key`` (:meth:`key` of whatever the value depends on), made on
        the first call only."""
        if key in self._store:
            value = self._store[key] = self._store.pop(key)  # the most recently used last
            return value
        value = make(*args)
        while len(self._store) >= self.kept:
            self._store.pop(next(iter(self._store)))
        self._store[key] = value
        return value

    def clear(self) -> None:
        self._store.clear()

    def __len__(self) -> int:
        return len(self._store)


class EachMemo:
    """A value per object (or per tuple of objects), compared by identity, made once: for an operation a
    year applies to every one of many objects, most of them last year's very objects (the town's block
    polygons, the buildings' footprints), so that only the new ones cost the operation.

    A GEOS operation on one geometry (a buffer, an intersection's area) is a pure function of it, so the
    value kept is the very value the operation would give again, to the bit. Like :class:`IdentityMemo` it
    holds its objects (their ids are not reused while a value is kept). What is kept lives two generations of
    ``span`` calls: a value not asked for in the last ``span`` to ``2 · span`` calls goes, so a year's several
    askers (each block selection of a year) share it and what the years left behind is let go.
    """

    def __init__(self, span: int = 8):
        self.span = span
        self._calls = 0
        self._new: dict[tuple[int, ...], tuple[tuple[Any, ...], Any]] = {}
        self._old: dict[tuple[int, ...], tuple[tuple[Any, ...], Any]] = {}

    def get(self, keys: Sequence[tuple[Any, ...]], make: Callable[[list[int]], Sequence[Any]]) -> list[Any]:
        """The value of each key (a tuple of objects), ``make(missing)`` giving those of the keys at positions
        ``missing`` not known yet (in that order; called once, and only when one is missing)."""
        self._calls += 1
        if self._calls % self.span == 0:
            self._old, self._new = self._new, {}
        out: list[Any] = [None] * len(keys)
        missing = []
        for i, key in enumerate(keys):
            ids = tuple(map(id, key))
            hit = self._new.get(ids) or self._old.get(ids)
            if hit is not None and all(a is b for a, b in zip(hit[0], key)):
                self._new[ids] = hit
                out[i] = hit[1]
            else:
                missing.append(i)
        if missing:
            for i, value in zip(missing, make(missing)):
                self._new[tuple(map(id, keys[i]))] = (keys[i], value)
                out[i] = value
        return out

    def __len__(self) -> int:
        return len(self._new.keys() | self._old.keys())
