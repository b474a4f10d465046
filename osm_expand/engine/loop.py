"""The year loop: a city lives through a history (003 Algorithm 1 with 002 §2.2).

One :func:`step` is one year::

    grow minor streets → blocks → traffic (trips, status, widths, trade)
    → grow major roads → build out (land use, lots, buildings)

:func:`start` makes the run's :class:`EngineState` (the city plus what the
stages remember from year to year and is not part of the city) and its
:class:`EngineContext` (what stays the same all run: the history and its
clock, the town's spacing and bearing, the random streams, the registry of
district patterns). :func:`step` is City → City for one year: it hands the
state on with the city of the year after, whose :attr:`City.year` is the
year just lived, and a :class:`YearReport`. :func:`osm_expand.maturation.mature`
runs the steps, sums them per era (:class:`EraReport`) and takes snapshots.

Each stage is a pure function of the city and its own memory; this module
only sequences them and keeps the nuclei of growth. Everything built
carries its ``year`` (the calendar year of the step,
:class:`~osm_expand.engine.history.Clock`) and ``era``.

The town as mapped is never demolished (a rebuilding road demolishes only
what the engine built, unless the history sets ``rebuild_old_town``).
"""
from __future__ import annotations

import math
import time
from collections import defaultdict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import cast

import numpy as np

from osm_expand.blocks import FaceMemo, blocks
from osm_expand.engine.buildout.report import ReportOptions, buildout_report
from osm_expand.engine.buildout.year import BuildoutMemory, BuildoutYear, buildout_year, start_buildout
from osm_expand.engine.growth.minor_streets import (
    STUB_REACH,
    GrowthMemory,
    GrowthOptions,
    GrowthYear,
    grow_district,
    grow_street_pattern,
    neighbourhood_length,
    settlement_length,
)
from osm_expand.engine.growth.nuclei import Nucleus, candidate_points, find_nuclei, new_junction_nuclei
from osm_expand.engine.growth.yardstick import DistrictYardstick
from osm_expand.engine.history import GROWTH_PATTERNS, Clock, Era, History, YearValues
from osm_expand.engine.planarity import without_touching
from osm_expand.engine.roads.major_roads import RoadMemory, RoadsYear, major_roads_year
from osm_expand.engine.traffic.simulation import TrafficMemory, TrafficYear, start_traffic, traffic_year
from osm_expand.model import City, Origin
from osm_expand.model.segments import SegmentTable
from synth.growth import GrowthPattern
from synth.patterns import AngleSpace, PatternOptions

#: Builds an era's district pattern (``example``, ``walk``, ``colonisation``) from its options.
PatternFactory = Callable[[str, object], GrowthPattern]
#: The random streams of a run, one per stage, each drawn from the run's seed alone (so that one stage
#: drawing more does not shift another's draws).
STREAMS = ("growth", "traffic", "roads", "buildout", "nuclei")
#: The first entropy word of the engine's streams beside the run's seed (the district's are ``[seed, site]``).
ENGINE_STREAM = 0xE9E


@dataclass(frozen=True)
class EngineOptions:
    """How the loop sequences the stages (the stages' own options live in the history)."""

    #: Major roads built or re-routed per year at most: 003 builds one road per short pair inside
    #: Algorithm 2, which in a year of sudden demand floods a town with parallel roads; one a year
    #: lets the next year's traffic see the new road first.
    roads_per_year: int = 1
    growth: GrowthOptions = field(default_factory=GrowthOptions)


