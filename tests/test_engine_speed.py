"""The engine's speed-ups (issue 22) give what the slow ways gave: same segments, same rasters, same bytes."""
from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.joins import _segments_near
from osm_expand.model import network_from_lines

coords = st.floats(0, 200, allow_nan=False)
polylines = st.lists(st.lists(st.tuples(coords, coords), min_size=2, max_size=6), min_size=1, max_size=12)


@settings(max_examples=60, deadline=None)
@given(polylines, st.lists(st.tuples(coords, coords), min_size=1, max_size=5), st.floats(0.5, 30),
       st.integers(0, 12))
def test_segments_near_points_are_every_segment_within_reach(lines, points, reach, count):
    """Every segment of the first ``count`` streets within ``reach`` of a point is among those kept, with
    its street, its place in the street and its ends (the tee insertion's old per-segment loop)."""
    net = network_from_lines(lines)
    count = min(count, len(net.streets))
    pts = np.array(points, dtype=float)
    owner, first, a, b = _segments_near(net, count, pts, reach)
    kept = {(int(k), int(i)) for k, i in zip(owner, first)}
    for k, s in enumerate(net.streets[:count]):
        for i in range(len(s.nodes) - 1):
            seg = shapely.LineString(net.xy[list(s.nodes[i:i + 2])])
            if shapely.dwithin(seg, shapely.points(pts), reach).any():
                assert (k, i) in kept
    for k, i, p, q in zip(owner.tolist(), first.tolist(), a, b):
        nodes = net.streets[k].nodes
        assert np.array_equal(p, net.xy[nodes[i]]) and np.array_equal(q, net.xy[nodes[i + 1]])


def test_a_window_measured_for_some_measures_gives_those_as_measured_for_all():
    """The patterns' windows (:func:`osm_expand.growth_patterns.measure_in_windows`) skip strokes, blocks and
    alignment; what they read is what the full measurement gives, and a skipped measure is refused."""
    import pytest

    from osm_expand.growth_patterns import measure_in_windows
    from osm_expand.measures import LineSet, Measure, measure_network
    from synth.patches import TYPICAL
    from tests.conftest import loaded

    net = loaded("krems.osm.gz")
    lines = [net.street_xy(s) for s in net.streets]
    indexed = LineSet.from_lines(lines)
    in_window = measure_in_windows(lines)
    for centre in net.xy[:: max(len(net.xy) // 5, 1)][:5]:
        window = shapely.Point(centre).buffer(400.0)
        full, quick = measure_network(indexed, window=window), in_window(window)
        for name in (*TYPICAL, "dead_end_share", "two_core_share"):
            assert np.array_equal(np.asarray(full.value(name)), np.asarray(quick.value(name)), equal_nan=True)
        with pytest.raises(ValueError):
            quick.value(Measure.ALIGNMENT)
        assert quick.blocks == -1 and quick.pieces == -1 and full.blocks >= 0


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(0, 10 ** 6), min_size=1, max_size=200, unique=True), st.integers(0, 2))
def test_the_cycles_of_a_permutation_are_the_walks_from_each_least_element(keys, shape):
    """The faces' walk vectorised (:func:`osm_expand.blocks._cycles`): each cycle from its least element,
    the cycles in the order of those, as the walk from every unused element found them."""
    from osm_expand.blocks import _cycles

    m = len(keys)
    order = np.argsort(keys)  # a permutation drawn by hypothesis
    nxt = order.copy()
    if shape == 1:  # one long cycle
        nxt = np.empty(m, dtype=np.int64)
        nxt[order] = np.roll(order, -1)
    elif shape == 2:  # fixed points only
        nxt = np.arange(m)
    walk = nxt.tolist()
    used, sequence, starts = [False] * m, [], []
    for h0 in range(m):
        if not used[h0]:
            starts.append(len(sequence))
            h = h0
            while not used[h]:
                used[h] = True
                sequence.append(h)
                h = walk[h]
    got = _cycles(np.asarray(nxt))
    assert got[0].tolist() == sequence and got[1].tolist() == starts
