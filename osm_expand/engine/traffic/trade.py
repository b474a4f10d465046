"""Trade routes between neighbouring cities and their traffic (seed 003 §3.4, Algorithm 2).

Every pair ``p_i`` of neighbouring cities keeps a list ``P_i`` of *trade
routes*: paths over major-road segments, each carrying a traffic
``T(P_{i,j})`` (initially 0). A segment can lie on many routes, of this and
other pairs, so traffic is also kept per segment: ``T(s)`` is the sum over
the routes through ``s``. With ``O2`` a scalar (003; 000 §4.2.8 calls it
``c1`` and uses 100 per metre, so a 6 m street carries 600 units)::

    T_A(s)       = O2 · WIDTH(s) − T(s)                  available on a segment
    T_A(P_{i,j}) = min over s ∈ P_{i,j} of T_A(s)        available on a route
    T_A(P_i)     = saturate the routes of P_i one by one  available to the pair
                   and sum what each took; then restore

Algorithm 2 for one pair, as implemented by :func:`redistribute`::

    T(P_i) := 0                      the pair's own traffic leaves its segments
    if T_A(P_i) < t(t):              shortfall = t(t) − T_A(P_i) > 0
        (the engine proposes P_A over existing major roads and P_B with new
         roads, keeps the cheaper, adds it with add_route, and calls
         redistribute again)
    GREEDILYREDISTRIBUTE(t(t), P_i)  shortest route first, each takes
                                     min(what is left, T_A(route))

What the seed leaves open, and the choice made here:

- *The order of saturation in T_A(P_i).* Not given; we use the order of the
  greedy redistribution (route length ascending, ties by the order routes
  were added), so T_A(P_i) is exactly what GREEDILYREDISTRIBUTE can place and
  the shortfall is ``t(t) − T_A(P_i)``.
- *Increase vs total.* §3.1 speaks of the increase ``t(t) − t(t−1)``;
  Algorithm 2 resets the pair and redistributes the whole ``t(t)``. Both
  agree: :func:`assign_increase` adds the increase to the pair's demand
  (the last ``t`` asked of it, met or not) and runs Algorithm 2 on the sum.
  A shortfall the major-road step could not resolve is therefore asked for
  again next year rather than forgotten.
- *Notation.* The seed writes the saturation once with a lower-case
  ``t_A(P_{i,j}) = 0``; it is the same ``T_A`` (the text's own definition
  just before it), not the traffic function ``t(t)``.
- *Capacity below the traffic* (after a width shrinks, a segment splits or
  O2 changes with the era): a route's availability is clamped at 0, never
  negative; such routes are counted as over capacity in the report.

:mod:`osm_expand.engine.traffic.trade_routes` finds the routes: each pair's
first route ``P_{i,1}`` over the real town's major roads (003 §3.2.2: found,
not built, where the roads exist) and the same minimum-weight search as the
core of §3.4.2's ``P_A`` over major roads with room. :func:`trade_year`
runs Algorithm 2 over all pairs with the major-road step as a callback.

The state is immutable: every operation returns a new :class:`TradeState`.
Segment ids are positions in the caller's segment table; when that table
changes other than by appending, map the routes with :func:`remap_segments`.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np
from numpy.typing import NDArray

from osm_expand.errors import InputError
from osm_expand.model.options import require_positive
from osm_expand.model.pieces import Pieces

__all__ = [
    "TradeOptions",
    "TradeReport",
    "TradeRoute",
    "TradeState",
    "TradeYear",
    "add_route",
    "assign_increase",
    "available_capacity",
    "draw_traffic_factor",
    "extend_segments",
    "new_trade_state",
    "pair_capacity",
    "redistribute",
    "remap_segments",
    "route_capacity",
    "segment_capacity",
    "segments_with_room",
    "trade_report",
    "trade_year",
]

Pair = tuple[int, int]

#: Relative tolerance for "is there room": 1e-9 of the traffic scale.
_EPS = 1e-9


@dataclass(frozen=True)
class TradeOptions:
    #: Traffic units one metre of street width carries (003 §3.4.2 ``O2``;
    #: 000 §4.2.8 ``c1 = 100``: a 6 m street carries 600 units).
    o2: float = 100.0
    #: 003 §3.5: the city's traffic factor ``b`` in ``t(t) = b·G(t)`` is drawn
    #: uniformly from (b_min, b_max) = (0.7, 1.3).
    b_min: float = 0.7
    #: See ``b_min``.
    b_max: float = 1.3

    def __post_init__(self) -> None:
        require_positive(self, ("o2",))
        if not 0 <= self.b_min <= self.b_max:
            raise InputError(f"trade: need 0 ≤ b_min ≤ b_max, got {self.b_min}, {self.b_max}")


@dataclass(frozen=True, eq=False)
class TradeRoute:
    """One trade route ``P_{i,j}``: a path over segments, its length and its traffic.

    Attributes
    ----------
    pair : (u, v) with u < v
        The neighbouring cities it joins (indices into the neighbour list).
    segments : (k,) int64, read-only
        Segment ids in path order (each at most once).
    length : float
        Route length in metres (the greedy order key).
    traffic : float
        ``T(P_{i,j})``, traffic units.
    """

    pair: Pair
    segments: NDArray[np.int64]
    length: float
    traffic: float = 0.0


@dataclass(frozen=True, eq=False)
class TradeState:
    """All trade routes of a town and each pair's demand ``t``.

    Attributes
    ----------
    n_segments : int
        Length of the segment table the route ids index.
    routes : tuple of TradeRoute
        In the order they were added.
    demand : mapping pair → float
        The ``t(t)`` last asked of each pair (met or not).
    """

    n_segments: int
    routes: tuple[TradeRoute, ...] = ()
    demand: Mapping[Pair, float] = field(default_factory=lambda: MappingProxyType({}))

    def pair_routes(self, pair: Pair) -> list[int]:
        """Indices into ``routes`` of the pair's routes, in greedy order (length, then age)."""
        key = _pair(pair)
        own = [k for k, r in enumerate(self.routes) if r.pair == key]
        return sorted(own, key=lambda k: self.routes[k].length)  # stable: ties keep age order

    def carried(self, pair: Pair) -> float:
        """Traffic the pair's routes carry now, ``Σ_j T(P_{i,j})``."""
        key = _pair(pair)
        return float(sum(r.traffic for r in self.routes if r.pair == key))

    def segment_traffic(self) -> NDArray[np.float64]:
        """``T(s)`` for every segment: (n_segments,) float64, summed over all routes."""
        return _traffic_of(self.routes, self.n_segments)


