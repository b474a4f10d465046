"""Which OSM ``highway=*`` values count as streets, and how important each is.

The default set is the drivable public network. ``service`` roads (car parks,
driveways) and paths are opt-in: they multiply the junction count without
shaping the town.
"""
from __future__ import annotations

DRIVABLE: frozenset[str] = frozenset({
    "motorway", "trunk", "primary", "secondary", "tertiary", "unclassified",
    "residential", "living_street", "road",
    "motorway_link", "trunk_link", "primary_link", "secondary_link", "tertiary_link",
})
#: The major road classes: a street of these is a major road as mapped (roads keep it when reused,
#: snapshots draw it thick); their ``_link`` ramps are not in it.
MAJOR: tuple[str, ...] = ("motorway", "trunk", "primary", "secondary")
SERVICE: frozenset[str] = frozenset({"service"})
PATHS: frozenset[str] = frozenset({
    "footway", "path", "track", "pedestrian", "cycleway", "bridleway", "steps", "busway",
})

_RANK = {
    "motorway": 0, "trunk": 1, "primary": 2, "secondary": 3, "tertiary": 4,
    "unclassified": 5, "residential": 6, "living_street": 7, "road": 7,
    "service": 8, "busway": 8,
}


def highway_set(service: bool = False, paths: bool = False) -> frozenset[str]:
    """The highway values kept by ingest for the given opt-ins."""
    kept = set(DRIVABLE)
    if service:
        kept |= SERVICE
    if paths:
        kept |= PATHS
    return frozenset(kept)


def rank(highway: str) -> float:
    """Smaller is more important; a link ranks just below its road."""
    if highway.endswith("_link"):
        return _RANK.get(highway[:-5], 9) + 0.5
    return _RANK.get(highway, 9)
