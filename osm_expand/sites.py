"""Where the town should grow: distance maps and the expansion site (004 §4.3.1).

The town and its surroundings are rasterised at ``cell`` metres: water (water
areas, buffered rivers, sea) and city (blocks, and every street buffered by
half a block's depth). Euclidean distance transforms give, per cell, the
distance to water, the distance to the city, and the *free radius*: the
distance to anything unbuildable, which is exactly the radius of the largest
empty disc centred there (better than 004's four-direction estimate).

Land outside the map's data bounds is unknown, not free: unless
``beyond_bounds``, it counts as unbuildable, so the site lies inside the
bounds. Unbuildable land (:mod:`osm_expand.land`: cemeteries, parks,
railway land, existing buildings, ...) is an obstacle like water.

A site scores by closeness to the city and to water (1 when the district's
disc touches them, falling off with the gap), by *contact* (the share of a
ring ``contact_width`` wide around the disc that is town: a bay of the town
beats a corner, and gives the joining streets somewhere to go) and by room to
spare, each in [0, 1] and weighted; it loses its closeness to the city when the way there
crosses water (the far bank of a river is not next to the town). Only cells
whose free radius holds a disc of the district's area qualify. ``direction`` restricts the search to a 90° sector
seen from the town's centre; ``at`` skips the search. :func:`choose_sites` ranks
several sites at least a district's radius apart, best first, so the
pipeline can try the next when the best cannot be joined to the town.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.ndimage import distance_transform_edt
from scipy.signal import fftconvolve

from osm_expand.errors import InputError
from osm_expand.model import City, StreetNetwork

DIRECTIONS = {"E": 0, "NE": 45, "N": 90, "NW": 135, "W": 180, "SW": 225, "S": 270, "SE": 315}


@dataclass(frozen=True)
class SiteOptions:
    cell: float = 10.0  # raster cell (m); grows for very large towns to keep the raster under ~4 M cells
    city_weight: float = 1.0
    water_weight: float = 0.5
    room_weight: float = 0.25
    contact_weight: float = 1.0
    contact_width: float = 200.0  # m: the ring around the district whose share of town is its contact
    street_buffer: float = 40.0  # m either side of a street that counts as city (frontage lots)
    area_share: float = 0.25  # default district area: this share of the town's built-up area


@dataclass(frozen=True)
class DistanceMaps:
    origin: np.ndarray  # (x, y) of the lower-left cell corner
    cell: float
    water: np.ndarray  # bool (rows = y, cols = x)
    city: np.ndarray  # bool
    blocked: np.ndarray  # bool: unbuildable land, and outside the bounds unless beyond_bounds
    water_distance: np.ndarray  # m
    city_distance: np.ndarray  # m
    free_radius: np.ndarray  # m to the nearest water, city or blocked cell
    nearest_city: np.ndarray  # (2, rows, cols) row and column of each cell's nearest city cell

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        return _cell_centres(self.origin, self.cell, self.water.shape)


@dataclass(frozen=True)
class Site:
    centre: np.ndarray
    area: float
    region: shapely.Polygon  # where the district may grow: a disc of ``area`` around the centre
    score: float


def built_area(net: StreetNetwork, blocks: list[shapely.Polygon], opts: SiteOptions) -> shapely.Geometry:
    """The town's built-up area: its blocks, and every street buffered by ``street_buffer`` metres."""
    streets = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    return shapely.union_all([*blocks, shapely.buffer(shapely.MultiLineString(streets), opts.street_buffer)])


#: The raster never has more cells than this (the cell grows instead).
MAX_CELLS = 4e6


