"""The district's corners: how sharply its streets turn where no junction explains it, counted beside its
town's own rate, and the corners beyond that rate straightened (:func:`_straighten`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.model import City, StreetNetwork, polyline_length, turn_angles
from osm_expand.model.geometry import linestrings_of
from synth.patches.source import _neighbourhood_points, _source


def corner_turns(net: StreetNetwork, among: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The nodes where exactly two segments meet (of ``among`` only when given, e.g. the district's), in
    ascending order, and the turn (degrees, 0-180) at each: how sharply a street bends where no junction
    explains it.

    The fidelity yardstick reads streets as chains between junctions (:mod:`osm_expand.measures`), so
    a bend at a node of degree 2 is part of one street's curvature however it arose: an L left where a
    seam cut a tee's arm, a seam link zig-zagging between two cut streets, a perimeter street on the
    jagged edge of the free land (issue 20: Krems seed 0 had 41 turns over 45°, 13 of them such Ls).
    A district is judged by how many of these exceed 45° per km beside its town's own rate.
    """
    seg = np.array([(a, b) for s in net.streets for a, b in zip(s.nodes[:-1], s.nodes[1:]) if a != b],
                   dtype=np.int64).reshape(-1, 2)
    degree = np.bincount(seg.ravel(), minlength=len(net.xy))
    node, other = np.concatenate([seg[:, 0], seg[:, 1]]), np.concatenate([seg[:, 1], seg[:, 0]])
    two = degree[node] == 2
    if among is not None:
        two &= np.isin(node, among)
    order = np.argsort(node[two], kind="stable")
    node, other = node[two][order], other[two][order]
    at, before, after = node[0::2], other[0::2], other[1::2]
    return at, turn_angles(net.xy[at] - net.xy[before], net.xy[after] - net.xy[at])


#: degrees: a turn sharper than this at a node of degree 2 is a corner (issue 20's count).
SHARP = 45.0


def sharp_corners(net: StreetNetwork) -> tuple[int, float]:
    """The corners sharper than :data:`SHARP` at degree-2 nodes of ``net``'s new streets, and those
    streets' length in km: the count and the length it is read over, so that a district's rate per km
    can stand beside its town's (:func:`neighbourhood_corner_rates`)."""
    mine = [s for s in net.streets if s.is_new]
    if not mine:
        return 0, 0.0
    nodes = np.unique(np.concatenate([np.asarray(s.nodes) for s in mine]))
    km = sum(polyline_length(net.street_xy(s)) for s in mine) / 1000.0
    return int((corner_turns(net, nodes)[1] > SHARP).sum()), float(km)


