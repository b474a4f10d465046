"""Example patches: districts quilted from the town as mapped, and judged like real parts of it."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.ingest import load
from osm_expand.model import network_from_lines
from osm_expand.model.topology import dangling_chains, segment_degree, without_segments
from osm_expand.pipeline import ExpandOptions, expand
from synth.patches import PatchOptions
from synth.patches.corners import corner_turns, sharp_corners
from synth.patches.placing import _free_land
from synth.patches.quilt import _Quilt
from synth.patches.seams import _connector
from synth.patches.topology import _Aim, _more_dead_ends, _trim
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
             [(50.0, -40.0), (0.0, -40.0), (0.0, -100.0)], [(50.0, -40.0), (90.0, -40.0)],
             [(90.0, -40.0), (90.0, -100.0)]]
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


def test_corners_are_counted_at_nodes_of_degree_two_only():
    """The corner count (issue 20) reads the turn at each node where exactly two segments meet: an L's
    corner, a bend in a street, never a junction."""
    net = network_from_lines([[(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (150.0, 150.0)],
                              [(100.0, 100.0), (0.0, 100.0)]])
    turns = corner_turns(net)[1]
    assert turns.round().tolist() == [90.0]  # (100, 0); the tee at (100, 100) is a junction


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


@pytest.mark.parametrize("name", ["krems.osm.gz", "andorra.osm.pbf"])
def test_a_band_around_the_median_takes_patches_below_it_the_default_only_above(name):
    """Issue 20 (h29e): the candidate patches are drawn as the yardstick draws the town's neighbourhoods (the
    denser half of junction discs); the default band, 1-2.5 times their median density, keeps only the
    denser half of those, the town's densest quarter (Andorra: its straight valley floor, which every
    engine district copied). A band of a factor of two either way takes candidates below the median as
    much as above it."""
    from synth.patches.source import _candidate_patches, _density, _neighbourhood_points, _source

    grown = district(name, 0)
    source = _source(grown.city, grown.learned.example)
    for band, below in (((1.0, 2.5), False), ((0.5, 2.0), True)):
        opts = PatchOptions(density_band=band)
        size = opts.cell_size * grown.learned.example.spacing
        drawn = _neighbourhood_points(source, opts.candidates, size / 2, np.random.default_rng(0))
        median = float(np.median(_density(source, drawn, size / 2)))
        patches = _candidate_patches(source, size, opts, np.random.default_rng(0))
        local = _density(source, patches, size / 2)
        if below:
            assert (local < median).sum() >= len(patches) / 3, (band, np.round(local / median, 2))
        else:
            assert (local >= median * (1 - 1e-9)).all(), (band, np.round(local / median, 2))


def test_krems_district_bends_at_its_degree_2_nodes_within_a_bound_read_from_its_town():
    """Issue 20's curvature defect, counted: corners sharper than 45° at nodes of degree 2, where no
    junction explains a bend (Ls left by trimmed tees, seam links' joints, perimeter streets). Krems'
    neighbourhoods at the district's size have 0.68 a km (median; as mapped, the reading the district's
    copied ways stand beside, session 39), its seed-0 district 8.1 (41 over 5.1 km; twelve times) as of
    h27d: a guard that it gets no worse than fifteen times, not yet the town's own rate (session 39's
    ``corner_reach`` straightened them to it, measured and removed: docs/tried.md)."""
    result = district("krems.osm.gz", 0)
    corners, km = sharp_corners(result.city.network)
    median, _ = _neighbourhood_corner_rate(result)
    assert km > 1.0 and median > 0.0
    assert corners / km <= 15.0 * median, (corners, km, median)


def _neighbourhood_corner_rate(result) -> tuple[float, float]:
    """Median and 90th percentile of the corners over 45° per km of ``result``'s town as mapped, in 16 of its
    neighbourhoods at the district's area (:func:`synth.patches.corners.neighbourhood_corner_rates`)."""
    from synth.patches.corners import neighbourhood_corner_rates

    radius = float(np.sqrt(result.report["district_area_m2"] / np.pi))
    rates = neighbourhood_corner_rates(result.city, radius)
    return float(np.nanmedian(rates)), float(np.nanpercentile(rates, 90))


