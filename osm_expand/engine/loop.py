"""The year loop: a city lives through a history (003 Algorithm 1 with 002 §2.2).

One step is one year::

    grow minor streets → blocks → traffic (trips, status, widths, trade)
    → grow major roads → build out (land use, lots, buildings)

Each stage is a pure function of the city and its own memory (what it
remembers from year to year and is not part of the city); this module only
sequences them, keeps the nuclei of growth, and sums what happened into one
report per era. Everything built carries its ``year`` (the calendar year of
the step, :class:`~osm_expand.engine.history.Clock`) and ``era``.

The town as mapped is never demolished (a rebuilding road demolishes only
what the engine built, unless the history sets ``rebuild_old_town``).
"""
from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, cast

import numpy as np

from osm_expand.blocks import FaceMemo, blocks
from osm_expand.engine.growth.minor_streets import (
    STUB_REACH,
    GrowthMemory,
    GrowthOptions,
    GrowthYear,
    grow_district,
    grow_street_pattern,
)
from osm_expand.engine.growth.nuclei import Nucleus, candidate_points, find_nuclei, new_junction_nuclei
from osm_expand.engine.history import GROWTH_PATTERNS, Era, History, YearValues
from osm_expand.engine.planarity import without_touching
from osm_expand.engine.roads.major_roads import RoadMemory, RoadsYear, major_roads_year
from osm_expand.engine.segments import SegmentTable
from osm_expand.engine.traffic.simulation import TrafficMemory, TrafficYear, start_traffic, traffic_year
from osm_expand.model import City, Origin
from synth.growth import GrowthPattern
from synth.patterns import AngleSpace, PatternOptions

if TYPE_CHECKING:
    from osm_expand.engine.buildout.year import BuildoutYear

#: Builds an era's district pattern (``example``, ``walk``, ``colonisation``) from its options.
PatternFactory = Callable[[str, object], GrowthPattern]
#: Told after every year: (years done, years in all, the era's name).
YearProgress = Callable[[int, int, str], None]
#: Called with the city, the calendar year, the era and traffic per street id when a snapshot is due.
Snapshot = Callable[[City, int, str, dict[int, float]], None]


@dataclass(frozen=True)
class EngineOptions:
    """How the loop sequences the stages (the stages' own options live in the history)."""

    #: Major roads built or re-routed per year at most: 003 builds one road per short pair inside
    #: Algorithm 2, which in a year of sudden demand floods a town with parallel roads; one a year
    #: lets the next year's traffic see the new road first.
    roads_per_year: int = 1
    growth: GrowthOptions = field(default_factory=GrowthOptions)


@dataclass
class EraReport:
    """What happened in one era of a run (summed over its years)."""

    name: str
    first_year: int
    last_year: int
    growth: GrowthYear = field(default_factory=GrowthYear)
    traffic: TrafficYear = field(default_factory=TrafficYear)
    roads: RoadsYear = field(default_factory=RoadsYear)
    buildout: BuildoutYear | None = None

    def to_dict(self) -> dict:
        out = {"era": self.name, "years": [self.first_year, self.last_year],
               "streets_grown": self.growth.streets, "street_length_km": round(self.growth.length_m / 1000, 3),
               "districts": self.growth.districts, **self.traffic.to_dict(), **self.roads.to_dict()}
        out["bridges_built"] = self.roads.bridges + self.growth.bridges
        out["street_bridges"] = self.growth.bridges
        if self.buildout is not None:
            out.update(self.buildout.to_dict())
        return out


@dataclass(frozen=True)
class EngineResult:
    city: City
    eras: list[EraReport]
    seconds: dict[str, float]  #: wall time per stage (``lattice`` apart from ``roads``)
    report: dict


@dataclass
class _State:
    """The loop's own state across years."""

    city: City
    nuclei: list[Nucleus]
    growth: GrowthMemory
    traffic: TrafficMemory
    roads: RoadMemory
    buildout: object | None = None
    patterns: dict[str, GrowthPattern] = field(default_factory=dict)  #: district patterns by era
    carry: float = 0.0
    seconds: defaultdict[str, float] = field(default_factory=lambda: defaultdict(float))
    faces: FaceMemo = field(default_factory=FaceMemo)  #: last year's faces: blocks redo only what changed


