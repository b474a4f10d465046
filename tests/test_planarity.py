"""The engine's planarity safety net on hand-built streets with known answers."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.engine.planarity import touching_pairs, without_touching
from osm_expand.model import City, Origin, network_from_lines

OLD = {"origin": Origin.SOURCE}
NEW = {"origin": Origin.ENGINE, "hierarchy": 3}
ROAD = {"origin": Origin.ENGINE, "hierarchy": 0, "highway": "primary"}


def city(lines, attrs) -> City:
    return City(network=network_from_lines([np.asarray(ln, dtype=float) for ln in lines], list(attrs)))


def pairs(c: City, probe) -> list[tuple[int, int]]:
    return [tuple(p) for p in touching_pairs(c, np.asarray(probe, dtype=bool)).tolist()]


def test_a_junction_shared_by_both_streets_is_fine():
    c = city([[(0, 0), (100, 0)], [(100, 0), (100, 100)], [(100, 0), (200, 0)]], [OLD, NEW, NEW])
    assert pairs(c, [False, True, True]) == []


def test_a_crossing_without_a_node_is_caught():
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)]], [OLD, NEW])
    assert pairs(c, [False, True]) == [(1, 0)]


def test_a_t_junction_ending_on_a_street_without_its_node_is_caught():
    c = city([[(0, 0), (100, 0)], [(50, 0), (50, 50)]], [OLD, NEW])
    assert pairs(c, [False, True]) == [(1, 0)]


def test_two_parallel_streets_a_hair_apart_overlap_once_written():
    """Parallel 0.1 mm apart: GEOS sees no intersection, the millimetres written do (a CG run's case)."""
    c = city([[(0, 0), (100, 10)], [(50, 5.0001), (150, 15.0001)]], [NEW, NEW])
    assert pairs(c, [True, True]) == [(0, 1)]


def test_a_new_street_running_back_along_an_old_one_from_a_shared_node_is_caught():
    c = city([[(0, 0), (100, 0)], [(100, 0), (40, 0)]], [OLD, NEW])
    assert pairs(c, [False, True]) == [(1, 0)]


def test_two_nodes_a_millimetre_apart_stay_two_nodes():
    """Ends 1.1 mm apart are distinct once written: streets meeting at each are not touching."""
    c = city([[(0, 0), (50, 0), (50.0011, 0), (100, 0)], [(50, 0), (50, 50)], [(50.0011, 0), (50.0011, -50)]],
             [OLD, NEW, NEW])
    assert pairs(c, [False, True, True]) == []


def test_streets_on_different_layers_may_cross():
    bridge = {**NEW, "layer": 1, "bridge": True}
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)]], [OLD, bridge])
    assert pairs(c, [False, True]) == []


def test_only_probed_streets_are_judged():
    """The town as mapped is given back as mapped: two old streets that cross are not the net's business."""
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)]], [OLD, OLD])
    assert pairs(c, [False, False]) == []


def test_of_two_new_streets_the_later_goes_and_an_old_one_stays():
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)], [(20, -50), (20, 50)]], [OLD, NEW, NEW])
    known = {c.network.streets[0].id}
    kept, dropped = without_touching(c, known)
    assert dropped == 2 and [s.id for s in kept.network.streets] == [c.network.streets[0].id]
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)], [(0, 20), (100, 20)]], [NEW, NEW, OLD])
    kept, dropped = without_touching(c, {c.network.streets[2].id})
    assert dropped == 1 and [s.id for s in kept.network.streets] == [c.network.streets[k].id for k in (0, 2)]


def test_a_major_road_keeps_its_way_and_the_minor_street_goes():
    c = city([[(0, 0), (100, 0)], [(50, -50), (50, 50)]], [ROAD, NEW])
    known = {c.network.streets[1].id}  # the minor street was there first, the road is new
    kept, dropped = without_touching(c, known)
    assert dropped == 1 and kept.network.streets[0].hierarchy == 0 and len(kept.network.streets) == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 200), st.floats(0, 200), st.floats(0, 200)),
                min_size=2, max_size=12))