@dataclass(frozen=True)
class TradeReport:
    """A snapshot of the trade routes for the ``--json`` report.

    Attributes
    ----------
    pairs, routes : int
        Pairs with at least one route; routes.
    demand, carried, unmet : float
        Σ of the pairs' demand ``t``, of the traffic placed, and their difference.
    pairs_short : int
        Pairs whose routes cannot carry their demand (capacity ran out).
    routes_at_capacity : int
        Routes with no capacity left (``T_A(P_{i,j}) ≤ 0``).
    routes_over_capacity : int
        Routes over a segment whose traffic exceeds ``O2·width``.
    segments_over_capacity : int
        Such segments.
    """

    pairs: int
    routes: int
    demand: float
    carried: float
    unmet: float
    pairs_short: int
    routes_at_capacity: int
    routes_over_capacity: int
    segments_over_capacity: int

    def as_dict(self) -> dict[str, float | int]:
        """Plain JSON-ready values."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class TradeYear:
    """What one year of Algorithm 2 did, for the ``--json`` report (sum these over an era).

    Attributes
    ----------
    pairs : int
        Pairs simulated.
    short : int
        Pairs whose routes could not carry ``t(t)`` (capacity ran out).
    shortfall : float
        Σ of their shortfalls, traffic units.
    routes_added : int
        New trade routes the major-road step supplied (P_A or P_B).
    unresolved : int
        Pairs still short at the end of the year.
    """

    pairs: int = 0
    short: int = 0
    shortfall: float = 0.0
    routes_added: int = 0
    unresolved: int = 0

    def as_dict(self) -> dict[str, float | int]:
        """Plain JSON-ready values."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def __add__(self, other: TradeYear) -> TradeYear:
        return TradeYear(*(getattr(self, k) + getattr(other, k) for k in self.__dataclass_fields__))


