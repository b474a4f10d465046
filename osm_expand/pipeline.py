"""The whole pipeline: grow a district next to a real town (``osm-expand CITY``).

simplify → example → blocks → distance maps and site → random walk in the
site (junctions of the old town's edge with free slots are targets, the old
streets are never crossed) → one network of old and new streets.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np
import shapely

from osm_expand.blocks import blocks
from osm_expand.errors import InputError
from osm_expand.joins import connections, join_to_town
from osm_expand.model import Street, StreetNetwork, polyline_length
from osm_expand.sites import Site, SiteOptions, built_area, choose_site, distance_maps
from simplify import simplify
from simplify.example import Example, build_example
from simplify.hierarchy import with_levels
from synth.grow import grow


@dataclass(frozen=True)
class ExpandOptions:
    seed: int = 0
    direction: str | None = None  # N, NE, ..., or None / "auto"
    at: tuple[float, float] | None = None  # site centre in metres
    area: float | None = None  # m²; default: SiteOptions.area_share of the built-up area
    site: SiteOptions = field(default_factory=SiteOptions)


@dataclass
class ExpandResult:
    network: StreetNetwork  # old and new streets together
    origins: list[str]  # per street: "source" or "grown"
    site: Site
    report: dict


#: What :func:`simplified_or_fail` says when nothing is left.
NOTHING_LEFT = "no streets left after simplification (every street is a dead end or isolated)"


def simplified_or_fail(raw: StreetNetwork, options=None):
    """:func:`simplify.simplify`, or :class:`InputError` when no street survives it."""
    result = simplify(raw, options)
    if not result.network.streets:
        raise InputError(NOTHING_LEFT)
    return result


def expand(raw: StreetNetwork, options: ExpandOptions | None = None, progress=lambda msg: None) -> ExpandResult:
    opts = options or ExpandOptions()
    progress("simplifying")
    simplified = simplified_or_fail(raw)
    source = with_levels(simplified.network)
    example = build_example(source, simplified.dead_ends)
    progress("finding blocks and a site")
    town_blocks = blocks(source)
    built = built_area(source, town_blocks, opts.site)
    area = opts.area or opts.site.area_share * built.area
    spacing = example.spacing
    if area < MIN_BLOCKS * spacing ** 2:
        raise InputError(f"a district of {area:,.0f} m² would hold fewer than {MIN_BLOCKS} blocks at this town's "
                         f"{spacing:.0f} m junction spacing; give --area of at least {MIN_BLOCKS * spacing ** 2:,.0f}")
    radius = float(np.sqrt(area / np.pi))
    maps = distance_maps(source, town_blocks, margin=2.5 * radius, opts=opts.site, built=built)
    site = choose_site(maps, area, opts.site, direction=opts.direction, at=opts.at)
    if site is None:
        raise InputError(f"no room for a district of {area:,.0f} m² around the town (try a smaller --area)")
    progress("growing streets")
    water = shapely.union_all([*raw.context.water, *raw.context.sea])
    old_town = shapely.union_all(shapely.buffer(np.asarray(town_blocks, dtype=object), -1.0))
    obstacles = shapely.union_all([water, old_town])
    border, slots = _border_junctions(example, site, radius + 2 * spacing)
    near = shapely.STRtree([shapely.LineString(source.street_xy(s)) for s in source.streets])
    reach = site.region.buffer(0.5 * radius)
    old = [source.street_xy(source.streets[k]) for k in sorted(near.query(reach, predicate="intersects").tolist())]
    grown = grow(example, site.region, obstacles=obstacles, border_xy=border, border_slots=slots,
                 seed=opts.seed, old_streets=old)
    if not grown.polylines():
        raise InputError(f"too small to grow from: {len(example.junctions)} junctions in "
                         f"{len(source.streets)} streets gave no new street")
    progress("joining the district to the town")
    network, origins = _combine(source, example, grown.polylines())
    network, origins = join_to_town(network, origins, border, old_town, water, reach=2 * spacing, spread=2 * spacing)
    new = [k for k, o in enumerate(origins) if o == "grown"]
    report = {
        "site_centre": [round(float(v), 1) for v in site.centre], "site_area_m2": round(area),
        "spacing_m": round(spacing, 1), "source_streets": len(source.streets), "grown_streets": len(new),
        "district_area_m2": round(district_area(network, origins)),
        "grown_length_km": round(sum(polyline_length(network.street_xy(network.streets[k])) for k in new) / 1000, 3),
        "connections": connections(network, origins),
    }
    return ExpandResult(network=network, origins=origins, site=site, report=report)


#: A district smaller than this many blocks (squares of the town's junction spacing) is refused.
MIN_BLOCKS = 9


def district_area(net: StreetNetwork, origins: list[str]) -> float:
    """The area of the new district's outline: the convex hull of its streets (m²)."""
    lines = [shapely.LineString(net.street_xy(s)) for s, o in zip(net.streets, origins) if o == "grown"]
    return float(shapely.MultiLineString(lines).convex_hull.area) if lines else 0.0


def _border_junctions(example: Example, site: Site, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Old-town junctions with a free slot within ``reach`` of the site's centre."""
    near = np.hypot(*(example.xy - site.centre).T) <= reach
    pick = near & (example.slots > 0)
    return example.xy[pick], example.slots[pick]


def _class_by_level(source: StreetNetwork) -> dict[int, str]:
    counts: dict[int, Counter] = {}
    for s in source.streets:
        counts.setdefault(s.hierarchy, Counter())[s.highway] += 1
    return {lv: c.most_common(1)[0][0] for lv, c in counts.items()}


def _combine(source: StreetNetwork, example: Example, polylines) -> tuple[StreetNetwork, list[str]]:
    """Old streets plus new ones; a new street ending on an old junction shares its node."""
    at_junction = {(float(x), float(y)): int(n) for n, (x, y) in zip(example.junctions, example.xy)}
    highway = _class_by_level(source)
    xy = [source.xy]
    next_id = len(source.xy)
    index: dict[tuple[float, float], int] = {}
    streets = list(source.streets)
    for level, pts in polylines:
        nodes = []
        for x, y in np.asarray(pts, dtype=float):
            key = (float(x), float(y))
            if key in at_junction:
                nodes.append(at_junction[key])
                continue
            if key not in index:
                index[key] = next_id
                next_id += 1
                xy.append(np.array([[x, y]]))
            nodes.append(index[key])
        streets.append(Street(nodes=tuple(nodes), highway=highway.get(level, "residential"),
                              hierarchy=int(level), status="planned"))
    all_xy = np.vstack(xy)
    ids = np.concatenate([source.node_ids, np.zeros(len(all_xy) - len(source.xy), dtype=np.int64)])
    origins = ["source"] * len(source.streets) + ["grown"] * (len(streets) - len(source.streets))
    return replace(source, xy=all_xy, node_ids=ids, streets=tuple(streets)), origins
