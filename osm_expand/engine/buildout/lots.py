"""Lots: blocks split recursively into street-facing parcels (002 §5.1 with 004 §4.3.3).

A block arrives as a polygon bounded by street centre lines, with its
*frontage*: the streets along its boundary (and, optionally, the streets
that run into it), each with the street's id and width
(:func:`block_frontage` finds them). Subdivision then runs in three steps:

1. **Shrink** (004 §6.1). The block loses every point closer than half a
   street's width to that street's centre line: the block minus the round
   buffers of its frontage pieces. This is the per-edge offset 004 wished
   for (a straight-skeleton shrink, not a shrink about the centre, so
   concave blocks stay inside themselves), and it keeps every lot, and so
   every building, off the streets. Holes (a separate piece of network
   inside a block) are then cut open by a line across each hole.
2. **Label.** Each edge of the shrunk ring that runs at half a width from a
   frontage piece faces that street; the other edges (water, map edge,
   cuts) face none. Labels travel with the edges through every split, so a
   lot always knows which streets it fronts.
3. **Split** (002 §5.1, steps 1–5). While a polygon is larger than the land
   use's ``max_area``: (1) consecutive edges on the same street within
   ``side_angle`` of the side's first edge form one *side* (collinear edges
   merged); (2) street sides are tried first, longest first — 004's
   preference for "one of the three longest edges with street access"
   picks the same side whenever such an edge exists; (3) a split line
   starts at a random point of the side's middle region
   (``offset_spread``; narrower when the polygon is under twice
   ``max_area``, so both halves fit), approximately perpendicular to it
   (``angle_spread``), and runs into the polygon to the *first* edge it
   meets, so a concave polygon is cut at the nearest intersected edge
   (004 figure 8); (4) the split is taken when both parts are at least
   ``min_area``, keep a width/length ratio of at least ``min_ratio`` (or,
   for a polygon narrower than that already, at least its own) and both
   front a street; (5) after ``tries`` candidates on a side, the next street
   side and then the sides not on a street are tried (002's fallback);
   sides that cannot keep the ratio are skipped. A split that leaves one
   part without access is taken only when no candidate gives both parts
   access. Without any acceptable split the polygon stays one lot, larger
   than ``max_area`` (rare: odd wedges).

Parts without street access are discarded (004 §4.3.3; this wins over 002's
fallback, whose back parts are dropped rather than kept), as are lots
smaller than ``min_area`` or whose longest street side is shorter than
``min_frontage``. A cut from a street side always leaves both parts on that
street, so land is lost only behind deep lots and in the middle of blocks
too deep for lots from every side (about a quarter of a 150 m square block,
most of a field between villages).

002's table of ``maxarea``/``minratio`` per land use is missing from the
text; the defaults in :data:`DEFAULT_LOT_OPTIONS` are plausible European
figures (see each field) and are meant to be calibrated from the town's own
buildings (:func:`osm_expand.engine.buildout.footprint_sizes.calibrated_lot_options`).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from types import MappingProxyType

import numpy as np
import shapely
import shapely.errors
import shapely.ops

from osm_expand.errors import InputError
from osm_expand.model.city import Lot  # the one lot type, re-exported for the build-out's modules
from osm_expand.model.enums import parse_enum
from osm_expand.model.geometry import ring_area, ring_edge_lengths

__all__ = [
    "DEFAULT_LOT_OPTIONS", "NO_STREET", "Frontage", "LandUse", "Lot", "LotOptions", "Side", "lot_sides",
    "block_frontage", "land_use", "shrink_block", "subdivide", "subdivide_blocks",
]

#: Edge label of an edge that faces no street.
NO_STREET = -1
#: Edges shorter than this (m) are dropped when rings are cleaned.
_MIN_EDGE = 1e-6
#: Points per quarter circle of the round street buffers in the shrink.
_QUAD_SEGS = 8
#: The buffers' radius over the half width: their chords then never come
#: closer than the half width to the street (circumscribed, not inscribed).
_CHORD = 1.0 / math.cos(math.pi / (4 * _QUAD_SEGS))


class LandUse(StrEnum):
    """Land-use types with their own lot and building rules (002 §4, table 5)."""

    RESIDENTIAL_LOW = "residential_low"
    RESIDENTIAL_HIGH = "residential_high"
    COMMERCIAL = "commercial"
    INDUSTRIAL = "industrial"
    PARK = "park"


def land_use(value: str) -> LandUse:
    """The :class:`LandUse` named ``value``; :class:`InputError` listing the valid ones otherwise."""
    return parse_enum(LandUse, value, "land use")


@dataclass(frozen=True)
class LotOptions:
    """Subdivision rules of one land-use type (002 §5.1 ``maxarea_t``, ``minratio_t``)."""

    #: m²: polygons larger than this are split (002 §5.1 maxarea_t).
    max_area: float = 900.0
    #: Width/length of each part of a split, at least (002 §5.1 minratio_t).
    min_ratio: float = 0.3
    #: m²: no split may make a smaller part, and smaller lots are discarded:
    #: too small for a building with its setbacks.
    min_area: float = 150.0
    #: m: a lot whose longest street side is shorter has no usable access.
    min_frontage: float = 8.0
    #: The split point lies within this fraction of the side's length either
    #: side of its middle (002 §5.1 step 3, "the middle region").
    offset_spread: float = 0.15
    #: Degrees: the split line deviates from the side's normal by up to this
    #: (002 §5.1 step 3, "approximately perpendicular"); small, as lot lines
    #: in the towns we start from are nearly orthogonal to the street.
    angle_spread: float = 3.0
    #: Random candidates per side before the next side is tried (002 §5.1
    #: step 5, "several iterations").
    tries: int = 4
    #: Sides tried per polygon (street sides first, then the others); sides
    #: shorter than ``min_frontage`` are not tried.
    max_sides: int = 6
    #: Degrees: consecutive edges on the same street turning less than this
    #: from the side's first edge form one side (002 §5.1 step 1).
    side_angle: float = 10.0

    def __post_init__(self) -> None:
        checks = {
            "max_area": self.max_area > 0, "min_ratio": 0 <= self.min_ratio <= 1,
            "min_area": 0 <= self.min_area < self.max_area, "min_frontage": self.min_frontage >= 0,
            "offset_spread": 0 <= self.offset_spread < 0.5, "angle_spread": 0 <= self.angle_spread < 60,
            "tries": self.tries >= 1, "max_sides": self.max_sides >= 1,
            "side_angle": 0 <= self.side_angle < 90,
        }
        for key, ok in checks.items():
            if not ok:
                raise InputError(f"lot option {key}={getattr(self, key)!r} is out of range")


#: Defaults per land use. 002's table is missing; the figures are typical
#: for Central European towns: detached-house plots of 400–900 m², urban
#: residential and mixed plots of 600–1,500 m², commercial plots up to
#: 2,500 m², industrial plots of one to a few hectares (002 figure 10: "much
#: larger lots" in industrial zones). Parks keep big lots and get no building.
DEFAULT_LOT_OPTIONS: Mapping[LandUse, LotOptions] = MappingProxyType({
    LandUse.RESIDENTIAL_LOW: LotOptions(max_area=900.0, min_ratio=0.3, min_area=150.0, min_frontage=8.0),
    LandUse.RESIDENTIAL_HIGH: LotOptions(max_area=1500.0, min_ratio=0.25, min_area=200.0, min_frontage=10.0),
    LandUse.COMMERCIAL: LotOptions(max_area=2500.0, min_ratio=0.25, min_area=300.0, min_frontage=12.0),
    LandUse.INDUSTRIAL: LotOptions(max_area=8000.0, min_ratio=0.2, min_area=800.0, min_frontage=20.0),
    LandUse.PARK: LotOptions(max_area=20000.0, min_ratio=0.1, min_area=400.0, min_frontage=5.0),
})


@dataclass(frozen=True, eq=False)
class Frontage:
    """A street along a block's boundary (or running into the block).

    ``line`` is the street's centre line along the block, ``(M, 2)`` metres
    (M ≥ 2); ``street`` the street's id (≥ 0); ``width`` its full width (m).
    """

    line: np.ndarray
    street: int
    width: float

    def __post_init__(self) -> None:
        if self.street < 0:
            raise InputError(f"frontage street id {self.street} is negative (ids must be >= 0)")
        if not (self.width >= 0 and math.isfinite(self.width)):
            raise InputError(f"frontage width {self.width!r} of street {self.street} is not a width")
        if len(self.line) < 2:
            raise InputError(f"frontage line of street {self.street} has fewer than two points")


@dataclass(frozen=True)
class Side:
    """A run of edges of a lot ring on one street (or none), nearly collinear.

    ``start``/``end`` are the chord's end points (2,); ``first``/``count``
    index the ring's edges (edge k runs ``ring[k] → ring[k+1]``, cyclic).
    """

    start: np.ndarray
    end: np.ndarray
    street: int
    length: float
    first: int
    count: int


def lot_sides(lot: Lot, side_angle: float = 10.0) -> list[Side]:
    """The lot ring's edges grouped into sides (002 §5.1 step 1), see :func:`_sides`."""
    return _sides(lot.ring, lot.edge_street, side_angle)


