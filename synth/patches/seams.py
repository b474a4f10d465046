"""Seams: cut streets continued into the neighbouring cell's (004 §3.1's transition probability) or run on
to a tee."""
from __future__ import annotations

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _close, _lay, _meet, _Quilt


def _walk_seams(quilt: _Quilt, spacing: float, opts: PatchOptions, occupied: shapely.Geometry,
                old: shapely.Geometry) -> int:
    """Continue cut streets across the seams, most probable transition first; returns the links made.

    A transition's probability is 004's (§3.1) on the gap between the two cut ends and the angle
    between the two cut streets; links that turn more than ``seam_turn``, or that would cross
    anything, are not made, and those cut ends run on to a tee, along the edge, or are trimmed. Other
    readings of a link's turn, and straight links, were tried: docs/tried.md (session 41).
    """
    if len(quilt.cut_xy) < 2:
        return 0
    xy, heading = np.array(quilt.cut_xy), np.array(quilt.cut_heading)
    cell = np.array(quilt.cut_cell)
    pairs = cKDTree(xy).query_pairs(opts.seam_gap * spacing, output_type="ndarray")
    pairs = pairs[cell[pairs[:, 0]] != cell[pairs[:, 1]]]
    if not len(pairs):
        return 0
    gap = np.hypot(*(xy[pairs[:, 1]] - xy[pairs[:, 0]]).T)
    turn = np.degrees(np.arccos(np.clip(-(heading[pairs[:, 0]] * heading[pairs[:, 1]]).sum(axis=1), -1.0, 1.0)))
    sg, st = opts.seam_sigma
    p = np.exp(-0.5 * (gap / (sg * spacing)) ** 2) * np.exp(-0.5 * (turn / st) ** 2)
    board = _Board(quilt, occupied, old)
    used = np.zeros(len(xy), dtype=bool)
    links = 0
    for k in np.argsort(-p, kind="stable").tolist():
        a, b = pairs[k]
        if used[a] or used[b] or turn[k] > opts.seam_turn:
            continue
        if gap[k] > 1e-6:
            path = _connector(xy[a], heading[a], xy[b], heading[b])
            if not board.clear(path):
                continue
            _lay(board, quilt, path, a)
        used[a] = used[b] = True
        links += 1
    _close(quilt, used)
    return links


#: Metres between the points of a curved seam connector.
CONNECTOR_STEP = 10.0


def _connector(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> np.ndarray:
    """A smooth curve from cut end ``a`` (heading ``da`` out of its street) to ``b`` (heading ``db``):
    the cubic Bézier whose inner control points lie a third of the gap ahead of each end."""
    gap = float(np.hypot(*(b - a)))
    n = max(int(np.ceil(gap / CONNECTOR_STEP)), 1)
    if n == 1:
        return np.array([a, b])
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    p1, p2 = a + da * gap / 3, b + db * gap / 3
    pts = (1 - t) ** 3 * a + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t ** 2 * p2 + t ** 3 * b
    pts[0], pts[-1] = a, b
    return pts


def _tees(quilt: _Quilt, old: shapely.Geometry, spacing: float, opts: PatchOptions,
          occupied: shapely.Geometry) -> int:
    """Cut streets left over run on to the first street ahead, of the district or of the town; tees made."""
    board = _Board(quilt, occupied, old)
    reach = opts.tee_reach * spacing
    town = shapely.get_parts(old)
    town_tree = shapely.STRtree(town)
    used = np.zeros(len(quilt.cut_xy), dtype=bool)
    tees = 0
    for k, (p, d, own) in enumerate(zip(quilt.cut_xy, quilt.cut_heading, quilt.cut_piece)):
        ray = shapely.LineString([p + d * 1e-3, p + d * reach])
        hits = [(_meet(ray, quilt.xy[j], p, d, opts.tee_angle), j)
                for j in board.tree.query(ray, predicate="intersects").tolist() if j != own]
        hits += [(_meet(ray, np.asarray(town[i].coords), p, d, opts.tee_angle), -1)
                 for i in town_tree.query(ray, predicate="intersects").tolist()]
        met = [(meet, j) for meet, j in hits if meet is not None]
        if not met:
            continue
        (at, fair), j = min(met, key=lambda h: float(np.hypot(*(h[0][0] - p))))
        if not fair or not board.clear(np.array([p, at])):  # the first street ahead, met too flat, blocks it
            continue
        board.added.append(shapely.LineString([p, at]))
        quilt.add(np.array([p, at]), quilt.highway[own], quilt.level[own])
        if j >= 0:
            quilt.splits.setdefault(j, []).append(at)
            quilt.tees.append((p, at))
        used[k] = True
        tees += 1
    _close(quilt, used)
    return tees