def test_the_towns_corner_rate_is_read_in_its_neighbourhoods_on_its_streets_as_mapped():
    """Issue 20 (session 39): the district copies the town's mapped ways, so its corners per km stand beside
    the same reading of the town's neighbourhoods, not of the simplified example (which drops nodes and
    merges ways: Krems 1.03 a km there) nor of the whole extract (0.36, mostly country roads). Krems'
    neighbourhoods at the district's size: 0.7 median; an L street of 2 km with one right-angle corner: 0.5."""
    median, p90 = _neighbourhood_corner_rate(district("krems.osm.gz", 0))
    assert 0.4 < median < 1.0 < p90 < 2.5, (median, p90)
    from synth.patches.corners import corners_in_discs

    ell = network_from_lines([np.array([[0.0, 0.0], [500.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0]])],
                             [{"highway": "residential"}])
    assert corners_in_discs(ell, np.array([[500.0, 500.0]]), 2000.0)[0] == pytest.approx(0.5)


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


def test_a_grower_reused_over_seeds_grows_what_a_fresh_one_grows():
    """The Python API's promise, same seed, same district: one pattern object grown with seed 0 then seed 1
    gives seed 1's district of a fresh run (the ranked patches it kept were drawn with seed 0's generator:
    Krems' seed 1 grew 84 streets at another site instead of 77; ``district_fidelity.py --option`` reused one)."""
    from osm_expand.growth_patterns import make_pattern
    from osm_expand.pipeline import learn

    city = load(FIXTURES / "krems.osm.gz")
    grower = make_pattern("example", learn(city).example)
    expand(city, ExpandOptions(seed=0), pattern=grower)
    reused, fresh = expand(city, ExpandOptions(seed=1), pattern=grower), district("krems.osm.gz", 1)
    assert reused.report["site_centre"] == fresh.report["site_centre"]
    a, b = reused.city.network, fresh.city.network
    assert len(a.streets) == len(b.streets)
    assert all(np.array_equal(a.street_xy(s), b.street_xy(t)) for s, t in zip(a.streets, b.streets))


def test_a_fresh_pattern_keeps_its_options_and_nothing_it_computed():
    """:meth:`ExamplePatches.fresh`: the same options and helpers, an empty cache (its ranked patches were drawn
    with the first district's generator)."""
    from osm_expand.growth_patterns import make_pattern
    from synth.growth import for_a_run

    pattern = make_pattern("example", district("krems.osm.gz", 0).learned.example, PatchOptions(cells=5))
    pattern.cache["kept"] = 1.0
    fresh = for_a_run(pattern)
    assert fresh.cache == {} and pattern.cache
    assert fresh.options == pattern.options and fresh.measure is pattern.measure


