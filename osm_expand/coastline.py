"""Assemble ``natural=coastline`` ways into sea polygons inside the bounds.

OSM draws coastline with land on the left. Extracts clip it, so the pieces
are merged, the bounding box is cut by them, and each resulting face is
classified as sea when it lies to the right of its nearest coastline segment.

A piece that ends inside the box (the map's bounds reach past the data, as
a ``--bbox``/``--around`` clip or a ``<bounds>`` drawn wide does) or on its
edge (bounds equal to the nodes' extent, where rounding decides whether the
end is in or out) cuts nothing: the box stayed one face and was all sea or
all land by a vote. Such an end is carried on in its last direction past
the box, so the coast divides the box, land on its left.
"""
from __future__ import annotations

import numpy as np
import shapely
from shapely.ops import polygonize, unary_union


def assemble_sea(lines: list[np.ndarray], box: shapely.Polygon) -> tuple:
    """Sea polygons within ``box`` from coastline polylines (metres)."""
    if not lines:
        return ()
    coast = shapely.line_merge(shapely.MultiLineString([ln for ln in lines if len(ln) >= 2]))
    parts = [_carried_past(p, box) for p in getattr(coast, "geoms", [coast])]
    noded = unary_union([box.boundary, *parts])
    faces = [f for f in polygonize(noded) if f.area > 1.0 and box.contains(f.representative_point())]
    segments = np.concatenate([_segments(np.asarray(p.coords)) for p in parts])
    if not len(segments):
        return ()
    tree = shapely.STRtree(shapely.linestrings(segments))
    sea = []
    for face in faces:
        if _is_sea(face, segments, tree):
            sea.append(face)
    return tuple(sea)


def _carried_past(part: shapely.LineString, box: shapely.Polygon) -> shapely.LineString:
    """An open coastline with each end that lies in the box (or on its edge) carried on straight,
    in the direction of its last stretch, to beyond the box."""
    coords = np.asarray(part.coords)
    if part.is_closed or len(coords) < 2:
        return part
    minx, miny, maxx, maxy = box.bounds
    reach = 2.0 * float(np.hypot(maxx - minx, maxy - miny)) + 1.0
    edge = box.buffer(1e-6 * reach + 1e-6)  # the edge itself counts as in
    head: list[np.ndarray] = []
    tail: list[np.ndarray] = []
    for end, toward, out in ((coords[0], coords[1:], head), (coords[-1], coords[-2::-1], tail)):
        if not edge.contains(shapely.Point(end)):
            continue
        step = end - toward
        far = np.flatnonzero(np.hypot(step[:, 0], step[:, 1]) > 1e-9)
        if len(far):
            d = step[far[0]] / np.hypot(*step[far[0]])
            out.append(end + reach * d)
    return shapely.LineString([*head, *coords, *tail])


def _segments(coords: np.ndarray) -> np.ndarray:
    return np.stack([coords[:-1], coords[1:]], axis=1)


def _is_sea(face: shapely.Polygon, segments: np.ndarray, tree: shapely.STRtree) -> bool:
    """Majority vote of a few interior points: right of the nearest coast segment is sea."""
    pts = [face.representative_point()]
    minx, miny, maxx, maxy = face.bounds
    rng = np.random.default_rng(0)
    for x, y in rng.uniform((minx, miny), (maxx, maxy), size=(40, 2)):
        p = shapely.Point(x, y)
        if face.contains(p):
            pts.append(p)
        if len(pts) >= 7:
            break
    votes = 0
    for p in pts:
        a, b = segments[tree.nearest(p)]
        cross = (b[0] - a[0]) * (p.y - a[1]) - (b[1] - a[1]) * (p.x - a[0])
        votes += 1 if cross < 0 else -1
    return votes > 0
