"""Histories: the eras and time functions a city lives through (003 §3.1, 000 §4.2.9, 002 §4).

A *history* is 003's "historical context", shared by every city it is run
on: the growth and major-road functions G(t) and R(t), the sequence of
minor-road patterns K(t) and the time-independent coefficients O1…O4
(003 §3.1). 000 §4.2.9 splits K(t) into *eras*: "the parametrization of
street patterns, together with the relative frequency distribution of major
road types, form a (historical) era", and "a sequence of eras, each with an
assigned starting date, defines a history"; an era may occur at several
places in a history. 002 adds the land-use types with their goals, the
land price avgprice(t) and the update interval of the land-use simulation
(002 §4.1: a longer interval makes a centrally planned city).

A history is a TOML file (format: ``docs/histories.md``). The bundled ones
are package data (``osm_expand/histories/*.toml``): ``example`` (the
default), ``european``, ``north-american``. This module is the history
itself; reading one, by name or path, is
:func:`osm_expand.engine.history.reader.load_history`'s (every problem one
:class:`~osm_expand.errors.HistoryError` line ``FILE: key.path: what is
wrong``).

**Decisions the seeds leave open.**

- *G(t) is a share.* 003 grows minor roads from the first G(t) candidate
  nodes a year (a count); 002 grows ``streetgrowth[t]`` × the current number
  of streets × the time step (a share). A count suits one town only; a share
  lets one history serve Monaco and Campo Grande alike, so ``growth`` is
  002's share of the network's segments added per year. The loop turns it
  into this year's number of new streets with :meth:`YearValues.new_streets`
  (fractions carry over to the next year) and, for 003's start-based
  patterns, into ⌈streets / ``streets_per_start``⌉ starts.
- *t(t) has its own function.* 003 §3.5 makes the traffic a slightly
  randomised copy of ``b·G(t)`` with ``b ~ U(0.7, 1.3)`` per city. With G a
  share (a rate that falls as towns mature) a copy would make traffic fall
  too, so ``traffic`` is its own function, in 003's traffic units
  (``O2·width`` is a segment's capacity) per pair of neighbouring cities,
  and the city's t(t) = b·traffic(t) with b drawn by :meth:`History.traffic_factor`
  (:func:`osm_expand.engine.traffic.trade.draw_traffic_factor`). 003's Algorithm 2
  needs only the yearly increase t(t) − t(t−1) (trade routes start empty,
  003 §3.4.2), so the bundled functions are rates: 000 §4.2.8's own traffic
  drift, (E[r] − c2)·c3 = (0.5 − 0.3)·50 = 10 units a year, is the modern one.
- *A(t) is a width.* 003 §3.4.2 calls A(t) both "recommended traffic
  capacity" and "the recommended width" that new major roads are widened to;
  :func:`osm_expand.engine.roads.road_types.plan_major_road` takes a width, so A(t)
  is in metres (its capacity is O2·A(t)).
- *The clock.* ``anchor = "map"``: the history's years are calendar years
  and a run begins in the map's year (in ``start`` when the map has no year
  or an older one): the town as mapped lives on into the future.
  ``anchor = "start"``: the history is replayed from its ``start`` on the
  town as mapped, whatever the map's year, and what is built is dated from
  the map's year on (history year ``start`` is the map's year). See
  :class:`Clock`.
- *Eras in order.* 000 A.3 wants the active entries "ordered … by year" and
  §4.2.9 assumes no two start in the same year: eras are listed in time
  order with increasing start years; the run's first year must lie in an
  era (``start`` is not before the first era).

**The loop** (003 Algorithm 1 with 002 §2.2; see ``docs/histories.md``)::

    history = load_history(args.history)                 # "example" by default
    clock = history.clock(city.year)
    b = history.traffic_factor(rng)                      # per city, 003 §3.5
    carry = 0.0
    for step in range(years):
        year = clock.history_year(step)                  # eras and functions
        dated = clock.calendar_year(step)                # stamped on what is built, with era.name
        now = history.values_at(year, traffic_factor=b)
        era = now.era
        count, carry = now.new_streets(n_segments, carry)
        pattern = history.pattern_options(era)           # grow `count` streets with era.pattern
        ...trade_year(state, pairs, now.traffic_increase, o2·width)   # Algorithm 2
        ...road_type = history.major_road_type(rng, year)             # when a new road is built
        ...pathfinding_graph(..., costs=now.costs); propose_route(..., routing=now.routing)
        ...plan_major_road(..., width=now.road_width); choose(..., o3=now.o3, o4=now.o4)
        if now.land_use_update: update_land_use(..., types=history.land_use_types)
        ...lot_economy(..., avgprice=now.avgprice)
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from types import MappingProxyType
from typing import Any

import numpy as np

from osm_expand.engine.buildout.economy import EconomyOptions, TypeEconomy
from osm_expand.engine.buildout.footprints import FootprintOptions
from osm_expand.engine.buildout.landuse_types import LandUseOptions, LandUseType
from osm_expand.engine.buildout.lots import LandUse, LotOptions
from osm_expand.engine.growth.nuclei import NucleiOptions
from osm_expand.engine.history.timefn import TimeFunction
from osm_expand.engine.roads.built_up import BuiltUpOptions
from osm_expand.engine.roads.lattice import LatticeOptions
from osm_expand.engine.roads.path_graph import EdgeCosts, GraphOptions
from osm_expand.engine.roads.road_types import MajorRoadOptions, RoadType
from osm_expand.engine.roads.routing import RoutingOptions
from osm_expand.engine.traffic.neighbours import NeighbourOptions
from osm_expand.engine.traffic.trade import TradeOptions, draw_traffic_factor
from osm_expand.engine.traffic.trips import TripOptions
from osm_expand.errors import HistoryError
from osm_expand.growth_patterns import era_defaults
from synth.colonisation import ColonisationOptions
from synth.patches import PatchOptions
from synth.patterns import PatternOptions
from synth.walk import WalkOptions

__all__ = [
    "Anchor", "Clock", "DEFAULT_HISTORY", "DEFAULT_YEARS", "MAX_YEARS", "Era", "GROWTH_PATTERNS", "History",
    "KernelOptions", "PatternSettings", "YearValues",
]

#: The history ``osm-expand CITY`` runs when ``--history`` is not given.
DEFAULT_HISTORY = "example"
#: Years a history runs when it does not say (``years``): "what could this town look like in 50 years"
#: (DESIGN.md's users), about two generations of building.
DEFAULT_YEARS = 50
#: Most years a run may simulate (``--years``, ``years``): a simulated year costs seconds to tens of
#: seconds on the fixture towns (Campo Grande's 30 years take 298 s), so 1,000 years are hours to days
#: of work; more is a typo, and would run on without a word.
MAX_YEARS = 1000
#: Largest G(t) (share of the network's segments added in one year): 1.0 doubles the network in a
#: year, a hundred times the fastest real growth (1.1 %/year, see DEFAULT_GROWTH); more never finishes.
MAX_GROWTH = 1.0
#: G(t) when a history does not give ``growth``: 1 % of the segments a year, Germany's settlement and
#: transport area around 2000 (129 ha a day on about 43,000 km², 1.1 %/year; Destatis).
DEFAULT_GROWTH = 0.01
#: Traffic rise per year (units per pair of neighbouring cities) when ``traffic`` is not given:
#: 000 §4.2.8's drift Δt = (r − c2)·c3 with r ~ U(0, 1), c2 = 0.3, c3 = 50, i.e. 10 a year on average.
DEFAULT_TRAFFIC_RATE = 10.0
#: avgprice(t) when not given: the level the bundled margins assume (:mod:`osm_expand.engine.buildout.economy`:
#: avgprice · margin is each type's floor-area ratio at 100).
DEFAULT_AVGPRICE = 100.0


#: Growth patterns that grow whole districts, by name, with the options an era starts from: the registry of
#: growth patterns (:mod:`osm_expand.growth_patterns`, which the command line's ``--pattern`` and the
#: pipeline read too). The Beneš street patterns (:data:`synth.patterns.PATTERNS`) grow from starts
#: (003 §3.3.2).
GROWTH_PATTERNS: Mapping[str, Any] = MappingProxyType(era_defaults())

#: An era's pattern options: the kernel's own options object.
PatternSettings = PatternOptions | PatchOptions | WalkOptions | ColonisationOptions


class Anchor(StrEnum):
    """How a history's years meet the map's year (see :class:`Clock`)."""

    MAP = "map"  #: the history's years are calendar years; the run begins in the map's year
    START = "start"  #: the history is replayed from its start; the map's year is its ``start``


@dataclass(frozen=True)
class Clock:
    """The years of one run: history years for eras and functions, calendar years for dates.

    Step ``k`` (0, 1, …) of the loop is history year ``first + k``; what it
    builds is dated ``first + k + offset``.

    Attributes
    ----------
    first : int
        The history year of the run's first step.
    offset : int
        Calendar year minus history year.
    """

    first: int
    offset: int = 0

    def history_year(self, step: int) -> int:
        """The history year of loop step ``step`` (0-based): what eras and time functions are read at."""
        return self.first + int(step)

    def calendar_year(self, step: int) -> int:
        """The calendar year of loop step ``step``: the ``year`` stamped on what it builds."""
        return self.first + int(step) + self.offset


@dataclass(frozen=True)
class Era:
    """One entry of a history's sequence of eras (000 §4.2.9).

    An era that recurs is several entries with the same name and the same
    definition at different start years.

    Attributes
    ----------
    name : str
    start : int
        History year the era begins.
    end : int or None
        History year the next era begins (exclusive); None for the last era.
    pattern : str
        Growth pattern: a district pattern of :data:`GROWTH_PATTERNS`
        (``example``, ``walk``, ``colonisation``) or a Beneš street pattern of
        :data:`synth.patterns.PATTERNS`.
    options : PatternOptions, PatchOptions, WalkOptions or ColonisationOptions
        The pattern's kernel options: the named set with the era's overrides.
    road_types : tuple of (RoadType, float)
        Relative frequencies of the four major-road types (000 §4.2.7, §4.2.9),
        as written (not normalised); at least one positive.
    land_use_interval : int or None
        Years between land-use updates in this era (002 §4.1); None: the
        history's ``options.land_use.update_interval``.
    description : str
    """

    name: str
    start: int
    end: int | None
    pattern: str
    options: PatternSettings
    road_types: tuple[tuple[RoadType, float], ...]
    land_use_interval: int | None = None
    description: str = ""

    def road_type_shares(self) -> dict[RoadType, float]:
        """The four road types' probabilities (summing to 1), every type present, in :class:`RoadType` order."""
        weights = dict(self.road_types)
        total = sum(weights.values())
        return {t: weights.get(t, 0.0) / total for t in RoadType}


