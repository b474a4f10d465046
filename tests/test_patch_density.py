"""The example patches' street density in discs (:func:`synth.patches.source._density`): clipping only
the streets that cross a disc's edge, all discs at once, gives each disc the sum that clipping every street
to it alone gave, to the bit (a street that crosses itself is clipped as before)."""
from __future__ import annotations

import functools

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.patches.source import _density, _lengths_in, _Source, _source
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
    assert _lengths_in(source, [disc])[0] == _every_street_clipped(source, disc)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 10_000), st.floats(30.0, 900.0)), min_size=0, max_size=12))
def test_many_discs_at_once_give_each_disc_its_own_sum(discs):
    """The discs are queried and clipped together: each still gets, to the bit, the sum it got alone
    (overlapping discs, discs holding nothing, repeated discs)."""
    source = _krems_source()
    xy = shapely.get_coordinates(source.lines)
    made = [shapely.buffer(shapely.Point(xy[at % len(xy)]), radius) for at, radius in discs]
    made.append(shapely.buffer(shapely.Point(xy.min(axis=0) - 5_000.0), 50.0))  # far from every street
    got = _lengths_in(source, made)
    assert got.tolist() == [_every_street_clipped(source, d) for d in made]


def test_a_disc_holding_whole_streets_and_cut_ones_counts_both():
    source = _krems_source()
    centre = shapely.get_coordinates(source.lines).mean(axis=0)
    disc = shapely.buffer(shapely.Point(centre), 500.0)
    inside = shapely.contains_properly(disc, source.lines).sum()
    crossing = shapely.crosses(disc, source.lines).sum()
    assert inside > 10 and crossing > 3  # both ways of counting are taken
    got = _density(source, centre[None, :], 500.0)[0]
    assert got == _every_street_clipped(source, shapely.buffer(shapely.Point(centre), 500.0)) / (np.pi * 500.0 ** 2)


def test_a_street_that_crosses_or_runs_over_itself_is_clipped_as_before():
    """GEOS splits a non-simple line at its crossings and merges a doubled-back part: the sum of a
    clipped loop is not its own length, so only simple streets take the shortcut."""
    loop = shapely.LineString([(0, 0), (100, 100), (100, 0), (0, 100), (37.3, 11.9)])  # crosses itself
    doubled = shapely.LineString([(-200, -200), (-100, -200), (-150, -200), (-150, -150)])  # runs back over itself
    straight = shapely.LineString([(300, 0), (300, 480)])  # crosses the disc's edge
    lines = np.array([loop, doubled, straight], dtype=object)
    source = _Source(lines=lines, highway=("residential",) * 3, level=np.zeros(3, int),
                     tree=shapely.STRtree(lines))
    disc = shapely.buffer(shapely.Point(0, 0), 400.0)
    assert not shapely.is_simple(doubled) and shapely.length(shapely.intersection(doubled, disc)) < doubled.length
    assert _lengths_in(source, [disc])[0] == _every_street_clipped(source, disc)
