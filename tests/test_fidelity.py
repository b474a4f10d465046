"""The fidelity score: measures on hand-built networks with known answers, and the verdict on Krems."""
from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial import cKDTree
from scipy.stats import ks_2samp

from osm_expand.errors import InputError
from osm_expand.fidelity import FidelityOptions, compare, fidelity, judge, ks_distance, real_parts, town_reference
from osm_expand.measures import (
    DISTRIBUTIONS,
    LineSet,
    Measure,
    MeasureOptions,
    count_pieces,
    junction_points,
    measure_network,
    orientation_entropy,
    two_core,
)
from tests.conftest import loaded


def grid(n: int = 11, step: float = 100.0, stub: float = 50.0, origin=(0.0, 0.0), turn: float = 0.0):
    """n × n junctions ``step`` apart, every street running ``stub`` metres past the last one."""
    span = np.arange(n) * step
    ends = np.r_[-stub, span, span[-1] + stub]
    rows = [np.column_stack([ends, np.full(n + 2, y)]) for y in span]
    cols = [np.column_stack([np.full(n + 2, x), ends]) for x in span]
    c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
    rot = np.array([[c, s], [-s, c]])
    return [ln @ rot + np.asarray(origin) for ln in rows + cols]


def ring(radius: float = 200.0, n: int = 2000, pieces: int = 1):
    t = np.linspace(0.0, 2 * np.pi, n + 1)
    pts = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    pts[-1] = pts[0]
    cuts = np.linspace(0, n, pieces + 1).astype(int)
    return [pts[a:b + 1] for a, b in zip(cuts, cuts[1:])]


def binary_tree(depth: int = 3, length: float = 100.0):
    """A root stub going north, then each node forks into two branches ±45° off its heading."""
    lines = [np.array([[0.0, -length], [0.0, 0.0]])]
    tips = [(np.zeros(2), math.pi / 2, length)]
    for _ in range(depth):
        nxt = []
        for p, heading, ln in tips:
            for turn in (-math.pi / 4, math.pi / 4):
                h = heading + turn
                q = p + ln / 2 * np.array([math.cos(h), math.sin(h)])
                lines.append(np.array([p, q]))
                nxt.append((q, h, ln / 2))
        tips = nxt
    return lines


def zigzag(n: int = 10, step: float = 20.0, angle: float = 30.0):
    a = math.radians(angle)
    d = np.array([[step * math.cos(a), step * math.sin(a) * (1 if k % 2 == 0 else -1)] for k in range(n)])
    return [np.vstack([[0.0, 0.0], np.cumsum(d, axis=0)])]


def tangle(centre, area: float, rng: np.random.Generator, n: int = 150, length: float = 200.0):
    """Random straight chords at random angles in a disc, noded where they cross."""
    r = math.sqrt(area / math.pi)
    ang = rng.uniform(0, 2 * np.pi, n)
    rad = r * np.sqrt(rng.uniform(0, 1, n))
    mid = np.asarray(centre) + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    head = rng.uniform(0, np.pi, n)
    half = length / 2 * np.column_stack([np.cos(head), np.sin(head)])
    segs = shapely.linestrings(np.stack([mid - half, mid + half], axis=1))
    noded = shapely.get_parts(shapely.union_all(segs))
    return [shapely.get_coordinates(g) for g in noded]


# ---------------------------------------------------------------- measures with known answers


def test_a_perfect_grid_has_right_angles_square_blocks_and_four_way_junctions():
    m = measure_network(grid())
    assert (m.junctions, m.dead_ends, m.open_ends, m.edges, m.blocks) == (121, 44, 0, 264, 100)
    assert sorted(set(m.edge_length.round(6))) == [50.0, 100.0]
    np.testing.assert_allclose(m.circuity, 1.0)
    np.testing.assert_allclose(m.junction_angle, 90.0)
    assert len(m.junction_angle) == 4 * 121
    np.testing.assert_allclose(m.stroke_length, 1100.0)  # every street is one stroke
    assert len(m.stroke_length) == 22
    np.testing.assert_allclose(m.block_area, 10_000.0)
    np.testing.assert_allclose(m.block_compactness, math.pi / 4)
    np.testing.assert_allclose(m.alignment, 0.0, atol=1e-9)
    np.testing.assert_allclose(m.curvature, 0.0, atol=1e-9)
    assert m.orientation_entropy == pytest.approx(math.log(4))
    assert (m.three_way_share, m.four_way_share, m.dead_end_share) == pytest.approx((0, 121 / 165, 44 / 165))