@dataclass(frozen=True)
class EngineContext:
    """What stays the same for a whole run: read by every :func:`step`, changed by none.

    The random streams are generators (they move on as they are drawn
    from); the context holds the same ones all run, one per stage
    (:data:`STREAMS`).
    """

    history: History
    clock: Clock  #: step ``k`` ↔ history and calendar years
    traffic_factor: float  #: the city's b of t(t) = b·traffic(t) (003 §3.5), drawn once
    spacing: float  #: the town's junction spacing (m): the scale of district patterns and joins
    bearing: float  #: the town's dominant street bearing modulo 90° (degrees): a world grid follows it
    patterns: PatternFactory  #: the registry of district patterns over the town's example
    streams: Mapping[str, np.random.Generator]
    options: EngineOptions = EngineOptions()
    #: The run's seed: the town's neighbourhoods a named pattern's era aims at are drawn from it
    #: (:attr:`GrowthOptions.pattern_aim`).
    seed: int = 0
    #: The history year of the run's last step (None: the run's length not known): with
    #: :attr:`GrowthOptions.district_neighbourhoods` the length owed then is grown as an era's end's is, not lost.
    #: Derived once, by :func:`start` beside the clock, from the run's ``years``.
    last_year: int | None = None

    def values(self, year: int) -> YearValues:
        """The history's numbers for calendar year ``year`` (its era among them)."""
        return self.history.values_at(year - self.clock.offset, traffic_factor=self.traffic_factor)

    def starts_era(self, year: int, previous: str | None) -> bool:
        """Whether calendar year ``year`` opens an era after a year of era ``previous`` (None: the first
        year): another era, or the same era named again by a history that restarts it."""
        era = self.history.era_at(year - self.clock.offset)
        return previous is None or era.name != previous or era.start == year - self.clock.offset


@dataclass
class EngineState:
    """The city and what the stages remember from year to year (not part of the city).

    :func:`step` hands the state on: the memories are the stages' own and
    move on with it, so a state once stepped is spent (step the one it returns).
    """

    city: City
    nuclei: list[Nucleus]
    growth: GrowthMemory
    traffic: TrafficMemory
    roads: RoadMemory
    buildout: BuildoutMemory
    patterns: dict[str, GrowthPattern] = field(default_factory=dict)  #: district patterns by era
    carry: float = 0.0  #: the fraction of a street owed from last year
    seconds: defaultdict[str, float] = field(default_factory=lambda: defaultdict(float))  #: wall time per stage
    faces: FaceMemo = field(default_factory=FaceMemo)  #: last year's faces: blocks redo only what changed

    def traffic_by_street(self) -> dict[int, float]:
        """This year's trips per street id (the busiest segment of each street)."""
        table = self.traffic.table
        traffic = self.traffic.trips.traffic
        n = len(self.city.network.streets)
        if len(traffic) != len(table) or table.first[-1] != len(table) or len(table.first) != n + 1:
            return {}
        per = table.per_street(np.asarray(traffic, dtype=float), n, "max")
        return {s.id: float(v) for s, v in zip(self.city.network.streets, per)}


@dataclass(frozen=True)
class YearReport:
    """What one year did."""

    year: int  #: calendar year
    era: str
    growth: GrowthYear
    traffic: TrafficYear
    roads: RoadsYear
    buildout: BuildoutYear


@dataclass
class EraReport:
    """What happened in one era of a run (summed over its years)."""

    name: str
    first_year: int
    last_year: int
    growth: GrowthYear = field(default_factory=GrowthYear)
    traffic: TrafficYear = field(default_factory=TrafficYear)
    roads: RoadsYear = field(default_factory=RoadsYear)
    buildout: BuildoutYear = field(default_factory=BuildoutYear)

    def add(self, year: YearReport) -> None:
        """Count ``year`` in this era."""
        self.last_year = year.year
        self.growth = self.growth + year.growth
        self.traffic = self.traffic + year.traffic
        self.roads = self.roads + year.roads
        self.buildout = self.buildout + year.buildout

    def to_dict(self) -> dict:
        out = {"era": self.name, "years": [self.first_year, self.last_year],
               "streets_grown": self.growth.streets, "street_length_km": round(self.growth.length_m / 1000, 3),
               "districts": self.growth.districts, **self.traffic.to_dict(), **self.roads.to_dict()}
        out["bridges_built"] = self.roads.bridges + self.growth.bridges
        out["street_bridges"] = self.growth.bridges
        out.update(self.buildout.to_dict())
        return out


