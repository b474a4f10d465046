"""Land use calibrated from the map: OSM ``landuse=*`` polygons as the bundled types' shares and lots' types.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.landuse_types import (
    DEFAULT_OPTIONS,
    DEFAULT_TYPES,
    UNASSIGNED,
    LandUseOptions,
    LandUseType,
    goal_shares,
)

#: OSM ``landuse=*`` (and a few ``leisure=*``) values → bundled type. Housing
#: is ``residential``, split by ground coverage into low/high density when
#: building footprints are given. Shops and offices are ``commercial``;
#: production, storage and transport land is ``industrial``; urban green open
#: to people is ``park``. Farmland, forest, meadow, water and the like are not
#: urban land use and are left out (forest counts as ``green`` for distances).
OSM_LANDUSE: Mapping[str, str] = {
    "residential": "residential",
    "retail": "commercial", "commercial": "commercial", "shops": "commercial",
    "industrial": "industrial", "port": "industrial", "railway": "industrial",
    "depot": "industrial", "garages": "industrial", "quarry": "industrial",
    "grass": "park", "recreation_ground": "park", "village_green": "park",
    "park": "park", "garden": "park", "cemetery": "park", "allotments": "park",
    "playground": "park", "pitch": "park", "sports_centre": "park",
}


@dataclass(frozen=True)
class LandUseCalibration:
    """Shares of the town's own land use and the goals derived from them (aligned with ``types``).

    ``shares`` (T,) are the town's tagged land use by area; ``goals`` (T,)
    blend them with the bundled goals by ``weight`` (see
    :func:`calibrate_landuse`); ``coverage`` is the share of the buildings
    (counted) inside mapped land use (or the mapped area over the town
    area); ``ignored`` the tag values that map to no type, with their counts.
    """

    shares: NDArray[np.float64]
    goals: NDArray[np.float64]
    mapped_area: float
    coverage: float
    weight: float
    ignored: tuple[tuple[str, int], ...]

    def with_goals(self, types: Sequence[LandUseType]) -> tuple[LandUseType, ...]:
        """The types with their goals replaced by the calibrated ones."""
        return tuple(LandUseType(t.name, float(g), t.terms, t.lot_size) for t, g in zip(types, self.goals))


def _resolve_types(names: Sequence[str]) -> dict[str, int]:
    index = {n: i for i, n in enumerate(names)}
    low = index.get("residential_low", index.get("residential", -1))
    high = index.get("residential_high", low)
    out = {}
    for value, kind in OSM_LANDUSE.items():
        if kind == "residential":
            out[value] = low
        else:
            out[value] = index.get(kind, -1)
    out["_residential_high"] = high
    return out


def _classified_pieces(polygons: Sequence[tuple[Any, str]], types: Sequence[LandUseType],
                       buildings: Sequence[Any] | None, options: LandUseOptions
                       ) -> tuple[list[Any], NDArray[np.int64], dict[str, int]]:
    """Mapped polygons, overlaps resolved (smaller wins), with their type index."""
    resolve = _resolve_types([t.name for t in types])
    ignored: dict[str, int] = {}
    geoms, kinds = [], []
    for geom, value in polygons:
        t = resolve.get(str(value), -1)
        if t < 0 or geom is None or shapely.is_empty(geom) or shapely.area(geom) <= 0:
            ignored[str(value)] = ignored.get(str(value), 0) + 1
            continue
        geoms.append(shapely.make_valid(geom) if not shapely.is_valid(geom) else geom)
        kinds.append((t, str(value) == "residential"))
    if not geoms:
        return [], np.zeros(0, np.int64), ignored
    areas = shapely.area(np.asarray(geoms, dtype=object))
    order = np.argsort(areas, kind="stable")  # small, specific polygons win over the large ones they sit in
    geoms = [geoms[i] for i in order]
    kinds = [kinds[i] for i in order]
    tree = shapely.STRtree(geoms)
    pieces = []
    for i, g in enumerate(geoms):
        earlier = [j for j in tree.query(g, predicate="intersects").tolist() if j < i]
        pieces.append(g.difference(shapely.union_all([geoms[j] for j in earlier])) if earlier else g)
    index = np.array([t for t, _ in kinds], dtype=np.int64)
    residential = np.array([r for _, r in kinds])
    if buildings is not None and len(buildings) and residential.any():
        footprints = np.asarray(list(buildings), dtype=object)
        foot = shapely.STRtree(footprints)
        high = resolve["_residential_high"]
        for i in np.flatnonzero(residential).tolist():
            hits = foot.query(pieces[i], predicate="intersects")
            covered = shapely.area(shapely.intersection(footprints[hits], pieces[i])).sum() if len(hits) else 0.0
            if shapely.area(pieces[i]) > 0 and covered / shapely.area(pieces[i]) > options.high_density_coverage:
                index[i] = high
    return pieces, index, ignored


def calibrate_landuse(polygons: Sequence[tuple[Any, str]], town_area: float | Any, *,
                      types: Sequence[LandUseType] = DEFAULT_TYPES,
                      buildings: Sequence[Any] | None = None,
                      options: LandUseOptions = DEFAULT_OPTIONS) -> LandUseCalibration:
    """Initial shares and goals from the town's own ``landuse=*`` polygons (issue: calibrate from OSM).

    Parameters
    ----------
    polygons : sequence of (shapely Polygon, str)
        The town's land-use areas (m) with their ``landuse`` (or ``leisure``)
        value; values map to types by :data:`OSM_LANDUSE`, others are ignored.
        Where polygons overlap, the smaller one owns the overlap (a park inside
        a residential area is a park).
    town_area : float or shapely Polygon
        The town's built-up area (m²), or its outline: then land use outside
        it does not count (a residential polygon spanning a whole valley
        counts only where the town is) and its area is the town area.
    types : sequence of LandUseType
        Types named ``residential_low``/``residential_high`` (or
        ``residential``), ``commercial``, ``industrial``, ``park`` receive the
        mapped values.
    buildings : sequence of shapely Polygon, optional
        Building footprints (m); a residential polygon whose footprints cover
        more than ``high_density_coverage`` of it is high-density, and the
        coverage is the share of the buildings (a point inside each) in mapped polygons.

    Returns
    -------
    LandUseCalibration
        ``goals = w·shares + (1 − w)·bundled goals`` with
        ``w = min(1, coverage / min_calibration_coverage)`` (all bundled when
        nothing maps).
    """
    names = [t.name for t in types]
    default = goal_shares(types)
    outline = None
    if isinstance(town_area, shapely.Geometry):
        outline, town_area = town_area, float(shapely.area(town_area))
    pieces, index, ignored = _classified_pieces(polygons, types, buildings, options)
    geoms = np.asarray(pieces, dtype=object)
    if outline is not None and len(geoms):
        geoms = shapely.intersection(geoms, outline)
    per = (np.bincount(index, weights=shapely.area(geoms), minlength=len(names)).astype(np.float64)
           if len(index) else np.zeros(len(names)))
    mapped = float(per.sum())
    shares = per / mapped if mapped > 0 else np.zeros(len(names))
    if buildings is not None and len(buildings):
        points = shapely.point_on_surface(np.asarray(list(buildings), dtype=object))
        inside = np.zeros(len(points), dtype=bool)
        if len(geoms):
            hit, _ = shapely.STRtree(geoms).query(points, predicate="intersects")
            inside[hit] = True
        coverage = float(inside.mean())
    else:
        coverage = min(1.0, mapped / town_area) if town_area > 0 else 0.0
    weight = min(1.0, coverage / options.min_calibration_coverage) if mapped > 0 else 0.0
    goals = weight * shares + (1.0 - weight) * default
    return LandUseCalibration(shares, goals / goals.sum(), mapped, coverage, weight,
                              tuple(sorted(ignored.items())))


def types_from_polygons(xy: NDArray[np.float64], polygons: Sequence[tuple[Any, str]], *,
                        types: Sequence[LandUseType] = DEFAULT_TYPES,
                        buildings: Sequence[Any] | None = None,
                        options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.int64]:
    """The type of the tagged land-use polygon each point lies in, same mapping as :func:`calibrate_landuse`.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    polygons : sequence of (shapely Polygon, str)

    Returns
    -------
    ndarray of int, shape (L,)
        Type index, ``UNASSIGNED`` outside every mapped polygon (initial types
        for the old town's lots).
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.full(len(xy), UNASSIGNED, dtype=np.int64)
    pieces, index, _ = _classified_pieces(polygons, types, buildings, options)
    if not pieces or not len(xy):
        return out
    points = shapely.points(xy)
    pi, gi = shapely.STRtree(pieces).query(points, predicate="within")
    out[pi] = index[gi]
    return out
