"""How faithful a simplified network is to the streets it came from.

Simplification may move a junction to a cluster centroid or drop a slip
road, but the town must stay recognisable: most of the original street
length should lie close to some simplified street.
"""
from __future__ import annotations

import numpy as np
import shapely

from osm_expand.model import StreetNetwork
from simplify.crossings import add_missing_intersections
from simplify.dead_ends import prune_dead_ends
from simplify.intersections import extract_intersections
from simplify.options import SimplifyOptions


def pruned_reference(net: StreetNetwork) -> StreetNetwork:
    """The ingested network with its dead ends pruned: what simplification should keep."""
    ref, _ = add_missing_intersections(extract_intersections(net), SimplifyOptions())
    return prune_dead_ends(ref)[0]


def _segments(net: StreetNetwork, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints and lengths of the streets cut into pieces of at most ``step`` metres."""
    lines = shapely.segmentize([shapely.LineString(net.street_xy(s)) for s in net.streets], step)
    coords, index = shapely.get_coordinates(lines, return_index=True)
    same = index[1:] == index[:-1]
    a, b = coords[:-1][same], coords[1:][same]
    return (a + b) / 2, np.hypot(*(b - a).T)


def length_within(reference: StreetNetwork, simplified: StreetNetwork, radius: float = 25.0,
                  step: float = 5.0) -> float:
    """Share of ``reference`` street length within ``radius`` metres of ``simplified`` streets."""
    mid, length = _segments(reference, step)
    if length.sum() == 0:
        return 1.0
    if not simplified.streets:
        return 0.0
    target = shapely.STRtree([shapely.LineString(simplified.street_xy(s)) for s in simplified.streets])
    hit, _ = target.query(shapely.points(mid), predicate="dwithin", distance=radius)
    covered = np.zeros(len(mid), dtype=bool)
    covered[hit] = True
    return float(length[covered].sum() / length.sum())
