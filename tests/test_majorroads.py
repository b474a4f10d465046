"""The pathfinding lattice G, B, G′, turn-penalised routing and major road plans (003 §3.4; 000 §4.2.3, §4.2.7)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from math import gcd

import numpy as np
import pytest
import shapely
from hypothesis import example, given, settings
from hypothesis import strategies as st

from osm_expand.engine.roads import path_graph
from osm_expand.engine.roads.built_up import BuiltUpOptions, built_up_area, segment_sides
from osm_expand.engine.roads.lattice import (
    NO_EDGE,
    EdgeKind,
    LatticeOptions,
    Raster,
    VertexClass,
    build_lattice,
    lattice_directions,
)
from osm_expand.engine.roads.path_graph import EdgeCosts, StreetPart, implicit_graph, pathfinding_graph
from osm_expand.engine.roads.road_types import (
    MajorRoadOptions,
    RoadType,
    allowed_streets,
    centroid_smoothing,
    chaikin,
    max_turn,
    parse_road_type,
    plan_major_road,
    propose_route,
    smooth_polyline,
)
from osm_expand.engine.roads.routing import (
    Choice,
    RoutingOptions,
    choose,
    find_route,
    route_over_major_roads,
    turn_penalty,
)
from osm_expand.errors import InputError
from osm_expand.model.segments import SegmentTable

CELL = 5.0


def raster(mask_fn, extent, cell=CELL) -> Raster:
    """A boolean raster over ``extent`` from a predicate on cell centres."""
    x0, y0, x1, y1 = extent
    xs, ys = np.meshgrid(x0 + (np.arange(int((x1 - x0) / cell) + 1) + 0.5) * cell,
                         y0 + (np.arange(int((y1 - y0) / cell) + 1) + 0.5) * cell)
    return Raster(mask_fn(xs, ys), (x0, y0), cell)

def random_blobs(rng: np.random.Generator, extent, n: int, *, within: tuple[float, float],
                 radius: tuple[float, float]) -> Raster:
    """``n`` forbidden discs at random (centres' both coordinates and radii uniform in the ranges, m)
    on ``extent``, rasterised at 10 m."""
    centres, radii = rng.uniform(*within, (n, 2)), rng.uniform(*radius, n)
    return raster(lambda x, y: (np.hypot(x[..., None] - centres[:, 0], y[..., None] - centres[:, 1])
                                < radii).any(axis=-1), extent, cell=10.0)



def river(extent, y_lo, y_hi) -> Raster:
    return raster(lambda x, y: (y > y_lo) & (y < y_hi), extent)


def random_river_lattice(rng: np.random.Generator):
    """An 800 × 600 m lattice with four forbidden discs, a 50 m river across it at a random height and a
    random radius of 1-4 (drawn from ``rng`` in that order)."""
    extent = (0, 0, 800, 600)
    blobs = random_blobs(rng, extent, 4, within=(50, 750), radius=(20, 70))
    y_lo = float(rng.uniform(100, 450))
    return build_lattice(extent, water=river(extent, y_lo, y_lo + 50), forbidden=blobs,
                         options=LatticeOptions(radius=int(rng.integers(1, 5))))


def samples_along(lattice, src, dst, per_edge=40) -> np.ndarray:
    xy = lattice.vertex_xy()
    t = np.linspace(0.0, 1.0, per_edge)[None, :, None]
    return xy[src][:, None, :] + t * (xy[dst] - xy[src])[:, None, :]


def grid_lines(x0, y0, n, size):
    """Street polylines of an n × n block grid with ``size`` m blocks."""
    ticks = np.arange(n + 1) * size
    lines = []
    for t in ticks:
        lines.append(np.stack([x0 + ticks, np.full(n + 1, y0 + t)], axis=1))
        lines.append(np.stack([np.full(n + 1, x0 + t), y0 + ticks], axis=1))
    return lines


def blocks_of(segments: SegmentTable) -> list:
    return list(shapely.get_parts(shapely.polygonize(list(segments.lines()))))


# ---------------------------------------------------------------- the lattice G


@pytest.mark.parametrize("radius, count", [(1, 4), (2, 8), (8, 120)])
def test_directions_are_the_primitive_vectors_within_the_radius(radius, count):
    d = lattice_directions(radius)
    assert len(d) == count
    assert all(gcd(abs(int(a)), abs(int(b))) == 1 for a, b in d)
    assert (d[:, 0] ** 2 + d[:, 1] ** 2 <= radius * radius).all()
    half = len(d) // 2
    np.testing.assert_array_equal(d[half:], -d[:half])
    assert len({tuple(v) for v in d.tolist()}) == count


def test_an_inner_vertex_joins_the_nearest_vertex_in_every_direction():
    lat = build_lattice((0, 0, 400, 400), options=LatticeOptions(radius=3))
    kind, _ = lat.directed_tables()
    ny, nx = lat.shape
    centre = (ny // 2) * nx + nx // 2
    assert (kind[centre] == EdgeKind.LAND).all()  # every one of the D directions, out and in
    edges = lat.edges()
    out = edges["src"] == centre
    np.testing.assert_array_equal(np.sort(edges["dst"][out] - centre),
                                  np.sort(lat.direction_offset[:len(lat.directions) // 2]))
    # a corner vertex only has the directions that stay on the map
    assert (kind[0] != NO_EDGE).sum() == (lat.directions >= 0).all(axis=1).sum()


def test_forbidden_vertices_have_no_edges_and_no_edge_crosses_forbidden_ground():
    extent = (0, 0, 400, 400)
    forbidden = raster(lambda x, y: (np.abs(x - 200) < 60) & (np.abs(y - 200) < 60), extent)
    lat = build_lattice(extent, forbidden=forbidden, options=LatticeOptions(radius=4))
    edges = lat.edges()
    bad = np.flatnonzero(lat.vertex_class == VertexClass.FORBIDDEN)
    assert len(bad) > 0
    assert not np.isin(edges["src"], bad).any() and not np.isin(edges["dst"], bad).any()
    pts = samples_along(lat, edges["src"], edges["dst"])
    assert not ((np.abs(pts[..., 0] - 200) < 55) & (np.abs(pts[..., 1] - 200) < 55)).any()


def test_a_river_makes_water_harbour_and_bridge_edges_and_keeps_land_edges_dry():
    extent = (0, 0, 600, 600)
    lat = build_lattice(extent, water=river(extent, 250, 350), options=LatticeOptions(radius=4))
    e = lat.edges()
    xy = lat.vertex_xy()
    kinds = set(np.unique(e["kind"]).tolist())
    assert {EdgeKind.LAND, EdgeKind.WATER, EdgeKind.HARBOUR, EdgeKind.BRIDGE} <= kinds
    land = e["kind"] == EdgeKind.LAND
    pts = samples_along(lat, e["src"][land], e["dst"][land])
    assert not ((pts[..., 1] > 252) & (pts[..., 1] < 348)).any()
    water = e["kind"] == EdgeKind.WATER
    assert (lat.vertex_class[e["src"][water]] == VertexClass.WATER).all()
    harbour = e["kind"] == EdgeKind.HARBOUR
    classes = np.sort(np.stack([lat.vertex_class[e["src"][harbour]], lat.vertex_class[e["dst"][harbour]]], 1), 1)
    assert (classes == [VertexClass.LAND, VertexClass.WATER]).all()
    bridge = e["kind"] == EdgeKind.BRIDGE
    ys = np.sort(np.stack([xy[e["src"][bridge], 1], xy[e["dst"][bridge], 1]], 1), 1)
    assert (ys[:, 0] < 250).all() and (ys[:, 1] > 350).all()  # bank to bank, over the river
    assert (lat.vertex_class[e["src"][bridge]] == VertexClass.LAND).all()
    assert (lat.vertex_class[e["dst"][bridge]] == VertexClass.LAND).all()


def test_bridges_are_near_the_shortest_crossing_of_their_ends():
    extent = (0, 0, 600, 600)
    slack = 1.25
    lat = build_lattice(extent, water=river(extent, 250, 350), options=LatticeOptions(radius=4, bridge_slack=slack))
    e = lat.edges()
    bridge = e["kind"] == EdgeKind.BRIDGE
    src, dst, length = e["src"][bridge], e["dst"][bridge], e["length"][bridge]
    shortest = np.full(lat.n_vertices, np.inf)
    np.minimum.at(shortest, src, length)
    np.minimum.at(shortest, dst, length)
    assert (length <= slack * np.minimum(shortest[src], shortest[dst]) + 1e-9).all()
    assert length.min() == pytest.approx(120.0)  # straight across: 240 → 360 on a 20 m lattice


def test_a_height_raster_makes_slopes_dearer_and_cuts_off_cliffs():
    extent = (0, 0, 400, 400)
    ramp = raster(lambda x, y: np.zeros(x.shape, bool), extent, cell=10.0)
    xs = ramp.origin[0] + (np.arange(ramp.values.shape[1]) + 0.5) * ramp.cell
    height = Raster(np.broadcast_to(0.2 * np.maximum(xs - 200, 0.0), ramp.values.shape).copy(), ramp.origin, 10.0)
    lat = build_lattice(extent, height=height, options=LatticeOptions(radius=2, slope_weight=10.0))
    e = lat.edges()
    xy = lat.vertex_xy()
    d = lat.directions[e["direction"]]
    ratio = lat.unit_weight.ravel()[lat.unit_kind.ravel() != NO_EDGE] / e["length"]
    on_slope = (xy[e["src"], 0] > 220) & (xy[e["dst"], 0] > 220)
    flat = (xy[e["src"], 0] < 180) & (xy[e["dst"], 0] < 180)
    np.testing.assert_allclose(ratio[flat], 1.0)
    expected = np.maximum(1.0, 10.0 * 0.2 * np.abs(d[:, 0]) / np.hypot(*d.T))  # length · max(1, O1 · slope)
    np.testing.assert_allclose(ratio[on_slope], expected[on_slope], rtol=1e-6)
    steep = build_lattice(extent, height=height, options=LatticeOptions(radius=2, slope_cutoff=0.15)).edges()

    steep_on_slope = (xy[steep["src"], 0] > 220) & (xy[steep["dst"], 0] > 220)
    steep_d = lat.directions[steep["direction"]]
    assert not (steep_on_slope & (steep_d[:, 1] == 0)).any()  # slope 0.2 > 0.15: cut off
    assert (steep_on_slope & (np.abs(steep_d[:, 0]) == np.abs(steep_d[:, 1]))).any()  # 0.14 diagonals stay


# ---------------------------------------------------------------- B


def test_built_up_area_removes_every_land_edge_through_it_and_keeps_the_rest():
    extent = (0, 0, 600, 600)
    lat = build_lattice(extent, water=river(extent, 500, 560), options=LatticeOptions(radius=4))
    disc = shapely.Point(250, 250).buffer(100)
    cut = lat.with_built_up(disc)
    live = cut.edges(live=True)
    land = live["kind"] == EdgeKind.LAND
    pts = samples_along(cut, live["src"][land], live["dst"][land])
    assert not shapely.contains_xy(shapely.buffer(disc, -6), pts[..., 0], pts[..., 1]).any()
    before, after = lat.edges(live=True), live
    assert (before["kind"] != EdgeKind.LAND).sum() == (after["kind"] != EdgeKind.LAND).sum()  # bridges stay
    far = (cut.vertex_xy()[live["src"], 0] > 450) & (cut.vertex_xy()[live["dst"], 0] > 450)
    old_far = (lat.vertex_xy()[before["src"], 0] > 450) & (lat.vertex_xy()[before["dst"], 0] > 450)
    assert far.sum() == old_far.sum()
    kind, _ = cut.directed_tables()  # both directions of a removed edge are gone
    assert (kind != NO_EDGE).sum() == 2 * ((cut.unit_kind != NO_EDGE) & ~cut.unit_removed).sum()


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 400), st.floats(0, 400), st.floats(10, 120)), min_size=1, max_size=4))
def test_b_never_shrinks(discs):
    lat = build_lattice((0, 0, 400, 400), options=LatticeOptions(radius=3))
    area = None
    for x, y, r in discs:
        grown = lat.with_built_up(shapely.Point(x, y).buffer(r))
        assert (grown.unit_removed >= lat.unit_removed).all()
        assert (grown.built_up >= lat.built_up).all()
        assert ((grown.directed_kind == NO_EDGE) >= (lat.directed_kind == NO_EDGE)).all()
        lat = grown
        segs = SegmentTable.from_lines([np.array([[x, y], [x + r, y]])], major=[False], width=[6.0])
        new = built_up_area([], segs, previous=area)
        if area is not None:
            assert shapely.area(shapely.difference(area.area, new.area)) < 1e-6
        area = new
    again = lat.with_built_up(shapely.Point(200, 200).buffer(1))  # a smaller B changes nothing back
    assert (again.unit_removed >= lat.unit_removed).all()


@settings(max_examples=10, deadline=None)
@given(st.floats(150, 350), st.floats(150, 350), st.integers(1, 3), st.integers(1, 3), st.floats(40, 90))
def test_b_grown_from_last_year_measures_and_tests_only_the_new_ground(x0, y0, n, more, size):
    """Next year's B tests only the blocks that are new (an unchanged block keeps its verdict:
    measuring every block's water share again was a quarter of B's year on Campo Grande) and
    rasterises only the fine points near what it added; it is the B made from scratch."""
    import osm_expand.engine.roads.built_up as built_up_module

    extent = (0, 0, 1000, 1000)
    water = shapely.box(0, 0, 1000, 60)
    lat = build_lattice(extent, options=LatticeOptions(radius=3))
    segs = SegmentTable.from_lines(grid_lines(x0, y0, n, size), major=[False] * (2 * n + 2),
                                   width=[6.0] * (2 * n + 2))
    first = built_up_area(blocks_of(segs), segs, water=water)
    lat = lat.with_built_up(first.area, first.added)
    across, up = x0 + np.arange(n + more + 1) * size, y0 + np.arange(n + 1) * size  # more columns east
    lines = [np.stack([across, np.full(len(across), y)], axis=1) for y in up]
    lines += [np.stack([np.full(len(up), x), up], axis=1) for x in across]
    segs2 = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    measured = []  # the blocks whose water is looked for (then overlaid where it touches them)
    intersects = shapely.intersects

    def counted(a, b, **kw):
        if isinstance(b, np.ndarray):  # B's blocks against the water; not a scalar call from elsewhere
            measured.append(len(b))
        return intersects(a, b, **kw)

    with pytest.MonkeyPatch.context() as monkey:  # hypothesis: no function-scoped monkeypatch fixture
        monkey.setattr(built_up_module.shapely, "intersects", counted)
        second = built_up_area(blocks_of(segs2), segs2, water=water, previous=first)
    assert sum(measured) == n * more  # the new column's blocks, not the n² unchanged ones
    assert second.added is not None and len(second.added) >= n * more
    fresh = built_up_area(blocks_of(segs2), segs2, water=water, previous=first.__class__(first.area, first.blocks))
    assert shapely.equals(second.area, fresh.area) and shapely.equals(second.blocks, fresh.blocks)
    assert np.array_equal(lat.with_built_up(second.area, second.added).built_up,
                          lat.with_built_up(second.area).built_up)
    assert lat.with_built_up(second.area).built_up.sum() > lat.built_up.sum()


@settings(max_examples=10, deadline=None)
@given(st.integers(3, 5), st.floats(40, 90), st.integers(0, 2**32 - 1))
def test_b_and_its_blocks_are_carried_from_last_year_not_unioned_again(n, size, seed):
    """Issue 22: a year's B and union of built-up blocks are last year's with what changed taken
    out and joined (a street gone merges two blocks, a new column adds some, water makes one
    terrain): never the union of every block again, and the same ground as made from scratch."""
    import osm_expand.engine.roads.built_up as built_up_module

    rng = np.random.default_rng(seed)
    lines = grid_lines(100, 100, n, size)
    segs = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    # a street inside the grid goes (two blocks become one), a column of blocks comes east
    inner = [k for k, line in enumerate(lines) if 0 < k // 2 < n]
    gone = int(rng.choice(inner))
    ticks = 100 + np.arange(n + 2) * size
    later = [line for k, line in enumerate(lines) if k != gone]
    later += [np.array([[ticks[-2], y], [ticks[-1], y]]) for y in ticks[:-1]]
    later.append(np.stack([np.full(n + 1, ticks[-1]), ticks[:-1]], axis=1))
    segs2 = SegmentTable.from_lines(later, major=[False] * len(later), width=[6.0] * len(later))
    blocks2 = blocks_of(segs2)
    # water over one old block's middle: it is terrain now (a built-up block no longer)
    c = shapely.get_coordinates(shapely.centroid(blocks2[int(rng.integers(len(blocks2)))]))[0]
    water = shapely.union(shapely.box(0, 0, 2000, 20), shapely.box(*(c - 0.45 * size), *(c + 0.45 * size)))
    first = built_up_area(blocks_of(segs), segs, water=water)
    unioned: set[int] = set()
    union_all = shapely.union_all
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(built_up_module.shapely, "union_all",
                       lambda g, **kw: unioned.update(map(id, np.atleast_1d(np.asarray(g, dtype=object))))
                       or union_all(g, **kw))
        second = built_up_area(blocks2, segs2, water=water, previous=first)
    old = {shapely.normalize(b).wkb for b in blocks_of(segs)}
    kept = [b for b in blocks2 if shapely.normalize(b).wkb in old]
    assert kept and not unioned & set(map(id, kept))  # only what changed is unioned, not the blocks kept
    fresh = built_up_area(blocks2, segs2, water=water, previous=first.__class__(first.area, first.blocks))
    for a, b in ((second.blocks, fresh.blocks), (second.area, fresh.area)):
        assert shapely.area(shapely.symmetric_difference(a, b)) < 1e-6
    assert shapely.area(second.blocks) < shapely.area(shapely.union_all(blocks2))  # the wet block is out


def test_block_verdicts_are_carried_only_with_the_water_and_options_they_were_measured_with():
    """A block found built-up last year is terrain this year if the water now covers it: the
    carried verdicts hold for the water and options they were measured with, not for others."""
    segs = SegmentTable.from_lines(grid_lines(200, 200, 2, 60), major=[False] * 6, width=[6.0] * 6)
    dry = built_up_area(blocks_of(segs), segs, water=None)
    assert shapely.area(dry.blocks) > 0
    flooded = shapely.box(0, 0, 1000, 1000)
    wet = built_up_area(blocks_of(segs), segs, water=flooded, previous=dry)
    assert wet.blocks.is_empty  # measured again under water, not carried as built-up
    again = built_up_area(blocks_of(segs), segs, water=None, previous=dry,
                          options=BuiltUpOptions(terrain_block_area=1.0))
    assert again.blocks.is_empty  # other options: measured again


def test_a_raster_from_geometry_keeps_a_stream_thinner_than_a_cell():
    stream = shapely.LineString([(0, 52), (200, 57)]).buffer(1.5)  # 3 m wide, between cell centres
    r = Raster.from_geometry(stream, (0, 0, 200, 100), cell=10.0)
    row, col, _ = r.cell_index(np.full(21, 100.0), np.linspace(0, 100, 21))
    assert r.values[row, col].any()
    assert not r.values[0].any() and not r.values[-1].any()


def test_built_up_area_follows_equation_1():
    segs = SegmentTable.from_lines(grid_lines(0, 0, 2, 100) + [np.array([[200, 100], [600, 100]])],
                               major=[False] * 7, width=[6.0] * 7)
    blocks = blocks_of(segs) + [shapely.box(200, 100, 600, 600)]  # a large terrain block
    b = built_up_area(blocks, segs)
    assert shapely.covers(b.area, shapely.box(0, 0, 200, 200))  # built-up blocks
    assert b.area.contains(shapely.Point(400, 120))  # NB of a street on a terrain block
    assert not b.area.contains(shapely.Point(400, 400))  # inside the terrain block
    assert not b.blocks.contains(shapely.Point(400, 400))
    sides = segment_sides(segs, b.blocks)
    assert sides.max() == 2 and sides.min() == 0


# ---------------------------------------------------------------- G′


def town_graph(costs: EdgeCosts | None = None, through_major=False):
    """A 3 × 3 block town (100 m blocks) in the middle of 1 km of open land."""
    extent = (0, 0, 1000, 1000)
    lines = grid_lines(350, 350, 3, 100)
    major = [False] * len(lines)
    if through_major:
        major[2] = True  # the horizontal street at y = 450
    segs = SegmentTable.from_lines(lines, major=major, width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, options=LatticeOptions(radius=4)).with_built_up(built.area)
    return pathfinding_graph(lat, segs, built, costs=costs or EdgeCosts()), segs


def test_stitches_join_the_town_to_the_lattice_without_crossing_streets():
    g, segs = town_graph()
    stitch = (g.kind == EdgeKind.STITCH) & (g.src < g.dst)
    assert stitch.sum() > 20
    lines = shapely.linestrings(np.stack([g.xy[g.src[stitch]], g.xy[g.dst[stitch]]], axis=1))
    for line in lines:  # a stitch meets streets only at its own end
        touch = shapely.intersection(line, shapely.multilinestrings(segs.lines()))
        assert shapely.get_num_coordinates(touch) <= 2
    # the lattice end of every stitch is a live land vertex outside B
    lattice_end = np.where(g.src[stitch] < g.n_lattice, g.src[stitch], g.dst[stitch])
    lattice_end = lattice_end[lattice_end < g.n_lattice]
    assert not g.lattice.fine_lookup(g.lattice.built_up, g.xy[lattice_end]).any()
    # only streets on the shell get stitches: the centre crossing (450, 450) has none
    centre = g.node_vertex(int(np.argmin(np.hypot(*(segs.xy - [450, 450]).T))))
    assert not ((g.src == centre) & (g.kind == EdgeKind.STITCH)).any()


def test_a_new_road_avoids_the_town_unless_a_cheap_major_road_crosses_it():
    west, east = np.array([0.0, 460.0]), np.array([1000.0, 460.0])
    g, _ = town_graph(EdgeCosts(minor=3.0))
    route = find_route(g, g.nearest_vertex(west), g.nearest_vertex(east))
    assert not (route.kind == EdgeKind.MINOR).any()
    assert ((route.xy[:, 1] < 330) | (route.xy[:, 1] > 670) | (route.xy[:, 0] < 330) | (route.xy[:, 0] > 670)).all()
    g, segs = town_graph(EdgeCosts(minor=3.0, major=0.3), through_major=True)
    route = find_route(g, g.nearest_vertex(west), g.nearest_vertex(east))
    assert (route.kind == EdgeKind.MAJOR).sum() >= 3
    assert segs.major[route.segment[route.segment >= 0]].all()


# ---------------------------------------------------------------- turn penalty


def test_turn_penalty_is_a_scaled_smoothstep():
    kw = dict(centre=2.0 * np.pi / 3.0, width=np.pi / 3.0, height=100.0)
    assert turn_penalty(np.pi, **kw) == 0.0
    assert turn_penalty(0.0, **kw) == 100.0
    assert turn_penalty(2.0 * np.pi / 3.0, **kw) == pytest.approx(50.0)
    alpha = np.linspace(0, np.pi, 50)
    assert (np.diff(turn_penalty(alpha, **kw)) <= 1e-12).all()


def chicane_graph():
    """Streets only (the lattice is forbidden ground): a short chicane with three right
    angles and a longer, gently bending way round."""
    extent = (-50, -150, 450, 100)
    lines = [np.array([[0, 0], [200, 0], [200, 10], [400, 10], [400, 0]]),
             np.array([[0, 0], [100, -80], [300, -80], [400, 0]])]
    segs = SegmentTable.from_lines(lines, major=[True, True], width=[8.0, 8.0])
    lat = build_lattice(extent, forbidden=raster(lambda x, y: np.ones(x.shape, bool), extent, cell=10.0),
                        options=LatticeOptions(radius=2))
    g = pathfinding_graph(lat, segs)
    node = lambda xy: g.node_vertex(int(np.argmin(np.hypot(*(segs.xy - xy).T))))  # noqa: E731
    return g, node([0, 0]), node([400, 0])


def test_the_turn_penalty_changes_the_route_plain_dijkstra_takes():
    g, s, t = chicane_graph()
    plain = find_route(g, s, t, options=RoutingOptions(turn_height=0.0))
    penalised = find_route(g, s, t, options=RoutingOptions(turn_height=150.0))
    assert plain.length == pytest.approx(420.0)  # through the chicane
    assert penalised.length == pytest.approx(2 * np.hypot(100, 80) + 200)  # round the bend
    assert penalised.xy[:, 1].min() == pytest.approx(-80.0)
    assert penalised.turn_cost < 150.0 < plain.cost + 3 * 150.0 - penalised.cost


def test_on_an_open_field_the_penalised_route_turns_once():
    lat = build_lattice((0, 0, 300, 300), options=LatticeOptions(radius=1))
    g = pathfinding_graph(lat, SegmentTable.from_lines([], major=[], width=[]))
    s, t = g.nearest_vertex([0, 0]), g.nearest_vertex([200, 200])
    route = find_route(g, s, t)
    assert route.length == pytest.approx(400.0)
    turns = np.count_nonzero(np.abs(np.diff(np.arctan2(*np.diff(route.xy, axis=0).T[::-1]))) > 1e-9)
    assert turns == 1
    assert route.turn_cost == pytest.approx(150.0)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_pruned_search_finds_the_same_cost_as_searching_everything(seed):
    from osm_expand.engine.roads.routing import _bin_penalties, _expanded_search
    rng = np.random.default_rng(seed)
    extent = (0, 0, 600, 600)
    blobs = random_blobs(rng, extent, 6, within=(50, 550), radius=(20, 90))
    lat = build_lattice(extent, forbidden=blobs, options=LatticeOptions(radius=int(rng.integers(1, 4))))
    g = pathfinding_graph(lat, SegmentTable.from_lines([], major=[], width=[]))
    live = g.live_vertices()
    s, t = (int(v) for v in rng.choice(live, 2, replace=False))
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)))
    route = find_route(g, s, t, options=opts)
    lat_ok, extra_ok = g.masks()
    full = _expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t, _bin_penalties(opts),
                            opts.heading_bins, np.inf)
    assert (route is None) == (full is None)
    if route is not None:
        assert route.cost == pytest.approx(full[1], abs=1e-5)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_tiled_a_star_finds_the_cost_of_searching_the_whole_expanded_graph(seed):
    """Issue 22: the exact search made tile by tile as it reaches them (``routing._tiled_search``,
    tiny tiles and no region searched whole, so the tiles must grow) costs each route what
    Dijkstra over the whole heading-expanded graph gives, on a street grid among forbidden blobs
    under turn penalties from light to heavy (the next test: the tiles grew on most maps)."""
    _tiled_against_whole(seed)


def _tiled_against_whole(seed: int) -> bool:
    """Three routes on one random map, each of the whole graph's cost; whether the tiles grew."""
    from osm_expand.engine.roads import routing
    rng = np.random.default_rng(seed)
    extent = (0, 0, 800, 800)
    blobs = random_blobs(rng, extent, 5, within=(50, 750), radius=(20, 70))
    n = int(rng.integers(2, 5))
    lines = grid_lines(250, 250, n, 300 / n)
    segs = SegmentTable.from_lines(lines, major=[bool(b) for b in rng.integers(0, 2, len(lines))],
                                   width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, forbidden=blobs,
                        options=LatticeOptions(radius=int(rng.integers(1, 4)))).with_built_up(built.area)
    g = pathfinding_graph(lat, segs, built)
    live = g.live_vertices()
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 900)), tile_cells=int(rng.integers(1, 5)),
                          whole_region=0)
    lat_ok, extra_ok = g.masks()
    made = []  # heading-expanded searches per route (the band's and the tiles'): more when the tiles grew
    heading_search = routing._heading_search

    def counted(*args, **kwargs):
        made[-1] += 1
        return heading_search(*args, **kwargs)

    routing._heading_search = counted
    try:
        for _ in range(3):
            s, t = (int(v) for v in rng.choice(live, 2, replace=False))
            made.append(0)
            route = find_route(g, s, t, options=opts)
            full = routing._expanded_search(g, lat_ok, extra_ok, np.arange(g.n_vertices), s, t,
                                            routing._bin_penalties(opts), opts.heading_bins, np.inf)
            assert (route is None) == (full is None)
            if route is not None:
                assert route.cost == pytest.approx(full[1], rel=1e-9, abs=1e-5)
    finally:
        routing._heading_search = heading_search
    return max(made) > 2  # the band's search is one of them