def start(city: City, history: History, *, seed: int, spacing: float, patterns: PatternFactory,
          join_points: np.ndarray | None = None, options: EngineOptions = EngineOptions(),
          years: int | None = None) -> tuple[EngineState, EngineContext]:
    """The state and context of a run of ``history`` on ``city``, before its first year.

    Parameters
    ----------
    city : City
        The town as mapped (and any grown district); its :attr:`~City.year` (the map's) sets the clock.
    history : History
    seed : int
        The run's seed: each stage draws from its own stream of it (:data:`STREAMS`).
    spacing : float
        The town's junction spacing (m): the scale of district patterns and joins.
    patterns : callable
        ``(name, options) -> GrowthPattern`` for the district patterns.
    join_points : ndarray, shape (J, 2), optional
        Where a grown district joins the town: nuclei of growth (003 §3.3.2).
    options : EngineOptions
    years : int, optional
        The run's length in steps, when known: its last step's history year
        (:attr:`EngineContext.last_year`) ends an open era's district floor.

    Returns
    -------
    (EngineState, EngineContext)
        The city with its blocks and the stages' first memories; the run's fixed context.
    """
    rng = np.random.default_rng([seed, ENGINE_STREAM])
    streams = {name: np.random.default_rng([seed, ENGINE_STREAM, k]) for k, name in enumerate(STREAMS)}
    clock = history.clock(city.year)
    b = history.traffic_factor(rng)
    started = time.perf_counter()
    faces = FaceMemo()
    city = _with_blocks(city, None, faces)
    state = EngineState(city=city, nuclei=_initial_nuclei(city, join_points), growth=GrowthMemory(),
                        traffic=start_traffic(city, streams["traffic"]), roads=RoadMemory(),
                        buildout=start_buildout(city, history, streams["buildout"]), faces=faces)
    state.seconds["start"] += time.perf_counter() - started
    context = EngineContext(history=history, clock=clock, traffic_factor=b, spacing=spacing,
                            bearing=_town_bearing(SegmentTable.from_city(city)), patterns=patterns,
                            streams=MappingProxyType(streams), options=options, seed=seed,
                            last_year=None if years is None else clock.history_year(years - 1))
    return state, context


def step(state: EngineState, context: EngineContext, year: int) -> tuple[EngineState, YearReport]:
    """One year of the loop: the state with the city after calendar year ``year``, and what it did.

    The years of a run are ``context.clock.calendar_year(k)`` for ``k = 0, 1, …``
    in order (each stage's memory and random stream assume the year before
    was the one stepped). The returned state's city has ``year`` as its
    :attr:`~osm_expand.model.City.year`.
    """
    now = context.values(year)
    era = now.era
    streams = context.streams
    t = time.perf_counter()
    before = len(state.city.network.streets)
    grown = _grow(state, era, now, year, streams["growth"], spacing=context.spacing,
                  district_pattern=context.patterns, bearing=context.bearing, options=context.options,
                  last_year=context.last_year, seed=context.seed)
    state.seconds["growth"] += time.perf_counter() - t
    if len(state.city.network.streets) != before:
        t = time.perf_counter()
        state.city = _with_blocks(state.city, year, state.faces)
        state.seconds["blocks"] += time.perf_counter() - t
    t = time.perf_counter()
    state.city, state.traffic, traffic, short = traffic_year(
        state.city, state.traffic, streams["traffic"], year=year, increase=now.traffic_increase, o2=now.o2,
        options=context.history.options.trips)
    state.seconds["traffic"] += time.perf_counter() - t
    t = time.perf_counter()
    had_lattice = state.roads.lattice is not None
    city, state.traffic, state.roads, roads, junctions = major_roads_year(
        state.city, state.traffic, state.roads, short, context.history, now, streams["roads"], year=year,
        era=era.name, most=context.options.roads_per_year)
    spent = time.perf_counter() - t
    state.seconds["lattice" if not had_lattice and state.roads.lattice is not None else "roads"] += spent
    if city is not state.city:
        state.city = _with_blocks(city, year, state.faces)
    if len(junctions):
        z = candidate_points(_arrays(state.city), spawned_mask=np.zeros(len(state.city.network.xy), bool),
                             temporary_points=False)
        state.nuclei += new_junction_nuclei(junctions, bounds=state.city.bounds_xy, candidates_xy=z.xy,
                                            rng=streams["nuclei"], existing=state.nuclei,
                                            options=context.history.options.nuclei)
    t = time.perf_counter()
    state.city, state.buildout, built = buildout_year(state.city, state.buildout, context.history, now,
                                                      streams["buildout"], year=year,
                                                      traffic=state.traffic_by_street())
    state.seconds["buildout"] += time.perf_counter() - t
    state.city = state.city.replace(year=year)
    return state, YearReport(year=year, era=era.name, growth=grown, traffic=traffic, roads=roads, buildout=built)


