"""The trips' searches, compiled: Dijkstra from each source up to a cost, touching only what it reaches.

Trips (:mod:`osm_expand.engine.traffic.trips`) search from a batch of
segment midpoints up to ``limit`` on the edge-expanded graph
(:class:`~osm_expand.engine.traffic.trip_graph.TripGraph`), take the travel
cost to every segment reached, draw destinations and walk their paths back.
With scipy (``scipy.sparse.csgraph.dijkstra``) a batch took a multi-start
search for the union of what the starts reach, the induced subgraph as a
CSR matrix, the searches on it with dense distance and predecessor rows,
and dense (sources × segments) tables of costs: Campo Grande's first fill
(every segment sampled: 191 batches of 64 sources on a 54,528-vertex graph)
took 5.2 s CPU, 4.0 of them in those three calls.

Here (:func:`batch_costs`) each search runs on the whole graph's CSR arrays
and resets only the vertices it reached; the costs come out as the entries
the dense table's row-major scan gave (by source, then by segment
ascending, finite and wanted only), and :func:`walk_paths` walks the drawn
paths back along each search's predecessors. Campo Grande's captured first
fill, three back-to-back pairs on a loaded machine: 6.2 → 5.0 s CPU. The
searches themselves cost what scipy's did (about 100 ns a vertex reached,
38.8 M of them: 12,224 sources × 3,172); the saving is the tables and the
union search. A lazy 4-ary heap (the route search's) was 25 % slower here,
and numbering the vertices by a Morton order of the segments 5 % slower.

The distances and predecessors must be scipy's, ties included: the trips
drawn, and so the traffic, the widths and every output byte, follow them.
scipy 1.17's Dijkstra (a lazy ``std::priority_queue`` of ``(−distance,
vertex)``) scans the vertices by distance and, of equal ones, the highest
numbered first, and takes a relaxation only when strictly cheaper and not
above ``limit`` (:mod:`osm_expand.engine.roads.expanded_search` gives the
argument; its ``_before`` is the order used here). The heap here holds
each vertex once and lowers its key in place; it pops the least (distance,
−vertex) of the vertices reached and not scanned, the set scipy's queue
holds live, so the two scan alike, with the same float sums. And scipy on
the induced subgraph made the same steps as on the whole graph (its
vertices keep their order, each row its arcs' order). So the costs, the
draws and the paths are those of the scipy code they replace
(``tests/test_trip_search.py``: random graphs full of ties, zero weights
among them; grid towns against the dense table of scipy's rows).

The kernels are compiled by numba on first use and cached (``_compiled``,
:mod:`osm_expand.engine.roads.expanded_search`): with an empty cache a
user's first run spends 4.65 s CPU compiling ``_batch`` and ``_walk``
(session 37's review), later runs load them. This module, and with it
numba, is imported only when trips are searched.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.roads.expanded_search import NO_PRED, _before, _compiled

__all__ = ["batch_costs", "walk_paths"]

#: ``at`` of a vertex not in the heap (not reached yet)
_OUT = -1
#: ``at`` of a vertex popped (its distance final)
_SCANNED = -2


@_compiled(inline="always")
def _search(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, start: int, limit: float, dist: np.ndarray,
            pred: np.ndarray, at: np.ndarray, touched: np.ndarray, keys: np.ndarray, heap: np.ndarray) -> int:
    """Dijkstra from ``start`` up to ``limit`` on the CSR graph (``indptr``, ``indices``, ``data``), scipy's
    steps (module docstring). ``dist``, ``pred`` and ``at`` (∞, ``NO_PRED`` and ``_OUT`` everywhere
    before) are set for the vertices reached, listed in ``touched[:reached]`` in the order first
    reached; the caller resets them. Returns ``reached``.

    The heap (``keys``, ``heap``: a binary heap of vertices, ``at`` each one's place, ``_SCANNED``
    once popped) holds every vertex once and lowers its key in place (25 % less CPU than
    :mod:`~osm_expand.engine.roads.expanded_search`'s lazy heap on Campo Grande's first fill). It
    pops by scipy's order too: each time the least (distance, −vertex) of the vertices reached and
    not scanned, the very set scipy's lazy queue holds live, so the two scan alike."""
    dist[start] = 0.0
    touched[0] = start
    reached = 1
    keys[0] = 0.0
    heap[0] = start
    at[start] = 0
    length = 1
    while length > 0:
        u = heap[0]
        key = keys[0]
        at[u] = _SCANNED
        length -= 1
        if length > 0:  # the last entry sifts down from the top
            last_key = keys[length]
            last = heap[length]
            hole = 0
            while True:
                c = 2 * hole + 1
                if c >= length:
                    break
                if c + 1 < length and _before(keys[c + 1], heap[c + 1], keys[c], heap[c]):
                    c += 1
                if not _before(keys[c], heap[c], last_key, last):
                    break
                keys[hole] = keys[c]
                heap[hole] = heap[c]
                at[heap[hole]] = hole
                hole = c
            keys[hole] = last_key
            heap[hole] = last
            at[last] = hole
        for j in range(indptr[u], indptr[u + 1]):
            v = indices[j]
            place = at[v]
            if place == _SCANNED:
                continue
            nv = key + data[j]
            if nv <= limit and dist[v] > nv:  # scipy: strictly cheaper, not above the limit
                if place == _OUT:
                    touched[reached] = v
                    reached += 1
                    hole = length
                    length += 1
                else:
                    hole = place
                dist[v] = nv
                pred[v] = u
                while hole > 0:  # the vertex sifts up to its place
                    up = (hole - 1) >> 1
                    if not _before(nv, v, keys[up], heap[up]):
                        break
                    keys[hole] = keys[up]
                    heap[hole] = heap[up]
                    at[heap[hole]] = hole
                    hole = up
                keys[hole] = nv
                heap[hole] = v
                at[v] = hole
    return reached


