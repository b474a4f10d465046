"""The pathfinding lattice G, the built-up area B and the stitched graph G′.

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
loop over vertices. :func:`build_lattice` keeps only the fine rasters and
the bridges (their filter needs the whole map); the land, water and harbour
edges of a rectangle of vertices (:meth:`Lattice.window`) are generated from
the rasters when that window is first searched.

**B** (003 Eq. 1) is ``FILL(S) \\ ∪ FILL(B_T) ∪ NB(S) ∪ ∪ NB(B_T)``: the
built-up blocks plus a neighbourhood of every street on the shell or on a
terrain block. Terrain blocks are those larger than ``terrain_block_area``
(003's "simple block-area classifier") or holding water (000's water
blocks). Streets between two built-up blocks lie inside built-up blocks, so
B is computed as the built-up blocks plus ``neighbourhood`` metres around
every street, and joined to the previous B: it never shrinks.
:meth:`Lattice.with_built_up` removes every land edge that traverses B from
the lattice for good (003: "permanently remove all land edges that traverse
B"); water, harbour and bridge edges stay.

**G′** (:func:`pathfinding_graph`) is that lattice plus the street segments
(major and minor; long segments on the shell get a point every
``split_spacing`` m so that a road can join them anywhere, like 003 §3.3's
temporary nodes) plus *stitches*: short new-road edges from the street
points on the shell and on terrain blocks to nearby live land vertices, and
between shell points (003 Fig. 9), none crossing or grazing a street,
entering a built-up block or touching water. Edge costs are multiplied by
C1…C6 (003 §3.4.2) by kind. The lattice part of G′ stays a table (vertex ×
direction); the other edges are short arrays. Its CSR matrix holds the
allowed edges row by row, so it is built without sorting, and cached.

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

The water and forbidden rasters should be drawn generously
(:meth:`Raster.from_geometry`: a cell is water when water comes within half
its diagonal): the lattice sees water only where the raster says so, and a
stream thinner than a cell that falls between cell centres would get a road
across it without a bridge.
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from enum import IntEnum
from math import gcd

import numpy as np
import shapely
from scipy.sparse import csr_matrix
from scipy.spatial import cKDTree

from osm_expand.errors import InputError

__all__ = [
    "VertexClass", "EdgeKind", "Raster", "LatticeOptions", "Lattice", "build_lattice",
    "lattice_directions", "Segments", "BuiltUpOptions", "BuiltUpArea", "built_up_area",
    "segment_sides", "EdgeCosts", "GraphOptions", "PathGraph", "pathfinding_graph", "StreetPart", "street_part",
    "GraphWindow", "ImplicitGraph", "implicit_graph",
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

    def cell_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row, column of the cell holding each point, and whether it is inside the raster."""
        col = np.floor((np.asarray(x) - self.origin[0]) / self.cell).astype(np.int64)
        row = np.floor((np.asarray(y) - self.origin[1]) / self.cell).astype(np.int64)
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
        _positive(self, ("spacing", "slope_weight", "slope_cutoff", "max_bridge_length"))
        if self.radius < 1 or self.samples_per_spacing < 1:
            raise InputError("lattice: radius and samples_per_spacing must be at least 1")
        if self.bridge_slack < 1.0:
            raise InputError(f"lattice: bridge_slack must be ≥ 1, got {self.bridge_slack}")


def _positive(opts: object, names: Sequence[str]) -> None:
    for name in names:
        value = getattr(opts, name)
        if not value > 0:
            raise InputError(f"{type(opts).__name__}.{name} must be positive, got {value}")


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


@dataclass(frozen=True)
class Lattice:
    """The pathfinding graph G over a rectangle of vertices, its edges made when asked for.

    A lattice stores no edge table: only the fine rasters of the whole map
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
    Never mutated: :meth:`with_built_up` returns a new one.
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
    def directed_weight(self) -> np.ndarray:
        """(V, D) float32, weights of :attr:`directed_kind`."""
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

    def with_built_up(self, area: shapely.Geometry | None) -> Lattice:
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

        Returns
        -------
        Lattice
            A new lattice (``self`` when nothing changes).
        """
        if area is None or area.is_empty:
            return self
        fine = _rasterise(area, self.fine_origin, self.fine_step, self.built_up.shape, known=self.built_up)
        if np.array_equal(fine, self.built_up):
            return self
        return replace(self, built_up=fine, _cache={})

    def directed_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """Live unit edges in both directions: ``(V, D)`` kind (uint8, NO_EDGE) and weight (float32).

        Row = tail vertex. Column ``k + D/2`` of vertex w holds the edge that
        arrives at w along direction k, i.e. the unit edge of vertex ``w − d_k``.
        """
        if "directed" not in self._cache:
            kind, weight, removed = self._units()
            live = np.where(removed, np.uint8(NO_EDGE), kind)
            self._cache["directed"] = _directed(live, weight, self.directions, self.shape)
        return self._cache["directed"]


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
    pw = pf = ph = None
    if lat.map_units is None:
        pw = _crop(lat.water, row, col, fine_shape, False)
        pf = _crop(lat.forbidden, row, col, fine_shape, True)
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
            assert pw is not None and pf is not None  # cropped above when there are no map units
            profile, slope = _profiles(lat.directions[k], pw, pf, ph, pad, (ny, nx), f, lat.spacing)
            unit_kind[k], unit_weight[k] = _unit_edges(lat.directions[k], profile, slope, lat.spacing, opts)
            bridge = np.flatnonzero(unit_kind[k] == EdgeKind.BRIDGE)
            if len(bridge):
                kept = np.zeros(len(bridge), dtype=bool) if map_v is None else \
                    np.isin(k * v_map + map_v[bridge], lat.bridge_keys, assume_unique=True)
                unit_kind[k, bridge[~kept]] = NO_EDGE
        land = unit_kind[k] == EdgeKind.LAND
        if land.any():
            touched = np.zeros((ny, nx), dtype=bool)
            for oy, ox in _offsets(lat.directions[k], f):
                touched |= _slice(pb, pad, oy, ox, (ny, nx), f)
            removed[k] = land & touched.ravel()
    return unit_kind, unit_weight, removed