#: The major-road step, as :func:`trade_year` calls it: given the state (the
#: pair's routes saturated), the pair and its shortfall, return the state with
#: the winning route added (segment table remapped or extended as needed)
#: and the new per-segment capacities, or None when nothing can be built.
Proposer = Callable[[TradeState, Pair, float], "tuple[TradeState, NDArray[np.float64]] | None"]


# --------------------------------------------------------------------------- helpers

def _pair(pair: Sequence[int]) -> Pair:
    u, v = (int(p) for p in pair)
    if u == v:
        raise InputError(f"trade: a pair joins two different cities, got ({u}, {v})")
    return (u, v) if u < v else (v, u)


def _traffic_of(routes: Sequence[TradeRoute], n_segments: int) -> NDArray[np.float64]:
    if not routes:
        return np.zeros(n_segments)
    segs = np.concatenate([r.segments for r in routes])
    weights = np.repeat([r.traffic for r in routes], [len(r.segments) for r in routes])
    return np.bincount(segs, weights=weights, minlength=n_segments).astype(np.float64)


def _capacity_array(state: TradeState, segment_capacity: NDArray[np.floating]) -> NDArray[np.float64]:
    cap = np.asarray(segment_capacity, dtype=np.float64).reshape(-1)
    if len(cap) != state.n_segments:
        raise InputError(f"trade: {len(cap)} segment capacities for {state.n_segments} segments")
    return cap


def _frozen(a: NDArray[np.int64]) -> NDArray[np.int64]:
    a = np.array(a, dtype=np.int64)
    a.flags.writeable = False
    return a


def _saturate(order: Sequence[int], routes: Sequence[TradeRoute], free: NDArray[np.float64],
              total: float) -> tuple[list[float], NDArray[np.float64]]:
    """Greedy fill: each route in ``order`` takes min(left, min of ``free`` on it); returns takes, free."""
    free = free.copy()
    left = float(total)
    takes = []
    for k in order:
        segs = routes[k].segments
        take = min(left, max(0.0, float(free[segs].min())))
        free[segs] -= take
        left -= take
        takes.append(take)
    return takes, free


# --------------------------------------------------------------------------- public API

def segment_capacity(width: NDArray[np.floating], *, options: TradeOptions = TradeOptions()) -> NDArray[np.float64]:
    """Maximum traffic of each segment, ``O2 · WIDTH(s)`` (003 §3.4.2; 000 §4.2.8).

    Parameters
    ----------
    width : (E,) float
        Street widths in metres.
    options : TradeOptions

    Returns
    -------
    (E,) float64
        Traffic units.
    """
    return options.o2 * np.asarray(width, dtype=np.float64)


def draw_traffic_factor(rng: np.random.Generator, *, options: TradeOptions = TradeOptions()) -> float:
    """The city's ``b`` in ``t(t) = b·G(t)``, uniform in (b_min, b_max) (003 §3.5)."""
    return float(rng.uniform(options.b_min, options.b_max))


def new_trade_state(n_segments: int) -> TradeState:
    """An empty state over a segment table of ``n_segments`` segments."""
    if n_segments < 0:
        raise InputError(f"trade: n_segments must be ≥ 0, got {n_segments}")
    return TradeState(int(n_segments))


