"""Which land is not free to build on, from what the map says.

Unbuildable (a documented default, configurable with
:class:`LandOptions` or ``--unbuildable``): cemeteries, railway land,
military land, airports (``aeroway=*``), parks and nature reserves,
landfills and quarries, and every existing building (with a small margin,
so no new street passes through one, whether it stands in a block or alone
in a field). Water and sea are kept apart in the city; the blocks of the
town are added by :attr:`osm_expand.model.City.occupied`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.errors import InputError
from osm_expand.model import City

#: ``key=value`` (or ``key=*`` for any value) of mapped areas that are not buildable.
UNBUILDABLE = ("landuse=cemetery", "amenity=grave_yard", "landuse=railway", "landuse=military", "military=*",
               "aeroway=*", "leisure=park", "leisure=nature_reserve", "landuse=landfill", "landuse=quarry")


@dataclass(frozen=True)
class LandOptions:
    #: Mapped areas that are not buildable, as ``key=value`` or ``key=*``.
    unbuildable: tuple[str, ...] = UNBUILDABLE
    #: Metres kept clear around existing buildings (their minimum rectangles, as the XML draws them).
    building_margin: float = 2.0

    def __post_init__(self) -> None:
        for rule in self.unbuildable:
            key, sep, value = rule.partition("=")
            if not sep or not key or not value:
                raise InputError(f"unbuildable: {rule!r} is not KEY=VALUE or KEY=*")


def parse_rules(text: str) -> tuple[str, ...]:
    """``--unbuildable`` text: comma-separated ``key=value`` rules; an empty string means none."""
    rules = tuple(r.strip() for r in text.split(",") if r.strip())
    LandOptions(unbuildable=rules)  # validates
    return rules


def matches(key: str, value: str, rules: tuple[str, ...]) -> bool:
    """Does a mapped area ``key=value`` fall under one of ``rules``?"""
    return any(r == f"{key}=*" or r == f"{key}={value}" for r in rules)


def unbuildable(city: City, options: LandOptions | None = None) -> shapely.Geometry:
    """The land nothing new may take (metres), water aside."""
    opts = options or LandOptions()
    parts = [a.polygon for a in city.areas if matches(a.key, a.value, opts.unbuildable)]
    outlines = building_outlines(city)
    if len(outlines):
        parts.extend(shapely.buffer(outlines, opts.building_margin, join_style="mitre").tolist())
    return shapely.union_all(parts) if parts else shapely.GeometryCollection()


def building_outlines(city: City) -> np.ndarray:
    """The minimum rotated rectangle of every building footprint (what the XML draws), as an array."""
    if not city.buildings:
        return np.empty(0, dtype=object)
    polys = np.array([shapely.Polygon(b.ring) for b in city.buildings], dtype=object)
    return shapely.oriented_envelope(polys)
