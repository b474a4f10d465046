"""Space colonisation as a growth pattern (issue 12): hand-built towns with known answers, then
Krems, Campo Grande and Andorra through the real pipeline (joins, planarity, forbidden ground,
fidelity, the XML, determinism, debug features)."""
from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
import shapely

from osm_expand.errors import InputError
from osm_expand.export import write_urbanenvironment
from osm_expand.export.urban import validate
from osm_expand.ingest import load
from osm_expand.model import City, Origin, network_from_lines
from osm_expand.pipeline import ExpandOptions, expand, learn
from synth.colonisation import ColonisationOptions
from synth.colonisation_pattern import (
    DEBUG_LAYERS,
    Colonisation,
    ColonisationPatternOptions,
    colonisation_from_config,
    town_highways,
)
from synth.flowfield import FlowPrimitive
from tests.conftest import FIXTURES

SL = 100.0
GEOMETRY_TYPES = {"Point", "LineString", "Polygon", "MultiPoint", "MultiLineString", "MultiPolygon"}


def town(lines, highways=None) -> City:
    """A city of the given streets (metres), mapped (origin source)."""
    attrs = [{"highway": h} for h in (highways or ["residential"] * len(lines))]
    return City(network=network_from_lines([np.asarray(ln, dtype=float) for ln in lines], attrs))


def grown(city: City, region, **kwargs):
    pattern = Colonisation(kwargs.pop("town", SL), **kwargs)
    return pattern.grow(city, region, np.random.default_rng(7))


def check_debug_features(features: list[dict]) -> None:
    """Every feature is a GeoJSON Feature with a known layer, finite coordinates and JSON properties."""
    json.dumps(features, allow_nan=False)  # no NaN, no numpy scalars, nothing unserialisable

    def coords(c):
        if isinstance(c, (int, float)):
            return [c]
        return [v for x in c for v in coords(x)]

    for f in features:
        assert f["type"] == "Feature" and f["properties"]["layer"] in DEBUG_LAYERS
        g = f["geometry"]
        if f["properties"]["layer"] == "parameters":
            assert g is None
            continue
        assert g["type"] in GEOMETRY_TYPES
        values = coords(g["coordinates"])
        assert values and all(math.isfinite(v) for v in values)
        assert shapely.from_geojson(json.dumps(g)).is_valid


# --------------------------------------------------------------------------- hand-built towns


def test_streets_grow_from_the_town_street_and_end_exactly_on_it():
    street = [(-200.0, 0.0), (1700.0, 0.0)]
    city = town([street])
    region = shapely.box(0.0, 0.0, 1500.0, 1200.0)
    growth = grown(city, region)
    assert len(growth.streets) >= 5
    ends = np.array([s.xy[k] for s in growth.streets for k in (0, -1)])
    on_town = ends[np.abs(ends[:, 1]) < 1e-6]
    assert len(on_town) >= 2  # growth starts from the town
    assert (on_town[:, 1] == 0.0).all()  # exactly on the town street: the joining step makes them tees
    for s in growth.streets:  # a town point is only ever a street's end
        assert (np.abs(s.xy[1:-1, 1]) > 1e-6).all()
    inside = region.buffer(0.1 * SL + 1e-6)
    assert all(inside.covers(shapely.LineString(s.xy)) for s in growth.streets)
    assert growth.debug["seed_streets"] == 1 and growth.debug["corridor"] is False
    assert growth.footprint.equals(region)