@_compiled(inline="always")
def _grown(a: np.ndarray, size: int) -> np.ndarray:
    """``a`` with room for ``size`` entries (doubled until it has)."""
    if size <= len(a):
        return a
    n = max(len(a), 1)
    while n < size:
        n *= 2
    return np.concatenate((a, np.empty(n - len(a), dtype=a.dtype)))


@_compiled()
def _batch(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, sources: np.ndarray, e: int,
           wanted: np.ndarray, limit: float) -> tuple[np.ndarray, ...]:
    """The trips' searches of one batch (:func:`batch_costs`): the destinations' entries, and each
    search's vertices, distances and predecessors (``ptr``: where each search's rows start; :func:`_walk`
    reads the vertices and predecessors, the tests all three: with ``e`` 0 any CSR graph is searched
    from ``sources`` themselves)."""
    n = len(indptr) - 1
    dist = np.full(n, np.inf)
    pred = np.full(n, NO_PRED, dtype=np.int32)
    at = np.full(n, _OUT, dtype=np.int32)
    touched = np.empty(n, dtype=np.int32)
    keys = np.empty(n)
    heap = np.empty(n, dtype=np.int32)
    s_count = len(sources)
    ptr = np.zeros(s_count + 1, dtype=np.int64)
    r_vertex = np.empty(1024, dtype=np.int64)
    r_dist = np.empty(1024)
    r_pred = np.empty(1024, dtype=np.int64)
    seen = np.zeros(e, dtype=np.bool_)
    union = np.empty(e, dtype=np.int64)
    k = 0
    rows = 0
    for i in range(s_count):
        reached = _search(indptr, indices, data, 2 * e + sources[i], limit, dist, pred, at, touched, keys, heap)
        r_vertex = _grown(r_vertex, rows + reached)
        r_dist = _grown(r_dist, rows + reached)
        r_pred = _grown(r_pred, rows + reached)
        for t in range(reached):
            v = touched[t]
            r_vertex[rows] = v
            r_dist[rows] = dist[v]
            r_pred[rows] = pred[v]
            rows += 1
            dist[v] = np.inf
            pred[v] = NO_PRED
            at[v] = _OUT
            if v < 2 * e:
                seg = v - e if v >= e else v
                if not seen[seg]:
                    seen[seg] = True
                    union[k] = seg
                    k += 1
        ptr[i + 1] = rows
    union = np.sort(union[:k])
    # each row over the batch's segments in ascending order, as the dense (S, K) table's row-major scan
    forward = np.full(e, np.inf)
    backward = np.full(e, np.inf)
    out_row = np.empty(1024, dtype=np.int64)
    out_seg = np.empty(1024, dtype=np.int64)
    out_cost = np.empty(1024)
    out_back = np.empty(1024, dtype=np.bool_)
    m = 0
    for i in range(s_count):
        for t in range(ptr[i], ptr[i + 1]):
            v = r_vertex[t]
            if v < e:
                forward[v] = r_dist[t]
            elif v < 2 * e:
                backward[v - e] = r_dist[t]
        out_row = _grown(out_row, m + k)
        out_seg = _grown(out_seg, m + k)
        out_cost = _grown(out_cost, m + k)
        out_back = _grown(out_back, m + k)
        own = sources[i]
        for c in range(k):
            seg = union[c]
            f = forward[seg]
            b = backward[seg]
            cost = b if b < f else f
            if cost < np.inf and wanted[seg] and seg != own:
                out_row[m] = i
                out_seg[m] = seg
                out_cost[m] = cost
                out_back[m] = b < f
                m += 1
        for t in range(ptr[i], ptr[i + 1]):
            v = r_vertex[t]
            if v < e:
                forward[v] = np.inf
            elif v < 2 * e:
                backward[v - e] = np.inf
    return out_row[:m], out_seg[:m], out_cost[:m], out_back[:m], ptr, r_vertex[:rows], r_dist[:rows], r_pred[:rows]


