"""The pathfinding lattice G.

Seed 003 §3.2.2 (Fig. 3b/c) and §3.4.2 (Eq. 1, Fig. 9); seed 000 §4.2.3 and
§4.2.7.

**G** is a regular lattice of vertices ``spacing`` (ℓ = 20 m) apart. Each
vertex connects to the nearest other vertex in every lattice direction within
``radius`` r = 8: the primitive vectors (dx, dy) (gcd 1) with
dx² + dy² ≤ r², 120 of them. Vertices are land, water or forbidden (from
raster masks). Marching along each edge (``samples_per_spacing`` samples per
ℓ) classifies it:

- *land*: every sample on land; weight ``length · max(1, O1 · slope)`` with
  the largest slope between samples (flat without a height raster); dropped
  above ``slope_cutoff``;
- *water*: every sample on water (routes for boats; roads do not use them);
- *harbour*: between adjacent land and water vertices, one change of medium;
- *bridge*: land to land over one stretch of water (000 §4.2.3): a unit edge
  land→water→land, or a straight run of k unit edges along one direction
  (land→water, water…, water→land) up to ``max_bridge_length``. Of the
  crossings from a vertex only those at most ``bridge_slack`` times its
  shortest crossing are kept (000 keeps the shortest ray, i.e. a bridge
  roughly perpendicular to the bank; the slack lets a road keep its line).

Forbidden samples end an edge; forbidden vertices have no edges. Edges are
made with array slicing: for a direction and a sample offset the samples of
*every* vertex are one strided slice of a fine raster, so there is no Python
loop over vertices (only the few edges with water are marched sample by
sample). :func:`build_lattice` keeps the fine rasters, the bridges (their
filter needs the whole map) and the map's unit edges; the live unit edges
(B removed) are one ``(D/2, V)`` table over the map, made when first
searched and carried from one B to the next (only the edges the new ground
touches go), and a rectangle of vertices (:meth:`Lattice.window`) makes its
edges in both directions from it; on a map of up to ``_MAP_DIRECTED_BYTES``
that table becomes the map's ``(V, D)`` directed table, carried alike, and a
window crops its rows.

The water and forbidden rasters should be drawn generously
(:meth:`Raster.from_geometry`: a cell is water when water comes within half
its diagonal): the lattice sees water only where the raster says so, and a
stream thinner than a cell that falls between cell centres would get a road
across it without a bridge.

The built-up area B is :mod:`osm_expand.engine.roads.built_up`; the stitched graph G′ searched on it
is :mod:`osm_expand.engine.roads.path_graph`.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import IntEnum
from math import gcd

import numpy as np
import shapely

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive

__all__ = [
    "VertexClass", "EdgeKind", "ROAD_KINDS", "Raster", "LatticeOptions", "Lattice", "LatticeWeights",
    "build_lattice", "lattice_directions",
]


class VertexClass(IntEnum):
    """Class of a lattice vertex (003 §3.2.2: L_L, L_W, L_F)."""

    LAND = 0
    WATER = 1
    FORBIDDEN = 2


class EdgeKind(IntEnum):
    """Kind of an edge of G′; the cost coefficient of each is in :class:`EdgeCosts`."""

    LAND = 0  #: new road over land (lattice)
    WATER = 1  #: waterway (lattice)
    HARBOUR = 2  #: unbuilt harbour, land ↔ water (lattice), C3
    BRIDGE = 3  #: unbuilt bridge (lattice), C5
    STITCH = 4  #: new road joining the lattice to a street, or two shell streets
    MAJOR = 5  #: existing major road segment, C1
    MINOR = 6  #: existing minor road segment, C2
    BUILT_HARBOUR = 7  #: existing harbour segment, C4


#: Kinds a road can be built on (the others are waterways and harbours).
ROAD_KINDS = (EdgeKind.LAND, EdgeKind.BRIDGE, EdgeKind.STITCH, EdgeKind.MAJOR, EdgeKind.MINOR)
#: per uint8 kind: a bridge or harbour edge (:meth:`Lattice.special_entries`; B removes land edges only)
_IS_SPECIAL = np.isin(np.arange(256), [EdgeKind.BRIDGE, EdgeKind.HARBOUR])

# unit-edge profiles along the marched samples
_MIXED, _L, _W, _LW, _WL, _LWL = 0, 1, 2, 3, 4, 5


@dataclass(frozen=True)
class Raster:
    """A raster over the map: ``values[i, j]`` covers the cell whose lower-left
    corner is ``origin + (j, i) · cell`` (rows run north, as in
    :class:`osm_expand.sites.DistanceMaps`)."""

    values: np.ndarray  #: (rows, cols) bool or float
    origin: tuple[float, float]  #: m, lower-left corner of cell (0, 0)
    cell: float  #: m, cell side

    def __post_init__(self) -> None:
        if np.ndim(self.values) != 2 or not self.cell > 0:
            raise InputError(f"raster: need a 2-D array and a positive cell size, got shape "
                             f"{np.shape(self.values)} and cell {self.cell}")

    @classmethod
    def from_geometry(cls, geom: shapely.Geometry | None, extent: tuple[float, float, float, float],
                      cell: float = 10.0) -> Raster:
        """A boolean raster of the cells that ``geom`` touches (or comes within half a cell's
        diagonal of, so that no thin river is lost between cell centres).

        Parameters
        ----------
        geom
            Polygons (e.g. water), metres; None: an all-false raster.
        extent
            ``(xmin, ymin, xmax, ymax)`` metres, covered by whole cells from the lower-left corner.
        cell
            Cell side, metres.

        Returns
        -------
        Raster
        """
        x0, y0, x1, y1 = map(float, extent)
        cols, rows = int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1
        values = np.zeros((rows, cols), dtype=bool)
        if geom is not None and not geom.is_empty:
            grown = shapely.buffer(geom, cell * np.sqrt(0.5), quad_segs=2)
            shapely.prepare(grown)
            xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) * cell, y0 + (np.arange(rows) + 0.5) * cell)
            values = shapely.contains_xy(grown, xs, ys)
        return cls(values, (x0, y0), cell)

    @classmethod
    def from_polygons(cls, polygons: list, extent: tuple[float, float, float, float],
                      cell: float = 10.0) -> Raster:
        """Like :meth:`from_geometry` for many small polygons (buildings), without their union.

        PIL fills each polygon and its outline (scan lines, in C; holes are
        cleared), then one cell of dilation takes in every cell the polygon
        comes within half a cell's diagonal of. On Krems' 1,195 buildings and
        unbuildable areas at 5 m it marks 74,577 cells against
        :meth:`from_geometry`'s 55,056 (all but 4 of them), in a fifth of the
        time and without the 0.3 s union: a little more ground kept clear.
        """
        from PIL import Image, ImageDraw
        from scipy.ndimage import binary_dilation

        x0, y0, x1, y1 = map(float, extent)
        cols, rows = int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1
        image = Image.new("1", (cols, rows), 0)
        draw = ImageDraw.Draw(image)

        def px(ring) -> list[tuple[float, float]]:  # PIL pixel (i, j) covers [i, i+1): centres at +0.5
            return [tuple(p) for p in ((np.asarray(ring.coords)[:, :2] - (x0, y0)) / cell - 0.5).tolist()]

        for poly in (p for geom in polygons for p in shapely.get_parts(geom)
                     if isinstance(p, shapely.Polygon) and not p.is_empty):
            draw.polygon(px(poly.exterior), fill=1, outline=1)
            for hole in poly.interiors:
                draw.polygon(px(hole), fill=0, outline=0)
            draw.line(px(poly.exterior), fill=1)  # the boundary of a hole is still the polygon's
        values = np.asarray(image, dtype=bool)
        if values.any():
            values = binary_dilation(values, structure=np.ones((3, 3), dtype=bool))
        return cls(values, (x0, y0), cell)

    def rows_cols(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cell row of each ``y`` and the cell column of each ``x``, unclipped (may lie outside).

        Each from its own coordinate alone, so ``x`` and ``y`` may differ in shape: a grid of
        points' rows and columns from its ys and xs (:func:`_resample_any`)."""
        col = np.floor((np.asarray(x) - self.origin[0]) / self.cell).astype(np.int64)
        row = np.floor((np.asarray(y) - self.origin[1]) / self.cell).astype(np.int64)
        return row, col

    def cell_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row, column of the cell holding each point, and whether it is inside the raster."""
        row, col = self.rows_cols(x, y)
        rows, cols = self.values.shape
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        return np.clip(row, 0, rows - 1), np.clip(col, 0, cols - 1), inside


@dataclass(frozen=True)
class LatticeOptions:
    """Tunables of the pathfinding lattice G (003 §3.2.2; 000 §4.2.3)."""

    spacing: float = 20.0  #: m, lattice spacing ℓ (003 §3.2.2)
    radius: int = 8  #: lattice units, neighbourhood radius r: directions (dx, dy) with dx² + dy² ≤ r² (003)
    #: samples per ℓ when marching along an edge (the fine raster is ℓ / this; 2 → 10 m,
    #: the resolution of osm_expand.sites' water raster)
    samples_per_spacing: int = 2
    #: O1: weight = length · max(1, O1 · slope) (003 §3.2.2); 000 uses 0.3 per degree of
    #: inclination, i.e. 0.3 · 180/π per radian ≈ per unit of slope for small slopes
    slope_weight: float = 17.19
    slope_cutoff: float = 0.577  #: rise/run; steeper land edges are dropped (000: α_max = π/6 → tan = 0.577)
    max_bridge_length: float = 600.0  #: m; the Danube at Krems is ~300 m wide, allow oblique crossings
    #: keep a bridge only if at most this times the shortest crossing from either end
    #: (000 keeps only the shortest, i.e. ~perpendicular; 1.25 allows ±37°)
    bridge_slack: float = 1.25

    def __post_init__(self) -> None:
        require_positive(self, ("spacing", "slope_weight", "slope_cutoff", "max_bridge_length"))
        if self.radius < 1 or self.samples_per_spacing < 1:
            raise InputError("lattice: radius and samples_per_spacing must be at least 1")
        if self.bridge_slack < 1.0:
            raise InputError(f"lattice: bridge_slack must be ≥ 1, got {self.bridge_slack}")


def lattice_directions(radius: int) -> np.ndarray:
    """The primitive lattice directions within ``radius``, ``(D, 2)`` int.

    The first half (dy > 0, or dy = 0 and dx > 0) sorted by angle, then their
    negations in the same order, so direction ``k + D/2`` is direction ``k``
    reversed. radius 1 → 4 directions, 2 → 8 (the king's moves and no knight's
    as 2² + 1² > 2²; see ``test_majorroads``), 8 → 120.
    """
    half = [(dx, dy) for dx in range(-radius, radius + 1) for dy in range(0, radius + 1)
            if (dy > 0 or dx > 0) and dx * dx + dy * dy <= radius * radius and gcd(abs(dx), dy) == 1]
    half.sort(key=lambda d: np.arctan2(d[1], d[0]))
    first = np.array(half, dtype=np.int64).reshape(-1, 2)
    return np.concatenate([first, -first])


#: ``unit_kind`` value of a missing edge.
NO_EDGE = 255


class LatticeWeights:
    """A ``(V, D)`` float32 table of lattice edge costs, worked out from the kinds when read.

    On flat land an entry's cost is its direction's length times a factor of its kind (1;
    C5 for a bridge, C3 for a harbour in G′): the table a window of G′ held was 4 bytes an
    entry, 285 MB and 0.6 s to fill for Campo Grande's whole map, where a search reads only
    the entries it reaches. Indexing (slices, index arrays, boolean masks) gives what the
    dense table would: ``float32(length · factor)``, the dense table's own arithmetic.
    """

    def __init__(self, kind: np.ndarray, length: np.ndarray, factor: np.ndarray | None = None) -> None:
        self.kind = kind  #: (V, D) uint8 kinds (shared, not copied)
        self.length = np.asarray(length, dtype=np.float32).astype(np.float64)  #: (D,) m
        #: (256,) float64 factor by kind (None: 1)
        self.factor = np.ones(256) if factor is None else np.asarray(factor, dtype=np.float64)
        self._cols = np.broadcast_to(np.arange(kind.shape[1], dtype=np.intp), kind.shape)
        #: (256 · D,) float32, the cost of kind k along direction d at ``k · D + d``
        self._table = (self.length[None, :] * self.factor[:, None]).astype(np.float32).reshape(-1)
        #: the same costs widened to float64 (exactly), what G′'s CSR holds: read from here, a window's
        #: tens of millions of entries are not converted one by one (:meth:`masked`)
        self._table64 = self._table.astype(np.float64)

    shape = property(lambda self: self.kind.shape)
    ndim = 2
    dtype = np.dtype(np.float32)

    @property
    def table64(self) -> np.ndarray:
        """(256 · D,) float64: the cost of kind k along direction d at ``k · D + d`` (what G′'s CSR
        holds; the compiled route search reads its lattice moves' weights from here)."""
        return self._table64

    def __getitem__(self, key) -> np.ndarray:
        return (self.length[self._cols[key]] * self.factor[self.kind[key]]).astype(np.float32)

    def at(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """``self[rows, cols]`` for index arrays, as float64 (the float32 values, exactly): one lookup
        of kind · D + direction, where ``__getitem__`` gathers lengths and factors and multiplies
        (2.5 times as long on the heading-expanded graph's lattice moves, its largest gather)."""
        return self.entries(self.kind[rows, cols], cols)

    def masked(self, rows: slice, mask: np.ndarray) -> np.ndarray:
        """``self[rows][mask]`` without the rows' whole table: only the entries ``mask`` picks
        (one lookup of kind · D + direction: twice as fast as gathering kinds and directions),
        as float64 (the float32 values, exactly: G′'s CSR holds float64)."""
        n_dir = self.kind.shape[1]
        code = self.kind[rows].astype(np.int32) * n_dir + np.arange(n_dir, dtype=np.int32)
        return self._table64[code[mask]]

    def entries(self, kind: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The costs of entries of the given kinds along the given directions, as :meth:`masked`'s
        (float64, the float32 values exactly): where only the live entries' kinds are read."""
        return self._table64[kind.astype(np.intp) * self.kind.shape[1] + direction]

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self[:]
        return out if dtype is None else out.astype(dtype)

    def times(self, factors: dict[int, float]) -> LatticeWeights:
        """The same table with the entries of some kinds multiplied (C3, C5 in G′)."""
        factor = self.factor.copy()
        for k, f in factors.items():
            factor[int(k)] *= f
        return LatticeWeights(self.kind, self.length.astype(np.float32), factor)


@dataclass(frozen=True)
class Lattice:
    """The pathfinding graph G over a rectangle of vertices, its edges made when asked for.

    A lattice stores no edge table of its own: only the fine rasters of the whole map
    (water, forbidden, built-up B, height; ``spacing / samples`` apart) and
    the bridges the whole-map filter kept (one-step bridges as keys, longer
    ones as arrays). A *window* (:meth:`window`) is the same map seen
    through a rectangle of its vertices, sharing those rasters: its edges
    are the map's edges with both ends in the rectangle, generated from the
    rasters when first asked for (:attr:`unit_kind` …, cached), so a search
    that touches a corridor of the map pays for that corridor only.

    Vertex ``i · nx + j`` of a lattice sits at ``origin + (j, i) · spacing``
    and is map vertex ``(offset[0] + i) · map_nx + offset[1] + j``. The
    unit edge from vertex v along half-direction k (``directions[k]``,
    k < D/2) is ``unit_kind[k, v]`` (:data:`NO_EDGE` when there is none)
    with weight ``unit_weight[k, v]``. ``directed_kind`` /
    ``directed_weight`` hold the live edges seen from both ends, for G′.
    Its rasters are never mutated: :meth:`with_built_up` returns a new
    lattice. What it mutates are its caches: ``_cache`` (its own) and
    ``_shared`` (the map's live unit edges, one table for the map and
    all its windows of one B), which :meth:`with_built_up` hands on to the
    next B's lattice and edits there: the old lattice makes its table again
    if asked (one child each; windows make their directed tables from it).
    """

    origin: np.ndarray  #: (2,) m, position of vertex 0 (of this window)
    spacing: float  #: m, ℓ
    shape: tuple[int, int]  #: (ny, nx) vertices of this window
    samples: int  #: fine raster samples per ℓ
    directions: np.ndarray  #: (D, 2) int lattice directions, second half the first reversed
    water: np.ndarray  #: fine raster bool over the whole map
    forbidden: np.ndarray  #: fine raster bool over the whole map
    built_up: np.ndarray  #: fine raster bool over the whole map, B (monotone)
    #: sorted keys ``k · V_map + v_map`` of the one-step bridges (half-direction k from map vertex v)
    #: that the whole-map bridge filter kept
    bridge_keys: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: (K, 4) int64 bridges of two or more steps over the whole map: map src, map dst,
    #: half-direction, steps
    map_bridges: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), dtype=np.int64))
    height: np.ndarray | None = None  #: fine raster float64 m, or None (flat)
    slope_weight: float = 17.19  #: O1, also for the street and stitch edges of G′
    slope_cutoff: float = 0.577  #: rise/run above which a new stretch of road is not built
    offset: tuple[int, int] = (0, 0)  #: (row, col) of vertex 0 in the map's vertex grid
    map_shape: tuple[int, int] | None = None  #: (ny, nx) vertices of the whole map (None: this shape)
    map_origin: np.ndarray | None = None  #: (2,) m, the map's vertex 0 (None: ``origin``)
    #: fine raster bool over the whole map, or None: the part of ``forbidden`` a stitch may cross (the
    #: town's presumed frontage, :attr:`~osm_expand.model.land.Land.presumed`): no new road runs through
    #: the houses the map does not show, but one may leave a street across them, as one between houses
    stitch_only: np.ndarray | None = None
    #: the whole map's unit edges before B, ``(D/2, V_map)`` kind (one-step bridges filtered) and
    #: weight (None on flat land: the weight is then the edge's length): :func:`build_lattice`
    #: makes them anyway for the bridges, and they never change (water, forbidden ground and
    #: height are fixed), so a window crops them instead of sampling the rasters again.
    #: None: a window samples the rasters
    map_units: tuple[np.ndarray, np.ndarray | None] | None = field(default=None, repr=False, compare=False)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)
    #: what the map and all its windows of one B share: ``"live"``, the whole map's live unit edges
    #: ``(D/2, V_map)`` (:func:`_map_live_units`), made once per run and cut by every window
    #: (:func:`_window_directed`); :meth:`with_built_up` carries it to the next B, removing only the
    #: edges the new ground touches; ``"special"``, the map's bridge and harbour entries;
    #: ``"directed"``, the map's live directed kinds ``(V_map, D)`` (:meth:`_map_directed`), which
    #: replace ``"live"`` once made: every window's table is cropped from it (:func:`_cropped`), and
    #: :meth:`with_built_up` carries it as it does ``"live"`` (:func:`_directed_without_touched`)
    _shared: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_vertices(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def full_shape(self) -> tuple[int, int]:
        """(ny, nx) vertices of the whole map."""
        return self.shape if self.map_shape is None else self.map_shape

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` m of this lattice's vertices."""
        x0, y0 = self.origin
        return (float(x0), float(y0), float(x0 + (self.shape[1] - 1) * self.spacing),
                float(y0 + (self.shape[0] - 1) * self.spacing))

    @property
    def radius(self) -> int:
        return int(np.abs(self.directions).max())

    @property
    def fine_step(self) -> float:
        """m between fine raster points."""
        return self.spacing / self.samples

    @property
    def fine_origin(self) -> np.ndarray:
        """(2,) m, position of fine raster point (0, 0): the map's vertex 0."""
        return self.origin if self.map_origin is None else self.map_origin

    @property
    def direction_length(self) -> np.ndarray:
        """(D,) m, length of the unit edge along each direction."""
        return np.hypot(*self.directions.T) * self.spacing

    @property
    def direction_offset(self) -> np.ndarray:
        """(D,) vertex index step along each direction."""
        return self.directions[:, 1] * self.shape[1] + self.directions[:, 0]

    @property
    def vertex_class(self) -> np.ndarray:
        """(V,) uint8 :class:`VertexClass` of each vertex (from the fine rasters)."""
        f, (ny, nx), (r0, c0) = self.samples, self.shape, self.offset
        rows, cols = slice(r0 * f, (r0 + ny - 1) * f + 1, f), slice(c0 * f, (c0 + nx - 1) * f + 1, f)
        return np.where(self.forbidden[rows, cols], VertexClass.FORBIDDEN,
                        np.where(self.water[rows, cols], VertexClass.WATER, VertexClass.LAND)).astype(np.uint8).ravel()

    def vertex_xy(self, index: np.ndarray | None = None) -> np.ndarray:
        """Positions of vertices (all when ``index`` is None), ``(n, 2)`` m."""
        ny, nx = self.shape
        idx = np.arange(ny * nx) if index is None else np.asarray(index)
        if self.map_origin is None:
            return self.origin + np.stack([idx % nx, idx // nx], axis=-1) * self.spacing
        # a window: the same arithmetic as the map's, so a vertex has the same position in both
        return self.map_origin + np.stack([self.offset[1] + idx % nx, self.offset[0] + idx // nx],
                                          axis=-1) * self.spacing

    def map_vertex(self, index: np.ndarray) -> np.ndarray:
        """The map vertex of each of this lattice's vertices."""
        idx = np.asarray(index, dtype=np.int64)
        nx = self.shape[1]
        return (self.offset[0] + idx // nx) * self.full_shape[1] + self.offset[1] + idx % nx

    def window(self, row: int, col: int, rows: int, cols: int) -> Lattice:
        """The map seen through the vertices ``[row, row + rows) × [col, col + cols)`` of this
        lattice (clipped to it): same rasters, edges with both ends inside; nothing is computed yet."""
        ny, nx = self.shape
        r0, c0 = min(max(int(row), 0), ny - 1), min(max(int(col), 0), nx - 1)
        r1, c1 = min(max(int(row + rows), r0 + 1), ny), min(max(int(col + cols), c0 + 1), nx)
        if (r0, c0, r1, c1) == (0, 0, ny, nx):
            return self
        offset = (self.offset[0] + r0, self.offset[1] + c0)
        return replace(self, origin=self.fine_origin + np.array([offset[1], offset[0]]) * self.spacing,
                       shape=(r1 - r0, c1 - c0), offset=offset, map_shape=self.full_shape,
                       map_origin=self.fine_origin, _cache={})

    # the edge tables, generated from the rasters on first use

    @property
    def unit_kind(self) -> np.ndarray:
        """(D/2, V) uint8 EdgeKind (LAND, WATER, HARBOUR, BRIDGE) or NO_EDGE."""
        return self._units()[0]

    @property
    def unit_weight(self) -> np.ndarray:
        """(D/2, V) float32 length · max(1, O1 · slope), before C1…C6."""
        return self._units()[1]

    @property
    def unit_removed(self) -> np.ndarray:
        """(D/2, V) bool, land edges that traverse B (permanent: B only grows)."""
        return self._units()[2]

    @property
    def directed_kind(self) -> np.ndarray:
        """(V, D) uint8: the live unit edges seen from both ends (row = tail vertex; column
        ``k + D/2`` of w is the edge of ``w − d_k``)."""
        return self.directed_tables()[0]

    @property
    def directed_weight(self) -> np.ndarray | LatticeWeights:
        """(V, D) float32, weights of :attr:`directed_kind` (on flat land read from the kinds)."""
        return self.directed_tables()[1]

    @property
    def bridge_src(self) -> np.ndarray:
        """(K,) int64, bridges of two or more steps with both ends in this lattice (its vertices)."""
        return self._bridges()[0]

    @property
    def bridge_dst(self) -> np.ndarray:
        return self._bridges()[1]

    @property
    def bridge_direction(self) -> np.ndarray:
        return self._bridges()[2]

    @property
    def bridge_length(self) -> np.ndarray:
        """(K,) m."""
        return self._bridges()[3]

    def _bridges(self) -> tuple[np.ndarray, ...]:
        if "bridges" not in self._cache:
            src, dst, k, steps = (self.map_bridges[:, i] for i in range(4))
            a, b = self._local(src), self._local(dst)
            keep = (a >= 0) & (b >= 0)
            self._cache["bridges"] = (a[keep], b[keep], k[keep], steps[keep] * self.direction_length[k[keep]])
        return self._cache["bridges"]

    def _local(self, map_vertex: np.ndarray) -> np.ndarray:
        """This lattice's index of map vertices, −1 outside it."""
        mnx = self.full_shape[1]
        r, c = map_vertex // mnx - self.offset[0], map_vertex % mnx - self.offset[1]
        inside = (r >= 0) & (r < self.shape[0]) & (c >= 0) & (c < self.shape[1])
        return np.where(inside, r * self.shape[1] + c, -1)

    def _units(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if "units" not in self._cache:
            self._cache["units"] = _unit_tables(self)
        return self._cache["units"]

    def edges(self, *, live: bool = False) -> dict[str, np.ndarray]:
        """All undirected edges as arrays ``src, dst, kind, direction, length, removed``
        (unit edges, then long bridges); with ``live`` without those removed by B."""
        mask = self.unit_kind != NO_EDGE
        if live:
            mask &= ~self.unit_removed
        flat = np.flatnonzero(mask)
        k, src = flat // self.n_vertices, flat % self.n_vertices
        n_b = len(self.bridge_src)
        return {
            "src": np.concatenate([src, self.bridge_src]),
            "dst": np.concatenate([src + self.direction_offset[k], self.bridge_dst]),
            "kind": np.concatenate([self.unit_kind.ravel()[flat], np.full(n_b, EdgeKind.BRIDGE, np.uint8)]),
            "direction": np.concatenate([k, self.bridge_direction]),
            "length": np.concatenate([self.direction_length[k], self.bridge_length]),
            "removed": np.concatenate([self.unit_removed.ravel()[flat], np.zeros(n_b, dtype=bool)]),
        }

    def fine_lookup(self, mask: np.ndarray, xy: np.ndarray, outside: bool = True) -> np.ndarray:
        """Value of a fine-raster mask at points ``(..., 2)`` (nearest fine point)."""
        ij = np.rint((np.asarray(xy) - self.fine_origin) / self.fine_step).astype(np.int64)
        rows, cols = mask.shape
        inside = (ij[..., 1] >= 0) & (ij[..., 1] < rows) & (ij[..., 0] >= 0) & (ij[..., 0] < cols)
        value = mask[np.clip(ij[..., 1], 0, rows - 1), np.clip(ij[..., 0], 0, cols - 1)]
        return np.where(inside, value, outside)

    def height_at(self, xy: np.ndarray) -> np.ndarray | None:
        """Height at points (nearest fine point), or None without a height raster."""
        if self.height is None:
            return None
        ij = np.rint((np.asarray(xy) - self.fine_origin) / self.fine_step).astype(np.int64)
        rows, cols = self.height.shape
        return self.height[np.clip(ij[..., 1], 0, rows - 1), np.clip(ij[..., 0], 0, cols - 1)]

    def with_built_up(self, area: shapely.Geometry | None, added: np.ndarray | None = None) -> Lattice:
        """This lattice with B grown by ``area``: every land edge that traverses it is removed.

        003 §3.4.2: B can only expand, so removal is permanent: the result's
        ``built_up`` and ``unit_removed`` are supersets of this one's. Water,
        harbour and bridge edges stay (003 removes land edges only). Only the
        B raster changes here; the edges follow it when they are generated.

        Parameters
        ----------
        area
            B (e.g. :attr:`BuiltUpArea.area`), shapely geometry in metres; it
            is joined to the B already removed. None or empty: no change.
        added
            Geometries outside which ``area`` holds no ground the B already removed did not
            (:attr:`BuiltUpArea.added`): only the fine points within their bounding boxes are
            tested. None: every point in ``area``'s bounding box B does not hold yet (on
            Campo Grande most of the town's box, a quarter of a second a road year).

        Returns
        -------
        Lattice
            A new lattice (``self`` when nothing changes).
        """
        if area is None or area.is_empty:
            return self
        within = None if added is None else shapely.bounds(np.asarray(added, dtype=object).reshape(-1))
        fine = _rasterise(area, self.fine_origin, self.fine_step, self.built_up.shape, known=self.built_up,
                          within=within)
        if np.array_equal(fine, self.built_up):
            return self
        return replace(self, built_up=fine, _cache={}, _shared=self.handed_on(fine & ~self.built_up))

    def handed_on(self, grown: np.ndarray) -> dict:
        """What this lattice's map tables become for the next B, ``grown`` the fine points it takes in
        (:meth:`with_built_up`; ``benchmarks/route_replay.py`` carries them from one captured call to
        the next so): the live unit edges or directed kinds without the land edges that sample it, the
        bridge and harbour entries as they are. Handed on, not copied: this lattice makes them again
        if asked."""
        shared = {}
        table = self._shared.pop("live", None)
        if table is not None:
            shared["live"] = _without_touched(table, self, grown)
        directed = self._shared.pop("directed", None)  # the map's directed table, where it replaced them
        if directed is not None:
            shared["directed"] = _directed_without_touched(directed, self, grown)
        if "special" in self._shared:  # B removes land edges only
            shared["special"] = self._shared["special"]
        return shared

    def directed_tables(self) -> tuple[np.ndarray, np.ndarray | LatticeWeights]:
        """Live unit edges in both directions: ``(V, D)`` kind (uint8, NO_EDGE) and weight (float32).

        Row = tail vertex. Column ``k + D/2`` of vertex w holds the edge that
        arrives at w along direction k, i.e. the unit edge of vertex ``w − d_k``.
        """
        if "directed" not in self._cache:
            if self.map_units is not None and self.map_units[1] is None:  # flat: cut from the map's live units
                self._cache["directed"] = self._window_tables()
            else:
                kind, unit_weight, removed = self._units()
                live = np.where(removed, np.uint8(NO_EDGE), kind)
                out_kind, out_weight = _directed(live, unit_weight, self.directions, self.shape)
                assert out_weight is not None  # weights given
                self._cache["directed"] = (out_kind, out_weight)
        return self._cache["directed"]

    def special_entries(self) -> np.ndarray:
        """Sorted flat indices into :meth:`directed_tables` (``v · D + column``) of the bridge and
        harbour entries: cropped from the map's, found once per run (B removes land edges only)
        where a search of every window looked through its whole table for them."""
        if self.map_units is None or self.map_units[1] is not None:
            return np.flatnonzero(_IS_SPECIAL[self.directed_tables()[0]])
        if "special" not in self._shared:
            self._shared["special"] = _map_special(self)
        n_dir = len(self.directions)
        v, col = np.divmod(self._shared["special"], n_dir)
        (ny, nx), (r0, c0) = self.shape, self.offset
        r, c = np.divmod(v, self.full_shape[1])
        r, c = r - r0, c - c0
        tr, tc = r + self.directions[col, 1], c + self.directions[col, 0]
        inside = ((r >= 0) & (r < ny) & (c >= 0) & (c < nx) & (tr >= 0) & (tr < ny) & (tc >= 0) & (tc < nx))
        return (r[inside] * nx + c[inside]) * n_dir + col[inside]

    def _map_table(self) -> np.ndarray:
        """The whole map's live unit edges of this B (:func:`_map_live_units`), made on first use."""
        table = self._shared.get("live")
        if table is None:
            table = self._shared["live"] = _map_live_units(self)
        return table

    def _window_tables(self) -> tuple[np.ndarray, LatticeWeights]:
        """:meth:`directed_tables` cut from the whole map's live unit edges (made once per run and
        carried from B to B, shared by every window; :func:`_window_directed`).

        The same tables as :func:`_directed` of the window's own unit tables: an edge with both
        ends in the window has the map's kind and B's removal (its samples lie between its ends).
        Every search window of a road year made its unit tables, B's removals and both directions
        again (Campo Grande: 10.3 s of 48 windows, 18 road years), though B changes once a year.
        On flat land an edge's weight is its length (:class:`LatticeWeights`, no table).
        """
        map_ny, map_nx = self.full_shape
        if map_ny * map_nx * len(self.directions) <= _MAP_DIRECTED_BYTES:
            kind = _cropped(self._map_directed(), self.full_shape, self.offset, self.shape, self.directions)
        else:
            kind = _window_directed(self._map_table(), self.full_shape, self.offset, self.shape, self.directions)
        return kind, LatticeWeights(kind, self.direction_length)

    def _map_directed(self) -> np.ndarray:
        """The whole map's live directed kinds ``(V_map, D)`` of this B (:func:`_window_directed` of the
        map), made once per run from its live unit edges, which it replaces (twice their size, the
        same edges), and carried from B to B (:meth:`with_built_up`): a window's table is a crop of it
        (:func:`_cropped`), where it was cut from the ``(D/2, V_map)`` unit edges afresh each time."""
        if "directed" not in self._shared:
            table = _window_directed(self._map_table(), self.full_shape, (0, 0), self.full_shape, self.directions)
            self._shared["directed"] = table
            del self._shared["live"]
        return self._shared["directed"]


def _crop(a: np.ndarray, row: int, col: int, shape: tuple[int, int], value) -> np.ndarray:
    """``a[row:row + h, col:col + w]`` with ``value`` where that lies outside ``a``."""
    h, w = shape
    out = np.full((h, w), value, dtype=a.dtype)
    r0, c0 = max(row, 0), max(col, 0)
    r1, c1 = min(row + h, a.shape[0]), min(col + w, a.shape[1])
    if r1 > r0 and c1 > c0:
        out[r0 - row:r1 - row, c0 - col:c1 - col] = a[r0:r1, c0:c1]
    return out


def _unit_tables(lat: Lattice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kind, weight and removal by B of every unit edge of a lattice (window), from the rasters.

    The kinds and weights are the map's (:attr:`Lattice.map_units`, made
    once by :func:`build_lattice`) cropped to the window; without them, the
    fine rasters are cropped to the window plus ``radius`` vertices on each
    side (beyond the map: dry, forbidden, flat), then each direction's
    samples are strided slices as in :func:`build_lattice` (the same samples:
    an edge inside the window never reaches past it). An edge with an end
    outside the window is not generated; a one-step bridge is kept when the
    whole-map filter kept it (:attr:`Lattice.bridge_keys`). Removal by B is
    sampled from the B raster, which grows every year.
    """
    f, (ny, nx), pad = lat.samples, lat.shape, lat.radius * lat.samples
    fine_shape = ((ny - 1) * f + 1 + 2 * pad, (nx - 1) * f + 1 + 2 * pad)
    row, col = lat.offset[0] * f - pad, lat.offset[1] * f - pad
    pb = _crop(lat.built_up, row, col, fine_shape, False)
    pc = ph = None
    if lat.map_units is None:
        pc = _crop(_codes(lat.water, lat.forbidden), row, col, fine_shape, 2)
        ph = None if lat.height is None else _crop(lat.height, row, col, fine_shape, 0.0)
    half = len(lat.directions) // 2
    n = ny * nx
    unit_kind = np.full((half, n), NO_EDGE, dtype=np.uint8)
    unit_weight = np.zeros((half, n), dtype=np.float32)
    removed = np.zeros((half, n), dtype=bool)
    opts = replace(LatticeOptions(), slope_weight=lat.slope_weight, slope_cutoff=lat.slope_cutoff)
    map_v = lat.map_vertex(np.arange(n)) if len(lat.bridge_keys) else None
    v_map = lat.full_shape[0] * lat.full_shape[1]
    r0, c0 = lat.offset
    iy, ix = np.divmod(np.arange(n), nx)
    for k in range(half):
        if lat.map_units is not None:  # the map's edges with both ends in the window
            map_kind, map_weight = lat.map_units
            dx, dy = (int(c) for c in lat.directions[k])
            inside = ((ix + dx >= 0) & (ix + dx < nx) & (iy + dy >= 0) & (iy + dy < ny))
            unit_kind[k] = np.where(inside, map_kind[k].reshape(lat.full_shape)[r0:r0 + ny, c0:c0 + nx].ravel(),
                                    np.uint8(NO_EDGE))
            unit_weight[k] = lat.direction_length[k] if map_weight is None else \
                map_weight[k].reshape(lat.full_shape)[r0:r0 + ny, c0:c0 + nx].ravel()
        else:
            assert pc is not None  # cropped above when there are no map units
            profile, slope = _profiles(lat.directions[k], pc, ph, pad, (ny, nx), f, lat.spacing)
            unit_kind[k], weight_k = _unit_edges(lat.directions[k], profile, slope, lat.spacing, opts)
            unit_weight[k] = lat.direction_length[k] if weight_k is None else weight_k
            bridge = np.flatnonzero(unit_kind[k] == EdgeKind.BRIDGE)
            if len(bridge):
                kept = np.zeros(len(bridge), dtype=bool) if map_v is None else \
                    np.isin(k * v_map + map_v[bridge], lat.bridge_keys, assume_unique=True)
                unit_kind[k, bridge[~kept]] = NO_EDGE
        land = unit_kind[k] == EdgeKind.LAND
        if land.any():
            removed[k] = land & _touched(pb, pad, lat.directions[k], (ny, nx), f).ravel()
    return unit_kind, unit_weight, removed


def _touched(padded: np.ndarray, pad: int, d: np.ndarray, shape: tuple[int, int], f: int) -> np.ndarray:
    """``(ny, nx)`` bool: whether the unit edge along ``d`` from each vertex samples a true point of
    a fine raster (padded by ``pad`` fine points round the vertices' own)."""
    touched = np.zeros(shape, dtype=bool)
    for oy, ox in _offsets(d, f):
        touched |= _slice(padded, pad, oy, ox, shape, f)
    return touched


def _map_live_units(lat: Lattice) -> np.ndarray:
    """The whole map's live unit edges ``(D/2, V_map)``: its unit edges (:attr:`Lattice.map_units`),
    the land ones that traverse B removed (NO_EDGE). Every window's directed tables are cut from it
    (:func:`_window_directed`).

    Each edge once, from its tail only: half the size of a directed ``(V_map, D)`` table of the map
    (143 MB against 285 MB on the synthetic 10,000-street town), and no transposed copy to make.
    """
    assert lat.map_units is not None  # only a lattice made by build_lattice has the map's edges
    return _without_touched(lat.map_units[0].copy(), lat, lat.built_up)


def _map_special(lat: Lattice) -> np.ndarray:
    """Sorted flat indices ``v · D + column`` into the whole map's directed tables of its bridge
    and harbour entries, from both ends: read direction by direction from :attr:`Lattice.map_units`
    (B removes land edges only), where a mask of the whole ``(V_map, D)`` table took 285 MB."""
    assert lat.map_units is not None
    map_kind = lat.map_units[0]
    n_dir = len(lat.directions)
    half = n_dir // 2
    offset = lat.directions[:, 1] * lat.full_shape[1] + lat.directions[:, 0]
    found = [np.zeros(0, dtype=np.int64)]
    for k in range(half):
        v = np.flatnonzero(_IS_SPECIAL[map_kind[k]])
        found += [v * n_dir + k, (v + offset[k]) * n_dir + half + k]
    return np.sort(np.concatenate(found))


def _window_directed(live: np.ndarray, map_shape: tuple[int, int], offset: tuple[int, int],
                     shape: tuple[int, int], directions: np.ndarray) -> np.ndarray:
    """A window's live directed kinds ``(V, D)`` (:meth:`Lattice.directed_tables`' layout) from the
    map's live unit edges ``(D/2, V_map)``: the edges with both ends in the window, each seen from
    its tail (column k) and from its head (column ``k + D/2``).

    Written a block of rows at a time (about 2 MB of the result), so that the 120 columns' strided
    writes stay in the cache."""
    (map_ny, map_nx), (r0, c0), (ny, nx) = map_shape, offset, shape
    n_dir = len(directions)
    half = n_dir // 2
    units = live.reshape(half, map_ny, map_nx)
    out = np.full((ny, nx, n_dir), NO_EDGE, dtype=np.uint8)
    block = max(1, (1 << 21) // max(nx * n_dir, 1))
    steps = directions[:half].tolist()  # dy ≥ 0 in the first half
    for a in range(0, ny, block):
        b = min(a + block, ny)
        for k, (dx, dy) in enumerate(steps):
            j0, j1 = max(0, -dx), min(nx, nx - dx)  # the head's column inside
            if j1 <= j0:
                continue
            i1 = min(b, ny - dy)  # from the tail (i, j) to (i + dy, j + dx)
            if i1 > a:
                out[a:i1, j0:j1, k] = units[k, r0 + a:r0 + i1, c0 + j0:c0 + j1]
            i0 = max(a, dy)  # at the head (i, j), from (i − dy, j − dx)
            if b > i0:
                out[i0:b, j0 + dx:j1 + dx, half + k] = units[k, r0 + i0 - dy:r0 + b - dy, c0 + j0:c0 + j1]
    return out.reshape(ny * nx, n_dir)


#: bytes of the map's live directed kinds (:meth:`Lattice._map_directed`, one byte a vertex and direction)
#: up to which windows crop their tables from it: Campo Grande's 71 MB (595,000 vertices × 120) fit,
#: the synthetic 10,000-street town's 285 MB do not (its windows cut their tables from the unit edges,
#: :func:`_window_directed`, as before). It replaces the map's unit edges (36 MB on Campo Grande) for
#: the run, so the run holds 36 MB more. Campo Grande's windows: a 626 × 453 window's table 0.113 →
#: 0.059 s CPU cropped, the whole map's 0.215 → 0.077 s (/tmp/h43r/crop_bench.py, session 43); its
#: default command (session 43, warm numba cache, runs back to back): the 66 windows' tables 2.23 / 2.41
#: → 1.08 s CPU, ``with_built_up`` 0.75 / 0.80 → 0.86 s, peak 0.879 → 0.912 GB, the same bytes
_MAP_DIRECTED_BYTES = 128 * 2**20


def _cropped(table: np.ndarray, map_shape: tuple[int, int], offset: tuple[int, int], shape: tuple[int, int],
             directions: np.ndarray) -> np.ndarray:
    """A window's live directed kinds ``(V, D)`` (:func:`_window_directed`'s) cropped from the map's
    (``table``: its rows the window covers made): a copy of the window's rows, then the edges whose
    other end leaves the window (within ``radius`` of its sides) set to NO_EDGE.

    The map's table holds an edge where both ends are on the map, the window's where both are in the
    window: the same entries but those. A row of the window is one run of ``nx · D`` bytes of the
    map's, where cutting it from the ``(D/2, V_map)`` unit edges wrote 120 strided columns."""
    (map_ny, map_nx), (r0, c0), (ny, nx) = map_shape, offset, shape
    n_dir = len(directions)
    half = n_dir // 2
    out = table.reshape(map_ny, map_nx, n_dir)[r0:r0 + ny, c0:c0 + nx].copy()
    for k, (dx, dy) in enumerate(directions[:half].tolist()):  # dy ≥ 0 in the first half
        # from the tail (i, j) to (i + dy, j + dx); at the head (i, j) from (i − dy, j − dx)
        out[max(ny - dy, 0):, :, k] = NO_EDGE
        out[:min(dy, ny), :, half + k] = NO_EDGE
        if dx > 0:
            out[:, max(nx - dx, 0):, k] = NO_EDGE
            out[:, :min(dx, nx), half + k] = NO_EDGE
        elif dx < 0:
            out[:, :min(-dx, nx), k] = NO_EDGE
            out[:, max(nx + dx, 0):, half + k] = NO_EDGE
    return out.reshape(ny * nx, n_dir)


def _near_the_new_ground(lat: Lattice, grown: np.ndarray
                         ) -> tuple[tuple[int, int, int, int], tuple[int, int], int, np.ndarray] | None:
    """The vertices whose edges may sample ``grown`` (fine points B took in): their box ``(r0, r1, c0,
    c1)`` (ends excluded: the vertices within ``radius`` of its bounding box), its shape, the fine pad
    (``radius`` vertices of fine samples) and ``grown`` cropped to the box and pad; None when nothing grew."""
    fi, fj = np.flatnonzero(grown.any(axis=1)), np.flatnonzero(grown.any(axis=0))  # its rows and columns
    if not len(fi):
        return None
    f, radius, (map_ny, map_nx) = lat.samples, lat.radius, lat.full_shape
    r0, r1 = max(int(fi[0]) // f - radius, 0), min(-(-int(fi[-1]) // f) + radius + 1, map_ny)
    c0, c1 = max(int(fj[0]) // f - radius, 0), min(-(-int(fj[-1]) // f) + radius + 1, map_nx)
    box = (r0, r1, c0, c1)
    shape = (r1 - r0, c1 - c0)
    pad = radius * f
    fine_shape = ((shape[0] - 1) * f + 1 + 2 * pad, (shape[1] - 1) * f + 1 + 2 * pad)
    return box, shape, pad, _crop(grown, r0 * f - pad, c0 * f - pad, fine_shape, False)


def _directed_without_touched(table: np.ndarray, lat: Lattice, grown: np.ndarray) -> np.ndarray:
    """The map's live directed kinds (:meth:`Lattice._map_directed`) without the land edges that sample
    ``grown`` (fine points B took in), changed in place and returned: :func:`_without_touched` on the
    edges' tail columns, each removal repeated in its head's column (``k + D/2`` of ``v + d_k``).
    The same table :func:`_window_directed` makes of the map's unit edges so carried: an edge of the
    map ends on it, so a head outside it is never live."""
    near = _near_the_new_ground(lat, grown)
    if near is None:
        return table
    (r0, r1, c0, c1), shape, pad, pg = near
    f, (map_ny, map_nx) = lat.samples, lat.full_shape
    n_dir = len(lat.directions)
    half = n_dir // 2
    cube = table.reshape(map_ny, map_nx, n_dir)
    for k, (dx, dy) in enumerate(lat.directions[:half].tolist()):
        part = cube[r0:r1, c0:c1, k]  # a view: the edges from the vertices near the new ground
        gone = (part == EdgeKind.LAND) & _touched(pg, pad, lat.directions[k], shape, f)
        part[gone] = NO_EDGE
        # their heads (r + dy, c + dx), the part of them on the map (dy ≥ 0 in the first half)
        h0, h1 = r0 + dy, min(r1 + dy, map_ny)
        g0, g1 = max(c0 + dx, 0), min(c1 + dx, map_nx)
        if h1 > h0 and g1 > g0:
            cube[h0:h1, g0:g1, half + k][gone[:h1 - h0, g0 - c0 - dx:g1 - c0 - dx]] = NO_EDGE
    return table


def _without_touched(table: np.ndarray, lat: Lattice, grown: np.ndarray) -> np.ndarray:
    """The map's live unit edges (:func:`_map_live_units`) without the land edges that sample
    ``grown`` (fine points B took in), changed in place and returned.

    B only grows, so the edges it removes from one year to the next are those that sample
    the new ground: only the vertices within ``radius`` of its bounding box are looked at.
    """
    near = _near_the_new_ground(lat, grown)
    if near is None:
        return table
    (r0, r1, c0, c1), shape, pad, pg = near
    f, (map_ny, map_nx) = lat.samples, lat.full_shape
    units = table.reshape(-1, map_ny, map_nx)
    for k in range(len(lat.directions) // 2):
        part = units[k, r0:r1, c0:c1]  # a view: the edges from the vertices near the new ground
        part[(part == EdgeKind.LAND) & _touched(pg, pad, lat.directions[k], shape, f)] = NO_EDGE
    return table


def _directed(unit_kind: np.ndarray, unit_weight: np.ndarray | None, directions: np.ndarray,
              shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray | None]:
    """The (V, D) tables of :meth:`Lattice.directed_tables` from the (D/2, V) unit tables
    (the weights None when ``unit_weight`` is)."""
    ny, nx = shape
    half = len(directions) // 2
    kind = unit_kind.reshape(half, ny, nx)
    weight = None if unit_weight is None else unit_weight.reshape(half, ny, nx)
    # written in the (V, D) layout at once: no (D, V) table and no transposed copy of it
    out_kind = np.full((ny, nx, 2 * half), NO_EDGE, dtype=np.uint8)
    out_kind[:, :, :half] = kind.transpose(1, 2, 0)
    out_weight = None
    if weight is not None:
        out_weight = np.zeros((ny, nx, 2 * half), dtype=np.float32)
        out_weight[:, :, :half] = weight.transpose(1, 2, 0)
    for k, (dx, dy) in enumerate(directions[:half].tolist()):
        # the edge of (iy − dy, ix − dx), seen from its head (iy, ix)
        ys, yt = slice(0, max(ny - dy, 0)), slice(min(dy, ny), ny)
        xs, xt = (slice(0, max(nx - dx, 0)), slice(min(dx, nx), nx)) if dx >= 0 else \
            (slice(min(-dx, nx), nx), slice(0, max(nx + dx, 0)))
        out_kind[yt, xt, half + k] = kind[k, ys, xs]
        if out_weight is not None and weight is not None:
            out_weight[yt, xt, half + k] = weight[k, ys, xs]
    n = ny * nx
    return out_kind.reshape(n, 2 * half), None if out_weight is None else out_weight.reshape(n, 2 * half)


def build_lattice(extent: tuple[float, float, float, float], *, water: Raster | None = None,
                  forbidden: Raster | None = None, height: Raster | None = None,
                  options: LatticeOptions | None = None, stitch_only: Raster | None = None) -> Lattice:
    """Build the pathfinding lattice G over a rectangle (003 §3.2.2; 000 §4.2.3).

    Only the fine rasters and the bridges are made here (bridges need the
    whole map: a crossing is kept when it is near the shortest from either
    of its ends); the land, water and harbour edges are generated from the
    rasters when a window of the lattice is first searched.

    Parameters
    ----------
    extent
        ``(xmin, ymin, xmax, ymax)`` in metres; vertex 0 sits at the lower-left corner.
    water, forbidden
        Boolean rasters (any cell size); a fine point is water (forbidden) when
        the cell under it is, or when a true cell's centre is nearest to it
        (thin rivers survive coarsening). Missing: none.
    height
        Elevation raster in metres, sampled bilinearly; missing: flat.
    options
        :class:`LatticeOptions`.
    stitch_only
        Boolean raster of ground forbidden to the lattice that a stitch of G′ may still cross
        (:attr:`Lattice.stitch_only`); missing: none.

    Returns
    -------
    Lattice
        Vertices, classes and edges with kinds and weights; nothing removed yet.
    """
    opts = options or LatticeOptions()
    x0, y0, x1, y1 = map(float, extent)
    if not (x1 > x0 and y1 > y0):
        raise InputError(f"lattice: empty extent {extent}")
    ell, f = opts.spacing, opts.samples_per_spacing
    nx, ny = int((x1 - x0) // ell) + 1, int((y1 - y0) // ell) + 1
    origin = np.array([x0, y0])
    fine_shape = ((ny - 1) * f + 1, (nx - 1) * f + 1)
    step = ell / f
    water_f = _resample_any(water, origin, step, fine_shape)
    forbidden_f = _resample_any(forbidden, origin, step, fine_shape)
    stitch_f = None if stitch_only is None else _resample_any(stitch_only, origin, step, fine_shape)
    if stitch_f is not None:
        stitch_f &= ~forbidden_f & ~water_f
        forbidden_f = forbidden_f | stitch_f
    height_f = _resample_linear(height, origin, step, fine_shape)
    directions = lattice_directions(opts.radius)
    half = len(directions) // 2
    pad = opts.radius * f
    pc, _ = _pad(_codes(water_f, forbidden_f), pad, 2)  # beyond the map: dry, forbidden, flat
    ph = None if height_f is None else _pad(height_f, pad, 0.0)[0]
    unit_src, unit_k, bridges = [], [], []
    map_kind = np.empty((half, ny * nx), dtype=np.uint8)
    map_weight = None if ph is None else np.empty((half, ny * nx), dtype=np.float32)
    for k in range(half):
        profile, slope = _profiles(directions[k], pc, ph, pad, (ny, nx), f, ell)
        kind_k, weight_k = _unit_edges(directions[k], profile, slope, ell, opts)
        map_kind[k] = kind_k
        if map_weight is not None and weight_k is not None:
            map_weight[k] = weight_k
        src = np.flatnonzero(profile.ravel() == _LWL)  # one-step bridges (_unit_edges)
        unit_src.append(src)
        unit_k.append(np.full(len(src), k, dtype=np.int64))
        bridges.append(_long_bridges(k, directions[k], profile, (ny, nx), ell, opts))
    ub_src, ub_k = np.concatenate(unit_src), np.concatenate(unit_k)
    bsrc, bdst, bdir, blen = (np.concatenate(c) for c in zip(*bridges))
    # of the crossings from a vertex keep the near-shortest (000: the shortest ray)
    offset = directions[:, 1] * nx + directions[:, 0]
    length = np.hypot(*directions.T) * ell
    keep = _bridge_filter(np.concatenate([ub_src, bsrc]), np.concatenate([ub_src + offset[ub_k], bdst]),
                          np.concatenate([length[ub_k], blen]), ny * nx, opts.bridge_slack)
    n_unit = len(ub_src)
    keys = np.sort(ub_k[keep[:n_unit]] * (ny * nx) + ub_src[keep[:n_unit]])
    keep = keep[n_unit:]
    steps = np.rint(blen / np.maximum(length[bdir], 1e-9)).astype(np.int64)
    map_bridges = np.stack([bsrc, bdst, bdir, steps], axis=1)[keep].astype(np.int64).reshape(-1, 4)
    is_bridge = map_kind.reshape(-1) == EdgeKind.BRIDGE  # one-step bridges the filter dropped go
    map_kind.reshape(-1)[np.flatnonzero(is_bridge)[~np.isin(np.flatnonzero(is_bridge), keys, assume_unique=True)]] \
        = NO_EDGE
    return Lattice(
        origin=origin, spacing=ell, shape=(ny, nx), samples=f, directions=directions,
        water=water_f, forbidden=forbidden_f, built_up=np.zeros(fine_shape, dtype=bool),
        bridge_keys=keys, map_bridges=map_bridges, height=height_f,
        slope_weight=opts.slope_weight, slope_cutoff=opts.slope_cutoff, stitch_only=stitch_f,
        map_units=(map_kind, map_weight),
    )


def _offsets(d: np.ndarray, f: int) -> list[tuple[int, int]]:
    """Fine-raster offsets (oy, ox) of the samples along one unit edge, DDA style."""
    dx, dy = int(d[0]), int(d[1])
    m = max(abs(dx), abs(dy)) * f
    t = np.arange(m + 1) / m
    return list(zip(np.rint(t * dy * f).astype(int).tolist(), np.rint(t * dx * f).astype(int).tolist()))


def _pad(a: np.ndarray, pad: int, value) -> tuple[np.ndarray, int]:
    return np.pad(a, pad, constant_values=value), pad


def _slice(padded: np.ndarray, pad: int, oy: int, ox: int, shape: tuple[int, int], f: int) -> np.ndarray:
    """The fine values at every vertex shifted by (oy, ox) fine steps, as an (ny, nx) array."""
    ny, nx = shape
    r0, c0 = pad + oy, pad + ox
    return padded[r0:r0 + (ny - 1) * f + 1:f, c0:c0 + (nx - 1) * f + 1:f]


def _codes(water: np.ndarray, forbidden: np.ndarray) -> np.ndarray:
    """The fine points as one uint8 raster: bit 0 water, bit 1 forbidden (what :func:`_profiles` reads)."""
    return water.astype(np.uint8) | (forbidden.astype(np.uint8) << 1)


def _profiles(d: np.ndarray, pc: np.ndarray, ph: np.ndarray | None, pad: int,
              shape: tuple[int, int], f: int, ell: float) -> tuple[np.ndarray, np.ndarray | None]:
    """Per vertex, the profile code of its unit edge along ``d`` and the edge's largest slope
    (None without heights).

    ``pc`` is :func:`_codes` of the fine rasters padded by ``pad`` points. Over every vertex
    only whether some sample is forbidden and whether some is water is read (one or-ed slice
    a sample); the edges with water and nothing forbidden, a few in a hundred, are then
    marched one sample at a time to tell water, harbour and bridge apart. Counting water
    samples and changes of medium at every vertex took two thirds of the synthetic
    10,000-street town's 11 s :func:`build_lattice`; the profiles are the same.
    """
    offsets = _offsets(d, f)
    m = len(offsets) - 1
    seen = np.zeros(shape, dtype=np.uint8)  # bit 0: a water sample, bit 1: a forbidden one
    for oy, ox in offsets:
        seen |= _slice(pc, pad, oy, ox, shape, f)
    profile = np.full(shape, _MIXED, dtype=np.uint8)
    profile[seen == 0] = _L
    ny, nx = shape
    wet = np.flatnonzero(seen.ravel() == 1)  # water and nothing forbidden
    if len(wet):
        iy, ix = np.divmod(wet, nx)
        r0, c0 = pad + iy * f, pad + ix * f
        n_water = np.zeros(len(wet), dtype=np.int16)
        changes = np.zeros(len(wet), dtype=np.int16)
        first_w = prev_w = pc[r0 + offsets[0][0], c0 + offsets[0][1]] == 1
        n_water += first_w
        for oy, ox in offsets[1:]:
            w = pc[r0 + oy, c0 + ox] == 1
            n_water += w
            changes += w != prev_w
            prev_w = w
        code = np.full(len(wet), _MIXED, dtype=np.uint8)
        code[n_water == m + 1] = _W
        code[(changes == 1) & ~first_w] = _LW
        code[(changes == 1) & first_w] = _WL
        code[(changes == 2) & ~first_w & ~prev_w] = _LWL
        profile.ravel()[wet] = code
    # an edge whose far end lies outside the lattice
    dx, dy = int(d[0]), int(d[1])
    if dx > 0:
        profile[:, max(nx - dx, 0):] = _MIXED
    elif dx < 0:
        profile[:, :min(-dx, nx)] = _MIXED
    if dy > 0:
        profile[max(ny - dy, 0):, :] = _MIXED
    elif dy < 0:
        profile[:min(-dy, ny), :] = _MIXED
    if ph is None:
        return profile, None
    slope = np.zeros(shape)
    step = float(np.hypot(*d)) * ell / m
    prev_h = None
    for oy, ox in offsets:
        h = _slice(ph, pad, oy, ox, shape, f)
        if prev_h is not None:
            np.maximum(slope, np.abs(h - prev_h) / step, out=slope)
        prev_h = h
    return profile, slope


def _unit_edges(d: np.ndarray, profile: np.ndarray, slope: np.ndarray | None, ell: float,
                opts: LatticeOptions) -> tuple[np.ndarray, np.ndarray | None]:
    """Kind (or NO_EDGE) and weight of every vertex's unit edge along ``d``: land, water,
    harbour (adjacent vertices only) or a one-step bridge. Without slopes (flat land) the
    weight is None: every edge's is its length."""
    length = float(np.hypot(*d)) * ell
    flat_profile = profile.ravel()
    kind = np.full(flat_profile.shape, NO_EDGE, dtype=np.uint8)
    land = flat_profile == _L
    if slope is not None:
        land &= slope.ravel() <= opts.slope_cutoff
    kind[land] = EdgeKind.LAND
    kind[flat_profile == _W] = EdgeKind.WATER
    if d[0] * d[0] + d[1] * d[1] <= 2:
        kind[(flat_profile == _LW) | (flat_profile == _WL)] = EdgeKind.HARBOUR
    kind[flat_profile == _LWL] = EdgeKind.BRIDGE
    if slope is None:
        return kind, None
    weight = np.where(kind == EdgeKind.LAND, length * np.maximum(1.0, opts.slope_weight * slope.ravel()), length)
    return kind, weight.astype(np.float32)


def _long_bridges(k: int, d: np.ndarray, profile: np.ndarray, shape: tuple[int, int], ell: float,
                  opts: LatticeOptions) -> tuple[np.ndarray, ...]:
    """Bridges of two or more unit steps along ``d``: land→water, water…, water→land."""
    ny, nx = shape
    unit = float(np.hypot(*d)) * ell
    iy, ix = np.nonzero(profile == _LW)
    start = iy * nx + ix
    found: list[tuple[np.ndarray, np.ndarray]] = []
    j = 1
    while len(start) and (j + 1) * unit <= opts.max_bridge_length:
        cy, cx = iy + j * d[1], ix + j * d[0]
        inside = (cy >= 0) & (cy < ny) & (cx >= 0) & (cx < nx)
        code = np.full(len(start), _MIXED, dtype=np.uint8)
        code[inside] = profile[cy[inside], cx[inside]]
        land = code == _WL
        if land.any():
            found.append((start[land], np.full(int(land.sum()), j + 1)))
        go_on = code == _W
        iy, ix, start = iy[go_on], ix[go_on], start[go_on]
        j += 1
    if not found:
        e = np.zeros(0, dtype=np.int64)
        return e, e, e, np.zeros(0)
    src = np.concatenate([s for s, _ in found])
    steps = np.concatenate([n for _, n in found])
    return src, src + steps * (d[1] * nx + d[0]), np.full(len(src), k), steps * unit


def _bridge_filter(src: np.ndarray, dst: np.ndarray, length: np.ndarray, n: int, slack: float) -> np.ndarray:
    """Keep bridges no longer than ``slack`` × the shortest crossing from either end."""
    shortest = np.full(n, np.inf)
    np.minimum.at(shortest, src, length)
    np.minimum.at(shortest, dst, length)
    return length <= slack * np.minimum(shortest[src], shortest[dst]) + 1e-9


def _fine_points(origin: np.ndarray, step: float, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    return np.meshgrid(origin[0] + np.arange(shape[1]) * step, origin[1] + np.arange(shape[0]) * step)


def _resample_any(raster: Raster | None, origin: np.ndarray, step: float, shape: tuple[int, int]) -> np.ndarray:
    """A boolean raster on the fine points: the cell under each point, or-ed with every
    true input cell whose centre is nearest to that point (no thin river is lost).

    Both are separable: a fine point's cell row depends on its y alone and its column on its
    x alone, and so does the fine point nearest to a cell's centre. So the first is one
    ``values[rows][:, cols]`` and the second the input's rows or-ed together by the fine row
    their centres fall on, then its columns by fine column: no array of points or of true
    cells (the synthetic 10,000-street town's 5 m raster of presumed frontage has 9.5 million
    true cells: their indices and centres took 0.6 GB and 1.8 s; the same points, the same bools).
    """
    out = np.zeros(shape, dtype=bool)
    if raster is None:
        return out
    values = np.asarray(raster.values, dtype=bool)
    n_rows, n_cols = values.shape
    # the cell under each fine point: its row from its y, its column from its x
    row, col = raster.rows_cols(origin[0] + np.arange(shape[1]) * step, origin[1] + np.arange(shape[0]) * step)
    col_in, row_in = (col >= 0) & (col < n_cols), (row >= 0) & (row < n_rows)
    if col_in.any() and row_in.any():
        out[np.ix_(row_in, col_in)] = values[np.ix_(row[row_in], col[col_in])]
    if not values.any():
        return out
    # the fine point nearest to each cell's centre
    fj = np.rint((raster.origin[0] + (np.arange(n_cols) + 0.5) * raster.cell - origin[0]) / step).astype(np.int64)
    fi = np.rint((raster.origin[1] + (np.arange(n_rows) + 0.5) * raster.cell - origin[1]) / step).astype(np.int64)
    r_ok = np.flatnonzero((fi >= 0) & (fi < shape[0]))
    c_ok = np.flatnonzero((fj >= 0) & (fj < shape[1]))
    if not len(r_ok) or not len(c_ok):
        return out
    r_first = r_ok[np.flatnonzero(np.diff(fi[r_ok], prepend=-1))]  # fi is non-decreasing: runs of one fine row
    c_first = c_ok[np.flatnonzero(np.diff(fj[c_ok], prepend=-1))]
    block = values[r_ok[0]:r_ok[-1] + 1, c_ok[0]:c_ok[-1] + 1]
    block = np.logical_or.reduceat(block, r_first - r_ok[0], axis=0)
    block = np.logical_or.reduceat(block, c_first - c_ok[0], axis=1)
    out[np.ix_(fi[r_first], fj[c_first])] |= block
    return out


def _resample_linear(raster: Raster | None, origin: np.ndarray, step: float,
                     shape: tuple[int, int]) -> np.ndarray | None:
    """Bilinear samples of a float raster (cell centres as knots) on the fine points."""
    if raster is None:
        return None
    from scipy.ndimage import map_coordinates
    xs, ys = _fine_points(origin, step, shape)
    cols = (xs - raster.origin[0]) / raster.cell - 0.5
    rows = (ys - raster.origin[1]) / raster.cell - 0.5
    return map_coordinates(np.asarray(raster.values, dtype=float), [rows, cols], order=1, mode="nearest")


#: fine points a side of the tiles :func:`_rasterise` classifies at once (a tile inside B or outside it
#: is not tested point by point): the synthetic 10,000-street town's first B tested 9 million points
_RASTER_TILE = 16


def _rasterise(geom: shapely.Geometry, origin: np.ndarray, step: float, shape: tuple[int, int],
               known: np.ndarray | None = None, within: np.ndarray | None = None) -> np.ndarray:
    """Fine points covered by ``geom`` (only the points inside its bounding box are tested),
    or-ed with ``known``, whose true points are not tested again (B only grows: each year
    tests only the ground it did not cover yet); with ``within`` (``(n, 4)`` bounds), only
    the points inside one of those boxes are.

    The points are taken in tiles (:data:`_RASTER_TILE`): a tile whose closed box ``geom``
    contains is covered, one whose box it does not meet is not, and only the points of the
    tiles across its boundary are tested one by one. The synthetic 10,000-street town's first
    B: 3.3 → 1.2 s CPU, peak +344 → +103 MB (its 9 million points and their coordinates); the
    same points."""
    out = np.zeros(shape, dtype=bool) if known is None else known.copy()
    gx0, gy0, gx1, gy1 = geom.bounds
    j0, j1 = max(int(np.floor((gx0 - origin[0]) / step)), 0), min(int(np.ceil((gx1 - origin[0]) / step)) + 1, shape[1])
    i0, i1 = max(int(np.floor((gy0 - origin[1]) / step)), 0), min(int(np.ceil((gy1 - origin[1]) / step)) + 1, shape[0])
    if j1 <= j0 or i1 <= i0:
        return out
    todo = ~out[i0:i1, j0:j1]
    if within is not None:
        boxes = np.asarray(within, dtype=float).reshape(-1, 4)
        boxes = boxes[np.isfinite(boxes).all(axis=1)]
        near = np.zeros_like(todo)
        lo_j = np.floor((boxes[:, 0] - origin[0]) / step).astype(np.int64) - j0
        hi_j = np.ceil((boxes[:, 2] - origin[0]) / step).astype(np.int64) + 1 - j0
        lo_i = np.floor((boxes[:, 1] - origin[1]) / step).astype(np.int64) - i0
        hi_i = np.ceil((boxes[:, 3] - origin[1]) / step).astype(np.int64) + 1 - i0
        for a, b, c, d in zip(np.maximum(lo_i, 0).tolist(), np.maximum(hi_i, 0).tolist(),
                              np.maximum(lo_j, 0).tolist(), np.maximum(hi_j, 0).tolist()):
            near[a:b, c:d] = True
        todo &= near
    shapely.prepare(geom)
    # tiles of points: one wholly inside geom (its closed box is) takes every point, one wholly outside
    # none; only the points of tiles across geom's boundary are tested one by one
    h, w = todo.shape
    t = _RASTER_TILE
    th, tw = -(-h // t), -(-w // t)
    busy = np.pad(todo, ((0, th * t - h), (0, tw * t - w))).reshape(th, t, tw, t).any(axis=(1, 3))
    ti, tj = np.nonzero(busy)
    a_i, a_j = ti * t, tj * t
    b_i, b_j = np.minimum(a_i + t, h) - 1, np.minimum(a_j + t, w) - 1  # the tiles' last points
    state = np.full((th, tw), 2, dtype=np.uint8)  # 0 outside, 1 inside, 2 tested point by point
    solid = (b_i > a_i) & (b_j > a_j)  # a box of one row or column is no polygon
    boxes = shapely.box(origin[0] + (j0 + a_j[solid]) * step, origin[1] + (i0 + a_i[solid]) * step,
                        origin[0] + (j0 + b_j[solid]) * step, origin[1] + (i0 + b_i[solid]) * step)
    try:
        inside, meets = shapely.contains(geom, boxes), shapely.intersects(geom, boxes)
    except shapely.errors.GEOSException:  # an invalid B a box test refuses: every point tested, as before
        inside, meets = np.zeros(len(boxes), dtype=bool), np.ones(len(boxes), dtype=bool)
    state[ti[solid], tj[solid]] = np.where(inside, 1, np.where(meets, 2, 0))
    state = np.repeat(np.repeat(state, t, axis=0), t, axis=1)[:h, :w]
    part = out[i0:i1, j0:j1]  # a view
    part[todo & (state == 1)] = True
    ii, jj = np.nonzero(todo & (state == 2))
    part[ii, jj] = shapely.intersects_xy(geom, origin[0] + (j0 + jj) * step, origin[1] + (i0 + ii) * step)
    return out