def test_the_two_core_share_of_a_grid_is_one_and_of_a_tree_zero():
    assert measure_network(grid(stub=0.0)).two_core_share == 1.0
    assert measure_network(binary_tree(depth=4)).two_core_share == 0.0
    # the grid's 44 stubs of 50 m are dead-end trees: pruned
    with_stubs = measure_network(grid())
    assert with_stubs.two_core_share == pytest.approx(1 - 44 * 50.0 / with_stubs.length)
    # a ring has no dead end; a tree hanging off it is pruned back to the ring
    circle = measure_network(ring(200.0, n=400) + [np.array([[200.0, 0.0], [300.0, 0.0], [400.0, 50.0]])])
    assert circle.two_core_share == pytest.approx(2 * math.pi * 200 / circle.length, rel=1e-4)


def test_ends_cut_by_the_window_are_not_pruned_from_the_two_core():
    # the stubs end 50 m past the grid: this window cuts them 20 m past it, so they are not dead ends
    cut = measure_network(grid(), window=shapely.box(-20, -20, 1020, 1020))
    assert cut.dead_ends == 0 and cut.two_core_share == 1.0
    # a street crossing the window through: kept; one entering and ending inside: pruned
    window = shapely.box(0, 0, 100, 100)
    lines = [np.array([[-10.0, 50.0], [110.0, 50.0]]), np.array([[50.0, -10.0], [50.0, 30.0]])]
    m = measure_network(lines, window=window)
    assert m.two_core_share == pytest.approx(100.0 / 130.0)
    assert two_core(np.array([0, 1]), np.array([1, 2]), 3, anchored=np.array([True, False, True])).all()


def test_pieces_are_the_streets_buffered_30_m_and_merged():
    assert measure_network(grid()).pieces == 1
    far = grid(n=3) + grid(n=3, origin=(1000.0, 0.0)) + [np.array([[0.0, 500.0], [10.0, 500.0]])]
    assert measure_network(far).pieces == 3
    # 59 m apart the 30 m buffers overlap; 61 m apart they do not
    assert count_pieces([np.array([[0.0, 0.0], [100.0, 0.0]]), np.array([[0.0, 59.0], [100.0, 59.0]])]) == 1
    assert count_pieces([np.array([[0.0, 0.0], [100.0, 0.0]]), np.array([[0.0, 61.0], [100.0, 61.0]])]) == 2
    union = shapely.union_all(shapely.buffer([shapely.LineString(ln) for ln in far], 30.0))
    assert len(shapely.get_parts(union)) == 3
    assert measure_network(grid(), pieces=False).pieces == -1


def test_density_is_street_length_over_the_window_area():
    window = shapely.box(-100, -100, 1100, 1100)  # 1.44 km², the stub ends 50 m inside
    m = measure_network(grid(), window=window)
    assert m.length == pytest.approx(22 * 1100.0)
    assert m.density == pytest.approx(24.2 / 1.44)
    assert m.open_ends == 0 and m.dead_ends == 44


@pytest.mark.parametrize("turn", [3.0, 40.0, 90.0])
def test_a_turned_grid_keeps_the_entropy_of_four_bins(turn):
    # bins are centred on 0°, 10°, …: a grid turned less than 5° off a bin centre still fills four
    assert measure_network(grid(turn=turn)).orientation_entropy == pytest.approx(math.log(4))


def test_a_grid_turned_half_a_bin_spreads_over_more_bins():
    assert measure_network(grid(turn=5.0)).orientation_entropy > math.log(4) + 0.1


def test_orientation_entropy_is_the_one_osm_expand_stats_reports():
    from simplify.statistics import orientation_entropy as stats_entropy

    rng = np.random.default_rng(3)
    segs = rng.uniform(-500, 500, (200, 2, 2))
    assert orientation_entropy(segs[:, 1] - segs[:, 0]) == pytest.approx(stats_entropy(segs))


