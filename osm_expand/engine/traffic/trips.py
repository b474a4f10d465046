"""Trips inside the town: Weber et al.'s traffic demand model (seed 002 §3.2).

Each street segment ``i`` sends ``n = residents_i · trips_per_resident``
one-person trips a day. A trip's destination ``j`` is sampled with
probability proportional to its *attraction*::

    attraction_ij = residents_j · f(distance_ij)

with ``f`` an exponential ``exp(−d / decay_length)`` or 002's power law
``1/x²``, here ``(1 + d / decay_length)^(−decay_power)`` so that a trip next
door stays finite (002: "f can be 1/x² or an exponential function").
``distance_ij`` is the travel cost of the shortest path between the two
segments' midpoints, in metres of minor street: each segment costs its
length times ``minor_speed / speed`` (major roads are faster), and a turn by
``α`` between consecutive segments costs ``turn_cost · α / 90°`` (002: "we
rate a 90 degree turn as a straight 500 m drive"; linear in the angle, as in
space syntax's angular analysis that 002 cites). Every segment on the path
carries the trip's volume: ``traffic`` is people per day using the street.

Turn costs need an *edge-expanded* graph: one vertex per direction of each
segment (``d = e`` runs ``edges[e, 0] → edges[e, 1]``, ``d = E + e`` back),
an arc from ``d1`` into ``d2`` wherever ``d1`` ends where ``d2`` starts,
weighing half of each segment plus the turn (no U-turns except at dead
ends). One more vertex per segment (``2E + e``) has arcs into both of its
directions, so one Dijkstra row from it gives the cost from the segment's
midpoint in either direction. :func:`trip_graph` builds this once and hands
the same graph back while the network is unchanged.

Incremental re-sampling (002 §3.2): each step, trips are recomputed for all
new segments (no trips yet), all segments whose residents changed, and a
share ``sample_rate`` of the rest; a re-sampled segment's old trips leave
the traffic, its new ones enter. Destinations are drawn independently per
trip (a multinomial over the attractions), identical trips become one path
with a larger volume, and
the volume of one simulated trip grows with the town so the total stays near
``target_trips`` (002: "less discrete trips with a higher volume"). Where
002 keeps a dynamic all-pairs matrix, we run batched
``scipy.sparse.csgraph.dijkstra`` from the sampled segments with
``limit = cutoff · decay_length`` (destinations further away would draw
fewer than ``f(limit)`` of the trips: 5 % of the nearest's weight at the
defaults); 002 itself switched to per-trip Dijkstra above 10,000 streets.

Streets (002 §2, §3.2): new streets are *planned*, take part in the traffic
at once, and are *built* when their traffic reaches ``build_threshold``
(:func:`update_status`). A built street's width follows its traffic after
``width_delay`` years (:func:`update_widths`): lanes for the traffic, each
``lane_width`` wide, plus a sidewalk on each side.
"""
from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive
from osm_expand.model.pieces import Pieces

__all__ = [
    "DistanceDecay",
    "TripGraph",
    "TripOptions",
    "TripReport",
    "TripState",
    "extend_trip_state",
    "new_trip_state",
    "remap_trip_state",
    "residents_from_blocks",
    "residents_from_lots",
    "shortest_route",
    "step_trips",
    "travel_costs",
    "trip_graph",
    "update_status",
    "update_widths",
    "width_for_traffic",
]

#: Arcs weigh at least this (equivalent metres): Dijkstra needs positive weights.
_MIN_ARC = 1e-6


class DistanceDecay(enum.StrEnum):
    """The gravity model's distance function ``f`` (002 §3.2, after McNally)."""

    EXPONENTIAL = "exponential"
    POWER = "power"


