"""Small geometry kernels every stage shares (metres, NumPy arrays)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely


def polyline_length(xy: np.ndarray) -> float:
    """Length of a polyline.

    Parameters
    ----------
    xy : (n, 2) float array
        Points in metres.

    Returns
    -------
    float
        Metres; 0 for fewer than two points.

    Examples
    --------
    >>> polyline_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]]))
    6.0
    >>> polyline_length(np.zeros((0, 2)))
    0.0
    """
    if len(xy) < 2:
        return 0.0
    return float(np.hypot(*np.diff(xy, axis=0).T).sum())


def linestrings_of(xy: Sequence[np.ndarray]) -> np.ndarray:
    """The polylines ``xy`` (each ``(n_i, 2)`` m, ``n_i`` ≥ 2) as shapely LineStrings, an object array made in
    one GEOS call: one constructor call per line costs thousands of calls where a district or a board makes
    its lines again and again."""
    if not len(xy):
        return np.empty(0, dtype=object)
    counts = np.fromiter((len(p) for p in xy), dtype=np.intp, count=len(xy))
    return shapely.linestrings(np.concatenate([np.asarray(p, dtype=float) for p in xy]),
                               indices=np.repeat(np.arange(len(xy)), counts))


def turn_angles(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """How sharply a path turns from direction ``before`` to direction ``after``: the heading change in
    degrees, 0 (straight on) to 180 (back), whichever side.

    A street's bend at a node of degree 2 (``synth.patches``' corner count) and a chord's bend
    (:func:`chord_bends`) read it, so that what one stage counts as a corner is what another avoids.
    Two copies remain, left because their outputs would move by the last bit: the yardstick's
    curvature (``measures.shape``) and the major roads' turns (``engine.roads.road_types``, radians).

    Parameters
    ----------
    before, after : (n, 2) or (2,) float array
        Direction vectors (any length but zero), e.g. the segment into a node and the one out of it.

    Returns
    -------
    (n,) float array or float
        Degrees in [0, 180].

    >>> turn_angles(np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 2.0], [1.0, -1.0]])).round().tolist()
    [90.0, 45.0]
    >>> float(turn_angles(np.array([1.0, 0.0]), np.array([-1.0, 0.0])))
    180.0
    """
    before, after = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    turn = np.arctan2(after[..., 1], after[..., 0]) - np.arctan2(before[..., 1], before[..., 0])
    return np.degrees(np.abs((turn + np.pi) % (2 * np.pi) - np.pi))


def chord_bends(xy: np.ndarray, at: np.ndarray, step: float) -> np.ndarray:
    """How sharply a polyline bends at arc positions ``at`` as chords of ``step`` metres see it: the
    heading change (degrees, 0–180) from the chord ending at each position to the chord starting there.

    The fidelity yardstick reads a street's curvature the same way (``measures``' ``curvature``:
    consecutive chords of 20 m), so a street made with its bends read this way bends as it will be
    judged: a jog of a metre is no bend, a corner is one wherever it falls between the samples.
    Chords are clipped at the polyline's ends.

    >>> xy = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 40.0]])
    >>> chord_bends(xy, np.array([10.0, 40.0]), 20.0).round().tolist()
    [0.0, 90.0]
    """
    seg = np.hypot(*np.diff(xy, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])

    def point(s: np.ndarray) -> np.ndarray:
        s = np.clip(s, 0.0, cum[-1])
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
        t = np.divide(s - cum[k], seg[k], out=np.zeros_like(s), where=seg[k] > 0)
        return xy[k] + t[:, None] * (xy[k + 1] - xy[k])

    at = np.asarray(at, dtype=np.float64)
    here = point(at)
    back, ahead = here - point(at - step), point(at + step) - here
    bend = turn_angles(back, ahead)
    flat = (np.hypot(*back.T) < 1e-9) | (np.hypot(*ahead.T) < 1e-9)  # at an end: no chord on one side
    return np.where(flat, 0.0, bend)


def ring_area(ring: np.ndarray) -> float:
    """Signed shoelace area (m²) of a ring given without its closing point, positive counter-clockwise.

    >>> ring_area(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]]))
    6.0
    """
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(x[:-1] @ y[1:] - x[1:] @ y[:-1] + x[-1] * y[0] - x[0] * y[-1])


def ring_edge_lengths(ring: np.ndarray) -> np.ndarray:
    """Length of each edge ``ring[k] → ring[k + 1]`` of a ring given without its closing point, (N,) metres."""
    d = np.concatenate((ring[1:], ring[:1])) - ring
    return np.hypot(d[:, 0], d[:, 1])


def ray_meet(p: np.ndarray, d: np.ndarray, line: np.ndarray, reach: float
             ) -> tuple[float, np.ndarray, float] | None:
    """Where the ray from ``p`` along the unit vector ``d`` first crosses the polyline ``line``
    ``(n, 2)`` within ``reach`` metres: (distance along the ray, the point, the angle in degrees
    between ray and segment, 0–90); None when it does not.

    >>> t, q, angle = ray_meet(np.zeros(2), np.array([1.0, 0.0]), np.array([[5.0, -1], [5, 1]]), 10.0)
    >>> float(t), q.tolist(), round(angle)
    (5.0, [5.0, 0.0], 90)
    """
    a, b = line[:-1], line[1:]
    seg = b - a
    cross = seg[:, 0] * d[1] - seg[:, 1] * d[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((a[:, 0] - p[0]) * seg[:, 1] - (a[:, 1] - p[1]) * seg[:, 0]) / -cross  # along the ray
        u = ((a[:, 0] - p[0]) * d[1] - (a[:, 1] - p[1]) * d[0]) / -cross  # along the segment
    ok = np.isfinite(t) & (t > 1e-3) & (t <= reach) & (u >= 0.0) & (u <= 1.0)
    if not ok.any():
        return None
    i = int(np.flatnonzero(ok)[np.argmin(t[ok])])
    sin = abs(float(cross[i])) / max(float(np.hypot(*seg[i])), 1e-12)
    return float(t[i]), a[i] + u[i] * seg[i], float(np.degrees(np.arcsin(min(sin, 1.0))))


def closest_on_segments(pt: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The closest point of segments a→b to point(s) ``pt`` (broadcast).

    Parameters
    ----------
    pt, a, b : (..., 2) float arrays
        Points and segment ends in metres; shapes broadcast.

    Returns
    -------
    t : (...) float array
        Parameter of the closest point along each segment, in [0, 1].
    foot : (..., 2) float array
        The closest point.
    distance : (...) float array
        Metres from ``pt`` to ``foot``.

    Examples
    --------
    >>> t, foot, d = closest_on_segments(np.array([5.0, 3.0]), np.array([0.0, 0.0]), np.array([10.0, 0.0]))
    >>> float(t), foot.tolist(), float(d)
    (0.5, [5.0, 0.0], 3.0)
    """
    d = b - a
    t = np.clip(((pt - a) * d).sum(axis=-1) / np.maximum((d * d).sum(axis=-1), 1e-24), 0.0, 1.0)
    foot = a + t[..., None] * d
    return t, foot, np.hypot(*np.moveaxis(pt - foot, -1, 0))


