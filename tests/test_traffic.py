"""Traffic kernels of the maturation engine on small hand-built maps.

Neighbouring cities (003 §3.1, §3.5), trade routes and Algorithm 2 (003
§3.4), Weber's trips, planned → built and widths (002 §3.2).
"""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from osm_expand.engine.traffic.neighbours import (
    NeighbourKind,
    NeighbourOptions,
    initial_pairs,
    neighbour_cities,
    neighbour_pairs,
)
from osm_expand.engine.traffic.trade import (
    TradeOptions,
    add_route,
    assign_increase,
    extend_segments,
    new_trade_state,
    pair_capacity,
    redistribute,
    remap_segments,
    segment_capacity,
    segments_with_room,
    trade_report,
    trade_year,
)
from osm_expand.engine.traffic.trade_routes import initial_trade_state, route_between
from osm_expand.engine.traffic.trips import (
    TripOptions,
    extend_trip_state,
    new_trip_state,
    remap_trip_state,
    residents_from_blocks,
    residents_from_lots,
    shortest_route,
    step_trips,
    travel_costs,
    trip_graph,
    update_status,
    update_widths,
    width_for_traffic,
)
from osm_expand.errors import InputError
from osm_expand.model.highways import MAJOR
from tests.conftest import loaded

BOX = (-1000.0, -1000.0, 1000.0, 1000.0)
SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])


def cross(extra: list[tuple[tuple[float, float], tuple[float, float], str]] = ()):
    """Two primaries crossing at the origin and leaving the box on all four sides, plus extras."""
    lines = [((0, 0), (1000, 0), "primary"), ((0, 0), (-1000, 0), "primary"),
             ((0, 0), (0, 1000), "secondary"), ((0, 0), (0, -1000), "secondary"), *extra]
    return as_table(lines)


def as_table(lines):
    index: dict[tuple[float, float], int] = {}
    edges, classes = [], []
    for a, b, cls in lines:
        edges.append([index.setdefault(tuple(map(float, a)), len(index)),
                      index.setdefault(tuple(map(float, b)), len(index))])
        classes.append(cls)
    return np.array(list(index), dtype=float), np.array(edges), np.array(classes)


# --------------------------------------------------------------------------- neighbours

def test_a_cross_of_two_primaries_leaving_a_box_gives_four_road_neighbours():
    xy, edges, hw = cross([((0, 0), (300, 300), "residential"), ((300, 300), (1000, 300), "residential")])
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0))
    assert len(nb) == 4 and not nb.fallback
    assert set(nb.kind) == {NeighbourKind.ROAD}
    # exits attach to the four road ends; each neighbour sits 5 km beyond its side
    ends = {tuple(xy[n]) for n in nb.exit_node}
    assert ends == {(1000.0, 0.0), (-1000.0, 0.0), (0.0, 1000.0), (0.0, -1000.0)}
    expected = {(6000.0, 0.0), (0.0, 6000.0), (-6000.0, 0.0), (0.0, -6000.0)}
    assert {tuple(np.round(p, 6)) for p in nb.xy} == expected
    # sorted counter-clockwise from east
    assert np.allclose(nb.xy[0], [6000, 0]) and np.allclose(nb.xy[1], [0, 6000])


def test_a_dual_carriageway_is_one_neighbour_and_a_road_ending_inside_is_none():
    xy, edges, hw = cross([((500, 20), (1000, 20), "primary"),      # second carriageway, 20 m apart
                           ((0, 0), (-400, 500), "trunk")])         # ends 500 m inside: no exit
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0))
    assert len(nb) == 4


def test_a_road_running_on_beyond_the_box_enters_where_it_crosses_the_outline():
    xy, edges, hw = cross([((0, 300), (900, 300), "trunk"), ((900, 300), (1400, 500), "trunk"),
                           ((1400, 500), (1400, 3000), "trunk")])
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0))
    assert len(nb) == 5
    k = int(np.argmin(np.abs(nb.entry_xy[:, 1] - 340)))
    assert nb.entry_xy[k] == pytest.approx([1000.0, 340.0])            # 900,300 → 1400,500 at x = 1000
    assert xy[nb.exit_node[k]].tolist() == [900.0, 300.0]              # the node inside, not 3 km out
    heading = np.array([500.0, 200.0]) / np.hypot(500, 200)
    assert nb.xy[k] == pytest.approx(nb.entry_xy[k] + 5000 * heading)


