"""Blocks by wall following: faces of the street graph, valid and disjoint."""
from __future__ import annotations

import pytest
import shapely

from osm_expand.blocks import blocks, faces
from osm_expand.model import network_from_lines
from tests.conftest import simplified


def grid(n=3, step=100.0, origin=(0.0, 0.0)):
    x0, y0 = origin
    span = [i * step for i in range(n)]
    lines = [[(x0 + x, y0 + y) for x in span] for y in span]
    lines += [[(x0 + x, y0 + y) for y in span] for x in span]
    return lines


def test_a_grid_has_its_squares_as_blocks_and_one_outer_face():
    net = network_from_lines(grid())
    rings = faces(net)
    assert len(rings) == 5  # four squares and the outside
    found = blocks(net)
    assert sorted(round(b.polygon.area) for b in found) == [10000] * 4


def test_curved_streets_keep_their_shape_in_the_block():
    # a square whose top street bulges 30 m: the block follows the bulge
    lines = [[(0, 0), (100, 0)], [(100, 0), (100, 100)], [(100, 100), (50, 130), (0, 100)], [(0, 100), (0, 0)]]
    (block,) = blocks(network_from_lines(lines))
    assert block.polygon.area == pytest.approx(10000 + 100 * 30 / 2)


def test_a_separate_network_inside_a_block_becomes_a_hole():
    outer = grid(2, 1000.0)
    inner = grid(2, 100.0, origin=(400.0, 400.0))
    found = [b.polygon for b in blocks(network_from_lines(outer + inner))]
    areas = sorted(round(p.area) for p in found)
    assert areas == [10000, 1_000_000 - 10000]
    assert sum(p.area for p in found) == pytest.approx(shapely.union_all(found).area)


@pytest.mark.parametrize("name", ["krems.osm.gz", "campo-grande.osm.gz", "monaco.osm.gz", "andorra.osm.pbf",
                                  "north-bayreuth.osm.gz"])
def test_town_blocks_are_valid_and_disjoint(name):
    net = simplified(name).network
    found = [b.polygon for b in blocks(net)]
    assert len(found) > 50
    assert all(p.is_valid and p.area >= 100 for p in found)
    assert sum(p.area for p in found) == pytest.approx(shapely.union_all(found).area, rel=1e-6)


def test_each_edge_of_a_block_knows_its_street():
    lines = [[(0, 0), (100, 0)], [(100, 0), (100, 100)], [(100, 100), (50, 130), (0, 100)], [(0, 100), (0, 0)]]
    net = network_from_lines(lines)
    (block,) = blocks(net)
    ring = block.polygon.exterior.coords
    assert len(block.street_ids) == len(ring) - 1
    for (a, b), k in zip(zip(ring[:-1], ring[1:]), block.street_ids):
        street = next(s for s in net.streets if s.id == k)
        assert shapely.LineString(net.street_xy(street)).buffer(1e-6).covers(shapely.LineString([a, b]))


def test_dead_ends_of_the_town_as_mapped_bound_no_block():
    """A cul-de-sac inside a block (the town as mapped, not simplified) leaves the block whole."""
    square = [[(0.0, 0.0), (100.0, 0.0), (100.0, 20.0), (100.0, 100.0)], [(100.0, 100.0), (0.0, 100.0)],
              [(0.0, 100.0), (0.0, 50.0), (0.0, 0.0)]]
    culs = [[(0.0, 50.0), (40.0, 50.0)], [(100.0, 20.0), (60.0, 20.0), (60.0, 40.0)], [(60.0, 20.0), (70.0, 10.0)]]
    (block,) = blocks(network_from_lines(square + culs))
    assert block.polygon.area == pytest.approx(10000.0)


@pytest.mark.parametrize("name", ["krems.osm.gz", "north-bayreuth.osm.gz"])
def test_blocks_of_the_town_as_mapped_are_valid_disjoint_and_cover_the_simplified_ones(name):
    from tests.conftest import loaded

    real = [b.polygon for b in blocks(loaded(name))]
    assert len(real) > 50 and all(p.is_valid for p in real)
    union = shapely.union_all(real)
    assert sum(p.area for p in real) == pytest.approx(union.area, rel=1e-6)
    simple = shapely.union_all([b.polygon for b in blocks(simplified(name).network)])
    assert union.intersection(simple).area >= 0.8 * simple.area


