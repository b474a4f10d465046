"""The turn-penalised search's machinery (issue 22): the heading-expanded graph, A* on it, its bounds."""
from __future__ import annotations

import sys
import tracemalloc
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.roads import routing
from osm_expand.engine.roads.built_up import built_up_area
from osm_expand.engine.roads.expanded_search import PlainSearch
from osm_expand.engine.roads.lattice import EdgeKind, LatticeOptions, Raster, build_lattice
from osm_expand.engine.roads.path_graph import EdgeCosts, PathGraph, implicit_graph, pathfinding_graph
from osm_expand.engine.roads.routing import RoutingOptions
from osm_expand.errors import OptionError
from osm_expand.model.segments import SegmentTable
from tests.test_majorroads import blocks_of, grid_lines, random_blobs, random_town
from tests.test_majorroads import krems as krems_town  # noqa: F401 (a fixture)


def random_map(seed: int):
    """A street grid (major and minor) among forbidden blobs on an 800 m field, and its G′."""
    rng = np.random.default_rng(seed)
    extent = (0, 0, 800, 800)
    blobs = random_blobs(rng, extent, 5, within=(50, 750), radius=(20, 70))
    n = int(rng.integers(2, 5))
    lines = grid_lines(float(rng.uniform(100, 300)), float(rng.uniform(100, 300)), n, 300 / n)
    segs = SegmentTable.from_lines(lines, major=[bool(b) for b in rng.integers(0, 2, len(lines))],
                                   width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, forbidden=blobs,
                        options=LatticeOptions(radius=int(rng.integers(1, 4)))).with_built_up(built.area)
    return pathfinding_graph(lat, segs, built), rng


def reference_expanded(g, lat, extra, region, penalties, k) -> csr_matrix:
    """The expanded graph written plainly: every entry with its row, a stable sort by row in the
    order arrivals' cheap turns (q ascending), arrivals → hub, lattice moves (directions
    ascending), other edges (edges ascending), hub → departures. States: arrivals ``v·k + j``, then
    departures ``(n + v)·k + j``, then hubs ``2nk + v`` (``routing._States``)."""
    n = len(region)
    local = np.full(g.n_vertices, -1)
    local[region] = np.arange(n)
    height = penalties.max()
    cheap = np.flatnonzero(penalties < height - 1e-9)
    rows, cols, vals = [], [], []
    v = np.arange(n)

    def arr(v, j):
        return v * k + j

    def dep(v, j):
        return (n + v) * k + j

    for q in cheap:  # arr(v, i) → dep(v, i + q)
        rows.append(arr(v[:, None], np.arange(k)).ravel())
        cols.append(dep(v[:, None], (np.arange(k) + q) % k).ravel())
        vals.append(np.full(n * k, max(penalties[q], routing._EPS)))
    rows.append(arr(v[:, None], np.arange(k)).ravel())
    cols.append(np.repeat(2 * n * k + v, k))
    vals.append(np.full(n * k, height))
    # the cheap turns of a row in q order and then the hub: a stable sort on (row, order within row)
    turn_rows, turn_cols, turn_vals = (np.stack(x, axis=1).ravel() for x in (rows, cols, vals))
    rows, cols, vals = [turn_rows], [turn_cols], [turn_vals]
    dir_bin = routing._bins(g.direction_heading, k)
    u, d = np.nonzero(lat)
    w = u + g.lattice.direction_offset[d]
    keep = (local[u] >= 0) & (local[w] >= 0)
    u, d, w = u[keep], d[keep], w[keep]
    order = np.lexsort((d, dir_bin[d], local[u]))  # by row dep(u, bin), directions ascending
    u, d, w = u[order], d[order], w[order]
    rows.append(dep(local[u], dir_bin[d]))
    cols.append(arr(local[w], dir_bin[d]))
    vals.append(g.lat_weight[u, d].astype(float))
    e = np.flatnonzero(extra & (local[g.src] >= 0) & (local[g.dst] >= 0))
    b = routing._bins(g.heading[e], k)
    rows.append(dep(local[g.src[e]], b))
    cols.append(arr(local[g.dst[e]], b))
    vals.append(g.weight[e])
    rows.append(np.repeat(2 * n * k + v, k))
    cols.append(dep(v[:, None], np.arange(k)).ravel())
    vals.append(np.full(n * k, routing._EPS))
    rows, cols, vals = (np.concatenate(x) for x in (rows, cols, vals))
    order = np.argsort(rows, kind="stable")
    size = n * (2 * k + 1)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=size))])
    return csr_matrix((vals[order], cols[order], indptr), shape=(size, size))


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_expanded_graph_is_the_plainly_written_one_entry_for_entry(seed):
    """The block-wise writer (no sort) puts every entry where a plain sort by row would: the same
    CSR arrays, so scipy's Dijkstra breaks ties as before and routes keep their bytes."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), turn_centre=float(rng.uniform(1.8, 2.7)))
    lat, extra = g.masks()
    region = np.flatnonzero(rng.random(g.n_vertices) < rng.uniform(0.3, 1.0))
    penalties = routing._bin_penalties(opts)
    made, local = routing._expanded_graph(g, lat, extra, region, penalties, opts.heading_bins)
    want = reference_expanded(g, lat, extra, region, penalties, opts.heading_bins)
    assert np.array_equal(made.indptr, want.indptr)
    assert np.array_equal(made.indices, want.indices)
    assert np.array_equal(made.data, want.data)
    assert np.array_equal(local[region], np.arange(len(region)))


def renumbered(m: csr_matrix, new: np.ndarray) -> csr_matrix:
    """``m`` with state x named ``new[x]``: each row's entries kept in their order, their columns renamed."""
    order = np.argsort(new)  # the old state of each new row
    lengths = np.diff(m.indptr)[order]
    indptr = np.concatenate([[0], np.cumsum(lengths)])
    take = np.repeat(m.indptr[order] - indptr[:-1], lengths) + np.arange(indptr[-1])
    return csr_matrix((m.data[take], new[m.indices[take]], indptr), shape=m.shape)


def predecessor_rule(m: csr_matrix, dist: np.ndarray, source: int) -> tuple[np.ndarray, int]:
    """Each state's predecessor as scipy 1.17's Dijkstra (a priority queue) picks it: of the
    in-neighbours u whose ``dist[u] + w`` is the state's distance, the one of least ``dist[u]`` and, of
    equal ones, the highest numbered; −9999 where none (unreached, and the source). And how many
    states have more than one such in-neighbour (ties, where the order decides)."""
    rows = np.repeat(np.arange(m.shape[0]), np.diff(m.indptr))
    attains = np.isfinite(dist[rows]) & (dist[rows] + m.data == dist[m.indices]) & (m.indices != source)
    u, x = rows[attains], m.indices[attains]
    order = np.lexsort((-u, dist[u], x))
    u, x = u[order], x[order]
    first = np.ones(len(x), dtype=bool)
    first[1:] = x[1:] != x[:-1]
    pred = np.full(m.shape[0], -9999)
    pred[x[first]] = u[first]
    return pred, int(np.count_nonzero(np.diff(np.flatnonzero(np.append(first, True))) > 1))


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_states_numbered_by_kind_give_every_state_the_predecessor_the_per_vertex_numbering_gave(seed):
    """Why numbering the states by kind (``routing._States``, session 35) keeps every route's bytes.
    scipy's Dijkstra takes a state's predecessor by the distances and the state numbers of its
    in-neighbours that attain its distance (:func:`predecessor_rule`; a random numbering changes
    some). Those in-neighbours are all departures (of an arrival), or one vertex's arrivals and hub
    (of a departure or the hub), whose order both numberings share: every state gets the same
    distance and the same predecessor as under the per-vertex numbering it replaced, ties included
    (a street grid has many exactly equal routes)."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)))
    k = opts.heading_bins
    lat, extra = g.masks()
    made, _ = routing._expanded_graph(g, lat, extra, np.arange(g.n_vertices), routing._bin_penalties(opts), k)
    states = routing._States(g.n_vertices, k)
    every = np.arange(states.size)
    per_vertex = states.vertex(every) * (2 * k + 1) + states.slot(every)  # the numbering before
    assert np.array_equal(np.sort(per_vertex), every)
    assert np.array_equal(states.state(states.vertex(every), states.slot(every)), every)
    s = states.hub(int(rng.choice(g.live_vertices())))
    want, want_pred = dijkstra(made, indices=s, return_predecessors=True)
    rule, tied = predecessor_rule(made, want, s)
    assert np.array_equal(want_pred, rule)
    assert tied > 0  # states with two or more predecessors of exactly equal cost
    before = renumbered(made, per_vertex)
    got, pred = dijkstra(before, indices=per_vertex[s], return_predecessors=True)
    assert np.array_equal(got[per_vertex], want)
    reached = want_pred >= 0
    assert np.array_equal(pred[per_vertex][reached], per_vertex[want_pred[reached]])
    assert (pred[per_vertex][~reached] < 0).all()


def test_a_graph_holds_no_lattice_mask_table_and_its_masks_read_as_the_kinds_compared():
    """Issue 22: G′ keeps no (V, D) bool table beside ``lat_kind`` (on the synthetic town's whole map
    one was 293 MB through both searches); its lattice mask is made row block by row block as read,
    the same values as the whole table compared with the kinds."""
    g, rng = random_map(11)
    held = [v for x in vars(g).values() for v in (x.values() if isinstance(x, dict) else [x])]
    assert not any(isinstance(v, np.ndarray) and v.dtype == bool and v.shape == g.lat_kind.shape for v in held)
    for kinds in (routing.ROAD_KINDS, (EdgeKind.LAND,), (EdgeKind.HARBOUR, EdgeKind.WATER), (EdgeKind.MAJOR,)):
        lat, _ = g.masks(kinds)
        want = np.isin(g.lat_kind, [int(k) for k in kinds])
        assert np.array_equal(np.asarray(lat), want)
        rows = rng.integers(0, g.n_lattice, 50)
        assert np.array_equal(lat[rows], want[rows])
        assert np.array_equal(lat[10:30], want[10:30])


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_flat_lattice_weights_read_pairwise_are_the_tables_own_values(seed):
    """``LatticeWeights.at`` (one lookup of kind · D + direction, what the expanded graph's lattice
    moves read) gives the very values indexing the table gives, widened to float64, also where C3 and
    C5 scale the bridge and harbour entries (:meth:`LatticeWeights.times`)."""
    g, rng = random_map(seed)
    weight = g.lat_weight
    assert isinstance(weight, routing.LatticeWeights)
    scaled = weight.times({int(EdgeKind.BRIDGE): float(rng.uniform(1, 9)), int(EdgeKind.HARBOUR): 2.5})
    rows = rng.integers(0, g.n_lattice, 5000)
    cols = rng.integers(0, weight.shape[1], 5000)
    for table in (weight, scaled):
        got = table.at(rows, cols)
        assert got.dtype == np.float64
        assert np.array_equal(got, table[rows, cols].astype(np.float64))


def test_the_expanded_graph_needs_little_more_memory_than_it_keeps():
    """Issue 22: memory follows the states searched. On an open 6 km field (90,000 vertices, 3 M
    states) making the expanded graph allocates at most 12 bytes a state beyond what it returns
    (measured 6.6; with 64-bit row lengths and row pointers, copied to 32 bits by scipy, 20.2): on
    the synthetic 10,000-street town's last tiled search, 22.5 M states, those were 450 MB."""
    segs = SegmentTable.from_lines([np.array([[100.0, 100.0], [300.0, 100.0]])], major=[True], width=[6.0])
    g = pathfinding_graph(build_lattice((0, 0, 6000, 6000), options=LatticeOptions(radius=1)), segs)
    opts = RoutingOptions()
    lat, extra = g.masks()
    penalties = routing._bin_penalties(opts)
    tracemalloc.start()
    try:
        made, local = routing._expanded_graph(g, lat, extra, np.arange(g.n_vertices), penalties, opts.heading_bins)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    kept = made.data.nbytes + made.indices.nbytes + made.indptr.nbytes + local.nbytes
    assert made.shape[0] > 2_000_000
    assert peak - kept < 12 * made.shape[0]


