"""Space colonisation (seed 001 ch. 4): flow primitives, angle rules, snapping, inter-connection,
pruning, steepness, information maps, planarity, determinism, capillarity and the 90° grid."""
from __future__ import annotations

import json

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from osm_expand.errors import InputError
from synth.colonisation import (
    ColonisationOptions,
    ColonisationResult,
    chain_streets,
    colonise,
    connection_force,
    constrain_turn,
    extra_pruning,
    ideal_directions,
)
from synth.colonisation.kernel import _Colonist
from synth.colonisation.options import _Phase
from synth.flowfield import FlowPrimitive, flow_field, primitive_velocity
from synth.infomaps import (
    InfoMapOptions,
    Raster,
    border_from_geometries,
    density_from_points,
    forbidden_cells,
    slopes_within,
    town_density,
)

SL = 100.0


# --------------------------------------------------------------------------- helpers


def referee(res: ColonisationResult, seeds, region, forbidden=None) -> dict[str, int]:
    """Counts of broken promises: crossings without a shared node, short segments, forbidden, outside."""
    xy, edges = res.xy, res.edges
    if not len(edges):
        return {"crossings": 0, "short": 0, "forbidden": 0, "outside": 0}
    lines = shapely.linestrings(np.stack([xy[edges[:, 0]], xy[edges[:, 1]]], axis=1))
    tree = shapely.STRtree(lines)
    crossings = 0
    i, j = tree.query(lines, predicate="intersects")
    for a, b in zip(i[i < j].tolist(), j[i < j].tolist()):
        shared = set(edges[a].tolist()) & set(edges[b].tolist())
        inter = shapely.intersection(lines[a], lines[b])
        ok = (len(shared) == 1 and inter.geom_type == "Point"
              and np.allclose(inter.coords[0], xy[shared.pop()], atol=1e-6))
        crossings += not ok
    for line in seeds:
        old = shapely.LineString(line)
        for a in tree.query(old, predicate="intersects").tolist():
            ends = [xy[v] for v in edges[a].tolist() if res.fixed[v]]
            pts = shapely.get_coordinates(shapely.intersection(lines[a], old))
            inter = shapely.intersection(lines[a], old)
            if inter.geom_type not in ("Point", "MultiPoint") or not all(
                    any(np.hypot(*(p - e)) < 1e-6 for e in ends) for p in pts):
                crossings += 1
    short = int((shapely.length(lines) < res.options.min_segment_m - 1e-9).sum())
    bad_ground = 0 if forbidden is None else int(shapely.intersects(forbidden, lines).sum())
    inside = region.buffer(res.options.edge_tolerance * res.options.segment_length + 1e-6)
    outside = int((~shapely.covers(inside, lines)).sum())
    return {"crossings": crossings, "short": short, "forbidden": bad_ground, "outside": outside}


def board(seeds, **options) -> tuple[_Colonist, _Phase]:
    """A run's state with only old streets, for driving single growth steps by hand."""
    opts = ColonisationOptions(segment_length=SL, seed_spacing=50.0, **options)
    col = _Colonist(shapely.box(-2000, -2000, 2000, 2000), None, opts, np.random.default_rng(0), None, None, None,
                    None)
    col.add_seeds([np.asarray(s, dtype=float) for s in seeds])
    return col, _Phase.of(opts, 1)


def branch(col: _Colonist, points, level: int, phase: int = 1) -> list[int]:
    """Grown nodes along ``points`` (the first must be an existing node id or a point), edges of ``level``."""
    net = col.net
    ids = []
    for p in points:
        if isinstance(p, int):
            ids.append(p)
            continue
        parent = ids[-1] if ids else -1
        m = net.add_node(np.asarray(p, dtype=float), parent=parent, phase=phase)
        if ids:
            e = net.add_edge(ids[-1], m, level=level, phase=phase)
            net.creator[m] = e
        ids.append(m)
    return ids