def distance_maps(city: City, margin: float, opts: SiteOptions | None = None,
                  built: shapely.Geometry | None = None, *, beyond_bounds: bool = False) -> DistanceMaps:
    """Rasters around the town, ``margin`` metres beyond its streets on every side.

    Parameters
    ----------
    city : City
        With its blocks (and unbuildable land) set.
    margin : float
        Metres of land around the streets to rasterise.
    opts : SiteOptions
    built : shapely geometry, optional
        :func:`built_area`, when the caller has it already.
    beyond_bounds : bool
        Land outside the map's bounds counts as free (default: unknown, so blocked).
    """
    opts = opts or SiteOptions()
    net = city.network
    pts = net.xy[net.used_nodes()]
    x0, y0 = pts.min(axis=0) - margin
    x1, y1 = pts.max(axis=0) + margin
    if not beyond_bounds:  # no need to rasterise what is blocked anyway
        bx0, by0, bx1, by1 = city.bounds_xy
        x0, y0, x1, y1 = max(x0, bx0 - opts.cell), max(y0, by0 - opts.cell), min(x1, bx1 + opts.cell), min(y1, by1 + opts.cell)
    cell = max(opts.cell, float(np.sqrt((x1 - x0) * (y1 - y0) / MAX_CELLS)))
    nx, ny = int(np.ceil((x1 - x0) / cell)), int(np.ceil((y1 - y0) / cell))
    xs, ys = _cell_centres(np.array([x0, y0]), cell, (ny, nx))
    water = _raster(city.water_geometry(), xs, ys)
    blocks = [b.polygon for b in city.blocks]
    city_mask = _raster(built if built is not None else built_area(net, blocks, opts), xs, ys) & ~water
    blocked = _raster(city.unbuildable, xs, ys)
    if not beyond_bounds:
        blocked |= ~_raster(city.bounds_polygon, xs, ys)
    if city_mask.any():
        city_cells, nearest = distance_transform_edt(~city_mask, return_indices=True)
        city_distance, nearest = city_cells * cell, nearest.astype(np.int32)
    else:
        city_distance, nearest = np.full(city_mask.shape, np.inf), np.zeros((2, *city_mask.shape), dtype=np.int32)
    return DistanceMaps(
        origin=np.array([x0, y0]), cell=cell, water=water, city=city_mask, blocked=blocked,
        water_distance=_distance(water, cell), city_distance=city_distance,
        free_radius=_distance(water | city_mask | blocked, cell), nearest_city=nearest,
    )


