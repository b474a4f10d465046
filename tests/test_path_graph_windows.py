"""A window's G′ (issue 22's speed work on the windows): its edges and its search matrix are those of
the straightforward construction, on Krems and on made-up towns with a river and a hill."""
from __future__ import annotations

import numpy as np
import test_majorroads
from hypothesis import given, settings
from hypothesis import strategies as st
from test_majorroads import _grid_year, grid_lines, river

from osm_expand.engine.roads import path_graph
from osm_expand.engine.roads.lattice import ROAD_KINDS, EdgeKind, LatticeOptions, Raster, build_lattice
from osm_expand.engine.roads.path_graph import implicit_graph

krems = test_majorroads.krems  # Krems' G′ and its implicit graph (a module fixture)


def _one_sort(lattice, segments, streets, stitch_within, cache, costs):
    """The window's directed edges as G′ made them before the street part's were sorted once a
    year: every part in both directions, one stable sort by (tail, head, weight), of parallel
    edges the first. The reference :func:`path_graph._merged_edges` must equal."""
    n_lat = lattice.n_vertices
    xy = np.concatenate([lattice.vertex_xy(), streets.xy])
    lat_kind, _, bridges = path_graph._lattice_part(lattice, segments, costs, streets.tree)
    used = path_graph.KindMask(lat_kind, path_graph._lattice_key((EdgeKind.LAND, EdgeKind.BRIDGE))).any_per_row()
    targets = np.flatnonzero(used & (lattice.vertex_class == path_graph.VertexClass.LAND))
    points = streets.points
    if stitch_within is not None and len(points):
        px, py = streets.xy[points].T
        points = points[(px >= stitch_within[0]) & (px <= stitch_within[2])
                        & (py >= stitch_within[1]) & (py <= stitch_within[3])]
    pairs = path_graph._lattice_stitches(lattice, segments, streets, xy, targets, points,
                                         path_graph.GraphOptions(), cache)

    def shifted(edges):
        u, v, *rest = edges
        return (u + n_lat, v + n_lat, *rest)

    parts = [bridges, shifted(streets.edges), path_graph._stitch_edges(lattice, pairs, xy), shifted(streets.shell)]
    # every part sorted at once (the merge's reference): the very sort the street part's edges get alone
    src, dst, kind, seg, length, weight, heading = path_graph._sorted_edges(parts, xy)
    return {"src": src, "dst": dst, "kind": kind, "segment": seg, "length": length, "weight": weight,
            "heading": heading}


def _assert_one_sort(implicit, boxes):
    """Each window's edges equal :func:`_one_sort`'s, value and type, with the same stitch cache."""
    for box in boxes:
        window = implicit.window(box)
        g = window.graph
        within = None
        if not window.whole:
            reach = implicit.options.stitch_radius + g.lattice.radius * g.lattice.spacing
            x0, y0 = g.lattice.origin
            x1, y1 = g.lattice.origin + (np.array(g.lattice.shape[::-1]) - 1) * g.lattice.spacing
            ny, nx = implicit.lattice.shape
            (r0, c0), (h, w) = g.lattice.offset, g.lattice.shape
            open_side = (c0 > 0, r0 > 0, c0 + w < nx, r0 + h < ny)
            within = (x0 + reach if open_side[0] else -np.inf, y0 + reach if open_side[1] else -np.inf,
                      x1 - reach if open_side[2] else np.inf, y1 - reach if open_side[3] else np.inf)
        expected = _one_sort(g.lattice, implicit.segments, implicit.streets, within, implicit.stitches,
                             implicit.costs)
        assert (np.diff(g.src) >= 0).all()
        for name, want in expected.items():
            got = getattr(g, name)
            assert got.dtype == want.dtype, name
            assert np.array_equal(got, want), name


