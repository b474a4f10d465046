"""The measures themselves, each computed on the lines or on their graph (definitions in
:mod:`osm_expand.measures`)."""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from osm_expand.measures.graph import _Graph
from osm_expand.measures.lines import LineSet

__all__ = ["count_pieces", "orientation_entropy", "piece_labels"]


def piece_labels(geoms: np.ndarray, buffer: float) -> np.ndarray:
    """The piece of each line: lines buffered ``buffer`` m each side and merged (:mod:`osm_expand.measures`).

    Two buffers overlap when their lines are within ``2 * buffer``; the pieces are the connected
    components of those pairs (an STRtree query, no union of polygons).

    Returns
    -------
    ``(len(geoms),)`` int labels 0..pieces-1.
    """
    geoms = np.asarray(geoms, dtype=object)
    if len(geoms) == 0:
        return np.zeros(0, dtype=np.int64)
    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="dwithin", distance=2.0 * buffer)
    link = sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(len(geoms), len(geoms)))
    return csgraph.connected_components(link, directed=False)[1]


def count_pieces(lines: Sequence[np.ndarray] | LineSet, buffer: float = 30.0) -> int:
    """How many pieces ``lines`` make on the map, buffered ``buffer`` m each side (:mod:`osm_expand.measures`)."""
    labels = piece_labels(LineSet.from_lines(lines).geoms, buffer)
    return int(labels.max() + 1) if len(labels) else 0


def orientation_entropy(vectors: np.ndarray, weights: np.ndarray | None = None, *, bins: int = 36) -> float:
    """Boeing's (2019) orientation entropy of segment directions, in nats.

    Parameters
    ----------
    vectors : ``(K, 2)`` segment vectors (dx east, dy north), metres.
    weights : ``(K,)`` weights; default the segments' lengths.
    bins : bins over 360°; bin ``i`` is centred on ``i * 360 / bins`` degrees.

    Returns
    -------
    The Shannon entropy ``-Σ p_i ln p_i`` of the compass bearings, each
    segment counted in both directions; NaN when there is nothing to weigh.
    """
    vectors = np.asarray(vectors, dtype=np.float64).reshape(-1, 2)
    w = np.hypot(*vectors.T) if weights is None else np.asarray(weights, dtype=np.float64)
    if len(vectors) == 0 or not w.sum() > 0:
        return float("nan")
    bearing = np.degrees(np.arctan2(vectors[:, 0], vectors[:, 1])) % 360.0
    both = np.concatenate([bearing, (bearing + 180.0) % 360.0])
    width = 360.0 / bins
    idx = np.floor((both + width / 2) / width).astype(np.int64) % bins
    counts = np.bincount(idx, weights=np.concatenate([w, w]), minlength=bins)
    p = counts[counts > 0] / counts.sum()
    return float(-(p * np.log(p)).sum())