def test_a_river_crossing_the_box_adds_two_water_neighbours():
    xy, edges, hw = cross()
    river = shapely.box(400, -1500, 480, 1500)  # 80 m wide, north to south
    stream = shapely.box(-600, -1500, -595, 1500)  # 5 m: not navigable
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0), water=[river, stream])
    assert len(nb) == 6
    water = nb.kind == NeighbourKind.WATER
    assert water.sum() == 2 and (nb.exit_node[water] == -1).all()
    assert {tuple(np.round(p)) for p in nb.entry_xy[water]} == {(440.0, 1000.0), (440.0, -1000.0)}


def test_a_town_with_one_exit_gets_the_fallback_with_four_to_ten_neighbours():
    xy, edges, hw = as_table([((0, 0), (1000, 0), "primary"), ((0, 0), (0, 300), "residential"),
                              ((0, 0), (-200, 0), "residential")])
    counts = []
    for seed in range(40):
        nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(seed))
        assert 4 <= len(nb) <= 10 and nb.fallback
        real = ~nb.generated
        assert real.sum() == 1 and xy[nb.exit_node[real][0]].tolist() == [1000.0, 0.0]
        assert (nb.exit_node[nb.generated] == -1).all()
        # every generated neighbour is outside the box, its entry on the outline
        assert (np.abs(nb.xy).max(axis=1) > 1000).all()
        assert np.allclose(np.abs(nb.entry_xy).max(axis=1), 1000.0)
        counts.append(len(nb))
    assert len(set(counts)) > 2 and 5.5 < np.mean(counts) < 8.5  # 4 + Binomial(6, ½): mean 7
    again = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(7))
    first = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(7))
    assert np.array_equal(again.xy, first.xy) and np.array_equal(again.kind, first.kind)


def test_fallback_rays_are_evenly_spaced_up_to_the_perturbation():
    xy, edges, hw = as_table([((0, 0), (100, 0), "residential")])
    for seed in range(20):
        nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(seed))
        c = len(nb)
        assert nb.generated.all()
        angle = np.sort(np.mod(np.arctan2(nb.xy[:, 1], nb.xy[:, 0]), 2 * np.pi))
        gaps = np.diff(np.r_[angle, angle[0] + 2 * np.pi])
        # θ_i ∈ (−π/2c, π/2c): neighbouring rays are between π/c and 3π/c apart
        assert (gaps > np.pi / c - 1e-9).all() and (gaps < 3 * np.pi / c + 1e-9).all()


def test_pairs_are_sorted_by_angle_and_the_initial_pairs_stay_connected():
    xy, edges, hw = cross()
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0))
    pairs = neighbour_pairs(nb)
    assert len(pairs) == 6 and (pairs[:, 0] < pairs[:, 1]).all()
    # four right angles first, then the two straight-across pairs
    assert {tuple(p) for p in pairs[4:]} == {(0, 2), (1, 3)}
    kept = initial_pairs(nb, np.random.default_rng(1))
    # three 90° pairs go; the fourth would leave the two 180° pairs disconnected, so it stays
    assert 3 <= len(kept) < 6
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    g = coo_matrix((np.ones(len(kept)), (kept[:, 0], kept[:, 1])), shape=(4, 4))
    assert connected_components(g, directed=False)[0] == 1


def test_neighbour_inputs_are_checked():
    xy, edges, hw = cross()
    with pytest.raises(InputError, match="bounds"):
        neighbour_cities(xy, edges, hw, (0, 0, -1, 1), np.random.default_rng(0))
    with pytest.raises(InputError, match="centre"):
        neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0), centre=(5000, 0))
    with pytest.raises(InputError, match="c_min"):
        NeighbourOptions(c_min=4, c_mean=3, c_max=10)


coord = st.integers(min_value=-12, max_value=12).map(lambda v: v * 100.0)  # reaches past the box
road = st.tuples(st.tuples(coord, coord), st.tuples(coord, coord),
                 st.sampled_from(["motorway", "primary", "secondary", "residential", "primary_link"]))


@SETTINGS
@given(st.lists(road, min_size=1, max_size=30), st.integers(0, 2**32 - 1))
def test_neighbours_always_lie_beyond_the_box_and_number_three_to_ten(lines, seed):
    lines = [(a, b, c) for a, b, c in lines if a != b]
    if not lines:
        return
    xy, edges, hw = as_table(lines)
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(seed))
    assert 3 <= len(nb) <= 10
    assert (np.abs(nb.xy).max(axis=1) > 1000.0 + 1e-6).all()             # outside the bounds
    assert np.allclose(np.abs(nb.entry_xy).max(axis=1), 1000.0)          # entering on the outline
    real = nb.exit_node >= 0
    for node in nb.exit_node[real]:                                       # an end of a major road
        assert np.isin(hw[(edges == node).any(axis=1)], ["motorway", "primary", "secondary"]).any()
    assert (nb.generated | real).all()                                   # no water here: roads or rays