def summary(state: EngineState, context: EngineContext, eras: list[EraReport], *, judge: bool = True) -> dict:
    """The run's JSON-ready report: its years, the city's traffic factor, what each era did, the build-out's
    measures (``judge``: with the similarity of its land use to the town's, :class:`ReportOptions`) and the
    wall time per stage."""
    first, last = eras[0].first_year, eras[-1].last_year
    return {"history": context.history.name, "years": last - first + 1, "first_year": first, "last_year": last,
            "traffic_factor": round(context.traffic_factor, 4),
            "neighbour_cities": int(len(state.traffic.neighbours.exit_node)),
            "trade_pairs": int(len(state.traffic.pairs)), "nuclei": len(state.nuclei),
            "eras": [e.to_dict() for e in eras],
            "seconds": {k: round(v, 3) for k, v in sorted(state.seconds.items())},
            "buildout": buildout_report(state.city, state.buildout, context.history,
                                        options=ReportOptions(similarity=judge))}

def _grow(state: EngineState, era: Era, now: YearValues, year: int, rng: np.random.Generator, *, spacing: float,
          district_pattern: PatternFactory, bearing: float, options: EngineOptions,
          last_year: int | None = None, seed: int = 0) -> GrowthYear:
    """This year's minor streets: a street pattern from its starts, or a district once enough is owed."""
    count, state.carry = now.new_streets(_junction_edges(state.city), state.carry)
    known = {s.id for s in state.city.network.streets}
    grown = _grow_streets(state, era, now, year, rng, count, spacing=spacing, district_pattern=district_pattern,
                          bearing=bearing, options=options, last_year=last_year, seed=seed)
    state.city, dropped = without_touching(state.city, known)
    if dropped:
        grown = replace(grown, streets=max(grown.streets - dropped, 0))
    return grown


def _grow_streets(state: EngineState, era: Era, now: YearValues, year: int, rng: np.random.Generator, count: int, *,
                  spacing: float, district_pattern: PatternFactory, bearing: float,
                  options: EngineOptions, last_year: int | None = None, seed: int = 0) -> GrowthYear:
    centre = np.asarray(state.nuclei[0].xy)
    if era.pattern in GROWTH_PATTERNS:
        state.growth.owed += count * spacing
        if state.growth.owed < options.growth.min_district * spacing:
            return GrowthYear()
        if options.growth.district_neighbourhoods > 0 and not state.growth.due:
            if state.growth.neighbourhood is None:
                # once a run, on the city of the first year a district pattern owes min_district spacings: the
                # town as mapped plus whatever earlier years grew (a street-pattern era's streets among them)
                state.growth.neighbourhood = neighbourhood_length(state.city, growth=options.growth)
            share = options.growth.district_town_share
            if math.isfinite(share) and state.growth.settlement is None:  # with the neighbourhood, once a run
                state.growth.settlement = settlement_length(state.city, growth=options.growth)
            era_ends = ((era.end is not None and now.year + 1 >= era.end)
                        or (last_year is not None and now.year >= last_year))
            floor = options.growth.district_neighbourhoods * state.growth.neighbourhood
            if math.isfinite(share) and state.growth.settlement is not None:  # at most that share of the town at a time
                floor = min(floor, share * state.growth.settlement)
            if state.growth.owed < floor and not era_ends:
                return GrowthYear()  # not yet the floor, and the era goes on: wait
            # owed: tried each year from now on until a district is placed. Like the owed length it belongs to,
            # ``due`` outlives its era: a street-pattern era between leaves both as they were, and the next district
            # era tries its first district at min_district without waiting for the floor again.
            state.growth.due = True
        if era.name not in state.patterns:  # one object per era: it keeps what it learned between districts
            state.patterns[era.name] = district_pattern(era.pattern, era.options)
        pattern = state.patterns[era.name]
        state.city, grown = grow_district(state.city, pattern, state.growth.owed, 2.0 / spacing, state.nuclei,
                                          rng, spacing=spacing, year=year, era=era.name,
                                          options=options.growth)
        if grown.districts:
            state.growth.owed = max(state.growth.owed - grown.length_m, 0.0)
            state.growth.due = False
        else:  # no site took a district: wait until a bigger one is owed (its disc reaches further)
            state.growth.owed -= options.growth.min_district * spacing
        return grown
    opts = cast(PatternOptions, era.options)  # a street pattern's era holds PatternOptions
    if isinstance(opts, PatternOptions) and opts.angle_space == AngleSpace.WORLD and opts.angle_offset_deg == 0.0:
        opts = replace(opts, angle_offset_deg=bearing)  # a world-space grid follows the town's own grid
    aim = None
    if options.growth.pattern_aim and count > 0:
        if state.growth.yardstick is None:  # measured once a run, from the run's seed
            state.growth.yardstick = DistrictYardstick.of_town(state.city, seed=seed)
        aim = state.growth.yardstick
    state.city, grown = grow_street_pattern(state.city, count, opts, state.nuclei, state.growth, rng, year=year,
                                            era=era.name, centre=centre, reach=STUB_REACH * spacing, aim=aim)
    return grown


