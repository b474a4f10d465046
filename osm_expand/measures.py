"""Measures of a street network: the numbers a fidelity verdict compares.

The input is any set of polylines in metres, so the same measures describe an
OSM file as read, a GeoJSON file, the tool's own XML (segments with
coordinates only) or a grown district. Nothing here reads the project's
model.

Graph, from the lines alone
---------------------------
*Nodes* are points identified by their coordinates rounded to
``node_precision`` (1 cm): two lines that share a point share a node; a
bridge crossing a street without a shared point is no junction. Repeated
segments (a street drawn twice) count once. The *degree* of a node is the
number of segment ends there (a street passing through counts 2). *Junctions* have degree ≥ 3, *dead ends*
degree 1; degree-2 nodes are shape points. *Edges* are the maximal chains of
segments between nodes that are not shape points; a closed chain of shape
points (a ring with no junction) is one edge too.

*Open* ends are neither dead ends nor junctions: ends made by clipping the
lines to the ``window`` (degree-1 nodes within ``open_tolerance`` of its
boundary) and the caller's ``open_points`` (where a grown district meets the
old town; any node there). An edge with an open end is *cut*.

The measures (the fidelity issue; seed 004 §5.2–5.3 asks a district to look like its town)
-----------------------------------------------------------------------------------------
Distributions (1-D arrays):

- ``edge_length`` (m): arc length of every edge that is not cut.
- ``circuity``: arc length / chord (straight end-to-end distance) of every
  edge that is not cut, not a loop and has a chord of at least
  ``min_chord``. A cut edge's inside piece is not a real edge, so it enters
  neither.
- ``stroke_length`` (m): at each junction the pairs of edge ends that
  deflect less than ``stroke_deflection`` (180° minus the angle between the
  two leaving directions) are joined, smallest deflection first, each end at
  most once (greedy; ties by position); the chains of joined edges are
  strokes. Cut edges count with their length inside the window: a stroke
  cut by a window of the district's area is what both the district and a
  real part of that area show, and dropping cut strokes would drop every
  through street.
- ``junction_angle`` (degrees): around each junction, the angles between
  angularly consecutive edge ends (they sum to 360°; a four-way grid
  junction gives 90° four times, a T gives 90°, 90°, 180°). An edge end's
  direction points to the point ``heading_reach`` metres along the edge
  (or its far end), not along its first shape segment.
- ``block_area`` (m²) and ``block_compactness`` (4πA/P², 1 for a disc,
  π/4 for a square): bounded faces of the edges
  (:func:`shapely.polygonize`; dangles and cut edges bound nothing) of at
  least ``min_block_area``. Faces cut by the window are not closed and are
  not counted.
- ``alignment`` (degrees, 0–45): for each edge with a chord (cut ones
  included: their inside chord), the chord's direction against those of its
  ``alignment_neighbours`` nearest edges by arc midpoint within
  ``alignment_radius``, one value per (edge, neighbour) pair: the absolute
  difference mod 90°, folded to [0°, 45°] (0 for parallel and for
  perpendicular streets).
- ``curvature`` (degrees): every edge (cut ones included) resampled every
  ``curvature_step`` metres from its start; the absolute heading change
  between consecutive steps. A circle of radius R gives step/R radians.

Scalars (floats, NaN when undefined):

- ``density`` (km per km²): street length inside the window / window area.
  Without a window, the window is the lines' convex hull grown by
  ``hull_margin``.
- ``orientation_entropy`` (nats): Boeing (2019), "Urban spatial order:
  street network orientation, configuration, and entropy", Applied Network
  Science 4:67: the Shannon entropy of compass bearings in 36 bins of 10°
  centred on 0°, 10°, … (as osmnx's ``orientation_entropy``), every
  segment counted in both directions and weighted by its length. A grid
  aligned with the axes has ln 4 ≈ 1.386, uniform bearings ln 36 ≈ 3.584.
  Boeing bins each edge's end-to-end bearing; segment bearings keep the
  shape of curved edges (as :mod:`simplify.statistics` does).
- ``three_way_share``, ``four_way_share``, ``dead_end_share``: the
  shares of degree-3 junctions, degree-4 junctions and dead ends among the
  junctions and dead ends (Boeing's node proportions; open ends and shape
  points are not counted). :mod:`simplify.statistics` reports the 3- and
  4-way shares among junctions only, on the simplified network.
- ``two_core_share``: the share of the street length left after pruning
  dead-end trees (issue 20): edges with a dead end are removed, then those
  that became dead ends, until none is left (:func:`two_core`). Open ends
  are never pruned: a street cut by the window runs on outside it, and a
  district's street ending on the old town is joined there. How much of the
  network forms blocks or runs through: 1 for a grid without stubs, 0 for a
  tree; NaN with no street.

Apart from the verdict, ``pieces`` counts what the network makes on the
map: its lines (clipped to the window) buffered ``piece_buffer`` metres each
side and merged, the number of polygons (issue 20: a neighbourhood is one
piece). Two lines are in one piece when they are within twice the buffer of
each other, so the count is the connected components of the lines' "within
2 × buffer" pairs (an STRtree query), not a union of buffers.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from enum import StrEnum

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from osm_expand.errors import InputError

__all__ = ["DISTRIBUTIONS", "SCALARS", "LineSet", "Measure", "MeasureOptions", "NetworkMeasures",
           "count_pieces", "junction_points", "measure_named", "measure_network", "orientation_entropy", "two_core"]


class Measure(StrEnum):
    """The fourteen measures, in report order: eight distributions, then six scalars."""

    EDGE_LENGTH = "edge_length"
    CIRCUITY = "circuity"
    STROKE_LENGTH = "stroke_length"
    JUNCTION_ANGLE = "junction_angle"
    BLOCK_AREA = "block_area"
    BLOCK_COMPACTNESS = "block_compactness"
    ALIGNMENT = "alignment"
    CURVATURE = "curvature"
    DENSITY = "density"
    ORIENTATION_ENTROPY = "orientation_entropy"
    THREE_WAY_SHARE = "three_way_share"
    FOUR_WAY_SHARE = "four_way_share"
    DEAD_END_SHARE = "dead_end_share"
    TWO_CORE_SHARE = "two_core_share"


DISTRIBUTIONS: tuple[Measure, ...] = tuple(Measure)[:8]
SCALARS: tuple[Measure, ...] = tuple(Measure)[8:]


def measure_named(name: Measure | str) -> Measure:
    """The :class:`Measure` called ``name``; :class:`InputError` listing the valid names otherwise."""
    try:
        return Measure(name)
    except ValueError:
        raise InputError(f"unknown measure {name!r} (valid: {', '.join(m.value for m in Measure)})") from None


@dataclass(frozen=True)
class MeasureOptions:
    #: m: coordinates equal after rounding to this are one node. 1 cm keeps
    #: OSM's 1e-7° (≈ 1 cm) apart and joins what a writer rounded.
    node_precision: float = 0.01
    #: m: a line end this close to the window's boundary was made by the
    #: clip (or an open point this close to a node marks it open). 1 m covers
    #: a disc drawn as a 64-gon (its sagitta is < 0.1 % of the radius).
    open_tolerance: float = 1.0
    #: m: the default window (no ``window`` given) is the convex hull grown
    #: by this, so ends on the hull are not taken for clip ends.
    hull_margin: float = 5.0
    #: m: an edge end's direction points this far along the edge; the same
    #: reach as ``SimplifyOptions.heading_reach`` (a jittery first shape
    #: segment must not decide an angle).
    heading_reach: float = 20.0
    #: degrees: edge ends continue as one stroke below this deflection (issue).
    stroke_deflection: float = 30.0
    #: m²: smaller faces are slivers between dual carriageways and in
    #: junction shapes, not blocks (a 7 m × 7 m face).
    min_block_area: float = 50.0
    #: edges each edge's chord is compared with (issue).
    alignment_neighbours: int = 6
    #: m: neighbours farther than this (by arc midpoint) are not compared (issue).
    alignment_radius: float = 150.0
    #: m: curvature samples each edge this often (issue).
    curvature_step: float = 20.0
    #: m: edges with a shorter chord have no direction for circuity and
    #: alignment (loops and tiny links).
    min_chord: float = 1.0
    #: bins of the orientation histogram (Boeing 2019: 36 of 10°).
    orientation_bins: int = 36
    #: degrees: angles (junction angles, alignment, curvature) are rounded to this. OSM's 7 decimals
    #: (about 1 cm) give a 20 m step a direction good to 0.03°; below that a KS distance only compares
    #: rounding noise (a straight grid's 3e-13° against another's 8e-13°).
    angle_resolution: float = 0.1
    #: m each side: streets buffered this much and merged make a network's pieces (issue 20: 30 m,
    #: about a building lot's depth, so a street and the houses along it are one strip of town).
    piece_buffer: float = 30.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not value > 0:
                raise InputError(f"measures option {f.name} must be positive, got {value!r}")


@dataclass(frozen=True, eq=False)
class NetworkMeasures:
    """The measures of one network in one window (see the module docstring).

    Distributions are 1-D float64 arrays in the order the network gives
    them; scalars are floats, NaN when undefined (shares with no junction
    or dead end, entropy with no street).
    """

    edge_length: np.ndarray
    circuity: np.ndarray
    stroke_length: np.ndarray
    junction_angle: np.ndarray
    block_area: np.ndarray
    block_compactness: np.ndarray
    alignment: np.ndarray
    curvature: np.ndarray
    density: float
    orientation_entropy: float
    three_way_share: float
    four_way_share: float
    dead_end_share: float
    two_core_share: float
    #: m of street inside the window, and the window's area (m²).
    length: float
    area: float
    junctions: int
    dead_ends: int
    open_ends: int
    edges: int
    cut_edges: int
    blocks: int
    #: pieces on the map (module docstring); -1 when not counted (``pieces=False``).
    pieces: int = -1
    #: measures not computed (``measure_network(wanted=...)``): empty here, and :meth:`value` refuses them.
    left_out: frozenset[Measure] = frozenset()

    def value(self, measure: Measure | str) -> np.ndarray | float:
        """One measure by name: an array for a distribution, a float for a scalar."""
        m = measure_named(measure)
        if m in self.left_out:
            raise ValueError(f"measure {m.value!r} was not computed (left out by measure_network's wanted)")
        return getattr(self, m.value)

    def counts(self) -> dict[str, float]:
        """The plain counts, JSON-ready."""
        return {"length_km": round(self.length / 1000, 3), "area_km2": round(self.area / 1e6, 4),
                "junctions": self.junctions, "dead_ends": self.dead_ends, "open_ends": self.open_ends,
                "edges": self.edges, "cut_edges": self.cut_edges, "blocks": self.blocks,
                **({"pieces": self.pieces} if self.pieces >= 0 else {})}


# ---------------------------------------------------------------- input lines


@dataclass(frozen=True, eq=False)
class LineSet:
    """Polylines gathered once, so that many windows can be measured on them.

    ``coords`` ``(P, 2)`` metres of every line one after the other,
    ``line_of`` ``(P,)`` the line each point belongs to, ``geoms`` the
    lines as shapely LineStrings and ``tree`` an STRtree over them.
    """

    coords: np.ndarray
    line_of: np.ndarray
    geoms: np.ndarray
    tree: shapely.STRtree

    @classmethod
    def from_lines(cls, lines: Sequence[np.ndarray] | LineSet) -> LineSet:
        """Gather ``lines`` (each ``(n_i, 2)`` metres; lines of fewer than 2 points are dropped)."""
        if isinstance(lines, LineSet):
            return lines
        arrays = [np.asarray(ln, dtype=np.float64).reshape(-1, 2) for ln in lines]
        arrays = [a for a in arrays if len(a) >= 2]
        if arrays:
            coords = np.concatenate(arrays)
            line_of = np.repeat(np.arange(len(arrays)), [len(a) for a in arrays])
            geoms = shapely.linestrings(coords, indices=line_of)
        else:
            coords, line_of, geoms = np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.empty(0, dtype=object)
        return cls(coords=coords, line_of=line_of, geoms=geoms, tree=shapely.STRtree(geoms))

    def hull(self, margin: float) -> shapely.Polygon:
        """The convex hull of all points grown by ``margin`` metres (an empty polygon when no line)."""
        if len(self.coords) == 0:
            return shapely.Polygon()
        return shapely.multipoints(self.coords).convex_hull.buffer(margin)

    def clip(self, window: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
        """Points and line labels of the pieces of the lines inside ``window``.

        Lines wholly inside are taken as they are; only those crossing the
        boundary go through a shapely intersection.
        """
        cand = self.tree.query(window)
        if len(cand) == 0:
            return np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
        shapely.prepare(window)
        geoms = self.geoms[cand]
        inside = shapely.contains_properly(window, geoms)
        keep = np.zeros(len(self.geoms), dtype=bool)
        keep[cand[inside]] = True
        mask = keep[self.line_of]
        crossing = geoms[~inside][shapely.intersects(window, geoms[~inside])]
        pieces = shapely.get_parts(shapely.intersection(crossing, window))
        pieces = pieces[shapely.get_type_id(pieces) == 1]  # LineStrings; touching points drop out
        xy, label = shapely.get_coordinates(pieces, return_index=True)
        return (np.concatenate([self.coords[mask], xy]),
                np.concatenate([self.line_of[mask], label + len(self.geoms)]))


# ---------------------------------------------------------------- the graph


@dataclass(frozen=True, eq=False)
class _Graph:
    """Nodes, deduplicated segments and the edges (chains) over them."""

    xy: np.ndarray  # (N, 2) node coordinates
    degree: np.ndarray  # (N,)
    is_open: np.ndarray  # (N,) bool
    tail: np.ndarray  # (S,) node of each segment's start, segments in edge order
    head: np.ndarray  # (S,)
    seg_len: np.ndarray  # (S,)
    edge_of: np.ndarray  # (S,) edge of each segment, non-decreasing
    first: np.ndarray  # (E,) first segment of each edge
    last: np.ndarray  # (E,) last segment of each edge
    length: np.ndarray  # (E,) arc length
    cum_start: np.ndarray  # (S,) arc length along the concatenated edges where each segment starts

    @property
    def start_node(self) -> np.ndarray:
        return self.tail[self.first]

    @property
    def end_node(self) -> np.ndarray:
        return self.head[self.last]

    def point_at(self, edge: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """Points ``dist`` metres along ``edge`` (clipped to the edge), ``(K, 2)``."""
        d = np.clip(dist, 0.0, self.length[edge])
        target = self.cum_start[self.first[edge]] + d
        k = np.searchsorted(self.cum_start, target, side="right") - 1
        k = np.clip(k, self.first[edge], self.last[edge])
        t = np.clip((target - self.cum_start[k]) / np.maximum(self.seg_len[k], 1e-12), 0.0, 1.0)
        a, b = self.xy[self.tail[k]], self.xy[self.head[k]]
        return a + t[:, None] * (b - a)


def _nodes(coords: np.ndarray, precision: float) -> tuple[np.ndarray, np.ndarray]:
    """Node id of every point (equal after rounding to ``precision``) and the nodes' coordinates."""
    if len(coords) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2))
    q = np.rint(coords / precision).astype(np.int64)
    q -= q.min(axis=0)
    key = q[:, 0] * (int(q[:, 1].max()) + 1) + q[:, 1]  # < 2⁶³ for any town: 1000 km is 1e8 cm
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    return inverse.reshape(-1), coords[first]