# --------------------------------------------------------------------------- trade routes (Algorithm 2)

#: widths 10, 6, 8, 7, 9 m at O2 = 100 → capacities 1000, 600, 800, 700, 900
WIDTH = np.array([10.0, 6.0, 8.0, 7.0, 9.0])


def worked_example():
    """Pair (1, 2) carries 200 on s3, s4; pair (0, 1) has A = s0, s1 (1000 m) and B = s1, s2, s3 (1500 m)."""
    cap = segment_capacity(WIDTH, options=TradeOptions(o2=100.0))
    state = new_trade_state(5)
    state = add_route(state, (2, 1), [3, 4], 500.0)
    state, short = redistribute(state, (1, 2), 200.0, cap)
    assert short == 0.0
    state = add_route(state, (0, 1), [1, 2, 3], 1500.0)   # B, added first but longer
    state = add_route(state, (0, 1), [0, 1], 1000.0)      # A
    return state, cap


def test_algorithm_2_arithmetic_on_two_routes_sharing_a_segment():
    state, cap = worked_example()
    assert np.array_equal(cap, [1000, 600, 800, 700, 900])
    # T_A(P_i): A (shorter) saturates first: min(1000, 600) = 600, leaving s1 at 0;
    # B then has min(0, 800, 700 - 200) = 0. Not 600 + 500: s1 is shared.
    assert pair_capacity(state, (0, 1), cap) == pytest.approx(600.0)
    fits, short = redistribute(state, (0, 1), 400.0, cap)
    assert short == 0.0
    assert [r.traffic for r in fits.routes] == pytest.approx([200.0, 0.0, 400.0])
    too_much, short = redistribute(state, (0, 1), 900.0, cap)
    assert short == pytest.approx(300.0)
    assert np.allclose(too_much.segment_traffic(), [600, 600, 0, 200, 200])
    # the major-road step finds D = s2, s3 with room for the shortfall, adds it, redistributes
    room = segments_with_room(too_much, cap, short)
    assert room.tolist() == [True, False, True, True, True]
    solved = add_route(too_much, (0, 1), [2, 3], 2000.0)
    solved, short = redistribute(solved, (0, 1), 900.0, cap)
    assert short == 0.0
    assert [r.traffic for r in solved.routes] == pytest.approx([200.0, 0.0, 600.0, 300.0])
    assert np.allclose(solved.segment_traffic(), [600, 600, 300, 500, 200])
    # the original states are untouched
    assert [r.traffic for r in state.routes] == pytest.approx([200.0, 0.0, 0.0])


def test_shortfall_is_zero_when_capacity_suffices_so_nothing_is_built():
    state, cap = worked_example()
    for year in range(6):
        state, short = assign_increase(state, (0, 1), 100.0, cap)
        assert short == 0.0 and len(state.routes) == 3
    assert state.carried((0, 1)) == pytest.approx(600.0)
    state, short = assign_increase(state, (0, 1), 100.0, cap)
    assert short == pytest.approx(100.0) and state.demand[(0, 1)] == pytest.approx(700.0)
    # an unmet demand is asked again: a fall of 50 leaves t = 650, still 50 short
    state, short = assign_increase(state, (0, 1), -50.0, cap)
    assert short == pytest.approx(50.0)


def test_a_trade_year_asks_the_major_road_step_only_when_capacity_runs_out():
    state, cap = worked_example()
    asked = []

    def propose(st, pair, short):
        asked.append((pair, round(short, 6)))
        return add_route(st, pair, [2, 3], 2000.0), cap

    # +300 for both pairs: (1, 2) has 700 − 0 on its route → fits; (0, 1) has 600 → fits
    state, cap2, year = trade_year(state, [(1, 2), (0, 1)], 300.0, cap, propose=propose)
    assert asked == [] and year.as_dict() == dict(pairs=2, short=0, shortfall=0.0, routes_added=0, unresolved=0)
    # another +300: (1, 2) → 800 on s3/s4 (cap 700) short by 100 — the proposer's route [2, 3]
    # shares s3, so it adds nothing; then (0, 1) → 600 fits exactly on A.
    state, cap2, year = trade_year(state, [(1, 2), (0, 1)], 300.0, cap, propose=propose)
    assert asked == [((1, 2), 100.0)]
    assert (year.short, year.routes_added, year.unresolved) == (1, 1, 1)
    assert state.carried((0, 1)) == pytest.approx(600.0) and state.carried((1, 2)) == pytest.approx(700.0)
    # without a proposer the shortfall stays, counted
    _, _, year = trade_year(state, [(1, 2)], 0.0, cap)
    assert (year.short, year.unresolved, year.shortfall) == (1, 1, pytest.approx(100.0))


