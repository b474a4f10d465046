"""What the town's own footprints teach the build-out: their sizes (area, frontage, depth) and the lot
sizes that hold them (issue: lot and footprint sizes start from the town); read once, by
:func:`~osm_expand.engine.buildout.calibration.calibrate_town`. Placing buildings on lots is
:mod:`osm_expand.engine.buildout.footprints`.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import shapely

from osm_expand.engine.buildout.footprints import DEFAULT_FOOTPRINT_OPTIONS, FootprintOptions, SizeTargets
from osm_expand.engine.buildout.lots import DEFAULT_LOT_OPTIONS, LandUse, LotOptions, land_use

__all__ = ["calibrate_sizes", "calibrated_lot_options", "footprint_dimensions"]


def footprint_dimensions(footprints: Sequence[shapely.Geometry | np.ndarray], *,
                         street_lines: Sequence[shapely.LineString] = ()) -> np.ndarray:
    """Area, frontage and depth of existing footprints, ``(K, 3)`` (m², m, m).

    Frontage and depth are the sides of each footprint's minimum rotated
    rectangle; the frontage is the side more nearly parallel to the nearest
    street (its direction 1 m either side of the closest point), or the
    shorter side without streets. Footprints under 1 m² are dropped.

    A footprint is any shapely geometry or a ring of points: a multipolygon
    building with several outers counts as its polygons (each a building's
    size), and what is not a polygon once made valid (a ring cut to a line
    by the extract, fewer than three points) is dropped, as the reader can
    hand any of these over.
    """
    polys = _polygon_parts(footprints)
    if not len(polys):
        return np.zeros((0, 3))
    area = shapely.area(polys)
    keep = area >= 1.0
    polys, area = polys[keep], area[keep]
    s1, s2 = _rectangle_sides(polys)
    l1, l2 = np.hypot(s1[:, 0], s1[:, 1]), np.hypot(s2[:, 0], s2[:, 1])
    first_is_front = l1 <= l2
    if len(street_lines):
        lines = np.array(list(street_lines), dtype=object)
        centre = shapely.centroid(polys)
        tree = shapely.STRtree(lines)
        _, nearest = tree.query_nearest(centre, all_matches=False)
        line = lines[nearest]
        at = shapely.line_locate_point(line, centre)
        ahead = shapely.get_coordinates(shapely.line_interpolate_point(line, at + 1.0))
        behind = shapely.get_coordinates(shapely.line_interpolate_point(line, at - 1.0))
        t = ahead - behind
        t = t / np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-12)[:, None]
        c1 = np.abs((s1 * t).sum(axis=1)) / np.maximum(l1, 1e-12)
        c2 = np.abs((s2 * t).sum(axis=1)) / np.maximum(l2, 1e-12)
        first_is_front = c1 >= c2
    frontage = np.where(first_is_front, l1, l2)
    depth = np.where(first_is_front, l2, l1)
    return np.column_stack([area, frontage, depth])


def _rectangle_sides(polys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two adjacent sides (vectors) of each polygon's minimum rotated rectangle, ``(K, 2)`` each.

    Where GEOS's rotated rectangle comes out degenerate for a polygon of real
    area (a line, a side of zero or NaN length, or a rectangle smaller than
    the polygon; seen on a ring with a subnormal coordinate, 1e-214), the
    axis-aligned bounding box stands in:
    it encloses the polygon too, so every footprint of at least 1 m² is still
    measured and its frontage × depth still covers its area.

    GEOS divides by each hull edge's length: an edge shorter than ~1e-154 m
    (a subnormal coordinate beside a normal one, as in
    ``(0 0, 0 2, 1 5.6e-219, 1 0)``, 1 m²) has a square that underflows to 0,
    a division by zero (numpy's warning, printed by CI) and a NaN or infinite
    candidate, which the check below replaces like any degenerate rectangle.
    """
    with np.errstate(invalid="ignore", divide="ignore"):  # the degenerate ones are replaced below
        env = shapely.oriented_envelope(polys)
    corners = np.full((len(polys), 5, 2), np.nan)
    rect = shapely.get_type_id(env) == 3
    rect[rect] = shapely.get_num_coordinates(env[rect]) == 5
    corners[rect] = shapely.get_coordinates(shapely.get_exterior_ring(env[rect])).reshape(-1, 5, 2)
    s1, s2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 1]
    # NaN compares False; a rectangle that does not hold the polygon's area does not enclose it
    good = np.hypot(s1[:, 0], s1[:, 1]) * np.hypot(s2[:, 0], s2[:, 1]) >= shapely.area(polys) * (1 - 1e-9)
    if not good.all():
        box = shapely.bounds(polys[~good])
        width, height = box[:, 2] - box[:, 0], box[:, 3] - box[:, 1]
        s1[~good] = np.column_stack([width, np.zeros_like(width)])
        s2[~good] = np.column_stack([np.zeros_like(height), height])
    return s1, s2