def _same_blocks(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.polygon.equals_exact(y.polygon, 0.0) and x.street_ids == y.street_ids


def test_a_face_memo_gives_the_blocks_of_a_fresh_run_while_the_network_grows_and_shrinks():
    from osm_expand.blocks import FaceMemo

    outer = grid(2, 1000.0)
    inner = grid(2, 100.0, origin=(400.0, 400.0))
    # crosses the inner square without a junction: overlapping faces
    bridge = [[(0.0, 0.0), (450.0, 430.0), (1000.0, 1000.0)]]
    steps = [grid(4), grid(4) + grid(2, 50.0, origin=(300.0, 300.0)), outer + inner, outer + inner + bridge,
             outer + inner, grid(4)]
    memo = FaceMemo()
    counts = []
    for lines in steps:
        net = network_from_lines(lines)
        found = blocks(net, memo=memo)
        _same_blocks(found, blocks(net))
        counts.append(len(found))
    assert counts[3] != counts[2]  # the bridge changed which faces are blocks


def test_a_face_memo_follows_a_real_town_when_a_district_is_added():
    from osm_expand.blocks import FaceMemo
    from osm_expand.ingest import load
    from osm_expand.pipeline import ExpandOptions, expand
    from tests.conftest import FIXTURES

    city = load(FIXTURES / "krems.osm.gz")
    grown = expand(city, ExpandOptions(seed=0, fidelity=False)).city
    memo = FaceMemo()
    for net in (city.network, grown.network, city.network):
        _same_blocks(blocks(net, memo=memo), blocks(net))


def test_the_faces_signed_areas_at_once_have_the_sign_of_each_ring_alone():
    """:func:`_Faces.signed_areas` sums every ring at once; the sign (block or not) is each ring's own,
    degenerate rings (there and back along one street, zero area) included."""
    import numpy as np
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from osm_expand.blocks import _Faces, _signed_area

    coord = st.floats(-5000.0, 5000.0, allow_nan=False).map(lambda v: round(v, 3))
    ring = st.lists(st.tuples(coord, coord), min_size=2, max_size=8).map(
        lambda pts: pts + pts[-2::-1])  # out and back: signed area exactly zero, whatever the rounding
    plain = st.lists(st.tuples(coord, coord), min_size=3, max_size=8)

    @settings(max_examples=200, deadline=None)
    @given(st.lists(st.one_of(ring, plain), min_size=1, max_size=6))
    def check(rings):
        closed = [np.array(r + r[:1], dtype=float) for r in rings]
        at = np.concatenate([[0], np.cumsum([len(c) for c in closed])])
        faces = _Faces(closed=np.concatenate(closed), ring_at=at, ids=np.zeros(0, np.int64),
                       id_at=at - np.arange(len(at)), edges=[1] * len(closed))
        got = faces.signed_areas()
        for c, a in zip(closed, got.tolist()):
            assert (a > 0) == (_signed_area(c) > 0)
            assert abs(a - _signed_area(c)) <= 1e-6 * max(1.0, abs(_signed_area(c)))

    check()


def test_blocks_stamped_as_they_are_made_are_the_blocks_stamped_afterwards():
    from osm_expand.blocks import FaceMemo
    from osm_expand.model import Origin

    net = network_from_lines(grid(4) + grid(2, 50.0, origin=(300.0, 300.0)))
    stamp = lambda ids: (Origin.ENGINE, 2000 + min(ids)) if max(ids) % 2 else (Origin.SOURCE, None)  # noqa: E731
    plain = blocks(net, year=1999)
    stamped = blocks(net, year=1999, memo=FaceMemo(), stamp=stamp)
    _same_blocks(stamped, plain)
    assert [(b.id, b.origin, b.year) for b in stamped] == [(b.id, *stamp(b.street_ids)) for b in plain]
    assert {b.origin for b in stamped} == {Origin.ENGINE, Origin.SOURCE}


@pytest.mark.parametrize("name", ["monaco.osm.gz", "krems.osm.gz", "andorra.osm.pbf"])
def test_overlapping_and_nested_faces_found_at_once_are_those_of_all_three_queries(name):
    """With every face new, :func:`_settled_pairs` leaves out the ``within`` query (its pairs are the
    ``contains`` pairs turned round); the pairs are those of asking all three predicates, on real towns whose
    bridges and separate pieces of network make faces overlap and nest."""
    import numpy as np

    from osm_expand.blocks import FaceMemo, _face_arrays, _settled_pairs, _valid_polygons
    from tests.conftest import loaded

    found = _face_arrays(loaded(name))
    may = np.flatnonzero((np.diff(found.ring_at) >= 4) & (found.signed_areas() > 0))
    polys = [p for p in _valid_polygons(found, may) if p is not None]
    keys = [p.wkb for p in polys]
    pairs = _settled_pairs(polys, keys, FaceMemo())
    tree = shapely.STRtree(polys)
    asked = [np.stack(tree.query(polys, predicate=p), axis=1) for p in ("overlaps", "contains", "within")]
    every = np.sort(np.concatenate(asked), axis=1)
    every = np.unique(every[every[:, 0] != every[:, 1]], axis=0)
    assert len(asked[1]) > 0 and np.array_equal(pairs, every)  # some faces nest: the shortcut is exercised


@pytest.mark.parametrize("name", ["krems", "campo-grande"])
def test_streets_cut_where_they_touch_themselves_at_once_are_those_cut_one_by_one(name):
    # the blocks' pieces find the streets that visit a node twice (or are rings, or too short) in one sort,
    # and split only those: the streets and their order are those of split_self_touching street by street
    from dataclasses import replace

    from osm_expand.blocks import _cut_where_self_touching
    from osm_expand.ingest import load
    from osm_expand.model.topology import flat_nodes, split_self_touching

    net = load(f"fixtures/{name}.osm.gz").network
    s = net.streets
    # a street that comes back to its middle node, a spike (a-b-a), a ring, a one-node street and a list of nodes
    extra = (replace(s[0], nodes=(*s[0].nodes, s[0].nodes[len(s[0].nodes) // 2])),
             replace(s[1], nodes=(s[1].nodes[0], s[1].nodes[1], s[1].nodes[0])),
             replace(s[2], nodes=(*s[2].nodes, s[2].nodes[0])),
             replace(s[3], nodes=(s[3].nodes[0],)), replace(s[4], nodes=list(s[4].nodes)))
    for streets in (s, (*s[:10], *extra, *s[10:])):
        got, flat = _cut_where_self_touching(streets)
        want = [p for street in streets for p in split_self_touching(street)]
        assert [(p.id, tuple(p.nodes)) for p in got] == [(p.id, tuple(p.nodes)) for p in want]
        assert all(a is b for a, b in zip(got, want) if a.nodes is b.nodes)  # unsplit streets are not copied
        for mine, theirs in zip(flat, flat_nodes(want)):
            assert mine.dtype == theirs.dtype and (mine == theirs).all()
    assert len(_cut_where_self_touching((*s[:10], *extra, *s[10:]))[0]) != len(s) + len(extra)  # the extras were cut