def _cell_centres(origin: np.ndarray, cell: float, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    ny, nx = shape
    return np.meshgrid(origin[0] + (np.arange(nx) + 0.5) * cell, origin[1] + (np.arange(ny) + 0.5) * cell)


def _raster(geom, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    if geom is None or geom.is_empty:
        return np.zeros(xs.shape, dtype=bool)
    shapely.prepare(geom)
    return shapely.contains_xy(geom, xs, ys)


def _distance(mask: np.ndarray, cell: float) -> np.ndarray:
    if not mask.any():
        return np.full(mask.shape, np.inf)
    return distance_transform_edt(~mask) * cell


def choose_sites(maps: DistanceMaps, area: float, opts: SiteOptions | None = None, *,
                 direction: str | None = None, at: tuple[float, float] | None = None, most: int = 5) -> list[Site]:
    """The best places for a district of ``area`` m², best first; empty when nothing has room.

    Parameters
    ----------
    maps : DistanceMaps
    area : float
        m².
    opts : SiteOptions
    direction : {"N", "NE", "E", "SE", "S", "SW", "W", "NW"}, optional
        Keep the site in the 90° sector on that side of the town's centre.
    at : (x, y), optional
        Use this centre (metres) and skip the search.
    most : int
        How many sites to return; each is at least a district's radius from the better ones.
    """
    opts = opts or SiteOptions()
    if at is not None:
        return [_disc(np.asarray(at, dtype=float), area, float("nan"))]
    if direction is not None and direction.upper() not in DIRECTIONS:
        raise InputError(f"direction must be one of {', '.join(DIRECTIONS)}, got {direction!r}")
    radius = float(np.sqrt(area / np.pi))
    xs, ys = maps.centres()
    score = _score(maps, radius, opts)
    score = score - opts.city_weight * _across_water(maps, score)
    if direction and direction.upper() != "AUTO":
        score = np.where(_in_sector(maps, xs, ys, DIRECTIONS[direction.upper()]), score, -np.inf)
    flat = score.ravel()
    ranked = np.flatnonzero(np.isfinite(flat))
    ranked = ranked[np.argsort(-flat[ranked], kind="stable")]
    sites: list[Site] = []
    for i in ranked.tolist():
        centre = np.array([xs.flat[i], ys.flat[i]])
        if all(np.hypot(*(centre - s.centre)) >= radius for s in sites):
            sites.append(_disc(centre, area, float(flat[i])))
            if len(sites) >= most:
                break
    return sites


def choose_site(maps: DistanceMaps, area: float, opts: SiteOptions | None = None,
                direction: str | None = None, at: tuple[float, float] | None = None) -> Site | None:
    """The best site (:func:`choose_sites`), or None when nothing has room."""
    sites = choose_sites(maps, area, opts, direction=direction, at=at, most=1)
    return sites[0] if sites else None


def _disc(centre: np.ndarray, area: float, score: float) -> Site:
    return Site(centre=centre, area=area, region=shapely.Point(centre).buffer(np.sqrt(area / np.pi), 64), score=score)


def _score(maps: DistanceMaps, radius: float, opts: SiteOptions) -> np.ndarray:
    """1 for a disc that touches the city (or water), falling off with the gap; room beyond need adds a little."""
    gap_city = np.maximum(maps.city_distance - radius, 0.0)
    near_city = np.exp(-gap_city / radius)
    if maps.water.any():
        near_water = np.exp(-np.maximum(maps.water_distance - radius, 0.0) / radius)
    else:
        near_water = np.zeros_like(near_city)
    room = np.clip((maps.free_radius - radius) / radius, 0.0, 1.0)
    contact = _ring_share(maps.city, radius / maps.cell, (radius + opts.contact_width) / maps.cell)
    score = (opts.city_weight * near_city + opts.contact_weight * contact + opts.water_weight * near_water
             + opts.room_weight * room)
    return np.where(maps.free_radius >= radius, score, -np.inf)


def _ring_share(mask: np.ndarray, inner: float, outer: float) -> np.ndarray:
    """Per cell, the share of the ring ``inner``..``outer`` cells around it that is ``mask``.

    A district in a bay of the town borders it along a long arc, and can be
    joined to it by many streets; one touching a corner only by one.
    """
    r = int(np.ceil(outer))
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    dist = np.hypot(dx, dy)
    ring = ((dist >= inner) & (dist <= outer)).astype(float)
    share = fftconvolve(mask.astype(float), ring / ring.sum(), mode="same")
    return np.clip(share, 0.0, 1.0)


def _across_water(maps: DistanceMaps, score: np.ndarray, samples: int = 32, top: int = 2000) -> np.ndarray:
    """1 where the straight way from a cell to the nearest city cell crosses water, else 0.

    A district on the far bank of a river is not next to the town, however
    close it looks. Only the ``top`` best-scoring cells are checked.
    """
    out = np.zeros(maps.water.shape)
    finite = np.flatnonzero(np.isfinite(score.ravel()))
    if not maps.water.any() or not maps.city.any() or len(finite) == 0:
        return out
    ci, cj = maps.nearest_city
    cand = finite[np.argsort(-score.ravel()[finite], kind="stable")[:top]]
    i0, j0 = np.unravel_index(cand, maps.water.shape)
    i1, j1 = ci.ravel()[cand], cj.ravel()[cand]
    t = np.linspace(0.0, 1.0, samples)[:, None]
    ii = np.rint(i0 + t * (i1 - i0)).astype(int)
    jj = np.rint(j0 + t * (j1 - j0)).astype(int)
    out.ravel()[cand] = maps.water[ii, jj].any(axis=0)
    return out


def _in_sector(maps: DistanceMaps, xs: np.ndarray, ys: np.ndarray, bearing_deg: float) -> np.ndarray:
    """Cells within 45° either side of ``bearing_deg`` (0 = east, 90 = north) from the city's centre."""
    cy, cx = np.argwhere(maps.city).mean(axis=0)
    centre = maps.origin + (np.array([cx, cy]) + 0.5) * maps.cell
    angle = np.degrees(np.arctan2(ys - centre[1], xs - centre[0]))
    return np.abs((angle - bearing_deg + 180.0) % 360.0 - 180.0) <= 45.0
