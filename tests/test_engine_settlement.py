"""The engine's districts grow at the town's own edge (issue 20): the far bank of a river is seen from the town's
own settlement (built-up land less than 200 m apart merged, the piece with the most area:
:func:`osm_expand.sites.settlement`, :func:`osm_expand.sites.settlement_maps`), not from a village on it."""
from __future__ import annotations

import functools

import numpy as np
import pytest
import shapely
from scipy.ndimage import distance_transform_edt

from osm_expand.engine.growth.minor_streets import GrowthOptions
from osm_expand.errors import OptionError
from osm_expand.growth_fidelity import before_the_years, is_major_road
from osm_expand.ingest import load
from osm_expand.model import Origin
from osm_expand.sites import (
    SETTLEMENT_GAP,
    DistanceMaps,
    SiteOptions,
    _across_water,
    distance_maps,
    far_bank,
    settlement,
    settlement_maps,
)
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
    if one:  # the town is all the built-up land: only the far bank is set (no water: none)
        assert far_bank.nearest_city is maps.nearest_city and far_bank.city_distance is maps.city_distance
        assert far_bank.far_bank is not None and not far_bank.far_bank.any()
        return
    # only the far bank is seen from the town: the nearest town cell of a cell by the hamlet; the site's
    # closeness still measures to all the built-up land
    row, col = far_bank.nearest_city[:, 30, left + 25]
    assert town[row, col] and far_bank.city_distance is maps.city_distance


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


def _maps(city: np.ndarray, water: np.ndarray, cell: float = 10.0) -> DistanceMaps:
    """Distance maps of a synthetic raster: ``city`` and ``water`` bool, rows = y."""
    cells, nearest = distance_transform_edt(~city, return_indices=True)
    zeros = np.zeros(city.shape)
    return DistanceMaps(origin=np.zeros(2), cell=cell, water=water, city=city, outside=np.zeros_like(city),
                        unbuildable=np.zeros_like(city), water_distance=zeros, city_distance=cells * cell,
                        free_radius=zeros, nearest_city=nearest.astype(np.int32), corridor=np.zeros_like(city))


#: A river across the whole raster (rows 48-52) and a cell just south of it whose nearest town cell lies north of it
RIVER = slice(48, 53)
SOUTH_BANK_CELL = (46, 75)


@pytest.mark.parametrize("town_on_both_banks", [True, False])
def test_a_river_is_a_divide_only_when_the_town_lies_on_one_bank(town_on_both_banks):
    """A river the town lies on both sides of is no divide (Andorra la Vella on the Gran Valira, a stream through
    north-bayreuth): a cell on the south bank whose straight way to its nearest town cell crosses the river stays
    next to the town when the town holds land on the south bank too; with the town on the north bank alone (Krems
    on the Danube), the whole south bank is the far bank. On the old code (the straight line) the cell was across
    water in both cases."""
    water = np.zeros((100, 200), dtype=bool)
    water[RIVER] = True
    city = np.zeros_like(water)
    city[55:90, 20:80] = True  # the town north of the river
    if town_on_both_banks:
        city[10:46, 20:60] = True  # ... and its quarter south of it, 30 m across the river (one settlement)
    maps = settlement_maps(_maps(city, water))
    row, col = SOUTH_BANK_CELL
    ni, nj = maps.nearest_city[:, row, col]
    assert ni > RIVER.stop  # the nearest town cell is across the river
    score = np.zeros(water.shape)
    score[row, col] = 1.0  # the best cell: the straight line's test checks it
    across = _across_water(maps, score)
    assert across[row, col] == (0.0 if town_on_both_banks else 1.0)
    assert (across[:RIVER.start] == across[row, col]).all()  # the whole south bank alike
    assert not across[RIVER.stop:].any()  # the town's own bank never


def test_the_far_bank_is_land_water_cuts_off_from_the_town():
    """Land joined to the town's around the end of a lake is not across water, however the straight line runs;
    an island is; water itself is not the far bank."""
    water = np.zeros((60, 60), dtype=bool)
    water[20:40, 0:50] = True  # a lake open at its east end
    water[45:55, 5:15] = True
    water[47:53, 7:13] = False  # an island in a pond
    town = np.zeros_like(water)
    town[45:60, 20:40] = True
    far = far_bank(water, town)
    assert not far[:20].any()  # north of the lake: joined round its east end
    assert far[47:53, 7:13].all()  # the island
    assert not far[water].any()


@pytest.mark.parametrize("name", ["krems.osm.gz", "andorra.osm.pbf"])
def test_the_far_bank_on_the_fixtures(name):
    """Krems: Mautern's bank of the Danube is the far bank, the town's own bank is not; Andorra: the Gran Valira,
    which Andorra la Vella lies on both sides of, divides nothing (the straight line to the nearest town cell
    crossed it)."""
    from osm_expand.pipeline import prepare

    city = prepare(load(FIXTURES / name))
    maps = settlement_maps(distance_maps(city, SiteOptions(cell=20.0), margin=1500.0))
    assert maps.far_bank is not None
    if name.startswith("krems"):
        assert maps.far_bank[_cell(maps, MAUTERN)] and not maps.far_bank[_cell(maps, KREMS_OLD_TOWN)]
        assert 0.2 < maps.far_bank[~maps.water].mean() < 0.6
    else:  # at most a few cells of islands, none within 2 km of the town (31 cells, 6.5 km from it)
        assert maps.water.any() and maps.far_bank.mean() < 1e-4
        near = distance_transform_edt(~settlement(maps)) * maps.cell < 2000.0
        assert not (maps.far_bank & near).any()