def run(city: City, history: History, *, years: int, seed: int, spacing: float,
        district_pattern: PatternFactory, join_points: np.ndarray | None = None,
        options: EngineOptions = EngineOptions(), buildout: Buildout | None = None,
        progress: YearProgress | None = None, snapshot: Snapshot | None = None,
        snapshot_every: int | None = None) -> EngineResult:
    """Let ``city`` live through ``years`` years of ``history``.

    Parameters
    ----------
    city : City
        The town as mapped (and any grown district), with its blocks.
    history : History
    years : int
        Years to simulate (0: the city comes back unchanged).
    seed : int
        The run's seed: each stage draws from its own stream of it.
    spacing : float
        The town's junction spacing (m): the scale of district patterns and joins.
    district_pattern : callable
        ``(name, options) -> GrowthPattern`` for the district patterns.
    join_points : ndarray, shape (J, 2), optional
        Where a grown district joins the town: nuclei of growth (003 §3.3.2).
    buildout : Buildout, optional
        Land use, lots and buildings; skipped when None.
    progress : callable, optional
        Told after each year.
    snapshot : callable, optional
        Called at the end of each era, or every ``snapshot_every`` years.
    """
    if years <= 0:
        return EngineResult(city, [], {}, {"years": 0})
    rng = np.random.default_rng([seed, 0xE9E])
    streams = {name: np.random.default_rng([seed, 0xE9E, k]) for k, name in
               enumerate(("growth", "traffic", "roads", "buildout", "nuclei"))}
    clock = history.clock(city.year)
    b = history.traffic_factor(rng)
    started = time.perf_counter()
    faces = FaceMemo()
    city = _with_blocks(city, None, faces)
    state = _State(city=city, nuclei=_initial_nuclei(city, join_points), growth=GrowthMemory(),
                   traffic=start_traffic(city, streams["traffic"]), roads=RoadMemory(), faces=faces)
    if buildout is not None:
        state.buildout = buildout.start(city, history, streams["buildout"])
    state.seconds["start"] += time.perf_counter() - started
    bearing = _town_bearing(SegmentTable.from_city(city))
    eras: list[EraReport] = []
    for step in range(years):
        now = history.values_at(clock.history_year(step), traffic_factor=b)
        year = clock.calendar_year(step)
        if not eras or eras[-1].name != now.era.name or now.era.start == clock.history_year(step):
            if eras and snapshot is not None and snapshot_every is None:
                snapshot(state.city, eras[-1].last_year, eras[-1].name, _traffic_by_street(state))
            eras.append(EraReport(now.era.name, year, year))
        report = eras[-1]
        report.last_year = year
        _one_year(state, history, now, year, streams, spacing=spacing, district_pattern=district_pattern,
                  bearing=bearing, options=options, buildout=buildout, report=report)
        if snapshot is not None and snapshot_every and (step + 1) % snapshot_every == 0:
            snapshot(state.city, year, now.era.name, _traffic_by_street(state))
        if progress is not None:
            progress(step + 1, years, now.era.name)
    if snapshot is not None and snapshot_every is None:
        snapshot(state.city, eras[-1].last_year, eras[-1].name, _traffic_by_street(state))
    result = {"history": history.name, "years": years, "first_year": clock.calendar_year(0),
              "last_year": clock.calendar_year(years - 1), "traffic_factor": round(b, 4),
              "neighbour_cities": int(len(state.traffic.neighbours.exit_node)),
              "trade_pairs": int(len(state.traffic.pairs)), "nuclei": len(state.nuclei),
              "eras": [e.to_dict() for e in eras],
              "seconds": {k: round(v, 3) for k, v in sorted(state.seconds.items())}}
    if buildout is not None and state.buildout is not None:
        result["buildout"] = buildout.report(state.city, state.buildout, history)
    return EngineResult(state.city, eras, dict(state.seconds), result)


@dataclass(frozen=True)
class Buildout:
    """The build-out stage as the loop calls it (land use, lots, buildings: issue 11's step)."""

    start: Callable  #: (city, history, rng) -> memory
    year: Callable  #: (city, memory, history, now, rng, *, year, traffic) -> (city, memory, year report)
    report: Callable  #: (city, memory, history) -> dict