def test_trade_report_counts_short_pairs_and_saturated_and_overloaded_routes():
    state, cap = worked_example()
    state, _ = redistribute(state, (0, 1), 900.0, cap)
    rep = trade_report(state, cap)
    assert (rep.pairs, rep.routes, rep.pairs_short) == (2, 3, 1)
    assert rep.demand == pytest.approx(1100.0) and rep.unmet == pytest.approx(300.0)
    assert rep.routes_at_capacity == 2 and rep.routes_over_capacity == 0   # A and B share the full s1
    narrower = cap.copy()
    narrower[4] = 100.0  # s4 narrowed below its 200
    rep = trade_report(state, narrower)
    assert rep.routes_over_capacity == 1 and rep.segments_over_capacity == 1
    assert set(rep.as_dict()) >= {"routes_over_capacity", "pairs_short", "unmet"}


def test_routes_follow_the_segment_table_through_splits_and_growth():
    state, cap = worked_example()
    state, _ = redistribute(state, (0, 1), 400.0, cap)
    split = remap_segments(state, [[0], [1, 5], [2], [3], [4]], 6)
    assert split.routes[2].segments.tolist() == [0, 1, 5]
    assert np.allclose(split.segment_traffic(), [400, 400, 0, 200, 200, 400])
    grown = extend_segments(state, 8)
    assert grown.segment_traffic().shape == (8,)
    with pytest.raises(InputError, match="twice"):
        add_route(state, (0, 1), [0, 0], 10.0)
    with pytest.raises(InputError, match="different cities"):
        add_route(state, (1, 1), [0], 10.0)


@SETTINGS
@given(st.lists(st.floats(1.0, 20.0), min_size=6, max_size=6),
       st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3), st.sets(st.integers(0, 5), min_size=1, max_size=4),
                          st.floats(100.0, 5000.0)), min_size=1, max_size=8),
       st.lists(st.floats(0.0, 3000.0), min_size=1, max_size=12))
def test_algorithm_2_never_overloads_a_segment_and_accounts_for_every_unit(widths, routes, demands):
    cap = segment_capacity(np.array(widths))
    state = new_trade_state(6)
    pairs = []
    for u, v, segs, length in routes:
        if u != v:
            state = add_route(state, (u, v), sorted(segs), length)
            pairs.append((min(u, v), max(u, v)))
    for k, total in enumerate(demands):
        if not pairs:
            break
        pair = pairs[k % len(pairs)]
        before = pair_capacity(state, pair, cap)
        state, short = redistribute(state, pair, total, cap)
        assert short == pytest.approx(max(0.0, total - before), abs=1e-6)
        assert state.carried(pair) + short == pytest.approx(total, abs=1e-6)
        assert (state.segment_traffic() <= cap + 1e-6).all()
        assert all(r.traffic >= 0 for r in state.routes)


def test_first_routes_run_over_major_roads_between_the_exits():
    # the cross, plus a residential link from the east end to the north end
    xy, edges, hw = cross([((1000, 0), (0, 1000), "residential")])
    nb = neighbour_cities(xy, edges, hw, BOX, np.random.default_rng(0))
    length = np.hypot(*(xy[edges[:, 1]] - xy[edges[:, 0]]).T)
    major = hw != "residential"
    state, missing = initial_trade_state(edges, length, major, nb.exit_node, neighbour_pairs(nb))
    assert len(state.routes) == 6 and len(missing) == 0
    assert all(r.length == pytest.approx(2000.0) and len(r.segments) == 2 for r in state.routes)
    # with the east arm cut off the major network, its three pairs are missing
    cut = major.copy()
    cut[0] = False
    state, missing = initial_trade_state(edges, length, cut, nb.exit_node, neighbour_pairs(nb))
    assert len(state.routes) == 3 and len(missing) == 3 and (missing == 0).any(axis=1).all()
    # P_A over roads with room: the lighter of two parallel segments, none when blocked
    par = np.array([[0, 1], [0, 1], [1, 2]])
    assert route_between(par, np.array([5.0, 3.0, 1.0]), np.ones(3, bool), 0, 2).tolist() == [1, 2]
    assert route_between(par, np.array([5.0, 3.0, 1.0]), np.array([True, True, False]), 0, 2) is None


