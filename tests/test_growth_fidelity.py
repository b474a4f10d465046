"""What the engine grows, judged (issue 20): the Landscape Expansion Index on hand-built land, the window,
the per-era verdicts with their open ends, and the report of a real run."""
from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
import shapely

from osm_expand.fidelity import judge, real_parts, town_reference
from osm_expand.growth_fidelity import (
    BuiltUp,
    GrowthFidelityOptions,
    city_growth_fidelity,
    growth_fidelity,
    growth_window,
    is_major_road,
    landscape_expansion,
    piece_areas,
    piece_references,
    streets_land,
    town_margin,
)
from osm_expand.ingest import load
from osm_expand.measures import LineSet, Measure, measure_network
from osm_expand.model import City, Origin, network_from_lines
from tests.conftest import FIXTURES, expanded_and_matured
from tests.test_fidelity import DISTRICT_AREAS, grid, scatter_of_fragments, town_lines


def town_square(side: float = 1000.0, cell: float = 10.0) -> BuiltUp:
    """Built-up land: a square from (0, 0) to (side, side), in a raster reaching 500 m around it."""
    n = int((side + 1000.0) / cell)
    centres = -500.0 + (np.arange(n) + 0.5) * cell
    xs, ys = np.meshgrid(centres, centres)
    mask = (xs >= 0) & (xs <= side) & (ys >= 0) & (ys <= side)
    return BuiltUp(mask=mask, origin=np.array([-500.0, -500.0]), cell=cell)


def test_infill_edge_and_outlying_growth_by_their_landscape_expansion_index():
    built = town_square()
    infill = np.array([[400.0, 500.0], [600.0, 500.0]])  # inside the town: its ring is all built up
    edge = np.array([[1000.0, 200.0], [1200.0, 200.0]])  # from the town's edge outwards
    outlying = np.array([[1300.0, 800.0], [1400.0, 800.0]])  # 300 m beyond it
    result = landscape_expansion([infill, edge, outlying], built)
    assert len(result.lei) == 3
    assert result.lei.min() == 0.0  # the outlying one
    assert result.lei.max() == 100.0  # the infill one: every ring cell is town
    assert 0 < np.sort(result.lei)[1] <= 50  # the edge one: a sliver of its ring touches the town
    assert (result.infill, result.edge, result.outlying) == pytest.approx((0.4, 0.4, 0.2))
    d = result.to_dict()
    assert d["patches"] == 3 and d["new_length_km"] == pytest.approx(0.5)
    json.dumps(d, allow_nan=False)


def test_growth_joined_to_earlier_growth_is_edge_expansion_not_outlying():
    built = town_square()
    earlier = [np.array([[1000.0, 500.0], [1400.0, 500.0]])]  # an earlier era's street out of the town
    later = [np.array([[1400.0, 500.0], [1600.0, 500.0]])]  # this era's, continuing it
    alone = landscape_expansion(later, built)
    assert alone.outlying == 1.0
    after = landscape_expansion(later, built, earlier_lines=earlier)
    assert after.edge == 1.0 and 0 < after.lei[0] <= 50


def test_a_connected_piece_of_new_streets_is_one_patch():
    lines = grid(n=4, step=100.0, origin=(2000.0, 2000.0))  # far from the town: one outlying patch
    result = landscape_expansion(lines, town_square())
    assert len(result.lei) == 1 and result.outlying == 1.0
    assert landscape_expansion([], town_square()).to_dict()["infill"] is None


def test_the_growth_window_holds_the_blocks_between_the_streets_and_a_margin_beyond():
    opts = GrowthFidelityOptions()
    window = growth_window(grid(n=6, step=100.0, stub=0.0), opts)
    # the 500 m square grid and 50 m round it (corners rounded)
    assert window.geom_type == "Polygon" and not window.interiors
    assert window.area == pytest.approx(600.0 ** 2 - (4 - math.pi) * 50.0 ** 2, rel=0.01)
    assert growth_window([], opts).is_empty


def _network_with_eras():
    """A town grid, then era "a" adds a cul-de-sac off it, then era "b" continues that into a loop."""
    town = grid(n=6, step=100.0, stub=0.0)
    stub = [np.array([[500.0, 200.0], [700.0, 200.0]])]
    loop = [np.array([[700.0, 200.0], [700.0, 400.0], [500.0, 400.0]])]
    lines = town + stub + loop
    attrs = ([{"origin": Origin.SOURCE}] * len(town) + [{"origin": Origin.ENGINE, "era": "a", "year": 2030}]
             + [{"origin": Origin.ENGINE, "era": "b", "year": 2040}])
    return network_from_lines(lines, attrs), town


