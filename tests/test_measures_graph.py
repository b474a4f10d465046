"""The measures' graph (:func:`osm_expand.measures.graph._build_graph`): telling a graph without rings of
shape points by a bounded pointer jumping gives, to the bit, the graph that finding the rings first gave."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.measures import graph
from osm_expand.measures.kinds import MeasureOptions
from osm_expand.measures.lines import LineSet


def _ring(n: int, radius: float = 100.0, at: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    t = np.linspace(0.0, 2 * np.pi, n + 1)
    pts = np.column_stack([at[0] + radius * np.cos(t), at[1] + radius * np.sin(t)])
    pts[-1] = pts[0]
    return pts


def _graphs(lines: list[np.ndarray], window: shapely.Geometry | None, monkeypatch: pytest.MonkeyPatch):
    """The graph as built now, and as built with the rings always looked for first (the old way)."""
    line_set = LineSet.from_lines(lines)
    coords, label = (line_set.coords, line_set.line_of) if window is None else line_set.clip(window)
    kwargs = {"window": window, "open_points": None, "opts": MeasureOptions()}
    now = graph._build_graph(coords, label, **kwargs)
    rank = graph._rank
    with monkeypatch.context() as m:
        m.setattr(graph, "_rank", lambda nxt, rounds=None: None if rounds is not None else rank(nxt))
        old = graph._build_graph(coords, label, **kwargs)
    return now, old


def _same(a, b) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert x.dtype == y.dtype and np.array_equal(x, y), f.name


@pytest.mark.parametrize("n", [3, 4, 5, 7, 8, 15, 16, 17, 31, 32, 33, 64, 100, 128, 129])
def test_a_ring_of_shape_points_of_any_length_is_one_edge_as_before(n, monkeypatch):
    """A ring of 2^k segments settles under pointer jumping with each half-edge on itself: it must still
    be found and broken."""
    now, old = _graphs([_ring(n)], None, monkeypatch)
    _same(now, old)
    assert len(now.first) == 1 and now.length[0] == pytest.approx(now.seg_len.sum())


def test_rings_beside_chains_trees_and_a_ring_with_a_tail_are_built_as_before(monkeypatch):
    lines = [_ring(16), _ring(12, at=(500.0, 0.0)), _ring(32, at=(0.0, 500.0)),
             np.array([[500.0, 100.0], [500.0, 300.0], [520.0, 400.0]]),  # a tail on the second ring
             np.array([[-500.0, 0.0], [-400.0, 10.0], [-300.0, 0.0], [-200.0, 30.0]]),
             np.array([[-400.0, 10.0], [-400.0, 200.0]])]
    now, old = _graphs(lines, None, monkeypatch)
    _same(now, old)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.integers(3, 70), st.floats(-300.0, 300.0), st.floats(-300.0, 300.0)),
                min_size=1, max_size=6),
       st.floats(50.0, 400.0))
def test_random_rings_clipped_by_a_disc_are_built_as_before(rings, radius):
    """Overlapping rings make junctions, a disc cuts them into chains with open ends: the graph is the
    same either way."""
    lines = [_ring(n, 80.0, (x, y)) for n, x, y in rings]
    with pytest.MonkeyPatch.context() as monkeypatch:
        now, old = _graphs(lines, shapely.Point(0.0, 0.0).buffer(radius), monkeypatch)
    _same(now, old)
