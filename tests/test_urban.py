"""The <urbanenvironment> writer: schema, geometry, georeferencing, and reading it back."""
from __future__ import annotations

import numpy as np
import pytest
from lxml import etree
from pyproj import Transformer

from osm_expand.export.urban import validate, write_urbanenvironment
from osm_expand.ingest import load
from osm_expand.model import Building, City, Origin, network_from_lines
from osm_expand.model.geometry import _rectangle_around
from simplify.hierarchy import with_levels
from simplify.invariants import violations
from tests.conftest import FIXTURES, simplified

BOX = Building(rings=(np.array([[0.0, 0.0], [12.0, 0.0], [12.0, 8.0], [0.0, 8.0], [0.0, 0.0]]),), height=9.5,
               origin=Origin.ENGINE, year=2030)
#: A mapped footprint, not a rectangle: the XML gets its minimum rotated rectangle.
L_SHAPE = Building(rings=(np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 5.0], [5.0, 5.0], [5.0, 20.0], [0.0, 20.0],
                                    [0.0, 0.0]]) + 500.0,), height=None, levels=3, osm_id=77)


def _write(tmp_path, name="krems.osm.gz", file="town.xml"):
    net = with_levels(simplified(name).network)
    out = tmp_path / file
    write_urbanenvironment(City(network=net, buildings=(BOX, L_SHAPE)), out)
    return net, out


def test_output_validates_against_the_shipped_schema(tmp_path):
    _, out = _write(tmp_path)
    assert validate(out) == []
    root = etree.parse(str(out)).getroot()
    assert root.tag == "urbanenvironment" and [c.tag for c in root] == ["streets", "buildings"]
    box, mapped = root.findall("buildings/building")
    assert box.get("height") == "9.50" and len(box.findall("node")) == 4
    assert box.get("origin") == "engine" and box.get("year") == "2030"
    assert mapped.get("origin") == "source" and mapped.get("osm_id") == "77"


def test_a_mapped_footprint_becomes_its_minimum_rectangle(tmp_path):
    _, out = _write(tmp_path)
    mapped = etree.parse(str(out)).getroot().findall("buildings/building")[1]
    pts = np.array([[float(n.get("x")), float(n.get("y"))] for n in mapped.findall("node")])
    sides = np.roll(pts, -1, axis=0) - pts
    assert sorted(np.round(np.hypot(*sides.T), 3)) == [20.0, 20.0, 20.0, 20.0]
    assert float(mapped.get("height")) == pytest.approx(6.0)  # no height tag: the writer's fallback


def test_a_building_with_three_corners_is_rejected(tmp_path):
    _, out = _write(tmp_path)
    doc = etree.parse(str(out))
    nodes = doc.getroot().find("buildings/building").findall("node")
    nodes[0].getparent().remove(nodes[0])
    doc.write(str(tmp_path / "bad.xml"))
    assert validate(tmp_path / "bad.xml")


def test_segments_are_the_streets_shapes_and_never_cross(tmp_path):
    net, out = _write(tmp_path)
    streets = etree.parse(str(out)).getroot().find("streets")
    segs = [[(float(s.get("x1")), float(s.get("y1"))), (float(s.get("x2")), float(s.get("y2")))]
            for st in streets for s in st]
    assert len(segs) == sum(len(s.nodes) - 1 for s in net.streets)
    attrs = [{"layer": int(st.get("layer")), "bridge": st.get("bridge") == "yes", "tunnel": st.get("tunnel") == "yes"}
             for st in streets for _ in st]
    assert not violations(network_from_lines(segs, attrs))["crossings_without_junction"]
    assert {st.get("origin") for st in streets} == {"source"}
    assert all(st.get("hierarchy") is not None for st in streets)


def test_coordinates_can_be_georeferenced_again(tmp_path):
    net, out = _write(tmp_path, "monaco.osm.gz")
    root = etree.parse(str(out)).getroot()
    back = Transformer.from_crs(root.get("projection"), "EPSG:4326", always_xy=True)
    seg = root.find("streets/street/segment")
    lon, lat = back.transform(float(seg.get("x1")), float(seg.get("y1")))
    first = net.streets[0].nodes[0]
    lon0, lat0 = net.context.projection.to_lonlat(net.xy[first, 0], net.xy[first, 1])
    assert lon == pytest.approx(float(lon0), abs=1e-7) and lat == pytest.approx(float(lat0), abs=1e-7)
    assert float(root.get("lon0")) == pytest.approx(7.42, abs=0.02)


def test_the_xml_reads_back_as_the_same_streets_and_buildings(tmp_path):
    net, out = _write(tmp_path)
    back = load(out)
    assert len(back.network.streets) == len(net.streets)
    assert [s.highway for s in back.network.streets] == [s.highway for s in net.streets]
    assert np.allclose(back.network.total_length(), net.total_length(), rtol=1e-6)
    assert [b.origin for b in back.buildings] == [Origin.ENGINE, Origin.SOURCE]
    assert back.projection.lon0 == pytest.approx(net.context.projection.lon0, abs=1e-7)


def test_same_network_same_bytes(tmp_path):
    _, a = _write(tmp_path, file="a.xml")
    _, b = _write(tmp_path, file="b.xml")
    assert a.read_bytes() == b.read_bytes()


