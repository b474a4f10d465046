"""The land model: frontage learned from the town, taken land, land cover (issue 20)."""
from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import shapely

from osm_expand.blocks import blocks
from osm_expand.errors import OptionError
from osm_expand.ingest import load
from osm_expand.land import LAND_COVER, SETTLEMENT, WORKS, LandOptions, frontage_depth, land_cover_taken, read_land
from osm_expand.model import Building, City, MappedArea, network_from_lines
from osm_expand.sites import SiteOptions, choose_site, distance_maps
from tests.conftest import FIXTURES


@cache
def town(name: str) -> City:
    return load(FIXTURES / name)


def square(x0: float, y0: float, size: float) -> np.ndarray:
    return np.array([(x0, y0), (x0 + size, y0), (x0 + size, y0 + size), (x0, y0 + size), (x0, y0)])


def street_city(buildings=(), areas=(), highway="residential") -> City:
    """One street along y = 0 from x = 0 to 1000, and whatever is given."""
    net = network_from_lines([[(0.0, 0.0), (1000.0, 0.0)]], [{"highway": highway}])
    return City(network=net, buildings=tuple(buildings), areas=tuple(areas))


@pytest.mark.parametrize("name,low,high", [("krems.osm.gz", 60.0, 100.0), ("north-bayreuth.osm.gz", 55.0, 100.0)])
def test_the_frontage_depth_is_learned_from_the_towns_buildings(name, low, high):
    depth, source = frontage_depth(town(name))
    assert source == "learned"
    assert low <= depth["minor"] <= high and low <= depth["major"] <= high


def test_a_few_landmark_buildings_teach_no_depth():
    """Campo Grande maps 102 buildings on hundreds of kilometres of street: the default holds."""
    depth, source = frontage_depth(town("campo-grande.osm.gz"))
    assert source == "default"
    assert depth == {"major": LandOptions().default_depth, "minor": LandOptions().default_depth}


@pytest.mark.parametrize("name", ["krems.osm.gz", "north-bayreuth.osm.gz"])
def test_a_town_without_its_buildings_reads_nearly_the_same_occupied_land(name):
    """Taken out of the file, the buildings still stand on taken land, and the built-up area a site
    keeps out of is nearly the same."""
    city = town(name)
    bare = city.replace(buildings=())
    taken = shapely.union_all(read_land(bare).taken)
    shapely.prepare(taken)
    footprints = np.array([b.polygon for b in city.buildings], dtype=object)
    on_taken = shapely.covers(taken, shapely.centroid(footprints)).mean()
    assert on_taken >= 0.95
    with_buildings = shapely.union_all(read_land(city).town)
    without = shapely.union_all(read_land(bare).town)
    overlap = with_buildings.intersection(without).area / with_buildings.union(without).area
    assert overlap >= 0.8


def test_a_gap_between_mapped_houses_is_free_and_an_unmapped_street_is_taken():
    houses = [Building(rings=(square(x, 10.0, 12.0),)) for x in range(0, 400, 25)]  # x < 400 only
    land = read_land(street_city(houses), LandOptions(min_buildings=1, min_buildings_per_100m=0.0))
    taken = shapely.union_all(land.taken)
    assert taken.covers(shapely.Point(200.0, 20.0))  # among the houses
    assert not taken.covers(shapely.Point(200.0, -30.0))  # across the street from them: shown empty
    assert taken.covers(shapely.Point(800.0, 20.0)) and taken.covers(shapely.Point(800.0, -30.0))  # unmapped


def test_a_dead_ends_frontage_stops_at_its_tip():
    land = read_land(street_city())
    taken = shapely.union_all(land.taken)
    assert taken.covers(shapely.Point(500.0, 50.0))
    assert not taken.intersects(shapely.Point(1010.0, 0.0))  # beyond the dead end the fields are free


def test_the_houses_round_a_dead_ends_tip_are_taken_and_the_way_straight_on_is_free():
    """Past a cul-de-sac's tip its last houses stand beside the way on (a disc of the frontage depth round
    the tip is taken), while a street continuing it runs straight on (45° each side stays free)."""
    taken = shapely.union_all(read_land(street_city(), LandOptions(dead_end_open_deg=45.0)).taken)
    assert taken.covers(shapely.Point(1030.0, 40.0)) and taken.covers(shapely.Point(1030.0, -40.0))  # 53° off
    assert not taken.intersects(shapely.Point(1050.0, 10.0)) and not taken.intersects(shapely.Point(1200.0, 0.0))
    flat = shapely.union_all(read_land(street_city()).taken)  # the default (off): the frontage stops at the tip
    assert not flat.intersects(shapely.Point(1030.0, 40.0))
    country = read_land(street_city(highway="unclassified"), LandOptions(dead_end_open_deg=45.0))
    assert not len(country.taken)  # a road with no frontage has no cap either