def test_a_history_with_a_bad_patch_option_fails_in_one_line(tmp_path, capsys):
    """The history's ``pattern_options`` reach :class:`PatchOptions`: a bad value (``roads_out_open = "false"``,
    a string where true or false is meant) is one line on stderr and exit code 2 before the town is grown, and
    no output is written."""
    from osm_expand.cli import main

    text = (FIXTURES.parent / "osm_expand" / "histories" / "example.toml").read_text()
    era = 'pattern = "example"'
    assert era in text
    path = tmp_path / "h.toml"
    path.write_text(text.replace(era, era + '\npattern_options = { roads_out_open = "false" }', 1))
    out = tmp_path / "o.xml"
    code = main([str(FIXTURES / "monaco.osm.gz"), "--history", str(path), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "roads_out_open" in err and "true or false" in err, err
    assert not out.exists()


def _grid(bearing_deg: float, n: int = 6, step: float = 80.0, at=(0.0, 0.0)) -> np.ndarray:
    """An n×n street grid of ``step`` metres running at ``bearing_deg``, as LineStrings."""
    a = np.radians(bearing_deg)
    u, v = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
    span = step * (n - 1)
    lines = [(np.array(at) + i * step * v, np.array(at) + i * step * v + span * u) for i in range(n)]
    lines += [(np.array(at) + i * step * u, np.array(at) + i * step * u + span * v) for i in range(n)]
    return np.array([shapely.LineString(ln) for ln in lines])


@pytest.mark.parametrize("bearing", [0.4, 12.3, 33.7, 47.6, 89.2])
def test_a_grids_main_direction_is_the_centre_of_its_fullest_bin(bearing):
    """A patch turns to meet its neighbours' grid, each grid read as the centre of its fullest 5° bin of
    bearings (mod 90°): within 2.5° of the grid's own bearing. (Session 32's reading from the bearings
    themselves, ``grain_from_bearings``, measured and left off, is in docs/tried.md.)"""
    from synth.patches.placing import _main_direction

    got = np.degrees(_main_direction(_grid(bearing), 2.0))
    assert got % 5.0 == pytest.approx(2.5)
    assert abs((got - bearing + 45.0) % 90.0 - 45.0) <= 2.5 + 1e-9, got


def test_each_cut_end_at_the_edge_takes_one_perimeter_run_and_meets_it_in_an_l():
    """A cut end joined to a perimeter street turns into it at a node of degree two (an L, no tee): each cut
    end takes one run, so of three cut streets side by side at the edge one run is laid and one end is left
    open for the trimming (session 34's ``ring_streets``, chaining the runs into tees, is in docs/tried.md)."""
    from synth.patches.edges import _edge_streets
    from synth.patches.quilt import _network

    spacing = 100.0
    region = shapely.box(0.0, 0.0, 600.0, 400.0)
    quilt = _Quilt()
    for k, x in enumerate((200.0, 300.0, 400.0)):  # three streets running down to the edge, cut there
        quilt.add(np.array([[x, 150.0], [x, 0.5]]), "residential", 0)
        quilt.cut_xy.append(np.array([x, 0.5]))
        quilt.cut_heading.append(np.array([0.0, -1.0]))
        quilt.cut_cell.append(k)
        quilt.cut_piece.append(k)
    made = _edge_streets(quilt, region, spacing, PatchOptions(), shapely.Polygon(), shapely.MultiLineString())
    net = _network(quilt)
    degree = segment_degree(net.streets, len(net.xy))
    assert made == 1 and int((degree == 3).sum()) == 0
    assert len(quilt.cut_xy) == 1  # a cut end on a run is closed; the third is left open


def _old_chain_without(streets, end, seg):
    """The chain the old ``_more_dead_ends`` measured: the streets made again without ``seg``, walked afresh."""
    return dangling_chains(without_segments(streets, {seg}), [end]).get(end)


def _walk_checks(streets):
    """Every segment at a node of two segments, taken away and the chain from that node walked both ways."""
    import networkx as nx

    from osm_expand.model.topology import dangling_chain, segment_neighbours
    from synth.patches.topology import _bridges

    neighbours = segment_neighbours(streets)
    graph = nx.Graph([(a, b) for s in streets for a, b in zip(s.nodes[:-1], s.nodes[1:])])
    assert _bridges(neighbours) == {(min(u, v), max(u, v)) for u, v in nx.bridges(graph) if u != v}
    checked = 0
    for node, near in neighbours.items():
        if len(near) != 2:
            continue
        for other in set(near):
            seg = (min(node, other), max(node, other))
            assert dangling_chain(neighbours, node, without=seg) == _old_chain_without(streets, node, seg)
            checked += 1
    assert dangling_chains(streets, list(neighbours)) == {
        leaf: c for leaf in neighbours if (c := dangling_chain(neighbours, leaf)) is not None}
    return checked


@pytest.mark.parametrize("name", ["monaco.osm.gz", "krems.osm.gz"])
def test_a_chain_walked_past_a_taken_segment_is_the_one_walked_on_the_streets_without_it(name):
    """``_more_dead_ends`` walks each candidate tee's cul-de-sac on one neighbour map per round, skipping
    the tee, and finds the bridges itself: the same chains and bridges as the streets made again without
    the tee and ``networkx.bridges`` (what it did before), on every degree-2 node of a real town."""
    streets = load(FIXTURES / name, context=False).network.streets
    assert _walk_checks(streets) > 100


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.integers(0, 14), min_size=2, max_size=6), min_size=1, max_size=14))
def test_chains_past_a_taken_segment_and_bridges_match_the_networks_made_again(paths):
    """The same on random small networks: shared and doubled segments, loops, streets through a node twice."""
    from osm_expand.model.network import Street
    from osm_expand.model.topology import clean_nodes

    streets = [Street(nodes=nodes, highway="residential") for p in paths if (nodes := clean_nodes(p)) is not None]
    _walk_checks(streets)


def _old_pieces(net):
    """The pieces as ``_keep_joinable`` found them before: a networkx graph with each segment's street."""
    import networkx as nx

    graph = nx.Graph()
    for k, s in enumerate(net.streets):
        graph.add_edges_from((a, b, {"street": k}) for a, b in zip(s.nodes[:-1], s.nodes[1:]))
    return [sorted({d["street"] for _, _, d in graph.subgraph(comp).edges(data=True)})
            for comp in nx.connected_components(graph)]