def test_the_tiled_a_star_grows_its_tiles_on_most_maps():
    """The equal costs above are not vacuous: on most of twelve fixed maps the tiles grew."""
    grew = [_tiled_against_whole(seed) for seed in range(12)]
    assert sum(grew) >= 6


def random_town(rng: np.random.Generator):
    """G′ of a random 1 km map: a 3 × 3 street grid of random major streets, a river across at a random
    height, five forbidden blobs and a lattice radius of 2–4 (the growing-window and bound tests' map)."""
    extent = (0, 0, 1000, 1000)
    blobs = random_blobs(rng, extent, 5, within=(50, 950), radius=(20, 80))
    y_lo = float(rng.uniform(100, 800))
    segs = SegmentTable.from_lines(grid_lines(350, 350, 3, 100), major=[bool(b) for b in rng.integers(0, 2, 8)],
                                   width=[6.0] * 8)
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, water=river(extent, y_lo, y_lo + 60), forbidden=blobs,
                        options=LatticeOptions(radius=int(rng.integers(2, 5)))).with_built_up(built.area)
    return implicit_graph(lat, segs, built)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1))
@example(4194305)  # a bound from the target's side (binned headings reversed) overstated this map's route
def test_the_implicit_search_in_growing_windows_finds_the_cost_of_the_whole_map(seed):
    """A town, a river and forbidden blobs; small first windows force the windows to grow."""
    rng = np.random.default_rng(seed)
    implicit = random_town(rng)
    whole = implicit.whole()
    live = whole.live_vertices()
    opts = RoutingOptions(turn_height=float(rng.uniform(20, 400)), window_margin=float(rng.uniform(20, 200)),
                          window_share=0.0)
    for _ in range(3):
        s, t = (int(v) for v in rng.choice(live, 2, replace=False))
        old = find_route(whole, s, t, options=opts)
        new = find_route(implicit, s, t, options=opts)
        assert (old is None) == (new is None)
        if old is not None:
            assert new.cost == pytest.approx(old.cost, rel=1e-9, abs=1e-6)
            lat_ok, extra_ok = whole.masks()
            steps = whole.steps(new.vertices[:-1], new.vertices[1:], lat_ok, extra_ok)
            assert float(steps.weight.sum()) == pytest.approx(float(new.edge_weight.sum()))  # edges of G′
            assert np.array_equal(whole.xy[new.vertices], new.xy)


