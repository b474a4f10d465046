"""Building footprints: the largest rectangle facing the street in each lot (004 §4.3.4, 002 §5.3).

**The rectangle** (004 §4.3.4). One side of the building lies on the lot's
street edge, moved back by the front setback; the building is as large as
fits the lot with side and back setbacks, and no longer than twice its width
either way (004's 1:2 cut, figure 10). 004 finds it with a two-point sweep:
two points start at the ends of the street edge, a perpendicular from each
runs to the lot boundary, the shorter one bounds the rectangle, and that
point moves toward the middle. That greedy sweep misses the best rectangle
when a notch sits between the two points, so here both points sweep every
pair of positions: in the street edge's frame (u along the edge, v into
the lot) the free depth ``h(u)`` of the lot above the front setback line is
sampled at a grid of ``resolution`` metres plus just either side of every
vertex and every crossing of the setback line (``h`` is linear between
those, so the minimum of ``h`` over a pair's span is exact at the samples);
``min h`` over all pairs comes from one running minimum, and the pair with
the largest building after setbacks, the ratio cut and the size target wins.
The rectangle is computed in the frame and rotated back, so it is exactly
rectangular.

**Placement** (002 §2.2, §5.3). A lot gets a building only when one of its
streets is *built*; the building faces the built street with the most
traffic (002 §5.3 "the street with the highest traffic value"), on its
longest side along that street; where no building fits there, the next
side, the chord of a curved run of sides, then the next built street by
traffic, and last all of these again at the least setbacks of the ranges
(a shallow lot builds at the minimum its zoning allows). Front, side
and back setbacks are drawn per block from the land use's ranges (002 §5.3
"determined stochastically for each block"); each lot adds a random extra
front setback ("how far a building can move back from the front setback").

**Sizes from the town** (issue: "size distributions start from the town's
own buildings").
:func:`~osm_expand.engine.buildout.footprint_sizes.calibrate_sizes` measures
the town's footprints — area, and frontage and depth from each footprint's minimum rotated
rectangle, frontage being the side more parallel to the nearest street.
Each lot first gets its largest rectangle (its *room*); then, per land use,
lots ranked by room take the town's footprints ranked by area within the
land use's quantile band (``size_band``), each rank moved by a little noise
(``size_noise``): big lots get big buildings, and the building is the
largest rectangle in the room no larger than its target, shaped like it.
So the generated footprint-area distribution follows the town's as long as
the lots have the room;
:func:`~osm_expand.engine.buildout.footprint_sizes.calibrated_lot_options`
sizes the lots for that (see there for the footprint → lot mapping). A random pairing of lots
and targets instead left the median 17–26 % short on Krems and Andorra,
because big targets fell on small lots.
"""
from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from types import MappingProxyType
from typing import cast

import numpy as np
import shapely

from osm_expand.engine.buildout.lots import LandUse, Lot, land_use, lot_sides
from osm_expand.errors import InputError

__all__ = [
    "DEFAULT_FOOTPRINT_OPTIONS", "Footprint", "FootprintOptions", "Rectangle", "SizeTargets",
    "largest_street_rectangle", "place_buildings",
]

#: Samples of the depth profile per street edge, at most (speed bound for long edges).
_MAX_GRID = 160
#: m: a footprint keeps at least this much from every side of its lot, even at a zero setback
#: (a shop built to the street line). The files write coordinates to the millimetre, and a side
#: laid exactly on the lot's edge could round to half a millimetre outside it.
EDGE_CLEARANCE = 0.005