def _straighten(net: StreetNetwork, budget: int, reach: float, old: shapely.Geometry,
                occupied: shapely.Geometry) -> StreetNetwork:
    """The district with its corners beyond ``budget`` straightened: runs of one to three nodes of degree
    two around a corner moved towards the straight line between the nodes either side, no farther than
    it takes (:data:`SHARES`), as long as that line lies within ``reach`` metres and the new pieces
    cross nothing (the district's other streets, the town's ``old`` ones, ``occupied`` land) that the
    old ones did not.

    The seams leave corners that no street of the town has: a seam link a few metres off the cut
    street it continues (a jog: two turns of 50-140° a few metres apart), a perimeter street meeting a
    cut street a metre or two from where it was cut (a spike), an L of a trimmed tee. The town's own
    streets as mapped turn more than :data:`SHARP` at a node of degree two 0.7-1.2 times a km in its
    neighbourhoods at the district's size (median; :func:`corners_in_discs`, read by
    ``ExamplePatches._corner_rate``), so the ``budget`` (the caller's: that rate over the district's
    length) is how many of them a district of the town may keep. Moves are greedy, the one that takes away
    the most corners around it first (then the smallest); only positions change, never which nodes a
    street joins, so dead ends, loops, junctions and pieces stay as they were.
    """
    seg = np.array([(a, b) for s in net.streets for a, b in zip(s.nodes[:-1], s.nodes[1:]) if a != b],
                   dtype=np.int64).reshape(-1, 2)
    if not len(seg):
        return net
    seg = np.unique(np.sort(seg, axis=1), axis=0)
    degree = np.bincount(seg.ravel(), minlength=len(net.xy))
    node, other = np.concatenate([seg[:, 0], seg[:, 1]]), np.concatenate([seg[:, 1], seg[:, 0]])
    order = np.argsort(node, kind="stable")
    node, other = node[order], other[order]
    start = np.searchsorted(node, np.arange(len(net.xy)))
    xy = net.xy.copy()
    two = degree == 2
    first, second = other[np.minimum(start, len(other) - 1)], other[np.minimum(start + 1, len(other) - 1)]

    def turns(n: np.ndarray) -> np.ndarray:
        """The turn (degrees) at nodes ``n``: 0 where the degree is not two."""
        n = np.asarray(n, dtype=np.int64)
        t = turn_angles(xy[n] - xy[first[n]], xy[second[n]] - xy[n])
        return np.where(two[n], t, 0.0)

    def beyond(n: int, came: int) -> int:
        """The neighbour of degree-2 node ``n`` that is not ``came``."""
        return int(second[n] if first[n] == came else first[n])

    def runs(v: int) -> list[tuple[int, list[int], int]]:
        """Runs of degree-2 nodes through ``v`` (one to three nodes) with the anchors either side."""
        u, w = int(first[v]), int(second[v])
        out = [(u, [v], w)]
        if two[u]:
            out.append((beyond(u, v), [u, v], w))
        if two[w]:
            out.append((u, [v, w], beyond(w, v)))
        if two[u] and two[w]:
            out.append((beyond(u, v), [u, v, w], beyond(w, v)))
        return [(a, run, b) for a, run, b in out if a != b and a not in run and b not in run]

    turn = turns(np.arange(len(xy)))
    for _ in range(PASSES):
        corners = np.flatnonzero(turn > SHARP)
        if len(corners) <= budget:
            break
        count, moved_any = len(corners), False
        for v in corners[np.argsort(-turn[corners], kind="stable")].tolist():
            if count <= budget:
                break
            if turn[v] <= SHARP:  # straightened with a neighbour's run
                continue
            moves = []
            for a, run, b in runs(v):
                path = xy[[a, *run, b]]
                arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
                if (np.diff(arc) <= 0.0).any():
                    continue
                line = xy[a] + (arc[1:-1] / arc[-1])[:, None] * (xy[b] - xy[a])
                if float(np.hypot(*(line - path[1:-1]).T).max()) > reach:
                    continue
                around = np.unique([a, *run, b])
                keep = xy[run].copy()
                best = None
                for share in SHARES:  # no farther than it takes: the street keeps what it can of its shape
                    new = keep + share * (line - keep)
                    if float(np.hypot(*(new - net.xy[run]).T).max()) > reach:  # over every pass: from the start
                        continue
                    xy[run] = new
                    gain = int((turn[around] > SHARP).sum() - (turns(around) > SHARP).sum())
                    if gain > 0 and (best is None or gain > -best[0]):
                        best = (-gain, float(np.hypot(*(new - keep).T).max()), (a, *run, b), new, around)
                xy[run] = keep
                if best is not None:
                    moves.append(best)
            for less, _, key, new, around in sorted(moves, key=lambda m: (m[0], m[1], m[2])):  # most gain first
                if _clear(xy, seg, key, new, old, occupied):
                    xy[list(key[1:-1])] = new
                    turn[around] = turns(around)
                    count += less
                    moved_any = True
                    break
        if not moved_any:
            break
    return net.replace(xy=xy) if not np.array_equal(xy, net.xy) else net


#: How far towards the straight line a run is tried, in turn: the first share that takes the most corners
#: away is taken, so that a jog is eased only until it turns no more than :data:`SHARP`.
SHARES = (0.25, 0.5, 0.75, 1.0)
#: Passes over the district's corners, sharpest first, while any was straightened and too many are left.
PASSES = 3


