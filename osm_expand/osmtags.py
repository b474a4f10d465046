"""Reading OSM tags into typed values: numbers with units, a street's attributes.

Its own module because two readers need it: :mod:`osm_expand.ingest` (the
OSM file) and :mod:`osm_expand.readback` (an osm-expand output read back,
whose streets carry the same tags); before, readback imported ingest's
private helper while ingest imported readback, a circle.
"""
from __future__ import annotations

import math
import re

__all__ = ["number", "street_attrs"]


def street_attrs(way_id: int, tags) -> dict:
    """The typed :class:`Street` fields of a way's tags (and the tags themselves)."""
    layer = number(tags.get("layer"))
    return {
        "highway": tags.get("highway"),
        "name": tags.get("name"),
        "layer": int(layer) if layer is not None and abs(layer) < 10 else 0,
        "bridge": tags.get("bridge", "no") not in ("no", "false", "0"),
        "tunnel": tags.get("tunnel", "no") not in ("no", "false", "0"),
        "junction": tags.get("junction"),
        "lanes": number(tags.get("lanes")),
        "width": number(tags.get("width")),
        "osm_ids": (way_id,),
        "tags": tuple(dict(tags).items()),
    }


_NUMBER = re.compile(r"^\s*(-?\d+(?:[.,]\d+)?)\s*(m|meters?|metres?|ft|')?\s*$", re.IGNORECASE)


def number(text: str | None) -> float | None:
    """Parse OSM numeric tags such as ``12``, ``12.5 m`` or ``40'`` (metres); None if unusable.

    >>> number("12.5 m"), number("40'"), number("3;4"), number("wide")
    (12.5, 12.192, 3.0, None)
    """
    if not text:
        return None
    m = _NUMBER.match(text.split(";")[0])
    if not m:
        return None
    value = float(m.group(1).replace(",", "."))
    if m.group(2) and m.group(2).lower() in ("ft", "'"):
        value *= 0.3048
    return value if math.isfinite(value) else None