@dataclass(frozen=True)
class FootprintOptions:
    """Building rules of one land-use type (002 §5.3, 004 §4.3.4)."""

    #: m, range of the front setback from the street side of the lot, drawn
    #: per block (002 §5.3); the lot is already half a street width off the
    #: street's centre line.
    front_setback: tuple[float, float] = (3.0, 6.0)
    #: m, range of the setback from the lot's sides, drawn per block (002 §5.3).
    side_setback: tuple[float, float] = (1.5, 3.0)
    #: m, range of the setback from the lot's back, drawn per block (002 §5.3).
    back_setback: tuple[float, float] = (3.0, 8.0)
    #: m, a lot's building moves back by up to this much more than the
    #: block's front setback (002 §5.3 "variations for how far a building can
    #: move back from the front setback").
    front_variation: float = 2.0
    #: Longest side over shortest side, at most (004 §4.3.4: 1:2).
    max_ratio: float = 2.0
    #: m, buildings with a shorter side are not built.
    min_side: float = 5.0
    #: m², size target when the town has no buildings to calibrate from.
    target_area: float = 150.0
    #: Frontage/depth of the target when the town has no buildings.
    target_ratio: float = 1.2
    #: Quantile band of the town's footprint areas this land use draws its
    #: size targets from (beyond 002: its building library is not in the text).
    size_band: tuple[float, float] = (0.05, 0.95)
    #: Quantiles by which a lot's rank among its land use's lots (by room
    #: for a building) is moved at random before it picks the town's
    #: footprint of that rank: 0 couples big lots to big buildings strictly.
    size_noise: float = 0.15
    #: Whether lots of this land use get buildings at all (parks do not).
    build: bool = True

    def __post_init__(self) -> None:
        for key in ("front_setback", "side_setback", "back_setback"):
            lo, hi = getattr(self, key)
            if not (0 <= lo <= hi and math.isfinite(hi)):
                raise InputError(f"footprint option {key}={(lo, hi)!r} is not a range of metres")
        lo, hi = self.size_band
        checks = {
            "front_variation": self.front_variation >= 0, "max_ratio": self.max_ratio >= 1,
            "min_side": self.min_side >= 0, "target_area": self.target_area > 0,
            "target_ratio": self.target_ratio > 0, "size_band": 0 <= lo <= hi <= 1,
            "size_noise": 0 <= self.size_noise <= 1,
        }
        for key, ok in checks.items():
            if not ok:
                raise InputError(f"footprint option {key}={getattr(self, key)!r} is out of range")


#: Defaults per land use (002 §5.3 gives no numbers). Setbacks follow common
#: Central European zoning: detached houses 3–6 m behind the street line and
#: 1.5–3 m from the neighbours; urban residential and commercial buildings on
#: or near the street line; industrial halls well back with room for yards.
#: Targets without calibration: a 150 m² house, 450 m² apartment block,
#: 600 m² shop or office, 2,500 m² hall. Bands: houses from the lower 80 %
#: of the town's footprints, denser uses from the upper 70 %, industry from
#: the upper 40 %, so a mix like the town's keeps the town's median.
DEFAULT_FOOTPRINT_OPTIONS: Mapping[LandUse, FootprintOptions] = MappingProxyType({
    LandUse.RESIDENTIAL_LOW: FootprintOptions(),
    LandUse.RESIDENTIAL_HIGH: FootprintOptions(
        front_setback=(0.0, 3.0), side_setback=(0.5, 2.0), back_setback=(3.0, 6.0), front_variation=1.0,
        min_side=8.0, target_area=450.0, target_ratio=1.5, size_band=(0.3, 1.0)),
    LandUse.COMMERCIAL: FootprintOptions(
        front_setback=(0.0, 5.0), side_setback=(0.5, 3.0), back_setback=(3.0, 8.0), front_variation=2.0,
        min_side=8.0, target_area=600.0, target_ratio=1.5, size_band=(0.3, 1.0)),
    LandUse.INDUSTRIAL: FootprintOptions(
        front_setback=(5.0, 12.0), side_setback=(4.0, 8.0), back_setback=(5.0, 10.0), front_variation=3.0,
        min_side=12.0, target_area=2500.0, target_ratio=1.5, size_band=(0.6, 1.0)),
    LandUse.PARK: FootprintOptions(build=False),
})


@dataclass(frozen=True, eq=False)
class Rectangle:
    """A building rectangle: ``corners`` (4, 2) counter-clockwise, ``corners[0] → corners[1]`` the front.

    ``frontage`` (m) is the front side's length, ``depth`` (m) the other side's.
    """

    corners: np.ndarray
    frontage: float
    depth: float

    @property
    def area(self) -> float:
        """m²."""
        return self.frontage * self.depth

    @cached_property
    def polygon(self) -> shapely.Polygon:
        return shapely.Polygon(self.corners)


@dataclass(frozen=True, eq=False)
class Footprint:
    """A generated building's footprint: its rectangle, lot (index into the lots), street it faces, land use."""

    rectangle: Rectangle
    lot: int
    street: int
    land_use: str


