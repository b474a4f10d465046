"""The year's traffic (003 Algorithm 1, TRAFFICSIMULATION; 002 §3.2): trips, trade, status, widths.

- **Trips inside the town** (002 §3.2, :mod:`osm_expand.engine.traffic.trips`):
  residents per street (from the lots' people once there are lots, else
  block area × a density, shared by the block's sides), gravity
  destinations, travel times with turn costs; new and changed streets and a
  share of the rest are re-sampled each year.
- **Status and widths**: a planned street is built when its traffic passes
  the threshold; widths follow traffic after a delay (002).
- **Trade between neighbouring cities** (003 §3.4, Algorithm 2,
  :mod:`osm_expand.engine.traffic.trade`): the yearly increase t(t) − t(t−1) per
  pair is distributed over the pair's trade routes by length; pairs that
  fall short are handed to the major-road step
  (:mod:`osm_expand.engine.roads.major_roads`), which re-routes them over major roads
  with room or builds a new road. The trade step runs over *all* pairs
  first and the major roads are built after it (not inside Algorithm 2's
  loop), so the segment table stays fixed during the pass.

Neighbouring cities come from where the real town's major roads leave the
map (:mod:`osm_expand.engine.traffic.neighbours`); for trade routes, tertiary roads
and all links count as major roads too (the issue's towns join their exits
over them). Only pairs that trade by road are simulated: a neighbour
reached over water (a river or the sea leaving the map) trades by ship,
and its land leg inside the town is not modelled, so it never asks for a
road.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from osm_expand.engine.traffic.neighbours import Neighbours, initial_pairs, neighbour_cities
from osm_expand.engine.traffic.trade import (
    TradeState,
    TradeYear,
    extend_segments,
    remap_segments,
    segment_capacity,
    trade_report,
    trade_year,
)
from osm_expand.engine.traffic.trade_routes import initial_trade_state
from osm_expand.engine.traffic.trips import (
    TripGraph,
    TripOptions,
    TripState,
    extend_trip_state,
    new_trip_state,
    remap_trip_state,
    residents_from_blocks,
    step_trips,
    trip_graph,
    update_status,
    update_widths,
)
from osm_expand.model import City, Status, match_points
from osm_expand.model.highways import TRADE
from osm_expand.model.network import pair_keys
from osm_expand.model.segments import SegmentTable, segment_pieces

#: Highway classes a trade route may use (the model's named set).
TRADE_CLASSES = TRADE


@dataclass
class TrafficMemory:
    """What traffic remembers from year to year (not part of the city)."""

    table: SegmentTable  #: the segment table the states below are indexed by
    trips: TripState
    graph: TripGraph | None
    neighbours: Neighbours
    pairs: np.ndarray  #: (P, 2) neighbour pairs that trade
    trade: TradeState
    pending: dict[int, int] = field(default_factory=dict)  #: street id → year its width began to wait
    first: bool = True
    people: tuple = ()  #: (blocks, lots, segments, people per segment): the last residents, kept while those hold


@dataclass(frozen=True)
class TrafficYear:
    trips: int = 0
    people: float = 0.0
    built: int = 0  #: planned streets built this year
    widened: int = 0
    trade: TradeYear = field(default_factory=TradeYear)
    #: Trade routes over a segment carrying more than O2·width (Algorithm 2 never overloads one: this
    #: counts what narrowing streets or growing demand left over capacity), at the worst year
    routes_over_capacity: int = 0
    #: Trade routes with no capacity left (T_A(P) ≤ 0, 003 §3.4.2): where capacity ran out, at the worst year
    routes_at_capacity: int = 0

    def __add__(self, other: TrafficYear) -> TrafficYear:
        return TrafficYear(self.trips + other.trips, self.people + other.people, self.built + other.built,
                           self.widened + other.widened, self.trade + other.trade,
                           max(self.routes_over_capacity, other.routes_over_capacity),
                           max(self.routes_at_capacity, other.routes_at_capacity))

    def to_dict(self) -> dict:
        return {"trips": self.trips, "people_per_day": round(self.people), "streets_built": self.built,
                "streets_widened": self.widened, "trade_pairs_short": self.trade.short,
                "trade_routes_added": self.trade.routes_added, "routes_over_capacity": self.routes_over_capacity,
                "routes_at_capacity": self.routes_at_capacity}


def trade_major(table: SegmentTable, city: City) -> np.ndarray:
    """Segments a trade route may use."""
    cls = np.array([s.highway in TRADE_CLASSES for s in city.network.streets], dtype=bool)
    return cls[table.street] if len(table) else np.zeros(0, dtype=bool)


def start_traffic(city: City, rng: np.random.Generator) -> TrafficMemory:
    """Neighbouring cities, their pairs and first trade routes over the real major roads (003 §3.2)."""
    table = SegmentTable.from_city(city)
    highway = np.array([city.network.streets[k].highway for k in table.street.tolist()])
    bounds = city.bounds_xy
    neighbours = neighbour_cities(table.xy, table.uv, highway, bounds, rng, water=[*city.water, *city.sea])
    pairs = np.asarray(initial_pairs(neighbours, rng)).reshape(-1, 2)
    by_road = neighbours.exit_node[pairs].min(axis=1) >= 0 if len(pairs) else np.zeros(0, dtype=bool)
    pairs = pairs[by_road & (neighbours.exit_node[pairs[:, 0]] != neighbours.exit_node[pairs[:, 1]])]
    trade, _ = initial_trade_state(table.uv, table.length, trade_major(table, city), neighbours.exit_node, pairs)
    return TrafficMemory(table=table, trips=new_trip_state(len(table)), graph=None, neighbours=neighbours,
                         pairs=np.asarray(pairs).reshape(-1, 2), trade=trade)


def follow(memory: TrafficMemory, city: City) -> TrafficMemory:
    """The memory re-indexed by the city's current segment table (streets added, split or removed)."""
    new = SegmentTable.from_city(city)
    old = memory.table
    if len(new) == len(old) and np.array_equal(new.uv, old.uv):
        return memory
    if len(new) > len(old) and np.array_equal(new.uv[:len(old)], old.uv):
        trips, trade = extend_trip_state(memory.trips, len(new)), extend_segments(memory.trade, len(new))
    else:
        pieces = segment_pieces(old, new, city)
        trips, trade = remap_trip_state(memory.trips, pieces, len(new)), remap_segments(memory.trade, pieces, len(new))
    return replace(memory, table=new, trips=trips, trade=trade)