# ---------------------------------------------------------------- smoothing


def test_centroid_smoothing_and_chaikin_keep_the_ends():
    xy = np.array([[0, 0], [10, 0], [10, 10], [20, 10], [20, 20]], dtype=float)
    c = centroid_smoothing(xy)
    np.testing.assert_allclose(c, [[0, 0], [20 / 3, 10 / 3], [50 / 3, 40 / 3], [20, 20]])
    k = chaikin(xy, 2)
    np.testing.assert_allclose(k[[0, -1]], xy[[0, -1]])
    assert len(k) > len(xy)


def test_smoothing_keeps_its_pinned_points_and_reduces_turning():
    stairs = np.array([[0, 0], [40, 0], [40, 40], [60, 40], [80, 40], [80, 80], [120, 80], [120, 120], [160, 120]],
                      float)
    pinned = np.zeros(len(stairs), dtype=bool)
    pinned[3] = True  # e.g. a junction with a major road half way along a step
    out, flags = smooth_polyline(stairs, pinned, step=20.0)
    np.testing.assert_array_equal(out[0], stairs[0])
    np.testing.assert_array_equal(out[-1], stairs[-1])
    assert any((out == stairs[3]).all(axis=1))  # kept exactly
    np.testing.assert_array_equal(out[flags], stairs[[0, 3, 8]])
    assert max_turn(out) < max_turn(stairs) / 2
    corner = np.array([[0, 0], [40, 0], [40, 40]], float)  # a pinned corner stays a corner
    out, _ = smooth_polyline(corner, np.array([False, True, False]))
    np.testing.assert_array_equal(out, corner)


# ---------------------------------------------------------------- major roads


def river_graph():
    extent = (0, 0, 800, 600)
    water = river(extent, 250, 330)
    lat = build_lattice(extent, water=water, options=LatticeOptions(radius=4))
    no_streets = SegmentTable.from_lines([], major=[], width=[])
    return pathfinding_graph(lat, no_streets), water


def test_a_route_over_a_river_gets_exactly_one_bridge_where_it_crosses():
    g, water = river_graph()
    route = propose_route(g, g.nearest_vertex([200, 40]), g.nearest_vertex([600, 560]), RoadType.CITY)
    plan = plan_major_road(g, route, RoadType.CITY, 12.0)
    assert plan.bridges == 1
    bridge = next(r for r in plan.new_roads if r.bridge)
    assert bridge.xy[:, 1].min() < 250 and bridge.xy[:, 1].max() > 330
    for road in plan.new_roads:
        if road.bridge:
            continue
        dense = np.concatenate([np.linspace(a, b, 20) for a, b in zip(road.xy[:-1], road.xy[1:])])
        row, col, inside = water.cell_index(dense[:, 0], dense[:, 1])
        assert not (water.values[row, col] & inside).any()  # no street in water
    same_bank = propose_route(g, g.nearest_vertex([40, 40]), g.nearest_vertex([760, 200]), RoadType.CITY)
    assert plan_major_road(g, same_bank, RoadType.CITY, 12.0).bridges == 0


def test_new_roads_are_smoothed_but_start_and_end_where_the_route_does():
    g, _ = river_graph()
    route = propose_route(g, g.nearest_vertex([40, 40]), g.nearest_vertex([760, 200]), RoadType.BYPASS)
    plan = plan_major_road(g, route, RoadType.BYPASS, 12.0)
    road = plan.new_roads[0]
    np.testing.assert_allclose(road.xy[[0, -1]], route.xy[[0, -1]])
    assert max_turn(road.xy) <= max_turn(route.xy) + 1e-9


def straight_major_road(available):
    extent = (0, 0, 1000, 600)
    segs = SegmentTable.from_lines([np.array([[0, 300], [250, 300], [500, 300], [750, 300], [1000, 300]])],
                               major=[True], width=[6.0], available=[available])
    lat = build_lattice(extent, options=LatticeOptions(radius=4))
    built = built_up_area([], segs)
    g = pathfinding_graph(lat.with_built_up(built.area), segs, built)
    return g, segs, g.node_vertex(int(np.argmin(segs.xy[:, 0]))), g.node_vertex(int(np.argmax(segs.xy[:, 0])))


def test_rerouting_is_chosen_when_the_major_roads_have_capacity():
    g, segs, s, t = straight_major_road(available=500.0)
    reroute = route_over_major_roads(g, s, t, demand=100.0)
    new = propose_route(g, s, t, RoadType.CITY, demand=100.0)
    assert reroute is not None and reroute.length == pytest.approx(1000.0)
    assert choose(new, reroute) is Choice.REROUTE


def test_without_capacity_the_new_route_widens_the_extendible_road():
    g, segs, s, t = straight_major_road(available=50.0)
    assert route_over_major_roads(g, s, t, demand=100.0) is None
    new = propose_route(g, s, t, RoadType.CITY, demand=100.0)
    assert choose(new, None) is Choice.NEW
    plan = plan_major_road(g, new, RoadType.CITY, 12.0)
    assert not plan.new_roads
    np.testing.assert_array_equal(np.sort(plan.reused), np.arange(4))
    np.testing.assert_array_equal(np.sort(plan.widen), np.arange(4))  # 6 m < A = 12 m, extendible


