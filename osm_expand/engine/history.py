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
default), ``european``, ``north-american``. :func:`load_history` reads one
by name or path; every problem is one :class:`~osm_expand.errors.InputError`
line ``FILE: key.path: what is wrong``.

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
  (:func:`osm_expand.engine.trade.draw_traffic_factor`). 003's Algorithm 2
  needs only the yearly increase t(t) − t(t−1) (trade routes start empty,
  003 §3.4.2), so the bundled functions are rates: 000 §4.2.8's own traffic
  drift, (E[r] − c2)·c3 = (0.5 − 0.3)·50 = 10 units a year, is the modern one.
- *A(t) is a width.* 003 §3.4.2 calls A(t) both "recommended traffic
  capacity" and "the recommended width" that new major roads are widened to;
  :func:`osm_expand.engine.majorroads.plan_major_road` takes a width, so A(t)
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

import difflib
import math
import os
import tomllib
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import MISSING, asdict, dataclass, field, fields, replace
from enum import StrEnum
from importlib import resources
from inspect import signature
from pathlib import Path
from types import MappingProxyType
from typing import Any, NoReturn

import numpy as np

from osm_expand.engine.economy import DEFAULT_ECONOMY, EconomyOptions, TypeEconomy
from osm_expand.engine.footprints import DEFAULT_FOOTPRINT_OPTIONS, FootprintOptions
from osm_expand.engine.landuse import (
    DEFAULT_TYPES,
    Attribute,
    LandUseOptions,
    LandUseType,
    Valuation,
    ValuationTerm,
    types_from_config,
)
from osm_expand.engine.lattice import BuiltUpOptions, EdgeCosts, GraphOptions, LatticeOptions
from osm_expand.engine.lots import DEFAULT_LOT_OPTIONS, LandUse, LotOptions
from osm_expand.engine.majorroads import MajorRoadOptions, RoadType
from osm_expand.engine.neighbours import NeighbourOptions
from osm_expand.engine.nuclei import NucleiOptions
from osm_expand.engine.routing import RoutingOptions, choose
from osm_expand.engine.timefn import TimeFunction
from osm_expand.engine.trade import TradeOptions, draw_traffic_factor
from osm_expand.engine.trips import TripOptions
from osm_expand.errors import HistoryError, InputError
from osm_expand.growth_patterns import era_defaults
from osm_expand.model.enums import parse_enum
from synth.colonisation import ColonisationOptions
from synth.patches import PatchOptions
from synth.patterns import PATTERNS, PatternOptions
from synth.walk import WalkOptions