def _directed(unit_kind: np.ndarray, unit_weight: np.ndarray, directions: np.ndarray,
              shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The (V, D) tables of :meth:`Lattice.directed_tables` from the (D/2, V) unit tables."""
    ny, nx = shape
    half = len(directions) // 2
    kind, weight = unit_kind.reshape(half, ny, nx), unit_weight.reshape(half, ny, nx)
    # written in the (V, D) layout at once: no (D, V) table and no transposed copy of it
    out_kind = np.full((ny, nx, 2 * half), NO_EDGE, dtype=np.uint8)
    out_weight = np.zeros((ny, nx, 2 * half), dtype=np.float32)
    out_kind[:, :, :half] = kind.transpose(1, 2, 0)
    out_weight[:, :, :half] = weight.transpose(1, 2, 0)
    for k, (dx, dy) in enumerate(directions[:half].tolist()):
        # the edge of (iy − dy, ix − dx), seen from its head (iy, ix)
        ys, yt = slice(0, max(ny - dy, 0)), slice(min(dy, ny), ny)
        xs, xt = (slice(0, max(nx - dx, 0)), slice(min(dx, nx), nx)) if dx >= 0 else \
            (slice(min(-dx, nx), nx), slice(0, max(nx + dx, 0)))
        out_kind[yt, xt, half + k] = kind[k, ys, xs]
        out_weight[yt, xt, half + k] = weight[k, ys, xs]
    n = ny * nx
    return out_kind.reshape(n, 2 * half), out_weight.reshape(n, 2 * half)


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
    pw, _ = _pad(water_f, pad, False)
    pf, _ = _pad(forbidden_f, pad, True)
    ph = None if height_f is None else _pad(height_f, pad, 0.0)[0]
    unit_src, unit_k, bridges = [], [], []
    map_kind = np.empty((half, ny * nx), dtype=np.uint8)
    map_weight = None if ph is None else np.empty((half, ny * nx), dtype=np.float32)
    for k in range(half):
        profile, slope = _profiles(directions[k], pw, pf, None if ph is None else ph, pad, (ny, nx), f, ell)
        kind_k, weight_k = _unit_edges(directions[k], profile, slope, ell, opts)
        map_kind[k] = kind_k
        if map_weight is not None:
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


def _profiles(d: np.ndarray, pw: np.ndarray, pf: np.ndarray, ph: np.ndarray | None, pad: int,
              shape: tuple[int, int], f: int, ell: float) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex, the profile code of its unit edge along ``d`` and the edge's largest slope."""
    offsets = _offsets(d, f)
    m = len(offsets) - 1
    any_forbidden = np.zeros(shape, dtype=bool)
    n_water = np.zeros(shape, dtype=np.int16)
    changes = np.zeros(shape, dtype=np.int16)
    slope = np.zeros(shape)
    step = float(np.hypot(*d)) * ell / m
    prev_w = prev_h = first_w = None
    for oy, ox in offsets:
        w = _slice(pw, pad, oy, ox, shape, f)
        any_forbidden |= _slice(pf, pad, oy, ox, shape, f)
        n_water += w
        if ph is not None:
            h = _slice(ph, pad, oy, ox, shape, f)
            if prev_h is not None:
                np.maximum(slope, np.abs(h - prev_h) / step, out=slope)
            prev_h = h
        if prev_w is None:
            first_w = w
        else:
            changes += w != prev_w
        prev_w = w
    assert first_w is not None and prev_w is not None  # offsets has at least two points
    profile = np.full(shape, _MIXED, dtype=np.uint8)
    ok = ~any_forbidden
    profile[ok & (n_water == 0)] = _L
    profile[ok & (n_water == m + 1)] = _W
    profile[ok & (changes == 1) & ~first_w] = _LW
    profile[ok & (changes == 1) & first_w] = _WL
    profile[ok & (changes == 2) & ~first_w & ~prev_w] = _LWL
    ny, nx = shape
    iy, ix = np.mgrid[0:ny, 0:nx]
    profile[(ix + d[0] < 0) | (ix + d[0] >= nx) | (iy + d[1] < 0) | (iy + d[1] >= ny)] = _MIXED
    return profile, slope


def _unit_edges(d: np.ndarray, profile: np.ndarray, slope: np.ndarray, ell: float,
                opts: LatticeOptions) -> tuple[np.ndarray, np.ndarray]:
    """Kind (or NO_EDGE) and weight of every vertex's unit edge along ``d``: land, water,
    harbour (adjacent vertices only) or a one-step bridge."""
    length = float(np.hypot(*d)) * ell
    flat_profile, flat_slope = profile.ravel(), slope.ravel()
    kind = np.full(flat_profile.shape, NO_EDGE, dtype=np.uint8)
    kind[(flat_profile == _L) & (flat_slope <= opts.slope_cutoff)] = EdgeKind.LAND
    kind[flat_profile == _W] = EdgeKind.WATER
    if d[0] * d[0] + d[1] * d[1] <= 2:
        kind[(flat_profile == _LW) | (flat_profile == _WL)] = EdgeKind.HARBOUR
    kind[flat_profile == _LWL] = EdgeKind.BRIDGE
    weight = np.where(kind == EdgeKind.LAND, length * np.maximum(1.0, opts.slope_weight * flat_slope), length)
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
    true input cell whose centre is nearest to that point (no thin river is lost)."""
    out = np.zeros(shape, dtype=bool)
    if raster is None:
        return out
    xs, ys = _fine_points(origin, step, shape)
    row, col, inside = raster.cell_index(xs, ys)
    out |= np.asarray(raster.values, dtype=bool)[row, col] & inside
    r, c = np.nonzero(np.asarray(raster.values, dtype=bool))
    cx = raster.origin[0] + (c + 0.5) * raster.cell
    cy = raster.origin[1] + (r + 0.5) * raster.cell
    fj = np.rint((cx - origin[0]) / step).astype(np.int64)
    fi = np.rint((cy - origin[1]) / step).astype(np.int64)
    ok = (fi >= 0) & (fi < shape[0]) & (fj >= 0) & (fj < shape[1])
    out[fi[ok], fj[ok]] = True
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


def _rasterise(geom: shapely.Geometry, origin: np.ndarray, step: float, shape: tuple[int, int],
               known: np.ndarray | None = None) -> np.ndarray:
    """Fine points covered by ``geom`` (only the points inside its bounding box are tested),
    or-ed with ``known``, whose true points are not tested again (B only grows: each year
    tests only the ground it did not cover yet)."""
    out = np.zeros(shape, dtype=bool) if known is None else known.copy()
    gx0, gy0, gx1, gy1 = geom.bounds
    j0, j1 = max(int(np.floor((gx0 - origin[0]) / step)), 0), min(int(np.ceil((gx1 - origin[0]) / step)) + 1, shape[1])
    i0, i1 = max(int(np.floor((gy0 - origin[1]) / step)), 0), min(int(np.ceil((gy1 - origin[1]) / step)) + 1, shape[0])
    if j1 <= j0 or i1 <= i0:
        return out
    ii, jj = np.nonzero(~out[i0:i1, j0:j1])
    shapely.prepare(geom)
    out[i0 + ii, j0 + jj] = shapely.intersects_xy(geom, origin[0] + (j0 + jj) * step, origin[1] + (i0 + ii) * step)
    return out


# ---------------------------------------------------------------- street segments


@dataclass(frozen=True)
class Segments:
    """The segment graph G = (J, S) (003 §3.2.2) as plain arrays.

    Straight junction-to-junction (or shape-point) segments between nodes.
    ``available`` is each segment's remaining traffic capacity
    ``O2 · width − T(s)`` (003 §3.4.2), None when capacity does not matter.
    """

    xy: np.ndarray  #: (N, 2) float64 m, node positions
    uv: np.ndarray  #: (S, 2) int, node indices of each segment
    major: np.ndarray  #: (S,) bool, major road (else minor)
    width: np.ndarray  #: (S,) float64 m
    bridge: np.ndarray  #: (S,) bool
    available: np.ndarray | None = None  #: (S,) remaining capacity, traffic units
    harbour: np.ndarray | None = None  #: (S,) bool, built harbour segments (C4)

    def __post_init__(self) -> None:
        n = len(self.uv)
        if np.ndim(self.xy) != 2 or np.shape(self.xy)[1:] != (2,) or np.shape(self.uv) != (n, 2):
            raise InputError("segments: xy must be (N, 2) and uv (S, 2)")
        for name in ("major", "width", "bridge", "available", "harbour"):
            value = getattr(self, name)
            if value is not None and np.shape(value) != (n,):
                raise InputError(f"segments: {name} must have one value per segment ({n}), got {np.shape(value)}")
        if n and (np.min(self.uv) < 0 or np.max(self.uv) >= len(self.xy)):
            raise InputError("segments: uv refers to a node that does not exist")

    @classmethod
    def from_lines(cls, lines: Sequence[np.ndarray], *, major: Sequence[bool], width: Sequence[float],
                   bridge: Sequence[bool] | None = None, available: Sequence[float] | None = None) -> Segments:
        """Segments from polylines; points equal to the micrometre become one node.

        Parameters
        ----------
        lines
            Polylines, each ``(M, 2)`` metres; every consecutive pair of points is a segment.
        major, width, bridge, available
            One value per polyline, given to all its segments (``bridge``
            default False, ``available`` default None: unlimited).

        Returns
        -------
        Segments
        """
        pts = [np.asarray(line, dtype=float).reshape(-1, 2) for line in lines]
        counts = np.array([len(p) - 1 for p in pts])
        every = np.concatenate(pts) if pts else np.zeros((0, 2))
        xy, inverse = np.unique(np.round(every, 6), axis=0, return_inverse=True)
        inverse = inverse.ravel()
        starts = np.concatenate([[0], np.cumsum([len(p) for p in pts])])
        uv = np.concatenate([np.stack([inverse[s:e - 1], inverse[s + 1:e]], axis=1)
                             for s, e in zip(starts[:-1], starts[1:])]) if pts else np.zeros((0, 2), int)
        per = lambda values, dtype: np.repeat(np.asarray(values, dtype=dtype), counts)  # noqa: E731
        keep = uv[:, 0] != uv[:, 1]
        return cls(
            xy=xy, uv=uv[keep], major=per(major, bool)[keep], width=per(width, float)[keep],
            bridge=(per(bridge, bool) if bridge is not None else np.zeros(counts.sum(), bool))[keep],
            available=None if available is None else per(available, float)[keep],
        )

    @property
    def a(self) -> np.ndarray:
        return self.xy[self.uv[:, 0]]

    @property
    def b(self) -> np.ndarray:
        return self.xy[self.uv[:, 1]]

    def lengths(self) -> np.ndarray:
        return np.hypot(*(self.b - self.a).T)

    def lines(self) -> np.ndarray:
        """One shapely LineString per segment."""
        return shapely.linestrings(np.stack([self.a, self.b], axis=1))


def segment_sides(segments: Segments, built_blocks: shapely.Geometry | None) -> np.ndarray:
    """How many sides of each segment touch a built-up block.

    Tested half a width plus 2 m to the left and right of the midpoint. A
    segment with at most one built-up side is on the shell or a terrain
    block: *extendible* (003 §3.4.2, C6) and a place to stitch to.

    Parameters
    ----------
    segments
        The segment graph.
    built_blocks
        Union of the built-up blocks (:attr:`BuiltUpArea.blocks`); None: none.

    Returns
    -------
    numpy.ndarray
        ``(S,)`` int in {0, 1, 2}.
    """
    if built_blocks is None or built_blocks.is_empty or not len(segments.uv):
        return np.zeros(len(segments.uv), dtype=np.int64)
    a, b = segments.a, segments.b
    mid = 0.5 * (a + b)
    tangent = (b - a) / np.maximum(np.hypot(*(b - a).T), 1e-9)[:, None]
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1) * (0.5 * segments.width + 2.0)[:, None]
    shapely.prepare(built_blocks)
    left = shapely.contains_xy(built_blocks, *(mid + normal).T)
    right = shapely.contains_xy(built_blocks, *(mid - normal).T)
    return left.astype(np.int64) + right


# ---------------------------------------------------------------- the built-up area B


@dataclass(frozen=True)
class BuiltUpOptions:
    """Tunables of the built-up area B (003 Eq. 1)."""

    #: m², blocks larger than this are terrain (fields, forests): 003's block-area classifier.
    #: 000 §4.2.7 prints "95 m2" (garbled); town blocks rarely exceed a few hectares (Krems:
    #: 90 % of its blocks are under 2.3 ha), fields between villages do.
    terrain_block_area: float = 50_000.0
    #: share of a block under water above which it is a water block, i.e. terrain (000 §4.2.7)
    water_block_share: float = 0.05
    #: m, NB: the neighbourhood of the outlines (shell, terrain blocks) that B includes;
    #: 1.5 ℓ keeps new roads a lattice step clear of the streets they run beside
    neighbourhood: float = 30.0

    def __post_init__(self) -> None:
        _positive(self, ("terrain_block_area", "neighbourhood"))


@dataclass(frozen=True)
class BuiltUpArea:
    """B and the blocks it came from."""

    area: shapely.Geometry  #: B, monotone over the years
    blocks: shapely.Geometry  #: union of the current built-up blocks B_B,i


def built_up_area(blocks: Sequence[shapely.Geometry], segments: Segments, *,
                  water: shapely.Geometry | None = None, previous: BuiltUpArea | None = None,
                  options: BuiltUpOptions | None = None) -> BuiltUpArea:
    """The built-up area B of 003 Eq. 1, grown from ``previous`` (it never shrinks).

    Parameters
    ----------
    blocks
        Faces of the segment graph (shapely polygons, m), e.g. :func:`osm_expand.blocks.blocks`.
    segments
        The segment graph.
    water
        Water polygons; blocks with more than ``water_block_share`` water are terrain.
    previous
        Last year's B, joined into the result.
    options
        :class:`BuiltUpOptions`.

    Returns
    -------
    BuiltUpArea
        ``area`` = previous B ∪ built-up blocks ∪ ``neighbourhood`` m around every
        segment; ``blocks`` = the built-up blocks of now.
    """
    opts = options or BuiltUpOptions()
    polys = np.array([b for b in blocks if b is not None and not b.is_empty], dtype=object)
    built = np.ones(len(polys), dtype=bool)
    if len(polys):
        area = shapely.area(polys)
        built &= area <= opts.terrain_block_area
        if water is not None and not water.is_empty:
            shapely.prepare(water)
            wet = shapely.area(shapely.intersection(polys, water))
            built &= wet <= opts.water_block_share * area
    built_blocks = shapely.union_all(polys[built]) if built.any() else shapely.Polygon()
    parts = [built_blocks]
    if len(segments.uv):
        lines = segments.lines()
        if previous is not None:  # B never shrinks: only segments it does not hold yet are buffered
            shapely.prepare(previous.area)
            a, b = segments.a, segments.b
            held = (shapely.contains_xy(previous.area, *a.T) & shapely.contains_xy(previous.area, *b.T)
                    & shapely.contains_xy(previous.area, *(0.5 * (a + b)).T))
            lines = lines[~held]
        if len(lines):
            # each segment buffered, then one cascaded union: 5× faster than buffering the
            # multilinestring (Campo Grande's 17,978 segments: 1.7 s against 8.7 s), same polygon
            parts.extend(shapely.buffer(lines, opts.neighbourhood, quad_segs=4).tolist())
    if previous is not None:
        parts.append(previous.area)
    return BuiltUpArea(area=shapely.union_all(parts), blocks=built_blocks)


# ---------------------------------------------------------------- G′


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
        _positive(self, ("major", "minor", "harbour", "built_harbour", "bridge", "extendible"))


@dataclass(frozen=True)
class GraphOptions:
    """Tunables of G′: splitting streets and stitching them to the lattice (003 Fig. 9)."""

    #: m, a shell segment longer than 2ℓ gets a point every this many metres (003 §3.3: 1.25ℓ)
    split_spacing: float = 25.0
    #: m, street points connect to live land vertices this close (B's 30 m plus 2.5ℓ)
    stitch_radius: float = 80.0
    shell_stitch_radius: float = 120.0  #: m, shell points connect to each other this close (003 Fig. 9)
    #: m, a stitch keeps this far from every street except near its own end
    clearance: float = 5.0
    #: stitches per street point to its nearest live land vertices (000 joins all within the
    #: radius; the nearest 16 give every heading away from the street and keep G′ small)
    max_stitches: int = 16
    max_shell_stitches: int = 8  #: stitches per shell point to its nearest shell points

    def __post_init__(self) -> None:
        _positive(self, ("split_spacing", "stitch_radius", "shell_stitch_radius", "clearance",
                         "max_stitches", "max_shell_stitches"))


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
    segments: Segments
    xy: np.ndarray  #: (V′, 2) m
    n_lattice: int
    split_segment: np.ndarray  #: (P,) parent segment of each split point
    lat_kind: np.ndarray  #: (V, D) uint8 EdgeKind or NO_EDGE
    lat_weight: np.ndarray  #: (V, D) float32 cost, × C3 / C5 for harbours / bridges
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
              street_ok: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
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
            ``(V, D)`` bool over ``lat_kind`` and ``(E,)`` bool over the other edges.
        """
        table = np.zeros(256, dtype=bool)
        table[[int(k) for k in kinds]] = True
        lat = table[self.lat_kind]
        extra = table[self.kind]
        if street_ok is not None and len(street_ok):
            extra &= (self.segment < 0) | np.asarray(street_ok, dtype=bool)[np.maximum(self.segment, 0)]
        return lat, extra

    def matrix(self, kinds: Sequence[EdgeKind] = ROAD_KINDS) -> csr_matrix:
        """CSR adjacency ``(V′, V′)`` over the edges of the given kinds (cached: the two most recent).

        Only the allowed edges are in it. Use :meth:`restricted` to leave streets out.
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

    def _csr(self, lat: np.ndarray, extra: np.ndarray) -> tuple[csr_matrix, np.ndarray, np.ndarray]:
        """One CSR of the allowed edges, without sorting, and where each allowed other edge sits in it.

        A row holds its live lattice edges in direction order, then its other
        edges in their (tail-sorted) order. Only the edges that exist are
        written, each straight to its place: a lattice edge ``j`` (in row-major
        order of ``lat``) goes to ``j`` + the other edges of earlier rows, an
        other edge ``i`` to ``i`` + the lattice edges of its row and earlier
        ones. The lattice part is done in blocks of rows, so the temporaries
        stay a few MB while the whole map's window has ~5·10⁷ edges (writing
        every slot of the ``(V, D)`` table and dropping the empty ones cost a
        second and 12 bytes a slot per window, and per-edge int64 indices 3 GB).
        """
        n_lat, n_dir = lat.shape
        n = self.n_vertices
        lat_counts = np.zeros(n, dtype=np.int64)
        lat_counts[:n_lat] = np.count_nonzero(lat, axis=1)
        ex = np.flatnonzero(extra)
        ex_src = self.src[ex]
        ex_counts = np.bincount(ex_src, minlength=n)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(lat_counts + ex_counts, out=indptr[1:])
        total = int(indptr[-1])
        index_type = np.int32 if max(total, n) < 2**31 else np.int64
        indices = np.empty(total, dtype=index_type)
        data = np.empty(total)
        lat_through = np.cumsum(lat_counts)  # lattice edges in rows up to each row
        ex_before = np.cumsum(ex_counts) - ex_counts  # other edges in the rows before each row
        offset = self.lattice.direction_offset.astype(index_type)
        block = max(1, (1 << 22) // max(n_dir, 1))
        done = 0
        for a in range(0, n_lat, block):
            b = min(a + block, n_lat)
            live = lat[a:b]
            k = int(lat_through[b - 1]) - done
            if not k:
                continue
            pos = np.arange(done, done + k) + np.repeat(ex_before[a:b], lat_counts[a:b])
            indices[pos] = (np.arange(a, b, dtype=index_type)[:, None] + offset)[live]
            data[pos] = self.lat_weight[a:b][live]
            done += k
        pos = np.arange(len(ex)) + lat_through[ex_src]
        indices[pos] = self.dst[ex]
        data[pos] = self.weight[ex]
        return csr_matrix((data, indices, indptr), shape=(n, n)), ex, pos

    def step(self, u: int, v: int, lat: np.ndarray, extra: np.ndarray) -> dict[str, float]:
        """The cheapest allowed edge u → v (``lat``, ``extra`` from :meth:`masks`).

        Returns
        -------
        dict
            ``kind``, ``segment`` (−1 if none), ``length`` (m), ``weight``,
            ``heading`` (radians); :class:`InputError` when there is no such edge.
        """
        best: dict[str, float] | None = None
        if u < self.n_lattice and v < self.n_lattice:
            nx = self.lattice.shape[1]
            d = (v % nx - u % nx, v // nx - u // nx)
            hit = np.flatnonzero((self.lattice.directions[:, 0] == d[0]) & (self.lattice.directions[:, 1] == d[1]))
            if len(hit) and lat[u, hit[0]]:
                k = int(hit[0])
                best = {"kind": int(self.lat_kind[u, k]), "segment": -1,
                        "length": float(self.lattice.direction_length[k]),
                        "weight": float(self.lat_weight[u, k]), "heading": float(self.direction_heading[k])}
        lo, hi = np.searchsorted(self.src, [u, u + 1])
        for e in (lo + np.flatnonzero((self.dst[lo:hi] == v) & extra[lo:hi])).tolist():
            if best is None or self.weight[e] < best["weight"]:
                best = {"kind": int(self.kind[e]), "segment": int(self.segment[e]), "length": float(self.length[e]),
                        "weight": float(self.weight[e]), "heading": float(self.heading[e])}
        if best is None:
            raise InputError(f"G′ has no allowed edge from vertex {u} to {v}")
        return best

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

    segments: Segments
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


def street_part(lattice: Lattice, segments: Segments, built: BuiltUpArea | None = None, *,
                costs: EdgeCosts | None = None, options: GraphOptions | None = None) -> StreetPart:
    """The street pieces and shell stitches of G′ (003 Fig. 9), made once a year.

    Parameters
    ----------
    lattice
        Any window of the map's lattice (its rasters check the stitches for water).
    segments, built, costs, options
        As :func:`pathfinding_graph`.

    Returns
    -------
    StreetPart
    """
    costs = costs or EdgeCosts()
    opts = options or GraphOptions()
    blocks = built.blocks if built is not None else None
    extendible = segment_sides(segments, blocks) <= 1
    split_xy, split_parent, pieces = _split_segments(segments, extendible, opts.split_spacing)
    xy = np.concatenate([segments.xy, split_xy])
    n_nodes = len(segments.xy)
    edges = _segment_part(lattice, segments, xy, pieces, extendible, 0, costs)
    ext_pieces = pieces[extendible[pieces[:, 0]]]
    points = _code_vertex(np.unique(ext_pieces[:, 1:].ravel()), 0, n_nodes)
    tree = shapely.STRtree(segments.lines())
    inner = None
    if blocks is not None and not blocks.is_empty:
        inner = shapely.buffer(blocks, -0.5)
        if inner.is_empty:
            inner = None
        else:
            shapely.prepare(inner)
    shell = np.zeros((0, 2), dtype=np.int64)
    if len(points):
        shell = _nearest_pairs(xy[points], xy[points], points, points, opts.max_shell_stitches + 1,
                               opts.shell_stitch_radius)
        shell = np.unique(np.sort(shell[shell[:, 0] != shell[:, 1]], axis=1), axis=0)
        shell = shell[~_duplicates_piece(shell, pieces, 0, n_nodes, len(xy))]
        shell = shell[_stitch_ok(lattice, segments, xy, shell, split_parent, 0, opts, tree, inner)]
    part = StreetPart(segments=segments, blocks=blocks, extendible=extendible, split_xy=split_xy,
                      split_parent=split_parent, pieces=pieces, xy=xy, points=points, edges=edges,
                      shell=(), tree=tree, inner=inner)
    return replace(part, shell=_stitch_edges(lattice, shell, xy))


def _stitch_edges(lattice: Lattice, pairs: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, ...]:
    """Stitch edges (u, v, kind, segment, length, weight) of checked pairs, none steeper than the cutoff."""
    u, v = pairs[:, 0], pairs[:, 1]
    length, weight, slope = _road_weight(lattice, xy, u, v)
    keep = slope <= lattice.slope_cutoff
    n = int(keep.sum())
    return u[keep], v[keep], np.full(n, EdgeKind.STITCH, np.uint8), np.full(n, -1), length[keep], weight[keep]


def _shifted(edges: tuple[np.ndarray, ...], by: int) -> tuple[np.ndarray, ...]:
    u, v, *rest = edges
    return (u + by, v + by, *rest)


def pathfinding_graph(lattice: Lattice, segments: Segments, built: BuiltUpArea | None = None, *,
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
    parts = [bridges, _shifted(streets.edges, n_lat)]
    land_or_bridge = np.zeros(256, dtype=bool)
    land_or_bridge[[EdgeKind.LAND, EdgeKind.BRIDGE]] = True
    targets = np.flatnonzero(land_or_bridge[lat_kind].any(axis=1)
                             & (lattice.vertex_class == VertexClass.LAND))
    points = streets.points
    if stitch_within is not None and len(points):
        px, py = streets.xy[points].T
        points = points[(px >= stitch_within[0]) & (px <= stitch_within[2])
                        & (py >= stitch_within[1]) & (py <= stitch_within[3])]
    pairs = _lattice_stitches(lattice, segments, streets, xy, targets, points, opts, stitch_cache)
    parts.append(_stitch_edges(lattice, pairs, xy))
    parts.append(_shifted(streets.shell, n_lat))
    src, dst, kind, seg, length, weight = (np.concatenate(c) for c in zip(*parts))
    heading = np.arctan2(xy[dst, 1] - xy[src, 1], xy[dst, 0] - xy[src, 0])
    back = np.where(heading > 0, heading - np.pi, heading + np.pi)
    src, dst = np.concatenate([src, dst]), np.concatenate([dst, src])
    kind, seg, length, weight = (np.concatenate([a, a]) for a in (kind, seg, length, weight))
    heading = np.concatenate([heading, back])
    order = np.lexsort((weight, dst, src))
    first = np.ones(len(order), dtype=bool)  # of parallel edges keep the cheapest
    first[1:] = (src[order][1:] != src[order][:-1]) | (dst[order][1:] != dst[order][:-1])
    order = order[first]
    return PathGraph(lattice=lattice, segments=segments, xy=xy, n_lattice=n_lat, split_segment=streets.split_parent,
                     lat_kind=lat_kind, lat_weight=lat_weight, src=src[order], dst=dst[order], kind=kind[order],
                     segment=seg[order], length=length[order], weight=weight[order], heading=heading[order],
                     extendible=streets.extendible)


def _lattice_stitches(lattice: Lattice, segments: Segments, streets: StreetPart, xy: np.ndarray, targets: np.ndarray,
                      points: np.ndarray, opts: GraphOptions, cache: dict | None) -> np.ndarray:
    """Checked stitches ``(G′ street vertex, lattice vertex)`` from street points (street-local ids)
    to their nearest live land vertices; with ``cache``, each point is checked once a year."""
    n_lat = lattice.n_vertices
    if not len(points) or not len(targets):
        return np.zeros((0, 2), dtype=np.int64)

    def checked(chosen: np.ndarray) -> np.ndarray:
        ids = chosen + n_lat
        pairs = _nearest_pairs(xy[ids], xy[targets], ids, targets, opts.max_stitches, opts.stitch_radius,
                               keys=lattice.map_vertex(targets))
        return pairs[_stitch_ok(lattice, segments, xy, pairs, streets.split_parent, n_lat, opts, streets.tree,
                                streets.inner)]

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


def _lattice_part(lattice: Lattice, segments: Segments, costs: EdgeCosts,
                  tree: shapely.STRtree | None = None) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """Directed live lattice tables with C3 (harbour) and C5 (bridge), and the long bridges
    as edges; bridges and harbours that cross a street are left out (a new bridge does
    not pass over a road)."""
    kind, weight = lattice.directed_tables()
    lattice._cache.pop("directed", None)  # the tables become G′'s: edited in place, made again if asked for
    is_special = np.zeros(256, dtype=bool)
    is_special[[EdgeKind.BRIDGE, EdgeKind.HARBOUR]] = True
    special = np.flatnonzero(is_special[kind])
    flat_kind, flat_weight = kind.reshape(-1), weight.reshape(-1)
    flat_weight[special] *= np.where(flat_kind[special] == EdgeKind.BRIDGE, costs.bridge, costs.harbour)
    n_dir = kind.shape[1]
    rows = special // n_dir
    ends = np.stack([rows, rows + lattice.direction_offset[special - rows * n_dir]], axis=1)
    ends = np.concatenate([ends, np.stack([lattice.bridge_src, lattice.bridge_dst], axis=1)])
    crossing = np.zeros(len(ends), dtype=bool)
    if len(ends) and len(segments.uv):
        xy = lattice.vertex_xy(ends.ravel()).reshape(-1, 2, 2)
        tree = tree if tree is not None else shapely.STRtree(segments.lines())
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
    segments: Segments
    streets: StreetPart
    costs: EdgeCosts
    options: GraphOptions
    #: the stitches already checked this year (see :func:`pathfinding_graph`)
    stitches: dict = field(default_factory=dict, repr=False, compare=False)

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
        if not whole:
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
            a, b = sub._local(lat.map_bridges[:, 0]), sub._local(lat.map_bridges[:, 1])
            exits.append(np.where(a >= 0, a, b)[(a >= 0) != (b >= 0)])
        graph = pathfinding_graph(sub, self.segments, costs=self.costs, options=self.options, streets=self.streets,
                                  stitch_within=within, stitch_cache=self.stitches)
        sub._cache.clear()  # the edge tables live on in the graph's; a window is searched once
        return GraphWindow(graph=graph, whole=whole, exits=np.unique(np.concatenate(exits)) if exits
                           else np.zeros(0, dtype=np.int64), n_map_lattice=lat.n_vertices)


def implicit_graph(lattice: Lattice, segments: Segments, built: BuiltUpArea | None = None, *,
                   costs: EdgeCosts | None = None, options: GraphOptions | None = None) -> ImplicitGraph:
    """This year's G′ without its lattice tables: only the street part is made now.

    Parameters
    ----------
    lattice, segments, built, costs, options
        As :func:`pathfinding_graph`.

    Returns
    -------
    ImplicitGraph
    """
    costs = costs or EdgeCosts()
    opts = options or GraphOptions()
    return ImplicitGraph(lattice=lattice, segments=segments,
                         streets=street_part(lattice, segments, built, costs=costs, options=opts),
                         costs=costs, options=opts)


def _split_segments(segments: Segments, split: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interior points along the marked segments of at least 2ℓ (= 2 × spacing / 1.25):
    ⌊length / spacing⌋ equidistant ones, as 003 §3.3 adds temporary nodes.

    Returns the split points, their parent segments, and the pieces as
    ``(segment, from_vertex_code, to_vertex_code)`` rows where a code ≥ 0 is
    a node and ``−1 − p`` is split point ``p``.
    """
    length = segments.lengths()
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