def test_what_the_net_keeps_has_no_touching_pair(segments):
    lines = [[(x0, y0), (x1, y1)] for x0, y0, x1, y1 in segments if np.hypot(x1 - x0, y1 - y0) > 1.0]
    if len(lines) < 2:
        return
    c = city(lines, [NEW] * len(lines))
    kept, dropped = without_touching(c, set())
    assert not len(touching_pairs(kept, np.ones(len(kept.network.streets), dtype=bool)))
    assert len(kept.network.streets) + dropped == len(c.network.streets)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 200), st.floats(0, 200), st.floats(0, 200), st.booleans()),
                min_size=2, max_size=12))
def test_probing_some_streets_finds_their_pairs_among_all(segments):
    """Only segments near the probed ones are searched: the pairs are those of probing every street
    that have a probed street, the probed one first (of two probed streets, the lower index first)."""
    rows = [(x0, y0, x1, y1, p) for x0, y0, x1, y1, p in segments if np.hypot(x1 - x0, y1 - y0) > 1.0]
    if len(rows) < 2:
        return
    c = city([[(x0, y0), (x1, y1)] for x0, y0, x1, y1, _ in rows], [NEW] * len(rows))
    probe = np.resize(np.array([p for *_, p in rows], dtype=bool), len(c.network.streets))
    every = touching_pairs(c, np.ones(len(c.network.streets), dtype=bool)).tolist()
    want = sorted({(a, b) if probe[a] else (b, a) for a, b in every if probe[a] or probe[b]})
    assert sorted(map(tuple, touching_pairs(c, probe).tolist())) == want


def written_crossings(c: City) -> list[tuple[int, int]]:
    """Street pairs that touch away from a shared node in the written file (the referee's reading,
    independent of the engine's code): coordinates to the millimetre, shared ends within 1 cm."""
    import itertools

    import shapely

    net = c.network
    segs, owner, layer = [], [], []
    for k, s in enumerate(net.streets):
        pts = np.round(net.street_xy(s), 3)
        for p, q in itertools.pairwise(pts):
            segs.append((p, q))
            owner.append(k)
            layer.append(s.layer_key)
    lines = shapely.linestrings(np.array(segs))
    out = []
    for i, j in zip(*shapely.STRtree(lines).query(lines, predicate="intersects")):
        if i >= j or layer[i] != layer[j] or (not net.streets[owner[i]].is_new and not net.streets[owner[j]].is_new):
            continue
        touch = shapely.intersection(lines[i], lines[j])
        if touch.geom_type not in ("Point", "MultiPoint"):
            out.append((owner[i], owner[j]))
            continue
        shared = [p for p in segs[i] if any(np.hypot(*(p - q)) < 1e-6 for q in segs[j])]
        pts = shapely.get_coordinates(touch)
        if not all(any(np.hypot(*(p - q)) < 1e-2 for q in shared) for p in pts):
            out.append((owner[i], owner[j]))
    return out


def test_the_district_goes_through_the_net_too():
    """Monaco, seed 7: two streets of the district grown before the engine met 1 mm apart once
    written (an end on the other street, no node); the net judged only the engine's own streets."""
    from osm_expand.ingest import load
    from osm_expand.pipeline import ExpandOptions, expand
    from tests.conftest import FIXTURES

    result = expand(load(FIXTURES / "monaco.osm.gz"), ExpandOptions(seed=7, fidelity=False))
    assert "touching_streets_dropped" in result.report  # the net ran over the district
    assert written_crossings(result.city) == []
    # and it catches a new street across a district street without a node
    net = result.city.network
    k = result.city.new_streets()[0]
    a, b = net.street_xy(net.streets[k])[:2]
    mid = (a + b) / 2
    normal = np.array([-(b - a)[1], (b - a)[0]]) / np.hypot(*(b - a))
    stub = [mid + normal * 30.0, mid - normal * 2.0]
    city = result.city.replace(network=net.with_new_streets([np.array(stub)], [{"highway": "residential"}]))
    _, dropped = without_touching(city, known={s.id for s in net.streets})
    assert dropped == 1