__all__ = [
    "Anchor", "Clock", "DEFAULT_HISTORY", "DEFAULT_YEARS", "MAX_YEARS", "Era", "GROWTH_PATTERNS", "History",
    "KernelOptions",
    "PatternSettings", "YearValues", "bundled", "history_from_mapping", "load_history",
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
#: Largest history file read, bytes: the bundled ones are under 10 kB; ``--history /dev/zero`` would
#: otherwise be read until memory runs out.
MAX_HISTORY_BYTES = 1 << 20
#: G(t) when a history does not give ``growth``: 1 % of the segments a year, Germany's settlement and
#: transport area around 2000 (129 ha a day on about 43,000 km², 1.1 %/year; Destatis).
DEFAULT_GROWTH = 0.01
#: Traffic rise per year (units per pair of neighbouring cities) when ``traffic`` is not given:
#: 000 §4.2.8's drift Δt = (r − c2)·c3 with r ~ U(0, 1), c2 = 0.3, c3 = 50, i.e. 10 a year on average.
DEFAULT_TRAFFIC_RATE = 10.0
#: avgprice(t) when not given: the level the bundled margins assume (:mod:`osm_expand.engine.economy`:
#: avgprice · margin is each type's floor-area ratio at 100).
DEFAULT_AVGPRICE = 100.0


def _field_default(cls: type, name: str) -> Any:
    # cls is an options dataclass; ``type`` does not tell mypy so
    f = cls.__dataclass_fields__[name]  # type: ignore[attr-defined]
    return f.default_factory() if f.default_factory is not MISSING else f.default


def _narrowest_major_road() -> float:
    """A(t) when not given: the narrowest major road the trip model builds (two lanes and sidewalks, 11 m)."""
    t = TripOptions()
    return t.major_min_lanes * t.lane_width + 2.0 * t.sidewalk_width


#: Growth patterns that grow whole districts, by name, with the options an era starts from: the registry of
#: growth patterns (:mod:`osm_expand.growth_patterns`, which the command line's ``--pattern`` and the
#: pipeline read too). The Beneš street patterns (:data:`synth.patterns.PATTERNS`) grow from starts
#: (003 §3.3.2).
GROWTH_PATTERNS: Mapping[str, Any] = MappingProxyType(era_defaults())

#: An era's pattern options: the kernel's own options object.
PatternSettings = PatternOptions | PatchOptions | WalkOptions | ColonisationOptions


def _pattern_names() -> list[str]:
    return [*GROWTH_PATTERNS, *PATTERNS]


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


#: Fields of kernel options that the history sets elsewhere: field → the key that sets it.
_SET_ELSEWHERE: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "lattice": {"slope_weight": "coefficients.o1"},
    "trade": {"o2": "coefficients.o2"},
    "routing": {"turn_centre": "roads.turn_centre_deg", "turn_width": "roads.turn_width_deg",
                "turn_height": "roads.turn_height"},
})


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
        C1…C6 (003 §3.4.2) for :func:`~osm_expand.engine.lattice.pathfinding_graph`.
    routing : RoutingOptions
        The turn penalty P(t, α) (003 Fig. 6) with the history's routing options.
    o1, o2, o3, o4 : float
        003's time-independent coefficients: slope weight, capacity per metre
        of width, length and cost weights of WINNER (:func:`~osm_expand.engine.routing.choose`).
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
        C1…C6 by :class:`~osm_expand.engine.lattice.EdgeCosts` field
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
        :func:`~osm_expand.engine.nuclei.rank_candidates`; a world-space grid's
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


# ============================================================================ reading


def bundled() -> list[str]:
    """Names of the bundled histories (``osm_expand/histories/*.toml``), sorted."""
    folder = resources.files("osm_expand").joinpath("histories")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_history(name_or_path: str | os.PathLike[str] = DEFAULT_HISTORY) -> History:
    """A history by bundled name (``example``, ``european``, ``north-american``) or TOML file path.

    Parameters
    ----------
    name_or_path : str or path
        A bundled name, or the path of a ``.toml`` file.

    Returns
    -------
    History

    Raises
    ------
    InputError
        One line ``FILE: key.path: what is wrong`` (``FILE`` is ``<name>.toml``
        for a bundled history, else the path as given): a missing file, bad
        TOML, a missing or unknown key, a wrong type or value.
    """
    text, label, source, stem = _read(name_or_path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise HistoryError(f"{label}: not valid TOML: {e}") from None
    return history_from_mapping(data, label=label, source=source, default_name=stem)


def _read(name_or_path: str | os.PathLike[str]) -> tuple[str, str, str, str]:
    """The file's text, its label for messages, its source and its stem."""
    given = os.fspath(name_or_path)
    if not given.strip():
        raise HistoryError(f"history {given!r}: give a bundled history ({', '.join(bundled())}) or a .toml file")
    if given in bundled():
        text = resources.files("osm_expand").joinpath("histories", f"{given}.toml").read_text(encoding="utf-8")
        return text, f"{given}.toml", f"bundled:{given}", given
    path = Path(given)
    if not path.exists():
        if path.suffix != ".toml" and os.sep not in given:
            raise HistoryError(f"history {given!r}: not a bundled history ({', '.join(bundled())}) "
                               "nor a .toml file")
        raise HistoryError(f"{given}: no such history file")
    if path.is_dir():
        raise HistoryError(f"{given}: is a directory, not a history file")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_HISTORY_BYTES + 1)
        if len(data) > MAX_HISTORY_BYTES:
            raise HistoryError(f"{given}: too large for a history file (more than {MAX_HISTORY_BYTES >> 20} MB)")
        return data.decode("utf-8-sig"), given, str(path), path.stem  # -sig: a BOM (Windows editors) is fine
    except UnicodeDecodeError:
        raise HistoryError(f"{given}: not a text file (UTF-8 TOML expected)") from None
    except OSError as e:
        raise HistoryError(f"{given}: cannot read: {e.strerror or e}") from None


