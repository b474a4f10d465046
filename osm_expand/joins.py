"""Joining the grown district to the old town.

The random walk already ends some new streets on old-town junctions with
free slots. What it leaves unjoined is joined here, the way towns actually
grow into their edges, in two kinds of street:

* to an old *border junction* with a free slot that no new street reached;
* as a *tee* onto an old street: from a loose end or a small junction of the
  district straight to the nearest point of the old street, which gets a new
  junction there (on an existing node of it when one is within
  :data:`TEE_SNAP` metres).

A joining street crosses no street and no old block; it may bridge up to
:data:`MAX_BRIDGE` metres of water (it is then tagged as a bridge). Joins
keep ``spread`` metres apart, so a district that borders the town along an arc
is joined along all of it rather than by a bundle of streets in one place.
"""
from __future__ import annotations

import numpy as np
import shapely
from scipy.spatial import cKDTree

from osm_expand.model import Street, StreetNetwork
from synth.segment_index import SegmentIndex

#: A joining street may bridge this much water (m): streams and ditches.
MAX_BRIDGE = 15.0
#: A tee this close to a node of the old street joins at that node (m).
TEE_SNAP = 5.0


class _Board:
    """The combined network being joined, with a segment index for the no-crossing rule."""

    def __init__(self, net: StreetNetwork, origins: list[str], old_town, water, cell: float):
        self.net, self.old_town, self.water = net, old_town, water
        self.xy = [net.xy]
        self.n_nodes = len(net.xy)
        self.streets, self.origins = list(net.streets), list(origins)
        self.index = SegmentIndex(max(cell, 1.0))
        self.segment: dict[tuple[int, int], int] = {}
        for s in self.streets:
            for a, b in zip(s.nodes, s.nodes[1:]):
                self.segment[(a, b)] = self.index.add(net.xy[a], net.xy[b], a, b)
        self.joined_at: list[np.ndarray] = []

    def point(self, n: int) -> np.ndarray:
        return self.net.xy[n] if n < len(self.net.xy) else self.xy[1 + n - len(self.net.xy)][0]

    def wet_length(self, g: int, p: np.ndarray, at: np.ndarray) -> float | None:
        """Water crossed by a street from node ``g`` to point ``p`` (None: it may not be built)."""
        line = shapely.LineString([self.point(g), p]).difference(shapely.Point(at).buffer(TEE_SNAP))
        if line.is_empty or self.old_town.intersects(line):
            return None
        wet = float(self.water.intersection(line).length) if not self.water.is_empty else 0.0
        return wet if wet <= MAX_BRIDGE else None

    def far_from_joins(self, p: np.ndarray, spread: float) -> bool:
        return all(np.hypot(*(p - q)) >= spread for q in self.joined_at)

    def join(self, g: int, b: int, wet: float) -> None:
        self.segment[(b, g)] = self.index.add(self.point(b), self.point(g), b, g)
        self.streets.append(Street(nodes=(b, g), highway="residential", hierarchy=0, status="planned",
                                   bridge=wet > 0, layer=1 if wet > 0 else 0))
        self.origins.append("grown")
        self.joined_at.append(self.point(b))

    def try_junction(self, g: int, b: int, spread: float) -> bool:
        p = self.point(b)
        if not self.far_from_joins(p, spread) or self.index.crosses(self.point(g), p, b, g):
            return False
        wet = self.wet_length(g, p, p)
        if wet is None:
            return False
        self.join(g, b, wet)
        return True

    def try_tee(self, g: int, k: int, spread: float) -> bool:
        """Join ``g`` to the nearest point of old street ``k``, splitting it there."""
        street = self.streets[k]
        pts = np.array([self.point(n) for n in street.nodes])
        i, p = _nearest_on_polyline(pts, self.point(g))
        a, b = street.nodes[i], street.nodes[i + 1]
        for end in (a, b):
            if np.hypot(*(self.point(end) - p)) <= TEE_SNAP:
                return self.try_junction(g, end, spread)
        if not self.far_from_joins(p, spread):
            return False
        wet = self.wet_length(g, p, p)
        if wet is None:
            return False
        n = self.n_nodes
        old = self.segment.pop((a, b))
        self.index.remove(old)
        halves = [self.index.add(pts[i], p, a, n), self.index.add(p, pts[i + 1], n, b)]
        if self.index.crosses(self.point(g), p, n, g):
            for h in halves:
                self.index.remove(h)
            self.segment[(a, b)] = self.index.add(pts[i], pts[i + 1], a, b)
            return False
        self.segment[(a, n)], self.segment[(n, b)] = halves
        self.xy.append(p[None, :])
        self.n_nodes += 1
        self.streets[k] = street.with_nodes(street.nodes[: i + 1] + (n,) + street.nodes[i + 1:])
        self.join(g, n, wet)
        return True

    def network(self) -> tuple[StreetNetwork, list[str]]:
        xy = np.vstack(self.xy)
        ids = np.concatenate([self.net.node_ids, np.zeros(len(xy) - len(self.net.xy), dtype=np.int64)])
        return self.net.replace(xy=xy, node_ids=ids, streets=tuple(self.streets)), self.origins


