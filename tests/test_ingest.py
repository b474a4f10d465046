"""Ingest on the real extracts: streets, context, projection, clipped ways."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.ingest import _number, load
from osm_expand.model.highways import DRIVABLE, highway_set, rank
from tests.conftest import ALL, FIXTURES, loaded


@pytest.mark.parametrize("name", ALL)
def test_every_fixture_loads_streets_in_metres(name):
    net = loaded(name, service=True)
    assert net.streets and len(net.xy) == len(net.node_ids)
    assert np.isfinite(net.xy).all()
    x0, y0, x1, y1 = net.context.bounds_xy
    # the data lies around its bounds (ways crossing the edge keep their outside nodes)
    mx, my = np.median(net.xy, axis=0)
    assert x0 <= mx <= x1 and y0 <= my <= y1
    assert all(s.highway in highway_set(service=True) for s in net.streets)


def test_default_set_is_drivable_only():
    net = loaded("krems.osm.gz")
    assert {s.highway for s in net.streets} <= DRIVABLE
    assert "service" in {s.highway for s in loaded("krems.osm.gz", service=True).streets}


def test_clipped_ways_are_split_and_counted():
    net = loaded("campo-grande.osm.gz")
    assert net.stats["clipped_ways"] > 100
    # ways with fewer than two nodes left are dropped, the rest keep their known nodes only
    assert len(net.streets) < net.stats["input_ways"]
    assert all(len(s.nodes) >= 2 for s in net.streets)


def test_missing_bounds_are_computed_from_the_data():
    net = loaded("monaco.osm.gz")
    assert not net.context.bounds_from_header
    lon0, lat0, lon1, lat1 = net.context.bounds_lonlat
    assert 7.40 < lon0 < lon1 < 7.45 and 43.72 < lat0 < lat1 < 43.76
    assert loaded("krems.osm.gz").context.bounds_from_header


def test_projection_round_trips_to_a_millimetre():
    net = loaded("andorra.osm.pbf")
    proj = net.context.projection
    lon, lat = proj.to_lonlat(net.xy[:, 0], net.xy[:, 1])
    x, y = proj.to_xy(lon, lat)
    assert np.abs(np.column_stack([x, y]) - net.xy).max() < 1e-3
    assert "+proj=tmerc" in proj.proj_string


def test_distances_are_metres():
    # Krems: the old town's extract spans a few kilometres, not degrees
    x0, y0, x1, y1 = loaded("krems.osm.gz").context.bounds_xy
    assert 1_000 < x1 - x0 < 20_000 and 1_000 < y1 - y0 < 20_000


def test_street_attributes_are_kept():
    net = loaded("monaco.osm.gz")
    tunnels = [s for s in net.streets if s.tunnel]
    assert tunnels and any(s.layer < 0 for s in tunnels)
    assert any(s.bridge for s in net.streets)
    assert any(s.name == "Boulevard Charles III" for s in net.streets)
    assert any(s.junction == "roundabout" for s in net.streets)


def test_context_water_sea_and_buildings():
    krems = load(FIXTURES / "krems.osm.gz")
    assert krems.water and len(krems.buildings) > 1000
    # the Danube's riverbank multipolygon lacks an inner member in the extract: its outer ring is kept
    assert max(w.area for w in krems.water) > 5e6
    monaco = load(FIXTURES / "monaco.osm.gz")
    assert monaco.sea, "coastline must close into sea"
    # Monaco's harbour (Port Hercule) is sea; the Palace on the Rock is land
    import shapely
    proj = monaco.projection
    sea = shapely.union_all(list(monaco.sea))
    harbour = shapely.Point(*[v[0] for v in proj.to_xy(np.array([7.4235]), np.array([43.7350]))])
    palace = shapely.Point(*[v[0] for v in proj.to_xy(np.array([7.4202]), np.array([43.7314]))])
    assert sea.contains(harbour) and not sea.contains(palace)
    heights = [b.height for b in load(FIXTURES / "berlin-siegessaeule.osm.gz").buildings if b.height]
    assert heights and all(h > 0 for h in heights)


def _monaco_on_land(city) -> None:
    """The town is land and the open sea south-east of it is sea (the harbour too)."""
    import shapely

    sea = shapely.union_all(list(city.sea))
    lines = shapely.MultiLineString([city.network.street_xy(s) for s in city.network.streets])
    assert lines.intersection(sea).length < 0.01 * lines.length
    buildings = shapely.union_all([b.polygon for b in city.buildings])
    assert buildings.intersection(sea).area < 0.01 * buildings.area
    proj = city.projection
    for lon, lat in ((7.4235, 43.7350), (7.45, 43.72)):  # Port Hercule, offshore
        assert sea.contains(shapely.Point(*[v[0] for v in proj.to_xy(np.array([lon]), np.array([lat]))]))


def test_a_clip_reaching_past_the_coastline_keeps_the_town_on_land(tmp_path):
    """``--around`` a coastal town clips a box wider than the data: the coastline ends inside it
    (issue 21, point 2: the whole box was sea, and the run refused as "too little town")."""
    from osm_expand.clip import box_around, clip

    extract = clip(FIXTURES / "monaco.osm.gz", {"town": box_around(7.4246, 43.7384, 3000)}, tmp_path)["town"]
    _monaco_on_land(load(extract))


def test_bounds_equal_to_the_nodes_extent_keep_the_town_on_land(tmp_path):
    """A ``<bounds>`` drawn exactly around the nodes: the coastline ends on the box's edge."""
    import gzip
    import re

    import osmium

    src = FIXTURES / "monaco.osm.gz"
    ll = np.array([(n.location.lon, n.location.lat) for n in osmium.FileProcessor(str(src), osmium.osm.NODE)])
    with gzip.open(src, "rt", encoding="utf-8") as fh:
        text = re.sub(r"<bounds[^>]*/>", "", fh.read())
    at = text.index(">", text.index("<osm")) + 1
    (lon0, lat0), (lon1, lat1) = ll.min(axis=0), ll.max(axis=0)
    bounds = f'<bounds minlat="{lat0:.7f}" minlon="{lon0:.7f}" maxlat="{lat1:.7f}" maxlon="{lon1:.7f}"/>'
    path = tmp_path / "monaco.osm"
    path.write_text(text[:at] + bounds + text[at:], encoding="utf-8")
    city = load(path)
    assert city.context.bounds_from_header
    _monaco_on_land(city)


