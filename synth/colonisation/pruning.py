"""The grown network's last steps: the extra pruning of 001 §4.2.4, and segments chained into streets."""
from __future__ import annotations

import numpy as np


def extra_pruning(edges: np.ndarray, *, deletable: np.ndarray, level: np.ndarray,
                  length: np.ndarray) -> np.ndarray:
    """Which edges survive 001 §4.2.4's extra pruning.

    A triangle a, b, c (all three mutually connected) with a and b of degree
    >= 3 and c of degree 2 loses one of c's edges: the less important one
    (higher level), then the longer one, then the one to the higher node id
    (001 leaves the choice open; keeping c's more important, shorter edge
    keeps c on the street it came from). Only ``deletable`` edges go; when
    neither of c's edges may go, the triangle stays. Triangles whose nodes
    all have degree >= 3, and those at a road end (two nodes of degree 2),
    stay. Nodes are visited in increasing order with the current degrees,
    repeatedly, until nothing changes.

    Parameters
    ----------
    edges : ndarray of int, shape (E, 2)
        Node pairs.
    deletable : ndarray of bool, shape (E,)
        Edges that may be deleted (grown ones; the old town's stay).
    level : ndarray of int, shape (E,)
        Hierarchy level per edge (0 most important).
    length : ndarray of float, shape (E,)
        Edge lengths.

    Returns
    -------
    ndarray of bool, shape (E,)
        True for the edges kept.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    keep = np.ones(len(edges), dtype=bool)
    adj: dict[int, dict[int, int]] = {}
    for e, (u, v) in enumerate(edges.tolist()):
        adj.setdefault(u, {})[v] = e
        adj.setdefault(v, {})[u] = e
    changed = True
    while changed:
        changed = False
        for c in sorted(adj):
            if len(adj[c]) != 2:
                continue
            a, b = sorted(adj[c])
            if b not in adj[a] or len(adj[a]) < 3 or len(adj[b]) < 3:
                continue
            pair = [(int(level[adj[c][x]]), float(length[adj[c][x]]), x, adj[c][x]) for x in (a, b)
                    if deletable[adj[c][x]]]
            if not pair:
                continue
            _, _, other, e = max(pair)
            keep[e] = False
            del adj[c][other], adj[other][c]
            changed = True
    return keep


def chain_streets(edges: np.ndarray, xy: np.ndarray, level: np.ndarray, *, degree: np.ndarray,
                  max_turn_deg: float) -> list[list[int]]:
    """Chain edges into streets: node sequences of one level each.

    A street continues through a node of (total) degree 2 whose two edges
    have the same level, and through a junction along the straightest pair
    of same-level edges turning less than ``max_turn_deg`` (pairs taken
    greedily, straightest first). A closed chain repeats its first node.

    Parameters
    ----------
    edges : ndarray of int, shape (E, 2)
        The edges to chain.
    xy : ndarray, shape (N, 2)
        Node positions, metres.
    level : ndarray of int, shape (E,)
        Level per edge.
    degree : ndarray of int, shape (N,)
        Degree of every node in the whole network (old streets included), so
        that a street ending on an old street is not continued through it.
    max_turn_deg : float
        Largest turn to continue through a junction, degrees.

    Returns
    -------
    list of list of int
        Node sequences, in a deterministic order (by smallest edge id).
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    at: dict[int, list[int]] = {}
    for e, (u, v) in enumerate(edges.tolist()):
        at.setdefault(u, []).append(e)
        at.setdefault(v, []).append(e)
    partner: dict[tuple[int, int], int] = {}  # (node, edge) -> the edge the street continues on
    for node, es in at.items():
        if len(es) < 2:
            continue
        if degree[node] == 2 and len(es) == 2:
            if level[es[0]] == level[es[1]]:
                partner[(node, es[0])], partner[(node, es[1])] = es[1], es[0]
            continue
        out = {e: xy[edges[e, 1] if edges[e, 0] == node else edges[e, 0]] - xy[node] for e in es}
        pairs = []
        for i, e1 in enumerate(es):
            for e2 in es[i + 1:]:
                if level[e1] != level[e2]:
                    continue
                d1, d2 = out[e1], out[e2]
                cos = float(d1 @ d2) / max(float(np.hypot(*d1) * np.hypot(*d2)), 1e-12)
                turn = 180.0 - np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
                if turn < max_turn_deg:
                    pairs.append((turn, e1, e2))
        used: set[int] = set()
        for _, e1, e2 in sorted(pairs):
            if e1 not in used and e2 not in used:
                used |= {e1, e2}
                partner[(node, e1)], partner[(node, e2)] = e2, e1
    done = np.zeros(len(edges), dtype=bool)
    streets: list[list[int]] = []

    def walk(e: int, node: int) -> list[int]:
        """Nodes from ``node`` along ``e`` and onward until the chain ends or closes."""
        path = [node]
        while True:
            done[e] = True
            u, v = edges[e]
            node = int(v if u == node else u)
            path.append(node)
            nxt = partner.get((node, e))
            if nxt is None or done[nxt]:
                return path
            e = nxt

    for e in range(len(edges)):  # open chains first: start at an end whose edge has no partner there
        if done[e]:
            continue
        u, v = (int(x) for x in edges[e])
        if (u, e) not in partner:
            streets.append(walk(e, u))
        elif (v, e) not in partner:
            streets.append(walk(e, v))
    for e in range(len(edges)):  # what is left are closed rings
        if not done[e]:
            streets.append(walk(e, int(edges[e, 0])))
    return streets
