"""Gravelius ordering of streets (004 §3.1, §4.3.2).

In each connected component the longest street gets level 0, the streets
crossing a level-k street get level k+1, and so on: the level is the
breadth-first distance from the component's longest street in the graph
whose vertices are streets and whose edges are shared junctions.

Ties: the longest street is chosen by length, then by importance of its
highway class, then by its position in the network (so the result is
deterministic); a street crossing several levels takes the lowest.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components

from osm_expand.model import StreetNetwork
from osm_expand.model.highways import rank
from osm_expand.model.topology import lengths


def street_adjacency(net: StreetNetwork):
    """Sparse street × street matrix: 1 where two streets share a node."""
    n = len(net.streets)
    owner = np.repeat(np.arange(n), [len(s.nodes) for s in net.streets])
    nodes = np.fromiter((v for s in net.streets for v in s.nodes), dtype=np.int64, count=len(owner))
    order = np.lexsort((owner, nodes))
    nodes, owner = nodes[order], owner[order]
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    d = 1
    while d < len(nodes):  # a node joins a handful of streets: pair entries up to that far apart
        same = nodes[d:] == nodes[:-d]
        if not same.any():
            break
        pair = same & (owner[d:] != owner[:-d])
        rows.append(owner[:-d][pair])
        cols.append(owner[d:][pair])
        d += 1
    row = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    col = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
    m = coo_matrix((np.ones(len(row)), (row, col)), shape=(n, n)).tocsr()
    return ((m + m.T) > 0).astype(np.int8)


def gravelius_levels(net: StreetNetwork) -> np.ndarray:
    """Level per street (0 = the longest street of its component)."""
    n = len(net.streets)
    if n == 0:
        return np.zeros(0, dtype=np.int32)
    adj = street_adjacency(net)
    n_comp, comp = connected_components(adj, directed=False)
    length = np.array([lengths(net.xy, s.nodes) for s in net.streets])
    key = [(-length[k], rank(s.highway), k) for k, s in enumerate(net.streets)]
    levels = np.full(n, -1, dtype=np.int32)
    for c in range(n_comp):
        members = np.flatnonzero(comp == c)
        root = min(members, key=lambda k: key[k])
        order, pred = breadth_first_order(adj, root, directed=False, return_predecessors=True)
        levels[root] = 0
        for k in order[1:]:
            levels[k] = levels[pred[k]] + 1
    return levels


def with_levels(net: StreetNetwork) -> StreetNetwork:
    """The network with each street's ``hierarchy`` set to its Gravelius level."""
    from dataclasses import replace

    levels = gravelius_levels(net)
    return net.replace(streets=tuple(replace(s, hierarchy=int(lv)) for s, lv in zip(net.streets, levels)))