def _polygon_parts(footprints: Sequence[shapely.Geometry | np.ndarray]) -> np.ndarray:
    """The valid polygons of footprints given as geometries or point rings (see :func:`footprint_dimensions`)."""
    geoms = []
    for f in footprints:
        if isinstance(f, shapely.Geometry):
            geoms.append(f)
            continue
        ring = np.asarray(f, dtype=float).reshape(-1, 2)
        if len(ring) >= 3 and np.isfinite(ring).all():
            geoms.append(shapely.Polygon(ring))
    # polygons one by one first: GEOS cannot make valid a multipolygon with a collapsed part
    # ("mixed-dimension"); a bow-tie made valid is a multipolygon, a collection may hold multipolygons
    polys = _polygons(np.array(geoms, dtype=object))
    return _polygons(shapely.make_valid(polys))


def _polygons(geoms: np.ndarray) -> np.ndarray:
    parts = shapely.get_parts(shapely.get_parts(geoms))
    return parts[shapely.get_type_id(parts) == 3]


def calibrate_sizes(footprints: Sequence[shapely.Geometry | np.ndarray], *,
                    street_lines: Sequence[shapely.LineString] = ()) -> SizeTargets:
    """The town's footprint sizes (area, frontage, depth; see :func:`footprint_dimensions`)."""
    dims = footprint_dimensions(footprints, street_lines=street_lines)
    return SizeTargets(samples=dims[np.argsort(dims[:, 0], kind="stable")])


def calibrated_lot_options(sizes: SizeTargets, *,
                           lot_options: Mapping[LandUse, LotOptions] = DEFAULT_LOT_OPTIONS,
                           footprint_options: Mapping[LandUse, FootprintOptions] = DEFAULT_FOOTPRINT_OPTIONS,
                           lot_factor: float = 1.6) -> dict[LandUse, LotOptions]:
    """Lot options sized to hold the town's buildings (002 §5.1 ``maxarea_t`` from the town).

    The footprint → lot mapping: a building of area A and frontage/depth ρ
    with setbacks (front f, side s, back b) needs a lot of

        need(A) = (√(Aρ) + 2s) · (√(A/ρ) + f + b)

    (upper ends of the setback ranges, f including the front variation, ρ
    the town's median). Recursive halving leaves lots between about half
    and all of ``max_area``, so ``max_area = lot_factor · need(A₇₅)`` with
    A₇₅ the area at three quarters of the land use's size band. With the
    default factor the lots hold the buildings :func:`place_buildings`
    gives them by rank, and the generated footprint-area median lands
    within 1 % of the town's on Krems and Andorra with only low-density
    housing, and 7–10 % above it with a mix of land uses
    (``benchmarks/lots_speed.py``, ``--mix``); lot_factor 1.6 with A₅₀
    instead gave 7–17 % below.
    ``min_area`` is lowered to a third of ``max_area`` where it would
    otherwise block splitting. Land uses without buildings keep their options.
    """
    if not sizes.count:
        return {land_use(k): v for k, v in lot_options.items()}
    rho = float(np.median(sizes.samples[:, 1] / np.maximum(sizes.samples[:, 2], 1e-9)))
    out = {}
    for key, lot_opts in lot_options.items():
        use = land_use(key)
        fp = footprint_options.get(use)
        if fp is None or not fp.build:
            out[use] = lot_opts
            continue
        band = fp.size_band
        area, _ = sizes.at(band[0] + 0.75 * (band[1] - band[0]), fp.max_ratio)
        r = min(max(rho, 1.0 / fp.max_ratio), fp.max_ratio)
        need = ((math.sqrt(float(area) * r) + 2.0 * fp.side_setback[1])
                * (math.sqrt(float(area) / r) + fp.front_setback[1] + fp.front_variation + fp.back_setback[1]))
        max_area = lot_factor * need
        out[use] = replace(lot_opts, max_area=max_area, min_area=min(lot_opts.min_area, max_area / 3.0))
    return out
