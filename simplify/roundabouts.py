"""Pass 5 (004 §4.2.3): collapse roundabouts to a single junction.

A roundabout is a connected group of ``junction=roundabout|circular`` streets
up to ``roundabout_max_diameter``, or an untagged closed street up to
``loop_max_diameter`` (loops are more reliable than tags, and car-park loops
go the same way). Its nodes are replaced by its centroid, so approaches now
end there; the duplicates and small loops this leaves are cleaned by the
overlap pass that follows.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.components import UnionFind
from osm_expand.model.topology import append_nodes, replace_nodes
from simplify.options import SimplifyOptions

ROUNDABOUT_TAGS = frozenset({"roundabout", "circular"})


def collapse_roundabouts(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, int]:
    """Returns the network and the number of roundabouts collapsed."""
    groups = [g for g in _tagged_groups(net.streets) if _diameter(net, g) <= opts.roundabout_max_diameter]
    tagged = {k for g in groups for k in g}
    groups += [[k] for k, s in enumerate(net.streets)
               if k not in tagged and s.is_closed and s.junction not in ROUNDABOUT_TAGS
               and _diameter(net, [k]) <= opts.loop_max_diameter]
    approaches = _approaches(net, groups)
    groups = [g for g, n in zip(groups, approaches) if n >= 2]
    if not groups:
        return net, 0
    centres = np.array([_centre(net, g) for g in groups])
    xy, ids, first = append_nodes(net, centres)
    remap: dict[int, int] = {}
    for i, g in enumerate(groups):
        for k in g:
            for n in net.streets[k].nodes:
                remap[n] = first + i
    gone = {k for g in groups for k in g}
    kept = tuple(s for k, s in enumerate(net.streets) if k not in gone)
    return net.replace(xy=xy, node_ids=ids, streets=replace_nodes(kept, remap)), len(groups)


def _approaches(net: StreetNetwork, groups: list[list[int]]) -> list[int]:
    """Per group, the street ends meeting its ring (a street passing through counts twice).

    A ring with one approach is a turning loop: collapsing it would turn the
    road into a dead end and delete it, so it stays.
    """
    ring_of: dict[int, int] = {}
    member = set()
    for g, group in enumerate(groups):
        for k in group:
            member.add(k)
            ring_of.update((n, g) for n in net.streets[k].nodes)
    count = [0] * len(groups)
    for k, s in enumerate(net.streets):
        if k in member:
            continue
        last = len(s.nodes) - 1
        for i, n in enumerate(s.nodes):
            ring = ring_of.get(n)
            if ring is not None:
                count[ring] += 1 if i in (0, last) else 2
    return count


def _tagged_groups(streets: tuple[Street, ...]) -> list[list[int]]:
    """Roundabout-tagged streets joined through shared nodes."""
    tagged = [k for k, s in enumerate(streets) if s.junction in ROUNDABOUT_TAGS]
    if not tagged:
        return []
    ds = UnionFind(tagged)
    owner: dict[int, int] = {}
    for k in tagged:
        for n in streets[k].nodes:
            if n in owner:
                ds.merge(owner[n], k)
            else:
                owner[n] = k
    return sorted(sorted(g) for g in ds.subsets())


def _group_xy(net: StreetNetwork, group: list[int]) -> np.ndarray:
    return np.concatenate([net.street_xy(net.streets[k]) for k in group])


def _diameter(net: StreetNetwork, group: list[int]) -> float:
    pts = _group_xy(net, group)
    return float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0))))


def _centre(net: StreetNetwork, group: list[int]) -> np.ndarray:
    """Area centroid when the group closes a ring, else the mean of its nodes."""
    pts = _group_xy(net, group)
    if len(group) == 1 and net.streets[group[0]].is_closed:
        poly = shapely.Polygon(pts)
        if poly.is_valid and poly.area > 1.0:
            c = poly.centroid
            return np.array([c.x, c.y])
    merged = shapely.line_merge(shapely.MultiLineString([net.street_xy(net.streets[k]) for k in group]))
    if merged.geom_type == "LineString" and merged.is_ring:
        poly = shapely.Polygon(merged.coords)
        if poly.is_valid and poly.area > 1.0:
            c = poly.centroid
            return np.array([c.x, c.y])
    return pts.mean(axis=0)
