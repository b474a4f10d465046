"""Example patches: districts quilted from the town as mapped, and judged like real parts of it."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import shapely

from osm_expand.ingest import load
from osm_expand.model import chord_bends, network_from_lines
from osm_expand.model.topology import dangling_chains, segment_degree, without_segments
from osm_expand.pipeline import ExpandOptions, expand
from synth.patches import BEND_STEP, PatchOptions
from synth.patches.edges import _edge_streets
from synth.patches.placing import _free_land
from synth.patches.quilt import _Quilt
from synth.patches.seams import _connector, _walk_seams
from synth.patches.topology import _Aim, _fewer_dead_ends, _more_dead_ends, _trim, corner_turns, sharp_corners
from tests.conftest import FIXTURES


def test_a_dangling_chain_runs_back_to_the_nearest_junction():
    net = network_from_lines([[(0, 0), (10, 0), (20, 0)], [(20, 0), (30, 0)], [(20, 0), (20, 10), (20, 20)],
                              [(20, 0), (20, -10)]])
    chains = dangling_chains(net.streets, [0])
    assert chains == {0: {(0, 1), (1, 2)}}
    kept = without_segments(net.streets, chains[0])
    assert [s.nodes for s in kept] == [(2, 3), (2, 4, 5), (2, 6)]


def test_a_street_cut_by_a_seam_is_trimmed_back_and_so_is_a_junction_left_dangling():
    # a T whose two arms were both cut by seams: the stem is left hanging at the T and goes too
    lines = [[(0.0, 0.0), (50.0, 0.0)], [(50.0, 0.0), (100.0, 0.0)], [(50.0, 0.0), (50.0, -40.0)],
             [(50.0, -40.0), (0.0, -40.0), (0.0, -100.0)], [(50.0, -40.0), (90.0, -40.0)], [(90.0, -40.0), (90.0, -100.0)]]
    net = network_from_lines(lines)
    quilt = _Quilt(cut_xy=[np.array([0.0, 0.0]), np.array([100.0, 0.0])])
    trimmed = _trim(net, quilt, edge=shapely.LineString([(500, 500), (600, 500)]), keep_out=1e9)
    left = {tuple(map(tuple, trimmed.street_xy(s))) for s in trimmed.streets}
    assert all((50.0, 0.0) not in line for line in left)  # the T and its stem are gone
    assert any((0.0, -100.0) in line for line in left)  # the rest stays


def test_a_long_street_cut_by_the_sites_edge_stays_as_a_road_out():
    net = network_from_lines([[(0.0, 0.0), (300.0, 0.0)], [(0.0, 0.0), (0.0, 50.0)], [(0.0, 0.0), (0.0, -50.0)]])
    quilt = _Quilt(cut_xy=[np.array([300.0, 0.0])])
    edge = shapely.LineString([(300.0, -500.0), (300.0, 500.0)])
    assert len(_trim(net, quilt, edge=edge, keep_out=100.0).streets) == 3
    assert len(_trim(net, quilt, edge=edge, keep_out=1000.0).streets) == 2


def test_a_seam_connector_is_a_smooth_curve_between_the_two_cut_ends():
    a, b = np.array([0.0, 0.0]), np.array([60.0, 20.0])
    path = _connector(a, np.array([1.0, 0.0]), b, np.array([-1.0, 0.0]))
    assert np.array_equal(path[0], a) and np.array_equal(path[-1], b)
    step = np.diff(path, axis=0)
    turn = np.degrees(np.abs(np.diff(np.unwrap(np.arctan2(step[:, 1], step[:, 0])))))
    assert turn.max() < 25.0 and shapely.LineString(path).is_simple


def _cut_quilt(pieces, ends, cells):
    """A quilt of ``pieces`` whose cut ends are ``ends`` (piece, which end: 0 or -1), in ``cells``."""
    quilt = _Quilt()
    for xy in pieces:
        quilt.add(np.array(xy, dtype=float), "residential", 1)
    for (k, which), cell in zip(ends, cells):
        xy = quilt.xy[k]
        end, prev = (xy[0], xy[1]) if which == 0 else (xy[-1], xy[-2])
        quilt.cut_xy.append(end)
        quilt.cut_heading.append((end - prev) / np.hypot(*(end - prev)))
        quilt.cut_cell.append(cell)
        quilt.cut_piece.append(k)
    return quilt


def test_a_seam_link_between_cut_streets_that_do_not_line_up_is_not_made():
    """Issue 20 (h26d): two streets cut side by side by a seam have no angle between them, and the link
    that joined them turned across the seam and back, a zig-zag (Krems seed 0: a third of the district's
    bends over 45°). A link is judged by how the street bends through it, chord by chord."""
    side_by_side = [[(0.0, 0.0), (100.0, 0.0)], [(200.0, 30.0), (100.0, 30.0)]]
    in_line = [[(0.0, 300.0), (100.0, 300.0)], [(230.0, 300.0), (130.0, 300.0)]]
    quilt = _cut_quilt(side_by_side + in_line, [(0, -1), (1, -1), (2, -1), (3, -1)], [0, 1, 0, 1])
    links = _walk_seams(quilt, 100.0, PatchOptions(seam_bend_quantile=0.9), shapely.Polygon(),
                        shapely.MultiLineString(), 20.0)
    assert links == 1 and len(quilt.xy) == 5
    link = quilt.xy[4]
    assert {tuple(link[0]), tuple(link[-1])} == {(100.0, 300.0), (130.0, 300.0)}  # the streets in line


def test_two_cut_ends_closer_than_a_connector_step_meet_halfway_rather_than_jog():
    """Issue 20 (h27d): most of the district's sharp turns at degree-2 nodes are where a seam link meets
    its cut streets, and a link under one connector step is a straight piece that turns twice across
    the seam (here 51° each way). With ``seam_meet`` the two streets' ends move to their midpoint: one
    node of degree 2 where they turn by a few degrees, and no link piece."""
    pieces = [[(0.0, 0.0), (50.0, 0.0)], [(104.0, 5.0), (54.0, 5.0)]]
    for meet, n_pieces in ((True, 2), (False, 3)):
        quilt = _cut_quilt(pieces, [(0, -1), (1, -1)], [0, 1])
        assert _walk_seams(quilt, 100.0, PatchOptions(seam_meet=meet), shapely.Polygon(),
                           shapely.MultiLineString()) == 1
        assert len(quilt.xy) == n_pieces
        net = network_from_lines(quilt.xy)
        turns = corner_turns(net)
        assert len(turns) == 2 - meet
        assert (turns.max() < 10.0) if meet else (turns.min() > 45.0)
    assert tuple(quilt.xy[0][-1]) == (50.0, 0.0)  # by default the streets stay where they were cut


def test_a_cut_street_whose_trimming_would_leave_an_l_bend_stays_as_the_cul_de_sac_first():
    """Issue 20 (h26d): trimming a cut street back to its junction turned the town's tees into L-bends,
    the district's sharpest bends (Krems seed 0: 16 of its 28 over 45°). With room for one cul-de-sac,
    the arm of the T stays and the street off a straight one goes, though the latter is nearer the
    town's cul-de-sac length."""
    tee_arm = [[(0.0, 0.0), (0.0, -100.0)], [(0.0, 0.0), (-100.0, 0.0)], [(0.0, 0.0), (60.0, 0.0)]]
    off_straight = [[(300.0, 0.0), (300.0, -100.0)], [(300.0, 0.0), (300.0, 100.0)], [(300.0, 0.0), (350.0, 0.0)]]
    net = network_from_lines(tee_arm + off_straight)
    quilt = _Quilt(cut_xy=[np.array([60.0, 0.0]), np.array([350.0, 0.0])])
    far = shapely.LineString([(5000, 5000), (5100, 5000)])
    trimmed = _trim(net, quilt, edge=far, keep_out=1e9, keep=1, stub=10.0, like=50.0,
                    corner_bend=45.0)
    left = {tuple(map(float, p)) for st in trimmed.streets for p in trimmed.street_xy(st)}
    assert (60.0, 0.0) in left and (350.0, 0.0) not in left