def add_route(state: TradeState, pair: Sequence[int], route_segments: Sequence[int] | NDArray[np.integer],
              length: float, *, n_segments: int | None = None) -> TradeState:
    """Add a trade route ``P_{i,j}`` for ``pair`` carrying no traffic yet (003 §3.2.2, Algorithm 2).

    Parameters
    ----------
    state : TradeState
    pair : (u, v)
        Neighbour indices, u ≠ v (order does not matter).
    route_segments : (k,) int
        Segment ids along the path, each at most once.
    length : float
        Route length in metres (> 0); routes are filled shortest first.
    n_segments : int, optional
        The segment table's new size when it has grown by appending segments
        (the new route may use them); never smaller than the current size.

    Returns
    -------
    TradeState
        With the route appended; call :func:`redistribute` to give it traffic.
    """
    key = _pair(pair)
    n = state.n_segments if n_segments is None else int(n_segments)
    if n < state.n_segments:
        raise InputError(f"trade: n_segments cannot shrink ({state.n_segments} → {n}); use remap_segments")
    segs = np.asarray(route_segments, dtype=np.int64).reshape(-1)
    if len(segs) == 0:
        raise InputError(f"trade: the route for pair {key} has no segments")
    if segs.min() < 0 or segs.max() >= n:
        raise InputError(f"trade: the route for pair {key} uses a segment outside 0..{n - 1}")
    if len(np.unique(segs)) != len(segs):
        raise InputError(f"trade: the route for pair {key} uses a segment twice")
    if not (np.isfinite(length) and length > 0):
        raise InputError(f"trade: route length must be > 0 m, got {length}")
    route = TradeRoute(key, _frozen(segs), float(length))
    demand = dict(state.demand)
    demand.setdefault(key, 0.0)
    return TradeState(n, state.routes + (route,), MappingProxyType(demand))


def available_capacity(state: TradeState, segment_capacity: NDArray[np.floating]) -> NDArray[np.float64]:
    """``T_A(s) = O2·WIDTH(s) − T(s)`` per segment (003 §3.4.2); negative when overloaded.

    Parameters
    ----------
    state : TradeState
    segment_capacity : (E,) float
        ``O2·width`` per segment (:func:`segment_capacity`).

    Returns
    -------
    (E,) float64
    """
    return _capacity_array(state, segment_capacity) - state.segment_traffic()


def segments_with_room(state: TradeState, segment_capacity: NDArray[np.floating],
                       amount: float) -> NDArray[np.bool_]:
    """Segments that can take ``amount`` more traffic.

    003 §3.4.2 "Trade route over existing major roads": in the temporary
    graph of major roads, segments that cannot accommodate the increase get
    infinite weight. Use this mask (and the ``shortfall`` of
    :func:`redistribute` as ``amount``) to build that graph.

    Returns
    -------
    (E,) bool
    """
    free = available_capacity(state, segment_capacity)
    return free >= amount - _EPS * max(1.0, abs(amount))


def route_capacity(state: TradeState, route: int, segment_capacity: NDArray[np.floating]) -> float:
    """``T_A(P_{i,j}) = min_s T_A(s)`` over the route (clamped at 0), index into ``state.routes``."""
    free = available_capacity(state, segment_capacity)
    return max(0.0, float(free[state.routes[route].segments].min()))


def pair_capacity(state: TradeState, pair: Sequence[int], segment_capacity: NDArray[np.floating]) -> float:
    """``T_A(P_i)`` with the pair's own traffic reset (Algorithm 2, lines 2–3).

    The pair's routes are saturated one by one in greedy order (shortest
    first) on the segments' capacity minus the *other* pairs' traffic; the
    sum of what each took is returned and nothing is changed.

    Returns
    -------
    float
        Traffic units the pair's routes could carry in total.
    """
    key = _pair(pair)
    cap = _capacity_array(state, segment_capacity)
    order = state.pair_routes(key)
    others = [r for r in state.routes if r.pair != key]
    takes, _ = _saturate(order, state.routes, cap - _traffic_of(others, state.n_segments), np.inf)
    return float(sum(takes))


