"""The whole pipeline: grow a district next to a real town (``osm-expand CITY``).

learn the town (simplify → example) → blocks of the town as mapped →
unbuildable land → distance maps and ranked sites → a growth pattern grows
streets in the best site → the shared joining step joins them to the real
streets; a district joined by fewer than :data:`MIN_JOINS` streets is no
success, and the next site is tried (:func:`osm_expand.district.place_district`,
the loop the engine's districts use too).

The result is the whole city: the town as mapped plus the district, each
street marked with its origin. The simplified network and the example are
how the town was learned; they are returned beside it, never as the town.
Then :func:`osm_expand.maturation.mature`, a step of its own, lets it live
through the years of a history (the engine).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely

from osm_expand.blocks import blocks
from osm_expand.district import at_least, place_district
from osm_expand.engine.planarity import without_touching
from osm_expand.errors import InputError, NoRoomError
from osm_expand.fidelity import FidelityReport, fidelity
from osm_expand.growth_patterns import make_pattern
from osm_expand.heights import with_heights
from osm_expand.joins import JoinReport
from osm_expand.land import LandOptions, land_cover_taken, read_land, unbuildable
from osm_expand.model import City, Origin, StreetNetwork, polyline_length
from osm_expand.sites import DistanceMaps, Site, SiteOptions, choose_sites, default_district_area, distance_maps
from simplify import simplify
from simplify.example import Example, build_example
from simplify.hierarchy import with_levels
from simplify.options import SimplifyOptions
from synth.growth import Growth, GrowthPattern, for_a_run

#: A district smaller than this many blocks (squares of the town's junction spacing) is refused.
MIN_BLOCKS = 9
#: The largest district: this many times the town's built-up area (bounds the work and the memory).
MAX_AREA_SHARE = 4.0
#: A district joined to the town by fewer streets than this is not a success.
MIN_JOINS = 2
#: Sites tried, best first, before giving up.
SITES_TRIED = 5
#: The report's note when the district grows beyond the map's bounds because the town fills them.
BEYOND_NOTE = ("the town fills its map: the district grows at its edge beyond the data bounds "
               "(--within-bounds to refuse instead)")
#: The report's note when the district could be joined only across the town's presumed frontage.
CROSSED_NOTE = ("the district is joined to the town between houses the map does not show (no site could be "
                "joined around the town's frontage)")
#: Every note the report may carry (the command line prints each on stderr, even with -q).
NOTES = (BEYOND_NOTE, CROSSED_NOTE)
#: What :func:`simplified_or_fail` says when nothing is left.
NOTHING_LEFT = "no streets left after simplification (every street is a dead end or isolated)"

Progress = Callable[[str], None]


@dataclass(frozen=True)
class ExpandOptions:
    """Where and how the district grows (keyword-only fields; defaults are the CLI's)."""

    seed: int = 0
    direction: str | None = None  #: N, NE, ..., or None for the best site anywhere
    at: tuple[float, float] | None = None  #: site centre in metres
    #: m²; default: ``site.area_share`` of the built-up area, at most ``site.neighbourhood_area``
    area: float | None = None
    #: land outside the map's data bounds: True free, False never taken, None (default) taken only when the
    #: town fills its map (no site inside it), with :data:`BEYOND_NOTE` in the report
    beyond_bounds: bool | None = None
    pattern: str = "example"  #: growth pattern: a name of :data:`osm_expand.growth_patterns.PATTERN_NAMES`
    #: judge the district against real neighbourhoods of the town (:mod:`osm_expand.fidelity`)
    fidelity: bool = True
    site: SiteOptions = field(default_factory=SiteOptions)
    land: LandOptions = field(default_factory=LandOptions)


@dataclass(frozen=True)
class Learned:
    """How the town was learned: its simplified network and the example (004 §4.2, §3.1)."""

    simplified: StreetNetwork
    example: Example
    report: dict


@dataclass(frozen=True)
class ExpandResult:
    city: City  #: the town as mapped and the new district
    site: Site
    learned: Learned
    joins: JoinReport
    growth: Growth  #: what the pattern returned (its footprint is the district's area)
    fidelity: FidelityReport | None
    report: dict


def district_pattern(learned: Learned) -> Callable[[str, object], GrowthPattern]:
    """The engine's factory of district patterns for an era: ``(name, options) -> GrowthPattern``, from the
    registry of growth patterns (:mod:`osm_expand.growth_patterns`) over the town's example."""
    return lambda name, options: make_pattern(name, learned.example, options)


def simplified_or_fail(raw: StreetNetwork, options: SimplifyOptions | None = None):
    """:func:`simplify.simplify`, or :class:`InputError` when no street survives it."""
    result = simplify(raw, options)
    if not result.network.streets:
        raise InputError(NOTHING_LEFT)
    return result


def learn(city: City) -> Learned:
    """The town's example: simplified streets with Gravelius levels and per-junction statistics."""
    result = simplified_or_fail(city.network)
    source = with_levels(result.network)
    return Learned(simplified=source, example=build_example(source, result.dead_ends), report=result.report)


def prepare(city: City, land: LandOptions | None = None) -> City:
    """The city with its blocks (from the streets as mapped), unbuildable land, the land model (frontage,
    settlement, land cover: :func:`osm_expand.land.read_land`) and building heights."""
    return with_heights(city).replace(blocks=tuple(blocks(city.network, year=None)),
                                      unbuildable=unbuildable(city, land), land=read_land(city, land))


def expand(city: City, options: ExpandOptions | None = None, *, pattern: GrowthPattern | None = None,
           progress: Progress = lambda message: None) -> ExpandResult:
    """Grow a district next to the town and join it to the real streets.

    Parameters
    ----------
    city : City
        The town as read by :func:`osm_expand.load`.
    options : ExpandOptions
        Seed, where and how big.
    pattern : GrowthPattern, optional
        How streets grow; default the registry's ``options.pattern`` over the town's own example. A
        copy without what the object kept from districts it grew before is used
        (:func:`synth.growth.for_a_run`), so the same seed grows the same district with a reused object.
    progress : callable
        Told the name of each stage as it starts.

    Returns
    -------
    ExpandResult
        The whole city (the town as mapped and the district), the site, how
        the town was learned, the joins and a JSON-ready report.

    Raises
    ------
    InputError
        A town too small to learn from, an area out of range, no room, or a
        district that cannot be joined to the town.
    """
    opts = options or ExpandOptions()
    progress("simplifying the town into an example")
    learned = learn(city)
    progress("finding blocks, unbuildable land and a site")
    city = prepare(city, opts.land)
    maps = distance_maps(city, opts.site, margin=_margin(city), beyond_bounds=bool(opts.beyond_bounds))
    area = _district_area(opts, maps.built_area, learned.example.spacing)
    sites, maps, beyond = _sites(city, maps, area, opts)
    if not sites:
        raise NoRoomError(_no_room(maps, area, learned.example.spacing, beyond))
    notes = [BEYOND_NOTE] if beyond and not opts.beyond_bounds else []
    if pattern is None:
        pattern = make_pattern(opts.pattern, learned.example)  # OptionError for a name not in the registry
    else:  # none of what the object kept from districts it grew before: the same seed, the same district
        pattern = for_a_run(pattern)
    spacing = learned.example.spacing
    placement = place_district(
        city, sites, pattern, spacing=spacing, accept=at_least(MIN_JOINS),
        rng=lambda attempt: np.random.default_rng([opts.seed, attempt]),
        bounds=None if beyond else city.bounds_polygon, year=city.year, cross_taken_last=True,
        progress=lambda attempt: progress(f"growing streets ({pattern.name}) at site {attempt + 1}"))
    placed = placement.placed
    if placed is None:
        raise InputError(f"the district cannot be joined to the town by {MIN_JOINS} streets at any of the "
                         f"{len(placement.tried)} best sites ({placement.describe_tried()}); "
                         f"try --at or another --direction")
    attempt, site, growth, grown, joins = placed.rank, placed.site, placed.growth, placed.city, placed.joins
    if placed.crossed:
        notes.append(CROSSED_NOTE)
    # the engine's planarity net, over the district too: the pattern's exact checks miss streets that
    # touch once written to the millimetre (Monaco, seed 7: an end 1 mm from another street)
    grown, untouched = without_touching(grown, known={s.id for s in city.network.streets})
    if opts.fidelity:
        progress("judging the district against real parts of the town")
    judged = _judge(city, grown, growth, joins, opts.seed) if opts.fidelity else None
    report = {**_report(grown, site, area, spacing, joins, attempt, pattern.name, judged),
              "touching_streets_dropped": untouched}
    report.update(beyond_bounds=beyond, land=city.land.to_dict() if city.land is not None else None,
                  land_cover_taken=land_cover_taken(city, grown), notes=notes)
    return ExpandResult(city=grown, site=site, learned=learned, joins=joins, growth=growth, fidelity=judged,
                        report=report)


def _margin(city: City) -> float:
    """Land rasterised around the town's streets: half the town's diagonal (m)."""
    pts = city.network.xy[city.network.used_nodes()]
    return 0.5 * float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0))))


