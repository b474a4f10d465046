"""The random walk: its rejection rules, no crossings, determinism, reproduction."""
from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand import cli
from osm_expand.model import network_from_lines
from simplify import simplify
from simplify.example import build_example
from synth.reproduce import cloud_from_example, example_segments, reproduce
from synth.segment_index import SegmentIndex
from synth.walk import NodeCloud, random_walk
from tests.conftest import FIXTURES, simplified


def cloud(xy, level, cap=None, mean=100.0, std=20.0, angle_std=10.0):
    """Every junction with one record of the given level (second record empty)."""
    n = len(xy)
    lv = np.full((n, 2), -1)
    lv[:, 0] = level
    caps = np.zeros((n, 2), dtype=np.int64)
    caps[:, 0] = 2 if cap is None else cap
    full = lambda v: np.column_stack([np.full(n, v), np.full(n, np.nan)])  # noqa: E731
    return NodeCloud(xy=np.asarray(xy, dtype=float), level=lv, length_mean=full(mean), length_std=full(std),
                     angle_mean=full(0.0), angle_std=full(angle_std), cap=caps)


def test_a_straight_row_is_walked_end_to_end():
    xy = [(0, 0), (100, 0), (200, 0), (300, 0), (400, 0)]
    walk = random_walk(cloud(xy, [0] * 5, cap=[1, 2, 2, 2, 1]))
    assert walk.segments == {(0, 1), (1, 2), (2, 3), (3, 4)}
    assert len(walk.streets) == 1


def test_a_target_of_another_level_is_never_taken():
    xy = [(0, 0), (100, 0), (200, 0)]
    walk = random_walk(cloud(xy, [0, 1, 0], cap=[1, 2, 1], std=60.0))
    assert (0, 1) not in walk.segments and (1, 2) not in walk.segments


def test_a_target_without_a_free_slot_is_never_taken():
    xy = [(0, 0), (100, 0), (200, 0)]
    walk = random_walk(cloud(xy, [0, 0, 0], cap=[1, 0, 1], std=60.0))
    assert not any(1 in seg for seg in walk.segments)


def test_transitions_below_the_threshold_are_not_taken():
    xy = [(0, 0), (100, 0), (400, 0)]  # 300 m is 10 standard deviations from 100 m
    walk = random_walk(cloud(xy, [0, 0, 0], cap=[1, 2, 1], std=20.0))
    assert walk.segments == {(0, 1)}


def test_a_step_never_crosses_what_is_drawn_or_an_obstacle():
    # level 0 draws the vertical street first; the level 1 row would have to cross it
    xy = [(150, -100), (150, 0), (150, 100), (100, 0), (200, 0)]
    lv = [0, 0, 0, 1, 1]
    walk = random_walk(cloud(xy, lv, cap=[1, 2, 1, 1, 1], std=40.0))
    assert (3, 4) not in walk.segments
    wall = shapely.LineString([(50, -50), (50, 50)])
    row = random_walk(cloud([(0, 0), (100, 0)], [0, 0], cap=[1, 1]), obstacles=wall)
    assert row.segments == set()


def test_an_end_record_takes_one_segment_a_passing_one_two():
    xy = [(0, 0), (100, 0), (200, 0)]
    walk = random_walk(cloud(xy, [0, 0, 0], cap=[1, 1, 1]))
    assert len(walk.segments) == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 40)), min_size=3, max_size=60, unique=True),
       st.integers(0, 3), st.integers(0, 10))
def test_walked_segments_never_cross(points, levels, seed):
    xy = np.array(points, dtype=float) * 25.0
    lv = np.arange(len(xy)) % (levels + 1)
    walk = random_walk(cloud(xy, lv, std=40.0, angle_std=45.0), seed=seed)
    segs = sorted(walk.segments)
    if not segs:
        return
    lines = [shapely.LineString([xy[a], xy[b]]) for a, b in segs]
    for i, j in zip(*shapely.STRtree(lines).query(lines, predicate="intersects")):
        if i < j:
            shared = set(segs[i]) & set(segs[j])
            assert shared, "segments may touch only at a junction they share"
            assert lines[i].intersection(lines[j]).geom_type == "Point"


def test_segment_index_rules():
    index = SegmentIndex(cell=50.0)
    index.add(np.array([0.0, 0.0]), np.array([100.0, 0.0]), 0, 1)
    assert index.crosses(np.array([50.0, -50.0]), np.array([50.0, 50.0]), 2, 3)  # a proper crossing
    assert index.crosses(np.array([50.0, 0.0]), np.array([50.0, 50.0]), 2, 3)  # a T without a junction
    assert not index.crosses(np.array([100.0, 0.0]), np.array([150.0, 50.0]), 1, 3)  # at the shared node
    assert index.crosses(np.array([100.0, 0.0]), np.array([40.0, 0.0]), 1, 3)  # folding back along it
    assert not index.crosses(np.array([0.0, 10.0]), np.array([100.0, 10.0]), 4, 5)  # parallel, apart


