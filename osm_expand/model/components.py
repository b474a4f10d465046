"""Connected components and closeness of points, for the paths that must start fast.

SciPy's ``csgraph``, ``DisjointSet`` and ``cKDTree`` do these jobs, but
importing any SciPy submodule costs 0.12–0.16 s (its array-API layer), a
quarter of ``osm-expand simplify``'s whole run on a town. The simplify passes
need only components of small graphs, a union–find and radius queries on
junctions, so they use these: NumPy for the components, a textbook union–find,
and shapely's STRtree (already imported) for the geometry; the nearest known
point within a radius is :func:`osm_expand.model.geometry.match_points`.
"""
from __future__ import annotations

from collections.abc import Hashable, Iterable
from typing import Generic, TypeVar

import numpy as np
import shapely


def component_labels(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """A component label per vertex ``0..n-1`` of the undirected graph with edges ``(i[k], j[k])``.

    Labels are ``0..c-1`` in order of each component's smallest vertex, as
    ``scipy.sparse.csgraph.connected_components`` numbers them. Hooking roots
    onto the smaller root and pointer jumping, vectorised: O((n + m) log n).

    >>> component_labels(5, np.array([3, 1]), np.array([4, 0])).tolist()
    [0, 0, 1, 2, 2]
    """
    parent = np.arange(n)
    i, j = np.asarray(i, dtype=np.intp), np.asarray(j, dtype=np.intp)
    while len(i):
        ri, rj = parent[i], parent[j]
        apart = ri != rj
        if not apart.any():
            break
        ri, rj = ri[apart], rj[apart]
        np.minimum.at(parent, np.maximum(ri, rj), np.minimum(ri, rj))
        while True:  # pointer jumping: every vertex straight to its root
            up = parent[parent]
            if np.array_equal(up, parent):
                break
            parent = up
        i, j = i[apart], j[apart]
    return np.unique(parent, return_inverse=True)[1].reshape(-1)


_T = TypeVar("_T", bound=Hashable)


class UnionFind(Generic[_T]):
    """Disjoint sets of hashable items, for merges decided one at a time (union by size, path halving)."""

    def __init__(self, items: Iterable[_T] = ()) -> None:
        self._parent: dict[_T, _T] = {}
        self._size: dict[_T, int] = {}
        for item in items:
            self.add(item)

    def add(self, item: _T) -> None:
        if item not in self._parent:
            self._parent[item] = item
            self._size[item] = 1

    def __getitem__(self, item: _T) -> _T:
        """The representative of ``item``'s set."""
        parent = self._parent
        while parent[item] != item:
            parent[item] = parent[parent[item]]
            item = parent[item]
        return item

    def connected(self, a: _T, b: _T) -> bool:
        return self[a] == self[b]

    def merge(self, a: _T, b: _T) -> None:
        ra, rb = self[a], self[b]
        if ra == rb:
            return
        if self._size[ra] < self._size[rb]:
            ra, rb = rb, ra
        self._parent[rb] = ra
        self._size[ra] += self._size[rb]

    def subsets(self) -> list[list[_T]]:
        """The sets, each in the order its items were added."""
        groups: dict[_T, list[_T]] = {}
        for item in self._parent:
            groups.setdefault(self[item], []).append(item)
        return list(groups.values())


def close_pairs(points: np.ndarray, radius: float) -> np.ndarray:
    """``(k, 2)`` index pairs ``i < j`` of points at most ``radius`` apart, sorted."""
    pts = shapely.points(np.asarray(points, dtype=float).reshape(-1, 2))
    a, b = shapely.STRtree(pts).query(pts, predicate="dwithin", distance=radius)
    keep = a < b
    pairs = np.column_stack([a[keep], b[keep]])
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

