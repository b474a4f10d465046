"""Joining grown streets to the town: the one step after any growth pattern.

The new streets enter the city's network first; a new street that ends on a
node of the town (it carries that node's exact coordinates) shares the node.
The rest of the joining is done the way towns actually grow into their
edges: short straight *joining streets* from the district to

* a node of the town with a free slot (a junction, or a street's end), or
* a street of the town, meeting it in a new *tee* junction.

A tee inserts the new node into the town's way (as JOSM does when a way is
drawn onto another): the way keeps its id, tags and shape, and gains a node.

Candidates are found from the town's side: every border node, and points
every ``spread / 2`` metres along the town's streets near the district;
each is linked to the nearest point of the new streets (a new junction there
too, unless an existing node is within :data:`SNAP` metres), and a tee is then
squared onto the old street. Border nodes go first, then the shortest links.
A link crosses no street and nothing occupied (blocks, unbuildable land,
buildings), ends on no node that already has four segments, may bridge up to
:data:`MAX_BRIDGE` metres of water (it is then tagged as a bridge), and keeps
``spread`` metres from other joins, so a district bordering the town along an
arc is joined along it.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.errors import OptionError
from osm_expand.model import City, Origin, Status, Street, StreetNetwork, closest_on_segments
from osm_expand.model.geometry import linestrings_of
from osm_expand.model.topology import MAX_DEGREE, append_nodes, segment_degree

#: A joining street may bridge this much water (m): streams and ditches.
MAX_BRIDGE = 15.0
#: A link end this close to an existing node uses the node (m).
SNAP = 5.0
#: Links shorter than this are not worth a street (m).
MIN_LINK = 10.0
#: Junction spacings (:func:`join_growth`'s ``run_on``): a new street's dead end left this close to a street
#: of the town runs on to it in a joining street after the ``most`` joins, ``spread`` apart, are made
#: (:func:`_run_on_ends`; each end tries its nearest town street only); 0: never.
#: A district's street that the growth's clearance cut ends a few metres short of the town's street it was
#: heading for (Campo Grande seed 0: 14 of the engine's 122 dead ends lie 14.9 m, its patches' clearance of
#: 0.15 spacings, from a street of the town; the district counted them as joined, :mod:`synth.patches.topology`),
#: and the join stops at ``most`` places, which a large district's own tees onto the town already are.
#: Off: at 0.3 (twice the clearance; it joins the pipeline's district too), ``engine_growth.py --seed 0``: Campo
#: Grande 4 4 5 -> 5 5 5, 2-core share 0.9644 below [0.9684-0.979] -> 0.9721 in [0.9638-0.9811], dead ends 0.055
#: -> 0.045, pieces 5 -> 2, 12 joining streets (3 before), but its districts moved (334 -> 350 km, density 19.5
#: above its range); Krems, Andorra, north-bayreuth, Monaco the same; ``--seed 1``: Krems 3 3 4 -> 1 0 1,
#: Andorra 0 0 1 -> 1 1 1, north-bayreuth 3 3 3 -> 3 4 3, Monaco the same (session 33, h33c).
END_RUN_ON = 0.0


@dataclass(frozen=True)
class JoinReport:
    """Where the new streets meet the town."""

    joins: int  #: nodes of the town that new streets end on or pass through
    links: int  #: joining streets added
    tees: int  #: of which end on a town street in a new node
    at: np.ndarray  #: (joins, 2) metres

    def to_dict(self) -> dict:
        return {"joins": self.joins, "joining_streets": self.links, "tees": self.tees,
                "at": [[round(float(x), 1), round(float(y), 1)] for x, y in self.at]}


#: A new street's end this close to a town street (m) lies on it: the town's way gets the node (a tee).
ON_STREET = 1e-3


def join_growth(city: City, streets: Sequence, *, spacing: float, origin: Origin = Origin.GROWN,
                status: Status = Status.PLANNED, year: int | None = None, era: str | None = None,
                most: int = 8, cross_taken: bool = False, occupied: Occupied | None = None,
                run_on: float = END_RUN_ON) -> tuple[City, JoinReport]:
    """The shared joining step after any growth pattern: its streets into the city, joined to the town.

    Parameters
    ----------
    city : City
    streets : sequence of :class:`synth.growth.NewStreet`-like objects
        With ``xy``, ``highway``, ``hierarchy``, ``bridge`` and ``layer``.
    spacing : float
        The town's junction spacing (m): joining streets reach at most two of them, and keep two apart.
    origin, status, year, era
        Stamped on the new streets and the joining streets.
    most : int
        Stop once the new streets are joined at this many places.
    occupied : Occupied, optional
        The occupied land near the streets, already made (:func:`occupied_near`): used when it was made for
        the very area this join reads (the same box and ``taken``), else made again.
    run_on : float
        Junction spacings: a new street's dead end this close to a town street runs on to it after the
        joins (:data:`END_RUN_ON`, off).
    """
    attrs = [{"highway": s.highway, "hierarchy": s.hierarchy, "bridge": s.bridge, "layer": s.layer,
              "origin": origin, "status": status, "year": year, "era": era} for s in streets]
    grown = add_streets(city, [s.xy for s in streets], attrs)
    new = list(range(len(city.network.streets), len(grown.network.streets)))
    return join_to_town(grown, new, reach=2 * spacing, spread=2 * spacing, most=most, year=year, era=era,
                        cross_taken=cross_taken, occupied=occupied, run_on=run_on * spacing)


def add_streets(city: City, lines: Sequence[np.ndarray], attrs: Sequence[dict]) -> City:
    """The city with new streets along ``lines``.

    An end on a town node's exact coordinates shares the node; an end on a
    town street between its nodes becomes a tee: the node is inserted into
    the town's way, which keeps its id, tags and shape.
    """
    old_count, old_nodes = len(city.network.streets), len(city.network.xy)
    net = city.network.with_new_streets(lines, attrs, one_street_per_segment=True)
    ends = sorted({n for s in net.streets[old_count:] for n in (s.nodes[0], s.nodes[-1]) if n >= old_nodes})
    return city.replace(network=_insert_tees(net, old_count, np.array(ends, dtype=np.int64)))


def _insert_tees(net: StreetNetwork, old_count: int, ends: np.ndarray) -> StreetNetwork:
    """Insert each of the nodes ``ends`` into the town street segment it lies on (if any)."""
    if not len(ends):
        return net
    owner, first, a, b = _segments_near(net, old_count, net.xy[ends], ON_STREET)
    if not len(owner):
        return net
    tree = shapely.STRtree(shapely.linestrings(np.stack([a, b], axis=1)))
    pts, segs = tree.query(shapely.points(net.xy[ends]), predicate="dwithin", distance=ON_STREET)
    streets = list(net.streets)
    inserts: dict[int, list[tuple[int, float, int]]] = {}
    for p_i, s_i in zip(pts.tolist(), segs.tolist()):
        node, k, i = int(ends[p_i]), int(owner[s_i]), int(first[s_i])
        if node in streets[k].nodes:
            continue
        t, _, d = closest_on_segments(net.xy[node], a[s_i], b[s_i])
        if d <= ON_STREET and 0.0 < float(t) < 1.0:
            inserts.setdefault(k, []).append((i, float(t), node))
    for k, items in inserts.items():
        nodes = list(streets[k].nodes)
        for i, _, node in sorted(items, reverse=True):  # from the street's end, so earlier positions hold
            nodes.insert(i + 1, node)
        streets[k] = streets[k].with_nodes(nodes)
    return net.replace(streets=tuple(streets))


def _segments_near(net: StreetNetwork, count: int, points: np.ndarray, reach: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The segments of the first ``count`` streets whose box comes within ``reach`` of the box of
    ``points``: each one's street, its position in the street, and its two ends. Gathered in one
    pass over the node arrays (a Python loop over Campo Grande's 50,000 segments took 10 s of a
    30-year run), and only those that can be within reach go into the caller's tree."""
    streets = net.streets[:count]
    sizes = np.fromiter((len(s.nodes) for s in streets), dtype=np.int64, count=len(streets))
    nodes = np.fromiter((n for s in streets for n in s.nodes), dtype=np.intp, count=int(sizes.sum()))
    per = np.maximum(sizes - 1, 0)
    owner = np.repeat(np.arange(len(streets)), per)
    first = np.arange(int(per.sum())) - np.repeat(np.cumsum(per) - per, per)
    at = np.repeat(np.cumsum(sizes) - sizes, per) + first
    a, b = net.xy[nodes[at]], net.xy[nodes[at + 1]]
    lo, hi = points.min(axis=0) - reach, points.max(axis=0) + reach
    near = np.flatnonzero(((np.minimum(a, b) <= hi) & (np.maximum(a, b) >= lo)).all(axis=1))
    return owner[near], first[near], a[near], b[near]