def test_grid_is_reproduced_almost_perfectly():
    lines = [[(x, y * 100.0) for x in range(0, 1001, 100)] for y in range(6)]
    lines += [[(x * 100.0, y) for y in range(0, 501, 100)] for x in range(11)]
    ex = build_example(simplify(network_from_lines(lines)).network)
    score = reproduce(ex, seed=1)
    assert score["recall"] >= 0.9 and score["precision"] >= 0.9


def test_same_seed_same_walk_different_seed_different_walk():
    ex = build_example(simplified("krems.osm.gz").network)
    a = random_walk(cloud_from_example(ex), seed=4)
    b = random_walk(cloud_from_example(ex), seed=4)
    c = random_walk(cloud_from_example(ex), seed=5)
    assert a.streets == b.streets and a.streets != c.streets


#: Mean recall and precision of seeds 0-2, just under what was measured (Krems 0.817 / 0.939,
#: north-bayreuth 0.883 / 0.959): a regression of a point fails. 004 §5.3 reports 70 ± 5 %.
REPRODUCTION_FLOOR = {"krems.osm.gz": (0.80, 0.93), "north-bayreuth.osm.gz": (0.87, 0.95)}


@pytest.mark.parametrize("name", sorted(REPRODUCTION_FLOOR))
def test_reproduction_keeps_its_measured_recall_and_precision(name):
    result = simplified(name)
    ex = build_example(result.network, result.dead_ends)
    scores = [reproduce(ex, seed) for seed in range(3)]
    recall, precision = REPRODUCTION_FLOOR[name]
    assert np.mean([s["recall"] for s in scores]) >= recall
    assert np.mean([s["precision"] for s in scores]) >= precision
    assert len(example_segments(ex)) == scores[0]["segments_original"]


def test_reproduce_command(capsys):
    assert cli.main(["reproduce", str(FIXTURES / "West-Oakland.osm.bz2"), "--json", "-q", "--seed", "2"]) == 0
    score = json.loads(capsys.readouterr().out)
    assert 0 <= score["recall"] <= 1 and 0 <= score["precision"] <= 1 and score["seed"] == 2


def _grow(name: str, seed: int = 1):
    import shapely as shp

    from osm_expand.ingest import load
    from synth.grow import grow

    city = load(FIXTURES / name)
    result = simplify(city.network)
    ex = build_example(result.network, result.dead_ends)
    lo, hi = ex.xy.min(axis=0), ex.xy.max(axis=0)
    side = float((hi - lo).max())
    region = shp.box(hi[0] + 200, (lo[1] + hi[1] - side) / 2, hi[0] + 200 + side, (lo[1] + hi[1] + side) / 2)
    water = list(city.water) + list(city.sea)
    obstacles = shp.union_all(water) if water else None
    grown = grow(ex, region, obstacles=obstacles, seed=seed)
    return grown, region, obstacles


_grown_network = functools.cache(_grow)


def test_growth_next_to_a_town_never_crosses_and_stays_dry():
    from simplify.invariants import violations

    for name in ("krems.osm.gz", "north-bayreuth.osm.gz"):
        grown, region, water = _grown_network(name)
        lines = [[tuple(p) for p in pl] for _, pl in grown.polylines()]
        assert len(lines) > 50
        net = network_from_lines(lines)
        assert violations(net)["crossings_without_junction"] == 0
        assert all(region.covers(shapely.LineString(line)) for line in lines)
        if water is not None:
            assert not any(water.intersects(shapely.LineString(line)) for line in lines)


def test_growth_is_deterministic():
    """Two independent runs (no cache between them) with one seed draw the same streets."""
    a, _, _ = _grow("krems.osm.gz", seed=7)
    b, _, _ = _grow("krems.osm.gz", seed=7)
    assert a.walk.streets == b.walk.streets
    assert all(np.array_equal(p, q) for (_, p), (_, q) in zip(a.polylines(), b.polylines()))
    c, _, _ = _grow("krems.osm.gz", seed=8)
    assert c.walk.streets != a.walk.streets


