"""The district being quilted: its pieces and open cut ends, what a new link must keep clear of, and the
street network they make."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
import shapely.ops

from osm_expand.model import Origin, StreetNetwork, network_from_lines, polyline_length
from osm_expand.model.geometry import closest_on_segments, linestrings_of, ray_meet


@dataclass
class _Quilt:
    """The district being quilted: pieces (polylines with class and level) and the cut ends still open."""

    xy: list[np.ndarray] = field(default_factory=list)
    highway: list[str] = field(default_factory=list)
    level: list[int] = field(default_factory=list)
    #: per cut end: position, heading out of the street, cell, piece
    cut_xy: list[np.ndarray] = field(default_factory=list)
    cut_heading: list[np.ndarray] = field(default_factory=list)
    cut_cell: list[int] = field(default_factory=list)
    cut_piece: list[int] = field(default_factory=list)
    #: points to insert into a piece (a tee from another street lands there)
    splits: dict[int, list[np.ndarray]] = field(default_factory=dict)
    #: the patch centres (in the town) the cells take, in order
    grid: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    #: the tees made from cut ends onto streets of the district: (cut end, foot) pairs
    tees: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    def add(self, xy: np.ndarray, highway: str, level: int) -> int:
        self.xy.append(xy)
        self.highway.append(highway)
        self.level.append(level)
        return len(self.xy) - 1


class _Board:
    """What a seam link or a tee must not touch: the quilt's pieces, the links added, what is occupied."""

    def __init__(self, quilt: _Quilt, occupied: shapely.Geometry, old: shapely.Geometry | None = None):
        self.tree = shapely.STRtree(linestrings_of(quilt.xy))  # a board per seam step
        self.added: list[shapely.LineString] = []
        self.occupied, self.old = occupied, old

    def clear(self, path: np.ndarray) -> bool:
        """Does the polyline ``path`` touch streets only at its two ends, and nothing occupied?"""
        a, b = path[0], path[-1]
        line = shapely.LineString(path)
        if line.length > 2.0:
            inner = shapely.ops.substring(line, 1.0, line.length - 1.0)
            if self.occupied.intersects(inner) or (self.old is not None and self.old.intersects(inner)):
                return False
        if not line.is_simple:
            return False
        hits = self.tree.geometries.take(self.tree.query(line, predicate="intersects"))
        touches = shapely.intersection(line, [*hits, *self.added])
        touches = touches[~shapely.is_empty(touches)]
        if not len(touches):  # most paths touch nothing but at their ends' own streets: no disc to build
            return True
        ends = shapely.MultiPoint([a, b]).buffer(1e-6)
        return bool(shapely.covers(ends, touches).all())


def _lay(board: _Board, quilt: _Quilt, path: np.ndarray, end: int) -> None:
    """Lay ``path`` from the cut street ``end`` into the quilt, of that street's class and level, and on the
    board so that later links keep clear of it."""
    board.added.append(shapely.LineString(path))
    quilt.add(path, quilt.highway[quilt.cut_piece[end]], quilt.level[quilt.cut_piece[end]])


def _close(quilt: _Quilt, used: np.ndarray) -> None:
    """Forget the cut ends that are no longer open."""
    keep = np.flatnonzero(~used).tolist()
    for name in ("cut_xy", "cut_heading", "cut_cell", "cut_piece"):
        values = getattr(quilt, name)
        setattr(quilt, name, [values[k] for k in keep])


def _meet(ray: shapely.LineString, line: np.ndarray, p: np.ndarray, d: np.ndarray,
          min_angle: float) -> tuple[np.ndarray, bool] | None:
    """Where ``ray`` first meets ``line``, and whether at ``min_angle`` or more; None if it does not."""
    met = ray_meet(p, d, line, ray.length + 1e-3)
    return None if met is None else (met[1], met[2] >= min_angle)


def _network(quilt: _Quilt) -> StreetNetwork:
    """The quilt as a network: tees inserted into the pieces they land on; shared points shared nodes."""
    lines = []
    for j, xy in enumerate(quilt.xy):
        extra = quilt.splits.get(j)
        if extra:
            xy = _insert_points(xy, np.array(extra))
        lines.append(xy)
    attrs = [{"highway": hw, "hierarchy": lv, "origin": Origin.GROWN} for hw, lv in zip(quilt.highway, quilt.level)]
    return network_from_lines(lines, attrs)


def _insert_points(xy: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The polyline with ``points`` (which lie on it) inserted in order along it."""
    a, b = xy[:-1], xy[1:]
    where = []
    for q in points:
        t, _, d = closest_on_segments(q[None, :], a, b)
        i = int(np.argmin(d))
        where.append((i, float(t[i]), q))
    out = []
    for i in range(len(xy)):
        out.append(xy[i])
        for _, _, q in sorted((w for w in where if w[0] == i), key=lambda w: w[1]):
            if not (np.array_equal(q, xy[i]) or (i + 1 < len(xy) and np.array_equal(q, xy[i + 1]))):
                out.append(q)
    return np.array(out)


def _planar(net: StreetNetwork) -> StreetNetwork:
    """The district with no two streets touching away from a node they share: of each such pair the
    shorter street goes (the seams, tees and perimeter streets each check what stood when they were
    made; two cut ends of neighbouring cells can still end a few decimetres past each other)."""
    if len(net.streets) < 2:
        return net
    pairs = [(a, b, k) for k, st in enumerate(net.streets) for a, b in zip(st.nodes[:-1], st.nodes[1:])]
    seg = np.array([(a, b) for a, b, _ in pairs], dtype=np.intp)
    owner = np.array([k for _, _, k in pairs])
    lines = shapely.linestrings(net.xy[seg])
    left, right = shapely.STRtree(lines).query(lines, predicate="intersects")
    keep = left < right
    left, right = left[keep], right[keep]
    shared = (seg[left][:, :, None] == seg[right][:, None, :]).any(axis=(1, 2))
    left, right = left[~shared], right[~shared]
    if not len(left):
        return net
    length = np.array([polyline_length(net.street_xy(st)) for st in net.streets])
    drop = set()
    for i, j in zip(owner[left].tolist(), owner[right].tolist()):
        if i != j and i not in drop and j not in drop:
            drop.add(i if (length[i], i) < (length[j], j) else j)
    return net.replace(streets=tuple(st for k, st in enumerate(net.streets) if k not in drop))