def _district_area(opts: ExpandOptions, built: float, spacing: float) -> float:
    """The district's area (m²), checked against the town's size before any work."""
    smallest, largest = MIN_BLOCKS * spacing ** 2, MAX_AREA_SHARE * built
    # by default a quarter of the town, at least the smallest district and at most a neighbourhood unit
    area = opts.area or max(default_district_area(opts.site, built), smallest)
    if smallest > largest:
        raise InputError(f"too little town to grow from: {built:.0f} m² built up, and a district of {MIN_BLOCKS} "
                         f"blocks at its {spacing:.0f} m junction spacing ({np.ceil(smallest):.0f} m²) may be at "
                         f"most {MAX_AREA_SHARE:g} times that (motorways and ramps are not town)")
    if area < smallest:
        raise InputError(f"a district of {area:.0f} m² would hold fewer than {MIN_BLOCKS} blocks at this town's "
                         f"{spacing:.0f} m junction spacing; try --area {np.ceil(smallest):.0f} (or more)")
    if area > largest:
        raise InputError(f"--area {area:.0f} is more than {MAX_AREA_SHARE:g} times the town's built-up area "
                         f"({built:.0f} m²); the district may be at most --area {np.floor(largest):.0f}")
    return area


def _sites(city: City, maps: DistanceMaps, area: float, opts: ExpandOptions
           ) -> tuple[list[Site], DistanceMaps, bool]:
    """The ranked sites, the maps they were found on, and whether they may lie beyond the map's bounds:
    inside them first unless ``opts.beyond_bounds``; beyond them when that is None and nothing fits
    inside (the town fills its map)."""
    beyond = bool(opts.beyond_bounds)
    radius = float(np.sqrt(area / np.pi))
    if beyond and 2.5 * radius > _margin(city):
        maps = distance_maps(city, opts.site, margin=2.5 * radius, beyond_bounds=True)
    sites = choose_sites(maps, area, opts.site, direction=opts.direction, at=opts.at, most=SITES_TRIED)
    if not sites and opts.beyond_bounds is None:
        beyond = True
        maps = distance_maps(city, opts.site, margin=max(_margin(city), 2.5 * radius), beyond_bounds=True)
        sites = choose_sites(maps, area, opts.site, direction=opts.direction, at=opts.at, most=SITES_TRIED)
    return sites, maps, beyond


