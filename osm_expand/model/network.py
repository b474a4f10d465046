"""Streets and the street network: nodes in metres, streets over them.

Nodes live in a single ``(N, 2)`` float64 array of metres in a local
transverse Mercator projection; streets are ordered node-index sequences that
keep the full OSM shape between junctions. Stages never mutate a network:
they build a new one with :meth:`StreetNetwork.replace` so that every pass
stays a pure function.
"""
from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from itertools import chain
from typing import Any

import numpy as np
import shapely

from osm_expand.model.components import close_pairs, component_labels
from osm_expand.model.enums import parse_enum
from osm_expand.model.geometry import match_points, polyline_length
from osm_expand.model.projection import LocalProjection


class Origin(enum.StrEnum):
    """Where a street, block or building came from."""

    SOURCE = "source"  #: the real town, as mapped in OpenStreetMap
    GROWN = "grown"  #: a district grown by a growth pattern
    JOIN = "join"  #: a street joining grown streets to the town
    ENGINE = "engine"  #: built by the engine during the simulated years

    @classmethod
    def parse(cls, value: str) -> Origin:
        return parse_enum(cls, value, "origin")


class Status(enum.StrEnum):
    """Planned streets exist on the map; they become built when traffic uses them (002 §2)."""

    BUILT = "built"
    PLANNED = "planned"

    @classmethod
    def parse(cls, value: str) -> Status:
        return parse_enum(cls, value, "status")


Tags = tuple[tuple[str, str], ...]


@dataclass(frozen=True, slots=True)
class Street:
    """One street: an ordered run of node indices plus its attributes.

    ``nodes`` includes shape points, not only junctions. A closed street
    (a ring) repeats its first node at the end. ``id`` is stable for the
    life of a city (unique among a city's streets; the pieces of a street
    in a derived network such as the simplified one share it). ``tags`` are
    the way's OSM tags as mapped (empty for streets the tool made); the
    typed fields are what the stages read.
    """

    nodes: tuple[int, ...]
    highway: str
    name: str | None = None
    layer: int = 0
    bridge: bool = False
    tunnel: bool = False
    junction: str | None = None
    lanes: float | None = None
    width: float | None = None  #: metres
    osm_ids: tuple[int, ...] = ()
    hierarchy: int = -1  #: Gravelius level; -1 unknown
    status: Status = Status.BUILT
    year: int | None = None  #: the year it was built (None: before the history)
    id: int = -1
    origin: Origin = Origin.SOURCE
    era: str | None = None  #: the era of the history it was built in
    tags: Tags = ()

    @property
    def layer_key(self) -> tuple[int, bool, bool]:
        """Streets cross only at a junction when their layer keys are equal."""
        return (self.layer, self.bridge, self.tunnel)

    @property
    def is_closed(self) -> bool:
        return len(self.nodes) > 2 and self.nodes[0] == self.nodes[-1]

    @property
    def is_new(self) -> bool:
        """Made by the tool (grown, joining, or built by the engine), not mapped."""
        return self.origin != Origin.SOURCE

    def with_nodes(self, nodes: tuple[int, ...] | list[int]) -> Street:
        return replace(self, nodes=tuple(nodes))


@dataclass(frozen=True)
class Context:
    """Where a network lies on the earth: its projection and the bounds of its data."""

    projection: LocalProjection
    bounds_lonlat: tuple[float, float, float, float]  #: (lon0, lat0, lon1, lat1)
    bounds_from_header: bool

    @property
    def bounds_xy(self) -> tuple[float, float, float, float]:
        """The bounds in metres: (x0, y0, x1, y1) around the projected corners."""
        lon0, lat0, lon1, lat1 = self.bounds_lonlat
        xs, ys = self.projection.to_xy(np.array([lon0, lon1, lon0, lon1]), np.array([lat0, lat0, lat1, lat1]))
        return (float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max()))


