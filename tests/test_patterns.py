"""Beneš street patterns (000 §4.2.6), the street graph, and the nuclei/candidate ranking (003 §3.3.2)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from osm_expand.engine.growth.nuclei import (
    Candidates,
    NucleiOptions,
    Nucleus,
    NucleusKind,
    candidate_points,
    candidate_rank,
    edge_attenuation,
    find_nuclei,
    new_junction_nuclei,
    rank_candidates,
)
from osm_expand.errors import InputError
from synth.patterns import (
    GRID_19TH_CENTURY,
    PATTERNS,
    RADIAL,
    PatternOptions,
    Proposal,
    Rule,
    Start,
    StreetProposal,
    check_proposal,
    grow_streets,
    pattern,
    propose,
)
from synth.segment_index import _intersects
from synth.street_graph import StreetGraph

#: Rules with round thresholds for hand-built maps; bridges off unless a test turns them on.
BASE = PatternOptions(min_angle_deg=30.0, min_length_m=10.0, max_length_m=200.0, min_cs_distance_m=5.0,
                      min_cc_distance_m=5.0, snap_radius_m=25.0, look_ahead=1.5, max_degree=4,
                      bridges_enabled=False)


def graph(xy, edges, **kw) -> StreetGraph:
    return StreetGraph.from_segments(np.asarray(xy, dtype=float), np.asarray(edges).reshape(-1, 2), **kw)


def stub(*extra_xy, extra_edges=()):
    """Start S = node 0 at the origin with one street west to node 1, plus extra nodes (from 2) and edges."""
    xy = [(0.0, 0.0), (-100.0, 0.0), *extra_xy]
    return graph(xy, [(0, 1), *extra_edges])


def new_end(x, y) -> StreetProposal:
    return StreetProposal(Proposal.DEFAULT, (float(x), float(y)))


def fixed(angle_deg: float, length: float = 50.0, **kw) -> PatternOptions:
    """Always draw this world angle and length."""
    base = {**{f: getattr(BASE, f) for f in BASE.__dataclass_fields__}, **dict(
        angle_space="world", angle_pdf=((angle_deg, 1.0),), angle_pdf_kind="discrete", angle_spread_deg=0.0,
        length_mean_m=length, length_sd_m=0.0, attempts_per_start=1)}
    return PatternOptions(**{**base, **kw})


def segment_crossings(g: StreetGraph) -> int:
    """Pairs of segments that touch away from a shared node (brute force)."""
    xy, e = g.xy, g.edges
    bad = 0
    for k in range(len(e)):
        share = np.isin(e[:, 0], e[k]) | np.isin(e[:, 1], e[k])
        bad += int(_intersects(xy[e[k, 0]], xy[e[k, 1]], xy[e[~share, 0]], xy[e[~share, 1]]).sum())
    return bad


# ------------------------------------------------------------------ the street graph

def test_graph_builds_adjacency_grid_and_attributes():
    g = graph([(0, 0), (100, 0), (100, 100), (500, 500)], [(0, 1), (1, 2)], created=[1.0, 2.0],
              bridge=[False, True], major=[True, False], cell=10.0)
    assert g.n_nodes == 4 and g.n_segments == 2
    assert g.degree.tolist() == [1, 2, 1, 0]
    assert g.neighbours(1) == [0, 2]
    assert g.created.tolist() == [1.0, 2.0] and g.bridge.tolist() == [False, True]
    assert g.segments_in_box((40, -5), (60, 5)).tolist() == [0]
    ids, d = g.nodes_within((95, 5), 10)
    assert ids.tolist() == [1] and d[0] == pytest.approx(math.hypot(5, 5))
    assert g.nearest_node((480, 470)) == 3
    assert g.segment_at((100, 30)) == 1
    assert g.crosses((50, -10), (50, 10)) and not g.crosses((50, 10), (60, 20))


def test_split_keeps_the_id_for_the_first_half_and_appends_the_second():
    g = graph([(0, 0), (100, 0)], [(0, 1)], created=[3.0], major=[True], cell=10.0)
    w = g.split(0, (40, 0.3))
    assert w == 2 and g.xy[w].tolist() == [40.0, 0.0]          # projected onto the segment
    assert g.edges.tolist() == [[0, 2], [2, 1]]
    assert g.major.tolist() == [True, True] and g.created.tolist() == [3.0, 3.0]
    assert g.degree.tolist() == [1, 1, 2]
    assert g.segment_at((20, 0)) == 0 and g.segment_at((70, 0)) == 1
    assert g.segments_in_box((60, -1), (80, 1)).tolist() == [1]


def test_copy_is_independent():
    g = graph([(0, 0), (100, 0)], [(0, 1)], cell=10.0)
    h = g.copy()
    h.split(0, (50, 0))
    assert g.n_segments == 1 and h.n_segments == 2
    assert g.segments_in_box((60, -1), (80, 1)).tolist() == [0]


def test_graph_rejects_bad_edges():
    with pytest.raises(InputError, match="outside"):
        graph([(0, 0)], [(0, 1)])
    with pytest.raises(InputError, match="itself"):
        graph([(0, 0), (1, 1)], [(1, 1)])


# ------------------------------------------------------------------ the four proposals

def test_default_alone_in_empty_space():
    g = stub()
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)
    assert [p.kind for p in props] == [Proposal.DEFAULT]
    assert props[0].end_xy == pytest.approx((50.0, 0.0))


def test_shorten_ends_at_the_first_street_crossed():
    g = stub((30, -50), (30, 50), (40, -50), (40, 50), extra_edges=[(2, 3), (4, 5)])
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)
    assert [p.kind for p in props] == [Proposal.SHORTEN, Proposal.DEFAULT]
    assert props[0].end_xy == pytest.approx((30.0, 0.0)) and props[0].end_segment == 1


def test_extend_reaches_a_street_within_the_look_ahead():
    g = stub((65, -50), (65, 50), (80, -50), (80, 50), extra_edges=[(2, 3), (4, 5)])
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)
    assert [p.kind for p in props] == [Proposal.EXTEND, Proposal.DEFAULT]
    assert props[0].end_xy == pytest.approx((65.0, 0.0)) and props[0].end_segment == 1
    beyond = stub((76, -50), (76, 50), extra_edges=[(2, 3)])   # 76 m > 1.5 × 50 m
    assert [p.kind for p in propose(beyond, Start.at_node(beyond, 0), angle=0.0, length=50.0,
                                    options=BASE)] == [Proposal.DEFAULT]


def test_a_hit_at_a_street_end_becomes_that_crossing():
    g = stub((30, 0), (30, 50), extra_edges=[(2, 3)])
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=replace_opts(snap_enabled=False))
    assert props[0].kind is Proposal.SHORTEN and props[0].end_node == 2 and props[0].end_segment == -1


def test_snap_takes_the_nearest_crossing_near_the_default_end():
    g = stub((60, 10), (120, 10), (45, 20), extra_edges=[(2, 3), (4, 2)])
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)
    assert props[0].kind is Proposal.SNAP and props[0].end_node == 2    # 11.2 m, nearer than node 4


def test_proposals_come_in_the_order_snap_shorten_extend_default():
    g = stub((30, -50), (30, 50), (65, -50), (65, 50), (52, 3), (52, 40),
             extra_edges=[(2, 3), (4, 5), (6, 7)])
    kinds = [p.kind for p in propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)]
    assert kinds == [Proposal.SNAP, Proposal.SHORTEN, Proposal.EXTEND, Proposal.DEFAULT]
    off = PatternOptions.from_mapping({**{f: getattr(BASE, f) for f in BASE.__dataclass_fields__},
                                       "snap_enabled": False, "extend_enabled": False})
    kinds = [p.kind for p in propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=off)]
    assert kinds == [Proposal.SHORTEN, Proposal.DEFAULT]


def test_streets_sharing_the_start_crossing_are_not_intersections():
    g = stub((50, 50), (50, -50), extra_edges=[(0, 2), (0, 3)])
    props = propose(g, Start.at_node(g, 0), angle=0.0, length=50.0, options=BASE)
    assert [p.kind for p in props] == [Proposal.DEFAULT]


# ------------------------------------------------------------------ first valid wins

def grow_once(g, start, options, **kw):
    return grow_streets(g, [start] if isinstance(start, Start) else [start], options=options,
                        rng=np.random.default_rng(0), **kw)


def test_a_valid_snap_wins_over_default():
    g = stub((60, 10), (120, 10), extra_edges=[(2, 3)])
    step = grow_once(g, 0, fixed(0.0))
    assert step.proposal.tolist() == ["snap"] and g.edges[step.new_segments[0]].tolist() == [0, 2]
    assert len(step.new_nodes) == 0


def test_an_invalid_snap_falls_through_to_shorten():
    g = stub((60, 10), (120, 10), (60, 60), (60, -60), (110, 60), (30, -50), (30, 50),
             extra_edges=[(2, 3), (2, 4), (2, 5), (2, 6), (7, 8)])     # node 2 has degree 4
    step = grow_once(g, 0, fixed(0.0))
    assert step.proposal.tolist() == ["shorten"]
    assert g.xy[step.new_nodes[0]] == pytest.approx((30.0, 0.0))
    assert step.split_segment.tolist() == [5] and step.split_node.tolist() == step.new_nodes.tolist()


def test_extend_wins_over_default_and_splits_the_street_it_reaches():
    g = stub((65, -50), (65, 50), extra_edges=[(2, 3)])
    step = grow_once(g, 0, fixed(0.0))
    assert step.proposal.tolist() == ["extend"]
    node = step.split_node[0]
    assert g.xy[node] == pytest.approx((65.0, 0.0)) and g.node_degree(node) == 3
    assert g.edges[step.split_new_segment[0]].tolist() == [node, 3]


def test_default_when_nothing_else_applies():
    g = stub()
    step = grow_once(g, 0, fixed(90.0))
    assert step.proposal.tolist() == ["default"] and g.xy[step.new_nodes[0]] == pytest.approx((0.0, 50.0))
    assert g.spawned[0] and step.grown.tolist() == [True] and step.start_node.tolist() == [0]


def test_switched_off_methods_are_skipped():
    g = stub((60, 10), (120, 10), extra_edges=[(2, 3)])
    step = grow_once(g, 0, fixed(0.0, snap_enabled=False))
    assert step.proposal.tolist() == ["default"]
    h = stub()
    assert grow_once(h, 0, fixed(90.0, default_enabled=False)).grown.tolist() == [False]
    assert h.spawned[0]          # exhausted starts are marked, so they leave the candidate set


# ------------------------------------------------------------------ the seven rules

def test_rule_a_no_crossing_of_streets():
    g = stub((30, -50), (30, 50), extra_edges=[(2, 3)])
    s = Start.at_node(g, 0)
    assert check_proposal(g, s, new_end(60, 0), options=BASE) is Rule.CROSSING
    assert check_proposal(g, s, new_end(20, 0), options=BASE) is None


def test_rule_a_no_passing_through_a_crossing():
    g = stub((30, 0), (30, 50), extra_edges=[(2, 3)])
    options = replace_opts(min_cs_distance_m=0.0, min_cc_distance_m=0.0)
    assert check_proposal(g, Start.at_node(g, 0), new_end(60, 0), options=options) is Rule.CROSSING


def replace_opts(**kw) -> PatternOptions:
    return PatternOptions.from_mapping({**{f: getattr(BASE, f) for f in BASE.__dataclass_fields__}, **kw})


def test_rule_b_minimum_angle_at_the_start_and_at_the_end():
    g = stub((50, 0), (10, 8), (100, 40), extra_edges=[(2, 3)])
    s = Start.at_node(g, 0)
    a = math.radians(170)
    assert check_proposal(g, s, new_end(50 * math.cos(a), 50 * math.sin(a)), options=BASE) is Rule.ANGLE
    assert check_proposal(g, s, new_end(0, 50), options=BASE) is None
    snap = StreetProposal(Proposal.SNAP, (50.0, 0.0), end_node=2)    # node 2's street runs back at 11°
    assert check_proposal(g, s, snap, options=BASE) is Rule.ANGLE
    h = stub((50, 0), (100, 10), extra_edges=[(2, 3)])
    assert check_proposal(h, Start.at_node(h, 0), snap, options=BASE) is None


def test_rule_c_length_range():
    g = stub()
    s = Start.at_node(g, 0)
    options = replace_opts(min_cc_distance_m=3.0)
    assert check_proposal(g, s, new_end(8, 0), options=options) is Rule.LENGTH
    assert check_proposal(g, s, new_end(250, 0), options=options) is Rule.LENGTH
    assert check_proposal(g, s, new_end(12, 0), options=options) is None


def test_rule_d_distance_to_other_streets():
    s_close = stub((10, 3), (40, 3), extra_edges=[(2, 3)])
    s_far = stub((10, 8), (40, 8), extra_edges=[(2, 3)])
    assert check_proposal(s_close, Start.at_node(s_close, 0), new_end(50, 0), options=BASE) is Rule.CS_DISTANCE
    assert check_proposal(s_far, Start.at_node(s_far, 0), new_end(50, 0), options=BASE) is None


def test_rule_e_new_crossing_distance_to_crossings():
    options = replace_opts(min_cs_distance_m=2.0, min_cc_distance_m=10.0)
    g = stub((56, 0), (56, 40), extra_edges=[(2, 3)])
    assert check_proposal(g, Start.at_node(g, 0), new_end(50, 0), options=options) is Rule.CC_DISTANCE
    assert check_proposal(g, Start.at_node(g, 0), new_end(45, 0), options=options) is None


def test_rule_e_applies_to_a_start_that_splits_a_segment():
    g = graph([(0, 0), (100, 0)], [(0, 1)])
    options = replace_opts(min_cc_distance_m=10.0)
    assert check_proposal(g, Start.on_segment(0, (5, 0)), new_end(5, 50), options=options) is Rule.CC_DISTANCE
    assert check_proposal(g, Start.on_segment(0, (50, 0)), new_end(50, 50), options=options) is None


def test_rule_f_no_triangles():
    g = graph([(0, 0), (0, -60), (60, -60)], [(0, 1), (1, 2)])
    s = Start.at_node(g, 0)
    assert check_proposal(g, s, StreetProposal(Proposal.SNAP, (60.0, -60.0), end_node=2), options=BASE) is Rule.TRIANGLE
    on_ab = StreetProposal(Proposal.SHORTEN, (45.0, -60.0), end_segment=1)
    assert check_proposal(g, s, on_ab, options=BASE) is Rule.TRIANGLE
    h = graph([(0, 0), (-60, 0), (0, -60), (60, -60)], [(0, 1), (2, 3)])   # no S–A street: no triangle
    assert check_proposal(h, Start.at_node(h, 0), StreetProposal(Proposal.SNAP, (60.0, -60.0), end_node=3),
                          options=BASE) is None


def test_rule_g_maximum_degree():
    options = replace_opts(max_degree=3)
    g = stub((50, 0), (50, 60), (50, -60), (100, 0), extra_edges=[(2, 3), (2, 4), (2, 5)])
    to_full = StreetProposal(Proposal.SNAP, (50.0, 0.0), end_node=2)
    assert check_proposal(g, Start.at_node(g, 0), to_full, options=options) is Rule.DEGREE
    assert check_proposal(g, Start.at_node(g, 0), to_full, options=BASE) is None
    busy = stub((0, 60), (0, -60), extra_edges=[(0, 2), (0, 3)])
    assert check_proposal(busy, Start.at_node(busy, 0), new_end(50, 0), options=options) is Rule.DEGREE


# ------------------------------------------------------------------ water, forbidden, bridges

RIVER = shapely.box(30, -500, 60, 500)   # 30 m wide, north–south


def test_a_street_may_not_end_in_water_nor_cross_it_without_bridges():
    g = stub()
    s = Start.at_node(g, 0)
    assert check_proposal(g, s, new_end(40, 0), options=BASE, water=RIVER) is Rule.WATER
    assert check_proposal(g, s, new_end(80, 0), options=BASE, water=RIVER) is Rule.WATER
    assert check_proposal(g, s, new_end(0, 80), options=BASE, water=RIVER) is None


def test_forbidden_areas_are_not_touched():
    g = stub()
    zone = shapely.box(20, -5, 30, 5)
    assert check_proposal(g, Start.at_node(g, 0), new_end(50, 0), options=BASE, forbidden=zone) is Rule.FORBIDDEN
    assert check_proposal(g, Start.at_node(g, 0), new_end(15, 0), options=BASE, forbidden=zone) is None


def test_a_proposal_over_water_is_a_bridge_with_its_limits():
    options = replace_opts(bridges_enabled=True, max_bridge_length_m=100.0, min_bridge_spacing_m=200.0,
                           bridge_rays=0)
    g = stub()
    s = Start.at_node(g, 0)
    assert check_proposal(g, s, new_end(80, 0), options=options, water=RIVER) is None
    assert check_proposal(g, s, new_end(80, 0), options=replace_opts(
        bridges_enabled=True, max_bridge_length_m=60.0, bridge_rays=0), water=RIVER) is Rule.BRIDGE_LENGTH
    g.bridge_tried[0] = True
    assert check_proposal(g, s, new_end(80, 0), options=options, water=RIVER) is Rule.BRIDGE_ATTEMPT
    near = graph([(0, 0), (-100, 0), (0, 150), (90, 150)], [(0, 1), (2, 3)], bridge=[False, True])
    assert check_proposal(near, Start.at_node(near, 0), new_end(80, 0), options=options,
                          water=RIVER) is Rule.BRIDGE_SPACING


def test_one_bridge_attempt_per_crossing():
    options = fixed(0.0, length=80.0, bridges_enabled=True, max_bridge_length_m=100.0,
                    min_bridge_spacing_m=200.0, bridge_rays=0)
    g = graph([(0, 0), (-100, 0), (0, 150), (90, 150)], [(0, 1), (2, 3)], bridge=[False, True])
    first = grow_once(g, 0, options, water=RIVER)                       # too near the other bridge
    assert not first.grown[0] and g.bridge_tried[0]
    g2 = graph([(0, 0), (-100, 0)], [(0, 1)])
    g2.bridge_tried[0] = True                                           # attempt already used
    assert not grow_once(g2, 0, options, water=RIVER).grown[0]
    g3 = graph([(0, 0), (-100, 0)], [(0, 1)])
    step = grow_once(g3, 0, options, water=RIVER)
    assert step.bridges.tolist() == step.new_segments.tolist() and g3.bridge[step.new_segments[0]]
    assert g3.bridge_tried[0] and g3.bridge_tried[step.new_nodes[0]]


def test_a_crossing_near_water_shoots_rays_for_the_shortest_bridge():
    options = fixed(90.0, bridges_enabled=True, max_bridge_length_m=120.0, bridge_rays=32)
    g = graph([(15, 0), (-100, 0)], [(0, 1)])                           # 15 m from the river bank
    step = grow_once(g, 0, options, water=RIVER)
    assert step.proposal.tolist() == ["bridge"] and len(step.bridges) == 1
    end = g.xy[step.new_nodes[0]]
    assert end[0] > 60 and not shapely.intersects_xy(RIVER, *end)
    assert np.hypot(*(end - g.xy[0])) < 55                              # about perpendicular: 45 m + sampling


# ------------------------------------------------------------------ frames, lengths, starts on segments

def test_crossing_space_measures_from_the_time_wise_first_street():
    g = graph([(0, 0), (-100, 0), (0, 100)], [(0, 1), (0, 2)], created=[1.0, 2.0])   # west is older
    options = fixed(90.0, angle_space="crossing")
    step = grow_once(g, 0, options)
    assert g.xy[step.new_nodes[0]] == pytest.approx((0.0, -50.0))        # 180° + 90° = south


def test_world_grid_lengths_follow_the_orientation():
    g = graph([(0, 0), (-110, 0)], [(0, 1)])
    options = PatternOptions.from_mapping({**{f: getattr(GRID_19TH_CENTURY, f) for f in
                                              GRID_19TH_CENTURY.__dataclass_fields__}, "length_jitter": 0.0,
                                           "attempts_per_start": 20, "streets_per_start": 3})
    grow_once(g, 0, options)
    d = g.xy[g.neighbours(0)] - g.xy[0]
    length, angle = np.hypot(*d.T), np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360
    assert np.allclose(angle % 90, 0, atol=1e-9) and g.node_degree(0) == 4
    assert np.allclose(np.where(np.isclose(angle % 180, 0), 110.0, 70.0), length)


def test_radial_ring_streets_stay_on_their_circle():
    g = graph([(100, 0), (200, 0)], [(0, 1)])
    options = PatternOptions.from_mapping({**{f: getattr(RADIAL, f) for f in RADIAL.__dataclass_fields__},
                                           "angle_pdf": ((90.0, 1.0),), "length_jitter": 0.0})
    step = grow_once(g, 0, options, centre=(0.0, 0.0))
    assert np.hypot(*g.xy[step.new_nodes[0]]) == pytest.approx(100.0)
    with pytest.raises(InputError, match="centre"):
        grow_once(g, 0, options)


def test_a_start_on_a_segment_is_split_only_when_a_street_grows():
    g = graph([(0, 0), (100, 0)], [(0, 1)])
    starts = Candidates(xy=np.array([[50.0, 0.0]]), node=np.array([-1]), segment=np.array([0]), t=np.array([0.5]))
    step = grow_streets(g, starts, options=fixed(90.0), rng=np.random.default_rng(0))
    w = step.start_node[0]
    assert step.split_segment.tolist() == [0] and step.split_node.tolist() == [w]
    assert g.node_degree(w) == 3 and g.spawned[w] and g.xy[step.new_nodes[-1]] == pytest.approx((50.0, 50.0))
    h = graph([(0, 0), (100, 0)], [(0, 1)])
    fail = grow_streets(h, starts, options=fixed(10.0), rng=np.random.default_rng(0))   # 10°: too flat
    assert h.n_segments == 1 and h.n_nodes == 2 and fail.start_node.tolist() == [-1]
    assert fail.failed_xy.tolist() == [[50.0, 0.0]]


def test_patterns_without_segment_starts_skip_them():
    g = graph([(0, 0), (100, 0)], [(0, 1)])
    step = grow_streets(g, [Start.on_segment(0, (50, 0)), Start.at_node(g, 0)],
                        options=fixed(90.0, segment_starts=False), rng=np.random.default_rng(0))
    assert step.grown.tolist() == [False, True] and len(step.failed_xy) == 0 and len(step.split_node) == 0


def test_a_segment_start_is_found_again_after_an_earlier_split():
    g = graph([(0, 0), (200, 0)], [(0, 1)])
    starts = [Start.on_segment(0, (50, 0)), Start.on_segment(0, (150, 0))]
    step = grow_streets(g, starts, options=fixed(90.0), rng=np.random.default_rng(0))
    assert step.grown.tolist() == [True, True] and len(step.split_node) == 2
    assert segment_crossings(g) == 0


# ------------------------------------------------------------------ options

def test_options_reject_bad_values_and_list_valid_choices():
    with pytest.raises(InputError, match="angle_space.*world, crossing, centre"):
        PatternOptions(angle_space="polar")
    with pytest.raises(InputError, match="max_length_m"):
        PatternOptions(min_length_m=50.0, max_length_m=40.0)
    with pytest.raises(InputError, match="min_cs_distance_m"):
        PatternOptions(min_cs_distance_m=-1.0)
    with pytest.raises(InputError, match="length_from_orientation"):
        PatternOptions(length_mode="orientation")
    with pytest.raises(InputError, match="unknown key"):
        PatternOptions.from_mapping({"snap_radius": 25})
    with pytest.raises(InputError, match="not one of"):
        pattern("baroque")


def test_options_from_toml_style_lists_and_named_sets():
    o = PatternOptions.from_mapping({"angle_pdf": [[0, 1], [90, 2]], "angle_space": "world"})
    assert o.angle_pdf == ((0.0, 1.0), (90.0, 2.0)) and o.angle_space == "world"
    assert pattern("grid", min_angle_deg=70.0).min_angle_deg == 70.0
    for name, options in PATTERNS.items():
        assert options.snap_radius_m == 25.0 and options.look_ahead == 1.5, name


# ------------------------------------------------------------------ candidates Z and ranking

def test_candidate_counts_follow_floor_length_over_1_25_ell():
    xy = np.array([[0, 0], [100, 0], [0, 50], [39, 50], [0, 100], [40, 100], [0, 150], [50, 150.0]])
    edges = np.array([[0, 1], [2, 3], [4, 5], [6, 7]])
    z = candidate_points((xy, edges), spawned_mask=np.ones(8, bool), ell=20.0)
    assert np.bincount(z.segment, minlength=4).tolist() == [4, 0, 1, 2]   # 100, 39, 40, 50 m
    assert z.xy[z.segment == 0, 0].tolist() == pytest.approx([20, 40, 60, 80])
    assert z.xy[z.segment == 2].tolist() == [[20.0, 100.0]]
    assert (z.node == -1).all()


def test_candidates_are_unspawned_used_nodes_below_max_degree():
    xy = np.array([[0, 0], [30, 0], [0, 30], [-30, 0], [0, -30], [500, 500.0]])
    edges = np.array([[0, 1], [0, 2], [0, 3], [0, 4]])
    spawned = np.array([False, True, False, False, False, False])
    z = candidate_points((xy, edges), spawned_mask=spawned, ell=20.0)
    assert z.node.tolist() == [0, 2, 3, 4]                                 # not 1 (spawned), not 5 (isolated)
    assert candidate_points((xy, edges), spawned_mask=spawned, ell=20.0, max_degree=4).node.tolist() == [2, 3, 4]


def test_candidates_skip_masked_segments_and_failed_points():
    xy = np.array([[0, 0], [100, 0.0]])
    z = candidate_points((xy, [[0, 1]]), spawned_mask=[True, True], ell=20.0, exclude_points=[[40, 1]])
    assert z.xy[:, 0].tolist() == [20.0, 60.0, 80.0]
    assert len(candidate_points((xy, [[0, 1]]), spawned_mask=[True, True], ell=20.0, segment_mask=[False])) == 0
    assert len(candidate_points((xy, [[0, 1]]), spawned_mask=[True, True], ell=20.0, temporary_points=False)) == 0


def test_rank_is_distance_to_the_nearest_nucleus_times_one_minus_strength():
    nuclei = [Nucleus((0.0, 0.0), 1.0, NucleusKind.CENTRE), Nucleus((100.0, 0.0), 0.5, NucleusKind.JUNCTION)]
    z = np.array([[60.0, 0], [90, 0], [40, 0], [10, 0], [55, 0]])
    rank, dist = candidate_rank(z, nuclei)
    assert rank.tolist() == pytest.approx([20.0, 5.0, 0.0, 0.0, 22.5])    # (55, 0): its nearest is the junction
    assert rank_candidates(z, nuclei, take=3).tolist() == [3, 2, 1]       # centre cell by distance, then 5.0
    assert rank_candidates(z, nuclei, take=10).tolist() == [3, 2, 1, 0, 4]
    with pytest.raises(InputError, match="no nuclei"):
        rank_candidates(z, [], take=1)


def test_equal_ranks_keep_the_candidate_order():
    nuclei = [Nucleus((0.0, 0.0), 0.5, NucleusKind.JUNCTION)]
    z = np.array([[10.0, 0], [0, 10], [-10, 0], [0, -10]])
    assert rank_candidates(z, nuclei, take=4).tolist() == [0, 1, 2, 3]


# ------------------------------------------------------------------ nuclei

def major_cross():
    """A + crossing at (500, 500) and a T at (800, 500) of major roads, with shape nodes between."""
    xy = np.array([[500, 500], [500, 900], [500, 100], [100, 500], [650, 500], [800, 500], [950, 500],
                   [800, 300.0]])
    edges = np.array([[0, 1], [0, 2], [0, 3], [0, 4], [4, 5], [5, 6], [5, 7]])
    return xy, edges


def test_centre_is_the_highest_degree_junction_with_strength_one():
    xy, edges = major_cross()
    nuclei = find_nuclei(xy, edges, bounds=(0, 0, 1000, 1000), join_points=[[200, 200]], bridge_ends=[[300, 700]])
    assert nuclei[0].kind is NucleusKind.CENTRE and nuclei[0].xy == (500.0, 500.0) and nuclei[0].strength == 1.0
    kinds = {n.kind: n for n in nuclei}
    assert kinds[NucleusKind.JUNCTION].xy == (800.0, 500.0) and kinds[NucleusKind.JUNCTION].strength == 0.5
    assert kinds[NucleusKind.JOIN].xy == (200.0, 200.0) and kinds[NucleusKind.BRIDGE].strength == 0.6
    assert len(nuclei) == 4                                               # no nucleus at shape nodes (degree 2)


def test_nuclei_fade_near_the_map_edge_and_merge_when_close():
    assert edge_attenuation([[0, 500], [50, 500], [100, 500], [500, 500]], (0, 0, 1000, 1000), 0.1).tolist() == \
        pytest.approx([0.0, 0.5, 1.0, 1.0])
    xy, edges = major_cross()
    nuclei = find_nuclei(xy, edges, bounds=(0, 0, 1000, 1000), join_points=[[810, 500], [990, 500]])
    by_kind = {}
    for n in nuclei:
        by_kind.setdefault(n.kind, []).append(n)
    assert [n.xy for n in by_kind[NucleusKind.JOIN]] == [(810.0, 500.0), (990.0, 500.0)]
    assert NucleusKind.JUNCTION not in by_kind                            # merged into the join 10 m away
    assert by_kind[NucleusKind.JOIN][1].strength < 0.05                   # 10 m from the edge


def test_new_junction_nuclei_add_chance_ones_from_the_candidates():
    z = np.array([[100.0 * i, 300.0] for i in range(1, 9)])
    existing = [Nucleus((500.0, 500.0), 1.0, NucleusKind.CENTRE)]
    new = new_junction_nuclei([[300, 600], [505, 505]], bounds=(0, 0, 1000, 1000), candidates_xy=z,
                              rng=np.random.default_rng(4), existing=existing,
                              options=NucleiOptions(chance_per_new_junction=2))
    kinds = [n.kind for n in new]
    assert kinds.count(NucleusKind.NEW_JUNCTION) == 1                     # (505, 505) sits on the centre
    assert kinds.count(NucleusKind.CHANCE) == 4
    assert all(any(np.allclose(n.xy, p) for p in z) for n in new if n.kind is NucleusKind.CHANCE)
    again = new_junction_nuclei([[300, 600], [505, 505]], bounds=(0, 0, 1000, 1000), candidates_xy=z,
                                rng=np.random.default_rng(4), existing=existing,
                                options=NucleiOptions(chance_per_new_junction=2))
    assert again == new


# ------------------------------------------------------------------ whole growth: determinism and invariants

def perturbed_grid(n: int, spacing: float, jitter: float, keep: np.ndarray, seed: int):
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    xy = np.stack([i.ravel(), j.ravel()], 1) * spacing + rng.uniform(-jitter, jitter, (n * n, 2))
    idx = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1),
                            np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1)])
    edges = edges[keep[: len(edges)]] if keep is not None else edges
    return xy, edges


def simulate(xy, edges, options, seed, years=4, take=15, water=None):
    """A few engine years on a start graph; returns the graph and a mask of grown streets (and their halves)."""
    g = StreetGraph.from_segments(xy, edges)
    rng = np.random.default_rng(seed)
    lo, hi = xy.min(0) - 300, xy.max(0) + 300
    nuclei = find_nuclei(xy, edges, bounds=(lo[0], lo[1], hi[0], hi[1]))
    failed = np.zeros((0, 2))
    grown: set[int] = set()
    for year in range(years):
        z = candidate_points(g, spawned_mask=g.spawned, ell=20.0, max_degree=options.max_degree,
                             temporary_points=options.segment_starts, exclude_points=failed)
        step = grow_streets(g, z.take(rank_candidates(z.xy, nuclei, take=take)), options=options, rng=rng,
                            centre=nuclei[0].xy, time=float(year), water=water)
        failed = np.concatenate([failed, step.failed_xy])
        for parent, _, half in zip(step.split_segment, step.split_node, step.split_new_segment):
            if parent in grown:
                grown.add(int(half))
        grown.update(step.new_segments.tolist())   # splits of this step's own streets come after them
        for parent, _, half in zip(step.split_segment, step.split_node, step.split_new_segment):
            if parent in grown:
                grown.add(int(half))
    mask = np.zeros(g.n_segments, dtype=bool)
    mask[sorted(grown)] = True
    return g, mask


def test_same_seed_same_city_other_seed_other_city():
    xy, edges = perturbed_grid(5, 100.0, 10.0, None, 0)
    a, b, c = (simulate(xy, edges, PATTERNS["organic"], s)[0] for s in (7, 7, 8))
    assert np.array_equal(a.xy, b.xy) and np.array_equal(a.edges, b.edges)
    assert not (a.n_nodes == c.n_nodes and np.array_equal(a.xy, c.xy))
    assert a.n_segments > len(edges) + 30


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(3, 5), spacing=st.floats(50.0, 150.0), jitter=st.floats(0.0, 0.2),
       keep=st.lists(st.booleans(), min_size=40, max_size=40), seed=st.integers(0, 2**16),
       name=st.sampled_from(sorted(PATTERNS)), river=st.booleans())
def test_growth_stays_planar_within_max_degree_and_min_angle(n, spacing, jitter, keep, seed, name, river):
    keep_mask = np.array(keep + [True] * 40)
    xy, edges = perturbed_grid(n, spacing, jitter * spacing, keep_mask, seed)
    if len(edges) == 0:
        return
    options = PATTERNS[name]
    water = shapely.box(-400.0, -80.0, 1000.0, -50.0) if river else None   # south of the grid (jitter ≤ 30 m)
    degree0 = StreetGraph.from_segments(xy, edges).degree
    g, grown = simulate(xy, edges, options, seed, water=water)
    assert segment_crossings(g) == 0
    if water is not None:
        assert not shapely.intersects_xy(water, g.xy[:, 0], g.xy[:, 1]).any()
        over = shapely.intersects(water, shapely.linestrings(np.stack([g.xy[g.edges[:, 0]], g.xy[g.edges[:, 1]]], 1)))
        assert (g.bridge[grown] == over[grown]).all()
    initial = np.zeros(g.n_nodes, dtype=np.int64)
    initial[: len(degree0)] = degree0
    assert (g.degree <= np.maximum(np.maximum(initial, 2), options.max_degree)).all()
    min_angle = math.radians(options.min_angle_deg) - 1e-6
    for node in range(g.n_nodes):
        segs = g.incident(node)
        for k, s in enumerate(segs):
            for t in segs[k + 1:]:
                if grown[s] or grown[t]:
                    gap = abs((_direction(g, node, s) - _direction(g, node, t) + math.pi) % (2 * math.pi) - math.pi)
                    assert gap >= min_angle, (name, node, s, t, math.degrees(gap))


def _direction(g, node, seg):
    u, v = g.edges[seg]
    d = g.xy[v if u == node else u] - g.xy[node]
    return math.atan2(d[1], d[0])


# ------------------------------------------------------------------ degenerate inputs and errors

def test_library_errors_name_the_problem():
    g = stub()
    with pytest.raises(InputError, match="start node ids"):
        grow_streets(g, [5], options=BASE, rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="ell"):
        candidate_points(g, spawned_mask=g.spawned, ell=0.0)
    with pytest.raises(InputError, match="spawned_mask"):
        candidate_points(g, spawned_mask=[False], ell=20.0)
    with pytest.raises(InputError, match="take"):
        rank_candidates(np.zeros((1, 2)), [Nucleus((0.0, 0.0), 1.0, NucleusKind.CENTRE)], take=-1)
    with pytest.raises(InputError, match="junction_strength"):
        NucleiOptions(junction_strength=1.5)


def test_empty_inputs_give_empty_results():
    g = stub()
    step = grow_streets(g, [], options=BASE, rng=np.random.default_rng(0))
    assert len(step.new_segments) == 0 and len(step.grown) == 0 and g.n_segments == 1
    z = candidate_points((np.zeros((0, 2)), np.zeros((0, 2), dtype=int)), spawned_mask=np.zeros(0, bool))
    assert len(z) == 0 and z.xy.shape == (0, 2)
    assert rank_candidates(z.xy, [Nucleus((0.0, 0.0), 1.0, NucleusKind.CENTRE)], take=5).tolist() == []
    nuclei = find_nuclei(np.zeros((0, 2)), np.zeros((0, 2), dtype=int), bounds=(0, 0, 1000, 600))
    assert nuclei == [Nucleus((500.0, 300.0), 1.0, NucleusKind.CENTRE)]    # no major roads: the map's middle
    assert StreetGraph.from_segments(np.zeros((0, 2)), np.zeros((0, 2), dtype=int)).n_segments == 0


def test_angle_pdfs_discrete_continuous_and_gaussian():
    from synth.patterns.growing import _Sampler
    rng = np.random.default_rng(0)
    tri = _Sampler(PatternOptions(angle_pdf=((0, 0), (90, 1), (180, 0), (270, 0)), angle_pdf_kind="continuous"))
    a = np.array([tri.angle(rng) for _ in range(4000)])
    assert ((a >= 0) & (a <= 180)).all() and abs(a.mean() - 90) < 2 and abs(a.std() - 180 / math.sqrt(24)) < 2
    gauss = _Sampler(PatternOptions(angle_pdf=((90, 1),), angle_pdf_kind="gaussian", angle_spread_deg=10))
    g = np.array([gauss.angle(rng) for _ in range(4000)])
    assert abs(g.mean() - 90) < 1 and abs(g.std() - 10) < 0.5
    disc = _Sampler(PatternOptions(angle_pdf=((0, 3), (90, 1)), angle_pdf_kind="discrete"))
    d = np.array([disc.angle(rng) for _ in range(4000)])
    assert set(d.tolist()) == {0.0, 90.0} and abs((d == 0).mean() - 0.75) < 0.03
