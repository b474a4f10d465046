"""Property tests: any set of lines comes out of simplification satisfying the invariants."""
from __future__ import annotations

import numpy as np
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from osm_expand.model import network_from_lines
from simplify import simplify
from simplify.crossings import add_missing_intersections
from simplify.intersections import extract_intersections
from simplify.invariants import violations
from simplify.options import SimplifyOptions
from simplify.overlaps import remove_overlaps

coord = st.integers(min_value=0, max_value=60).map(lambda v: v * 10.0)  # a 600 m box, 10 m lattice
point = st.tuples(coord, coord)
polyline = st.lists(point, min_size=2, max_size=6)
street_attrs = st.fixed_dictionaries({
    "highway": st.sampled_from(["primary", "residential", "tertiary"]),
    "layer": st.sampled_from([0, 0, 0, 1]),
    "name": st.sampled_from([None, "A", "B"]),
})
line_sets = st.lists(st.tuples(polyline, street_attrs), min_size=1, max_size=25)

# 100 examples by default; HYPOTHESIS_PROFILE=thorough runs 2000 (see conftest.py)
SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(line_sets)
def test_simplify_always_satisfies_the_invariants(items):
    net = network_from_lines([p for p, _ in items], [a for _, a in items])
    result = simplify(net)
    assert violations(result.network) == dict.fromkeys(violations(result.network), 0)
    # nothing is invented: every node of the output lies on an input street or within the largest
    # distance a pass may move it (a roundabout's centre: 40 m; a fused cluster's: 10 m discs chained)
    out = result.network
    if out.streets:
        before = shapely.union_all([shapely.LineString(net.street_xy(s)) for s in net.streets])
        used = out.xy[out.used_nodes()]
        assert shapely.distance(before, shapely.points(used)).max() <= 50.0


@SETTINGS
@given(line_sets)
def test_noding_leaves_no_unshared_crossing(items):
    """After noding, what still touches is an exact duplicate, which the overlap pass removes."""
    net = extract_intersections(network_from_lines([p for p, _ in items], [a for _, a in items]))
    noded, _ = add_missing_intersections(net, SimplifyOptions())
    # noding moves no street (a street folding back over itself loses the fold)
    assert noded.total_length() <= net.total_length() + 0.5
    before = shapely.union_all([shapely.LineString(net.street_xy(s)) for s in net.streets]).buffer(0.1)
    assert all(before.contains(shapely.LineString(noded.street_xy(s))) for s in noded.streets)
    cleaned, _ = remove_overlaps(noded, SimplifyOptions(overlap_tolerance=1e-6))
    assert violations(cleaned)["crossings_without_junction"] == 0


@SETTINGS
@given(line_sets)
def test_simplification_is_deterministic(items):
    lines, attrs = [p for p, _ in items], [a for _, a in items]
    a = simplify(network_from_lines(lines, attrs))
    b = simplify(network_from_lines(lines, attrs))
    assert a.network.streets == b.network.streets and a.report == b.report
    assert (a.network.xy == b.network.xy).all()


@given(st.lists(st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)), min_size=2, max_size=40),
       st.floats(0.1, 50.0))
def test_thinning_keeps_the_ends_and_spaces_the_rest(points, step):
    from osm_expand.model.topology import spaced_points

    pts = np.asarray(points, dtype=float)
    out = pts[spaced_points(pts, step)]
    assert np.array_equal(out[0], pts[0]) and np.array_equal(out[-1], pts[-1])
    inner = out[1:-1]
    if len(inner):
        gaps = np.hypot(*np.diff(out, axis=0).T)
        assert (gaps >= step).all()
    rows = {tuple(p) for p in pts.tolist()}
    assert all(tuple(p) in rows for p in out.tolist())


@SETTINGS
@given(st.lists(st.lists(st.integers(min_value=0, max_value=12), min_size=0, max_size=7), max_size=12),
       st.integers(min_value=0, max_value=15))
def test_segment_degree_counts_each_segment_end(runs, n_nodes):
    """:func:`~osm_expand.model.topology.segment_degree` (three counts of one flat array, issue 22) is the
    count of segment ends at each node, segment by segment, for any streets: one-node streets, repeated
    and ringed nodes, nodes past ``n_nodes`` (the count then runs to the largest node that ends a segment)."""
    from osm_expand.model import Street
    from osm_expand.model.topology import segment_degree

    streets = [Street(nodes=tuple(r), highway="residential", id=k) for k, r in enumerate(runs)]
    ends = [n for r in runs for n in (*r[:-1], *r[1:])]
    expected = np.bincount(np.asarray(ends, dtype=np.int64), minlength=n_nodes)
    got = segment_degree(streets, n_nodes)
    assert got.dtype == expected.dtype and np.array_equal(got, expected)