def test_choose_compares_o3_length_plus_o4_cost():
    g, _, s, t = straight_major_road(available=500.0)
    reroute = route_over_major_roads(g, s, t)
    assert choose(None, None) is Choice.NONE
    assert choose(None, reroute) is Choice.REROUTE
    short = find_route(g, s, t, kinds=[EdgeKind.LAND, EdgeKind.STITCH])
    detour = type(reroute)(reroute.vertices, reroute.xy, reroute.kind, reroute.segment, reroute.edge_length * 3,
                           reroute.edge_weight * 3)
    assert choose(short, detour, o3=1.0, o4=0.0) is Choice.NEW
    with pytest.raises(InputError, match="O3"):
        choose(short, detour, o3=-1.0)


def test_a_rebuilding_city_road_demolishes_minor_streets_but_no_major_road():
    extent = (0, 0, 600, 600)
    lines = grid_lines(100, 100, 4, 100)
    major = [False] * len(lines)
    major[4] = True  # horizontal street y = 300
    segs = SegmentTable.from_lines(lines, major=major, width=[6.0] * len(lines))
    land = raster(lambda x, y: (x > 90) & (x < 510) & (y > 90) & (y < 510), extent)
    forbidden = Raster(~land.values, land.origin, land.cell)
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, forbidden=forbidden, options=LatticeOptions(radius=4)).with_built_up(built.area)
    g = pathfinding_graph(lat, segs, built, costs=EdgeCosts(minor=1.0))
    node = lambda xy: g.node_vertex(int(np.argmin(np.hypot(*(segs.xy - xy).T))))  # noqa: E731
    route = propose_route(g, node([100, 100]), node([500, 500]), RoadType.REBUILDING_CITY)
    lots = np.array([shapely.box(110 + 100 * i, 110 + 100 * j, 190 + 100 * i, 190 + 100 * j)
                     for i in range(4) for j in range(4)])
    plan = plan_major_road(g, route, RoadType.REBUILDING_CITY, 12.0, lots=lots)
    assert len(plan.demolished) > 0
    assert not segs.major[plan.demolished].any()
    assert len(plan.demolished_lots) > 0
    # what meets the road where it starts and ends is not in its way
    at_ends = np.flatnonzero(np.isin(segs.uv, route.vertices[[0, -1]] - g.n_lattice).any(axis=1))
    assert not np.isin(np.setdiff1d(at_ends, route.segment), plan.demolished).any()
    city = plan_major_road(g, route, RoadType.CITY, 12.0)
    assert len(city.demolished) == 0 and len(city.demolished_lots) == 0


def test_a_bypass_keeps_to_streets_on_the_edge_of_town_by_default():
    g, segs = town_graph()
    ok = allowed_streets(g, RoadType.BYPASS)
    np.testing.assert_array_equal(ok, g.extendible)
    literal = allowed_streets(g, "bypass", options=MajorRoadOptions(bypass_streets="interior"))
    np.testing.assert_array_equal(literal, ~g.extendible)
    assert allowed_streets(g, RoadType.CITY) is None


def test_bad_choices_and_parameters_raise_input_errors():
    with pytest.raises(InputError, match="bypass, city, smooth_city, rebuilding_city"):
        parse_road_type("motorway")
    with pytest.raises(InputError, match="bypass_streets"):
        MajorRoadOptions(bypass_streets="everywhere")
    with pytest.raises(InputError, match="radius"):
        LatticeOptions(radius=0)
    with pytest.raises(InputError, match="spacing"):
        LatticeOptions(spacing=-1.0)
    with pytest.raises(InputError, match="width"):
        replace(SegmentTable.from_lines([np.array([[0.0, 0.0], [1.0, 0.0]])], major=[True], width=[1.0]),
                width=np.array([1.0, 2.0]))
    with pytest.raises(InputError, match="extent"):
        build_lattice((0, 0, 0, 10))
    with pytest.raises(InputError, match="bridge"):
        EdgeCosts(bridge=0.0)


# ---------------------------------------------------------------- Krems (real data)


def network_and_water(town):
    """The street network and the water of a City."""
    return town.network, town.water_geometry()


#: highway classes taken as major roads on Krems (tertiary and above)
MAJOR_HIGHWAYS = {"motorway", "trunk", "primary", "secondary", "tertiary"}


@pytest.fixture(scope="module")
def krems():
    from conftest import FIXTURES

    from osm_expand.ingest import load
    net, water = network_and_water(load(FIXTURES / "krems.osm.gz"))
    major = [s.highway.removesuffix("_link") in MAJOR_HIGHWAYS for s in net.streets]
    segs = SegmentTable.from_lines([net.street_xy(s) for s in net.streets], major=major,
                               width=[12.0 if m else 6.0 for m in major], bridge=[s.bridge for s in net.streets])
    x0, y0 = net.xy.min(axis=0) - 100
    x1, y1 = net.xy.max(axis=0) + 100
    extent = (x0, y0, x1, y1)
    assert shapely.area(water) > 1e6  # the Danube
    water_raster = Raster.from_geometry(water, extent, cell=10.0)
    built = built_up_area(blocks_of(segs), segs, water=water)
    lat = build_lattice(extent, water=water_raster).with_built_up(built.area)
    implicit = implicit_graph(lat, segs, built)
    g = implicit.whole()
    degree = np.bincount(segs.uv[segs.major].ravel(), minlength=len(segs.xy))
    edge = np.minimum.reduce([segs.xy[:, 0] - x0, x1 - segs.xy[:, 0], segs.xy[:, 1] - y0, y1 - segs.xy[:, 1]])
    exits = np.flatnonzero((degree == 1) & (edge < 200))
    return g, segs, exits, water_raster, implicit


def test_krems_new_major_roads_stay_dry_and_bridge_only_where_they_must(krems):
    g, segs, exits, water, _ = krems
    assert len(exits) >= 3
    xy = segs.xy[exits]
    west, north, south_east = exits[np.argmin(xy[:, 0])], exits[np.argmax(xy[:, 1])], exits[np.argmin(xy[:, 1])]
    built_something = 0
    streets = shapely.STRtree(segs.lines())
    trips = [(west, north, RoadType.CITY), (north, south_east, RoadType.CITY), (west, south_east, RoadType.CITY),
             (west, north, RoadType.BYPASS)]
    for a, b, road_type in trips:
        s, t = g.node_vertex(a), g.node_vertex(b)
        new = propose_route(g, s, t, road_type)
        reroute = route_over_major_roads(g, s, t)
        assert new is not None
        if reroute is not None:
            assert new.cost <= reroute.cost + 1e-6  # G′ contains every re-route
        plan = plan_major_road(g, new, road_type, 12.0)
        built_something += len(plan.new_roads)
        for road in plan.new_roads:
            dense = np.concatenate([np.linspace(p, q, 40) for p, q in zip(road.xy[:-1], road.xy[1:])])
            row, col, inside = water.cell_index(dense[:, 0], dense[:, 1])
            wet = water.values[row, col] & inside
            if road.bridge:
                assert wet.any() and not wet[0] and not wet[-1]  # over water, landing on land
            else:
                assert not wet.any()  # no street in water
            line = shapely.LineString(road.xy)  # it meets streets only at its ends (junctions)
            meet = shapely.get_coordinates(shapely.intersection(segs.lines()[streets.query(line)], line))
            assert np.min(np.hypot(*(meet[:, None] - road.xy[[0, -1]]).transpose(2, 0, 1)), axis=1,
                          initial=np.inf).max(initial=0.0) < 0.01
        assert plan.bridges <= 1
    assert built_something > 0


def test_on_krems_the_implicit_search_finds_routes_of_the_same_cost_in_a_part_of_the_map(krems, monkeypatch):
    """The issue's equal-cost test on a real town: every road type between the exits and
    between random street nodes costs the same searched in windows as on the whole map's G′
    (the old search), and a route across part of the town generates only part of the lattice."""
    from osm_expand.engine.roads.path_graph import ImplicitGraph
    g, segs, exits, _, implicit = krems
    seen: list[int] = []
    window = ImplicitGraph.window
    monkeypatch.setattr(ImplicitGraph, "window", lambda self, bounds: seen.append(
        (w := window(self, bounds)).graph.lattice.n_vertices) or w)
    rng = np.random.default_rng(3)
    nodes = np.concatenate([exits[:3], rng.choice(len(segs.xy), 2, replace=False)])
    for k, (a, b) in enumerate(zip(nodes[:-1], nodes[1:])):
        s, t = g.node_vertex(int(a)), g.node_vertex(int(b))
        for road_type in (RoadType.CITY, RoadType.BYPASS if k % 2 else RoadType.SMOOTH_CITY):
            old, new = propose_route(g, s, t, road_type), propose_route(implicit, s, t, road_type)
            assert (old is None) == (new is None)
            if old is not None:
                assert new.cost == pytest.approx(old.cost, rel=1e-9)
                assert new.length == pytest.approx(old.length, rel=0.2)  # same cost, nearly the same road
        old, new = route_over_major_roads(g, s, t), route_over_major_roads(implicit, s, t)
        assert (old is None) == (new is None)
        if old is not None:
            assert new.cost == pytest.approx(old.cost, rel=1e-9)
    assert min(seen) < g.n_lattice / 4


def test_new_roads_keep_out_of_buildings_as_the_outputs_draw_them():
    """Krems, seed 1: a new primary road ran through the minimum rectangles (what the XML draws) of two
    huge mapped building outlines (0.21 and 0.035 km²) while missing the outlines themselves."""
    import shapely

    from osm_expand.ingest import load
    from osm_expand.land import building_outlines
    from osm_expand.model import Origin
    from tests.conftest import FIXTURES, expanded_and_matured

    city = expanded_and_matured(load(FIXTURES / "krems.osm.gz"), seed=1).city
    net = city.network
    roads = [shapely.LineString(net.street_xy(s)) for s in net.streets
             if s.origin == Origin.ENGINE and s.highway in ("primary", "secondary", "trunk")]
    town = city.replace(buildings=tuple(b for b in city.buildings if b.origin == Origin.SOURCE))
    outlines = building_outlines(town)
    assert roads
    crossed = shapely.STRtree(outlines).query(roads, predicate="crosses")
    assert not crossed.size


@pytest.mark.xfail(strict=True, reason="issue 20 open: with the transplanted district (session 43's default) Krems' "
                   "2014 trunk road leaves the town's streets by three 55-70 m stitches across the presumed frontage "
                   "(71 m deep) and crosses 3 withheld houses")
def test_new_roads_keep_out_of_the_houses_the_map_does_not_show():
    """Krems with its buildings withheld, seed 0: a new primary road ran through the town's presumed frontage
    behind its streets and crossed 4 of the real (withheld) buildings; the lattice now forbids the presumed
    frontage (a stitch may still cross it), so the roads are still built and crossed none with the quilt's
    district. With the transplant's, the roads go elsewhere and three stitches (from a street to the lattice,
    each across the whole 71 m frontage) cross a withheld house each: marked as the known failure it is."""
    import shapely

    from osm_expand.ingest import load
    from osm_expand.model import Origin
    from tests.conftest import FIXTURES, expanded_and_matured

    mapped = load(FIXTURES / "krems.osm.gz")
    city = expanded_and_matured(mapped.replace(buildings=()), seed=0).city
    net = city.network
    roads = [shapely.LineString(net.street_xy(s)) for s in net.streets
             if s.origin == Origin.ENGINE and s.highway in ("primary", "secondary", "trunk")]
    assert roads
    real = [b.polygon for b in mapped.buildings]
    assert not shapely.STRtree(real).query(roads, predicate="intersects").size