def _exits_problem(g, rng):
    """The exits' search tests' set-up on a random map ``g``: its masks, live vertices, two of them ``s`` and
    ``t`` (drawn from ``rng``), the straight-line bound to ``t`` at the cheapest unit cost and the plain
    distances from ``s`` (infinite where the map does not join them: each test decides)."""
    lat, extra = g.masks()
    live = g.live_vertices()
    s, t = (int(v) for v in rng.choice(live, 2, replace=False))
    c = routing.cheapest_unit_cost(EdgeCosts(), routing.ROAD_KINDS)
    straight = c * np.hypot(*(g.xy - g.xy[t]).T)
    return lat, extra, live, s, t, straight, dijkstra(g.matrix(), indices=s)


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_exits_search_by_a_star_finds_dijkstras_arrival_costs(seed):
    """``_tiled_search`` without a target runs A* (reduced costs) and gives every exit the least
    turn-penalised arrival cost Dijkstra over the whole expanded graph gives, where that is below C."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), tile_cells=int(rng.integers(1, 5)),
                          whole_region=int(rng.choice([0, 10**6])))
    lat, extra, live, s, t, straight, from_source = _exits_problem(g, rng)
    if not np.isfinite(from_source[t]):
        return
    penalties = routing._bin_penalties(opts)
    k = opts.heading_bins
    whole, local = routing._expanded_graph(g, lat, extra, np.arange(g.n_vertices), penalties, k)
    states = routing._States(g.n_vertices, k)
    dist = dijkstra(whole, indices=states.hub(s))
    arrive = states.by_vertex(dist)[0].min(axis=1)
    arrive[s] = 0.0
    cost = float(np.quantile(arrive[np.isfinite(arrive)], 0.6))  # a C that leaves some exits out
    exits = rng.choice(live, min(200, len(live)), replace=False)
    _, got = routing._tiled_search(g, lat, extra, s, None, from_source + straight, straight, ([s], cost),
                                   np.array([s]), penalties, opts, g.xy[t], exits=exits)
    # what the window's test needs: an exact arrival wherever it and the straight line may be below C
    short = arrive[exits] + straight[exits] < cost * (1 - 1e-6)
    assert short.any()
    # less the slack the free edges' ε may add (2 ε a state), never more
    assert got[short] == pytest.approx(arrive[exits][short], rel=1e-9, abs=1e-3)
    found = np.isfinite(got)  # ∞: no arrival that with the straight line stays below C
    assert (got[found] <= arrive[exits][found] + 1e-6).all()  # never above the true arrival


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1.9, 2.9), st.floats(0.2, 1.2))
def test_the_turns_still_needed_never_exceed_what_the_rest_of_any_route_costs(seed, centre, width):
    """The tiled search's turn floor (``routing._turns_needed``) is admissible: from every state of
    the heading-expanded graph (arriving on bin b, or departing on it), the turn-free distance to
    the target plus the turns the floor says are still needed is never above the true least cost
    of the rest (Dijkstra from the target over the reversed expanded graph), under penalties from
    ones that let 22.5° turns pass free to ones that charge them."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), turn_centre=centre, turn_width=width)
    k = opts.heading_bins
    lat, extra = g.masks()
    live = g.live_vertices()
    t = int(rng.choice(live))
    penalties = routing._bin_penalties(opts)
    whole, _ = routing._expanded_graph(g, lat, extra, np.arange(g.n_vertices), penalties, k)
    by_vertex = routing._States(g.n_vertices, k).by_vertex
    rest = by_vertex(dijkstra(whole.T.tocsr(), indices=t * k + np.arange(k), min_only=True))
    plain = dijkstra(g.matrix(), indices=t)
    need = routing._turn_floor(penalties)
    bins = np.arange(k)
    floor = routing._turns_needed(need, bins[None, :], g.xy[:, None, :], g.xy[t])  # (V, K)
    for states in rest[:2]:  # arrivals (may turn at once), departures
        ok = np.isfinite(states)
        assert ((plain[:, None] + floor)[ok] <= states[ok] * (1 + 1e-9) + 1e-6).all()
    if need.any():
        assert (floor[np.isfinite(rest[0])] > 0).any()  # the floor is not vacuous here


def test_no_matrix_of_g_prime_is_written_for_a_route(monkeypatch):
    """Memory (issue 22, session 37): the plain searches read G′'s tables as they go, as the
    heading-expanded one does, so no CSR matrix of a window (the whole map's: 2.3 GB on the
    synthetic 10,000-street town) or of a G′ given directly is ever written for a route."""
    g, rng = random_map(7)
    implicit = implicit_graph(g.lattice, g.segments, None)
    whole = implicit.whole()
    live = whole.live_vertices()

    def refused(*_):
        raise AssertionError("a matrix of G′ was written")

    monkeypatch.setattr(PathGraph, "_csr", refused)
    opts = RoutingOptions(turn_height=300.0, window_share=0.0, window_margin=50.0)
    found = 0
    for _ in range(6):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        for graph in (implicit, whole):
            found += routing.find_route(graph, s, t, options=opts) is not None
    assert found and not whole._cache


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(2.6, 2.9), st.floats(0.2, 0.6), st.sampled_from([8, 16, 7]))
def test_routes_with_the_turn_floor_charging_cost_what_the_whole_expanded_graph_gives(seed, centre, width, k):
    """End to end with the floor on (penalties that charge even the smallest turns; tiny tiles, so
    that they must grow): every route costs what Dijkstra over the whole expanded graph gives. An
    odd K searches without the floor (it is reasoned for an even K) and stays exact too."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), turn_centre=centre, turn_width=width,
                          heading_bins=k, tile_cells=int(rng.integers(1, 4)), whole_region=0)
    penalties = routing._bin_penalties(opts)
    # the strategies mostly give penalties that charge one bin's turn; where they do not (e.g. K = 16,
    # centre 2.61, width 0.25: 22.5° is free) the floor has nothing to add, which is not this test's case
    assume(routing._turn_floor(penalties).any() or k % 2 == 1)
    lat_ok, extra_ok = g.masks()
    live = g.live_vertices()
    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        route = routing.find_route(g, s, t, options=opts)
        full = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, penalties, k, np.inf)
        assert (route is None) == (full is None)
        if route is not None:
            assert route.cost == pytest.approx(full[1], rel=1e-9, abs=1e-5)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.sampled_from([8, 16]))
def test_the_backward_search_costs_what_the_whole_expanded_graph_gives(seed, light, k):
    """Issue 22: the route searched from the target backwards (``_backward_route``: A* on the reversed
    expanded graph, its tiles of 1–3 vertices so that they must grow, with the turn floor charging
    even the smallest turns or not) costs what Dijkstra over the whole heading-expanded graph gives
    and what the forward search finds, and its turns are those its cost counts."""
    g, rng = random_map(seed)
    opts = _backward_options(rng, light, k)
    penalties = routing._bin_penalties(opts)
    lat_ok, extra_ok = g.masks()
    live = g.live_vertices()
    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        route = routing.find_route(g, s, t, options=opts)
        forward = routing.find_route(g, s, t, options=replace(opts, backward=False))
        full = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, penalties, k, np.inf)
        assert (route is None) == (full is None) == (forward is None)
        if route is not None and forward is not None and full is not None:
            assert route.cost == pytest.approx(full[1], rel=1e-9, abs=1e-5)
            assert route.cost == pytest.approx(forward.cost, rel=1e-12, abs=1e-9)
            bins = routing._bins(routing._headings(route), k)
            assert route.turn_cost == pytest.approx(float(penalties[(bins[1:] - bins[:-1]) % k].sum()), abs=1e-6)


def _backward_options(rng: np.random.Generator, light: bool, k: int = 16) -> RoutingOptions:
    """Turn penalties that charge even one bin's turn (``light``: the turn floor counts) or the
    default's shape, and backward tiles of 1–3 lattice vertices."""
    centre, width = (2.7, 0.4) if light else (2.0 * np.pi / 3.0, np.pi / 3.0)
    return RoutingOptions(turn_height=float(rng.uniform(20, 900)), turn_centre=centre, turn_width=width,
                          heading_bins=k, backward=True, backward_tile_cells=int(rng.integers(1, 4)))


