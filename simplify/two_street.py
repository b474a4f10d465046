"""Pass 8 (004 §4.2.6): no junction joins more than two streets.

At a junction each street is *Passing* (the node is inside it) or an
*Endpoint*. The valid states are two Passing, one Passing and one Endpoint,
or two Endpoints. With fewer than two Passing streets, Endpoint pairs are
fused, straightest first, until there are two; with more than two, all but
the two most important are split there and become Endpoints. Endpoints left
over lose the junction: they are cut back to their previous junction,
except that one (or two, with no Passing street) may stay when no two
Passing streets could be made.

Cutting back a street that has no other junction would delete it whole and
can set off a cascade of new dead ends. Such a street is *separated*
instead, as 004 §3.1 allows ("discarded or separated"): its end moves to a
new junction ``separation`` metres along the Passing street it leans
towards, so that junction joins exactly two streets.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.highways import rank
from osm_expand.model.topology import append_nodes, heading, lengths, point_along
from simplify.merging import combine, end_angle
from simplify.options import SimplifyOptions
from simplify.streetset import StreetSet


class _Nodes:
    """The network's coordinates plus the junctions that separation adds."""

    def __init__(self, xy: np.ndarray, room: int):
        self.n = len(xy)
        self.xy = np.vstack([xy, np.zeros((room, 2))])

    def add(self, point: np.ndarray) -> int:
        self.xy[self.n] = point
        self.n += 1
        return self.n - 1


def enforce_two_streets(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, dict[str, int]]:
    work = StreetSet(net.streets)
    counts = {"fused": 0, "split": 0, "cut_back": 0, "separated": 0}
    crowded = sorted(n for n, ks in work.at.items() if len(ks) > 2)
    nodes = _Nodes(net.xy, sum(len(work.at[n]) for n in crowded))
    for node in crowded:
        if work.count(node) > 2:
            _resolve(work, nodes, node, opts, counts)
    if nodes.n == len(net.xy):
        return net.replace(streets=work.ordered()), counts
    xy, ids, _ = append_nodes(net, nodes.xy[len(net.xy):nodes.n])
    return net.replace(xy=xy, node_ids=ids, streets=work.ordered()), counts


def _importance(xy: np.ndarray, street: Street, k: int) -> tuple:
    return (rank(street.highway), -lengths(xy, street.nodes), k)


def _is_passing(street: Street, node: int) -> bool:
    return street.is_closed or (node != street.nodes[0] and node != street.nodes[-1])


def _resolve(work: StreetSet, nodes: _Nodes, node: int, opts: SimplifyOptions, counts: dict[str, int]) -> None:
    xy = nodes.xy
    ks = sorted(work.at[node])
    passing = sorted((k for k in ks if _is_passing(work.streets[k], node)),
                     key=lambda k: _importance(xy, work.streets[k], k))
    for k in passing[2:]:
        _split_at(work, k, node)
        counts["split"] += 1
    passing = passing[:2]
    while len(passing) < 2:
        fused = _fuse_straightest(work, xy, node, opts)
        if fused is None:
            break
        passing.append(fused)
        counts["fused"] += 1
    ends = sorted((k for k in work.at[node] if k not in passing),
                  key=lambda k: _importance(xy, work.streets[k], k))
    allowed = {2: 0, 1: 1, 0: 2}[len(passing)]
    hosts = passing + ends[:allowed]
    for k in ends[allowed:]:
        if _has_inner_junction(work, k, node) or not _separate(work, nodes, node, k, hosts, opts):
            _cut_back(work, k, node)
            counts["cut_back"] += 1
        else:
            counts["separated"] += 1


def _split_at(work: StreetSet, k: int, node: int) -> None:
    street = work.remove(k)
    nodes = street.nodes
    if street.is_closed:  # open the ring at node; cut it again opposite so no piece is a loop
        i = nodes.index(node)
        ring = nodes[i:-1] + nodes[:i] + (node,)
        mid = len(ring) // 2
        halves = [ring[:mid + 1], ring[mid:]]
    else:
        i = nodes.index(node)
        halves = [nodes[:i + 1], nodes[i:]]
    for h in halves:
        if len(h) >= 2:
            work.add(street.with_nodes(h))


