"""A mutable working set of streets with a node → streets index.

Passes that decide one junction at a time (dead ends, two-street rule) need
to see the effect of each decision on the next; this keeps those updates
O(street length) instead of rescanning the network.
"""
from __future__ import annotations

from collections import defaultdict

from osm_expand.model import Street


class StreetSet:
    def __init__(self, streets: tuple[Street, ...] | list[Street]):
        self.streets: dict[int, Street] = {}
        self.at: defaultdict[int, set[int]] = defaultdict(set)
        self._next = 0
        for s in streets:
            self.add(s)

    def add(self, street: Street) -> int:
        k = self._next
        self._next += 1
        self.streets[k] = street
        for n in street.nodes:
            self.at[n].add(k)
        return k

    def remove(self, k: int) -> Street:
        street = self.streets.pop(k)
        for n in street.nodes:
            self.at[n].discard(k)
        return street

    def replace(self, k: int, street: Street) -> None:
        self.remove(k)
        self.streets[k] = street
        for n in street.nodes:
            self.at[n].add(k)

    def count(self, node: int) -> int:
        return len(self.at.get(node, ()))

    def ordered(self) -> tuple[Street, ...]:
        """Streets in insertion order, so results do not depend on hashing."""
        return tuple(self.streets[k] for k in sorted(self.streets))
