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


def _resample_any_by_points(raster, origin, step, shape):
    """The lattice's fine raster as it was made point by point (the reference for :func:`_resample_any`)."""
    out = np.zeros(shape, dtype=bool)
    xs, ys = np.meshgrid(origin[0] + np.arange(shape[1]) * step, origin[1] + np.arange(shape[0]) * step)
    row, col, inside = raster.cell_index(xs, ys)
    out |= np.asarray(raster.values, dtype=bool)[row, col] & inside
    r, c = np.nonzero(np.asarray(raster.values, dtype=bool))
    fj = np.rint((raster.origin[0] + (c + 0.5) * raster.cell - origin[0]) / step).astype(np.int64)
    fi = np.rint((raster.origin[1] + (r + 0.5) * raster.cell - origin[1]) / step).astype(np.int64)
    ok = (fi >= 0) & (fi < shape[0]) & (fj >= 0) & (fj < shape[1])
    out[fi[ok], fj[ok]] = True
    return out


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_lattices_fine_raster_made_by_rows_and_columns_is_the_one_made_point_by_point(seed):
    """:func:`~osm_expand.engine.roads.lattice._resample_any` reads the cell under each fine point and the
    fine point nearest each true cell's centre by rows and columns (the synthetic 10,000-street town's
    presumed frontage: 9.5 million true cells, 0.6 GB of indices point by point): the same bools, for
    any cell size against the fine step, either raster partly off the other."""
    from osm_expand.engine.roads.lattice import Raster, _resample_any

    rng = np.random.default_rng(seed)
    values = rng.random((int(rng.integers(1, 40)), int(rng.integers(1, 40)))) < rng.random()
    raster = Raster(values, (float(rng.uniform(-50, 50)), float(rng.uniform(-50, 50))),
                    float(rng.choice([2.5, 3.0, 5.0, 7.3, 10.0, 20.0, 31.0])))
    origin = rng.uniform(-60, 60, 2)
    step = float(rng.choice([2.5, 5.0, 7.0, 10.0]))
    shape = (int(rng.integers(1, 60)), int(rng.integers(1, 60)))
    assert np.array_equal(_resample_any(raster, origin, step, shape),
                          _resample_any_by_points(raster, origin, step, shape))