def residents(city: City, table: SegmentTable, options: TripOptions) -> np.ndarray:
    """People per segment: from the lots when there are some, else block area × density."""
    if city.lots:
        people = _lot_people(city, table)
        if people.sum() > 0:
            return people
    rings = [np.asarray(b.polygon.exterior.coords) for b in city.blocks]
    if not rings or not len(table):
        return np.zeros(len(table))
    owner = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    nodes = match_points(np.concatenate(rings), table.xy)
    a, b = nodes[:-1], nodes[1:]
    same = (owner[:-1] == owner[1:]) & (a >= 0) & (b >= 0)
    segment = _segment_lookup(table, a[same], b[same])
    block = owner[:-1][same]
    ok = segment >= 0
    block, segment = block[ok], segment[ok]
    areas = np.array([blk.polygon.area for blk in city.blocks])
    order = np.argsort(block, kind="stable")
    sides = np.split(segment[order], np.cumsum(np.bincount(block, minlength=len(rings)))[:-1])
    return residents_from_blocks(areas, sides, table.length, options=options)


def _segment_lookup(table: SegmentTable, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The segment joining nodes a[i] and b[i] (either direction), or -1."""
    keys = pair_keys(table.uv[:, 0], table.uv[:, 1])
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    want = pair_keys(a, b)
    at = np.clip(np.searchsorted(sorted_keys, want), 0, max(len(keys) - 1, 0))
    found = sorted_keys[at] == want if len(keys) else np.zeros(len(want), dtype=bool)
    return np.where(found, order[at], -1)


def _lot_people(city: City, table: SegmentTable) -> np.ndarray:
    """The lots' people on the middle segment of the street each lot faces.

    All lots at once: a street's segments in table order, its middle one
    (``segments[len // 2]``) by a stable sort; the people summed per segment
    in the lots' order, as one by one.
    """
    people = np.zeros(len(table))
    if not city.lots or not len(table):
        return people
    order = np.argsort(table.street_id, kind="stable")  # each street's segments, in table order
    ids, start, count = np.unique(table.street_id[order], return_index=True, return_counts=True)
    middle = order[start + count // 2]
    street = np.array([-1 if lot.street is None else lot.street for lot in city.lots], dtype=np.int64)
    at = np.minimum(np.searchsorted(ids, street), len(ids) - 1)
    found = (ids[at] == street) & np.array([lot.street is not None for lot in city.lots], dtype=bool)
    weights = np.array([lot.people for lot in city.lots], dtype=np.float64)[found]
    return np.bincount(middle[at[found]], weights=weights, minlength=len(table)).astype(np.float64)


def traffic_year(city: City, memory: TrafficMemory, rng: np.random.Generator, *, year: int, increase: float,
                 o2: float, options: TripOptions) -> tuple[City, TrafficMemory, TrafficYear, list[tuple[int, int]]]:
    """One year of trips, status, widths and trade; the pairs whose trade routes fell short."""
    memory = follow(memory, city)
    table = memory.table
    graph = trip_graph(table.xy, table.uv, length=table.length, major=table.major, previous=memory.graph,
                       options=options)
    key = (city.blocks, city.lots, len(table))
    if memory.people[:3] != key or memory.people[0] is not city.blocks or memory.people[1] is not city.lots:
        memory = replace(memory, people=(*key, residents(city, table, options)))
    trips, report = step_trips(memory.trips, graph, memory.people[3], rng, full=memory.first, options=options)
    city, built, widened, pending = _streets_follow_traffic(city, table, trips.traffic, memory.pending, year, options)
    cap = segment_capacity(table.width) * (o2 / 100.0)
    trade, cap, counts = trade_year(memory.trade, memory.pairs, increase, cap)
    keys = [(int(min(p)), int(max(p))) for p in memory.pairs]
    short = [k for k in keys if trade.demand.get(k, 0.0) > trade.carried(k) + 1e-6]
    capacity = trade_report(trade, cap)
    memory = replace(memory, trips=trips, graph=graph, trade=trade, pending=pending, first=False)
    year_report = TrafficYear(trips=report.trips, people=report.people, built=built, widened=widened, trade=counts,
                              routes_over_capacity=capacity.routes_over_capacity,
                              routes_at_capacity=capacity.routes_at_capacity)
    return city, memory, year_report, short


def _streets_follow_traffic(city: City, table: SegmentTable, traffic: np.ndarray, pending: dict[int, int],
                            year: int, options: TripOptions) -> tuple[City, int, int, dict[int, int]]:
    """Planned streets with traffic are built; widths follow traffic after the delay (002 §2, §3.2)."""
    streets = list(city.network.streets)
    n = len(streets)
    per_street = table.per_street(traffic, n, "max")
    built = np.array([s.status == Status.BUILT for s in streets])
    built_year = np.array([s.year if s.year is not None else -1 for s in streets], dtype=np.int64)
    now_built, now_year = update_status(built, per_street, built_year, year=year, options=options)
    width = table.per_street(table.width, n, "max")
    major = table.per_street(table.major.astype(float), n, "max") > 0
    since = np.array([pending.get(s.id, -1) for s in streets], dtype=np.int64)
    now = now_built & ~built  # planned streets built this year
    old_year = np.where(now, now_year, np.minimum(built_year, year - 1))
    new_width, since = update_widths(width, per_street, now_built, old_year, since, year=year, major=major,
                                     options=options)
    changed_status = int(now.sum())
    # only the streets whose status or width changes are visited (the loop over every street and its numpy
    # scalars was a quarter of this step on Campo Grande; a year changes a few)
    is_new = np.array([s.is_new for s in streets], dtype=bool)
    wider = np.where(is_new, np.abs(new_width - width) > 0.01, new_width > width + 0.01)
    now_list, wider_list = now.tolist(), wider.tolist()
    for k in np.flatnonzero(now | wider).tolist():
        if now_list[k]:
            streets[k] = replace(streets[k], status=Status.BUILT)
        if wider_list[k]:
            streets[k] = replace(streets[k], width=float(new_width[k]))
    widened = int(wider.sum())
    waiting = np.flatnonzero(since >= 0)  # the few streets whose widening waits, not a numpy scalar per street
    pending = dict(zip([streets[k].id for k in waiting.tolist()], since[waiting].tolist()))
    return city.replace(network=city.network.replace(streets=tuple(streets))), changed_status, widened, pending