@dataclass(frozen=True)
class Occupied:
    """The occupied land a join reads (:meth:`City.occupied_within` of its area), with what it was made for."""

    bounds: tuple[float, float, float, float]  #: the bounds of the area asked for
    taken: bool  #: whether the town's presumed frontage counts (:attr:`~osm_expand.model.land.Land.taken`)
    geometry: shapely.Geometry


def occupied_near(city: City, lines: Sequence[np.ndarray], *, reach: float, spread: float, taken: bool = True,
                  made: Occupied | None = None) -> Occupied:
    """The occupied land around the new streets ``lines`` that a join with ``reach`` and ``spread`` reads: in
    their bounding box grown by ``reach + spread + 1`` metres (no joining street leaves it). ``made``, when
    made on this same city's land for the very same box and ``taken`` (the caller's promise: only the box
    and the flag are compared), is given back as it is (its union was a tenth of a join's
    cost on Campo Grande, and :func:`osm_expand.district.place_district` needs it before joining too)."""
    near = shapely.MultiLineString(list(lines)).envelope.buffer(reach + spread + 1.0)
    x0, y0, x1, y1 = (float(v) for v in near.bounds)
    bounds = (x0, y0, x1, y1)
    if made is not None and made.bounds == bounds and made.taken == taken:
        return made
    return Occupied(bounds=bounds, taken=taken, geometry=city.occupied_within(near, taken=taken))