def test_an_era_is_judged_with_what_stood_when_it_ended():
    net, town = _network_with_eras()
    built = town_square(side=500.0)
    result = growth_fidelity(net, town, built=built, rng=0)
    assert list(result.per_era) == ["a", "b"]
    a, b, overall = result.per_era["a"], result.per_era["b"], result.overall
    # era a's street ended in a field: a dead end then, though era b joined it later
    assert a.district.dead_ends == 1 and a.district.open_ends == 1
    assert a.verdict(Measure.TWO_CORE_SHARE).value == 0.0
    # era b closed the loop: both its ends meet streets that stood before it
    assert b.district.dead_ends == 0 and b.verdict(Measure.TWO_CORE_SHARE).value == 1.0
    assert overall.district.dead_ends == 0 and overall.pieces == 1
    # era b's street starts where era a's ended, outside the town: edge expansion, not outlying
    assert result.lei_per_era["b"].outlying == 0.0
    d = result.to_dict()
    assert set(d) == {"overall", "per_era", "lei", "major_roads_km"} and set(d["lei"]["per_era"]) == {"a", "b"}
    json.dumps(d, allow_nan=False)


def test_the_engines_major_roads_are_not_judged_as_a_neighbourhood():
    """A bypass the engine built across the fields (``primary``, hierarchy 0, the era's width: how
    :mod:`osm_expand.engine.roads.major_roads` builds them) is no neighbourhood: the verdict and the LEI are
    those of the street growth alone, and the bypass's length is reported apart. (Monaco, seed 0: its 3.4 km
    bypass was half the window and put density, curvature and orientation entropy off; 10.7 of 14 off on
    average over three reference seeds before, 8 now.)"""
    town = grid(n=11, step=100.0, stub=0.0)
    district = grid(n=4, step=100.0, stub=0.0, origin=(1000.0, 300.0))  # beside the town, sharing its edge
    bypass = [np.array([[1000.0, 0.0], [2500.0, -800.0], [4000.0, -800.0]])]
    street = {"origin": Origin.ENGINE, "era": "a", "year": 2030}
    road = {**street, "highway": "primary", "hierarchy": 0, "width": 18.0}
    lines = town + district + bypass
    attrs = [{"origin": Origin.SOURCE}] * len(town) + [street] * len(district) + [road]
    net = network_from_lines(lines, attrs)
    without = network_from_lines(town + district, attrs[:-1])
    assert [is_major_road(s) for s in net.streets].count(True) == 1
    built = town_square()
    judged, alone = (growth_fidelity(n, town, built=built, rng=0) for n in (net, without))
    assert judged.to_dict()["overall"] == alone.to_dict()["overall"]
    assert judged.lei.to_dict() == alone.lei.to_dict()
    assert judged.to_dict()["major_roads_km"] == pytest.approx(3.2, abs=0.01)
    # a street pattern's primary street (no width) is street growth
    plain = network_from_lines(lines, attrs[:-1] + [{**street, "highway": "primary", "hierarchy": 0}])
    assert not any(is_major_road(s) for s in plain.streets)


def test_a_growth_of_pieces_is_judged_against_one_disc_per_piece():
    """Each reference part holds one disc per piece of the window, of that piece's area, apart from the others;
    a window of one piece gets the discs of a district's reference."""
    town = grid(n=31, step=100.0, stub=0.0)
    squares = [shapely.box(x, 0.0, x + side, side) for x, side in ((-2000.0, 600.0), (-4000.0, 300.0))]
    window = shapely.union_all(squares)
    discs = GrowthFidelityOptions(references_on_streets_land=False)  # the discs themselves (the grid ends)
    ref = piece_references(town, window, rng=np.random.default_rng(0), growth_options=discs)
    assert len(ref.windows) == 32 and ref.area == pytest.approx(window.area)
    for w in ref.windows:
        parts = shapely.get_parts(w)
        assert sorted(shapely.area(parts)) == pytest.approx([300.0 ** 2, 600.0 ** 2], rel=1e-6)
    one = piece_references(town, squares[0], rng=np.random.default_rng(1), growth_options=discs)
    district = town_reference(town, squares[0].area, rng=np.random.default_rng(1))
    assert all(a.equals(b) for a, b in zip(one.windows, district.windows))