@dataclass(frozen=True)
class StreetNetwork:
    """Nodes in metres, streets over them, and where they lie.

    ``node_ids`` holds each node's OSM id (0 for nodes the tool made).
    """

    xy: np.ndarray  #: (N, 2) float64, metres
    node_ids: np.ndarray  #: (N,) int64
    streets: tuple[Street, ...]
    context: Context
    stats: dict[str, Any] = field(default_factory=dict)

    def replace(self, **changes: Any) -> StreetNetwork:
        return replace(self, **changes)

    def street_xy(self, street: Street) -> np.ndarray:
        return self.xy[np.asarray(street.nodes, dtype=np.intp)]

    def street_lines(self) -> np.ndarray:
        """Every street's polyline as a LineString, (S,) object array in street order, made in one call.

        Made once per network and handed back read-only: a district of the engine asks for the
        lines of the same network six times (sites, region, pattern, joins), 28 ms each on Campo
        Grande's 10,000 streets (13.8 s of a 30-year run before the memo); a network is never
        changed in place, so its lines never go stale.
        """
        lines = self.__dict__.get("_street_lines")
        if lines is None:
            lines = self._make_street_lines()
            lines.flags.writeable = False
            self.__dict__["_street_lines"] = lines  # frozen: the memo bypasses __setattr__, as cached_property does
        return lines

    def _make_street_lines(self) -> np.ndarray:
        if not self.streets:
            return np.empty(0, dtype=object)
        sizes = np.fromiter((len(s.nodes) for s in self.streets), dtype=np.int64, count=len(self.streets))
        nodes = np.fromiter((n for s in self.streets for n in s.nodes), dtype=np.intp, count=int(sizes.sum()))
        return shapely.linestrings(self.xy[nodes], indices=np.repeat(np.arange(len(sizes)), sizes))

    def __getstate__(self) -> dict:
        """Pickled without the memos of :meth:`street_lines` and :meth:`_segment_keys` (remade on demand)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_street_lines", "_segment_key_memo")}

    def used_nodes(self) -> np.ndarray:
        """Sorted indices of the nodes that some street references."""
        if not self.streets:
            return np.zeros(0, dtype=np.intp)
        return np.unique(np.concatenate([np.asarray(s.nodes, dtype=np.intp) for s in self.streets]))

    def total_length(self) -> float:
        """Metres of street, summed street by street; measured once per network (a network never changes in
        place): a district's pattern asks the same networks again while it compares its tries (Krems: 44
        asks, half of them repeats, 4,000 streets measured one by one)."""
        total = self.__dict__.get("_total_length")
        if total is None:
            total = self.__dict__["_total_length"] = float(sum(polyline_length(self.street_xy(s))
                                                               for s in self.streets))
        return total

    def next_street_id(self) -> int:
        """An id no street of this network has."""
        return max((s.id for s in self.streets), default=-1) + 1

    def _segment_keys(self) -> np.ndarray:
        """The undirected segments of every street as sorted unique keys (:func:`pair_keys`), read-only.

        Made once per network, and handed on by :meth:`with_new_streets` to the network it makes
        (this one's keys and the new streets'): a year of Campo Grande adds streets some 200 times,
        and gathering the keys of its 10,000 streets each time cost 1.2 s of 30 years.
        """
        keys = self.__dict__.get("_segment_key_memo")
        if keys is None:
            _, u, v = segment_nodes(self.streets)
            keys = np.unique(pair_keys(u, v))
            keys.flags.writeable = False
            self.__dict__["_segment_key_memo"] = keys  # frozen: the memo bypasses __setattr__, as street_lines' does
        return keys

    def with_new_streets(self, lines: Sequence[np.ndarray], attrs: Sequence[Mapping[str, Any]], *,
                         one_street_per_segment: bool = False, same_node: float | None = None) -> StreetNetwork:
        """This network plus streets along ``lines`` (metres), each with the given :class:`Street` fields.

        A point within :data:`SAME_NODE` (1 mm) of a node of this network is
        that node; points shared by the new lines become one new node. New
        streets get fresh ids; new nodes get OSM id 0. With
        ``one_street_per_segment`` a new line is cut where it would run along
        a segment some street already has (what the tool grows; a file read
        back keeps what it holds, parallel streets of a simplified network
        included). ``same_node`` overrides the 1 mm (0: equal coordinates only,
        for coordinates that are not metres).
        """
        tolerance = SAME_NODE if same_node is None else float(same_node)
        if not len(lines):
            return self
        pts = np.concatenate([np.asarray(ln, dtype=float).reshape(-1, 2) for ln in lines])
        known = match_points(pts, self.xy, tolerance)
        fresh = np.flatnonzero(known < 0)
        group = _same_points(pts[fresh], tolerance)  # points of the new lines within SAME_NODE are one node
        first_of, number = np.unique(group, return_index=True)[1], np.zeros(len(fresh), dtype=np.int64)
        number[first_of] = np.arange(len(first_of))
        known[fresh] = len(self.xy) + number[group]
        xy = np.vstack([self.xy, pts[fresh[first_of]].reshape(-1, 2)])
        ids = np.concatenate([self.node_ids, np.zeros(len(first_of), dtype=np.int64)])
        first, streets = self.next_street_id(), list(self.streets)
        inherited = one_street_per_segment or "_segment_key_memo" in self.__dict__
        taken = _SegmentKeys(self._segment_keys() if inherited else np.zeros(0, np.int64),
                             active=one_street_per_segment)
        extra = first + len(lines)  # ids of the second and later pieces of a line cut by a duplicate
        start = 0
        for k, (line, fields) in enumerate(zip(lines, attrs)):
            n = len(line)
            run = known[start:start + n]
            start += n
            # no zero-length segments (np.concatenate, not np.r_: its indexing machinery took 0.4 s of
            # Campo Grande's 19,500 new lines a run, profiled)
            run = run[np.concatenate(([True], run[1:] != run[:-1]))]
            for j, piece in enumerate(taken.new_pieces(run)):
                street_id = first + k if j == 0 else extra
                extra += j > 0
                streets.append(Street(nodes=tuple(piece.tolist()),
                                      **{"highway": "residential", **fields, "id": street_id}))
        out = self.replace(xy=xy, node_ids=ids, streets=tuple(streets))
        if inherited:
            keys = np.union1d(self._segment_keys(), np.fromiter(taken.added, dtype=np.int64, count=len(taken.added)))
            keys.flags.writeable = False
            out.__dict__["_segment_key_memo"] = keys
        return out


def segment_nodes(streets: Sequence[Street]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each street's node count, (S,) int64, and the two nodes of every segment, (E,) int64 each, street after
    street: the nodes read as one flat array, each node but a street's last starting a segment with the next.

    Why one array: an array per street took most of a segment table's and the segment keys' time on Campo
    Grande (3,600 streets as read, 38 tables and 36 key sets a run)."""
    counts = np.fromiter(map(len, (s.nodes for s in streets)), dtype=np.int64, count=len(streets))
    flat = np.fromiter(chain.from_iterable(s.nodes for s in streets), dtype=np.int64, count=int(counts.sum()))
    starts = np.ones(len(flat), dtype=bool)
    starts[np.cumsum(counts)[counts > 0] - 1] = False
    at = np.flatnonzero(starts)
    return counts, flat[at], flat[at + 1]