@_compiled()
def _walk(ptr: np.ndarray, r_vertex: np.ndarray, r_pred: np.ndarray, rows: np.ndarray, ends: np.ndarray, e: int,
          n: int) -> tuple[np.ndarray, np.ndarray]:
    """Each path's segments from its end back to its start's segment (the predecessors of search
    ``rows[i]`` from vertex ``ends[i]`` while they are directions), one path after another, and the
    paths' lengths. ``rows`` ascending."""
    before = np.full(n, NO_PRED, dtype=np.int64)
    out = np.empty(1024, dtype=np.int64)
    lengths = np.zeros(len(rows), dtype=np.int64)
    m = 0
    last = -1
    for i in range(len(rows)):
        r = rows[i]
        if r != last:
            if last >= 0:
                for t in range(ptr[last], ptr[last + 1]):
                    before[r_vertex[t]] = NO_PRED
            for t in range(ptr[r], ptr[r + 1]):
                before[r_vertex[t]] = r_pred[t]
            last = r
        v = ends[i]
        for _ in range(2 * e + 1):  # a path visits each direction at most once
            out = _grown(out, m + 1)
            out[m] = v - e if v >= e else v
            m += 1
            lengths[i] += 1
            p = before[v]
            if p < 0 or p >= 2 * e:
                break
            v = p
    return out[:m], lengths


def batch_costs(indptr: NDArray[np.integer], indices: NDArray[np.integer], data: NDArray[np.floating],
                sources: NDArray[np.integer], n_segments: int, wanted: NDArray[np.bool_], limit: float,
                ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_], tuple]:
    """The trips' searches of one batch on the edge-expanded graph (CSR arrays, :class:`TripGraph`'s
    numbering: directions ``0 … 2E − 1``, midpoints ``2E + e``): the travel cost from each source's
    midpoint to every other segment it reaches within ``limit`` that is ``wanted``.

    Returns
    -------
    row, segment : (M,) int64
        The entries: a source's position in ``sources`` and a destination segment, by row, then by
        segment ascending (the row-major order of a dense ``(S, segments)`` table's finite entries).
    cost : (M,) float64
        The cheaper of the segment's two directions (scipy's distances).
    back : (M,) bool
        Whether that is the backward direction (strictly cheaper than the forward one).
    paths : tuple
        What :func:`walk_paths` reads of the searches.

    Raises
    ------
    ValueError
        A source outside the midpoints, ``wanted`` not one flag per segment, or a graph of 2³¹ arcs
        or vertices or more (the kernel reads its CSR arrays as int32, which would wrap silently;
        numba checks no bounds, so each would read or write outside the arrays).
    """
    sources = np.ascontiguousarray(sources, dtype=np.int64).reshape(-1)
    n = len(indptr) - 1
    e = int(n_segments)
    if len(sources) and (sources.min() < 0 or 2 * e + sources.max() >= n):
        raise ValueError(f"batch_costs: sources must lie in 0 … {(n - 2 * e) - 1}")
    if len(wanted) != e:
        raise ValueError(f"batch_costs: {len(wanted)} wanted flags for {e} segments")
    if n >= 2**31 or (len(indptr) > 0 and int(indptr[-1]) >= 2**31):
        raise ValueError(f"batch_costs: {n} vertices and {int(indptr[-1])} arcs: more than int32 numbers")
    row, segment, cost, back, ptr, vertex, _, before = _batch(
        np.ascontiguousarray(indptr, dtype=np.int32), np.ascontiguousarray(indices, dtype=np.int32),
        np.ascontiguousarray(data, dtype=np.float64), sources, e, np.ascontiguousarray(wanted, dtype=np.bool_),
        float(limit))
    return row, segment, cost, back, (ptr, vertex, before, e, n)


def walk_paths(paths: tuple, rows: NDArray[np.int64], ends: NDArray[np.int64],
               ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The segments of each path (search ``rows[i]``, ascending, to direction vertex ``ends[i]``) from
    its end back to the segment after its source, step by step over all paths: the first segment of
    every path, then the second of those that have one, and so on; with each entry's path index."""
    ptr, vertex, before, e, n = paths
    segments, lengths = _walk(ptr, vertex, before, np.ascontiguousarray(rows, dtype=np.int64),
                              np.ascontiguousarray(ends, dtype=np.int64), e, n)
    path = np.repeat(np.arange(len(rows)), lengths)
    step = np.arange(len(segments)) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    order = np.argsort(step, kind="stable")
    return segments[order], path[order]