def test_a_stitch_may_cross_stitch_only_ground_that_no_lattice_edge_may():
    """:attr:`Lattice.stitch_only` (the town's presumed frontage) is forbidden to the lattice's vertices and
    edges, as ``forbidden`` is, but stitches from the streets still cross it to the land beyond."""
    extent = (0, 0, 1000, 1000)
    segs = SegmentTable.from_lines(grid_lines(350, 350, 3, 100), major=[False] * 8, width=[6.0] * 8)
    built = built_up_area(blocks_of(segs), segs)
    frontage = shapely.box(350, 350, 650, 650).buffer(40.0, join_style="mitre")  # 40 m behind the shell
    opts = LatticeOptions(radius=4)
    graphs = {}
    for kind in ("stitch_only", "forbidden"):
        lat = build_lattice(extent, options=opts, **{kind: Raster.from_geometry(frontage, extent, CELL)})
        graphs[kind] = pathfinding_graph(lat.with_built_up(built.area), segs, built)
    soft, hard = graphs["stitch_only"], graphs["forbidden"]
    assert np.array_equal(soft.lattice.vertex_class, hard.lattice.vertex_class)
    for g in (soft, hard):  # no lattice edge runs through the frontage
        lattice = (g.kind != EdgeKind.STITCH) & (g.src < g.n_lattice) & (g.dst < g.n_lattice)
        assert not g.lattice.fine_lookup(g.lattice.forbidden, samples_along(g.lattice, g.src[lattice],
                                                                           g.dst[lattice])).any()
    stitches = {name: int(((g.kind == EdgeKind.STITCH) & ((g.src < g.n_lattice) | (g.dst < g.n_lattice))).sum())
                for name, g in graphs.items()}
    assert stitches["stitch_only"] > 20 and stitches["forbidden"] == 0
