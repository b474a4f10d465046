"""The example patches' street density in a disc (:func:`synth.patches.source._density`): clipping only
the streets that cross the disc's edge gives the sum that clipping every street gave, to the bit."""
from __future__ import annotations

import functools

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.patches.source import _density, _length_in, _source
from tests.test_patches import district


@functools.lru_cache(maxsize=1)
def _krems_source():
    grown = district("krems.osm.gz", 0)
    return _source(grown.city, grown.learned.example, everything=True)


def _every_street_clipped(source, disc) -> float:
    """The sum as it was made before: every street whose box meets the disc's, clipped to the disc."""
    return float(shapely.length(shapely.intersection(source.lines[source.tree.query(disc)], disc)).sum())


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.floats(30.0, 900.0))
def test_the_length_in_a_disc_is_the_length_of_every_street_clipped_to_it(at, radius):
    source = _krems_source()
    xy = shapely.get_coordinates(source.lines)
    disc = shapely.buffer(shapely.Point(xy[at % len(xy)]), radius)
    assert _length_in(source, disc) == _every_street_clipped(source, disc)


def test_a_disc_holding_whole_streets_and_cut_ones_counts_both():
    source = _krems_source()
    centre = shapely.get_coordinates(source.lines).mean(axis=0)
    disc = shapely.buffer(shapely.Point(centre), 500.0)
    inside = shapely.contains_properly(disc, source.lines).sum()
    crossing = shapely.crosses(disc, source.lines).sum()
    assert inside > 10 and crossing > 3  # both ways of counting are taken
    got = _density(source, centre[None, :], 500.0)[0]
    assert got == _every_street_clipped(source, shapely.buffer(shapely.Point(centre), 500.0)) / (np.pi * 500.0 ** 2)