@pytest.mark.parametrize("bad", [0.0, 90.0, -10.0, float("nan")])
def test_an_open_angle_past_a_tip_outside_0_to_90_degrees_is_refused(bad):
    with pytest.raises(OptionError, match="dead_end_open_deg"):
        LandOptions(dead_end_open_deg=bad)


def test_withheld_from_krems_the_last_houses_of_two_cul_de_sacs_are_taken():
    """With Krems' buildings withheld and the verdict band, a join leaving Wichmanngasse's tip at 60° to the
    street and an engine street passing another cul-de-sac's tip crossed the last house of each
    (``benchmarks/withheld_buildings.py``): the frontage stopped square at the tips, and 16 % and 6 % of the
    two houses stood past it. With ``dead_end_open_deg=45`` (off by default: :class:`LandOptions`) they are
    wholly taken."""
    city = town("krems.osm.gz")
    houses = [b.polygon for b in city.buildings if b.osm_id in (58817545, 140588568)]
    assert len(houses) == 2
    bare = city.replace(buildings=())
    now = shapely.union_all(read_land(bare, LandOptions(dead_end_open_deg=45.0)).taken)
    assert all(shapely.area(shapely.intersection(h, now)) >= h.area - 1e-6 for h in houses)
    flat = shapely.union_all(read_land(bare).taken)
    assert all(shapely.area(shapely.intersection(h, flat)) < 0.95 * h.area for h in houses)


def test_a_country_road_has_no_frontage_in_the_fields():
    land = read_land(street_city(highway="unclassified"))
    assert not len(land.taken)


def test_settlement_land_use_is_taken_and_fields_are_not():
    homes = MappedArea(polygon=shapely.box(2000, 2000, 2300, 2300), key="landuse", value="residential")
    field = MappedArea(polygon=shapely.box(3000, 3000, 3300, 3300), key="landuse", value="farmland")
    taken = shapely.union_all(read_land(street_city(areas=(homes, field))).taken)
    assert taken.covers(shapely.Point(2150, 2150)) and not taken.intersects(shapely.Point(3150, 3150))


def test_the_land_cover_table_gives_each_cover_its_cost():
    areas = tuple(MappedArea(polygon=shapely.box(2000 + 400 * k, 0, 2300 + 400 * k, 300), key=kv.split("=")[0],
                             value=kv.split("=")[1]) for k, kv in enumerate(["landuse=forest", "landuse=farmland"]))
    land = read_land(street_city(areas=areas))
    assert dict(zip(land.cover_kind, land.cover_cost.tolist())) == {
        "landuse=forest": LAND_COVER["landuse=forest"], "landuse=farmland": LAND_COVER["landuse=farmland"]}
    assert LAND_COVER["landuse=forest"] > LAND_COVER["landuse=farmland"] == 0.0


def test_a_site_takes_the_fields_before_the_forest():
    """A town with forest on its west and farmland on its east grows east, and the report's land cover
    taken says farmland."""
    span = [0.0, 100.0, 200.0, 300.0]
    lines = [[(x, y) for x in span] for y in span] + [[(x, y) for y in span] for x in span]
    net = network_from_lines(lines)
    woods = shapely.box(-1500, -1500, 380, 1800).difference(shapely.box(-30, -30, 330, 330))
    forest = MappedArea(polygon=woods, key="landuse", value="forest")
    farm = MappedArea(polygon=shapely.box(380, -1500, 1800, 1800), key="landuse", value="farmland")
    city = City(network=net, blocks=tuple(blocks(net)), areas=(forest, farm))
    city = city.replace(land=read_land(city, LandOptions(default_depth=20.0)))
    site = choose_site(distance_maps(city, SiteOptions(), margin=1200.0, beyond_bounds=True), 250_000.0)
    assert site is not None and site.centre[0] > 300.0
    grown_line = np.array([[600.0, 100.0], [900.0, 100.0]])
    grown = city.replace(network=city.network.with_new_streets([grown_line], [{"highway": "residential"}]))
    took = land_cover_taken(city, grown)
    assert max(took, key=took.get) == "landuse=farmland"


