"""Where the town should grow: distance maps and the expansion site (004 §4.3.1).

The town and its surroundings are rasterised at ``cell`` metres:

- *water*: water areas, buffered rivers, sea;
- *city*, the built-up area: the town's land (:mod:`osm_expand.land`: the
  frontage of its streets to the depth its buildings show, its settlement
  land use and buildings; a country road between villages has no
  frontage, and neither have motorways and ramps) and the blocks that are
  town (a block over :data:`~osm_expand.model.land.OPEN_BLOCK` m² only when
  built on; none that only corridors bound, else an interchange's loops
  make a patch of town in the fields); its area is the town's *built-up
  area*;
- *outside*: land beyond the map's data bounds, which is unknown rather than
  free (unless ``beyond_bounds``);
- *unbuildable*: land nothing new may take (:mod:`osm_expand.land`: parks,
  cemeteries, railway land, existing buildings, ...).

Euclidean distance transforms give, per cell, the distance to water, the
distance to the city, and the *free radius*: the distance to water, city or
the outside, which is exactly the radius of the largest disc centred there
that touches none of them (better than 004's four-direction estimate).
Unbuildable land may lie inside a site (a district grows around a farmstead
or a park; its streets avoid them), but at most ``max_unbuildable`` of it.

A site scores by closeness to the city and to water (1 when the district's
disc touches them, falling off with the gap), by *contact* (the share of a
ring ``contact_width`` wide around the disc that is town: a bay of the town
beats a corner, and gives the joining streets somewhere to go) and by room
to spare, each in [0, 1] and weighted, less its unbuildable share and the
mean development cost of its land cover (fields before forest); it loses
its closeness to the city when it lies across water (the far bank of a
river is not next to the town): for the pipeline's district, when the
straight way to the nearest city cell crosses water; for the engine's,
when water cuts its land off from the town's own settlement
(:func:`settlement_maps`, :func:`far_bank`: built-up land less than
:data:`SETTLEMENT_GAP` apart is one settlement, the largest is the town, so
a village on the far bank does not make the far bank the town's, and a
river the town lies on both sides of is no divide).
Motorways and trunk roads
(:data:`CORRIDORS`) cut the land: a district's streets cross none of the
town's streets and these have no junctions to meet, so free land in the
disc that they cut off from its centre costs its share
(``cut_off_weight``). ``direction`` restricts the search to a 90° sector
seen from the town's centre; ``at`` skips the search.
:func:`choose_sites` ranks several sites at least a district's radius apart,
best first, so the pipeline can try the next when the best cannot be joined
to the town.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass, replace

import numpy as np
import shapely
from scipy.ndimage import distance_transform_edt, label

from osm_expand.errors import InputError
from osm_expand.land import read_land
from osm_expand.model import City, Land, highways
from osm_expand.model.components import component_labels
from osm_expand.model.memo import ContentMemo, IdentityMemo

DIRECTIONS = {"E": 0, "NE": 45, "N": 90, "NW": 135, "W": 180, "SW": 225, "S": 270, "SE": 315}
#: The raster never has more cells than this (the cell grows instead).
MAX_CELLS = 4e6


@dataclass(frozen=True)
class SiteOptions:
    #: Raster cell (m); grows for very large maps to keep the raster under :data:`MAX_CELLS`.
    cell: float = 10.0
    city_weight: float = 1.0  #: weight of closeness to the town
    water_weight: float = 0.5  #: weight of closeness to water (004: towns grow along rivers)
    room_weight: float = 0.25  #: weight of free room beyond the district's radius
    contact_weight: float = 1.0  #: weight of the share of the ring around the site that is town
    contact_width: float = 200.0  #: m: the ring around the district whose share of town is its contact
    area_share: float = 0.25  #: default district area: this share of the town's built-up area ...
    #: ... but at most one neighbourhood unit (m²): Perry's (1929) 160 acres, the land within a
    #: quarter-mile walk of its centre: a new quarter, not a second town (Campo Grande's quarter of its
    #: built-up area is 20 km²)
    neighbourhood_area: float = 650_000.0
    max_unbuildable: float = 0.25  #: a site may hold at most this share of unbuildable land
    unbuildable_weight: float = 1.0  #: score lost per share of unbuildable land in the site
    #: score lost per unit of the disc's mean land-cover cost (:data:`osm_expand.land.LAND_COVER`: 0 for
    #: farmland, 0.6 for forest): a disc of forest loses about what a quarter of unbuildable land costs
    #: plus its water bonus, so a town grows onto its fields first, into its woods when nothing else is near.
    cover_weight: float = 0.75
    #: score lost per share of the disc that is free land cut off from its centre by a motorway or trunk
    #: road (the district would grow there in pockets no street of it can reach)
    cut_off_weight: float = 1.0


def default_district_area(opts: SiteOptions, built: float) -> float:
    """A town's default district area (m²): ``area_share`` of its ``built`` built-up land (m²), at most one
    ``neighbourhood_area``.

    One place for the pipeline's first district (which floors it at its smallest district) and the engine's
    neighbourhood (:func:`osm_expand.engine.growth.minor_streets.neighbourhood_length`, its district floor's
    unit): both stand for a neighbourhood of the town, the discs the district verdict judges against.
    """
    return min(opts.area_share * built, opts.neighbourhood_area)


#: Roads that cut the land: a district's streets cross none of the town's streets, and these have
#: no junctions to meet them at, so a district's land must lie on one side of them.
CORRIDORS = highways.CORRIDORS


def _of_class(net, classes: frozenset[str]) -> np.ndarray:
    """Per street, whether its highway class is one of ``classes``."""
    return np.fromiter((s.highway in classes for s in net.streets), dtype=bool, count=len(net.streets))


@dataclass(frozen=True)
class DistanceMaps:
    origin: np.ndarray  #: (x, y) of the lower-left cell corner, metres
    cell: float  #: metres
    water: np.ndarray  #: bool (rows = y, cols = x)
    city: np.ndarray  #: bool: the built-up area
    outside: np.ndarray  #: bool: beyond the map's bounds (all False with ``beyond_bounds``)
    unbuildable: np.ndarray  #: bool
    water_distance: np.ndarray  #: m
    city_distance: np.ndarray  #: m
    free_radius: np.ndarray  #: m to the nearest water, city or outside cell
    #: (2, rows, cols) row and column of each cell's nearest city cell: any built-up cell in the pipeline's
    #: maps, the town's settlement's in the engine's (:func:`settlement_maps`); what :func:`_across_water`'s
    #: straight-line test looks across when :attr:`far_bank` is unset
    nearest_city: np.ndarray
    #: bool: motorways, trunk roads and their ramps, which new streets never cross (no junction on them)
    corridor: np.ndarray
    #: development cost of the land cover in each cell, 0 (farmland, unmapped) to < 1
    cost: np.ndarray | None = None
    #: bool: land on the far bank from the town (:func:`far_bank`: its piece of land, water as the barrier,
    #: holds none of the town's settlement); when set, what :func:`_across_water` reads instead of the
    #: straight way to the nearest city cell
    far_bank: np.ndarray | None = None

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        return _cell_centres(self.origin, self.cell, self.water.shape)

    @property
    def built_area(self) -> float:
        """The town's built-up area (m²)."""
        return float(self.city.sum()) * self.cell ** 2


