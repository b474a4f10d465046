"""A uniform-grid index of segments that grows while streets are drawn.

The random walk asks, for every step, "would this segment cross anything
drawn so far?". A KD-tree cannot grow; a grid of cells about one junction
spacing wide can, and a query only looks at the few segments in the cells
the new segment's bounding box covers.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np

EPS = 1e-9


class SegmentIndex:
    def __init__(self, cell: float, capacity: int = 1024):
        self.cell = float(cell)
        self.grid: defaultdict[tuple[int, int], list[int]] = defaultdict(list)
        self.n = 0
        self.a = np.zeros((capacity, 2))
        self.b = np.zeros((capacity, 2))
        self.ends = np.zeros((capacity, 2), dtype=np.int64)
        self.active = np.zeros(capacity, dtype=bool)

    def _grow(self) -> None:
        for name in ("a", "b", "ends", "active"):
            old = getattr(self, name)
            new = np.zeros((2 * len(old),) + old.shape[1:], dtype=old.dtype)
            new[: len(old)] = old
            setattr(self, name, new)

    def _cells(self, a: np.ndarray, b: np.ndarray):
        lo = np.floor(np.minimum(a, b) / self.cell).astype(int)
        hi = np.floor(np.maximum(a, b) / self.cell).astype(int)
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                yield (i, j)

    def add(self, a: np.ndarray, b: np.ndarray, u: int, v: int) -> int:
        """Store segment u–v (at a–b); returns its id for :meth:`remove`."""
        if self.n == len(self.a):
            self._grow()
        k = self.n
        self.a[k], self.b[k], self.ends[k], self.active[k] = a, b, (u, v), True
        self.n += 1
        for c in self._cells(a, b):
            self.grid[c].append(k)
        return k

    def remove(self, k: int) -> None:
        self.active[k] = False

    def crosses(self, a: np.ndarray, b: np.ndarray, u: int, v: int) -> bool:
        """Does segment u–v (at a–b) touch a stored segment anywhere but at a shared end node?"""
        near = {k for c in self._cells(a, b) for k in self.grid.get(c, ())}
        if not near:
            return False
        ids = np.fromiter(near, dtype=np.int64)
        ids = ids[self.active[ids]]
        ends, p, q = self.ends[ids], self.a[ids], self.b[ids]
        shared = (ends[:, 0] == u) | (ends[:, 0] == v) | (ends[:, 1] == u) | (ends[:, 1] == v)
        if shared.any():  # touching at the shared node is fine, running along each other is not
            s = shared
            if _collinear_overlap(a, b, p[s], q[s]).any():
                return True
            p, q = p[~s], q[~s]
        return bool(_intersects(a, b, p, q).any())


def _orient(a, b, c) -> np.ndarray:
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def _on_segment(a, b, c) -> np.ndarray:
    return ((np.minimum(a[..., 0], b[..., 0]) - EPS <= c[..., 0])
            & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]) + EPS)
            & (np.minimum(a[..., 1], b[..., 1]) - EPS <= c[..., 1])
            & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]) + EPS))


def _intersects(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Segment a–b against many p–q, touching included."""
    if len(p) == 0:
        return np.zeros(0, dtype=bool)
    scale = max(float(np.hypot(*(b - a))), 1.0)
    tol = EPS * scale * scale
    d1, d2 = _orient(p, q, a), _orient(p, q, b)
    d3, d4 = _orient(a, b, p), _orient(a, b, q)
    proper = (((d1 > tol) & (d2 < -tol)) | ((d1 < -tol) & (d2 > tol))) & \
             (((d3 > tol) & (d4 < -tol)) | ((d3 < -tol) & (d4 > tol)))
    touch = ((np.abs(d1) <= tol) & _on_segment(p, q, a)) | ((np.abs(d2) <= tol) & _on_segment(p, q, b)) | \
            ((np.abs(d3) <= tol) & _on_segment(a, b, p)) | ((np.abs(d4) <= tol) & _on_segment(a, b, q))
    return proper | touch


def _collinear_overlap(a, b, p, q) -> np.ndarray:
    """Segments sharing an end that also run along a–b (a fold-back)."""
    scale = max(float(np.hypot(*(b - a))), 1.0)
    tol = 1e-7 * scale * scale
    col = (np.abs(_orient(a, b, p)) <= tol) & (np.abs(_orient(a, b, q)) <= tol)
    d = b - a
    tp = ((p - a) @ d) / max(d @ d, EPS)
    tq = ((q - a) @ d) / max(d @ d, EPS)
    lo, hi = np.minimum(tp, tq), np.maximum(tp, tq)
    return col & (np.minimum(hi, 1.0) - np.maximum(lo, 0.0) > 1e-6)
