"""Each simplification pass on small hand-built networks (metres)."""
from __future__ import annotations

import numpy as np
import pytest

from osm_expand.model import network_from_lines
from osm_expand.model.topology import junction_mask, street_counts
from simplify import SimplifyOptions, simplify
from simplify.clusters import fuse_clusters
from simplify.crossings import add_missing_intersections
from simplify.dead_ends import prune_dead_ends
from simplify.intersections import extract_intersections
from simplify.invariants import violations
from simplify.merging import merge_streets
from simplify.overlaps import remove_overlaps
from simplify.roundabouts import collapse_roundabouts
from simplify.two_street import enforce_two_streets

OPTS = SimplifyOptions()


def junctions(net):
    return {tuple(np.round(net.xy[i], 6)) for i in np.flatnonzero(junction_mask(net.streets, len(net.xy)))}


def square(size=100.0, origin=(0.0, 0.0)):
    x, y = origin
    return [[(x, y), (x + size, y)], [(x + size, y), (x + size, y + size)],
            [(x + size, y + size), (x, y + size)], [(x, y + size), (x, y)]]


# -- 1. intersection extraction -------------------------------------------------

def test_self_touching_street_is_cut_at_the_repeated_node():
    lollipop = [(0, 0), (100, 0), (150, 50), (200, 0), (100, 0)]
    net = extract_intersections(network_from_lines([lollipop]))
    assert sorted(len(s.nodes) for s in net.streets) == [2, 4]
    assert junctions(net) == {(100.0, 0.0)}
    assert any(s.is_closed for s in net.streets)


def test_back_and_forth_spike_disappears():
    net = extract_intersections(network_from_lines([[(0, 0), (50, 0), (0, 0)]]))
    assert net.streets == ()


# -- 2. missing intersections --------------------------------------------------

def test_crossing_on_the_same_layer_gets_a_junction():
    net, added = add_missing_intersections(network_from_lines([[(-50, 0), (50, 0)], [(0, -50), (0, 50)]]), OPTS)
    assert added > 0
    assert junctions(net) == {(0.0, 0.0)}
    assert violations(net)["crossings_without_junction"] == 0


def test_bridge_over_a_street_is_not_a_junction():
    lines = [[(-50, 0), (50, 0)], [(0, -50), (0, 50)]]
    net, added = add_missing_intersections(network_from_lines(lines, [{}, {"bridge": True, "layer": 1}]), OPTS)
    assert added == 0 and junctions(net) == set()


def test_street_ending_on_another_without_a_node_is_joined():
    net, _ = add_missing_intersections(network_from_lines([[(-50, 0), (50, 0)], [(10, 0), (10, 60)]]), OPTS)
    assert junctions(net) == {(10.0, 0.0)}


def test_collinear_overlap_shares_its_end_nodes():
    net, _ = add_missing_intersections(network_from_lines([[(0, 0), (100, 0)], [(50, 0), (150, 0)]]), OPTS)
    assert junctions(net) == {(50.0, 0.0), (100.0, 0.0)}


def test_three_streets_through_one_point_share_one_node():
    lines = [[(-50, 0), (50, 0)], [(0, -50), (0, 50)], [(-50, -50), (50, 50)]]
    net, _ = add_missing_intersections(network_from_lines(lines), OPTS)
    assert junctions(net) == {(0.0, 0.0)}
    assert street_counts(net.streets, len(net.xy)).max() == 3


# -- 3. dead ends --------------------------------------------------------------

def test_cul_de_sac_tree_is_removed_and_recorded():
    tree = [[(100, 50), (160, 50)], [(160, 50), (200, 80)], [(160, 50), (200, 20)]]
    net = extract_intersections(network_from_lines(square() + tree))
    net, dead = prune_dead_ends(net)
    assert len(net.streets) == 4
    assert sum(d.length for d in dead) == pytest.approx(60 + 2 * np.hypot(40, 30))
    assert violations(net)["dead_ends"] == 0


def test_isolated_street_goes_entirely():
    net, dead = prune_dead_ends(network_from_lines(square() + [[(500, 500), (600, 500)]]))
    assert len(net.streets) == 4 and dead[0].attach == -1 and dead[0].length == pytest.approx(100)


def test_a_ring_is_not_a_dead_end():
    ring = [(0, 0), (100, 0), (100, 100), (0, 100), (0, 0)]
    net, dead = prune_dead_ends(network_from_lines([ring]))
    assert len(net.streets) == 1 and not dead


# -- 4. overlaps ---------------------------------------------------------------

def test_close_parallel_duplicate_is_removed_distant_one_kept():
    close = [(0, 0), (50, 8), (100, 0)]
    far = [(0, 0), (50, 80), (100, 0)]
    base = [[(0, 0), (100, 0)], [(-50, 0), (0, 0)], [(100, 0), (150, 0)]]
    net, removed = remove_overlaps(network_from_lines(base + [close], [{"highway": "primary"}, {}, {}, {}]), OPTS)
    assert len(removed) == 1 and len(net.streets) == 3
    assert net.streets[0].highway == "primary"  # the more important one stays
    net, removed = remove_overlaps(network_from_lines(base + [far]), OPTS)
    assert removed == [] and len(net.streets) == 4


