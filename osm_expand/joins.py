"""Joining the grown district to the old town.

The random walk already ends some new streets on old-town junctions with
free slots. The rest of the joining is done here, the way towns actually grow
into their edges: short straight streets from the district to

* an old *border junction* with a free slot, or
* an old street, meeting it in a new *tee* junction.

Candidates are found from the town's side: every border junction, and points
every ``spread / 2`` metres along the old streets near the district; each is
linked to the nearest point of the district's streets (a new junction there
too, unless an existing node is within :data:`SNAP` metres), and a tee is then
squared onto the old street. Border junctions go first, then the shortest
links. A link crosses no street and no old block, ends on no node that
already has four streets, may bridge up to :data:`MAX_BRIDGE` metres of water
(it is then tagged as a bridge), and keeps ``spread`` metres from other
joins, so a district bordering the town along an arc is joined along it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.model import Street, StreetNetwork, closest_on_segments
from simplify.topology import MAX_DEGREE, append_nodes, segment_degree

#: A joining street may bridge this much water (m): streams and ditches.
MAX_BRIDGE = 15.0
#: A link end this close to an existing node uses the node (m).
SNAP = 5.0
#: Links shorter than this are not worth a street (m).
MIN_LINK = 10.0


@dataclass(frozen=True)
class _Link:
    length: float
    border: bool
    new_street: int  # index of the grown street the link leaves from
    new_at: tuple[float, float]
    old_street: int
    old_at: tuple[float, float]


class _Board:
    """The combined network being joined: streets, degrees and the links added so far."""

    def __init__(self, net: StreetNetwork, origins: list[str], old_town, water):
        self.net, self.old_town, self.water = net, old_town, water
        self.new_xy: list[np.ndarray] = []
        self.streets, self.origins = list(net.streets), list(origins)
        self.lines = shapely.STRtree([shapely.LineString(net.street_xy(s)) for s in net.streets])
        self.links: list[shapely.LineString] = []
        self.degree = segment_degree(net.streets, len(net.xy)).tolist()
        self.joined_at: list[np.ndarray] = []

    def point(self, n: int) -> np.ndarray:
        return self.net.xy[n] if n < len(self.net.xy) else self.new_xy[n - len(self.net.xy)]

    def street_xy(self, k: int) -> np.ndarray:
        return np.array([self.point(n) for n in self.streets[k].nodes])

    def snapped(self, k: int, at: np.ndarray) -> tuple[int | None, np.ndarray]:
        """The node of street ``k`` within :data:`SNAP` of ``at`` (else None) and where the link ends."""
        pts = self.street_xy(k)
        d = np.hypot(*(pts - at).T)
        i = int(np.argmin(d))
        return (self.streets[k].nodes[i], pts[i]) if d[i] <= SNAP else (None, at)

    def split(self, k: int, at: np.ndarray) -> int:
        """A new node on street ``k`` at ``at`` (which lies on it)."""
        pts = self.street_xy(k)
        i = int(np.argmin(closest_on_segments(at, pts[:-1], pts[1:])[2]))
        n = len(self.net.xy) + len(self.new_xy)
        self.new_xy.append(np.asarray(at, dtype=float))
        self.degree.append(2)
        street = self.streets[k]
        self.streets[k] = street.with_nodes(street.nodes[: i + 1] + (n,) + street.nodes[i + 1:])
        return n

    def wet_length(self, line: shapely.LineString) -> float:
        return float(self.water.intersection(line).length) if not self.water.is_empty else 0.0

    def clear(self, line: shapely.LineString) -> bool:
        """No old block on the link, and it meets streets and other links only at its two ends."""
        if self.old_town.intersects(line):
            return False
        hits = self.lines.geometries.take(self.lines.query(line, predicate="intersects"))
        touches = shapely.intersection(line, [*hits, *self.links])
        ends = shapely.MultiPoint(list(line.coords)).buffer(1e-6)
        return bool((shapely.is_empty(touches) | shapely.covers(ends, touches)).all())

    def try_link(self, link: _Link, spread: float) -> bool:
        g_node, g = self.snapped(link.new_street, np.array(link.new_at))
        o_node, o = self.snapped(link.old_street, np.array(link.old_at))
        if float(np.hypot(*(g - o))) < MIN_LINK or not all(np.hypot(*(o - q)) >= spread for q in self.joined_at):
            return False
        line = shapely.LineString([g, o])
        if any(n is not None and self.degree[n] >= MAX_DEGREE for n in (g_node, o_node)) or not self.clear(line):
            return False
        wet = self.wet_length(line)
        if wet > MAX_BRIDGE:
            return False
        g_node = self.split(link.new_street, g) if g_node is None else g_node
        o_node = self.split(link.old_street, o) if o_node is None else o_node
        self.degree[g_node] += 1
        self.degree[o_node] += 1
        self.links.append(line)
        self.streets.append(Street(nodes=(o_node, g_node), highway="residential", hierarchy=0, status="planned",
                                   bridge=wet > 0, layer=1 if wet > 0 else 0))
        self.origins.append("grown")
        self.joined_at.append(o)
        return True

    def network(self) -> tuple[StreetNetwork, list[str]]:
        xy, ids, _ = append_nodes(self.net, np.array(self.new_xy))
        return self.net.replace(xy=xy, node_ids=ids, streets=tuple(self.streets)), self.origins


def join_to_town(net: StreetNetwork, origins: list[str], border: np.ndarray, old_town, water,
                 reach: float, spread: float, most: int = 8) -> tuple[StreetNetwork, list[str]]:
    """Add joining streets until the district is joined at ``most`` places or no candidate is left."""
    grown = [k for k, o in enumerate(origins) if o == "grown"]
    old = [k for k, o in enumerate(origins) if o == "source"]
    if not grown or not old:
        return net, origins
    board = _Board(net, origins, old_town, water)
    board.joined_at = [net.xy[n] for n in sorted(_shared_nodes(net, origins))]
    for link in _candidates(net, grown, old, border, reach, spread):
        if len(board.joined_at) >= most:
            break
        board.try_link(link, spread)
    return board.network()


def _candidates(net: StreetNetwork, grown: list[int], old: list[int], border: np.ndarray,
                reach: float, spread: float) -> list[_Link]:
    """Links from border junctions and from points along old streets to the nearest new street."""
    new_lines = [shapely.LineString(net.street_xy(net.streets[k])) for k in grown]
    old_lines = [shapely.LineString(net.street_xy(net.streets[k])) for k in old]
    district = shapely.STRtree(new_lines)
    old_tree = shapely.STRtree(old_lines)
    starts: list[tuple[bool, int, shapely.Point]] = []
    for x, y in np.asarray(border, dtype=float).reshape(-1, 2):
        p = shapely.Point(x, y)
        starts.append((True, int(old_tree.query_nearest(p)[0]), p))
    near = np.unique(old_tree.query(new_lines, predicate="dwithin", distance=reach)[1])
    for j in near.tolist():
        line = old_lines[j]
        for d in np.arange(0.0, line.length + 1e-9, spread / 2):
            starts.append((False, j, line.interpolate(d)))
    links = []
    for border_start, j, p in starts:
        k = int(district.query_nearest(p)[0])
        g = _foot(new_lines[k], p)
        o = p if border_start else _foot(old_lines[j], g)
        length = float(g.distance(o))
        if length <= reach:
            links.append(_Link(length, border_start, grown[k], (g.x, g.y), old[j], (o.x, o.y)))
    return sorted(links, key=lambda c: (not c.border, c.length, c.new_at, c.old_at))


def _foot(line: shapely.LineString, p: shapely.Point) -> shapely.Point:
    """The point of ``line`` nearest to ``p``."""
    return line.interpolate(line.project(p))


def _shared_nodes(net: StreetNetwork, origins: list[str]) -> set[int]:
    """Old-town nodes on new streets: where the district is joined."""
    old = {n for s, o in zip(net.streets, origins) if o == "source" for n in s.nodes}
    return {n for s, o in zip(net.streets, origins) if o == "grown" for n in s.nodes} & old


def connections(net: StreetNetwork, origins: list[str]) -> int:
    """How many places the district is joined at."""
    return len(_shared_nodes(net, origins))