def redistribute(state: TradeState, pair: Sequence[int], total: float,
                 segment_capacity: NDArray[np.floating]) -> tuple[TradeState, float]:
    """Algorithm 2 for one pair: reset its traffic, then GREEDILYREDISTRIBUTE ``t(t)``.

    Parameters
    ----------
    state : TradeState
    pair : (u, v)
    total : float
        ``t(t)``, the traffic between the pair this year (≥ 0).
    segment_capacity : (E,) float
        ``O2·width`` per segment.

    Returns
    -------
    state : TradeState
        The pair's routes carry their greedy shares; ``demand[pair] = total``.
    shortfall : float
        ``max(0, t(t) − T_A(P_i))``: traffic no route of the pair can carry.
        Zero means nothing needs building (003 §3.1 step 3); otherwise the
        major-road step proposes a new route (re-route over major roads with
        room, :func:`segments_with_room`, or a new road), adds it with
        :func:`add_route` and calls this again.
    """
    if not (np.isfinite(total) and total >= 0):
        raise InputError(f"trade: traffic t(t) must be a finite number ≥ 0, got {total}")
    key = _pair(pair)
    cap = _capacity_array(state, segment_capacity)
    order = state.pair_routes(key)
    others = [r for r in state.routes if r.pair != key]
    takes, _ = _saturate(order, state.routes, cap - _traffic_of(others, state.n_segments), total)
    routes = list(state.routes)
    for k, take in zip(order, takes):
        routes[k] = replace(routes[k], traffic=take)
    shortfall = float(total) - float(sum(takes))
    if shortfall <= _EPS * max(1.0, float(total)):
        shortfall = 0.0
    demand = dict(state.demand)
    demand[key] = float(total)
    return TradeState(state.n_segments, tuple(routes), MappingProxyType(demand)), shortfall


def assign_increase(state: TradeState, pair: Sequence[int], increase: float,
                    segment_capacity: NDArray[np.floating]) -> tuple[TradeState, float]:
    """One year of Algorithm 2 for one pair, given the increase ``t(t) − t(t−1)``.

    ``t(t)`` is the pair's previous demand plus ``increase`` (clamped at 0);
    then :func:`redistribute`.

    Parameters
    ----------
    state : TradeState
    pair : (u, v)
    increase : float
        ``t(t) − t(t−1)`` in traffic units (may be negative).
    segment_capacity : (E,) float
        ``O2·width`` per segment.

    Returns
    -------
    state : TradeState
    shortfall : float
        See :func:`redistribute`.
    """
    key = _pair(pair)
    total = max(0.0, state.demand.get(key, 0.0) + float(increase))
    return redistribute(state, key, total, segment_capacity)


def extend_segments(state: TradeState, n_segments: int) -> TradeState:
    """The same routes over a segment table grown by appending segments (ids kept).

    Parameters
    ----------
    state : TradeState
    n_segments : int
        New table size, at least ``state.n_segments``.

    Returns
    -------
    TradeState
    """
    if n_segments < state.n_segments:
        raise InputError(f"trade: n_segments cannot shrink ({state.n_segments} → {n_segments}); "
                         "use remap_segments")
    return replace(state, n_segments=int(n_segments))


def remap_segments(state: TradeState, pieces: Pieces | Sequence[Sequence[int]], n_segments: int) -> TradeState:
    """Follow the segment table through a rebuild: old segment ``i`` became ``pieces[i]``.

    A split segment maps to its pieces (a route through it runs through all
    of them), a kept one to its one new id, a deleted one to ``[]``. A route
    that loses every segment is dropped (its pair asks again for its traffic
    next year); a route whose pieces repeat keeps the first occurrence.

    Parameters
    ----------
    state : TradeState
    pieces : Pieces, or a sequence of length ``state.n_segments`` of int sequences
        New ids (in ``0..n_segments-1``) for each old segment, in path order
        when the old segment is traversed from its first to its second node.
    n_segments : int
        Size of the new segment table.

    Returns
    -------
    TradeState
    """
    pieces = Pieces.of(pieces)
    if len(pieces) != state.n_segments:
        raise InputError(f"trade: remap needs {state.n_segments} entries, got {len(pieces)}")
    if len(pieces.flat) and (pieces.flat.min() < 0 or pieces.flat.max() >= n_segments):
        raise InputError(f"trade: remap points outside 0..{n_segments - 1}")
    routes = []
    for r in state.routes:
        segs = pieces.gather(r.segments)
        if len(segs) == 0:
            continue
        _, first = np.unique(segs, return_index=True)
        routes.append(replace(r, segments=_frozen(segs[np.sort(first)])))
    return TradeState(int(n_segments), tuple(routes), state.demand)


