"""Issue 22 (session 42): the exits' search of a route's window pauses, and stops where what it has
found already settles the next window (``expanded_search.expanded_steps``, ``routing._Growth``)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.engine.roads import path_graph, routing
from osm_expand.engine.roads.expanded_search import expanded_dijkstra, expanded_steps
from osm_expand.engine.roads.routing import RoutingOptions
from tests.test_majorroads import random_town
from tests.test_routing_search import _route_problem, random_map


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16]), st.sampled_from(["plain", "reduced", "ties"]))
def test_a_search_paused_and_gone_on_is_the_search_run_whole_state_for_state(seed, k, mode):
    """Paused after a few popped entries at a time and gone on with from the states it left queued, the
    compiled search scans the same states in the same order as one run whole: on random street grids
    full of routes of exactly equal cost, plain, on A*'s reduced costs (the exits' search) and by A*
    with the route's tie rule, every state ends with the same distance and predecessor, to the bit.
    While paused, every distance is an upper bound of its end (what the exits' early stop reads)."""
    g, rng, opts, lat, extra, s, t, d_s, d_t, limit = _route_problem(seed, k)
    region = np.flatnonzero(d_s + d_t <= limit)
    states = routing._States(len(region), k)
    local = routing._local(g, region, k)
    rows = routing._expanded_rows(g, lat, extra, region, local, routing._bin_penalties(opts), k)
    start = states.hub(int(local[s]))
    h = None if mode == "plain" else d_t[region] * (1.0 - routing._SHRINK)
    ties = mode == "ties"
    want, want_pred = expanded_dijkstra(rows, start, limit, h=h, return_predecessors=True, ties=ties)
    resume, pauses, seen = None, 0, []
    while True:
        dist, pred, resume = expanded_steps(rows, start, limit, h=h, return_predecessors=True, ties=ties,
                                            resume=resume, budget=int(rng.integers(1, 200)))
        if resume is None:
            break
        pauses += 1
        if len(seen) < 5:
            seen.append(dist.copy())
    assert np.array_equal(dist, want)
    assert np.array_equal(pred, want_pred)
    for before in seen:
        assert (before >= dist).all()
    assert pauses > 0 or np.isfinite(want).sum() < 200


def test_a_search_left_with_no_budget_pauses_before_its_first_pop_and_goes_on_from_its_start():
    g, _ = random_map(7)
    lat, extra = g.masks()
    region = g.live_vertices()
    local = routing._local(g, region, 16)
    rows = routing._expanded_rows(g, lat, extra, region, local, routing._bin_penalties(RoutingOptions()), 16)
    start = routing._States(len(region), 16).hub(0)
    limit = 2000.0
    dist, _, paused = expanded_steps(rows, start, limit, budget=0)
    assert paused is not None and paused.seeds.tolist() == [start]
    assert np.isfinite(dist).sum() == 1
    dist, _, paused = expanded_steps(rows, start, limit, resume=paused)
    assert paused is None
    assert np.array_equal(dist, expanded_dijkstra(rows, start, limit)[0])


def _growth(rng: np.random.Generator) -> tuple[routing._Growth, np.ndarray, np.ndarray]:
    """A random window with exits round its sides (and a few inside, as long bridges' ends), a target
    beyond it, its best cost and the exits' plain distances and true arrival costs (some ∞)."""
    size = rng.uniform(500, 3000, 2)
    lo = rng.uniform(0, 5000, 2)
    bounds = np.concatenate([lo, lo + size])
    reach = float(rng.uniform(50, 250))
    inside = bounds + np.array([10.0, 10.0, -10.0, -10.0])
    n = int(rng.integers(5, 300))
    side = rng.integers(0, 5, n)  # 4: inside (a bridge's end)
    along = lo + rng.uniform(0, 1, (n, 2)) * size
    depth = rng.uniform(0, reach, n)
    x = np.select([side == 0, side == 2], [inside[0] + depth, inside[2] - depth], along[:, 0])
    y = np.select([side == 1, side == 3], [inside[1] + depth, inside[3] - depth], along[:, 1])
    exit_xy = np.stack([x, y], axis=1)
    target = bounds[:2] + size * rng.uniform(0.2, 0.8, 2)
    c = float(rng.uniform(0.3, 1.0))
    rest = c * np.hypot(*(exit_xy - target).T)
    cost = float(rng.uniform(1.0, 3.0) * rest.max())
    plain = rng.uniform(0, 0.5, n) * cost
    arrive = plain + rng.uniform(0, 1.0, n) * cost
    arrive[rng.random(n) < 0.2] = np.inf
    growth = routing._Growth(bounds, inside, exit_xy, rest, target, cost, c, reach, float(rng.uniform(0.05, 1.0)))
    return growth, plain, arrive


def _next_window(growth: routing._Growth, reached: np.ndarray, whole: np.ndarray, least: float):
    """The window ``_implicit_route`` searches next (the map's bounds where it covers more than ``least``)."""
    nxt = growth.next(reached)
    if nxt is not None and routing._seen(nxt, whole) > least:
        return whole
    return nxt


def test_what_settles_the_next_window_settles_it_whatever_the_exits_search_still_finds():
    """``_Growth.settles`` says yes to bounds of the exits' arrivals (what a paused search has found: the
    scanned exits' own values, above them an upper bound, ∞ where it has not reached an exit yet, and
    where the search is in its last round a lower bound) only where the window made from the true
    arrivals, which are lower and may make more exits short, is the one made from the upper bounds:
    the map, the growth's cap, the window the lower bounds make too, or none (no exit short)."""
    fired = {"map": 0, "cap": 0, "bracket": 0, "none": 0}
    for seed in range(4000):
        rng = np.random.default_rng(seed)
        growth, plain, arrive = _growth(rng)
        whole = growth.bounds + rng.uniform(0.5, 3.0) * np.array([-1, -1, 1, 1]) * (growth.bounds[2] - growth.bounds[0])
        least = float(rng.uniform(0.2, 0.8) * routing._seen(whole, whole))
        done = rng.random(len(plain)) < rng.uniform(0, 1)  # the exits scanned so far: their own values
        upper = np.where(done, arrive, np.where(rng.random(len(plain)) < 0.5, np.inf,
                                                arrive + rng.exponential(0.05, len(plain)) * growth.cost))
        lower = None
        if rng.random() < 0.5:
            lower = np.where(done, arrive, np.maximum(arrive - rng.exponential(0.02, len(plain)) * growth.cost, 0.0))
        if not growth.settles(plain, whole, least, upper, lower):
            continue
        got = _next_window(growth, np.maximum(plain, upper), whole, least)
        want = _next_window(growth, np.maximum(plain, arrive), whole, least)
        if got is None:
            assert want is None
            fired["none"] += 1
            continue
        assert want is not None and np.array_equal(got, want)
        fired["map" if got is whole else "cap" if np.array_equal(got, growth.cap) else "bracket"] += 1
    assert fired["none"] >= 1 and min(fired["map"], fired["cap"], fired["bracket"]) >= 100, fired


def test_a_window_whose_short_exits_are_all_away_from_its_sides_is_never_settled():
    """Where no short exit lies near a side, ``_grown`` doubles the window, which a later exit near a
    side would undo: the search is not stopped there."""
    rng = np.random.default_rng(3)
    growth, plain, arrive = _growth(rng)
    centre = 0.5 * (growth.inside[:2] + growth.inside[2:])
    growth = replace(growth, exit_xy=np.tile(centre, (len(plain), 1)))
    whole = growth.bounds + np.array([-1e5, -1e5, 1e5, 1e5])
    assert growth.next(np.zeros(len(plain))) is not None
    assert not growth.settles(plain, whole, 0.0, np.zeros(len(plain)))


@pytest.mark.parametrize("first_pause", [64, routing._FIRST_PAUSE])
def test_routes_and_windows_are_those_of_exits_searches_run_to_their_end(monkeypatch, first_pause):
    """On random towns, routes searched in growing windows (``_implicit_route``) with the exits' search
    stopped early go through the same windows to the same routes, vertex for vertex and cost for
    cost, as with every exits' search run to its end (paused more often than in a run, too)."""
    windows: list[tuple[float, ...]] = []
    real_window = path_graph.ImplicitGraph.window
    real_settles = routing._Growth.settles
    stops = []

    def recorded(self, bounds):
        windows.append(tuple(bounds))
        return real_window(self, bounds)

    def counted(self, *args):
        stops.append(real_settles(self, *args))
        return stops[-1]

    monkeypatch.setattr(path_graph.ImplicitGraph, "window", recorded)
    monkeypatch.setattr(routing, "_FIRST_PAUSE", first_pause)
    for seed in range(6):
        rng = np.random.default_rng(seed)
        implicit = random_town(rng)
        live = implicit.whole().live_vertices()
        opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)), window_margin=float(rng.uniform(20, 200)),
                              window_share=0.0, growth_share=float(rng.uniform(0.1, 0.5)))
        pairs = [tuple(int(v) for v in rng.choice(live, 2, replace=False)) for _ in range(3)]
        runs = []
        for settles in (counted, lambda *args: False):
            monkeypatch.setattr(routing._Growth, "settles", settles)
            found = []
            for s, t in pairs:
                windows.clear()
                route = routing.find_route(implicit, s, t, options=opts)
                found.append((list(windows), None if route is None else (route.vertices.tolist(), route.cost)))
            runs.append(found)
        assert runs[0] == runs[1]
    assert sum(stops) >= 5


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_a_paused_exits_search_bounds_the_arrivals_it_ends_with(seed, at_once):
    """At every pause of the exits' search (``_tiled_search`` without a target, paused every 16 popped
    entries here), the bounds ``_arrival_bounds`` makes hold the arrivals the search ends with: never
    above the upper bound, never below the lower one (made only where the region is searched at once:
    its one round is its last), and equal to both for the exits already scanned, to the bit."""
    from tests.test_routing_search import _exits_problem

    g, rng = random_map(seed)
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), tile_cells=int(rng.integers(1, 5)),
                          whole_region=10**6 if at_once else 0)
    lat, extra, live, s, t, straight, from_source = _exits_problem(g, rng)
    if not np.isfinite(from_source[t]):
        return
    penalties = routing._bin_penalties(opts)
    exits = rng.choice(live, min(200, len(live)), replace=False)
    cost = float(rng.uniform(1.0, 2.0) * (from_source[t] + opts.turn_height))
    seen = []
    real = routing._arrival_bounds

    def recorded(*args):
        seen.append(real(*args))
        return seen[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(routing, "_arrival_bounds", recorded)
        patch.setattr(routing, "_FIRST_PAUSE", 16)
        _, got = routing._tiled_search(g, lat, extra, s, None, from_source + straight, straight, ([s], cost),
                                       np.array([s]), penalties, opts, g.xy[t], exits=exits,
                                       settled=lambda upper, lower: False)
    assert got is not None
    for upper, lower in seen:
        assert (got <= upper).all()
        assert (lower is None) == (not at_once)
        if lower is not None:
            assert (lower <= got).all()
            exact = lower == upper
            assert np.array_equal(got[exact], upper[exact])
    assert len(seen) > 0 or np.isfinite(got).sum() < 3