def test_small_loop_is_removed_and_an_exempt_one_kept():
    loop = [(0, 0), (20, 10), (20, -10), (0, 0)]
    lines = [[(-100, 0), (0, 0)], loop]
    net = network_from_lines(lines)
    out, removed = remove_overlaps(net, OPTS)
    assert len(out.streets) == 1
    node = removed[0][0]
    out, removed = remove_overlaps(net, OPTS, exempt=frozenset({(node, node)}))
    assert len(out.streets) == 2 and not removed


# -- 5. roundabouts ------------------------------------------------------------

def ring(cx, cy, r, n=12):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = [(round(cx + r * np.cos(t), 6), round(cy + r * np.sin(t), 6)) for t in a]
    return pts + [pts[0]]


def test_tagged_roundabout_collapses_to_its_centroid():
    rb = ring(0, 0, 15)
    approaches = [[rb[i], (rb[i][0] * 10, rb[i][1] * 10)] for i in (0, 3, 6, 9)]
    net = network_from_lines([rb] + approaches, [{"junction": "roundabout"}] + [{}] * 4)
    out, n = collapse_roundabouts(net, OPTS)
    assert n == 1 and len(out.streets) == 4
    centre = {s.nodes[0] for s in out.streets}
    assert len(centre) == 1
    assert np.allclose(out.xy[centre.pop()], (0, 0), atol=1e-6)


def test_turning_loop_with_one_approach_stays():
    rb = ring(0, 0, 10)
    net = network_from_lines([rb, [rb[0], (200, 0)]])
    out, n = collapse_roundabouts(net, OPTS)
    assert n == 0 and len(out.streets) == 2


def test_large_roundabout_is_kept():
    rb = ring(0, 0, 100, n=40)
    approaches = [[rb[i], (rb[i][0] * 3, rb[i][1] * 3)] for i in (0, 10, 20, 30)]
    net = network_from_lines([rb] + approaches, [{"junction": "roundabout"}] + [{}] * 4)
    assert collapse_roundabouts(net, OPTS)[1] == 0


# -- 6. node clusters ----------------------------------------------------------

def test_close_junctions_fuse_distant_ones_do_not():
    # a dual carriageway: two parallel roads 8 m apart crossed by a street
    lines = [[(-100, 0), (0, 0), (100, 0)], [(-100, 8), (0, 8), (100, 8)], [(0, -100), (0, 0), (0, 8), (0, 100)]]
    net = extract_intersections(network_from_lines(lines))
    out, n = fuse_clusters(net, OPTS)
    assert n == 1
    assert junctions(out) == {(0.0, 4.0)}
    far = extract_intersections(network_from_lines([[(-100, 0), (0, 0), (100, 0)], [(-100, 80), (0, 80), (100, 80)],
                                                    [(0, -100), (0, 0), (0, 80), (0, 100)]]))
    assert fuse_clusters(far, OPTS)[1] == 0


def test_a_small_ring_around_a_fused_junction_disappears_cleanly():
    # two junctions 8 m apart, joined also by a tiny ring: fusing must not leave a [c, c] street
    lines = [[(-100, 0), (0, 0), (8, 0), (100, 0)], [(0, -100), (0, 0)], [(8, 0), (8, 100)],
             [(0, 0), (3, 3), (5, 3), (8, 0)]]
    net = extract_intersections(network_from_lines(lines))
    out, _ = fuse_clusters(net, OPTS)
    assert all(a != b for s in out.streets for a, b in zip(s.nodes, s.nodes[1:]))


# -- 7. merging ----------------------------------------------------------------

def test_straight_fragments_merge_bent_ones_do_not():
    lines = [[(-100, 0), (0, 0)], [(0, 0), (100, 3)], [(0, 0), (0, 100)]]
    out, n = merge_streets(network_from_lines(lines), OPTS)
    assert n == 1 and len(out.streets) == 2
    assert max(len(s.nodes) for s in out.streets) == 3
    bent = [[(-100, 0), (0, 0)], [(0, 0), (100, 40)], [(0, 0), (0, 100)]]  # 158 degrees
    assert merge_streets(network_from_lines(bent), OPTS)[1] == 0


def test_same_name_beats_a_straighter_stranger():
    lines = [[(-100, 0), (0, 0)], [(0, 0), (100, 0)], [(0, 0), (100, -20)]]
    attrs = [{"name": "Main"}, {"name": "Other"}, {"name": "Main"}]
    out, n = merge_streets(network_from_lines(lines, attrs), OPTS)
    assert n == 1
    merged = next(s for s in out.streets if len(s.nodes) == 3)
    assert merged.name == "Main" and tuple(out.xy[merged.nodes[-1]]) == (100.0, -20.0)