# --------------------------------------------------------------------------- trips (002 §3.2)

def staircase_or_detour():
    """From the source (west) to the target (north-east): an 8-turn staircase of 800 m,
    or a 1,900 m detour with two turns."""
    lines = [((-100, 0), (0, 0))]                                    # 0: source
    lines += [((400, 400), (500, 400))]                              # 1: target
    stairs = [(0, 0), (100, 0), (100, 100), (200, 100), (200, 200), (300, 200), (300, 300),
              (400, 300), (400, 400)]
    lines += list(zip(stairs[:-1], stairs[1:]))                      # 2..9
    lines += [((0, 0), (1000, 0)), ((1000, 0), (1000, 400)), ((1000, 400), (500, 400))]  # 10..12
    xy, edges, _ = as_table([(a, b, "residential") for a, b in lines])
    return xy, edges


def test_turn_costs_change_a_trips_route():
    xy, edges = staircase_or_detour()
    with_turns = trip_graph(xy, edges, options=TripOptions(turn_cost=500.0))
    no_turns = trip_graph(xy, edges, options=TripOptions(turn_cost=0.0))
    assert shortest_route(with_turns, 0, 1).tolist() == [0, 10, 11, 12, 1]
    assert shortest_route(no_turns, 0, 1).tolist() == [0, *range(2, 10), 1]
    # and the traffic lands there: only the two ends have residents, 200 trips a day each way
    residents = np.zeros(len(edges))
    residents[[0, 1]] = 100.0
    for graph, used, unused in ((with_turns, [10, 11, 12], range(2, 10)), (no_turns, range(2, 10), [10, 11, 12])):
        state, rep = step_trips(new_trip_state(len(edges)), graph, residents, np.random.default_rng(0), full=True)
        assert rep.trips == 400 and rep.volume == 1.0
        assert np.allclose(state.traffic[list(used)], 400.0) and np.allclose(state.traffic[list(unused)], 0.0)
        assert np.allclose(state.traffic[[0, 1]], 400.0)


def test_travel_cost_counts_half_segments_turns_and_speed():
    xy, edges, _ = as_table([((0, 0), (100, 0), ""), ((100, 0), (200, 0), ""), ((200, 0), (300, 0), ""),
                             ((300, 0), (300, 100), "")])
    g = trip_graph(xy, edges)
    cost = travel_costs(g, 0)
    assert cost[:4] == pytest.approx([0, 100, 200, 50 + 100 + 100 + 50 + 500], abs=1e-3)
    fast = trip_graph(xy, edges, major=np.array([False, True, False, False]))
    assert travel_costs(fast, 0)[2] == pytest.approx(50 + 100 * 30 / 50 + 50, abs=1e-3)
    assert trip_graph(xy, edges, previous=g) is g           # unchanged network: same graph
    assert trip_graph(xy, edges, previous=fast) is not fast


def test_destinations_follow_residents_and_distance_decay():
    # a source between two destinations: east at 100 m (cost 100), west at 1,600 m
    xy, edges, _ = as_table([((0, 0), (100, 0), ""), ((100, 0), (200, 0), ""),
                             ((0, 0), (-1500, 0), ""), ((-1500, 0), (-1600, 0), "")])
    opts = TripOptions(decay_length=1000.0, target_trips=10**9)
    g = trip_graph(xy, edges, options=opts)
    residents = np.array([10000.0, 300.0, 0.0, 300.0])
    state, rep = step_trips(new_trip_state(4), g, residents, np.random.default_rng(3), full=True, options=opts)
    from_source = state.contributions[0].toarray().ravel()
    east, west = from_source[1], from_source[3]
    # attraction ∝ residents · exp(−d / L): the ratio is exp((1600 − 100) / 1000)
    assert east / west == pytest.approx(np.exp(1.5), rel=0.05)
    assert east + west == pytest.approx(20000.0, rel=0.02)