def test_an_end_on_a_town_node_has_the_nodes_exact_coordinates():
    # a street with a vertex every 37.3 m: snapping lands on vertices, which must be copied exactly
    xs = np.arange(-200.0, 1700.0, 37.3) + 0.123456789
    city = town([np.column_stack([xs, np.full_like(xs, 0.1)])])
    growth = grown(city, shapely.box(0.0, 0.1, 1500.0, 1200.0))
    nodes = {tuple(p) for p in city.network.xy.tolist()}
    ends = [tuple(s.xy[k]) for s in growth.streets for k in (0, -1)]
    on_town = [e for e in ends if abs(e[1] - 0.1) < 1e-6]
    assert on_town
    on_nodes = [e for e in on_town if e in nodes]
    assert on_nodes  # some ends are town nodes: identical coordinates, no rounding
    result = expand_like(city, growth)
    shared = {n for s in result.network.streets if s.origin == Origin.GROWN for n in (s.nodes[0], s.nodes[-1])}
    assert len(shared & set(result.network.streets[0].nodes)) == len(set(on_town))


def expand_like(city: City, growth) -> City:
    """The pipeline's shared joining step on a hand-built city (without the join links)."""
    from osm_expand.joins import add_streets

    attrs = [{"highway": s.highway, "hierarchy": s.hierarchy, "origin": Origin.GROWN} for s in growth.streets]
    return add_streets(city, [s.xy for s in growth.streets], attrs)


def test_a_site_away_from_the_town_gets_a_corridor_to_it():
    city = town([[(-1000.0, 0.0), (1000.0, 0.0)]])
    region = shapely.Point(0.0, 900.0).buffer(500.0)  # 400 m from the street: nothing touches it
    growth = grown(city, region)
    assert growth.debug["corridor"] is True and growth.debug["seed_streets"] == 1
    ends = np.array([s.xy[k] for s in growth.streets for k in (0, -1)])
    assert (np.abs(ends[:, 1]) < 1e-6).any()  # reached the town street
    layers = {f["properties"]["layer"] for f in growth.debug["features"]}
    assert "colonisation_corridor" in layers
    assert growth.footprint.area > region.area
    far = grown(city, shapely.Point(0.0, 4000.0).buffer(500.0))  # beyond corridor_reach (20 SL = 2 km)
    assert far.streets == () and far.debug["corridor"] is False


def test_nothing_grows_on_water_nor_outside_the_region():
    city = town([[(-200.0, 0.0), (1700.0, 0.0)]])
    lake = shapely.box(300.0, 300.0, 900.0, 800.0)
    city = city.replace(water=(lake,))
    region = shapely.box(0.0, 0.0, 1500.0, 1200.0)
    growth = grown(city, region)
    lines = [shapely.LineString(s.xy) for s in growth.streets]
    assert lines and not any(line.intersects(lake) for line in lines)
    assert growth.footprint.equals(shapely.difference(region, city.occupied))
    aps = [f for f in growth.debug["features"] if f["properties"]["layer"] == "attraction_point"]
    assert aps and not any(lake.contains(shapely.Point(f["geometry"]["coordinates"])) for f in aps)


def test_motorways_are_neither_joined_nor_crossed_but_bridges_may_be_passed_under():
    city = town([[(-200.0, 0.0), (1700.0, 0.0)], [(750.0, -200.0), (750.0, 1400.0)]],
                ["residential", "motorway"])
    growth = grown(city, shapely.box(0.0, 0.0, 1500.0, 1200.0))
    motorway = shapely.LineString([(750.0, -200.0), (750.0, 1400.0)])
    assert growth.streets and not any(shapely.LineString(s.xy).distance(motorway) < 1.0 for s in growth.streets)
    assert growth.debug["seed_streets"] == 1


def test_a_flow_field_from_primitives_shows_in_the_debug_features():
    city = town([[(-200.0, 0.0), (1700.0, 0.0)]])
    prims = (FlowPrimitive("uniform", strength=1.0, direction_deg=90.0), FlowPrimitive("vortex", 750.0, 600.0))
    growth = grown(city, shapely.box(0.0, 0.0, 1500.0, 1200.0), flow_primitives=prims,
                   pattern=ColonisationPatternOptions(flow_step=2))
    feats = growth.debug["features"]
    check_debug_features(feats)
    layers = [f["properties"]["layer"] for f in feats]
    assert layers.count("flow_primitive") == 2 and layers.count("flow_vector") > 0
    assert set(layers) >= {"attraction_point", "colonisation_region", "colonisation_join", "parameters"}
    params = growth.debug["parameters"]
    assert params["options"]["segment_length"] == SL and params["maps"]["flow"] is True
    shown = next(f for f in feats if f["properties"]["layer"] == "parameters")["properties"]
    assert shown == {"layer": "parameters", **params}


