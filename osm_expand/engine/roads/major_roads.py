"""Growing major roads (003 Algorithm 1, GROWMAJORROADS; 003 §3.4.2, 000 §4.2.7).

For a pair of neighbouring cities whose trade routes fell short this year:
re-route the shortfall over existing major roads with room, or build a new
road on the pathfinding graph G′ (the lattice with land, water and bridge
edges, the built-up area B removed, the streets stitched in) as the era's
road type — whichever scores less ``O3·length + O4·cost``
(:func:`osm_expand.engine.roads.routing.choose`). A new road's stretches join the
city as major streets (``primary``; a bypass ``trunk``), origin ``engine``,
built at once with the width A(t); the streets it runs along become major
and the extendible ones are widened to A(t). A rebuilding city road
demolishes the engine's own minor streets under it; the town as mapped is
never demolished.

The lattice (its rasters and bridges) is built once per run (it covers
the map's bounds); B and G′'s street part are rebuilt only in a year that
needs a road, so most years cost nothing here; a year's second pair on
the same city (the first was re-routed) gets the same G′ again, and a later
year with nothing built since (the same streets, blocks and B) gets the last
G′'s street part again with its own costs (:func:`_same_street_part`). G′ is implicit
(:class:`~osm_expand.engine.roads.path_graph.ImplicitGraph`): each search makes the
lattice's edges of the window it needs, and a re-route over major roads
makes none.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import shapely

from osm_expand.engine.history import History, YearValues
from osm_expand.engine.planarity import without_touching
from osm_expand.engine.roads.built_up import BuiltUpArea, built_up_area
from osm_expand.engine.roads.lattice import Lattice, Raster, build_lattice
from osm_expand.engine.roads.path_graph import (
    EdgeCosts,
    ImplicitGraph,
    ShellVerdicts,
    implicit_graph,
    lattice_verdicts,
    street_part_again,
)
from osm_expand.engine.roads.road_types import RoadType, plan_major_road, propose_route
from osm_expand.engine.roads.routing import Choice, choose, route_over_major_roads
from osm_expand.engine.traffic.simulation import TrafficMemory, follow, trade_major
from osm_expand.engine.traffic.trade import add_route, segment_capacity
from osm_expand.engine.traffic.trade_routes import route_between
from osm_expand.joins import add_streets
from osm_expand.land import UNBUILDABLE, building_outlines, matches
from osm_expand.model import City, Origin, Status
from osm_expand.model.highways import MAJOR
from osm_expand.model.segments import SegmentTable
from osm_expand.model.topology import without_segments

#: Highway class of a new major road by type: a bypass is a through road, the others town roads.
ROAD_CLASS = {RoadType.BYPASS: "trunk", RoadType.CITY: "primary", RoadType.SMOOTH_CITY: "primary",
              RoadType.REBUILDING_CITY: "primary"}
#: A reused minor street that becomes part of a major road is reclassified to this.
UPGRADED = "secondary"
#: Metres of land around the map's bounds the lattice covers.
LATTICE_MARGIN = 100.0
#: Cell (m) of the raster of forbidden land (unbuildable areas and buildings) the lattice samples:
#: fine enough that a house between two lattice vertices blocks the edge.
BUILDING_CELL = 5.0


class LastGraph(NamedTuple):
    """The last G′ and what it was made of (:attr:`RoadMemory.last`)."""

    city: City
    table: SegmentTable  #: the traffic's segment table
    now: YearValues
    history: History
    graph: ImplicitGraph


@dataclass
class RoadMemory:
    """What major-road building remembers from year to year."""

    lattice: Lattice | None = None
    built: BuiltUpArea | None = None
    #: the last G′'s shell-stitch verdicts: a stitch nothing changed near is not checked again
    verdicts: ShellVerdicts | None = None
    #: the last G′'s stitches to the lattice, filled as its windows were searched (its verdicts
    #: are the next G′'s, :func:`~osm_expand.engine.roads.path_graph.lattice_verdicts`)
    stitches: dict | None = None
    #: the last G′ and what it was made of: a second pair of the same year on the same city (the
    #: first was re-routed, nothing was built) gets that G′ again, with this call's capacities; a
    #: later year with nothing built since (the same street part, :func:`_same_street_part`) gets its
    #: street part again, with that year's costs (:func:`_graph`)
    last: LastGraph | None = field(default=None, repr=False, compare=False)


@dataclass(frozen=True)
class RoadsYear:
    """What the major-road step did in a year (sum them over an era)."""

    built: Counter = field(default_factory=Counter)  #: new roads by type (new stretches or minor streets made major)
    rerouted: int = 0
    bridges: int = 0
    length_m: float = 0.0  #: new stretches laid
    demolished: int = 0  #: engine-built segments a rebuilding road removed
    upgraded_m: float = 0.0  #: minor streets a new road runs along (they become major)
    #: "new roads" that lie wholly on major roads: all they do is widen the extendible ones to A(t)
    widened: int = 0

    def __add__(self, other: RoadsYear) -> RoadsYear:
        return RoadsYear(self.built + other.built, self.rerouted + other.rerouted, self.bridges + other.bridges,
                         self.length_m + other.length_m, self.demolished + other.demolished,
                         self.upgraded_m + other.upgraded_m, self.widened + other.widened)

    def to_dict(self) -> dict:
        return {"major_roads_built": {str(k): v for k, v in sorted(self.built.items())},
                "major_roads_widened": self.widened, "reroutes": self.rerouted, "bridges_built": self.bridges,
                "major_road_length_km": round(self.length_m / 1000, 3),
                "major_road_upgraded_km": round(self.upgraded_m / 1000, 3), "demolished_segments": self.demolished}


def major_roads_year(city: City, traffic: TrafficMemory, memory: RoadMemory, short: list[tuple[int, int]],
                     history: History, now: YearValues, rng: np.random.Generator, *, year: int, era: str,
                     most: int = 1) -> tuple[City, TrafficMemory, RoadMemory, RoadsYear, np.ndarray]:
    """Solve up to ``most`` short pairs: re-route or build. Returns the city, memories, counts and new junctions."""
    report = RoadsYear()
    junctions: list[np.ndarray] = []
    nodes = traffic.neighbours.exit_node
    todo = [p for p in short if nodes[p[0]] >= 0 and nodes[p[1]] >= 0 and nodes[p[0]] != nodes[p[1]]]
    for pair in todo[:most]:
        table = traffic.table
        demand = max(traffic.trade.demand.get(pair, 0.0) - traffic.trade.carried(pair), 1.0)
        graph, memory = _graph(city, traffic, memory, now, history)
        s, t = graph.node_vertex(int(nodes[pair[0]])), graph.node_vertex(int(nodes[pair[1]]))
        road_type = history.major_road_type(rng, now.year)
        reroute = route_over_major_roads(graph, s, t, demand=demand, options=now.routing)
        new = propose_route(graph, s, t, road_type, demand=demand, routing=now.routing,
                            options=history.options.major_roads)
        if choose(new, reroute, o3=now.o3, o4=now.o4) is Choice.REROUTE and reroute is not None:
            segs = np.unique(reroute.segment[reroute.segment >= 0])
            trade = add_route(traffic.trade, pair, segs, reroute.length, n_segments=len(table))
            traffic = replace(traffic, trade=trade)
            report = report + RoadsYear(rerouted=1)
            continue
        if new is None:
            continue
        plan = plan_major_road(graph, new, road_type, width=now.road_width, options=history.options.major_roads)
        known = {s.id for s in city.network.streets}
        city, made, upgraded = _apply(city, table, plan, year=year, era=era, old_town=history.rebuild_old_town)
        city, _ = without_touching(city, known)  # the road is noded into the streets it meets; a touch it missed goes
        traffic = follow(traffic, city)
        route = _route(traffic, city, int(nodes[pair[0]]), int(nodes[pair[1]]))
        if route is not None:
            traffic = replace(traffic, trade=add_route(traffic.trade, pair, route,
                                                       float(traffic.table.length[route].sum()),
                                                       n_segments=len(traffic.table)))
        junctions += [r.xy[0] for r in plan.new_roads] + [r.xy[-1] for r in plan.new_roads]
        # the city changed: G′ is made again next time, B grown from what it was
        length = sum(r.length for r in plan.new_roads)
        if length > 0 or upgraded > 0:
            report = report + RoadsYear(built=Counter({plan.road_type.value: 1}), bridges=plan.bridges,
                                        length_m=length, demolished=made, upgraded_m=upgraded)
        else:  # the cheapest route on G′ ran over major roads only: a widening, not a new road
            report = report + RoadsYear(widened=1, demolished=made)
    return city, traffic, memory, report, np.array(junctions).reshape(-1, 2)


def water_beyond_the_map(water: shapely.Geometry, bounds: tuple[float, float, float, float],
                         margin: float) -> shapely.Geometry:
    """``water`` carried on across the lattice's margin beyond the map's ``bounds``.

    The map stops at its bounds, the sea and the river do not: where water meets the edge of the
    map, it goes on outward by ``margin`` (and round a corner it fills). Left as land, the margin
    was a strip round the sea: Monaco's new road of a later year ran along the map's edge through
    it, round the whole bay.
    """
    if water.is_empty or margin <= 0:
        return water
    beyond = beyond_the_map(shapely.buffer(water, 1.0), bounds, margin)  # what reaches the edge within a metre
    return shapely.union_all([water, *beyond]) if beyond else water


def town_beyond_the_map(streets: np.ndarray, bounds: tuple[float, float, float, float], margin: float,
                        reach: float) -> shapely.Geometry:
    """The town carried on across the lattice's margin where its streets meet the map's ``bounds``.

    A clipped extract cuts the town's streets at its bounds; the town goes on beyond them. Where a
    street (a line of ``streets``) comes within ``reach`` of the edge, the edge is the town's for
    ``reach`` either side, and that stretch goes on outward by ``margin`` and inward by ``reach``.
    Left as free land, the margin was a corridor round the town: Campo Grande's new primary and
    trunk roads (3.2, 6.4 and 8.1 km) ran round its western and northern edges outside the map,
    beside the streets the clip cut. The strip inside is taken too: the clip leaves a street's
    last node up to a few metres short of the edge, and the land between it and the edge is the
    town's as much as the margin is.
    """
    if margin <= 0 or not len(streets):
        return shapely.Polygon()
    x0, y0, x1, y1 = map(float, bounds)
    inner = shapely.box(x0 + reach, y0 + reach, x1 - reach, y1 - reach) if min(x1 - x0, y1 - y0) > 2 * reach \
        else shapely.Polygon()
    near = streets[~shapely.within(streets, inner)] if not inner.is_empty else streets
    if not len(near):
        return shapely.Polygon()
    beyond = beyond_the_map(shapely.union_all(shapely.buffer(near, reach, quad_segs=2)), bounds, margin, reach)
    return shapely.union_all(beyond) if beyond else shapely.Polygon()


def beyond_the_map(ground: shapely.Geometry, bounds: tuple[float, float, float, float],
                   margin: float, inward: float = 0.0) -> list[shapely.Polygon]:
    """The stretches of the map's edge that ``ground`` covers, each carried outward by ``margin``
    (and inward by ``inward``).

    Round a corner the stretch runs on, so that no gap opens at the corner.
    """
    x0, y0, x1, y1 = map(float, bounds)
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    outward = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])  # below, right, above, left
    beyond = []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        along = (b - a) / max(float(np.hypot(*(b - a))), 1e-9)
        for part in shapely.get_parts(shapely.intersection(shapely.LineString([a, b]), ground)):
            coords = shapely.get_coordinates(part)
            if len(coords) < 2:
                continue
            start, end = coords[0], coords[-1]
            if np.dot(end - start, along) < 0:
                start, end = end, start
            # a stretch reaching a corner runs on round it, so that no gap opens at the corner
            start = start - along * margin if np.hypot(*(start - a)) < 1.0 else start
            end = end + along * margin if np.hypot(*(end - b)) < 1.0 else end
            out, back = outward[k] * margin, -outward[k] * inward
            beyond.append(shapely.Polygon([start + back, end + back, end + out, start + out]))
    return beyond


#: The entries of a :class:`SegmentTable`'s cache that depend on its ends alone (``xy``, ``uv``), which
#: :func:`_segments` leaves as they are: its lines, their keys and their tree.
_GEOMETRY_CACHE = ("lines", "end_keys", "tree")


def _segments(city: City, traffic: TrafficMemory, o2: float) -> SegmentTable:
    """The traffic's segment table with this year's major roads and trade capacity left.

    The lines, their keys and tree are made on the traffic's table and shared with the result (same
    ends): a year's calls with the same table (re-routes, years with nothing built: 8 of Campo
    Grande's 18 G′ calls) made them again for each new table, every call."""
    table = traffic.table
    cap = segment_capacity(table.width) * (o2 / 100.0)
    out = replace(table, major=trade_major(table, city), available=cap - traffic.trade.segment_traffic())
    table.lines()
    table.end_keys()
    out._cache.update({k: table._cache[k] for k in _GEOMETRY_CACHE if k in table._cache})
    return out


