"""The city's streets as a table of straight segments: what the engine's kernels compute on.

Traffic, trade routes, the pathfinding graph and street growth all work on
segments (consecutive node pairs of the streets), with per-segment arrays:
length, width, major or minor, built or planned, bridge, the year it was
built. The table is derived from the city whenever the engine needs it
(it is never a second copy of the streets), and per-segment results come
back to the streets with :meth:`SegmentTable.per_street`.

It lives in the model, beside the streets it is derived from, as the one
segment table of the code (issue 23). The major roads read it with two
optional columns of their own: each segment's remaining trade capacity
(``available``) and the built harbour segments (``harbour``);
:meth:`SegmentTable.from_lines` makes a table of bare polylines for their
tests. ``synth``'s :class:`~synth.street_graph.StreetGraph` is not a second
table: it is the growth kernels' mutable graph with its grids, built from
these arrays (:meth:`~synth.street_graph.StreetGraph.from_segments`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from osm_expand.errors import InputError
from osm_expand.model import highways
from osm_expand.model.city import City
from osm_expand.model.network import Status, Street, segment_nodes
from osm_expand.model.pieces import Pieces

#: Highway classes that are major roads (003's major roads: the trade routes run on them).
MAJOR = highways.MAJOR_AND_LINKS
#: Carriageway width (m) by class when the map says neither ``width`` nor ``lanes`` (RAS-06 / AASHTO:
#: 3.5 m lanes; two lanes on most town streets, four on primaries, more on motorways).
DEFAULT_WIDTH = {"motorway": 22.0, "trunk": 15.0, "primary": 14.0, "secondary": 10.0, "tertiary": 8.0,
                 "unclassified": 6.0, "residential": 6.0, "living_street": 5.0, "road": 6.0, "service": 4.0}
#: Metres per lane when only ``lanes`` is mapped.
LANE_WIDTH = 3.5
#: The last network :meth:`SegmentTable.from_city` saw, and its table.
_LAST: list = [None, None]


def street_width(street: Street) -> float:
    """A street's width (m): mapped, else from its lanes, else by its class."""
    if street.width and street.width > 0:
        return float(street.width)
    if street.lanes and street.lanes > 0:
        return float(street.lanes) * LANE_WIDTH
    return DEFAULT_WIDTH.get(street.highway.removesuffix("_link"), 6.0)


def is_major(street: Street) -> bool:
    return street.highway in MAJOR