def test_a_kept_tee_stays_a_junction_through_trimming_and_the_dead_end_steps():
    """Issue 20 (h27d): a seam that cuts a tee's arm left an L where the town had a T. With
    ``keep_tees`` the arm stays whatever the cul-de-sac budget (none here), and the dead-end step that
    drops short cul-de-sacs when the district has too many leaves it: the junction keeps its three
    streets. By default the arm is trimmed and the junction is a corner of 90°."""
    net = network_from_lines([[(0.0, 0.0), (0.0, -150.0)], [(0.0, 0.0), (-150.0, 0.0)], [(0.0, 0.0), (60.0, 0.0)]])
    quilt = _Quilt(cut_xy=[np.array([60.0, 0.0])])
    far = shapely.LineString([(5000, 5000), (5100, 5000)])
    junction = int(np.flatnonzero(np.hypot(*net.xy.T) < 1e-9)[0])
    kept = _trim(net, quilt, edge=far, keep_out=1e9, keep=0, corner_bend=45.0, tees=True)
    assert segment_degree(kept.streets, len(kept.xy))[junction] == 3
    opts = PatchOptions(corner_bend=45.0, keep_tees=True)
    aim = _Aim(dead_end_share=0.0, two_core_share=0.0)  # every dead end is one too many
    nothing = shapely.MultiLineString(), shapely.Polygon()
    after = _fewer_dead_ends(kept, *nothing, 100.0, opts, aim)  # the arm is shorter than a spacing
    assert segment_degree(after.streets, len(after.xy))[junction] == 3
    dropped = _fewer_dead_ends(kept, *nothing, 100.0, PatchOptions(corner_bend=45.0), aim)
    assert segment_degree(dropped.streets, len(dropped.xy))[junction] == 2
    trimmed = _trim(net, quilt, edge=far, keep_out=1e9, keep=0, corner_bend=45.0)
    assert segment_degree(trimmed.streets, len(trimmed.xy))[junction] == 2
    assert corner_turns(trimmed, np.array([junction])).round().tolist() == [90.0]