def test_user_maps_read_from_npy_and_pgm_steer_the_growth(tmp_path):
    """A density map (.npy) empty in the east half keeps every AP west; a border map (PGM) bars a band."""
    from osm_expand.rasters import read_raster

    density = np.ones((12, 15))  # 100 m cells over (0, 0)-(1500, 1200), image order (row 0 north)
    density[:, 8:] = 0.0  # x >= 800 m: nobody lives there
    np.save(tmp_path / "density.npy", density)
    (tmp_path / "density.npy.json").write_text(json.dumps({"origin": [0.0, 1200.0], "cell_size": 100.0}))
    band = np.zeros((12, 15), dtype=np.uint8)
    band[5, :] = 255  # image row 5 from the north: y in [600, 700) m is forbidden
    pgm = b"P5 15 12 255\n" + band.tobytes()
    (tmp_path / "border.pgm").write_bytes(pgm)
    (tmp_path / "border.json").write_text(json.dumps({"origin": [0.0, 1200.0], "cell_size": 100.0}))
    from synth.infomaps import Raster

    maps = {k: Raster(*read_raster(tmp_path / f)) for k, f in (("density", "density.npy"), ("border", "border.pgm"))}
    city = town([[(-200.0, 0.0), (1700.0, 0.0)]])
    growth = grown(city, shapely.box(0.0, 0.0, 1500.0, 1200.0), **maps)
    assert growth.debug["density"] == "user" and growth.debug["parameters"]["maps"]["border"] is True
    aps = np.array([f["geometry"]["coordinates"] for f in growth.debug["features"]
                    if f["properties"]["layer"] == "attraction_point"])
    assert len(aps) and (aps[:, 0] < 850.0).all()  # bilinear: zero from the first empty cell's centre on
    assert not ((aps[:, 1] >= 600.0) & (aps[:, 1] < 700.0)).any()
    lines = [shapely.LineString(s.xy) for s in growth.streets]
    assert lines and not any(line.intersects(shapely.box(0.0, 600.0, 1500.0, 700.0)) for line in lines)


def test_the_segment_length_is_the_towns_spacing_and_replaces_the_kernels():
    city = town([[(-200.0, 0.0), (1700.0, 0.0)]])
    growth = grown(city, shapely.box(0.0, 0.0, 1500.0, 1200.0), town=60.0,
                   options=ColonisationOptions(segment_length=999.0))
    assert growth.debug["segment_length_m"] == 60.0
    inner = [np.hypot(*np.diff(s.xy, axis=0).T) for s in growth.streets]
    assert np.median(np.concatenate(inner)) == pytest.approx(60.0, rel=0.1)
    with pytest.raises(InputError, match="segment length"):
        Colonisation(0.0).grow(city, shapely.box(0, 0, 100, 100), np.random.default_rng(0))


def test_the_towns_own_highway_classes():
    kernel = ("secondary", "tertiary", "residential")
    assert town_highways(town([[(0, 0), (1, 0)], [(0, 1), (1, 1)]], ["tertiary", "residential"]), kernel) == (
        "tertiary", "tertiary", "residential")
    assert town_highways(town([[(0, 0), (1, 0)]], ["unclassified"]), kernel) == (
        "unclassified", "unclassified", "residential")
    assert town_highways(town([[(0, 0), (1, 0)], [(0, 1), (1, 1)]], ["secondary", "residential"]), kernel) == (
        "secondary", "residential", "residential")