def degrees(res: ColonisationResult) -> np.ndarray:
    return np.bincount(res.edges.ravel(), minlength=len(res.xy))


# --------------------------------------------------------------------------- flow primitives (001 §4.3.2)


def test_a_source_flows_outward_and_a_sink_inward():
    pts = np.array([[10.0, 0.0], [0.0, -20.0], [-3.0, 4.0]])
    for kind, sign in (("source", 1.0), ("sink", -1.0)):
        v = primitive_velocity(FlowPrimitive(kind, 0.0, 0.0, strength=2 * np.pi), pts, core=1.0)
        radial = (v * pts).sum(axis=1) / np.hypot(*pts.T)
        np.testing.assert_allclose(radial, sign / np.hypot(*pts.T))  # v_r = a / (2π r)
        np.testing.assert_allclose(v[:, 0] * pts[:, 1] - v[:, 1] * pts[:, 0], 0.0, atol=1e-12)  # no swirl


def test_a_vortex_is_tangential_counter_clockwise_for_positive_strength():
    pts = np.array([[5.0, 0.0], [0.0, 5.0], [-2.0, -2.0]])
    v = primitive_velocity(FlowPrimitive("vortex", 0.0, 0.0, strength=2 * np.pi), pts, core=1.0)
    np.testing.assert_allclose((v * pts).sum(axis=1), 0.0, atol=1e-12)
    cross = pts[:, 0] * v[:, 1] - pts[:, 1] * v[:, 0]
    assert (cross > 0).all()
    np.testing.assert_allclose(np.hypot(*v.T), 1.0 / np.hypot(*pts.T))  # v_θ = b / (2π r)
    clockwise = primitive_velocity(FlowPrimitive("vortex", 0.0, 0.0, strength=-1.0), pts, core=1.0)
    assert (pts[:, 0] * clockwise[:, 1] - pts[:, 1] * clockwise[:, 0] < 0).all()


def test_uniform_flow_is_the_same_everywhere_and_the_centre_is_finite():
    pts = np.array([[0.0, 0.0], [1e4, -3e3]])
    v = primitive_velocity(FlowPrimitive("uniform", strength=3.0, direction_deg=90.0), pts, core=1.0)
    np.testing.assert_allclose(v, [[0.0, 3.0], [0.0, 3.0]], atol=1e-12)
    for kind in ("source", "sink", "vortex"):
        at = primitive_velocity(FlowPrimitive(kind, 5.0, 5.0), np.array([[5.0, 5.0], [5.5, 5.0]]), core=1.0)
        assert np.isfinite(at).all() and not at[0].any()  # r = 0: zero, not a division by zero
        assert np.hypot(*at[1]) == pytest.approx(0.5 / (2 * np.pi))  # the Rankine core grows linearly


def test_a_gridded_field_sums_its_primitives_and_interpolates_between_cells():
    prims = [FlowPrimitive("uniform", strength=0.01, direction_deg=0.0), FlowPrimitive("vortex", 500, 500, 30.0)]
    field = flow_field(prims, bounds=(0, 0, 1000, 1000), cell=50.0)
    centres = field.centres()
    exact = sum(primitive_velocity(p, centres, core=50.0) for p in prims)
    np.testing.assert_allclose(field.sample(centres), exact, atol=1e-12)
    mid = (centres[0] + centres[1]) / 2
    np.testing.assert_allclose(field.sample(mid[None])[0], (exact[0] + exact[1]) / 2)
    with pytest.raises(InputError, match="one of uniform, source, sink, vortex"):
        FlowPrimitive("doublet")


# --------------------------------------------------------------------------- angles (001 §4.1.2)


