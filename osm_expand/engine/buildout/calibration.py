"""What the town itself says about its land use, lots and buildings (issue 11's calibration).

The build-out (:mod:`osm_expand.engine.buildout.year`) fills new blocks with lots
and buildings that should look like the town's own. Before the first year it
reads, from the town as mapped (never changing it):

- **Footprints** of the town's buildings (valid polygons) and their minimum
  rotated rectangles, which is what the ``<urbanenvironment>`` XML draws and
  what no generated building may overlap.
- **Sizes** (002 §5.1 ``maxarea_t``, 004 §4.3.4): footprint area, frontage
  and depth (:func:`~osm_expand.engine.buildout.footprint_sizes.calibrate_sizes`). The
  town's footprint-area distribution is then shared out among the lot
  classes that build (:func:`size_bands`): each class draws its buildings
  from a band of the town's area quantiles, as wide as its share of the
  buildings (:func:`building_shares`: goal area over the class's lot size),
  the classes stacked by their typical building (houses lowest, halls
  highest) and overlapping by ``band_overlap``. Buildings drawn so have the
  town's footprint distribution whatever the mix, median included (the
  history's fixed bands drew half of them from the upper part of the town's
  distribution and left Krems' median 12–36 % high); the build-out restacks
  the bands each year by the buildings it has and is about to build. Lot
  options are sized to hold these buildings
  (:func:`~osm_expand.engine.buildout.footprint_sizes.calibrated_lot_options`).
- **Heights** (002 §5.2, 004 §4.3.4): storey height and height distribution
  from the ``height`` / ``building:levels`` *tags*
  (:func:`~osm_expand.engine.buildout.economy.calibrate_heights`); without tags the
  documented defaults (3 m storeys, 2–3–4 floors). ``Building.height`` is
  not read: the pipeline fills it for every building from the same tags or
  the town's typical height, which would make untagged towns look tagged.
- **The centre(s)** (002 §4.3 ``centerdist``, 004 §4.3.4's height fall-off):
  the peaks of the town's building density (footprint area smoothed by a
  Gaussian of ``centre_radius``); the highest is the centre, other peaks at
  least ``centre_separation`` away and ``secondary_share`` as high are
  secondary centres (Krems and Stein, say). Without buildings: the density of
  the streets' nodes.
- **Land use** (002 §4; issue: "calibrate from OSM"): the town's ``landuse=*``
  and ``leisure=*`` polygons give its own shares and the goals
  (:func:`~osm_expand.engine.buildout.landuse_osm.calibrate_landuse`, clipped to the town:
  its buildings buffered by ``town_buffer``).
- **Town units**: the land-use simulation needs the old town as lots (the
  neighbourhood of new lots, the city's shares, and the comparison with the
  real land use). The town has no lots, so its buildings are gathered into
  grid cells of ``town_cell`` metres; each occupied cell is one unit at the
  footprint-weighted mean of its buildings' centroids, with the area
  ``min(cell², footprints / coverage)`` (``coverage``: the town's own ground
  coverage, footprint area over the area of the blocks that hold buildings)
  and the mapped type of the polygon it lies in (or none). Cells rather than
  one unit per building keep the yearly update cheap (Krems: 1,195 buildings,
  about 400 units) while staying finer than the 256 m neighbourhood.
- **Green and water** for the distance attributes.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage

from osm_expand.engine.buildout.economy import HeightCalibration, calibrate_heights
from osm_expand.engine.buildout.footprint_sizes import calibrate_sizes, calibrated_lot_options
from osm_expand.engine.buildout.footprints import FootprintOptions, SizeTargets
from osm_expand.engine.buildout.landuse_osm import LandUseCalibration, calibrate_landuse, types_from_polygons
from osm_expand.engine.buildout.landuse_types import UNASSIGNED, LandUseType
from osm_expand.engine.buildout.lot_values import distance_to
from osm_expand.engine.buildout.lots import LandUse, LotOptions, land_use
from osm_expand.engine.history import History
from osm_expand.errors import InputError
from osm_expand.land import unbuildable as unbuildable_land
from osm_expand.model import City, Origin
from osm_expand.model.options import require_positive

__all__ = ["CalibrationOptions", "TownCalibration", "building_shares", "calibrate_town", "find_centres", "size_bands",
           "tag_number", "town_units"]


@dataclass(frozen=True)
class CalibrationOptions:
    """How the build-out reads the town (defaults with their reasons)."""

    #: m, side of the grid cells that gather the town's buildings into land-use units: about two
    #: lots of the town's size (Krems' median lot ~800 m²), far below 002's 256 m neighbourhood.
    town_cell: float = 40.0
    #: m, σ of the Gaussian that smooths building density when looking for centres: a
    #: five-minute walk, the scale of a small town's core (004 gives no number).
    centre_radius: float = 250.0
    #: m, grid cell of that density map.
    centre_cell: float = 25.0
    #: At most this many centres (002 §4.3: "the closest city center"; one main, two secondary).
    max_centres: int = 3
    #: A secondary centre's density peak is at least this share of the main one's.
    secondary_share: float = 0.5
    #: m, secondary centres lie at least this far from every other centre (a separate core, not
    #: the other end of the same old town).
    centre_separation: float = 1000.0
    #: m, the town for land-use calibration is its buildings buffered by this (002's shares are of the
    #: city, not of the fields and forests an extract also holds); 60 m is a street and a front garden.
    town_buffer: float = 60.0
    #: Ground coverage (footprint / block area) when the town has no blocks with buildings: a small
    #: European town's residential blocks (detached 10–25 %, terraces 35–60 %).
    default_coverage: float = 0.3
    #: The measured coverage is clipped to this range (a few huge fields around a village must
    #: not make its units enormous).
    coverage_range: tuple[float, float] = (0.1, 0.6)
    #: Share the town's footprint distribution among the lot classes by the goals (:func:`size_bands`);
    #: False keeps the history's ``size_band`` of each class.
    size_bands: bool = True
    #: Quantiles by which neighbouring classes' bands overlap on each side (a large house may be
    #: bigger than a small shop).
    band_overlap: float = 0.05
    #: ``key=value`` of mapped areas that are green for the ``green_dist`` attribute (002 §4.3
    #: "forest"): forests, woods and open green the public uses.
    green: tuple[str, ...] = ("landuse=forest", "natural=wood", "natural=scrub", "natural=heath",
                              "natural=grassland", "landuse=meadow", "landuse=grass", "landuse=recreation_ground",
                              "landuse=village_green", "leisure=park", "leisure=garden", "leisure=nature_reserve")

    def __post_init__(self) -> None:
        require_positive(self, ("town_cell", "centre_radius", "centre_cell", "centre_separation", "town_buffer",
                                "default_coverage"))
        if self.max_centres < 1:
            raise InputError(f"calibration max_centres: must be at least 1, got {self.max_centres}")
        if not 0 < self.secondary_share <= 1:
            raise InputError(f"calibration secondary_share: must lie in (0, 1], got {self.secondary_share}")
        if not 0 <= self.band_overlap < 0.5:
            raise InputError(f"calibration band_overlap: must lie in [0, 0.5), got {self.band_overlap}")
        lo, hi = self.coverage_range
        if not 0 < lo <= hi <= 1:
            raise InputError(f"calibration coverage_range: must be 0 < low ≤ high ≤ 1, got {self.coverage_range}")


@dataclass(frozen=True, eq=False)
class TownCalibration:
    """Everything the build-out learns from the town as mapped, once, before the first year.

    Arrays of objects are shapely geometries; ``unit_*`` arrays are aligned
    (U,), one entry per land-use unit of the old town.
    """

    footprints: NDArray[np.object_]  #: (B,) the town's building footprints, valid polygons (m)
    outlines: NDArray[np.object_]  #: (B,) their minimum rotated rectangles (what the XML draws)
    building_points: NDArray[np.float64]  #: (B, 2) a point inside each footprint (m)
    centres: NDArray[np.float64]  #: (C, 2) the centre(s), main one first (m)
    extent: float  #: m, what ``center_dist`` is divided by: the diagonal of the city's streets
    coverage: float  #: the town's ground coverage (footprint / area of blocks with buildings)
    sizes: SizeTargets  #: the town's footprint area, frontage and depth
    heights: HeightCalibration  #: storey height and target height distribution
    landuse: LandUseCalibration | None  #: None when no mapped polygon maps to a type
    types: tuple[LandUseType, ...]  #: the history's types with the calibrated goals
    lot_options: Mapping[LandUse, LotOptions]  #: per lot class, sized to hold the town's buildings
    footprint_options: Mapping[LandUse, FootprintOptions]  #: per lot class, size bands from :func:`size_bands`
    building_shares: Mapping[LandUse, float]  #: expected share of the buildings per class (:func:`building_shares`)
    polygons: tuple[tuple[shapely.Geometry, str], ...]  #: mapped land use (geometry, value)
    water: tuple[shapely.Geometry, ...]  #: water and sea (m)
    green: tuple[shapely.Geometry, ...]  #: forests, woods and parks (m)
    unbuildable: shapely.Geometry  #: land no lot may take: mapped no-build areas, the town's buildings + margin
    unit_xy: NDArray[np.float64]  #: (U, 2) the town units' positions (m)
    unit_area: NDArray[np.float64]  #: (U,) their areas (m²)
    unit_real: NDArray[np.int64]  #: (U,) type index of the mapped land use they lie in, or UNASSIGNED
    unit_floor_space: NDArray[np.float64]  #: (U,) floor space of their buildings (m²): footprint × storeys
    unit_street: NDArray[np.int64]  #: (U,) id of the nearest street of the town (their traffic)
    unit_water: NDArray[np.float64]  #: (U,) distance to water (m)
    unit_green: NDArray[np.float64]  #: (U,) distance to green (m)


def tag_number(tags: Mapping[str, str] | tuple[tuple[str, str], ...], key: str) -> float:
    """The leading number of an OSM tag value (``"12"``, ``"12.5 m"``, ``"3;4"``), NaN when absent or unreadable.

    Examples
    --------
    >>> tag_number({"height": "12.5 m"}, "height"), tag_number((("building:levels", "3"),), "building:levels")
    (12.5, 3.0)
    >>> math.isnan(tag_number({}, "height")), math.isnan(tag_number({"height": "tall"}, "height"))
    (True, True)
    """
    value = dict(tags).get(key)
    if value is None:
        return math.nan
    text = value.strip().replace(",", ".")
    end = 0
    while end < len(text) and (text[end].isdigit() or text[end] == "."):
        end += 1
    try:
        return float(text[:end])
    except ValueError:
        return math.nan


def find_centres(points: NDArray[np.float64], weights: NDArray[np.float64], *,
                 options: CalibrationOptions = CalibrationOptions()) -> NDArray[np.float64]:
    """The centre(s) of a town: peaks of its smoothed building density (002 §4.3, 004 §4.3.4).

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Building centroids (or street nodes), metres.
    weights : ndarray, shape (N,)
        Their weights (footprint area), ≥ 0.

    Returns
    -------
    ndarray, shape (C, 2)
        1 ≤ C ≤ ``max_centres``: the highest peak first, then lower peaks at
        least ``secondary_share`` as high and ``centre_separation`` from every
        centre before them. Each centre is the weighted mean of the points
        within ``centre_radius`` of its peak cell.

    Raises
    ------
    InputError
        No points.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(pts) == 0:
        raise InputError("calibration: a town needs buildings or streets to have a centre")
    pad = 3 * options.centre_radius
    lo = pts.min(axis=0) - pad
    span = float((pts.max(axis=0) + pad - lo).max())
    cell = max(options.centre_cell, span / 1999)  # at most 2,000 cells a side (50 km at 25 m)
    shape = np.ceil((pts.max(axis=0) + pad - lo) / cell).astype(int) + 1
    ij = np.clip(((pts - lo) / cell).astype(int), 0, shape - 1)
    grid = np.zeros(tuple(shape))
    np.add.at(grid, (ij[:, 0], ij[:, 1]), w if w.sum() > 0 else np.ones(len(pts)))
    density = ndimage.gaussian_filter(grid, sigma=options.centre_radius / cell, mode="constant")
    size = 2 * int(options.centre_separation / cell) + 1
    peaks = (density == ndimage.maximum_filter(density, size=size, mode="constant")) & (density > 0)
    pi, pj = np.nonzero(peaks)
    order = np.lexsort((pj, pi, -density[pi, pj]))  # highest first, ties by position (deterministic)
    top = density[pi[order[0]], pj[order[0]]]
    chosen: list[np.ndarray] = []
    for k in order.tolist():
        if len(chosen) == options.max_centres or density[pi[k], pj[k]] < options.secondary_share * top:
            break
        at = lo + cell * np.array([pi[k], pj[k]], dtype=float)
        if any(np.hypot(*(at - c)) < options.centre_separation for c in chosen):
            continue
        near = np.hypot(*(pts - at).T) <= options.centre_radius
        wk = w[near] if w[near].sum() > 0 else np.ones(int(near.sum()))
        chosen.append(np.average(pts[near], axis=0, weights=wk) if near.any() else at)
    return np.array(chosen)


