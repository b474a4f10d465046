"""The edge-expanded street graph with turn costs that trips are routed on, and the travel costs and
routes on it (see :mod:`osm_expand.engine.traffic.trips` for the model)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from osm_expand.engine.traffic.trip_options import TripOptions
from osm_expand.errors import InputError

__all__ = ["TripGraph", "shortest_route", "travel_costs", "trip_graph"]


#: Arcs weigh at least this (equivalent metres): Dijkstra needs positive weights.
_MIN_ARC = 1e-6


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
               previous: TripGraph | None = None, options: TripOptions = TripOptions()) -> TripGraph:  # noqa: B008 (frozen)
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
