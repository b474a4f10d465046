"""One lot type (issue 23): the lot a block is split into is the lot the city holds and the exporters write."""
from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given
from hypothesis import strategies as st

from osm_expand.engine.buildout import lots
from osm_expand.engine.buildout.year import LotState
from osm_expand.model import Lot
from osm_expand.model.city import DEFAULT_LOT_LAND_USE
from osm_expand.model.geometry import ring_area, ring_edge_lengths

SQUARE = np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 30.0], [0.0, 30.0]])


def test_the_build_out_splits_blocks_into_the_models_lots():
    assert lots.Lot is Lot and LotState.__dataclass_fields__["lot"].type == "Lot"
    block = shapely.Polygon(SQUARE * 3)
    split = lots.subdivide(block, [lots.Frontage(np.array([[-4.0, -4.0], [64.0, -4.0]]), 7, 8.0)],
                           rng=np.random.default_rng(0), block_index=2)
    assert split and all(isinstance(lot, Lot) and lot.block == 2 and lot.street == -1 for lot in split)
    assert DEFAULT_LOT_LAND_USE == lots.LandUse.RESIDENTIAL_LOW.value


def test_a_placed_lot_keeps_its_shape_and_the_polygon_already_made():
    lot = Lot(ring=SQUARE, edge_street=np.array([4, -1, -1, 4]))
    polygon = lot.polygon
    placed = lot.placed(block=9, street=4, land_use="commercial", people=12.5, id=3, year=2031)
    assert placed.polygon is polygon and placed.area == lot.area == 600.0
    assert (placed.block, placed.street, placed.land_use, placed.people, placed.id, placed.year) == (
        9, 4, "commercial", 12.5, 3, 2031)
    assert placed.frontage_length(4) == 50.0 and placed.streets.tolist() == [4]


@given(st.lists(st.tuples(st.floats(-500, 500), st.floats(-500, 500)), min_size=3, max_size=30))
def test_the_shoelace_area_and_edge_lengths_are_shapelys(points):
    hull = shapely.MultiPoint(points).convex_hull
    if hull.geom_type != "Polygon" or hull.area < 1e-3:
        return
    ring = np.asarray(shapely.geometry.polygon.orient(hull, 1.0).exterior.coords)[:-1]
    assert np.isclose(ring_area(ring), hull.area, rtol=1e-9, atol=1e-6)
    assert np.isclose(ring_area(ring[::-1]), -hull.area, rtol=1e-9, atol=1e-6)
    assert np.isclose(ring_edge_lengths(ring).sum(), hull.length, rtol=1e-9)
