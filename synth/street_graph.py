"""A small mutable planar street graph for the growth kernels (seed 000 §4.2.5, §4.2.6).

Seed 000 §4.2.5 keeps the road network "in a GIS": a planar graph whose
straight edges are *streets* (here: segments) and whose vertices are
*crossings* (here: nodes). The street-pattern kernel (:mod:`synth.patterns`)
asks it, for every proposal, which segments and nodes lie near a line or a
point, adds nodes and segments, and splits a segment where a new street ends
on it. Everything is in metres, x east, y north.

Storage is a set of growable NumPy arrays (node positions, segment ends and
per-segment attributes: creation time, bridge flag, major flag), Python lists
for adjacency (cheap appends) and two uniform grids: the project's
:class:`synth.segment_index.SegmentIndex` for segments (by composition; its
ids are mapped to this graph's segment ids because a split re-indexes the
shortened half) and a plain dict grid for nodes. :meth:`StreetGraph.from_segments`
builds both grids vectorised, so a 5,000-segment town takes a few
milliseconds and the engine may rebuild the graph every year or keep it and
let the kernel update it.

Segment ids are never reused and never deleted: a split keeps the old id for
the half at the segment's first end and appends the other half.
"""
from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from osm_expand.errors import InputError
from osm_expand.model.geometry import closest_on_segments
from synth.segment_index import SegmentIndex

__all__ = ["StreetGraph"]

#: Cell size bounds (m) when ``from_segments`` chooses the grid cell itself
#: (twice the median segment length, clipped): small enough that a query
#: looks at a handful of segments, large enough that long roads span few cells.
MIN_AUTO_CELL = 20.0
MAX_AUTO_CELL = 200.0