@pytest.mark.parametrize("pieces", [1, 3])
def test_a_ring_has_no_junction_one_round_block_and_curvature_step_over_radius(pieces):
    radius = 200.0
    m = measure_network(ring(radius, pieces=pieces))
    assert (m.junctions, m.dead_ends, m.edges, m.blocks) == (0, 0, 1, 1)
    assert math.isnan(m.three_way_share) and math.isnan(m.dead_end_share)
    assert m.edge_length[0] == pytest.approx(2 * math.pi * radius, rel=1e-5)
    assert len(m.circuity) == 0 and len(m.junction_angle) == 0 and len(m.alignment) == 0
    np.testing.assert_allclose(m.curvature, math.degrees(20.0 / radius), atol=0.05)  # rounded to 0.1°  # samples on a 2000-gon
    assert m.block_area[0] == pytest.approx(math.pi * radius ** 2, rel=1e-5)
    assert m.block_compactness[0] == pytest.approx(1.0, abs=1e-5)
    assert m.stroke_length == pytest.approx([2 * math.pi * radius], rel=1e-5)
    assert m.orientation_entropy == pytest.approx(math.log(36), abs=1e-3)


def test_a_tree_has_no_blocks_and_its_leaves_are_its_dead_ends():
    m = measure_network(binary_tree(depth=3))
    assert (m.junctions, m.dead_ends, m.blocks) == (7, 9, 0)
    assert m.dead_end_share == pytest.approx(9 / 16)
    assert m.three_way_share == pytest.approx(7 / 16)
    assert m.four_way_share == 0.0
    # each fork: 90° between the branches, 135° between each branch and the way back
    assert sorted(m.junction_angle.round(6)) == [90.0] * 7 + [135.0] * 14
    # branches deflect 45° from the trunk: no two edges continue each other
    assert len(m.stroke_length) == m.edges == 15
    np.testing.assert_allclose(np.sort(m.stroke_length), np.sort(m.edge_length))


def test_a_zigzag_has_the_circuity_and_curvature_of_its_angle():
    m = measure_network(zigzag(n=10, step=20.0, angle=30.0))
    assert (m.edges, m.dead_ends, m.junctions) == (1, 2, 0)
    assert m.dead_end_share == 1.0
    assert m.circuity == pytest.approx([1 / math.cos(math.radians(30))])
    np.testing.assert_allclose(m.curvature, 60.0)
    assert len(m.curvature) == 9


def test_strokes_take_the_straightest_continuation_first():
    # three streets end at a junction: B continues A with 5° of deflection, C with 10°
    a = np.array([[0.0, 0.0], [100.0, 0.0]])
    b = np.array([[0.0, 0.0], [-100 * math.cos(math.radians(5)), 100 * math.sin(math.radians(5))]])
    c = np.array([[0.0, 0.0], [-60 * math.cos(math.radians(10)), -60 * math.sin(math.radians(10))]])
    m = measure_network([a, b, c])
    assert sorted(m.stroke_length.round(6)) == [60.0, 200.0]


def test_edges_run_from_junction_to_junction_across_lines():
    # one street drawn as two OSM ways meeting end to end is one edge
    m = measure_network([np.array([[0.0, 0.0], [50.0, 0.0]]), np.array([[50.0, 0.0], [50.0, 80.0]])])
    assert m.edges == 1 and m.edge_length == pytest.approx([130.0])
    assert m.circuity == pytest.approx([130.0 / math.hypot(50, 80)])


def test_loose_segments_measure_as_the_polylines_they_make():
    # the tool's XML has only segments: shared end points make the same graph as the polylines
    lines = grid(5) + ring(80.0, n=40) + zigzag(6)
    loose = [ln[k:k + 2] for ln in lines for k in range(len(ln) - 1)]
    whole, parts = measure_network(lines), measure_network(loose[::-1])
    assert (parts.junctions, parts.dead_ends, parts.edges, parts.blocks) == (
        whole.junctions, whole.dead_ends, whole.edges, whole.blocks)
    for d in DISTRIBUTIONS:
        np.testing.assert_allclose(np.sort(parts.value(d)), np.sort(whole.value(d)), atol=1e-9)


def test_a_bridge_without_a_shared_point_is_no_junction():
    m = measure_network([np.array([[-50.0, 0.0], [50.0, 0.0]]), np.array([[0.0, -50.0], [0.0, 50.0]])])
    assert (m.junctions, m.dead_ends, m.edges) == (0, 4, 2)


