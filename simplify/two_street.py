"""Pass 8 (004 §4.2.6): no junction joins more than two streets.

At a junction each street is *Passing* (the node is inside it) or an
*Endpoint*. The valid states are two Passing, one Passing and one Endpoint,
or two Endpoints. With fewer than two Passing streets, Endpoint pairs are
fused, straightest first, until there are two; with more than two, all but
the two most important are split there and become Endpoints. Endpoints left
over lose the junction: they are cut back to their previous junction,
except that one (or two, with no Passing street) may stay when no two
Passing streets could be made.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

from osm_expand.highways import rank
from osm_expand.model import Street, StreetNetwork
from simplify.merging import combine, end_angle
from simplify.options import SimplifyOptions
from simplify.streetset import StreetSet
from simplify.topology import lengths


def enforce_two_streets(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, dict[str, int]]:
    work = StreetSet(net.streets)
    counts = {"fused": 0, "split": 0, "cut_back": 0}
    crowded = sorted(n for n, ks in work.at.items() if len(ks) > 2)
    for node in crowded:
        if work.count(node) > 2:
            _resolve(work, net.xy, node, opts, counts)
    return net.replace(streets=work.ordered()), counts


def _importance(xy: np.ndarray, street: Street, k: int) -> tuple:
    return (rank(street.highway), -lengths(xy, street.nodes), k)


def _is_passing(street: Street, node: int) -> bool:
    return street.is_closed or (node != street.nodes[0] and node != street.nodes[-1])


def _resolve(work: StreetSet, xy: np.ndarray, node: int, opts: SimplifyOptions, counts: dict[str, int]) -> None:
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
    for k in ends[allowed:]:
        _cut_back(work, k, node)
        counts["cut_back"] += 1


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
        if a.layer_key != b.layer_key:
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