@dataclass(frozen=True)
class _Link:
    length: float
    border: bool
    new_street: int  # index of the new street the link leaves from
    new_at: tuple[float, float]
    old_street: int
    old_at: tuple[float, float]


class _Board:
    """The network being joined: streets, degrees and the links added so far."""

    def __init__(self, net: StreetNetwork, occupied: shapely.Geometry, water: shapely.Geometry,
                 year: int | None, era: str | None):
        self.net, self.occupied, self.water, self.year, self.era = net, occupied, water, year, era
        self.new_xy: list[np.ndarray] = []
        self.streets = list(net.streets)
        self.lines = shapely.STRtree(net.street_lines())
        self.links: list[shapely.LineString] = []
        self.degree = segment_degree(net.streets, len(net.xy)).tolist()
        self.joined_at: list[np.ndarray] = []
        self.tees = 0
        self.next_id = net.next_street_id()

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
        """A new node on street ``k`` at ``at`` (which lies on it), inserted into its node list."""
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
        """Nothing occupied on the link, and it meets streets and other links only at its two ends."""
        if self.occupied.intersects(shapely.LineString(_trim(np.asarray(line.coords), 1.0))):
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
        if o_node is None:
            o_node = self.split(link.old_street, o)
            self.tees += 1
        self.degree[g_node] += 1
        self.degree[o_node] += 1
        self.links.append(line)
        self.streets.append(Street(nodes=(o_node, g_node), highway="residential", hierarchy=0, status=Status.PLANNED,
                                   bridge=wet > 0, layer=1 if wet > 0 else 0, id=self.next_id, origin=Origin.JOIN,
                                   year=self.year, era=self.era))
        self.next_id += 1
        self.joined_at.append(o)
        return True

    def network(self) -> StreetNetwork:
        xy, ids, _ = append_nodes(self.net, np.array(self.new_xy))
        return self.net.replace(xy=xy, node_ids=ids, streets=tuple(self.streets))


