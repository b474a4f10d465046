"""Building a new trade route as the era's kind of major road (seed 000 §4.2.7; 003 §3.4.2).

000 §4.2.7 names four major road types; an era says which it builds:

1. **bypass**: lattice edges and only some streets. 000 says streets
   "incident with two final or active blocks", which "forces it to sway away
   from streets on the inside of cities"; the two halves disagree, and the
   default follows the purpose: streets with at most one built-up side
   (country roads, the town's edge, existing bridges), never the town's
   inside (``bypass_streets = "interior"`` gives the literal reading);
2. **city road**: the route as found;
3. **smooth city road**: a city road found with a larger turn penalty
   (``smooth_turn_factor`` × S_p);
4. **rebuilding city road**: a city road that is smoothed *over* the minor
   streets it reuses and demolishes what lies under it (segments, lots); the
   crossings left behind heal as the town grows again.

Smoothing (000 §4.2.7): the polyline's consecutive pairs of segments
{l1, l2}, {l3, l4}, … each make a triangle whose centroid replaces it (the
ends stay), then Chaikin corner cutting. Junctions with major roads and
bridge ends are pinned: smoothing runs only between pinned points, which
are kept exactly. Lattice paths have long straight edges, so the polyline
is first resampled every ``smoothing_step`` metres: the centroids then cut
corners locally (by about a third of a step), not across a whole edge. A
smoothed stretch that would touch water or cross a street it must not falls
back to Chaikin alone, then to the path itself (which is valid by
construction).

After building, the extendible segments the road runs along are widened to
A(t) (003 §3.4.2). The result is a plain :class:`MajorRoadPlan`; the caller
applies it to the city model.

A year of the loop (003 Algorithm 2), for a pair of neighbouring cities whose
trade routes lack ``demand`` capacity, with this year's R(t) and O1…O4::

    lattice = build_lattice(extent, water=Raster.from_geometry(water, extent))  # once per map
    built = built_up_area(blocks, segments, water=water, previous=built)        # each year
    lattice = lattice.with_built_up(built.area)
    graph = pathfinding_graph(lattice, segments, built, costs=EdgeCosts(...))   # C1…C6
    s, t = graph.node_vertex(node_a), graph.node_vertex(node_b)
    reroute = route_over_major_roads(graph, s, t, demand=demand, options=turns)
    new = propose_route(graph, s, t, era_road_type, demand=demand, routing=turns)
    if choose(new, reroute, o3=o3, o4=o4) is Choice.NEW:
        plan = plan_major_road(graph, new, era_road_type, width=a_of_t, lots=lots)
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np
import shapely

from osm_expand.engine.roads.lattice import ROAD_KINDS, EdgeKind
from osm_expand.engine.roads.path_graph import ImplicitGraph, PathGraph
from osm_expand.engine.roads.routing import Route, RoutingOptions, find_route
from osm_expand.errors import InputError
from osm_expand.model.enums import parse_enum
from osm_expand.model.options import require_positive

__all__ = ["RoadType", "BypassStreets", "MajorRoadOptions", "NewRoad", "MajorRoadPlan", "parse_road_type",
           "allowed_streets", "capacity_ok", "propose_route", "plan_major_road", "smooth_polyline",
           "centroid_smoothing", "chaikin", "max_turn"]


class RoadType(StrEnum):
    """The four major road types of 000 §4.2.7."""

    BYPASS = "bypass"
    CITY = "city"
    SMOOTH_CITY = "smooth_city"
    REBUILDING_CITY = "rebuilding_city"


class BypassStreets(StrEnum):
    """Which existing streets a bypass may run along."""

    INTERIOR = "interior"  #: 000's words: streets with a built-up block on both sides
    EXTERIOR = "exterior"  #: streets with at most one built-up side (country roads, the town's edge)
    NONE = "none"  #: no existing street


def parse_road_type(value: str) -> RoadType:
    """A :class:`RoadType` from its name; :class:`InputError` listing the valid ones otherwise."""
    return parse_enum(RoadType, value, "road type")


@dataclass(frozen=True)
class MajorRoadOptions:
    """Tunables of building major roads (000 §4.2.7; the seeds give no numbers)."""

    #: × S_p(t) for a smooth city road (000: "extra penalties for sharp curves")
    smooth_turn_factor: float = 3.0
    #: BypassStreets: which streets a bypass may use. 000 §4.2.7's words ("streets incident with
    #: two final or active blocks") read literally are "interior", but its purpose ("forces it
    #: to sway away from streets on the inside of cities") and Krems (an interior-only bypass
    #: cannot reuse the Danube bridges, so it builds its own) favour "exterior"
    bypass_streets: str = "exterior"
    smoothing_step: float = 40.0  #: m, resampling before smoothing (2ℓ: corners cut by ~13 m)
    chaikin_iterations: int = 2  #: 000: Chaikin "to somewhat smoothen the result"
    #: m, smoothed polylines are thinned (Douglas–Peucker) within this: fewer shape points,
    #: which 000 §4.2.7 wants so that streets may later join the road
    simplify_tolerance: float = 0.5
    demolish_margin: float = 2.0  #: m beyond half the road's width that a rebuilding road clears
    water_routes: bool = False  #: allow waterways and harbours (trade by boat; not a road)

    def __post_init__(self) -> None:
        require_positive(self, ("smoothing_step",))
        if not (self.smooth_turn_factor >= 1.0 and self.demolish_margin >= 0):
            raise InputError("MajorRoadOptions: smooth_turn_factor must be ≥ 1 and demolish_margin not negative")
        if self.chaikin_iterations < 0:
            raise InputError("MajorRoadOptions.chaikin_iterations must not be negative")
        parse_enum(BypassStreets, self.bypass_streets, "MajorRoadOptions.bypass_streets")


@dataclass(frozen=True)
class NewRoad:
    """One new stretch of road: a polyline between two attachment points.

    An end is an existing street node (``*_node``), a point inside an
    existing segment that must be split there (``*_segment``), or neither
    (a point shared with the neighbouring new stretch, e.g. a bridge end).
    """

    xy: np.ndarray  #: (M, 2) m
    bridge: bool
    start_node: int = -1
    end_node: int = -1
    start_segment: int = -1
    end_segment: int = -1

    @property
    def length(self) -> float:
        return float(np.hypot(*np.diff(self.xy, axis=0).T).sum())


@dataclass(frozen=True)
class MajorRoadPlan:
    """What building a route changes; the caller applies it to the city model."""

    road_type: RoadType
    width: float  #: m, A(t): the width of new stretches and of widened segments
    new_roads: tuple[NewRoad, ...]  #: new stretches, in route order
    #: (k,) segment ids the road runs along, in route order (they become major). Where a new
    #: stretch joins a segment inside (NewRoad.*_segment) the road follows only part of it
    reused: np.ndarray
    widen: np.ndarray  #: (w,) extendible reused segments narrower than ``width``
    demolished: np.ndarray  #: (d,) segment ids removed (rebuilding city road)
    demolished_lots: np.ndarray  #: (l,) lot indices removed (rebuilding city road)
    route: Route = field(repr=False)

    @property
    def bridges(self) -> int:
        return sum(r.bridge for r in self.new_roads)


def allowed_streets(graph: PathGraph | ImplicitGraph, road_type: RoadType | str, *,
                    options: MajorRoadOptions | None = None) -> np.ndarray | None:
    """Which segments a road of this type may run along (000 §4.2.7).

    Parameters
    ----------
    graph
        G′ (for which segments are extendible).
    road_type
        :class:`RoadType`; only a bypass is restricted.
    options
        ``bypass_streets`` of :class:`MajorRoadOptions`.

    Returns
    -------
    numpy.ndarray or None
        ``(S,)`` bool, or None when every segment may be used.
    """
    opts = options or MajorRoadOptions()
    if parse_road_type(road_type) is not RoadType.BYPASS:
        return None
    which = parse_enum(BypassStreets, opts.bypass_streets, "MajorRoadOptions.bypass_streets")
    if which is BypassStreets.INTERIOR:
        return ~graph.extendible
    if which is BypassStreets.EXTERIOR:
        return graph.extendible.copy()
    return np.zeros(len(graph.extendible), dtype=bool)


def propose_route(graph: PathGraph | ImplicitGraph, source: int, target: int, road_type: RoadType | str, *,
                  demand: float = 0.0,
                  routing: RoutingOptions | None = None, options: MajorRoadOptions | None = None) -> Route | None:
    """PROPOSEFROMNEW (003 §3.4.2) for a road type: the turn-penalised route on G′.

    Parameters
    ----------
    graph
        G′ of this year.
    source, target
        G′ vertices.
    road_type
        :class:`RoadType`; decides the usable streets and the turn penalty.
    demand
        The traffic the route must carry: a street is usable if its
        ``available`` capacity suffices or it is extendible (000 §4.2.8:
        streets beside at most one built-up block can be widened, so their
        capacity is unlimited).
    routing
        The turn penalty P(t, α) of this year.
    options
        :class:`MajorRoadOptions`.

    Returns
    -------
    Route or None
    """
    opts = options or MajorRoadOptions()
    kind = parse_road_type(road_type)
    routing = routing or RoutingOptions()
    if kind is RoadType.SMOOTH_CITY:
        routing = replace(routing, turn_height=routing.turn_height * opts.smooth_turn_factor)
    kinds = list(ROAD_KINDS)
    if opts.water_routes:
        kinds += [EdgeKind.WATER, EdgeKind.HARBOUR, EdgeKind.BUILT_HARBOUR]
    usable = capacity_ok(graph, demand)
    allowed = allowed_streets(graph, kind, options=opts)
    street_ok = usable if allowed is None else usable & allowed
    return find_route(graph, source, target, kinds=kinds, street_ok=street_ok, options=routing)


def capacity_ok(graph: PathGraph | ImplicitGraph, demand: float) -> np.ndarray:
    """SegmentTable that can carry ``demand`` more traffic (000 §4.2.8).

    Parameters
    ----------
    graph
        G′ (segments with ``available`` capacity, and which are extendible).
    demand
        Traffic units.

    Returns
    -------
    numpy.ndarray
        ``(S,)`` bool: ``available ≥ demand``, or extendible (can be widened).
    """
    segs = graph.segments
    if segs.available is None:
        return np.ones(len(segs.uv), dtype=bool)
    return graph.extendible | (segs.available >= demand)


# ---------------------------------------------------------------- smoothing


def centroid_smoothing(xy: np.ndarray) -> np.ndarray:
    """000 §4.2.7: pairs of consecutive segments become their triangle's centroid; ends stay.

    Parameters
    ----------
    xy
        ``(M, 2)`` polyline of n = M − 1 segments, metres.

    Returns
    -------
    numpy.ndarray
        ``(⌊n/2⌋ + 2, 2)``: the first point, one centroid per pair
        {l1, l2}, {l3, l4}, …, the last point (an odd last segment is in no pair).

    >>> centroid_smoothing(np.array([[0., 0.], [3., 3.], [6., 0.]])).tolist()
    [[0.0, 0.0], [3.0, 1.0], [6.0, 0.0]]
    """
    n = len(xy) - 1
    if n < 2:
        return xy.copy()
    k = np.arange(n // 2)
    centroids = (xy[2 * k] + xy[2 * k + 1] + xy[2 * k + 2]) / 3.0
    return np.concatenate([xy[:1], centroids, xy[-1:]])


def chaikin(xy: np.ndarray, iterations: int) -> np.ndarray:
    """Chaikin corner cutting: each segment gives its quarter points; both ends stay.

    Parameters
    ----------
    xy
        ``(M, 2)`` polyline, metres.
    iterations
        How many times to cut.

    Returns
    -------
    numpy.ndarray
        The polyline; each iteration turns M points into 2M − 2.

    >>> chaikin(np.array([[0., 0.], [4., 0.], [4., 4.]]), 1).tolist()
    [[0.0, 0.0], [3.0, 0.0], [4.0, 1.0], [4.0, 4.0]]
    """
    for _ in range(iterations):
        if len(xy) < 3:
            break
        a, b = xy[:-1], xy[1:]
        cut = np.stack([0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b], axis=1).reshape(-1, 2)
        xy = np.concatenate([xy[:1], cut[1:-1], xy[-1:]])
    return xy


def _resample(xy: np.ndarray, step: float) -> np.ndarray:
    """Points every ≤ ``step`` m along each segment (the original vertices kept)."""
    seg = np.diff(xy, axis=0)
    count = np.maximum(np.ceil(np.hypot(*seg.T) / step).astype(np.int64), 1)
    t = np.concatenate([np.arange(c) / c for c in count.tolist()])
    start = np.repeat(np.arange(len(seg)), count)
    return np.concatenate([xy[start] + t[:, None] * seg[start], xy[-1:]])


def _simplified(xy: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas–Peucker within ``tolerance`` m; the ends stay."""
    if len(xy) < 3 or tolerance <= 0:
        return xy
    out = shapely.get_coordinates(shapely.simplify(shapely.LineString(xy), tolerance))
    out[0], out[-1] = xy[0], xy[-1]
    return out