def test_the_backward_search_takes_the_forward_searchs_routes_and_its_tiles_grow(monkeypatch):
    """With these fixed seeds (maps 0–11, their pairs and penalties) the backward search takes
    exactly the forward search's vertices and its cost, on twelve random maps (72 routes, light and
    default penalties), and on most of them its tiles had to grow (more than one expanded graph
    besides the final forward one). Only the cost is promised in general: of several routes of
    exactly equal cost the two searches may pick different ones, which these seeds do not meet."""
    made = routing._expanded_graph
    calls: list[int] = []

    def counted(*args, **kwargs):
        calls.append(1)
        return made(*args, **kwargs)

    grew = routes = 0
    monkeypatch.setattr(routing, "_expanded_graph", counted)
    for seed in range(12):
        g, rng = random_map(seed)
        live = g.live_vertices()
        for light in (True, False):
            opts = _backward_options(rng, light)
            for _ in range(3):
                s, t = (int(v) for v in rng.choice(live, 2, replace=False))
                calls.clear()
                route = routing.find_route(g, s, t, options=opts)
                grew += len(calls) > 2
                forward = routing.find_route(g, s, t, options=replace(opts, backward=False))
                routes += 1
                assert (route is None) == (forward is None)
                if route is not None and forward is not None:
                    assert np.array_equal(route.vertices, forward.vertices)
                    assert route.cost == pytest.approx(forward.cost, rel=1e-12, abs=1e-9)
    assert routes == 72 and grew >= routes // 3


def test_the_backward_search_falls_back_to_the_forward_one_when_its_last_dijkstra_disagrees(monkeypatch):
    """Finding 2 of session 31: when the backward search's last (forward, plain) Dijkstra does not
    reach the target within the cost found, the route is the forward search's, not the plain route
    the backward search started from. Made to happen by adding 10⁶ to that Dijkstra's distances."""
    real = dijkstra
    spoilt: list[int] = []

    def disagreeing(m, *args, **kwargs):
        out = real(m, *args, **kwargs)
        if kwargs.get("return_predecessors") and sys._getframe(1).f_code.co_name == "_backward_route":
            spoilt.append(1)
            return out[0] + 1e6, out[1]
        return out

    monkeypatch.setattr(routing, "dijkstra", disagreeing)
    for seed in range(6):
        g, rng = random_map(seed)
        live = g.live_vertices()
        opts = _backward_options(rng, True)
        for _ in range(3):
            s, t = (int(v) for v in rng.choice(live, 2, replace=False))
            route = routing.find_route(g, s, t, options=opts)
            forward = routing.find_route(g, s, t, options=replace(opts, backward=False))
            assert (route is None) == (forward is None)
            if route is not None and forward is not None:
                assert route.cost == pytest.approx(forward.cost, rel=1e-12, abs=1e-9)
    assert spoilt  # the backward search's last Dijkstra ran (a route cheaper than the plain one's)


def _first_bounds(g, s, t, opts):
    """The plain shortest path with its turns (the search's old first bound) and the band's bound, on G′."""
    lat_ok, extra_ok = g.masks()
    with g.restricted(routing.ROAD_KINDS, None) as matrix:
        d_s, pred = dijkstra(matrix, indices=s, return_predecessors=True)
        if not np.isfinite(d_s[t]):
            return None
        d_t = dijkstra(matrix, indices=t)
    plain = routing._walk_back(pred, s, t)
    first = (plain, routing._route_cost(g, np.asarray(plain), lat_ok, extra_ok, opts))
    band = routing._band_bound(g, lat_ok, extra_ok, s, t, d_s + d_t, d_t, first, routing._bin_penalties(opts), opts)
    return first, band


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.sampled_from([8, 16]))
@example(2, 1, 16)  # _route_cost's own slack put the band's route 1.6e-6 above the band's cost
def test_the_bands_first_bound_is_an_upper_bound_of_the_best_cost_and_never_above_the_plain_routes(seed, cells, k):
    """Issue 22: the band's route (``_band_bound``, searched by A* in tiles of 1–6 vertices round the
    plain shortest path) is feasible: its cost bounds the whole expanded graph's best from above,
    and it is never above the bound it started from (the plain route with its turns, itself an
    upper bound by ``_route_cost``). The route found with the band costs what the whole expanded
    graph gives, as it does without it."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k, bound_cells=cells)
    penalties = routing._bin_penalties(opts)
    lat_ok, extra_ok = g.masks()
    live = g.live_vertices()
    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        full = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, penalties, k, np.inf)
        bounds = _first_bounds(g, s, t, opts)
        assert (full is None) == (bounds is None)
        if full is None or bounds is None:
            continue
        (plain, plain_cost), (band, band_cost) = bounds
        assert full[1] <= plain_cost and full[1] <= band_cost <= plain_cost
        assert band[0] == s and band[-1] == t
        again = routing._route_cost(g, np.asarray(band), lat_ok, extra_ok, opts)
        # the band's route is a route of G′; ``_route_cost`` adds its own rounding slack (1e-9 relative,
        # 1e-6 and ε per state), which the band's cost need not hold (seed 2: 1.6e-6 over)
        slack = 1e-9 * band_cost + 1e-6 + 4 * len(band) * (2 * k + 1) * routing._EPS
        assert again is not None and full[1] <= again <= band_cost + slack
        route = routing.find_route(g, s, t, options=opts)
        assert route is not None
        assert route.cost == pytest.approx(full[1], rel=1e-9, abs=1e-5)


def test_the_band_tightens_the_first_bound_and_keeps_the_routes_vertex_for_vertex(monkeypatch):
    """With these fixed seeds (maps 0–11, three pairs each, default penalties) the band's bound is
    below the plain route's on most routes, the search settles far fewer states with it than without,
    and takes exactly the same vertices and cost (no exactly equal routes to flip on these seeds;
    only the cost is promised in general, by the test above)."""
    settled = {"on": 0, "off": 0}
    which = ["on"]
    real = routing._heading_search

    def counted(*args, **kwargs):
        out = real(*args, **kwargs)
        if sys._getframe(1).f_code.co_name == "_tiled_search":
            settled[which[0]] += int(np.isfinite(out[0]).sum())
        return out

    monkeypatch.setattr(routing, "_heading_search", counted)
    tighter = routes = 0
    for seed in range(12):
        g, rng = random_map(seed)
        live = g.live_vertices()
        opts = RoutingOptions(turn_height=float(rng.uniform(100, 400)))
        for _ in range(3):
            s, t = (int(v) for v in rng.choice(live, 2, replace=False))
            bounds = _first_bounds(g, s, t, opts)
            if bounds is None:
                continue
            routes += 1
            tighter += bounds[1][1] < bounds[0][1]
            which[0] = "on"
            on = routing.find_route(g, s, t, options=opts)
            which[0] = "off"
            off = routing.find_route(g, s, t, options=replace(opts, bound_cells=0))
            assert on is not None and off is not None
            assert np.array_equal(on.vertices, off.vertices)
            assert on.cost == pytest.approx(off.cost, rel=1e-12, abs=1e-9)
    assert routes >= 30 and tighter >= 2 * routes // 3  # 28 of 36
    assert settled["on"] < 0.75 * settled["off"]  # 199,249 against 402,089 states


def test_a_larger_windows_search_starts_from_the_smaller_windows_route(monkeypatch):
    """Issue 22: in growing windows (``_implicit_route``) each window after the first is bound by the
    last window's best route, costed again in the new window (``_route_cost``): it is a route
    there, its cost at least the new window's best, it becomes the first bound (cheaper than the
    plain route with its turns) at least once, and the routes are those found without the band,
    vertex for vertex."""

    costed: list[float] = []
    real = routing._route_cost

    def recorded(*args, **kwargs):
        out = real(*args, **kwargs)
        if sys._getframe(1).f_code.co_name == "_search" and out is not None:
            costed.append(out)
        return out

    first_bounds: list[float] = []  # the first bound of each window's search (_best_route's ``first``)
    best_route = routing._best_route

    def bound_recorded(*args, **kwargs):
        first_bounds.append(args[7][1])
        return best_route(*args, **kwargs)

    monkeypatch.setattr(routing, "_route_cost", recorded)
    monkeypatch.setattr(routing, "_best_route", bound_recorded)
    used = became = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        implicit = random_town(rng)
        live = implicit.whole().live_vertices()
        opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)), window_margin=float(rng.uniform(20, 200)),
                              window_share=0.0)
        for _ in range(3):
            s, t = (int(v) for v in rng.choice(live, 2, replace=False))
            costed.clear()
            first_bounds.clear()
            route = routing.find_route(implicit, s, t, options=opts)
            off = routing.find_route(implicit, s, t, options=replace(opts, bound_cells=0))
            assert (route is None) == (off is None)
            if route is None or off is None:
                continue
            assert np.array_equal(route.vertices, off.vertices)
            assert route.cost == pytest.approx(off.cost, rel=1e-12, abs=1e-9)
            used += len(costed) > 0
            # _search takes the smaller window's route only when it is cheaper than the plain one
            became += any(c in first_bounds for c in costed)
            assert all(c >= route.cost - 1e-6 for c in costed)
    assert used >= 3
    assert became >= 1


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_exits_bound_through_the_exits_keeps_every_short_exits_arrival(seed):
    """Issue 22: the exits' search bound by the plain distance to an exit and the straight line on
    (``_via_exits``) is a consistent bound at least the straight line's and at most ``c·|x − t|`` at
    an exit, and every exit whose arrival plus ``c·|x − t|`` is below the route's cost (those the
    window's growth reads) arrives at exactly the cost the straight line's search gives."""
    rng = np.random.default_rng(seed)
    implicit = random_town(rng)
    live = implicit.whole().live_vertices()
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)))
    c = routing.cheapest_unit_cost(implicit.costs, routing.ROAD_KINDS)
    checked = 0
    for _ in range(3):
        s_map, t_map = (int(v) for v in rng.choice(live, 2, replace=False))
        ends = implicit.vertex_xy(np.array([s_map, t_map]))
        lo, hi = ends.min(axis=0) - 150, ends.max(axis=0) + 150
        window = implicit.window((lo[0], lo[1], hi[0], hi[1]))
        if window.whole or not len(window.exits):
            continue
        g = window.graph
        s, t = window.from_map(np.array([s_map, t_map])).tolist()
        rest = c * np.hypot(*(g.xy[window.exits] - ends[1]).T)
        route, from_source, via = routing._search(g, s, t, routing.ROAD_KINDS, None, opts, exits=(window.exits, rest))
        if route is None or via is None:
            continue
        straight = c * np.hypot(*(g.xy - ends[1]).T)
        assert (via >= straight - 1e-9 * straight - 1e-6).all()
        assert ((via[window.exits] <= rest + 1e-9) | (rest > route.cost)).all()  # ∞ above the first bound
        with g.restricted(routing.ROAD_KINDS, None) as m:
            coo = m.tocoo()
        finite = np.isfinite(via[coo.row]) & np.isfinite(via[coo.col])
        assert (via[coo.row] <= coo.data + via[coo.col] + 1e-9 * via[coo.row] + 1e-6)[finite].all()  # consistent
        penalties = routing._bin_penalties(opts)
        args = (window, routing.ROAD_KINDS, None, s, ends[1], c, from_source, route, penalties, opts)
        old = routing._exit_arrivals(*args)
        new = routing._exit_arrivals(*args, via)
        short = old + rest < route.cost - 1e-9 * route.cost
        # each search takes off its rounding slack (2 ε a state of its graph), which the smaller graph's is less of
        slack = 2 * g.n_vertices * (2 * opts.heading_bins + 1) * routing._EPS
        np.testing.assert_allclose(new[short], old[short], rtol=0, atol=slack)
        assert not (new + rest < route.cost - 1e-9 * route.cost - slack)[~short].any()
        checked += 1
    assume(checked > 0)


@pytest.mark.parametrize("name", ["bound_cells", "tile_cells", "backward_tile_cells", "turn_bound"])
@pytest.mark.parametrize("value", [float("nan"), 2.5, 4.0, "4", True, -1, None])
def test_routing_options_refuse_a_cell_count_that_is_not_a_whole_number(name, value):
    with pytest.raises(OptionError, match=f"RoutingOptions.{name} must be a whole number"):
        RoutingOptions(**{name: value})


@pytest.mark.parametrize("share", [0.0, -0.1, 1.5, float("nan"), True])
def test_routing_options_refuse_a_turn_share_outside_0_1(share):
    with pytest.raises(OptionError, match="turn_share must be in"):
        RoutingOptions(turn_share=share)


def test_routing_options_take_whole_cell_counts():
    assert RoutingOptions(bound_cells=0).bound_cells == 0  # 0: no band
    assert RoutingOptions(tile_cells=np.int64(3), backward_tile_cells=1).tile_cells == 3
    with pytest.raises(OptionError, match="tile_cells must be a whole number of at least 1, got 0"):
        RoutingOptions(tile_cells=0)


def reference_step(g, u: int, v: int, lat, extra) -> dict[str, float]:
    """The cheapest allowed edge u → v of G′ ``g`` found edge by edge (what ``PathGraph.step`` was,
    the reference for :meth:`PathGraph.steps`): the lattice edge first, then the other edges from u
    in order, each taken only when strictly cheaper; :class:`InputError` when there is none."""
    best: dict[str, float] | None = None
    if u < g.n_lattice and v < g.n_lattice:
        nx = g.lattice.shape[1]
        d = (v % nx - u % nx, v // nx - u // nx)
        hit = np.flatnonzero((g.lattice.directions[:, 0] == d[0]) & (g.lattice.directions[:, 1] == d[1]))
        if len(hit) and lat[u, hit[0]]:
            k = int(hit[0])
            best = {"kind": int(g.lat_kind[u, k]), "segment": -1, "length": float(g.lattice.direction_length[k]),
                    "weight": float(g.lat_weight[u, k]), "heading": float(g.direction_heading[k])}
    lo, hi = np.searchsorted(g.src, [u, u + 1])
    for e in (lo + np.flatnonzero((g.dst[lo:hi] == v) & extra[lo:hi])).tolist():
        if best is None or g.weight[e] < best["weight"]:
            best = {"kind": int(g.kind[e]), "segment": int(g.segment[e]), "length": float(g.length[e]),
                    "weight": float(g.weight[e]), "heading": float(g.heading[e])}
    if best is None:
        raise routing.InputError(f"G′ has no allowed edge from vertex {u} to {v}")
    return best


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**20))
def test_a_routes_edges_at_once_are_the_ones_picked_edge_by_edge(seed):
    """:meth:`PathGraph.steps` (a route's edges in one call) picks, for every pair, the edge
    :func:`reference_step` picks: the cheapest allowed, the lattice edge on a tie, else the first
    other edge of that weight; and it refuses a pair without an allowed edge as the reference does."""
    g, rng = random_map(seed)
    kinds = [routing.EdgeKind.LAND, routing.EdgeKind.BRIDGE, routing.EdgeKind.STITCH, routing.EdgeKind.MAJOR,
             routing.EdgeKind.MINOR]
    ok = rng.integers(0, 2, len(g.segments.uv)).astype(bool)
    lat, extra = g.masks(kinds[:int(rng.integers(1, 6))], ok)
    # pairs from the allowed edges of both tables (so some pairs have both), and some of no edge
    rows, dirs = np.nonzero(lat)
    pick = rng.integers(0, len(rows), min(len(rows), 200)) if len(rows) else np.zeros(0, dtype=np.int64)
    u = rows[pick]
    v = u + g.lattice.direction_offset[dirs[pick]]
    e = np.flatnonzero(extra)
    e = e[rng.integers(0, len(e), min(len(e), 200))] if len(e) else e
    u, v = np.concatenate([u, g.src[e], g.dst[e]]), np.concatenate([v, g.dst[e], g.src[e]])
    at_once = g.steps(u, v, lat, extra)
    one = [reference_step(g, int(a), int(b), lat, extra) for a, b in zip(u, v)]
    for name in ("kind", "segment", "length", "weight", "heading"):
        assert getattr(at_once, name).tolist() == [s[name] for s in one], name
    far = int(g.n_vertices - 1)
    with pytest.raises(routing.InputError):
        reference_step(g, 0, far, lat, extra)
    with pytest.raises(routing.InputError):
        g.steps(np.array([0]), np.array([far]), lat, extra)


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.sampled_from([8, 16]))
def test_a_routes_a_star_search_costs_what_plain_dijkstra_and_the_whole_expanded_graph_give(seed, tiles, k):
    """``route_astar`` (A* on reduced costs for the route; off by default): of several routes of equal
    cost it may take another than plain Dijkstra (Campo Grande's second road did), never a dearer
    one: its cost is the plain search's and the whole expanded graph's, over growing tiles or not.
    No band (``bound_cells=0``): the first bound is the turn-blind route's cost, loose, so the A*
    search itself finds the route (its cost summed by ``_path_cost``), not the band's bound."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k, bound_cells=0,
                          tile_cells=int(rng.integers(1, 4)), whole_region=0 if tiles else 100_000,
                          route_astar=False)
    fast = replace(opts, route_astar=True)
    penalties = routing._bin_penalties(opts)
    lat_ok, extra_ok = g.masks()
    live = g.live_vertices()
    summed: list[float] = []  # the costs of the routes the A* searches found
    path_cost = routing._path_cost

    def counted(*args) -> float:
        summed.append(path_cost(*args))
        return summed[-1]

    by_astar = 0
    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        plain = routing.find_route(g, s, t, options=opts)
        summed.clear()
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(routing, "_path_cost", counted)
            route = routing.find_route(g, s, t, options=fast)
        full = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, penalties, k, np.inf)
        assert (route is None) == (full is None) == (plain is None)
        if route is not None:
            assert route.cost == pytest.approx(full[1], rel=1e-9, abs=1e-5)
            assert route.cost == pytest.approx(plain.cost, rel=1e-9, abs=1e-5)
            # the route is the A* search's own: its cost is one that _path_cost summed
            by_astar += any(x == pytest.approx(route.cost, rel=1e-9, abs=1e-6) for x in summed)
    assume(by_astar > 0)  # most examples have one (7 of 8 in a run); none at all: Unsatisfiable


