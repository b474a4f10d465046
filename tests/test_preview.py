"""The preview draws new streets by when they grew: the district, then each era, named in a legend."""
from __future__ import annotations

import numpy as np
import pytest

from osm_expand.export.preview import STAGE_COLOURS, growth_stages, write_preview
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