def _one_year(state: _State, history: History, now: YearValues, year: int, streams: dict, *, spacing: float,
              district_pattern: PatternFactory, bearing: float, options: EngineOptions,
              buildout: Buildout | None, report: EraReport) -> None:
    era = now.era
    t = time.perf_counter()
    before = len(state.city.network.streets)
    grown = _grow(state, era, now, year, streams["growth"], spacing=spacing, district_pattern=district_pattern,
                  bearing=bearing, options=options)
    report.growth = report.growth + grown
    state.seconds["growth"] += time.perf_counter() - t
    if len(state.city.network.streets) != before:
        t = time.perf_counter()
        state.city = _with_blocks(state.city, year, state.faces)
        state.seconds["blocks"] += time.perf_counter() - t
    t = time.perf_counter()
    trips = history.options.trips
    state.city, state.traffic, traffic, short = traffic_year(
        state.city, state.traffic, streams["traffic"], year=year, increase=now.traffic_increase, o2=now.o2,
        options=trips)
    report.traffic = report.traffic + traffic
    state.seconds["traffic"] += time.perf_counter() - t
    t = time.perf_counter()
    had_lattice = state.roads.lattice is not None
    city, state.traffic, state.roads, roads, junctions = major_roads_year(
        state.city, state.traffic, state.roads, short, history, now, streams["roads"], year=year, era=era.name,
        most=options.roads_per_year)
    spent = time.perf_counter() - t
    state.seconds["lattice" if not had_lattice and state.roads.lattice is not None else "roads"] += spent
    report.roads = report.roads + roads
    if city is not state.city:
        state.city = _with_blocks(city, year, state.faces)
    if len(junctions):
        z = candidate_points(_arrays(state.city), spawned_mask=np.zeros(len(state.city.network.xy), bool),
                             temporary_points=False)
        state.nuclei += new_junction_nuclei(junctions, bounds=state.city.bounds_xy, candidates_xy=z.xy,
                                            rng=streams["nuclei"], existing=state.nuclei,
                                            options=history.options.nuclei)
    if buildout is not None:
        t = time.perf_counter()
        state.city, state.buildout, built = buildout.year(state.city, state.buildout, history, now,
                                                          streams["buildout"], year=year,
                                                          traffic=_traffic_by_street(state))
        report.buildout = built if report.buildout is None else report.buildout + built
        state.seconds["buildout"] += time.perf_counter() - t


def _grow(state: _State, era: Era, now: YearValues, year: int, rng: np.random.Generator, *, spacing: float,
          district_pattern: PatternFactory, bearing: float, options: EngineOptions) -> GrowthYear:
    """This year's minor streets: a street pattern from its starts, or a district once enough is owed."""
    count, state.carry = now.new_streets(_junction_edges(state.city), state.carry)
    known = {s.id for s in state.city.network.streets}
    grown = _grow_streets(state, era, now, year, rng, count, spacing=spacing, district_pattern=district_pattern,
                          bearing=bearing, options=options)
    state.city, dropped = without_touching(state.city, known)
    if dropped:
        grown = replace(grown, streets=max(grown.streets - dropped, 0))
    return grown


def _grow_streets(state: _State, era: Era, now: YearValues, year: int, rng: np.random.Generator, count: int, *,
                  spacing: float, district_pattern: PatternFactory, bearing: float,
                  options: EngineOptions) -> GrowthYear:
    centre = np.asarray(state.nuclei[0].xy)
    if era.pattern in GROWTH_PATTERNS:
        state.growth.owed += count * spacing
        if state.growth.owed < options.growth.min_district * spacing:
            return GrowthYear()
        if era.name not in state.patterns:  # one object per era: it keeps what it learned between districts
            state.patterns[era.name] = district_pattern(era.pattern, era.options)
        pattern = state.patterns[era.name]
        state.city, grown = grow_district(state.city, pattern, state.growth.owed, 2.0 / spacing, state.nuclei,
                                          state.growth, rng, spacing=spacing, year=year, era=era.name)
        if grown.districts:
            state.growth.owed = max(state.growth.owed - grown.length_m, 0.0)
        else:  # no site took a district: wait until a bigger one is owed (its disc reaches further)
            state.growth.owed -= options.growth.min_district * spacing
        return grown
    opts = cast(PatternOptions, era.options)  # a street pattern's era holds PatternOptions
    if isinstance(opts, PatternOptions) and opts.angle_space == AngleSpace.WORLD and opts.angle_offset_deg == 0.0:
        opts = replace(opts, angle_offset_deg=bearing)  # a world-space grid follows the town's own grid
    state.city, grown = grow_street_pattern(state.city, count, opts, state.nuclei, state.growth, rng, year=year,
                                            era=era.name, centre=centre, reach=STUB_REACH * spacing)
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
    found = blocks(city.network, year=year, memo=faces)
    new_by_id = {s.id: s for s in city.network.streets if s.origin != Origin.SOURCE}  # most blocks have none
    out = []
    for blk in found:
        new = [new_by_id[i] for i in blk.street_ids if i in new_by_id]
        if not new:
            out.append(replace(blk, origin=Origin.SOURCE, year=None))
            continue
        origin = Origin.ENGINE if any(s.origin == Origin.ENGINE for s in new) else Origin.GROWN
        years = [s.year for s in new if s.year is not None]
        out.append(replace(blk, origin=origin, year=max(years) if years else year))
    return city.replace(blocks=tuple(out))


def _traffic_by_street(state: _State) -> dict[int, float]:
    """This year's trips per street id (the busiest segment of each street)."""
    table = state.traffic.table
    traffic = state.traffic.trips.traffic
    n = len(state.city.network.streets)
    if len(traffic) != len(table) or table.first[-1] != len(table) or len(table.first) != n + 1:
        return {}
    per = table.per_street(np.asarray(traffic, dtype=float), n, "max")
    return {s.id: float(v) for s, v in zip(state.city.network.streets, per)}