def test_merging_never_closes_a_loop():
    lines = [[(0, 0), (100, 0), (100, 1)], [(100, 1), (0, 1), (0, 0)]]
    out, n = merge_streets(network_from_lines(lines), OPTS)
    assert not any(s.is_closed for s in out.streets)


def test_bridge_does_not_merge_with_the_road():
    lines = [[(-100, 0), (0, 0)], [(0, 0), (100, 0)]]
    out, n = merge_streets(network_from_lines(lines, [{}, {"bridge": True, "layer": 1}]), OPTS)
    assert n == 0


# -- 8. two-street intersections ------------------------------------------------

def star(n_arms, length=100.0):
    angles = np.linspace(0, 2 * np.pi, n_arms, endpoint=False)
    return [[(0.0, 0.0), (round(length * np.cos(a), 6), round(length * np.sin(a), 6))] for a in angles]


@pytest.mark.parametrize("arms,extra", [(3, 0), (4, 0), (5, 1), (6, 2)])
def test_star_junction_keeps_two_streets(arms, extra):
    net = network_from_lines(star(arms))
    out, counts = enforce_two_streets(net, OPTS)
    assert street_counts(out.streets, len(out.xy)).max() <= 2
    assert counts["fused"] == {3: 1, 4: 2, 5: 2, 6: 2}[arms]
    # arms with no other junction would vanish whole if cut back: they are separated instead
    assert counts["separated"] == extra and counts["cut_back"] == 0
    assert out.total_length() == pytest.approx(net.total_length(), abs=2 * extra * OPTS.separation)
    assert violations(out)["junctions_with_more_than_two_streets"] == 0


def test_leftover_endpoint_with_an_inner_junction_is_cut_back():
    # a fifth arm that crosses a ring road 50 m out keeps its outer part
    arms = star(5)
    fifth = arms[4]
    arms[4] = [fifth[0], tuple(v / 2 for v in fifth[1]), fifth[1]]
    ring_road = ring(0, 0, 50, n=40)
    net, _ = add_missing_intersections(network_from_lines(arms + [ring_road]), OPTS)
    out, counts = enforce_two_streets(net, OPTS)
    assert street_counts(out.streets, len(out.xy)).max() <= 2
    assert counts["cut_back"] + counts["separated"] >= 1


def test_three_passing_streets_split_the_least_important():
    lines = [[(-100, 0), (100, 0)], [(0, -100), (0, 100)], [(-100, -100), (100, 100)]]
    attrs = [{"highway": "primary"}, {"highway": "secondary"}, {"highway": "residential"}]
    net = network_from_lines([[*lines[0][:1], (0, 0), lines[0][1]], [lines[1][0], (0, 0), lines[1][1]],
                              [lines[2][0], (0, 0), lines[2][1]]], attrs)
    out, counts = enforce_two_streets(net, OPTS)
    assert counts["split"] == 1 and counts["cut_back"] + counts["separated"] == 2
    centre = int(np.flatnonzero((net.xy == (0, 0)).all(axis=1))[0])
    assert sorted(s.highway for s in out.streets if centre in s.nodes) == ["primary", "secondary"]
    assert street_counts(out.streets, len(out.xy)).max() <= 2


# -- the whole pipeline --------------------------------------------------------

def grid(n=4, step=100.0):
    lines = [[(0, i * step), ((n - 1) * step, i * step)] for i in range(n)]
    lines += [[(i * step, 0), (i * step, (n - 1) * step)] for i in range(n)]
    return lines


def test_grid_without_nodes_becomes_a_clean_network():
    result = simplify(network_from_lines(grid()))
    net = result.network
    assert not any(violations(net).values())
    # 4x4 grid of whole lines: every crossing, border T and corner (two ends meeting) is a junction
    assert result.report["junctions"] == 16 and result.report["streets"] == 8
    assert [p["pass"] for p in result.report["passes"]] == [
        "input", "intersections", "missing_intersections", "dead_ends", "overlaps", "roundabouts",
        "clusters", "merging", "two_street", "final"]


def test_merging_keeps_every_field_of_the_longest_part():
    """combine used to rebuild a Street field by field and reset hierarchy, status, year, origin and id."""
    from osm_expand.model import Origin, Status
    from simplify.merging import combine

    net = network_from_lines([[(0, 0), (100, 0)], [(100, 0), (300, 0)]],
                             [{"name": "A", "hierarchy": 2, "status": Status.PLANNED, "year": 1901,
                               "origin": Origin.GROWN, "era": "old", "width": 7.0},
                              {"highway": "primary", "hierarchy": 1, "status": Status.BUILT, "year": 1950,
                               "origin": Origin.GROWN, "era": "new", "width": 12.0}])
    a, b = net.streets
    merged = combine(net.xy, [a, b], a.nodes + b.nodes[1:])
    assert (merged.hierarchy, merged.status, merged.year, merged.era, merged.width, merged.id) == \
        (1, Status.BUILT, 1950, "new", 12.0, b.id)
    assert merged.name == "A" and merged.highway == "primary" and merged.origin == Origin.GROWN