def _profiles_sample_by_sample(d, pw, pf, pad, shape, f):
    """The unit edges' profile codes counted at every vertex (the reference for :func:`_profiles`)."""
    from osm_expand.engine.roads import lattice as L

    offsets = L._offsets(d, f)
    m = len(offsets) - 1
    any_forbidden = np.zeros(shape, dtype=bool)
    n_water = np.zeros(shape, dtype=np.int16)
    changes = np.zeros(shape, dtype=np.int16)
    prev_w = first_w = None
    for oy, ox in offsets:
        w = L._slice(pw, pad, oy, ox, shape, f)
        any_forbidden |= L._slice(pf, pad, oy, ox, shape, f)
        n_water += w
        if prev_w is None:
            first_w = w
        else:
            changes += w != prev_w
        prev_w = w
    profile = np.full(shape, L._MIXED, dtype=np.uint8)
    ok = ~any_forbidden
    profile[ok & (n_water == 0)] = L._L
    profile[ok & (n_water == m + 1)] = L._W
    profile[ok & (changes == 1) & ~first_w] = L._LW
    profile[ok & (changes == 1) & first_w] = L._WL
    profile[ok & (changes == 2) & ~first_w & ~prev_w] = L._LWL
    ny, nx = shape
    iy, ix = np.mgrid[0:ny, 0:nx]
    profile[(ix + d[0] < 0) | (ix + d[0] >= nx) | (iy + d[1] < 0) | (iy + d[1] >= ny)] = L._MIXED
    return profile


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_edges_marched_only_where_there_is_water_have_the_profiles_counted_everywhere(seed):
    """:func:`~osm_expand.engine.roads.lattice._profiles` reads only whether an edge samples water or
    forbidden ground at every vertex and marches the wet edges alone (two thirds of the synthetic
    town's 11 s lattice went to counting at every vertex): every direction's profile codes are the
    ones counted sample by sample, on rivers, ponds and forbidden blobs with the map's edge near."""
    from osm_expand.engine.roads import lattice as L

    rng = np.random.default_rng(seed)
    f, radius = int(rng.integers(1, 4)), int(rng.integers(1, 6))
    ny, nx = int(rng.integers(2, 25)), int(rng.integers(2, 25))
    fine = ((ny - 1) * f + 1, (nx - 1) * f + 1)
    water = rng.random(fine) < rng.uniform(0, 0.3)
    water[:, int(rng.integers(0, fine[1])):][:, :int(rng.integers(0, 6))] = True  # a river
    forbidden = rng.random(fine) < rng.uniform(0, 0.1)
    pad = radius * f
    pw, pf = np.pad(water, pad, constant_values=False), np.pad(forbidden, pad, constant_values=True)
    pc = np.pad(L._codes(water, forbidden), pad, constant_values=2)
    for d in L.lattice_directions(radius):
        profile, slope = L._profiles(d, pc, None, pad, (ny, nx), f, 20.0)
        assert slope is None
        assert np.array_equal(profile, _profiles_sample_by_sample(d, pw, pf, pad, (ny, nx), f))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_windows_directed_kinds_cut_from_the_maps_unit_edges_are_its_own_unit_edges_from_both_ends(seed):
    """:func:`~osm_expand.engine.roads.lattice._window_directed` cuts a window's ``(V, D)`` directed kinds
    from the map's live unit edges ``(D/2, V_map)`` (the map's directed table, twice their size, is gone):
    they are :func:`~osm_expand.engine.roads.lattice._directed` of the window's own unit edges, the edges
    with an end outside it left out; and the map's bridge and harbour entries read direction by direction
    (:func:`~osm_expand.engine.roads.lattice._map_special`) are those of its directed table."""
    from osm_expand.engine.roads import lattice as L

    rng = np.random.default_rng(seed)
    radius = int(rng.integers(1, 5))
    directions = L.lattice_directions(radius)
    half = len(directions) // 2
    map_ny, map_nx = int(rng.integers(1, 30)), int(rng.integers(1, 30))
    live = rng.choice(np.array([0, 1, 2, 3, L.NO_EDGE], dtype=np.uint8), size=(half, map_ny * map_nx))
    iy, ix = np.divmod(np.arange(map_ny * map_nx), map_nx)
    for k, (dx, dy) in enumerate(directions[:half].tolist()):  # the map's edges end on the map
        live[k, (ix + dx < 0) | (ix + dx >= map_nx) | (iy + dy >= map_ny)] = L.NO_EDGE
    r0, c0 = int(rng.integers(0, map_ny)), int(rng.integers(0, map_nx))
    ny, nx = int(rng.integers(1, map_ny - r0 + 1)), int(rng.integers(1, map_nx - c0 + 1))
    got = L._window_directed(live, (map_ny, map_nx), (r0, c0), (ny, nx), directions)
    own = live.reshape(half, map_ny, map_nx)[:, r0:r0 + ny, c0:c0 + nx].copy()
    wy, wx = np.divmod(np.arange(ny * nx), nx)
    own = own.reshape(half, ny * nx)
    for k, (dx, dy) in enumerate(directions[:half].tolist()):
        own[k, (wx + dx < 0) | (wx + dx >= nx) | (wy + dy >= ny)] = L.NO_EDGE
    expected, _ = L._directed(own, None, directions, (ny, nx))
    assert np.array_equal(got, expected)

    class Map:  # what _map_special reads of a lattice
        pass
    lat = Map()
    lat.map_units, lat.directions, lat.full_shape = (live, None), directions, (map_ny, map_nx)
    whole, _ = L._directed(live, None, directions, (map_ny, map_nx))
    special = np.flatnonzero(np.isin(whole, [L.EdgeKind.BRIDGE, L.EdgeKind.HARBOUR]))
    assert np.array_equal(L._map_special(lat), special)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_b_rasterised_tile_by_tile_covers_the_points_it_covers_point_by_point(seed):
    """:func:`~osm_expand.engine.roads.lattice._rasterise` takes a tile of points wholly inside B or
    outside it at once and tests only the tiles across its boundary (the synthetic town's first B
    tested 9 million points one by one): the same points, for blobs with holes, thin slivers, points
    on the boundary, the ground already covered and the boxes of what was added."""
    from osm_expand.engine.roads.lattice import _rasterise

    rng = np.random.default_rng(seed)
    step = float(rng.choice([1.0, 2.5, 10.0]))
    shape = (int(rng.integers(1, 90)), int(rng.integers(1, 90)))
    origin = rng.uniform(-20, 20, 2)
    parts = [shapely.Point(rng.uniform(-20, 120, 2)).buffer(float(rng.uniform(1, 60)),
                                                            quad_segs=int(rng.integers(1, 8)))
             for _ in range(int(rng.integers(1, 5)))]
    parts.append(shapely.box(*(origin + 5 * step), *(origin + [30 * step, 5 * step + 1e-3])))  # a sliver
    parts.append(shapely.box(*origin, *(origin + 8 * step)))  # points on its boundary
    geom = shapely.union_all(parts)
    if rng.random() < 0.5:
        geom = geom.difference(shapely.Point(rng.uniform(0, 100, 2)).buffer(float(rng.uniform(5, 30))))
    known = rng.random(shape) < 0.05 if rng.random() < 0.5 else None
    within = np.array([p.bounds for p in parts[:2]]) if rng.random() < 0.5 else None
    got = _rasterise(geom, origin, step, shape, known=known, within=within)
    expected = np.zeros(shape, dtype=bool) if known is None else known.copy()
    iy, ix = np.mgrid[0:shape[0], 0:shape[1]]
    test = ~expected
    if within is not None:
        near = np.zeros(shape, dtype=bool)
        for x0, y0, x1, y1 in within:
            near |= ((ix >= np.floor((x0 - origin[0]) / step)) & (ix <= np.ceil((x1 - origin[0]) / step))
                     & (iy >= np.floor((y0 - origin[1]) / step)) & (iy <= np.ceil((y1 - origin[1]) / step)))
        test &= near
    expected[test] = shapely.intersects_xy(geom, origin[0] + ix[test] * step, origin[1] + iy[test] * step)
    assert np.array_equal(got, expected)