@dataclass(frozen=True, eq=False)
class SizeTargets:
    """The town's own footprint sizes (issue: lot and footprint sizes start from the town).

    ``samples`` is ``(K, 3)``: area (m²), frontage (m), depth (m) per
    footprint, sorted by area. Quartiles are (25 %, 50 %, 75 %).
    """

    samples: np.ndarray

    @property
    def count(self) -> int:
        return len(self.samples)

    def quartiles(self, column: int = 0) -> tuple[float, float, float]:
        """Quartiles of area (0), frontage (1) or depth (2)."""
        q = np.percentile(self.samples[:, column], [25, 50, 75])
        return float(q[0]), float(q[1]), float(q[2])

    def at(self, quantile: np.ndarray | float, max_ratio: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
        """Area (m²) and frontage/depth ratio (clipped to [1/max_ratio, max_ratio]) at area quantiles."""
        q = np.clip(np.asarray(quantile, dtype=float), 0.0, 1.0)
        k = np.rint(q * (self.count - 1)).astype(np.intp)
        ratio = self.samples[k, 1] / np.maximum(self.samples[k, 2], 1e-9)
        return self.samples[k, 0], np.clip(ratio, 1.0 / max_ratio, max_ratio)


# ----------------------------------------------------------------------------- the rectangle sweep


def _depth_profile(a: np.ndarray, b: np.ndarray, u: np.ndarray, v0: float, *, left: bool) -> np.ndarray:
    """Free depth above the line v = v0 at each u: distance to the first boundary crossing, 0 outside.

    ``a``, ``b``: (E, 2) edge ends in the street frame; ``u``: (S,). A
    vertical at u crosses edge k when exactly one end lies right of u (the
    half-open rule: x > u gives the limit from the right, ``left=False``;
    x ≥ u the limit from the left, ``left=True``); (u, v0) is inside when
    the number of crossings above it is odd.
    """
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    if left:
        cross = (ax[None, :] < u[:, None]) != (bx[None, :] < u[:, None])
    else:
        cross = (ax[None, :] <= u[:, None]) != (bx[None, :] <= u[:, None])
    with np.errstate(all="ignore"):  # vertical edges never cross a vertical line; their slope is unused
        y = ay[None, :] + (u[:, None] - ax[None, :]) * ((by - ay) / (bx - ax))[None, :]
    above = cross & (y > v0 + 1e-9)
    inside = (above.sum(axis=1) % 2) == 1
    first = np.where(above, y, np.inf).min(axis=1, initial=np.inf)
    return np.where(inside, first - v0, 0.0)


def _samples(a: np.ndarray, b: np.ndarray, length: float, v0: float, resolution: float) -> np.ndarray:
    """Positions along the edge: a grid plus every breakpoint of the depth profile and just either side of it."""
    n = int(min(max(math.ceil(length / resolution) + 1, 2), _MAX_GRID))
    eps = 1e-7 * max(1.0, length)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a level edge has no crossing: t is ±inf
        t = (v0 - a[:, 1]) / (b[:, 1] - a[:, 1])
        on_line = a[:, 0] + t * (b[:, 0] - a[:, 0])
    breaks = np.concatenate([a[:, 0], on_line[(t >= 0) & (t <= 1)]])
    breaks = breaks[(breaks > 0) & (breaks < length)]
    u = np.concatenate([np.linspace(0.0, length, n), breaks - eps, breaks, breaks + eps])
    return np.unique(np.clip(u, 0.0, length))


def _fit(width: np.ndarray, depth: np.ndarray, target_area: float, target_ratio: float,
         max_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Building sides inside the available ``width`` × ``depth`` (m): the size target, then the ratio cut.

    Without a target (``inf``) the building takes all the room. With one, it
    takes the target's preferred frontage and depth, and when the room is
    short one way, grows the other way to keep the target area. Then the
    longer side is cut to ``max_ratio`` times the shorter (004 §4.3.4).
    """
    w, d = width, depth
    if math.isfinite(target_area):
        w_pref, d_pref = math.sqrt(target_area * target_ratio), math.sqrt(target_area / target_ratio)
        w, d = np.minimum(width, w_pref), np.minimum(depth, d_pref)
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(d < d_pref, np.minimum(width, target_area / d), w)
            d = np.where(w < w_pref, np.minimum(depth, target_area / w), d)
    w = np.minimum(w, max_ratio * d)
    d = np.minimum(d, max_ratio * w)
    return w, d


def _sweep(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray, normal: np.ndarray, *,
           setbacks: tuple[float, float, float], max_ratio: float, target_area: float,
           target_ratio: float, min_side: float, resolution: float) -> Rectangle | None:
    """The pair sweep on edges a→b (E, 2) in world coordinates; see the module docstring."""
    length = float(np.hypot(*(q - p)))
    if length <= 0:
        return None
    e = (q - p) / length
    n = np.array([-e[1], e[0]])
    sign = 1.0 if float(n @ normal) > 0 else -1.0
    n = sign * n
    frame = np.array([e, n]).T  # world → (u, v): (x - p) @ frame
    fa, fb = (a - p) @ frame, (b - p) @ frame
    front, side, back = setbacks
    u = _samples(fa, fb, length, front, resolution)
    right_of = _depth_profile(fa, fb, u, front, left=False)  # h(u+), what a rectangle starting at u sees
    left_of = _depth_profile(fa, fb, u, front, left=True)  # h(u-), what a rectangle ending at u sees
    if math.isfinite(target_area):
        i, j, bw, bd = _best_span(u, right_of, left_of, side, back, max_ratio, min_side, length, target_area,
                                  target_ratio)
    else:  # every lot's room: the same span, compiled (:mod:`~osm_expand.engine.buildout.sweep_kernel`)
        from osm_expand.engine.buildout.sweep_kernel import best_span

        i, j, bw, bd = best_span(u, right_of, left_of, float(side), float(back), float(max_ratio),
                                 float(min_side), length)
    if i < 0:
        return None
    return _rectangle(p, e, n, sign, u[i] + side, u[j] - side, bw, bd, front, length)


def _best_span(u: np.ndarray, right_of: np.ndarray, left_of: np.ndarray, side: float, back: float,
               max_ratio: float, min_side: float, length: float, target_area: float = math.inf,
               target_ratio: float = 1.0) -> tuple[int, int, float, float]:
    """The span (i, j) of samples ``u`` with the best building and its frontage and depth (i = -1: none), in
    (S, S) arrays: :func:`~osm_expand.engine.buildout.sweep_kernel.best_span` with a size target."""
    both = np.minimum(right_of, left_of)
    idx = np.arange(len(u))
    span = np.where(idx[None, :] > idx[:, None], both[None, :], np.inf)
    inner = np.minimum.accumulate(span, axis=1)  # inner[i, j] = min over samples i+1..j
    inner = np.concatenate([np.full((len(u), 1), np.inf), inner[:, :-1]], axis=1)  # … over i+1..j-1
    low = np.minimum(np.minimum(right_of[:, None], left_of[None, :]), inner)
    low = np.where(idx[None, :] > idx[:, None], low, np.inf)  # low[i, j]: free depth over (u_i, u_j)
    width = u[None, :] - u[:, None] - 2.0 * side
    depth = low - back
    w, d = _fit(np.maximum(width, 0.0), np.maximum(depth, 0.0), target_area, target_ratio, max_ratio)
    ok = (width > 0) & (depth > 0) & np.isfinite(low) & (np.minimum(w, d) >= max(min_side, 1e-9))
    if not ok.any():
        return -1, -1, 0.0, 0.0
    centre = 0.5 * (u[None, :] + u[:, None])
    # ties (a size target met by many spans) go to the target's shape, then to the middle of the edge
    shape = np.abs(w - math.sqrt(target_area * target_ratio)) if math.isfinite(target_area) else 0.0
    score = np.where(ok, w * d - 1e-3 * shape - 1e-6 * np.abs(centre - 0.5 * length), -np.inf)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    return int(i), int(j), float(w[i, j]), float(d[i, j])


def _rectangle(p: np.ndarray, e: np.ndarray, n: np.ndarray, sign: float, lo: float, hi: float, bw: float,
               bd: float, front: float, length: float) -> Rectangle:
    """The building ``bw`` × ``bd`` between ``lo`` and ``hi`` along the edge, in world coordinates."""
    mid = min(max(0.5 * length, lo + 0.5 * bw), hi - 0.5 * bw)  # as central on the edge as the room allows
    u0, u1, v0, v1 = mid - 0.5 * bw, mid + 0.5 * bw, front, front + bd
    order = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)] if sign > 0 else [(u1, v0), (u0, v0), (u0, v1), (u1, v1)]
    uv = np.array(order)
    corners = p + uv[:, :1] * e + uv[:, 1:] * n
    return Rectangle(corners=corners, frontage=bw, depth=bd)


def _edges(lot: shapely.Polygon | np.ndarray) -> tuple[np.ndarray, np.ndarray, shapely.Polygon | None]:
    if isinstance(lot, shapely.Polygon):
        rings = [np.asarray(r.coords) for r in [lot.exterior, *lot.interiors]]
        return np.vstack([r[:-1] for r in rings]), np.vstack([r[1:] for r in rings]), lot
    ring = np.asarray(lot, dtype=float)
    if len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    return ring, np.concatenate((ring[1:], ring[:1])), None


def largest_street_rectangle(lot: shapely.Polygon | np.ndarray, street_edge: tuple[np.ndarray, np.ndarray], *,
                             max_ratio: float = 2.0, setbacks: tuple[float, float, float] = (0.0, 0.0, 0.0),
                             target_area: float = math.inf, target_ratio: float = 1.0, min_side: float = 0.0,
                             resolution: float = 0.25) -> Rectangle | None:
    """The largest rectangle in a lot with its front on the street edge (004 §4.3.4).

    Parameters
    ----------
    lot : the lot, a shapely Polygon or an ``(N, 2)`` ring (metres), convex or not.
    street_edge : (p, q), two (2,) points of the lot's boundary on the street;
        the building's front is parallel to p→q and lies between them.
    max_ratio : longest over shortest side, at most (004: 2).
    setbacks : (front, side, back) in metres: the front is this far from the
        line p→q, and the rectangle grown by ``side`` along the street and by
        ``back`` away from it still lies in the lot.
    target_area, target_ratio : an optional size target (m², frontage/depth);
        the building is the largest rectangle no larger than the target,
        shaped like it where the room allows. ``inf``: as large as fits.
    min_side : m, smaller buildings count as no fit.
    resolution : m, grid spacing of the sweep along the edge (vertices of
        the lot are always sampled exactly).

    Returns
    -------
    The :class:`Rectangle` (exactly rectangular: built in the edge's frame and
    rotated back), or None when nothing of ``min_side`` fits.
    """
    a, b, poly = _edges(lot)
    p, q = np.asarray(street_edge[0], dtype=float), np.asarray(street_edge[1], dtype=float)
    length = float(np.hypot(*(q - p)))
    if length <= 0:
        return None
    e = (q - p) / length
    left = np.array([-e[1], e[0]])
    probe = 0.5 * (p + q) + 1e-4 * max(1.0, length) * left
    poly = poly if poly is not None else shapely.Polygon(a)
    normal = left if shapely.contains_xy(poly, probe[0], probe[1]) else -left
    return _sweep(a, b, p, q, normal, setbacks=setbacks, max_ratio=max_ratio, target_area=target_area,
                  target_ratio=target_ratio, min_side=min_side, resolution=resolution)


# ----------------------------------------------------------------------------- placement


def _traffic(table: Mapping[int, float] | np.ndarray, street: int) -> float:
    if isinstance(table, np.ndarray):
        return float(table[street]) if 0 <= street < len(table) else 0.0
    return float(table.get(street, 0.0))


def _is_built(built: Collection[int] | np.ndarray, street: int) -> bool:
    if isinstance(built, np.ndarray) and built.dtype == bool:
        return bool(built[street]) if 0 <= street < len(built) else False
    return street in built


def _targets(room: list[tuple[int, int, Rectangle]], uses: list[LandUse], draw: np.ndarray,
             options: Mapping[LandUse, FootprintOptions], sizes: SizeTargets | None) -> list[tuple[float, float]]:
    """Size target (m², frontage/depth) per lot with room for a building.

    From the town (``sizes``): per land use, lots ranked by the room they
    have get the town's footprints ranked by area within the land use's
    ``size_band`` (big lots, big buildings), each rank moved by up to
    ``size_noise`` quantiles at random. Without the town: the land use's
    ``target_area``/``target_ratio``.
    """
    out = [(options[uses[k]].target_area, options[uses[k]].target_ratio) for k, _, _ in room]
    if sizes is None or not sizes.count:
        return out
    use = np.array([uses[k].value for k, _, _ in room])
    area = np.array([rect.area for _, _, rect in room])
    for name in np.unique(use):
        rows = np.flatnonzero(use == name)
        opts = options[name]
        rank = np.empty(len(rows))
        rank[np.argsort(area[rows], kind="stable")] = (np.arange(len(rows)) + 0.5) / len(rows)
        noise = opts.size_noise * (2.0 * draw[[room[r][0] for r in rows]] - 1.0)
        q = opts.size_band[0] + np.clip(rank + noise, 0.0, 1.0) * (opts.size_band[1] - opts.size_band[0])
        a, ratio = sizes.at(q, opts.max_ratio)
        for r, ak, rk in zip(rows.tolist(), a.tolist(), ratio.tolist()):
            out[r] = (ak, rk)
    return out


def _shrink(rect: Rectangle, frontage: float, depth: float) -> Rectangle:
    """A rectangle of the given sides inside ``rect``, on its front, centred along it."""
    c = rect.corners
    e = (c[1] - c[0]) / max(rect.frontage, 1e-12)
    n = np.array([-e[1], e[0]])  # counter-clockwise corners: the back is to the left of the front
    mid = 0.5 * (c[0] + c[1])
    a, b = mid - 0.5 * frontage * e, mid + 0.5 * frontage * e
    corners = np.array([a, b, b + depth * n, a + depth * n])
    return Rectangle(corners=corners, frontage=frontage, depth=depth)


def place_buildings(lots: Sequence[Lot], *, traffic_per_street: Mapping[int, float] | np.ndarray,
                    built_streets: Collection[int] | np.ndarray,
                    options: Mapping[LandUse, FootprintOptions] = DEFAULT_FOOTPRINT_OPTIONS,
                    rng: np.random.Generator, sizes: SizeTargets | None = None,
                    obstacles: Sequence[shapely.Geometry] = (), resolution: float = 0.5) -> list[Footprint]:
    """A building footprint per lot near a built street (002 §2.2, §5.3; 004 §4.3.4).

    Parameters
    ----------
    lots : the lots (:func:`osm_expand.engine.buildout.lots.subdivide_blocks`).
    traffic_per_street : traffic per street id (a mapping, or an array
        indexed by id); the building faces the built frontage street with the
        most traffic (ties: the longer frontage, then the smaller id) where
        it fits, else the next.
    built_streets : ids of built streets (a collection, or a bool array
        indexed by id); lots on planned streets only get no building.
    options : :class:`FootprintOptions` per land use.
    rng : the run's random generator: three setback draws per block, two
        draws per lot, in order, whatever is built.
    sizes : the town's footprint sizes
        (:func:`~osm_expand.engine.buildout.footprint_sizes.calibrate_sizes`): lots
        ranked by room get the town's footprints ranked by area (module
        docstring); without them each land use's ``target_area`` and
        ``target_ratio`` apply.
    obstacles : geometries no building may touch (streets crossing a block
        without bounding it, the town's existing buildings).
    resolution : m, sweep grid spacing.

    Returns
    -------
    The footprints, in lot order, at most one per lot. Heights are not
    set here (the economy model, 002 §5.2, gives them).
    """
    uses = [land_use(lot.land_use) for lot in lots]
    for u in set(uses):
        if u not in options:
            raise InputError(f"no footprint options for land use {u.value!r}")
    blocks = np.array([lot.block for lot in lots], dtype=np.int64)
    _, block_row = np.unique(blocks, return_inverse=True)
    block_draw = rng.random((int(block_row.max()) + 1 if len(lots) else 0, 3))
    lot_draw = rng.random((len(lots), 2))
    room: list[tuple[int, int, Rectangle]] = []  # (lot, street, largest rectangle)
    for k, lot in enumerate(lots):
        opts = options[uses[k]]
        built = [int(s) for s in lot.streets if _is_built(built_streets, int(s))]
        if not opts.build or not built:
            continue
        f = block_draw[block_row[k]]
        front = opts.front_setback[0] + f[0] * (opts.front_setback[1] - opts.front_setback[0])
        front += lot_draw[k, 0] * opts.front_variation
        side_sb = opts.side_setback[0] + f[1] * (opts.side_setback[1] - opts.side_setback[0])
        back = opts.back_setback[0] + f[2] * (opts.back_setback[1] - opts.back_setback[0])
        built.sort(key=lambda s: (-_traffic(traffic_per_street, s), -lot.frontage_length(s), s))
        least = (opts.front_setback[0], opts.side_setback[0], opts.back_setback[0])
        for setbacks in ((front, side_sb, back), least):  # a shallow lot builds at the least setbacks
            clear = cast(tuple[float, float, float], tuple(max(x, EDGE_CLEARANCE) for x in setbacks))
            found = _room(lot, built, clear, opts, resolution)
            if found is not None:
                room.append((k, *found))
                break
    targets = _targets(room, uses, lot_draw[:, 1], options, sizes)
    out: list[Footprint] = []
    for (k, street, rect), (area, ratio) in zip(room, targets):
        opts = options[uses[k]]
        fit_w, fit_d = _fit(np.array(rect.frontage), np.array(rect.depth), area, ratio, opts.max_ratio)
        w = max(float(fit_w), min(opts.min_side, rect.frontage))
        d = max(float(fit_d), min(opts.min_side, rect.depth))
        out.append(Footprint(rectangle=_shrink(rect, w, d), lot=k, street=street, land_use=uses[k].value))
    if obstacles and out:
        tree = shapely.STRtree(list(obstacles))
        hit = np.unique(tree.query([fp.rectangle.polygon for fp in out], predicate="intersects")[0])
        keep = np.ones(len(out), dtype=bool)
        keep[hit] = False
        out = [fp for fp, ok in zip(out, keep.tolist()) if ok]
    return out


def _room(lot: Lot, built: Sequence[int], setbacks: tuple[float, float, float], opts: FootprintOptions,
          resolution: float) -> tuple[int, Rectangle] | None:
    """The street and largest rectangle of the first front, in order of preference, where one fits.

    Streets in the order given (the busiest first); along each, its straight
    sides longest first, then the chords of its curved runs.
    """
    ring = lot.ring
    nxt = np.concatenate((ring[1:], ring[:1]))
    sides = lot_sides(lot)
    for street in built:
        fronts = [(s.start, s.end) for s in sorted((s for s in sides if s.street == street), key=lambda s: -s.length)]
        for start, end in fronts + _curved_fronts(sides, street):
            chord = end - start
            normal = np.array([-chord[1], chord[0]])  # lots are counter-clockwise: inward is left
            rect = _sweep(ring, nxt, start, end, normal, setbacks=setbacks, max_ratio=opts.max_ratio,
                          target_area=math.inf, target_ratio=1.0, min_side=opts.min_side, resolution=resolution)
            if rect is not None:
                return street, rect
    return None


def _curved_fronts(sides: Sequence, street: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Chords of runs of two or more consecutive sides on ``street`` (a curved street edge), longest first.

    Tried after the straight sides: along a curve each side is short, but
    the chord across the run is the front a builder would take. Where the
    curve bends into the lot the chord is moved in by the bend, so the front
    setback counts from the street edge's innermost point.
    """
    n = len(sides)
    on = [s.street == street for s in sides]
    if n < 2 or all(on):
        return []
    start = next(k for k in range(n) if not on[k - 1] and on[k]) if any(on) else 0
    runs, k = [], start
    while k < start + n:
        if not on[k % n]:
            k += 1
            continue
        j = k
        while j + 1 < start + n and on[(j + 1) % n]:
            j += 1
        if j > k:
            a, b = sides[k % n].start, sides[j % n].end
            length = float(np.hypot(*(b - a)))
            if length > 0:
                inward = np.array([a[1] - b[1], b[0] - a[0]]) / length  # lots are counter-clockwise
                ends = np.array([p for m in range(k, j + 1) for p in (sides[m % n].start, sides[m % n].end)])
                bend = max(float(((ends - a) @ inward).max()), 0.0)
                runs.append((length, a + bend * inward, b + bend * inward))
        k = j + 1
    return [(a, b) for _, a, b in sorted(runs, key=lambda r: -r[0])]