def _ks(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import ks_2samp

    return float(ks_2samp(a, b).statistic)


def test_grown_streets_have_the_towns_spacing_and_turning():
    """Kolmogorov–Smirnov distance to the source ≤ 0.15 (mean of three seeds)."""
    for name in ("krems.osm.gz", "north-bayreuth.osm.gz"):
        result = simplified(name)
        source = build_example(result.network, result.dead_ends)
        spacing, turning = [], []
        for seed in (0, 1, 2):
            grown, _, _ = _grown_network(name, seed=seed)
            ex = build_example(network_from_lines([[tuple(p) for p in pl] for _, pl in grown.polylines()]))
            cat = lambda e, a: np.concatenate([getattr(s, a) for s in e.streets])  # noqa: E731
            spacing.append(_ks(cat(ex, "spacing"), cat(source, "spacing")))
            turning.append(_ks(cat(ex, "turning"), cat(source, "turning")))
        assert np.mean(spacing) <= 0.15, (name, spacing)
        assert np.mean(turning) <= 0.15, (name, turning)


def test_grown_junctions_are_three_and_four_way_like_the_towns():
    """3-way and 4-way shares within 0.10 of the source (mean of three seeds).

    Both sides are measured the same way: simplified (dead ends pruned,
    continuations merged), then the example's junction degrees, as
    ``osm-expand stats`` does for a town.
    """
    from simplify.statistics import example_statistics

    for name in ("krems.osm.gz", "north-bayreuth.osm.gz"):
        result = simplified(name)
        source = example_statistics(build_example(result.network, result.dead_ends))
        shares = []
        for seed in (0, 1, 2):
            grown, _, _ = _grown_network(name, seed=seed)
            again = simplify(network_from_lines([[tuple(p) for p in pl] for _, pl in grown.polylines()]))
            stats = example_statistics(build_example(again.network, again.dead_ends))
            shares.append((stats["three_way_share"], stats["four_way_share"]))
        three, four = np.mean(shares, axis=0)
        assert abs(three - source["three_way_share"]) <= 0.10, (name, shares, source["three_way_share"])
        assert abs(four - source["four_way_share"]) <= 0.10, (name, shares, source["four_way_share"])


def test_same_seed_same_bytes(tmp_path):
    from osm_expand.export import write_geojson
    from osm_expand.model import City

    for name in ("a", "b"):
        grown, _, _ = _grow("krems.osm.gz", seed=11)  # grown afresh each time
        net = network_from_lines([[tuple(p) for p in pl] for _, pl in grown.polylines()],
                                 [{"hierarchy": lv} for lv, _ in grown.polylines()])
        write_geojson(City(network=net), tmp_path / f"{name}.geojson")
    assert (tmp_path / "a.geojson").read_bytes() == (tmp_path / "b.geojson").read_bytes()


def test_border_junctions_of_the_old_town_are_targets_of_any_level():
    from synth.walk import ANY_LEVEL

    xy = [(0, 0), (100, 0), (200, 0), (300, 0)]
    c = cloud(xy, [1, 1, 1, 1], cap=[1, 2, 2, 1])
    level = c.level.copy()
    level[3, 0] = ANY_LEVEL  # an old-town junction with a free slot
    c = NodeCloud(xy=c.xy, level=level, length_mean=c.length_mean, length_std=c.length_std,
                  angle_mean=c.angle_mean, angle_std=c.angle_std, cap=c.cap)
    assert (2, 3) in random_walk(c).segments


def test_a_grown_district_connects_to_the_old_town():
    import shapely as shp

    from osm_expand.ingest import load
    from synth.grow import grow

    city = load(FIXTURES / "north-bayreuth.osm.gz")
    result = simplify(city.network)
    ex = build_example(result.network, result.dead_ends)
    lo, hi = ex.xy.min(axis=0), ex.xy.max(axis=0)
    side = float((hi - lo).max())
    edge = (ex.slots > 0) & (ex.xy[:, 0] > hi[0] - 600)  # old-town junctions with room, on its east side
    region = shp.union_all([shp.box(hi[0] + 50, (lo[1] + hi[1] - side) / 2, hi[0] + 50 + side, (lo[1] + hi[1] + side) / 2),
                            shp.box(float(ex.xy[edge, 0].min()) - 1, lo[1], hi[0] + 60, hi[1])])
    grown = grow(ex, region, obstacles=shp.union_all(list(city.water)), border_xy=ex.xy[edge],
                 border_slots=ex.slots[edge], seed=1)
    core = len(grown.cloud) - int(edge.sum())
    links = [(a, b) for _, p in grown.walk.streets for a, b in zip(p, p[1:]) if (a >= core) != (b >= core)]
    assert len(links) >= 1


def _walker(c):
    from synth.walk import WalkOptions, _Walker

    return _Walker(c, WalkOptions(complete=True), None, 100.0)


def test_junctions_short_of_their_segments_are_paired_by_a_side_street():
    c = cloud([(0, 0), (100, 0), (0, 300)], [0, 0, 0], cap=[1, 1, 1])
    walker = _walker(c)
    assert walker.pair_up() == [(0, [0, 1])]  # 300 m is beyond reach for the third; paired ones are full
    assert (walker.used[:2, 0] == 1).all() and walker.used[2, 0] == 0


def test_a_side_street_at_a_sliver_angle_to_a_segment_is_refused():
    c = cloud([(0, 0), (100, 0), (300, 30)], [0, 0, 0], cap=[2, 1, 1])
    walker = _walker(c)
    walker.connect(0, 0, 2, 0)  # 0 → 2 runs about 8.5° from 0 → 1
    assert walker.pair_up() == []