def _turns(xy: np.ndarray) -> np.ndarray:
    """Turning angle (radians, 0 = straight) at each interior vertex."""
    d = np.diff(xy, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    return np.abs((np.diff(heading) + np.pi) % (2.0 * np.pi) - np.pi)


def max_turn(xy: np.ndarray) -> float:
    """The sharpest turn of a polyline, radians (0 for fewer than three points)."""
    return float(_turns(xy).max()) if len(xy) >= 3 else 0.0


def smooth_polyline(xy: np.ndarray, pinned: np.ndarray, *, step: float = 40.0, iterations: int = 2,
                    tolerance: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Smooth a polyline between its pinned points (000 §4.2.7).

    Parameters
    ----------
    xy
        ``(M, 2)`` polyline, metres.
    pinned
        ``(M,)`` bool; both ends count as pinned. Pinned points are kept exactly.
    step
        Resampling distance (m) before the centroid pass.
    iterations
        Chaikin iterations after the centroid pass.
    tolerance
        Metres; the smoothed polyline is thinned (Douglas–Peucker) within this.

    Returns
    -------
    (xy, pinned)
        The smoothed polyline and which of its points are the pinned ones.
    """
    xy = np.asarray(xy, dtype=float)
    pins = np.asarray(pinned, dtype=bool).copy()
    if len(xy) < 3:
        return xy.copy(), np.ones(len(xy), dtype=bool)
    pins[0] = pins[-1] = True
    at = np.flatnonzero(pins)
    parts, flags = [xy[:1]], [np.array([True])]
    for a, b in zip(at[:-1], at[1:]):
        run = _simplified(chaikin(centroid_smoothing(_resample(xy[a:b + 1], step)), iterations), tolerance)
        parts.append(run[1:])
        flag = np.zeros(len(run) - 1, dtype=bool)
        flag[-1] = True
        flags.append(flag)
    return np.concatenate(parts), np.concatenate(flags)


# ---------------------------------------------------------------- building


def plan_major_road(graph: PathGraph | ImplicitGraph, route: Route, road_type: RoadType | str, width: float, *,
                    lots: np.ndarray | None = None, options: MajorRoadOptions | None = None) -> MajorRoadPlan:
    """Turn a route on G′ into new roads, upgrades, widenings and demolitions (000 §4.2.7).

    Parameters
    ----------
    graph
        The G′ the route was found on.
    route
        From :func:`propose_route` (or :func:`osm_expand.engine.roads.routing.find_route`).
    road_type
        :class:`RoadType` of this era.
    width
        A(t), metres: width of the new stretches; extendible reused segments
        narrower than this are widened to it (003 §3.4.2).
    lots
        Lot polygons (shapely, m), for what a rebuilding city road demolishes.
    options
        :class:`MajorRoadOptions`.

    Returns
    -------
    MajorRoadPlan
    """
    opts = options or MajorRoadOptions()
    kind = parse_road_type(road_type)
    if not width > 0:
        raise InputError(f"plan_major_road: width must be positive, got {width}")
    segs = graph.segments
    rebuild = kind is RoadType.REBUILDING_CITY
    # per edge: an existing street kept as it is, a new bridge, or new road; a rebuilding
    # road keeps only the major roads and bridges it follows and rebuilds over minor streets
    street = route.segment >= 0
    kept = street.copy()
    if rebuild:
        seg = np.maximum(route.segment, 0)
        kept &= segs.major[seg] | segs.bridge[seg]
    bridge = route.kind == EdgeKind.BRIDGE
    # a new stretch ends at every street point it meets (a junction), except that a
    # rebuilding road runs on over the minor streets it replaces
    junction = route.vertices >= graph.n_lattice
    reused = _unique_in_order(route.segment[kept])
    new_roads: list[NewRoad] = []
    demolished = np.zeros(0, dtype=np.int64)
    edge = 0
    while edge < len(route.kind):
        if kept[edge]:
            edge += 1
            continue
        end = edge + 1
        if not bridge[edge]:
            while end < len(route.kind) and not kept[end] and not bridge[end] and (rebuild or not junction[end]):
                end += 1
        xy = route.xy[edge:end + 1]
        if not bridge[edge]:
            pins = _pins(graph, route, edge, end) if rebuild else np.zeros(len(xy), dtype=bool)
            xy = _smoothed(graph, xy, pins, rebuild, opts)
        new_roads.append(_new_road(graph, route.vertices[edge], route.vertices[end], xy, bool(bridge[edge])))
        edge = end
    demolished_lots = np.zeros(0, dtype=np.int64)
    if rebuild and any(not r.bridge for r in new_roads):
        demolished, demolished_lots = _demolition(graph, new_roads, width, lots, opts)
    widen = reused[graph.extendible[reused] & (segs.width[reused] < width)] if len(reused) else reused
    return MajorRoadPlan(road_type=kind, width=float(width), new_roads=tuple(new_roads), reused=reused, widen=widen,
                         demolished=demolished, demolished_lots=demolished_lots, route=route)


def _unique_in_order(values: np.ndarray) -> np.ndarray:
    if not len(values):
        return np.zeros(0, dtype=np.int64)
    _, first = np.unique(values, return_index=True)
    return values[np.sort(first)].astype(np.int64)


def _pins(graph: PathGraph | ImplicitGraph, route: Route, start: int, end: int) -> np.ndarray:
    """Inside a rebuilt stretch: street nodes where a major road the route does not follow meets it."""
    segs = graph.segments
    node = route.vertices[start:end + 1] - graph.n_lattice
    is_node = (node >= 0) & (node < len(segs.xy))
    major = np.flatnonzero(segs.major)
    crossing = major[~np.isin(major, route.segment)]  # major roads the route does not run along
    return is_node & np.isin(node, segs.uv[crossing].ravel())


def _smoothed(graph: PathGraph | ImplicitGraph, xy: np.ndarray, pins: np.ndarray, rebuild: bool,
              opts: MajorRoadOptions) -> np.ndarray:
    """The smoothest of (centroid + Chaikin, Chaikin, as found) that stays dry and crosses no street
    it must not (for a rebuilding road: no major road or bridge away from its pins)."""
    tries = [smooth_polyline(xy, pins, step=opts.smoothing_step, iterations=opts.chaikin_iterations,
                             tolerance=opts.simplify_tolerance)[0]]
    pinned = pins.copy()
    pinned[0] = pinned[-1] = True
    at = np.flatnonzero(pinned)
    tries.append(np.concatenate([xy[:1]] + [chaikin(_resample(xy[a:b + 1], opts.smoothing_step),
                                                    opts.chaikin_iterations)[1:] for a, b in zip(at[:-1], at[1:])]))
    for candidate in tries:
        if _acceptable(graph, candidate, xy[pinned], rebuild):
            return candidate
    return xy.copy()


def _acceptable(graph: PathGraph | ImplicitGraph, xy: np.ndarray, pinned_xy: np.ndarray, rebuild: bool) -> bool:
    lattice = graph.lattice
    dense = _resample(xy, lattice.fine_step)
    if lattice.fine_lookup(lattice.water | lattice.forbidden, dense).any():
        return False
    segs = graph.segments
    if not len(segs.uv):
        return True
    line = shapely.LineString(xy)
    hits = segs.tree().query(line, predicate="intersects")
    if rebuild:
        hits = hits[segs.major[hits] | segs.bridge[hits]]
    if not len(hits):
        return True
    # touching streets is allowed only at the pinned points (the ends, junctions)
    where = shapely.intersection(segs.lines()[hits], line)
    points = shapely.get_coordinates(where)
    if not len(points):
        return True
    near = np.min(np.hypot(*(points[:, None, :] - pinned_xy[None, :, :]).transpose(2, 0, 1)), axis=1)
    return bool((near < 1e-6 + 0.01).all())


def _new_road(graph: PathGraph | ImplicitGraph, start: int, end: int, xy: np.ndarray, bridge: bool) -> NewRoad:
    def attach(vertex: int) -> tuple[int, int]:
        rel = vertex - graph.n_lattice
        if rel < 0:
            return -1, -1
        if rel < len(graph.segments.xy):
            return rel, -1
        return -1, int(graph.split_segment[rel - len(graph.segments.xy)])

    (sn, ss), (en, es) = attach(int(start)), attach(int(end))
    return NewRoad(xy=xy, bridge=bridge, start_node=sn, end_node=en, start_segment=ss, end_segment=es)


def _along(segs, roads: list[NewRoad], tolerance: float = 1.0) -> np.ndarray:
    """Minor, non-bridge segments the road runs along end to end (both ends within ``tolerance`` m of
    it): short ones lie wholly in the discs the corridor leaves out, yet the road replaces them."""
    line = shapely.union_all([shapely.LineString(r.xy) for r in roads])
    near = segs.tree().query(line, predicate="dwithin", distance=tolerance)
    near = near[~segs.major[near] & ~segs.bridge[near]]
    a, b = shapely.points(segs.xy[segs.uv[near, 0]]), shapely.points(segs.xy[segs.uv[near, 1]])
    on = (shapely.distance(a, line) <= tolerance) & (shapely.distance(b, line) <= tolerance)
    return np.sort(near[on]).astype(np.int64)


def _demolition(graph: PathGraph | ImplicitGraph, roads: list[NewRoad], width: float, lots: np.ndarray | None,
                opts: MajorRoadOptions) -> tuple[np.ndarray, np.ndarray]:
    """Minor, non-bridge segments and lots under a rebuilding road's corridor (000 §4.2.7).

    The corridor is the road buffered by half its width plus a margin, less a
    disc of that radius around each end: the streets that meet the road
    where it is pinned (junctions with major roads, bridge ends, the ends of
    the route) are not in its way.
    """
    half = 0.5 * width + opts.demolish_margin
    pieces = [r for r in roads if not r.bridge]
    ends = shapely.points(np.concatenate([r.xy[[0, -1]] for r in pieces]))
    corridor = shapely.difference(
        shapely.union_all([shapely.buffer(shapely.LineString(r.xy), half, cap_style="flat") for r in pieces]),
        shapely.union_all(shapely.buffer(ends, half)))
    segs = graph.segments
    gone = np.zeros(0, dtype=np.int64)
    if len(segs.uv) and not corridor.is_empty:
        hit = segs.tree().query(corridor, predicate="intersects")
        hit = hit[~segs.major[hit] & ~segs.bridge[hit]]
        inside = shapely.length(shapely.intersection(segs.lines()[hit], corridor))
        gone = np.sort(hit[inside > 1.0]).astype(np.int64)  # more than grazing its edge
        gone = np.union1d(gone, _along(segs, pieces))
    lots_gone = np.zeros(0, dtype=np.int64)
    if lots is not None and len(lots) and not corridor.is_empty:
        lots_gone = np.sort(shapely.STRtree(np.asarray(lots)).query(corridor, predicate="intersects")).astype(np.int64)
    return gone, lots_gone