def test_on_krems_the_a_star_search_in_larger_windows_costs_what_the_exact_search_of_the_whole_graph_gives(krems_town):  # noqa: E501, F811
    """Issue 22 (session 34): A* for the route (``route_astar``) with larger first windows
    (``window_share``, ``growth_share`` 0.5; Campo Grande's default command 73.6 → 59.4 s CPU, off by
    default for issue 20's sake, see ``route_astar``) may take another of several routes of exactly
    equal cost, never a dearer one. On Krems' streets and land, between its exits and random street
    nodes, for new roads (every road kind) and re-routes (major roads only), the route found on the
    implicit G′ costs what plain Dijkstra over the whole map's heading-expanded graph finds (relative
    1e-9), and what the default search (plain Dijkstra, windows of a quarter) finds; the same pair
    searched again gives the very same route."""
    g, segs, exits, _, implicit = krems_town
    old = RoutingOptions()
    assert not old.route_astar and old.window_share == 0.25  # the defaults, against which A* is checked
    opts = replace(old, route_astar=True, window_share=0.5, growth_share=0.5)
    penalties = routing._bin_penalties(opts)
    rng = np.random.default_rng(34)
    nodes = np.concatenate([exits[:2], rng.choice(len(segs.xy), 2, replace=False)])
    checked = 0
    for a, b in zip(nodes[:-1], nodes[1:]):
        s, t = g.node_vertex(int(a)), g.node_vertex(int(b))
        for kinds in (routing.ROAD_KINDS, (EdgeKind.MAJOR,)):
            lat_ok, extra_ok = g.masks(kinds)
            exact = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, penalties,
                                             opts.heading_bins, np.inf)
            new = routing.find_route(implicit, s, t, kinds=kinds, options=opts)
            before = routing.find_route(implicit, s, t, kinds=kinds, options=old)
            assert (new is None) == (exact is None) == (before is None)
            if new is None:
                continue
            assert new.cost == pytest.approx(exact[1], rel=1e-9)
            assert new.cost == pytest.approx(before.cost, rel=1e-9)
            again = routing.find_route(implicit, s, t, kinds=kinds, options=opts)
            assert again is not None and np.array_equal(again.vertices, new.vertices)
            checked += 1
    assert checked >= 3  # 3 pairs: the new roads all found (re-routes over major roads only where those join them)