def history_from_mapping(data: Mapping[str, Any], *, label: str = "<history>", source: str = "",
                         default_name: str = "history") -> History:
    """A :class:`History` from parsed TOML (``tomllib.loads``); errors start with ``label``.

    Parameters
    ----------
    data : mapping
        The file's top-level table.
    label : str
        The file's name for error messages.
    source : str
        Stored in :attr:`History.source`.
    default_name : str
        The name when the file gives none (the file's stem).

    Returns
    -------
    History
    """
    return _Reader(label).history(data, source=source or label, default_name=default_name)


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


#: Top-level keys of a history file.
_TOP = ("name", "description", "start", "anchor", "years", "rebuild_old_town", "growth", "traffic", "avgprice", "roads",
        "coefficients", "eras", "land_use", "lots", "buildings", "options")
_ROADS = ("width", "turn_centre_deg", "turn_width_deg", "turn_height", "costs")
_COEFFICIENTS = ("o1", "o2", "o3", "o4")
_ERA = ("name", "start", "description", "pattern", "pattern_options", "road_types", "land_use_interval")
#: Era keys that make up its definition (a recurring era repeats only name and start).
_ERA_DEFINITION = ("pattern", "pattern_options", "road_types", "land_use_interval", "description")
_LAND_USE = ("name", "goal", "lot_size", "terms", "economy")
#: An era's definition: pattern, options, road types, land-use interval, description.
_EraDefinition = tuple[str, PatternSettings, tuple[tuple[RoadType, float], ...], "int | None", str]