def test_a_works_enclosure_is_taken_land_though_no_building_is_mapped():
    """Krems' sewage plant (``man_made=wastewater_plant``, way 29735498, no landuse around it) holds
    four houses: with the buildings withheld it must still read as the town's land."""
    city = town("krems.osm.gz")
    plant = [a for a in city.areas if a.osm_id == 29735498]
    assert [(a.key, a.value) for a in plant] == [("man_made", "wastewater_plant")]
    bare = city.replace(buildings=())
    taken = shapely.union_all(read_land(bare, LandOptions(settlement=SETTLEMENT + WORKS)).taken)
    assert taken.intersection(plant[0].polygon).area >= 0.95 * plant[0].polygon.area


def test_a_street_end_a_service_way_continues_gets_land_past_its_tip():
    """The service way (not a street of the network) turns north at the residential street's end:
    that end is a junction, so the corner past the tip is taken."""
    drive = shapely.LineString([(1000.0, 0.0), (1000.0, 300.0)])
    plain, continued = street_city(), street_city().replace(service_lines=(drive,))
    corner = shapely.Point(1020.0, -20.0)  # past the tip, south of the service way's flat end
    assert not shapely.union_all(read_land(plain).taken).intersects(corner)
    assert not shapely.union_all(read_land(continued).taken).intersects(corner)  # off by default
    taken = shapely.union_all(read_land(continued, LandOptions(service_ways=True)).taken)
    assert taken.covers(corner) and taken.covers(shapely.Point(1050.0, 150.0))  # and the way's own frontage


@pytest.mark.parametrize("name", ["krems.osm.gz", "north-bayreuth.osm.gz"])
def test_service_ways_are_land_evidence_and_leave_the_network_as_it_was(name):
    """Read by default as evidence only: the streets are those of a read without context (which keeps
    no evidence), and with ``--service`` they are streets and no longer evidence."""
    city = town(name)
    assert len(city.service_lines) > 0
    assert not any(s.highway == "service" for s in city.network.streets)
    bare = load(FIXTURES / name, context=False)
    assert bare.service_lines == ()
    assert [s.nodes for s in city.network.streets] == [s.nodes for s in bare.network.streets]
    assert np.array_equal(city.network.xy, bare.network.xy)
    assert load(FIXTURES / name, service=True).service_lines == ()



def _less_piece_by_piece(claimed: np.ndarray, holes: np.ndarray) -> np.ndarray:
    """The survey cut as it was before session 39: each piece less a union of the holes that meet it."""
    which, near = shapely.STRtree(holes).query(claimed, predicate="intersects")
    out = claimed.copy()
    for k in np.unique(which).tolist():
        out[k] = shapely.difference(claimed[k], shapely.union_all(holes[near[which == k]]))
    return out


def _surveyed_piece_by_piece(city: City, opts: LandOptions) -> tuple[np.ndarray, np.ndarray]:
    """:func:`read_land`'s ``taken`` and ``presumed`` as cut before session 39 (reference only)."""
    import osm_expand.land as land_module

    depth, _ = frontage_depth(city, opts)
    footprints = land_module._footprints(city)
    settlement = [a.polygon for a in city.areas if land_module.matches(a.key, a.value, opts.settlement)]
    service = np.array(city.service_lines if opts.service_ways else (), dtype=object)
    frontage, lines, widths, caps = land_module._frontage(city, depth, footprints, settlement, service,
                                                          opts.dead_end_open_deg)
    discs = shapely.buffer(footprints, opts.survey_radius, quad_segs=4)
    empty = land_module._empty_cells(lines, widths, footprints, opts.survey_radius)
    settled = np.array(settlement + caps, dtype=object)

    def kept(geoms: np.ndarray) -> np.ndarray:
        parts = shapely.get_parts(geoms)
        return parts[(shapely.get_type_id(parts) == 3) & (shapely.area(parts) >= opts.min_piece)]

    taken = kept(np.concatenate([_less_piece_by_piece(np.array(frontage, dtype=object), empty),
                                 _less_piece_by_piece(settled, discs)]))
    presumed = kept(_less_piece_by_piece(np.array([*frontage, *settlement, *caps], dtype=object), discs))
    return taken, presumed


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz", "north-bayreuth.osm.gz"])
def test_one_union_of_the_survey_holes_cuts_the_same_land_as_a_union_per_piece(name):
    """Session 39: read_land cuts the frontage and settlement by one union of all the survey holes (one
    vectorised difference) instead of a union per piece: the vertices differ in the last bits, the land
    does not (area to 1e-6, what lies in one and not the other under 1 m²)."""
    city = town(name)
    land = read_land(city)
    for new, old in zip((land.taken, land.presumed), _surveyed_piece_by_piece(city, LandOptions())):
        a, b = shapely.union_all(new), shapely.union_all(old)
        assert abs(a.area - b.area) <= 1e-6 * b.area
        assert shapely.symmetric_difference(a, b).area < 1.0
        assert len(new) > 0


