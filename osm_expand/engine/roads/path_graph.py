"""The stitched graph G′ over the lattice G, whole or searched in windows (003 §3.4.2, Fig. 9).

**G′** (:func:`pathfinding_graph`) is that lattice plus the street segments
(major and minor; long segments on the shell get a point every
``split_spacing`` m so that a road can join them anywhere, like 003 §3.3's
temporary nodes) plus *stitches*: short new-road edges from the street
points on the shell and on terrain blocks to nearby live land vertices, and
between shell points (003 Fig. 9), none crossing or grazing a street,
entering a built-up block or touching water. Edge costs are multiplied by
C1…C6 (003 §3.4.2) by kind. The lattice part of G′ stays a table (vertex ×
direction); the other edges are short arrays. The route searches read those
as they go (compiled, :mod:`~osm_expand.engine.roads.expanded_search`); its CSR
matrix (the tests' reference) holds the allowed edges row by row, so it is
built without sorting, and cached.

**The implicit G′** (:func:`implicit_graph`, what the engine uses): a year's
street part (pieces, split points, shell stitches; :func:`street_part`) and
nothing over the whole map. A search asks for G′ over a window of the
lattice (:meth:`ImplicitGraph.window`): exactly the whole G′'s edges between
the window's vertices, except at its *exits* (vertices near an open side,
street points whose stitches could reach past it, ends of long bridges that
cross it), and :func:`osm_expand.engine.roads.routing.find_route` grows the window
until no exit can lead to a cheaper route. On Campo Grande (a lattice of
1118 × 532 vertices) the whole G′ had 134 million adjacency entries; a
window holds the corridor a route can use.

The stitches are chosen and checked in :mod:`osm_expand.engine.roads.stitches`
(their street tests carried over from year to year).
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np
import shapely
from scipy.sparse import csr_matrix

from osm_expand.engine.roads.built_up import BlocksChanged, BuiltUpArea, segment_sides
from osm_expand.engine.roads.lattice import NO_EDGE, ROAD_KINDS, EdgeKind, Lattice, LatticeWeights, VertexClass
from osm_expand.engine.roads.stitches import (
    GraphOptions,
    ShellVerdicts,
    carried_ok,
    lattice_verdicts,
    nearest_pairs,
    stitch_ok,
    within_reach,
)
from osm_expand.errors import InputError
from osm_expand.model.options import require_positive
from osm_expand.model.segments import SegmentTable

__all__ = [
    "EdgeCosts", "GraphOptions", "PathGraph", "pathfinding_graph", "ShellVerdicts", "StreetPart", "street_part",
    "GraphWindow", "ImplicitGraph", "implicit_graph", "lattice_verdicts", "street_part_again",
]


@dataclass(frozen=True)
class EdgeCosts:
    """The cost coefficients C1…C6 of R(t) (003 §3.4.2), the current year's values.

    A new road over open land costs 1 per metre of weight; these multiply the
    other kinds. Defaults (003's table is missing) make a new road reuse major
    roads, avoid minor streets and build a bridge only when no existing
    crossing is within a long detour.
    """

    major: float = 0.5  #: C1, existing major road: reuse is cheap (003: "small value to reuse heavily")
    minor: float = 2.0  #: C2, existing minor road: avoided if possible (003's own example)
    harbour: float = 10.0  #: C3, unbuilt harbour
    built_harbour: float = 1.0  #: C4, built harbour
    #: C5, unbuilt bridge: 000 §4.2.3 "a very large constant … only when absolutely necessary";
    #: 15 makes a 300 m bridge cost a 4.5 km detour
    bridge: float = 15.0
    #: C6, extendible segment (not between two built-up blocks), multiplies C1/C2: widening is easy
    extendible: float = 0.8

    def __post_init__(self) -> None:
        require_positive(self, ("major", "minor", "harbour", "built_harbour", "bridge", "extendible"))


#: The kinds a lattice table (``lat_kind``) holds besides NO_EDGE: the lattice's own edges.
LATTICE_KINDS = (EdgeKind.LAND, EdgeKind.WATER, EdgeKind.HARBOUR, EdgeKind.BRIDGE)


def _lattice_key(kinds: Sequence[int]) -> tuple[int, ...]:
    """The lattice kinds among ``kinds``, sorted: what :func:`_of_kinds` of them depends on."""
    return tuple(sorted({int(k) for k in kinds} & {int(k) for k in LATTICE_KINDS}))


def _of_kinds(lat_kind: np.ndarray, kinds: Sequence[int]) -> np.ndarray:
    """Whether each entry of a lattice table is of one of ``kinds``.

    One comparison per lattice kind asked for: a lookup table indexed by the whole
    ``(V, D)`` table was four times slower (0.076 s against 0.018 s for two kinds on a
    table the size of Campo Grande's map, 594,776 vertices × 120 directions), and nothing
    is cached: :class:`KindMask` asks it again for every block of rows it is read by.
    """
    wanted = _lattice_key(kinds)
    if not wanted:
        return np.zeros(lat_kind.shape, dtype=bool)
    out = lat_kind == wanted[0]  # the first comparison is the result's memory: no zeroed table first
    for k in wanted[1:]:
        out |= lat_kind == k
    return out


#: share of a block's lattice entries below which :meth:`PathGraph._csr` reads only the live ones (their
#: positions, then their kinds) rather than masking whole-block tables: on Campo Grande's first road's
#: window a block 4 % live took 2.4 ms against 8.9 ms, one 36 % live 8.0 against 9.7 ms (the same entries)
_SPARSE_SHARE = 0.3

#: entries of a lattice table read at once by :class:`KindMask`'s row blocks (4 Mi: a block's
#: temporaries stay a few MB, where the whole map's (V, D) bool table was 293 MB; issue 22)
_BLOCK_ENTRIES = 1 << 22


@dataclass(frozen=True, eq=False)
class KindMask:
    """Which lattice edges a route may use (``lat_kind`` of one of ``kinds``), worked out for the rows
    read, like a ``(V, D)`` bool table.

    Issue 22: on the synthetic 10,000-street town's whole map the table was 293 MB held through
    the plain and the heading-expanded searches, beside ``lat_kind`` it is made from; the
    searches read it block by block of rows, and one comparison per kind a block is cheap
    (:func:`_of_kinds`: 0.02 s for Campo Grande's whole map). Compared and hashed by identity
    (``eq=False``): the generated ``__eq__``/``__hash__`` compared the array and made ``hash(mask)`` raise.
    """

    kind: np.ndarray  #: (V, D) uint8 EdgeKind or NO_EDGE
    kinds: tuple[int, ...]  #: the lattice kinds allowed (:func:`_lattice_key`)

    @property
    def shape(self) -> tuple[Any, ...]:
        return self.kind.shape

    def __getitem__(self, index: Any) -> np.ndarray:
        return _of_kinds(self.kind[index], self.kinds)

    def __array__(self, dtype: Any = None, copy: object = None) -> np.ndarray:
        """The whole table (tests, small maps), as ``dtype`` when one is asked for (always a new array,
        so ``copy`` is met either way)."""
        out = _of_kinds(self.kind, self.kinds)
        return out if dtype is None else out.astype(dtype, copy=False)

    def row_blocks(self, rows: np.ndarray | None = None) -> Iterator[tuple[int, int]]:
        """``(first, end)`` ranges that read the table (or the given ``rows`` of it) a block at a time:
        the one place the block size is set (:data:`_BLOCK_ENTRIES`)."""
        n = self.shape[0] if rows is None else len(rows)
        block = max(1, _BLOCK_ENTRIES // max(self.shape[1], 1))
        for a in range(0, n, block):
            yield a, min(a + block, n)

    def count_per_row(self, rows: np.ndarray | None = None) -> np.ndarray:
        """``(V,)`` int64 (or one per ``rows``): the allowed edges of each row, read block by block."""
        n = self.shape[0] if rows is None else len(rows)
        out = np.zeros(n, dtype=np.int64)
        for a, b in self.row_blocks(rows):
            out[a:b] = np.count_nonzero(self[a:b] if rows is None else self[rows[a:b]], axis=1)
        return out

    def any_per_row(self) -> np.ndarray:
        """``(V,)`` bool: whether each row has an allowed edge, read block by block."""
        out = np.zeros(self.shape[0], dtype=bool)
        for a, b in self.row_blocks():
            out[a:b] = self[a:b].any(axis=1)
        return out


class Steps(NamedTuple):
    """The edges :meth:`PathGraph.steps` picks, one entry per vertex pair (a route's edges)."""

    kind: np.ndarray  #: uint8 :class:`EdgeKind`
    segment: np.ndarray  #: int64 the edge's street segment, −1 when it has none (a lattice edge)
    length: np.ndarray  #: m
    weight: np.ndarray  #: the edge's cost
    heading: np.ndarray  #: radians


@dataclass(frozen=True)
class PathGraph:
    """G′ (003 Fig. 9): lattice vertices, then street nodes, then split points.

    Vertex ``i < n_lattice`` is lattice vertex ``i``; ``n_lattice + j`` is
    street node ``j``; after those come the split points. The live lattice
    edges are the directed tables ``lat_kind`` / ``lat_weight`` (row = tail
    vertex, column = direction, see :meth:`Lattice.directed_tables`); every
    other edge (long bridges, street pieces, stitches) is in the directed
    edge arrays, sorted by tail. Every edge exists in both directions with
    the same weight.
    """

    lattice: Lattice
    segments: SegmentTable
    xy: np.ndarray  #: (V′, 2) m
    n_lattice: int
    split_segment: np.ndarray  #: (P,) parent segment of each split point
    lat_kind: np.ndarray  #: (V, D) uint8 EdgeKind or NO_EDGE
    #: (V, D) float32 cost, × C3 / C5 for harbours / bridges (on flat land worked out when read)
    lat_weight: np.ndarray | LatticeWeights
    src: np.ndarray  #: (E,) int64, sorted
    dst: np.ndarray  #: (E,) int64
    kind: np.ndarray  #: (E,) uint8 EdgeKind
    segment: np.ndarray  #: (E,) int64 street segment (−1 if none)
    length: np.ndarray  #: (E,) m
    weight: np.ndarray  #: (E,) cost: length · max(1, O1 · slope) × C1…C6 by kind
    heading: np.ndarray  #: (E,) radians, direction of travel src → dst
    extendible: np.ndarray  #: (S,) bool per segment: at most one built-up side (C6)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_vertices(self) -> int:
        return len(self.xy)

    @property
    def direction_heading(self) -> np.ndarray:
        """(D,) radians of the lattice directions."""
        d = self.lattice.directions
        return np.arctan2(d[:, 1], d[:, 0])

    def node_vertex(self, node: int) -> int:
        """The G′ vertex of a street node."""
        return self.n_lattice + int(node)

    def masks(self, kinds: Sequence[EdgeKind] = ROAD_KINDS,
              street_ok: np.ndarray | None = None) -> tuple[KindMask, np.ndarray]:
        """Which edges a route may use.

        Parameters
        ----------
        kinds
            The edge kinds allowed.
        street_ok
            ``(S,)`` bool per segment, whether its pieces may be used (None: all).

        Returns
        -------
        (lattice, other)
            ``(V, D)`` bool over ``lat_kind``, made as it is read (:class:`KindMask`), and ``(E,)``
            bool over the other edges.
        """
        table = np.zeros(256, dtype=bool)
        table[[int(k) for k in kinds]] = True
        lat = KindMask(self.lat_kind, _lattice_key(kinds))
        extra = table[self.kind]
        if street_ok is not None and len(street_ok):
            extra &= (self.segment < 0) | np.asarray(street_ok, dtype=bool)[np.maximum(self.segment, 0)]
        return lat, extra

    def matrix(self, kinds: Sequence[EdgeKind] = ROAD_KINDS) -> csr_matrix:
        """CSR adjacency ``(V′, V′)`` over the edges of the given kinds (cached: the two most recent).

        Only the allowed edges are in it. Use :meth:`restricted` to leave streets out. The route
        searches write no matrix (they read the tables as they go, ``routing._plain_rows``, session
        37): this is the reference the tests hold them to, and the benchmarks' plain searches.
        """
        return self._base(kinds)[0]

    @contextmanager
    def restricted(self, kinds: Sequence[EdgeKind] = ROAD_KINDS,
                   street_ok: np.ndarray | None = None) -> Iterator[csr_matrix]:
        """:meth:`matrix` with the streets not in ``street_ok`` at infinite weight, for the
        duration of the ``with`` block (the cached weights are restored afterwards, so no
        copy of the whole matrix is made)."""
        base, ex, pos = self._base(kinds)
        bad = np.zeros(0, dtype=np.int64)
        if street_ok is not None and len(street_ok):
            seg = self.segment[ex]
            bad = pos[(seg >= 0) & ~np.asarray(street_ok, dtype=bool)[np.maximum(seg, 0)]]
        saved = base.data[bad].copy()
        base.data[bad] = np.inf
        try:
            yield base
        finally:
            base.data[bad] = saved

    def _base(self, kinds: Sequence[EdgeKind]) -> tuple[csr_matrix, np.ndarray, np.ndarray]:
        key = tuple(sorted(int(k) for k in kinds))
        if key not in self._cache:
            if len(self._cache) >= 2:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = self._csr(*self.masks(kinds))
        return self._cache[key]

    def _csr(self, lat: KindMask, extra: np.ndarray) -> tuple[csr_matrix, np.ndarray, np.ndarray]:
        """One CSR of the allowed edges, without sorting, and where each allowed other edge sits in it.

        A row holds its live lattice edges in direction order, then its other
        edges in their (tail-sorted) order. Only the edges that exist are
        written: an other edge ``i`` goes to ``i`` + the lattice edges of its
        row and earlier ones; the lattice edges fill the rest of their rows'
        span in row-major order of ``lat``. The lattice part is done in blocks
        of rows, so the temporaries stay a few MB while the whole map's window
        has ~5·10⁷ edges (writing every slot of the ``(V, D)`` table and dropping
        the empty ones cost a second and 12 bytes a slot per window, and per-edge
        int64 indices 3 GB); a block without other edges is one slice, the others
        are filled through a mask of their slots (a position per lattice edge
        took a fifth more time: 0.75 s against 0.6 s on Campo Grande's map).
        """
        n_lat = lat.shape[0]
        n = self.n_vertices
        lat_counts = np.zeros(n, dtype=np.int64)
        lat_counts[:n_lat] = lat.count_per_row()
        ex = np.flatnonzero(extra)
        ex_src = self.src[ex]
        ex_counts = np.bincount(ex_src, minlength=n)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(lat_counts + ex_counts, out=indptr[1:])
        total = int(indptr[-1])
        index_type = np.int32 if max(total, n) < 2**31 else np.int64
        indices = np.empty(total, dtype=index_type)
        data = np.empty(total)
        pos = np.arange(len(ex)) + np.cumsum(lat_counts)[ex_src]  # each other edge after its row's lattice edges
        offset = self.lattice.direction_offset.astype(index_type)
        weight = self.lat_weight
        for a, b in lat.row_blocks():
            lo, hi = int(indptr[a]), int(indptr[b])
            if lo == hi:
                continue
            live = lat[a:b]
            if hi - lo < _SPARSE_SHARE * live.size:  # few live entries: only theirs are read
                flat = np.flatnonzero(live)
                row, col = np.divmod(flat, live.shape[1])
                heads = np.add((row + a).astype(index_type), offset[col])
                cost = (weight.entries(weight.kind[a:b].reshape(-1)[flat], col) if isinstance(weight, LatticeWeights)
                        else weight[a:b].reshape(-1)[flat])
            else:
                heads = np.add.outer(np.arange(a, b, dtype=index_type), offset)[live]
                cost = weight.masked(slice(a, b), live) if isinstance(weight, LatticeWeights) else weight[a:b][live]
            if len(heads) == hi - lo:  # no other edge starts in these rows
                indices[lo:hi] = heads
                data[lo:hi] = cost
            else:
                slot = np.ones(hi - lo, dtype=bool)
                e0, e1 = np.searchsorted(ex_src, [a, b])  # ex_src is sorted (src is)
                slot[pos[e0:e1] - lo] = False
                indices[lo:hi][slot] = heads
                data[lo:hi][slot] = cost
        indices[pos] = self.dst[ex]
        data[pos] = self.weight[ex]
        return csr_matrix((data, indices, indptr), shape=(n, n)), ex, pos

    def steps(self, u: np.ndarray, v: np.ndarray, lat: KindMask, extra: np.ndarray) -> Steps:
        """The cheapest allowed edge ``u[i] → v[i]`` of each pair (``lat``, ``extra`` from
        :meth:`masks`), the lattice edge on a tie, else the first other edge of that weight: a
        route's edges in one call (one call per edge was 72,000 Python calls and 1 s of Campo
        Grande's run; the tests keep that edge-by-edge choice as the reference).

        Returns
        -------
        Steps
            One entry per pair; :class:`InputError` when a pair has no allowed edge.
        """
        u = np.asarray(u, dtype=np.int64).ravel()
        v = np.asarray(v, dtype=np.int64).ravel()
        m = len(u)
        out = Steps(kind=np.zeros(m, dtype=np.uint8), segment=np.full(m, -1, dtype=np.int64),
                    length=np.zeros(m), weight=np.full(m, np.inf), heading=np.zeros(m))
        found = np.zeros(m, dtype=bool)
        n_lat = self.n_lattice
        both = np.flatnonzero((u < n_lat) & (v < n_lat))
        if len(both):
            nx = self.lattice.shape[1]
            dirs = self.lattice.directions
            r = int(np.abs(dirs).max()) if len(dirs) else 0
            table = np.full((2 * r + 1, 2 * r + 1), -1, dtype=np.int64)
            table[dirs[:, 0] + r, dirs[:, 1] + r] = np.arange(len(dirs))  # one cell each: the directions are unique
            dx = v[both] % nx - u[both] % nx
            dy = v[both] // nx - u[both] // nx
            near = (np.abs(dx) <= r) & (np.abs(dy) <= r)
            k = np.full(len(both), -1, dtype=np.int64)
            k[near] = table[dx[near] + r, dy[near] + r]
            ok = k >= 0
            ok[ok] = lat[u[both[ok]], k[ok]]
            at, k = both[ok], k[ok]
            out.kind[at] = self.lat_kind[u[at], k]
            out.length[at] = self.lattice.direction_length[k]
            out.weight[at] = np.asarray(self.lat_weight[u[at], k], dtype=np.float64)
            out.heading[at] = self.direction_heading[k]
            found[at] = True
        lo, hi = np.searchsorted(self.src, u), np.searchsorted(self.src, u + 1)
        count = hi - lo
        pair = np.repeat(np.arange(m), count)
        edge = np.repeat(lo, count) + np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        keep = (self.dst[edge] == v[pair]) & extra[edge]
        pair, edge = pair[keep], edge[keep]
        order = np.lexsort((edge, self.weight[edge], pair))  # by pair, then weight, then edge
        pair, edge = pair[order], edge[order]
        first = np.ones(len(pair), dtype=bool)
        first[1:] = pair[1:] != pair[:-1]
        pair, edge = pair[first], edge[first]
        better = ~found[pair] | (self.weight[edge] < out.weight[pair])
        pair, edge = pair[better], edge[better]
        out.kind[pair] = self.kind[edge]
        out.segment[pair] = self.segment[edge]
        out.length[pair] = self.length[edge]
        out.weight[pair] = self.weight[edge]
        out.heading[pair] = self.heading[edge]
        found[pair] = True
        if not found.all():
            i = int(np.flatnonzero(~found)[0])
            raise InputError(f"G′ has no allowed edge from vertex {u[i]} to {v[i]}")
        return out

    def live_vertices(self) -> np.ndarray:
        """Vertices with at least one edge, sorted."""
        lat = np.flatnonzero((self.lat_kind != NO_EDGE).any(axis=1))
        return np.union1d(lat, self.src)

    def nearest_vertex(self, xy: np.ndarray) -> int:
        """The live vertex nearest to a point ``(2,)`` m."""
        candidates = self.live_vertices()
        d = np.hypot(*(self.xy[candidates] - np.asarray(xy, dtype=float)).T)
        return int(candidates[np.argmin(d)])


@dataclass(frozen=True)
class StreetPart:
    """The street side of G′ for one year, the same whichever window of the lattice is searched.

    Street points are numbered street-locally: node j is j, split point p is
    ``N + p``; in a G′ they follow the lattice's vertices.
    """

    segments: SegmentTable
    blocks: shapely.Geometry | None  #: the built-up blocks (stitches stay out of them)
    extendible: np.ndarray  #: (S,) bool, at most one built-up side (C6)
    split_xy: np.ndarray  #: (P, 2) m
    split_parent: np.ndarray  #: (P,) parent segment of each split point
    pieces: np.ndarray  #: (Q, 3) segment, from code, to code (see :func:`_split_segments`)
    xy: np.ndarray  #: (N + P, 2) m, street points
    points: np.ndarray  #: street-local ids of the extendible street points (where stitches start)
    edges: tuple[np.ndarray, ...]  #: street pieces: u, v (street-local), kind, segment, length, weight
    shell: tuple[np.ndarray, ...]  #: checked stitches between shell points, as ``edges``
    tree: shapely.STRtree  #: the segments' lines
    inner: shapely.Geometry | None  #: the built-up blocks shrunk by 0.5 m (None: none)
    #: this year's street verdicts on the shell stitches, for next year's (:func:`street_part`)
    verdicts: ShellVerdicts | None = None
    #: the blocks that changed since the last B (:attr:`BuiltUpArea.changed`): a stitch away from
    #: them keeps its verdict on the built-up blocks
    changed: BlocksChanged | None = None

    @cached_property
    def sorted_edges(self) -> tuple[np.ndarray, ...]:
        """The street pieces and shell stitches in both directions as G′ holds them, street-locally
        numbered: sorted by (tail, head), of parallel edges the cheapest (the first of equal ones,
        pieces before shell stitches, forward before backward), as ``src, dst, kind, segment,
        length, weight, heading``.

        Made once per street part (a new object, e.g. from :func:`street_part_again`, makes it
        again): every window of a year holds the same street edges, and sorting them with the
        window's own edges was most of :func:`pathfinding_graph`'s own time (Campo Grande's 36
        captured searches, 48 windows, profiled: 1.63 s, now 1.17 s with this sort and the merges). A
        street edge joins two street points, a window's own edges (long
        bridges, stitches to the lattice) a lattice vertex, so no pair of ends is in both and
        the two sorted lists merge into the order one sort of them all gave
        (:func:`_merged_edges`)."""
        return _sorted_edges([self.edges, self.shell], self.xy)


def street_part(lattice: Lattice, segments: SegmentTable, built: BuiltUpArea | None = None, *,
                costs: EdgeCosts | None = None, options: GraphOptions | None = None,
                previous: ShellVerdicts | None = None) -> StreetPart:
    """The street pieces and shell stitches of G′ (003 Fig. 9), made once a year.

    Parameters
    ----------
    lattice
        Any window of the map's lattice (its rasters check the stitches for water).
    segments, built, costs, options
        As :func:`pathfinding_graph`.
    previous
        Last year's :attr:`StreetPart.verdicts` (None: every shell stitch is checked);
        the result is the same either way.

    Returns
    -------
    StreetPart
    """
    costs = costs or EdgeCosts()
    opts = options or GraphOptions()
    blocks = built.blocks if built is not None else None
    changed = built.changed if built is not None else None
    extendible = segment_sides(segments, blocks) <= 1
    split_xy, split_parent, pieces = _split_segments(segments, extendible, opts.split_spacing)
    xy = np.concatenate([segments.xy, split_xy])
    n_nodes = len(segments.xy)
    edges = _segment_part(lattice, segments, xy, pieces, extendible, 0, costs)
    ext_pieces = pieces[extendible[pieces[:, 0]]]
    points = _code_vertex(_unique(ext_pieces[:, 1:].ravel()), 0, n_nodes)
    tree = segments.tree()
    inner = None
    if blocks is not None and not blocks.is_empty:
        inner = shapely.buffer(blocks, -0.5)
        if inner.is_empty:
            inner = None
        else:
            shapely.prepare(inner)
    shell = np.zeros((0, 2), dtype=np.int64)
    verdicts = None
    if len(points):
        shell = nearest_pairs(xy[points], xy[points], points, points, opts.max_shell_stitches + 1,
                               opts.shell_stitch_radius)
        shell = np.sort(shell[shell[:, 0] != shell[:, 1]], axis=1)
        # each pair once, in (a, b) order: one int64 key a row (np.unique's axis=0 sorted rows as
        # records, 0.1 s a year on Campo Grande's shell)
        key = _unique(shell[:, 0] * np.int64(len(xy)) + shell[:, 1])
        shell = np.stack([key // len(xy), key % len(xy)], axis=1)
        shell = shell[~_duplicates_piece(shell, pieces, 0, n_nodes, len(xy))]
        ok, verdicts = carried_ok(lattice, segments, xy, shell, split_parent, 0, opts, tree, inner, previous,
                                  blocks=blocks, changed=changed)
        shell = shell[ok]
    part = StreetPart(segments=segments, blocks=blocks, extendible=extendible, split_xy=split_xy,
                      split_parent=split_parent, pieces=pieces, xy=xy, points=points, edges=edges,
                      shell=(), tree=tree, inner=inner, verdicts=verdicts, changed=changed)
    return replace(part, shell=_stitch_edges(lattice, shell, xy))


def street_part_again(part: StreetPart, lattice: Lattice, segments: SegmentTable, costs: EdgeCosts) -> StreetPart:
    """``part`` for ``segments`` of the very same ends, widths and harbours, on the same lattice and
    blocks, with another year's costs, capacities and major roads: only the street pieces' kinds and
    weights are worked out again (C1…C6 and which streets are major change from year to year; the
    points, pieces, stitches and their verdicts do not depend on them)."""
    edges = _segment_part(lattice, segments, part.xy, part.pieces, part.extendible, 0, costs)
    return replace(part, segments=segments, edges=edges)


def _stitch_edges(lattice: Lattice, pairs: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, ...]:
    """Stitch edges (u, v, kind, segment, length, weight) of checked pairs, none steeper than the cutoff."""
    u, v = pairs[:, 0], pairs[:, 1]
    length, weight, slope = _road_weight(lattice, xy, u, v)
    keep = slope <= lattice.slope_cutoff
    n = int(keep.sum())
    return u[keep], v[keep], np.full(n, EdgeKind.STITCH, np.uint8), np.full(n, -1), length[keep], weight[keep]


def pathfinding_graph(lattice: Lattice, segments: SegmentTable, built: BuiltUpArea | None = None, *,
                      costs: EdgeCosts | None = None, options: GraphOptions | None = None,
                      streets: StreetPart | None = None,
                      stitch_within: tuple[float, float, float, float] | None = None,
                      stitch_cache: dict | None = None) -> PathGraph:
    """Assemble G′ from the lattice (B already removed), the segments and stitches (003 §3.4.2).

    Parameters
    ----------
    lattice
        G after :meth:`Lattice.with_built_up`, or a window of it.
    segments
        The current segment graph.
    built
        B and the built-up blocks (for extendible segments and stitch checks);
        None: no built-up blocks (every segment extendible).
    costs
        C1…C6 of this year.
    options
        :class:`GraphOptions`.
    streets
        This year's :func:`street_part` (made here when None).
    stitch_within
        ``(xmin, ymin, xmax, ymax)`` m: only street points inside get stitches to the
        lattice (a window's edge: a point nearer to it may miss its nearest vertices).
    stitch_cache
        Stitches already checked this year (see :class:`ImplicitGraph`).

    Returns
    -------
    PathGraph
        Lattice tables plus street, stitch and long-bridge edges in both
        directions, with kinds, C-weighted costs and headings. Every segment
        is in it; which ones a route may use (capacity, road type) is a mask
        given to the search, so one G′ serves a whole year.
    """
    costs = costs or EdgeCosts()
    opts = options or GraphOptions()
    if streets is None:
        streets = street_part(lattice, segments, built, costs=costs, options=opts)
    n_lat = lattice.n_vertices
    xy = np.concatenate([lattice.vertex_xy(), streets.xy])
    lat_kind, lat_weight, bridges = _lattice_part(lattice, segments, costs, streets.tree)
    # the vertices with a land or bridge edge (what a road may use of the lattice), by blocks of rows:
    # no (V, D) table more than ``lat_kind`` (issue 22)
    used = KindMask(lat_kind, _lattice_key((EdgeKind.LAND, EdgeKind.BRIDGE))).any_per_row()
    targets = np.flatnonzero(used & (lattice.vertex_class == VertexClass.LAND))
    points = streets.points
    if stitch_within is not None and len(points):
        px, py = streets.xy[points].T
        points = points[(px >= stitch_within[0]) & (px <= stitch_within[2])
                        & (py >= stitch_within[1]) & (py <= stitch_within[3])]
    pairs = _lattice_stitches(lattice, segments, streets, xy, targets, points, opts, stitch_cache)
    own = _sorted_edges([bridges, _stitch_edges(lattice, pairs, xy)], xy)
    src, dst, kind, seg, length, weight, heading = _merged_edges(streets.sorted_edges, own, n_lat, len(xy))
    return PathGraph(lattice=lattice, segments=segments, xy=xy, n_lattice=n_lat, split_segment=streets.split_parent,
                     lat_kind=lat_kind, lat_weight=lat_weight, src=src, dst=dst, kind=kind, segment=seg,
                     length=length, weight=weight, heading=heading, extendible=streets.extendible)


def _sorted_edges(parts: Sequence[tuple[np.ndarray, ...]], xy: np.ndarray) -> tuple[np.ndarray, ...]:
    """Undirected edges ``(u, v, kind, segment, length, weight)`` of ``parts`` (in this order) in both
    directions, sorted by (tail, head), of parallel edges the cheapest (the first of equal weight
    in the order: the parts' forward edges, then the backward ones), with their headings
    (``xy``: the vertices' positions), as ``src, dst, kind, segment, length, weight, heading``."""
    src, dst, kind, seg, length, weight = (np.concatenate(c) for c in zip(*parts))
    heading = np.arctan2(xy[dst, 1] - xy[src, 1], xy[dst, 0] - xy[src, 0])
    back = np.where(heading > 0, heading - np.pi, heading + np.pi)
    src, dst = np.concatenate([src, dst]), np.concatenate([dst, src])
    kind, seg, length, weight = (np.concatenate([a, a]) for a in (kind, seg, length, weight))
    heading = np.concatenate([heading, back])
    order = _edge_order(src, dst, weight, len(xy))
    return tuple(a[order] for a in (src, dst, kind, seg, length, weight, heading))


def _edge_order(src: np.ndarray, dst: np.ndarray, weight: np.ndarray, n: int) -> np.ndarray:
    """The edges ``(src, dst)`` (vertices below ``n``) in (tail, head) order, of parallel edges only the
    cheapest (the first of equal weight): the order ``np.lexsort((weight, dst, src))`` gives, with its
    first of each (tail, head) kept.

    One stable sort of (tail, head) as one int64, then only the parallel edges (few) put in weight order:
    the lexsort's three passes over every edge were 2-3 times the time (the street part's and each
    window's own edges on Campo Grande)."""
    key = src * np.int64(n) + dst
    order = np.argsort(key, kind="stable")
    ranked = key[order]
    parallel = np.zeros(len(order), dtype=bool)  # an edge with the (tail, head) of the one before it
    parallel[1:] = ranked[1:] == ranked[:-1]
    if parallel.any():
        group = parallel.copy()
        group[:-1] |= parallel[1:]
        at = np.flatnonzero(group)
        members = order[at]  # each group's edges in their order: lexsort keeps it among equal weights
        order[at] = members[np.lexsort((weight[members], key[members]))]
    return order[~parallel]  # of parallel edges keep the cheapest


def _merged_edges(street: tuple[np.ndarray, ...], own: tuple[np.ndarray, ...], n_lat: int,
                  n: int) -> tuple[np.ndarray, ...]:
    """A window's sorted edges (:func:`_sorted_edges`): the street part's (:attr:`StreetPart.sorted_edges`,
    street-local: shifted by ``n_lat``) merged with the window's ``own`` (each end a G′ vertex of ``n``).

    No (tail, head) pair is in both (a street edge joins two street points, the window's own touch
    the lattice), so the merge by that key is the order of one stable sort of them all."""
    s_src, s_dst = street[0] + n_lat, street[1] + n_lat
    key = np.searchsorted(s_src * np.int64(n) + s_dst, own[0] * np.int64(n) + own[1])
    at = key + np.arange(len(key))  # each own edge's place among them all
    mine = np.zeros(len(s_src) + len(key), dtype=bool)
    mine[at] = True
    out = []
    for s_col, o_col in zip((s_src, s_dst, *street[2:]), own):
        col = np.empty(len(mine), dtype=np.result_type(s_col, o_col))
        col[at] = o_col
        col[~mine] = s_col
        out.append(col)
    return tuple(out)


def _lattice_stitches(lattice: Lattice, segments: SegmentTable, streets: StreetPart, xy: np.ndarray,
                      targets: np.ndarray,
                      points: np.ndarray, opts: GraphOptions, cache: dict | None) -> np.ndarray:
    """Checked stitches ``(G′ street vertex, lattice vertex)`` from street points (street-local ids)
    to their nearest live land vertices; with ``cache``, each point is checked once a year."""
    n_lat = lattice.n_vertices
    if not len(points) or not len(targets):
        return np.zeros((0, 2), dtype=np.int64)

    def checked(chosen: np.ndarray) -> np.ndarray:
        ids = chosen + n_lat
        # only the targets a chosen point can reach go into the search tree: the same pairs (every
        # candidate within the radius is among them, and ties go by map vertex), where the tree of
        # a window's every live land vertex (~5·10⁵ on Campo Grande) was most of the stitches' time
        near = targets[within_reach(lattice, xy[ids], targets, opts.stitch_radius)]
        pairs = nearest_pairs(xy[ids], xy[near], ids, near, opts.max_stitches, opts.stitch_radius,
                               keys=lattice.map_vertex(near))
        if cache is None:
            return pairs[stitch_ok(lattice, segments, xy, pairs, streets.split_parent, n_lat, opts, streets.tree,
                                    streets.inner)]
        ok, verdicts = carried_ok(lattice, segments, xy, pairs, streets.split_parent, n_lat, opts, streets.tree,
                                   streets.inner, cache.get("previous"), memo=cache, blocks=streets.blocks,
                                   changed=streets.changed)
        cache.setdefault("verdicts", []).append(verdicts)
        return pairs[ok]

    if cache is None:
        return checked(points)
    done = cache.setdefault("done", np.zeros(len(streets.xy), dtype=bool))
    found = cache.setdefault("pairs", [np.zeros((0, 2), dtype=np.int64)])
    todo = points[~done[points]]
    if len(todo):
        pairs = checked(todo)
        found.append(np.stack([pairs[:, 0] - n_lat, lattice.map_vertex(pairs[:, 1])], axis=1))
        done[todo] = True
    every = np.concatenate(found)
    cache["pairs"] = [every]
    mine = np.zeros(len(streets.xy), dtype=bool)
    mine[points] = True
    every = every[mine[every[:, 0]]]
    return np.stack([every[:, 0] + n_lat, lattice._local(every[:, 1])], axis=1)


def _lattice_part(lattice: Lattice, segments: SegmentTable, costs: EdgeCosts,
                  tree: shapely.STRtree | None = None) -> tuple[np.ndarray, np.ndarray | LatticeWeights,
                                                                 tuple[np.ndarray, ...]]:
    """Directed live lattice tables with C3 (harbour) and C5 (bridge), and the long bridges
    as edges; bridges and harbours that cross a street are left out (a new bridge does
    not pass over a road)."""
    kind, weight = lattice.directed_tables()
    special = lattice.special_entries()
    lattice._cache.pop("directed", None)  # the tables become G′'s: edited in place, made again if asked for
    if isinstance(weight, LatticeWeights):
        weight = weight.times({EdgeKind.BRIDGE: costs.bridge, EdgeKind.HARBOUR: costs.harbour})
    else:
        flat_kind, flat_weight = kind.reshape(-1), weight.reshape(-1)
        flat_weight[special] *= np.where(flat_kind[special] == EdgeKind.BRIDGE, costs.bridge, costs.harbour)
    n_dir = kind.shape[1]
    rows = special // n_dir
    ends = np.stack([rows, rows + lattice.direction_offset[special - rows * n_dir]], axis=1)
    ends = np.concatenate([ends, np.stack([lattice.bridge_src, lattice.bridge_dst], axis=1)])
    crossing = np.zeros(len(ends), dtype=bool)
    if len(ends) and len(segments.uv):
        xy = lattice.vertex_xy(ends.ravel()).reshape(-1, 2, 2)
        tree = tree if tree is not None else segments.tree()
        hit, _ = tree.query(shapely.linestrings(xy), predicate="intersects")
        crossing[hit] = True
    np.put(kind, special[crossing[:len(special)]], NO_EDGE)
    ok = ~crossing[len(special):]
    n = int(ok.sum())
    bridges = (lattice.bridge_src[ok], lattice.bridge_dst[ok], np.full(n, EdgeKind.BRIDGE, np.uint8),
               np.full(n, -1), lattice.bridge_length[ok], lattice.bridge_length[ok] * costs.bridge)
    return kind, weight, bridges


@dataclass(frozen=True)
class GraphWindow:
    """G′ over a window of the lattice (:meth:`ImplicitGraph.window`) and how it sits in the map.

    ``graph`` numbers the window's lattice vertices first, then every street
    point of the map. It holds exactly the edges of the whole G′ between its
    vertices, except those that start at ``exits``: vertices near the
    window's edge (their lattice edges, their stitches or a long bridge may
    leave it). A route that leaves the window passes one of them first.
    """

    graph: PathGraph
    whole: bool  #: the window is the whole map
    exits: np.ndarray  #: window vertices where an edge of G′ may leave the window
    n_map_lattice: int  #: vertices of the whole map's lattice

    def to_map(self, vertices: np.ndarray) -> np.ndarray:
        """Map G′ vertex of each window vertex."""
        v = np.asarray(vertices, dtype=np.int64)
        n = self.graph.n_lattice
        return np.where(v < n, self.graph.lattice.map_vertex(np.minimum(v, max(n - 1, 0))),
                        v - n + self.n_map_lattice)

    def from_map(self, vertices: np.ndarray) -> np.ndarray:
        """Window vertex of each map G′ vertex (−1 outside the window)."""
        v = np.asarray(vertices, dtype=np.int64)
        street = v >= self.n_map_lattice
        lattice = self.graph.lattice._local(np.where(street, 0, v))
        return np.where(street, v - self.n_map_lattice + self.graph.n_lattice, lattice)


@dataclass(frozen=True)
class ImplicitGraph:
    """A year's G′ whose lattice part is made only where a search looks (see :meth:`window`).

    It answers what the major-road step asks of G′ (vertex numbering, street
    points, which segments are extendible, the rasters) without any table
    over the whole map; :func:`osm_expand.engine.roads.routing.find_route` searches
    it in growing windows until the result is provably the whole map's.
    Vertex numbering is the whole map's G′: lattice vertices, street nodes,
    split points.
    """

    lattice: Lattice  #: the whole map (B removed), its edges never generated here
    segments: SegmentTable
    streets: StreetPart
    costs: EdgeCosts
    options: GraphOptions
    #: the stitches already checked this year (see :func:`pathfinding_graph`); ``"previous"``: the
    #: street verdicts of the last G′'s stitches to the lattice (:meth:`lattice_verdicts`)
    stitches: dict = field(default_factory=dict, repr=False, compare=False)

    def lattice_verdicts(self) -> ShellVerdicts | None:
        """The street verdicts of every stitch to the lattice checked so far, for the next G′
        (:func:`implicit_graph`'s ``previous_lattice``); None when none was checked."""
        return lattice_verdicts(self.stitches)

    @property
    def n_lattice(self) -> int:
        return self.lattice.n_vertices

    @property
    def n_vertices(self) -> int:
        return self.n_lattice + len(self.streets.xy)

    @property
    def split_segment(self) -> np.ndarray:
        return self.streets.split_parent

    @property
    def extendible(self) -> np.ndarray:
        return self.streets.extendible

    def node_vertex(self, node: int) -> int:
        """The G′ vertex of a street node."""
        return self.n_lattice + int(node)

    def vertex_xy(self, vertices: np.ndarray) -> np.ndarray:
        """Positions of G′ vertices, ``(n, 2)`` m."""
        v = np.atleast_1d(np.asarray(vertices, dtype=np.int64))
        street = v >= self.n_lattice
        out = self.lattice.vertex_xy(np.where(street, 0, v))
        out[street] = self.streets.xy[v[street] - self.n_lattice]
        return out

    def whole(self) -> PathGraph:
        """The whole map's G′ (every lattice table made: the old search, for comparison)."""
        return pathfinding_graph(self.lattice, self.segments, costs=self.costs, options=self.options,
                                 streets=self.streets)

    def window(self, bounds: tuple[float, float, float, float]) -> GraphWindow:
        """G′ over the lattice vertices inside ``(xmin, ymin, xmax, ymax)`` m (clipped to the map).

        Lattice vertices within the neighbourhood radius of a side of the
        window that is not the map's, street points whose stitches could
        reach past it (stitch radius + radius), and the ends of long bridges
        that cross it are the window's ``exits``.
        """
        lat = self.lattice
        ny, nx = lat.shape
        ell = lat.spacing
        c0 = int(np.floor((bounds[0] - lat.origin[0]) / ell))
        r0 = int(np.floor((bounds[1] - lat.origin[1]) / ell))
        c1 = int(np.ceil((bounds[2] - lat.origin[0]) / ell)) + 1
        r1 = int(np.ceil((bounds[3] - lat.origin[1]) / ell)) + 1
        sub = lat.window(r0, c0, r1 - r0, c1 - c0)
        whole = sub is lat
        r0, c0 = sub.offset
        h, w = sub.shape
        open_side = (c0 > 0, r0 > 0, c0 + w < nx, r0 + h < ny)  # left, bottom, right, top
        band = sub.radius
        x0, y0 = sub.origin
        x1, y1 = sub.origin + (np.array([w, h]) - 1) * ell
        reach = self.options.stitch_radius + band * ell
        within = None
        exits: list[np.ndarray] = []
        a, b = sub._local(lat.map_bridges[:, 0]), sub._local(lat.map_bridges[:, 1])
        if sub is not lat:
            within = (x0 + reach if open_side[0] else -np.inf, y0 + reach if open_side[1] else -np.inf,
                      x1 - reach if open_side[2] else np.inf, y1 - reach if open_side[3] else np.inf)
            iy, ix = np.divmod(np.arange(h * w), w)
            near = ((open_side[0] & (ix < band)) | (open_side[1] & (iy < band))
                    | (open_side[2] & (ix >= w - band)) | (open_side[3] & (iy >= h - band)))
            exits.append(np.flatnonzero(near))
            pts = self.streets.points
            px, py = self.streets.xy[pts].T
            outside = (px < within[0]) | (px > within[2]) | (py < within[1]) | (py > within[3])
            exits.append(sub.n_vertices + pts[outside])
            exits.append(np.where(a >= 0, a, b)[(a >= 0) != (b >= 0)])
        graph = pathfinding_graph(sub, self.segments, costs=self.costs, options=self.options, streets=self.streets,
                                  stitch_within=within, stitch_cache=self.stitches)
        sub._cache.clear()  # the edge tables live on in the graph's; a window is searched once
        return GraphWindow(graph=graph, whole=whole, exits=np.unique(np.concatenate(exits)) if exits
                           else np.zeros(0, dtype=np.int64), n_map_lattice=lat.n_vertices)


def implicit_graph(lattice: Lattice, segments: SegmentTable, built: BuiltUpArea | None = None, *,
                   costs: EdgeCosts | None = None, options: GraphOptions | None = None,
                   previous: ShellVerdicts | None = None,
                   previous_lattice: ShellVerdicts | None = None) -> ImplicitGraph:
    """This year's G′ without its lattice tables: only the street part is made now.

    Parameters
    ----------
    lattice, segments, built, costs, options
        As :func:`pathfinding_graph`.
    previous
        Last year's shell verdicts (:attr:`StreetPart.verdicts`), see :func:`street_part`.
    previous_lattice
        The last G′'s verdicts on the stitches to the lattice (:meth:`ImplicitGraph.lattice_verdicts`):
        a stitch nothing changed near is not tested against the streets again.

    Returns
    -------
    ImplicitGraph
    """
    costs = costs or EdgeCosts()
    opts = options or GraphOptions()
    return ImplicitGraph(lattice=lattice, segments=segments,
                         streets=street_part(lattice, segments, built, costs=costs, options=opts,
                                             previous=previous),
                         costs=costs, options=opts,
                         stitches={} if previous_lattice is None else {"previous": previous_lattice})


def _split_segments(segments: SegmentTable, split: np.ndarray, spacing: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interior points along the marked segments of at least 2ℓ (= 2 × spacing / 1.25):
    ⌊length / spacing⌋ equidistant ones, as 003 §3.3 adds temporary nodes.

    Returns the split points, their parent segments, and the pieces as
    ``(segment, from_vertex_code, to_vertex_code)`` rows where a code ≥ 0 is
    a node and ``−1 − p`` is split point ``p``.
    """
    length = segments.length
    count = np.where(split & (length >= 2.0 * spacing / 1.25), np.floor(length / spacing).astype(np.int64), 0)
    parent = np.repeat(np.arange(len(length)), count)
    first = np.concatenate([[0], np.cumsum(count)])[:-1]
    rank = np.arange(int(count.sum())) - np.repeat(first, count)
    t = (rank + 1) / np.repeat(count + 1, count)
    a, b = segments.a, segments.b
    split_xy = a[parent] + t[:, None] * (b[parent] - a[parent])
    # pieces: each segment's chain node u, p1..pk, node v
    chain_len = count + 2
    seg_of = np.repeat(np.arange(len(length)), chain_len - 1)
    codes = np.empty(int(chain_len.sum()), dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(chain_len)])[:-1]
    codes[starts] = segments.uv[:, 0]
    codes[starts + chain_len - 1] = segments.uv[:, 1]
    interior = np.ones(len(codes), dtype=bool)
    interior[starts] = interior[starts + chain_len - 1] = False
    codes[interior] = -1 - np.arange(int(count.sum()))
    last = np.zeros(len(codes), dtype=bool)
    last[starts + chain_len - 1] = True
    from_code = codes[~last]
    to_code = codes[np.flatnonzero(~last) + 1]
    return split_xy, parent, np.stack([seg_of, from_code, to_code], axis=1)


def _unique(values: np.ndarray) -> np.ndarray:
    """``np.unique`` of a 1-D integer array, by sorting: numpy 2's hashing ``np.unique`` took ten
    times as long on a street part's codes and pair keys (2.4 s of Campo Grande's 11 street parts)."""
    out = np.sort(values)
    keep = np.ones(len(out), dtype=bool)
    keep[1:] = out[1:] != out[:-1]
    return out[keep]


def _code_vertex(code: np.ndarray, n_lat: int, n_nodes: int) -> np.ndarray:
    return np.where(code >= 0, n_lat + code, n_lat + n_nodes + (-1 - code))


def _segment_part(lattice: Lattice, segments: SegmentTable, xy: np.ndarray, pieces: np.ndarray,
                  extendible: np.ndarray, n_lat: int, costs: EdgeCosts) -> tuple[np.ndarray, ...]:
    """Street pieces with C1 / C2 / C4 and C6; weight = length · max(1, O1 · slope)."""
    seg = pieces[:, 0]
    n_nodes = len(segments.xy)
    u = _code_vertex(pieces[:, 1], n_lat, n_nodes)
    v = _code_vertex(pieces[:, 2], n_lat, n_nodes)
    kind = np.where(segments.major[seg], EdgeKind.MAJOR, EdgeKind.MINOR).astype(np.uint8)
    factor = np.where(segments.major[seg], costs.major, costs.minor)
    if segments.harbour is not None:
        kind[segments.harbour[seg]] = EdgeKind.BUILT_HARBOUR
        factor = np.where(segments.harbour[seg], costs.built_harbour, factor)
    factor = factor * np.where(extendible[seg], costs.extendible, 1.0)
    length, weight, _ = _road_weight(lattice, xy, u, v)
    return u, v, kind, seg, length, weight * factor


def _road_weight(lattice: Lattice, xy: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """Length, weight ``length · max(1, O1 · slope)`` (slope between the ends) and slope of straight edges."""
    length = np.hypot(*(xy[v] - xy[u]).T)
    slope = np.zeros(len(u))
    if lattice.height is not None and len(u):
        at_v, at_u = lattice.height_at(xy[v]), lattice.height_at(xy[u])
        assert at_v is not None and at_u is not None  # the lattice has heights
        slope = np.abs(at_v - at_u) / np.maximum(length, 1e-9)
    return length, length * np.maximum(1.0, lattice.slope_weight * slope), slope


def _duplicates_piece(pairs: np.ndarray, pieces: np.ndarray, n_lat: int, n_nodes: int, n: int) -> np.ndarray:
    """Sorted pairs that join the two ends of a street piece (a stitch would lie on the street)."""
    ends = np.sort(np.stack([_code_vertex(pieces[:, 1], n_lat, n_nodes),
                             _code_vertex(pieces[:, 2], n_lat, n_nodes)], 1), axis=1)
    known = np.sort(ends[:, 0] * np.int64(n) + ends[:, 1])  # searched, not np.isin (which hashes: see _unique)
    if not len(known):
        return np.zeros(len(pairs), dtype=bool)
    key = pairs[:, 0] * np.int64(n) + pairs[:, 1]
    return known[np.minimum(np.searchsorted(known, key), len(known) - 1)] == key