def test_a_perimeter_street_runs_straight_past_the_jagged_edge_of_the_free_land():
    """Issue 20 (h26d): the free land's edge is jagged at every plot, and the perimeter street that
    followed it a few metres inside wiggled with it (north-bayreuth seed 0: most of the district's
    bends over 20°). Pulled taut (``perimeter_tees``), it runs straight where the edge lets it."""
    bays = [shapely.box(x, -12.0, x + 14.0, 1.0) for x in (115.0, 145.0)]  # the edge steps out and back
    region = shapely.union_all([shapely.box(0.0, 0.0, 300.0, 300.0), *bays])
    quilt = _cut_quilt([[(100.0, 200.0), (100.0, 0.0)], [(175.0, 200.0), (175.0, 0.0)]], [(0, -1), (1, -1)], [0, 0])
    made = _edge_streets(quilt, region, 100.0, PatchOptions(perimeter_tees=True), shapely.Polygon(),
                          shapely.MultiLineString())
    assert made == 1
    street = quilt.xy[2]
    assert sorted([tuple(street[0]), tuple(street[-1])]) == [(100.0, 4.0), (175.0, 4.0)]  # tees 4 m inside
    along = np.linspace(0.0, shapely.LineString(street).length, 9)
    assert chord_bends(street, along, BEND_STEP).max() < 1.0


@functools.cache
def district(name: str, seed: int):
    return expand(load(FIXTURES / name), ExpandOptions(seed=seed))


@pytest.mark.parametrize("name", ["krems.osm.gz", "andorra.osm.pbf"])
def test_the_district_is_as_alike_to_its_town_as_the_towns_own_districts(name):
    """Issue 20's verdict over seeds 0-4: off on at most 3 of the 14 measures on average, street density,
    dead-end and 2-core share in range on at least 4 of the 5 seeds, at most 2 pieces. (Issue 9 pinned
    seed 0 alone at 3 off; one seed moves by one measure with any change of the topology: Andorra's
    seed 0 is off on 4 since its district keeps its town's cul-de-sacs, seeds 0-4 on 2.8-3.0.)"""
    reports = [district(name, seed).fidelity for seed in range(5)]
    assert all(r is not None for r in reports)
    off = [r.off for r in reports]
    assert np.mean(off) <= 3.0, off
    for measure in ("density", "dead_end_share", "two_core_share"):
        assert sum(r.verdict(measure).ok for r in reports) >= 4, measure
    assert max(r.pieces for r in reports) <= 2


def test_krems_district_bends_at_its_degree_2_nodes_within_a_bound_read_from_its_town():
    """Issue 20's curvature defect, counted: corners sharper than 45° at nodes of degree 2, where no
    junction explains a bend (Ls left by trimmed tees, seam links' joints, perimeter streets). Krems'
    own simplified streets have 1.0 a km, its seed-0 district 8.1 (41 over 5.1 km) as of h27d: a guard
    that it gets no worse than ten times its town's rate, not yet the town's own rate."""
    result = district("krems.osm.gz", 0)
    corners, km = sharp_corners(result.city.network)
    town, town_km = sharp_corners(result.learned.simplified, new=False)
    assert km > 1.0 and town_km > 10.0
    assert corners / km <= 10.0 * town / town_km, (corners, km, town, town_km)


def test_the_fidelity_report_is_in_the_json_report():
    result = district("krems.osm.gz", 0)
    f = result.report["fidelity"]
    assert set(f["measures"]) == {v.measure.value for v in result.fidelity.verdicts} and len(f["measures"]) == 14
    assert f["off"] == result.fidelity.off and isinstance(f["believable"], bool)


@pytest.mark.parametrize("seed", [2, 3])
def test_a_krems_district_has_the_cul_de_sacs_of_the_towns_neighbourhoods(seed):
    """Issue 20: small Krems districts ended with every cut street joined or trimmed — no dead end, all of
    their length on loops (0 and 1.0 on seeds 2-4; the town's neighbourhoods: 3-20 % and 0.83-0.98).
    Roads out at the district's outer edge are read as running on, as the streets a real neighbourhood's
    disc cuts are; the district keeps cul-de-sacs inside it (seed 4 still ends with one, 0.036 against
    0.041: issue 20 asks 4 of 5 seeds)."""
    report = district("krems.osm.gz", seed).fidelity
    assert report is not None and report.district.dead_ends > 0
    for name in ("dead_end_share", "two_core_share"):
        verdict = report.verdict(name)
        assert verdict.ok, (name, verdict.value, verdict.low, verdict.high)