def test_a_lone_street_is_judged_with_the_district_beside_it():
    """Pieces under ``min_piece_area`` get no disc of their own: their area goes to the nearest district-sized
    piece, or all into one disc when no piece is that large."""
    big, far = shapely.box(0.0, 0.0, 400.0, 400.0), shapely.box(5000.0, 0.0, 5300.0, 300.0)
    near, other = shapely.box(500.0, 0.0, 600.0, 100.0), shapely.box(5400.0, 0.0, 5500.0, 50.0)
    areas = piece_areas(shapely.union_all([big, far, near, other]), 40_000.0)
    assert areas.tolist() == pytest.approx([400.0 ** 2 + 100.0 ** 2, 300.0 ** 2 + 100.0 * 50.0])
    assert piece_areas(shapely.union_all([near, other]), 40_000.0).tolist() == pytest.approx([15_000.0])


def test_the_towns_own_neighbourhoods_apart_are_judged_alike_by_the_piece_yardstick():
    """Four of north-bayreuth's real neighbourhoods, cut out and set apart as the engine grows districts,
    are in the range of its neighbourhoods' street density and orientation entropy against unions of one disc
    per piece; against one disc of their summed area (the yardstick before) they were too dense (9.99 km/km²
    against 3.5–7.0: on a mostly rural extract a 2 km² disc is mostly fields) and too varied in orientation."""
    net = load(FIXTURES / "north-bayreuth.osm.gz").network
    town = LineSet.from_lines([net.street_xy(s) for s in net.streets])
    discs = real_parts(town, 500_000.0, n=4, rng=np.random.default_rng(100))
    lines, moved = [], []
    for k, disc in enumerate(discs):
        shift = np.array([k * 3000.0, 0.0]) - np.asarray(disc.centroid.coords[0])
        cut = shapely.get_parts(shapely.intersection(town.geoms, disc))
        lines += [shapely.get_coordinates(g) + shift for g in cut if g.geom_type == "LineString"]
        moved.append(shapely.affinity.translate(disc, *shift))
    window = shapely.union_all(moved)
    measured = measure_network(lines, window=window)  # in their discs: the references on theirs too
    pieces = judge(measured, piece_references(town, window, rng=np.random.default_rng(0),
                                              growth_options=GrowthFidelityOptions(references_on_streets_land=False)))
    one_disc = judge(measured, town_reference(town, window.area, rng=np.random.default_rng(0)))
    for measure in (Measure.DENSITY, Measure.ORIENTATION_ENTROPY):
        assert pieces.verdict(measure).ok and not one_disc.verdict(measure).ok, measure
    assert pieces.off <= 2  # measured: 0 (one disc: 4)


def _strip(x0: float, x1: float, y0: float, rows: int, step: float = 100.0) -> list[np.ndarray]:
    """A grid ``rows`` streets deep (``step`` apart) from ``x0`` to ``x1``: a town along a valley floor."""
    ys = y0 + np.arange(rows) * step
    xs = np.arange(x0, x1 + 1e-9, step)
    return ([np.column_stack([xs, np.full(len(xs), y)]) for y in ys]
            + [np.column_stack([np.full(rows, x), ys]) for x in xs])


def test_a_copy_of_a_valley_towns_own_fabric_reads_within_a_tenth_of_its_neighbourhoods_density():
    """A town along a valley floor, four streets deep between empty slopes, and a growth that is a copy of its own
    fabric: measured on its streets' land (:func:`growth_window`), as the engine's growth is, it is as dense as the
    town's neighbourhoods measured on theirs (:func:`streets_land`). Against the discs, which reach up the empty
    slopes, it read too dense (Andorra's engine districts in its valley: 15.8 km/km² against
    7.7–12.5)."""
    town = _strip(0.0, 5000.0, 0.0, 4)
    growth = _strip(0.0, 600.0, 3000.0, 4)
    window = growth_window(growth)
    measured = measure_network(growth, window=window)
    on_land = judge(measured, piece_references(town, window, rng=np.random.default_rng(0)))
    in_discs = judge(measured, piece_references(town, window, rng=np.random.default_rng(0),
                                                growth_options=GrowthFidelityOptions(references_on_streets_land=False)))
    land, discs = on_land.verdict(Measure.DENSITY), in_discs.verdict(Measure.DENSITY)
    # every neighbourhood of a uniform strip is alike, so the range is a point: the growth is within 10 % of it
    # (its window has a margin all round; a disc cuts the strip at its sides) ...
    assert land.value == pytest.approx((land.low + land.high) / 2, rel=0.1)
    assert not discs.ok and discs.value > 1.2 * discs.high  # ... against the discs it was too dense (16.2 > 13.2)