def compiled_and_scipy(g, lat, extra, region, penalties, k, start, limit, h):
    """The compiled search's and scipy's (on the written expanded graph, reduced by ``h`` as
    ``routing._reduced`` does) distances and predecessors from state ``start``."""
    local = routing._local(g, region, k)
    got = routing._heading_search(g, lat, extra, region, local, penalties, k, start, limit, h=h, predecessors=True)
    made, _ = routing._expanded_graph(g, lat, extra, region, penalties, k)
    if h is not None:
        made = routing._reduced(made, h, routing._States(len(region), k))
    want = dijkstra(made, indices=start, return_predecessors=True, limit=limit)
    return got, want


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]), st.booleans(), st.booleans())
def test_the_compiled_search_gives_every_state_scipys_distance_and_predecessor(seed, k, astar, limited):
    """Issue 22 (session 36): the compiled search (``expanded_search``), which makes the arrivals' and
    hubs' rows as it reaches them, is scipy's Dijkstra step for step: on a random street grid among
    forbidden blobs (many routes of exactly equal cost), over a random region, plain or on A*'s reduced
    costs, with or without a limit, every state's distance and predecessor are scipy's, ties included
    (the predecessor rule :func:`predecessor_rule` describes), so the routes keep their bytes."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k)
    lat, extra = g.masks()
    region = np.flatnonzero(rng.random(g.n_vertices) < rng.uniform(0.5, 1.0))
    assume(len(region) > 0)
    states = routing._States(len(region), k)
    start = states.hub(int(rng.integers(len(region))))
    h = rng.uniform(0.0, 300.0, len(region)) if astar else None  # inconsistent too: reduced costs raised to ε
    limit = float(rng.uniform(300.0, 3000.0)) if limited else np.inf
    (dist, pred), (want, want_pred) = compiled_and_scipy(g, lat, extra, region, routing._bin_penalties(opts), k,
                                                         start, limit, h)
    assert np.array_equal(dist, want)
    assert np.array_equal(pred, want_pred)
    if not astar and not limited:
        made, _ = routing._expanded_graph(g, lat, extra, region, routing._bin_penalties(opts), k)
        assert np.array_equal(pred, predecessor_rule(made, want, start)[0])


def test_on_krems_the_compiled_search_is_scipys_state_for_state(krems_town):  # noqa: F811
    """On Krems' streets, land and water (the real lattice, streets, stitches and bridges), between two
    of its exits over the region a route between them can use (turn-free ``d_s + d_t`` within 1.5 times
    their distance), plain and by A* with the turn-free distance to the target as bound (as
    ``_band_bound`` and ``_tiled_search`` run it): every state's distance and predecessor are scipy's,
    and so the route walked back from the target is the same."""
    g, segs, exits, _, _ = krems_town
    opts = RoutingOptions()
    k = opts.heading_bins
    penalties = routing._bin_penalties(opts)
    lat, extra = g.masks()
    s, t = g.node_vertex(int(exits[0])), g.node_vertex(int(exits[1]))
    with g.restricted(routing.ROAD_KINDS, None) as matrix:
        d_s, d_t = dijkstra(matrix, indices=[s, t])
    region = np.flatnonzero(d_s + d_t <= 1.5 * d_s[t])
    states = routing._States(len(region), k)
    local = routing._local(g, region, k)
    start, end_vertex = states.hub(int(local[s])), int(local[t])
    for h in (None, d_t[region] * (1.0 - routing._SHRINK)):
        (dist, pred), (want, want_pred) = compiled_and_scipy(g, lat, extra, region, penalties, k, start,
                                                             3.0 * d_s[t], h)
        assert np.isfinite(dist).sum() > 50_000
        assert np.array_equal(dist, want)
        assert np.array_equal(pred, want_pred)
        end = routing._target_end(want, states, end_vertex)
        assert np.isfinite(want[end])
        assert routing._vertex_path(pred, start, end, region, states) == \
            routing._vertex_path(want_pred, start, end, region, states)


def _route_problem(seed: int, k: int):
    """A random street grid (:func:`random_map`), turn options of ``k`` heading bins, two of its live vertices
    ``s`` and ``t`` joined by a road, their plain distances over the roads and a route limit of 1.2-3 times the
    shortest plus one turn: the set-up the route search's state-for-state tests share (drawn in this order
    from the map's generator, which the tests draw on after)."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k)
    lat, extra = g.masks()
    live = g.live_vertices()
    s, t = (int(v) for v in rng.choice(live, 2, replace=False))
    with g.restricted(routing.ROAD_KINDS, None) as matrix:
        d_s, d_t = dijkstra(matrix, indices=[s, t])
    assume(np.isfinite(d_s[t]))
    limit = float(rng.uniform(1.2, 3.0)) * d_s[t] + opts.turn_height
    return g, rng, opts, lat, extra, s, t, d_s, d_t, limit


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]))
def test_a_star_with_scipys_tie_rule_walks_back_plain_dijkstras_routes_state_for_state(seed, k):
    """Issue 22 (session 36): the route search's A* on the graph's own weights (``ties``: keyed by
    ``g + h``, h the turn-free distance to the target, limit C on ``g + h``), scipy's predecessor rule
    applied as states relax, gives every state of a route found below C the distance and the
    predecessor scipy's Dijkstra with the limit C on ``g`` gives: from each of a few targets the
    route walked back is the same states with the same distances, on street grids full of exactly
    equal routes, while it searches fewer states."""
    g, rng, opts, lat, extra, s, t, d_s, d_t, limit = _route_problem(seed, k)
    region = np.flatnonzero(d_s + d_t <= limit)
    states = routing._States(len(region), k)
    local = routing._local(g, region, k)
    start = states.hub(int(local[s]))
    penalties = routing._bin_penalties(opts)
    made, _ = routing._expanded_graph(g, lat, extra, region, penalties, k)
    want, want_pred = dijkstra(made, indices=start, return_predecessors=True, limit=limit)
    h = d_t[region] * (1.0 - routing._SHRINK)
    dist, pred = routing._heading_search(g, lat, extra, region, local, penalties, k, start, limit, h=h,
                                         predecessors=True, ties=True)
    assert np.isfinite(dist).sum() <= np.isfinite(want).sum()
    end = routing._target_end(want, states, int(local[t]))
    assert routing._target_end(dist, states, int(local[t])) == end
    if not np.isfinite(want[end]):
        assert not np.isfinite(dist[end])
        return
    path = routing._walk_back(want_pred, start, end)
    assert routing._walk_back(pred, start, end) == path
    assert np.array_equal(dist[path], want[path])
    # every state A* kept within the limit has scipy's distance where g + h is within it, never less
    kept = np.isfinite(dist)
    assert (dist[kept] >= want[kept]).all()
    sure = kept & (want + states.per_state(h) < limit - 1e-6 * limit)
    assert np.array_equal(dist[sure], want[sure])


def _twice(x: float) -> float:
    return 2.0 * x


def test_the_compiled_search_compiles_uncached_where_numba_has_nowhere_to_cache_it(monkeypatch):
    """Review 6 (session 36): where neither the package's folder nor numba's user cache is writable,
    numba's ``njit(cache=True)`` raises RuntimeError when it decorates, so importing the search failed;
    the module's decorator compiles without the cache there instead."""
    import numba.core.caching
    from numba import njit

    from osm_expand.engine.roads import expanded_search

    monkeypatch.setattr(numba.core.caching.CacheImpl, "_locator_classes", [])
    with pytest.raises(RuntimeError, match="cannot cache"):
        njit(cache=True)(_twice)
    assert expanded_search._compiled()(_twice)(1.5) == 3.0


def tiny_expanded(n: int, k: int):
    """An expanded graph over ``n`` vertices without lattice vertices or other edges: each vertex's
    arrivals, departures and hub, joined by its turns alone."""
    from osm_expand.engine.roads.expanded_search import Expanded

    i64 = np.int64
    return Expanded(n=n, k=k, cheap=np.zeros(1, i64), cheap_cost=np.ones(1), hub_cost=5.0, eps=routing._EPS,
                    region=np.arange(n, dtype=i64), local=np.arange(n, dtype=np.int32), n_lat=0,
                    lat_kind=np.zeros((1, 1), np.uint8), allowed=np.zeros(256, bool), offset=np.zeros(1, i64),
                    dirs_ptr=np.zeros(k + 1, i64), dirs=np.zeros(0, i64), table=np.zeros(0),
                    plain=np.zeros((1, 1), np.float32), w_kind=np.zeros((1, 1), np.uint8),
                    e_ptr=np.zeros(n + 1, i64), e_bin=np.zeros(0, i64), e_col=np.zeros(0, i64), e_val=np.zeros(0))