def _clear(xy: np.ndarray, seg: np.ndarray, key: tuple[int, ...], new: np.ndarray, old: shapely.Geometry,
           occupied: shapely.Geometry) -> bool:
    """Does the run ``key`` (anchor, moved nodes, anchor) laid through ``new`` touch no other segment of
    the district but at its two anchors, and nothing of the town or occupied land its old course did not?"""
    a, b = key[0], key[-1]
    run = set(key[1:-1])
    after = shapely.LineString(np.vstack([xy[a], new, xy[b]]))
    before = shapely.LineString(xy[list(key)])
    if not after.is_simple:
        return False
    others = seg[~(np.isin(seg[:, 0], list(run)) | np.isin(seg[:, 1], list(run)))]
    lines = shapely.linestrings(xy[others])
    hits = shapely.intersection(after, lines[shapely.intersects(after, lines)])
    ends = shapely.MultiPoint([xy[a], xy[b]]).buffer(1e-6)
    if not (shapely.is_empty(hits) | shapely.covers(ends, hits)).all():
        return False
    for obstacle in (old, occupied):  # where the old course touched it (a tee's anchor), no more than that
        if obstacle is not None and not obstacle.is_empty and obstacle.intersects(after) \
                and not before.intersection(obstacle).buffer(1e-6).covers(after.intersection(obstacle)):
            return False
    return True


@dataclass(frozen=True)
class MappedCorners:
    """The town's streets as mapped and their corners sharper than :data:`SHARP` at nodes of degree two:
    read once per network, then counted in any disc (:func:`corners_in_discs`).

    Every street as mapped, the motorways and ramps too (:data:`~synth.patches.options.NOT_COPIED`), which a
    district never copies: the neighbourhoods are read as the verdict reads them (its ``everything``
    source), so a rate here is the town's as the yardstick sees it, not only of what may be copied."""

    lines: np.ndarray  #: shapely LineStrings of the mapped streets
    tree: shapely.STRtree
    sharp: np.ndarray  #: (n, 2) the corners' positions

    @classmethod
    def of(cls, net: StreetNetwork) -> MappedCorners:
        mapped = [s for s in net.streets if not s.is_new]
        if not mapped:
            empty = np.zeros(0, dtype=object)
            return cls(lines=empty, tree=shapely.STRtree(empty), sharp=np.zeros((0, 2)))
        at, turns = corner_turns(net, np.unique(np.concatenate([np.asarray(s.nodes) for s in mapped])))
        lines = linestrings_of([net.street_xy(s) for s in mapped])
        return cls(lines=lines, tree=shapely.STRtree(lines), sharp=net.xy[at[turns > SHARP]])


def corners_in_discs(net: StreetNetwork | MappedCorners, centres: np.ndarray, radius: float) -> np.ndarray:
    """Corners sharper than :data:`SHARP` per km at degree-2 nodes of ``net``'s streets as mapped, in each disc
    of ``radius`` metres on ``centres`` (the town's neighbourhoods, drawn as the fidelity yardstick draws them):
    the rate a district of that area is read beside; NaN for a disc with no street.

    Read on the streets the district copies (the town as mapped, with its nodes), not on the simplified example:
    simplification drops nodes, merges ways and removes short streets, so a rate read there is not the same
    reading as the district's (whose pieces are the mapped ways, and whose links are laid every few metres).
    Krems: 1.03 per km on its simplified streets, 0.36 over the whole extract as mapped, 0.7-0.8 (median) in
    its neighbourhoods at the district's size; north-bayreuth 1.06, 0.74, 1.0-1.2.
    """
    read = net if isinstance(net, MappedCorners) else MappedCorners.of(net)
    out = np.full(len(centres), np.nan)
    for k, c in enumerate(np.asarray(centres, dtype=float).reshape(-1, 2)):
        disc = shapely.Point(c).buffer(radius, 16)
        near = read.lines[read.tree.query(disc, predicate="intersects")]
        km = float(shapely.length(shapely.intersection(near, disc)).sum()) / 1000.0
        if km > 0:
            out[k] = float((np.hypot(*(read.sharp - c).T) <= radius).sum()) / km
    return out


def neighbourhood_corner_rates(city: City, radius: float, n: int = 16, seed: int = 0) -> np.ndarray:
    """:func:`corners_in_discs` of ``city``'s streets as mapped in ``n`` of its neighbourhoods of ``radius``
    metres (the yardstick's draw, :func:`~synth.patches.source._neighbourhood_points`, on every street of the
    town with generator ``seed``): the rates a district of that radius is read beside (their median and 90th
    percentile in the benchmarks and tests). The source needs no example: the draw never reads its levels."""
    around = _neighbourhood_points(_source(city, None, everything=True), n, radius, np.random.default_rng(seed))
    return corners_in_discs(city.network, around, radius)
