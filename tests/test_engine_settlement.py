"""The engine's districts grow at the town's own edge (issue 20): the far bank of a river is seen from the town's
own settlement (built-up land less than 200 m apart merged, the piece with the most area:
:func:`osm_expand.sites.settlement`, :func:`osm_expand.sites.settlement_maps`), not from a village on it."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import shapely

from osm_expand.engine.growth.minor_streets import GrowthOptions
from osm_expand.errors import OptionError
from osm_expand.growth_fidelity import before_the_years, is_major_road
from osm_expand.ingest import load
from osm_expand.model import Origin
from osm_expand.sites import SETTLEMENT_GAP, DistanceMaps, SiteOptions, distance_maps, settlement, settlement_maps
from tests.conftest import FIXTURES, expanded_and_matured

#: Krems' old town (its centre nucleus) and the village of Mautern across the Danube (m, the fixture's projection)
KREMS_OLD_TOWN = (-593.0, 696.0)
MAUTERN = (-2007.0, -1222.0)


def _cell(maps: DistanceMaps, xy) -> tuple[int, int]:
    col, row = ((np.asarray(xy) - maps.origin) // maps.cell).astype(int)
    return row, col


@functools.cache
def _krems_run():
    return expanded_and_matured(load(FIXTURES / "krems.osm.gz"), seed=0)


def test_krems_settlement_is_the_town_north_of_the_danube_not_mautern():
    city = before_the_years(_krems_run().city)
    maps = distance_maps(city, SiteOptions(cell=40.0), margin=1000.0)
    town = settlement(maps)
    assert town[_cell(maps, KREMS_OLD_TOWN)]
    row, col = _cell(maps, MAUTERN)
    assert maps.city[row - 1:row + 2, col - 1:col + 2].any()  # Mautern is built-up land ...
    assert not town[row - 1:row + 2, col - 1:col + 2].any()  # ... but not Krems'
    assert 0.8 < town.sum() / maps.city.sum() < 1.0  # most of the built-up land, not all


@pytest.mark.parametrize("gap, one", [(150.0, True), (190.0, True), (260.0, False), (400.0, False)])
def test_built_up_land_less_than_the_gap_apart_is_one_settlement(gap, one):
    """Two squares of built-up land ``gap`` m apart, the larger one the town: the smaller is its part only
    when nearer than :data:`SETTLEMENT_GAP`; the town's closeness then measures to the town alone."""
    cell = 10.0
    city = np.zeros((60, 200), dtype=bool)
    city[10:50, 10:60] = True  # the town, 40 x 50 cells
    left = 60 + int(gap / cell)
    city[20:40, left:left + 20] = True  # a hamlet, 20 x 20 cells
    zeros = np.zeros(city.shape)
    maps = DistanceMaps(origin=np.zeros(2), cell=cell, water=np.zeros_like(city), city=city,
                        outside=np.zeros_like(city), unbuildable=np.zeros_like(city), water_distance=zeros,
                        city_distance=zeros, free_radius=zeros, nearest_city=np.zeros((2, *city.shape), dtype=np.int32),
                        corridor=np.zeros_like(city))
    town = settlement(maps)
    assert town[30, 30] and town[30, left + 5] == one
    far_bank = settlement_maps(maps)
    only = settlement_maps(maps, only=True)
    if one:
        assert far_bank is maps and only is maps
        return
    # by default only the far bank is seen from the town: the nearest town cell of a cell by the hamlet
    row, col = far_bank.nearest_city[:, 30, left + 25]
    assert town[row, col] and far_bank.city_distance is maps.city_distance and far_bank.settlement is None
    # with ``only`` the closeness and contact count the town alone; the hamlet is still taken land
    assert only.settlement is not None and only.city is maps.city
    assert only.city_distance[30, left + 5] == pytest.approx(cell * (left + 5 - 59), abs=cell)


def test_krems_engine_districts_touch_krems_own_settlement():
    """Krems, default history, seed 0 (default options): every piece of the engine's street growth (its streets
    buffered 30 m, merged) reaches the town's settlement; on main 88bd933 the run's second quarter grew beside Mautern,
    across the Danube, a piece 300 m and more from Krems' built-up land."""
    run = _krems_run().city
    maps = distance_maps(before_the_years(run), SiteOptions(cell=20.0), margin=1500.0)
    town = settlement(maps)
    net = run.network
    grown = [net.street_xy(s) for s in net.streets if s.origin == Origin.ENGINE and not is_major_road(s)]
    assert grown
    lines = np.array([shapely.LineString(x) for x in grown], dtype=object)
    pieces = shapely.get_parts(shapely.union_all(shapely.buffer(lines, 30.0)))
    rows, cols = np.nonzero(town)
    cells = shapely.points(maps.origin + (np.column_stack([cols, rows]) + 0.5) * maps.cell)
    gaps = [float(shapely.distance(piece, shapely.multipoints(cells))) for piece in pieces]
    assert max(gaps) <= 2 * maps.cell, gaps


@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_the_settlement_gap_refuses_a_negative_or_not_finite_distance(value):
    with pytest.raises(OptionError):
        GrowthOptions(settlement_gap=value)


def test_the_settlement_gap_is_the_eeas_200_m_by_default():
    assert GrowthOptions().settlement_gap == SETTLEMENT_GAP == 200.0


def test_settlement_only_is_off_by_default():
    assert GrowthOptions().settlement_only is False