@pytest.mark.parametrize("name", ["monaco.osm.gz", "north-bayreuth.osm.gz"])
def test_the_pieces_of_a_real_network_are_those_networkx_found_in_the_same_order(name):
    from synth.patches.topology import _pieces

    net = load(FIXTURES / name, context=False).network
    # every other street only: more pieces than the connected town has
    half = net.replace(streets=net.streets[::2])
    for n in (net, half):
        assert _pieces(n) == _old_pieces(n)
    assert len(_pieces(half)) > 10


@settings(max_examples=80, deadline=None)
@given(st.lists(st.lists(st.integers(0, 14), min_size=2, max_size=6), min_size=1, max_size=14))
def test_the_pieces_of_a_random_network_are_those_networkx_found(paths):
    """Shared and doubled segments (the later street keeps the segment), loops, unused nodes."""
    from osm_expand.model.network import Street
    from osm_expand.model.topology import clean_nodes
    from synth.patches.topology import _pieces

    streets = tuple(Street(nodes=nodes, highway="residential") for p in paths
                    if (nodes := clean_nodes(p)) is not None)
    if not streets:
        return
    net = network_from_lines([[(0.0, 0.0), (1.0, 0.0)]]).replace(streets=streets)
    net = net.replace(xy=np.zeros((15, 2)), node_ids=np.zeros(15, dtype=np.int64))
    assert _pieces(net) == _old_pieces(net)


def test_lines_read_and_made_in_one_call_are_those_made_one_by_one():
    """``source._line_xy`` (the town's streets as arrays for the measures) and ``model.geometry.linestrings_of``
    (a seam board's pieces) give what reading or making each line alone gave, on Monaco's streets."""
    from osm_expand.model.geometry import linestrings_of as _lines
    from synth.patches.source import _line_xy

    lines = load(FIXTURES / "monaco.osm.gz", context=False).network.street_lines()
    xy = _line_xy(lines)
    assert len(xy) == len(lines) and _line_xy(lines[:0]) == []
    assert all(a.dtype == b.dtype and np.array_equal(a, b) for a, b in zip(xy, (np.asarray(ln.coords) for ln in lines)))
    made = _lines(xy)
    assert len(_lines([])) == 0
    assert shapely.equals_exact(made, lines, tolerance=0.0).all()


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(-0.8, 0.8))
def test_a_cells_cut_ends_measured_at_once_are_those_measured_end_by_end(seed, turn):
    """``placing._cut_ends`` (every piece's two ends tested in one distance call and one tree query) marks
    the ends that testing each end alone marked: on the cell's edge, or on a point where the street met one
    that is not copied, under a turned and moved patch."""
    from scipy.spatial import cKDTree

    from synth.patches.placing import _cut_ends, _Transform
    from synth.patches.source import _Source

    rng = np.random.default_rng(seed)
    move = _Transform(rng.uniform(-500, 500, 2), rng.uniform(-500, 500, 2), turn)
    cell = shapely.Point(move.target_centre).buffer(120.0)
    boundary = shapely.boundary(cell)
    ring = shapely.get_coordinates(boundary)
    broken_src = rng.uniform(-600, 600, (5, 2))
    pieces = []
    for _ in range(int(rng.integers(0, 12))):
        ends = [move.target_centre + rng.normal(0, 60, 2) for _ in range(2)]
        for k in range(2):
            if rng.random() < 0.3:
                ends[k] = ring[int(rng.integers(len(ring)))]  # on the cell's edge
            elif rng.random() < 0.3:
                ends[k] = move.forward(broken_src[int(rng.integers(5))][None, :])[0]  # met a motorway in the town
        pieces.append(np.array([ends[0], (ends[0] + ends[1]) / 2, ends[1]]))
    lines = np.array([shapely.LineString([(0, 0), (1, 1)])], dtype=object)
    source = _Source(lines=lines, highway=("residential",), level=np.zeros(1, int), tree=shapely.STRtree(lines),
                     broken=cKDTree(broken_src))

    def one_by_one(end):
        return bool(shapely.distance(boundary, shapely.Point(end)) < 1e-6
                    or source.broken.query(move.back(end[None, :]), distance_upper_bound=1e-6)[0][0] < 1e-6)

    got = _cut_ends(source, move, boundary, pieces)
    assert [xy is p for (xy, _), p in zip(got, pieces)] == [True] * len(pieces)
    assert [c.tolist() for _, c in got] == [[one_by_one(p[0]), one_by_one(p[-1])] for p in pieces]