def test_a_history_configuration_builds_the_pattern_and_refuses_unknown_keys():
    pattern = colonisation_from_config(80.0, {"angle_range_1": [30.0, 45.0], "confined": False,
                                              "flow": [{"kind": "sink", "x": 10.0, "y": 5.0, "strength": 2.0}]})
    assert pattern.options.angle_range_1 == (30.0, 45.0) and not pattern.pattern.confined
    assert pattern.flow_primitives[0].kind == "sink" and pattern.name == "colonisation"
    with pytest.raises(InputError, match="unknown key 'kill'.*valid keys are"):
        colonisation_from_config(80.0, {"kill": 2.0})
    with pytest.raises(InputError, match="segment_length"):
        colonisation_from_config(80.0, {"segment_length": 50.0})
    with pytest.raises(InputError, match="corridor_width"):
        colonisation_from_config(80.0, {"corridor_width": -1.0})
    with pytest.raises(InputError, match="flow primitive key 'angle'"):
        colonisation_from_config(80.0, {"flow": [{"kind": "uniform", "angle": 3.0}]})


# --------------------------------------------------------------------------- real towns


REAL = ["krems.osm.gz", "campo-grande.osm.gz", "andorra.osm.pbf"]


@functools.cache
def town_and_pattern(name: str) -> tuple[City, Colonisation]:
    city = load(FIXTURES / name)
    return city, Colonisation(learn(city).example)


@functools.cache
def expanded(name: str, seed: int = 0):
    city, pattern = town_and_pattern(name)
    return expand(city, ExpandOptions(seed=seed), pattern=pattern)


@pytest.mark.parametrize("name", REAL)
def test_a_colonisation_district_is_joined_to_the_town_at_two_places_at_least(name):
    result = expanded(name)
    assert result.report["pattern"] == "colonisation"
    assert result.joins.joins >= 2 and result.report["grown_streets"] >= 10


@pytest.mark.parametrize("name", REAL)
def test_new_streets_meet_every_street_only_at_shared_nodes(name):
    """No new segment crosses or touches another street's segment except at a node both have."""
    net = expanded(name).city.network
    segs, owner = [], []
    for k, s in enumerate(net.streets):
        segs += list(zip(s.nodes[:-1], s.nodes[1:]))
        owner += [k] * (len(s.nodes) - 1)
    segs, owner = np.array(segs), np.array(owner)
    new = np.array([net.streets[k].is_new for k in owner])
    lines = shapely.linestrings(net.xy[segs])
    left, right = shapely.STRtree(lines).query(lines[new], predicate="intersects")
    left = np.flatnonzero(new)[left]
    bad = [(i, j) for i, j in zip(left.tolist(), right.tolist())
           if i != j and not set(segs[i].tolist()) & set(segs[j].tolist())
           and net.streets[owner[i]].layer_key == net.streets[owner[j]].layer_key]
    assert not bad


@pytest.mark.parametrize("name", REAL)
def test_no_grown_street_in_water_or_on_occupied_ground(name):
    result = expanded(name)
    city, net = result.city, result.city.network
    # colonisation's roads may cross the town's presumed frontage (taken land) to leave its streets
    everything = shapely.box(*np.r_[net.xy.min(axis=0) - 1e3, net.xy.max(axis=0) + 1e3])
    water, occupied = city.water_geometry(), city.occupied_within(everything, taken=False)
    for s in net.streets:
        if s.origin == Origin.GROWN:
            line = shapely.LineString(net.street_xy(s))
            assert not line.intersects(occupied) and (water.is_empty or not line.intersects(water))
        elif s.origin == Origin.JOIN:  # the joining step's own rule: its ends may touch what they join
            a, b = net.street_xy(s)[[0, -1]]
            u = (b - a) / np.hypot(*(b - a))
            assert not shapely.LineString([a + u, b - u]).intersects(occupied)


