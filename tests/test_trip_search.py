"""The trips' compiled Dijkstra (:mod:`osm_expand.engine.traffic.trip_search`) against scipy's.

The trips drawn, and so the traffic and every output byte, follow the
distances and predecessors: the compiled searches must give scipy's, ties
included, and a batch must draw what the dense table of scipy's rows drew.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.traffic.trip_search import _batch, batch_costs
from osm_expand.engine.traffic.trips import TripGraph, TripOptions, _decay, _draws, _sample_batch, trip_graph


def dense_sample_batch(graph: TripGraph, sources: np.ndarray, n_trips: np.ndarray, residents: np.ndarray,
                       volume: float, rng: np.random.Generator, options: TripOptions) -> tuple:
    """``_sample_batch`` by its definition: scipy's rows over the whole graph, the dense (sources ×
    segments) table of costs, its finite entries in row-major order, the paths walked back step by
    step over all of them (the code before the compiled search, on the whole graph; the draws over the
    entries are the trips' own :func:`_draws`)."""
    e = graph.n_segments
    dist, pred = dijkstra(graph.matrix, directed=True, indices=2 * e + sources, return_predecessors=True,
                          limit=options.limit)
    forward, backward = dist[:, :e], dist[:, e:2 * e]
    cost = np.minimum(forward, backward)
    cost[np.arange(len(sources)), sources] = np.inf  # no trips to one's own street
    row, col = np.nonzero(np.isfinite(cost) & (residents > 0)[None, :])
    weight = residents[col] * _decay(cost[row, col], options)
    pick, count, drawn, stranded = _draws(row, weight, n_trips, len(sources), rng)
    if drawn == 0:
        return [], [], [], 0, stranded
    row, col = row[pick], col[pick]
    people = count * volume
    cur = col + e * (backward[row, col] < forward[row, col])
    src_out, seg_out, vol_out = [], [], []
    while len(cur):
        src_out.append(sources[row])
        seg_out.append(cur % e)
        vol_out.append(people)
        nxt = pred[row, cur]
        on = (nxt >= 0) & (nxt < 2 * e)
        row, cur, people = row[on], nxt[on], people[on]
    return src_out, seg_out, vol_out, drawn, stranded


def limited_dijkstra(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, starts: np.ndarray, limit: float,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The trips' compiled searches (``_batch``'s, with no segments: from ``starts`` themselves) as
    scipy's ``dijkstra(matrix, indices=starts, return_predecessors=True, limit=limit)`` gives them,
    kept to the vertices some start reaches: those vertices ascending, the (S, K) distances and the
    predecessors as column indices (−9999: none)."""
    starts = np.asarray(starts, dtype=np.int64)
    *_, ptr, vertex, distance, before = _batch(
        np.asarray(indptr, dtype=np.int32), np.asarray(indices, dtype=np.int32), np.asarray(data, dtype=np.float64),
        starts, 0, np.zeros(0, dtype=np.bool_), float(limit))
    row = np.repeat(np.arange(len(starts)), np.diff(ptr))
    vertices = np.unique(vertex)
    column = np.searchsorted(vertices, vertex)
    dist = np.full((len(starts), len(vertices)), np.inf)
    dist[row, column] = distance
    pred = np.full((len(starts), len(vertices)), -9999, dtype=np.int32)
    has = before >= 0
    pred[row[has], column[has]] = np.searchsorted(vertices, before[has])
    return vertices, dist, pred


@st.composite
def tied_graphs(draw: st.DrawFn) -> tuple[csr_matrix, np.ndarray, float]:
    """A directed graph of a few dozen vertices whose weights come from a handful of values (a zero
    among them), so that many paths tie; starts; a limit."""
    n = draw(st.integers(1, 40))
    m = draw(st.integers(0, 4 * n))
    tail = np.array(draw(st.lists(st.integers(0, n - 1), min_size=m, max_size=m)), dtype=np.int64)
    head = np.array(draw(st.lists(st.integers(0, n - 1), min_size=m, max_size=m)), dtype=np.int64)
    weight = np.array(draw(st.lists(st.sampled_from([0.0, 0.5, 1.0, 1.0, 2.0, 0.1, 0.2, 0.3]), min_size=m,
                                    max_size=m)))
    keep = tail != head
    graph = csr_matrix((weight[keep], (tail[keep], head[keep])), shape=(n, n))
    starts = np.array(draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=6)), dtype=np.int64)
    limit = draw(st.sampled_from([0.0, 0.3, 1.0, 2.5, np.inf]))
    return graph, starts, limit


@settings(max_examples=400, deadline=None)
@given(tied_graphs())
def test_the_compiled_searches_give_scipys_distances_and_predecessors_ties_included(case):
    """Every distance and predecessor scipy's Dijkstra gives on the whole graph, on graphs full of
    equal paths (weights from a few values, zeros among them), repeated starts and tight limits:
    the compiled search scans in scipy's order (distance, then the highest vertex) and relaxes as it
    does (strictly cheaper, not above the limit)."""
    graph, starts, limit = case
    want, want_pred = dijkstra(graph, directed=True, indices=starts, return_predecessors=True, limit=limit)
    vertex, dist, pred = limited_dijkstra(graph.indptr, graph.indices, graph.data, starts, limit)
    outside = np.ones(graph.shape[0], bool)
    outside[vertex] = False
    assert np.all(np.diff(vertex) > 0)
    assert np.isinf(want[:, outside]).all() and (want_pred[:, outside] == -9999).all()
    assert np.array_equal(dist, want[:, vertex])
    assert np.array_equal(np.where(pred >= 0, vertex[np.maximum(pred, 0)], -9999), want_pred[:, vertex])


@st.composite
def grid_towns(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A town on a square grid of 10 m (every block's sides of equal length: ties everywhere): some of
    the grid's streets, some of them major; the residents of each segment."""
    side = draw(st.integers(2, 7))
    xy = np.array([(10.0 * i, 10.0 * j) for j in range(side) for i in range(side)])
    edges = [(k, k + 1) for k in range(side * side) if (k + 1) % side] + \
            [(k, k + side) for k in range(side * (side - 1))]
    chosen = draw(st.lists(st.sampled_from(edges), min_size=1, max_size=len(edges), unique=True))
    uv = np.array(chosen, dtype=np.int64)
    flip = np.array(draw(st.lists(st.booleans(), min_size=len(uv), max_size=len(uv))))
    uv[flip] = uv[flip][:, ::-1]
    major = np.array(draw(st.lists(st.booleans(), min_size=len(uv), max_size=len(uv))))
    residents = np.array(draw(st.lists(st.sampled_from([0.0, 1.0, 5.0, 12.5]), min_size=len(uv),
                                       max_size=len(uv))))
    return xy, uv, np.c_[major, residents]


@settings(max_examples=200, deadline=None)
@given(grid_towns(), st.integers(0, 2**32 - 1), st.sampled_from([15.0, 40.0, 1500.0]))
def test_a_batch_draws_the_trips_of_the_dense_table_of_scipys_rows(town, seed, decay_length):
    """``_sample_batch`` (compiled searches, entries and walk) gives the very (source, segment, people)
    triples, in the same order, and the same counts as the dense table of scipy's rows, on grid towns
    full of equal paths and with limits that cut them (``decay_length`` × ``cutoff``)."""
    xy, uv, extra = town
    major, residents = extra[:, 0].astype(bool), extra[:, 1]
    options = TripOptions(decay_length=decay_length, turn_cost=25.0)
    g = trip_graph(xy, uv, major=major, options=options)
    rng = np.random.default_rng(seed)
    sources = np.sort(rng.choice(len(uv), rng.integers(1, len(uv) + 1), replace=False))
    n_trips = rng.integers(0, 6, len(sources))
    got = _sample_batch(g, sources, n_trips, residents, 1.5, np.random.default_rng(seed), options)
    want = dense_sample_batch(g, sources, n_trips, residents, 1.5, np.random.default_rng(seed), options)
    assert got[3:] == want[3:]
    for a, b in zip(got[:3], want[:3]):
        assert np.array_equal(np.concatenate(a) if a else np.zeros(0), np.concatenate(b) if b else np.zeros(0))


def test_batch_costs_refuses_a_source_outside_the_graph():
    """numba checks no bounds: a source past the table would read and write outside the arrays."""
    g = trip_graph(np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([[0, 1]]))
    m = g.matrix
    with pytest.raises(ValueError, match="sources must lie in"):
        batch_costs(m.indptr, m.indices, m.data, np.array([1]), 1, np.ones(1, bool), 100.0)
    with pytest.raises(ValueError, match="sources must lie in"):
        batch_costs(m.indptr, m.indices, m.data, np.array([-1]), 1, np.ones(1, bool), 100.0)


def test_batch_costs_refuses_wanted_flags_of_another_length_and_arcs_past_int32():
    """Review of session 37: ``_batch`` reads ``wanted`` by segment and the CSR arrays as int32, with
    no bounds checked: too few flags read past their end, and 2³¹ arcs or more would wrap silently.
    Both are refused before the kernel runs (the arcs' count is read from ``indptr``'s last entry)."""
    g = trip_graph(np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]), np.array([[0, 1], [1, 2]]))
    m = g.matrix
    with pytest.raises(ValueError, match="wanted flags"):
        batch_costs(m.indptr, m.indices, m.data, np.array([0]), 2, np.ones(1, bool), 100.0)
    huge = m.indptr.astype(np.int64)
    huge[-1] = 2**31
    with pytest.raises(ValueError, match="int32"):
        batch_costs(huge, m.indices, m.data, np.array([0]), 2, np.ones(2, bool), 100.0)
    batch_costs(m.indptr, m.indices, m.data, np.array([0]), 2, np.ones(2, bool), 100.0)
