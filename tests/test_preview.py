"""The preview draws new streets by when they grew: the district, then each era, named in a legend."""
from __future__ import annotations

import numpy as np
import pytest

from osm_expand.errors import InputError
from osm_expand.export.preview import STAGE_COLOURS, growth_stages, picture_frame, write_preview
from osm_expand.ingest import load
from osm_expand.model import Building, City, Origin, network_from_lines
from tests.conftest import FIXTURES, expanded_and_matured

TOWN = {"origin": Origin.SOURCE}
DISTRICT = {"origin": Origin.GROWN, "hierarchy": 4}
JOIN = {"origin": Origin.JOIN}
#: Era names whose alphabetical order is the reverse of the history's: the order must come from the years.
LATE = {"origin": Origin.ENGINE, "era": "a-late", "year": 2051, "hierarchy": 2}
EARLY = {"origin": Origin.ENGINE, "era": "z-early", "year": 2031, "hierarchy": 7}
EARLY_ROAD = {**EARLY, "highway": "secondary", "year": 2035}


def small_city() -> City:
    """A town street, a district of two streets joined to it, and two eras of the engine."""
    lines = [[(0, 0), (400, 0)], [(400, 0), (400, 100)], [(400, 100), (500, 100)], [(500, 100), (500, 200)],
             [(0, 0), (0, 300)], [(0, 300), (200, 300)], [(200, 300), (200, 500)], [(500, 200), (600, 400)]]
    attrs = [TOWN, JOIN, DISTRICT, DISTRICT, EARLY, EARLY_ROAD, LATE, LATE]
    box = Building(rings=(np.array([[10.0, 10.0], [30.0, 10.0], [30.0, 25.0], [10.0, 25.0], [10.0, 10.0]]),),
                   height=9.0, origin=Origin.ENGINE, year=2040, land_use="residential_low")
    return City(network=network_from_lines([np.asarray(ln, dtype=float) for ln in lines], attrs), buildings=(box,))


def test_the_stages_are_the_district_then_the_eras_in_the_order_they_grew():
    stages = growth_stages(small_city().network.streets)
    assert [label for label, _ in stages] == ["district", "z-early (2031–2035)", "a-late (2051)"]
    assert [len(streets) for _, streets in stages] == [2, 2, 2]
    assert all(s.origin == Origin.ENGINE and s.era == "z-early" for s in stages[1][1])


def test_a_town_without_new_streets_has_no_stage():
    assert growth_stages([s for s in small_city().network.streets if s.origin == Origin.SOURCE]) == []


@pytest.mark.parametrize("color_by", ["origin", "landuse", "year"])
def test_the_legend_names_the_district_and_each_era_not_the_hierarchy(tmp_path, color_by):
    out = tmp_path / "map.svg"
    write_preview(small_city(), out, color_by=color_by)
    svg = out.read_text(encoding="utf-8")  # matplotlib writes each text as a comment beside its glyphs
    for label in ("district", "z-early (2031–2035)", "a-late (2051)", "joining streets"):
        assert f"<!-- {label} -->" in svg
    assert "Gravelius" not in svg
    assert STAGE_COLOURS[0] in svg and STAGE_COLOURS[1] in svg and STAGE_COLOURS[2] in svg
    if color_by == "landuse":  # the buildings' legend is kept beside the streets'
        assert "<!-- land use -->" in svg and "<!-- residential low -->" in svg


def test_the_same_city_draws_the_same_png_bytes(tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    write_preview(small_city(), a)
    write_preview(small_city(), b)
    assert a.read_bytes() == b.read_bytes() and a.stat().st_size > 5_000


def test_krems_default_run_draws_its_district_and_both_eras(tmp_path):
    """The README's first command: the legend names the district and each era the default history grew."""
    result = expanded_and_matured(load(FIXTURES / "krems.osm.gz"), seed=0)
    eras = {s.era for s in result.city.network.streets if s.origin == Origin.ENGINE}
    assert eras == {"contemporary", "consolidation"}
    out = tmp_path / "krems.svg"
    write_preview(result.city, out, result.site.region)
    svg = out.read_text(encoding="utf-8")
    labels = [label for label, _ in growth_stages(result.city.network.streets)]
    assert labels[0] == "district" and [label.split(" ")[0] for label in labels[1:]] == ["contemporary",
                                                                                        "consolidation"]
    assert all(f"<!-- {label} -->" in svg for label in labels)
    town_frame(result)


def town_frame(result) -> None:
    """Krems' town frame: every new street and the site inside it, the countryside's roads cut.

    Krems' extract is 9.6 × 6.4 km round a town of about 4 × 1.3 km: drawn whole, the district is a
    scribble; the town frame holds the old town, the centre and what grew in under half the area.
    """
    city, region = result.city, result.site.region
    x0, y0, x1, y1 = picture_frame(city, region)
    a0, b0, a1, b1 = picture_frame(city, region, "all")
    assert a0 <= x0 < x1 <= a1 and b0 <= y0 < y1 <= b1
    assert (x1 - x0) * (y1 - y0) < 0.5 * (a1 - a0) * (b1 - b0)
    net = city.network
    new = np.vstack([net.street_xy(net.streets[k]) for k in city.new_streets()])
    inside = (new[:, 0] > x0) & (new[:, 0] < x1) & (new[:, 1] > y0) & (new[:, 1] < y1)
    assert inside.all()
    rx0, ry0, rx1, ry1 = region.bounds
    assert x0 < rx0 and rx1 < x1 and y0 < ry0 and ry1 < y1
    old_town = net.xy[[n for s in net.streets if s.origin == Origin.SOURCE and s.name == "Untere Landstraße"
                       for n in s.nodes]]  # the old town's main street, at the town's west end
    assert len(old_town) and ((old_town[:, 0] > x0) & (old_town[:, 0] < x1)).all()


def test_the_frame_is_the_whole_map_when_the_town_cannot_be_told():
    """Fewer junctions than a neighbourhood has: no town to frame, the whole map (and an unknown frame refused)."""
    city = small_city()
    assert picture_frame(city, frame="town") == picture_frame(city, frame="all")
    with pytest.raises(InputError, match="frame"):
        picture_frame(city, frame="county")
