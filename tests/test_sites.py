"""Distance maps and the expansion site."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.blocks import blocks
from osm_expand.ingest import load
from osm_expand.model import network_from_lines
from osm_expand.sites import SiteOptions, built_area, choose_site, distance_maps
from simplify import simplify
from tests.conftest import FIXTURES


def town(size=3, step=100.0):
    span = [i * step for i in range(size + 1)]
    lines = [[(x, y) for x in span] for y in span] + [[(x, y) for y in span] for x in span]
    net = network_from_lines(lines)
    return net, blocks(net)


def test_free_radius_is_the_exact_distance_to_the_town():
    net, bl = town()
    maps = distance_maps(net, bl, margin=1000.0, opts=SiteOptions(cell=10.0, street_buffer=0.0))
    xs, ys = maps.centres()
    # a cell 500 m east of the town's east edge (x = 300) has 500 m of free radius, to a cell
    j = np.argmin(np.abs(xs[0] - 805.0))
    i = np.argmin(np.abs(ys[:, 0] - 155.0))
    assert maps.free_radius[i, j] == pytest.approx(505.0, abs=maps.cell)
    assert maps.city_distance[i, j] == pytest.approx(maps.free_radius[i, j])


def test_the_site_touches_the_town_and_keeps_out_of_it():
    net, bl = town()
    maps = distance_maps(net, bl, margin=1000.0)
    site = choose_site(maps, area=90_000.0)
    city = shapely.union_all(bl)
    assert site is not None and site.region.intersection(city).area == 0
    assert site.region.distance(city) <= SiteOptions().street_buffer + 2 * maps.cell


@pytest.mark.parametrize("direction,check", [("N", lambda c: c[1] > 300), ("S", lambda c: c[1] < 0),
                                             ("E", lambda c: c[0] > 300), ("W", lambda c: c[0] < 0)])
def test_a_direction_puts_the_site_on_that_side(direction, check):
    net, bl = town()
    site = choose_site(distance_maps(net, bl, margin=1000.0), area=90_000.0, direction=direction)
    assert check(site.centre)


def test_a_given_point_is_used_and_no_room_gives_none():
    net, bl = town()
    maps = distance_maps(net, bl, margin=200.0)
    assert np.allclose(choose_site(maps, 10_000.0, at=(1000.0, 50.0)).centre, (1000.0, 50.0))
    assert choose_site(maps, 10_000_000.0) is None  # a 10 km² disc does not fit in the margin


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz"])
def test_town_sites_stay_dry_and_off_the_blocks(name):
    raw = load(FIXTURES / name)
    net = simplify(raw).network.replace(context=raw.context)
    bl = blocks(net)
    opts = SiteOptions()
    area = opts.area_share * built_area(net, bl, opts).area
    maps = distance_maps(net, bl, margin=2 * np.sqrt(area / np.pi), opts=opts)
    site = choose_site(maps, area, opts)
    water = shapely.union_all(list(raw.context.water) + list(raw.context.sea))
    assert site.region.intersection(shapely.union_all(bl)).area == 0
    assert site.region.intersection(water).area < 0.01 * area  # raster cells may graze the shore
    assert site.region.area == pytest.approx(area, rel=0.01)