def _graph(city: City, traffic: TrafficMemory, memory: RoadMemory, now: YearValues, history: History):
    """This year's G′ (the lattice built once per run, B grown).

    A year's second short pair on the very same city (the first was re-routed: the city, its
    segment table, the year's values are the same objects) has the same G′ but for the trade
    capacity left on each segment: the last G′ is handed back with this call's segments, and its
    stitches checked so far with it (made again, they were the same). So does a later year in
    which no street was built since and B did not grow (:func:`_same_street_part`; on Campo
    Grande's default run 7 of 18 calls had the last call's segments).
    """
    if memory.lattice is None:
        x0, y0, x1, y1 = city.bounds_xy
        extent = (x0 - LATTICE_MARGIN, y0 - LATTICE_MARGIN, x1 + LATTICE_MARGIN, y1 + LATTICE_MARGIN)
        cell = history.options.lattice.spacing
        water = Raster.from_geometry(water_beyond_the_map(city.water_geometry(), city.bounds_xy, LATTICE_MARGIN),
                                     extent, cell)
        areas = [a.polygon for a in city.areas if matches(a.key, a.value, UNBUILDABLE)]
        # a new road never runs through a building as the outputs draw it (its minimum rectangle: a huge
        # mapped outline's rectangle reaches well past it, and Krems seed 1's new road ran through two)
        houses = building_outlines(city).tolist()
        # nor round the town outside the map, where the clip cut its streets (the town goes on there)
        town = town_beyond_the_map(city.network.street_lines(), city.bounds_xy, LATTICE_MARGIN,
                                   history.options.built_up.neighbourhood)
        areas += [] if town.is_empty else [town]
        forbidden = Raster.from_polygons(areas + houses, extent, BUILDING_CELL) if areas or houses else None
        # nor through the houses the map does not show (the town's presumed frontage), though it may leave a
        # street across them: withheld from Krems' file, 4 real buildings stood in a new primary road's way
        presumed = [] if city.land is None else city.land.presumed.tolist()
        memory = replace(memory, lattice=build_lattice(
            extent, water=water, forbidden=forbidden, options=history.options.lattice,
            stitch_only=Raster.from_polygons(presumed, extent, BUILDING_CELL) if presumed else None))
    segments = _segments(city, traffic, now.o2)
    made = memory.last
    if made is not None and all(a is b for a, b in zip((made.city, made.table, made.now, made.history),
                                                        (city, traffic.table, now, history))):
        last = made.graph
        return replace(last, segments=segments, streets=replace(last.streets, segments=segments)), memory
    built = built_up_area([b.polygon for b in city.blocks], segments, water=city.water_geometry(),
                          previous=memory.built, options=history.options.built_up)
    assert memory.lattice is not None  # built above on the first year
    # B did not grow (the very area of the last call): the lattice has it removed already
    grew = memory.built is None or built.area is not memory.built.area
    lattice = memory.lattice.with_built_up(built.area, built.added) if grew else memory.lattice
    if made is not None and _same_street_part(made.graph, lattice, built, segments, history):
        # a later year whose streets, blocks and B are as the last G′'s (no street was built since)
        last = made.graph
        costs = now.costs or EdgeCosts()
        graph = replace(last, segments=segments, costs=costs,
                        streets=street_part_again(last.streets, lattice, segments, costs))
        return graph, replace(memory, lattice=lattice, built=built, last=LastGraph(city, traffic.table, now, history,
                                                                                   graph))
    graph = implicit_graph(lattice, segments, built, costs=now.costs, options=history.options.graph,
                           previous=memory.verdicts,
                           previous_lattice=None if memory.stitches is None else lattice_verdicts(memory.stitches))
    return graph, replace(memory, lattice=lattice, built=built, verdicts=graph.streets.verdicts,
                          stitches=graph.stitches, last=LastGraph(city, traffic.table, now, history, graph))


