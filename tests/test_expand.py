"""The whole expansion on real towns: where the district goes, how it joins, what the exports keep."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import shapely

from osm_expand.blocks import blocks
from osm_expand.export.osm import write_osm
from osm_expand.ingest import load
from osm_expand.joins import MAX_BRIDGE
from osm_expand.pipeline import ExpandOptions, expand
from simplify import simplify
from tests.conftest import FIXTURES

TOWNS = ["krems.osm.gz", "monaco.osm.gz", "north-bayreuth.osm.gz", "andorra.osm.pbf", "campo-grande.osm.gz"]


@functools.cache
def expanded(name: str):
    raw = load(FIXTURES / name)
    return raw, expand(raw, ExpandOptions(seed=0))


def _grown_lines(result):
    net = result.network
    return [(s, shapely.LineString(net.street_xy(s))) for s, o in zip(net.streets, result.origins) if o == "grown"]


@pytest.mark.parametrize("name", TOWNS)
def test_the_district_is_joined_to_the_town_by_at_least_two_streets(name):
    _, result = expanded(name)
    assert result.report["connections"] >= 2


@pytest.mark.parametrize("name", TOWNS)
def test_the_district_has_the_area_asked_for(name):
    _, result = expanded(name)
    assert result.report["district_area_m2"] == pytest.approx(result.site.area, rel=0.20)


@pytest.mark.parametrize("name", TOWNS)
def test_the_district_keeps_off_the_old_blocks_and_out_of_the_water(name):
    raw, result = expanded(name)
    old = [s for s, o in zip(result.network.streets, result.origins) if o == "source"]
    town_blocks = shapely.union_all([b.buffer(-1.0) for b in blocks(result.network.replace(streets=tuple(old)))])
    water = shapely.union_all([*raw.context.water, *raw.context.sea])
    for street, line in _grown_lines(result):
        assert not line.intersects(town_blocks)
        wet = line.intersection(water).length if not water.is_empty else 0.0
        assert wet == 0.0 or (street.bridge and wet <= MAX_BRIDGE + 10.0)  # + the 5 m kept at each end


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz", "campo-grande.osm.gz"])
def test_the_osm_output_reads_back_to_the_same_junctions(name, tmp_path):
    _, result = expanded(name)
    write_osm(result.network, tmp_path / "out.osm")
    back = load(tmp_path / "out.osm")
    before = simplify(result.network).report["junctions"]
    after = simplify(back).report["junctions"]
    assert abs(after - before) <= 0.01 * before
    assert len(back.streets) == len(result.network.streets)


@pytest.mark.parametrize("name", TOWNS)
def test_old_and_new_streets_meet_only_at_junctions(name):
    from simplify.invariants import violations

    _, result = expanded(name)
    assert violations(result.network)["crossings_without_junction"] == 0


@pytest.mark.parametrize("name", TOWNS)
def test_no_segment_is_shorter_than_a_shape_step(name):
    """Shorter ones would collapse at OSM's 7 decimals, or at the referee's 6."""
    _, result = expanded(name)
    for street, line in _grown_lines(result):
        steps = np.hypot(*np.diff(np.asarray(line.coords), axis=0).T)
        assert steps.min() >= 0.5, (street.hierarchy, steps.min())