def test_a_street_drawn_twice_counts_once():
    once = measure_network(grid(5))
    twice = measure_network(grid(5) + grid(5)[::-1])
    assert (twice.junctions, twice.edges, twice.length) == (once.junctions, once.edges, once.length)
    for d in DISTRIBUTIONS:
        np.testing.assert_allclose(np.sort(twice.value(d)), np.sort(once.value(d)))


def test_a_grid_clipped_by_a_disc_has_open_ends_not_dead_ends():
    disc = shapely.Point(500, 500).buffer(320, quad_segs=16)
    m = measure_network(grid(), window=disc)
    assert m.dead_ends == 0 and m.dead_end_share == 0.0
    assert m.four_way_share == 1.0
    assert m.open_ends > 0 and m.cut_edges == m.open_ends
    np.testing.assert_allclose(m.edge_length, 100.0)  # cut pieces are not edges of their own length
    assert m.length == pytest.approx(shapely.intersection(shapely.MultiLineString(grid()), disc).length)
    # blocks cut by the disc are not closed
    assert 0 < m.blocks < 32 and np.allclose(m.block_area, 10_000.0)


def test_open_points_mark_where_a_district_meets_the_town():
    lines = [np.array([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]]), np.array([[100.0, 0.0], [100.0, 100.0]])]
    plain = measure_network(lines)
    joined = measure_network(lines, open_points=np.array([[0.0, 0.0], [200.0, 0.0]]))
    assert (plain.dead_ends, plain.junctions) == (3, 1)
    assert (joined.dead_ends, joined.junctions, joined.open_ends, joined.cut_edges) == (1, 1, 2, 2)
    assert joined.dead_end_share == 0.5


def test_an_empty_network_has_empty_measures():
    m = measure_network([])
    assert m.edges == 0 and all(len(m.value(d)) == 0 for d in DISTRIBUTIONS)
    assert math.isnan(m.orientation_entropy) and math.isnan(m.density)


def test_bad_options_are_input_errors():
    with pytest.raises(InputError, match="curvature_step"):
        MeasureOptions(curvature_step=0.0)
    with pytest.raises(InputError, match="ks_percentile"):
        FidelityOptions(ks_percentile=150.0)


segments = st.lists(st.tuples(*[st.floats(0, 1000, allow_nan=False)] * 4), min_size=1, max_size=25)


@given(segments)
def test_every_junction_is_ringed_by_360_degrees_and_strokes_cover_every_street(segs):
    lines = [np.array([[x0, y0], [x1, y1]]) for x0, y0, x1, y1 in segs if math.hypot(x1 - x0, y1 - y0) > 1]
    noded = shapely.get_parts(shapely.union_all(shapely.linestrings(lines))) if lines else []
    m = measure_network([shapely.get_coordinates(g) for g in noded])
    assert m.junction_angle.sum() == pytest.approx(360.0 * m.junctions, abs=0.05 * len(m.junction_angle))  # 0.1° rounding
    assert m.stroke_length.sum() == pytest.approx(m.length)
    assert np.all((m.alignment >= 0) & (m.alignment <= 45 + 1e-9))
    assert np.all(m.circuity >= 1 - 1e-9)


walks = st.lists(st.lists(st.tuples(st.integers(0, 20), st.integers(0, 20)), min_size=2, max_size=12),
                min_size=1, max_size=8)


@given(walks, st.booleans())
def test_lines_on_a_lattice_clipped_or_not_keep_their_length_in_strokes(paths, closed):
    # lines on a 50 m lattice share points where they meet, run over each other and close into rings
    lines = [np.array(p + p[:1] if closed else p, dtype=float) * 50.0 for p in paths]
    window = shapely.Point(500.0, 500.0).buffer(420.0)
    for win in (None, window):
        m = measure_network(lines, window=win)
        assert m.stroke_length.sum() == pytest.approx(m.length)
        assert m.junction_angle.sum() == pytest.approx(360.0 * m.junctions, abs=0.05 * len(m.junction_angle))
        assert m.edge_length.sum() <= m.length + 1e-6
        assert m.cut_edges <= m.edges and (win is not None or m.open_ends == 0)


