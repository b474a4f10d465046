"""Pass 2 (004 §4.2.1): remove dead ends, iteratively.

A street end that is not a junction is cut back to the street's nearest
junction; a street left with nothing between junctions disappears, which can
turn its last junction into a new dead end, so whole cul-de-sac trees go.
What is removed is recorded (where it hung, how long, which class), because
the synthesiser must put dead ends back in the town's proportion (004 §6.2).

The pass is a worklist: only streets with an open end are visited, plus the
streets whose end a removal turns into a new dead end, so a network with few
dead ends costs a few vectorised counts, not a walk over every street. The
visiting order (highest street index first, a new dead end right after the
removal that made it) is that of a queue over every street, whose other
visits change nothing, so the result does not depend on the shortcut.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.topology import flat_nodes, lengths, street_counts


@dataclass(frozen=True)
class DeadEnd:
    """A removed dead-end piece: the junction it hung from (-1 if none) and its length."""

    attach: int
    length: float
    highway: str


@dataclass(frozen=True)
class Pruned:
    """A pruned network, what was cut off, and the nodes no street references any more."""

    network: StreetNetwork
    dead: list[DeadEnd]
    lost: frozenset[int]


def dead_end_count(net: StreetNetwork, counts: np.ndarray | None = None) -> int:
    """Open street ends that no other street shares (``counts``: :func:`street_counts`, if at hand)."""
    counts = street_counts(net.streets, len(net.xy)) if counts is None else counts
    return int((counts[_open_ends(net.streets)] < 2).sum())


def prune_dead_ends(net: StreetNetwork) -> tuple[StreetNetwork, list[DeadEnd]]:
    pruned = prune(net)
    return pruned.network, pruned.dead


def prune(net: StreetNetwork) -> Pruned:
    """:func:`prune_dead_ends`, also naming the nodes it left unused (what overlap removal asks)."""
    counts = street_counts(net.streets, len(net.xy))
    ends = _open_ends(net.streets).reshape(-1, 2)
    dead = (counts[ends] < 2).any(axis=1)
    if not dead.any():
        return Pruned(net, [], frozenset())
    closed = np.fromiter((s.is_closed for s in net.streets), dtype=bool, count=len(net.streets))
    open_ids = np.flatnonzero(~closed)
    work = _Work(net, counts)
    work.run(open_ids[dead].tolist())
    kept = tuple(s for s in work.streets if s is not None)
    lost = frozenset(n for n in work.touched if work.counts[n] == 0)
    return Pruned(net.replace(streets=kept), work.removed, lost)


def _open_ends(streets: tuple[Street, ...]) -> np.ndarray:
    """First and last node of every street that is not a ring, interleaved."""
    return np.fromiter((n for s in streets if not s.is_closed for n in (s.nodes[0], s.nodes[-1])), dtype=np.int64)


class _Work:
    """Streets being pruned, with how many streets reference each node, kept up to date."""

    def __init__(self, net: StreetNetwork, counts: np.ndarray):
        self.xy = net.xy
        self.original = net.streets
        self.streets: list[Street | None] = list(net.streets)
        self.counts = counts
        self.removed: list[DeadEnd] = []
        self.touched: set[int] = set()
        self._at: tuple[np.ndarray, np.ndarray] | None = None

    def run(self, queue: list[int]) -> None:
        """Visit ``queue`` from its end; a street whose end a removal frees is visited next."""
        while queue:
            k = queue.pop()
            street = self.streets[k]
            if street is None or street.is_closed:
                continue
            queue.extend(self._visit(k, street))

    def _visit(self, k: int, street: Street) -> list[int]:
        nodes = street.nodes
        start = self._first_junction(nodes)
        if start is None:  # touches nothing: the whole street is a dead end
            self.removed.append(DeadEnd(-1, lengths(self.xy, nodes), street.highway))
            self._set(k, None)
            return []
        back = self._first_junction(nodes[::-1])
        assert back is not None  # start found a junction, so the search from the other end does too
        end = len(nodes) - 1 - back
        if start > 0:
            self.removed.append(DeadEnd(nodes[start], lengths(self.xy, nodes[:start + 1]), street.highway))
        if end < len(nodes) - 1:
            self.removed.append(DeadEnd(nodes[end], lengths(self.xy, nodes[end:]), street.highway))
        if start == 0 and end == len(nodes) - 1:
            return []
        if end - start < 1:  # shrank to one junction: the street goes
            self._set(k, None)
            return self._new_dead_ends(nodes[start])
        self._set(k, street.with_nodes(nodes[start:end + 1]))
        return []

    def _first_junction(self, nodes: tuple[int, ...]) -> int | None:
        counts = self.counts
        for i, n in enumerate(nodes):
            if counts[n] >= 2:
                return i
        return None

    def _set(self, k: int, street: Street | None) -> None:
        """Replace (or with None remove) street ``k``; a node it no longer has loses one street."""
        old = self.streets[k]
        assert old is not None, "a removed street is never set again"
        gone = set(old.nodes).difference(street.nodes if street is not None else ())
        for n in gone:
            self.counts[n] -= 1
        self.touched |= gone
        self.streets[k] = street

    def _new_dead_ends(self, node: int) -> list[int]:
        """Streets that now end at ``node`` without anyone else there."""
        if self.counts[node] != 1:
            return []
        (k,) = (j for j in self._streets_at(node) if (t := self.streets[j]) is not None and node in t.nodes)
        s = self.streets[k]
        assert s is not None  # chosen above among the streets still there
        return [k] if node in (s.nodes[0], s.nodes[-1]) and not s.is_closed else []

    def _streets_at(self, node: int) -> set[int]:
        """The streets that referenced ``node`` before pruning (an index built on first use)."""
        if self._at is None:
            nodes, owner = flat_nodes(self.original)
            order = np.argsort(nodes, kind="stable")
            self._at = (nodes[order], owner[order])
        nodes, owner = self._at
        lo, hi = np.searchsorted(nodes, [node, node + 1])
        return set(owner[lo:hi].tolist())


def dead_end_summary(items: list[DeadEnd]) -> dict[str, float]:
    total = float(np.sum([d.length for d in items])) if items else 0.0
    return {"dead_ends_removed": len(items), "dead_end_length_m": round(total, 1)}
