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
#: The major classes with their ``_link`` ramps: a segment of these is a major road to the engine's
#: traffic, lattice and widths (003's major roads, on which trade routes run).
MAJOR_AND_LINKS: frozenset[str] = frozenset({*MAJOR, *(f"{c}_link" for c in MAJOR)})
#: The classes a trade route may run on (003: "entirely over major roads"; here tertiary too), with their
#: ``_link`` ramps (:mod:`osm_expand.engine.traffic.simulation`).
TRADE: frozenset[str] = frozenset({*MAJOR_AND_LINKS, "tertiary", "tertiary_link"})
#: Motorways and trunk roads with their ramps: they have no junctions for a new street to meet, so they
#: cut the land (a district's land lies on one side of them, :mod:`osm_expand.sites`), and no piece of
#: them is ever copied into a district (:mod:`synth.patches`).
CORRIDORS: frozenset[str] = frozenset({"motorway", "motorway_link", "trunk", "trunk_link"})
#: Town street classes from most to least important, below the corridors: a grown street's class may
#: move down this ladder to one the town has (:mod:`synth.colonisation_pattern`).
CLASS_LADDER: tuple[str, ...] = ("primary", "secondary", "tertiary", "unclassified", "residential", "living_street")
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