def test_turns_snap_into_the_range_or_the_straight_ahead_tolerance():
    # [30°, 45°] with the default tolerance of half the amplitude: [0°, 7.5°]
    turns = np.array([20.0, -5.0, 10.0, 60.0, -38.0, -25.0])
    np.testing.assert_allclose(constrain_turn(turns, lo=30, hi=45, tolerance=7.5),
                               [30.0, -5.0, 7.5, 45.0, -38.0, -30.0])
    # a fixed 90° leaves only straight ahead besides it
    np.testing.assert_allclose(constrain_turn(np.array([10.0, -50.0, 130.0]), lo=90, hi=90, tolerance=0.0),
                               [0.0, -90.0, 90.0])
    # without the straight-ahead option everything goes into the range
    np.testing.assert_allclose(constrain_turn(np.array([2.0]), lo=30, hi=45, tolerance=7.5, straight=False), [30.0])
    opts = ColonisationOptions(angle_range_1=(30.0, 45.0))
    assert opts.tolerance_of(1) == 7.5 and ColonisationOptions().tolerance_of(1) == 0.0


def test_a_node_grows_along_the_snapped_turn():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(90.0, 90.0), min_angle=(0.0, 0.0))
    a, b = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    d = col._angle_snap(b, np.array([np.cos(np.radians(30)), np.sin(np.radians(30))]), ph)  # 60° right → 90°
    np.testing.assert_allclose(d, [1.0, 0.0], atol=1e-12)
    d = col._angle_snap(b, np.array([np.sin(np.radians(20)), np.cos(np.radians(20))]), ph)  # 20° → straight
    np.testing.assert_allclose(d, [0.0, 1.0], atol=1e-12)


def test_options_are_validated_with_one_line_errors():
    with pytest.raises(InputError, match="radius_of_influence.*must exceed phase 1's kill distance"):
        ColonisationOptions(radius_of_influence=2.0, kill_distance=(2.0, 1.0))
    with pytest.raises(InputError, match="hierarchy_basis.*one of introduced, reference"):
        ColonisationOptions(hierarchy_basis="area")
    with pytest.raises(InputError, match="angle_range_2"):
        ColonisationOptions(angle_range_2=(100.0, 80.0))
    assert ColonisationOptions(kill_distance=(3.0, 0.0)).kill(2) == 1.5  # half of phase 1's (001 §4.2.3)
    json.dumps(ColonisationOptions().to_dict())


# --------------------------------------------------------------------------- snapping and merging (001 §4.1.3)


def test_a_new_node_near_a_node_of_equal_hierarchy_merges_at_the_average():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    m, _ = branch(col, [(20.0, 100.0), (20.0, 200.0)], level=1)
    reached, _ = col._attempt(n, np.array([0.0, 1.0]), ph)
    assert reached == m and m in col.net.adj[n]
    np.testing.assert_allclose(col.net.xy[m], [10.0, 100.0])


def test_the_less_important_node_moves_to_the_more_important_one():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=0)  # a primary dead end: its extension is primary
    m, _ = branch(col, [(20.0, 100.0), (20.0, 200.0)], level=1)
    col._attempt(n, np.array([0.0, 1.0]), ph)
    np.testing.assert_allclose(col.net.xy[m], [0.0, 100.0])  # the secondary node moved onto the primary road
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    m, _ = branch(col, [(20.0, 100.0), (20.0, 200.0)], level=0)
    col._attempt(n, np.array([0.0, 1.0]), ph)
    np.testing.assert_allclose(col.net.xy[m], [20.0, 100.0])  # the primary node stays


