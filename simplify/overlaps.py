"""Pass 3 (004 §4.2.1): remove overlapping duplicates and small loops.

Two street pieces joining the same two junctions are one road drawn twice
(a lay-by, a split carriageway, two ways on the same nodes) when they stay
within ``overlap_tolerance`` of each other on the same layer; the less
important one goes. A tunnel or bridge beside a surface road is not a copy.
Pieces that leave a junction and come back to it shorter than
``small_loop_length`` go too. Pieces far apart (a real two-sided block) stay.

A duplicate or loop can be the only cycle that keeps a stretch of road from
being a dead end (a dual carriageway leading off the map, a turning loop).
Callers pass such pieces, by their junction pair, in ``exempt``.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np
import shapely

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.highways import rank
from osm_expand.model.network import pair_keys
from osm_expand.model.topology import clean_nodes, junction_mask, lengths, piece_table
from simplify.options import SimplifyOptions

PieceKey = tuple[int, int]
#: Pieces closer than this (m) are the same line drawn twice and always go.
IDENTICAL = 1.0


def remove_overlaps(net: StreetNetwork, opts: SimplifyOptions,
                    exempt: frozenset[PieceKey] = frozenset()) -> tuple[StreetNetwork, list[PieceKey]]:
    """Returns the network and the junction pairs of the removed pieces."""
    return OverlapPlan(net, opts).remove(exempt)


class OverlapPlan:
    """One network's pieces, loops and duplicate groups, found once for any number of exemption sets.

    A group's decision depends only on its tolerance, so it is remembered:
    trying a larger ``exempt`` re-decides only the groups it exempts.
    """

    def __init__(self, net: StreetNetwork, opts: SimplifyOptions):
        self.net, self.opts = net, opts
        table = piece_table(net.streets, junction_mask(net.streets, len(net.xy)))
        self.loops = list(_loops(table))
        self.groups = _parallel_groups(table)
        self.street_len = _LazyLengths(net)
        self.decided: dict[tuple[PieceKey, float], list[tuple[int, int, int]]] = {}
        self.short_loop: dict[int, bool] = {}

    def remove(self, exempt: frozenset[PieceKey] = frozenset()) -> tuple[StreetNetwork, list[PieceKey]]:
        """The network without the removed pieces, and their junction pairs."""
        net = self.net
        drop: defaultdict[int, list[tuple[int, int]]] = defaultdict(list)
        for i, (k, a, b, u) in enumerate(self.loops):
            if (u, u) not in exempt and self._short(i):
                drop[k].append((a, b))
        for key in self.groups:
            # an exempt pair still loses exact copies: two streets on the same line cross everywhere
            for k, a, b in self._duplicates(key, IDENTICAL if key in exempt else self.opts.overlap_tolerance):
                drop[k].append((a, b))
        if not drop:
            return net, []
        streets: list[Street] = []
        removed: list[PieceKey] = []
        for k, street in enumerate(net.streets):
            streets.extend(cut_out(street, drop[k]) if k in drop else [street])
            for a, b in drop.get(k, ()):
                u, v = street.nodes[a], street.nodes[b]
                removed.append((min(u, v), max(u, v)))
        return net.replace(streets=tuple(streets)), removed

    def _short(self, i: int) -> bool:
        if i not in self.short_loop:
            k, a, b, _ = self.loops[i]
            self.short_loop[i] = lengths(self.net.xy, self.net.streets[k].nodes[a:b + 1]) < self.opts.small_loop_length
        return self.short_loop[i]

    def _duplicates(self, key: PieceKey, tolerance: float) -> list[tuple[int, int, int]]:
        if (key, tolerance) not in self.decided:
            self.decided[key, tolerance] = _duplicates(self.net, self.groups[key], self.street_len, tolerance)
        return self.decided[key, tolerance]


def _loops(table: dict[str, np.ndarray]):
    """Pieces that leave a junction and return to it: (street, a, b, node)."""
    sel = np.flatnonzero(table["u"] == table["v"])
    return zip(*(table[c][sel].tolist() for c in ("street", "a", "b", "u")))


def _parallel_groups(table: dict[str, np.ndarray]) -> dict[PieceKey, list[tuple[int, int, int]]]:
    """Pieces grouped by their (unordered) junction pair, only pairs joined more than once."""
    u, v = table["u"], table["v"]
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    ok = lo != hi
    keys = pair_keys(u, v)
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    sel = np.flatnonzero(ok & (counts[inverse] > 1))
    groups: defaultdict[PieceKey, list[tuple[int, int, int]]] = defaultdict(list)
    for i in sel.tolist():
        groups[(int(lo[i]), int(hi[i]))].append((int(table["street"][i]), int(table["a"][i]), int(table["b"][i])))
    return groups


class _LazyLengths:
    """Street lengths, computed only for the few streets that have duplicates."""

    def __init__(self, net: StreetNetwork):
        self.net = net
        self.cache: dict[int, float] = {}

    def __getitem__(self, k: int) -> float:
        if k not in self.cache:
            self.cache[k] = lengths(self.net.xy, self.net.streets[k].nodes)
        return self.cache[k]


def _duplicates(net: StreetNetwork, members, street_len, tolerance: float):
    """Members within ``tolerance`` of a more important member that is kept.

    Greedy in order of importance, so a group of three copies keeps one even
    when a distinct, more important piece joins the same junctions.
    """
    order = sorted(members, key=lambda m: (rank(net.streets[m[0]].highway), -street_len[m[0]], m[0], m[1]))
    lines = [shapely.LineString(net.xy[list(net.streets[k].nodes[a:b + 1])]) for k, a, b in order]
    layer = [net.streets[k].layer_key for k, _, _ in order]
    kept: list[int] = []
    dropped = []
    for i, member in enumerate(order):
        same_layer = [j for j in kept if layer[j] == layer[i]]  # a tunnel under a road is no copy of it
        if same_layer and np.min(shapely.hausdorff_distance([lines[j] for j in same_layer], lines[i])) <= tolerance:
            dropped.append(member)
        else:
            kept.append(i)
    return dropped


def cut_out(street: Street, ranges: list[tuple[int, int]]) -> list[Street]:
    """The parts of ``street`` left after removing the given position ranges."""
    nodes = street.nodes
    parts, start = [], 0
    for a, b in sorted(ranges):
        if a > start:
            parts.append(nodes[start:a + 1])
        start = max(start, b)
    if start < len(nodes) - 1:
        parts.append(nodes[start:])
    out = []
    for part in parts:
        cleaned = clean_nodes(part)
        if cleaned is not None:
            out.append(street.with_nodes(cleaned))
    return out