@dataclass(frozen=True)
class SegmentTable:
    """Every segment of every street, in street order (arrays aligned by segment)."""

    xy: np.ndarray  #: (N, 2) metres: the city's nodes
    uv: np.ndarray  #: (E, 2) node indices
    street: np.ndarray  #: (E,) index of the street in ``city.network.streets``
    length: np.ndarray  #: (E,) metres
    width: np.ndarray  #: (E,) metres
    major: np.ndarray  #: (E,) bool
    built: np.ndarray  #: (E,) bool: planned streets exist on the map but carry no built traffic yet
    bridge: np.ndarray  #: (E,) bool
    year: np.ndarray  #: (E,) the year built, -1 for the town as mapped
    street_id: np.ndarray  #: (E,) the street's stable id (:attr:`Street.id`)
    first: np.ndarray  #: (S + 1,) the first segment of each street (segments of street k: first[k]..first[k+1])
    #: (E,) remaining trade capacity ``O2 · width − T(s)`` (003 §3.4.2, traffic units); None: not read
    available: np.ndarray | None = None
    #: (E,) bool, built harbour segments (003's C4); None: none. Nothing sets it yet (no harbour
    #: street is read from a map), so G′'s C4 branch waits for one
    harbour: np.ndarray | None = None
    #: the segments' lines and their STRtree, made once per table (a road year asks several times)
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = len(self.uv)
        if np.ndim(self.xy) != 2 or np.shape(self.xy)[1:] != (2,) or np.shape(self.uv) != (n, 2):
            raise InputError("segments: xy must be (N, 2) and uv (E, 2)")
        for name in ("street", "length", "width", "major", "built", "bridge", "year", "street_id", "available",
                     "harbour"):
            value = getattr(self, name)
            if value is not None and np.shape(value) != (n,):
                raise InputError(f"segments: {name} must have one value per segment ({n}), got {np.shape(value)}")
        if n and (np.min(self.uv) < 0 or np.max(self.uv) >= len(self.xy)):
            raise InputError("segments: uv refers to a node that does not exist")

    @classmethod
    def from_lines(cls, lines: Sequence[np.ndarray], *, major: Sequence[bool], width: Sequence[float],
                   bridge: Sequence[bool] | None = None, available: Sequence[float] | None = None) -> SegmentTable:
        """A table of polylines (one street each); points equal to the micrometre become one node.

        Parameters
        ----------
        lines
            Polylines, each ``(M, 2)`` metres; every consecutive pair of points is a segment.
        major, width, bridge, available
            One value per polyline, given to all its segments (``bridge``
            default False, ``available`` default None: unlimited).

        Returns
        -------
        SegmentTable
            Every segment built, of the town as mapped (year −1); a polyline's
            street id is its index.
        """
        pts = [np.asarray(line, dtype=float).reshape(-1, 2) for line in lines]
        counts = np.array([len(p) - 1 for p in pts], dtype=np.int64)
        every = np.concatenate(pts) if pts else np.zeros((0, 2))
        xy, inverse = np.unique(np.round(every, 6), axis=0, return_inverse=True)
        inverse = inverse.ravel()
        starts = np.concatenate([[0], np.cumsum([len(p) for p in pts])])
        uv = np.concatenate([np.stack([inverse[s:e - 1], inverse[s + 1:e]], axis=1)
                             for s, e in zip(starts[:-1], starts[1:])]) if pts else np.zeros((0, 2), np.int64)
        per = lambda values, dtype: np.repeat(np.asarray(values, dtype=dtype), counts)  # noqa: E731
        keep = uv[:, 0] != uv[:, 1]
        street = per(np.arange(len(pts)), np.int64)[keep]
        uv = uv[keep]
        return cls(
            xy=xy, uv=uv, street=street, length=np.hypot(*(xy[uv[:, 1]] - xy[uv[:, 0]]).T),
            width=per(width, float)[keep], major=per(major, bool)[keep], built=np.ones(len(uv), bool),
            bridge=(per(bridge, bool) if bridge is not None else np.zeros(counts.sum(), bool))[keep],
            year=np.full(len(uv), -1, np.int64), street_id=street.copy(),
            first=np.searchsorted(street, np.arange(len(pts) + 1)).astype(np.int64),
            available=None if available is None else per(available, float)[keep],
        )

    @property
    def a(self) -> np.ndarray:
        """(E, 2) each segment's first end."""
        return self.xy[self.uv[:, 0]]

    @property
    def b(self) -> np.ndarray:
        """(E, 2) each segment's second end."""
        return self.xy[self.uv[:, 1]]

    def lines(self) -> np.ndarray:
        """One shapely LineString per segment (made once per table, read-only: it is shared)."""
        if "lines" not in self._cache:
            lines = shapely.linestrings(np.stack([self.a, self.b], axis=1))
            lines.flags.writeable = False
            self._cache["lines"] = lines
        return self._cache["lines"]

    def end_keys(self) -> np.ndarray:
        """``(E,)`` void keys, one a segment: the bytes of its two ends' float64 coordinates, the
        lesser end (by x, then y) first (made once per table, read-only: it is shared).

        A segment reversed has the same key; a segment split or moved has another. The road
        engine's year-to-year memos (B's held segments, the stitches' carried street verdicts)
        compare them across years; :meth:`numpy.ndarray.tolist` gives them as ``bytes``, and
        :meth:`ends_of_keys` reads them back as ends.
        """
        if "end_keys" not in self._cache:
            a, b = np.asarray(self.a, dtype=np.float64), np.asarray(self.b, dtype=np.float64)
            first = (a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] <= b[:, 1]))
            ends = np.ascontiguousarray(np.concatenate([np.where(first[:, None], a, b),
                                                        np.where(first[:, None], b, a)], axis=1))
            keys = ends.view(np.dtype((np.void, ends.dtype.itemsize * 4))).ravel()
            keys.flags.writeable = False
            self._cache["end_keys"] = keys
        return self._cache["end_keys"]

    @staticmethod
    def ends_of_keys(keys: np.ndarray) -> np.ndarray:
        """``(K, 2, 2)`` float64 ends of the segments whose :meth:`end_keys` are ``keys`` (lesser end
        first): the one reader of that layout, beside its writer."""
        return np.frombuffer(keys.tobytes(), dtype=np.float64).reshape(-1, 2, 2)

    def __getstate__(self) -> dict:
        """Pickled without the made lines, tree and keys (made again when asked for)."""
        return {**self.__dict__, "_cache": {}}

    def tree(self) -> shapely.STRtree:
        """An STRtree over :meth:`lines`, made once per table."""
        if "tree" not in self._cache:
            self._cache["tree"] = shapely.STRtree(self.lines())
        return self._cache["tree"]

    @classmethod
    def from_city(cls, city: City) -> SegmentTable:
        """The table of ``city``'s streets; the last network's table comes back as it is.

        A year asks for the same network's table several times (growth,
        nuclei, the safety net, traffic); networks are immutable, so the
        table of the very same network object is the same table.
        """
        if _LAST[0] is city.network:
            return _LAST[1]
        table = cls._build(city)
        _LAST[:] = [city.network, table]
        return table

    @classmethod
    def _build(cls, city: City) -> SegmentTable:
        """The table, the streets read in two passes: their segments' nodes (:func:`segment_nodes`) and their
        fields row by row (a pass per field and an array per street: 6.9 ms of Campo Grande's 3,600
        streets, 5.9 ms so; 38 tables a run)."""
        streets = city.network.streets
        counts, u, v = segment_nodes(streets)
        sizes = counts - 1
        uv = np.column_stack([u, v]) if streets else np.zeros((0, 2), dtype=np.int64)
        street = np.repeat(np.arange(len(streets)), sizes)
        rows = [(street_width(s), s.highway in MAJOR, s.status == Status.BUILT, s.bridge,
                 s.year if s.year is not None and s.is_new else -1, s.id) for s in streets]
        width, major, built, bridge, year, ids = zip(*rows) if rows else ((),) * 6
        per = lambda values, dtype: np.repeat(np.asarray(values, dtype=dtype), sizes)  # noqa: E731
        xy = city.network.xy
        table = cls(
            xy=xy, uv=uv, street=street, length=np.hypot(*(xy[uv[:, 1]] - xy[uv[:, 0]]).T),
            width=per(width, float), major=per(major, bool), built=per(built, bool), bridge=per(bridge, bool),
            year=per(year, np.int64), street_id=per(ids, np.int64),
            first=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        )
        for name in ("uv", "street", "length", "width", "major", "built", "bridge", "year", "street_id", "first"):
            getattr(table, name).flags.writeable = False  # the table is shared (from_city hands it out again)
        return table

    def __len__(self) -> int:
        return len(self.uv)

    def per_street(self, values: np.ndarray, n_streets: int, how: str = "max") -> np.ndarray:
        """A per-segment array reduced to each street (``max`` or ``sum``); 0 for streets without segments."""
        out = np.zeros(n_streets)
        if how == "max":
            np.maximum.at(out, self.street, values)
        else:
            np.add.at(out, self.street, values)
        return out