def _trim(pts: np.ndarray, by: float) -> np.ndarray:
    """A two-point segment shortened by ``by`` metres at each end (its ends may touch what they join)."""
    a, b = pts[0], pts[-1]
    length = float(np.hypot(*(b - a)))
    if length <= 2 * by:
        return np.array([(a + b) / 2, (a + b) / 2 + 1e-9])
    u = (b - a) / length
    return np.array([a + by * u, b - by * u])


def join_to_town(city: City, new: Sequence[int], *, reach: float, spread: float, most: int = 8,
                 year: int | None = None, era: str | None = None, cross_taken: bool = False,
                 occupied: Occupied | None = None, run_on: float = 0.0) -> tuple[City, JoinReport]:
    """Add joining streets from the streets ``new`` (indices) to the town until it is joined at ``most`` places.

    Parameters
    ----------
    city : City
        With the new streets already in its network (:func:`add_streets`).
    new : sequence of int
        Indices of the new streets in ``city.network.streets``.
    reach : float
        Longest joining street (m).
    spread : float
        Joins keep this far apart (m).
    most : int
        Stop once the district is joined at this many places.
    year, era
        Stamped on the joining streets.
    occupied : Occupied, optional
        As :func:`join_growth`'s.
    run_on : float
        Metres: then a dead end of the new streets this close to a town street runs on to it
        (:func:`_run_on_ends`); 0: never.

    Returns
    -------
    (City, JoinReport)
    """
    if not (math.isfinite(run_on) and run_on >= 0):
        raise OptionError(f"join run_on must be a finite number of metres >= 0, got {run_on!r}")
    net = city.network
    new = list(new)
    old = [k for k, s in enumerate(net.streets) if s.origin == Origin.SOURCE]
    if not new or not old:
        return city, _report(net, new, 0, 0)
    made = occupied_near(city, [net.street_xy(net.streets[k]) for k in new], reach=reach, spread=spread,
                         taken=not cross_taken, made=occupied)
    board = _Board(net, made.geometry, city.water_geometry(), year, era)
    board.joined_at = [net.xy[n] for n in sorted(_shared_nodes(net, new))]
    border = _border(net, old)
    for link in _candidates(net, new, old, border, reach, spread):
        if len(board.joined_at) >= most:
            break
        board.try_link(link, spread)
    if run_on > 0:
        _run_on_ends(board, net, new, old, run_on)
    joined = board.network()
    added = list(range(len(net.streets), len(joined.streets)))
    return city.replace(network=joined), _report(joined, new + added, len(added), board.tees)


def _run_on_ends(board: _Board, net: StreetNetwork, new: list[int], old: list[int], reach: float) -> None:
    """Join each dead end of the streets ``new`` within ``reach`` metres of a street ``old`` to its nearest
    point there, nearest first, whatever the joins made so far (:data:`END_RUN_ON`): the link's own
    checks hold (clear of streets and occupied land, a free slot at both ends, little water)."""
    ends = sorted({(n, k) for k in new for n in (net.streets[k].nodes[0], net.streets[k].nodes[-1])
                   if board.degree[n] == 1})
    if not ends:
        return
    lines = net.street_lines()[old]
    tree = shapely.STRtree(lines)
    points = shapely.points(net.xy[[n for n, _ in ends]])
    (which, near), dist = tree.query_nearest(points, max_distance=reach, return_distance=True, all_matches=False)
    for i in np.argsort(dist, kind="stable"):
        n, k = ends[which[i]]
        if board.degree[n] != 1:
            continue
        line = lines[near[i]]
        foot = shapely.line_interpolate_point(line, shapely.line_locate_point(line, points[which[i]]))
        at = (float(net.xy[n, 0]), float(net.xy[n, 1]))
        board.try_link(_Link(float(dist[i]), False, k, at, old[near[i]], (foot.x, foot.y)), 0.0)