def trade_report(state: TradeState, segment_capacity: NDArray[np.floating]) -> TradeReport:
    """Counts for the ``--json`` report (see :class:`TradeReport`).

    Parameters
    ----------
    state : TradeState
    segment_capacity : (E,) float
        ``O2·width`` per segment.

    Returns
    -------
    TradeReport
    """
    cap = _capacity_array(state, segment_capacity)
    traffic = state.segment_traffic()
    free = cap - traffic
    scale = max(1.0, float(np.abs(cap).max(initial=0.0)))
    over = free < -_EPS * scale
    at_cap = [float(free[r.segments].min()) <= _EPS * scale for r in state.routes]
    over_routes = [bool(over[r.segments].any()) for r in state.routes]
    pairs = sorted({r.pair for r in state.routes})
    carried = {p: state.carried(p) for p in state.demand}
    unmet = {p: max(0.0, d - carried[p]) for p, d in state.demand.items()}
    return TradeReport(
        pairs=len(pairs),
        routes=len(state.routes),
        demand=float(sum(state.demand.values())),
        carried=float(sum(carried.values())),
        unmet=float(sum(unmet.values())),
        pairs_short=int(sum(u > _EPS * max(1.0, state.demand[p]) for p, u in unmet.items())),
        routes_at_capacity=int(sum(at_cap)),
        routes_over_capacity=int(sum(over_routes)),
        segments_over_capacity=int(over.sum()),
    )


def trade_year(state: TradeState, pairs: Sequence[Sequence[int]] | NDArray[np.integer],
               increase: float | Mapping[Pair, float],
               segment_capacity: NDArray[np.floating], *,
               propose: Proposer | None = None) -> tuple[TradeState, NDArray[np.float64], TradeYear]:
    """One pass of 003 Algorithm 2 over all pairs (the TRAFFICSIMULATION step of Algorithm 1).

    For each pair in order: :func:`assign_increase`; if it falls short,
    ``propose`` (PROPOSEFROMMAJOR / PROPOSEFROMNEW / WINNER /
    TRADEROUTESEGMENTGRAPH) adds a route, and ``t(t)`` is redistributed
    greedily again over the pair's routes.

    Parameters
    ----------
    state : TradeState
    pairs : sequence of (u, v)
        Pairs in simulation order.
    increase : float or mapping pair → float
        ``t(t) − t(t−1)``, one number for every pair (003: one traffic
        function per city) or per pair.
    segment_capacity : (E,) float
        ``O2·width`` per segment.
    propose : callable, optional
        See :data:`Proposer`; without it shortfalls stay unresolved.

    Returns
    -------
    state : TradeState
    segment_capacity : (E',) float64
        The capacities after any roads the proposer built.
    year : TradeYear
    """
    cap = np.asarray(segment_capacity, dtype=np.float64)
    counts = TradeYear()
    for pair in pairs:
        key = _pair(pair)
        inc = increase.get(key, 0.0) if isinstance(increase, Mapping) else float(increase)
        state, short = assign_increase(state, key, inc, cap)
        added = 0
        if short > 0:
            counts = counts + TradeYear(short=1, shortfall=short)
            built = propose(state, key, short) if propose is not None else None
            if built is not None:
                before = len(state.routes)
                state, cap = built[0], np.asarray(built[1], dtype=np.float64)
                added = len(state.routes) - before
                state, short = redistribute(state, key, state.demand[key], cap)
        counts = counts + TradeYear(pairs=1, routes_added=added, unresolved=int(short > 0))
    return state, cap, counts