def _no_room(maps: DistanceMaps, area: float, spacing: float, beyond: bool) -> str:
    """Why no site fits, and an ``--area`` that does: nine tenths of the largest disc of free land
    (a site holding that much exists by construction), when that still makes a district."""
    free = ~(maps.water | maps.city | maps.outside)
    largest = float(np.pi * maps.free_radius[free].max() ** 2) if free.any() else 0.0
    where = "beyond the map's bounds too" if beyond else "inside the map's bounds"
    fits = np.floor(0.9 * largest / 1000.0) * 1000.0
    if fits >= MIN_BLOCKS * spacing ** 2 and fits < area:
        return f"no room for a district of {area:.0f} m² {where}; try --area {fits:.0f}"
    hint = "" if beyond else "; try --beyond-bounds to grow outside them"
    return f"no room for a district of {area:.0f} m² {where}, nor for the smallest ({MIN_BLOCKS} blocks){hint}"


def district_area(city: City) -> float:
    """The area of the new district's outline: the convex hull of its new streets (m²)."""
    lines = [shapely.LineString(city.network.street_xy(city.network.streets[k])) for k in city.new_streets()]
    return float(shapely.MultiLineString(lines).convex_hull.area) if lines else 0.0


def _judge(town: City, grown: City, growth: Growth, joins: JoinReport, seed: int) -> FidelityReport | None:
    """The district against real parts of the town as mapped (its own random stream: growth is unchanged)."""
    net = grown.network
    district = [net.street_xy(net.streets[k]) for k in grown.new_streets()]
    if not district or growth.footprint is None or growth.footprint.is_empty:
        return None
    # the footprint's holes (mapped buildings with their margin, taken land) filled: the yardstick reads
    # a street ending on its window's boundary as cut by it and running on, which a street ending at a
    # house inside the district does not (Krems seed 2: 12 dead ends on the map, 4 counted with the holes)
    window = shapely.union_all([shapely.Polygon(p.exterior) for p in shapely.get_parts(growth.footprint)
                                if p.geom_type == "Polygon"])
    town_lines = [town.network.street_xy(s) for s in town.network.streets]
    return fidelity(district, town_lines, window=window, open_points=joins.at,
                    rng=np.random.default_rng([seed, 0xF1DE]))


def _report(city: City, site: Site, area: float, spacing: float, joins: JoinReport, attempt: int, pattern: str,
            judged: FidelityReport | None) -> dict:
    net = city.network
    new = city.new_streets()
    grown = [k for k in new if net.streets[k].origin == Origin.GROWN]
    return {
        "site_centre": [round(float(v), 1) for v in site.centre], "site_area_m2": round(area),
        "site_rank": attempt + 1, "spacing_m": round(spacing, 1),
        "source_streets": sum(1 for s in net.streets if s.origin == Origin.SOURCE),
        "source_buildings": len(city.buildings), "grown_streets": len(grown),
        "district_area_m2": round(district_area(city)),
        "grown_length_km": round(sum(polyline_length(net.street_xy(net.streets[k])) for k in new) / 1000, 3),
        "connections": joins.joins, "joins": joins.to_dict(), "pattern": pattern,
        **({"fidelity": judged.to_dict()} if judged is not None else {}),
    }