def _border(net: StreetNetwork, old: list[int]) -> np.ndarray:
    """Ends of the town's streets that are open: dead ends and junctions with a free slot."""
    degree = segment_degree(net.streets, len(net.xy))
    ends = {n for k in old for n in (net.streets[k].nodes[0], net.streets[k].nodes[-1])}
    pick = sorted(n for n in ends if degree[n] < MAX_DEGREE)
    return net.xy[pick].reshape(-1, 2)


def _candidates(net: StreetNetwork, new: list[int], old: list[int], border: np.ndarray,
                reach: float, spread: float) -> list[_Link]:
    """Links from border nodes and from points along old streets to the nearest new street."""
    every = net.street_lines()
    links = [_Link(length, border_start, new[k], g, old[j], o)
             for length, border_start, k, g, j, o in _candidate_links(every[new].tolist(), every[old].tolist(),
                                                                      border, reach, spread)]
    return sorted(links, key=lambda c: (not c.border, c.length, c.new_at, c.old_at))


def _candidate_links(new_lines: list, old_lines: list, border: np.ndarray, reach: float, spread: float,
                     *, longer: float = 0.0) -> list[tuple[float, bool, int, tuple[float, float], int,
                                                           tuple[float, float]]]:
    """:func:`_candidates` on lines: ``(length, from a border node, new line, its end, old line, its end)``
    per link, indices into ``new_lines`` and ``old_lines``, in the order the starts are taken (the border
    nodes, then points every ``spread / 2`` along each old street near the new ones). Every start at once
    (the nearest line and the feet by array calls of shapely, the same GEOS operations as one by one).
    ``longer``: sample the old streets this much beyond their length (:func:`join_places`)."""
    new_arr, old_arr = np.array(new_lines, dtype=object), np.array(old_lines, dtype=object)
    district = shapely.STRtree(new_arr)
    old_tree = shapely.STRtree(old_arr)
    hull = shapely.MultiLineString(new_lines).convex_hull.buffer(reach)
    near_border = border[shapely.contains_xy(hull, border[:, 0], border[:, 1])] if len(border) else border
    near = np.unique(old_tree.query(new_arr, predicate="dwithin", distance=reach)[1])
    steps = [np.arange(0.0, length + longer + 1e-9, spread / 2) for length in shapely.length(old_arr[near]).tolist()]
    along = np.repeat(near, [len(d) for d in steps]).astype(np.int64)
    points = np.concatenate([shapely.points(near_border.reshape(-1, 2)),
                             shapely.line_interpolate_point(old_arr[along], np.concatenate([[], *steps]))])
    if not len(points):
        return []
    from_border = np.arange(len(points)) < len(near_border)
    old_j = np.concatenate([_first_nearest(old_tree, points[from_border]), along])
    k = _first_nearest(district, points)
    g = _feet(new_arr[k], points)
    o = points.copy()
    o[~from_border] = _feet(old_arr[old_j[~from_border]], g[~from_border])
    length = shapely.distance(g, o)
    keep = np.flatnonzero(length <= reach)
    gxy, oxy = shapely.get_coordinates(g[keep]).tolist(), shapely.get_coordinates(o[keep]).tolist()
    return [(float(length[i]), bool(from_border[i]), int(k[i]), tuple(gi), int(old_j[i]), tuple(oi))
            for i, gi, oi in zip(keep.tolist(), gxy, oxy)]