def _segments(node: np.ndarray, label: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct undirected segments (u, v) between consecutive points of one line, u ≠ v."""
    same = label[1:] == label[:-1]
    u, v = node[:-1][same], node[1:][same]
    real = u != v
    u, v = u[real], v[real]
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    n = int(max(node.max(initial=0) + 1, 1))
    _, keep = np.unique(lo * n + hi, return_index=True)
    keep.sort()
    return u[keep], v[keep]


def _open_nodes(xy: np.ndarray, degree: np.ndarray, window: shapely.Geometry | None,
                open_points: np.ndarray | None, tol: float) -> np.ndarray:
    is_open = np.zeros(len(xy), dtype=bool)
    if window is not None:
        ends = np.flatnonzero(degree == 1)
        if len(ends):
            dist = shapely.distance(shapely.boundary(window), shapely.points(xy[ends]))
            is_open[ends[dist <= tol]] = True
    if open_points is not None and len(open_points) and len(xy):
        tree = cKDTree(xy)
        hits = tree.query_ball_point(np.asarray(open_points, dtype=np.float64).reshape(-1, 2), tol)
        flat = np.fromiter((i for h in hits for i in h), dtype=np.int64)
        is_open[flat] = True
    return is_open


def _successors(tail: np.ndarray, head: np.ndarray, breaks: np.ndarray) -> np.ndarray:
    """For half-edge h (2s: u→v, 2s+1: v→u) the half-edge that continues it, or -1 at a break node."""
    n_half = len(tail)
    nxt = np.full(n_half, -1, dtype=np.int64)
    order = np.argsort(tail, kind="stable")
    t_sorted = tail[order]
    # at a shape point exactly two half-edges leave: consecutive in ``order``
    pair = np.flatnonzero((t_sorted[1:] == t_sorted[:-1]) & ~breaks[t_sorted[:-1]])
    o1, o2 = order[pair], order[pair + 1]
    nxt[o1 ^ 1] = o2
    nxt[o2 ^ 1] = o1
    return nxt


def _build_graph(coords: np.ndarray, label: np.ndarray, *, window: shapely.Geometry | None,
                 open_points: np.ndarray | None, opts: MeasureOptions) -> _Graph:
    node, xy = _nodes(coords, opts.node_precision)
    u, v = _segments(node, label)
    degree = np.bincount(np.concatenate([u, v]), minlength=len(xy))
    is_open = _open_nodes(xy, degree, window, open_points, opts.open_tolerance)
    tail = np.empty(2 * len(u), dtype=np.int64)
    tail[0::2], tail[1::2] = u, v
    head = np.empty_like(tail)
    head[0::2], head[1::2] = v, u
    breaks = (degree != 2) | is_open
    nxt = _successors(tail, head, breaks)
    # rings of shape points: break each at its smallest node (both directions agree)
    n_half = len(tail)
    if n_half:
        has = nxt >= 0
        link = sparse.csr_matrix((np.ones(int(has.sum())), (np.flatnonzero(has), nxt[has])),
                                 shape=(n_half, n_half))
        _, comp = csgraph.connected_components(link, directed=True, connection="weak")
        ends = np.bincount(comp, weights=(~has).astype(np.float64), minlength=comp.max() + 1)
        ring = ends[comp] == 0
        if ring.any():
            anchor = np.full(comp.max() + 1, np.iinfo(np.int64).max)
            np.minimum.at(anchor, comp[ring], tail[ring])
            breaks = breaks.copy()
            breaks[anchor[anchor < np.iinfo(np.int64).max]] = True
            nxt = _successors(tail, head, breaks)
    # list ranking by pointer jumping: steps to the end of the chain, and that end
    ptr = np.where(nxt >= 0, nxt, np.arange(n_half))
    dist = (nxt >= 0).astype(np.int64)
    while True:
        nptr = ptr[ptr]
        dist = dist + dist[ptr]
        if np.array_equal(nptr, ptr):
            break
        ptr = nptr
    # keep one direction of each chain: the one whose first half-edge is below the reverse's first
    start = np.flatnonzero(breaks[tail])
    kept_first = start[start < (ptr[start] ^ 1)]
    edge_at_end = np.full(n_half, -1, dtype=np.int64)
    edge_at_end[ptr[kept_first]] = np.arange(len(kept_first))
    edge = edge_at_end[ptr]
    mine = np.flatnonzero(edge >= 0)
    order = mine[np.lexsort((-dist[mine], edge[mine]))]
    tail_o, head_o, edge_o = tail[order], head[order], edge[order]
    seg_len = np.hypot(*(xy[head_o] - xy[tail_o]).T)
    n_edges = len(kept_first)
    bounds = np.searchsorted(edge_o, np.arange(n_edges + 1))
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    return _Graph(xy=xy, degree=degree, is_open=is_open, tail=tail_o, head=head_o, seg_len=seg_len,
                  edge_of=edge_o, first=bounds[:-1], last=bounds[1:] - 1,
                  length=cum[bounds[1:]] - cum[bounds[:-1]], cum_start=cum[:-1])


# ---------------------------------------------------------------- measures


def junction_points(lines: Sequence[np.ndarray] | LineSet, options: MeasureOptions | None = None) -> np.ndarray:
    """``(K, 2)`` metres: the junctions (degree ≥ 3) of the lines, nodes made as for the measures."""
    opts = options or MeasureOptions()
    line_set = LineSet.from_lines(lines)
    node, xy = _nodes(line_set.coords, opts.node_precision)
    u, v = _segments(node, line_set.line_of)
    degree = np.bincount(np.concatenate([u, v]), minlength=len(xy))
    return xy[degree >= 3]


def two_core(u: np.ndarray, v: np.ndarray, n: int, anchored: np.ndarray | None = None) -> np.ndarray:
    """Which edges ``(u[i], v[i])`` lie in the 2-core: dead-end trees peeled off, leaf by leaf.

    Parameters
    ----------
    u, v : ``(E,)`` end nodes of each edge (a loop has ``u == v``: it counts 2 at its node).
    n : number of nodes.
    anchored : ``(n,)`` bool, nodes never peeled (open ends: the network runs on beyond them).

    Returns
    -------
    ``(E,)`` bool: kept edges. Each round peels every edge with a free end of degree 1, so the
    rounds are the depth of the deepest tree (a handful on a street graph of junction-to-junction
    edges), each a vectorised pass.
    """
    u, v = np.asarray(u, dtype=np.int64), np.asarray(v, dtype=np.int64)
    keep = np.ones(len(u), dtype=bool)
    fixed = np.zeros(n, dtype=bool) if anchored is None else np.asarray(anchored, dtype=bool)
    while True:
        degree = np.bincount(u[keep], minlength=n) + np.bincount(v[keep], minlength=n)
        leaf = (degree == 1) & ~fixed
        peel = keep & (leaf[u] | leaf[v])
        if not peel.any():
            return keep
        keep &= ~peel


def piece_labels(geoms: np.ndarray, buffer: float) -> np.ndarray:
    """The piece of each line: lines buffered ``buffer`` m each side and merged (module docstring).

    Two buffers overlap when their lines are within ``2 * buffer``; the pieces are the connected
    components of those pairs (an STRtree query, no union of polygons).

    Returns
    -------
    ``(len(geoms),)`` int labels 0..pieces-1.
    """
    geoms = np.asarray(geoms, dtype=object)
    if len(geoms) == 0:
        return np.zeros(0, dtype=np.int64)
    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="dwithin", distance=2.0 * buffer)
    link = sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(len(geoms), len(geoms)))
    return csgraph.connected_components(link, directed=False)[1]


def count_pieces(lines: Sequence[np.ndarray] | LineSet, buffer: float = 30.0) -> int:
    """How many pieces ``lines`` make on the map, buffered ``buffer`` m each side (module docstring)."""
    labels = piece_labels(LineSet.from_lines(lines).geoms, buffer)
    return int(labels.max() + 1) if len(labels) else 0


def orientation_entropy(vectors: np.ndarray, weights: np.ndarray | None = None, *, bins: int = 36) -> float:
    """Boeing's (2019) orientation entropy of segment directions, in nats.

    Parameters
    ----------
    vectors : ``(K, 2)`` segment vectors (dx east, dy north), metres.
    weights : ``(K,)`` weights; default the segments' lengths.
    bins : bins over 360°; bin ``i`` is centred on ``i * 360 / bins`` degrees.

    Returns
    -------
    The Shannon entropy ``-Σ p_i ln p_i`` of the compass bearings, each
    segment counted in both directions; NaN when there is nothing to weigh.
    """
    vectors = np.asarray(vectors, dtype=np.float64).reshape(-1, 2)
    w = np.hypot(*vectors.T) if weights is None else np.asarray(weights, dtype=np.float64)
    if len(vectors) == 0 or not w.sum() > 0:
        return float("nan")
    bearing = np.degrees(np.arctan2(vectors[:, 0], vectors[:, 1])) % 360.0
    both = np.concatenate([bearing, (bearing + 180.0) % 360.0])
    width = 360.0 / bins
    idx = np.floor((both + width / 2) / width).astype(np.int64) % bins
    counts = np.bincount(idx, weights=np.concatenate([w, w]), minlength=bins)
    p = counts[counts > 0] / counts.sum()
    return float(-(p * np.log(p)).sum())


def _edge_ends(g: _Graph, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per edge end (2E: start ends then end ends): node, edge and direction angle (radians)."""
    n = len(g.length)
    edges = np.arange(n)
    r = np.minimum(reach, g.length)
    out_start = g.point_at(edges, r) - g.xy[g.start_node]
    out_end = g.point_at(edges, g.length - r) - g.xy[g.end_node]
    vec = np.concatenate([out_start, out_end])
    return (np.concatenate([g.start_node, g.end_node]), np.concatenate([edges, edges]),
            np.arctan2(vec[:, 1], vec[:, 0]))


def _junction_angles(node: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Angles (degrees) between angularly consecutive ends around each node; input: ends at junctions."""
    if len(node) == 0:
        return np.zeros(0)
    order = np.lexsort((angle, node))
    nd, an = node[order], angle[order]
    group_start = np.flatnonzero(np.r_[True, nd[1:] != nd[:-1]])
    size = np.diff(np.r_[group_start, len(nd)])
    nxt = np.arange(len(nd)) + 1
    last = group_start + size - 1
    nxt[last] = group_start
    gap = an[nxt] - an
    gap[last] += 2 * np.pi  # the last end wraps round to the first: the gaps sum to 360° even when ends coincide
    return np.degrees(gap[np.repeat(size, size) > 1])


def _pairs_within_groups(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All index pairs i < j with ``group[i] == group[j]``; ``group`` sorted."""
    n = len(group)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    size = np.diff(np.r_[starts, n])
    pos = np.arange(n) - np.repeat(starts, size)
    later = np.repeat(size, size) - pos - 1
    i = np.repeat(np.arange(n), later)
    j = i + (np.arange(len(i)) - np.repeat(np.cumsum(later) - later, later)) + 1
    return i, j


def _greedy_matching(i: np.ndarray, j: np.ndarray, cost: np.ndarray, n: int) -> np.ndarray:
    """Pairs taken cheapest first, each item at most once (mask over the pairs).

    Rounds of mutually best pairs give the same matching as the sequential
    greedy, since each round takes the cheapest remaining pair and no pair it
    takes is beaten by a cheaper one still open.
    """
    rank = np.empty(len(cost), dtype=np.int64)
    rank[np.lexsort((j, i, cost))] = np.arange(len(cost))
    taken = np.zeros(len(cost), dtype=bool)
    used = np.zeros(n, dtype=bool)
    alive = np.ones(len(cost), dtype=bool)
    big = np.iinfo(np.int64).max
    while alive.any():
        best = np.full(n, big)
        np.minimum.at(best, i[alive], rank[alive])
        np.minimum.at(best, j[alive], rank[alive])
        win = alive & (best[i] == rank) & (best[j] == rank)
        taken |= win
        used[i[win]] = True
        used[j[win]] = True
        alive &= ~used[i] & ~used[j]
    return taken


def _strokes(g: _Graph, node: np.ndarray, edge: np.ndarray, angle: np.ndarray, max_deflection: float) -> np.ndarray:
    """Stroke lengths (m): edges joined through junctions where they deflect least."""
    n_edges = len(g.length)
    if n_edges == 0:
        return np.zeros(0)
    order = np.argsort(node, kind="stable")
    i, j = _pairs_within_groups(node[order])
    i, j = order[i], order[j]
    between = np.abs((angle[i] - angle[j] + np.pi) % (2 * np.pi) - np.pi)  # [0, π]
    deflection = 180.0 - np.degrees(between)
    ok = deflection < max_deflection
    i, j, deflection = i[ok], j[ok], deflection[ok]
    taken = _greedy_matching(i, j, deflection, len(node))
    a, b = edge[i[taken]], edge[j[taken]]
    link = sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(n_edges, n_edges))
    _, label = csgraph.connected_components(link, directed=False)
    return np.bincount(label, weights=g.length)


def _blocks(g: _Graph, min_area: float) -> tuple[np.ndarray, np.ndarray]:
    """Areas (m²) and compactness 4πA/P² of the bounded faces of the edges."""
    n_edges = len(g.length)
    if n_edges == 0:
        return np.zeros(0), np.zeros(0)
    # each edge's points: the tails of its segments, then the head of its last one
    slot = np.arange(len(g.tail)) + g.edge_of
    pts = np.empty((len(g.tail) + n_edges, 2))
    owner = np.empty(len(g.tail) + n_edges, dtype=np.int64)
    pts[slot], owner[slot] = g.xy[g.tail], g.edge_of
    end_slot = g.last + np.arange(n_edges) + 1
    pts[end_slot], owner[end_slot] = g.xy[g.end_node], np.arange(n_edges)
    lines = shapely.linestrings(pts, indices=owner)
    faces = shapely.get_parts(shapely.polygonize(lines))
    area = shapely.area(faces)
    perimeter = shapely.length(faces)
    big = area >= min_area
    return area[big], 4 * math.pi * area[big] / perimeter[big] ** 2


def _alignment(g: _Graph, usable: np.ndarray, k: int, radius: float) -> np.ndarray:
    """|Δ chord direction| mod 90°, folded to [0°, 45°], for each edge against its k nearest."""
    edges = np.flatnonzero(usable)
    if len(edges) < 2:
        return np.zeros(0)
    chord = g.xy[g.end_node[edges]] - g.xy[g.start_node[edges]]
    theta = np.degrees(np.arctan2(chord[:, 1], chord[:, 0]))
    mid = g.point_at(edges, g.length[edges] / 2)
    near = min(k + 1, len(edges))
    _, idx = cKDTree(mid).query(mid, k=near, distance_upper_bound=radius)
    idx = idx.reshape(len(edges), near)
    me = np.arange(len(edges))[:, None]
    valid = (idx < len(edges)) & (idx != me)
    valid &= np.cumsum(valid, axis=1) <= k
    a = np.broadcast_to(me, idx.shape)[valid]
    diff = np.abs(theta[a] - theta[idx[valid]]) % 90.0
    return np.minimum(diff, 90.0 - diff)


def _curvature(g: _Graph, step: float) -> np.ndarray:
    """Absolute heading change (degrees) between consecutive ``step``-metre chords along each edge."""
    steps = np.floor(g.length / step + 1e-9).astype(np.int64)
    edges = np.flatnonzero(steps >= 2)
    if len(edges) == 0:
        return np.zeros(0)
    n_pts = steps[edges] + 1
    edge = np.repeat(edges, n_pts)
    k = np.arange(len(edge)) - np.repeat(np.cumsum(n_pts) - n_pts, n_pts)
    pts = g.point_at(edge, k * step)
    d = np.diff(pts, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    within = edge[1:] == edge[:-1]  # chord p_k → p_k+1 lies on one edge
    turn = (heading[1:] - heading[:-1] + np.pi) % (2 * np.pi) - np.pi
    return np.degrees(np.abs(turn[within[1:] & within[:-1]]))


def _rounded(angles: np.ndarray, resolution: float) -> np.ndarray:
    """Angles rounded to ``resolution`` degrees (see :class:`MeasureOptions`)."""
    return np.round(angles / resolution) * resolution


def measure_network(lines: Sequence[np.ndarray] | LineSet, *, window: shapely.Geometry | None = None,
                    open_points: np.ndarray | None = None, options: MeasureOptions | None = None,
                    pieces: bool = True, wanted: Sequence[Measure | str] | None = None) -> NetworkMeasures:
    """Every measure of a street network inside ``window``.

    Parameters
    ----------
    lines : polylines, each ``(n_i, 2)`` float metres (or a :class:`LineSet`
        of them, to measure many windows on the same lines cheaply).
    window : shapely polygon, metres: the area measured; lines are clipped
        to it and ends made by the clip are open. Default: the lines' convex
        hull grown by ``options.hull_margin`` (nothing is clipped).
    open_points : ``(K, 2)`` metres: more open ends (where a district's
        streets end on the old town); nodes within ``open_tolerance``.
    options : :class:`MeasureOptions`.
    pieces : count the pieces (False for a whole town, where nobody asks and it costs most).
    wanted : the measures the caller reads (default: all). Of the others, the costly ones are left
        out (strokes, blocks — their count is then -1 — and alignment: half of a window's time,
        for a pattern ranking thousands of windows by five measures); they come back empty and
        :meth:`NetworkMeasures.value` refuses them. What is computed is the same either way.

    Returns
    -------
    :class:`NetworkMeasures`: eight distributions, six scalars and counts.
    """
    opts = options or MeasureOptions()
    asked = set(Measure) if wanted is None else {measure_named(m) for m in wanted}
    left_out = frozenset({Measure.STROKE_LENGTH, Measure.BLOCK_AREA, Measure.BLOCK_COMPACTNESS, Measure.ALIGNMENT}
                         - asked)
    blocks_left_out = {Measure.BLOCK_AREA, Measure.BLOCK_COMPACTNESS} <= left_out
    line_set = LineSet.from_lines(lines)
    if window is None:
        region = line_set.hull(opts.hull_margin)
        coords, label = line_set.coords, line_set.line_of
    else:
        region = window
        coords, label = line_set.clip(window)
    g = _build_graph(coords, label, window=window, open_points=open_points, opts=opts)
    area = float(region.area)
    total = float(g.seg_len.sum())
    junction = (g.degree >= 3) & ~g.is_open
    dead_end = (g.degree == 1) & ~g.is_open
    counted = int(junction.sum() + dead_end.sum())
    share = (lambda mask: float(mask.sum() / counted)) if counted else (lambda mask: float("nan"))

    cut = g.is_open[g.start_node] | g.is_open[g.end_node]
    chord = np.hypot(*(g.xy[g.end_node] - g.xy[g.start_node]).T)
    has_chord = chord >= opts.min_chord
    node, edge, angle = _edge_ends(g, opts.heading_reach)
    at_junction = junction[node]
    block_area, compactness = (np.zeros(0), np.zeros(0)) if blocks_left_out else _blocks(g, opts.min_block_area)
    vectors = g.xy[g.head] - g.xy[g.tail]
    core = two_core(g.start_node, g.end_node, len(g.xy), anchored=g.is_open)
    n_pieces = -1
    if pieces:
        dense = np.unique(label, return_inverse=True)[1].reshape(-1)
        geoms = shapely.linestrings(coords, indices=dense) if len(coords) else np.empty(0, dtype=object)
        labels = piece_labels(geoms, opts.piece_buffer)
        n_pieces = int(labels.max() + 1) if len(labels) else 0
    return NetworkMeasures(
        edge_length=g.length[~cut],
        circuity=g.length[~cut & has_chord] / chord[~cut & has_chord],
        stroke_length=np.zeros(0) if Measure.STROKE_LENGTH in left_out else
        _strokes(g, node[at_junction], edge[at_junction], angle[at_junction], opts.stroke_deflection),
        junction_angle=_rounded(_junction_angles(node[at_junction], angle[at_junction]), opts.angle_resolution),
        block_area=block_area,
        block_compactness=compactness,
        alignment=np.zeros(0) if Measure.ALIGNMENT in left_out else
        _rounded(_alignment(g, has_chord, opts.alignment_neighbours, opts.alignment_radius), opts.angle_resolution),
        curvature=_rounded(_curvature(g, opts.curvature_step), opts.angle_resolution),
        density=total * 1000.0 / area if area > 0 else float("nan"),
        orientation_entropy=orientation_entropy(vectors, bins=opts.orientation_bins),
        three_way_share=share(junction & (g.degree == 3)),
        four_way_share=share(junction & (g.degree == 4)),
        dead_end_share=share(dead_end),
        two_core_share=float(g.seg_len[core[g.edge_of]].sum() / total) if total > 0 else float("nan"),
        length=total, area=area,
        junctions=int(junction.sum()), dead_ends=int(dead_end.sum()), open_ends=int(g.is_open.sum()),
        edges=len(g.length), cut_edges=int(cut.sum()), blocks=-1 if blocks_left_out else len(block_area),
        pieces=n_pieces, left_out=left_out,
    )
