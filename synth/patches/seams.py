"""Seams: cut streets continued into the neighbouring cell's (004 §3.1's transition probability) or run on
to a tee."""
from __future__ import annotations

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model import chord_bends
from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _close, _lay, _meet, _Quilt


def _walk_seams(quilt: _Quilt, spacing: float, opts: PatchOptions, occupied: shapely.Geometry,
                old: shapely.Geometry, bend: float = float("inf")) -> int:
    """Continue cut streets across the seams, most probable transition first; returns the links made.

    A transition is judged by how the street bends on its way through the link (:func:`_link_bend`,
    read chord by chord as the town's streets are), not by the angle between the two cut streets
    alone: two parallel streets cut side by side have no angle between them, but the link that joins
    them turns across the seam and back, a zig-zag. Links bending more than ``bend`` degrees are not
    made; those cut ends run on to a tee, along the edge, or are trimmed. With ``opts.seam_joint`` set, a
    link is judged instead by its sharpest vertex turn, where it meets its two streets included
    (:func:`_joint_turn`): the turn :func:`~synth.patches.topology.corner_turns` counts.
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
    if opts.seam_joint is not None:
        bend = opts.seam_joint
        bends = np.array([_joint_turn(xy[a], heading[a], xy[b], heading[b]) for a, b in pairs.tolist()])
    elif np.isfinite(bend):
        bends = np.array([_link_bend(xy[a], heading[a], xy[b], heading[b]) for a, b in pairs.tolist()])
    else:  # no limit: 004's transition on the angle between the two cut streets
        bends = turn
    sg, st = opts.seam_sigma
    p = np.exp(-0.5 * (gap / (sg * spacing)) ** 2) * np.exp(-0.5 * (bends / st) ** 2)
    board = _Board(quilt, occupied, old)
    used = np.zeros(len(xy), dtype=bool)
    links = 0
    for k in np.argsort(-p, kind="stable").tolist():
        a, b = pairs[k]
        if used[a] or used[b] or turn[k] > opts.seam_turn or bends[k] > bend:
            continue
        if gap[k] > 1e-6:
            path = _connector(xy[a], heading[a], xy[b], heading[b])
            if not board.clear(path):
                continue
            if not (opts.seam_meet and len(path) == 2 and _meet_midway(quilt, a, b)):
                _lay(board, quilt, path, a)
        used[a] = used[b] = True
        links += 1
    _close(quilt, used)
    return links


def _meet_midway(quilt: _Quilt, a: int, b: int) -> bool:
    """Cut ends ``a`` and ``b``, closer than a connector step, meet halfway: each street's end moves to
    their midpoint, where a straight link between them would turn twice across the seam (a jog), so
    that the offset is spread over the two streets' last pieces. Only where each last piece is at least
    as long as the gap (else the street's end would turn more than the link); True when done."""
    ends = []
    mid = (quilt.cut_xy[a] + quilt.cut_xy[b]) / 2.0
    gap = float(np.hypot(*(quilt.cut_xy[b] - quilt.cut_xy[a])))
    for k in (a, b):
        xy = quilt.xy[quilt.cut_piece[k]]
        at = 0 if np.array_equal(xy[0], quilt.cut_xy[k]) else len(xy) - 1
        if not np.array_equal(xy[at], quilt.cut_xy[k]) or len(xy) < 2:
            return False
        if float(np.hypot(*(xy[at] - xy[1 if at == 0 else at - 1]))) < gap:
            return False
        ends.append((quilt.cut_piece[k], at))
    for piece, at in ends:
        moved = quilt.xy[piece].copy()
        moved[at] = mid
        quilt.xy[piece] = moved
    return True


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


#: Metres of chord over which a street's bends are read (the fidelity yardstick's curvature step,
#: ``osm_expand.measures.MeasureOptions.curvature_step``).
BEND_STEP = 20.0


def _link_bend(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> float:
    """The sharpest bend (degrees per :data:`BEND_STEP` chord) of the street that runs into cut end
    ``a`` (heading ``da`` out of it), through the seam link to ``b`` and on into ``b``'s street: read
    at the two cut ends and at every point of the link, the streets behind taken straight."""
    link = _connector(a, da, b, db)
    path = np.vstack([a - da * BEND_STEP, link, b - db * BEND_STEP])
    at = BEND_STEP + np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(link, axis=0).T))])
    return float(chord_bends(path, at, BEND_STEP).max())


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


def _joint_turn(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> float:
    """The sharpest turn (degrees) at a vertex of the street through the seam link from cut end ``a``
    to ``b``, the cut streets' last metre included: where the link meets its streets and inside it."""
    path = np.vstack([a - da, _connector(a, da, b, db), b - db])
    d = np.diff(path, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    turn = np.degrees(np.abs((np.diff(h) + np.pi) % (2 * np.pi) - np.pi))
    return float(turn.max()) if len(turn) else 0.0