def test_old_town_nodes_never_move():
    col, ph = board([[(20.0, 100.0), (20.0, 1000.0)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=0)
    reached, _ = col._attempt(n, np.array([0.0, 1.0]), ph)
    assert col.net.fixed[reached]
    np.testing.assert_allclose(col.net.xy[reached], [20.0, 100.0])


def test_a_new_node_near_the_middle_of_a_segment_splits_it():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    u, v = branch(col, [(-100.0, 110.0), (100.0, 110.0)], level=1)
    reached, _ = col._attempt(n, np.array([0.0, 1.0]), ph)
    np.testing.assert_allclose(col.net.xy[reached], [0.0, 110.0])
    assert set(col.net.adj[reached]) == {u, v, n} and v not in col.net.adj[u]


def test_a_snap_onto_an_old_street_is_reported_as_a_join_on_its_segment():
    seed = np.array([[-1000.0, 110.0], [1000.0, 110.0]])
    opts = ColonisationOptions(segment_length=SL, seed_spacing=50.0, angle_range_1=(0.0, 180.0),
                               min_angle=(0.0, 0.0), second_phase=False)
    col = _Colonist(shapely.box(-2000, -2000, 2000, 2000), None, opts, np.random.default_rng(0), None, None, None,
                    None)
    col.add_seeds([seed])
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    reached, _ = col._attempt(n, np.array([0.0, 1.0]), _Phase.of(opts, 1))
    res = col.result(None)
    join = next(j for j in res.joins if j.node == reached)
    assert (join.seed, join.segment, join.vertex) == (0, 0, False)
    assert join.xy == pytest.approx((0.0, 110.0))


def test_a_proposal_crossing_a_segment_stops_on_it():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], angle_range_1=(0.0, 180.0), min_angle=(0.0, 0.0))
    a, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    u, v = branch(col, [(-100.0, 50.0), (100.0, 50.0)], level=1)
    reached, _ = col._attempt(n, np.array([0.0, 1.0]), ph)  # the proposal (0, 100) would cross y = 50
    np.testing.assert_allclose(col.net.xy[reached], [0.0, 50.0])


# --------------------------------------------------------------------------- inter-connection (001 §4.2.1)


def test_the_force_formula_and_the_ideal_directions():
    assert connection_force(0.0, 0.0, 100.0) == 1.0
    assert connection_force(180.0, 10.0, 100.0) == 0.0
    assert connection_force(45.0, 100.0, 100.0) == 0.0
    assert connection_force(90.0, 50.0, 100.0) == pytest.approx(0.25)
    # no descendants: straight on along the incoming connection, or perpendicular to it
    np.testing.assert_allclose(np.sort(ideal_directions(np.array([[0.0, -1.0]]), np.array([0.0, 1.0]))),
                               [0.0, 90.0, 180.0])
    # with descendants: bisectors of consecutive connection directions (E, N, W → 45°, 135°, 270°)
    np.testing.assert_allclose(np.sort(ideal_directions(np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]), None)),
                               [45.0, 135.0, 270.0])


def test_the_strongest_candidate_connects():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], min_angle=(0.0, 0.0))
    ph2 = _Phase.of(col.o, 2)
    _, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)  # ideal: north, east, west
    east, _ = branch(col, [(70.0, 0.0), (70.0, -300.0)], level=1)  # α = 0, |NC| = 70: force 0.30
    diag, _ = branch(col, [(-35.0, 35.0), (-300.0, 300.0)], level=1)  # α = 45°, |NC| = 49.5: force 0.38
    for m in range(n + 1, col.net.n):
        col.net.phase[m] = 0  # only n chooses
    col.interconnect(ph2)
    forces = connection_force(np.array([0.0, 45.0]), np.array([70.0, np.hypot(35, 35)]), SL)
    assert forces[1] > forces[0]
    assert diag in col.net.adj[n] and east not in col.net.adj[n]


def test_inter_connection_never_closes_a_triangle():
    col, ph = board([[(-1000, -1500), (1000, -1500)]], min_angle=(0.0, 0.0))
    p, n = branch(col, [(0.0, -100.0), (0.0, 0.0)], level=1)
    c, _ = branch(col, [(60.0, -20.0), (300.0, -20.0)], level=1)
    col.net.add_edge(p, c, level=1, phase=1)  # c shares the neighbour p with n
    col.interconnect(_Phase.of(col.o, 2))
    assert c not in col.net.adj[n]


# --------------------------------------------------------------------------- extra pruning (001 §4.2.4)