def test_the_compiled_search_refuses_what_would_read_or_write_outside_its_arrays():
    """Review 4 (session 36): numba checks no bounds, so the wrapper does: a start below 0 (which
    wrapped round) or past the states (which wrote beyond them), a start that is not a hub with
    ``ties`` (whose key reads h of the hub's vertex), an h not of one value a vertex, and more
    states than the int32 predecessors number; a valid start still searches."""
    from osm_expand.engine.roads.expanded_search import expanded_dijkstra

    g = tiny_expanded(3, 4)
    size = 3 * 9
    h = np.zeros(3)
    for start in (-1, size, size + 5):
        with pytest.raises(ValueError, match="not among"):
            expanded_dijkstra(g, start, np.inf)
    with pytest.raises(ValueError, match="must be a hub"):
        expanded_dijkstra(g, 2 * 3 * 4 - 1, np.inf, h=h, return_predecessors=True, ties=True)
    with pytest.raises(ValueError, match="one per vertex"):
        expanded_dijkstra(g, size - 1, np.inf, h=np.zeros(2))
    with pytest.raises(ValueError, match="32 bits"):
        expanded_dijkstra(tiny_expanded(2**31 // 9 + 1, 4), 0, np.inf, return_predecessors=True)
    hub = 2 * 3 * 4 + 1
    dist, pred = expanded_dijkstra(g, hub, np.inf, h=h, return_predecessors=True, ties=True)
    assert dist[hub] == 0.0 and np.isfinite(dist[12 + 4:12 + 8]).all() and (pred[12 + 4:12 + 8] == hub).all()


def joined_reference(m: csr_matrix, seeds: np.ndarray, at: np.ndarray, limit: float) -> np.ndarray:
    """scipy's distances from a source joined to each seed at ``at`` (its row weighs ``at + 1``, the 1
    taken off after): how ``routing._via_exits`` searched the window's matrix up to session 36."""
    n = m.shape[0]
    indptr = np.concatenate([m.indptr, [m.indptr[-1] + len(seeds)]])
    joined = csr_matrix((np.concatenate([m.data, at + 1.0]), np.concatenate([m.indices, seeds.astype(m.indices.dtype)]),
                         indptr), shape=(n + 1, n + 1))
    return dijkstra(joined, indices=n, limit=limit + 1.0)[:n] - 1.0


def assert_plain_searches_are_scipys(g, kinds, street_ok, s: int, limit: float, seeds: np.ndarray,
                                     at: np.ndarray) -> int:
    """The compiled plain search against scipy's Dijkstra on G′'s own matrix (``restricted``, the
    reference): from ``s`` with predecessors and no limit, from ``s`` up to ``limit``, and from
    ``seeds`` joined at ``at`` (``_via_exits``): every distance and predecessor equal; the vertices
    reached from ``s``."""
    lat, extra = g.masks(kinds, street_ok)
    rows = routing._plain_rows(g, lat, extra)
    with g.restricted(kinds, street_ok) as m:
        want, want_pred = dijkstra(m, indices=s, return_predecessors=True)
        want_limited = dijkstra(m, indices=s, limit=limit)
        want_joined = joined_reference(m, seeds, at, limit)
    dist, pred = routing._plain_search(rows, [s], predecessors=True)
    assert np.array_equal(dist, want)
    assert np.array_equal(pred, want_pred)
    assert np.array_equal(routing._plain_search(rows, [s], limit=limit)[0], want_limited)
    assert np.array_equal(routing._via_exits(rows, seeds, at, limit), want_joined)
    # in two parts, as the route search runs it: up to a vertex t, then on up to a limit at least d(s, t)
    # chosen from what was found; cut to that limit, it is scipy's search with the limit from the start
    reached = np.flatnonzero(np.isfinite(want))
    for t in reached[:: max(1, len(reached) // 3)]:
        after = float(want[t]) * 1.3 + 10.0
        with g.restricted(kinds, street_ok) as m:
            want_after, want_after_pred = dijkstra(m, indices=s, return_predecessors=True, limit=after)
        search = PlainSearch(rows, np.array([s]), predecessors=True)
        assert search.run(stop=int(t))
        assert routing._walk_back(search.pred, s, int(t)) == routing._walk_back(want_pred, s, int(t))
        search.run(after)
        search.cut(after)
        assert np.array_equal(search.dist, want_after)
        assert np.array_equal(search.pred, want_after_pred)
    return int(np.isfinite(want).sum())


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["roads", "streets", "major", "land", "water"]), st.booleans())
def test_the_compiled_plain_search_is_scipys_vertex_for_vertex(seed, which, hill):
    """Issue 22 (session 37): the plain (turn-free) searches of a window (from the source with
    predecessors, from the target up to the bound, from the exits joined at their bounds) run
    compiled on G′'s tables, no matrix written; on a window of a random town (a street grid, a river
    with its bridges and harbours, forbidden blobs, on a hill or flat: float32 weights or weights by
    kind), with some streets refused and the kinds a route may use varied, every distance and
    predecessor is scipy's on the window's matrix, ties included (grids are full of exactly equal
    paths), so the plain route, the bounds and the routes keep their bytes."""
    from tests.test_majorroads import random_blobs, river

    rng = np.random.default_rng(seed)
    extent = (0, 0, 1000, 800)
    segs = SegmentTable.from_lines(grid_lines(300, 250, 3, 100), major=[bool(b) for b in rng.integers(0, 2, 8)],
                                   width=[6.0] * 8)
    built = built_up_area(blocks_of(segs), segs)
    xs = 5.0 + 10.0 * np.arange(100)
    ramp = np.broadcast_to(float(rng.uniform(0.05, 0.4)) * np.maximum(xs - 500, 0.0), (80, 100)).copy()
    y_lo = float(rng.uniform(100, 600))
    lat = build_lattice(extent, water=river(extent, y_lo, y_lo + 60),
                        forbidden=random_blobs(rng, extent, 4, within=(50, 950), radius=(20, 70)),
                        height=Raster(ramp, (0.0, 0.0), 10.0) if hill else None,
                        options=LatticeOptions(radius=int(rng.integers(1, 4)))).with_built_up(built.area)
    implicit = implicit_graph(lat, segs, built)
    x0, y0 = rng.uniform(0, 500), rng.uniform(0, 400)
    window = implicit.window((x0, y0, x0 + rng.uniform(200, 700), y0 + rng.uniform(200, 500)))
    g = window.graph
    kinds = {"roads": routing.ROAD_KINDS, "streets": (EdgeKind.MAJOR, EdgeKind.MINOR), "water": (EdgeKind.LAND,
             EdgeKind.WATER, EdgeKind.HARBOUR, EdgeKind.BUILT_HARBOUR),
             "major": (EdgeKind.MAJOR,), "land": (EdgeKind.LAND, EdgeKind.STITCH, EdgeKind.MINOR)}[which]
    street_ok = rng.random(len(segs.uv)) < 0.8 if rng.random() < 0.5 else None
    live = g.live_vertices()
    s = int(rng.choice(live))
    seeds = np.unique(rng.choice(g.n_vertices, int(rng.integers(1, 40))))
    at = rng.uniform(0.0, 400.0, len(seeds))
    assert_plain_searches_are_scipys(g, kinds, street_ok, s, float(rng.uniform(50.0, 800.0)), seeds, at)


def test_on_krems_the_compiled_plain_search_is_scipys_vertex_for_vertex(krems_town):  # noqa: F811
    """On a window of Krems' own G′ (its land, the Danube, its bridges, streets and stitches) round
    two of its exits, as the first road search makes it: the compiled plain searches give scipy's
    distances and predecessors on the window's matrix, vertex for vertex."""
    g_whole, segs, exits, _, implicit = krems_town
    ends = implicit.vertex_xy(np.array([g_whole.node_vertex(int(exits[0])), g_whole.node_vertex(int(exits[1]))]))
    lo, hi = ends.min(axis=0) - 400, ends.max(axis=0) + 400
    window = implicit.window((lo[0], lo[1], hi[0], hi[1]))
    g = window.graph
    s = int(window.from_map(np.array([g_whole.node_vertex(int(exits[0]))]))[0])
    c = routing.cheapest_unit_cost(implicit.costs, routing.ROAD_KINDS)
    rest = c * np.hypot(*(g.xy[window.exits] - ends[1]).T)
    reached = assert_plain_searches_are_scipys(g, routing.ROAD_KINDS, None, s, 3000.0, window.exits, rest)
    assert reached > 30_000


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_windows_source_distances_are_scipys_up_to_past_the_routes_cost(seed):
    """Issue 22 (session 37): the source's plain search stops at the target, then goes on only up to
    past the first bound (the plain route with its turns), which every reader compares them with:
    up to there every distance is scipy's on the whole window, beyond it ∞ — and the route, the
    one the window's matrix gave (a larger window grows by the exits within the route's cost)."""
    rng = np.random.default_rng(seed)
    implicit = random_town(rng)
    live = implicit.whole().live_vertices()
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)))
    checked = 0
    for _ in range(3):
        s_map, t_map = (int(v) for v in rng.choice(live, 2, replace=False))
        ends = implicit.vertex_xy(np.array([s_map, t_map]))
        lo, hi = ends.min(axis=0) - 150, ends.max(axis=0) + 150
        window = implicit.window((lo[0], lo[1], hi[0], hi[1]))
        g = window.graph
        s, t = (int(v) for v in window.from_map(np.array([s_map, t_map])))
        route, from_source, _ = routing._search(g, s, t, routing.ROAD_KINDS, None, opts)
        with g.restricted(routing.ROAD_KINDS, None) as m:
            want, want_pred = dijkstra(m, indices=s, return_predecessors=True)
        if route is None:
            assert np.array_equal(from_source, want)
            continue
        kept = np.isfinite(from_source)
        assert np.array_equal(from_source[kept], want[kept])
        # what is cut lies above the first bound, d(s, t) + the plain route's turns, the value the cut is
        # made from (the route's cost is at most that: a weaker test)
        lat, extra = g.masks(routing.ROAD_KINDS, None)
        plain_route = routing._route(g, routing._walk_back(want_pred, s, t), lat, extra, 0.0)
        bins = routing._bins(routing._headings(plain_route), opts.heading_bins)
        plain_turns = float(routing._bin_penalties(opts)[(bins[1:] - bins[:-1]) % opts.heading_bins].sum())
        assert route.cost <= float(want[t]) + plain_turns + 1e-6
        assert (want[~kept] > float(want[t]) + plain_turns).all()
        checked += 1
    assume(checked > 0)


def star_plain_graph(n_edges: int, seed: int = 0):
    """A plain G′ with no lattice: vertex 0 joined to each of ``n_edges`` others by one edge (random
    weights, some equal), and each of those back to 0."""
    from osm_expand.engine.roads.expanded_search import Plain

    rng = np.random.default_rng(seed)
    n = n_edges + 1
    heads = np.arange(1, n, dtype=np.int64)
    weights = rng.integers(1, 50, n_edges).astype(np.float64)
    e_ptr = np.concatenate(([0], n_edges + np.arange(n, dtype=np.int64)))
    e_col = np.concatenate((heads, np.zeros(n_edges, dtype=np.int64)))
    e_val = np.concatenate((weights, weights))
    graph = Plain(n=n, n_lat=0, lat_kind=np.zeros((0, 8), dtype=np.uint8), allowed=np.ones(256, dtype=np.bool_),
                  offset=np.zeros(8, dtype=np.int64), table=np.empty(0), plain=np.zeros((1, 1), dtype=np.float32),
                  w_kind=np.zeros((1, 1), dtype=np.uint8), e_ptr=e_ptr, e_col=e_col, e_val=e_val)
    rows = np.repeat(np.arange(n), np.diff(e_ptr))
    return graph, csr_matrix((e_val, (rows, e_col)), shape=(n, n))


def test_the_plain_search_grows_its_heap_for_a_vertex_with_more_edges_than_it_has_rows():
    """Review of session 37: the plain scan doubled its heap once before a vertex's row, so a vertex
    of more edges than twice the heap's 4,096 rows wrote past its end (numba checks no bounds: the
    process died). Now it grows until the row fits, and the search is scipy's."""
    from osm_expand.engine.roads.expanded_search import plain_dijkstra

    graph, matrix = star_plain_graph(50_000)
    dist, pred = plain_dijkstra(graph, np.array([0]), return_predecessors=True)
    want, want_pred = dijkstra(matrix, indices=0, return_predecessors=True)
    assert np.array_equal(dist, want)
    assert np.array_equal(pred, want_pred)