@dataclass(frozen=True)
class Site:
    centre: np.ndarray
    area: float
    region: shapely.Polygon  #: where the district may grow: a disc of ``area`` around the centre
    score: float


def distance_maps(city: City, opts: SiteOptions | None = None, *, margin: float = 0.0,
                  beyond_bounds: bool = False) -> DistanceMaps:
    """Rasters of the town and its surroundings.

    Parameters
    ----------
    city : City
        With its blocks and unbuildable land set (:func:`osm_expand.pipeline.prepare`).
    opts : SiteOptions
    margin : float
        Metres of land around the town's streets to rasterise; the map's
        bounds limit it unless ``beyond_bounds``.
    beyond_bounds : bool
        Land outside the map's bounds counts as free (default: unknown, so a site may not take it).
    """
    opts = opts or SiteOptions()
    net = city.network
    pts = net.xy[net.used_nodes()]
    x0, y0 = pts.min(axis=0) - margin
    x1, y1 = pts.max(axis=0) + margin
    if not beyond_bounds:  # no need to rasterise what a site may not take anyway
        bx0, by0, bx1, by1 = city.bounds_xy
        x0, y0 = max(x0, bx0 - opts.cell), max(y0, by0 - opts.cell)
        x1, y1 = min(x1, bx1 + opts.cell), min(y1, by1 + opts.cell)
    cell = max(opts.cell, float(np.sqrt((x1 - x0) * (y1 - y0) / MAX_CELLS)))
    nx, ny = int(np.ceil((x1 - x0) / cell)), int(np.ceil((y1 - y0) / cell))
    xs, ys = _cell_centres(np.array([x0, y0]), cell, (ny, nx))
    water = _raster(city.water_geometry(), xs, ys)
    lines = net.street_lines()
    land = city.land if city.land is not None else read_land(city)
    city_mask = _built_up(city, land, xs, ys) & ~water
    outside = np.zeros_like(water) if beyond_bounds else ~_raster(city.bounds_polygon, xs, ys, remember=False)
    city_distance, nearest = _nearest(city_mask, cell)
    return DistanceMaps(
        origin=np.array([x0, y0]), cell=cell, water=water, city=city_mask, outside=outside,
        unbuildable=_raster(city.unbuildable, xs, ys), water_distance=_distance(water, cell),
        city_distance=city_distance, free_radius=_distance(water | city_mask | outside, cell), nearest_city=nearest,
        corridor=_raster_each(shapely.buffer(lines[_of_class(net, CORRIDORS)], cell), xs, ys),
        cost=_cost_raster(land, xs, ys),
    )


#: Built-up land less than this far apart (m) is one settlement: the European Environment Agency's urban
#: morphological zones merge built-up patches less than 200 m apart (EEA 2002, *Towards an urban atlas*;
#: the rule of the UN's "contiguous built-up area" too). Krems and the village of Mautern face each other
#: across the Danube 300–500 m apart: two settlements; a town's own pieces between its streams and parks
#: are one (Krems: 5.15 km² of its 5.76 km² of built-up land in one piece at 200 m, 17 pieces at 100 m).
SETTLEMENT_GAP = 200.0


def settlement(maps: DistanceMaps, gap: float = SETTLEMENT_GAP) -> np.ndarray:
    """The town's own built-up land: the piece of ``maps.city`` with the most area, pieces less than ``gap``
    metres apart counted as one (:data:`SETTLEMENT_GAP`), to within about a raster cell (the gap is measured
    between cells; diagonal gaps join a cell further through 8-connectivity).

    Why: the engine's districts grow "at the edge of the built-up land ... joined to what is there, as real
    towns grow" (issue 20), and that is the town's edge, not a village's on the far bank of a river: a site
    scored by contact with any built-up land put Krems' engine quarter beside Mautern, across the Danube.
    The town is the piece with the most built-up area (its centre and most of its streets; on an extract of
    villages, the largest village, where the pipeline's district grows too).
    """
    if not maps.city.any():
        return maps.city
    pieces, area = _settlement_pieces(maps, gap)
    keep = np.zeros(len(area), dtype=bool)
    keep[int(np.argmax(area))] = True
    keep[0] = False
    return maps.city & keep[pieces]


def settlement_distance(maps: DistanceMaps, xy: np.ndarray, gap: float = SETTLEMENT_GAP) -> np.ndarray:
    """Per point (``(K, 2)`` m), the distance (m) from its raster cell to the town's settlement
    (:func:`settlement`); infinite off the raster or without built-up land."""
    town = settlement(maps, gap)
    if not town.any():
        return np.full(len(np.asarray(xy).reshape(-1, 2)), np.inf)
    return raster_at(maps, _nearest(town, maps.cell)[0], xy)


