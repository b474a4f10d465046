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
graph at about ``K · (2m + 3)`` turn edges per vertex instead of K², and
scipy's C Dijkstra runs on it.

The expanded graph is built only over the vertices that can lie on an
optimal route: with ``d_s``, ``d_t`` the plain (turn-free, hence lower-bound)
distances from source and target and ``U`` the penalised cost of the plain
shortest path (a feasible route), a vertex v can be on the best route only
if ``d_s(v) + d_t(v) ≤ U``. This pruning is exact. U is first lowered by a
search in a corridor ``corridor_width`` wide along the plain route, so that
the exact search covers only a narrow ellipse around the best route.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from osm_expand.engine.lattice import ROAD_KINDS, EdgeKind, PathGraph
from osm_expand.errors import InputError

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
    #: m, the first (cheap, inexact) search keeps within this of the plain shortest route;
    #: its cost bounds the exact second search (5ℓ)
    corridor_width: float = 100.0

    def __post_init__(self) -> None:
        if not (self.turn_width > 0 and self.turn_height >= 0):
            raise InputError("RoutingOptions: turn_width must be positive and turn_height not negative")
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


def find_route(graph: PathGraph, source: int, target: int, *, kinds: Sequence[EdgeKind] = ROAD_KINDS,
               street_ok: np.ndarray | None = None, options: RoutingOptions | None = None) -> Route | None:
    """The least-cost route on G′ with turn penalties (003 §3.4.2, PROPOSEFROMNEW).

    Parameters
    ----------
    graph
        G′ from :func:`osm_expand.engine.lattice.pathfinding_graph`.
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
    if source == target:
        return _route(graph, [source], *graph.masks(kinds, street_ok), 0.0)
    lat, extra = graph.masks(kinds, street_ok)
    with graph.restricted(kinds, street_ok) as matrix:
        from_source, pred = dijkstra(matrix, indices=source, return_predecessors=True)
        if not np.isfinite(from_source[target]):
            return None
        return _best_route(graph, matrix, lat, extra, source, target, from_source, pred, opts)


def _best_route(graph: PathGraph, matrix: csr_matrix, lat: np.ndarray, extra: np.ndarray, source: int, target: int,
                from_source: np.ndarray, pred: np.ndarray, opts: RoutingOptions) -> Route:
    """The turn-penalised optimum, given the plain shortest-path tree from the source."""
    plain = _walk_back(pred, source, target)
    plain_route = _route(graph, plain, lat, extra, 0.0)
    penalties = _bin_penalties(opts)
    bins = _bins(_headings(plain_route), opts.heading_bins)
    plain_turns = float(penalties[(bins[1:] - bins[:-1]) % opts.heading_bins].sum())
    if opts.turn_height == 0 or plain_turns == 0:
        return _route(graph, plain, lat, extra, plain_turns)
    lower = float(from_source[target])
    bound = lower + plain_turns
    tolerance = 1e-9 * bound + 1e-6
    from_target = dijkstra(matrix, indices=target, limit=bound + tolerance)  # G′ is symmetric
    through = from_source + from_target
    best: tuple[list[int], float] = (plain, bound)
    # a cheap first search in a corridor along the plain route gives a good feasible cost,
    # which shrinks the exact region (d_s + d_t ≤ that cost) of the second search
    candidates = np.flatnonzero(through <= bound + tolerance)
    near = cKDTree(_densified(graph.xy[plain], opts.corridor_width)).query(
        graph.xy[candidates], distance_upper_bound=opts.corridor_width)[0]
    corridor = candidates[np.isfinite(near)]
    found = _expanded_search(graph, lat, extra, corridor, source, target, penalties, opts.heading_bins,
                             bound + tolerance)
    if found is not None and found[1] < best[1]:
        best = found
    region = np.flatnonzero(through <= best[1] + tolerance)
    if not np.isin(region, corridor).all():  # else the corridor search was already exact
        found = _expanded_search(graph, lat, extra, region, source, target, penalties, opts.heading_bins,
                                 best[1] + tolerance)
        if found is not None and found[1] < best[1]:
            best = found
    vertices, total = best
    route = _route(graph, vertices, lat, extra, 0.0)
    return _with_turn_cost(route, max(total - float(route.edge_weight.sum()), 0.0))


def _densified(xy: np.ndarray, step: float) -> np.ndarray:
    """Points along a polyline at most ``step`` apart (its vertices included)."""
    seg = np.diff(xy, axis=0)
    count = np.maximum(np.ceil(np.hypot(*seg.T) / step).astype(np.int64), 1)
    start = np.repeat(np.arange(len(seg)), count)
    t = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    return np.concatenate([xy[start] + (t / count[start])[:, None] * seg[start], xy[-1:]])


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


def _route(graph: PathGraph, vertices: Sequence[int], lat: np.ndarray, extra: np.ndarray,
           turn_cost: float) -> Route:
    steps = [graph.step(u, v, lat, extra) for u, v in zip(vertices[:-1], vertices[1:])]
    column = lambda name, dtype: np.array([s[name] for s in steps], dtype=dtype)  # noqa: E731
    v = np.asarray(vertices, dtype=np.int64)
    return Route(vertices=v, xy=graph.xy[v], kind=column("kind", np.uint8), segment=column("segment", np.int64),
                 edge_length=column("length", float), edge_weight=column("weight", float), turn_cost=turn_cost)


def _sorted_csr(n_rows: int, groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> csr_matrix:
    """A CSR matrix from groups of entries whose rows are each already non-decreasing.

    Rows are merged group by group (a row holds the first group's entries,
    then the second's, …) with counts and offsets only: no sort.
    """
    counts = [np.bincount(rows, minlength=n_rows) for rows, _, _ in groups]
    indptr = np.concatenate([[0], np.cumsum(np.sum(counts, axis=0))])
    indices = np.empty(indptr[-1], dtype=np.int64)
    data = np.empty(indptr[-1])
    before = np.zeros(n_rows, dtype=np.int64)  # entries of earlier groups in each row
    for (rows, cols, values), count in zip(groups, counts):
        group_start = np.cumsum(count) - count
        pos = indptr[rows] + before[rows] + np.arange(len(rows)) - group_start[rows]
        indices[pos] = cols
        data[pos] = values
        before += count
    return csr_matrix((data, indices, indptr), shape=(n_rows, n_rows))


def _expanded_search(graph: PathGraph, lat: np.ndarray, extra: np.ndarray, region: np.ndarray, source: int,
                     target: int, penalties: np.ndarray, k: int, limit: float) -> tuple[list[int], float] | None:
    """Dijkstra on the heading-expanded graph over ``region``; the vertex path and its cost."""
    n = len(region)
    per = 2 * k + 1  # arr 0…k−1, dep k…2k−1, hub 2k
    local = np.full(graph.n_vertices, -1, dtype=np.int64)
    local[region] = np.arange(n)
    base = np.arange(n) * per
    i = np.arange(k)
    height = float(penalties.max())
    cheap = np.flatnonzero(penalties < height - 1e-9)
    groups = []
    # turns: arr(v, i) → dep(v, i + q) where P < S_p, then arr(v, i) → hub(v) at S_p
    arr = (base[:, None] + i).ravel()
    groups.append((np.repeat(arr, len(cheap)), (base[:, None, None] + k + (i[:, None] + cheap) % k).ravel(),
                   np.tile(np.maximum(penalties[cheap], _EPS), n * k)))
    groups.append((arr, np.repeat(base + 2 * k, k), np.full(n * k, max(height, _EPS))))
    # lattice moves dep(u, b) → arr(v, b), columns taken in bin order so rows stay sorted
    n_lat, n_dir = lat.shape
    dir_bin = _bins(graph.direction_heading, k)
    by_bin = np.argsort(dir_bin, kind="stable")
    lat_region = region[region < n_lat]
    flat = np.flatnonzero(lat[lat_region][:, by_bin])
    r = flat // n_dir
    d = by_bin[flat - r * n_dir]
    u = lat_region[r]
    v = u + graph.lattice.direction_offset[d]
    keep = local[v] >= 0
    u, v, d = u[keep], v[keep], d[keep]
    groups.append((local[u] * per + k + dir_bin[d], local[v] * per + dir_bin[d],
                   graph.lat_weight[u, d].astype(np.float64)))
    # other moves (streets, stitches, long bridges)
    e = np.flatnonzero(extra & (local[graph.src] >= 0) & (local[graph.dst] >= 0))
    b = _bins(graph.heading[e], k)
    rows = local[graph.src[e]] * per + k + b
    order = np.argsort(rows, kind="stable")
    groups.append((rows[order], (local[graph.dst[e]] * per + b)[order], graph.weight[e][order]))
    # hub(v) → dep(v, j), free
    groups.append((np.repeat(base + 2 * k, k), (base[:, None] + k + i).ravel(), np.full(n * k, _EPS)))
    expanded = _sorted_csr(n * per, groups)
    start = local[source] * per + 2 * k
    dist, pred = dijkstra(expanded, indices=start, return_predecessors=True, limit=limit + 2 * n * _EPS)
    arrivals = local[target] * per + i
    best = int(arrivals[np.argmin(dist[arrivals])])
    if not np.isfinite(dist[best]):
        return None
    states = _walk_back(pred, start, best)
    vertices = region[np.asarray(states) // per]
    keep = np.ones(len(vertices), dtype=bool)
    keep[1:] = vertices[1:] != vertices[:-1]
    return vertices[keep].tolist(), float(dist[best])


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