def test_extra_pruning_cuts_a_triangle_corner_of_degree_two_only():
    # a, b of degree >= 3 (each has an outside street), c of degree 2: c loses its less important edge
    edges = np.array([[0, 1], [0, 2], [1, 2], [0, 3], [1, 4]])  # a=0, b=1, c=2
    level = np.array([1, 2, 1, 1, 1])
    keep = extra_pruning(edges, deletable=np.ones(5, bool), level=level, length=np.ones(5))
    assert keep.tolist() == [True, False, True, True, True]
    # all three of degree >= 3: stays
    edges3 = np.vstack([edges, [[2, 5]]])
    assert extra_pruning(edges3, deletable=np.ones(6, bool), level=np.ones(6), length=np.ones(6)).all()
    # a road-end triangle (two corners of degree 2) stays
    end = np.array([[0, 1], [0, 2], [1, 2], [0, 3]])
    assert extra_pruning(end, deletable=np.ones(4, bool), level=np.ones(4), length=np.ones(4)).all()
    # the old town's edges are never deleted
    assert extra_pruning(edges, deletable=np.zeros(5, bool), level=level, length=np.ones(5)).all()


# --------------------------------------------------------------------------- steepness (001 §4.3.1)


def test_steepness_is_checked_between_sample_points():
    ramp = Raster(origin=(0.0, 0.0), cell=10.0, values=np.tile(np.arange(20.0) * 1.0, (5, 1)))  # 10 % grade
    a, b = np.array([[15.0, 25.0]]), np.array([[165.0, 25.0]])
    assert slopes_within(ramp, a, b, max_steepness_deg=10.0, samples=4)[0]  # atan(0.1) = 5.7°
    assert not slopes_within(ramp, a, b, max_steepness_deg=5.0, samples=4)[0]
    valley = np.zeros((3, 21))
    valley[:, 10] = -60.0
    pit = Raster(origin=(0.0, 0.0), cell=10.0, values=valley)
    a, b = np.array([[5.0, 15.0]]), np.array([[205.0, 15.0]])
    assert slopes_within(pit, a, b, max_steepness_deg=10.0, samples=0)[0]  # ends level: 001 fig. 88a
    assert not slopes_within(pit, a, b, max_steepness_deg=10.0, samples=9)[0]  # the valley: fig. 88b


def test_growth_stops_at_a_cliff():
    values = np.zeros((40, 40))
    values[20:] = 500.0  # a 500 m cliff at y = 1000 m
    height = Raster(origin=(0.0, 0.0), cell=50.0, values=values)
    region = shapely.box(0, 0, 2000, 2000)
    seed = np.array([[0.0, 0.0], [2000.0, 0.0]])
    res = colonise(region, seeds=[seed], forbidden=None, options=ColonisationOptions(segment_length=SL),
                   rng=np.random.default_rng(0), height=height)
    used = np.unique(res.edges)
    assert len(res.edges) > 20 and res.xy[used, 1].max() < 1000.0


# --------------------------------------------------------------------------- information maps


def test_rasters_sample_bilinear_and_nearest():
    r = Raster(origin=(100.0, 200.0), cell=10.0, values=np.array([[0.0, 1.0], [2.0, 3.0]]))
    assert r.sample(np.array([[105.0, 205.0]]))[0] == 0.0  # a cell centre
    assert r.sample(np.array([[110.0, 210.0]]))[0] == pytest.approx(1.5)  # between all four
    assert r.sample(np.array([[119.0, 201.0]]), nearest=True)[0] == 1.0
    assert r.bounds == (100.0, 200.0, 120.0, 220.0)


def test_density_from_points_peaks_at_the_cluster_and_keeps_its_floor():
    pts = np.random.default_rng(0).normal([300.0, 300.0], 20.0, size=(200, 2))
    dens = density_from_points(pts, bounds=(0, 0, 1000, 1000), cell=20.0, bandwidth=60.0, floor=0.2)
    assert dens.values.max() == pytest.approx(1.0) and dens.values.min() == pytest.approx(0.2, abs=1e-6)
    assert dens.sample(np.array([[300.0, 300.0]]))[0] > 0.9 > 0.3 > dens.sample(np.array([[900.0, 900.0]]))[0]


