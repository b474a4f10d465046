"""Perimeter streets: cut ends met along the district's edge, a few metres inside it."""
from __future__ import annotations

import numpy as np
import shapely

from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _close, _lay, _Quilt
from synth.patches.seams import CONNECTOR_STEP

#: Metres inside the district's edge that a perimeter street runs.
EDGE_INSET = 4.0


def _edge_streets(quilt: _Quilt, region: shapely.Geometry, spacing: float, opts: PatchOptions,
                  occupied: shapely.Geometry, old: shapely.Geometry) -> int:
    """Join cut ends left at the district's edge to their neighbour along it by a perimeter street that
    follows the edge :data:`EDGE_INSET` metres inside; returns the streets made.

    Trimming them back instead leaves combs of cul-de-sacs along the edge
    and loses a third of the district's street length; joined, they close
    the edge blocks, as a housing estate's ring road does. Measured without
    them (session 34, ``engine_growth.py --seed 0``, off of 14 per
    reference): north-bayreuth 5 5 5 -> 4 4 4 but its 2-core share 0.732
    below range and its curvature still off (KS 0.126, the trimmed tees'
    Ls left), Monaco 2 3 3 -> 3 3 3 with its dead-end and 2-core shares
    out of range, Andorra 0 0 0 -> 7 7 9, Krems 3.1 km grown. Each cut end
    takes one run, so its street turns into the run at a node of degree
    two (an L). The street is the edge simplified at :data:`EDGE_INSET`
    (the edge is a union of buffers, jagged at a few metres), or the edge
    as it is where that is not clear. Ways tried of shaping, bounding and
    squaring these streets are in docs/tried.md (session 41).
    """
    if len(quilt.cut_xy) < 2:
        return 0
    inner = shapely.buffer(region, -EDGE_INSET)
    rings = [r for poly in shapely.get_parts(inner) if poly.geom_type == "Polygon" for r in [poly.exterior]]
    if not rings:
        return 0
    xy = np.array(quilt.cut_xy)
    at_edge = shapely.distance(shapely.boundary(region), shapely.points(xy)) < EDGE_INSET + 1.0
    runs = []  # (cut end, cut end, the edge between them), in the order they are laid
    for ring in rings:
        near = np.flatnonzero(at_edge & (shapely.distance(ring, shapely.points(xy)) < EDGE_INSET + 1.0))
        if len(near) < 2:
            continue
        where = shapely.line_locate_point(ring, shapely.points(xy[near]))
        order = near[np.argsort(where, kind="stable")]
        where = np.sort(where)
        total = ring.length
        pairs = [(k, k + 1) for k in range(len(order) - 1)] + ([(len(order) - 1, 0)] if len(order) > 2 else [])
        for i, j in pairs:
            a, b = int(order[i]), int(order[j])
            if quilt.cut_piece[a] == quilt.cut_piece[b]:
                continue
            along = (where[j] - where[i]) % total
            if along > opts.seam_gap * spacing:
                continue
            runs.append((a, b, np.vstack([xy[a], _ring_run(ring, float(where[i]), along), xy[b]])))
    board = _Board(quilt, occupied, old)
    used = np.zeros(len(xy), dtype=bool)
    made = 0
    for a, b, raw in runs:
        if used[a] or used[b]:
            continue
        simple = _simplified(raw, EDGE_INSET)
        path = simple if simple is not None and board.clear(simple) else raw
        if len(path) < 2 or not board.clear(path):
            continue
        _lay(board, quilt, path, a)
        used[a] = used[b] = True
        made += 1
    _close(quilt, used)
    return made


def _ring_run(ring: shapely.LinearRing, start: float, along: float) -> np.ndarray:
    """Points of ``ring`` from ``start`` metres along it, ``along`` metres onward (wrapping), every
    :data:`CONNECTOR_STEP` metres or so."""
    n = max(int(np.ceil(along / CONNECTOR_STEP)), 1)
    at = (start + np.linspace(0.0, along, n + 1)) % ring.length
    return shapely.get_coordinates(shapely.line_interpolate_point(ring, at))


def _simplified(raw: np.ndarray, tolerance: float) -> np.ndarray | None:
    """``raw`` simplified at ``tolerance`` metres; None if that leaves fewer than two points."""
    path = shapely.get_coordinates(shapely.simplify(shapely.LineString(raw), tolerance))
    return path if len(path) >= 2 else None