def _rectangle_with_np_unique(ring):
    """:func:`minimum_rectangle` as it was (main def3a8e): ``np.unique(axis=0)`` and a MultiPoint's hull."""
    import shapely

    pts = np.unique(np.asarray(ring, dtype=float).reshape(-1, 2), axis=0)
    if len(pts) < 3:
        return None
    hull = np.asarray(shapely.MultiPoint(pts).convex_hull.exterior.coords)
    return _rectangle_around(hull)  # the part that did not change


def test_the_rectangles_of_krems_are_those_np_unique_gave():
    """Issue 22: the footprint's distinct corners are sorted without ``np.unique(axis=0)`` (the writer's
    rectangles 0.15 -> 0.08 s on Krems); every one of Krems' 1,195 rectangles is the same to the bit."""
    from osm_expand.model.geometry import minimum_rectangle

    buildings = load(FIXTURES / "krems.osm.gz").buildings
    assert len(buildings) > 1000
    for b in buildings:
        got, want = minimum_rectangle(b.ring), _rectangle_with_np_unique(b.ring)
        assert (got is None and want is None) or got.tobytes() == want.tobytes()


def test_a_footprint_with_no_area_has_no_rectangle():
    """Fewer than three distinct corners, or all on one line (def3a8e raised AttributeError there): None."""
    from osm_expand.model.geometry import minimum_rectangle

    for ring in ([(0.0, 0.0), (5.0, 0.0), (0.0, 0.0)], [(0.0, 0.0), (2.0, 1.0), (4.0, 2.0), (0.0, 0.0)],
                 [(1.0, 1.0)] * 4):
        assert minimum_rectangle(np.array(ring)) is None
    assert minimum_rectangle(np.array([(0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (0.0, 0.0)])) is not None


def test_the_rectangles_made_in_one_batch_are_those_made_one_by_one():
    """Issue 22: the writer makes all minimum rectangles in one batch (one GEOS call for the hulls); every
    one of Krems' rectangles is the one :func:`minimum_rectangle` made as it was, to the bit, and a footprint with
    no area (fewer than three distinct corners, all on one line, none) has none, wherever it stands."""
    from osm_expand.model.geometry import minimum_rectangles

    rings = [b.ring for b in load(FIXTURES / "krems.osm.gz").buildings]
    flat = [np.array(r, dtype=float).reshape(-1, 2) for r in
            ([(0.0, 0.0), (5.0, 0.0), (0.0, 0.0)], [(0.0, 0.0), (2.0, 1.0), (4.0, 2.0), (0.0, 0.0)],
             [(1.0, 1.0)] * 4, [])]
    mixed = [flat[0], *rings[:50], flat[1], flat[2], *rings[50:], flat[3]]
    got = minimum_rectangles(mixed)
    assert len(got) == len(mixed)
    degenerate = {0, 51, 52, len(mixed) - 1}  # the flat ones (the old code raised on a line's hull)
    for k, (ring, rect) in enumerate(zip(mixed, got)):
        want = None if k in degenerate else _rectangle_with_np_unique(ring)
        assert (rect is None and want is None) or (rect is not None and want is not None
                                                   and rect.tobytes() == want.tobytes())
    assert [got[0], got[51], got[52], got[-1]] == [None] * 4
    assert minimum_rectangles([]) == []


def test_outlines_and_coordinates_formatted_at_once_are_each_corner_as_formatted_alone():
    """The writer formats all corners of all lots or blocks at once (:func:`_outlines`): the same nodes, in
    the same order, with the same text as each polygon's ring formatted corner by corner; a polygon with
    a hole gives its outer ring only and an empty one no node."""
    import shapely

    from osm_expand.export.urban import _formatted, _outlines

    rng = np.random.default_rng(3)
    square = shapely.Polygon([(0, 0), (10.0004, 0), (10, 10), (0, 10.1235)], holes=[[(2, 2), (3, 2), (3, 3)]])
    polys = [square, shapely.Polygon(), *(shapely.Point(rng.uniform(-5e4, 5e4, 2)).buffer(rng.uniform(1, 50), 3)
                                          for _ in range(20))]
    attrs = [{"id": str(k)} for k in range(len(polys))]
    for poly, el in zip(polys, _outlines("lot", attrs, polys), strict=True):
        corners = [] if poly.is_empty else np.asarray(poly.exterior.coords)[:-1]
        assert [(n.get("x"), n.get("y")) for n in el] == [(f"{x:.3f}", f"{y:.3f}") for x, y in corners]
    values = rng.uniform(-1e5, 1e5, (50, 2))
    assert _formatted(values) == [f"{v:.3f}" for v in values.ravel()]  # each numpy scalar alone


def test_xml_attrs_replace_only_what_xml_cannot_hold():
    """:func:`osm_expand.export.features.xml_attrs`: a clean dict comes back equal (a new dict, one search of
    all its text), a key or value with a character XML forbids has it replaced by U+FFFD."""
    from osm_expand.export.features import xml_attrs

    clean = {"name": "Obere Landstraße", "highway": "residential", "year": "2031"}
    out = xml_attrs(clean)
    assert out == clean and out is not clean
    assert xml_attrs({"na\x01me": "a\x02b", "ok": "\U0001F600"}) == {"na\ufffdme": "a\ufffdb", "ok": "\U0001F600"}
    assert xml_attrs({}) == {}