def test_a_town_density_covers_the_region_with_a_margin_and_fades_to_its_floor():
    town = np.random.default_rng(1).uniform([0.0, 0.0], [1000.0, 1000.0], size=(500, 2))
    dens = town_density(town, bounds=(1000.0, 0.0, 3000.0, 1000.0), segment_length=100.0)
    opts = InfoMapOptions()
    assert dens.cell == opts.cell * 100.0
    assert dens.bounds[0] == 1000.0 - opts.margin * 100.0 and dens.bounds[2] >= 3000.0 + opts.margin * 100.0
    near, far = dens.sample(np.array([[1100.0, 500.0], [2900.0, 500.0]]))
    assert near > 0.6 > opts.floor == pytest.approx(far, abs=0.01)


def test_border_maps_round_trip_to_forbidden_ground():
    lake = shapely.Point(500, 500).buffer(200)
    border = border_from_geometries([lake], bounds=(0, 0, 1000, 1000), cell=10.0)
    assert border.sample(np.array([[500.0, 500.0]]), nearest=True)[0] == 1.0
    assert border.sample(np.array([[50.0, 50.0]]), nearest=True)[0] == 0.0
    assert forbidden_cells(border).area == pytest.approx(lake.area, rel=0.03)


def test_no_attraction_point_or_street_on_forbidden_ground_and_density_steers_the_points():
    region = shapely.box(0, 0, 3000, 3000)
    lake = shapely.box(1000, 1000, 2000, 2000)
    dens = Raster(origin=(0.0, 0.0), cell=100.0, values=np.repeat([[1.0] * 15 + [0.0] * 15], 30, axis=0))  # east empty
    seed = np.array([[0.0, 0.0], [3000.0, 0.0]])
    res = colonise(region, seeds=[seed], forbidden=lake, options=ColonisationOptions(segment_length=SL),
                   rng=np.random.default_rng(1), density=dens)
    aps = res.attraction_xy
    assert not shapely.intersects_xy(lake, aps[:, 0], aps[:, 1]).any()
    first = (res.attraction_phase == 1).sum()
    expected = (3000 * 1500 - 1000 * 500) / SL ** 2  # one AP per SL² on the allowed, dense half
    assert (aps[:, 0] < 1550.0).all() and 0.85 * expected < first < 1.15 * expected
    assert referee(res, [seed], region, lake) == {"crossings": 0, "short": 0, "forbidden": 0, "outside": 0}


# --------------------------------------------------------------------------- whole runs


def test_streets_chain_straight_through_junctions_of_their_level():
    xy = np.array([[0, 0], [100, 0], [200, 0], [100, 100], [100, -100]], dtype=float)
    edges = np.array([[0, 1], [1, 2], [1, 3], [1, 4]])
    deg = np.bincount(edges.ravel())
    streets = chain_streets(edges, xy, np.array([0, 0, 1, 1]), degree=deg, max_turn_deg=45.0)
    assert sorted(map(sorted, streets)) == [[0, 1, 2], [1, 3, 4]]
    streets = chain_streets(edges, xy, np.array([0, 0, 1, 2]), degree=deg, max_turn_deg=45.0)
    assert len(streets) == 3  # a cross street of two levels breaks at the junction