def test_krems_windows_hold_the_edges_one_sort_of_all_its_parts_gave(krems):
    """Issue 22: every window of a year holds the same street pieces and shell stitches; they are
    sorted once per street part (:attr:`StreetPart.sorted_edges`) and merged with the window's own
    edges (long bridges, stitches to the lattice), where each window sorted them all again. The
    window's G′ is exactly what that sort gave: the same edges, in the same order, the same of
    parallel ones kept."""
    *_, implicit = krems
    x0, y0, x1, y1 = implicit.lattice.bounds
    w, h = x1 - x0, y1 - y0
    boxes = [(x0 + 0.3 * w, y0 + 0.3 * h, x0 + 0.5 * w, y0 + 0.6 * h), (x0, y0, x0 + 0.6 * w, y0 + 0.5 * h),
             (x0 + 0.1 * w, y0 + 0.4 * h, x1, y1), (x0, y0, x1, y1)]
    _assert_one_sort(implicit, boxes)
    street = implicit.streets.sorted_edges
    assert street is implicit.streets.sorted_edges  # made once
    pieces = len(implicit.streets.edges[0]) + len(implicit.streets.shell[0])
    assert 0 < len(street[0]) <= 2 * pieces


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_made_up_towns_windows_hold_the_edges_one_sort_gave(seed):
    """As on Krems, for a grid town beside a river (long bridges, harbours) in random windows."""
    rng = np.random.default_rng(seed)
    extent = (0, 0, 1200, 1200)
    lat = build_lattice(extent, water=river(extent, 1000, 1060), options=LatticeOptions(radius=2))
    lines = grid_lines(300, 300, int(rng.integers(2, 5)), float(rng.uniform(80.0, 150.0)))
    implicit = implicit_graph(*_grid_year(lat, lines))
    boxes = []
    for _ in range(3):
        a, b = rng.uniform(0, 1200, 2), rng.uniform(0, 1200, 2)
        boxes.append((min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1])))
    _assert_one_sort(implicit, boxes + [extent])


def _csr_both_ways(g, kinds, monkeypatch):
    """``g._csr`` with every block read whole (masked) and with only the live entries read."""
    out = []
    for share in (0.0, 2.0):
        monkeypatch.setattr(path_graph, "_SPARSE_SHARE", share)
        out.append(g._csr(*g.masks(kinds)))
    return out


def _assert_same_csr(a, b):
    (ma, exa, posa), (mb, exb, posb) = a, b
    for name in ("indptr", "indices", "data"):
        assert getattr(ma, name).dtype == getattr(mb, name).dtype
        assert np.array_equal(getattr(ma, name), getattr(mb, name)), name
    assert np.array_equal(exa, exb) and np.array_equal(posa, posb)


def test_krems_search_matrix_is_the_same_read_by_live_entries_or_whole_blocks(krems, monkeypatch):
    """Issue 22: a block of the lattice table few of whose entries are live (a window over the town,
    where B removed the land edges) is read entry by entry, a dense one by masking whole-block
    tables; both give the very same CSR, for every kind of edge asked for, on the map and a window."""
    g, *_, implicit = krems
    x0, y0, x1, y1 = implicit.lattice.bounds
    window = implicit.window((x0, y0, 0.5 * (x0 + x1), y1)).graph
    for graph in (g, window):
        for kinds in (ROAD_KINDS, (EdgeKind.LAND,), (EdgeKind.MAJOR,),
                      (*ROAD_KINDS, EdgeKind.WATER, EdgeKind.HARBOUR)):
            _assert_same_csr(*_csr_both_ways(graph, kinds, monkeypatch))


def test_a_hills_search_matrix_is_the_same_read_by_live_entries_or_whole_blocks(monkeypatch):
    """As on Krems where the lattice's weights are a dense table (a hill: slopes cost more)."""
    extent = (0, 0, 600, 400)
    cell = 10.0
    ny, nx = int(400 / cell), int(600 / cell)
    xs = (np.arange(nx) + 0.5) * cell
    height = Raster(np.broadcast_to(0.05 * np.maximum(xs - 300, 0.0), (ny, nx)).copy(), np.array([0.0, 0.0]), cell)
    lat = build_lattice(extent, height=height, water=river(extent, 300, 340),
                        options=LatticeOptions(radius=2, slope_weight=10.0))
    implicit = implicit_graph(*_grid_year(lat, grid_lines(100, 60, 3, 60.0)))
    g = implicit.window(extent).graph
    assert isinstance(g.lat_weight, np.ndarray)  # a dense table, not worked out from the kinds
    for kinds in (ROAD_KINDS, (*ROAD_KINDS, EdgeKind.WATER, EdgeKind.HARBOUR)):
        _assert_same_csr(*_csr_both_ways(g, kinds, monkeypatch))