# ---------------------------------------------------------------- the verdict


def test_ks_distance_is_scipys_two_sample_statistic():
    rng = np.random.default_rng(0)
    for n, k in [(5, 300), (100, 100), (40, 2000)]:
        a, b = rng.gamma(2, 50, n), rng.gamma(2.2, 45, k)
        b[:3] = a[:3]  # ties between the samples
        assert ks_distance(a, np.sort(b)) == pytest.approx(ks_2samp(a, b).statistic)
        x, y = rng.integers(0, 4, n).astype(float), rng.integers(0, 6, k).astype(float)  # ties everywhere
        assert ks_distance(x, np.sort(y)) == pytest.approx(ks_2samp(x, y).statistic)
    assert ks_distance(np.zeros(0), np.ones(3)) == 1.0 and math.isnan(ks_distance(np.zeros(0), np.zeros(0)))


def test_real_parts_are_discs_of_the_area_centred_on_the_densest_drawn_junctions():
    # a grid with a dense quarter (25 m spacing) in one corner: junctions there are most of the junctions
    lines = grid() + grid(n=13, step=25.0, stub=0.0, origin=(0.0, 0.0))
    noded = [shapely.get_coordinates(g) for g in shapely.get_parts(shapely.union_all([shapely.LineString(ln) for ln in lines]))]
    parts = real_parts(noded, 200_000.0, n=16, rng=np.random.default_rng(1))
    assert len(parts) == 16
    np.testing.assert_allclose(shapely.area(np.asarray(parts)), 200_000.0)
    junctions = junction_points(noded)
    centres = shapely.get_coordinates(shapely.centroid(np.asarray(parts)))
    assert cKDTree(junctions).query(centres)[0].max() < 1e-6  # every centre is a junction
    # the denser half of 32 drawn discs is kept: each holds at least as many junctions as any dropped one
    radius = math.sqrt(200_000.0 / math.pi)
    counts = cKDTree(junctions).query_ball_point(centres, radius * 0.999, return_length=True)
    drawn = junctions[np.random.default_rng(1).choice(len(junctions), 32, replace=False)]
    every = np.sort(cKDTree(junctions).query_ball_point(drawn, radius * 0.999, return_length=True))
    assert counts.min() >= every[15]
    with pytest.raises(InputError, match="no junction"):
        real_parts([np.array([[0.0, 0.0], [100.0, 0.0]])], 1e4, rng=0)


KREMS_DISTRICT = 1.1e6  # m²: what the pipeline grows next to Krems (a quarter of its built-up area)


@pytest.fixture(scope="module")
def krems():
    net = loaded("krems.osm.gz")
    return LineSet.from_lines([net.street_xy(s) for s in net.streets])


@pytest.fixture(scope="module")
def krems_reference(krems):
    return town_reference(krems, KREMS_DISTRICT, parts=16, rng=np.random.default_rng(7))


def _beside(lines: LineSet) -> np.ndarray:
    lo, hi = lines.coords.min(axis=0), lines.coords.max(axis=0)
    return np.array([hi[0] + 2000.0, (lo[1] + hi[1]) / 2])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_real_parts_of_krems_are_off_on_few_measures(krems, seed):
    ref = town_reference(krems, KREMS_DISTRICT, parts=16, rng=np.random.default_rng(seed))
    assert ref.part_values.shape == (16, len(Measure))
    report = judge(measure_network(krems, window=ref.windows[0]), ref)
    assert report.typical_off <= 3  # the median real part, judged against the other fifteen
    # sixteen more real parts judged as districts: at least half are off on as few; the
    # others are discs on Krems's rural fringe, a handful of streets in fields
    fresh = real_parts(krems, KREMS_DISTRICT, n=16, rng=np.random.default_rng(100 + seed))
    off = [judge(measure_network(krems, window=w), ref).off for w in fresh]
    assert sum(k <= 3 for k in off) >= 8


#: m²: the default districts' windows (the growth footprint of ``osm-expand TOWN``, seed 0, today).
DISTRICT_AREAS = {"krems.osm.gz": 0.97e6, "north-bayreuth.osm.gz": 1.57e6}


@functools.cache
def town_lines(name: str) -> LineSet:
    net = loaded(name)
    return LineSet.from_lines([net.street_xy(s) for s in net.streets])


