"""Assemble ``natural=coastline`` ways into sea polygons inside the bounds.

OSM draws coastline with land on the left. Extracts clip it, so the pieces
are merged, the bounding box is cut by them, and each resulting face is
classified as sea when it lies to the right of its nearest coastline segment.
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
    parts = list(getattr(coast, "geoms", [coast]))
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