def test_resampling_takes_new_changed_and_a_share_of_the_rest():
    xy = np.c_[np.arange(11) * 100.0, np.zeros(11)]
    edges = np.c_[np.arange(10), np.arange(1, 11)]
    opts = TripOptions(sample_rate=0.0)
    g = trip_graph(xy, edges, options=opts)
    residents = np.full(10, 50.0)
    rng = np.random.default_rng(0)
    state, rep = step_trips(new_trip_state(10), g, residents, rng, options=opts)
    assert (rep.sources, rep.new) == (10, 10)
    state, rep = step_trips(state, g, residents, rng, options=opts)
    assert rep.sources == 0
    changed = residents.copy()
    changed[4] = 0.0
    state, rep = step_trips(state, g, changed, rng, options=opts)
    assert (rep.sources, rep.changed) == (1, 1)
    assert state.contributions[4].nnz == 0                      # its old trips left the traffic
    assert np.allclose(state.traffic, np.asarray(state.contributions.sum(axis=0)).ravel())
    # a share of the rest
    state, rep = step_trips(state, g, changed, rng, options=TripOptions(sample_rate=1.0))
    assert rep.sources == 10 and rep.changed == 0
    # new segments appended to the table are sampled next, within max_sources
    xy2 = np.r_[xy, [[1100.0, 0], [1200.0, 0], [1300.0, 0]]]
    edges2 = np.r_[edges, [[10, 11], [11, 12], [12, 13]]]
    grown = extend_trip_state(state, 13)
    g2 = trip_graph(xy2, edges2, previous=g, options=opts)
    few = TripOptions(sample_rate=0.0, max_sources=2)
    grown, rep = step_trips(grown, g2, np.r_[changed, 50, 50, 50], rng, options=few)
    assert (rep.sources, rep.new, rep.deferred) == (2, 2, 1)


def test_same_generator_same_traffic_and_splits_carry_traffic_to_both_pieces():
    xy = np.c_[np.arange(6) * 100.0, np.zeros(6)]
    edges = np.c_[np.arange(5), np.arange(1, 6)]
    g = trip_graph(xy, edges)
    residents = np.array([80.0, 10.0, 30.0, 0.0, 60.0])
    a, _ = step_trips(new_trip_state(5), g, residents, np.random.default_rng(5), full=True)
    b, _ = step_trips(new_trip_state(5), g, residents, np.random.default_rng(5), full=True)
    assert np.array_equal(a.traffic, b.traffic)
    # every trip starts on its own street: the diagonal holds all people sent
    sent = step_trips(new_trip_state(5), g, residents, np.random.default_rng(5), full=True)[1].people
    assert a.contributions.diagonal().sum() == pytest.approx(sent)
    # segment 2 becomes pieces 2 and 5; trips through it now run through both
    split = remap_trip_state(a, [[0], [1], [2, 5], [3], [4]], 6)
    assert split.traffic[5] == pytest.approx(split.traffic[2])
    assert not split.sampled[2] and not split.sampled[5] and split.sampled[0]
    assert split.contributions[2].nnz == 0                       # trips from the split segment are redone


def test_residents_from_blocks_and_lots():
    # a 100 m square block of 1 ha at 80 people per ha: 20 per side
    res = residents_from_blocks([10000.0], [[0, 1, 2, 3]], np.full(5, 100.0))
    assert res.tolist() == pytest.approx([20.0, 20.0, 20.0, 20.0, 0.0])
    lots = residents_from_lots([3.0, 4.0, 5.0], [1, 1, -1], 3)
    assert lots.tolist() == [0.0, 7.0, 0.0]


def test_planned_streets_are_built_when_traffic_passes_the_threshold():
    built = np.array([False, False, False, True])
    years = np.array([0, 0, 0, 1950])
    traffic = np.array([49.9, 50.0, 500.0, 0.0])
    now, when = update_status(built, traffic, years, year=2001, options=TripOptions(build_threshold=50.0))
    assert now.tolist() == [False, True, True, True]
    assert when.tolist() == [0, 2001, 2001, 1950]


def test_width_classes():
    w = width_for_traffic(np.array([0.0, 4999.0, 5001.0, 1e9]), np.array([False, False, False, False]))
    assert w.tolist() == [7.5, 7.5, 11.0, 25.0]                 # 1, 1, 2, 6 lanes × 3.5 + 2 × 2
    assert width_for_traffic(np.array([0.0]), np.array([True])).tolist() == [11.0]