def town_units(points: NDArray[np.float64], footprint_area: NDArray[np.float64], *, cell: float,
               coverage: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The town's buildings gathered into grid cells: the old town's land-use units (module docstring).

    Parameters
    ----------
    points : ndarray, shape (B, 2)
        Building centroids (m).
    footprint_area : ndarray, shape (B,)
        Footprint areas (m²).
    cell : float
        Grid cell side (m).
    coverage : float
        Ground coverage in (0, 1]: a unit's area is its footprints / coverage, at most the cell.

    Returns
    -------
    xy : ndarray, shape (U, 2)
        Footprint-weighted mean centroid per occupied cell.
    area : ndarray, shape (U,)
        m².
    member : ndarray of int, shape (B,)
        The unit of each building.

    Examples
    --------
    >>> xy, area, member = town_units(np.array([[1.0, 1.0], [3.0, 1.0], [50.0, 1.0]]),
    ...                               np.array([100.0, 100.0, 50.0]), cell=40.0, coverage=0.25)
    >>> xy.tolist(), area.tolist(), member.tolist()
    ([[2.0, 1.0], [50.0, 1.0]], [800.0, 200.0], [0, 0, 1])
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    fa = np.asarray(footprint_area, dtype=np.float64)
    if len(pts) == 0:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
    keys = np.floor(pts / cell).astype(np.int64)
    _, member = np.unique(keys, axis=0, return_inverse=True)
    member = member.reshape(-1)
    n = int(member.max()) + 1
    total = np.bincount(member, weights=fa, minlength=n)
    safe = np.where(total > 0, total, 1.0)
    xy = np.column_stack([np.bincount(member, weights=fa * pts[:, k], minlength=n) / safe for k in (0, 1)])
    plain = np.column_stack([np.bincount(member, weights=pts[:, k], minlength=n) for k in (0, 1)])
    counts = np.bincount(member, minlength=n)
    xy = np.where((total > 0)[:, None], xy, plain / counts[:, None])
    area = np.minimum(np.maximum(total, 1.0) / coverage, cell * cell)
    return xy, area, member.astype(np.int64)


def building_shares(types: Sequence[LandUseType], lot_options: Mapping[LandUse, LotOptions],
                    footprint_options: Mapping[LandUse, FootprintOptions]) -> dict[LandUse, float]:
    """Each building lot class's expected share of the buildings under the goals.

    ``n_c ∝ Σ_t goal_t / max_area_c`` over the types of class c: the area
    the goals give the class over its lot size (recursive halving leaves lots
    of about the same fraction of ``max_area`` in every class). Classes
    without buildings (parks) are left out.

    Examples
    --------
    >>> from osm_expand.engine.buildout.landuse_types import DEFAULT_TYPES
    >>> from osm_expand.engine.buildout.lots import DEFAULT_LOT_OPTIONS
    >>> from osm_expand.engine.buildout.footprints import DEFAULT_FOOTPRINT_OPTIONS
    >>> shares = building_shares(DEFAULT_TYPES, DEFAULT_LOT_OPTIONS, DEFAULT_FOOTPRINT_OPTIONS)
    >>> {c.value: round(v, 3) for c, v in shares.items()}
    {'residential_low': 0.692, 'residential_high': 0.208, 'commercial': 0.075, 'industrial': 0.025}
    """
    count: dict[LandUse, float] = {}
    for t in types:
        cls = land_use(t.lot_size_key)
        if cls in footprint_options and footprint_options[cls].build and t.goal > 0:
            count[cls] = count.get(cls, 0.0) + t.goal / lot_options[cls].max_area
    total = sum(count.values())
    return {c: v / total for c, v in count.items()} if total > 0 else {}


def size_bands(counts: Mapping[LandUse, float], footprint_options: Mapping[LandUse, FootprintOptions], *,
               overlap: float = 0.05) -> dict[LandUse, FootprintOptions]:
    """Each building lot class's band of the town's footprint-area quantiles, as wide as its share.

    Classes are stacked by their typical building (``target_area``: houses,
    flats, shops, halls), each taking a band as wide as its share of
    ``counts`` (buildings, expected or real), widened by ``overlap`` on each
    inner side: buildings drawn this way have the town's footprint
    distribution whatever the mix, the small ones on houses, the large ones
    on halls.

    Parameters
    ----------
    counts : buildings (or shares) per lot class; classes missing or at 0 keep their options.
    footprint_options : per lot class.
    overlap : quantiles added on each side between neighbouring bands.

    Returns
    -------
    dict of LandUse to FootprintOptions
        ``footprint_options`` with ``size_band`` replaced for the counted classes.

    Examples
    --------
    >>> from osm_expand.engine.buildout.footprints import DEFAULT_FOOTPRINT_OPTIONS
    >>> bands = size_bands({LandUse.INDUSTRIAL: 1, LandUse.RESIDENTIAL_LOW: 3}, DEFAULT_FOOTPRINT_OPTIONS, overlap=0.1)
    >>> bands[LandUse.RESIDENTIAL_LOW].size_band, bands[LandUse.INDUSTRIAL].size_band
    ((0.0, 0.85), (0.65, 1.0))
    """
    out = dict(footprint_options)
    live = {c: float(v) for c, v in counts.items() if v > 0 and c in footprint_options and footprint_options[c].build}
    total = sum(live.values())
    if total <= 0:
        return out
    start = 0.0
    for cls in sorted(live, key=lambda c: (footprint_options[c].target_area, c.value)):
        end = min(start + live[cls] / total, 1.0)
        low = 0.0 if start <= 1e-12 else max(start - overlap, 0.0)
        high = 1.0 if end >= 1.0 - 1e-9 else min(end + overlap, 1.0)
        out[cls] = replace(footprint_options[cls], size_band=(round(low, 12), round(high, 12)))
        start = end
    return out


def _footprints(city: City) -> tuple[NDArray[np.object_], list[int]]:
    """Valid footprints of the town's own buildings (origin source) with their indices in ``city.buildings``."""
    polys, index = [], []
    for k, b in enumerate(city.buildings):
        if b.origin != Origin.SOURCE:
            continue
        poly = b.polygon
        if not poly.is_valid:
            poly = shapely.make_valid(poly)
        if poly.area >= 1.0:
            polys.append(poly)
            index.append(k)
    return np.array(polys, dtype=object), index


def _coverage(city: City, footprints: NDArray[np.object_], points: NDArray[np.float64],
              options: CalibrationOptions) -> float:
    """Footprint area over the area of the town's blocks that hold buildings (default without such blocks)."""
    blocks = [b.polygon for b in city.blocks]
    if not blocks or not len(footprints):
        return options.default_coverage
    tree = shapely.STRtree(blocks)
    pt, blk = tree.query(shapely.points(points), predicate="within")
    if not len(pt):
        return options.default_coverage
    used = np.unique(blk)
    covered = float(shapely.area(footprints[np.unique(pt)]).sum())
    ratio = covered / float(sum(blocks[k].area for k in used.tolist()))
    return float(np.clip(ratio, *options.coverage_range))


def _matches(key: str, value: str, rules: tuple[str, ...]) -> bool:
    return any(r == f"{key}=*" or r == f"{key}={value}" for r in rules)


def calibrate_town(city: City, history: History, *,
                   options: CalibrationOptions = CalibrationOptions()) -> TownCalibration:
    """Read footprints, sizes, heights, centres, land use and the town units from the town (module docstring).

    Parameters
    ----------
    city : City
        The town as mapped plus what was grown; only the town's own
        buildings (origin ``source``), its mapped areas, water, blocks and
        streets are read.
    history : History
        Its land-use types, lot and building options and economy options.

    Returns
    -------
    TownCalibration
    """
    net = city.network
    footprints, _ = _footprints(city)
    fp_area = shapely.area(footprints) if len(footprints) else np.zeros(0)
    points = shapely.get_coordinates(shapely.point_on_surface(footprints)) if len(footprints) else np.zeros((0, 2))
    outlines = shapely.oriented_envelope(footprints) if len(footprints) else np.zeros(0, dtype=object)
    lined = [i for i, s in enumerate(net.streets) if s.origin == Origin.SOURCE and len(s.nodes) >= 2]
    source = [net.streets[i] for i in lined]  # the town's streets, in the order of their lines
    source_lines = net.street_lines()[lined].tolist() if lined else []  # made once per network, in one call
    used = net.xy[net.used_nodes()]
    if len(points):
        centres = find_centres(points, fp_area, options=options)
    else:
        centres = find_centres(used, np.ones(len(used)), options=options)
    extent = float(np.hypot(*(used.max(axis=0) - used.min(axis=0)))) if len(used) else 1.0

    sizes = calibrate_sizes(list(footprints), street_lines=source_lines)
    tags = [b.tags for b in city.buildings if b.origin == Origin.SOURCE]
    heights = calibrate_heights(np.array([tag_number(t, "height") for t in tags], dtype=float),
                                np.array([tag_number(t, "building:levels") for t in tags], dtype=float),
                                options=history.options.economy)

    polygons = tuple((a.polygon, a.value) for a in city.areas if a.key in ("landuse", "leisure"))
    lu_options = history.options.land_use
    types = history.land_use_types
    landuse = None
    if polygons:
        if len(footprints):
            outline = shapely.union_all(shapely.buffer(footprints, options.town_buffer, quad_segs=2))
        else:
            outline = shapely.MultiPoint(used).convex_hull
        landuse = calibrate_landuse(list(polygons), outline, types=types, buildings=list(footprints),
                                    options=lu_options)
        if landuse.mapped_area > 0:
            types = landuse.with_goals(types)
        else:
            landuse = None

    footprint_options = dict(history.footprint_options)
    lot_options = calibrated_lot_options(sizes, lot_options=history.lot_options, footprint_options=footprint_options)
    shares = building_shares(types, lot_options, footprint_options)
    if options.size_bands and sizes.count:
        for _ in range(3):  # the bands size the lots, the lots weigh the bands: a few rounds settle
            footprint_options = size_bands(shares, history.footprint_options, overlap=options.band_overlap)
            lot_options = calibrated_lot_options(sizes, lot_options=history.lot_options,
                                                 footprint_options=footprint_options)
            shares = building_shares(types, lot_options, footprint_options)
    coverage = _coverage(city, footprints, points, options)
    unit_xy, unit_area, member = town_units(points, fp_area, cell=options.town_cell, coverage=coverage)
    unit_real = (types_from_polygons(unit_xy, list(polygons), types=types, buildings=list(footprints),
                                     options=lu_options)
                 if polygons and len(unit_xy) else np.full(len(unit_xy), UNASSIGNED, dtype=np.int64))
    storeys = _storeys(city, heights)
    floor_space = np.bincount(member, weights=fp_area * storeys, minlength=len(unit_xy)) if len(unit_xy) \
        else np.zeros(0)
    if source_lines and len(unit_xy):
        _, nearest = shapely.STRtree(source_lines).query_nearest(shapely.points(unit_xy), all_matches=False)
        unit_street = np.array([source[k].id for k in nearest.tolist()], dtype=np.int64)
    else:
        unit_street = np.full(len(unit_xy), -1, dtype=np.int64)

    water = tuple(g for g in (*city.water, *city.sea) if g is not None and not g.is_empty)
    green = tuple(a.polygon for a in city.areas if _matches(a.key, a.value, options.green))
    unbuildable = city.unbuildable if city.unbuildable is not None else unbuildable_land(city)
    return TownCalibration(
        footprints=footprints, outlines=outlines, building_points=points, centres=centres, extent=extent,
        coverage=coverage, sizes=sizes, heights=heights, landuse=landuse, types=types, lot_options=lot_options,
        footprint_options=footprint_options, building_shares=shares,
        polygons=polygons, water=water, green=green, unbuildable=unbuildable,
        unit_xy=unit_xy, unit_area=unit_area, unit_real=np.asarray(unit_real, dtype=np.int64),
        unit_floor_space=np.asarray(floor_space, dtype=np.float64), unit_street=unit_street,
        unit_water=distance_to(unit_xy, water), unit_green=distance_to(unit_xy, green))


def _storeys(city: City, heights: HeightCalibration) -> NDArray[np.float64]:
    """Storeys of each of the town's buildings (valid footprints only, same order as :func:`_footprints`).

    ``building:levels`` when tagged, else the ``height`` tag over the storey
    height, else the town's median height over it; at least one.
    """
    out = []
    for b in city.buildings:
        if b.origin != Origin.SOURCE:
            continue
        poly = b.polygon if b.polygon.is_valid else shapely.make_valid(b.polygon)
        if poly.area < 1.0:
            continue
        levels = tag_number(b.tags, "building:levels")
        height = tag_number(b.tags, "height")
        if not levels > 0:
            levels = (height if height > 0 else heights.median) / heights.storey_height
        out.append(max(float(levels), 1.0))
    return np.array(out, dtype=np.float64)