@pytest.mark.parametrize("name", list(DISTRICT_AREAS))
def test_real_neighbourhoods_are_off_on_a_median_of_at_most_three(name):
    """Issue 20: a real neighbourhood, judged against the others, is off on a median of 2–3 measures."""
    town = town_lines(name)
    medians = []
    for seed in range(3):
        ref = town_reference(town, DISTRICT_AREAS[name], rng=np.random.default_rng(seed))
        assert ref.part_values.shape == (32, len(Measure))
        report = judge(ref.parts[0], ref)
        medians.append(report.typical_off)
        assert sum(p.pieces == 1 for p in ref.parts) >= len(ref.parts) / 2  # a neighbourhood is one piece
    # measured: Krems 2.5, 2.0, 2.0; north-bayreuth 3.0, 2.0, 3.0
    assert max(medians) <= 3, medians


def scatter_of_fragments(town: LineSet, area: float) -> tuple[list[np.ndarray], shapely.Geometry]:
    """Eight fragments of the town's own streets (discs of 120 m), spread over a district of ``area``
    beside it, and that district's disc."""
    centre, radius = _beside(town), math.sqrt(area / math.pi)
    window = shapely.Point(centre).buffer(radius, quad_segs=16)
    rng = np.random.default_rng(0)
    junctions = junction_points(town)
    turns = np.linspace(0, 2 * math.pi, 7)[:-1]
    spots = [centre + 0.6 * radius * np.array([math.cos(a), math.sin(a)]) for a in turns] + [centre]
    fragments = []
    for spot in spots:
        at = junctions[rng.integers(len(junctions))]
        cut = shapely.get_parts(shapely.intersection(town.geoms, shapely.Point(at).buffer(120.0)))
        fragments += [shapely.get_coordinates(g) - at + spot for g in cut if g.geom_type == "LineString"]
    return fragments, window


@pytest.mark.parametrize("name", list(DISTRICT_AREAS))
def test_a_scatter_of_fragments_is_no_neighbourhood(name):
    """Eight fragments of the town's own streets (discs of 120 m), spread over a district beside it."""
    town, area = town_lines(name), DISTRICT_AREAS[name]
    ref = town_reference(town, area, rng=np.random.default_rng(0))
    fragments, window = scatter_of_fragments(town, area)
    report = judge(measure_network(fragments, window=window), ref)
    assert report.pieces >= 2 and report.to_dict()["pieces"] == report.pieces
    assert report.off >= 6 and not report.believable  # measured: Krems 9 off, north-bayreuth 10
    for measure in (Measure.DENSITY, Measure.DEAD_END_SHARE, Measure.TWO_CORE_SHARE):
        assert not report.verdict(measure).ok, measure