@dataclass(frozen=True)
class KernelOptions:
    """The kernels' time-independent options as the history sets them (``[options.<name>]``).

    ``lattice.slope_weight`` is O1 and ``trade.o2`` is O2 (set by
    ``[coefficients]``); ``routing``'s turn penalty fields are replaced by
    this year's R(t) in :attr:`YearValues.routing`.
    """

    lattice: LatticeOptions = field(default_factory=LatticeOptions)
    built_up: BuiltUpOptions = field(default_factory=BuiltUpOptions)
    graph: GraphOptions = field(default_factory=GraphOptions)
    routing: RoutingOptions = field(default_factory=RoutingOptions)
    major_roads: MajorRoadOptions = field(default_factory=MajorRoadOptions)
    trade: TradeOptions = field(default_factory=TradeOptions)
    trips: TripOptions = field(default_factory=TripOptions)
    neighbours: NeighbourOptions = field(default_factory=NeighbourOptions)
    nuclei: NucleiOptions = field(default_factory=NucleiOptions)
    land_use: LandUseOptions = field(default_factory=LandUseOptions)
    economy: EconomyOptions = field(default_factory=EconomyOptions)


@dataclass(frozen=True)
class YearValues:
    """One year's values of a history, as the kernels take them (plain numbers and options objects).

    Attributes
    ----------
    year : int
        The history year.
    era : Era
        The era of that year.
    growth : float
        G(t): share of the network's segments added this year (002 ``streetgrowth[t]``), ≥ 0.
    traffic : float
        t(t) = b·traffic(t), traffic units per pair of neighbouring cities (003 §3.5).
    traffic_increase : float
        t(t) − t(t − 1), what 003 Algorithm 2 adds to each pair's demand this year.
    avgprice : float
        avgprice(t), currency per m² of land (002 Eq. 9).
    road_width : float
        A(t), metres: the width of new major roads and of widened extendible segments (003 §3.4.2).
    costs : EdgeCosts
        C1…C6 (003 §3.4.2) for :func:`~osm_expand.engine.roads.path_graph.pathfinding_graph`.
    routing : RoutingOptions
        The turn penalty P(t, α) (003 Fig. 6) with the history's routing options.
    o1, o2, o3, o4 : float
        003's time-independent coefficients: slope weight, capacity per metre
        of width, length and cost weights of WINNER (:func:`~osm_expand.engine.roads.routing.choose`).
    land_use_update : bool
        Whether the land-use update (002 §4.1, Table 3) runs this year: in
        the era's first year and every ``land_use_interval`` years after.
    """

    year: int
    era: Era
    growth: float
    traffic: float
    traffic_increase: float
    avgprice: float
    road_width: float
    costs: EdgeCosts
    routing: RoutingOptions
    o1: float
    o2: float
    o3: float
    o4: float
    land_use_update: bool

    def new_streets(self, n_segments: int, carry: float = 0.0) -> tuple[int, float]:
        """This year's number of new streets, ``G(t) · n_segments`` with the fraction carried over.

        Parameters
        ----------
        n_segments : int
            Segments (junction-to-junction edges) of the network now.
        carry : float
            The fraction left over from last year (0 in the first year).

        Returns
        -------
        count : int
            Streets (segments) to grow this year.
        carry : float
            The fraction to pass next year, in [0, 1).

        A town of 150 segments at 1 % a year grows one street (carry 0.5),
        then two (carry 0).
        """
        quota = self.growth * max(int(n_segments), 0) + float(carry)
        count = int(math.floor(quota + 1e-9))
        return count, max(quota - count, 0.0)


