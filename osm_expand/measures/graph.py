"""The graph of the measures, made from the lines alone: nodes, degrees, open ends and edges (chains of
segments between nodes that are not shape points); see :mod:`osm_expand.measures`."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from osm_expand.measures.kinds import MeasureOptions
from osm_expand.measures.lines import LineSet
from osm_expand.model.network import pair_keys

__all__ = ["junction_points", "two_core"]


@dataclass(frozen=True, eq=False)
class _Graph:
    """Nodes, deduplicated segments and the edges (chains) over them."""

    xy: np.ndarray  # (N, 2) node coordinates
    degree: np.ndarray  # (N,)
    is_open: np.ndarray  # (N,) bool
    tail: np.ndarray  # (S,) node of each segment's start, segments in edge order
    head: np.ndarray  # (S,)
    seg_len: np.ndarray  # (S,)
    edge_of: np.ndarray  # (S,) edge of each segment, non-decreasing
    first: np.ndarray  # (E,) first segment of each edge
    last: np.ndarray  # (E,) last segment of each edge
    length: np.ndarray  # (E,) arc length
    cum_start: np.ndarray  # (S,) arc length along the concatenated edges where each segment starts

    @property
    def start_node(self) -> np.ndarray:
        return self.tail[self.first]

    @property
    def end_node(self) -> np.ndarray:
        return self.head[self.last]

    def point_at(self, edge: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """Points ``dist`` metres along ``edge`` (clipped to the edge), ``(K, 2)``."""
        d = np.clip(dist, 0.0, self.length[edge])
        target = self.cum_start[self.first[edge]] + d
        k = np.searchsorted(self.cum_start, target, side="right") - 1
        k = np.clip(k, self.first[edge], self.last[edge])
        t = np.clip((target - self.cum_start[k]) / np.maximum(self.seg_len[k], 1e-12), 0.0, 1.0)
        a, b = self.xy[self.tail[k]], self.xy[self.head[k]]
        return a + t[:, None] * (b - a)


def _nodes(coords: np.ndarray, precision: float) -> tuple[np.ndarray, np.ndarray]:
    """Node id of every point (equal after rounding to ``precision``) and the nodes' coordinates."""
    if len(coords) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2))
    q = np.rint(coords / precision).astype(np.int64)
    q -= q.min(axis=0)
    key = q[:, 0] * (int(q[:, 1].max()) + 1) + q[:, 1]  # < 2⁶³ for any town: 1000 km is 1e8 cm
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    return inverse.reshape(-1), coords[first]