def _nearest_on_polyline(pts: np.ndarray, q: np.ndarray) -> tuple[int, np.ndarray]:
    """The segment of a polyline nearest to ``q`` and the nearest point on it."""
    a, d = pts[:-1], np.diff(pts, axis=0)
    t = np.clip(np.einsum("ij,ij->i", q - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-12), 0.0, 1.0)
    foot = a + t[:, None] * d
    i = int(np.argmin(np.hypot(*(foot - q).T)))
    return i, foot[i]


def join_to_town(net: StreetNetwork, origins: list[str], border: np.ndarray, old_town, water,
                 reach: float, spread: float, most: int = 8) -> tuple[StreetNetwork, list[str]]:
    """Add up to ``most`` joining streets, border junctions first, then tees onto old streets."""
    grown = [k for k, o in enumerate(origins) if o == "grown"]
    if not grown:
        return net, origins
    board = _Board(net, origins, old_town, water, cell=reach / 2)
    old_nodes = {n for s, o in zip(net.streets, origins) if o == "source" for n in s.nodes}
    degree = _degrees(net.streets, grown)
    ends = sorted(n for n, d in degree.items() if d <= 3 and n not in old_nodes)
    ends_of_new = {n for k in grown for n in (net.streets[k].nodes[0], net.streets[k].nodes[-1])}
    board.joined_at = [net.xy[n] for n in sorted(ends_of_new & old_nodes)]
    if not ends:
        return net, origins
    tree = cKDTree(net.xy[ends])
    _join_border_junctions(board, net, border, tree, ends, reach, spread, most)
    _join_tees(board, net, origins, ends, degree, reach, spread, most)
    return board.network()


def _degrees(streets, which: list[int]) -> dict[int, int]:
    """Segments meeting at each node of the given streets (shape points count 2)."""
    degree: dict[int, int] = {}
    for k in which:
        for a, b in zip(streets[k].nodes, streets[k].nodes[1:]):
            degree[a] = degree.get(a, 0) + 1
            degree[b] = degree.get(b, 0) + 1
    return degree


def _join_border_junctions(board: _Board, net: StreetNetwork, border: np.ndarray, tree: cKDTree,
                           ends: list[int], reach: float, spread: float, most: int) -> None:
    node_at = {(float(x), float(y)): n for n, (x, y) in enumerate(net.xy)}
    for x, y in border:
        if len(board.joined_at) >= most:
            return
        b = node_at[(float(x), float(y))]
        dist, idx = tree.query(net.xy[b], k=min(8, len(ends)), distance_upper_bound=reach)
        for d, i in zip(np.atleast_1d(dist), np.atleast_1d(idx)):
            if not np.isfinite(d) or board.try_junction(ends[int(i)], b, spread):
                break


def _join_tees(board: _Board, net: StreetNetwork, origins: list[str], ends: list[int],
               degree: dict[int, int], reach: float, spread: float, most: int) -> None:
    """Loose ends first, then small junctions, nearest to the town first."""
    old = [k for k, o in enumerate(origins) if o == "source"]
    lines = shapely.STRtree([shapely.LineString(net.street_xy(net.streets[k])) for k in old])
    pts = shapely.points(net.xy[ends])
    gap = np.full(len(ends), np.inf)
    (which, _), dist = lines.query_nearest(pts, max_distance=reach, return_distance=True)
    np.minimum.at(gap, which, dist)
    for j in np.lexsort((gap, [degree[n] for n in ends])):
        if len(board.joined_at) >= most or gap[j] > reach:
            continue
        near = lines.query(pts[j], predicate="dwithin", distance=reach)
        for k in sorted(near.tolist(), key=lambda k: lines.geometries[k].distance(pts[j]))[:3]:
            if board.try_tee(ends[j], old[k], spread):
                break


def connections(net: StreetNetwork, origins: list[str]) -> int:
    """Old-town nodes that new streets end on: how many places the district is joined at."""
    old_nodes = {n for s, o in zip(net.streets, origins) if o == "source" for n in s.nodes}
    return len({n for s, o in zip(net.streets, origins) if o == "grown"
                for n in (s.nodes[0], s.nodes[-1]) if n in old_nodes})
