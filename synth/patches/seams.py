"""Seams: cut streets continued into the neighbouring cell's (004 §3.1's transition probability) or run on
to a tee."""
from __future__ import annotations

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model import turn_angles
from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _close, _lay, _meet, _Quilt


def _walk_seams(quilt: _Quilt, spacing: float, opts: PatchOptions, occupied: shapely.Geometry,
                old: shapely.Geometry) -> int:
    """Continue cut streets across the seams, most probable transition first; returns the links made.

    A transition's probability is 004's (§3.1) on the gap between the two cut ends and the angle
    between the two cut streets; links that turn more than ``seam_turn``, or that would cross
    anything, are not made, and those cut ends run on to a tee, along the edge, or are trimmed.
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
    if opts.seam_link_turn:
        turn = _link_turn(xy[pairs[:, 0]], heading[pairs[:, 0]], xy[pairs[:, 1]], heading[pairs[:, 1]])
    if opts.seam_jog is not None:  # a link turning further off either street is a hook or a sideways jog
        at_a, at_b = _link_turns(xy[pairs[:, 0]], heading[pairs[:, 0]], xy[pairs[:, 1]], heading[pairs[:, 1]])
        jog = np.maximum(at_a, at_b) > opts.seam_jog
    else:
        jog = np.zeros(len(pairs), dtype=bool)
    if opts.seam_passing:  # each end behind the other: the two streets pass side by side, a link would double back
        jog |= _passing(xy[pairs[:, 0]], heading[pairs[:, 0]], xy[pairs[:, 1]], heading[pairs[:, 1]])
    sg, st = opts.seam_sigma
    p = np.exp(-0.5 * (gap / (sg * spacing)) ** 2) * np.exp(-0.5 * (turn / st) ** 2)
    board = _Board(quilt, occupied, old)
    used = np.zeros(len(xy), dtype=bool)
    links = 0
    for k in np.argsort(-p, kind="stable").tolist():
        a, b = pairs[k]
        if used[a] or used[b] or turn[k] > opts.seam_turn or jog[k]:
            continue
        if gap[k] > 1e-6:
            path = np.array([xy[a], xy[b]]) if opts.straight_seams else _connector(xy[a], heading[a], xy[b], heading[b])
            if not board.clear(path):
                continue
            _lay(board, quilt, path, a)
        used[a] = used[b] = True
        links += 1
    _close(quilt, used)
    return links


def _link_turn(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> np.ndarray:
    """How much a street turns (degrees) going from cut end ``a`` (heading ``da`` out of its street) across
    the seam to cut end ``b`` (heading ``db``) and on into ``b``'s street: the turn from ``da`` onto the
    straight line ``a``-``b`` plus the turn from that line onto ``-db``; 0 where the ends coincide.

    The turn between the two streets alone (``-da . db``) reads two parallel streets a few metres apart
    sideways as a straight continuation; the link between them is a jog (an S of the smooth connector, two
    corners of a straight one) that the yardstick reads as bends at both joints."""
    at_a, at_b = _link_turns(a, da, b, db)
    return at_a + at_b


def _passing(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> np.ndarray:
    """Whether cut end ``b`` lies behind cut end ``a`` (heading ``da`` out of its street) and ``a`` behind ``b``
    (heading ``db``): the two streets run past each other side by side, and no street of the town continues
    one into the other. A link laid between them turns back more than 90° onto both (a hairpin, or a sliver
    beside one of them: Krems' district, seed 0, its two longest links 52-53 m, turning 131-157° off their
    streets); the transition's turn (``-da . db``, 2° and 7° there) reads them as a straight continuation."""
    chord = b - a
    return ((chord * da).sum(axis=1) < 0.0) & ((chord * db).sum(axis=1) > 0.0)


def _link_turns(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two terms of :func:`_link_turn`: degrees from ``da`` onto the straight line ``a``-``b``, and from
    it onto ``-db``; 0 where the ends coincide."""
    chord = b - a
    gap = np.hypot(*chord.T)
    u = chord / np.maximum(gap, 1e-12)[:, None]
    joined = gap > 1e-6
    return np.where(joined, turn_angles(da, u), 0.0), np.where(joined, turn_angles(u, -db), 0.0)


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