def test_a_coastal_clip_runs_through_the_main_command(tmp_path):
    from osm_expand import cli

    out = tmp_path / "m.xml"
    assert cli.main([str(FIXTURES / "monaco.osm.gz"), "--years", "0", "--around", "7.4246,43.7384",
                     "--radius", "3000", "-o", str(out), "-q"]) == 0
    assert out.stat().st_size > 0


def test_unsorted_file_falls_back_to_closed_way_areas():
    city = load(FIXTURES / "circle-bug.osm.gz", service=True)
    assert len(city.buildings) > 0


@pytest.mark.parametrize("text,value", [("12", 12.0), ("12.5 m", 12.5), ("3,5", 3.5), ("40'", 12.192),
                                        ("2;3", 2.0), ("tall", None), (None, None), ("", None)])
def test_numeric_tags(text, value):
    got = _number(text)
    assert (got is None and value is None) or got == pytest.approx(value)


def test_rank_orders_classes():
    assert rank("motorway") < rank("motorway_link") < rank("trunk") < rank("residential") < rank("service")


@settings(deadline=None)
@given(st.floats(0.0, 2 * np.pi), st.floats(0.2, 1.0), st.floats(-0.3, 0.3), st.booleans())
def test_an_open_coastline_divides_the_box_with_land_on_its_left(angle, reach, offset, on_edge):
    """A straight coast across a 1 km box, entering from outside and ending inside it (``reach`` of the
    way across) or exactly on its edge: land on the left, sea on the right, along its whole line."""
    import shapely

    from osm_expand.coastline import assemble_sea

    box = shapely.box(0.0, 0.0, 1000.0, 1000.0)
    d = np.array([np.cos(angle), np.sin(angle)])
    left = np.array([-d[1], d[0]])
    centre = np.array([500.0, 500.0]) + offset * 400.0 * left
    # where the line leaves the box going forward: the coast ends there (on_edge) or short of it
    exit_t = min(((1000.0 if di > 0 else 0.0) - ci) / di for di, ci in zip(d, centre) if abs(di) > 1e-9)
    end_t = exit_t if on_edge else reach * exit_t
    coast = np.array([centre - 2000.0 * d, centre + end_t * d])
    sea = shapely.union_all(list(assemble_sea([coast], box)))
    for t in np.linspace(-400.0, 0.0, 5):
        p = centre + t * d
        if not box.contains(shapely.Point(p + 30 * left)) or not box.contains(shapely.Point(p - 30 * left)):
            continue
        assert not sea.contains(shapely.Point(p + 30 * left))
        assert sea.contains(shapely.Point(p - 30 * left))


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz"])
def test_rings_projected_together_are_those_projected_one_by_one(name):
    """:func:`osm_expand.ingest._project_each` projects every ring in one call: each comes back with the very
    numbers a call of its own gives (PROJ projects point by point), so the buildings' rings are unchanged."""
    from osm_expand.ingest import _project, _project_each

    city = load(FIXTURES / name)
    proj = city.projection
    rings = [np.column_stack(proj.to_lonlat(*r.T)) for b in city.buildings[:300] for r in b.rings]
    rings.insert(3, np.empty((0, 2)))  # an empty sequence keeps its place
    together = _project_each(rings, proj)
    assert len(together) == len(rings)
    for ring, xy in zip(rings, together):
        alone = _project(ring, proj)
        assert xy.shape == alone.shape and xy.tobytes() == alone.tobytes()
    assert _project_each([], proj) == []