class StreetGraph:
    """A planar street graph that grows: nodes, straight segments, grids over both.

    Parameters
    ----------
    cell : float
        Side (m) of the uniform grid cells of both spatial indexes.
    capacity : int
        Initial room for nodes and segments (arrays double when full).

    Attributes
    ----------
    n_nodes, n_segments : int
        Counts; ids run ``0 .. n - 1``.
    """

    def __init__(self, *, cell: float = 50.0, capacity: int = 1024):
        if not cell > 0:
            raise InputError(f"street graph: cell must be > 0 m, got {cell}")
        capacity = max(int(capacity), 16)
        self.cell = float(cell)
        self.n_nodes = 0
        self.n_segments = 0
        self._xy = np.zeros((capacity, 2))
        self._spawned = np.zeros(capacity, dtype=bool)
        self._bridge_tried = np.zeros(capacity, dtype=bool)
        self._seg = np.zeros((capacity, 2), dtype=np.int64)
        self._created = np.zeros(capacity)
        self._bridge = np.zeros(capacity, dtype=bool)
        self._major = np.zeros(capacity, dtype=bool)
        self._index_id = np.zeros(capacity, dtype=np.int64)  # graph segment -> SegmentIndex id
        self._graph_id = np.zeros(capacity, dtype=np.int64)  # SegmentIndex id -> graph segment
        self._incident: list[list[int]] = []
        self.index = SegmentIndex(self.cell, capacity)
        self._node_grid: defaultdict[tuple[int, int], list[int]] = defaultdict(list)

    # ------------------------------------------------------------------ building

    @classmethod
    def from_segments(cls, xy: ArrayLike, edges: ArrayLike, *, created: ArrayLike | None = None,
                      bridge: ArrayLike | None = None, major: ArrayLike | None = None,
                      cell: float | None = None) -> StreetGraph:
        """Build a graph from node positions and segment end pairs, vectorised.

        Parameters
        ----------
        xy : array_like, shape (N, 2)
            Node positions (m). Every row becomes a node, used or not.
        edges : array_like of int, shape (E, 2)
            Segment ends as node ids. The segments should form a planar
            drawing (no crossings away from shared nodes); this is not checked.
        created : array_like, shape (E,), optional
            Creation time of each segment (a year, or any increasing order);
            the crossing-space angle of seed 000 §4.2.6 is measured from the
            time-wise first incident street. Default 0 for all.
        bridge, major : array_like of bool, shape (E,), optional
            Bridge and major-road flags. Default False.
        cell : float, optional
            Grid cell (m). Default: twice the median segment length, clipped
            to [20, 200] m.

        Returns
        -------
        StreetGraph
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
        n, e = len(xy), len(edges)
        if e and (edges.min() < 0 or edges.max() >= n):
            raise InputError(f"street graph: edges refer to nodes outside 0..{n - 1}")
        if e and (edges[:, 0] == edges[:, 1]).any():
            raise InputError("street graph: an edge joins a node to itself")
        seglen = np.hypot(*(xy[edges[:, 1]] - xy[edges[:, 0]]).T) if e else np.zeros(0)
        if cell is None:
            cell = float(np.clip(2.0 * np.median(seglen), MIN_AUTO_CELL, MAX_AUTO_CELL)) if e else 50.0
        g = cls(cell=cell, capacity=max(2 * n, 2 * e, 1024))
        g.n_nodes, g.n_segments = n, e
        g._xy[:n] = xy
        g._seg[:e] = edges
        g._created[:e] = _attr(created, e, 0.0, "created")
        g._bridge[:e] = _attr(bridge, e, False, "bridge")
        g._major[:e] = _attr(major, e, False, "major")
        g._index_id[:e] = np.arange(e)
        g._graph_id[:e] = np.arange(e)
        g._incident = _adjacency(edges, n)
        g._bulk_index(xy[edges[:, 0]], xy[edges[:, 1]], edges)
        for key, ids in _group_by_cell(np.floor(xy / g.cell).astype(np.int64), np.arange(n)):
            g._node_grid[key] = ids
        return g

    def _bulk_index(self, a: NDArray[np.float64], b: NDArray[np.float64], ends: NDArray[np.int64]) -> None:
        """Fill the SegmentIndex with segments 0..E-1 at once (each in every cell its box covers)."""
        idx, e = self.index, len(a)
        while len(idx.a) < e:
            idx._grow()
        idx.a[:e], idx.b[:e], idx.ends[:e], idx.active[:e] = a, b, ends, True
        idx.n = e
        if e == 0:
            return
        lo = np.floor(np.minimum(a, b) / idx.cell).astype(np.int64)
        hi = np.floor(np.maximum(a, b) / idx.cell).astype(np.int64)
        ny = hi[:, 1] - lo[:, 1] + 1
        count = (hi[:, 0] - lo[:, 0] + 1) * ny
        seg = np.repeat(np.arange(e), count)
        k = np.arange(len(seg)) - np.repeat(np.cumsum(count) - count, count)
        cells = np.stack([lo[seg, 0] + k // ny[seg], lo[seg, 1] + k % ny[seg]], axis=1)
        for key, ids in _group_by_cell(cells, seg):
            idx.grid[key] = ids

    def copy(self) -> StreetGraph:
        """An independent copy (arrays, adjacency and both grids)."""
        g = StreetGraph(cell=self.cell, capacity=len(self._xy))
        for name in ("n_nodes", "n_segments"):
            setattr(g, name, getattr(self, name))
        for name in ("_xy", "_spawned", "_bridge_tried", "_seg", "_created", "_bridge", "_major",
                     "_index_id", "_graph_id"):
            setattr(g, name, getattr(self, name).copy())
        g._incident = [list(x) for x in self._incident]
        g.index = SegmentIndex(self.cell, len(self.index.a))
        for name in ("a", "b", "ends", "active"):
            setattr(g.index, name, getattr(self.index, name).copy())
        g.index.n = self.index.n
        g.index.grid = defaultdict(list, {k: list(v) for k, v in self.index.grid.items()})
        g._node_grid = defaultdict(list, {k: list(v) for k, v in self._node_grid.items()})
        return g

    # ------------------------------------------------------------------ views

    @property
    def xy(self) -> NDArray[np.float64]:
        """Node positions (m), shape (n_nodes, 2); a view, do not write."""
        return self._xy[: self.n_nodes]

    @property
    def edges(self) -> NDArray[np.int64]:
        """Segment ends as node ids, shape (n_segments, 2); a view."""
        return self._seg[: self.n_segments]

    @property
    def created(self) -> NDArray[np.float64]:
        """Creation time of each segment, shape (n_segments,)."""
        return self._created[: self.n_segments]

    @property
    def bridge(self) -> NDArray[np.bool_]:
        """Bridge flag of each segment, shape (n_segments,)."""
        return self._bridge[: self.n_segments]

    @property
    def major(self) -> NDArray[np.bool_]:
        """Major-road flag of each segment, shape (n_segments,)."""
        return self._major[: self.n_segments]

    @property
    def spawned(self) -> NDArray[np.bool_]:
        """Per node: has it been a growth start already (seed 003 §3.3.2's "spawned")? Writable."""
        return self._spawned[: self.n_nodes]

    @property
    def bridge_tried(self) -> NDArray[np.bool_]:
        """Per node: has its one bridge attempt (seed 000 §4.2.6) been made? Writable."""
        return self._bridge_tried[: self.n_nodes]

    @property
    def degree(self) -> NDArray[np.int64]:
        """Number of segments at each node, shape (n_nodes,)."""
        return np.fromiter((len(s) for s in self._incident), dtype=np.int64, count=self.n_nodes)

    def incident(self, node: int) -> list[int]:
        """Ids of the segments at ``node`` (a copy)."""
        return list(self._incident[node])

    def node_degree(self, node: int) -> int:
        """Number of segments at ``node``."""
        return len(self._incident[node])

    def neighbours(self, node: int) -> list[int]:
        """Node ids joined to ``node`` by a segment, in incident-segment order."""
        seg = self._seg
        return [int(seg[s, 1] if seg[s, 0] == node else seg[s, 0]) for s in self._incident[node]]

    def segment_length(self, segments: ArrayLike | None = None) -> NDArray[np.float64]:
        """Length (m) of the given segments (default all), shape (k,)."""
        s = np.arange(self.n_segments) if segments is None else np.asarray(segments, dtype=np.int64)
        uv = self._seg[s]
        return np.hypot(*(self._xy[uv[..., 1]] - self._xy[uv[..., 0]]).T)

    # ------------------------------------------------------------------ editing

    def _room(self, arrays: tuple[str, ...], n: int) -> None:
        for name in arrays:
            old = getattr(self, name)
            if n > len(old):
                new = np.zeros((2 * len(old),) + old.shape[1:], dtype=old.dtype)
                new[: len(old)] = old
                setattr(self, name, new)

    def add_node(self, point: ArrayLike) -> int:
        """Add a node at ``point`` (m, shape (2,)); returns its id."""
        self._room(("_xy", "_spawned", "_bridge_tried"), self.n_nodes + 1)
        k = self.n_nodes
        p = np.asarray(point, dtype=np.float64)
        self._xy[k] = p
        self._spawned[k] = self._bridge_tried[k] = False
        self._incident.append([])
        self._node_grid[_cell_of(p, self.cell)].append(k)
        self.n_nodes += 1
        return k

    def add_segment(self, u: int, v: int, *, created: float = 0.0, bridge: bool = False,
                    major: bool = False) -> int:
        """Add the straight segment u–v; returns its id.

        Planarity is the caller's business (the pattern kernel checks it
        before adding).
        """
        if u == v:
            raise InputError(f"street graph: segment from node {u} to itself")
        self._room(("_seg", "_created", "_bridge", "_major", "_index_id"), self.n_segments + 1)
        k = self.n_segments
        self._seg[k] = (u, v)
        self._created[k], self._bridge[k], self._major[k] = created, bridge, major
        self._index_id[k] = self._index_add(k)
        self._incident[u].append(k)
        self._incident[v].append(k)
        self.n_segments += 1
        return k

    def _index_add(self, segment: int) -> int:
        u, v = self._seg[segment]
        i = self.index.add(self._xy[u], self._xy[v], int(u), int(v))
        self._room(("_graph_id",), i + 1)
        self._graph_id[i] = segment
        return i

    def split(self, segment: int, point: ArrayLike) -> int:
        """Split ``segment`` at ``point`` (projected onto it); returns the new node.

        The segment keeps its id and becomes the half from its first end to
        the new node; the other half is appended as segment
        ``n_segments - 1`` with the same creation time and flags.
        """
        u, v = (int(x) for x in self._seg[segment])
        a, b = self._xy[u], self._xy[v]
        d = b - a
        t = float(np.clip(np.dot(np.asarray(point, dtype=np.float64) - a, d) / max(float(d @ d), 1e-24), 0.0, 1.0))
        w = self.add_node(a + t * d)
        self.index.remove(int(self._index_id[segment]))
        self._seg[segment] = (u, w)
        self._index_id[segment] = self._index_add(segment)
        self._incident[v].remove(segment)
        self._incident[w].append(segment)
        self.add_segment(w, v, created=float(self._created[segment]), bridge=bool(self._bridge[segment]),
                         major=bool(self._major[segment]))
        return w

    # ------------------------------------------------------------------ queries

    def segments_in_box(self, lo: ArrayLike, hi: ArrayLike) -> NDArray[np.int64]:
        """Ids of the segments whose grid cells meet the box lo–hi (m), sorted.

        A superset of the segments that really meet the box: callers test
        the geometry.
        """
        idx = self.index
        found = _grid_lookup(idx.grid, lo, hi, idx.cell)
        if not found:
            return np.zeros(0, dtype=np.int64)
        ids = np.unique(np.concatenate(found))
        ids = ids[idx.active[ids]]
        return np.sort(self._graph_id[ids])

    def nodes_in_box(self, lo: ArrayLike, hi: ArrayLike) -> NDArray[np.int64]:
        """Ids of the nodes in the grid cells meeting the box lo–hi (m), sorted (a superset)."""
        found = _grid_lookup(self._node_grid, lo, hi, self.cell)
        return np.sort(np.concatenate(found)) if found else np.zeros(0, dtype=np.int64)

    def nodes_within(self, point: ArrayLike, radius: float) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Nodes within ``radius`` (m) of ``point``, nearest first (ties by id).

        Returns
        -------
        ids : ndarray of int, shape (k,)
        dist : ndarray of float, shape (k,)
            Distances (m).
        """
        p = np.asarray(point, dtype=np.float64)
        ids = self.nodes_in_box(p - radius, p + radius)
        d = np.hypot(*(self._xy[ids] - p).T)
        keep = d <= radius
        ids, d = ids[keep], d[keep]
        order = np.lexsort((ids, d))
        return ids[order], d[order]

    def nearest_node(self, point: ArrayLike, radius: float | None = None) -> int:
        """The node nearest to ``point`` (within ``radius`` m if given), or -1 if none."""
        if radius is not None:
            ids, _ = self.nodes_within(point, radius)
            return int(ids[0]) if len(ids) else -1
        if self.n_nodes == 0:
            return -1
        return int(np.argmin(np.hypot(*(self.xy - np.asarray(point, dtype=np.float64)).T)))

    def segment_at(self, point: ArrayLike, tolerance: float = 1e-6) -> int:
        """The segment passing within ``tolerance`` (m) of ``point`` (nearest; lowest id on ties), or -1."""
        p = np.asarray(point, dtype=np.float64)
        ids = self.segments_in_box(p - tolerance, p + tolerance)
        if len(ids) == 0:
            return -1
        a, b = self.segment_ends(ids)
        d = closest_on_segments(p, a, b)[2]
        k = int(np.argmin(d))
        return int(ids[k]) if d[k] <= tolerance else -1

    def segment_ends(self, segments: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """End positions (m) of the given segments: two arrays of shape (k, 2)."""
        uv = self._seg[np.asarray(segments, dtype=np.int64)]
        return self._xy[uv[..., 0]], self._xy[uv[..., 1]]

    def crosses(self, a: ArrayLike, b: ArrayLike, u: int = -1, v: int = -1) -> bool:
        """Would segment a–b (ends at nodes u, v, or -1) touch a segment not sharing one of those nodes?"""
        return self.index.crosses(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64), u, v)


def _attr(values: ArrayLike | None, n: int, default: float | bool, name: str) -> np.ndarray:
    if values is None:
        return np.full(n, default)
    arr = np.asarray(values).reshape(-1)
    if len(arr) != n:
        raise InputError(f"street graph: {name} has {len(arr)} values for {n} segments")
    return arr


def _adjacency(edges: NDArray[np.int64], n: int) -> list[list[int]]:
    """Per node, its segment ids in increasing order."""
    ends = edges.reshape(-1)
    seg = np.repeat(np.arange(len(edges)), 2)
    order = np.lexsort((seg, ends))
    split = np.searchsorted(ends[order], np.arange(n + 1))
    segs = seg[order].tolist()
    return [segs[split[i]:split[i + 1]] for i in range(n)]


def _group_by_cell(cells: NDArray[np.int64], ids: NDArray[np.int64]):
    """Yield ((i, j), [ids…]) for each distinct cell, ids in increasing order."""
    if len(ids) == 0:
        return
    order = np.lexsort((ids, cells[:, 1], cells[:, 0]))
    c = cells[order]
    new = np.ones(len(c), dtype=bool)
    new[1:] = (c[1:] != c[:-1]).any(axis=1)
    starts = np.flatnonzero(new)
    bounds = np.append(starts, len(c)).tolist()
    keys = c[starts].tolist()
    sorted_ids = ids[order].tolist()
    for k, (i, j) in enumerate(keys):
        yield (i, j), sorted_ids[bounds[k]:bounds[k + 1]]


def _grid_lookup(grid: dict, lo: ArrayLike, hi: ArrayLike, cell: float) -> list[list[int]]:
    lo_xy, hi_xy = np.asarray(lo), np.asarray(hi)
    ilo, jlo = math.floor(lo_xy[0] / cell), math.floor(lo_xy[1] / cell)
    ihi, jhi = math.floor(hi_xy[0] / cell), math.floor(hi_xy[1] / cell)
    out = []
    for i in range(ilo, ihi + 1):
        for j in range(jlo, jhi + 1):
            ids = grid.get((i, j))
            if ids:
                out.append(ids)
    return out


def _cell_of(p: NDArray[np.float64], cell: float) -> tuple[int, int]:
    return int(np.floor(p[0] / cell)), int(np.floor(p[1] / cell))
