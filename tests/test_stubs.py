"""The engine's stubs: run on, dropped, and trees hung on the town (issue 20)."""
from __future__ import annotations

import numpy as np
import shapely
from hypothesis import example, given, settings
from hypothesis import strategies as st

from osm_expand.engine.growth.stubs import close_stubs

TOWN = np.array([shapely.LineString([(0, 0), (1000, 0)])], dtype=object)
TOWN_NODES = np.array([[0.0, 0.0], [1000.0, 0.0]])
NOTHING = shapely.GeometryCollection()


def test_a_tree_hung_on_the_town_goes_with_loops_and_stays_without():
    """A 200 m spur (longer than the reach, so no stub rule drops it) is a comb's tooth; a street joined
    to the town at both ends and a ring on a stem close loops and stay; a branching tree (a cluster of
    culs-de-sac that a pattern without Snap and Extend never closes) goes like the spur."""
    spur = np.array([[100.0, 0], [100, 200]])
    u_turn = [np.array([[300.0, 0], [300, 150], [500, 150]]), np.array([[500.0, 150], [500, 0]])]
    stem = np.array([[700.0, 0], [700, 100]])
    ring = np.array([[700.0, 100], [800, 100], [800, 200], [700, 200], [700, 100]])
    lines = [spur, *u_turn, stem, ring]
    kept, flags, report = close_stubs(lines, [False] * 5, TOWN, TOWN_NODES, NOTHING, reach=50.0, loops=True)
    assert report.source == (1, 2, 3, 4) and len(kept) == 4 and flags == [False] * 4
    kept, _, report = close_stubs(lines, [False] * 5, TOWN, TOWN_NODES, NOTHING, reach=50.0)
    assert report.source == (0, 1, 2, 3, 4)
    tree = [np.array([[100.0, 0], [100, 200]]), np.array([[100.0, 200], [0, 300]]),
            np.array([[100.0, 200], [200, 300]])]
    kept, _, report = close_stubs(tree, [False] * 3, TOWN, TOWN_NODES, NOTHING, reach=50.0, loops=True)
    assert report.source == () and kept == [] and report.dropped == 3
    kept, _, report = close_stubs(tree, [False] * 3, TOWN, TOWN_NODES, NOTHING, reach=50.0)
    assert report.source == (0, 1, 2)


def test_a_stub_runs_on_to_the_street_ahead_and_the_link_takes_its_attributes():
    """The stub ends 30 m short of a new street ahead: the link runs on to it, the street it lands on gets
    the landing point as a vertex, and the report names the stub as the link's source."""
    cross = np.array([[0.0, 300], [400, 300]])
    legs = [np.array([[0.0, 0], [0, 300]]), np.array([[400.0, 0], [400, 300]])]
    stub = np.array([[200.0, 0], [200, 270]])
    kept, _, report = close_stubs([cross, *legs, stub], [False] * 4, TOWN, TOWN_NODES, NOTHING, reach=60.0,
                                  loops=True)
    assert report.tees == 1 and report.source == (0, 1, 2, 3, 3)
    assert np.allclose(kept[-1], [[200, 270], [200, 300]])
    assert any(np.allclose(p, [200, 300]) for p in kept[0])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 7), st.floats(20, 400), st.floats(-60, 60)), min_size=1, max_size=8,
                unique_by=lambda t: t[0]))
@example([(3, 37.0, 38.0), (4, 20.0, -50.0)])  # the link tees 0.14 m short of spur 3's tip: the tip goes
def test_with_loops_a_comb_goes_whole_and_every_street_kept_is_on_a_loop(spurs):
    """Combs of straight spurs off the town (130 m apart or more, so none crosses another): whatever a link
    runs on, no street kept lies off a loop (nor a tail of one past its last junction)."""
    lines = [np.array([[50.0 + 130 * i, 0.0], [50 + 130 * i + dx, h]]) for i, h, dx in spurs]
    kept, _, report = close_stubs(lines, [False] * len(lines), TOWN, TOWN_NODES, NOTHING, reach=50.0, loops=True)
    assert len(kept) == len(report.source)
    if kept:
        faces = shapely.polygonize(shapely.get_parts(shapely.union_all([shapely.LineString(k) for k in kept]
                                                                       + list(TOWN))))
        rings = shapely.union_all(shapely.boundary(shapely.get_parts(faces)))
        for k in kept:
            assert shapely.LineString(k).within(rings.buffer(1e-6))