@dataclass(frozen=True)
class TripOptions:
    # --- trips (002 §3.2; the paper gives no numbers)
    #: One-way trips a day per resident of a street (002 ``tripsperresidents``).
    #: 2: out and back; residents include people working or shopping there
    #: (002: "how many people will be there during a 24 hour period").
    trips_per_resident: float = 2.0
    #: Simulated trips if every segment were sampled (002: "the total number of
    #: simulated trips is approximately equal to a user specified constant");
    #: one simulated trip carries Σ trips / target_trips people (at least 1).
    target_trips: int = 30_000
    #: ``f``: ``"exponential"`` exp(−d/L) or ``"power"`` (1 + d/L)^−k (002: 1/x²).
    decay: str = "exponential"
    #: L, equivalent metres. 1.5 km: most trips inside a town stay within a
    #: few km, and a typical path also carries one or two 500 m turns.
    decay_length: float = 1500.0
    #: k of the power law (002: 1/x², so 2).
    decay_power: float = 2.0
    #: Dijkstra stops at cutoff · L (f there: e^−3 = 5 %, or 4^−2 = 6 % for the power law).
    cutoff: float = 3.0
    #: Cost of a 90° turn, metres of straight minor street (002: "a 90 degree
    #: turn as a straight 500m drive"); linear in the turn angle.
    turn_cost: float = 500.0
    #: Speed on minor streets, km/h (the cost unit: 1 m of minor street = 1).
    minor_speed: float = 30.0
    #: Speed on major roads, km/h (002: the distance depends on "the type of
    #: street and its speed"); 50 km/h is the urban limit in most of Europe.
    major_speed: float = 50.0
    #: Share of unchanged segments re-sampled each step (002 ``trafficsamplerate``).
    sample_rate: float = 0.08
    #: Residents changed when they differ from those at the last sampling by
    #: more than this share (and by more than one person).
    resident_change: float = 0.05
    #: At most this many segments are re-sampled per step (new, then changed,
    #: then the random share); the rest wait. Keeps a year ≤ 0.3 s at 3,000
    #: segments (one source costs about 0.5 ms of CPU there, 0.9 ms at 10,000);
    #: ``step_trips(full=True)`` ignores it (the first fill).
    max_sources: int = 250
    #: Sources per Dijkstra call: bounds the (batch × 3E) distance matrix.
    batch_sources: int = 64
    #: Residents per m² of block when lots are not known yet (80 per hectare:
    #: a European town's net residential density, counting day-time people).
    density: float = 0.008
    # --- status and widths (002 §2, §3.2)
    #: A planned street is built when its traffic reaches this (people/day;
    #: 002 "a user-defined threshold"): about ten houses' worth of trips.
    build_threshold: float = 50.0
    #: People a day one lane carries (≈ 4,000 vehicles at 1.25 people each,
    #: a comfortable urban lane); lanes = ceil(traffic / lane_capacity).
    lane_capacity: float = 5000.0
    #: Width of a lane, m (the issue: "lanes × 3.5 m + sidewalks").
    lane_width: float = 3.5
    #: Width of one sidewalk, m; a street has two.
    sidewalk_width: float = 2.0
    #: Fewest lanes of a minor street (a one-lane old-town street: 7.5 m).
    min_lanes: int = 1
    #: Fewest lanes of a major road (two-way: 11 m).
    major_min_lanes: int = 2
    #: Most lanes (25 m with sidewalks).
    max_lanes: int = 6
    #: Years between a width's need changing and the street being rebuilt
    #: (002: "the final street width is computed after a user specified time span").
    width_delay: int = 5
    #: Whether built streets may narrow when traffic falls (real streets are
    #: lined with buildings; by default they only widen).
    shrink: bool = False

    def __post_init__(self) -> None:
        try:
            DistanceDecay(self.decay)
        except ValueError:
            raise InputError(f"trips.decay must be one of {', '.join(d.value for d in DistanceDecay)}, "
                             f"got {self.decay!r}") from None
        require_positive(self, ("decay_length", "decay_power", "cutoff", "minor_speed", "major_speed",
                                "lane_capacity", "lane_width", "target_trips", "max_sources", "batch_sources"))
        for key in ("trips_per_resident", "turn_cost", "resident_change", "density",
                    "build_threshold", "sidewalk_width", "width_delay"):
            if not getattr(self, key) >= 0:
                raise InputError(f"trips.{key} must be ≥ 0, got {getattr(self, key)}")
        if not 0 <= self.sample_rate <= 1:
            raise InputError(f"trips.sample_rate is a share in [0, 1], got {self.sample_rate}")
        if not 1 <= self.min_lanes <= self.max_lanes or not 1 <= self.major_min_lanes <= self.max_lanes:
            raise InputError(f"trips: need 1 ≤ min_lanes, major_min_lanes ≤ max_lanes, got "
                             f"{self.min_lanes}, {self.major_min_lanes}, {self.max_lanes}")

    @property
    def limit(self) -> float:
        """Dijkstra's search radius, equivalent metres."""
        return self.cutoff * self.decay_length


# --------------------------------------------------------------------------- the graph

