"""A coarse lower bound on what a route on G′ still costs: the search window's guide.

:func:`osm_expand.engine.roads.routing.find_route` searches an implicit G′
in windows of the lattice and must know when no route through the rest of
the map can be cheaper than the window's best. A bound of *straight distance
× the cheapest cost a metre of any edge* (:func:`~osm_expand.engine.roads.
routing.cheapest_unit_cost`) is exact but weak: an existing major road costs
0.4 a metre, so every exit within 2.5 times the route's length looked
promising and the windows of Campo Grande grew to the whole map (6 GB) once
issue 20 closed the presumed frontage to new roads and routes detoured.

This module charges each part of the map what an edge through it costs at
least. The map is cut into square *cells* ``cell_size`` metres wide; a
cell's *unit cost* is the least cost a metre of any edge of the allowed
kinds that touches it (1 where new road can be laid or stitched, C1·C6 along
an extendible major road, C5 over water a bridge could cross, ∞ on built-up
or forbidden ground no street and no stitch reaches). A route is a polyline
of straight edges whose cost is at least ``Σ length × unit cost`` of the
cells it passes, turn penalties being ≥ 0. Each side of a cell is cut into
``pieces`` equal pieces; inside a cell a route goes from a piece of its
boundary to another at least the two pieces' distance apart. Dijkstra over
the pieces (edges: every pair of pieces of a cell, weight unit cost ×
distance) from the pieces of the target's cell then gives, for every cell, a
lower bound of the cost from anywhere in it to the target: an admissible
heuristic, so the search stays exact (a different route only if one of equal
cost). With both ends' bounds ``g`` and ``h`` every route cheaper than ``C``
lies in the cells with ``g + h ≤ C``: the window need hold no more.

On Campo Grande the cell graph of 200 m cells has about 6,000 cells and
1.5 million piece pairs; its two Dijkstras take a fraction of a second, once
per road search.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.roads.lattice import EdgeKind, ImplicitGraph
from osm_expand.errors import InputError

__all__ = ["BoundOptions", "CoarseBound", "coarse_bound"]


@dataclass(frozen=True)
class BoundOptions:
    """Tunables of the coarse lower bound (this module's own; not from the seeds)."""

    #: lattice spacings per cell side: 3 × 20 m = 60 m cells keep Campo Grande's cell graph at
    #: ~66,000 cells and 2 million edges (its Dijkstra a few tenths of a second) while a cell is
    #: still narrower than a street block
    cells_per_side: int = 3
    #: k, cells from a cell to the ring a stage of the bound reaches: a stage charges (k − 1) of
    #: every k cells crossed, at the least unit cost of the 2k − 1 cells square round it (4: 75 %
    #: of the straight cost, over a square of 7 × 60 = 420 m)
    ring: int = 4

    def __post_init__(self) -> None:
        if self.cells_per_side < 1 or self.ring < 2:
            raise InputError("BoundOptions: cells_per_side must be at least 1 and ring at least 2")


@dataclass(frozen=True)
class CoarseBound:
    """The cells of the map, their unit costs and the graph of the stages (see the module's text)."""

    origin: np.ndarray  #: (2,) m, lower-left corner of cell (0, 0)
    cell: float  #: m, cell side
    unit: np.ndarray  #: (ny, nx) cost per metre of the cheapest edge touching each cell (inf: none)
    least: np.ndarray  #: (ny · nx,) least unit cost over the (2k − 1)² square of cells round each cell
    ring: int  #: k
    #: the stages reversed: row B, column A, weight ``least[A] · gap(A, B)`` for B on A's ring;
    #: one more row (the start, empty here) at the end
    matrix: csr_matrix

    @property
    def shape(self) -> tuple[int, int]:
        return self.unit.shape  # type: ignore[return-value]

    def cells_of(self, xy: np.ndarray) -> np.ndarray:
        """``(n, 4)`` flat index of the (up to four) cells whose closure holds each point
        (repeated where fewer): a point on a cell's side belongs to both cells."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        ny, nx = self.shape
        eps = 1e-6 * self.cell
        out = []
        for dx in (-eps, eps):
            for dy in (-eps, eps):
                col = np.clip(np.floor((xy[:, 0] + dx - self.origin[0]) / self.cell).astype(np.int64), 0, nx - 1)
                row = np.clip(np.floor((xy[:, 1] + dy - self.origin[1]) / self.cell).astype(np.int64), 0, ny - 1)
                out.append(row * nx + col)
        return np.stack(out, axis=1)

    def from_point(self, xy: np.ndarray) -> np.ndarray:
        """``(ny · nx,)`` lower bound of the cost between ``xy`` and any point of each cell.

        A route from a point of cell A to ``xy`` (in one of the cells T) either
        reaches ``xy`` inside A's square of (2k − 1)² cells, at no less than
        ``least[A] · gap(A, T)``, or first leaves the square into a cell B of
        its ring, at no less than ``least[A] · gap(A, B)``, and goes on from
        B: Dijkstra from the start over the reversed stages.
        """
        ny, nx = self.shape
        n = ny * nx
        own = np.unique(self.cells_of(xy))
        k = self.ring
        ti, tj = np.divmod(own, nx)
        rows, cols = np.mgrid[0:ny, 0:nx]
        first = np.full(n, np.inf)
        for i, j in zip(ti.tolist(), tj.tolist()):
            near = (np.abs(rows - i) < k) & (np.abs(cols - j) < k)
            gap = np.hypot(np.maximum(np.abs(rows[near] - i) - 1, 0), np.maximum(np.abs(cols[near] - j) - 1, 0))
            flat = np.flatnonzero(near.ravel())
            first[flat] = np.minimum(first[flat], self.least[flat] * gap * self.cell)
        start = np.flatnonzero(np.isfinite(first))
        m = self.matrix
        indptr = m.indptr.copy()
        indptr[-1] += len(start)
        graph = csr_matrix((np.concatenate([m.data, first[start]]),
                            np.concatenate([m.indices, start.astype(m.indices.dtype)]), indptr), shape=m.shape)
        dist = dijkstra(graph, indices=n)[:n]
        dist[own] = 0.0
        # Dijkstra adds in floating point: keep a hair below it so that rounding never overstates
        return np.maximum(dist * (1.0 - 1e-9) - 1e-6, 0.0)

    def at(self, per_cell: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """A :meth:`from_point` bound at points: the least over the cells holding each."""
        return per_cell[self.cells_of(xy)].min(axis=1) if len(np.atleast_2d(xy)) else np.zeros(0)

    def box(self, mask: np.ndarray) -> np.ndarray | None:
        """``(xmin, ymin, xmax, ymax)`` m around the cells of a ``(ny · nx,)`` mask (None: none)."""
        flat = np.flatnonzero(mask)
        if not len(flat):
            return None
        row, col = np.divmod(flat, self.shape[1])
        return np.array([self.origin[0] + col.min() * self.cell, self.origin[1] + row.min() * self.cell,
                         self.origin[0] + (col.max() + 1) * self.cell, self.origin[1] + (row.max() + 1) * self.cell])


def _box_any(mask: np.ndarray, first: np.ndarray, last: np.ndarray, rows: bool) -> np.ndarray:
    """Whether ``mask`` has a true value in index ranges ``[first, last)`` along one axis."""
    count = np.cumsum(mask, axis=0 if rows else 1, dtype=np.int64)
    count = np.concatenate([np.zeros((1, mask.shape[1]) if rows else (mask.shape[0], 1), dtype=np.int64), count],
                           axis=0 if rows else 1)
    n = mask.shape[0 if rows else 1]
    lo, hi = np.clip(first, 0, n), np.clip(last, 0, n)
    if rows:
        return (count[hi] - count[lo]) > 0
    return (count[:, hi] - count[:, lo]) > 0


def _cells_touched(fine: np.ndarray, fine_origin: np.ndarray, step: float, origin: np.ndarray, cell: float,
                   shape: tuple[int, int], grow: float) -> np.ndarray:
    """``(ny, nx)`` bool: cells whose square grown by ``grow`` m holds a true fine point."""
    ny, nx = shape
    k = np.arange(ny)
    # fine rows whose y lies in [y0 − grow, y1 + grow] of each cell row
    y0 = origin[1] + k * cell - grow - fine_origin[1]
    r_first = np.ceil(y0 / step - 1e-9).astype(np.int64)
    r_last = np.floor((y0 + cell + 2 * grow) / step + 1e-9).astype(np.int64) + 1
    j = np.arange(nx)
    x0 = origin[0] + j * cell - grow - fine_origin[0]
    c_first = np.ceil(x0 / step - 1e-9).astype(np.int64)
    c_last = np.floor((x0 + cell + 2 * grow) / step + 1e-9).astype(np.int64) + 1
    by_row = _box_any(fine, r_first, r_last, rows=True)  # (ny, fine cols)
    return _box_any(by_row, c_first, c_last, rows=False)  # (ny, nx)


def _mark_boxes(unit: np.ndarray, origin: np.ndarray, cell: float, lo: np.ndarray, hi: np.ndarray,
                value: np.ndarray) -> None:
    """``unit = min(unit, value)`` over every cell meeting each box ``[lo, hi]`` (boxes at most a cell wide)."""
    ny, nx = unit.shape
    flat = unit.reshape(-1)
    c0 = np.clip(np.floor((lo[:, 0] - origin[0]) / cell).astype(np.int64), 0, nx - 1)
    c1 = np.clip(np.floor((hi[:, 0] - origin[0]) / cell).astype(np.int64), 0, nx - 1)
    r0 = np.clip(np.floor((lo[:, 1] - origin[1]) / cell).astype(np.int64), 0, ny - 1)
    r1 = np.clip(np.floor((hi[:, 1] - origin[1]) / cell).astype(np.int64), 0, ny - 1)
    for r in (r0, r1):
        for c in (c0, c1):
            np.minimum.at(flat, r * nx + c, value)


def coarse_bound(graph: ImplicitGraph, kinds: Sequence[EdgeKind], street_ok: np.ndarray | None = None,
                 options: BoundOptions | None = None) -> CoarseBound:
    """The cells of ``graph``'s map with the unit cost of the edges of ``kinds`` a route may use.

    Parameters
    ----------
    graph
        This year's implicit G′ (its rasters, B, street part and costs).
    kinds
        The edge kinds the search allows.
    street_ok
        ``(S,)`` bool, the street segments the search may use (None: all); a
        segment left out does not lower its cells' cost.
    options
        :class:`BoundOptions`.

    Returns
    -------
    CoarseBound
    """
    opts = options or BoundOptions()
    lat = graph.lattice
    costs = graph.costs
    allowed = {EdgeKind(k) for k in kinds}
    cell = lat.spacing * opts.cells_per_side
    step = lat.fine_step
    fine_origin = np.asarray(lat.fine_origin, dtype=float)
    fy, fx = lat.water.shape
    pts = graph.streets.xy
    lo = np.minimum(fine_origin, pts.min(axis=0) if len(pts) else fine_origin) - cell
    hi = np.maximum(fine_origin + np.array([fx - 1, fy - 1]) * step, pts.max(axis=0) if len(pts) else fine_origin)
    hi = hi + cell
    origin = fine_origin - np.ceil((fine_origin - lo) / cell) * cell  # cell sides on lattice lines
    nx, ny = (int(v) for v in np.ceil((hi - origin) / cell))
    unit = np.full((ny, nx), np.inf)
    # lattice edges: every point of an edge lies within √2 fine steps of one of its samples
    grow = 1.5 * step
    free = ~lat.forbidden
    if EdgeKind.LAND in allowed:
        land = free & ~lat.water & ~lat.built_up
        unit[_cells_touched(land, fine_origin, step, origin, cell, (ny, nx), grow)] = 1.0
    if EdgeKind.WATER in allowed:
        unit[_cells_touched(free & lat.water, fine_origin, step, origin, cell, (ny, nx), grow)] = 1.0
    lattice_other = [c for k, c in ((EdgeKind.HARBOUR, costs.harbour), (EdgeKind.BRIDGE, costs.bridge))
                     if k in allowed]
    if lattice_other:  # harbours and bridges: non-forbidden samples, water or land (in B too)
        touched = _cells_touched(free, fine_origin, step, origin, cell, (ny, nx), grow)
        unit[touched] = np.minimum(unit[touched], min(lattice_other))
    streets = graph.streets
    if EdgeKind.STITCH in allowed and len(streets.points):
        # a stitch joins a street point to a vertex or another point within its radius, ≥ 1 a metre
        reach = max(graph.options.stitch_radius, graph.options.shell_stitch_radius)
        xy = streets.xy[streets.points]
        _mark_reach(unit, origin, cell, xy, reach, 1.0)
    u, v, kind, seg, length, weight = streets.edges
    use = np.isin(kind, [int(k) for k in allowed & {EdgeKind.MAJOR, EdgeKind.MINOR, EdgeKind.BUILT_HARBOUR}])
    if street_ok is not None and len(street_ok):
        use &= np.asarray(street_ok, dtype=bool)[seg]
    if use.any():
        a, b = streets.xy[u[use]], streets.xy[v[use]]
        per = weight[use] / np.maximum(length[use], 1e-12)
        _mark_segments(unit, origin, cell, a, b, per)
    return _with_graph(origin, cell, unit * (1.0 - 1e-12), opts.ring)


def _mark_reach(unit: np.ndarray, origin: np.ndarray, cell: float, xy: np.ndarray, reach: float,
                value: float) -> None:
    """``unit = min(unit, value)`` on every cell within ``reach`` (as a square) of a point."""
    ny, nx = unit.shape
    c0 = np.clip(np.floor((xy[:, 0] - reach - origin[0]) / cell).astype(np.int64), 0, nx - 1)
    c1 = np.clip(np.floor((xy[:, 0] + reach - origin[0]) / cell).astype(np.int64), 0, nx - 1)
    r0 = np.clip(np.floor((xy[:, 1] - reach - origin[1]) / cell).astype(np.int64), 0, ny - 1)
    r1 = np.clip(np.floor((xy[:, 1] + reach - origin[1]) / cell).astype(np.int64), 0, ny - 1)
    marks = np.zeros((ny + 1, nx + 1), dtype=np.int64)  # 2-D difference array of the boxes
    np.add.at(marks, (r0, c0), 1)
    np.add.at(marks, (r0, c1 + 1), -1)
    np.add.at(marks, (r1 + 1, c0), -1)
    np.add.at(marks, (r1 + 1, c1 + 1), 1)
    hit = marks.cumsum(axis=0).cumsum(axis=1)[:ny, :nx] > 0
    unit[hit] = np.minimum(unit[hit], value)


def _mark_segments(unit: np.ndarray, origin: np.ndarray, cell: float, a: np.ndarray, b: np.ndarray,
                   per: np.ndarray) -> None:
    """``unit = min(unit, per)`` on every cell each straight segment ``a → b`` touches.

    Each segment is sampled at most ``cell / 4`` apart; every point of it lies
    within half a gap of a sample, so the cells meeting the boxes of that
    half-width round the samples hold the whole segment.
    """
    gap = cell / 4.0
    length = np.hypot(*(b - a).T)
    count = np.maximum(np.ceil(length / gap).astype(np.int64), 1) + 1
    which = np.repeat(np.arange(len(a)), count)
    t = (np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
    p = a[which] + t[:, None] * (b - a)[which]
    half = 0.5 * gap * (1.0 + 1e-9)
    _mark_boxes(unit, origin, cell, p - half, p + half, per[which])


def _with_graph(origin: np.ndarray, cell: float, unit: np.ndarray, k: int) -> CoarseBound:
    """The reversed stages of every cell to the cells of its ring (see :meth:`CoarseBound.from_point`)."""
    from scipy.ndimage import minimum_filter

    ny, nx = unit.shape
    n = ny * nx
    least = minimum_filter(unit, size=2 * k - 1, mode="constant", cval=np.inf).ravel()
    ring = [(di, dj) for di in range(-k, k + 1) for dj in range(-k, k + 1) if max(abs(di), abs(dj)) == k]
    iy, ix = np.divmod(np.arange(n), nx)
    heads, tails, weights = [], [], []
    for di, dj in ring:
        ok = (iy + di >= 0) & (iy + di < ny) & (ix + dj >= 0) & (ix + dj < nx) & np.isfinite(least)
        a = np.flatnonzero(ok)
        gap = cell * np.hypot(max(abs(di) - 1, 0), max(abs(dj) - 1, 0))
        heads.append(a + di * nx + dj)  # B: the reversed edge leaves it
        tails.append(a)
        weights.append(least[a] * gap)
    b, a, w = np.concatenate(heads), np.concatenate(tails), np.concatenate(weights)
    order = np.argsort(b, kind="stable")
    indptr = np.zeros(n + 2, dtype=np.int64)
    indptr[1:n + 1] = np.cumsum(np.bincount(b, minlength=n))
    indptr[n + 1] = indptr[n]
    matrix = csr_matrix((w[order], a[order].astype(np.int32), indptr), shape=(n + 1, n + 1))
    return CoarseBound(origin=origin, cell=cell, unit=unit, least=least, ring=k, matrix=matrix)
