"""Least-cost routes with the turn penalty P(t, α), and re-routing over major roads.

Seed 003 §3.4.2: a new trade route is found on G′ "by a modified Dijkstra's
algorithm [Vol08] which penalizes turns in paths using P(t, α)", where α is
the angle between consecutive segments (0 = turning back, π = straight on)
and P is SMOOTHSTEP scaled to centre S_c, width S_w and height S_p (Fig. 6):

    P(α) = S_p · (1 − smoothstep((α − S_c + S_w/2) / S_w)),   smoothstep(x) = 3x² − 2x³

(clamped to [0, 1]): no penalty for turns gentler than π − S_c − S_w/2, the
full S_p for those sharper than π − S_c + S_w/2.

A node graph cannot carry turn costs, so the search runs on a
*heading-expanded* graph (after [Vol08]): each vertex v has K arrival states
``arr(v, i)`` and K departure states ``dep(v, j)`` for headings binned to
2π/K, plus one hub. Travelling an edge of heading bin b goes
``dep(u, b) → arr(v, b)`` at the edge's cost; turning at v goes
``arr(v, i) → dep(v, j)`` at ``P`` of the binned turn, but only for the few
bin differences where P is below S_p: any sharper turn goes
``arr(v, i) → hub(v) → dep(v, j)`` at exactly S_p. That keeps the expanded
graph at about ``K · (2m + 3)`` turn edges per vertex instead of K². A
compiled search (:mod:`~osm_expand.engine.roads.expanded_search`) makes its
rows as it reaches the states, no matrix written, and takes the routes
scipy's Dijkstra would (:func:`_heading_search`).

The expanded graph is built only over the vertices that can lie on an
optimal route and that the search reaches: with ``d_s``, ``d_t`` the plain
(turn-free, hence lower-bound) distances from source and target and ``C``
the penalised cost of the best route found so far (at first the plain
shortest path's), a vertex v can be on a better route only if
``d_s(v) + d_t(v) ≤ C``. Of those, the expanded graph is made only over
tiles of the lattice that the search reaches: scipy's Dijkstra settles the
states with ``g ≤ C`` inside the active tiles, and a tile becomes active
when a state there may still lead to the target below C by A*'s test
``g + d_t < C`` (``d_t`` is a consistent bound: turn costs are ≥ 0)
(:func:`_tiled_search`). A route leaving the active tiles is also charged
the turns it must still make to head for the target (:func:`_turn_floor`:
a route whose edges' heading bins stay within an arc narrower than π ends
inside that arc's sector), which counts only in years whose P charges
turns of one bin. All these prunings are exact. C starts tight: at the
cost of a smaller window's best route where there was one, then of the best
route in a narrow band round that route or the plain one (:func:`_band_bound`,
A* over a few thousand vertices); the plain route's turns alone made C up
to 3.7 times the best. C is only a bound: the search still finds its own
route. The exits' search of a window (costs only, no route) runs A* on
reduced costs (:func:`_reduced`), bound by the plain distance to an exit
and the straight line on from there (:func:`_via_exits`); it pauses now and
then and stops where the exits it has reached already settle the next window
(:meth:`_Growth.settles`: the map, the growth's cap, or the same window from
the arrivals' lower and upper bounds), exact: the same windows to the bit.
With ``RoutingOptions.backward`` the route's search runs from the target
instead (:func:`_backward_route`, off: faster on some searches, slower on others).
"""
from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import StrEnum
from functools import partial
from numbers import Integral
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import binary_dilation
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.roads.lattice import ROAD_KINDS, EdgeKind, LatticeWeights
from osm_expand.engine.roads.path_graph import EdgeCosts, GraphWindow, ImplicitGraph, KindMask, PathGraph
from osm_expand.errors import InputError, OptionError
from osm_expand.model.options import require_positive

if TYPE_CHECKING:
    from osm_expand.engine.roads.expanded_search import Expanded, Plain, Resume

__all__ = ["RoutingOptions", "Route", "turn_penalty", "find_route", "route_over_major_roads", "Choice",
           "choose", "route_score"]

#: cost of the free transitions of the expanded graph (kept positive for scipy)
_EPS = 1e-9