@dataclass(frozen=True, eq=False)
class History:
    """A history read from a TOML file (see the module docstring and ``docs/histories.md``).

    Attributes
    ----------
    name, description : str
    source : str
        Where it was read from (``bundled:<name>`` or the file's path).
    start : int
        History year a run begins at (see :class:`Anchor`); not before the first era.
    anchor : Anchor
        How the history's years meet the map's year.
    years : int
        Years a run lasts unless the user says otherwise (``--years``).
    eras : tuple of Era
        In time order, start years increasing; an era may recur.
    growth, traffic, avgprice : TimeFunction
        G(t) (share of segments per year), the traffic base (units per pair;
        t(t) = b·traffic(t)) and avgprice(t) (per m² of land).
    road_width : TimeFunction
        A(t), metres.
    turn_centre_deg, turn_width_deg, turn_height : TimeFunction
        P(t, α)'s centre S_c and width S_w (degrees of α, 180° = straight on)
        and height S_p (cost units; 003 Fig. 6).
    costs : mapping of str to TimeFunction
        C1…C6 by :class:`~osm_expand.engine.roads.path_graph.EdgeCosts` field
        (major, minor, harbour, built_harbour, bridge, extendible).
    o1, o2, o3, o4 : float
        003's time-independent coefficients.
    land_use_types : tuple of LandUseType
        002 §4's types with their goals and valuation terms.
    economies : tuple of TypeEconomy
        One per land-use type, in the same order (002 §5.2 margins, occupants).
    lot_options, footprint_options : mapping of LandUse to options
        Lot subdivision (002 §5.1) and building (002 §5.3) rules per lot class.
    options : KernelOptions
        The kernels' other options.

    Histories compare and hash by identity (a loaded history is a value to
    read from, and may key a cache).
    """

    name: str
    source: str
    start: int
    anchor: Anchor
    years: int
    eras: tuple[Era, ...]
    growth: TimeFunction
    traffic: TimeFunction
    avgprice: TimeFunction
    road_width: TimeFunction
    turn_centre_deg: TimeFunction
    turn_width_deg: TimeFunction
    turn_height: TimeFunction
    costs: Mapping[str, TimeFunction]
    o1: float
    o2: float
    o3: float
    o4: float
    land_use_types: tuple[LandUseType, ...]
    economies: tuple[TypeEconomy, ...]
    lot_options: Mapping[LandUse, LotOptions]
    footprint_options: Mapping[LandUse, FootprintOptions]
    options: KernelOptions
    description: str = ""
    #: May a rebuilding major road demolish the town's own streets (003 §3.4.2's rebuilding city road
    #: on the real town)? False: only what the engine built is ever demolished.
    rebuild_old_town: bool = False

    # ------------------------------------------------------------------ time

    def clock(self, map_year: int | None) -> Clock:
        """The run's years for a map of ``map_year`` (None: the map has no date).

        ``anchor = "map"``: the run begins in ``max(map_year, start)`` (``start``
        without a map year) and dates are history years. ``anchor = "start"``:
        the run begins at ``start`` and dates count from the map's year (from
        ``start`` without one).
        """
        if self.anchor is Anchor.MAP:
            return Clock(first=self.start if map_year is None else max(int(map_year), self.start))
        return Clock(first=self.start, offset=0 if map_year is None else int(map_year) - self.start)

    def era_at(self, year: int) -> Era:
        """The era of history year ``year``: the last to start at or before it.

        Raises
        ------
        InputError
            ``year`` is before the first era.
        """
        starts = [e.start for e in self.eras]
        k = int(np.searchsorted(starts, year, side="right")) - 1
        if k < 0:
            raise HistoryError(f"history {self.name!r}: year {year} is before its first era ({starts[0]})")
        return self.eras[k]

    def values_at(self, year: int, *, traffic_factor: float = 1.0) -> YearValues:
        """This year's numbers for the kernels (003 §3.1's G, t, R; 002's avgprice; O1…O4).

        Parameters
        ----------
        year : int
            History year (:meth:`Clock.history_year`).
        traffic_factor : float
            The city's b of t(t) = b·traffic(t) (:meth:`traffic_factor`); 1: the history's own.

        Returns
        -------
        YearValues
        """
        era = self.era_at(year)
        routing = replace(self.options.routing, turn_centre=math.radians(self.turn_centre_deg(year)),
                          turn_width=math.radians(self.turn_width_deg(year)), turn_height=self.turn_height(year))
        interval = era.land_use_interval or self.options.land_use.update_interval
        b = float(traffic_factor)
        return YearValues(
            year=int(year), era=era, growth=self.growth(year), traffic=b * self.traffic(year),
            traffic_increase=b * (self.traffic(year) - self.traffic(year - 1)), avgprice=self.avgprice(year),
            road_width=self.road_width(year), costs=EdgeCosts(**{k: f(year) for k, f in self.costs.items()}),
            routing=routing, o1=self.o1, o2=self.o2, o3=self.o3, o4=self.o4,
            land_use_update=(int(year) - era.start) % interval == 0,
        )

    def eras_visited(self, map_year: int | None, years: int) -> list[Era]:
        """The eras a run of ``years`` years on a map of ``map_year`` passes through, in order."""
        clock = self.clock(map_year)
        out: list[Era] = []
        for step in range(max(int(years), 0)):
            era = self.era_at(clock.history_year(step))
            if not out or out[-1] is not era:
                out.append(era)
        return out

    def traffic_factor(self, rng: np.random.Generator) -> float:
        """The city's b, uniform in (b_min, b_max) = (0.7, 1.3) (003 §3.5); draw once per city."""
        return draw_traffic_factor(rng, options=self.options.trade)

    # ------------------------------------------------------------------ eras

    def pattern_options(self, era: Era | str) -> PatternSettings:
        """The era's growth-pattern options: the kernel's own options object.

        :class:`~synth.patterns.PatternOptions` for a Beneš pattern (grow from
        ⌈streets / ``streets_per_start``⌉ starts ranked by
        :func:`~osm_expand.engine.growth.nuclei.rank_candidates`; a world-space grid's
        ``angle_offset_deg`` is the loop's to set from the town's bearings),
        :class:`~synth.patches.PatchOptions` for ``example``,
        :class:`~synth.walk.WalkOptions` for ``walk``,
        :class:`~synth.colonisation.ColonisationOptions` for ``colonisation``
        (its ``segment_length`` is the loop's to set to the town's spacing).

        Parameters
        ----------
        era : Era or str
            An era of this history, or its name.
        """
        if isinstance(era, str):
            for e in self.eras:
                if e.name == era:
                    return e.options
            raise HistoryError(f"history {self.name!r} has no era {era!r} "
                               f"(eras: {', '.join(dict.fromkeys(e.name for e in self.eras))})")
        return era.options

    def major_road_type(self, rng: np.random.Generator, year: int) -> RoadType:
        """One of the four major-road types, drawn by the relative frequencies of the era of ``year``.

        000 §4.2.8: "one of the four major road types is chosen" for each new
        link; §4.2.9: the era gives their relative frequencies. One draw from
        ``rng`` per call.
        """
        shares = self.era_at(year).road_type_shares()
        kinds = list(shares)
        return kinds[int(rng.choice(len(kinds), p=np.array([shares[k] for k in kinds])))]

    @property
    def land_use_interval(self) -> int:
        """Years between land-use updates outside eras that set their own (002 §4.1)."""
        return self.options.land_use.update_interval

    def summary(self) -> dict[str, Any]:
        """Plain JSON-ready facts for a run's report: name, source, clock, years and eras."""
        return {"name": self.name, "source": self.source, "start": self.start, "anchor": self.anchor.value,
                "years": self.years,
                "eras": [{"name": e.name, "start": e.start, "end": e.end, "pattern": e.pattern,
                          "road_types": {t.value: w for t, w in e.road_types}} for e in self.eras]}