def test_a_plain_search_refuses_a_limit_above_its_last_one():
    """Review of session 37: what a limit kept out was never pushed, so a later, larger limit would
    miss it silently; the search keeps its last limit and refuses a larger one (an equal one and no
    limit at all go on)."""
    graph, matrix = star_plain_graph(100)
    search = PlainSearch(graph, np.array([0]), limit=20.0)
    search.run()
    search.run(20.0)
    assert np.array_equal(search.dist, dijkstra(matrix, indices=0, limit=20.0))
    with pytest.raises(ValueError, match="only fall"):
        search.run(30.0)
    search.run(10.0)
    search.cut(10.0)
    assert np.array_equal(search.dist, dijkstra(matrix, indices=0, limit=10.0))


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]), st.booleans(), st.integers(1, 5))
def test_a_search_gone_on_over_grown_tiles_ends_as_the_search_from_scratch_state_for_state(seed, k, ties, cells):
    """Issue 22 (session 38): the tiled search goes on from its last search when its tiles grow and C
    holds (``expanded_dijkstra``'s ``resume``, the departures with an edge into the added tiles scanned
    again, ``routing._again``), where it searched from scratch each time (the synthetic 10,000-street
    town's first road: four searches of 2.2, 4.6, 9.9 and 20 M states). On random street grids full of
    routes of exactly equal cost, by A* with the route's tie rule or on reduced costs (the exits'
    search), every state ends with the distance (and, with the tie rule, the predecessor) the search
    from scratch over the grown tiles gives."""
    from osm_expand.engine.roads.expanded_search import Resume

    g, rng, opts, lat, extra, s, t, d_s, d_t, limit = _route_problem(seed, k)
    in_region = d_s + d_t <= limit
    region = np.flatnonzero(in_region)
    states = routing._States(len(region), k)
    numbers = routing._local(g, region, k)
    tile, shape = routing._tile_of(g, cells)
    first = np.zeros(shape[0] * shape[1], dtype=bool)
    first[tile[s]] = True
    first = routing._dilated(first, shape)
    grown = first | (rng.random(len(first)) < rng.uniform(0.1, 0.9))
    penalties = routing._bin_penalties(opts)
    h = d_t[region] * (1.0 - routing._SHRINK)
    start = states.hub(int(numbers[s]))

    def search(active: np.ndarray, resume=None):
        local = numbers.copy()
        local[~(in_region & active[tile])] = -1
        return routing._heading_search(g, lat, extra, region, local, penalties, k, start, limit, h=h,
                                       predecessors=ties, ties=ties, resume=resume)

    before, after = in_region & first[tile], in_region & grown[tile]
    dist, pred = search(first)
    seeds = routing._again(g, lat, extra, numbers, before, after & ~before, tile, shape, states,
                           routing._bins(g.direction_heading, k), routing._bins(g.heading, k),
                           -(-g.lattice.radius // cells))
    got, got_pred = search(grown, Resume(dist.copy(), pred.copy(), seeds))
    want, want_pred = search(grown)
    assert np.array_equal(got, want)
    assert np.array_equal(got_pred, want_pred)
    if (after & ~before).any() and np.isfinite(want).sum() > np.isfinite(dist).sum():
        assert len(seeds)  # the added tiles were reached through the states scanned again


def _heading_searches():
    """Two stand-ins for ``routing._heading_search``: one that always searches from scratch (its ``resume``
    dropped) and one that records in the list returned with them whether each call went on."""
    heading_search = routing._heading_search
    resumed: list[bool] = []

    def from_scratch(*args, resume=None, **kwargs):
        return heading_search(*args, **kwargs)

    def counted(*args, resume=None, **kwargs):
        resumed.append(resume is not None)
        return heading_search(*args, resume=resume, **kwargs)

    return from_scratch, counted, resumed


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]))
def test_the_tiled_search_going_on_finds_the_routes_and_arrivals_of_searches_from_scratch(seed, k):
    """Issue 22 (session 38): ``_tiled_search`` going on from its last search as its tiles grow gives the
    routes (vertex for vertex, the same cost) and the exits' arrival costs that searching each time
    from scratch gives, and it does go on (tiles of 1–3 vertices, never the region at once)."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k, whole_region=0,
                          tile_cells=int(rng.integers(1, 4)))
    live = g.live_vertices()
    from_scratch, counted, resumed = _heading_searches()

    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(routing, "_heading_search", from_scratch)
            want = routing.find_route(g, s, t, options=opts)
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(routing, "_heading_search", counted)
            got = routing.find_route(g, s, t, options=opts)
        # above the cap (``resume_states``) each search numbers the active states and starts again
        capped = len(resumed)
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(routing, "_heading_search", counted)
            alone = routing.find_route(g, s, t, options=replace(opts, resume_states=0))
        assert not any(resumed[capped:])
        del resumed[capped:]
        assert (got is None) == (want is None) == (alone is None)
        if got is not None and alone is not None:
            assert np.array_equal(got.vertices, want.vertices)
            assert np.array_equal(alone.vertices, want.vertices)
            assert got.cost == want.cost == alone.cost
    assume(any(resumed))


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_exits_search_going_on_gives_the_arrivals_of_searches_from_scratch(seed):
    """Issue 22 (session 38): the exits' search (``_tiled_search`` without a target: A* on reduced
    costs) going on from its last search as its tiles grow gives every exit the very arrival cost
    that searching each time from scratch gives (tiles of 1–3 vertices, never the region at once)."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), whole_region=0,
                          tile_cells=int(rng.integers(1, 4)))
    lat, extra, live, s, t, straight, from_source = _exits_problem(g, rng)
    assume(np.isfinite(from_source[t]))
    penalties = routing._bin_penalties(opts)
    cost = float(from_source[t] + straight[s] + rng.uniform(0.5, 3.0) * opts.turn_height)
    exits = rng.choice(live, min(200, len(live)), replace=False)
    from_scratch, counted, resumed = _heading_searches()

    def arrivals(search):
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(routing, "_heading_search", search)
            return routing._tiled_search(g, lat, extra, s, None, from_source + straight, straight, ([s], cost),
                                         np.array([s]), penalties, opts, g.xy[t], exits=exits)[1]

    want, got = arrivals(from_scratch), arrivals(counted)
    assert np.array_equal(got, want)
    assume(any(resumed))


def test_a_search_goes_on_after_c_falls_only_where_the_states_left_out_lie_above_the_new_limit():
    """Issue 22 (session 38): ``_goes_on`` goes on while C holds, refuses a dearer C, and after C falls
    goes on only where every state of the vertices the region loses has ``g + h`` above the new C
    (plus the slack): here a vertex the source reaches at once is left out, and it must refuse."""
    g, rng = random_map(3)
    k = 8
    opts = RoutingOptions(heading_bins=k)
    lat, extra = g.masks()
    live = g.live_vertices()
    s = int(live[0])
    region = np.arange(g.n_vertices)
    states = routing._States(len(region), k)
    local = routing._local(g, region, k)
    h = np.zeros(g.n_vertices)
    dist, pred = routing._heading_search(g, lat, extra, region, local, routing._bin_penalties(opts), k,
                                         states.hub(int(local[s])), 1e9, h=h, predecessors=True, ties=True)
    inside = np.ones(g.n_vertices, dtype=bool)
    kept = (100.0, region, inside, dist, pred)
    assert routing._goes_on(kept, 100.0, inside, h, k)  # C holds
    assert not routing._goes_on(kept, 200.0, inside, h, k)  # never a dearer C
    assert routing._goes_on(kept, 50.0, inside, h, k)  # C fell, no vertex left out
    arrive, depart, hub = states.by_vertex(dist)
    far = np.minimum(np.minimum(arrive.min(axis=1), depart.min(axis=1)), hub) > 60.0
    assert far.any() and not far.all()
    assert routing._goes_on(kept, 50.0, ~far, h, k)  # the vertices left out: all their states above it
    near = inside.copy()
    near[s] = False  # the source's hub: g = 0, below any C
    assert not routing._goes_on(kept, 50.0, near, h, k)
    # on A*'s reduced costs (the exits' search) g + h is dist + h(source), not dist + h
    assert routing._goes_on(kept, 50.0, near, h + 1e6, k)
    assert not routing._goes_on(kept, 50.0, near, h + 1e6, k, 0.0)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_a_search_gone_on_after_c_falls_has_the_states_of_one_from_scratch_within_the_new_limit(seed, exits):
    """Issue 22 (session 38): where C falls and ``_tiled_search`` goes on (``_goes_on``), every state
    within the new limit (``g + h``; the reduced distance on reduced costs) has the distance, and with
    the tie rule the predecessor, that the search from scratch over the same states gives."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), whole_region=0,
                          tile_cells=int(rng.integers(1, 4)))
    live = g.live_vertices()
    heading_search = routing._heading_search
    fell = []
    limits = []

    def checked(graph, lat, extra, full, local, penalties, k, start, limit, *, h, resume=None, **kwargs):
        if resume is None:
            limits.append(limit)
            return heading_search(graph, lat, extra, full, local, penalties, k, start, limit, h=h, **kwargs)
        want, want_pred = heading_search(graph, lat, extra, full, local, penalties, k, start, limit, h=h, **kwargs)
        got, got_pred = heading_search(graph, lat, extra, full, local, penalties, k, start, limit, h=h,
                                       resume=resume, **kwargs)
        ties = kwargs.get("ties", False)
        within = want + (routing._States(len(full), k).per_state(h) if ties else 0.0) <= limit
        assert np.array_equal(got[within], want[within])
        if ties:
            assert np.array_equal(got_pred[within], want_pred[within])
        fell.append(limit < limits[-1])
        limits.append(limit)
        return got, got_pred

    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(routing, "_heading_search", checked)
        for _ in range(3):
            s, t = (int(v) for v in rng.choice(live, 2, replace=False))
            if exits:
                route = routing.find_route(g, s, t, options=opts)
                if route is None:
                    continue
                lat, extra = g.masks()
                c = routing.cheapest_unit_cost(EdgeCosts(), routing.ROAD_KINDS)
                straight = c * np.hypot(*(g.xy - g.xy[t]).T)
                from_source = dijkstra(g.matrix(), indices=s)
                routing._tiled_search(g, lat, extra, s, None, from_source + straight, straight,
                                      (route.vertices.tolist(), route.cost * 1.5), route.vertices,
                                      routing._bin_penalties(opts), opts, g.xy[t],
                                      exits=rng.choice(live, min(50, len(live)), replace=False))
            else:
                routing.find_route(g, s, t, options=opts)
    assume(any(fell))


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]), st.floats(1.0, 1.5))
def test_the_turns_in_the_corridor_keep_the_bound_consistent_and_below_the_cost_to_go(seed, k, stretch):
    """Issue 22 (session 40): the turns still to make searched only in the corridor of a cost C
    (``_turns_to_go`` with the limit ``C − d_s(v) − D(v)`` per vertex, d_s and D the plain distances
    from the source and to the target: what the route search gives it) make a bound ``D + T`` that
    is consistent on every edge of the expanded graph with its own weights, at least D, and never
    above the exact cost from a state to the target (scipy's Dijkstra backwards on the written
    graph), whatever C is: the route search's bound stays exact while T's search stays in the
    states a route within C can reach."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k)
    lat, extra = g.masks()
    live = g.live_vertices()
    s, t = (int(v) for v in rng.choice(live, 2, replace=False))
    penalties = routing._bin_penalties(opts)
    rows = routing._plain_rows(g, lat, extra)
    from_source, _ = routing._plain_search(rows, [s])
    from_target, _ = routing._plain_search(rows, [t])
    lower = from_source + from_target
    assume(np.isfinite(lower[s]))
    # C: the plain distance stretched (a route's cost with its turns lies above it)
    cost = float(lower[s]) * stretch + float(rng.uniform(0, 2)) * float(penalties.max())
    region = np.flatnonzero(lower <= cost)
    states = routing._States(len(region), k)
    local = routing._local(g, region, k)
    T = routing._turns_to_go(g, lat, extra, region, penalties, k, t, cost - lower[region])
    assert (T >= 0).all() and np.isfinite(T).all()
    made, _ = routing._expanded_graph(g, lat, extra, region, penalties, k)
    bound = from_target[region][states.vertex(np.arange(states.size))] + T
    rows_of = np.repeat(np.arange(made.shape[0]), np.diff(made.indptr))
    assert (bound[rows_of] <= made.data + bound[made.indices] + 1e-9).all()
    back = made.transpose().tocsr()
    exact = dijkstra(back, indices=states.arrivals(int(local[t])), min_only=True)
    assert (bound <= exact + 1e-9).all()
    # stopped after a budget of states (``RoutingOptions.turn_share``): clamped at the cost it had reached,
    # still consistent and below the cost to go
    part = routing._turns_to_go(g, lat, extra, region, penalties, k, t, cost - lower[region],
                                int(rng.integers(0, states.size)))
    assert np.array_equal(part, np.minimum(T, part.max()))
    bound = from_target[region][states.vertex(np.arange(states.size))] + part
    assert (bound[rows_of] <= made.data + bound[made.indices] + 1e-9).all()
    assert (bound <= exact + 1e-9).all()


