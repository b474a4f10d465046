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
The searches are compiled (:mod:`osm_expand.engine.traffic.trip_search`,
scipy's distances and predecessors, ties included): each touches only what
it reaches within the limit, so the first fill (every segment) costs what
the searches reach, not the batches times the whole graph.

Streets (002 §2, §3.2): new streets are *planned*, take part in the traffic
at once, and are *built* when their traffic reaches ``build_threshold``
(:func:`update_status`). A built street's width follows its traffic after
``width_delay`` years (:func:`update_widths`): lanes for the traffic, each
``lane_width`` wide, plus a sidewalk on each side.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from osm_expand.engine.traffic.residents import residents_from_blocks, residents_from_lots  # re-exported
from osm_expand.engine.traffic.street_widths import update_status, update_widths, width_for_traffic  # re-exported
from osm_expand.engine.traffic.trip_graph import (  # re-exported
    TripGraph,
    shortest_route,
    travel_costs,
    trip_graph,
)
from osm_expand.engine.traffic.trip_options import DistanceDecay, TripOptions  # re-exported
from osm_expand.errors import InputError
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
    volume, and all paths are walked back along the predecessors at once.
    The searches, the entries and the walk are compiled
    (:mod:`osm_expand.engine.traffic.trip_search`): each search touches only
    what it reaches within the limit, with scipy's distances and
    predecessors, and the entries come by source, then by segment ascending,
    as the finite entries of the dense (sources × segments) table did
    (Campo Grande's first fill: 5.2 s CPU with scipy's searches and that table).
    """
    from osm_expand.engine.traffic.trip_search import batch_costs, walk_paths  # numba, only when trips are searched

    e = graph.n_segments
    matrix = graph.matrix
    row, col, cost, back, paths = batch_costs(matrix.indptr, matrix.indices, matrix.data, sources, e,
                                              residents > 0, options.limit)  # no trips to one's own street
    weight = residents[col] * _decay(cost, options)
    pick, count, drawn, stranded = _draws(row, weight, n_trips, len(sources), rng)
    if drawn == 0:
        return [], [], [], 0, stranded
    row, col = row[pick], col[pick]
    people = count * volume
    segment, path = walk_paths(paths, row, col + e * back[pick])  # each path from its destination back
    return [sources[row][path]], [segment], [people[path]], drawn, stranded


def _draws(row: NDArray[np.int64], weight: NDArray[np.float64], n_trips: NDArray[np.int64], n_sources: int,
           rng: np.random.Generator) -> tuple[NDArray[np.int64], NDArray[np.int64], int, int]:
    """Which entries the batch's trips go to: ``n_trips`` draws per source by inverse transform over its row's
    attraction ``weight`` (entries sorted by ``row``; one cumulative sum over the whole batch), the draws of
    one entry merged. Returns the entries drawn, how many times each, the number of draws and the sources
    stranded (nothing attracts them, so they draw nothing)."""
    total = np.bincount(row, weights=weight, minlength=n_sources)
    reach = total > 0
    stranded = int((~reach).sum())
    draws = np.where(reach, n_trips, 0)
    if draws.sum() == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), 0, stranded
    cum = np.cumsum(weight)
    first = np.searchsorted(row, np.arange(n_sources))  # row's first entry (rows are sorted)
    base = np.r_[0.0, cum][first]
    drow = np.repeat(np.arange(n_sources), draws)
    u = base[drow] + rng.random(len(drow)) * total[drow]
    last = first + np.bincount(row, minlength=n_sources) - 1
    pick = np.clip(np.searchsorted(cum, u, side="right"), first[drow], last[drow])
    pick, count = np.unique(pick, return_counts=True)
    return pick, count, int(draws.sum()), stranded


def step_trips(state: TripState, graph: TripGraph, residents: NDArray[np.floating], rng: np.random.Generator,
               *, full: bool = False, options: TripOptions = TripOptions()) -> tuple[TripState, TripReport]:  # noqa: B008 (frozen)
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