def raster_at(maps: DistanceMaps, raster: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Per point (``(K, 2)`` m), the value of ``raster`` (shaped as ``maps``' rasters) at its cell;
    infinite off the rasters."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    col, row = np.floor((xy - maps.origin) / maps.cell).astype(np.int64).T
    inside = (row >= 0) & (row < raster.shape[0]) & (col >= 0) & (col < raster.shape[1])
    out = np.full(len(xy), np.inf)
    out[inside] = raster[row[inside], col[inside]]
    return out


def _settlement_pieces(maps: DistanceMaps, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """The pieces of the built-up land less than ``gap`` m apart (labels per cell, 0 away from them) and each
    label's built-up area (m², 0 for label 0)."""
    near = distance_transform_edt(~maps.city) * maps.cell <= 0.5 * gap  # pieces less than ``gap`` apart touch
    pieces, _ = label(near, structure=np.ones((3, 3), dtype=bool))
    area = np.bincount(pieces[maps.city], minlength=pieces.max() + 1).astype(float) * maps.cell ** 2
    area[0] = 0.0
    return pieces, area


def settlement_maps(maps: DistanceMaps, gap: float = SETTLEMENT_GAP) -> DistanceMaps:
    """``maps`` that measure the far bank from the town's own settlement (:func:`settlement`): a site on land
    that water cuts off from the *town* loses its closeness (:func:`far_bank`, read by :func:`_across_water`),
    however near a village on its own bank lies. Krems' engine quarter grew beside Mautern, across the
    Danube: the way to Mautern, its nearest built-up land, crosses no water. The site's closeness and contact
    still count all the built-up land (counting the town's settlement alone was measured and not adopted:
    ``docs/tried.md``).
    """
    town = settlement(maps, gap)
    if not town.any():
        return maps
    maps = replace(maps, far_bank=far_bank(maps.water, town))
    if town.sum() == maps.city.sum():
        return maps
    return replace(maps, nearest_city=_nearest(town, maps.cell)[1])


def _nearest(mask: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, the distance (m) to the nearest cell of ``mask`` and that cell's row and column
    (``(2, rows, cols)`` int32); inf and zeros when ``mask`` is empty."""
    if not mask.any():
        return np.full(mask.shape, np.inf), np.zeros((2, *mask.shape), dtype=np.int32)
    cells, nearest = distance_transform_edt(~mask, return_indices=True)
    return cells * cell, nearest.astype(np.int32)


def far_bank(water: np.ndarray, town: np.ndarray) -> np.ndarray:
    """Per cell, whether it lies on land that ``water`` cuts off from the ``town`` (both bool rasters): its
    piece of land (water the barrier, pieces joined edge to edge) holds no town cell. Water cells are not.

    Why not the straight way to the nearest town cell, as before (:func:`_across_water`): a river that the
    town lies on both sides of is no divide, whichever bank the nearest town cell is on. Andorra la Vella
    spans the Gran Valira: seen from its settlement, a site by a valley village whose straight line to the
    town crossed the river lost its closeness and the steep slope of the town won (seed 1, off of 14 per
    reference seed, ``benchmarks/engine_growth.py``: 0 0 1 on main 88bd933, 5 5 4 with the straight line,
    0 0 1 with this). The Danube between Krems and Mautern is a divide: no land of Krems' settlement lies
    south of it, so Mautern's bank is the far bank however the straight line runs. Tried and dropped: the
    way over land (water the barrier) much longer than the straight way, on a coarse raster: Andorra's
    seed 1 1 2 2, north-bayreuth's seed 0 unchanged (5 5 5). One labelling of the raster, no per-cell
    sampling.
    """
    land = ~water
    pieces, count = label(land)  # 4-connected: a river drawn corner to corner still divides
    holds = np.zeros(count + 1, dtype=bool)
    holds[pieces[town & land]] = True
    holds[0] = True  # water
    return ~holds[pieces]


def _built_up(city: City, land: Land, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The built-up land (:class:`~osm_expand.model.land.Land`: the frontage of the town's streets, its
    settlement land use and buildings) and the blocks that are town (:meth:`City.town_block_polygons`:
    none that only corridors bound, the land inside an interchange's ramps)."""
    built = (_drawn(_remembered(land, "town", lambda: _outlines_each(land.town)), xs, ys) if len(land.town)
             else np.zeros(xs.shape, dtype=bool))
    corridor = {s.id for s in city.network.streets if s.highway in CORRIDORS}
    blocks = city.town_block_polygons(among=np.array([not corridor.issuperset(b.street_ids) for b in city.blocks],
                                                     dtype=bool))
    return built | _raster_each(blocks, xs, ys) if len(blocks) else built


def _cost_raster(land: Land, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Per cell, the highest development cost of the land cover mapped there (0 where none is)."""
    cost = np.zeros(xs.shape)
    for value in np.unique(land.cover_cost).tolist():
        if value > 0:
            def outlines(value: float = value) -> tuple[_Outline, ...]:
                return _outlines_each(land.cover[land.cover_cost == value])
            drawn = _drawn(_remembered(land, ("cover", value), outlines), xs, ys)
            cost = np.where(drawn, np.maximum(cost, value), cost)
    return cost


def _cell_centres(origin: np.ndarray, cell: float, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    ny, nx = shape
    return np.meshgrid(origin[0] + (np.arange(nx) + 0.5) * cell, origin[1] + (np.arange(ny) + 0.5) * cell)


def _raster(geom, xs: np.ndarray, ys: np.ndarray, *, remember: bool = True) -> np.ndarray:
    """Cells whose centre lies in ``geom``, rasterised by PIL's polygon filler (scan lines, in C).
    ``remember``: ``geom`` is the model's, asked for again next year (:func:`_remembered`)."""
    if geom is None or geom.is_empty:
        return np.zeros(xs.shape, dtype=bool)
    def outline() -> tuple[_Outline, ...]:
        return (_outline(shapely.get_parts(shapely.get_parts(geom))),)
    return _drawn(_remembered(geom, None, outline) if remember else outline(), xs, ys)


@dataclass(frozen=True)
class _Outline:
    """Polygons' rings ready to draw: what does not depend on the raster, read from the shapes once."""

    coords: np.ndarray  #: (M, 2) every ring's points, ring after ring, metres
    ends: list[int]  #: where each ring ends in the flat x, y, x, y list of ``coords``
    fill: list[int]  #: per ring, 1 (an exterior) or 0 (a hole)


def _outline(parts: np.ndarray) -> _Outline:
    """The :class:`_Outline` of the polygons among ``parts`` (an array of geometries), in their order."""
    rings, fill = _rings(parts)
    coords, owner = shapely.get_coordinates(rings, return_index=True)
    ends = 2 * np.cumsum(np.bincount(owner, minlength=len(rings)))
    return _Outline(coords=coords, ends=ends.tolist(), fill=fill.tolist())


def _draw(outline: _Outline, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Fill ``outline``'s rings in order on the raster of cell centres ``xs``, ``ys``: each exterior set,
    each hole cleared. PIL's C filler is called directly (what ``ImageDraw.polygon(xy, fill=v)`` does,
    without its Python wrapper per ring: Campo Grande's built-up land has 11,000 polygons a year)."""
    from PIL import Image, ImageDraw

    ny, nx = xs.shape
    x0, y0 = xs[0, 0], ys[0, 0]
    cell = float(xs[0, 1] - x0) if nx > 1 else float(ys[1, 0] - y0)
    image = Image.new("1", (nx, ny), 0)
    draw = ImageDraw.Draw(image).draw
    ink = [draw.draw_ink(0), draw.draw_ink(1)]
    px = ((outline.coords - (x0, y0)) / cell).ravel().tolist()  # every ring's pixels in one pass, flat x, y, x, y
    for start, stop, value in zip([0, *outline.ends[:-1]], outline.ends, outline.fill):
        draw.draw_polygon(px[start:stop], ink[value], 1)
    return np.asarray(image, dtype=bool)


def _rings(parts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rings of the polygons among ``parts`` in drawing order (each exterior, then its holes), and
    the fill of each (1, 0 for a hole): the shapes read once for all, not a Python call per ring
    (Campo Grande's built-up land has half a million)."""
    polys = parts[(shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)]
    holes = shapely.get_num_interior_rings(polys)
    first = np.arange(len(polys)) + np.cumsum(holes) - holes  # each exterior's place
    rings = np.empty(len(polys) + int(holes.sum()), dtype=object)
    fill = np.zeros(len(rings), dtype=np.int64)
    rings[first], fill[first] = shapely.get_exterior_ring(polys), 1
    owner = np.repeat(np.arange(len(polys)), holes)
    nth = np.arange(len(owner)) - np.repeat(np.cumsum(holes) - holes, holes)  # which hole of its polygon
    rings[first[owner] + 1 + nth] = shapely.get_interior_ring(polys[owner], nth)
    return rings, fill


def _raster_each(polygons: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """:func:`_raster` of the union of ``polygons`` without computing it: each filled in turn.

    Buffering every street and filling each buffer is ten times faster than
    buffering the town's MultiLineString (which nodes every crossing). A hole
    of one polygon is cleared only where no hole-free polygon covers it.
    """
    return _drawn(_outlines_each(polygons), xs, ys)


def _outlines_each(polygons: np.ndarray) -> tuple[_Outline, ...]:
    """:func:`_raster_each`'s outlines: the hole-free polygons, then (drawn apart) those with holes."""
    parts = shapely.get_parts(polygons)
    parts = parts[(shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)]  # polygons, as _rings keeps
    holed = shapely.get_num_interior_rings(parts) > 0
    return (_outline(parts[~holed]), _outline(parts[holed])) if holed.any() else (_outline(parts),)


def _drawn(outlines: tuple[_Outline, ...], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The union of the rasters of ``outlines``, each drawn on its own."""
    filled = _draw(outlines[0], xs, ys)
    for more in outlines[1:]:
        filled = filled | _draw(more, xs, ys)
    return filled


#: The outlines of the model's shapes rasterised, by the shape's identity (:func:`_remembered`); a year
#: draws the water, the unbuildable land, the town and the land cover of each development cost.
_OUTLINES = IdentityMemo(kept=16)


def _remembered(source: object, tag: Hashable, make: Callable[[], tuple[_Outline, ...]]) -> tuple[_Outline, ...]:
    """``make()``, the outlines of ``tag`` of ``source``, read again only for another object.

    ``source`` is a shape or object of the model that never changes once made
    (the :class:`~osm_expand.model.land.Land`, the water's union): the engine
    rasterises the same land every year, on a raster whose cell follows the
    district's size, and the rings do not change with the raster (reading
    them was half of :func:`distance_maps` on Campo Grande).
    """
    return _OUTLINES.get((source,), tag, make)


def _distance(mask: np.ndarray, cell: float) -> np.ndarray:
    if not mask.any():
        return np.full(mask.shape, np.inf)
    return distance_transform_edt(~mask) * cell


#: A site's disc may grow to these multiples of the district's radius to find its area of free land.
RADIUS_STEPS = (1.0, 1.25, 1.5, 2.0)


def choose_sites(maps: DistanceMaps, area: float, opts: SiteOptions | None = None, *,
                 direction: str | None = None, at: tuple[float, float] | None = None, most: int = 5
                 ) -> list[Site]:
    """The best places for a district of ``area`` m² of free land, best first; empty when nothing has room.

    A site is a disc around a cell holding ``area`` m² of free land (not
    water, town or outside the map): the district's radius, or up to twice
    it (:data:`RADIUS_STEPS`) where the disc wraps around the town's edge or
    a shore, so the site takes the shape of the free land around the town.

    Parameters
    ----------
    maps : DistanceMaps
    area : float
        m² of free land the district needs.
    opts : SiteOptions
    direction : {"N", "NE", "E", "SE", "S", "SW", "W", "NW"}, optional
        Keep the site in the 90° sector on that side of the town's centre.
    at : (x, y), optional
        Use this centre (metres) and skip the search.
    most : int
        How many sites to return; each is at least a district's radius from the better ones.
    """
    opts = opts or SiteOptions()
    radius = float(np.sqrt(area / np.pi))
    if at is not None:
        centre = np.asarray(at, dtype=float)
        return [_disc(centre, _radius_at(maps, centre, area, radius), area, float("nan"))]
    if direction is not None and direction.upper() not in DIRECTIONS:
        raise InputError(f"direction must be one of {', '.join(DIRECTIONS)}, got {direction!r}")
    xs, ys = maps.centres()
    score, disc_radius = _best_radius(maps, area, radius, opts)
    score = score - opts.city_weight * _across_water(maps, score)
    if direction:
        score = np.where(_in_sector(maps, xs, ys, DIRECTIONS[direction.upper()]), score, -np.inf)
    flat = score.ravel()
    sites: list[Site] = []
    for i in _best_first(flat):
        centre = np.array([xs.flat[i], ys.flat[i]])
        if all(np.hypot(*(centre - s.centre)) >= radius for s in sites):
            sites.append(_disc(centre, float(disc_radius.flat[i]), area, float(flat[i])))
            if len(sites) >= most:
                break
    return sites


def _best_radius(maps: DistanceMaps, area: float, radius: float, opts: SiteOptions) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, the score of the smallest disc (of :data:`RADIUS_STEPS`) holding ``area`` of free land;
    free land in the disc that a motorway or trunk road cuts off from the centre costs."""
    hard = maps.water | maps.city | maps.outside
    free_land = ~hard
    best = np.full(hard.shape, -np.inf)
    best_radius = np.full(hard.shape, np.nan)
    rings = _RingShares(hard.shape, (RADIUS_STEPS[-1] * radius + opts.contact_width) / maps.cell)
    cut_off = _cut_off_shares(maps, free_land, area, radius, rings)
    for step, cut in zip(RADIUS_STEPS, cut_off):
        r = step * radius
        free = rings.share(free_land, 0.0, r / maps.cell) * np.pi * r * r  # beyond the raster is not free
        score = (_score(maps, r, opts, rings) - 0.25 * (step - 1.0)  # the tighter disc is the better district
                 - opts.cut_off_weight * cut)
        # a centre keeps a cell off the water: a shore cell's centre may lie in the water as drawn
        fits = (free >= area) & ~hard & (maps.water_distance > maps.cell) & np.isneginf(best)
        best = np.where(fits, score, best)
        best_radius = np.where(fits, r, best_radius)
    return best, best_radius


def _cut_off_shares(maps: DistanceMaps, free_land: np.ndarray, area: float, radius: float,
                    rings: _RingShares) -> list[np.ndarray]:
    """Per radius step and cell, the share of the disc that corridors cut off from the cell.

    That is the disc's share of the free land connected to the cell (water,
    town and the map's edge part it) less its share of the free land still
    connected once the corridors part it too. Pieces are 4-connected; only
    pieces of at least a fifth of ``area`` are convolved (a centre in a
    smaller pocket between ramps has everything around it cut off).
    """
    zero = [np.zeros(free_land.shape) for _ in RADIUS_STEPS]
    cut = maps.corridor & free_land
    if not cut.any():
        return zero
    whole, pieces = _piece_shares(free_land, area / 5, radius, maps.cell, rings)
    # a piece no corridor crosses is a piece of the parted land too: its shares are the ones just made
    kept = np.ones(int(pieces.max()) + 1, dtype=bool)
    kept[pieces[cut]] = False
    kept[0] = False
    parted, _ = _piece_shares(free_land & ~maps.corridor, area / 5, radius, maps.cell, rings,
                              known=(pieces, kept, whole))
    return [np.clip(w - p, 0.0, 1.0) for w, p in zip(whole, parted)]


def _piece_shares(land: np.ndarray, min_area: float, radius: float, cell: float, rings: _RingShares,
                  known: tuple[np.ndarray, np.ndarray, list[np.ndarray]] | None = None
                  ) -> tuple[list[np.ndarray], np.ndarray]:
    """Per radius step and cell of ``land``, the share of the disc that is the cell's own piece of it; and
    the pieces (labels).

    ``known``: the labels of other land, which of its pieces are pieces of ``land`` as well (the very
    cells), and their shares: those are copied, not convolved again (a piece a corridor does not cross,
    for :func:`_cut_off_shares`: 15 of Campo Grande's 18 in a year's site search).
    """
    pieces, _ = label(land)
    sizes = np.bincount(pieces.ravel()) * cell ** 2
    shares = [np.zeros(land.shape) for _ in RADIUS_STEPS]
    for piece in np.flatnonzero(sizes >= min_area):
        if piece == 0:  # not land
            continue
        mask = pieces == piece
        if known is not None:
            other, same, their = known
            at = other.flat[int(np.argmax(mask))]  # the other land's piece at one of its cells
            if same[at]:  # the same cells: the same convolutions, to the bit
                for share, theirs in zip(shares, their):
                    np.copyto(share, theirs, where=mask)
                continue
        for share, step in zip(shares, RADIUS_STEPS):
            np.copyto(share, rings.share(mask, 0.0, step * radius / cell), where=mask)
        rings.forget(mask)
    return shares, pieces


def _radius_at(maps: DistanceMaps, centre: np.ndarray, area: float, radius: float) -> float:
    """The smallest disc of :data:`RADIUS_STEPS` around a given centre that holds ``area`` of free land."""
    xs, ys = maps.centres()
    hard = maps.water | maps.city | maps.outside
    d = np.hypot(xs - centre[0], ys - centre[1])
    for step in RADIUS_STEPS:
        r = step * radius
        if float((~hard & (d <= r)).sum()) * maps.cell ** 2 >= area:
            return r
    return RADIUS_STEPS[-1] * radius


def choose_site(maps: DistanceMaps, area: float, opts: SiteOptions | None = None,
                direction: str | None = None, at: tuple[float, float] | None = None) -> Site | None:
    """The best site (:func:`choose_sites`), or None when nothing has room."""
    sites = choose_sites(maps, area, opts, direction=direction, at=at, most=1)
    return sites[0] if sites else None


def _disc(centre: np.ndarray, radius: float, area: float, score: float) -> Site:
    return Site(centre=centre, area=area, region=shapely.Point(centre).buffer(radius, 64), score=score)


def _score(maps: DistanceMaps, radius: float, opts: SiteOptions, rings: _RingShares) -> np.ndarray:
    """1 for a disc that touches the city (or water), falling off with the gap; room beyond need adds a
    little; unbuildable land inside costs. -inf where the disc holds too much unbuildable land."""
    gap_city = np.maximum(maps.city_distance - radius, 0.0)
    near_city = np.exp(-gap_city / radius)
    if maps.water.any():
        near_water = np.exp(-np.maximum(maps.water_distance - radius, 0.0) / radius)
    else:
        near_water = np.zeros_like(near_city)
    room = np.clip((maps.free_radius - radius) / radius, 0.0, 1.0)
    contact = rings.share(maps.city, radius / maps.cell, (radius + opts.contact_width) / maps.cell)
    taken = rings.share(maps.unbuildable, 0.0, radius / maps.cell)
    cover = rings.share(maps.cost, 0.0, radius / maps.cell) if maps.cost is not None else 0.0
    score = (opts.city_weight * near_city + opts.contact_weight * contact + opts.water_weight * near_water
             + opts.room_weight * room - opts.unbuildable_weight * taken - opts.cover_weight * cover)
    return np.where(taken <= opts.max_unbuildable, score, -np.inf)


#: Shares over rings wider than this many cells are convolved on a coarser grid (they are smooth).
COARSE_AT = 24


class _RingShares:
    """Per cell, the share of a ring of cells around it that is a mask, for a few masks and radii.

    A district in a bay of the town borders it along a long arc, and can be
    joined to it by many streets; one touching a corner only by one. With
    ``inner`` 0 it is the share of the disc. Cells beyond the raster count
    as not the mask.

    One site search asks for three masks at four radii: each mask's and each
    ring's Fourier transform (:mod:`scipy.fft`) is taken once and the shares
    are their products transformed back, 23 transforms where a convolution
    per share takes 36. Rings wider than :data:`COARSE_AT` cells are
    convolved on a grid ``f`` times coarser (block means), which changes the
    share by about a cell's width over the ring's, and resampled back.
    """

    def __init__(self, shape: tuple[int, int], outer_max: float):
        from scipy import fft

        self._fft = fft
        self.shape = shape
        self.outer_max = outer_max  #: the widest ring asked for (cells): the transforms are padded for it
        self._masks: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._rings: dict[tuple[float, float], np.ndarray] = {}

    def share(self, mask: np.ndarray, inner: float, outer: float) -> np.ndarray:
        """The share of the ring ``inner``..``outer`` cells around each cell that is ``mask``."""
        if outer > self.outer_max:
            raise ValueError(f"ring of {outer} cells asked of shares padded for {self.outer_max}")
        if not mask.any():
            return np.zeros(self.shape)
        f = max(int(outer // COARSE_AT), 1)
        cy, cx = self._coarse(f)
        share = self._fft.irfft2(self._mask(mask, f) * self._ring(inner, outer), s=self._pad(f))[:cy, :cx]
        if f > 1:
            share = np.repeat(np.repeat(share, f, axis=0), f, axis=1)[:self.shape[0], :self.shape[1]]
        return np.clip(share, 0.0, 1.0)

    def forget(self, mask: np.ndarray) -> None:
        """Drop a mask's transforms (a site search convolves many pieces of land, each once)."""
        for key in [k for k, (m, _) in self._masks.items() if m is mask]:
            del self._masks[key]

    def _coarse(self, f: int) -> tuple[int, int]:
        return -(-self.shape[0] // f), -(-self.shape[1] // f)

    def _pad(self, f: int) -> tuple[int, int]:
        reach = int(np.ceil(max(self.outer_max, COARSE_AT * f) / f))  # so that no ring wraps around
        cy, cx = self._coarse(f)
        return self._fft.next_fast_len(cy + reach, real=True), self._fft.next_fast_len(cx + reach, real=True)

    def _mask(self, mask: np.ndarray, f: int) -> np.ndarray:
        hit = self._masks.get((id(mask), f))
        if hit is None or hit[0] is not mask:
            grid = mask.astype(float)
            if f > 1:
                cy, cx = self._coarse(f)
                padded = np.zeros((cy * f, cx * f))
                padded[:self.shape[0], :self.shape[1]] = grid
                grid = padded.reshape(cy, f, cx, f).mean(axis=(1, 3))
            hit = self._masks[(id(mask), f)] = (mask, self._fft.rfft2(grid, s=self._pad(f)))
        return hit[1]

    def _ring(self, inner: float, outer: float) -> np.ndarray:
        key = (inner, outer)
        if key not in self._rings:
            f = max(int(outer // COARSE_AT), 1)
            pad = self._pad(f)
            r = int(np.ceil(outer / f))
            dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
            dist = np.hypot(dx, dy)
            ring = ((dist >= inner / f) & (dist <= outer / f)).astype(float)
            kernel = np.zeros(pad)
            np.add.at(kernel, (dy % pad[0], dx % pad[1]), ring / ring.sum())  # centred on cell (0, 0)
            self._rings[key] = self._fft.rfft2(kernel)
        return self._rings[key]


def _across_water(maps: DistanceMaps, score: np.ndarray, samples: int = 32, top: int = 2000) -> np.ndarray:
    """1 where a cell is across water from the town, else 0.

    A district on the far bank of a river is not next to the town, however
    close it looks. With :attr:`DistanceMaps.far_bank` (the engine's maps,
    :func:`settlement_maps`) that is land water cuts off from the town's
    settlement; without it (the pipeline's first district, unchanged) the
    straight way from a cell to the nearest city cell crossing water, with
    only the ``top`` best-scoring cells checked.
    """
    if maps.far_bank is not None:
        return maps.far_bank.astype(float)
    out = np.zeros(maps.water.shape)
    finite = np.flatnonzero(np.isfinite(score.ravel()))
    if not maps.water.any() or not maps.city.any() or len(finite) == 0:
        return out
    ci, cj = maps.nearest_city
    cand = _top(score.ravel(), finite, top)
    i0, j0 = np.unravel_index(cand, maps.water.shape)
    i1, j1 = ci.ravel()[cand], cj.ravel()[cand]
    t = np.linspace(0.0, 1.0, samples)[:, None]
    ii = np.rint(i0 + t * (i1 - i0)).astype(int)
    jj = np.rint(j0 + t * (j1 - j0)).astype(int)
    out.ravel()[cand] = maps.water[ii, jj].any(axis=0)
    return out


#: Cells ranked at first by :func:`_best_first`: the sites are nearly always among the best few thousand.
FIRST_RANKED = 4096
#: Each further batch :func:`_best_first` ranks is this many times the last.
RANKED_GROWTH = 4


def _top(values: np.ndarray, index: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` entries of ``index`` with the largest ``values``, largest first, ties in index order.

    The same as the first ``k`` of a stable descending sort of all of them,
    without sorting the million cells of a town's raster: everything at or
    above the k-th largest value is sorted, the rest never is.
    """
    if len(index) <= k:
        return index[np.argsort(-values[index], kind="stable")]
    v = values[index]
    kth = np.partition(v, len(v) - k)[len(v) - k]
    head = index[v >= kth]
    return head[np.argsort(-values[head], kind="stable")][:k]


def _best_first(flat: np.ndarray) -> Iterator[int]:
    """Indices of the finite cells, best first (ties in index order): the best
    :data:`FIRST_RANKED` at once, then the next best in batches each :data:`RANKED_GROWTH` times larger,
    only as far as a caller gets.

    Why batches: a caller that passes the first few thousand (the sites a radius apart lie further down
    when the best cells crowd one spot: Campo Grande's first district read 5,350 cells) needed only a few
    more, and sorting all the rest (two million cells) took 0.2 s of its 1.4 s site search.
    """
    rest = np.flatnonzero(np.isfinite(flat))  # ascending: :func:`_top` breaks ties in this order
    k = FIRST_RANKED
    while len(rest):
        head = _top(flat, rest, k)
        yield from head.tolist()
        if len(head) == len(rest):
            return
        ranked = np.zeros(len(flat), dtype=bool)
        ranked[head] = True
        rest = rest[~ranked[rest]]
        k *= RANKED_GROWTH


def _in_sector(maps: DistanceMaps, xs: np.ndarray, ys: np.ndarray, bearing_deg: float) -> np.ndarray:
    """Cells within 45° either side of ``bearing_deg`` (0 = east, 90 = north) from the city's centre."""
    cy, cx = np.argwhere(maps.city).mean(axis=0)
    centre = maps.origin + (np.array([cx, cy]) + 0.5) * maps.cell
    angle = np.degrees(np.arctan2(ys - centre[1], xs - centre[0]))
    return np.abs((angle - bearing_deg + 180.0) % 360.0 - 180.0) <= 45.0


def _cleared(near: np.ndarray, clearance: float) -> shapely.Geometry:
    """The streets ``near`` with their ``clearance``, as one buffer of them all: GEOS nodes the lines once,
    where the union of a buffer per street merged thousands of polygons."""
    return shapely.buffer(shapely.multilinestrings(near), clearance)


#: :func:`district_region`'s streets with their clearance by the streets' content: the buffer was a fifth of
#: Campo Grande's run, and the streets around a site, or in one of its discs and the next, are often the
#: same when the land the town takes there is not (Krems: 28 of 64 found; the region 1.48 -> 1.02 s CPU).
#: Why 32 entries: a year's engine districts try at most ``GrowthOptions.sites_tried`` (5) sites, each growing its
#: region through :data:`REGION_STEPS` (5 discs): 25 buffers; the hits are the next year's tries of the same sites
#: (and the pipeline's first district's few), so one year's tries and a few more suffice. (A buffer is a few
#: hundred kB at most: 32 of them cost little.)
_CLEARED = ContentMemo(kept=32)


#: A district's region grows to these multiples of its site's radius until its piece of free land holds
#: :data:`REGION_SHARE` of the district's area.
REGION_STEPS = (1.0, 1.25, 1.5, 2.0, 2.5)
REGION_SHARE = 0.8


def district_region(city: City, site: Site, *, clearance: float = 1.0,
                    bounds: shapely.Geometry | None = None) -> shapely.Geometry:
    """Where a district grows: the one piece of free land around the site's centre.

    The town's streets cut the free land into pieces (no new street crosses
    them; they are met only in tees), and so do water and the land the town
    takes. A district grown over several pieces is several scraps, so it
    takes the piece nearest the site's centre, in a disc grown
    (:data:`REGION_STEPS`) until that piece holds :data:`REGION_SHARE` of
    the site's area. Falls back to the site's disc when no free land is near.

    The steps are not all made in order: the step the site's own disc points
    to (:func:`_likely_step`) is made first, and a smaller step is made only
    when that step's free land does not rule it out (:func:`_rules_out`);
    the piece is the one the steps in order give (Krems' regions took all
    five steps, 1.4 s of its command, when the last alone decides).

    Parameters
    ----------
    city : City
    site : Site
    clearance : float
        Metres kept free along the town's streets when cutting the land.
    bounds : polygon, optional
        Land outside it is not free (the map's data bounds).
    """
    radius = float(np.sqrt(site.area / np.pi))
    centre = shapely.Point(site.centre)
    lines = city.network.street_lines()
    need = REGION_SHARE * site.area
    made: dict[int, _Step] = {}

    def step(i: int) -> _Step:
        if i not in made:
            made[i] = _region_step(city, centre, REGION_STEPS[i] * radius, site.area, lines, clearance, bounds)
        return made[i]

    def enough(i: int) -> bool:
        piece = step(i).piece
        return piece is not None and piece.area >= need

    first = _likely_step(site, radius)
    for i in range(first):  # a smaller step is the region when it holds enough; the first step may rule it out
        disc = _region_disc(centre, REGION_STEPS[i] * radius, bounds)
        if not _rules_out(step(first), disc, need, clearance) and enough(i):
            return step(i).piece
    for i in range(first, len(REGION_STEPS)):
        if enough(i):
            return step(i).piece
    for i in reversed(range(len(REGION_STEPS))):  # none holds enough: the last step with a piece
        piece = step(i).piece
        if piece is not None:
            return piece
    return site.region


@dataclass(frozen=True)
class _Step:
    """One step of :func:`district_region`: the town's streets that meet its disc, its free land and the
    piece of it the district would take (None when no free land is in the disc)."""

    near: np.ndarray
    free: shapely.Geometry
    piece: shapely.Geometry | None


def _region_disc(centre: shapely.Point, radius: float, bounds: shapely.Geometry | None) -> shapely.Geometry:
    """The disc of one step of :func:`district_region`, cut to ``bounds``: one function for the step's land
    (:func:`_region_step`) and the smaller discs :func:`_rules_out` is asked about, so that both are the
    same polygon (32 segments a quarter)."""
    disc = centre.buffer(radius, 32)
    return shapely.intersection(disc, bounds) if bounds is not None else disc


def _region_step(city: City, centre: shapely.Point, radius: float, area: float, lines: np.ndarray,
                 clearance: float, bounds: shapely.Geometry | None) -> _Step:
    """The free land in the disc of ``radius`` and the piece nearest the centre among those of at least a
    quarter of ``area`` (the nearest of all when none is that large)."""
    disc = _region_disc(centre, radius, bounds)
    occupied = city.occupied_within(disc)
    near = lines[shapely.intersects(lines, disc)] if len(lines) else lines
    cleared = _CLEARED.get(ContentMemo.key(near, clearance), _cleared, near, clearance)
    free = shapely.make_valid(shapely.difference(disc, shapely.union(occupied, cleared)))
    parts = [p for p in shapely.get_parts(free) if p.geom_type == "Polygon" and not p.is_empty]
    if not parts:
        return _Step(near, free, None)
    sizes = np.array([p.area for p in parts])
    gap = shapely.distance(centre, np.array(parts, dtype=object))
    big = sizes >= 0.25 * area
    pool = np.flatnonzero(big) if big.any() else np.arange(len(parts))
    return _Step(near, free, parts[int(pool[np.argmin(gap[pool])])])


def _likely_step(site: Site, radius: float) -> int:
    """The :data:`REGION_STEPS` index the site's own disc points to: the smallest step at least the disc's
    radius over ``radius`` (a site whose disc had to grow to hold its free land needs a larger region)."""
    x0, _, x1, _ = site.region.bounds
    ratio = 0.5 * (x1 - x0) / radius if radius > 0 else 1.0
    return next((i for i, s in enumerate(REGION_STEPS) if s >= ratio * (1.0 - 1e-9)), len(REGION_STEPS) - 1)


#: m: parts of free land nearer each other than this count as one piece in :func:`_rules_out` (a neck
#: GEOS may draw as two polygons touching at a point); m², with a relative 1e-6: the slack of its bound.
PINCH, SLACK = 1e-3, 1.0


def _rules_out(larger: _Step, disc: shapely.Geometry, need: float, clearance: float) -> bool:
    """Whether the smaller ``disc`` (in the ``larger`` step's disc) surely holds no piece of ``need`` m² of free land.

    Within the smaller disc the land is occupied by the same shapes as within the larger (the occupied land
    near a disc is all that meets its box), and the streets kept clear are those that meet it: all among the
    larger disc's, so its free land is the larger step's free land there, and where a street that meets the
    larger disc but not the smaller passes within ``clearance`` of it, its cleared strip, which the smaller
    step does not clear, as well (:func:`_strips_back`). A piece is connected, so it lies in one part of that
    land (parts within :data:`PINCH` counted as one, the strips overlapping the free land counted twice) and
    is no larger than the largest; ruled out when that falls short of ``need`` by :data:`SLACK`.
    """
    inside = shapely.intersects(larger.near, disc) if len(larger.near) else np.zeros(0, dtype=bool)
    outside = larger.near[~inside]
    reaching = outside[shapely.dwithin(outside, disc, clearance + PINCH)] if len(outside) else outside
    parts = _polygons(shapely.intersection(_polygons(larger.free), disc))
    if len(reaching):
        parts = np.concatenate([parts, _strips_back(reaching, disc, clearance)])
    if not len(parts):
        return True
    i, j = shapely.STRtree(parts).query(parts, predicate="dwithin", distance=PINCH)
    labels = component_labels(len(parts), i, j)
    largest = float(np.bincount(labels, weights=shapely.area(parts)).max())
    return largest < need * (1.0 - 1e-6) - SLACK


#: The strips :func:`_strips_back` gives back are this share wider than the clearance (plus :data:`PINCH`): a
#: buffer's arcs are chords inside the true circle (8 segments a quarter: 5 mm inside at 1 m), so the wider strip
#: holds the step's own strip whatever its arcs; the more land given back, the looser the bound, never wrong.
STRIP_PAD = 0.05


def _strips_back(streets: np.ndarray, disc: shapely.Geometry, clearance: float) -> np.ndarray:
    """The land within ``clearance`` of ``streets`` (a little more: :data:`STRIP_PAD`) in ``disc``, as polygons:
    what a larger step cleared along streets that do not meet the smaller ``disc`` but pass within ``clearance``
    of it, and the smaller step leaves free. Without them such a step was made whatever the rest of its land
    showed: Campo Grande's default run made 31 steps, 26 with them (its regions 4.69 -> 4.06 s CPU), Monaco's
    17 -> 15, the same regions."""
    strips = shapely.buffer(shapely.multilinestrings(streets), clearance * (1.0 + STRIP_PAD) + PINCH)
    return _polygons(shapely.intersection(strips, disc))


def _polygons(geoms: shapely.Geometry | np.ndarray) -> np.ndarray:
    """The non-empty polygons among ``geoms`` and in their (multi)polygons and collections, two levels deep
    (``make_valid`` may give a collection of a multipolygon and lines)."""
    parts = shapely.get_parts(shapely.get_parts(geoms))
    return parts[(shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)]