def test_real_parts_of_campo_grande_pass_and_a_grid_beside_it_does_not():
    net = loaded("campo-grande.osm.gz")
    town = LineSet.from_lines([net.street_xy(s) for s in net.streets])
    area = town.hull(0.0).area / 4  # ≈ 43 km², the benchmark's district
    ref = town_reference(town, area, parts=16, rng=np.random.default_rng(0))
    fresh = real_parts(town, area, n=8, rng=np.random.default_rng(1))
    off = [judge(measure_network(town, window=w), ref).off for w in fresh]
    assert judge(ref.parts[0], ref).typical_off <= 2
    assert sum(k <= 3 for k in off) >= 6
    centre = _beside(town)
    window = shapely.Point(centre).buffer(math.sqrt(area / math.pi), quad_segs=16)
    side = 2 * math.sqrt(area / math.pi)
    n = int(side // 90.0) + 1
    plain = judge(measure_network(grid(n=n, step=90.0, origin=centre - side / 2), window=window), ref)
    assert plain.off >= 4 and not plain.believable
    assert not plain.verdict(Measure.JUNCTION_ANGLE).ok


def test_a_random_tangle_is_not_a_district_of_krems(krems, krems_reference):
    centre = _beside(krems)
    lines = tangle(centre, KREMS_DISTRICT, np.random.default_rng(0))
    window = shapely.Point(centre).buffer(math.sqrt(KREMS_DISTRICT / math.pi), quad_segs=16)
    report = judge(measure_network(lines, window=window), krems_reference)
    assert report.off >= 6 and report.off > 2 * report.typical_off
    assert not report.density_ok and not report.believable
    for measure in (Measure.ORIENTATION_ENTROPY, Measure.THREE_WAY_SHARE, Measure.FOUR_WAY_SHARE,
                    Measure.CURVATURE):
        assert not report.verdict(measure).ok, measure


def test_a_plain_grid_beside_krems_is_off_on_orientation_and_angles(krems, krems_reference):
    centre = _beside(krems)
    window = shapely.Point(centre).buffer(math.sqrt(KREMS_DISTRICT / math.pi), quad_segs=16)
    lines = grid(n=13, step=90.0, origin=centre - 540.0)
    report = judge(measure_network(lines, window=window), krems_reference)
    for measure in (Measure.ORIENTATION_ENTROPY, Measure.JUNCTION_ANGLE, Measure.FOUR_WAY_SHARE,
                    Measure.ALIGNMENT):
        assert not report.verdict(measure).ok, measure
    assert not report.believable


def test_the_report_is_json_and_the_same_for_the_same_seed(krems):
    piece = [shapely.get_coordinates(g) for g in shapely.get_parts(
        shapely.intersection(krems.geoms, shapely.Point(krems.coords.mean(axis=0)).buffer(700)))]
    one = compare(piece, krems, rng=np.random.default_rng(11)).to_dict()
    two = compare(piece, krems, rng=np.random.default_rng(11)).to_dict()
    other = compare(piece, krems, rng=np.random.default_rng(12)).to_dict()
    assert json.dumps(one, allow_nan=False) == json.dumps(two, allow_nan=False)
    assert one["part_centres"] != other["part_centres"]
    assert set(one["measures"]) == {m.value for m in Measure}
    assert all(set(v) == {"kind", "value", "low", "high", "ok", "district", "town"} for v in one["measures"].values())
    assert one["off"] == sum(not v["ok"] for v in one["measures"].values())


def test_a_district_joined_to_the_town_is_judged_with_its_joins_open(krems):
    # the district: Krems's streets in a disc, its streets cut at the disc ending on "old town" nodes
    window = shapely.Point(krems.coords.mean(axis=0)).buffer(600.0)
    cut = shapely.get_parts(shapely.intersection(krems.geoms, window))
    lines = [shapely.get_coordinates(g) for g in cut if g.geom_type == "LineString" and not g.is_empty]
    ends = np.array([p for ln in lines for p in (ln[0], ln[-1]) if window.exterior.distance(shapely.Point(p)) < 1e-6])
    inner = window.buffer(10.0)  # a window the district does not touch: only the joins make open ends
    report = fidelity(lines, krems, window=inner, open_points=ends, rng=np.random.default_rng(4))
    alone = measure_network(lines, window=inner)
    assert report.district.open_ends == len(np.unique(ends.round(2), axis=0)) > 0
    assert report.district.dead_ends == alone.dead_ends - report.district.open_ends
    same = judge(measure_network(lines, window=inner, open_points=ends),
                 town_reference(krems, inner.area, rng=np.random.default_rng(4)))
    assert same.to_dict() == report.to_dict()


def test_fewer_than_sixteen_parts_is_an_input_error(krems):
    with pytest.raises(InputError, match="at least 16 real parts"):
        town_reference(krems, KREMS_DISTRICT, parts=8, rng=0)


def test_an_unknown_measure_name_lists_the_valid_ones():
    m = measure_network(grid(3))
    assert m.value("density") == m.density
    with pytest.raises(InputError, match="valid: edge_length, circuity"):
        m.value("sinuosity")


def test_scalar_range_is_the_verdicts_rule_for_one_measure():
    """h29f: a caller sampling neighbourhoods itself gets the range the verdict would give (10th–90th
    percentile; the dead-end share widened by 0.02 each side, the 2-core share not); a distribution has none."""
    from osm_expand.fidelity import scalar_range

    values = np.linspace(0.0, 0.5, 11)
    lo, hi = np.percentile(values, [10, 90])
    assert scalar_range("two_core_share", values) == pytest.approx((lo, hi))
    assert scalar_range("dead_end_share", values) == pytest.approx((lo - 0.02, hi + 0.02))
    with pytest.raises(InputError):
        scalar_range("edge_length", values)