def test_widths_follow_traffic_after_the_delay():
    opts = TripOptions(width_delay=5)
    width, pend = np.array([7.5]), np.array([-1])
    built, built_year = np.array([True]), np.array([1950])
    heavy = np.array([12000.0])  # three lanes: 14.5 m
    for year in range(2000, 2005):
        width, pend = update_widths(width, heavy, built, built_year, pend, year=year, options=opts)
        assert width[0] == 7.5 and pend[0] == 2000
    width, pend = update_widths(width, heavy, built, built_year, pend, year=2005, options=opts)
    assert width[0] == 14.5 and pend[0] == -1
    # a need that goes away before the delay is over changes nothing
    w2, p2 = update_widths(np.array([7.5]), heavy, built, built_year, np.array([-1]), year=2000, options=opts)
    w2, p2 = update_widths(w2, np.array([10.0]), built, built_year, p2, year=2002, options=opts)
    assert w2[0] == 7.5 and p2[0] == -1
    # by default built streets never narrow; with shrink they do, after the delay
    quiet = np.array([0.0])
    w3, p3 = update_widths(width, quiet, built, built_year, pend, year=2010, options=opts)
    assert w3[0] == 14.5 and p3[0] == -1
    narrow = TripOptions(width_delay=5, shrink=True)
    w4, p4 = update_widths(width, quiet, built, built_year, pend, year=2010, options=narrow)
    w4, p4 = update_widths(w4, quiet, built, built_year, p4, year=2015, options=narrow)
    assert w4[0] == 7.5


def test_a_street_built_now_gets_a_temporary_width_then_its_final_one():
    opts = TripOptions(width_delay=3)
    built, by, pend = np.array([True]), np.array([2000]), np.array([-1])
    width, pend = update_widths(np.array([0.0]), np.array([100.0]), built, by, pend, year=2000, options=opts)
    assert width[0] == 7.5 and pend[0] == 2000                  # temporary, final one pending
    width, pend = update_widths(width, np.array([6000.0]), built, by, pend, year=2003, options=opts)
    assert width[0] == 11.0 and pend[0] == -1
    planned = update_widths(np.array([3.0]), np.array([6000.0]), np.array([False]), np.array([0]),
                            np.array([-1]), year=2000, options=opts)[0]
    assert planned[0] == 11.0                                    # the plan follows traffic at once


def test_trip_options_and_inputs_are_checked():
    with pytest.raises(InputError, match="exponential, power"):
        TripOptions(decay="gaussian")
    with pytest.raises(InputError, match="sample_rate"):
        TripOptions(sample_rate=2.0)
    xy, edges = staircase_or_detour()
    g = trip_graph(xy, edges)
    with pytest.raises(InputError, match="segments"):
        step_trips(new_trip_state(3), g, np.zeros(len(edges)), np.random.default_rng(0))


def _pieces_one_by_one(old_table, city):
    """Each old segment's run of new segments, found street by street (the definition)."""
    streets = city.network.streets
    where = {s.id: k for k, s in enumerate(streets)}
    new_first = np.concatenate([[0], np.cumsum([len(s.nodes) - 1 for s in streets])])
    out = []
    for sid, (u, v) in zip(old_table.street_id.tolist(), old_table.uv.tolist()):
        k = where.get(sid)
        nodes = streets[k].nodes if k is not None else ()
        if u not in nodes or v not in nodes:
            out.append([])
            continue
        i = nodes.index(u)
        j = nodes.index(v, i + 1) if v in nodes[i + 1:] else nodes.index(v)
        out.append(list(range(int(new_first[k]) + min(i, j), int(new_first[k]) + max(i, j))))
    return out


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_segment_pieces_map_each_old_segment_to_the_run_it_became(seed):
    from dataclasses import replace as with_

    from osm_expand.model import City, network_from_lines
    from osm_expand.model.pieces import Pieces
    from osm_expand.model.segments import SegmentTable, segment_pieces

    rng = np.random.default_rng(seed)
    lines = [[(float(x), float(y)), (float(x) + 100.0, float(y)), (float(x) + 200.0, float(y) + 50.0)]
             for x, y in rng.integers(0, 2000, size=(int(rng.integers(1, 12)), 2))]
    net = network_from_lines(lines)
    before = City(network=net)
    old = SegmentTable.from_city(before)
    # a year's changes: a street demolished, a tee inserted into another, a street added
    streets = list(net.streets)
    xy = net.xy
    for k in range(len(streets)):
        roll = rng.random()
        if roll < 0.2:
            streets[k] = None
        elif roll < 0.5:
            xy = np.vstack([xy, xy[list(streets[k].nodes[:2])].mean(axis=0)])
            nodes = streets[k].nodes
            streets[k] = streets[k].with_nodes((nodes[0], len(xy) - 1, *nodes[1:]))
    kept = [s for s in streets if s is not None]
    extra = with_(net.streets[0], nodes=(0, len(xy)), id=10_000)
    xy = np.vstack([xy, [[-50.0, -50.0]]])
    after = City(network=net.replace(xy=xy, node_ids=np.zeros(len(xy), dtype=np.int64),
                                     streets=tuple(kept + [extra])))
    new = SegmentTable.from_city(after)
    got = segment_pieces(old, new, after)
    want = Pieces.of(_pieces_one_by_one(old, after))
    assert np.array_equal(got.offsets, want.offsets) and np.array_equal(got.flat, want.flat)
    assert all(0 <= s < len(new) for s in got.flat.tolist())