def match_points(points: np.ndarray, known: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
    """Which known point each point is (within ``tolerance`` metres), or -1.

    The one helper that turns coordinates back into nodes: synthesised
    streets that end on a town's node carry that node's exact coordinates.

    Parameters
    ----------
    points : (m, 2) float array
    known : (n, 2) float array
    tolerance : float
        Metres; 0 means equal coordinates.

    Returns
    -------
    (m,) int64 array
        Index into ``known`` of the nearest known point within the
        tolerance (the first of equal ones), -1 where there is none.

    Examples
    --------
    >>> match_points(np.array([[1.0, 1.0], [5.0, 5.0]]), np.array([[0.0, 0.0], [1.0, 1.0]])).tolist()
    [1, -1]
    >>> match_points(np.zeros((0, 2)), np.zeros((0, 2))).tolist()
    []
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    known = np.asarray(known, dtype=float).reshape(-1, 2)
    out = np.full(len(points), -1, dtype=np.int64)
    if not len(points) or not len(known):
        return out
    if tolerance <= 0.0:
        index: dict[tuple[float, float], int] = {}
        for i, key in enumerate(map(tuple, known.tolist())):
            index.setdefault(key, i)
        return np.fromiter((index.get(key, -1) for key in map(tuple, points.tolist())), dtype=np.int64,
                           count=len(points))
    import shapely  # STRtree, not SciPy's cKDTree: the simplify path must not pay SciPy's import

    # only the known points in reach of the box around ``points``: a year adds a few hundred points
    # to a town of 100,000 nodes, and the tree over all of them cost 3.9 s of Campo Grande's 30 years
    lo, hi = points.min(axis=0) - tolerance, points.max(axis=0) + tolerance
    near = np.flatnonzero(((known >= lo) & (known <= hi)).all(axis=1))
    if not len(near):
        return out
    src, hit = shapely.STRtree(shapely.points(known[near])).query_nearest(
        shapely.points(points), max_distance=tolerance, all_matches=True)
    if not len(src):
        return out
    # ``all_matches`` gives each point its equally nearest known points only: the first (lowest index) of
    # them (duplicate nodes at one spot; the whole-town tree returned whichever it reached first)
    order = np.lexsort((near[hit], src))
    src, hit = src[order], hit[order]
    first = np.r_[True, src[1:] != src[:-1]]
    out[src[first]] = near[hit[first]]
    return out


def minimum_rectangle(ring: np.ndarray) -> np.ndarray | None:
    """The minimum-area rectangle around a footprint: four corners, counter-clockwise.

    Parameters
    ----------
    ring : (n, 2) float array
        A footprint's outer ring in metres (closed or not).

    Returns
    -------
    (4, 2) float array, or None
        Exactly rectangular corners (built from one edge direction and its
        normal, not rounded by a polygon library), or None for a footprint
        with no area: fewer than three distinct corners, or all of them on
        one line (whose hull is a line: main def3a8e raised AttributeError
        there, reading a line's exterior).
    """
    return minimum_rectangles([ring])[0]


def minimum_rectangles(rings: Sequence[np.ndarray]) -> list[np.ndarray | None]:
    """:func:`minimum_rectangle` of each of ``rings`` (which is this of one ring), the distinct corners and
    their hulls made in one GEOS call for all: one call per footprint (four GEOS calls and a sort each) was
    most of the XML writer's time on Krems' 1,306 buildings.

    Parameters
    ----------
    rings : sequence of (n_i, 2) float arrays
        Footprints' outer rings in metres (closed or not).

    Returns
    -------
    list of (4, 2) float arrays or None
        In the order of ``rings``.
    """
    if not len(rings):
        return []
    sizes = np.array([len(r) for r in rings], dtype=np.int64)
    pts = np.concatenate([np.asarray(r, dtype=float).reshape(-1, 2) for r in rings])
    owner = np.repeat(np.arange(len(rings)), sizes)
    # each ring's distinct corners sorted by x, then y, all rings in one sort
    order = np.lexsort((pts[:, 1], pts[:, 0], owner))
    pts, owner = pts[order], owner[order]
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = (owner[1:] != owner[:-1]) | np.any(pts[1:] != pts[:-1], axis=1)
    pts, owner = pts[keep], owner[keep]
    distinct = np.bincount(owner, minlength=len(rings))
    asked = distinct >= 3
    out: list[np.ndarray | None] = [None] * len(rings)
    if not asked.any():
        return out
    mask = asked[owner]
    which = np.flatnonzero(asked)
    clouds = shapely.multipoints(pts[mask], indices=np.searchsorted(which, owner[mask]))
    hulls = shapely.get_exterior_ring(shapely.convex_hull(clouds))  # None where a hull is a line or a point
    coords, index = shapely.get_coordinates(hulls, return_index=True)
    starts = np.searchsorted(index, np.arange(len(which) + 1))
    for j, k in enumerate(which.tolist()):
        out[k] = _rectangle_around(coords[starts[j]:starts[j + 1]])
    return out


def _rectangle_around(hull: np.ndarray) -> np.ndarray | None:
    """The minimum-area rectangle around a closed convex hull ring (``(h, 2)``, first point repeated last), one
    of its edges lying on a side (the rotating-calipers fact), or None when the hull has no area."""
    if len(hull) < 4:
        return None
    edges = np.diff(hull, axis=0)
    lengths = np.hypot(*edges.T)
    edges, lengths = edges[lengths > 0], lengths[lengths > 0]
    u = edges / lengths[:, None]  # (k, 2) candidate directions
    v = np.column_stack([-u[:, 1], u[:, 0]])
    along, across = hull @ u.T, hull @ v.T  # (h, k)
    lo_u, hi_u, lo_v, hi_v = along.min(0), along.max(0), across.min(0), across.max(0)
    area = (hi_u - lo_u) * (hi_v - lo_v)
    k = int(np.argmin(area))
    if not area[k] > 0:
        return None
    corners = np.array([[lo_u[k], lo_v[k]], [hi_u[k], lo_v[k]], [hi_u[k], hi_v[k]], [lo_u[k], hi_v[k]]])
    return corners[:, :1] * u[k] + corners[:, 1:] * v[k]