def test_a_copy_of_a_small_block_towns_fabric_reads_its_neighbourhoods_density():
    """A town of 40 m blocks (Monaco's median block is 1,666 m²) and an engine growth that is a copy of its
    fabric, 15 × 15 junctions: with the window's margin half the town's block (20 m; :func:`town_margin`) the
    growth reads within a tenth of its neighbourhoods' street density, as a disc's rim lies on average half a
    block beyond the first street inside it (measured: 46.8 km/km² against 50.3). With the fixed 50 m margin
    (the yardstick before) the empty rim round the copy read it a quarter too sparse (38.8): the same fabric."""
    town = grid(n=60, step=40.0, stub=0.0)
    growth = grid(n=15, step=40.0, stub=0.0, origin=(4000.0, 0.0))
    engine = {"origin": Origin.ENGINE, "era": "a", "year": 2030}
    attrs = [{"origin": Origin.SOURCE}] * len(town) + [engine] * len(growth)
    net = network_from_lines(town + growth, attrs)
    built = town_square(side=2400.0)
    assert town_margin(measure_network(town, pieces=False)) == pytest.approx(20.0, rel=1e-6)
    scaled = growth_fidelity(net, town, built=built, rng=0).overall.verdict(Measure.DENSITY)
    fixed = growth_fidelity(net, town, built=built, rng=0,
                            options=GrowthFidelityOptions(window_margin_from_town=False)).overall.verdict(Measure.DENSITY)
    assert scaled.value == pytest.approx((scaled.low + scaled.high) / 2, rel=0.1)
    assert fixed.value < 0.85 * fixed.low and not fixed.ok


def test_the_window_margin_is_the_options_where_the_town_has_no_block():
    tree = [np.array([[0.0, 0.0], [500.0, 0.0]]), np.array([[250.0, 0.0], [250.0, 300.0]])]
    assert town_margin(measure_network(tree, pieces=False)) == GrowthFidelityOptions().window_margin
    town = measure_network(grid(n=6, step=100.0, stub=0.0), pieces=False)
    assert town_margin(town) == pytest.approx(50.0)
    assert town_margin(town, GrowthFidelityOptions(window_margin=30.0, window_margin_from_town=False)) == 30.0


@pytest.mark.parametrize("name", list(DISTRICT_AREAS))
def test_a_scatter_of_fragments_is_no_neighbourhood_on_the_streets_land_either(name):
    """The default growth yardstick (references on their streets' land, the growth on its window) still
    fails eight fragments of the town's own streets spread over a district beside it, as the disc
    yardstick does (``tests/test_fidelity.py``): measured 9 off on Krems, 8 on north-bayreuth."""
    town = town_lines(name)
    fragments, _ = scatter_of_fragments(town, DISTRICT_AREAS[name])
    window = growth_window(fragments)
    report = judge(measure_network(fragments, window=window), piece_references(town, window,
                                                                                rng=np.random.default_rng(0)))
    assert report.off >= 6 and not report.believable and report.pieces >= 2
    for measure in (Measure.DENSITY, Measure.DEAD_END_SHARE, Measure.TWO_CORE_SHARE):
        assert not report.verdict(measure).ok, measure


def test_the_land_of_a_discs_streets_is_the_disc_where_they_fill_it_and_less_where_they_do_not():
    g = grid(12, 50.0)  # a 550 m grid
    town = LineSet.from_lines(g)
    core = shapely.Point(275.0, 275.0).buffer(200.0)
    assert streets_land(town, core).area == pytest.approx(core.area, rel=1e-6)
    half = shapely.Point(550.0, 275.0).buffer(400.0)  # half over the grid, half over empty land
    land = streets_land(town, half)
    assert land.within(half.buffer(1e-6)) and land.area < 0.75 * half.area
    empty = shapely.Point(5000.0, 5000.0).buffer(100.0)
    assert streets_land(town, empty).equals(empty)