def _edge_ends(g: _Graph, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per edge end (2E: start ends then end ends): node, edge and direction angle (radians)."""
    n = len(g.length)
    edges = np.arange(n)
    r = np.minimum(reach, g.length)
    out_start = g.point_at(edges, r) - g.xy[g.start_node]
    out_end = g.point_at(edges, g.length - r) - g.xy[g.end_node]
    vec = np.concatenate([out_start, out_end])
    return (np.concatenate([g.start_node, g.end_node]), np.concatenate([edges, edges]),
            np.arctan2(vec[:, 1], vec[:, 0]))


def _junction_angles(node: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Angles (degrees) between angularly consecutive ends around each node; input: ends at junctions."""
    if len(node) == 0:
        return np.zeros(0)
    order = np.lexsort((angle, node))
    nd, an = node[order], angle[order]
    group_start = np.flatnonzero(np.r_[True, nd[1:] != nd[:-1]])
    size = np.diff(np.r_[group_start, len(nd)])
    nxt = np.arange(len(nd)) + 1
    last = group_start + size - 1
    nxt[last] = group_start
    gap = an[nxt] - an
    gap[last] += 2 * np.pi  # the last end wraps round to the first: the gaps sum to 360° even when ends coincide
    return np.degrees(gap[np.repeat(size, size) > 1])


def _pairs_within_groups(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All index pairs i < j with ``group[i] == group[j]``; ``group`` sorted."""
    n = len(group)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    size = np.diff(np.r_[starts, n])
    pos = np.arange(n) - np.repeat(starts, size)
    later = np.repeat(size, size) - pos - 1
    i = np.repeat(np.arange(n), later)
    j = i + (np.arange(len(i)) - np.repeat(np.cumsum(later) - later, later)) + 1
    return i, j


def _greedy_matching(i: np.ndarray, j: np.ndarray, cost: np.ndarray, n: int) -> np.ndarray:
    """Pairs taken cheapest first, each item at most once (mask over the pairs).

    Rounds of mutually best pairs give the same matching as the sequential
    greedy, since each round takes the cheapest remaining pair and no pair it
    takes is beaten by a cheaper one still open.
    """
    rank = np.empty(len(cost), dtype=np.int64)
    rank[np.lexsort((j, i, cost))] = np.arange(len(cost))
    taken = np.zeros(len(cost), dtype=bool)
    used = np.zeros(n, dtype=bool)
    alive = np.ones(len(cost), dtype=bool)
    big = np.iinfo(np.int64).max
    while alive.any():
        best = np.full(n, big)
        np.minimum.at(best, i[alive], rank[alive])
        np.minimum.at(best, j[alive], rank[alive])
        win = alive & (best[i] == rank) & (best[j] == rank)
        taken |= win
        used[i[win]] = True
        used[j[win]] = True
        alive &= ~used[i] & ~used[j]
    return taken


def _strokes(g: _Graph, node: np.ndarray, edge: np.ndarray, angle: np.ndarray, max_deflection: float) -> np.ndarray:
    """Stroke lengths (m): edges joined through junctions where they deflect least."""
    n_edges = len(g.length)
    if n_edges == 0:
        return np.zeros(0)
    order = np.argsort(node, kind="stable")
    i, j = _pairs_within_groups(node[order])
    i, j = order[i], order[j]
    between = np.abs((angle[i] - angle[j] + np.pi) % (2 * np.pi) - np.pi)  # [0, π]
    deflection = 180.0 - np.degrees(between)
    ok = deflection < max_deflection
    i, j, deflection = i[ok], j[ok], deflection[ok]
    taken = _greedy_matching(i, j, deflection, len(node))
    a, b = edge[i[taken]], edge[j[taken]]
    link = sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(n_edges, n_edges))
    _, label = csgraph.connected_components(link, directed=False)
    return np.bincount(label, weights=g.length)


def _blocks(g: _Graph, min_area: float) -> tuple[np.ndarray, np.ndarray]:
    """Areas (m²) and compactness 4πA/P² of the bounded faces of the edges."""
    n_edges = len(g.length)
    if n_edges == 0:
        return np.zeros(0), np.zeros(0)
    # each edge's points: the tails of its segments, then the head of its last one
    slot = np.arange(len(g.tail)) + g.edge_of
    pts = np.empty((len(g.tail) + n_edges, 2))
    owner = np.empty(len(g.tail) + n_edges, dtype=np.int64)
    pts[slot], owner[slot] = g.xy[g.tail], g.edge_of
    end_slot = g.last + np.arange(n_edges) + 1
    pts[end_slot], owner[end_slot] = g.xy[g.end_node], np.arange(n_edges)
    lines = shapely.linestrings(pts, indices=owner)
    faces = shapely.get_parts(shapely.polygonize(lines))
    area = shapely.area(faces)
    perimeter = shapely.length(faces)
    big = area >= min_area
    return area[big], 4 * math.pi * area[big] / perimeter[big] ** 2


def _alignment(g: _Graph, usable: np.ndarray, k: int, radius: float) -> np.ndarray:
    """|Δ chord direction| mod 90°, folded to [0°, 45°], for each edge against its k nearest."""
    edges = np.flatnonzero(usable)
    if len(edges) < 2:
        return np.zeros(0)
    chord = g.xy[g.end_node[edges]] - g.xy[g.start_node[edges]]
    theta = np.degrees(np.arctan2(chord[:, 1], chord[:, 0]))
    mid = g.point_at(edges, g.length[edges] / 2)
    near = min(k + 1, len(edges))
    _, idx = cKDTree(mid).query(mid, k=near, distance_upper_bound=radius)
    idx = idx.reshape(len(edges), near)
    me = np.arange(len(edges))[:, None]
    valid = (idx < len(edges)) & (idx != me)
    valid &= np.cumsum(valid, axis=1) <= k
    a = np.broadcast_to(me, idx.shape)[valid]
    diff = np.abs(theta[a] - theta[idx[valid]]) % 90.0
    return np.minimum(diff, 90.0 - diff)


def _curvature(g: _Graph, step: float) -> np.ndarray:
    """Absolute heading change (degrees) between consecutive ``step``-metre chords along each edge."""
    return _chords(g, step)[0]


def _chords(g: _Graph, step: float) -> tuple[np.ndarray, np.ndarray]:
    """The bends of :func:`_curvature` (degrees, (K,)) and the three points of each, ``(K, 3, 2)``: the
    chords p_k → p_k+1 → p_k+2, ``step`` metres apart along one edge (a benchmark places the bends)."""
    steps = np.floor(g.length / step + 1e-9).astype(np.int64)
    edges = np.flatnonzero(steps >= 2)
    if len(edges) == 0:
        return np.zeros(0), np.zeros((0, 3, 2))
    n_pts = steps[edges] + 1
    edge = np.repeat(edges, n_pts)
    k = np.arange(len(edge)) - np.repeat(np.cumsum(n_pts) - n_pts, n_pts)
    pts = g.point_at(edge, k * step)
    d = np.diff(pts, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    within = edge[1:] == edge[:-1]  # chord p_k → p_k+1 lies on one edge
    turn = (heading[1:] - heading[:-1] + np.pi) % (2 * np.pi) - np.pi
    ok = np.flatnonzero(within[1:] & within[:-1])
    return np.degrees(np.abs(turn[ok])), np.stack([pts[ok], pts[ok + 1], pts[ok + 2]], axis=1)


def _rounded(angles: np.ndarray, resolution: float) -> np.ndarray:
    """Angles rounded to ``resolution`` degrees (see :class:`MeasureOptions`)."""
    return np.round(angles / resolution) * resolution