# ----------------------------------------------------------------------------- frontage


def block_frontage(blocks: Sequence[shapely.Polygon], street_lines: Sequence[shapely.LineString],
                   street_ids: Sequence[int] | np.ndarray, widths: Sequence[float] | np.ndarray, *,
                   tolerance: float = 0.5, inside: bool = True) -> list[list[Frontage]]:
    """Frontage of every block from the streets whose centre lines bound it or run into it.

    Blocks that are faces of the street graph (:func:`osm_expand.blocks.blocks`)
    have every boundary edge on some street; each edge is given to the street
    nearest its midpoint within ``tolerance``, and consecutive edges of the
    same street become one :class:`Frontage`. Edges with no street that near
    (water, the map edge) get no frontage. With ``inside``, the parts of
    streets that run inside a block (dead ends and loops that
    simplification removed, the town's streets as mapped) are frontage too:
    the shrink carves them out and lots along them get access.

    Parameters
    ----------
    blocks : block polygons, metres (holes allowed).
    street_lines : the streets' centre lines, metres.
    street_ids : (S,) int, the id of each street (≥ 0).
    widths : (S,) float, each street's full width (m).
    tolerance : m, how far an edge's midpoint may be from its street; inside
        pieces are taken from the block shrunk by this much.
    inside : also take the streets inside blocks.

    Returns
    -------
    Per block, its frontage pieces: the boundary's in boundary order, then
    the inside ones by street.
    """
    ids = np.asarray(street_ids, dtype=np.int64)
    width = np.asarray(widths, dtype=float)
    if len(ids) != len(street_lines) or len(width) != len(street_lines):
        raise InputError("street_lines, street_ids and widths must have the same length")
    rings, owner = [], []
    for block, poly in enumerate(blocks):
        for ring in [poly.exterior, *poly.interiors]:
            rings.append(np.asarray(ring.coords))
            owner.append(block)
    out: list[list[Frontage]] = [[] for _ in blocks]
    if not rings or not len(street_lines):
        return out
    starts = np.vstack([r[:-1] for r in rings])
    ends = np.vstack([r[1:] for r in rings])
    nearest = _edge_streets(starts, ends, street_lines, tolerance)
    offsets = np.concatenate([[0], np.cumsum([len(r) - 1 for r in rings])])
    for k in range(len(rings)):
        lab = nearest[offsets[k]:offsets[k + 1]]
        a, b = starts[offsets[k]:offsets[k + 1]], ends[offsets[k]:offsets[k + 1]]
        for first, count in _runs(lab):
            s = int(lab[first])
            if s < 0:
                continue
            idx = (first + np.arange(count)) % len(lab)
            line = np.vstack([a[idx], b[idx[-1:]]])
            out[owner[k]].append(Frontage(line=line, street=int(ids[s]), width=float(width[s])))
    if inside:
        _add_inside(out, blocks, street_lines, ids, width, tolerance)
    return out


