"""Perimeter streets: cut ends met along the district's edge, a few metres inside it."""
from __future__ import annotations

import numpy as np
import shapely
import shapely.ops

from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _close, _lay, _Quilt
from synth.patches.seams import CONNECTOR_STEP

#: Metres inside the district's edge that a perimeter street runs.
EDGE_INSET = 4.0


def _edge_start(quilt: _Quilt, region: shapely.Geometry, occupied: shapely.Geometry, old: shapely.Geometry
                ) -> tuple[list, np.ndarray, np.ndarray, _Board] | None:
    """What both ways of walking the site's edge start from: the edge's rings drawn ``EDGE_INSET``
    inside the region, the cut streets' ends, which of them lie at the edge, and the board new
    streets are laid on (None: fewer than two cut ends, or no ring)."""
    if len(quilt.cut_xy) < 2:
        return None
    inner = shapely.buffer(region, -EDGE_INSET)
    rings = [r for poly in shapely.get_parts(inner) if poly.geom_type == "Polygon" for r in [poly.exterior]]
    if not rings:
        return None
    xy = np.array(quilt.cut_xy)
    at_edge = shapely.distance(shapely.boundary(region), shapely.points(xy)) < EDGE_INSET + 1.0
    return rings, xy, at_edge, _Board(quilt, occupied, old)


def _edge_streets(quilt: _Quilt, region: shapely.Geometry, spacing: float, opts: PatchOptions,
                  occupied: shapely.Geometry, old: shapely.Geometry) -> int:
    """Join cut ends left at the district's edge to their neighbour along it by a perimeter street that
    follows the edge :data:`EDGE_INSET` metres inside; returns the streets made.

    Trimming them back instead leaves combs of cul-de-sacs along the edge
    and loses a third of the district's street length; joined, they close
    the edge blocks, as a housing estate's ring road does.
    """
    if opts.perimeter_tees:
        return _perimeter_runs(quilt, region, spacing, opts, occupied, old)
    start = _edge_start(quilt, region, occupied, old)
    if start is None:
        return 0
    rings, xy, at_edge, board = start
    used = np.zeros(len(xy), dtype=bool)
    made = 0
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
            if used[a] or used[b] or quilt.cut_piece[a] == quilt.cut_piece[b]:
                continue
            along = (where[j] - where[i]) % total
            if along > opts.seam_gap * spacing:
                continue
            run = _ring_run(ring, float(where[i]), along)
            raw = np.vstack([xy[a], run, xy[b]])
            # the edge is a union of buffers, jagged at a few metres: a street follows it smoothly
            smooth = shapely.get_coordinates(shapely.simplify(shapely.LineString(raw), EDGE_INSET))
            path = smooth if len(smooth) >= 2 and board.clear(smooth) else raw
            if len(path) < 2 or not board.clear(path):
                continue
            _lay(board, quilt, path, a)
            used[a] = used[b] = True
            made += 1
    _close(quilt, used)
    return made