def test_a_monaco_district_is_one_piece_with_the_towns_share_on_loops():
    """Issue 20: Monaco's district came in two pieces (a street scrap on a 0.01 km² sliver of free land
    beside the 0.7 km² site) with 84 % of its length on loops against the neighbourhoods' 89-93 %."""
    report = district("monaco.osm.gz", 0).fidelity
    assert report is not None and report.pieces == 1
    verdict = report.verdict("two_core_share")
    assert verdict.ok, (verdict.value, verdict.low, verdict.high)


def test_a_sliver_of_free_land_beside_the_site_is_left_open():
    big, sliver = shapely.box(0, 0, 1000, 1000), shapely.box(1100, 0, 1150, 100)
    free = _free_land(shapely.Polygon(), shapely.union(big, sliver), shapely.MultiLineString(), 1.0, 50.0, 9.0)
    assert free.equals(big)
    # the largest part stays even when it is small itself
    alone = _free_land(shapely.Polygon(), sliver, shapely.MultiLineString(), 1.0, 50.0, 9.0)
    assert alone.equals(sliver)


def test_a_tee_is_taken_back_for_a_cul_de_sac_while_the_district_has_too_few():
    # a ladder: two rails and three rungs, plus a street whose cut end was teed onto the far rail
    rungs = [[(x, 0.0), (x, 200.0)] for x in (0.0, 200.0, 400.0)]
    stem = [[(100.0, 0.0), (100.0, 120.0)], [(100.0, 120.0), (100.0, 200.0)]]  # the second is the tee
    net = network_from_lines([[(0.0, 0.0), (100.0, 0.0), (200.0, 0.0), (400.0, 0.0)],
                              [(0.0, 200.0), (100.0, 200.0), (200.0, 200.0), (400.0, 200.0)], *rungs, *stem])
    tees = [(np.array([100.0, 120.0]), np.array([100.0, 200.0]))]
    far = shapely.LineString([(5000, 5000), (5100, 5000)])
    spacing = 100.0
    wanting = _more_dead_ends(net, tees, far, far, spacing, PatchOptions(), _Aim(0.25, 0.5))
    assert len(wanting.streets) == len(net.streets) - 1  # the tee went: a cul-de-sac of 120 m
    enough = _more_dead_ends(net, tees, far, far, spacing, PatchOptions(), _Aim(0.05, 0.5))
    assert len(enough.streets) == len(net.streets)  # no dead end wanted
    looped = _more_dead_ends(net, tees, far, far, spacing, PatchOptions(), _Aim(0.25, 0.99))
    assert len(looped.streets) == len(net.streets)  # the 2-core may not lose 120 m


def test_the_towns_streets_kept_between_districts_are_those_read_afresh():
    """ExamplePatches keeps the town's copyable streets for the next district on the same network
    (the engine tries several sites a year): the kept ones equal a fresh reading, and a district
    grown from them is the one grown by a new object with the same random state."""
    from osm_expand.growth_patterns import measure_in_windows
    from synth.patches import ExamplePatches
    from synth.patches.source import _source

    grown = district("krems.osm.gz", 0)
    city = grown.city
    pattern = ExamplePatches(grown.learned.example, measure=measure_in_windows)
    for everything in (False, True):
        kept, fresh = pattern._source(city, everything), _source(city, pattern.example, everything=everything)
        assert pattern._source(city, everything) is kept
        assert shapely.equals_exact(kept.lines, fresh.lines, 0).all() and kept.highway == fresh.highway
        assert np.array_equal(kept.level, fresh.level) and np.array_equal(kept.junctions, fresh.junctions)
    region = shapely.Point(city.network.xy[city.network.used_nodes()].mean(axis=0)).buffer(400.0)
    pattern.grow(city, region, np.random.default_rng(3))  # ranks the town's patches for this size
    again = pattern.grow(city, region, np.random.default_rng(3))  # from what it kept
    other = ExamplePatches(grown.learned.example, measure=measure_in_windows)
    other.cache.update({k: v for k, v in pattern.cache.items() if not (isinstance(k, tuple) and k[0] == "source")})
    fresh_grow = other.grow(city, region, np.random.default_rng(3))  # the same but for the kept streets
    assert len(again.streets) == len(fresh_grow.streets) > 0
    for a, b in zip(again.streets, fresh_grow.streets):
        assert np.array_equal(a.xy, b.xy)