def test_the_search_matrix_of_krems_holds_exactly_the_allowed_edges_of_g_prime(krems):
    """The CSR the search runs on has one entry per allowed edge of G′ and nothing else: no
    empty lattice slot is written (they cost a second and 12 bytes a slot per window on a
    town), each row keeps its lattice edges in direction order before its other edges, and
    :meth:`PathGraph.restricted` finds every street edge where the CSR put it."""
    g, segs, *_ = krems
    rng = np.random.default_rng(0)
    for kinds in (None, (EdgeKind.MAJOR, EdgeKind.MINOR)):
        lat, extra = g.masks(*(() if kinds is None else (kinds,)))
        matrix, ex, pos = g._csr(lat, extra)
        assert matrix.nnz == np.count_nonzero(lat) + np.count_nonzero(extra)
        assert np.isfinite(matrix.data).all()
        live = np.flatnonzero(lat)
        rows, dirs = np.divmod(live, lat.shape[1])
        expected = np.concatenate([rows * g.n_vertices + rows + g.lattice.direction_offset[dirs],
                                   g.src[ex] * g.n_vertices + g.dst[ex]])
        got = np.repeat(np.arange(g.n_vertices), np.diff(matrix.indptr)) * g.n_vertices + matrix.indices
        assert np.array_equal(np.sort(got), np.sort(expected))
        assert np.array_equal(matrix.data[pos], g.weight[ex])  # where ``restricted`` looks
        assert np.array_equal(matrix.indices[pos], g.dst[ex])
        some = rng.choice(len(live), min(len(live), 2000), replace=False) if len(live) else []
        for e in some:  # lattice entries first in their row, in direction order
            r = rows[e]
            row = matrix.indices[matrix.indptr[r]:matrix.indptr[r + 1]]
            assert row[np.count_nonzero(lat[r, :dirs[e]])] == r + g.lattice.direction_offset[dirs[e]]


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_window_crops_the_maps_edges_and_they_equal_the_rasters_own(seed):
    """A window's unit edges come from the map's tables made once by :func:`build_lattice`
    (the rasters are not sampled again: each window of a road year did it, a second a window
    on Campo Grande), and they are exactly what sampling the rasters in the window gives:
    kinds, weights (a hill) and B's removals, river, bridges and forbidden blobs included."""
    from dataclasses import replace

    import osm_expand.engine.roads.lattice as lattice_module
    rng = np.random.default_rng(seed)
    extent = (0, 0, 800, 600)
    blobs = random_blobs(rng, extent, 4, within=(50, 750), radius=(20, 70))
    y_lo = float(rng.uniform(100, 450))
    hill = raster(lambda x, y: np.zeros(x.shape, bool), extent, cell=10.0)
    xs = hill.origin[0] + (np.arange(hill.values.shape[1]) + 0.5) * hill.cell
    ramp = np.broadcast_to(float(rng.uniform(0.05, 0.4)) * np.maximum(xs - 400, 0.0), hill.values.shape).copy()
    lat = build_lattice(extent, water=river(extent, y_lo, y_lo + 50), forbidden=blobs,
                        height=Raster(ramp, hill.origin, 10.0) if seed % 2 else None,
                        options=LatticeOptions(radius=int(rng.integers(1, 5))))
    lat = lat.with_built_up(shapely.Point(rng.uniform(100, 700), rng.uniform(100, 500)).buffer(80.0))
    ny, nx = lat.shape
    r0, c0 = int(rng.integers(0, ny // 2)), int(rng.integers(0, nx // 2))
    window = lat.window(r0, c0, int(rng.integers(5, ny)), int(rng.integers(5, nx)))
    sampled = replace(window, map_units=None, _cache={})
    calls = []
    profiles = lattice_module._profiles
    try:
        lattice_module._profiles = lambda *a: calls.append(1) or profiles(*a)
        cropped = (window.unit_kind, window.unit_weight, window.unit_removed)
        assert not calls
        expected = (sampled.unit_kind, sampled.unit_weight, sampled.unit_removed)
        assert calls
    finally:
        lattice_module._profiles = profiles
    live = expected[0] != NO_EDGE
    assert np.array_equal(cropped[0], expected[0])
    assert np.array_equal(cropped[1][live], expected[1][live])
    assert np.array_equal(cropped[2], expected[2])
    assert live.any()


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_lattice_weights_read_from_the_kinds_equal_the_dense_table(seed):
    """G′'s lattice costs on flat land are read from the kinds (no (V, D) float32 table: 285 MB
    for Campo Grande's whole map): every way of reading them gives the dense table's values,
    C3 and C5 applied in its own float32 arithmetic."""
    from osm_expand.engine.roads.lattice import LatticeWeights

    rng = np.random.default_rng(seed)
    n, d = int(rng.integers(1, 40)), int(rng.integers(1, 12))
    kind = rng.choice(np.array([0, 1, 2, 3, NO_EDGE], dtype=np.uint8), size=(n, d))
    length = rng.uniform(5, 200, d)
    dense = np.empty((n, d), dtype=np.float32)
    dense[...] = length.astype(np.float32)
    special = np.flatnonzero(np.isin(kind, [EdgeKind.BRIDGE, EdgeKind.HARBOUR]))
    dense.reshape(-1)[special] *= np.where(kind.reshape(-1)[special] == EdgeKind.BRIDGE, 15.0, 10.0)
    lazy = LatticeWeights(kind, length).times({EdgeKind.BRIDGE: 15.0, EdgeKind.HARBOUR: 10.0})
    u, k = rng.integers(0, n, 50), rng.integers(0, d, 50)
    mask = rng.random((n, d)) < 0.5
    a, b = sorted(rng.integers(0, n + 1, 2).tolist())
    assert np.array_equal(lazy[u, k], dense[u, k]) and lazy[u, k].dtype == np.float32
    assert np.array_equal(lazy[mask], dense[mask])
    assert np.array_equal(lazy[a:b], dense[a:b])
    assert np.array_equal(lazy.masked(slice(a, b), mask[a:b]), dense[a:b][mask[a:b]])
    assert float(lazy[int(u[0]), int(k[0])]) == float(dense[u[0], k[0]])
    assert np.array_equal(np.asarray(lazy), dense)


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_windows_directed_tables_are_cropped_from_the_maps_made_once_per_b(seed):
    """A window's directed tables are cut from the whole map's, made once per B and carried
    to the next B by removing only the edges the new ground touches (every window of a road
    year made its own: 10.3 s of 48 windows on Campo Grande), and they equal what the
    window's own unit tables and B's removals give, year after year."""
    from dataclasses import replace

    rng = np.random.default_rng(seed)
    lat = random_river_lattice(rng)
    import osm_expand.engine.roads.lattice as lattice_module
    calls = []
    made = lattice_module._map_live_units
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(lattice_module, "_map_live_units", lambda lat: calls.append(1) or made(lat))
        for _ in range(3):  # B grows: the map's table is carried over, not made again
            lat = lat.with_built_up(shapely.Point(rng.uniform(100, 700), rng.uniform(100, 500)).buffer(60.0))
            ny, nx = lat.shape
            r0, c0 = int(rng.integers(0, ny // 2)), int(rng.integers(0, nx // 2))
            for window in (lat, lat.window(r0, c0, int(rng.integers(5, ny)), int(rng.integers(5, nx)))):
                kind, weight = window.directed_tables()
                sampled = replace(window, map_units=None, _cache={})
                exp_kind, exp_weight = sampled.directed_tables()
                live = exp_kind != NO_EDGE
                special = np.isin(exp_kind, [EdgeKind.BRIDGE, EdgeKind.HARBOUR])
                assert np.array_equal(window.special_entries(), np.flatnonzero(special))
                assert np.array_equal(sampled.special_entries(), np.flatnonzero(special))
                assert np.array_equal(kind, exp_kind)
                assert np.array_equal(weight[live], exp_weight[live])
                assert live.any()
    assert len(calls) == 1


def test_water_that_meets_the_edge_of_the_map_goes_on_beyond_it():
    """The sea does not stop at the map's bounds: a bay meeting the right and bottom edges carries on
    across the lattice's margin there, round the corner too; the land's edges stay land."""
    from osm_expand.engine.roads.major_roads import water_beyond_the_map

    sea = shapely.Polygon([(600, 0), (1000, 0), (1000, 500), (800, 300)])  # meets the bottom and right edges
    wet = water_beyond_the_map(sea, (0, 0, 1000, 1000), 100.0)
    assert wet.covers(sea)
    assert wet.contains(shapely.Point(900, -50)) and wet.contains(shapely.Point(1050, 200))
    assert wet.contains(shapely.Point(1050, -50))  # the corner
    assert not wet.intersects(shapely.Point(300, -50)) and not wet.intersects(shapely.Point(1050, 800))
    assert water_beyond_the_map(shapely.Polygon(), (0, 0, 1000, 1000), 100.0).is_empty


def test_the_town_goes_on_beyond_the_edge_where_the_clip_cut_its_streets():
    """Streets ending near the map's left edge (as a clipped extract cuts them) make the edge the town's
    there: the lattice's margin beyond them and a strip inside are taken, so no new road runs round
    the town outside the map (Campo Grande's 6.4 and 8.1 km roads did); the edge beyond a street far
    from it, and along the edge away from the cut streets, stays free."""
    from osm_expand.engine.roads.major_roads import town_beyond_the_map

    cut = [shapely.LineString([(x, 500.0), (x, 990.0 + x / 100)]) for x in (100.0, 200.0, 300.0)]  # end near the top
    inland = shapely.LineString([(500.0, 100.0), (500.0, 700.0)])
    town = town_beyond_the_map(np.array([*cut, inland], dtype=object), (0, 0, 1000, 1000), 100.0, 30.0)
    assert town.contains(shapely.Point(200, 1050))  # beyond a cut street's end
    assert town.intersects(shapely.LineString([(120, 1050), (180, 1050)]))  # no way along the edge between them
    assert town.contains(shapely.Point(200, 985))  # the strip inside the edge
    assert not town.intersects(shapely.Point(500, 1050)) and not town.intersects(shapely.Point(500, -50))
    assert not town.intersects(shapely.Point(800, 1050))
    assert not town.intersects(shapely.Point(200, 900))  # the town inside the map is the lattice's own business
    assert town_beyond_the_map(np.array([inland], dtype=object), (0, 0, 1000, 1000), 100.0, 30.0).is_empty
    assert town_beyond_the_map(np.empty(0, dtype=object), (0, 0, 1000, 1000), 100.0, 30.0).is_empty


def test_monacos_new_roads_do_not_run_round_the_sea_beyond_the_map():
    """Monaco, default years, seed 0: a new road of a later year ran along the map's edge round the
    whole bay, through the lattice's margin beyond the sea (the sea was cut at the bounds, the margin
    left as land); the margin beyond water is water now, and no new street runs there."""
    from osm_expand.engine.roads.major_roads import LATTICE_MARGIN, water_beyond_the_map
    from osm_expand.ingest import load
    from osm_expand.model import Origin
    from tests.conftest import FIXTURES, expanded_and_matured

    mapped = load(FIXTURES / "monaco.osm.gz")
    city = expanded_and_matured(mapped, seed=0).city
    sea = mapped.water_geometry()
    beyond = shapely.difference(water_beyond_the_map(sea, mapped.bounds_xy, LATTICE_MARGIN), sea.buffer(1.0))
    net = city.network
    new = [shapely.LineString(net.street_xy(s)) for s in net.streets if s.origin == Origin.ENGINE]
    assert new
    assert not shapely.intersects(shapely.union_all(new), beyond.buffer(-5.0))



@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_counting_turns_at_the_exits_keeps_the_search_exact(seed):
    """Issue 22: a window is proved with the turn-penalised costs of arriving at its exits (an A*
    towards the target, ``routing._tiled_search`` without a target) and grows by ``RoutingOptions.growth_share`` of its size a side at a time. On
    a street grid under heavy turn penalties, with tiny first windows and tiny tiles that must grow
    (no region searched whole), every route costs what one search of the whole map's G′ gives, and the
    exits' search (no target) runs at least once."""
    from osm_expand.engine.roads import routing
    rng = np.random.default_rng(seed)
    extent = (0, 0, 1600, 1600)
    n = int(rng.integers(4, 8))
    lines = grid_lines(400, 400, n, 800 / n)
    segs = SegmentTable.from_lines(lines, major=[bool(b) for b in rng.integers(0, 2, len(lines))],
                               width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    lat = build_lattice(extent, options=LatticeOptions(radius=int(rng.integers(2, 4)))).with_built_up(built.area)
    implicit = implicit_graph(lat, segs, built)
    whole = implicit.whole()
    opts = RoutingOptions(turn_height=float(rng.uniform(150, 600)), window_margin=float(rng.uniform(20, 120)),
                          window_share=0.0)
    tiny = replace(opts, whole_region=0, tile_cells=int(rng.integers(1, 5)))
    calls = []
    tiled = routing._tiled_search

    def counted(graph, lat, extra, source, target, *args, **kwargs):
        calls.append(target is None)
        return tiled(graph, lat, extra, source, target, *args, **kwargs)

    routing._tiled_search = counted
    try:
        for _ in range(3):
            a, b = (int(v) for v in rng.choice(len(segs.xy), 2, replace=False))
            s, t = whole.node_vertex(a), whole.node_vertex(b)
            old = find_route(whole, s, t, options=opts)
            for o in (opts, tiny):
                new = find_route(implicit, s, t, options=o)
                assert (old is None) == (new is None)
                if old is not None:
                    assert new.cost == pytest.approx(old.cost, rel=1e-9, abs=1e-6)
    finally:
        routing._tiled_search = tiled
    assert any(calls)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_shell_stitches_carried_over_from_last_year_equal_those_checked_afresh(seed):
    """Issue 22: a year's street part reuses last year's street tests of the shell stitches that
    nothing changed near (``ShellVerdicts``); with streets added and removed between the two
    years, the stitches equal those of a street part made from scratch."""
    from osm_expand.engine.roads.path_graph import street_part
    rng = np.random.default_rng(seed)
    extent = (0, 0, 1200, 1200)
    lines = grid_lines(300, 300, int(rng.integers(3, 6)), 120.0)
    lat = build_lattice(extent, water=river(extent, 1000, 1060), options=LatticeOptions(radius=2))

    def part(lines, previous=None):
        return street_part(*_grid_year(lat, lines), previous=previous)

    first = part(lines)
    later = [lines[k] for k in range(len(lines)) if k != int(rng.integers(len(lines)))]  # one street goes
    for _ in range(int(rng.integers(1, 4))):  # and a few come, some across the shell
        a = rng.uniform(150, 1000, 2)
        later.append(np.stack([a, a + rng.uniform(-250, 250, 2)]))
    fresh, carried = part(later), part(later, first.verdicts)
    assert first.verdicts is not None
    for x, y in zip(fresh.shell, carried.shell):
        assert np.array_equal(x, y)
    assert np.array_equal(fresh.verdicts.clear, carried.verdicts.clear)
    # the stitches to the lattice likewise, carried from the last G′'s searched windows
    def graph(lines, previous=None):
        return implicit_graph(*_grid_year(lat, lines), previous_lattice=previous)

    box = tuple(float(v) for v in (*rng.uniform(0, 250, 2), *rng.uniform(950, 1200, 2)))
    last = graph(lines)
    last.window(box)
    assert last.lattice_verdicts() is not None
    new, old = graph(later).window(box).graph, graph(later, last.lattice_verdicts()).window(box).graph
    for name in ("src", "dst", "kind", "weight"):
        assert np.array_equal(getattr(new, name), getattr(old, name))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sets(st.sampled_from(list(EdgeKind)), max_size=8))
def test_which_lattice_entries_are_of_some_kinds_is_the_lookup_table_answer(seed, kinds):
    """Issue 22: G′'s lattice masks are made by one comparison per lattice kind asked for (four
    times faster than a 256-entry table indexed by the whole ``(V, D)`` table); the same answer."""
    from osm_expand.engine.roads.path_graph import LATTICE_KINDS, _of_kinds

    rng = np.random.default_rng(seed)
    table = rng.choice(np.array([*map(int, LATTICE_KINDS), NO_EDGE], dtype=np.uint8), size=(50, 120))
    lookup = np.zeros(256, dtype=bool)
    lookup[[int(k) for k in kinds]] = True
    assert np.array_equal(_of_kinds(table, kinds), lookup[table])


def test_a_years_windows_share_one_reading_of_the_last_verdicts():
    """Issue 22: every window of a year checks its new stitches against the same last G′ and the
    same streets: the segments added or removed since are found (and put in a tree) once a year,
    not once a window, and the stitches are those of a G′ checked afresh."""
    import osm_expand.engine.roads.stitches as stitches_module

    extent = (0, 0, 1200, 1200)
    lines = grid_lines(300, 300, 4, 120.0)
    lat = build_lattice(extent, water=river(extent, 1000, 1060), options=LatticeOptions(radius=2))

    def graph(lines, previous=None):
        return implicit_graph(*_grid_year(lat, lines), previous_lattice=previous)

    last = graph(lines)
    last.window((0.0, 0.0, 1200.0, 1200.0))
    later = lines[1:] + [np.array([[310.0, 250.0], [700.0, 180.0]])]
    boxes = [(250.0, 250.0, 500.0, 500.0), (150.0, 150.0, 800.0, 800.0), (0.0, 0.0, 1200.0, 1200.0)]
    trees = []
    tree = shapely.STRtree
    carried = graph(later, last.lattice_verdicts())
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(stitches_module.shapely, "STRtree", lambda g, **kw: trees.append(len(g)) or tree(g, **kw))
        windows = [carried.window(b).graph for b in boxes]
    assert len(carried.stitches["verdicts"]) >= 2  # several windows checked stitches
    assert len(trees) == 1  # the changed segments' tree, made once
    fresh = graph(later)
    for b, old in zip(boxes, windows):
        new = fresh.window(b).graph
        for name in ("src", "dst", "kind", "weight"):
            assert np.array_equal(getattr(new, name), getattr(old, name))


def _grid_year(lat, lines):
    """A year of a made-up town: its lattice with B, its segments and B (the arguments of ``street_part`` and
    ``implicit_graph``)."""
    segs = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    return lat.with_built_up(built.area), segs, built


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_stitch_targets_a_point_can_reach_hold_every_vertex_within_the_radius(seed):
    """Issue 22: a window's stitches search a tree of only the live land vertices near the points
    being stitched (``within_reach``), not of every one of the window's (~5·10⁵ on Campo Grande's
    map). Every vertex within the radius of a point is kept, points off the window too, so the
    pairs are those of the search over them all."""
    from osm_expand.engine.roads.stitches import nearest_pairs, within_reach

    rng = np.random.default_rng(seed)
    extent = (0, 0, 1000, 800)
    lat = build_lattice(extent, options=LatticeOptions(radius=2))
    rows, cols = (int(v) for v in rng.integers(0, 20, 2))
    sub = lat.window(rows, cols, int(rng.integers(5, 40)), int(rng.integers(5, 50)))
    x0, y0, x1, y1 = sub.bounds
    points = rng.uniform([x0 - 150, y0 - 150], [x1 + 150, y1 + 150], (int(rng.integers(1, 30)), 2))
    vertices = np.flatnonzero(rng.random(sub.n_vertices) < 0.8)
    radius = float(rng.uniform(10, 120))
    kept = within_reach(sub, points, vertices, radius)
    d = np.hypot(*(sub.vertex_xy(vertices)[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    assert kept[(d <= radius).any(axis=1)].all()
    ids = np.arange(len(points)) + sub.n_vertices
    xy = np.concatenate([sub.vertex_xy(), points])
    for k in (1, 4, 16):
        every = nearest_pairs(points, xy[vertices], ids, vertices, k, radius, keys=sub.map_vertex(vertices))
        near = vertices[kept]
        assert np.array_equal(every, nearest_pairs(points, xy[near], ids, near, k, radius,
                                                   keys=sub.map_vertex(near)))


def test_a_second_pair_or_a_later_year_on_the_same_krems_streets_gets_the_g_prime_made_afresh(monkeypatch):
    """Issue 22: a year's second short pair on the very same city (the first was re-routed) is
    handed the last G′ again, with its own capacities, instead of making the street part anew.
    On Krems' default run, at every road year (the town grown by then), that G′ equals the one
    made afresh from the same memory: street part, capacities, and a window searched on each; and
    so does the G′ of a later year in which nothing was built."""
    from conftest import FIXTURES, expanded_and_matured

    import osm_expand.engine.roads.major_roads as mr
    import osm_expand.engine.roads.path_graph as pg
    from osm_expand.ingest import load

    made = []
    graph_of = mr._graph
    streets_of = pg.street_part
    calls = [0]

    def counted(*args, **kwargs):
        calls[0] += 1
        return streets_of(*args, **kwargs)

    def checked(city, traffic, memory, now, history):
        graph, memory = graph_of(city, traffic, memory, now, history)
        before = calls[0]
        # a re-route then leaves another capacity on the segments: the street part does not read it
        other = replace(traffic, trade=replace(traffic.trade, routes=()))
        again, kept = graph_of(city, other, memory, now, history)
        assert calls[0] == before and kept is memory  # nothing made again
        fresh, _ = graph_of(city, other, replace(memory, last=None), now, history)
        assert calls[0] == before + 1
        assert again.segments is not graph.segments
        assert np.array_equal(again.segments.available, fresh.segments.available, equal_nan=True)
        for name in ("extendible", "split_xy", "split_parent", "pieces", "xy", "points"):
            assert np.array_equal(getattr(again.streets, name), getattr(fresh.streets, name))
        for x, y in zip((*again.streets.edges, *again.streets.shell), (*fresh.streets.edges, *fresh.streets.shell)):
            assert np.array_equal(x, y)
        x0, y0, x1, y1 = city.bounds_xy
        box = (x0 + 0.3 * (x1 - x0), y0 + 0.3 * (y1 - y0), x0 + 0.7 * (x1 - x0), y0 + 0.7 * (y1 - y0))
        a, b = again.window(box).graph, fresh.window(box).graph
        for name in ("lat_kind", "src", "dst", "kind", "segment", "weight"):
            assert np.array_equal(getattr(a, name), getattr(b, name))
        # a later year in which nothing was built: another city, other costs, the same streets and B
        next_city = city.replace(year=(city.year or 0) + 1)
        next_now = replace(now, year=now.year + 1, costs=replace(now.costs, major=0.9 * now.costs.major,
                                                                 bridge=1.1 * now.costs.bridge))
        later, _ = graph_of(next_city, other, memory, next_now, history)
        assert calls[0] == before + 1  # the street part was not made again
        made_again, _ = graph_of(next_city, other, replace(memory, last=None), next_now, history)
        assert later.costs == made_again.costs != graph.costs
        for x, y in zip((*later.streets.edges, *later.streets.shell),
                        (*made_again.streets.edges, *made_again.streets.shell)):
            assert np.array_equal(x, y)
        c, d = later.window(box).graph, made_again.window(box).graph
        for name in ("lat_kind", "src", "dst", "kind", "segment", "weight"):
            assert np.array_equal(getattr(c, name), getattr(d, name))
        made.append(len(graph.segments))
        return graph, memory

    monkeypatch.setattr(pg, "street_part", counted)
    monkeypatch.setattr(mr, "_graph", checked)
    expanded_and_matured(load(FIXTURES / "krems.osm.gz"), history="example")
    assert len(made) >= 3 and made[-1] > made[0]  # several road years, the town grown between them


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_box_test_keeps_every_stitch_near_a_changed_segment(seed):
    """Issue 22: a carried stitch is measured against the segments added or removed since only if
    its box comes near one of theirs (``near_boxes``); every stitch within the distance of one
    of them is among those, so the verdicts carried are those a fresh check gives."""
    from osm_expand.engine.roads.stitches import near_boxes

    rng = np.random.default_rng(seed)
    span = float(rng.uniform(50, 5000))
    changed = rng.uniform(0, span, (int(rng.integers(1, 20)), 2, 2))
    changed[:, 1] = changed[:, 0] + rng.normal(0, span / 10, (len(changed), 2))
    a = rng.uniform(-span / 4, 1.25 * span, (400, 2))
    ends = np.stack([a, a + rng.normal(0, 60, (400, 2))], axis=1)
    distance = float(rng.uniform(0, 20))
    boxes = np.concatenate([changed.min(axis=1), changed.max(axis=1)], axis=1)
    kept = near_boxes(ends, boxes, distance)
    tree = shapely.STRtree(shapely.linestrings(changed))
    hit, _ = tree.query(shapely.linestrings(ends), predicate="dwithin", distance=distance)
    assert kept[hit].all()
    assert not near_boxes(ends, boxes[:0], distance).any()


def test_dry_verdicts_are_carried_only_on_the_ground_they_were_made_on(monkeypatch):
    """Issue 22: a shell stitch last year's verdicts hold is taken as dry without sampling the
    rasters again, but only on the very rasters it was found dry on: with a river across the
    town on this year's lattice, the stitches equal those checked afresh (none crosses it)."""
    from osm_expand.engine.roads import stitches
    from osm_expand.engine.roads.path_graph import street_part

    sampled = [0]  # stitches whose dryness was sampled along the rasters (stitches._dry's rows)
    dry = stitches._dry

    def counted(lattice, xy, pairs, opts):
        sampled[-1] += len(pairs)
        return dry(lattice, xy, pairs, opts)

    monkeypatch.setattr(stitches, "_dry", counted)
    extent = (0, 0, 1200, 1200)
    # dead-end streets facing each other across where the river will run (no block: all on the shell)
    lines = [np.array([[x, y0], [x, y0 + 160.0]]) for x in range(300, 901, 100) for y0 in (300.0, 540.0)]
    dry_land = build_lattice(extent, options=LatticeOptions(radius=2))
    wet = build_lattice(extent, water=river(extent, 470, 530), options=LatticeOptions(radius=2))
    last = street_part(*_grid_year(dry_land, lines))
    sampled.append(0)
    fresh = street_part(*_grid_year(wet, lines))
    sampled.append(0)
    carried = street_part(*_grid_year(wet, lines), previous=last.verdicts)
    assert len(fresh.shell[0]) < len(last.shell[0])  # the river took some stitches
    for x, y in zip(fresh.shell, carried.shell):
        assert np.array_equal(x, y)
    sampled.append(0)
    again = street_part(*_grid_year(wet, lines), previous=fresh.verdicts)  # the same ground: carried
    for x, y in zip(fresh.shell, again.shell):
        assert np.array_equal(x, y)
    _, on_fresh, on_other_ground, on_same_ground = sampled
    assert on_fresh > 0
    assert on_other_ground == on_fresh  # last year's ground was dry land: every stitch sampled again
    assert on_same_ground < on_fresh  # the verdicts made on this ground spared their stitches' samples


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_nearest_pairs_asks_again_only_the_points_tied_at_their_kth_candidate(seed):
    """Issue 22: a point whose k-th nearest candidate ties with the last one asked for is asked
    again for more, and only it (asking every point again made the shell's stitches a third of
    a year's street part on Campo Grande's grid); the pairs are the brute-force ones: each point's
    ``k`` nearest within the radius, equally near ones by key."""
    import osm_expand.engine.roads.stitches as stitches_module
    from osm_expand.engine.roads.stitches import nearest_pairs

    rng = np.random.default_rng(seed)
    # integer candidates on a grid and a ring of them round the origin: many exact ties
    grid = np.stack(np.meshgrid(np.arange(-6, 7), np.arange(-6, 7)), axis=-1).reshape(-1, 2) * 10.0
    ring = np.array([[30.0, 40.0], [40.0, 30.0], [-30.0, 40.0], [-40.0, 30.0], [30.0, -40.0], [40.0, -30.0],
                     [-30.0, -40.0], [-40.0, -30.0], [50.0, 0.0], [0.0, 50.0], [-50.0, 0.0], [0.0, -50.0]])
    to_xy = np.unique(np.concatenate([grid, ring]), axis=0)
    to_xy = to_xy[rng.permutation(len(to_xy))]
    far = rng.uniform(-65, 65, (int(rng.integers(5, 40)), 2))  # off the grid: rarely a tie
    from_xy = np.concatenate([[[0.0, 0.0]], [[5.0, 5.0]], far])
    k, radius = int(rng.integers(1, 10)), float(rng.uniform(20, 90))
    keys = rng.permutation(len(to_xy))
    asked: list[int] = []

    class Counted(stitches_module.cKDTree):
        def query(self, x, *args, **kwargs):
            asked.append(len(x))
            return super().query(x, *args, **kwargs)

    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(stitches_module, "cKDTree", Counted)
        pairs = nearest_pairs(from_xy, to_xy, np.arange(len(from_xy)), np.arange(len(to_xy)), k, radius, keys=keys)
    expected = []
    for i, p in enumerate(from_xy):
        d = np.sqrt(((to_xy - p) ** 2).sum(axis=1))
        near = np.flatnonzero(d <= radius)
        near = near[np.lexsort((keys[near], d[near]))][:k]
        expected += [[i, j] for j in near.tolist()]
    assert pairs.tolist() == expected
    assert asked[0] == len(from_xy) and all(n < len(from_xy) for n in asked[1:])


def test_b_tests_only_the_segments_last_years_b_was_not_made_with():
    """Issue 22: next year's B buffers only the segments it does not hold yet; a segment last
    year's B was made with lies in it and is not tested again (three points a segment in a
    polygon of the whole town was a fifth of B's year on Campo Grande): only the new ones are,
    and B is the one made testing them all."""
    import osm_expand.engine.roads.built_up as built_up_module

    segs = SegmentTable.from_lines(grid_lines(100, 100, 4, 60), major=[False] * 10, width=[6.0] * 10)
    first = built_up_area(blocks_of(segs), segs)
    lines = grid_lines(100, 100, 4, 60) + [np.array([[340.0, 160.0], [420.0, 160.0], [420.0, 400.0]])]
    segs2 = SegmentTable.from_lines(lines, major=[False] * 11, width=[6.0] * 11)
    tested: list[int] = []
    contains_xy = shapely.contains_xy
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(built_up_module.shapely, "contains_xy",
                       lambda g, x, y: tested.append(len(np.atleast_1d(x))) or contains_xy(g, x, y))
        second = built_up_area(blocks_of(segs2), segs2, previous=first)
    old = {(tuple(a), tuple(b)) for a, b in zip(segs.a.tolist(), segs.b.tolist())}
    new = sum((tuple(a), tuple(b)) not in old for a, b in zip(segs2.a.tolist(), segs2.b.tolist()))
    assert 0 < new < len(segs2.uv) and tested == [new] * 3
    fresh = built_up_area(blocks_of(segs2), segs2, previous=first.__class__(first.area, first.blocks))
    assert shapely.equals_exact(second.area, fresh.area, 0.0)


def test_a_segments_end_key_is_the_same_either_way_round_and_another_when_it_moves():
    """Issue 22 (review 33, 5): B's held segments and the stitches' carried street verdicts key a
    segment by its ends with one helper, the lesser end first: a street drawn the other way round
    keeps its segments' keys, a street moved by a micrometre does not."""
    lines = grid_lines(100, 100, 3, 60)
    segs = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    back = SegmentTable.from_lines([line[::-1] for line in lines], major=[False] * len(lines),
                                   width=[6.0] * len(lines))
    assert not np.array_equal(segs.a, back.a)  # the table holds them the other way round
    assert sorted(segs.end_keys().tolist()) == sorted(back.end_keys().tolist())  # each street reversed
    moved = SegmentTable.from_lines([line + 1e-6 for line in lines], major=[False] * len(lines),
                                    width=[6.0] * len(lines))
    assert not set(segs.end_keys().tolist()) & set(moved.end_keys().tolist())
    ends = SegmentTable.ends_of_keys(segs.end_keys())  # the layout's reader, beside its writer (review 33b, 10)
    assert ends.shape == (len(segs.uv), 2, 2)
    assert np.array_equal(np.sort(ends.reshape(-1, 4), axis=1),
                          np.sort(np.concatenate([segs.a, segs.b], axis=1), axis=1))
    assert np.array_equal(SegmentTable.ends_of_keys(segs.end_keys()[::2]), ends[::2])  # a strided view too


def test_a_kind_mask_reads_by_row_blocks_as_the_whole_table_and_hashes_by_identity(monkeypatch):
    """Review 33b (6, 7): :class:`KindMask` holds the row-block size once; its per-row counts and
    ``any`` (over all rows or given ones) are the whole table's, however small the blocks; it can
    be hashed (a frozen dataclass with an array field could not) and gives the dtype asked for."""
    lat = build_lattice((0, 0, 400, 400), water=river((0, 0, 400, 400), 150, 220),
                        options=LatticeOptions(radius=3))
    kind, _ = lat.directed_tables()
    mask = path_graph.KindMask(kind, path_graph._lattice_key((EdgeKind.LAND, EdgeKind.BRIDGE)))
    whole = np.isin(kind, [EdgeKind.LAND, EdgeKind.BRIDGE])
    assert whole.any() and not whole.all(axis=1).all()
    rows = np.random.default_rng(0).permutation(len(kind))[: len(kind) // 2]
    for entries in (1 << 22, kind.shape[1] * 7, 1):  # one block, several with a short last one, one row each
        monkeypatch.setattr(path_graph, "_BLOCK_ENTRIES", entries)
        blocks = list(mask.row_blocks())
        assert blocks[0][0] == 0 and blocks[-1][1] == len(kind)
        assert all(b0[1] == b1[0] for b0, b1 in zip(blocks, blocks[1:]))
        assert np.array_equal(mask.count_per_row(), whole.sum(axis=1))
        assert np.array_equal(mask.count_per_row(rows), whole[rows].sum(axis=1))
        assert np.array_equal(mask.any_per_row(), whole.any(axis=1))
    assert {mask: 1}[mask] == 1 and mask != path_graph.KindMask(kind, mask.kinds)  # by identity
    assert np.array_equal(np.asarray(mask), whole) and np.asarray(mask).dtype == bool
    as_int = np.asarray(mask, dtype=np.int64)
    assert as_int.dtype == np.int64 and np.array_equal(as_int, whole)


def test_b_does_not_test_again_a_segment_last_years_b_held_the_other_way_round():
    """Issue 22 (review 33, 5): a segment last year's B was made with is held whichever way round
    the table now holds it (B's key of it was the ends in the table's order, so a street drawn
    the other way round was tested again); B is the one made testing them all."""
    import osm_expand.engine.roads.built_up as built_up_module

    lines = grid_lines(100, 100, 4, 60)
    segs = SegmentTable.from_lines(lines, major=[False] * 10, width=[6.0] * 10)
    first = built_up_area(blocks_of(segs), segs)
    back = SegmentTable.from_lines([line[::-1] for line in lines], major=[False] * 10, width=[6.0] * 10)
    tested: list[int] = []
    contains_xy = shapely.contains_xy
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(built_up_module.shapely, "contains_xy",
                       lambda g, x, y: tested.append(len(np.atleast_1d(x))) or contains_xy(g, x, y))
        second = built_up_area(blocks_of(back), back, previous=first)
    assert tested == [] and second.area is first.area  # nothing new: B as it was
    fresh = built_up_area(blocks_of(back), back, previous=first.__class__(first.area, first.blocks))
    assert shapely.equals_exact(shapely.normalize(second.area), shapely.normalize(fresh.area), 0.0)


def test_the_stitch_key_hash_takes_no_keys_and_refuses_keys_of_broken_words():
    """Review 33, 14: ``_hash`` of no keys is no hashes (it raised: ``reshape(0, -1)``), and a key
    that is not whole 8-byte words is refused rather than read across rows."""
    from osm_expand.engine.roads.stitches import _hash

    assert _hash(np.zeros(0, dtype="V40")).shape == (0,)
    keys = np.ascontiguousarray(np.arange(10.0).reshape(2, 5)).view("V40").ravel()
    assert _hash(keys).shape == (2,) and _hash(keys)[0] != _hash(keys)[1]
    with pytest.raises(AssertionError):
        _hash(np.zeros(3, dtype="V12"))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 40), st.integers(0, 40))
def test_changed_segment_keys_are_those_not_found_as_many_times_in_the_other_year(seed, n_new, n_old):
    """Issue 22: the segments added or removed since the last verdicts (``stitches.changed_keys``,
    one sort of the keys' words) are those the count of each key's bytes in Python sets gave (the
    old code, kept here as the reference): every copy of a key found a different number of times in
    the two years, ``new``'s indices first, then ``old``'s shifted by ``len(new)``; 0.0 and -0.0 differ
    as bytes do. Keys from a handful of values, so repeats and keys in only one year are common."""
    from collections import Counter

    from osm_expand.engine.roads.stitches import changed_keys

    rng = np.random.default_rng(seed)
    values = np.array([0.0, -0.0, 1.5, 2.0, 1e-9])

    def keys(n):
        return np.ascontiguousarray(rng.choice(values, size=(n, 4))).view("V32").ravel()

    new, old = keys(n_new), keys(n_old)
    old_n, new_n = Counter(old.tolist()), Counter(new.tolist())
    same = {k for k, n in new_n.items() if old_n.get(k) == n}
    want = np.concatenate([np.flatnonzero([k not in same for k in new.tolist()]).astype(np.int64),
                           n_new + np.flatnonzero([k not in same for k in old.tolist()]).astype(np.int64)])
    got = changed_keys(new, old)
    assert got.dtype == np.int64 and np.array_equal(got, want)
    assert not len(changed_keys(new, new.copy()))


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_stitch_tests_against_the_built_up_blocks_are_carried_where_no_block_changed(seed):
    """Issue 22: a stitch clear of the streets last year and now, away from every block that became
    or stopped being built-up since (``BuiltUpArea.changed``), keeps its verdict on the built-up
    blocks: only the others are made lines and tested again (every clear stitch was, a quarter of
    a year's stitches on Campo Grande). With a street gone (two blocks become one) and new ones,
    the shell and the windows' stitches equal those checked afresh."""
    import osm_expand.engine.roads.stitches as stitches_module
    from osm_expand.engine.roads.path_graph import street_part

    rng = np.random.default_rng(seed)
    extent = (0, 0, 1200, 1200)
    n = int(rng.integers(3, 6))
    lines = grid_lines(300, 300, n, 120.0)
    lat = build_lattice(extent, water=river(extent, 1000, 1060), options=LatticeOptions(radius=2))
    segs = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    built = built_up_area(blocks_of(segs), segs)
    gone = int(rng.choice([k for k in range(len(lines)) if 0 < k // 2 < n]))  # two blocks become one
    later = [line for k, line in enumerate(lines) if k != gone]
    for _ in range(int(rng.integers(1, 4))):
        a = rng.uniform(150, 1000, 2)
        later.append(np.stack([a, a + rng.uniform(-250, 250, 2)]))
    segs2 = SegmentTable.from_lines(later, major=[False] * len(later), width=[6.0] * len(later))
    built2 = built_up_area(blocks_of(segs2), segs2, previous=built)
    assert built2.changed is not None and built2.changed.since is built.blocks and len(built2.changed.boxes)
    lat1, lat2 = lat.with_built_up(built.area), lat.with_built_up(built.area).with_built_up(built2.area, built2.added)
    first = street_part(lat1, segs, built)
    intersects = shapely.intersects

    def counted(run: Callable[[], StreetPart]) -> tuple[StreetPart, int]:
        """``run()`` and how many stitches it tested with ``shapely.intersects`` (patched on the
        shapely module itself, so every caller is counted: each run in a context of its own)."""
        tested: list[int] = []
        with pytest.MonkeyPatch.context() as monkey:
            monkey.setattr(stitches_module.shapely, "intersects",
                           lambda a, b: tested.append(len(np.atleast_1d(b))) or intersects(a, b))
            return run(), sum(tested)

    carried, n_carried = counted(lambda: street_part(lat2, segs2, built2, previous=first.verdicts))
    fresh, n_fresh = counted(lambda: street_part(lat2, segs2, built2))
    assert n_carried < n_fresh  # fewer tested than afresh
    for x, y in zip(fresh.shell, carried.shell, strict=True):
        assert np.array_equal(x, y)
    box = tuple(float(v) for v in (*rng.uniform(0, 250, 2), *rng.uniform(950, 1200, 2)))
    last = implicit_graph(lat1, segs, built)
    last.window(box)
    new = implicit_graph(lat2, segs2, built2).window(box).graph
    old = implicit_graph(lat2, segs2, built2, previous_lattice=last.lattice_verdicts()).window(box).graph
    for name in ("src", "dst", "kind", "weight"):
        assert np.array_equal(getattr(new, name), getattr(old, name))


@settings(max_examples=10, deadline=None)
@given(st.integers(3, 5), st.floats(40, 90), st.integers(0, 2**32 - 1))
def test_b_of_the_very_blocks_and_segments_of_last_year_is_the_b_made_of_copies(n, size, seed):
    """Issue 22: B keeps the key of each block that is one of the very polygon objects last year's B
    was made from, and takes every segment as held when the table shares last year's segment keys
    (the road step's second call of a year, a year with nothing built): the same B, blocks, verdicts
    and held segments as from copies of them, which are keyed and tested afresh."""
    rng = np.random.default_rng(seed)
    lines = grid_lines(100, 100, n, size)
    segs = SegmentTable.from_lines(lines, major=[False] * len(lines), width=[6.0] * len(lines))
    blocks = blocks_of(segs)
    water = shapely.box(0, 0, 2000, 100 + float(rng.uniform(5, size)))  # wets the first row of blocks
    first = built_up_area(blocks, segs, water=water)
    # this year: some of last year's very blocks, one street more (a new block split off), and copies
    extra = np.array([[100.0, 100.0 + size / 2], [100.0 + size, 100.0 + size / 2]])
    segs2 = SegmentTable.from_lines([*lines, extra], major=[False] * (len(lines) + 1), width=[6.0] * (len(lines) + 1))
    keep = [b for b in blocks if rng.random() < 0.7]
    later = keep + [b for b in blocks_of(segs2) if not any(shapely.equals(b, k) for k in keep)]
    copies = list(shapely.from_wkb(shapely.to_wkb(np.array(later, dtype=object))))
    for table in (segs, segs2):
        same = replace(table, width=table.width.copy())  # another table of the same ends
        same._cache.update(end_keys=table.end_keys())
        for made, fresh in ((built_up_area(later, same, water=water, previous=first),
                             built_up_area(copies, replace(table), water=water, previous=first)),):
            assert shapely.to_wkb(made.area) == shapely.to_wkb(fresh.area)
            assert shapely.to_wkb(made.blocks) == shapely.to_wkb(fresh.blocks)
            assert made.verdicts == fresh.verdicts and made.segments == fresh.segments
            assert np.array_equal(made.keys, fresh.keys)
            assert [shapely.to_wkb(g) for g in made.added] == [shapely.to_wkb(g) for g in fresh.added]
    # nothing changed at all: the very B again, nothing added
    again = built_up_area(blocks, segs, water=water, previous=first)
    assert again.area is first.area and again.blocks is first.blocks and not len(again.added)


def _order_by_lexsort(src, dst, weight):
    """The reference for :func:`path_graph._edge_order`: one lexsort by (tail, head, weight), the first of
    each (tail, head) kept."""
    order = np.lexsort((weight, dst, src))
    first = np.ones(len(order), dtype=bool)
    first[1:] = (src[order][1:] != src[order][:-1]) | (dst[order][1:] != dst[order][:-1])
    return order[first]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 300), st.integers(0, 600), st.booleans())
def test_g_primes_edges_sorted_by_one_key_are_those_of_the_lexsort(seed, n, m, special):
    """Issue 22: G′'s undirected edges are put in (tail, head) order by one stable sort of an int64
    key, only the parallel ones ordered by weight: the edges, their order and which of parallel
    edges is kept (the cheapest, the first of equal weight) are those of the lexsort, with ties,
    NaN and infinite weights."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 100, (n, 2))
    parts = []
    for _ in range(int(rng.integers(1, 3))):
        k = int(rng.integers(0, m + 1))
        weight = (rng.choice([1.0, 2.0, np.nan, np.inf], k) if special else np.round(rng.uniform(0, 3, k), 1))
        parts.append((rng.integers(0, n, k), rng.integers(0, n, k), rng.integers(0, 5, k).astype(np.uint8),
                      rng.integers(-1, 20, k), rng.uniform(0, 9, k), weight))
    u, v, kind, seg, length, weight = (np.concatenate([p[i] for p in parts]) for i in range(6))
    src, dst = np.concatenate([u, v]), np.concatenate([v, u])  # both ways: the forward edges, then the backward
    kind, seg, length, weight = (np.concatenate([a, a]) for a in (kind, seg, length, weight))
    order = _order_by_lexsort(src, dst, weight)
    assert np.array_equal(path_graph._edge_order(src, dst, weight, n), order)
    # the edges themselves are taken in that order, each with its heading tail to head
    got = path_graph._sorted_edges(parts, xy)
    for g, want in zip(got, (src, dst, kind, seg, length, weight)):
        assert g.dtype == want.dtype and np.array_equal(g, want[order], equal_nan=want.dtype.kind == "f")
    d = xy[dst[order]] - xy[src[order]]
    turn = np.angle(np.exp(1j * (got[6] - np.arctan2(d[:, 1], d[:, 0]))))
    assert got[6].dtype == np.float64 and np.allclose(turn, 0.0, atol=1e-12)


def test_a_year_that_only_made_streets_major_gets_last_years_street_part_with_the_new_kinds():
    """Issue 22: which streets are major is read by the street part only for its pieces' kinds and
    weights, which ``street_part_again`` works out anew: a year whose streets differ from the last
    G′'s only in that gets its street part again (``_same_street_part``), equal to one made afresh."""
    from types import SimpleNamespace

    from osm_expand.engine.roads.major_roads import _same_street_part
    from osm_expand.engine.roads.path_graph import street_part, street_part_again

    extent = (0, 0, 1200, 1200)
    lat = build_lattice(extent, water=river(extent, 1000, 1060), options=LatticeOptions(radius=2))
    lattice, segs, built = _grid_year(lat, grid_lines(300, 300, 4, 120.0))
    graph = implicit_graph(lattice, segs, built)
    history = SimpleNamespace(options=SimpleNamespace(graph=graph.options))  # all _same_street_part reads of it
    made_major = replace(segs, major=np.arange(len(segs.uv)) % 3 == 0)
    assert (made_major.major != segs.major).any()
    assert _same_street_part(graph, lattice, built, made_major, history)
    assert not _same_street_part(graph, lattice, built, replace(made_major, width=made_major.width + 1.0), history)
    costs = EdgeCosts(major=0.3)
    again = street_part_again(graph.streets, lattice, made_major, costs)
    fresh = street_part(lattice, made_major, built, costs=costs, options=graph.options)
    for x, y in zip((*again.edges, *again.shell, *again.sorted_edges), (*fresh.edges, *fresh.shell, *fresh.sorted_edges)):
        assert np.array_equal(x, y)
    assert set(np.unique(again.edges[2]).tolist()) == {int(EdgeKind.MAJOR), int(EdgeKind.MINOR)}