def test_a_district_grows_from_the_old_street_with_its_debug_layers():
    region = shapely.box(0, 0, 2000, 2000)
    seed = np.array([[-200.0, 0.0], [2200.0, 0.0]])
    flow = flow_field([FlowPrimitive("uniform", strength=1.0, direction_deg=10.0)], bounds=region.bounds,
                      cell=200.0)
    res = colonise(region, seeds=[seed], forbidden=None, options=ColonisationOptions(segment_length=SL),
                   rng=np.random.default_rng(3), flow=flow)
    assert len(res.streets) > 10 and len(res.joins) >= 2
    assert all(j.seed == 0 and abs(j.xy[1]) < 1e-6 for j in res.joins)
    assert {s.level for s in res.streets} <= {0, 1, 2}
    assert all(s.highway == res.options.highways[s.level] for s in res.streets)
    assert sum(len(s.nodes) - 1 for s in res.streets) == len(res.edges)  # every edge in exactly one street
    feats = res.debug_features(flow_step=2)
    layers = {f["properties"]["layer"] for f in feats}
    assert layers == {"attraction_point", "flow_vector", "flow_primitive", "parameters"}
    json.dumps(feats)


def test_same_generator_same_streets():
    region = shapely.Polygon([(0, 0), (1800, 200), (1500, 1700), (100, 1500)])
    seed = np.array([[0.0, 0.0], [900.0, 100.0], [1800.0, 200.0]])
    run = lambda s: colonise(region, seeds=[seed], forbidden=None,  # noqa: E731
                             options=ColonisationOptions(segment_length=SL), rng=np.random.default_rng(s))
    a, b, c = run(5), run(5), run(6)
    np.testing.assert_array_equal(a.edges, b.edges)
    np.testing.assert_array_equal(a.xy, b.xy)
    assert [s.nodes for s in a.streets] == [s.nodes for s in b.streets]
    assert not np.array_equal(a.attraction_xy, c.attraction_xy)


ANGLES = [(0.0, 180.0), (90.0, 90.0), (30.0, 45.0), (80.0, 100.0)]


@st.composite
def scenes(draw):
    w = draw(st.integers(8, 16)) * 50.0
    h = draw(st.integers(8, 16)) * 50.0
    tilt = draw(st.integers(-30, 30)) * 10.0
    region = shapely.Polygon([(0, 0), (w, tilt), (w + tilt, h), (tilt, h + tilt)])
    seeds = []
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(2, 4))
        pts = [(draw(st.integers(-2, 18)) * 50.0, draw(st.integers(-2, 18)) * 50.0) for _ in range(k)]
        if len(set(pts)) == k:
            seeds.append(np.array(pts))
    if not seeds:
        seeds = [np.array([(0.0, 0.0), (w, tilt)])]
    forbidden = None
    if draw(st.booleans()):
        forbidden = shapely.Point(draw(st.integers(2, 14)) * 50.0, draw(st.integers(2, 14)) * 50.0).buffer(120.0)
    opts = ColonisationOptions(
        segment_length=50.0, ap_density=(draw(st.sampled_from([0.3, 1.0])),) * 2,
        kill_distance=(draw(st.sampled_from([1.0, 2.0, 3.0])), 0.0), nodes_per_ap=(1, draw(st.sampled_from([1, 2, 4]))),
        angle_range_1=draw(st.sampled_from(ANGLES)), angle_range_2=draw(st.sampled_from(ANGLES)),
        snap_distance=draw(st.sampled_from([0.2, 0.4])), seed_spacing=draw(st.sampled_from([1.0, 2.0])),
        min_angle=(draw(st.sampled_from([0.0, 30.0])),) * 2)
    return region, seeds, forbidden, opts, draw(st.integers(0, 1000))