def _first_nearest(tree: shapely.STRtree, points: np.ndarray) -> np.ndarray:
    """Per point, the first of the tree's nearest geometries (``tree.query_nearest(p)[0]`` for each)."""
    if not len(points):
        return np.zeros(0, dtype=np.int64)
    source, hit = tree.query_nearest(points)
    first = np.unique(source, return_index=True)[1]
    return hit[first].astype(np.int64)


def _feet(lines: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Per line, the point nearest the point beside it (``line.interpolate(line.project(p))`` of each pair)."""
    return shapely.line_interpolate_point(lines, shapely.line_locate_point(lines, points))


def join_places(city: City, streets: Sequence, *, spacing: float, occupied: Occupied | None = None) -> np.ndarray:
    """Every place where :func:`join_growth` could join ``streets`` to the town, before joining them.

    The joins it reports (``JoinReport.at``) are nodes of the town's streets
    as mapped: where a new street ends on or passes through one, and the
    town's end of each joining street it adds. These are among the places
    given here: the new streets' points on a town street, and the town's end
    of every link :func:`join_to_town` would try (before it tests any for
    room, crossings or spread), with the town node it would snap to. So an
    acceptance rule that holds for more places whenever it holds for fewer,
    and rejects these, rejects whatever the joining would give: the district
    is known not to join without adding its streets to the network (the
    slow part of a join). Up to the millimetre the town's ways move by when
    the new streets' tees are inserted into them. Not listed (found in
    review, not met on the fixtures): a grown piece that lies along a town
    segment is dropped by the join before it links, so links near it may
    end at other town points; its own vertices are listed (on the town
    street), and two nearest new streets at one tie may be taken in
    another order.

    Parameters
    ----------
    city : City
        The town, without ``streets``.
    streets : sequence of :class:`synth.growth.NewStreet`-like objects
    spacing : float
        The town's junction spacing (m), as given to :func:`join_growth`.
    occupied : Occupied, optional
        The occupied land the join will read (:func:`occupied_near` of ``streets``): the links it blocks
        whatever their ends snap to (:func:`_blocked`) are left out, with their places. On Campo Grande's
        engine sites this told 34 of 60 grown districts unjoinable where the places alone told 12: the
        town's frontage stands between most of them and its streets.

    Returns
    -------
    (P, 2) float array, metres; empty when the streets meet no town street.
    """
    return join_candidates(city, streets, spacing=spacing).places(occupied)


@dataclass(frozen=True)
class JoinCandidates:
    """What :func:`join_places` finds before it reads the occupied land: the town's streets as lines, the new
    streets' points on them, and the links :func:`join_to_town` would try (:func:`_candidate_links`).

    Made once, asked for the places with and without the occupied land
    (:func:`osm_expand.district.place_district` asks both of every grown district, and found the candidate
    links twice).
    """

    old_lines: np.ndarray  #: (T,) LineStrings of the town's streets as mapped
    on_town: np.ndarray  #: (P, 2) the new streets' points on a town street, metres
    links: list  #: :func:`_candidate_links`' tuples

    def places(self, occupied: Occupied | None = None) -> np.ndarray:
        """:func:`join_places` with ``occupied``: (P, 2) float array, metres."""
        links = self.links
        places = [self.on_town]
        if links and occupied is not None:
            starts = np.array([g for *_, g, _j, _o in links])
            ends = np.array([o for *_, o in links])
            links = [link for link, blocked in zip(links, _blocked(starts, ends, occupied.geometry)) if not blocked]
        if links:
            ends = np.array([o for *_, o in links])
            places.append(ends)
            for (*_, j, _o), end in zip(links, ends):  # the town node a link's end snaps to (``_Board.snapped``)
                pts = shapely.get_coordinates(self.old_lines[j])
                d = np.hypot(*(pts - end).T)
                if d.min() <= SNAP + 0.01:
                    places.append(pts[d <= SNAP + 0.01])
        return np.concatenate(places).reshape(-1, 2)


def join_candidates(city: City, streets: Sequence, *, spacing: float) -> JoinCandidates:
    """The candidates of :func:`join_places` (which see), before any occupied land is read."""
    net = city.network
    old = [k for k, s in enumerate(net.streets) if s.origin == Origin.SOURCE]
    if not streets or not old:
        return JoinCandidates(np.empty(0, dtype=object), np.zeros((0, 2)), [])
    old_lines = net.street_lines()[old]
    new_xy = [np.asarray(s.xy, dtype=float) for s in streets]
    new_lines = linestrings_of(new_xy)
    vertices = np.concatenate(new_xy)
    on_town = shapely.STRtree(old_lines).query(shapely.points(vertices), predicate="dwithin",
                                               distance=10 * ON_STREET)[0]
    links = _candidate_links(new_lines.tolist(), old_lines.tolist(), _border(net, old), 2 * spacing, 2 * spacing,
                             longer=0.01)
    return JoinCandidates(old_lines, vertices[np.unique(on_town)], links)


#: Metres between the points of a link tested for occupied land (:func:`_blocked`): a coarser test misses some
#: blocked links (the join then tries them), never calls a link blocked that is not.
BLOCKED_STEP = 4.0


def _blocked(starts: np.ndarray, ends: np.ndarray, occupied: shapely.Geometry) -> np.ndarray:
    """Per link from ``starts`` to ``ends`` ((L, 2) arrays), whether occupied land blocks it wherever its ends
    snap to (:data:`SNAP`), so that :meth:`_Board.clear` refuses it.

    A snapped link runs within :data:`SNAP` of the link everywhere (its ends moved at most that far), so it
    meets occupied land when the link passes a point deeper than :data:`SNAP` inside it; the points tested
    keep ``2 × SNAP + 1`` m from the link's ends, so that the snapped link's nearest point is not within the
    1 m that :meth:`_Board.clear` leaves out at each end. Points every :data:`BLOCKED_STEP` m.
    """
    trim = 2.0 * SNAP + 1.0 + 0.01
    blocked = np.zeros(len(starts), dtype=bool)
    if not len(starts) or occupied.is_empty:
        return blocked
    along = ends - starts
    length = np.hypot(*along.T)
    count = np.maximum(np.floor((length - 2.0 * trim) / BLOCKED_STEP).astype(np.int64) + 1, 0)
    if not count.sum():
        return blocked
    owner = np.repeat(np.arange(len(starts)), count)
    nth = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    pts = starts[owner] + ((trim + nth * BLOCKED_STEP) / length[owner])[:, None] * along[owner]
    if shapely.get_type_id(occupied) not in (3, 6):  # a collection: its polygons are what blocks
        parts = shapely.get_parts(occupied)
        occupied = shapely.union_all(parts[np.isin(shapely.get_type_id(parts), (3, 6))])
    deep = shapely.contains_xy(occupied, pts[:, 0], pts[:, 1])
    if deep.any():
        edge = shapely.boundary(occupied)
        shapely.prepare(edge)
        deep[deep] = ~shapely.dwithin(edge, shapely.points(pts[deep]), SNAP + 0.01)
    blocked[owner[deep]] = True
    return blocked


def _shared_nodes(net: StreetNetwork, new: Sequence[int]) -> set[int]:
    """Nodes of the town on the new streets: where they are joined."""
    mine = set(new)
    old = {n for k, s in enumerate(net.streets) if k not in mine and s.origin == Origin.SOURCE for n in s.nodes}
    return {n for k in mine for n in net.streets[k].nodes} & old


def _report(net: StreetNetwork, new: Sequence[int], links: int, tees: int) -> JoinReport:
    shared = sorted(_shared_nodes(net, new))
    return JoinReport(joins=len(shared), links=links, tees=tees, at=net.xy[shared].reshape(-1, 2))