def test_the_lots_people_summed_at_once_are_the_sum_lot_by_lot():
    """``simulation._lot_people`` puts every lot's people on the middle segment of its street at once;
    the per-segment sums are those of adding the lots one by one, bit for bit."""
    from types import SimpleNamespace

    from hypothesis import given, settings
    from hypothesis import strategies as st

    from osm_expand.engine.traffic.simulation import _lot_people

    class Table(SimpleNamespace):
        def __len__(self):
            return len(self.street_id)

    people = st.floats(0.0, 500.0, allow_nan=False)

    @settings(max_examples=150, deadline=None)
    @given(st.lists(st.integers(0, 6), max_size=25),
           st.lists(st.tuples(st.one_of(st.none(), st.integers(-1, 8)), people), max_size=40))
    def check(segment_streets, lots):
        table = Table(street_id=np.array(segment_streets, dtype=np.int64))
        city = SimpleNamespace(lots=[SimpleNamespace(street=s, people=p) for s, p in lots])
        first: dict[int, list[int]] = {}
        for k, sid in enumerate(segment_streets):
            first.setdefault(sid, []).append(k)
        want = np.zeros(len(segment_streets))
        for lot in city.lots:  # the lot-by-lot rule
            segs = first.get(lot.street)
            if segs:
                want[segs[len(segs) // 2]] += lot.people
        assert np.array_equal(_lot_people(city, table), want)

    check()


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz"])
def test_searches_kept_to_what_a_batch_reaches_equal_the_whole_graphs(name):
    """The trips' compiled searches (each touching only what it reaches) give scipy's distances
    and predecessors on the whole graph bit for bit (ties broken the same way), renumbered to the
    columns some start reaches, for neighbouring starts, starts spread over the town, tight and open
    limits; and ``_sample_batch`` draws the same trips as the dense table of scipy's rows
    (:func:`tests.test_trip_search.dense_sample_batch`)."""
    from scipy.sparse.csgraph import dijkstra

    from osm_expand.engine.traffic.trips import _sample_batch
    from tests.test_trip_search import dense_sample_batch, limited_dijkstra

    net = loaded(name)
    uv = np.concatenate([np.c_[s.nodes[:-1], s.nodes[1:]] for s in net.streets])
    major = np.concatenate([np.full(len(s.nodes) - 1, s.highway in MAJOR) for s in net.streets])
    g = trip_graph(net.xy, uv, major=major)
    e = g.n_segments
    rng = np.random.default_rng(7)
    batches = [np.arange(40, 104), np.sort(rng.choice(e, 64, replace=False)), np.array([e - 1]), np.arange(e)]
    for starts in batches:
        for limit in (250.0, 1500.0, TripOptions().limit, np.inf):
            whole, whole_pred = dijkstra(g.matrix, directed=True, indices=2 * e + starts, return_predecessors=True,
                                         limit=limit)
            vertex, dist, pred = limited_dijkstra(g.matrix.indptr, g.matrix.indices, g.matrix.data, 2 * e + starts,
                                                  limit)
            assert np.all(np.diff(vertex) > 0)
            outside = np.ones(3 * e, bool)
            outside[vertex] = False
            assert np.isinf(whole[:, outside]).all() and (whole_pred[:, outside] == -9999).all()
            assert np.array_equal(dist, whole[:, vertex])
            assert np.array_equal(np.where(pred >= 0, vertex[np.maximum(pred, 0)], -9999), whole_pred[:, vertex])
            if np.isfinite(limit) and limit < 2000 and len(starts) < e:
                assert len(vertex) < 3 * e  # the point: a batch searches less than the town
    residents = rng.random(e) * 40 * (rng.random(e) < 0.7)
    for starts in batches[:3]:
        n_trips = rng.integers(0, 20, len(starts))
        got, want = (f(g, starts, n_trips, residents, 2.5, np.random.default_rng(3), TripOptions())
                     for f in (_sample_batch, dense_sample_batch))
        assert got[3:] == want[3:] and got[3] > 0
        for a, b in zip(got[:3], want[:3]):
            assert np.array_equal(np.concatenate(a), np.concatenate(b))