def _edge_streets(starts: np.ndarray, ends: np.ndarray, street_lines: Sequence[shapely.LineString],
                  tolerance: float) -> np.ndarray:
    """Index of the street each edge (E, 2)→(E, 2) lies on, or -1.

    An edge lies on the street whose line is nearest to both its ends and its
    midpoint (the largest of the three distances, at most ``tolerance``), so a
    street merely touching an edge's midpoint (a dead end leaving it) does not take it.
    """
    lines = np.array(list(street_lines), dtype=object)
    mids = shapely.points(0.5 * (starts + ends))
    edge, cand = shapely.STRtree(lines).query(mids, predicate="dwithin", distance=tolerance)
    worst = np.maximum.reduce([shapely.distance(shapely.points(starts[edge]), lines[cand]),
                               shapely.distance(mids[edge], lines[cand]),
                               shapely.distance(shapely.points(ends[edge]), lines[cand])])
    order = np.lexsort((cand, worst, edge))  # per edge, the best candidate first
    edge, cand, worst = edge[order], cand[order], worst[order]
    first = np.ones(len(edge), dtype=bool)
    first[1:] = edge[1:] != edge[:-1]
    nearest = np.full(len(starts), -1, dtype=np.int64)
    ok = first & (worst <= tolerance)
    nearest[edge[ok]] = cand[ok]
    return nearest