@settings(max_examples=12, deadline=None)
@example(4_267_211_612, 16, True)  # seeds keyed (g + h) + T, pops g + (h + T): a resumed seed skipped
@example(2470, 8, True)  # two routes of equal cost (2,359.73): T's search takes the other one
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]), st.booleans())
def test_the_turns_still_to_make_are_consistent_and_keep_the_routes(seed, k, tiles):
    """Issue 22 (session 39): the least turn cost from each state to the target (``_turns_to_go``, the
    expanded graph searched backwards on its turn penalties alone, compiled) is consistent on every
    edge of it (``T(x) ≤ t(x, y) + T(y)``, t the edge's turn cost, 0 for a move), clamped at a limit
    too, and 0 on the target's arrivals; added to the plain distance as the route search's bound
    (``RoutingOptions.turn_bound``) it finds routes of the very cost of the search by the plain distance
    alone, between the same ends, whole regions or growing tiles (examples where no search used T,
    a route found at once or a region above the cap, are not counted). The states searched are not
    compared: summed over the tile rounds they are no invariant (with T the growth test may grow
    other tiles). Where two routes cost the same to the last bit, the search with T may take the other one
    (issue 22 asks for a route of equal cost; session 41's CI drew seed 2470: the same 74 vertices' cost,
    another path): what is compared is the cost found by both and each route's ends."""
    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), heading_bins=k,
                          whole_region=0 if tiles else 100_000, tile_cells=int(rng.integers(1, 4)))
    lat, extra = g.masks()
    live = g.live_vertices()
    s, t = (int(v) for v in rng.choice(live, 2, replace=False))
    penalties = routing._bin_penalties(opts)
    region = np.arange(g.n_vertices)
    states = routing._States(len(region), k)
    T = routing._turns_to_go(g, lat, extra, region, penalties, k, t)
    assert (T[states.arrivals(t)] == 0.0).all()
    made, _ = routing._expanded_graph(g, lat, extra, region, penalties, k)
    nk = states.n * k
    rows_of = np.repeat(np.arange(made.shape[0]), np.diff(made.indptr))
    turn = np.where((rows_of >= nk) & (rows_of < 2 * nk), 0.0, made.data)
    tail, head = T[rows_of], T[made.indices]
    reach = np.isfinite(head)
    assert (tail[reach] <= turn[reach] + head[reach] + 1e-9).all()
    # the least, as scipy finds it backwards on the written graph with the turns' own costs (without the
    # floor ε: the arrivals' rows their cheap turns and the hub, first; the hubs' rows last, free; a free
    # edge 10⁻³⁰⁰: scipy reads 0 as no edge)
    raw = turn.copy()
    cheap, _, _ = routing._turn_rows(penalties)
    raw[:nk * (len(cheap) + 1)].reshape(-1, len(cheap) + 1)[:] = np.append(penalties[cheap], penalties.max())
    raw[-nk:] = 0.0
    back = csr_matrix((np.maximum(raw, 1e-300), made.indices, made.indptr), shape=made.shape).transpose().tocsr()
    want = dijkstra(back, indices=states.arrivals(t), min_only=True)
    assert np.array_equal(np.isfinite(T), np.isfinite(want))
    assert np.allclose(T[np.isfinite(T)], want[np.isfinite(want)], rtol=0, atol=1e-9)
    # clamped at a limit (the search's: the turns the best route so far may make) it stays consistent
    cut = float(np.median(T[np.isfinite(T)])) + 1.0
    clamped = routing._turns_to_go(g, lat, extra, region, penalties, k, t, cut)
    assert np.array_equal(clamped, np.minimum(T, cut))
    assert (clamped[rows_of] <= turn + clamped[made.indices] + 1e-9).all()
    used = []
    heading_search = routing._heading_search
    share = float(rng.choice([1.0, 0.3, 0.05]))  # T's search whole in its corridor, or stopped short

    def counted(*args, **kwargs):
        used.append(kwargs.get("turns") is not None)
        return heading_search(*args, **kwargs)

    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(routing, "_heading_search", counted)
        want = routing.find_route(g, s, t, options=replace(opts, turn_bound=0))
        got = routing.find_route(g, s, t, options=replace(opts, turn_bound=10**9, turn_share=share))
    assume(any(used))
    assert (want is None) == (got is None)
    if want is not None:
        assert got.cost == want.cost
        assert (got.vertices[0], got.vertices[-1]) == (want.vertices[0], want.vertices[-1])


@settings(max_examples=20, deadline=None)
@example(0, 8, True)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 8, 16]), st.booleans())
def test_the_turns_of_a_smaller_region_are_its_states_taken_from_the_first(seed, k, whole):
    """``_turns_over`` gives each state of a smaller region (a subset of the first, both sorted) the T of
    the same state (vertex and slot) of the first region, as a state-by-state gather does, and refuses
    a region not within the first (the compiled search reads T without bounds checks)."""
    rng = np.random.default_rng(seed)
    first = np.sort(rng.choice(500, int(rng.integers(1, 60)), replace=False))
    full = first if whole else np.sort(rng.choice(first, int(rng.integers(0, len(first) + 1)), replace=False))
    big, small = routing._States(len(first), k), routing._States(len(full), k)
    to_go = rng.uniform(0, 100, big.size)
    got = routing._turns_over(to_go, first, full, k)
    rank = np.searchsorted(first, full)
    v = np.repeat(np.arange(len(full)), 2 * k + 1)
    slot = np.tile(np.arange(2 * k + 1), len(full))
    want = np.empty(small.size)
    want[small.state(v, slot)] = to_go[big.state(rank[v], slot)]
    assert np.array_equal(got, want)
    outside = np.setdiff1d(np.arange(501), first)
    if len(full):
        wrong = np.sort(np.append(full[1:], rng.choice(outside)))
        with pytest.raises(ValueError, match="not within"):
            routing._turns_over(to_go, first, wrong, k)


def test_the_turns_search_refuses_arrays_it_would_read_out_of():
    """``expanded_search.turns_to_go`` is public and its compiled search reads without bounds checks: edges
    by head whose counts, tails or bins do not fit the graph, or turn costs not one per cheap turn, are
    refused before it runs; the arrays ``routing._turns_to_go`` makes are taken."""
    from osm_expand.engine.roads.expanded_search import turns_to_go

    g, _ = random_map(3)
    k = 8
    lat, extra = g.masks()
    region = np.arange(g.n_vertices)
    penalties = routing._bin_penalties(RoutingOptions(heading_bins=k))
    local = routing._local(g, region, k).astype(np.int32)
    rows = routing._expanded_rows(g, lat, extra, region, local, penalties, k)
    n = len(region)
    ends = routing._States(n, k).arrivals(0)
    ptr = np.zeros(n + 1, dtype=np.int64)
    ptr[1:] = 1  # one edge into vertex 0
    src, bins = np.array([1]), np.array([0])
    cost = np.maximum(penalties, 0.0)[rows.cheap]
    T = turns_to_go(rows, ends, ptr, src, bins, np.inf, cost, float(penalties.max()))
    assert len(T) == routing._States(n, k).size and (T[ends] == 0.0).all()
    bad = [(ptr, src, bins, cost[:-1]),  # a turn cost short
           (ptr, np.array([1, 2]), bins, cost),  # more tails than the edges counted
           (ptr, src, np.array([0, 1]), cost),  # more bins than the edges counted
           (ptr, np.array([n]), bins, cost),  # a tail past the vertices
           (ptr, np.array([-1]), bins, cost),  # a tail before them
           (ptr, src, np.array([k]), cost),  # a bin past the k
           (ptr[:-1], src, bins, cost)]  # not one run per vertex
    for p, s, b, c in bad:
        with pytest.raises(ValueError):
            turns_to_go(rows, ends, p, s, b, np.inf, c, float(penalties.max()))
    with pytest.raises(ValueError):  # a limit per vertex, one short
        turns_to_go(rows, ends, ptr, src, bins, np.zeros(n - 1), cost, float(penalties.max()))