class _Reader:
    """Reads one history file's parsed TOML; every error is ``label: key.path: what is wrong``."""

    def __init__(self, label: str):
        self.label = label

    def fail(self, key: str, why: str) -> NoReturn:
        raise HistoryError(f"{self.label}: {key}: {why}")

    # ------------------------------------------------------------------ plain values

    def table(self, value: Any, key: str) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {value!r}")
        return value

    def known(self, table: Mapping[str, Any], key: str, valid: Iterable[str]) -> None:
        valid = list(valid)
        for name in table:
            if name not in valid:
                close = difflib.get_close_matches(name, valid, n=1)
                hint = f"did you mean {close[0]!r}?" if close else f"valid: {', '.join(valid)}"
                self.fail(_join(key, name), f"unknown key ({hint})")

    def integer(self, value: Any, key: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected a whole number, got {value!r}")
        return int(value)

    def boolean(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {value!r}")
        return value

    def number(self, value: Any, key: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value!r}")
        return float(value)

    def text(self, value: Any, key: str) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {value!r}")
        return value

    def choice(self, value: Any, key: str, kind: type[StrEnum]) -> Any:
        if not isinstance(value, str):  # a StrEnum takes only its text
            self.fail(key, f"expected one of {', '.join(m.value for m in kind)}, got {value!r}")
        return parse_enum(kind, value, f"{self.label}: {key}", error=HistoryError)

    def function(self, value: Any, key: str, *, low: float | None = None, strict: bool = False,
                 high: float | None = None) -> TimeFunction:
        try:
            fn = TimeFunction.from_toml(value, key)
        except InputError as e:
            raise HistoryError(f"{self.label}: {e}") from None
        if low is not None and (fn.low <= low if strict else fn.low < low):
            self.fail(key, f"values must be {'>' if strict else '≥'} {low:g}, got {fn.low:g}")
        if high is not None and fn.high > high:
            self.fail(key, f"values must be ≤ {high:g}, got {fn.high:g}")
        return fn

    # ------------------------------------------------------------------ options dataclasses

    def convert(self, value: Any, hint: Any, key: str) -> Any:
        """``value`` checked against a dataclass field's type (lists become tuples)."""
        origin = typing.get_origin(hint)
        if hint is float:
            return self.number(value, key)
        if hint is bool:
            if not isinstance(value, bool):
                self.fail(key, f"expected true or false, got {value!r}")
            return value
        if hint is int:
            return self.integer(value, key)
        if isinstance(hint, type) and issubclass(hint, StrEnum):
            return self.choice(value, key, hint)
        if hint is str:
            return self.text(value, key)
        if origin is tuple:
            args = typing.get_args(hint)
            if not isinstance(value, (list, tuple)):
                self.fail(key, f"expected a list, got {value!r}")
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(self.convert(v, args[0], f"{key}[{i}]") for i, v in enumerate(value))
            if len(value) != len(args):
                self.fail(key, f"expected a list of {len(args)} values, got {value!r}")
            return tuple(self.convert(v, a, f"{key}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
        if origin in (typing.Union, types.UnionType):
            for arg in typing.get_args(hint):
                if arg is type(None):
                    continue
                try:
                    return self.convert(value, arg, key)
                except InputError:
                    pass
            self.fail(key, f"{value!r} is not a {hint}")
        return value  # any other type: the kernel's own checks judge it

    def build(self, cls: type, value: Any, key: str, *, base: Any = None,
              elsewhere: Mapping[str, str] = MappingProxyType({}), fixed: Mapping[str, Any] = MappingProxyType({}),
              ) -> Any:
        """An options dataclass from a TOML table: ``base`` (or the class defaults) with the table's values.

        ``elsewhere`` names fields the history sets under another key;
        ``fixed`` fields are set by the reader, not the file.
        """
        table = self.table(value, key)
        names = [f.name for f in fields(cls) if f.init and f.name not in fixed]
        for name in table:
            if name in elsewhere:
                self.fail(_join(key, name), f"set by {elsewhere[name]}, not here")
        self.known(table, key, names)
        hints = typing.get_type_hints(cls)
        values = {n: self.convert(v, hints[n], _join(key, n)) for n, v in table.items()}
        if base is None:
            for f in fields(cls):
                if f.init and f.name not in values and f.name not in fixed and \
                        f.default is MISSING and f.default_factory is MISSING:
                    self.fail(_join(key, f.name), "missing")
        try:
            return cls(**fixed, **values) if base is None else replace(base, **fixed, **values)
        except InputError as e:
            self.fail(key, str(e))
        except (TypeError, ValueError) as e:
            self.fail(key, str(e))

    # ------------------------------------------------------------------ the file

    def history(self, data: Mapping[str, Any], *, source: str, default_name: str) -> History:
        self.known(data, "", _TOP)
        for required in ("start", "eras"):
            if required not in data:
                self.fail(required, "missing")
        start = self.integer(data["start"], "start")
        years = self.integer(data.get("years", DEFAULT_YEARS), "years")
        if not 0 <= years <= MAX_YEARS:
            self.fail("years", f"must be 0 to {MAX_YEARS}, got {years}")
        eras = self.eras(data["eras"])
        if start < eras[0].start:
            self.fail("start", f"{start} is before the first era (eras[0].start = {eras[0].start})")
        o = self.coefficients(data.get("coefficients", {}))
        options = self.kernel_options(data.get("options", {}))
        options = replace(options, lattice=self.checked("coefficients.o1", replace, options.lattice,
                                                        slope_weight=o["o1"]),
                          trade=self.checked("coefficients.o2", replace, options.trade, o2=o["o2"]))
        types_, economies = self.land_use(data.get("land_use"))
        default_traffic = [[start, 0.0], [start + 100, 100 * DEFAULT_TRAFFIC_RATE]]
        return History(
            name=self.text(data.get("name", default_name), "name"), source=source, start=start,
            anchor=self.choice(data.get("anchor", Anchor.MAP.value), "anchor", Anchor), years=years, eras=eras,
            growth=self.function(data.get("growth", DEFAULT_GROWTH), "growth", low=0.0, high=MAX_GROWTH),
            traffic=self.function(data.get("traffic", default_traffic), "traffic", low=0.0),
            avgprice=self.function(data.get("avgprice", DEFAULT_AVGPRICE), "avgprice", low=0.0, strict=True),
            **self.roads(data.get("roads", {}), options.routing),
            o1=o["o1"], o2=o["o2"], o3=o["o3"], o4=o["o4"], land_use_types=types_, economies=economies,
            lot_options=self.per_class(data.get("lots", {}), "lots", LotOptions, DEFAULT_LOT_OPTIONS),
            footprint_options=self.per_class(data.get("buildings", {}), "buildings", FootprintOptions,
                                             DEFAULT_FOOTPRINT_OPTIONS),
            options=options, description=self.text(data.get("description", ""), "description"),
            rebuild_old_town=self.boolean(data.get("rebuild_old_town", False), "rebuild_old_town"),
        )

    def checked(self, key: str, make: Any, *args: Any, **kwargs: Any) -> Any:
        """``make(*args, **kwargs)``, its InputError reported under ``key``."""
        try:
            return make(*args, **kwargs)
        except InputError as e:
            self.fail(key, str(e))

    def roads(self, value: Any, routing: RoutingOptions) -> dict[str, Any]:
        """R(t) = (P, A, C1…C6) (003 §3.4.2): History's road fields, defaults from the kernels."""
        roads = self.table(value, "roads")
        self.known(roads, "roads", _ROADS)
        turn = {name: self.function(roads.get(name, default), f"roads.{name}")
                for name, default in (("turn_centre_deg", math.degrees(routing.turn_centre)),
                                      ("turn_width_deg", math.degrees(routing.turn_width)),
                                      ("turn_height", routing.turn_height))}
        if not 0.0 <= turn["turn_centre_deg"].low <= turn["turn_centre_deg"].high <= 180.0:
            self.fail("roads.turn_centre_deg", "values must lie in [0, 180] degrees (180: straight on)")
        # the functions are linear or constant between their sample years, so the kernel's per-field
        # bounds hold in every year when they hold at those years
        for year in sorted({y for f in turn.values() for y in f.years}):
            self.checked(f"roads: in year {year:g}", replace, routing,
                         turn_centre=math.radians(turn["turn_centre_deg"](year)),
                         turn_width=math.radians(turn["turn_width_deg"](year)),
                         turn_height=turn["turn_height"](year))
        width = self.function(roads.get("width", _narrowest_major_road()), "roads.width", low=0.0, strict=True)
        return {**turn, "road_width": width, "costs": MappingProxyType(self.costs(roads.get("costs", {})))}

    def coefficients(self, value: Any) -> dict[str, float]:
        """O1…O4 (003 §3.1); defaults from the kernels that use them."""
        table = self.table(value, "coefficients")
        self.known(table, "coefficients", _COEFFICIENTS)
        defaults = {"o1": _field_default(LatticeOptions, "slope_weight"), "o2": _field_default(TradeOptions, "o2"),
                    "o3": signature(choose).parameters["o3"].default,
                    "o4": signature(choose).parameters["o4"].default}
        out = {k: self.number(table.get(k, d), f"coefficients.{k}") for k, d in defaults.items()}
        for k in ("o3", "o4"):
            if out[k] < 0:
                self.fail(f"coefficients.{k}", f"must be ≥ 0, got {out[k]:g}")
        return out

    def costs(self, value: Any) -> dict[str, TimeFunction]:
        """C1…C6 as time functions by :class:`EdgeCosts` field; each checked by the kernel at its sample years."""
        table = self.table(value, "roads.costs")
        names = [f.name for f in fields(EdgeCosts)]
        self.known(table, "roads.costs", names)
        out = {n: self.function(table.get(n, _field_default(EdgeCosts, n)), f"roads.costs.{n}") for n in names}
        for n, fn in out.items():
            for v in (fn.low, fn.high):
                try:
                    EdgeCosts(**{n: v})
                except InputError as e:
                    self.fail(f"roads.costs.{n}", str(e))
        return out

    def kernel_options(self, value: Any) -> KernelOptions:
        table = self.table(value, "options")
        names = [f.name for f in fields(KernelOptions)]
        self.known(table, "options", names)
        hints = typing.get_type_hints(KernelOptions)
        built = {n: self.build(hints[n], v, f"options.{n}", elsewhere=_SET_ELSEWHERE.get(n, {}))
                 for n, v in table.items()}
        options = KernelOptions(**built)
        if options.land_use.update_interval < 1:  # LandUseOptions checks it only when the update runs
            self.fail("options.land_use.update_interval",
                      f"must be at least 1 year, got {options.land_use.update_interval}")
        return options

    def per_class(self, value: Any, key: str, cls: type, defaults: Mapping[LandUse, Any]) -> Mapping[LandUse, Any]:
        """Lot or building options per lot class (``[lots.<class>]``): the bundled ones with the file's values."""
        table = self.table(value, key)
        self.known(table, key, [u.value for u in LandUse])
        out = dict(defaults)
        for name, sub in table.items():
            out[LandUse(name)] = self.build(cls, sub, f"{key}.{name}", base=defaults.get(LandUse(name)))
        return MappingProxyType(out)

    # ------------------------------------------------------------------ eras

    def eras(self, value: Any) -> tuple[Era, ...]:
        if not isinstance(value, list) or not all(isinstance(e, Mapping) for e in value):
            self.fail("eras", "expected a list of tables ([[eras]])")
        if not value:
            self.fail("eras", "a history needs at least one era")
        definitions: dict[str, tuple[int, Mapping[str, Any]]] = {}
        for k, entry in enumerate(value):
            key = f"eras[{k}]"
            self.known(entry, key, _ERA)
            for required in ("name", "start"):
                if required not in entry:
                    self.fail(f"{key}.{required}", "missing")
            name = self.text(entry["name"], f"{key}.name")
            definition = {d: entry[d] for d in _ERA_DEFINITION if d in entry}
            if not definition:
                continue
            if name in definitions and definitions[name][1] != definition:
                self.fail(f"{key}.name", f"era {name!r} is already defined differently in "
                          f"eras[{definitions[name][0]}]; a recurring era gives only name and start")
            definitions.setdefault(name, (k, definition))
        made = {name: self.era_definition(definition, f"eras[{k}]") for name, (k, definition) in definitions.items()}
        starts: list[int] = []
        for k, entry in enumerate(value):
            start = self.integer(entry["start"], f"eras[{k}].start")
            if starts and start <= starts[-1]:
                self.fail(f"eras[{k}].start", f"{start} is not after eras[{k - 1}].start ({starts[-1]}): "
                          "eras are listed in time order, each starting in a later year")
            if entry["name"] not in made:
                self.fail(f"eras[{k}].pattern", f"missing (era {entry['name']!r} is defined nowhere in the file)")
            starts.append(start)
        eras = []
        for k, entry in enumerate(value):
            pattern, opts, road_types, interval, description = made[entry["name"]]
            eras.append(Era(name=entry["name"], start=starts[k], end=starts[k + 1] if k + 1 < len(starts) else None,
                            pattern=pattern, options=opts, road_types=road_types, land_use_interval=interval,
                            description=description))
        return tuple(eras)

    def era_definition(self, entry: Mapping[str, Any], key: str) -> _EraDefinition:
        """What an era is (000 §4.2.9): its pattern with options, road-type frequencies, land-use interval."""
        if "pattern" not in entry:
            self.fail(f"{key}.pattern", f"missing (one of {', '.join(_pattern_names())})")
        pattern = self.text(entry["pattern"], f"{key}.pattern")
        if pattern not in _pattern_names():
            self.fail(f"{key}.pattern", f"unknown pattern {pattern!r} (valid: {', '.join(_pattern_names())})")
        base = GROWTH_PATTERNS.get(pattern, PATTERNS.get(pattern))
        opts = self.build(type(base), entry.get("pattern_options", {}), f"{key}.pattern_options", base=base)
        if "road_types" not in entry:
            self.fail(f"{key}.road_types", f"missing (relative frequencies of {', '.join(t.value for t in RoadType)})")
        table = self.table(entry["road_types"], f"{key}.road_types")
        self.known(table, f"{key}.road_types", [t.value for t in RoadType])
        road_types = tuple((RoadType(n), self.number(w, f"{key}.road_types.{n}")) for n, w in table.items())
        if any(w < 0 for _, w in road_types) or sum(w for _, w in road_types) <= 0:
            self.fail(f"{key}.road_types", "frequencies must be ≥ 0 with at least one positive")
        interval = None
        if "land_use_interval" in entry:
            interval = self.integer(entry["land_use_interval"], f"{key}.land_use_interval")
            if interval < 1:
                self.fail(f"{key}.land_use_interval", f"must be at least 1 year, got {interval}")
        description = self.text(entry.get("description", ""), f"{key}.description")
        return pattern, opts, road_types, interval, description

    # ------------------------------------------------------------------ land use

    def land_use(self, value: Any) -> tuple[tuple[LandUseType, ...], tuple[TypeEconomy, ...]]:
        """002 §4's types (``[[land_use]]``): a type named like a bundled one may omit what it keeps."""
        if value is None:
            return DEFAULT_TYPES, tuple(_economy_of(t.name, t.lot_size_key) for t in DEFAULT_TYPES)
        if not isinstance(value, list) or not all(isinstance(e, Mapping) for e in value) or not value:
            self.fail("land_use", "expected a non-empty list of tables ([[land_use]])")
        bundled_types = {t.name: t for t in DEFAULT_TYPES}
        entries: list[dict[str, Any]] = []
        economies: list[TypeEconomy] = []
        seen: dict[str, int] = {}
        for k, entry in enumerate(value):
            key = f"land_use[{k}]"
            self.known(entry, key, _LAND_USE)
            if "name" not in entry:
                self.fail(f"{key}.name", "missing")
            name = self.text(entry["name"], f"{key}.name")
            if name in seen:
                self.fail(f"{key}.name", f"type {name!r} is already defined in land_use[{seen[name]}]")
            seen[name] = k
            known = bundled_types.get(name)
            for required in ("goal", "terms"):
                if known is None and required not in entry:
                    self.fail(f"{key}.{required}", f"missing (needed for a type that is not bundled: "
                              f"{', '.join(bundled_types)})")
            # below, known is None only where the entry has the key: fail() refused the rest just above
            goal = self.number(entry["goal"], f"{key}.goal") if "goal" in entry else known.goal  # type: ignore[union-attr]
            if goal < 0:
                self.fail(f"{key}.goal", f"must be ≥ 0 (a share of lot area), got {goal:g}")
            lot_size = self.text(entry.get("lot_size", known.lot_size if known else ""), f"{key}.lot_size")
            if (lot_size or name) not in {u.value for u in LandUse}:
                self.fail(f"{key}.lot_size", f"{lot_size or name!r} is not a lot class (valid: "
                          f"{', '.join(u.value for u in LandUse)}); a new type names the class it is built like")
            terms = self.terms(entry["terms"], f"{key}.terms") if "terms" in entry else known.terms  # type: ignore[union-attr]
            entries.append({"name": name, "goal": goal, "lot_size": lot_size,
                            "terms": [asdict(t) for t in terms]})
            base = _economy_of(name, lot_size or name)
            economies.append(self.build(TypeEconomy, entry.get("economy", {}), f"{key}.economy", base=base,
                                        fixed={"name": name}))
        names = [e["name"] for e in entries]
        for k, e in enumerate(entries):
            for j, t in enumerate(e["terms"]):
                if t["attribute"] == Attribute.INFLUENCE.value and t["of_type"] not in names:
                    where = f"land_use[{k}].terms[{j}].of_type" if "terms" in value[k] else f"land_use[{k}].name"
                    why = "" if "terms" in value[k] else f"the bundled terms of {e['name']!r} weigh it; "
                    self.fail(where, f"{why}type {t['of_type']!r} is not defined (types: {', '.join(names)})")
        try:
            types_ = types_from_config(entries)
        except InputError as e:
            raise HistoryError(f"{self.label}: {e}") from None
        return types_, tuple(economies)

    def terms(self, value: Any, key: str) -> tuple[ValuationTerm, ...]:
        if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
            self.fail(key, "expected a list of tables ([[land_use.terms]])")
        out = []
        for j, t in enumerate(value):
            where = f"{key}[{j}]"
            term = self.build(ValuationTerm, t, where)
            self.choice(term.kind, f"{where}.kind", Valuation)
            self.choice(term.attribute, f"{where}.attribute", Attribute)
            out.append(term)
        return tuple(out)


def _economy_of(name: str, lot_class: str) -> TypeEconomy:
    """The bundled economy of a type: by its name, else by its lot class, renamed."""
    by_name = {e.name: e for e in DEFAULT_ECONOMY}
    return replace(by_name.get(name) or by_name[lot_class], name=name)

