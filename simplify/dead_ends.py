"""Pass 2 (004 §4.2.1): remove dead ends, iteratively.

A street end that is not a junction is cut back to the street's nearest
junction; a street left with nothing between junctions disappears, which can
turn its last junction into a new dead end, so whole cul-de-sac trees go.
What is removed is recorded (where it hung, how long, which class), because
the synthesiser must put dead ends back in the town's proportion (004 §6.2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from osm_expand.model import StreetNetwork
from simplify.streetset import StreetSet
from osm_expand.model.topology import lengths, street_counts


@dataclass(frozen=True)
class DeadEnd:
    """A removed dead-end piece: the junction it hung from (-1 if none) and its length."""

    attach: int
    length: float
    highway: str


def dead_end_count(net: StreetNetwork, counts: np.ndarray | None = None) -> int:
    """Open street ends that no other street shares (``counts``: :func:`street_counts`, if at hand)."""
    counts = street_counts(net.streets, len(net.xy)) if counts is None else counts
    ends = np.array([(s.nodes[0], s.nodes[-1]) for s in net.streets if not s.is_closed], dtype=np.int64)
    return int((counts[ends.ravel()] < 2).sum())


def has_dead_end(net: StreetNetwork) -> bool:
    """Vectorised check, so clean networks skip the incremental pass entirely."""
    return dead_end_count(net) > 0


def prune_dead_ends(net: StreetNetwork) -> tuple[StreetNetwork, list[DeadEnd]]:
    if not has_dead_end(net):
        return net, []
    work = StreetSet(net.streets)
    removed: list[DeadEnd] = []
    queue = sorted(work.streets)
    while queue:
        k = queue.pop()
        if k not in work.streets:
            continue
        street = work.streets[k]
        if street.is_closed:
            continue
        nodes = list(street.nodes)
        start = _first_junction(work, nodes)
        if start is None:  # touches nothing: the whole street is a dead end
            removed.append(DeadEnd(-1, lengths(net.xy, nodes), street.highway))
            work.remove(k)
            continue
        end = len(nodes) - 1 - _first_junction(work, nodes[::-1])
        if start > 0:
            removed.append(DeadEnd(nodes[start], lengths(net.xy, nodes[:start + 1]), street.highway))
        if end < len(nodes) - 1:
            removed.append(DeadEnd(nodes[end], lengths(net.xy, nodes[end:]), street.highway))
        if start == 0 and end == len(nodes) - 1:
            continue
        if end - start < 1:  # shrank to one junction: the street goes
            work.remove(k)
            queue.extend(_new_dead_ends(work, nodes[start]))
        else:
            work.replace(k, street.with_nodes(nodes[start:end + 1]))
    return net.replace(streets=work.ordered()), removed


def _first_junction(work: StreetSet, nodes: list[int]) -> int | None:
    for i, n in enumerate(nodes):
        if work.count(n) >= 2:
            return i
    return None


def _new_dead_ends(work: StreetSet, node: int) -> list[int]:
    """Streets that now end at ``node`` without anyone else there."""
    if work.count(node) != 1:
        return []
    (k,) = work.at[node]
    s = work.streets[k]
    return [k] if node in (s.nodes[0], s.nodes[-1]) and not s.is_closed else []


def dead_end_summary(items: list[DeadEnd]) -> dict[str, float]:
    total = float(np.sum([d.length for d in items])) if items else 0.0
    return {"dead_ends_removed": len(items), "dead_end_length_m": round(total, 1)}