def _fuse_straightest(work: StreetSet, xy: np.ndarray, node: int, opts: SimplifyOptions) -> int | None:
    ends = [(k, work.streets[k].nodes[0] == node) for k in sorted(work.at[node])
            if not _is_passing(work.streets[k], node)]
    best = None
    for (ka, a_first), (kb, b_first) in combinations(ends, 2):
        a, b = work.streets[ka], work.streets[kb]
        far_a, far_b = a.nodes[-1 if a_first else 0], b.nodes[-1 if b_first else 0]
        if a.layer_key != b.layer_key or far_a == far_b:  # different layers, or a closed loop
            continue
        angle = end_angle(xy, a, a_first, b, b_first, opts.heading_reach)
        if best is None or angle > best[0]:
            best = (angle, ka, a_first, kb, b_first)
    if best is None:
        return None
    _, ka, a_first, kb, b_first = best
    a, b = work.remove(ka), work.remove(kb)
    a_seq = a.nodes[::-1] if a_first else a.nodes
    b_seq = b.nodes if b_first else b.nodes[::-1]
    return work.add(combine(xy, [a, b], a_seq + b_seq[1:]))


def _has_inner_junction(work: StreetSet, k: int, node: int) -> bool:
    """Would cutting street ``k`` back from ``node`` leave some of it?"""
    inner = work.streets[k].nodes[1:-1]
    return any(work.count(n) >= 2 for n in inner)


def _arms(street: Street, node: int) -> list[tuple[int, ...]]:
    """The street's node runs leaving ``node`` in each direction."""
    seq = street.nodes
    if street.is_closed:
        i = seq.index(node)
        ring = seq[i:-1] + seq[:i] + (node,)
        return [ring, ring[::-1]]
    i = seq.index(node)
    return [run for run in (seq[i:], seq[:i + 1][::-1]) if len(run) >= 2]


def _separate(work: StreetSet, nodes: _Nodes, node: int, k: int, hosts: list[int],
              opts: SimplifyOptions) -> bool:
    """Move street ``k``'s end from ``node`` onto the arm of a staying street it leans towards."""
    if opts.separation <= 0:
        return False
    xy = nodes.xy
    street = work.streets[k]
    own = street.nodes if street.nodes[0] == node else street.nodes[::-1]
    h = heading(xy, own, True, opts.heading_reach)
    best = None
    for p in hosts:
        for arm in _arms(work.streets[p], node):
            stop = next((j for j in range(1, len(arm)) if work.count(arm[j]) >= 2), len(arm) - 1)
            room = lengths(xy, arm[:stop + 1]) / 3
            dist = min(opts.separation, room)
            if dist < 1.0:
                continue
            point, j = point_along(xy, arm, dist)
            if np.hypot(*(point - xy[arm[j + 1]])) < 1e-6:  # landed on a shape point: pull back a little
                point, j = point_along(xy, arm, dist * 0.9)
            g = (point - xy[node]) / max(float(np.hypot(*(point - xy[node]))), 1e-12)
            score = -float(g @ h)
            if best is None or score < best[0]:
                best = (score, p, arm, point, j)
    if best is None:
        return False
    _, p, arm, point, j = best
    new = nodes.add(point)
    host = work.streets[p]
    a, b = arm[j], arm[j + 1]
    seq = list(host.nodes)
    for i in range(len(seq) - 1):
        if {seq[i], seq[i + 1]} == {a, b}:
            seq.insert(i + 1, new)
            break
    work.replace(p, host.with_nodes(seq))
    moved = (new,) + own[1:]
    work.replace(k, street.with_nodes(moved if street.nodes[0] == node else moved[::-1]))
    return True


def _cut_back(work: StreetSet, k: int, node: int) -> None:
    """Remove the piece between ``node`` and the street's previous junction."""
    street = work.remove(k)
    seq = street.nodes if street.nodes[0] == node else street.nodes[::-1]
    for i in range(1, len(seq)):
        if work.count(seq[i]) >= 1:
            rest = seq[i:]
            if len(rest) >= 2:
                work.add(street.with_nodes(rest if street.nodes[0] == node else rest[::-1]))
            return