@pytest.mark.parametrize("name", REAL)
def test_the_district_is_judged_and_written_as_valid_xml(name, tmp_path):
    result = expanded(name)
    assert result.fidelity is not None and result.report["fidelity"]["off"] == result.fidelity.off
    out = tmp_path / "district.xml"
    write_urbanenvironment(result.city, out)
    assert validate(out) == []


@pytest.mark.parametrize("name", REAL)
def test_the_debug_features_are_geojson_ready(name):
    growth = expanded(name).growth
    check_debug_features(growth.debug["features"])
    layers = {f["properties"]["layer"] for f in growth.debug["features"]}
    assert {"attraction_point", "colonisation_region", "colonisation_join", "parameters"} <= layers
    assert growth.debug["density"] == "town" and growth.debug["attraction_points"] > 0


def test_the_same_seed_grows_the_same_streets():
    city, pattern = town_and_pattern("krems.osm.gz")
    again = expand(city, ExpandOptions(seed=0), pattern=pattern)
    first = expanded("krems.osm.gz")
    assert len(first.growth.streets) == len(again.growth.streets)
    for a, b in zip(first.growth.streets, again.growth.streets):
        assert np.array_equal(a.xy, b.xy) and a.highway == b.highway and a.hierarchy == b.hierarchy
    other = expanded("krems.osm.gz", 1)
    assert [s.xy.tolist() for s in other.growth.streets] != [s.xy.tolist() for s in first.growth.streets]


def test_the_districts_blocks_take_lots_and_buildings_from_the_engine():
    """Blocks with a grown street on their edge split into lots, and the lots take buildings off the streets."""
    from osm_expand.blocks import blocks
    from osm_expand.engine.buildout.footprints import place_buildings
    from osm_expand.engine.buildout.lots import block_frontage, subdivide_blocks

    result = expanded("krems.osm.gz")
    net = result.city.network
    new_ids = {net.streets[k].id for k in result.city.new_streets()}
    mine = [b.polygon for b in blocks(net) if new_ids & set(b.street_ids)
            and result.growth.footprint.contains(b.polygon.representative_point())]
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    ids = [s.id for s in net.streets]
    rng = np.random.default_rng(3)
    lots = subdivide_blocks(mine, block_frontage(mine, lines, ids, [8.0] * len(ids)), ["residential_low"] * len(mine),
                            rng=rng)
    made = place_buildings(lots, traffic_per_street={}, built_streets=set(ids), rng=rng,
                           obstacles=[result.city.water_geometry(), *(b.polygon for b in result.city.buildings)])
    # a neighbourhood-sized district (issue 20) has a few blocks; each is split, and nearly every lot built on
    assert len(mine) >= 3 and len(lots) >= 5 * len(mine) and len(made) >= 0.9 * len(lots)
    houses = [fp.rectangle.polygon for fp in made]
    assert not shapely.STRtree(lines).query(houses, predicate="intersects").size


def test_debug_layers_go_into_the_geojson_in_lon_lat(tmp_path, capsys):
    from osm_expand import cli

    out = tmp_path / "krems.geojson"
    assert cli.main([str(FIXTURES / "krems.osm.gz"), "--pattern", "colonisation", "--years", "0",
                     "-o", str(out), "--debug-layers", "-q"]) == 0
    doc = json.loads(out.read_text())
    debug = [f for f in doc["features"] if f["properties"].get("feature") == "debug"]
    layers = {f["properties"]["layer"] for f in debug}
    assert {"attraction_point", "colonisation_region", "parameters"} <= layers
    lon, lat = next(f for f in debug if f["properties"]["layer"] == "attraction_point")["geometry"]["coordinates"]
    assert 15.5 < lon < 15.8 and 48.3 < lat < 48.5  # Krems, not local metres
    assert cli.main([str(FIXTURES / "krems.osm.gz"), "--years", "0", "-o", str(tmp_path / "k.xml"),
                     "--debug-layers"]) == 2
    assert "--debug-layers needs a GeoJSON output" in capsys.readouterr().err
    assert not (tmp_path / "k.xml").exists()