def test_the_default_finds_no_dead_ends_and_caps_on_do(monkeypatch):
    """Finding 14 of session 31: with ``dead_end_open_deg`` None (the default) no tree over the strips
    is built to find the dead ends (they would have no caps); with it set, it is."""
    import osm_expand.land as land_module

    trees: list[int] = []
    tree = shapely.STRtree

    def counted(geoms, *a, **k):
        trees.append(len(geoms))
        return tree(geoms, *a, **k)

    city = street_city()
    monkeypatch.setattr(land_module.shapely, "STRtree", counted)
    read_land(city)
    default = len(trees)
    trees.clear()
    read_land(city, LandOptions(dead_end_open_deg=45.0))
    assert len(trees) == default + 1


def test_a_dead_end_whose_tip_vertex_is_doubled_keeps_its_cap():
    """Finding 15 of session 31: straight on is taken from a frontage depth back along the street, so a
    tip mapped twice (a last segment of no length) still gets its cap, the same as the plain street's."""
    from osm_expand.land import _dead_end_caps

    plain = shapely.LineString([(0.0, 0.0), (500.0, 0.0), (1000.0, 0.0)])
    doubled = shapely.LineString([(0.0, 0.0), (500.0, 0.0), (1000.0, 0.0), (1000.0, 0.0)])
    width, dead = np.array([50.0, 50.0]), np.array([False, True])  # the last end is the dead end
    caps = _dead_end_caps(np.array([doubled], dtype=object), width, dead, 45.0)
    assert len(caps) == 1
    assert caps[0].covers(shapely.Point(1020.0, 30.0)) and not caps[0].intersects(shapely.Point(1040.0, 5.0))
    same = _dead_end_caps(np.array([plain], dtype=object), width, dead, 45.0)
    assert shapely.equals(caps[0], same[0])
    first = _dead_end_caps(np.array([doubled.reverse()], dtype=object), width, np.array([True, False]), 45.0)
    assert shapely.equals(first[0], same[0])  # the first end, the street drawn the other way


def _empty_cells_all_asked(lines, widths, footprints, radius):
    """``_empty_cells`` as it was (main def3a8e): every piece and every cell asked by ``dwithin``."""
    import osm_expand.land as land_module

    pieces, owner = land_module._pieces(lines)
    w = widths[owner]
    tree = shapely.STRtree(footprints)
    near = np.unique(tree.query(pieces, predicate="dwithin", distance=radius + float(w.max()) + 1.0)[0])
    pieces, w = pieces[near], w[near]
    cells = np.concatenate([shapely.buffer(pieces, w, cap_style="flat", single_sided=True),
                            shapely.buffer(pieces, -w, cap_style="flat", single_sided=True)])
    has_building = np.zeros(len(cells), dtype=bool)
    has_building[tree.query(cells, predicate="intersects")[0]] = True
    surveyed = np.zeros(len(cells), dtype=bool)
    surveyed[tree.query(cells, predicate="dwithin", distance=radius)[0]] = True
    empty = cells[surveyed & ~has_building]
    return shapely.buffer(empty, 0.5, join_style="mitre") if len(empty) else empty


@pytest.mark.parametrize("name", ["krems.osm.gz", "campo-grande.osm.gz"])
def test_the_empty_cells_are_those_every_pair_found(name):
    """Issue 22: the empty frontage is found by nearest buildings and only among cells without one (Krems'
    cells 0.29 -> 0.12 s); the very cells, to the bit, where a dense town and one of few buildings are read."""
    import osm_expand.land as land_module

    city = town(name)
    opts = LandOptions()
    depth, _ = frontage_depth(city, opts)
    footprints = land_module._footprints(city)
    settlement = [a.polygon for a in city.areas if land_module.matches(a.key, a.value, opts.settlement)]
    _, lines, widths, _ = land_module._frontage(city, depth, footprints, settlement, np.empty(0, dtype=object))
    got = land_module._empty_cells(lines, widths, footprints, opts.survey_radius)
    assert len(got) > 10
    assert shapely.to_wkb(got).tolist() == shapely.to_wkb(
        _empty_cells_all_asked(lines, widths, footprints, opts.survey_radius)).tolist()