@dataclass(frozen=True)
class RoutingOptions:
    """The turn penalty P(t, α) of R(t) (003 Fig. 6), this year's values, and the search.

    003's table of R(t) is missing. The defaults charge nothing for turns up
    to 30°, half of S_p at 60° and all of it from 90°: a road may bend, not
    zig-zag. S_p is in cost units (1 = one metre of new road on flat land):
    one sharp turn costs as much as 150 m of road.
    """

    turn_centre: float = 2.0 * np.pi / 3.0  #: rad, S_c(t): α where half the penalty applies (α = π: straight)
    turn_width: float = np.pi / 3.0  #: rad, S_w(t): width of the smoothstep
    turn_height: float = 150.0  #: cost units, S_p(t): penalty of a turn sharper than π − S_c + S_w/2
    #: heading bins K of the expanded graph: 16 → 22.5° (turns are measured to ±11°); the
    #: 120 lattice directions of r = 8 fall into them
    heading_bins: int = 16
    #: lattice vertices a side of the tiles in which the exact search's heading-expanded graph is made
    #: as the search reaches them (:func:`_tiled_search`): 16 → 320 m at ℓ = 20 m, twice the longest
    #: lattice edge (r = 8); any size is exact (an edge leaving the active tiles activates its far end's)
    tile_cells: int = 16
    #: vertices of the exact search's region up to which it is searched whole at once, without
    #: tiles (its expanded graph holds about 400 entries, 5 kB, a vertex: 100,000 → 0.5 GB); Campo
    #: Grande's regions hold 20,000–70,000, where growing tiles took 3–5 searches to reach all of it
    whole_region: int = 100_000
    #: m, the first window of an implicit G′ reaches this far beyond the two ends' bounding box
    #: (a few hundred metres: a route that bends round a block or a river bank stays inside);
    #: it doubles until the window provably holds the best route
    window_margin: float = 400.0
    #: share of the two ends' distance added to ``window_margin`` for the first window (long
    #: routes wander further from the straight line). 0.5 with ``growth_share`` 0.5 and ``route_astar``
    #: (session 34): Campo Grande's 14 dearest captured searches 32.3 → 21.4 s CPU (0.25, 0.25, plain
    #: Dijkstra) — the first window proves the route more often (39 windows for the 36 searches, were 48),
    #: and A* inside a larger window settles about the same corridor; 0.75: 34.3 s (more of them the whole map).
    #: Left at 0.25 with ``route_astar`` off (see there): the three change which of equal routes is taken
    window_share: float = 0.25
    #: a window covering more than this share of the map becomes the whole map (a second,
    #: larger window would cost more than searching the map at once)
    whole_share: float = 0.5
    #: a window that may still miss a cheaper route grows by at most this share of its size a side
    #: (at least twice its exits' reach) before it is searched again; with plain Dijkstra (session 32)
    #: 0.25 took Campo Grande's first two road searches from 8.7 + 6.8 s and 1.6 GB to 2.0 + 5.2 s and
    #: 1.0 GB (0.5: 3.2 + 6.3 s, 1.2 GB); with ``route_astar`` and ``window_share`` 0.5 (session 34), 0.5
    #: and 1.0 cost the same on the 14 dearest captured searches (23.2 and 22.1 s CPU, one run each);
    #: left at 0.25 with ``route_astar`` off (see there)
    growth_share: float = 0.25
    #: whether the tiled search charges a route leaving its active tiles the turns it must still
    #: make to head for the target (:func:`_turn_floor`: from P of this year's turns; none while
    #: turns up to 22.5° are free, as in the default P; an even `heading_bins` only) — fewer tiles, the same cost
    turn_floor: bool = True
    #: whether a route's turn-penalised search runs from the target backwards (:func:`_backward_route`:
    #: A* towards the source on the reversed expanded graph, bound by the plain distance from the
    #: source, then plain Dijkstra over the states of the best routes only); exact: the same cost
    #: (of several routes of exactly equal cost, possibly another; the forward search's if the last
    #: Dijkstra does not confirm the cost).
    #: Off: which end's A* settles fewer states depends on the search, and the reversed graph is a
    #: copy. Campo Grande's captured first three (``benchmarks/route_corridor_bounds.py directions``):
    #: 7.8 → 5.5, 7.2 → 7.3, 5.7 → 4.5 s CPU; the synthetic town's first 72.5 → 70.1 s (37 M states
    #: settled backwards, 53 M forwards); Campo Grande's default run 133.9 → 134.5 s CPU and
    #: 1.16 → 1.65 GB peak, the same bytes
    backward: bool = False
    #: lattice vertices a side of the backward search's tiles (:func:`_backward_route`): 8 → 160 m.
    #: It touches a narrow corridor (Campo Grande's first road: 2,000 vertices), so its region is
    #: never searched whole (``whole_region``) and small tiles keep it small: built over 16-vertex
    #: tiles, or whole, its expanded graph held 0.8–1.8 M states, over 8-vertex tiles 0.2 M
    backward_tile_cells: int = 8
    #: lattice vertices a side of the tiles of the narrow band (those of a known feasible route and
    #: their neighbours: ±1–2 tiles) searched first for a tight bound of the best cost
    #: (:func:`_band_bound`); 0: no band, the first bound is the plain shortest path's penalised cost
    #: (up to 3.7× the best on Campo Grande's searches) or the previous window's route's
    bound_cells: int = 4
    #: whether a route's turn-penalised search runs A* on reduced costs (Dijkstra on
    #: ``w + d_t(col) − d_t(row)``, :func:`_reduced`, the plain distance to the target d_t as bound, the
    #: route's cost summed again from the own weights) instead of A* by d_t on the graph's own weights
    #: with scipy's tie rule (the default, :func:`_tiled_search`), which takes plain Dijkstra's route.
    #: Both are exact (the same cost) and settle only the states with g + d_t ≤ C; the reduced costs'
    #: other float sums make it take, of several routes of equal cost, another than plain Dijkstra
    #: (3 of Campo Grande's 36 captured searches). Against plain Dijkstra (session 34, before the tie
    #: rule) it saved 8–12 % of those searches' CPU alone, with ``window_share`` and ``growth_share`` 0.5
    #: a third (Campo Grande's default command 73.6 → 59.4 s CPU). Off: its equal-cost roads move Monaco's and Campo
    #: Grande's later districts (issue 20's verdict, ``benchmarks/engine_growth.py``, off of 14, seeds 0 / 1 /
    #: 2: Monaco 2 3 3 / 3 3 2 / 4 5 5 → 5 4 4 (dead-end and 2-core shares out) / 3 3 2 / 4 5 5; Campo
    #: Grande 4 4 5 (2-core out) / 4 4 4 / 2 3 2 → 4 4 4 (in) / 4 4 4 / 3 3 3), and Monaco's seed-0 engine
    #: streets then fail ``tests/test_engine_districts.py``'s shares: a reshuffle, not a trend, but it is
    #: turned on only with the districts decoupled from the roads' ties (issue 20)
    route_astar: bool = False
    #: states (``n · (2k + 1)``, 33 a vertex at K = 16) of an exact search's region up to which its
    #: tiles' searches number them over the whole region and each goes on from the last
    #: (:func:`_tiled_search`); the distances and predecessors then span the whole region (12 B a
    #: state: 64 M → 0.77 GB, the synthetic town's 58 M fit) where numbered over the active tiles
    #: alone they spanned those. Above it (and with ``route_astar``) each search numbers the active
    #: states and starts again, as before going on was added. Below 2^31 (32-bit state numbers)
    resume_states: int = 64_000_000
    #: the route search (A* with scipy's tie rule, :func:`_tiled_search`) adds to each state's bound the
    #: least turn cost from it to the target (:func:`_turns_to_go`: turns alone, searched backwards once
    #: per search over its first region, in the corridor a route within the best cost C can use) where
    #: that region has at most this many states (0: never). Also a memory cap: T (8 B a state of the
    #: first region), a copy of it for each smaller region searched (8 B a state of that one, the
    #: last kept) and the backward search's heap and stack. Consistent, so each search over the same
    #: active tiles finds the same routes, distances and predecessors; but the tiles' growth test
    #: reads ∞ where a search did not scan, so with T fewer tiles may grow, and two routes of exactly
    #: equal cost through tiles only one of the runs grows could tie the other way (Campo Grande's 36
    #: captured calls: identical). Measured (session 40, ``benchmarks/route_replay.py``, one run, load
    #: 5–6): Campo Grande's 36 calls' route search plus T 5.16 → 3.07 s CPU (states summed over the
    #: tile rounds 8.32 → 3.40 M; regions up to 7.7 M states). The synthetic 10,000-street town's first
    #: road (a region of 57.9 M states; its route trades length for turns, so T cuts little): with T
    #: (``turn_share`` 0.05) 40.3 → 47.5 s CPU, so its regions stay above the cap and search as before.
    #: Session 39's T over the whole region, one limit: Campo Grande's 36 calls 18.6 → 24.5 s (T 8.35 s)
    turn_bound: int = 16_000_000
    #: the share of its region's states the turns' backward search (``turn_bound``) may scan before it
    #: stops; every state's T is then clamped at the turn cost it had reached (consistent, weaker, in
    #: bounded time). Campo Grande's 36 captured calls (session 40, ``benchmarks/route_replay.py``, one
    #: run), route search plus T:
    #: 1.0 (whole corridor) 8.04 s (with numba's compile), 0.10 3.24 s, 0.05 3.07 s, 0.02 3.18 s,
    #: 0.01 3.45 s, without T 5.16 s
    turn_share: float = 0.05

    def __post_init__(self) -> None:
        require_positive(self, ("window_margin", "growth_share", "turn_width"))
        if not (self.window_share >= 0 and self.turn_height >= 0):
            raise InputError("RoutingOptions: window_share and turn_height must not be negative")
        # counts of lattice vertices: a whole number (not a bool, not nan or 2.5, which failed later
        # in find_route with a TypeError)
        for name, least in (("bound_cells", 0), ("tile_cells", 1), ("backward_tile_cells", 1),
                            ("resume_states", 0), ("turn_bound", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Integral) or value < least:
                raise OptionError(f"RoutingOptions.{name} must be a whole number of at least {least}, got {value!r}")
        if isinstance(self.turn_share, bool) or not 0 < self.turn_share <= 1:
            raise OptionError(f"RoutingOptions.turn_share must be in (0, 1], got {self.turn_share!r}")
        if self.heading_bins < 4:
            raise InputError(f"RoutingOptions.heading_bins must be at least 4, got {self.heading_bins}")


def turn_penalty(alpha: np.ndarray | float, *, centre: float, width: float, height: float) -> np.ndarray:
    """P(t, α) (003 Fig. 6) for angles α in radians between consecutive segments (π = straight).

    >>> float(turn_penalty(np.pi, centre=2.0, width=1.0, height=10.0))
    0.0
    >>> float(turn_penalty(0.0, centre=2.0, width=1.0, height=10.0))
    10.0
    """
    x = np.clip((np.asarray(alpha, dtype=float) - centre + 0.5 * width) / width, 0.0, 1.0)
    return height * (1.0 - (3.0 * x * x - 2.0 * x ** 3))


@dataclass(frozen=True)
class Route:
    """A route as vertices and the edges between them.

    For :func:`find_route` the vertices are G′ vertices; for
    :func:`route_over_major_roads` they are street nodes.
    """

    vertices: np.ndarray  #: (M,) int
    xy: np.ndarray  #: (M, 2) m
    kind: np.ndarray  #: (M − 1,) uint8 EdgeKind per edge
    segment: np.ndarray  #: (M − 1,) int street segment per edge (−1: new)
    edge_length: np.ndarray  #: (M − 1,) m
    edge_weight: np.ndarray  #: (M − 1,) cost units (C1…C6 applied)
    turn_cost: float = 0.0  #: cost units, Σ P over the route's turns

    @property
    def length(self) -> float:
        """LENGTH(P) in metres (003 §3.4.2)."""
        return float(self.edge_length.sum())

    @property
    def cost(self) -> float:
        """COST(P): edge costs plus turn penalties."""
        return float(self.edge_weight.sum()) + self.turn_cost


def _bins(heading: np.ndarray, k: int) -> np.ndarray:
    return np.rint(np.asarray(heading) / (2.0 * np.pi / k)).astype(np.int64) % k


def _bin_penalties(opts: RoutingOptions) -> np.ndarray:
    """P for a turn of q bins, q = 0 … K − 1 (q and K − q are the same turn)."""
    k = opts.heading_bins
    q = np.arange(k)
    turn = np.minimum(q, k - q) * (2.0 * np.pi / k)
    return turn_penalty(np.pi - turn, centre=opts.turn_centre, width=opts.turn_width, height=opts.turn_height)


def find_route(graph: PathGraph | ImplicitGraph, source: int, target: int, *, kinds: Sequence[EdgeKind] = ROAD_KINDS,
               street_ok: np.ndarray | None = None, options: RoutingOptions | None = None) -> Route | None:
    """The least-cost route on G′ with turn penalties (003 §3.4.2, PROPOSEFROMNEW).

    Parameters
    ----------
    graph
        G′ from :func:`osm_expand.engine.roads.path_graph.pathfinding_graph`, or an
        :class:`~osm_expand.engine.roads.path_graph.ImplicitGraph` (searched in windows
        that grow until the route is provably the whole map's best, see
        :func:`_implicit_route`).
    source, target
        G′ vertices (e.g. ``graph.node_vertex(node)`` for street nodes).
    kinds
        Edge kinds the route may use (default: roads; no waterways or harbours).
    street_ok
        ``(S,)`` bool: which street segments may be used (None: all), e.g.
        those with enough capacity or extendible, and those the road type allows.
    options
        :class:`RoutingOptions` (the turn penalty of this year).

    Returns
    -------
    Route or None
        The route minimising Σ edge cost + Σ P(α) (headings binned to 2π/K);
        None when the target cannot be reached.
    """
    opts = options or RoutingOptions()
    if isinstance(graph, ImplicitGraph):
        return _implicit_route(graph, source, target, kinds, street_ok, opts)
    return _search(graph, source, target, kinds, street_ok, opts)[0]


def _search(graph: PathGraph, source: int, target: int, kinds: Sequence[EdgeKind], street_ok: np.ndarray | None,
            opts: RoutingOptions, known: np.ndarray | None = None,
            exits: tuple[np.ndarray, np.ndarray] | None = None
            ) -> tuple[Route | None, np.ndarray | None, np.ndarray | None]:
    """:func:`find_route` on a G′, and the plain (turn-free) distances from the source up to past the
    first bound (∞ beyond; all of them where the target is not reached).

    The plain searches are compiled (:class:`~osm_expand.engine.roads.expanded_search.PlainSearch`,
    the source's run in parts; :func:`_plain_search` for the others) and read G′'s tables as they go: no
    matrix of the graph is written (a window's was 8.2 s of Campo Grande's run and most of a road
    year's memory, session 36). The source's stops at the target and goes on only up to the first
    bound, which needs the plain route (Campo Grande's first 8 captured calls: 4.6 → 3.4 s CPU of
    plain searches, session 37). ``known`` is a route from the
    source to the target (its vertices; a smaller window's best): where it is allowed in this
    graph and cheaper than the plain shortest path with its turns, its cost is the first bound.
    ``exits`` (a window's exits and a lower bound of the cost from each to the target) asks also
    for ``min_x d(v, x) + bound(x)`` over them for every vertex v (∞ above the first bound), the
    exits' search's A* bound (:func:`_via_exits`); it is None where no
    exit's ``d(s, x) + bound(x)`` is below the first bound (then no exit is short and nothing reads it).
    """
    lat, extra = graph.masks(kinds, street_ok)
    if source == target:
        return _route(graph, [source], lat, extra, 0.0), None, None
    from osm_expand.engine.roads.expanded_search import PlainSearch

    rows = _plain_rows(graph, lat, extra)
    search = PlainSearch(rows, np.array([source]), predecessors=True)
    if not search.run(stop=target):  # the target is not reached: every distance (the window grows by them)
        return None, search.dist, None
    plain = _walk_back(search.pred, source, target)  # its vertices are scanned: their predecessors are final
    plain_route = _route(graph, plain, lat, extra, 0.0)
    penalties = _bin_penalties(opts)
    bins = _bins(_headings(plain_route), opts.heading_bins)
    plain_turns = float(penalties[(bins[1:] - bins[:-1]) % opts.heading_bins].sum())
    # the rest of the source's distances, up to the first bound: every reader compares them with a cost at
    # most that (the route's, the exits' bound below, _implicit_route's and _exit_arrivals' tests, all within
    # 1e-9 of it), so one beyond reads as one above it; the margin takes the float sums' last bits
    reach = max(float(search.dist[target]) + plain_turns, plain_route.cost)
    reach += 1e-6 * reach + 1e-3
    search.run(reach)
    search.cut(reach)
    from_source = search.dist
    del search
    if opts.turn_height == 0 or plain_turns == 0:
        return _with_turn_cost(plain_route, plain_turns), from_source, None
    bound = float(from_source[target]) + plain_turns
    first = (plain, bound)
    if known is not None:
        again = _route_cost(graph, known, lat, extra, opts)
        if again is not None and again < bound:
            first = (known.tolist(), again)
    limit = first[1] + 1e-9 * first[1] + 1e-6
    from_target, _ = _plain_search(rows, [target], limit=limit)  # G′ is symmetric
    # read only where an exit may be short (:func:`_implicit_route`: ``reached + rest`` below the
    # route's cost, which is at most the first bound): where none is, it is never read
    via = None
    if exits is not None and (from_source[exits[0]] + exits[1] < limit).any():
        via = _via_exits(rows, *exits, limit)
    del rows
    return _best_route(graph, lat, extra, source, target, from_source, from_target, first, opts), from_source, via


def _plain_rows(graph: PathGraph, lat: KindMask, extra: np.ndarray) -> Plain:
    """What the compiled plain search reads of G′ (:class:`~osm_expand.engine.roads.expanded_search.Plain`):
    the lattice's tables as they are, and the allowed other edges (``extra``) by tail, in edge order
    (``src`` is sorted), as :meth:`PathGraph._csr` writes a row after its lattice moves."""
    from osm_expand.engine.roads.expanded_search import Plain

    lat_kind, allowed, table, plain, w_kind = _lattice_rows(graph, lat)
    e = np.flatnonzero(extra)
    e_ptr = np.zeros(graph.n_vertices + 1, dtype=np.int64)
    np.cumsum(np.bincount(graph.src[e], minlength=graph.n_vertices), out=e_ptr[1:])
    return Plain(n=graph.n_vertices, n_lat=int(lat.shape[0]), lat_kind=lat_kind, allowed=allowed,
                 offset=graph.lattice.direction_offset.astype(np.int64), table=table, plain=plain, w_kind=w_kind,
                 e_ptr=e_ptr, e_col=graph.dst[e].astype(np.int64), e_val=graph.weight[e].astype(np.float64))


def _plain_search(rows: Plain, seeds: Sequence[int] | np.ndarray, seed_dist: np.ndarray | None = None,
                  limit: float = np.inf, predecessors: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """scipy's ``dijkstra`` on the plain G′ ``rows`` describes from one seed (at 0), or from a source
    joined to each seed at ``seed_dist``, up to ``limit``: the same distances and predecessors, ties
    included, with no matrix written (:func:`~osm_expand.engine.roads.expanded_search.plain_dijkstra`).
    Imported here, as :func:`_heading_search` does, so that commands which search no route do not
    import numba."""
    from osm_expand.engine.roads.expanded_search import plain_dijkstra

    return plain_dijkstra(rows, np.asarray(seeds, dtype=np.int64), seed_dist, limit, predecessors)


def _via_exits(rows: Plain, exits: np.ndarray, rest: np.ndarray, limit: float) -> np.ndarray:
    """``min_x d(v, x) + rest(x)`` over the exits x for every vertex v (d: the plain distance in the
    window; ∞ above ``limit``), by one Dijkstra from a source joined to each exit at ``rest(x)``.

    A route that leaves the window from v first reaches an exit x inside it, at no less than
    ``d(v, x)``, and then costs at least ``rest(x)`` (``c·|x − t|``): this bounds what is left of
    it far better than the straight line ``c·|v − t|`` (the window's land costs at least 1 a metre,
    ``c`` is the cheapest kind's, e.g. a major road's 0.4, and the exits lie round the window, not
    towards the target). It is a shortest-path distance on the plain graph, whose edges cost no
    more than the expanded graph's, and turns cost ≥ 0: a consistent A* bound, ``rest(x)`` at most
    at an exit x. G′ is symmetric, so the distances from the joined source are those to it.

    The joined source's edges weigh ``rest + 1`` and the 1 is taken off after, the sums the joined
    matrix of scipy's search made (sessions 32–36: a copy of the window's matrix with one more row;
    the bytes of every later sum depend on them). Measured on Campo Grande's default run
    (``--seed 0``, session 32): made for 22 of the 26 windows searched before the whole map's (the
    others had no exit within the first bound).
    """
    if not len(exits):
        return np.full(rows.n, np.inf)
    return _plain_search(rows, exits, rest + 1.0, limit + 1.0)[0] - 1.0


def _route_cost(graph: PathGraph, vertices: np.ndarray, lat: KindMask, extra: np.ndarray,
                opts: RoutingOptions) -> float | None:
    """An upper bound of the expanded graph's distance of the route over ``vertices`` (its cheapest
    edges, their binned turns and the free transitions' ε each); None when it is not allowed here."""
    if len(vertices) < 2 or (np.asarray(vertices) < 0).any():
        return None
    try:
        route = _route(graph, vertices.tolist(), lat, extra, 0.0)
    except InputError:  # an edge of the smaller window is not allowed in this one
        return None
    bins = _bins(_headings(route), opts.heading_bins)
    turns = float(_bin_penalties(opts)[(bins[1:] - bins[:-1]) % opts.heading_bins].sum())
    total = float(route.edge_weight.sum()) + turns
    return total + 1e-9 * total + 1e-6 + 4 * len(vertices) * (2 * opts.heading_bins + 1) * _EPS


#: Edge kinds whose edges touch the lattice (a search over none of them needs no lattice).
_LATTICE_KINDS = frozenset({EdgeKind.LAND, EdgeKind.WATER, EdgeKind.HARBOUR, EdgeKind.BRIDGE, EdgeKind.STITCH})


def cheapest_unit_cost(costs: EdgeCosts, kinds: Sequence[EdgeKind]) -> float:
    """The least cost per metre of straight distance any edge of the given kinds can have.

    Every edge weighs ``length · max(1, O1 · slope)`` times its kind's
    coefficient (streets also × C6 when extendible), and a straight edge is
    at least as long as the distance between its ends; turn penalties are
    not negative. So ``distance × this`` never overestimates what is left of
    a route: an admissible bound (A*'s heuristic).
    """
    c6 = min(1.0, costs.extendible)
    per = {EdgeKind.LAND: 1.0, EdgeKind.WATER: 1.0, EdgeKind.STITCH: 1.0, EdgeKind.HARBOUR: costs.harbour,
           EdgeKind.BRIDGE: costs.bridge, EdgeKind.MAJOR: costs.major * c6, EdgeKind.MINOR: costs.minor * c6,
           EdgeKind.BUILT_HARBOUR: costs.built_harbour * c6}
    return min(per[EdgeKind(k)] for k in kinds)


def _implicit_route(graph: ImplicitGraph, source: int, target: int, kinds: Sequence[EdgeKind],
                    street_ok: np.ndarray | None, opts: RoutingOptions) -> Route | None:
    """The whole map's best route, searched on G′ over growing windows of the lattice.

    Each window holds every edge of G′ between its vertices except those
    from its ``exits`` (:class:`~osm_expand.engine.roads.path_graph.GraphWindow`). A
    route that leaves the window first reaches an exit x, and its part
    before x uses the window's edges only. So it costs at least
    ``A(x) + c·|x − t|``, where A is the least turn-penalised cost of
    arriving at an exit from the source inside the window and c the least
    cost a metre (:func:`cheapest_unit_cost`); the plain distance stands in
    for A when that alone already settles it. When no exit's bound is below the cost
    of the window's best route, no route through the rest of the map can be
    cheaper and the window's route is the map's (equal cost; of several
    equal ones it may be another). Else the window grows, by at most
    ``growth_share`` of its size a side, towards where a cheaper route
    could go (:func:`_grown`), and its search starts from the last
    window's best route: where its edges are allowed in the larger window
    and it costs less there than the plain route with its turns, its cost
    is the first bound (:func:`_search`). The lattice edges are generated
    only for the windows searched, so memory and time follow the corridor
    a route can use, not the map.

    Counting turns is what keeps the windows small: in a street grid they
    are most of a route's cost (Campo Grande's first new road: 5,270 of
    8,867 cost units), and the straight-line bound with C1·C6 = 0.4 a metre
    let exits 2.5 times the route's length away look promising, so most
    searches ended on the whole map. A coarse bound from the cells' least
    cost a metre (a Dijkstra over 60 m cells) was tried first and was
    weaker than the straight line there. A matching bound from the target
    (the least turn-penalised arrival at the route's last exit, searched
    from the target as if the route cost the same reversed) was tried and
    dropped: with headings in bins a reversed route's turns fall in other
    bins and cost otherwise, and the bound overstated a random map's route
    (``tests/test_majorroads.py``, seed 4194305: 537.5 found against the
    map's 478.8).
    """
    ends = graph.vertex_xy(np.array([source, target]))
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    if not set(kinds) & _LATTICE_KINDS:  # streets only: the lattice plays no part, any window is exact
        window = graph.window((lo[0], lo[1], lo[0], lo[1]))
        s, t = window.from_map(np.array([source, target])).tolist()
        return _on_map(window, *_search(window.graph, s, t, kinds, street_ok, opts))
    c = cheapest_unit_cost(graph.costs, kinds)
    margin = opts.window_margin + opts.window_share * float(np.hypot(*(hi - lo)))
    bounds = np.array([lo[0] - margin, lo[1] - margin, hi[0] + margin, hi[1] + margin])
    whole = np.array(graph.lattice.bounds)
    reach = graph.options.stitch_radius + graph.lattice.radius * graph.lattice.spacing
    penalties = _bin_penalties(opts)
    map_area = float(np.prod(whole[2:] - whole[:2]))
    previous = None  # the last window's best route (map vertices): feasible in the next, a bound there
    while True:
        if _seen(bounds, whole) > opts.whole_share * map_area:  # nearly the map's size: take the map
            bounds = whole
        window = graph.window(tuple(bounds))
        s, t = window.from_map(np.array([source, target])).tolist()
        known = None if previous is None else window.from_map(previous)
        exits = window.exits
        exit_xy = window.graph.xy[exits]
        rest = c * np.hypot(*(exit_xy - ends[1]).T)  # what is left from an exit, at least
        # the whole map's window is the last: nothing reads its exits' bound
        route, from_source, via = _search(window.graph, s, t, kinds, street_ok, opts, known=known,
                                          exits=None if window.whole else (exits, rest))
        if window.whole or from_source is None:
            return _on_map(window, route, from_source)
        cost = route.cost if route is not None else np.inf
        growth = _Growth(bounds, np.array(window.graph.lattice.bounds), exit_xy, rest, ends[1], cost, c, reach,
                         opts.growth_share)
        reached = from_source[exits]
        if route is not None and opts.turn_height > 0 and growth.short(reached).any():
            # A route that leaves the window first reaches an exit x, and its part before x lies in the
            # window: it costs at least A(x), the least turn-penalised cost of arriving at x from the
            # source. In a street grid turns are most of a route's cost (Campo Grande: 5,270 of 8,867
            # cost units), so A is far above the plain distance. A is searched as A* with the bound
            # max(c·|v − t|, via(v)) (via: the plain distance to an exit and the straight line on from
            # there, :func:`_via_exits`, made when some exit may be short; both consistent, at most
            # c·|x − t| at an exit x), only where A(v) plus that bound may be below the route's cost;
            # an exit not reached there is not short. The search stops early where the exits it has
            # reached already settle the next window (:meth:`_Growth.settles`).
            settled = partial(growth.settles, reached, whole, opts.whole_share * map_area)
            reached = np.maximum(reached, _exit_arrivals(window, kinds, street_ok, s, ends[1], c, from_source,
                                                         route, penalties, opts, via, settled))
        grown = growth.next(reached)
        if grown is None:
            return _on_map(window, route, from_source)
        bounds = grown
        previous = None if route is None else window.to_map(route.vertices)
        del window, route, from_source, via  # the last window's tables go before the next is made


@dataclass(frozen=True)
class _Growth:
    """What decides the window after one of :func:`_implicit_route` from its exits' arrival costs."""

    bounds: np.ndarray  #: the window's bounds as asked (xmin, ymin, xmax, ymax) m
    inside: np.ndarray  #: its lattice's bounds
    exit_xy: np.ndarray  #: (X, 2) m, its exits
    rest: np.ndarray  #: (X,) at least what is left of a route from each exit to the target
    target: np.ndarray  #: (2,) m
    cost: float  #: the window's best route's cost (∞: none)
    c: float  #: the least cost a metre (:func:`cheapest_unit_cost`)
    reach: float  #: m, how far an edge of G′ reaches
    share: float  #: ``RoutingOptions.growth_share``

    def short(self, reached: np.ndarray) -> np.ndarray:
        """The exits through which a route could still be cheaper than the window's best."""
        limit = self.cost - 1e-9 * self.cost if np.isfinite(self.cost) else np.inf
        return reached + self.rest < limit

    @property
    def cap(self) -> np.ndarray:
        """The largest window one growth makes: each side moved by at most ``share`` of the window's size
        (at least ``2 · reach``) while the cost is finite."""
        size = np.tile(self.bounds[2:] - self.bounds[:2], 2)
        return self.bounds + np.maximum(self.share * size, 2.0 * self.reach) * np.array([-1, -1, 1, 1])

    def next(self, reached: np.ndarray) -> np.ndarray | None:
        """The next window's bounds where the exits are reached at ``reached``: None where no exit is short
        (the window's route is the map's), else :func:`_grown` within :attr:`cap`. The cap: the exits of a
        larger window are dearer to arrive at (more turns), so a step or two of growth usually proves the
        route, where the ellipses of the nearer exits would take in most of the map at once."""
        short = self.short(reached)
        if not short.any():
            return None
        grown = _grown(self.bounds, self.inside, self.exit_xy[short], reached[short], self.target, self.cost,
                       self.c, self.reach)
        if not np.isfinite(self.cost):
            return grown
        cap = self.cap
        return np.concatenate([np.maximum(grown[:2], cap[:2]), np.minimum(grown[2:], cap[2:])])

    def settles(self, plain: np.ndarray, whole: np.ndarray, least: float, upper: np.ndarray,
                lower: np.ndarray | None = None) -> bool:
        """Whether exits' arrival costs at most ``upper`` (and at least ``lower``, where given; at least
        ``plain``) settle the next window whatever the exits' search still finds: it covers more than
        ``least`` m² of the map (``whole``; it becomes the map), each side moved as far as one growth
        may (:attr:`cap`), or the window made from ``lower`` is the one made from ``upper`` (both
        None: no exit can be short, the window's route is the map's).

        Exact: the search goes on only to lower the arrivals and to find more exits short, and the next
        window only grows with them: a short exit adds its ellipse's box to the others' (:func:`_grown`,
        a union), a lower arrival widens its ellipse, an exit near a side moves that side out, and the
        cap and the map's share are monotone. All but where no short exit is near a side yet:
        :func:`_grown` then doubles the window, which a later exit near a side could undo, so the
        search does not stop there. The window from ``lower`` is the largest the search can still
        make: it bounds the true one from above as the one from ``upper`` does from below."""
        reached = np.maximum(plain, upper)
        nxt = self.next(reached)
        widest = None if lower is None else self.next(np.maximum(plain, lower))
        if lower is not None and widest is None:
            return True  # no exit short even at its lower bound (nor at its upper: nxt is None too)
        if nxt is None or not _near_sides(self.inside, self.exit_xy[self.short(reached)], self.reach).any():
            return False
        return bool(np.array_equal(nxt, self.cap) or _seen(nxt, whole) > least
                    or (widest is not None and np.array_equal(nxt, widest)))


def _exit_arrivals(window: GraphWindow, kinds: Sequence[EdgeKind], street_ok: np.ndarray | None, s: int,
                   target_xy: np.ndarray, c: float, from_source: np.ndarray, route: Route, penalties: np.ndarray,
                   opts: RoutingOptions, via: np.ndarray | None = None,
                   settled: Callable[[np.ndarray, np.ndarray | None], bool] | None = None) -> np.ndarray:
    """A(x) of :func:`_implicit_route` for the window's exits: the least turn-penalised arrival
    cost from the source inside the window, where it and ``c·|x − t|`` may be below the route's
    cost (∞ elsewhere), searched by A* towards the target (:func:`_tiled_search` without one).

    A*'s bound is the straight line ``c·|v − t|`` or, tighter, ``via`` (:func:`_via_exits`: the
    plain distance to an exit and the straight line on from there), both consistent and at most
    ``c·|x − t|`` at an exit x: an exit whose ``A(x) + c·|x − t|`` is below the route's cost is
    reached along states whose ``g + bound`` is too, so its arrival is the same with either, while
    the tighter bound leaves out the states far from every exit.

    ``settled`` (:meth:`_Growth.settles`) is asked now and then, with upper (and lower) bounds of the
    arrivals the search will end with, whether they already settle the next window; where it says
    so, the search stops and the upper bounds are returned (:func:`_tiled_search`)."""
    lat_ok, extra_ok = window.graph.masks(kinds, street_ok)
    straight = c * np.hypot(*(window.graph.xy - target_xy).T)
    if via is not None:
        straight = np.maximum(straight, via)
        if not from_source[s] + straight[s] <= route.cost + 1e-9 * route.cost + 1e-6:
            return np.full(len(window.exits), np.inf)  # A(x) + c·|x − t| ≥ via(s) > the cost at every exit
    _, arrive = _tiled_search(window.graph, lat_ok, extra_ok, s, None, from_source + straight, straight,
                              (route.vertices.tolist(), route.cost), route.vertices, penalties, opts, target_xy,
                              exits=window.exits, settled=settled)
    if arrive is None:  # exits were given: the search always returns their arrivals
        raise RuntimeError("the exits' search returned no arrivals")
    return arrive


def _seen(bounds: np.ndarray, whole: np.ndarray) -> float:
    """m², the part of the map a window's bounds cover."""
    return float(np.prod(np.maximum(np.minimum(bounds[2:], whole[2:]) - np.maximum(bounds[:2], whole[:2]), 0.0)))


def _grown(bounds: np.ndarray, inside: np.ndarray, exits: np.ndarray, reached: np.ndarray, target: np.ndarray,
           cost: float, c: float, reach: float) -> np.ndarray:
    """The next window: wide enough for every route that could still beat ``cost``.

    A route leaving by exit x (reached at ``d``) and passing a point y
    costs at least ``d + c·(|x − y| + |y − t|)``, so y lies in the ellipse
    with foci x and t whose string is ``(cost − d) / c``: the window takes
    in each such ellipse's bounding box. The sides near the exits move out
    by at least ``2 · reach`` (past the band where a point is an exit), so
    every step makes progress; without a finite cost every side doubles
    its distance to the ends. A route strays at most ``(cost − d) / c``
    from x: each box is cut to that square round its exit.
    """
    px, py = exits.T
    near = _near_sides(inside, exits, reach)
    step = np.where(near, 2.0 * reach, 0.0) * np.array([-1, -1, 1, 1])
    out = bounds + step
    if not np.isfinite(cost) or not near.any():
        centre = np.tile(0.5 * (bounds[:2] + bounds[2:]), 2)
        return np.where(near | ~np.isfinite(cost) | ~near.any(), centre + 2.0 * (bounds - centre), out)
    a = 0.5 * (cost - reached) / c  # semi-major axes
    f = 0.5 * np.hypot(*(target - exits).T)  # half the focal distance (< a: x is short)
    b = np.sqrt(np.maximum(a * a - f * f, 0.0))
    theta = np.arctan2(target[1] - py, target[0] - px)
    hx = np.sqrt((a * np.cos(theta)) ** 2 + (b * np.sin(theta)) ** 2)
    hy = np.sqrt((a * np.sin(theta)) ** 2 + (b * np.cos(theta)) ** 2)
    mx, my = 0.5 * (px + target[0]), 0.5 * (py + target[1])
    r = np.maximum(cost - reached, 0.0) / c
    box = np.array([np.maximum(mx - hx, px - r).min() - reach, np.maximum(my - hy, py - r).min() - reach,
                    np.minimum(mx + hx, px + r).max() + reach, np.minimum(my + hy, py + r).max() + reach])
    return np.concatenate([np.minimum(out[:2], box[:2]), np.maximum(out[2:], box[2:])])


def _near_sides(inside: np.ndarray, exits: np.ndarray, reach: float) -> np.ndarray:
    """(4,) bool: which sides of a window's lattice (``inside``: xmin, ymin, xmax, ymax) have an exit of
    ``exits`` (m) within ``reach`` (:func:`_grown` moves those out)."""
    px, py = exits.T
    return np.array([(px < inside[0] + reach).any(), (py < inside[1] + reach).any(),
                     (px > inside[2] - reach).any(), (py > inside[3] - reach).any()])


def _on_map(window: GraphWindow, route: Route | None, *_) -> Route | None:
    """A window's route with the map's G′ vertex numbers."""
    if route is None:
        return None
    return replace(route, vertices=window.to_map(route.vertices))


def _best_route(graph: PathGraph, lat: KindMask, extra: np.ndarray, source: int, target: int,
                from_source: np.ndarray, from_target: np.ndarray, first: tuple[list[int], float],
                opts: RoutingOptions) -> Route:
    """The turn-penalised optimum, given the plain distances from both ends (``from_target`` up to
    the bound) and a feasible route with an upper bound of its cost (the plain shortest path with
    its turns, or a smaller window's best route).

    Searched forwards (:func:`_tiled_search`) or, with ``opts.backward``, from the target backwards
    (:func:`_backward_route`), which falls back to the forward search when its last Dijkstra does
    not confirm the cost it found. The forward search's first bound is made tight first
    (:func:`_band_bound`); it is only a bound: the search still finds its own route (of several of
    exactly equal cost, the one its Dijkstra takes)."""
    penalties = _bin_penalties(opts)
    best = None
    lower = from_source + from_target
    if opts.backward:
        best = _backward_route(graph, lat, extra, source, target, from_source, from_target, first,
                               np.asarray(first[0]), penalties, opts)
    if best is None:
        bound = _band_bound(graph, lat, extra, source, target, lower, from_target, first, penalties, opts)
        # A*: the turn-free distance to the target is a consistent bound (turns cost ≥ 0), the first
        # tiles those of the feasible route
        best, _ = _tiled_search(graph, lat, extra, source, target, lower, from_target, bound,
                                np.asarray(bound[0]), penalties, opts, graph.xy[target])
    vertices, total = best
    route = _route(graph, vertices, lat, extra, 0.0)
    return _with_turn_cost(route, max(total - float(route.edge_weight.sum()), 0.0))


def _band_bound(graph: PathGraph, lat: KindMask, extra: np.ndarray, source: int, target: int, lower: np.ndarray,
                from_target: np.ndarray, first: tuple[list[int], float], penalties: np.ndarray,
                opts: RoutingOptions) -> tuple[list[int], float]:
    """A feasible route and an upper bound of its expanded-graph cost, tight: the best route in a
    narrow band round ``first`` (its vertices' tiles of ``bound_cells`` a side and their
    neighbours), or ``first`` where the band holds none cheaper.

    The search's prunings (the region ``d_s + d_t ≤ C``, Dijkstra's limit, A*'s test that grows its
    tiles) all work with the best cost C known; the plain shortest path's penalised cost is up to
    3.7 times the best on Campo Grande's searches (turns are most of a route's cost in a street
    grid); the band's best was a few per cent above the best at most on those searches (a
    measurement, not a guarantee: the bound is only as tight as the band's route). The band is searched by A* (reduced
    costs, :func:`_reduced`: ties do not matter for a bound) over its own vertices only, so it
    costs a small share of the search it bounds. The bound returned is the band route's
    distance plus rounding slack: the search that uses it finds a route strictly below it, its
    own (:func:`_tiled_search` keeps a route only where its Dijkstra finds one cheaper than C).
    """
    if opts.bound_cells < 1:
        return first
    k = opts.heading_bins
    cost = first[1]
    tile, _, active = _first_tiles(graph, opts.bound_cells, np.asarray(first[0]))
    # the source and target are in the band: on ``first``, and their ``lower`` is d(s, t) ≤ its cost
    verts = np.flatnonzero((lower <= cost + 1e-9 * cost + 1e-6) & active[tile])
    local = _local(graph, verts, k)
    states = _States(len(verts), k)
    slack = 2 * states.size * _EPS
    h = from_target[verts] * (1.0 - _SHRINK)
    start = states.hub(local[source])
    hs = float(h[local[source]])
    dist, pred = _heading_search(graph, lat, extra, verts, local, penalties, k, start, cost - hs + slack, h=h,
                                 predecessors=True)
    end = _target_end(dist, states, int(local[target]))
    found = float(dist[end]) + hs - float(h[local[target]])  # ≥ the path's cost: reduced costs only rounded up
    found += 1e-9 * found + 1e-6 + slack
    if not found < cost:
        return first  # nothing cheaper in the band (e.g. the plain route is the best): the search keeps first
    return _vertex_path(pred, start, end, verts, states), found


def _headings(route: Route) -> np.ndarray:
    """Heading (radians) of each edge of a route."""
    d = np.diff(route.xy, axis=0)
    return np.arctan2(d[:, 1], d[:, 0])


def _with_turn_cost(route: Route, turn_cost: float) -> Route:
    return replace(route, turn_cost=turn_cost)


def _walk_back(pred: np.ndarray, source: int, target: int) -> list[int]:
    path = [target]
    while path[-1] != source:
        path.append(int(pred[path[-1]]))
    return path[::-1]


def _route(graph: PathGraph, vertices: Sequence[int], lat: KindMask, extra: np.ndarray,
           turn_cost: float) -> Route:
    v = np.asarray(vertices, dtype=np.int64)
    steps = graph.steps(v[:-1], v[1:], lat, extra)
    return Route(vertices=v, xy=graph.xy[v], kind=steps.kind, segment=steps.segment,
                 edge_length=steps.length, edge_weight=steps.weight, turn_cost=turn_cost)


def _lattice_weight(graph: PathGraph, u: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The weights of the lattice edges from vertices ``u`` along directions ``d`` (float64 where
    flat land's weights are worked out from the kinds, :meth:`LatticeWeights.at`; the same values)."""
    weight = graph.lat_weight
    return weight.at(u, d) if isinstance(weight, LatticeWeights) else weight[u, d]


#: vertices per block when the expanded graph's entries are written (about a million entries a block)
_BLOCK = 8192


@dataclass(frozen=True)
class _States:
    """The numbering of the heading-expanded graph's states over ``n`` vertices with ``k`` heading
    bins: first every arrival ``arr(v, j) = v·k + j``, then every departure ``dep(v, j) = (n + v)·k + j``,
    then every hub ``hub(v) = 2nk + v`` (v the vertex's local number).

    Grouped by kind, not by vertex, so that the arrivals' rows (each vertex's cheap turns and the
    hub, the same for every vertex) and the hubs' rows are one regular block each of the CSR arrays,
    written by broadcasting where a vertex's rows between its departures were scattered writes:
    the arrivals and hubs are four fifths of the entries (Campo Grande's searches: 144 of about 180 a
    vertex). Making the expanded graphs of Campo Grande's 36 captured searches (213 M entries) took
    7.6 → 3.8 s CPU (session 35, one pair back to back on a loaded machine).

    The distances do not depend on the numbering. Of a state's in-neighbours that attain its
    distance, scipy's Dijkstra (1.17) takes the one of least distance and, of equal ones, the
    highest numbered as its predecessor: those in-neighbours are all departures (of an arrival), or one
    vertex's arrivals and its hub (of a departure or the hub), whose order this numbering and the
    per-vertex one it replaced (``v·(2k + 1) + slot``) share. So every state keeps its predecessor,
    ties included, and the routes their bytes (``tests/test_routing_search.py``; a random numbering
    changes some).
    """

    n: int  #: vertices
    k: int  #: heading bins

    @property
    def size(self) -> int:
        """States in all: ``n · (2k + 1)``."""
        return self.n * (2 * self.k + 1)

    def hub(self, v: int) -> int:
        """The hub state of local vertex ``v`` (where a route starts)."""
        return 2 * self.n * self.k + int(v)

    def arrivals(self, v: int) -> np.ndarray:
        """The ``k`` arrival states of local vertex ``v``, bins ascending (where a route ends)."""
        return int(v) * self.k + np.arange(self.k)

    def vertex(self, states: np.ndarray) -> np.ndarray:
        """The local vertex of each state."""
        s = np.asarray(states, dtype=np.int64)
        nk = self.n * self.k
        return np.where(s < 2 * nk, (s // self.k) % max(self.n, 1), s - 2 * nk)

    def slot(self, states: np.ndarray) -> np.ndarray:
        """Each state's place among its vertex's ``2k + 1``: arrivals j, departures ``k + j``, the hub 2k."""
        s = np.asarray(states, dtype=np.int64)
        nk = self.n * self.k
        return np.where(s < nk, s % self.k, np.where(s < 2 * nk, self.k + s % self.k, 2 * self.k))

    def state(self, v: np.ndarray, slot: np.ndarray) -> np.ndarray:
        """The state of local vertex ``v`` at ``slot`` (:meth:`slot`'s places)."""
        v, slot = np.asarray(v, dtype=np.int64), np.asarray(slot, dtype=np.int64)
        k, nk = self.k, self.n * self.k
        return np.where(slot < k, v * k + slot, np.where(slot < 2 * k, nk + v * k + slot - k, 2 * nk + v))

    def by_vertex(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Views of a per-state array: ``(n, k)`` arrivals, ``(n, k)`` departures, ``(n,)`` hubs."""
        nk = self.n * self.k
        return values[:nk].reshape(self.n, self.k), values[nk:2 * nk].reshape(self.n, self.k), values[2 * nk:]

    def per_state(self, h: np.ndarray) -> np.ndarray:
        """A per-vertex array spread to every state of its vertex."""
        return np.concatenate([np.repeat(h, self.k), np.repeat(h, self.k), h])


def _local(graph: PathGraph, region: np.ndarray, k: int) -> np.ndarray:
    """Each G′ vertex's local number in ``region`` (sorted), −1 outside; in 32 bits when the states fit."""
    it = np.dtype(np.int32 if _States(len(region), k).size < 2**31 else np.int64)
    local = np.full(graph.n_vertices, -1, dtype=it)
    local[region] = np.arange(len(region), dtype=it)
    return local


def _departure_order(graph: PathGraph, extra: np.ndarray, local: np.ndarray,
                     k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The order of a departure row's entries, which the written graph (:func:`_departures`) and the
    compiled search (:func:`_heading_search`) must share for scipy's ties: each direction's heading bin
    and the directions by bin (ascending within one), then the other edges (streets, stitches, long
    bridges) with both ends in the region (``local`` ≥ 0) by departure row ``dep(u, b)`` (ascending
    within one) and their bins, int64."""
    dir_bin = _bins(graph.direction_heading, k)
    by_bin = np.argsort(dir_bin, kind="stable")
    e = np.flatnonzero(extra & (local[graph.src] >= 0) & (local[graph.dst] >= 0))
    e_bin = _bins(graph.heading[e], k)
    order = np.argsort(local[graph.src[e]].astype(np.int64) * k + e_bin, kind="stable")
    return dir_bin, by_bin, e[order], e_bin[order]


def _departures(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, local: np.ndarray,
                k: int, skip: int = 0, tail: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The heading-expanded graph's departure rows over ``region`` (:func:`_expanded_graph`): each row's
    entry count (``n·k``, row ``dep(u, b)`` at ``u·k + b``), and the entries' columns (``arr(w, b)``)
    and weights, row after row, written from ``skip`` on in arrays with room for ``skip`` entries
    before them and ``tail`` after (the expanded matrix's arrivals and hubs; none for the departures
    alone).

    Each row ``dep(u, b)`` holds its lattice moves ``→ arr(w, b)`` (directions ascending) and then
    its other edges (streets, stitches, long bridges; edges ascending). Written block by block of
    vertices straight to their places (offsets from counts, no sort and no array as long as the
    graph but the result: a town's region has 10⁷–10⁸ entries); the lattice moves of a block are
    generated once (an upper bound of their number sizes the arrays, which are cut to length at the
    end).
    """
    n = len(region)
    nk = n * k
    it = local.dtype
    n_lat, n_dir = lat.shape
    dir_bin, by_bin, e, e_bin = _departure_order(graph, extra, local, k)
    dir_bin, e_bin = dir_bin.astype(it), e_bin.astype(it)
    offset = graph.lattice.direction_offset
    n_lat_region = int(np.searchsorted(region, n_lat))  # region's lattice vertices come first
    # other edges (streets, stitches, long bridges), by departure row dep(u, b) = u · k + b
    e_row = local[graph.src[e]].astype(np.int64) * k + e_bin
    e_col = local[graph.dst[e]] * k + e_bin  # arr(w, b)
    e_val = graph.weight[e]
    size = _States(n, k).size
    bound = skip + tail + len(e) + int(lat.count_per_row(region[:n_lat_region]).sum())
    indices = np.empty(bound, dtype=np.int32 if max(size, bound) < 2**31 else np.int64)
    data = np.empty(bound)
    dep_count = np.zeros(nk, dtype=indices.dtype)  # entries of each departure row
    at = skip  # entries written so far
    for a in range(0, n, _BLOCK):
        b = min(a + _BLOCK, n)
        part = region[a:min(b, n_lat_region)]  # the block's lattice vertices
        if len(part):
            flat = np.flatnonzero(lat[part][:, by_bin])
            r = flat // n_dir
            d = by_bin[flat - r * n_dir]
            u = part[r]
            v = u + offset[d]
            keep = local[v] >= 0
            u, v, d = u[keep], v[keep], d[keep]
            m_row = local[u].astype(np.int64) * k + dir_bin[d]  # non-decreasing
            m_col = local[v] * k + dir_bin[d]  # arr(v, b)
            m_val = _lattice_weight(graph, u, d)
        else:
            m_row = np.zeros(0, dtype=np.int64)
            m_col, m_val = np.zeros(0, dtype=it), np.zeros(0)
        lo, hi = np.searchsorted(e_row, [a * k, b * k])
        o_row = e_row[lo:hi] - a * k
        m_row -= a * k
        m_count = np.bincount(m_row, minlength=(b - a) * k)
        o_count = np.bincount(o_row, minlength=(b - a) * k)
        # a row's moves first, then its other edges: each entry's place among the block's departures is
        # its place among its own kind plus the other kind's entries before it (a gather from the
        # counts, where two binary searches of every move took as long as writing them)
        m_pos = at + np.arange(len(m_row)) + (np.cumsum(o_count) - o_count)[m_row]
        o_pos = at + np.arange(len(o_row)) + np.cumsum(m_count)[o_row]
        indices[m_pos], data[m_pos] = m_col, m_val
        indices[o_pos], data[o_pos] = e_col[lo:hi], e_val[lo:hi]
        dep_count[a * k:b * k] = m_count + o_count
        at += len(m_row) + len(o_row)
    indices.resize(at + tail, refcheck=False)
    data.resize(at + tail, refcheck=False)
    return dep_count, indices, data


def _turn_rows(penalties: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """An arrival row's turns: the bin differences q cheaper than S_p (ascending), their weights
    (at least ``_EPS``), and the weight of the row's last entry, to the hub (S_p)."""
    height = float(penalties.max())
    cheap = np.flatnonzero(penalties < height - 1e-9)
    return cheap, np.maximum(penalties[cheap], _EPS), max(height, _EPS)


def _expanded_graph(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, penalties: np.ndarray,
                    k: int) -> tuple[csr_matrix, np.ndarray]:
    """The heading-expanded graph over ``region`` (sorted; states numbered as :class:`_States` says)
    and each G′ vertex's local number (−1 outside).

    Each arrival row holds its cheap turns ``arr(v, i) → dep(v, i + q)`` (P < S_p, q ascending)
    and then ``arr(v, i) → hub(v)`` at S_p; each departure row ``dep(u, b)`` its lattice moves
    and other edges (:func:`_departures`); the hub row ``hub(v) → dep(v, j)`` for every j, free.
    The arrivals' and hubs' rows are one regular block each, written at once. The route searches
    make the arrivals' and hubs' rows as they go and never write this matrix
    (:mod:`~osm_expand.engine.roads.expanded_search`): it is the reference the tests hold them to,
    and :func:`_summed_cost` reads a route's own.
    """
    n = len(region)
    states = _States(n, k)
    nk = n * k
    local = _local(graph, region, k)
    it = local.dtype
    cheap_q, cheap_cost, hub_cost = _turn_rows(penalties)
    cheap = cheap_q.astype(it)
    n_turn = len(cheap) + 1  # entries of an arrival row: the cheap turns and the hub
    i = np.arange(k, dtype=it)
    n_arr = nk * n_turn  # the arrivals' entries, first
    dep_count, indices, data = _departures(graph, lat, extra, region, local, k, skip=n_arr, tail=nk)
    # the arrivals: each row its cheap turns, then the hub (block by block: no temporary as large as them)
    cols = indices[:n_arr].reshape(n, k, n_turn)
    turns = (nk + (i[:, None] + cheap) % k)[None]
    for a in range(0, n, _BLOCK):
        vert = np.arange(a, min(a + _BLOCK, n), dtype=it)
        cols[a:a + len(vert), :, :-1] = turns + (vert * k)[:, None, None]
        cols[a:a + len(vert), :, -1] = (2 * nk + vert)[:, None]
    vals = np.empty(n_turn)
    vals[:-1] = cheap_cost
    vals[-1] = hub_cost
    data[:n_arr].reshape(-1, n_turn)[:] = vals
    at = len(indices) - nk
    # the hubs: every departure, free
    indices[at:] = nk + np.arange(nk, dtype=indices.dtype)
    data[at:] = _EPS
    # the row pointers in the indices' type (32 bits while the bound fits), which the CSR keeps as they
    # are: made in 64 bits, they and the row lengths were two temporaries of 8 bytes a state next to the
    # CSR, and scipy copied them to 32 bits (the synthetic 10,000-street town's last tiled search,
    # 22.5 M states: 450 MB of the road year's peak)
    indptr = np.empty(states.size + 1, dtype=indices.dtype)
    indptr[0] = 0
    indptr[1:nk + 1] = n_turn
    indptr[nk + 1:2 * nk + 1] = dep_count
    indptr[2 * nk + 1:] = k
    del dep_count
    np.cumsum(indptr, dtype=indices.dtype, out=indptr)
    return csr_matrix((data, indices, indptr), shape=(states.size, states.size)), local


def _lattice_rows(graph: PathGraph, lat: KindMask) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                             np.ndarray]:
    """What the compiled searches read of the lattice's moves (:mod:`~osm_expand.engine.roads.expanded_search`):
    the kind table, the kinds allowed, and the weights as a table by ``kind · D + direction`` (a
    :class:`LatticeWeights`', read by its own kinds) or a float32 ``(V, D)`` table (sloped land's).

    One set of argument types, so a run compiles each search once (expanded_search's docstring): a
    float32 plain table (sloped land's, lattice.directed_tables; a (1, 1) one beside a kind table); a
    LatticeWeights is read by its own kinds, which need not be the mask's array, never by its (V, D)
    table made whole."""
    allowed = np.zeros(256, dtype=bool)
    if isinstance(lat, KindMask):
        lat_kind = lat.kind
        allowed[list(lat.kinds)] = True  # the lattice kinds among those asked for
    else:  # a plain (V, D) bool table
        lat_kind = np.asarray(lat, dtype=bool).view(np.uint8)
        allowed[1] = True
    weight = graph.lat_weight
    if isinstance(weight, LatticeWeights):
        return lat_kind, allowed, weight.table64, np.zeros((1, 1), np.float32), weight.kind
    # a float64 table (none of the lattice's) would keep its values and compile a second time
    return lat_kind, allowed, np.zeros(0), np.asarray(weight), np.zeros((1, 1), np.uint8)


def _heading_search(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, local: np.ndarray,
                    penalties: np.ndarray, k: int, start: int, limit: float, h: np.ndarray | None = None,
                    predecessors: bool = False, ties: bool = False,
                    resume: Resume | None = None, turns: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """scipy's Dijkstra from state ``start`` on the heading-expanded graph over ``region`` (``local``:
    :func:`_local`), up to ``limit``, on A*'s reduced costs with ``h`` (per region vertex, as
    :func:`_reduced` makes them): the distances and (with ``predecessors``, else empty) the predecessors,
    per state. With ``ties``: A* by ``h`` on the graph's own weights up to ``limit`` on ``g + h``,
    which gives the states of a route found below the limit the distances and predecessors scipy's
    Dijkstra up to ``limit`` on ``g`` gives, and searches fewer
    (:func:`~osm_expand.engine.roads.expanded_search.expanded_dijkstra`). With ``resume`` it goes on
    from the last search over the same states, ``local`` having more vertices since.

    The compiled search (:mod:`~osm_expand.engine.roads.expanded_search`) makes each state's row
    when it reaches it: the arrivals' and hubs' from the turn penalties, the departures' lattice
    moves from the lattice's kinds and weights (a direction's step is the same everywhere), and
    only the few other edges (streets, stitches, long bridges) are gathered first. No expanded
    matrix is written (:func:`_expanded_graph`, the tests' reference, writes them in the very
    order the search reads them), and it takes each state's predecessor as scipy does, ties
    included, so the routes keep their bytes. Imported here, so that commands which search no
    route do not import numba."""
    from osm_expand.engine.roads.expanded_search import expanded_dijkstra

    rows = _expanded_rows(graph, lat, extra, region, local, penalties, k)
    return expanded_dijkstra(rows, start, limit, h=h, return_predecessors=predecessors, ties=ties, resume=resume,
                             turns=turns)


def _heading_steps(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, local: np.ndarray,
                   penalties: np.ndarray, k: int, start: int, limit: float, h: np.ndarray,
                   resume: Resume | None, enough: Callable[[np.ndarray, np.ndarray], bool]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """:func:`_heading_search` on A*'s reduced costs (no predecessors), paused now and then to ask
    ``enough`` whether the distances so far (upper bounds of their ends) and the states still queued
    (no state not yet scanned ends below their least distance) already say enough; the distances,
    the predecessors (empty) and, where it stopped so before its end, the states it left queued.

    The pauses come after ``_FIRST_PAUSE`` popped entries, then each after twice as many as the last
    (a search that runs to the end asks about log₂ of its states / ``_FIRST_PAUSE`` times). Gone on
    with, a paused search scans as one run whole
    (:func:`~osm_expand.engine.roads.expanded_search.expanded_steps`): where ``enough`` never says
    yes, the same distances to the bit."""
    from osm_expand.engine.roads.expanded_search import expanded_steps

    rows = _expanded_rows(graph, lat, extra, region, local, penalties, k)
    budget = _FIRST_PAUSE
    while True:
        dist, pred, resume = expanded_steps(rows, start, limit, h=h, resume=resume, budget=budget)
        if resume is None:
            return dist, pred, None
        if enough(dist, resume.seeds):
            return dist, pred, resume.seeds
        budget *= 2


#: entries the exits' search pops before it first asks whether the next window is settled
#: (:func:`_heading_steps`); Campo Grande's captured calls (session 42) settled it after 0.3–5 % of
#: searches of 0.2–2.3 M states, so the first asks come early and the doubling keeps a search that
#: never settles it to a few asks
_FIRST_PAUSE = 4096


def _expanded_rows(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, local: np.ndarray,
                   penalties: np.ndarray, k: int) -> Expanded:
    """What the compiled searches read of the heading-expanded graph over ``region`` (``local``: the
    vertices searched numbered, the rest −1), beside the rows they make themselves
    (:class:`~osm_expand.engine.roads.expanded_search.Expanded`)."""
    from osm_expand.engine.roads.expanded_search import Expanded

    n = len(region)
    dir_bin, by_bin, e, e_bin = _departure_order(graph, extra, local, k)
    dirs = by_bin.astype(np.int64)  # by bin, directions ascending within one
    dirs_ptr = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(np.bincount(dir_bin, minlength=k), out=dirs_ptr[1:])
    lat_kind, allowed, table, plain, w_kind = _lattice_rows(graph, lat)
    if local.dtype != np.int32:  # local numbers below n: 32 bits hold them while n < 2³¹
        local = local.astype(np.int32)
    # the other edges by vertex, each vertex's in its departure rows' order (bin, then edge)
    e_src = local[graph.src[e]].astype(np.int64)
    e_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(e_src, minlength=n), out=e_ptr[1:])
    cheap, cheap_cost, hub_cost = _turn_rows(penalties)
    rows = Expanded(n=n, k=k, cheap=cheap.astype(np.int64), cheap_cost=cheap_cost, hub_cost=hub_cost, eps=_EPS,
                    region=region.astype(np.int64, copy=False), local=local, n_lat=int(lat.shape[0]), lat_kind=lat_kind,
                    allowed=allowed, offset=graph.lattice.direction_offset.astype(np.int64), dirs_ptr=dirs_ptr,
                    dirs=dirs, table=table, plain=plain, w_kind=w_kind, e_ptr=e_ptr, e_bin=e_bin,
                    e_col=local[graph.dst[e]].astype(np.int64) * k + e_bin, e_val=graph.weight[e].astype(np.float64))
    return rows


def _expanded_search(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, source: int,
                     target: int, penalties: np.ndarray, k: int, limit: float) -> tuple[list[int], float] | None:
    """Dijkstra on the heading-expanded graph over ``region``; the vertex path and its cost (over every
    vertex: the reference the tests hold :func:`_tiled_search` to)."""
    states = _States(len(region), k)
    expanded, local = _expanded_graph(graph, lat, extra, region, penalties, k)
    start = states.hub(local[source])
    dist, pred = dijkstra(expanded, indices=start, return_predecessors=True, limit=limit + 2 * states.n * _EPS)
    best = _target_end(dist, states, int(local[target]))
    if not np.isfinite(dist[best]):
        return None
    return _vertex_path(pred, start, best, region, states), float(dist[best])


def _turn_floor(penalties: np.ndarray) -> np.ndarray:
    """``need[m]``, m = 0 … K/2 (K even): the least turn cost of any route whose first edge's heading bin is
    b, or that arrives on b and may turn at once, when its end lies m bins away from b (:func:`_turns_needed`).

    Why it holds: an edge of bin b heads within ±Δ/2 of ``b·Δ`` (Δ = 2π/K; streets' pieces by
    their chords, the lattice's by their directions), so a route whose edges' bins all lie in an
    arc of bins narrower than π ends inside that arc's sector. A route from bin b to an end m bins
    off therefore visits a bin at least m away on that side, or spreads its bins over half the
    circle. Its turns cost at least those of the cheapest walk over the bins (a turn of q bins
    costs ``P(q)``, the hub ``S_p ≥ P(q)``) that does either: a Dijkstra over the walks' states
    (bin, the arc of bins visited so far) — a few hundred of them.
    """
    k = len(penalties)
    narrow = k // 2 - 2  # the widest arc (hi − lo bins) whose sector is narrower than π
    reach = np.full(narrow + 1, np.inf)  # least cost to visit a bin m ≥ 1 away on one side (mirror)
    reach[0] = 0.0
    span = np.inf  # least cost to visit bins spread over half the circle or more
    settled: set[tuple[int, int, int]] = set()
    heap = [(0.0, 0, 0, 0)]  # (cost, bin, lo, hi), offsets from the first bin
    while heap:
        cost, c, lo, hi = heapq.heappop(heap)
        if (c, lo, hi) in settled:
            continue
        settled.add((c, lo, hi))
        for m in (hi, -lo):
            reach[m] = min(reach[m], cost)
        for q in range(1, k):
            step = cost + float(penalties[q])
            b = c + q
            inside = [r for r in range(b - 2 * k, b + k, k) if lo <= r <= hi]
            if inside:
                heapq.heappush(heap, (step, inside[0], lo, hi))
                continue
            above = b + k * -(-(hi + 1 - b) // k)  # the bin's first offset above the arc
            below = above - k
            arcs = ((above, lo, above), (below, below, hi))
            width = min(new_hi - new_lo for _, new_lo, new_hi in arcs)  # the least arc holding them
            if width > narrow:
                span = min(span, step)
                continue
            for r, new_lo, new_hi in arcs:
                if new_hi - new_lo == width:
                    heapq.heappush(heap, (step, r, new_lo, new_hi))
    need = np.full(k // 2 + 1, span)
    need[:narrow + 1] = np.minimum(np.minimum.accumulate(reach[::-1])[::-1], span)
    return need


def _turns_needed(need: np.ndarray, heading_bin: np.ndarray, xy: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The least turn cost of the rest of a route at ``xy`` on ``heading_bin`` (departing on it, or
    arriving and free to turn at once) to ``goal``: ``need`` (:func:`_turn_floor`) of the bins
    between the heading and the goal's direction (0 at the goal itself).

    The goal m bins away means its direction lies beyond ``(m − ½)·Δ`` from the bin's centre
    (less 10⁻⁹ rad for rounding), so that no arc of bins short of m holds it.
    """
    k = 2 * (len(need) - 1)
    delta = 2.0 * np.pi / k
    d = goal - xy
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(d[..., 1], d[..., 0]) - heading_bin * delta))))
    m = np.clip(np.ceil((off - 0.5 * delta - 1e-9) / delta), 0, k // 2).astype(np.int64)
    return np.where((d[..., 0] == 0) & (d[..., 1] == 0), 0.0, need[m])


def _tile_of(graph: PathGraph, size: int) -> tuple[np.ndarray, tuple[int, int]]:
    """The tile of each G′ vertex, tiles being ``size`` × ``size`` lattice vertices (street points
    by the lattice vertex nearest them), and the tiles' grid shape (rows, columns)."""
    lat = graph.lattice
    ny, nx = lat.shape
    shape = (-(-ny // size), -(-nx // size))
    n_lat = graph.n_lattice
    row, col = np.divmod(np.arange(n_lat), nx)
    street = graph.xy[n_lat:]
    s_col = np.clip(np.rint((street[:, 0] - lat.origin[0]) / lat.spacing), 0, nx - 1).astype(np.int64)
    s_row = np.clip(np.rint((street[:, 1] - lat.origin[1]) / lat.spacing), 0, ny - 1).astype(np.int64)
    tile = np.concatenate([row // size * shape[1] + col // size, s_row // size * shape[1] + s_col // size])
    return tile, shape


def _first_tiles(graph: PathGraph, cells: int, seed: np.ndarray
                 ) -> tuple[np.ndarray, tuple[int, int], np.ndarray]:
    """The window's tiles of ``cells`` lattice cells (each vertex's tile and the tiles' shape) and the
    first active tiles: those of the ``seed`` vertices and their neighbours."""
    tile, shape = _tile_of(graph, cells)
    active = np.zeros(shape[0] * shape[1], dtype=bool)
    active[tile[np.asarray(seed, dtype=np.int64)]] = True
    return tile, shape, _dilated(active, shape)


def _grown_tiles(active: np.ndarray, reached: np.ndarray, region_tiles: np.ndarray, shape: tuple[int, int],
                 searched: int) -> np.ndarray:
    """The tiles to add to ``active`` (flat bool): those of the ``reached`` vertices' tiles and their
    neighbours, grown ring after ring until they hold at least ``searched`` vertices of the region
    (``region_tiles``: the tile of each region vertex) or no tile is left. At least twice as large each
    round: each search makes the expanded graph anew, so the searches together cost at most about
    twice the last one."""
    grow = np.zeros_like(active)
    grow[reached] = True
    grow = _dilated(grow, shape)
    per_tile = np.bincount(region_tiles, minlength=len(active))
    while per_tile[grow & ~active].sum() < searched and (per_tile[~active & ~grow] > 0).any():
        grow = _dilated(grow, shape)
    return grow


def _dilated(tiles: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Tiles (flat bool) and their eight neighbours."""
    return binary_dilation(tiles.reshape(shape), structure=np.ones((3, 3), dtype=bool)).ravel()


def _goes_on(kept: tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray], cost: float, region: np.ndarray,
             h: np.ndarray, k: int, reduced: float | None = None) -> bool:
    """Whether :func:`_tiled_search`'s next search (best cost ``cost``, ``region`` its vertices' bound) may
    go on from the last one (``kept``: the cost it was made with, the region's vertices it numbered,
    the active ones, its distances and predecessors) rather than start again. ``reduced``: None where
    the distances are g (the route search's, ``g + h`` read as ``dist + h``), else the source's scaled
    bound ``h(s)`` of a search on A*'s reduced costs (the exits'), whose ``dist = g + h − h(s)``:
    there ``g + h`` is ``dist + h(s)``.

    While C holds, the region, the states' numbers and the limit are the same and the active set only
    grows: it goes on. Where the last search found a cheaper route, C fell: the limit falls with it
    and the region loses the vertices whose bound is now above C. A state whose distance came through
    one of those has ``g + h`` at least that vertex's (h is consistent), so where every state of the
    vertices left out has ``g + h`` above the new limit, every state within it has the distance (and
    predecessor) a search without them gives, and those above it are never read as below C (the
    search's and the growth test's comparisons): it goes on, the states left out are simply no longer
    searched. Else it starts again: where such a state's ``g + h`` lies within the search's rounding
    slack above the new C (``2·states·ε``, of the whole region's states: 0.116 at the synthetic town's
    58 M, more than the region's margin ``1e-9·C + 1e-6``), or by rounding.

    The slack is the whole region's, not the active states' as each search from scratch had it: a
    search goes on only with the limit it was made with (:class:`~.expanded_search.Resume`), and the
    active states' slack grows with the tiles. Both bound the rounding; the larger scans a few more
    states (those within it above C, never taken: a route is taken only below C)."""
    made, full, inside, dist, _ = kept
    if cost == made:
        return True
    if not cost < made:
        return False
    states = _States(len(full), k)
    out = inside & ~region
    rows = np.searchsorted(full, np.flatnonzero(out))  # their states' vertex numbers (``full`` is sorted)
    arrive, depart, hub = states.by_vertex(dist)
    # g + h = dist + the bound the search read (``h[full]`` so scaled), vertex by vertex; dist + h(s) on reduced costs
    hy = h[full[rows]] * (1.0 - _SHRINK) if reduced is None else reduced
    least = np.minimum(np.minimum(arrive[rows].min(axis=1, initial=np.inf), depart[rows].min(axis=1, initial=np.inf)),
                       hub[rows]) + hy
    return bool((least > cost + 2 * states.size * _EPS).all())


def _again(graph: PathGraph, lat: KindMask, extra: np.ndarray, local: np.ndarray, before: np.ndarray,
           added: np.ndarray, tile: np.ndarray, shape: tuple[int, int], states: _States, dir_bin: np.ndarray,
           extra_bin: np.ndarray, rings: int) -> np.ndarray:
    """The states a search over the vertices ``before`` scans again when it goes on over ``added`` too
    (:func:`_tiled_search`): the departures ``dep(u, b)`` of the vertices u of ``before`` with an allowed
    edge of heading bin b into ``added`` (``local``: the states' vertex numbers). A cheaper path than
    the last search found passes such an edge, so these and the states whose distance then falls are
    all the search must scan again to end as a search from scratch over both would.

    The lattice's edges are looked for from the tiles within ``rings`` of the added vertices' (an
    edge spans at most the lattice's radius), the other edges (streets, stitches, long bridges) by
    their ends."""
    k, nk = states.k, states.n * states.k
    near = np.zeros(shape[0] * shape[1], dtype=bool)
    near[tile[added]] = True
    for _ in range(rings):
        near = _dilated(near, shape)
    n_lat = lat.shape[0]
    offset = graph.lattice.direction_offset
    tails = np.flatnonzero(before[:n_lat] & near[tile[:n_lat]])
    found = [np.zeros(0, dtype=np.int64)]
    for a in range(0, len(tails), _BLOCK):
        u = tails[a:a + _BLOCK]
        r, d = np.nonzero(lat[u])
        hit = added[u[r] + offset[d]]
        found.append(nk + local[u[r[hit]]].astype(np.int64) * k + dir_bin[d[hit]])
    e = np.flatnonzero(extra & before[graph.src] & added[graph.dst])
    found.append(nk + local[graph.src[e]].astype(np.int64) * k + extra_bin[e])
    return np.unique(np.concatenate(found))


def _turns_to_go(graph: PathGraph, lat: KindMask, extra: np.ndarray, region: np.ndarray, penalties: np.ndarray,
                 k: int, target: int, limit: float | np.ndarray = np.inf, budget: int = -1) -> np.ndarray:
    """Per state of the expanded graph over ``region`` (sorted, :class:`_States`' numbers), the least turn
    cost T of a path from it to an arrival at ``target`` inside the region, through states within
    ``limit`` (one for all, or per vertex: the region's order), clamped at the limit of its vertex:
    Dijkstra backwards from the target's arrivals on the turn penalties alone (without the search's
    floor ε), every move and other edge costing 0 (compiled,
    :func:`~osm_expand.engine.roads.expanded_search.turns_to_go`; no matrix written). With a
    ``budget`` (≥ 0) it stops after scanning that many states and clamps every T at the turn cost
    it had reached (``RoutingOptions.turn_share``).

    With one limit: consistent on the turns (``T(x) ≤ t(x, y) + T(y)``, t an edge's turn cost; the
    clamp keeps it so) and a lower bound of the turns of every route from x, so ``D + T`` (D the
    plain distance to the target, consistent on the lengths) is a consistent bound of the whole
    cost, ``min(len + turns) ≥ min len + min turns`` (session 39, h39s).

    The corridor (session 40): the route search gives each vertex the limit ``C′ − lower(v)``
    (``lower = d_s + D``, d_s the plain distance from the source; C′ the best cost known, a margin
    above). The bound is then ``B = min(D + T_r, C′ − d_s)``, T_r the least turns through states
    kept. Consistent: ``C′ − d_s`` is (``d_s(w) ≤ d_s(v) + c``), and on an edge x → y at c + t
    where y was kept, ``D(x) + T_r(x) ≤ c + t + D(y) + T_r(y)``; where y was not, B(y) is its
    ``C′ − d_s``; a minimum of consistent bounds is consistent. Below the cost to go h*(x): where
    ``d_s(x) + h*(x) > C′``, B ≤ C′ − d_s < h*; else every state p on x's best path to the target
    has ``d_s(p) + D(p) + T_path(p) ≤ d_s(x) + h*(x) ≤ C′``, so backwards from the target each is
    kept with T_r(p) ≤ T_path(p), and ``B(x) ≤ D(x) + T_path(x) ≤ h*(x)``. And B ≥ D in the region
    (its limits ≥ 0). The budget's clamp at τ is a minimum with a constant: consistent too.
    ``tests/test_routing_search.py`` checks both edge by edge against scipy's backward search.

    Campo Grande's 36 captured searches (session 40, ``benchmarks/route_replay.py``): one limit (h39s)
    scanned 92 % of call 15's 7.7 M states (4.3 s), the corridor 34 % (1.2 s)."""
    from osm_expand.engine.roads.expanded_search import turns_to_go

    local = _local(graph, region, k)
    if local.dtype != np.int32:
        local = local.astype(np.int32)
    rows = _expanded_rows(graph, lat, extra, region, local, penalties, k)
    e = np.flatnonzero(extra & (local[graph.src] >= 0) & (local[graph.dst] >= 0))
    head = local[graph.dst[e]].astype(np.int64)
    order = np.argsort(head, kind="stable")
    e, head = e[order], head[order]
    r_ptr = np.zeros(len(region) + 1, dtype=np.int64)
    np.cumsum(np.bincount(head, minlength=len(region)), out=r_ptr[1:])
    ends = _States(len(region), k).arrivals(int(local[target]))
    raw = np.maximum(penalties, 0.0)  # the turns without the search's floor ε: lower, so T stays below them
    return turns_to_go(rows, ends, r_ptr, local[graph.src[e]].astype(np.int64),
                       _bins(graph.heading[e], k).astype(np.int64), limit, raw[rows.cheap], float(raw.max()), budget)


def _turns_over(to_go: np.ndarray, first: np.ndarray, full: np.ndarray, k: int) -> np.ndarray:
    """:func:`_turns_to_go`'s T (by the states of the region ``first``) for the states of ``full`` (a
    subset of ``first``, both sorted): the arrivals, departures and hubs of ``full``'s vertices taken
    by block: 16 B a state at the peak (the three blocks and their concatenation; tracemalloc, 6.6 M
    states), where a state-by-state gather's index arrays peaked at 66 B a state.

    Raises
    ------
    ValueError
        Where ``full`` is not within ``first``: the compiled search reads T unchecked."""
    rank = np.searchsorted(first, full)
    if len(full) and (rank[-1] >= len(first) or not np.array_equal(first[rank], full)):
        raise ValueError("the region searched is not within the first region the turns were made over")
    if len(full) == len(first):
        return to_go
    arrive, depart, hub = _States(len(first), k).by_vertex(to_go)
    return np.concatenate([arrive[rank].ravel(), depart[rank].ravel(), hub[rank]])


def _vertex_path(pred: np.ndarray, start: int, end: int, verts: np.ndarray, states: _States) -> list[int]:
    """The G′ vertices of the expanded states' path from ``start`` to ``end`` (``verts``: the expanded
    graph's vertices, numbered by ``states``), a vertex once where its arrival and departure follow."""
    vertices = verts[states.vertex(np.asarray(_walk_back(pred, start, end)))]
    keep = np.ones(len(vertices), dtype=bool)
    keep[1:] = vertices[1:] != vertices[:-1]
    return vertices[keep].tolist()


#: share by which A*'s bound is lowered in the exits' search: the lattice's weights are float32, so a
#: straight-line bound exceeds an edge's weight by up to ~1e-7 of it, and lowered it is consistent again
_SHRINK = 1e-6


def _reduced(expanded: csr_matrix, h: np.ndarray, states: _States) -> csr_matrix:
    """The expanded graph (or its transpose) with A*'s reduced costs ``c(a, b) + h(b) − h(a)`` (``h``
    per vertex, its states numbered by ``states``), in place.

    With ``h`` consistent (``h(u) ≤ c(u, w) + h(w)`` for every edge; turns cost ≥ 0 and share
    their vertex's h) the reduced costs are not negative, and Dijkstra on them settles the states
    in the order of ``g + h``: with the limit ``C − h(source)`` only those A* settles below C
    (``g`` is the distance found plus ``h(state) − h(source)``). A cost that rounding made
    slightly negative is taken as the least positive one (``_EPS``, like the free edges).
    """
    h_state = states.per_state(h)
    indptr = expanded.indptr
    rows = _BLOCK * (2 * states.k + 1)  # a block of rows: about as many entries as a block of vertices had
    for a in range(0, states.size, rows):
        b = min(a + rows, states.size)
        lo, hi = int(indptr[a]), int(indptr[b])
        part = expanded.data[lo:hi]
        part += h_state[expanded.indices[lo:hi]] - np.repeat(h_state[a:b], np.diff(indptr[a:b + 1]))
        np.maximum(part, _EPS, out=part)
    return expanded


def _summed_cost(graph: PathGraph, lat: KindMask, extra: np.ndarray, verts: np.ndarray, states: list[int],
                 penalties: np.ndarray, k: int) -> float:
    """The cost of a path of states of the expanded graph over ``verts`` summed from the graph's own
    weights (:func:`_path_cost`), for a path A* found on reduced costs (whose distances are sums of
    the reduced weights, not of these): the expanded graph over the path's vertices alone holds the
    very same entries between them, so the sum is the same to the last bit. Only that small graph
    is written (the search itself writes none, :func:`_heading_search`); a copy of the searched
    graph's weights kept for this (session 34's first A* default) was 1.2 GB of the synthetic
    10,000-street town's first road year (153 M entries)."""
    big = _States(len(verts), k)
    path = np.asarray(states, dtype=np.int64)
    vertex = verts[big.vertex(path)]
    on = np.unique(vertex)
    small, local = _expanded_graph(graph, lat, extra, on, penalties, k)
    return _path_cost(small, small.data, _States(len(on), k).state(local[vertex], big.slot(path)).tolist())


def _path_cost(expanded: csr_matrix, raw: np.ndarray, states: list[int]) -> float:
    """The cost of a path of states summed from the expanded graph's own weights (``raw``: its data
    before :func:`_reduced`; the cheapest entry where two join the same states), in path order as a
    Dijkstra adds them."""
    total = 0.0
    for a, b in zip(states[:-1], states[1:]):
        lo, hi = expanded.indptr[a], expanded.indptr[a + 1]
        total += float(raw[lo:hi][expanded.indices[lo:hi] == b].min())
    return total


def _target_end(dist: np.ndarray, states: _States, target: int) -> int:
    """The target's cheapest arrival state, the first of equal ones (``target``: its local number;
    its arrivals in bin order): where a route search walks back from."""
    ends = states.arrivals(target)
    return int(ends[np.argmin(dist[ends])])


def _cheaper_end(dist: np.ndarray, states: _States, target: int, cost: float, offset: float = 0.0) -> int | None:
    """The target's cheapest arrival state (the first of equal ones, as :func:`_target_end`) when its
    cost, ``dist + offset``, is below ``cost`` (the best so far), else None: one test for both of
    :func:`_tiled_search`'s route searches (``offset``: A*'s shift ``h(s) − h(target)`` on reduced
    costs, added before the cheapest is chosen, as the costs are compared)."""
    ends = states.arrivals(target)
    arrive = dist[ends] + offset if offset else dist[ends]
    least = int(np.argmin(arrive))
    return int(ends[least]) if arrive[least] < cost else None


def _tiled_search(graph: PathGraph, lat: KindMask, extra: np.ndarray, source: int, target: int | None,
                  lower: np.ndarray, h: np.ndarray, best: tuple[list[int], float], seed: np.ndarray,
                  penalties: np.ndarray, opts: RoutingOptions, goal: np.ndarray, exits: np.ndarray | None = None,
                  settled: Callable[[np.ndarray, np.ndarray | None], bool] | None = None
                  ) -> tuple[tuple[list[int], float], np.ndarray | None]:
    """The turn-penalised search, the heading-expanded graph made tile by tile as A*'s test reaches them.

    Each search (:func:`_heading_search`: compiled, no expanded matrix is
    written, each state's row made as the search reaches it) covers the
    *active* vertices only: those of the active tiles (``tile_cells``
    lattice vertices a side) whose ``lower`` bound of a route through them
    (``d_s + h``) is within the best cost ``C`` found so far. After each
    search every allowed edge from an active vertex u to an inactive one w
    inside that bound is tested: a route leaving the active set by it costs
    at least ``g(dep(u, b)) + c(u, w) + h(w)`` (its part up to u lies in
    the active set, where the search's g is the least cost of departing u
    on that heading; ``h`` is a consistent lower bound of what is left),
    plus the turns it must still make from heading b at w to reach the
    goal (:func:`_turns_needed`, with ``turn_floor``). Where that is below
    C, the tile of w and its neighbours become active and the search goes
    on over them (:func:`_goes_on`, :func:`_again`: the states are numbered
    over the whole region, so the last search's distances and predecessors
    stay where they are and only the departures with an edge into the added
    tiles are scanned again; the synthetic 10,000-street town's searches had
    searched again from scratch each time, 2–6 searches of 2–56 M states);
    when no edge is, no route outside the active set can beat C, and
    the best route found is the best of the graph. The tiles follow A*'s
    states with ``g + h ≤ C``. Inside them the exits' search (no target),
    and a route's with ``route_astar`` (off by default), run A* on reduced
    costs (:func:`_reduced`), which settles only the states with
    ``g + h ≤ C``: the route's cost is then summed again from the graph's
    own weights (:func:`_summed_cost`). Without ``route_astar`` a route
    search runs A* by ``h`` on the graph's own weights with scipy's tie
    rule (``ties``): it too searches only the states with ``g + h ≤ C``,
    and its route, distances and predecessors are plain Dijkstra's.

    Parameters
    ----------
    lower
        (V′,) a lower bound of the cost of any route through each vertex (∞: none can be).
    h
        (V′,) a consistent lower bound of the cost from each vertex to the goal.
    best
        A feasible route (its vertices) and its cost C (an upper bound).
    seed
        Vertices whose tiles are active at first (a route's: its corridor).
    goal
        (2,) m, where the routes end (the target's place): with ``turn_floor`` a route leaving
        the active set on heading bin b at w is also charged the turns it needs to reach the goal
        from there (:func:`_turns_needed`; a lower bound, so the test stays exact).
    target
        The route's end (None: no route is sought, only the arrivals at ``exits`` below C).
    exits
        Vertices whose least arrival cost below C is returned (∞ when not below C).
    settled
        Without a target, asked as the exits' search goes (:func:`_heading_steps`) whether upper bounds
        of the exits' arrival costs (their costs so far, which only fall, a margin above) and, where the
        region is searched at once, lower bounds (:func:`_arrival_bounds`) already say enough; where it
        says so, the search stops and returns the upper bounds.

    Returns
    -------
    best, arrivals
        The best route and its cost (``best`` when none is cheaper), and the exits' arrival costs.
    """
    k = opts.heading_bins
    tile, shape, active = _first_tiles(graph, opts.tile_cells, seed)
    at_once = np.count_nonzero(lower <= best[1] + 1e-9 * best[1] + 1e-6) <= opts.whole_region
    if at_once:
        active[:] = True  # a small region at once: one search, no growing
    # The exits' search (costs only) runs A* (Dijkstra on reduced costs, :func:`_reduced`): it settles
    # only the states with g + h ≤ C. So does a route search with ``route_astar`` (off by default: of
    # several routes of equal cost it may take another than plain Dijkstra, Campo Grande's second and
    # third roads); without it, A* by h on the own weights with scipy's tie rule (plain Dijkstra's route)
    astar = target is None or opts.route_astar
    n_lat, n_dir = lat.shape
    dir_bin = _bins(graph.direction_heading, k)
    offset = graph.lattice.direction_offset
    extra_bin = _bins(graph.heading, k)
    # at once: nothing grows; an odd K: the floor's arcs and _turns_needed's bins are reasoned for an even K
    # (half the circle a whole number of bins), and with K = 5, 7, 9 it was above the true cost
    floor = opts.turn_floor and not at_once and k % 2 == 0
    need = _turn_floor(penalties) if floor else np.zeros(1)
    turns = bool(need.any())
    arrivals = None
    # the last search, gone on with while C holds or falls (:func:`_goes_on`, :func:`_again`): None, or
    # (cost, the region's vertices, inside, dist, pred); a route search with ``route_astar`` starts
    # again each time (its predecessors depend on the order of the relaxations)
    kept: tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
    goes_on = not (astar and target is not None)
    cap = min(opts.resume_states, 2**31 - 1)  # the region's states numbered whole up to this many
    lift = float(h[source] * (1.0 - _SHRINK)) if astar else None  # g + h = dist + lift on reduced costs
    # the turns still to make, by state of the first region (C only falls: later regions lie within it)
    first_region = np.zeros(0, dtype=np.int64)
    if opts.turn_bound and not astar and target is not None:
        first_region = np.flatnonzero(lower <= best[1] + 1e-9 * best[1] + 1e-6)
    to_go = None
    if target is not None and 0 < _States(len(first_region), k).size <= opts.turn_bound:
        # in the corridor of the turns a route through each vertex may make and still cost C: C − lower(v)
        # (lower = d_s + D, so the bound is min(D + T, C − d_s): consistent, :func:`_turns_to_go`)
        allowed = best[1] + 1e-6 * best[1] + 1e-3
        size = _States(len(first_region), k).size
        to_go = _turns_to_go(graph, lat, extra, first_region, penalties, k, target, allowed - lower[first_region],
                             int(opts.turn_share * size) if opts.turn_share < 1 else -1)
        to_go *= 1.0 - _SHRINK  # scaled as h is, in place: the first search reads it as it is (no copy)
    region_turns, region_turns_of = None, np.zeros(0, dtype=np.int64)  # the scaled T by state of the region searched
    from osm_expand.engine.roads.expanded_search import Resume

    while True:
        cost = made = best[1]
        region = lower <= cost + 1e-9 * cost + 1e-6
        inside = region & active[tile]
        verts = np.flatnonzero(inside)
        resume = None
        if kept is not None and _goes_on(kept, cost, region, h, k, lift):
            _, full, before, dist, pred = kept
            whole = True
            states = _States(len(full), k)
            local = _local(graph, full, k)
            before = before & region
            seeds = _again(graph, lat, extra, local, before, inside & ~before, tile, shape, states, dir_bin,
                           extra_bin, -(-graph.lattice.radius // opts.tile_cells))
            resume = Resume(dist, pred, seeds)
        else:
            # the states numbered over the whole region (a vertex's by its rank there), so that the tiles
            # grow without numbering them again: the rank in the region and in ``verts`` order two
            # states alike, which is all the tie rule reads of the numbers. A region above the cap
            # (``RoutingOptions.resume_states``), or a search that cannot go on, numbers the active ones
            whole = goes_on and _States(int(np.count_nonzero(region)), k).size <= cap
            full = np.flatnonzero(region) if whole else verts
            states = _States(len(full), k)
            local = _local(graph, full, k)
        kept = None  # the last search's arrays are the resumed search's, or go
        local[~inside] = -1  # the search reads only the active vertices
        # the rounding slack of the states numbered: the same limit each time C holds where numbered
        # over the whole region, the active states' (as each search was once made) where not
        slack = 2 * states.size * _EPS
        start = states.hub(local[source])
        if astar:  # A* (reduced costs): the exits' search, or a route's with ``route_astar``
            ha = h[full] * (1.0 - _SHRINK)
            hs = float(ha[local[source]])
            seek = target is not None and local[target] >= 0
            # g = distance + h(state) − h(source), added where read (the active vertices' rows, not the
            # whole region's); ``dist`` stays as searched, to go on with
            up = hs - ha
            shift: np.ndarray | None = up
            if settled is not None and target is None and exits is not None:
                # searched at once, this round is the last: what is still queued bounds the arrivals from below
                bounds = partial(_arrival_bounds, states, local, exits, source, up,
                                 2 * _States(len(verts), k).size * _EPS if at_once else None)
                dist, pred, queued = _heading_steps(graph, lat, extra, full, local, penalties, k, start,
                                                    cost - hs + slack, ha, resume, partial(_asked, settled, bounds))
                if queued is not None:
                    return best, bounds(dist, queued)[0]
            else:
                dist, pred = _heading_search(graph, lat, extra, full, local, penalties, k, start, cost - hs + slack,
                                             h=ha, predecessors=seek, resume=resume)
            if seek:
                last = _cheaper_end(dist, states, int(local[target]), cost, float(up[local[target]]))
                if last is not None:
                    total = _summed_cost(graph, lat, extra, full, _walk_back(pred, start, last), penalties, k)
                    if total < cost:
                        best = (_vertex_path(pred, start, last, full, states), total)
                        cost = best[1]
        else:
            # A* by h on the graph's own weights, scipy's predecessor rule applied as states relax: the
            # route (its states' distances and predecessors) is plain Dijkstra's, and the states with
            # g + h above C are not searched. Where the growth test below reads a departure's g, it is
            # exact wherever g + w + h(w) < C (consistency: then g + h(u) < C), as the test needs. With
            # T the bound is h + T: a departure it left unscanned has g = ∞ there, and the test lets
            # nothing grow from it, rightly: T is a lower bound of the turns to go over the whole
            # first region (admissible: :func:`_turns_to_go`), so any route through that departure
            # costs more than C.
            shift = None
            if to_go is not None and not np.array_equal(full, region_turns_of):  # made again where the region changed
                region_turns, region_turns_of = _turns_over(to_go, first_region, full, k), full
            dist, pred = _heading_search(graph, lat, extra, full, local, penalties, k, start, cost + slack,
                                         h=h[full] * (1.0 - _SHRINK), predecessors=True, ties=True, resume=resume,
                                         turns=region_turns)
            if target is not None and local[target] >= 0:
                end = _cheaper_end(dist, states, int(local[target]), cost)
                if end is not None:
                    best = (_vertex_path(pred, start, end, full, states), float(dist[end]))
                    cost = best[1]
        departs = states.by_vertex(dist)[1]  # g of the departures (plus ``shift`` for A*), a view
        if exits is not None:
            at = local[exits].astype(np.int64)
            row = np.maximum(at, 0)
            came = states.by_vertex(dist)[0][row]
            if shift is not None:
                came = came + shift[row][:, None]
            arrivals = np.where(at >= 0, came.min(axis=1), np.inf)
            arrivals[exits == source] = 0.0
            # the rounding slack of the states searched (the active ones), as when each search was made
            # over them alone
            arrivals = np.maximum(arrivals - 2 * _States(len(verts), k).size * _EPS, 0.0)
        if at_once:  # the whole region was searched: no edge leaves the active set, nothing can grow
            return best, arrivals
        threshold = cost - 1e-9 * cost
        outside = region & ~inside
        # lattice edges out of the vertices that may still lead somewhere below C
        rows = local[verts]
        gone = departs[rows] if shift is None else departs[rows] + shift[rows][:, None]
        open_ = verts[(verts < n_lat) & (gone.min(axis=1) + h[verts] < threshold)]
        del gone
        reached: list[np.ndarray] = []
        for a in range(0, len(open_), _BLOCK):
            u = open_[a:a + _BLOCK]
            live = lat[u]
            r, d = np.nonzero(live)
            w = u[r] + offset[d]
            out = outside[w]
            r, d, w = r[out], d[out], w[out]
            g = departs[local[u[r]], dir_bin[d]]
            if shift is not None:
                g = g + shift[local[u[r]]]
            lb = g + _lattice_weight(graph, u[r], d) + h[w]
            if turns:
                lb += _turns_needed(need, dir_bin[d], graph.xy[w], goal)
            reached.append(w[lb < threshold])
        e = np.flatnonzero(extra & inside[graph.src] & outside[graph.dst])
        g = departs[local[graph.src[e]], extra_bin[e]]
        if shift is not None:
            g = g + shift[local[graph.src[e]]]
        lb = g + graph.weight[e] + h[graph.dst[e]]
        if turns:
            lb += _turns_needed(need, extra_bin[e], graph.xy[graph.dst[e]], goal)
        reached.append(graph.dst[e][lb < threshold])
        w = np.concatenate(reached)
        del departs
        if not len(w):
            return best, arrivals
        if whole:  # numbered over the whole region: the next search may go on from this one (:func:`_goes_on`)
            kept = (made, full, inside, dist, pred)
        del dist, pred  # this search's states go before the next search's are made (unless it goes on)
        active |= _grown_tiles(active, tile[w], tile[region], shape, len(verts))


def _asked(settled: Callable[[np.ndarray, np.ndarray | None], bool],
           bounds: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray | None]], dist: np.ndarray,
           queued: np.ndarray) -> bool:
    """``settled`` asked with the exits' arrival bounds (``bounds``: :func:`_arrival_bounds`) of a paused search."""
    return settled(*bounds(dist, queued))


def _arrival_bounds(states: _States, local: np.ndarray, exits: np.ndarray, source: int, shift: np.ndarray,
                    slack: float | None, dist: np.ndarray, queued: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Upper and lower bounds of the arrival costs the exits' search (:func:`_tiled_search`: A* on reduced
    costs, g = ``dist + shift``), paused at ``dist`` with the states ``queued`` left, will end with.

    Upper: each exit's least arrival so far (a distance only falls as the search goes on; ∞ where not
    reached yet), a margin above the float sums of another order. Lower, where this round is the
    search's last (``slack``: the rounding slack its arrivals lose at the end; None: tiles may still
    grow, and a state of a tile added later could end below what is queued): on reduced costs (each
    at least ε > 0) no state not yet scanned ends below the least distance queued, so an exit ends at
    no less than that plus its shift, less the slack, a margin below. An exit whose arrival so far lies
    below that least was scanned: both bounds are then the very value the search ends with (the same
    float operations as its end's), so where no other exit matters the next window is made from the
    same floats as after the whole search (:meth:`_Growth.settles`)."""
    at = local[exits].astype(np.int64)
    row = np.maximum(at, 0)
    came = states.by_vertex(dist)[0][row].min(axis=1)
    above = np.where(at >= 0, came + shift[row], np.inf)
    above[exits == source] = 0.0
    upper = above + (1e-9 * above + 1e-6)
    if slack is None:
        return upper, None
    least = float(dist[queued].min()) if len(queued) else np.inf
    final = np.maximum(above - slack, 0.0)  # as the search's end makes them (:func:`_tiled_search`)
    below = np.where(at >= 0, np.maximum(least + shift[row] - slack, 0.0), np.inf) * (1.0 - 1e-9) - 1e-6
    done = (came < least) | (exits == source)
    return np.where(done, final, upper), np.where(done, final, below)


def _backward_route(graph: PathGraph, lat: KindMask, extra: np.ndarray, source: int, target: int,
                    from_source: np.ndarray, from_target: np.ndarray, best: tuple[list[int], float],
                    seed: np.ndarray, penalties: np.ndarray,
                    opts: RoutingOptions) -> tuple[list[int], float] | None:
    """The turn-penalised best route searched from the target backwards, tile by tile, then its vertices.

    The forward search from the source settles every state with ``g ≤ C``
    (``C`` the best cost known), and A* towards the target still settles
    those with ``g + d_t ≤ C``: the turn-free ``d_t`` ignores turns, which
    are most of a route's cost in a street grid. Searched backwards — on the
    reversed expanded graph from the target's arrival states, by A* with the
    plain distance from the source ``d_s`` as bound (consistent: turns cost
    ≥ 0) — the same test settles far fewer states where the target lies
    outside the dense grid (Campo Grande's first road: 31,000 states against
    the forward search's 1.4 million), and about as many where the source's
    plain distance is as weak a bound (the synthetic town's first: 37 million
    against 53), so it is off by default (``RoutingOptions.backward``; a search from both
    ends that meets in the middle is what would win both). The search gives ``b``, the least cost
    from each state to the target, exact where the rest of the route stays
    in the active tiles.

    The tiles grow as :func:`_tiled_search`'s do, mirrored: a route entering
    the active set by an edge ``u → w`` of heading bin q from an inactive u
    costs at least ``d_s(u) + c(u, w) + b(arr(w, q))``, plus (with
    ``turn_floor``) the turns its part before w must make, seen reversed: a
    walk from w on bin ``q + K/2`` to the source (:func:`_turns_needed`;
    reversing a route keeps its turns' angles and puts each edge's heading
    within half a bin of its bin's opposite). Where that is below C the
    tiles of u grow; when nowhere, every route below C lies in the active
    set and ``b(hub(source))`` is the best cost.

    The route itself is then searched forwards by plain Dijkstra over the
    vertices that may lie on a best route (``d_s(v) + b ≤ C`` for one of
    their states): a state on a best route is reached from states on best
    routes only, so its distance and its predecessor are those of a plain
    search over the whole region (of several exactly equal ones, the heap's
    order may pick another: the same cost). Should that search not reach the
    target within the cost found (plus the rounding slack), the two searches
    disagree: None, and the caller searches forwards instead of silently
    keeping ``best``.

    Parameters
    ----------
    from_source, from_target
        (V′,) the plain distances from the source and from the target, each ∞ beyond its cut (the
        source's past the first bound, :func:`_search`; the target's past the bound).
    best
        A feasible route (its vertices) and its cost C (an upper bound).
    seed
        Vertices whose tiles are active at first (the plain route's).

    Returns
    -------
    vertices, cost or None
        The best route (``best`` when none is cheaper); None when the last
        Dijkstra does not confirm the cost found.
    """
    k = opts.heading_bins
    tile, shape, active = _first_tiles(graph, opts.backward_tile_cells, seed)
    lower = from_source + from_target
    n_lat = lat.shape[0]
    dir_bin = _bins(graph.direction_heading, k)
    offset = graph.lattice.direction_offset
    extra_bin = _bins(graph.heading, k)
    need = _turn_floor(penalties) if opts.turn_floor and k % 2 == 0 else np.zeros(1)
    turns = bool(need.any())
    goal = graph.xy[source]
    upper = best[1]  # the least cost found so far (its route is searched at the end)
    while True:
        cost = upper
        region = lower <= cost + 1e-9 * cost + 1e-6
        inside = region & active[tile]
        verts = np.flatnonzero(inside)
        expanded, local = _expanded_graph(graph, lat, extra, verts, penalties, k)
        states = _States(len(verts), k)
        slack = 2 * states.size * _EPS
        back = expanded.T.tocsr()  # the reversed graph, the same states
        del expanded
        ha = from_source[verts] * (1.0 - _SHRINK)
        ht = float(ha[local[target]])
        ends = states.arrivals(local[target])
        dist = dijkstra(_reduced(back, ha, states), indices=ends, min_only=True, limit=cost - ht + slack)
        del back
        to_target = states.by_vertex(dist)  # b = distance − h(state) + h(target): arrivals, departures, hubs
        for part in to_target:
            part += (ht - ha)[:, None] if part.ndim == 2 else ht - ha
        found = float(to_target[2][local[source]])
        if found < cost - slack:
            cost = upper = found
        threshold = cost - 1e-9 * cost
        arrive = np.maximum(to_target[0] - slack, 0.0)  # b(arr(w, q)), never above the exact cost
        outside = region & ~inside
        # lattice edges u → w into the vertices that may still be on a route below C, from outside
        open_ = verts[(verts < n_lat) & (arrive.min(axis=1) + from_source[verts] < threshold)]
        reached: list[np.ndarray] = []
        for a in range(0, len(open_), _BLOCK):
            w = open_[a:a + _BLOCK]
            r, d = np.nonzero(np.ones((len(w), len(offset)), dtype=bool))
            u = w[r] - offset[d]
            ok = (u >= 0) & (u < n_lat)
            r, d, u = r[ok], d[ok], u[ok]
            ok = outside[u] & lat[u, d]
            r, d, u = r[ok], d[ok], u[ok]
            lb = from_source[u] + _lattice_weight(graph, u, d) + arrive[local[w[r]], dir_bin[d]]
            if turns:
                lb += _turns_needed(need, (dir_bin[d] + k // 2) % k, graph.xy[w[r]], goal)
            reached.append(u[lb < threshold])
        e = np.flatnonzero(extra & outside[graph.src] & inside[graph.dst])
        lb = from_source[graph.src[e]] + graph.weight[e] + arrive[local[graph.dst[e]], extra_bin[e]]
        if turns:
            lb += _turns_needed(need, (extra_bin[e] + k // 2) % k, graph.xy[graph.dst[e]], goal)
        reached.append(graph.src[e][lb < threshold])
        u = np.concatenate(reached)
        if not len(u):
            break
        del dist, to_target, arrive
        active |= _grown_tiles(active, tile[u], tile[region], shape, len(verts))
    if not cost < best[1]:
        return best
    # the vertices with a state that may lie on a best route: d_s(v) + b(state) ≤ C
    fs = from_source[verts]
    least = np.minimum(np.minimum((to_target[0] + fs[:, None]).min(axis=1), (to_target[1] + fs[:, None]).min(axis=1)),
                       to_target[2] + fs)
    on = verts[least <= cost + 1e-9 * cost + 1e-6 + slack]
    del dist, to_target, arrive, least
    expanded, local = _expanded_graph(graph, lat, extra, on, penalties, k)
    states = _States(len(on), k)
    start = states.hub(local[source])
    tolerance = 2 * states.size * _EPS + 1e-9 * cost + 1e-6
    forward, pred = dijkstra(expanded, indices=start, return_predecessors=True, limit=cost + tolerance)
    end = _target_end(forward, states, int(local[target]))
    if not forward[end] <= cost + tolerance:
        return None  # the backward search's cost is not confirmed: the caller searches forwards
    if not forward[end] < best[1]:
        return best
    return _vertex_path(pred, start, end, on, states), float(forward[end])


def route_over_major_roads(graph: PathGraph, source: int, target: int, *, demand: float = 0.0,
                           options: RoutingOptions | None = None) -> Route | None:
    """The best route over existing major roads only (003 §3.4.2, PROPOSEFROMMAJOR).

    003 builds a temporary graph of the major segments, with infinite weight
    on those that cannot take the extra traffic. Here that graph is G′
    restricted to major road pieces with ``available ≥ demand``, searched with
    the same costs (C1, and C6 on extendible ones) and turn penalty as a new
    route, so that :func:`choose` compares like with like: a new route that
    only reuses major roads costs exactly what re-routing over them does.

    Parameters
    ----------
    graph
        G′ of this year.
    source, target
        G′ vertices (street nodes: ``graph.node_vertex(node)``).
    demand
        The traffic increase t(t) − t(t − 1) the route must carry.
    options
        :class:`RoutingOptions`.

    Returns
    -------
    Route or None
        None when the major roads with enough capacity do not connect the two.
    """
    segs = graph.segments
    ok = np.asarray(segs.major, dtype=bool).copy()
    if segs.available is not None:
        ok &= segs.available >= demand
    return find_route(graph, source, target, kinds=(EdgeKind.MAJOR,), street_ok=ok, options=options)


class Choice(StrEnum):
    """Which proposal wins (003 Algorithm 2, WINNER)."""

    NEW = "new"  #: build the new route P_B
    REROUTE = "reroute"  #: route over existing major roads, P_A
    NONE = "none"  #: neither exists


def route_score(route: Route, *, o3: float, o4: float) -> float:
    """``O3 · LENGTH(P) + O4 · COST(P)`` (003 §3.4.2)."""
    return o3 * route.length + o4 * route.cost


def choose(new_route: Route | None, reroute: Route | None, *, o3: float = 1.0, o4: float = 1.0) -> Choice:
    """The proposal with the smaller ``O3 · length + O4 · cost`` (003 §3.4.2); ties re-route.

    003 leaves O3 and O4 open; 000 §4.2.8 compares physical length only
    (O3 = 1, O4 = 0). The defaults weigh both equally: a re-route over major
    roads (cost C1 per metre) then wins unless it is much longer than a new
    road (cost ≥ 1 per metre).
    """
    if o3 < 0 or o4 < 0:
        raise InputError(f"choose: O3 and O4 must not be negative, got {o3}, {o4}")
    if new_route is None and reroute is None:
        return Choice.NONE
    if new_route is None:
        return Choice.REROUTE
    if reroute is None:
        return Choice.NEW
    return Choice.REROUTE if route_score(reroute, o3=o3, o4=o4) <= route_score(new_route, o3=o3, o4=o4) else Choice.NEW