def _perimeter_runs(quilt: _Quilt, region: shapely.Geometry, spacing: float, opts: PatchOptions,
                  occupied: shapely.Geometry, old: shapely.Geometry) -> int:
    """:func:`_edge_streets` with ``perimeter_tees``: perimeter streets that each cut street meets in a
    tee where it crosses the edge :data:`EDGE_INSET` metres inside, pulled taut (:func:`_taut`); returns
    the perimeter streets made.

    The perimeter
    runs on past each cut street it meets (cut ends consecutive along the
    edge within ``seam_gap`` spacings form one run), so a cut street meets
    it in a tee, as streets meet a ring road, and only the run's two ends
    turn a corner: a perimeter link per pair of cut ends turned two corners
    per pair, a U of L-bends along the edge, the sharpest bends of the
    district (north-bayreuth seed 0: 15 of its 34).
    """
    start = _edge_start(quilt, region, occupied, old)
    if start is None:
        return 0
    rings, xy, at_edge, board = start
    inside = shapely.buffer(region, 0.5)
    shapely.prepare(inside)
    used = np.zeros(len(xy), dtype=bool)
    made = 0
    for ring in rings:
        near = np.flatnonzero(at_edge & (shapely.distance(ring, shapely.points(xy)) < EDGE_INSET + 1.0))
        meets = {int(k): at for k in near.tolist()
                 if (at := _meets_ring(quilt.xy[quilt.cut_piece[k]], xy[k], ring)) is not None}
        if len(meets) < 2:
            continue
        ends = np.array(sorted(meets))
        where = shapely.line_locate_point(ring, shapely.points([meets[k] for k in ends]))
        order = np.argsort(where, kind="stable")
        ends, where = ends[order], where[order]
        total = ring.length
        pairs = [(k, k + 1) for k in range(len(ends) - 1)] + [(len(ends) - 1, 0)]
        if len(ends) == 2:  # two ends: the shorter way round the ring
            pairs = [pairs[int((where[1] - where[0]) % total > (where[0] - where[1]) % total)]]
        for i, j in pairs:
            a, b = int(ends[i]), int(ends[j])
            if quilt.cut_piece[a] == quilt.cut_piece[b]:
                continue
            along = (where[j] - where[i]) % total
            if along > opts.seam_gap * spacing:
                continue
            run = _ring_run(ring, float(where[i]), along)
            raw = np.vstack([meets[a], run[1:-1], meets[b]]) if len(run) > 2 else np.array([meets[a], meets[b]])
            path = _taut(raw, board, inside)
            if path is None:
                continue
            for k in (a, b):
                if not used[k]:  # the cut street meets the perimeter where it crosses it; its last metres go
                    quilt.splits.setdefault(quilt.cut_piece[k], []).append(meets[k])
            _lay(board, quilt, path, a)
            used[a] = used[b] = True
            made += 1
    # the cut ends stay open: the few metres of each cut street past the perimeter are trimmed
    return made


def _taut(raw: np.ndarray, board: _Board, inside: shapely.Geometry) -> np.ndarray | None:
    """The perimeter street along ``raw`` (the edge, inset) pulled taut: from each point on to the
    farthest point of ``raw`` that a straight street reaches ``inside`` the district crossing nothing
    on the ``board`` (a string pulled along the edge); None when even ``raw`` is not clear.

    The free land's edge is the outline of buffers around buildings, land use and streets, jagged at
    every house: a street that follows it within a few metres wiggles at every plot (north-bayreuth
    seed 0: most of the district's bends over 20° were on its perimeter), where a road laid along
    such an edge runs straight from corner to corner and bends only where the edge makes it.
    """
    def reach(p: np.ndarray, q: np.ndarray) -> bool:
        line = shapely.LineString([p, q])
        return bool(inside.covers(line)) and board.clear(np.array([p, q]))

    path, i = [raw[0]], 0
    while i < len(raw) - 1:
        j = len(raw) - 1
        while j > i + 1 and not reach(raw[i], raw[j]):
            j -= 1
        path.append(raw[j])
        i = j
    out = np.array(path)
    return out if board.clear(out) else (raw if board.clear(raw) else None)


def _meets_ring(piece: np.ndarray, end: np.ndarray, ring: shapely.LinearRing) -> np.ndarray | None:
    """Where the cut street ``piece`` crosses ``ring`` nearest its cut end at ``end``, when within
    :data:`EDGE_INSET` metres and a few along the street from it; None otherwise."""
    line = shapely.LineString(piece)
    hit = shapely.get_coordinates(shapely.intersection(line, ring))
    if not len(hit):
        return None
    along = np.abs(shapely.line_locate_point(line, shapely.points(hit)) - line.line_locate_point(shapely.Point(end)))
    k = int(np.argmin(along))
    return hit[k] if along[k] <= 3.0 * EDGE_INSET else None


def _ring_run(ring: shapely.LinearRing, start: float, along: float) -> np.ndarray:
    """Points of ``ring`` from ``start`` metres along it, ``along`` metres onward (wrapping), every
    :data:`CONNECTOR_STEP` metres or so."""
    n = max(int(np.ceil(along / CONNECTOR_STEP)), 1)
    at = (start + np.linspace(0.0, along, n + 1)) % ring.length
    return shapely.get_coordinates(shapely.line_interpolate_point(ring, at))