def pair_keys(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """One int64 key per undirected node pair (``u[i]``, ``v[i]``): the same for either direction.

    Keys sort as the pairs ``(min, max)`` do (node indices below 2³¹), so sorting, ``np.unique`` and
    ``searchsorted`` over them see the pairs in lexicographic order. The one place the project makes
    undirected segment keys from node indices.
    """
    return np.minimum(u, v) * np.int64(1 << 32) + np.maximum(u, v)


class _SegmentKeys:
    """The undirected segments of a network as integer keys, to keep new streets from doubling one.

    A new line that runs along an existing segment (a major road routed over
    a short street it could not demolish, a join along a street) is cut
    there: two streets on one segment would cross everywhere along it.
    """

    def __init__(self, known: np.ndarray, active: bool = True):
        self.active = active
        self.known = known  #: sorted keys (:func:`pair_keys`) of the network's segments
        self.added: set[int] = set()  #: keys of the new lines' segments

    def new_pieces(self, run: np.ndarray) -> list[np.ndarray]:
        """``run`` split where it follows a known segment (pieces of ≥ 2 nodes); its segments become known."""
        if len(run) < 2:
            return []
        keys = pair_keys(run[:-1], run[1:])
        if not self.active:
            self.added.update(keys.tolist())
            return [run]
        at = np.minimum(np.searchsorted(self.known, keys), max(len(self.known) - 1, 0))
        dup = self.known[at] == keys if len(self.known) else np.zeros(len(keys), dtype=bool)
        dup |= np.fromiter((int(x) in self.added for x in keys.tolist()), dtype=bool, count=len(keys))
        self.added.update(keys.tolist())
        if not dup.any():
            return [run]
        pieces, begin = [], 0
        for i in np.flatnonzero(dup).tolist():
            if i > begin:
                pieces.append(run[begin:i + 1])
            begin = i + 1
        if begin < len(run) - 1:
            pieces.append(run[begin:])
        return pieces


#: A new street's point this close to a node (m) is that node: computed crossings and tee points land
#: within rounding of the node they mean, and a second node there would make a zero-length segment.
SAME_NODE = 1e-3


def _same_points(pts: np.ndarray, tolerance: float = SAME_NODE) -> np.ndarray:
    """A group label per point: points within :data:`SAME_NODE` (transitively) share the label of the
    first of them, so labels increase in order of first appearance."""
    if len(pts) < 2:
        return np.arange(len(pts))
    pairs = close_pairs(pts, tolerance)
    if not len(pairs):
        return np.arange(len(pts))
    label = component_labels(len(pts), pairs[:, 0], pairs[:, 1])
    first = np.full(label.max() + 1, len(pts))
    np.minimum.at(first, label, np.arange(len(pts)))
    return first[label]


def network_from_lines(lines: Sequence, attrs: Sequence[Mapping[str, Any]] | None = None,
                       projection: LocalProjection | None = None) -> StreetNetwork:
    """A network from polylines in metres; equal coordinates become one shared node.

    For hand-built examples, tests and networks read from files that only
    have coordinates. ``attrs`` gives per-line :class:`Street` fields
    (default: residential, layer 0).

    Examples
    --------
    >>> net = network_from_lines([[(0, 0), (100, 0)], [(100, 0), (100, 100)]])
    >>> len(net.xy), [s.nodes for s in net.streets]
    (3, [(0, 1), (1, 2)])
    >>> len(network_from_lines([]).streets)
    0
    """
    proj = projection or LocalProjection(0.0, 0.0)
    arrays = [np.asarray(line, dtype=float).reshape(-1, 2) for line in lines]
    if arrays:
        lon, lat = proj.to_lonlat(*np.concatenate(arrays).T)
        bounds = (float(lon.min()), float(lat.min()), float(lon.max()), float(lat.max()))
    else:
        bounds = (proj.lon0, proj.lat0, proj.lon0, proj.lat0)
    empty = StreetNetwork(xy=np.zeros((0, 2)), node_ids=np.zeros(0, dtype=np.int64), streets=(),
                          context=Context(projection=proj, bounds_lonlat=bounds, bounds_from_header=False))
    return empty.with_new_streets(arrays, attrs or [{}] * len(arrays), same_node=0.0)  # equal coordinates only
