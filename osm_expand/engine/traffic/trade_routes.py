"""Finding trade routes (003 §3.2.2, §3.4.2): the least-weight path over usable segments, and each
neighbour pair's first route over the real town's major roads.

The bookkeeping of the routes once found (their traffic, capacity and
Algorithm 2's redistribution) is :mod:`osm_expand.engine.traffic.trade`.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.traffic.trade import TradeState, add_route, new_trade_state
from osm_expand.errors import InputError

__all__ = ["initial_trade_state", "route_between"]


def route_between(edges: NDArray[np.integer], weight: NDArray[np.floating], usable: NDArray[np.bool_],
                  source_node: int, target_node: int) -> NDArray[np.int64] | None:
    """The minimum-weight path between two nodes over the usable segments.

    003 §3.2.2 finds the first trade route ``P_{i,1}`` of a pair whose road
    was not built by the initialisation in the segment graph; §3.4.2's
    ``P_A`` is the same search over major roads with room for the increase
    (``usable = major & segments_with_room(...)``: the others weigh ∞).

    Parameters
    ----------
    edges : (E, 2) int
        Segment end nodes.
    weight : (E,) float
        Segment weights (> 0): lengths, or 003's ``LENGTH · max(1, O1·slope)``.
    usable : (E,) bool
        Segments the path may use (both directions).
    source_node, target_node : int
        Node ids.

    Returns
    -------
    (k,) int64 or None
        Segment ids from source to target; None when they are not connected.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    w = np.asarray(weight, dtype=np.float64).reshape(-1)
    ok = np.asarray(usable, dtype=bool).reshape(-1)
    if not len(w) == len(ok) == len(edges):
        raise InputError(f"trade: {len(edges)} edges, {len(w)} weights, {len(ok)} usable flags")
    if source_node == target_node:
        return np.zeros(0, dtype=np.int64)
    n = int(max(edges.max(initial=-1), source_node, target_node)) + 1
    seg = np.flatnonzero(ok & np.isfinite(w))
    a = np.r_[edges[seg, 0], edges[seg, 1]]
    b = np.r_[edges[seg, 1], edges[seg, 0]]
    sid = np.r_[seg, seg]
    order = np.lexsort((sid, w[sid], b, a))  # parallel segments: keep the lightest, then the lowest id
    a, b, sid = a[order], b[order], sid[order]
    first = np.r_[True, (np.diff(a) != 0) | (np.diff(b) != 0)]
    a, b, sid = a[first], b[first], sid[first]
    graph = sparse.csr_matrix((np.maximum(w[sid], 1e-9), (a, b)), shape=(n, n))
    dist, pred = dijkstra(graph, directed=True, indices=int(source_node), return_predecessors=True)
    if not np.isfinite(dist[target_node]):
        return None
    nodes = [int(target_node)]
    while nodes[-1] != source_node:
        nodes.append(int(pred[nodes[-1]]))
    path = np.array(nodes[::-1])
    lookup = np.searchsorted(a * n + b, path[:-1] * n + path[1:])  # (a, b) rows are sorted
    return sid[lookup].astype(np.int64)


def initial_trade_state(edges: NDArray[np.integer], length: NDArray[np.floating], major: NDArray[np.bool_],
                        exit_node: NDArray[np.integer], pairs: NDArray[np.integer], *,
                        weight: NDArray[np.floating] | None = None) -> tuple[TradeState, NDArray[np.intp]]:
    """First trade route ``P_{i,1}`` of every pair over the real town's major roads (003 §3.2.2).

    Parameters
    ----------
    edges : (E, 2) int
        Segment end nodes.
    length : (E,) float
        Segment lengths, m (route length = their sum).
    major : (E,) bool
        Major-road segments (trade routes run "entirely over major roads").
    exit_node : (K,) int
        Each neighbour's node (:attr:`Neighbours.exit_node`; -1: none).
    pairs : (P, 2) int
        Neighbour index pairs (:func:`.neighbours.neighbour_pairs`).
    weight : (E,) float, optional
        Path weights (default: ``length``).

    Returns
    -------
    state : TradeState
        One route per connected pair, no traffic yet.
    missing : (M, 2) intp
        Pairs without a route: a neighbour without a node (water, generated)
        or not joined over major roads. The initialisation must build their
        roads (003 §3.2.2) or the major-road step will propose them.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    length = np.asarray(length, dtype=np.float64).reshape(-1)
    w = length if weight is None else np.asarray(weight, dtype=np.float64).reshape(-1)
    nodes = np.asarray(exit_node, dtype=np.int64).reshape(-1)
    state = new_trade_state(len(edges))
    missing = []
    for u, v in np.asarray(pairs, dtype=np.intp).reshape(-1, 2):
        a, b = nodes[u], nodes[v]
        path = route_between(edges, w, major, a, b) if a >= 0 and b >= 0 and a != b else None
        if path is None or len(path) == 0:
            missing.append((u, v))
            continue
        state = add_route(state, (u, v), path, float(length[path].sum()))
    return state, np.array(missing, dtype=np.intp).reshape(-1, 2)