@dataclass(frozen=True, eq=False)
class TripGraph:
    """The edge-expanded street graph with turn costs (see the module docstring).

    Attributes
    ----------
    edges : (E, 2) int64
        Segment end nodes, as given.
    ends_xy : (E, 4) float64
        Both ends' coordinates (to notice moved nodes).
    length : (E,) float64
        Segment lengths, m.
    major : (E,) bool
        Major roads (faster).
    cost : (E,) float64
        Traversal cost, equivalent metres of minor street.
    matrix : scipy.sparse.csr_matrix, (3E, 3E)
        Arc weights: directions ``0..2E-1``, midpoint starts ``2E..3E-1``.
    settings : tuple
        The options that shaped the weights (turn cost, speeds).
    """

    edges: NDArray[np.int64]
    ends_xy: NDArray[np.float64]
    length: NDArray[np.float64]
    major: NDArray[np.bool_]
    cost: NDArray[np.float64]
    matrix: sparse.csr_matrix
    settings: tuple[float, float, float]

    @property
    def n_segments(self) -> int:
        return len(self.edges)


def _settings(options: TripOptions) -> tuple[float, float, float]:
    return (options.turn_cost, options.minor_speed, options.major_speed)


def _segment_inputs(xy: NDArray[np.floating], edges: NDArray[np.integer], length: NDArray[np.floating] | None,
                    major: NDArray[np.bool_] | None,
                    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if len(edges) and (edges.min() < 0 or edges.max() >= len(xy)):
        raise InputError("trips: an edge refers to a node that does not exist")
    ends = np.concatenate([xy[edges[:, 0]], xy[edges[:, 1]]], axis=1) if len(edges) else np.zeros((0, 4))
    if length is None:
        length = np.hypot(ends[:, 2] - ends[:, 0], ends[:, 3] - ends[:, 1])
    length = np.asarray(length, dtype=np.float64).reshape(-1)
    major = np.zeros(len(edges), bool) if major is None else np.asarray(major, dtype=bool).reshape(-1)
    if len(length) != len(edges) or len(major) != len(edges):
        raise InputError(f"trips: {len(edges)} edges but {len(length)} lengths and {len(major)} major flags")
    if len(length) and not (np.all(np.isfinite(length)) and length.min() >= 0):
        raise InputError("trips: segment lengths must be finite and ≥ 0")
    return edges, ends, length, major


def _build(edges: NDArray[np.int64], ends: NDArray[np.float64], length: NDArray[np.float64],
           major: NDArray[np.bool_], options: TripOptions) -> TripGraph:
    e = len(edges)
    cost = length * np.where(major, options.minor_speed / options.major_speed, 1.0)
    tail = np.r_[edges[:, 0], edges[:, 1]]
    head = np.r_[edges[:, 1], edges[:, 0]]
    n_nodes = int(max(tail.max(initial=-1), head.max(initial=-1))) + 1
    by_tail = np.argsort(tail, kind="stable")
    start = np.searchsorted(tail[by_tail], np.arange(n_nodes + 1))
    degree = np.diff(start)
    # every (d1 into node v) × (d2 out of v)
    fan = degree[head] if e else np.zeros(0, np.int64)
    d1 = np.repeat(np.arange(2 * e), fan)
    offset = np.arange(len(d1)) - np.repeat(np.cumsum(fan) - fan, fan)
    d2 = by_tail[start[head[d1]] + offset]
    reverse = np.where(d1 < e, d1 + e, d1 - e)
    keep = (d2 != reverse) | (degree[head[d1]] == 1)  # U-turns only at dead ends
    d1, d2 = d1[keep], d2[keep]
    vec = np.r_[ends[:, 2:] - ends[:, :2], ends[:, :2] - ends[:, 2:]]
    norm = np.hypot(vec[:, 0], vec[:, 1])
    unit = vec / np.where(norm > 0, norm, 1.0)[:, None]
    turn = np.arccos(np.clip((unit[d1] * unit[d2]).sum(axis=1), -1.0, 1.0))
    dcost = np.r_[cost, cost]
    weight = np.maximum(dcost[d1] / 2 + dcost[d2] / 2 + options.turn_cost * turn / (np.pi / 2), _MIN_ARC)
    starts = np.arange(2 * e, 3 * e)
    rows = np.r_[d1, starts, starts]
    cols = np.r_[d2, np.arange(e), np.arange(e, 2 * e)]
    data = np.r_[weight, np.full(2 * e, _MIN_ARC)]
    matrix = sparse.csr_matrix((data, (rows, cols)), shape=(3 * e, 3 * e))
    frozen = (np.array(edges), np.array(ends), np.array(length), np.array(major), np.array(cost))
    for a in frozen:
        a.flags.writeable = False
    return TripGraph(*frozen, matrix, _settings(options))


def trip_graph(xy: NDArray[np.floating], edges: NDArray[np.integer], *,
               length: NDArray[np.floating] | None = None, major: NDArray[np.bool_] | None = None,
               previous: TripGraph | None = None, options: TripOptions = TripOptions()) -> TripGraph:
    """The edge-expanded graph of the street network, reused when nothing changed.

    Parameters
    ----------
    xy : (N, 2) float
        Node positions, m.
    edges : (E, 2) int
        Segment end nodes.
    length : (E,) float, optional
        Segment lengths along their shape, m (default: straight distance).
    major : (E,) bool, optional
        Major roads (travel at ``major_speed``); default all minor.
    previous : TripGraph, optional
        Last year's graph: returned as it is when edges, end points,
        lengths, classes and options are the same.
    options : TripOptions

    Returns
    -------
    TripGraph
    """
    edges, ends, length, major = _segment_inputs(xy, edges, length, major)
    if (previous is not None and previous.settings == _settings(options)
            and np.array_equal(previous.edges, edges) and np.array_equal(previous.ends_xy, ends)
            and np.array_equal(previous.length, length) and np.array_equal(previous.major, major)):
        return previous
    return _build(edges, ends, length, major, options)


def travel_costs(graph: TripGraph, source: int, *, limit: float = np.inf) -> NDArray[np.float64]:
    """Travel cost from segment ``source``'s midpoint to every segment's midpoint.

    Parameters
    ----------
    graph : TripGraph
    source : int
        Segment id.
    limit : float
        Stop searching beyond this cost (equivalent metres).

    Returns
    -------
    (E,) float64
        Equivalent metres (``inf`` beyond ``limit`` or unreachable); 0 at the source.
    """
    e = graph.n_segments
    dist = dijkstra(graph.matrix, directed=True, indices=2 * e + int(source), limit=limit)
    out = np.minimum(dist[:e], dist[e:2 * e])
    out[int(source)] = 0.0
    return out


def shortest_route(graph: TripGraph, source: int, target: int) -> NDArray[np.int64]:
    """Segments of the cheapest path (turns included) from ``source`` to ``target``.

    Parameters
    ----------
    graph : TripGraph
    source, target : int
        Segment ids.

    Returns
    -------
    (k,) int64
        Segment ids from ``source`` to ``target``, both included; empty when
        ``target`` cannot be reached.
    """
    e = graph.n_segments
    if not (0 <= source < e and 0 <= target < e):
        raise InputError(f"trips: segments must lie in 0..{e - 1}, got {source} and {target}")
    dist, pred = dijkstra(graph.matrix, directed=True, indices=2 * e + int(source), return_predecessors=True)
    if source == target:
        return np.array([source], dtype=np.int64)
    cur = target if dist[target] <= dist[e + target] else e + target
    if not np.isfinite(dist[cur]):
        return np.zeros(0, dtype=np.int64)
    path = []
    while 0 <= cur < 2 * e:
        path.append(cur % e)
        cur = pred[cur]
    return np.array(path[::-1], dtype=np.int64)


# --------------------------------------------------------------------------- residents

def residents_from_lots(lot_residents: NDArray[np.floating], lot_segment: NDArray[np.integer],
                        n_segments: int) -> NDArray[np.float64]:
    """``street[i].residents = Σ lot[j].residents`` over the lots facing it (002 §3.2).

    Parameters
    ----------
    lot_residents : (L,) float
        People per lot over 24 hours (residents, workers, visitors).
    lot_segment : (L,) int
        The segment each lot has its access from (-1: none, ignored).
    n_segments : int

    Returns
    -------
    (n_segments,) float64
    """
    res = np.asarray(lot_residents, dtype=np.float64).reshape(-1)
    seg = np.asarray(lot_segment, dtype=np.int64).reshape(-1)
    if len(res) != len(seg):
        raise InputError(f"trips: {len(res)} lot residents but {len(seg)} lot segments")
    ok = seg >= 0
    if ok.any() and seg[ok].max() >= n_segments:
        raise InputError(f"trips: a lot faces segment {seg[ok].max()}, beyond 0..{n_segments - 1}")
    return np.bincount(seg[ok], weights=res[ok], minlength=n_segments).astype(np.float64)


def residents_from_blocks(block_area: NDArray[np.floating],
                          block_segments: Sequence[Sequence[int]] | Sequence[NDArray[np.integer]],
                          segment_length: NDArray[np.floating], *,
                          options: TripOptions = TripOptions()) -> NDArray[np.float64]:
    """Residents per segment before lots exist: block area × ``density``, shared by side length.

    Parameters
    ----------
    block_area : (B,) float
        Block areas, m² (built-up blocks only; leave out water and fields).
    block_segments : sequence of B int sequences
        The segments bounding each block.
    segment_length : (E,) float
        Segment lengths, m.
    options : TripOptions
        ``density`` (people per m²).

    Returns
    -------
    (E,) float64
        A segment between two blocks collects from both.
    """
    area = np.asarray(block_area, dtype=np.float64).reshape(-1)
    seglen = np.asarray(segment_length, dtype=np.float64).reshape(-1)
    if len(area) != len(block_segments):
        raise InputError(f"trips: {len(area)} block areas but {len(block_segments)} segment lists")
    sizes = np.array([len(s) for s in block_segments], dtype=np.int64)
    if sizes.sum() == 0:
        return np.zeros(len(seglen))
    segs = np.concatenate([np.asarray(s, dtype=np.int64).reshape(-1) for s in block_segments])
    if segs.min() < 0 or segs.max() >= len(seglen):
        raise InputError(f"trips: a block lists a segment outside 0..{len(seglen) - 1}")
    block = np.repeat(np.arange(len(area)), sizes)
    side = seglen[segs]
    perimeter = np.bincount(block, weights=side, minlength=len(area))
    share = side / np.where(perimeter[block] > 0, perimeter[block], 1.0)
    share = np.where(perimeter[block] > 0, share, 1.0 / np.maximum(sizes[block], 1))
    people = area[block] * options.density * share
    return np.bincount(segs, weights=people, minlength=len(seglen)).astype(np.float64)


# --------------------------------------------------------------------------- the state

@dataclass(frozen=True, eq=False)
class TripState:
    """The trips of every segment and the traffic they make.

    Attributes
    ----------
    contributions : scipy.sparse.csr_matrix, (E, E)
        Row ``i``: people a day that segment ``i``'s trips put on each segment.
    sampled : (E,) bool
        Segments whose trips have been computed at least once.
    sampled_residents : (E,) float64
        Residents when each segment was last sampled.
    traffic : (E,) float64
        ``street[i].traffic``: people a day on each segment (column sums).
    """

    contributions: sparse.csr_matrix
    sampled: NDArray[np.bool_]
    sampled_residents: NDArray[np.float64]
    traffic: NDArray[np.float64]

    @property
    def n_segments(self) -> int:
        return len(self.sampled)


@dataclass(frozen=True)
class TripReport:
    """One step's trip sampling, for the ``--json`` report.

    Attributes
    ----------
    sources : int
        Segments re-sampled this step (new + changed + random share).
    new, changed : int
        Of which new segments and segments with changed residents.
    deferred : int
        Segments due but left for a later step (``max_sources``).
    trips : int
        Simulated trips sampled this step.
    people : float
        People a day those trips stand for (trips × volume).
    volume : float
        People per simulated trip.
    stranded : int
        Sampled segments with residents but no destination within reach.
    """

    sources: int
    new: int
    changed: int
    deferred: int
    trips: int
    people: float
    volume: float
    stranded: int

    def as_dict(self) -> dict[str, float | int]:
        """Plain JSON-ready values."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _readonly(a: NDArray) -> NDArray:
    a.flags.writeable = False
    return a


def _state(contributions: sparse.csr_matrix, sampled: NDArray[np.bool_],
           residents: NDArray[np.float64]) -> TripState:
    contributions = contributions.tocsr()
    contributions.eliminate_zeros()
    traffic = np.asarray(contributions.sum(axis=0)).reshape(-1).astype(np.float64)
    return TripState(contributions, _readonly(np.array(sampled, bool)),
                     _readonly(np.array(residents, np.float64)), _readonly(traffic))


def new_trip_state(n_segments: int) -> TripState:
    """No trips yet over ``n_segments`` segments (all of them new)."""
    n = int(n_segments)
    if n < 0:
        raise InputError(f"trips: n_segments must be ≥ 0, got {n}")
    return _state(sparse.csr_matrix((n, n)), np.zeros(n, bool), np.zeros(n))


def extend_trip_state(state: TripState, n_segments: int) -> TripState:
    """The same trips over a segment table grown by appending segments (ids kept)."""
    n, old = int(n_segments), state.n_segments
    if n < old:
        raise InputError(f"trips: n_segments cannot shrink ({old} → {n}); use remap_trip_state")
    c = state.contributions.tocoo()
    grown = sparse.csr_matrix((c.data, (c.row, c.col)), shape=(n, n))
    return _state(grown, np.r_[state.sampled, np.zeros(n - old, bool)],
                  np.r_[state.sampled_residents, np.zeros(n - old)])


def remap_trip_state(state: TripState, pieces: Pieces | Sequence[Sequence[int]], n_segments: int) -> TripState:
    """Follow the segment table through a rebuild: old segment ``i`` became ``pieces[i]``.

    Trips through a split segment now run through all its pieces; a
    segment kept one-to-one keeps its own trips; the trips *from* a split or
    deleted segment are dropped and its pieces count as new (re-sampled at
    the next step), as are segments no old one maps to.

    Parameters
    ----------
    state : TripState
    pieces : Pieces, or a sequence of length ``state.n_segments`` of int sequences
        New ids of each old segment (``[]`` when deleted).
    n_segments : int
        Size of the new table.

    Returns
    -------
    TripState
    """
    old, n = state.n_segments, int(n_segments)
    pieces = Pieces.of(pieces)
    if len(pieces) != old:
        raise InputError(f"trips: remap needs {old} entries, got {len(pieces)}")
    sizes, flat = pieces.sizes, pieces.flat
    if len(flat) and (flat.min() < 0 or flat.max() >= n):
        raise InputError(f"trips: remap points outside 0..{n - 1}")
    src = np.repeat(np.arange(old), sizes)
    columns = sparse.csr_matrix((np.ones(len(flat)), (src, flat)), shape=(old, n))
    one = sizes == 1
    kept_old = np.flatnonzero(one)
    kept_new = flat[np.cumsum(sizes)[one] - 1]
    rows = sparse.csr_matrix((np.ones(len(kept_old)), (kept_new, kept_old)), shape=(n, old))
    sampled = np.zeros(n, bool)
    residents = np.zeros(n)
    sampled[kept_new] = state.sampled[kept_old]
    residents[kept_new] = state.sampled_residents[kept_old]
    return _state(rows @ state.contributions @ columns, sampled, residents)


# --------------------------------------------------------------------------- one step

def _decay(cost: NDArray[np.float64], options: TripOptions) -> NDArray[np.float64]:
    if options.decay == DistanceDecay.EXPONENTIAL:
        return np.exp(-cost / options.decay_length)
    return (1.0 + cost / options.decay_length) ** (-options.decay_power)


def _due(state: TripState, residents: NDArray[np.float64], rng: np.random.Generator,
         options: TripOptions, full: bool) -> tuple[NDArray[np.int64], int, int, int]:
    """Segments to re-sample this step (sorted) and how many are new, changed and deferred.

    Priority when more are due than ``max_sources``: new, then changed, then
    the random share, each group in random order.
    """
    new = ~state.sampled
    delta = np.abs(residents - state.sampled_residents)
    changed = state.sampled & (delta > np.maximum(1.0, options.resident_change * state.sampled_residents))
    share = rng.random(len(residents)) < options.sample_rate
    if full:
        return np.arange(len(residents), dtype=np.int64), int(new.sum()), int(changed.sum()), 0
    groups = [np.flatnonzero(new), np.flatnonzero(changed),
              np.flatnonzero(state.sampled & ~changed & share)]
    order = np.concatenate([g[rng.permutation(len(g))] for g in groups])
    urgent = len(groups[0]) + len(groups[1])
    taken = order[:options.max_sources]
    deferred = max(0, min(urgent, len(order)) - len(taken))
    return np.sort(taken).astype(np.int64), int(new[taken].sum()), int(changed[taken].sum()), deferred


def _sample_batch(graph: TripGraph, sources: NDArray[np.int64], n_trips: NDArray[np.int64],
                  residents: NDArray[np.float64], volume: float, rng: np.random.Generator,
                  options: TripOptions) -> tuple[list[NDArray], list[NDArray], list[NDArray], int, int]:
    """Destinations and paths for one batch of sources: (source, segment, people) triples.

    Destinations are drawn by inverse transform over each row's attraction
    (one cumulative sum over the reachable entries of the whole batch), the
    draws of one source to one destination become one path of their summed
    volume, and all paths are walked back along the predecessor arrays at once.
    """
    e = graph.n_segments
    dist, pred = dijkstra(graph.matrix, directed=True, indices=2 * e + sources,
                          return_predecessors=True, limit=options.limit)
    forward, backward = dist[:, :e], dist[:, e:2 * e]
    cost = np.minimum(forward, backward)
    cost[np.arange(len(sources)), sources] = np.inf  # no trips to one's own street
    row, col = np.nonzero(np.isfinite(cost) & (residents > 0)[None, :])
    weight = residents[col] * _decay(cost[row, col], options)
    total = np.bincount(row, weights=weight, minlength=len(sources))
    reach = total > 0
    stranded = int((~reach).sum())
    draws = np.where(reach, n_trips, 0)
    if draws.sum() == 0:
        return [], [], [], 0, stranded
    cum = np.cumsum(weight)
    first = np.searchsorted(row, np.arange(len(sources)))  # row's first entry (rows are sorted)
    base = np.r_[0.0, cum][first]
    drow = np.repeat(np.arange(len(sources)), draws)
    u = base[drow] + rng.random(len(drow)) * total[drow]
    last = first + np.bincount(row, minlength=len(sources)) - 1
    pick = np.clip(np.searchsorted(cum, u, side="right"), first[drow], last[drow])
    pick, count = np.unique(pick, return_counts=True)
    row, col = row[pick], col[pick]
    people = count * volume
    cur = col + e * (backward[row, col] < forward[row, col])
    src_out, seg_out, vol_out = [], [], []
    for _ in range(2 * e + 1):  # a path visits each direction at most once
        if len(cur) == 0:
            break
        src_out.append(sources[row])
        seg_out.append(cur % e)
        vol_out.append(people)
        nxt = pred[row, cur]
        on = (nxt >= 0) & (nxt < 2 * e)
        row, cur, people = row[on], nxt[on], people[on]
    return src_out, seg_out, vol_out, int(draws.sum()), stranded


def step_trips(state: TripState, graph: TripGraph, residents: NDArray[np.floating], rng: np.random.Generator,
               *, full: bool = False, options: TripOptions = TripOptions()) -> tuple[TripState, TripReport]:
    """One step of 002 §3.2: re-sample trips of new, changed and some other segments.

    Parameters
    ----------
    state : TripState
        Last step's trips, over the same segment table as ``graph`` (grow it
        with :func:`extend_trip_state` or :func:`remap_trip_state` first).
    graph : TripGraph
        From :func:`trip_graph`.
    residents : (E,) float
        People per segment over 24 hours (:func:`residents_from_lots`, or
        :func:`residents_from_blocks` before lots exist).
    rng : numpy.random.Generator
        Chooses the random share, trip counts (stochastic rounding) and destinations.
    full : bool
        Re-sample every segment, ignoring ``max_sources`` (the first fill).
    options : TripOptions

    Returns
    -------
    state : TripState
        ``state.traffic`` is people a day per segment.
    report : TripReport
    """
    e = graph.n_segments
    res = np.asarray(residents, dtype=np.float64).reshape(-1)
    if state.n_segments != e or len(res) != e:
        raise InputError(f"trips: graph has {e} segments, state {state.n_segments}, residents {len(res)}")
    if e and not (np.all(np.isfinite(res)) and res.min() >= 0):
        raise InputError("trips: residents must be finite and ≥ 0")
    sources, n_new, n_changed, deferred = _due(state, res, rng, options, full)
    demand = res * options.trips_per_resident
    volume = max(1.0, float(demand.sum()) / options.target_trips)
    expected = demand[sources] / volume
    n_trips = np.floor(expected).astype(np.int64)
    n_trips += rng.random(len(sources)) < expected - n_trips  # stochastic rounding
    active = sources[n_trips > 0]
    active_trips = n_trips[n_trips > 0]
    src_parts, seg_parts, vol_parts = [], [], []
    trips = stranded = 0
    for lo in range(0, len(active), options.batch_sources):
        hi = lo + options.batch_sources
        s, g, v, t, st = _sample_batch(graph, active[lo:hi], active_trips[lo:hi], res, volume, rng, options)
        src_parts += s
        seg_parts += g
        vol_parts += v
        trips += t
        stranded += st
    if src_parts:
        fresh = sparse.csr_matrix((np.concatenate(vol_parts), (np.concatenate(src_parts),
                                                               np.concatenate(seg_parts))), shape=(e, e))
    else:
        fresh = sparse.csr_matrix((e, e))
    keep = np.ones(e)
    keep[sources] = 0.0
    contributions = sparse.diags(keep) @ state.contributions + fresh
    sampled = state.sampled.copy()
    sampled[sources] = True
    sampled_res = state.sampled_residents.copy()
    sampled_res[sources] = res[sources]
    report = TripReport(sources=len(sources), new=n_new, changed=n_changed, deferred=deferred,
                        trips=trips, people=trips * volume, volume=volume, stranded=stranded)
    return _state(contributions, sampled, sampled_res), report


# --------------------------------------------------------------------------- streets: status and width

def update_status(built: NDArray[np.bool_], traffic: NDArray[np.floating], built_year: NDArray[np.integer], *,
                  year: int, options: TripOptions = TripOptions()) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
    """Planned streets with enough traffic are built (002 §2, §3.2).

    Parameters
    ----------
    built : (E,) bool
        True for built streets, False for planned ones.
    traffic : (E,) float
        People a day (:attr:`TripState.traffic`).
    built_year : (E,) int
        Year each was built (any value for planned streets).
    year : int
        The current year.
    options : TripOptions
        ``build_threshold``.

    Returns
    -------
    built : (E,) bool
    built_year : (E,) int64
        ``year`` for the streets built now.
    """
    b = np.asarray(built, dtype=bool).reshape(-1)
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    y = np.asarray(built_year, dtype=np.int64).reshape(-1)
    if not len(b) == len(t) == len(y):
        raise InputError(f"trips: {len(b)} status flags, {len(t)} traffic values, {len(y)} years")
    now = ~b & (t >= options.build_threshold)
    return b | now, np.where(now, int(year), y)


def width_for_traffic(traffic: NDArray[np.floating], major: NDArray[np.bool_] | None = None, *,
                      options: TripOptions = TripOptions()) -> NDArray[np.float64]:
    """Street width the traffic asks for: lanes · lane_width + 2 · sidewalk_width.

    ``lanes = ceil(traffic / lane_capacity)``, clipped to
    [min_lanes (major_min_lanes for major roads), max_lanes].

    Parameters
    ----------
    traffic : (E,) float
        People a day.
    major : (E,) bool, optional
        Major roads (at least ``major_min_lanes``).
    options : TripOptions

    Returns
    -------
    (E,) float64
        Metres.
    """
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    low = np.full(len(t), options.min_lanes)
    if major is not None:
        low = np.where(np.asarray(major, dtype=bool).reshape(-1), options.major_min_lanes, low)
    lanes = np.clip(np.ceil(np.maximum(t, 0.0) / options.lane_capacity), low, options.max_lanes)
    return lanes * options.lane_width + 2 * options.sidewalk_width


def update_widths(width: NDArray[np.floating], traffic: NDArray[np.floating], built: NDArray[np.bool_],
                  built_year: NDArray[np.integer], pending_since: NDArray[np.integer], *, year: int,
                  major: NDArray[np.bool_] | None = None,
                  options: TripOptions = TripOptions()) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Widths follow traffic after ``width_delay`` years (002 §3.2).

    - Planned streets take the width their traffic asks for at once (the plan).
    - A street built this year gets a *temporary* width from its traffic
      now, and its final width ``width_delay`` years later (002).
    - A built street whose wanted width (only wider, unless ``shrink``)
      differs from its width starts a wait; if it still differs after
      ``width_delay`` years it takes the then wanted width. A wait ends
      early, unchanged, when the need goes away.

    Parameters
    ----------
    width : (E,) float
        Current widths, m.
    traffic : (E,) float
        People a day.
    built : (E,) bool
        Built (True) or planned.
    built_year : (E,) int
        Year each street was built. Give the real town's streets a year
        before the first simulated one: a street "built this year" gets a
        temporary width from its traffic, which would overwrite a mapped width.
    pending_since : (E,) int
        Year a wait started, -1 for none (start with all -1).
    year : int
        The current year.
    major : (E,) bool, optional
        Major roads (see :func:`width_for_traffic`).
    options : TripOptions

    Returns
    -------
    width : (E,) float64
    pending_since : (E,) int64
    """
    w = np.asarray(width, dtype=np.float64).reshape(-1)
    b = np.asarray(built, dtype=bool).reshape(-1)
    by = np.asarray(built_year, dtype=np.int64).reshape(-1)
    pend = np.asarray(pending_since, dtype=np.int64).reshape(-1).copy()
    t = np.asarray(traffic, dtype=np.float64).reshape(-1)
    if not len(w) == len(b) == len(by) == len(pend) == len(t):
        raise InputError("trips: width, traffic, built, built_year and pending_since differ in length")
    target = width_for_traffic(t, major, options=options)
    want = target if options.shrink else np.maximum(target, w)
    out = w.copy()
    planned = ~b
    out[planned] = target[planned]
    pend[planned] = -1
    fresh = b & (by == year)
    out[fresh] = target[fresh]
    pend[fresh] = year
    old = b & ~fresh
    differs = old & ~np.isclose(want, w)
    from_build = old & (pend >= 0) & (by == pend)  # the final width after the temporary one
    pend[old & ~differs & ~from_build] = -1
    pend[differs & (pend < 0)] = year
    due = old & (pend >= 0) & (year - pend >= options.width_delay)
    out[due] = want[due]
    pend[due] = -1
    return out, pend