def _code_vertex(code: np.ndarray, n_lat: int, n_nodes: int) -> np.ndarray:
    return np.where(code >= 0, n_lat + code, n_lat + n_nodes + (-1 - code))


def _segment_part(lattice: Lattice, segments: Segments, xy: np.ndarray, pieces: np.ndarray,
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


def _nearest_pairs(from_xy: np.ndarray, to_xy: np.ndarray, from_id: np.ndarray, to_id: np.ndarray, k: int,
                   radius: float, keys: np.ndarray | None = None) -> np.ndarray:
    """Pairs (from, to) of each point and its ``k`` nearest candidates within ``radius``.

    Of equally near candidates the one with the smaller key (``to_id`` by
    default) wins, so the choice never depends on which other candidates
    exist: street points on a grid town are often equally far from several
    lattice vertices, and a window of the lattice must stitch a point to
    the same vertices as the whole map.
    """
    n = len(to_xy)
    k = min(k, n)
    if not k or not len(from_xy):
        return np.zeros((0, 2), dtype=np.int64)
    keys = to_id if keys is None else np.asarray(keys)
    tree = cKDTree(to_xy)
    kk = min(2 * k, n)
    while True:
        dist, hit = tree.query(from_xy, k=kk, distance_upper_bound=radius)
        dist, hit = np.asarray(dist).reshape(len(from_xy), kk), np.asarray(hit).reshape(len(from_xy), kk)
        if kk == n or not (np.isfinite(dist[:, k - 1]) & (dist[:, kk - 1] == dist[:, k - 1])).any():
            break
        kk = min(2 * kk, n)  # a tie at the k-th nearest may go on past the candidates asked for
    found = hit < n
    row = np.broadcast_to(np.arange(len(from_xy))[:, None], hit.shape)[found]
    cand = hit[found]
    order = np.lexsort((keys[cand], dist[found], row))
    row, cand = row[order], cand[order]
    start = np.searchsorted(row, row, side="left")
    first = np.arange(len(row)) - start < k
    return np.stack([from_id[row[first]], to_id[cand[first]]], axis=1)


def _duplicates_piece(pairs: np.ndarray, pieces: np.ndarray, n_lat: int, n_nodes: int, n: int) -> np.ndarray:
    """Sorted pairs that join the two ends of a street piece (a stitch would lie on the street)."""
    ends = np.sort(np.stack([_code_vertex(pieces[:, 1], n_lat, n_nodes),
                             _code_vertex(pieces[:, 2], n_lat, n_nodes)], 1), axis=1)
    return np.isin(pairs[:, 0] * np.int64(n) + pairs[:, 1], ends[:, 0] * np.int64(n) + ends[:, 1])


def _stitch_ok(lattice: Lattice, segments: Segments, xy: np.ndarray, pairs: np.ndarray, split_parent: np.ndarray,
               n_lat: int, opts: GraphOptions, tree: shapely.STRtree | None = None,
               inner: shapely.Geometry | None = None) -> np.ndarray:
    """Stitches that cross no street, keep ``clearance`` from every street away from
    their ends, enter no built-up block (``inner``: the blocks shrunk by 0.5 m) and touch
    no water or forbidden ground (but :attr:`Lattice.stitch_only`)."""
    n_nodes = len(segments.xy)
    a, b = xy[pairs[:, 0]], xy[pairs[:, 1]]
    length = np.hypot(*(b - a).T)
    ok = length > 1e-6
    # water and forbidden ground along the stitch
    n_samples = max(int(np.ceil(opts.shell_stitch_radius / lattice.fine_step)) + 1, 2)
    t = np.linspace(0.0, 1.0, n_samples)
    samples = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
    blocked = lattice.water | lattice.forbidden
    if lattice.stitch_only is not None:
        blocked &= ~lattice.stitch_only
    wet = lattice.fine_lookup(blocked, samples)
    ok &= ~wet.any(axis=1)
    if len(segments.uv):
        # only the stitches still standing are made into lines and checked, each test on
        # fewer of them (most stitches of a window fail one test or another)
        tree = tree if tree is not None else shapely.STRtree(segments.lines())
        # crossing a street not incident to either end
        live = np.flatnonzero(ok)
        stitch, seg = tree.query(shapely.linestrings(np.stack([a[live], b[live]], axis=1)), predicate="intersects")
        incident = _incident(pairs[live[stitch]], seg, segments, split_parent, n_lat, n_nodes)
        ok[live[stitch[~incident]]] = False
        # grazing any street away from the ends
        live = np.flatnonzero(ok)
        a, b, length = a[live], b[live], length[live]
        trim = np.minimum(0.25 * length, 3.0 * opts.clearance) / np.maximum(length, 1e-9)
        core = shapely.linestrings(np.stack([a + trim[:, None] * (b - a), b - trim[:, None] * (b - a)], axis=1))
        stitch, _ = tree.query(core, predicate="dwithin", distance=opts.clearance)
        ok[live[stitch]] = False
        if inner is not None:
            rest = np.flatnonzero(ok[live])
            ok[live[rest]] = ~shapely.intersects(inner, core[rest])
    return ok


def _incident(pairs: np.ndarray, seg: np.ndarray, segments: Segments, split_parent: np.ndarray,
              n_lat: int, n_nodes: int) -> np.ndarray:
    """Whether segment ``seg`` touches a street end of the stitch ``pairs`` (node or split point)."""
    out = np.zeros(len(seg), dtype=bool)
    for end in (0, 1):
        node = pairs[:, end] - n_lat
        is_node = (node >= 0) & (node < n_nodes)
        out |= is_node & ((segments.uv[seg, 0] == node) | (segments.uv[seg, 1] == node))
        split = node - n_nodes
        is_split = split >= 0
        if is_split.any():
            out |= is_split & (split_parent[np.where(is_split, split, 0)] == seg)
    return out
