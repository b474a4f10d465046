"""joins.within_reach: the engine skips the join of a district no town street is near; the skip must
give the join's own answer (no place to join)."""
from __future__ import annotations

import functools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.ingest import load
from osm_expand.joins import join_growth, within_reach
from osm_expand.pipeline import prepare
from synth.growth import NewStreet
from tests.conftest import FIXTURES

SPACING = 80.0


@functools.cache
def krems():
    return prepare(load(FIXTURES / "krems.osm.gz"))


def _grid(x0: float, y0: float, size: float = 240.0) -> list[NewStreet]:
    """A small district: a square with a cross in it, lower-left corner at (x0, y0)."""
    a, b, m = 0.0, size, size / 2
    shapes = [[(a, a), (b, a), (b, b), (a, b), (a, a)], [(m, a), (m, b)], [(a, m), (b, m)]]
    return [NewStreet(xy=np.array(s) + (x0, y0)) for s in shapes]


@settings(max_examples=12, deadline=None)
@given(st.floats(-0.6, 1.4), st.floats(-0.6, 1.4))
def test_a_district_out_of_reach_finds_no_join(fx, fy):
    """Districts from inside the town to well beyond it: wherever ``within_reach`` says no, the join
    itself finds no place; a district on the town's streets is within reach."""
    city = krems()
    x0, y0, x1, y1 = city.bounds_xy
    streets = _grid(x0 + fx * (x1 - x0), y0 + fy * (y1 - y0))
    near = within_reach(city, [s.xy for s in streets], spacing=SPACING)
    _, joins = join_growth(city, streets, spacing=SPACING)
    if not near:
        assert len(joins.at) == 0
    if len(joins.at):
        assert near


def test_a_district_on_the_town_is_within_reach_and_one_far_off_is_not():
    city = krems()
    xy = city.network.xy[list(city.network.streets[0].nodes)]
    assert within_reach(city, [s.xy for s in _grid(*xy[0])], spacing=SPACING)
    x0, y0, x1, y1 = city.bounds_xy
    far = _grid(x1 + 10 * SPACING, y1 + 10 * SPACING)
    assert not within_reach(city, [s.xy for s in far], spacing=SPACING)
    assert len(join_growth(city, far, spacing=SPACING)[1].at) == 0
    assert not within_reach(city, [], spacing=SPACING)
