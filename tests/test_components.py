"""The SciPy-free components and closeness queries equal SciPy's, result for result.

``osm_expand.model.components`` replaces ``connected_components``,
``DisjointSet`` and ``cKDTree`` on the simplify path (for its start-up time);
SciPy stays the definition here.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
from conftest import FIXTURES
from hypothesis import given
from hypothesis import strategies as st
from scipy.cluster.hierarchy import DisjointSet
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from osm_expand.model import match_points
from osm_expand.model.components import UnionFind, close_pairs, component_labels

edges = st.integers(1, 60).flatmap(
    lambda n: st.tuples(st.just(n), st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=120)))
# coordinates on a 0.25 m lattice: distances are never within rounding of the radius
points = st.lists(st.tuples(st.integers(-200, 200), st.integers(-200, 200)), min_size=0, max_size=150).map(
    lambda p: np.array(p, dtype=float).reshape(-1, 2) / 4)


@given(edges)
def test_component_labels_are_scipys(graph):
    n, pairs = graph
    i = np.array([a for a, _ in pairs], dtype=np.intp)
    j = np.array([b for _, b in pairs], dtype=np.intp)
    matrix = coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    expected = connected_components(matrix, directed=False)[1]
    assert component_labels(n, i, j).tolist() == expected.tolist()


@given(edges)
def test_union_find_groups_as_disjoint_set(graph):
    n, pairs = graph
    ours, theirs = UnionFind(range(n)), DisjointSet(range(n))
    for a, b in pairs:
        assert ours.connected(a, b) == theirs.connected(a, b)
        ours.merge(a, b)
        theirs.merge(a, b)
    assert sorted(map(sorted, ours.subsets())) == sorted(map(sorted, theirs.subsets()))


@given(points, st.sampled_from([0.3, 1.0, 5.0]))
def test_close_pairs_are_kdtree_pairs(pts, radius):
    expected = cKDTree(pts).query_pairs(radius, output_type="ndarray") if len(pts) else np.zeros((0, 2), int)
    expected = expected[np.lexsort((expected[:, 1], expected[:, 0]))]
    assert close_pairs(pts, radius).tolist() == expected.tolist()


@given(points, points, st.sampled_from([0.3, 1.0, 5.0]))
def test_match_points_within_a_radius_finds_a_nearest_known_point(pts, known, radius):
    found = match_points(pts, known, radius)
    if not len(known):
        assert (found == -1).all()
        return
    dist, _ = cKDTree(known).query(pts, distance_upper_bound=radius + 1e-9) if len(pts) else (np.zeros(0), None)
    assert ((found >= 0) == np.isfinite(dist)).all()
    hit = found >= 0
    assert np.allclose(np.hypot(*(known[found[hit]] - pts[hit]).T), dist[hit])  # a nearest one (ties either)


def test_simplify_command_imports_no_scipy(tmp_path):
    """The whole point of the module: ``osm-expand simplify`` starts without SciPy's 0.15 s import."""
    code = ("import sys; from osm_expand.cli import main; rc = main(); "
            "sys.exit(rc if rc else 3 if any(m.split('.')[0] == 'scipy' for m in sys.modules) else 0)")
    out = tmp_path / "nb.osm"
    run = subprocess.run([sys.executable, "-c", code, "simplify", str(FIXTURES / "north-bayreuth.osm.gz"),
                          "-o", str(out), "-q"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr or "scipy was imported"
    assert out.stat().st_size > 0