def _add_inside(out: list[list[Frontage]], blocks: Sequence[shapely.Polygon],
                street_lines: Sequence[shapely.LineString], ids: np.ndarray, width: np.ndarray,
                tolerance: float) -> None:
    """Append the pieces of streets running inside each block (longer than twice the tolerance)."""
    cores = shapely.buffer(np.array(list(blocks), dtype=object), -tolerance)
    lines = np.array(list(street_lines), dtype=object)
    b, s = shapely.STRtree(lines).query(cores, predicate="intersects")
    order = np.lexsort((s, b))
    b, s = b[order], s[order]
    for block, street, geom in zip(b.tolist(), s.tolist(), _intersections(lines[s], cores[b])):
        for piece in shapely.get_parts(shapely.line_merge(geom) if geom.geom_type == "MultiLineString" else geom):
            if piece.geom_type == "LineString" and piece.length > 2 * tolerance:
                out[block].append(Frontage(line=np.asarray(piece.coords), street=int(ids[street]),
                                           width=float(width[street])))


def _intersections(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``shapely.intersection(a, b)`` pairwise; a pair GEOS cannot intersect ("found non-noded
    intersection", "side location conflict": Krems seed 1 in its second year) is tried again by
    :func:`_intersection`."""
    try:
        return shapely.intersection(a, b)
    except shapely.errors.GEOSException:
        out = []
        for x, y in zip(a.tolist(), b.tolist()):
            out.append(_intersection(x, y))
        return np.array(out, dtype=object)


def _intersection(x: shapely.Geometry, y: shapely.Geometry) -> shapely.Geometry:
    """One pair: as it is, then made valid (a block face that touches itself), then on a 1 mm grid;
    empty when GEOS can do none (the street then has no frontage inside that block)."""
    for attempt in (lambda: shapely.intersection(x, y),
                    lambda: shapely.intersection(shapely.make_valid(x), shapely.make_valid(y)),
                    lambda: shapely.intersection(shapely.make_valid(x), shapely.make_valid(y), grid_size=1e-3)):
        try:
            return attempt()
        except shapely.errors.GEOSException:
            continue
    return shapely.GeometryCollection()


def _runs(labels: np.ndarray) -> list[tuple[int, int]]:
    """Maximal cyclic runs of equal labels as (first index, length)."""
    n = len(labels)
    change = np.flatnonzero(labels != np.roll(labels, 1))
    if len(change) == 0:
        return [(0, n)]
    bounds = np.append(change, change[0] + n)
    return [(int(bounds[i]), int(bounds[i + 1] - bounds[i])) for i in range(len(change))]


# ----------------------------------------------------------------------------- shrink and label


def shrink_block(block: shapely.Polygon, frontage: Sequence[Frontage]) -> shapely.Geometry:
    """The block minus every point closer than half a width to a frontage street (004 §6.1).

    Round buffers of the frontage lines (``_QUAD_SEGS`` points per quarter
    circle, drawn around the circle so that no point closer than the half
    width survives; on straight streets they reach 0.5 % further) are
    subtracted: the per-edge offset, concave corners included. Returns a
    Polygon, MultiPolygon or an empty geometry.
    """
    if not frontage:
        return block
    lines = _lines(frontage)
    half = np.array([0.5 * f.width for f in frontage])
    streets = shapely.buffer(lines, _CHORD * half, quad_segs=_QUAD_SEGS)
    return shapely.difference(block, shapely.union_all(streets))


def _lines(frontage: Sequence[Frontage]) -> np.ndarray:
    """The frontage centre lines as a shapely array, (F,)."""
    coords = np.vstack([f.line for f in frontage])
    index = np.repeat(np.arange(len(frontage)), [len(f.line) for f in frontage])
    return shapely.linestrings(coords, indices=index)


def _hole_free(geom: shapely.Geometry) -> list[shapely.Polygon]:
    """Polygon parts of ``geom``, each hole cut open by a line across it."""
    todo = [g for g in shapely.get_parts(geom) if isinstance(g, shapely.Polygon) and not g.is_empty]
    done = []
    while todo:
        poly = todo.pop()
        if not poly.interiors:
            done.append(poly)
            continue
        hole = shapely.Polygon(poly.interiors[0])
        centre = np.asarray(hole.point_on_surface().coords[0])
        env = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)
        s1, s2 = env[1] - env[0], env[2] - env[1]
        across = s1 if np.hypot(*s1) < np.hypot(*s2) else s2  # cut across the narrow way
        across = across / max(np.hypot(*across), 1e-12)
        reach = 2.0 * math.hypot(*(np.subtract(poly.bounds[2:], poly.bounds[:2]))) + 1.0
        cut = shapely.LineString([centre - reach * across, centre + reach * across])
        pieces = shapely.ops.split(poly, cut)
        todo.extend(g for g in pieces.geoms if isinstance(g, shapely.Polygon) and g.area > 0)
    return done


def _label(ring: np.ndarray, frontage: Sequence[Frontage]) -> np.ndarray:
    """Street id faced by each edge of a shrunk ring, or NO_STREET.

    An edge faces the frontage piece whose centre line is half its width
    from the edge's midpoint, within 0.25 m + 5 % of that half width (the
    shrink's round buffers are polygons a little outside their circles).
    """
    labels = np.full(len(ring), NO_STREET, dtype=np.int64)
    if not frontage:
        return labels
    mids = shapely.points(0.5 * (ring + np.roll(ring, -1, axis=0)))
    lines = _lines(frontage)
    half = np.array([0.5 * f.width for f in frontage])
    off = np.abs(shapely.distance(mids[:, None], lines[None, :]) - half[None, :])
    best = np.argmin(off, axis=1)
    ok = off[np.arange(len(ring)), best] <= 0.25 + 0.05 * half[best]
    ids = np.array([f.street for f in frontage], dtype=np.int64)
    labels[ok] = ids[best[ok]]
    return labels


# ----------------------------------------------------------------------------- ring geometry


def _next(ring: np.ndarray) -> np.ndarray:
    """Each vertex's successor around the ring, (N, 2)."""
    return np.concatenate((ring[1:], ring[:1]))


def _ccw(poly: shapely.Polygon) -> np.ndarray:
    ring = np.asarray(poly.exterior.coords)[:-1]
    return ring if ring_area(ring) > 0 else ring[::-1].copy()


def _clean(ring: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop zero-length edges: for a null edge k, vertex k and label k go.

    Edge k−1 then runs to vertex k+1, where vertex k stood within ``_MIN_EDGE``,
    and keeps its label. (Dropping vertex k+1 instead shifts every label by one
    when the closing edge n−1 is the null one: vertex 0 would go, label n−1.)
    """
    for _ in range(3):
        null = ring_edge_lengths(ring) < _MIN_EDGE
        if not null.any() or len(ring) <= 3:
            break
        ring, labels = ring[~null], labels[~null]
    return ring, labels


def _sides(ring: np.ndarray, labels: np.ndarray, side_angle: float) -> list[Side]:
    """Group consecutive edges into sides: same label, direction within ``side_angle`` of the side's first edge.

    A sequential scan (a side's direction is its first edge's), in plain
    Python over lists: rings are short and numpy scalars are slow.
    """
    n = len(ring)
    vec = _next(ring) - ring
    length = np.hypot(vec[:, 0], vec[:, 1])
    unit = vec / np.maximum(length, 1e-12)[:, None]
    cos_tol = math.cos(math.radians(side_angle))
    ux, uy, lab = unit[:, 0].tolist(), unit[:, 1].tolist(), labels.tolist()
    first = 0
    for k in range(n):  # start at a break, so no side wraps past the start
        if lab[k] != lab[k - 1] or ux[k] * ux[k - 1] + uy[k] * uy[k - 1] < cos_tol:
            first = k
            break
    sides, k = [], first
    while k < first + n:
        i = k % n
        cx, cy, j = ux[i], uy[i], k + 1
        while j < first + n and lab[j % n] == lab[i] and ux[j % n] * cx + uy[j % n] * cy >= cos_tol:
            j += 1
        start, end = ring[i], ring[j % n]
        sides.append(Side(start=start, end=end, street=lab[i], length=math.hypot(*(end - start).tolist()),
                          first=i, count=j - k))
        k = j
    return sides


def _cast(ring: np.ndarray, edge: int, point: np.ndarray, direction: np.ndarray) -> tuple[int, np.ndarray] | None:
    """First edge (≠ ``edge``) hit by the ray point + s·direction, s > 0, and the hit point."""
    d = _next(ring) - ring
    ap = ring - point
    denom = direction[0] * d[:, 1] - direction[1] * d[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (ap[:, 0] * d[:, 1] - ap[:, 1] * d[:, 0]) / denom
        u = (ap[:, 0] * direction[1] - ap[:, 1] * direction[0]) / denom
    ok = (np.abs(denom) > 1e-12) & (s > 1e-7) & (u >= -1e-12) & (u <= 1 + 1e-12)
    ok[edge] = False
    if not ok.any():
        return None
    s = np.where(ok, s, np.inf)
    j = int(np.argmin(s))
    return j, point + s[j] * direction


def _split_ring(ring: np.ndarray, labels: np.ndarray, i: int, p: np.ndarray, j: int, q: np.ndarray):
    """Cut a CCW ring along the chord P (on edge i) → Q (on edge j) into two CCW rings with labels.

    Ring A: P, V[i+1..j], Q (edges: lab[i], …, lab[j], cut); ring B: Q,
    V[j+1..i], P (edges: lab[j], …, lab[i], cut). Indices are cyclic.
    """
    n = len(ring)
    ia = np.arange(i + 1, i + 1 + (j - i) % n) % n  # V[i+1..j]
    ib = np.arange(j + 1, j + 1 + (i - j) % n) % n  # V[j+1..i]
    ring_a = np.concatenate([p[None], ring[ia], q[None]])
    lab_a = np.concatenate([labels[i:i + 1], labels[ia[:-1]], [labels[j], NO_STREET]])
    ring_b = np.concatenate([q[None], ring[ib], p[None]])
    lab_b = np.concatenate([labels[j:j + 1], labels[ib[:-1]], [labels[i], NO_STREET]])
    return _clean(ring_a, lab_a), _clean(ring_b, lab_b)


def _extents(ring: np.ndarray, axis: np.ndarray) -> tuple[float, float]:
    """Extent (m) of a ring along the unit vector ``axis`` (2,) and across it."""
    along = ring @ axis
    across = ring @ np.array([-axis[1], axis[0]])
    return float(along.max() - along.min()), float(across.max() - across.min())


def _ratio(ring: np.ndarray, axis: np.ndarray) -> float:
    """Width/length of a ring's extent in the frame of ``axis`` (unit (2,)), ≤ 1."""
    w, d = _extents(ring, axis)
    return min(w, d) / max(w, d, 1e-12)


# ----------------------------------------------------------------------------- recursive split


def _point_on_side(ring: np.ndarray, side: Side, t: float) -> tuple[int, np.ndarray]:
    """The edge index and point at fraction ``t`` of the side's polyline length."""
    n = len(ring)
    idx = (side.first + np.arange(side.count)) % n
    seg = ring[(idx + 1) % n] - ring[idx]
    lens = np.hypot(seg[:, 0], seg[:, 1])
    target = t * lens.sum()
    cum = np.cumsum(lens)
    k = int(min(np.searchsorted(cum, target), len(idx) - 1))
    before = cum[k] - lens[k]
    f = (target - before) / max(lens[k], 1e-12)
    return int(idx[k]), ring[idx[k]] + min(max(f, 0.0), 1.0) * seg[k]


def _candidate_sides(ring: np.ndarray, sides: list[Side], opts: LotOptions) -> list[tuple[Side, float]]:
    """Sides worth a split, with the ratio a split must keep (002 §5.1 steps 2, 4 and 5).

    Street sides come first, longest first, then the sides not on a street.
    A split may not leave a part narrower than ``min_ratio`` — or than the
    polygon itself, for polygons (long strips) that are narrower already.
    A side is skipped when halving the polygon across it clearly cannot keep
    that ratio (estimated from the polygon's extents in the side's frame),
    which spares the random tries of step 3 on hopeless sides. Sides shorter
    than ``min_frontage`` (pieces of round corners) are not cut from.
    """
    sides = [side for side in sides if side.length >= max(opts.min_frontage, 1e-6)]
    if not sides:
        return []
    axis = np.array([(side.end - side.start) / side.length for side in sides])  # (S, 2)
    along = ring @ axis.T  # (N, S)
    across = ring @ np.column_stack([-axis[:, 1], axis[:, 0]]).T
    w = along.max(axis=0) - along.min(axis=0)
    d = across.max(axis=0) - across.min(axis=0)
    need = np.minimum(opts.min_ratio, np.minimum(w, d) / np.maximum(np.maximum(w, d), 1e-12))
    half = np.minimum(0.5 * w, d) / np.maximum(np.maximum(0.5 * w, d), 1e-12)
    keep = np.flatnonzero(half >= 0.8 * need)
    order = sorted(keep.tolist(), key=lambda k: (sides[k].street < 0, -sides[k].length, k))
    return [(sides[k], float(need[k])) for k in order[:opts.max_sides]]


def _split_once(ring: np.ndarray, labels: np.ndarray, opts: LotOptions, rng: np.random.Generator):
    """One split of 002 §5.1 steps 1–5; None when no acceptable split exists.

    The first candidate whose parts are both at least ``min_area``, keep the
    ratio and both front a street is taken; failing that, the first that
    leaves one part without access (that part is then discarded).
    """
    fallback = None
    # below twice max_area, keep the split near enough the middle that both parts fit (no extra split)
    spread = min(opts.offset_spread, max(0.9 * (opts.max_area / ring_area(ring) - 0.5), 0.0))
    for side, need in _candidate_sides(ring, _sides(ring, labels, opts.side_angle), opts):
        chord = (side.end - side.start) / side.length
        normal = np.array([-chord[1], chord[0]])  # inward for a counter-clockwise ring
        for t_draw, a_draw in rng.random((opts.tries, 2)).tolist():
            t = 0.5 + spread * (2.0 * t_draw - 1.0)
            angle = math.radians(opts.angle_spread * (2.0 * a_draw - 1.0))
            c, s = math.cos(angle), math.sin(angle)
            direction = np.array([c * normal[0] - s * normal[1], s * normal[0] + c * normal[1]])
            edge, point = _point_on_side(ring, side, t)
            hit = _cast(ring, edge, point, direction)
            if hit is None:
                continue
            (ra, la), (rb, lb) = _split_ring(ring, labels, edge, point, hit[0], hit[1])
            if len(ra) < 3 or len(rb) < 3 or min(ring_area(ra), ring_area(rb)) < max(opts.min_area, 1e-9):
                continue
            ratio = min(_ratio(ra, chord), _ratio(rb, chord))
            if ratio < 0.8 * need:
                break  # far off: other offsets on this side will not do
            if ratio < need:
                continue
            if (la >= 0).any() and (lb >= 0).any():
                return (ra, la), (rb, lb)
            if fallback is None:
                fallback = (ra, la), (rb, lb)  # one part has no access and will be discarded
            break  # this side cuts off land without access; try the next side
    return fallback


def _has_access(ring: np.ndarray, labels: np.ndarray, opts: LotOptions) -> bool:
    if not (labels >= 0).any():
        return False
    return max(s.length for s in _sides(ring, labels, opts.side_angle) if s.street >= 0) >= opts.min_frontage


def _subdivide_ring(ring: np.ndarray, labels: np.ndarray, opts: LotOptions,
                    rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """Recursive split (depth first, first part first) of one hole-free CCW ring."""
    lots, stack = [], [(ring, labels)]
    while stack:
        r, lab = stack.pop()
        if not (lab >= 0).any():
            continue  # no street access: discarded (004 §4.3.3)
        area = ring_area(r)
        if area > opts.max_area:
            parts = _split_once(r, lab, opts, rng)
            if parts is not None:
                stack.extend(reversed(parts))
                continue
        if area >= opts.min_area and _has_access(r, lab, opts):
            lots.append((r, lab))
    return lots


def subdivide(block: shapely.Polygon, frontage: Sequence[Frontage], *, options: LotOptions | None = None,
              rng: np.random.Generator, block_index: int = 0,
              land_use: str = LandUse.RESIDENTIAL_LOW.value) -> list[Lot]:
    """Split one block into lots with street access (002 §5.1 with 004 §4.3.3).

    Parameters
    ----------
    block : the block polygon bounded by street centre lines, metres.
    frontage : the parts of its boundary that are streets (see
        :class:`Frontage`, :func:`block_frontage`); parts not listed face no
        street (water, map edge) and are not shrunk.
    options : the land use's :class:`LotOptions` (default: low-density residential).
    rng : the run's random generator (split offsets and angles).
    block_index, land_use : stored in each :class:`Lot`.

    Returns
    -------
    The lots, each under ``options.max_area`` unless no split was possible,
    each with at least ``options.min_frontage`` metres on a street, in a
    deterministic order for a given generator state.
    """
    opts = options or DEFAULT_LOT_OPTIONS[LandUse.RESIDENTIAL_LOW]
    return _lots_of(shrink_block(block, frontage), frontage, opts, rng, block_index, land_use)


def _lots_of(shrunk: shapely.Geometry, frontage: Sequence[Frontage], opts: LotOptions,
             rng: np.random.Generator, block_index: int, land_use: str) -> list[Lot]:
    out = []
    for part in _hole_free(shrunk):
        ring = _ccw(part)
        if len(ring) < 3:
            continue
        ring, labels = _clean(ring, _label(ring, frontage))
        for r, lab in _subdivide_ring(ring, labels, opts, rng):
            out.append(Lot(ring=r, edge_street=lab, block=block_index, land_use=str(land_use)))
    return out


def subdivide_blocks(blocks: Sequence[shapely.Polygon], frontages: Sequence[Sequence[Frontage]],
                     land_uses: Sequence[str], *,
                     options: Mapping[LandUse, LotOptions] = DEFAULT_LOT_OPTIONS,
                     rng: np.random.Generator) -> list[Lot]:
    """Lots of many blocks: :func:`subdivide` per block, with the shrink done in one batch.

    Parameters
    ----------
    blocks : B block polygons, metres.
    frontages : per block, its :class:`Frontage` pieces.
    land_uses : per block, its land use (a :class:`LandUse` value).
    options : :class:`LotOptions` per land use.
    rng : the run's random generator, consumed block by block in order.

    Returns
    -------
    All lots, block by block; ``Lot.block`` is the block's index.
    """
    if not (len(blocks) == len(frontages) == len(land_uses)):
        raise InputError("blocks, frontages and land_uses must have the same length")
    uses = [land_use(u) for u in land_uses]
    for u in set(uses):
        if u not in options:
            raise InputError(f"no lot options for land use {u.value!r}")
    pieces = [f for fr in frontages for f in fr]
    shrunk = list(blocks)
    if pieces:
        lines = _lines(pieces)
        buffers = shapely.buffer(lines, _CHORD * np.array([0.5 * f.width for f in pieces]), quad_segs=_QUAD_SEGS)
        offsets = np.concatenate([[0], np.cumsum([len(fr) for fr in frontages])])
        for b in range(len(blocks)):
            if offsets[b + 1] > offsets[b]:
                shrunk[b] = shapely.difference(blocks[b], shapely.union_all(buffers[offsets[b]:offsets[b + 1]]))
    lots: list[Lot] = []
    for b, geom in enumerate(shrunk):
        lots.extend(_lots_of(geom, frontages[b], options[uses[b]], rng, b, uses[b].value))
    return lots
