"""The engine's planarity safety net: new streets that touch another street away from a shared node.

Every growth pattern and the joining step keep their streets planar with
exact predicates, yet two streets grown in one year can meet in ways neither
check saw: two gap-closing streets laid along the same line a hair apart
(parallel within 0.1 mm, so GEOS finds no intersection, while the
coordinates written to the millimetre overlap), or a new street that runs back along an
existing one from a node they share. This module finds such pairs with a
tolerance and says which street of each pair goes. It judges the streets the
engine grows each year and, before the engine, the district that
:func:`osm_expand.pipeline.expand` grows and joins (Monaco, seed 7: an end of a
district street 1 mm from another, unjudged while the net saw only the years).

Segments are judged the way the exported file will be read: coordinates
to the millimetre, a touch is fine only at an end both segments share, and
a collinear overlap is never a junction.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model import City, Origin
from osm_expand.model.segments import SegmentTable

#: Decimals of a metre the XML writes coordinates with (:mod:`osm_expand.export.urban`): segments
#: are judged as the file will hold them, so two streets a hair apart that the written
#: millimetres make overlap are caught, and two nodes a millimetre apart stay two nodes.
DECIMALS = 3
#: m: a touch closer than this to a node both segments end at is that node (the rounding of both
#: coordinates moves a point by under a millimetre).
NODE_TOLERANCE = 0.01


def touching_pairs(city: City, probe: np.ndarray) -> np.ndarray:
    """Street index pairs ``(k, m)``, ``k`` a probed street, that touch away from a node they share.

    Parameters
    ----------
    city : City
    probe : (S,) bool
        Streets to test (against every street).

    Returns
    -------
    (P, 2) int64
        Unique street pairs on the same layer, ``k`` probed; a pair of two probed streets appears
        once. ``k == m`` when a street touches itself.
    """
    net = city.network
    table = SegmentTable.from_city(city)
    if not len(table) or not probe.any():
        return np.zeros((0, 2), dtype=np.int64)
    owner, uv = table.street, table.uv
    ends = np.round(net.xy, DECIMALS)[uv]  # (E, 2, 2)
    lines = shapely.linestrings(ends)
    mine = np.flatnonzero(probe[owner])
    if not len(mine):
        return np.zeros((0, 2), dtype=np.int64)
    # only segments whose box meets the probed segments' box can touch them: the tree holds those
    # (a year's new streets are one district; the town's 50,000 segments were treed every year)
    lo, hi = ends[mine].min(axis=(0, 1)), ends[mine].max(axis=(0, 1))
    near = np.flatnonzero((ends.min(axis=1) <= hi).all(axis=1) & (ends.max(axis=1) >= lo).all(axis=1))
    left, right = shapely.STRtree(lines[near]).query(lines[mine], predicate="intersects")
    left, right = mine[left], near[right]
    a, b = owner[left], owner[right]
    layers: dict = {}
    layer = np.array([layers.setdefault(s.layer_key, len(layers)) for s in net.streets], dtype=np.int64)
    # each pair once: a pair of two probed streets (or two segments of one street) is met from both sides
    keep = (left != right) & (layer[a] == layer[b]) & ~(probe[b] & (b < a)) & ~((a == b) & (right < left))
    left, right, a, b = left[keep], right[keep], a[keep], b[keep]
    bad = _touching_away_from_shared_ends(lines[left], lines[right], ends[left], ends[right])
    pairs = np.column_stack([a[bad], b[bad]])
    return np.unique(pairs, axis=0) if len(pairs) else pairs.reshape(0, 2)


def _touching_away_from_shared_ends(s: np.ndarray, t: np.ndarray, s_ends: np.ndarray,
                                    t_ends: np.ndarray) -> np.ndarray:
    """For intersecting segment pairs: is any touch not an end both share? An overlap always is."""
    touch = shapely.intersection(s, t)
    kind = shapely.get_type_id(touch)
    bad = ~np.isin(kind, (0, 4))  # a line (collinear overlap) or anything but points
    pts, which = shapely.get_coordinates(touch, return_index=True)
    point_pairs = np.flatnonzero(~bad)
    if len(pts):
        near_s = np.hypot(*(s_ends[which] - pts[:, None, :]).transpose(2, 0, 1)).min(axis=1)
        near_t = np.hypot(*(t_ends[which] - pts[:, None, :]).transpose(2, 0, 1)).min(axis=1)
        shared = (near_s < NODE_TOLERANCE) & (near_t < NODE_TOLERANCE)
        off = np.zeros(len(s), dtype=bool)
        np.logical_or.at(off, which, ~shared)
        bad[point_pairs] = off[point_pairs]
    return bad


def streets_to_drop(city: City, pairs: np.ndarray, new: np.ndarray) -> set[int]:
    """Which street of each touching pair goes: of two new ones the later; a new one before an old one.

    The town as mapped is never dropped. A new major road (``origin = engine`` at hierarchy 0)
    outranks a new minor street: of a road and a minor street the minor one goes, even an old
    one the engine built, so that a trade route keeps its road.
    """
    streets = city.network.streets
    gone: set[int] = set()
    for k, m in pairs.tolist():
        if k in gone or m in gone:
            continue
        gone.add(_loser(streets, k, m, new))
    return gone


def _loser(streets, k: int, m: int, new: np.ndarray) -> int:
    road_k, road_m = _is_major(streets[k]), _is_major(streets[m])
    if road_k != road_m and streets[k].origin != Origin.SOURCE and streets[m].origin != Origin.SOURCE:
        return m if road_k else k
    if new[k] and new[m]:
        return max(k, m)
    return k if new[k] else m


def _is_major(street) -> bool:
    return street.origin == Origin.ENGINE and street.hierarchy == 0


def without_touching(city: City, known: set[int]) -> tuple[City, int]:
    """The city without the new streets (ids not in ``known``) that touch a street away from a node.

    Returns the city and how many streets went. Dropping a street can only remove touches, so one
    pass leaves the city planar with respect to everything new.
    """
    net = city.network
    new = np.array([s.id not in known for s in net.streets], dtype=bool)
    pairs = touching_pairs(city, new)
    if not len(pairs):
        return city, 0
    gone = streets_to_drop(city, pairs, new)
    kept = tuple(s for k, s in enumerate(net.streets) if k not in gone)
    return city.replace(network=net.replace(streets=kept)), len(gone)