def segment_pieces(old: SegmentTable, new: SegmentTable, city: City) -> Pieces:
    """For each segment of an older table, the segments of ``new`` (the table of ``city``) it became.

    The engine only adds streets, inserts nodes into streets (tees) or
    removes streets (a rebuilding road); a street keeps its id throughout.
    An old segment u–v of street *s* is the run of *s*'s new segments from u
    to v, or nothing when *s* is gone. A street whose segments are all as
    they were (nearly all, in a year) maps one to one, in a single pass.
    """
    ids = np.array([s.id for s in city.network.streets], dtype=np.int64)
    k = np.full(len(old), -1, dtype=np.int64)  # each old segment's street in the city now
    if len(ids):
        by_id = np.argsort(ids, kind="stable")
        at = by_id[np.clip(np.searchsorted(ids[by_id], old.street_id), 0, len(ids) - 1)]
        hit = ids[at] == old.street_id
        k[hit] = at[hit]
    present = k >= 0
    position = np.arange(len(old)) - old.first[old.street]
    old_count = np.diff(old.first)[old.street]
    new_count = np.where(present, np.diff(new.first)[np.maximum(k, 0)], -1)
    same = present & (old_count == new_count)
    candidate = np.where(same, new.first[np.maximum(k, 0)] + position, 0)
    same &= (new.uv[candidate] == old.uv).all(axis=1) if len(new) else False
    # a street is kept whole only when every one of its segments is
    whole = np.bincount(old.street, weights=~same, minlength=len(old.first) - 1) == 0
    fast = whole[old.street]
    sizes = np.where(fast, 1, 0)
    slow = np.flatnonzero(present & ~fast)
    runs = [_run(city.network.streets[int(k[e])].nodes, *old.uv[e].tolist()) for e in slow.tolist()]
    sizes[slow] = [hi - lo for lo, hi in runs]
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    flat = np.empty(int(offsets[-1]), dtype=np.int64)
    flat[offsets[:-1][fast]] = candidate[fast]
    for e, (lo, hi) in zip(slow.tolist(), runs):
        base = int(new.first[k[e]])
        flat[offsets[e]:offsets[e + 1]] = np.arange(base + lo, base + hi)
    return Pieces(offsets, flat)


def _run(nodes: tuple[int, ...], u: int, v: int) -> tuple[int, int]:
    """Positions (lo, hi) along ``nodes`` between u and v (lo == hi: not found)."""
    try:
        i = nodes.index(u)
        j = nodes.index(v, i + 1) if v in nodes[i + 1:] else nodes.index(v)
    except ValueError:
        return 0, 0
    return min(i, j), max(i, j)