def _same_street_part(last: ImplicitGraph, lattice: Lattice, built: BuiltUpArea, segments: SegmentTable,
                      history: History) -> bool:
    """Whether the G′ ``last`` has the street part this year's would but for the costs C1…C6
    (:func:`~osm_expand.engine.roads.path_graph.street_part_again`): the same lattice with B (the
    very object: B did not grow), the same built-up blocks (the very object: none came or went),
    the same options, and segments of the same ends, widths and harbours. Their capacity left is not
    read by the street part, nor which are major: only the pieces' kinds and weights, which
    :func:`street_part_again` works out again (Campo Grande's default run: one more of its 18 calls,
    a year that only made a street major, gets the last street part; the same street part)."""
    old = last.segments
    if (last.lattice is not lattice or last.streets.blocks is not built.blocks
            or last.options != history.options.graph or len(old) != len(segments)):
        return False
    same = all(np.array_equal(getattr(old, name), getattr(segments, name)) for name in ("xy", "uv", "width"))
    harbour = (old.harbour is None and segments.harbour is None) or (
        old.harbour is not None and segments.harbour is not None and np.array_equal(old.harbour, segments.harbour))
    return bool(same and harbour)


def _apply(city: City, table: SegmentTable, plan, *, year: int, era: str, old_town: bool = False
           ) -> tuple[City, int, float]:
    """The plan into the city: new stretches, upgraded and widened streets, demolitions; the demolished
    segments' count and the length (m) of the minor streets the road made major.

    A rebuilding road demolishes what the engine built under it; the town's own streets only when
    the history allows it (``old_town``: ``rebuild_old_town = true``)."""
    streets = list(city.network.streets)
    width = float(plan.width)
    reused = table.street[plan.reused].tolist()
    minor = np.array([streets[k].highway not in MAJOR for k in reused], dtype=bool)
    upgraded = float(table.length[plan.reused[minor]].sum())
    for k in set(reused):
        s = streets[k]
        highway = s.highway if s.highway in MAJOR else UPGRADED  # a major road as mapped keeps its class
        streets[k] = replace(s, highway=highway)
    for k in set(table.street[plan.widen].tolist()):
        streets[k] = replace(streets[k], width=max(width, streets[k].width or 0.0))
    gone = [int(g) for g in plan.demolished.tolist()
            if old_town or streets[table.street[g]].origin != Origin.SOURCE]
    if gone:
        drop = {(int(table.uv[g, 0]), int(table.uv[g, 1])) for g in gone}
        kept = without_segments(streets, drop)
        streets = list(kept)
    city = city.replace(network=city.network.replace(streets=tuple(streets)))
    highway = ROAD_CLASS[plan.road_type]
    attrs = [{"highway": highway, "hierarchy": 0, "origin": Origin.ENGINE, "status": Status.BUILT, "year": year,
              "era": era, "width": width, "bridge": r.bridge, "layer": 1 if r.bridge else 0} for r in plan.new_roads]
    return add_streets(city, [r.xy for r in plan.new_roads], attrs), len(gone), upgraded


def _route(traffic: TrafficMemory, city: City, a: int, b: int) -> np.ndarray | None:
    """The trade route between two exits over major roads now (the new road among them)."""
    table = traffic.table
    return route_between(table.uv, table.length, trade_major(table, city), a, b)