@settings(max_examples=max(settings().max_examples // 5, 10), deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
def test_grown_streets_are_planar_inside_the_region_and_off_forbidden_ground(scene):
    region, seeds, forbidden, opts, seed = scene
    res = colonise(region, seeds=seeds, forbidden=forbidden, options=opts, rng=np.random.default_rng(seed))
    assert referee(res, seeds, region, forbidden) == {"crossings": 0, "short": 0, "forbidden": 0, "outside": 0}
    assert not (degrees(res)[np.unique(res.edges)] == 0).any()


# --------------------------------------------------------------------------- capillarity and the grid (001 §5.3)


def capillarity(kd1: float, kd2: float, seed: int, second_phase: bool) -> tuple[float, float]:
    """§5.3's set-up (RoI 5, SL 1, N = 4, 2500 APs per phase on 100 × 100 SL, 1 %/1 %, 90°):
    dead-end share (dead ends among dead ends and junctions) and street length per SL²."""
    sl = 10.0
    opts = ColonisationOptions(segment_length=sl, radius_of_influence=5.0, kill_distance=(kd1, kd2),
                               nodes_per_ap=(1, 4), ap_density=(0.25, 0.25), angle_range_1=(90.0, 90.0),
                               angle_range_2=(90.0, 90.0), hierarchy_threshold=(0.01, 0.01),
                               second_phase=second_phase)
    region = shapely.box(0, 0, 100 * sl, 100 * sl)
    res = colonise(region, seeds=[np.array([[0.0, 0.0], [100 * sl, 0.0]])], forbidden=None, options=opts,
                   rng=np.random.default_rng(seed))
    deg = degrees(res)
    ends, junctions = (deg == 1).sum(), (deg >= 3).sum()
    length = np.hypot(*(res.xy[res.edges[:, 0]] - res.xy[res.edges[:, 1]]).T).sum() / sl
    return ends / max(ends + junctions, 1), length / 100 ** 2


def test_capillarity_more_kill_distance_more_dead_ends_and_fewer_streets():
    # 001 fig. 96: the first phase at KD 2, 3, 4 ("as the kill distance increases, the percentage of
    # dead-ends in the network increases. The road density also decreases")
    runs = np.array([[capillarity(kd, 0.0, s, second_phase=False) for s in range(3)] for kd in (2.0, 3.0, 4.0)])
    share, density = runs[:, :, 0].mean(axis=1), runs[:, :, 1].mean(axis=1)
    assert share[0] < share[1] < share[2]
    assert density[0] > density[1] > density[2]


def test_capillarity_in_the_second_phase_fewer_streets_as_its_kill_distance_grows():
    # 001 fig. 97: the second phase at KD 1.0, 1.5, 2.0 after a first phase at KD 3
    runs = np.array([[capillarity(3.0, kd, s, second_phase=True) for s in range(2)] for kd in (1.0, 2.0)])
    share, density = runs[:, :, 0].mean(axis=1), runs[:, :, 1].mean(axis=1)
    assert density[0] > density[1]
    assert share[0] < share[1]


def test_a_right_angled_first_phase_makes_right_angled_junctions():
    opts = ColonisationOptions(segment_length=SL, angle_range_1=(90.0, 90.0), second_phase=False)
    region = shapely.box(0, 0, 3000, 3000)
    seed = np.array([[0.0, 0.0], [3000.0, 0.0]])
    good = total = 0
    for s in range(3):
        res = colonise(region, seeds=[seed], forbidden=None, options=opts, rng=np.random.default_rng(s))
        xy, edges = res.xy, res.edges
        # junctions of the whole network: grown edges plus the old street's pieces at each grown node on it
        nbrs: dict[int, list[np.ndarray]] = {}
        for u, v in edges.tolist():
            nbrs.setdefault(u, []).append(xy[v] - xy[u])
            nbrs.setdefault(v, []).append(xy[u] - xy[v])
        for j in res.joins:
            for end in ((0.0, 0.0), (3000.0, 0.0)):
                if abs(j.xy[0] - end[0]) > 1e-6:
                    nbrs.setdefault(j.node, []).append(np.subtract(end, j.xy))
        for d in nbrs.values():
            if len(d) < 3:
                continue
            ang = np.sort(np.mod(np.degrees(np.arctan2([v[1] for v in d], [v[0] for v in d])), 360.0))
            gaps = np.diff(np.append(ang, ang[0] + 360.0))
            off = np.minimum(np.abs(gaps - 90.0), np.abs(gaps - 180.0))  # a street running straight through
            total += 1
            good += bool((off <= 10.0).all())
    assert total > 30 and good / total >= 0.8