def _junction_edges(city: City) -> int:
    """Junction-to-junction edges of the network: segments less the degree-2 nodes they chain through."""
    table = SegmentTable.from_city(city)
    degree = np.bincount(table.uv.ravel(), minlength=len(table.xy))
    return max(int(len(table) - (degree == 2).sum()), len(city.network.streets))


def _arrays(city: City) -> tuple[np.ndarray, np.ndarray]:
    table = SegmentTable.from_city(city)
    return table.xy, table.uv


def _initial_nuclei(city: City, join_points: np.ndarray | None) -> list[Nucleus]:
    """The town centre, junctions of the real major roads, the district's joins and bridge ends (003 §3.3.2)."""
    table = SegmentTable.from_city(city)
    source = np.array([city.network.streets[k].origin == Origin.SOURCE for k in table.street.tolist()], bool)
    major = table.major & source
    bridges = table.bridge & source
    ends = table.xy[table.uv[bridges].ravel()] if bridges.any() else None
    return find_nuclei(table.xy, table.uv[major], bounds=city.bounds_xy, join_points=join_points,
                       bridge_ends=ends)


def _town_bearing(table: SegmentTable) -> float:
    """The town's dominant street bearing modulo 90° (degrees), weighted by length: a grid's axis."""
    if not len(table):
        return 0.0
    d = table.xy[table.uv[:, 1]] - table.xy[table.uv[:, 0]]
    angle = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 90.0
    hist, edges = np.histogram(angle, bins=90, range=(0.0, 90.0), weights=table.length)
    smooth = hist + np.roll(hist, 1) + np.roll(hist, -1)  # circular: 89° and 0° are neighbours
    return float(edges[int(np.argmax(smooth))] + 0.5)


def _with_blocks(city: City, year: int | None, faces: FaceMemo) -> City:
    """The city with its blocks recomputed; a block's origin and year from the streets around it."""
    new_by_id = {s.id: s for s in city.network.streets if s.origin != Origin.SOURCE}  # most blocks have none
    new_ids = new_by_id.keys()

    def stamp(street_ids: tuple[int, ...]) -> tuple[Origin, int | None]:
        if new_ids.isdisjoint(street_ids):  # in C: most of a grown town's 20,000 blocks are the town's own
            return Origin.SOURCE, None
        new = [new_by_id[i] for i in street_ids if i in new_by_id]
        if not new:
            return Origin.SOURCE, None
        origin = Origin.ENGINE if any(s.origin == Origin.ENGINE for s in new) else Origin.GROWN
        years = [s.year for s in new if s.year is not None]
        return origin, max(years) if years else year

    return city.replace(blocks=tuple(blocks(city.network, year=year, memo=faces, stamp=stamp)))