def _segments(node: np.ndarray, label: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct undirected segments (u, v) between consecutive points of one line, u ≠ v."""
    same = label[1:] == label[:-1]
    u, v = node[:-1][same], node[1:][same]
    real = u != v
    u, v = u[real], v[real]
    _, keep = np.unique(pair_keys(u, v), return_index=True)
    keep.sort()
    return u[keep], v[keep]


def _open_nodes(xy: np.ndarray, degree: np.ndarray, window: shapely.Geometry | None,
                open_points: np.ndarray | None, tol: float) -> np.ndarray:
    is_open = np.zeros(len(xy), dtype=bool)
    if window is not None:
        ends = np.flatnonzero(degree == 1)
        if len(ends):
            dist = shapely.distance(shapely.boundary(window), shapely.points(xy[ends]))
            is_open[ends[dist <= tol]] = True
    if open_points is not None and len(open_points) and len(xy):
        tree = cKDTree(xy)
        hits = tree.query_ball_point(np.asarray(open_points, dtype=np.float64).reshape(-1, 2), tol)
        flat = np.fromiter((i for h in hits for i in h), dtype=np.int64)
        is_open[flat] = True
    return is_open


def _successors(tail: np.ndarray, head: np.ndarray, breaks: np.ndarray) -> np.ndarray:
    """For half-edge h (2s: u→v, 2s+1: v→u) the half-edge that continues it, or -1 at a break node."""
    n_half = len(tail)
    nxt = np.full(n_half, -1, dtype=np.int64)
    order = np.argsort(tail, kind="stable")
    t_sorted = tail[order]
    # at a shape point exactly two half-edges leave: consecutive in ``order``
    pair = np.flatnonzero((t_sorted[1:] == t_sorted[:-1]) & ~breaks[t_sorted[:-1]])
    o1, o2 = order[pair], order[pair + 1]
    nxt[o1 ^ 1] = o2
    nxt[o2 ^ 1] = o1
    return nxt


def _rank(nxt: np.ndarray, rounds: int | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """List ranking by pointer jumping: for each half-edge the end of its chain and the steps to it.

    With ``rounds``, None when the jumping has not settled after that many rounds or a half-edge's
    chain has no end (a ring of shape points): a chain of ``n`` half-edges settles in ``log2 n`` + 1
    rounds, so ``n.bit_length() + 1`` rounds tell a graph without rings (nearly every window) cheaply,
    where finding the rings first (:func:`_break_rings`) was a third of a window's graph.
    """
    n_half = len(nxt)
    ptr = np.where(nxt >= 0, nxt, np.arange(n_half))
    dist = (nxt >= 0).astype(np.int64)
    done = 0
    while True:
        nptr = ptr[ptr]
        dist = dist + dist[ptr]
        if np.array_equal(nptr, ptr):
            break
        ptr = nptr
        done += 1
        if rounds is not None and done >= rounds:
            return None
    if rounds is not None and n_half and bool((nxt[ptr] >= 0).any()):
        return None  # a ring whose length is a power of two settles with its half-edges on themselves
    return ptr, dist


def _break_rings(tail: np.ndarray, head: np.ndarray, breaks: np.ndarray,
                 nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rings of shape points broken, each at its smallest node (both directions agree): the breaks and
    successors after."""
    n_half = len(tail)
    if not n_half:
        return breaks, nxt
    has = nxt >= 0
    link = sparse.csr_matrix((np.ones(int(has.sum())), (np.flatnonzero(has), nxt[has])), shape=(n_half, n_half))
    _, comp = csgraph.connected_components(link, directed=True, connection="weak")
    ends = np.bincount(comp, weights=(~has).astype(np.float64), minlength=comp.max() + 1)
    ring = ends[comp] == 0
    if ring.any():
        anchor = np.full(comp.max() + 1, np.iinfo(np.int64).max)
        np.minimum.at(anchor, comp[ring], tail[ring])
        breaks = breaks.copy()
        breaks[anchor[anchor < np.iinfo(np.int64).max]] = True
        nxt = _successors(tail, head, breaks)
    return breaks, nxt


def _build_graph(coords: np.ndarray, label: np.ndarray, *, window: shapely.Geometry | None,
                 open_points: np.ndarray | None, opts: MeasureOptions) -> _Graph:
    node, xy = _nodes(coords, opts.node_precision)
    u, v = _segments(node, label)
    degree = np.bincount(np.concatenate([u, v]), minlength=len(xy))
    is_open = _open_nodes(xy, degree, window, open_points, opts.open_tolerance)
    tail = np.empty(2 * len(u), dtype=np.int64)
    tail[0::2], tail[1::2] = u, v
    head = np.empty_like(tail)
    head[0::2], head[1::2] = v, u
    breaks = (degree != 2) | is_open
    nxt = _successors(tail, head, breaks)
    n_half = len(tail)
    ranked = _rank(nxt, rounds=n_half.bit_length() + 1)
    if ranked is None:
        breaks, nxt = _break_rings(tail, head, breaks, nxt)
        ranked = _rank(nxt)
        assert ranked is not None  # without a limit on its rounds, the jumping always settles
    ptr, dist = ranked
    # keep one direction of each chain: the one whose first half-edge is below the reverse's first
    start = np.flatnonzero(breaks[tail])
    kept_first = start[start < (ptr[start] ^ 1)]
    edge_at_end = np.full(n_half, -1, dtype=np.int64)
    edge_at_end[ptr[kept_first]] = np.arange(len(kept_first))
    edge = edge_at_end[ptr]
    mine = np.flatnonzero(edge >= 0)
    order = mine[np.lexsort((-dist[mine], edge[mine]))]
    tail_o, head_o, edge_o = tail[order], head[order], edge[order]
    seg_len = np.hypot(*(xy[head_o] - xy[tail_o]).T)
    n_edges = len(kept_first)
    bounds = np.searchsorted(edge_o, np.arange(n_edges + 1))
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    return _Graph(xy=xy, degree=degree, is_open=is_open, tail=tail_o, head=head_o, seg_len=seg_len,
                  edge_of=edge_o, first=bounds[:-1], last=bounds[1:] - 1,
                  length=cum[bounds[1:]] - cum[bounds[:-1]], cum_start=cum[:-1])


def junction_points(lines: Sequence[np.ndarray] | LineSet, options: MeasureOptions | None = None) -> np.ndarray:
    """``(K, 2)`` metres: the junctions (degree ≥ 3) of the lines, nodes made as for the measures."""
    opts = options or MeasureOptions()
    line_set = LineSet.from_lines(lines)
    node, xy = _nodes(line_set.coords, opts.node_precision)
    u, v = _segments(node, line_set.line_of)
    degree = np.bincount(np.concatenate([u, v]), minlength=len(xy))
    return xy[degree >= 3]


def two_core(u: np.ndarray, v: np.ndarray, n: int, anchored: np.ndarray | None = None) -> np.ndarray:
    """Which edges ``(u[i], v[i])`` lie in the 2-core: dead-end trees peeled off, leaf by leaf.

    Parameters
    ----------
    u, v : ``(E,)`` end nodes of each edge (a loop has ``u == v``: it counts 2 at its node).
    n : number of nodes.
    anchored : ``(n,)`` bool, nodes never peeled (open ends: the network runs on beyond them).

    Returns
    -------
    ``(E,)`` bool: kept edges. Each round peels every edge with a free end of degree 1, so the
    rounds are the depth of the deepest tree (a handful on a street graph of junction-to-junction
    edges), each a vectorised pass.
    """
    u, v = np.asarray(u, dtype=np.int64), np.asarray(v, dtype=np.int64)
    keep = np.ones(len(u), dtype=bool)
    fixed = np.zeros(n, dtype=bool) if anchored is None else np.asarray(anchored, dtype=bool)
    while True:
        degree = np.bincount(u[keep], minlength=n) + np.bincount(v[keep], minlength=n)
        leaf = (degree == 1) & ~fixed
        peel = keep & (leaf[u] | leaf[v])
        if not peel.any():
            return keep
        keep &= ~peel
