"""The land of a set of streets: the streets closed (buffered, shrunk back), and a disc's part of it.

One rule in one place for the engine's growth verdict (:func:`osm_expand.growth_fidelity.growth_window`,
:func:`osm_expand.growth_fidelity.streets_land`, whose module docstring says why the window is a closing)
and its piece yardstick (:mod:`osm_expand.engine.growth.yardstick`), which close with one margin, the
town's (:func:`block_margin`). It imports only the measures' line set. (The example patches' target density
read it too, ``PatchOptions.target_on_streets_land``, measured, left off and removed in session 42:
docs/tried.md.)
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from osm_expand.measures import LineSet

#: m: the streets are buffered this much, then shrunk back to :data:`WINDOW_MARGIN`: the blocks between
#: them (up to 2 × 150 m across, a large town block) fall inside (the default of
#: ``GrowthFidelityOptions.window_close``).
WINDOW_CLOSE = 150.0
#: m: the land reaches this far beyond the outermost streets: half a 100 m town block, as a real
#: neighbourhood disc cuts the blocks on its rim in half on average (``GrowthFidelityOptions.window_margin``);
#: where the town's blocks are known, :func:`block_margin` of them is used instead.
WINDOW_MARGIN = 50.0


def block_margin(block_area: np.ndarray, close: float = WINDOW_CLOSE, default: float = WINDOW_MARGIN) -> float:
    """The margin (m) of a town whose blocks have the areas ``block_area`` (m²): half the side of its median
    block, ``sqrt(median) / 2``, at most ``close``; ``default`` where it has no block.

    Why: a real neighbourhood disc cuts the blocks on its rim at a random place, so the land between its rim
    and the first street inside is on average half a block of *that* town deep; the land of a growth, closed
    with this margin, then holds what a disc of its area holds (:mod:`osm_expand.growth_fidelity`). Monaco's
    median block is 1,666 m² (margin 20 m), Andorra's 32 m, Krems' 46 m, north-bayreuth's 53 m.
    """
    areas = np.asarray(block_area, dtype=float)
    areas = areas[np.isfinite(areas) & (areas > 0)]
    if not len(areas):
        return default
    return min(close, float(np.sqrt(np.median(areas))) / 2.0)


def closed_land(lines: Sequence[np.ndarray] | LineSet, close: float = WINDOW_CLOSE,
                margin: float = WINDOW_MARGIN) -> shapely.Geometry:
    """The land of ``lines``: buffered ``close`` m, shrunk back to ``margin`` (empty for no line)."""
    geoms = LineSet.from_lines(lines).geoms
    if len(geoms) == 0:
        return shapely.Polygon()
    grown = shapely.union_all(shapely.buffer(geoms, close, quad_segs=4))
    return shapely.buffer(grown, margin - close, quad_segs=4)


def land_in_disc(disc: shapely.Geometry, land: shapely.Geometry) -> shapely.Geometry:
    """``disc`` within ``land`` (its polygons only), or ``disc`` itself where no land is in it: its rim
    stays the disc's, so streets cut there stay open."""
    within = shapely.intersection(disc, land)
    if within.area <= 0:
        return disc
    if within.geom_type != "GeometryCollection":
        return within
    parts = shapely.get_parts(within)  # where the two only touch, points and lines too: the polygons only
    return shapely.union_all(parts[shapely.area(parts) > 0])