def test_no_engine_street_no_growth_verdict():
    net, _ = _network_with_eras()
    source_only = net.replace(streets=tuple(s for s in net.streets if s.origin == Origin.SOURCE))
    assert city_growth_fidelity(City(network=source_only), rng=0) is None


@functools.cache
def krems_years():
    return expanded_and_matured(load(FIXTURES / "krems.osm.gz"), seed=0, fidelity=True)


def test_the_json_report_judges_what_the_years_grew():
    result = krems_years()
    g = result.report["growth_fidelity"]
    assert set(g) == {"overall", "per_era", "lei", "major_roads_km"}
    eras = {s.era for s in result.city.network.streets if s.origin == Origin.ENGINE}
    assert set(g["per_era"]) == eras and set(g["lei"]["per_era"]) == eras
    assert len(g["overall"]["measures"]) == len(Measure) and g["overall"]["pieces"] >= 1
    lei = g["lei"]
    assert lei["infill"] + lei["edge"] + lei["outlying"] == pytest.approx(1.0, abs=1e-3)
    engine_km = sum(shapely.length(shapely.LineString(result.city.network.street_xy(s)))
                    for s in result.city.network.streets if s.origin == Origin.ENGINE) / 1000
    assert lei["new_length_km"] + g["major_roads_km"] == pytest.approx(engine_km, abs=2e-3)
    json.dumps(g, allow_nan=False)


def test_compare_prints_its_verdict_and_judges_the_years_of_a_run_output(tmp_path, capsys):
    from osm_expand import cli
    from osm_expand.export import write_geojson

    krems = str(FIXTURES / "krems.osm.gz")
    assert cli.main(["compare", krems, krems, "-q"]) == 0  # the text once read a key the report lacks
    out = capsys.readouterr().out
    assert "of 14 measures" in out and "piece" in out and "what the years grew" not in out
    grown = tmp_path / "grown.geojson"
    write_geojson(krems_years().city, grown)
    assert cli.main(["compare", str(grown), krems, "-q", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    g = report["growth_fidelity"]
    assert set(g) == {"overall", "per_era", "lei", "major_roads_km"} and len(g["overall"]["measures"]) == len(Measure)
    assert g["lei"]["new_length_km"] == pytest.approx(krems_years().report["growth_fidelity"]["lei"]["new_length_km"],
                                                      abs=0.01)


@functools.cache
def krems_european_city():
    return expanded_and_matured(load(FIXTURES / "krems.osm.gz"), seed=0, history="european").city


@functools.cache
def krems_european_years():
    g = city_growth_fidelity(krems_european_city(), rng=0)
    assert g is not None and g.overall is not None
    return g


def test_krems_european_years_grow_at_the_edge_and_close_their_loops():
    """Krems' ``european`` history (seed 0, 50 years): its suburban eras hung lone streets on the town, combs
    (dead-end share 0.22 against its neighbourhoods' 0.09-0.20); they go now (issue 20). Nearly all of its
    street length is infill or edge expansion. Its gründerzeit grid closed every stub (2-core share 0.9684
    against the town's 0.885-0.967 with the town's margin, a thousandth above); with the named pattern's aim
    (:attr:`~osm_expand.engine.growth.minor_streets.GrowthOptions.pattern_aim`, on) the 2-core share lies in the
    range of the town's real neighbourhoods with the default yardstick (0.9415) and with the fixed 50 m window
    margin it was first calibrated on."""
    g = krems_european_years()
    assert g.lei.infill + g.lei.edge >= 0.8
    assert g.overall.to_dict()["measures"]["two_core_share"]["ok"]
    calibrated = GrowthFidelityOptions(window_margin_from_town=False)
    fixed = city_growth_fidelity(krems_european_city(), rng=0, options=calibrated)
    assert fixed is not None and fixed.overall.to_dict()["measures"]["two_core_share"]["ok"]


def test_krems_european_years_have_no_more_dead_ends_than_its_neighbourhoods():
    """Judged per piece, the clusters of culs-de-sac its suburban eras hung on the town (which they never
    close) left a dead-end share of 0.1494 against its neighbourhoods' 0.048–0.149; they go now (0.085 in
    0.026–0.152 before the named pattern's aim, 0.130 with it)."""
    assert krems_european_years().overall.to_dict()["measures"]["dead_end_share"]["ok"]