def test_any_within_answers_as_the_dwithin_query_even_at_the_very_distance():
    """:func:`_any_within` against ``dwithin`` on squares and lines placed at exactly the distance, a hair
    inside and outside it, touching, inside one another, and empty."""
    from osm_expand.land import _any_within

    rng = np.random.default_rng(7)
    tree_geoms = shapely.box(*np.column_stack([rng.uniform(0, 1000, (200, 2)), rng.uniform(0, 1000, (200, 2))
                                               + rng.uniform(1, 30, (200, 2))]).T)
    tree = shapely.STRtree(tree_geoms)
    d = 25.0
    x0 = shapely.bounds(tree_geoms)[:, 2]
    y = shapely.bounds(tree_geoms)[:, 1]
    probes = [*shapely.points(x0 + d, y), *shapely.points(x0 + np.nextafter(d, 0), y),
              *shapely.points(x0 + np.nextafter(d, 100), y), *shapely.points(x0 + d * (1 + 1e-10), y),
              *shapely.linestrings(np.stack([np.column_stack([x0 + d, y - 5]), np.column_stack([x0 + d, y - 1])],
                                            axis=1)),
              *shapely.points(rng.uniform(-100, 1100, (300, 2))), *shapely.centroid(tree_geoms[:20]),
              shapely.Point(), shapely.box(-50, -50, 1100, 1100)]
    geoms = np.array(probes, dtype=object)
    for distance in (d, 0.0, 1e-3, 400.0):
        want = np.zeros(len(geoms), dtype=bool)
        want[tree.query(geoms, predicate="dwithin", distance=distance)[0]] = True
        assert _any_within(tree, geoms, distance).tolist() == want.tolist()
    assert not _any_within(shapely.STRtree(np.empty(0, dtype=object)), geoms, d).any()


def _occupied_within_piece_by_piece(city: City, area: shapely.Geometry, taken: bool = True) -> shapely.Geometry:
    """:meth:`City.occupied_within` as it was before session 39: the taken land's pieces meeting the box,
    unioned with the rest at every ask (reference only)."""
    from osm_expand.model.city import _block_index, _land_parts

    box = shapely.box(*area.bounds)
    parts, tree = _land_parts(city.water, city.sea, city.unbuildable)
    near = parts[tree.query(box, predicate="intersects")] if len(parts) else parts
    blocks, block_tree = _block_index(city.blocks)
    if len(blocks):
        blocks = shapely.buffer(city._town_of(blocks[np.sort(block_tree.query(box, predicate="intersects"))]), -1.0)
    held = city.land.taken_near(box) if city.land is not None and taken else []
    return shapely.union_all([*near.tolist(), *held, *blocks.tolist()])


@cache
def prepared(name: str) -> City:
    from osm_expand.pipeline import prepare

    return prepare(town(name))


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz", "north-bayreuth.osm.gz"])
def test_occupied_land_cut_from_one_union_of_the_taken_land_is_the_same_land(name):
    """Session 39: :meth:`City.occupied_within` cuts the asked box out of one union of the town's taken
    land (made once per land) instead of a union of the pieces meeting the box at every ask: inside the
    asked area the occupied land is the same (area to 1e-6, what lies in one and not the other under 1 m²),
    on discs across the town and with the taken land left out."""
    city = prepared(name)
    x0, y0, x1, y1 = shapely.total_bounds(city.land.taken)
    asked = 0
    for fx in (0.25, 0.5, 0.75):
        for fy in (0.25, 0.5, 0.75):
            area = shapely.Point(x0 + fx * (x1 - x0), y0 + fy * (y1 - y0)).buffer(400.0)
            for taken in (True, False):
                new = shapely.intersection(city.occupied_within(area, taken=taken), area)
                old = shapely.intersection(_occupied_within_piece_by_piece(city, area, taken), area)
                assert abs(new.area - old.area) <= 1e-6 * max(old.area, 1.0)
                assert shapely.symmetric_difference(new, old).area < 1.0
                asked += old.area > 0
    assert asked >= 9  # the discs meet the town
