"""Pass 7 (004 §4.2.5): merge street fragments into whole streets.

OSM splits a street wherever a tag changes. At each junction, the street
ends there are paired with the candidate closest to straight when the angle
between them exceeds ``merge_angle``; a candidate with the same name wins
over a straighter one with another name. Pairs are accepted best first and
never close a loop, then chains of pairs become single streets. Streets on
different layers never merge: a bridge stays a bridge.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import replace
from itertools import combinations

import numpy as np

from osm_expand.model import Street, StreetNetwork
from osm_expand.model.components import UnionFind
from osm_expand.model.highways import rank
from osm_expand.model.topology import end_angles, heading, headings, lengths
from simplify.options import SimplifyOptions

End = tuple[int, bool]  # (street index, True for its first node)


def end_angle(xy: np.ndarray, a: Street, a_start: bool, b: Street, b_start: bool, reach: float) -> float:
    """Angle (degrees) between two streets leaving the same node: 180 is straight on."""
    ha = heading(xy, a.nodes, a_start, reach)
    hb = heading(xy, b.nodes, b_start, reach)
    return float(end_angles(ha[None], hb[None])[0])


def merge_streets(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, int]:
    """Returns the network and how many joins were made."""
    streets = net.streets
    ends_at: defaultdict[int, list[End]] = defaultdict(list)
    for k, s in enumerate(streets):
        if not s.is_closed:
            ends_at[s.nodes[0]].append((k, True))
            ends_at[s.nodes[-1]].append((k, False))
    proposals = []
    for cands in _candidates(net, list(ends_at.values()), opts):
        proposals += _best_pairs(cands)
    proposals.sort(key=lambda p: (-p[0], -p[1], p[2], p[3]))
    chains = UnionFind(range(len(streets)))
    free_ends = {k: [s.nodes[0], s.nodes[-1]] for k, s in enumerate(streets)}
    partner: dict[End, End] = {}
    for _, _, e1, e2 in proposals:
        if e1 in partner or e2 in partner or chains.connected(e1[0], e2[0]):
            continue
        node = streets[e1[0]].nodes[0 if e1[1] else -1]
        a, b = list(free_ends[chains[e1[0]]]), list(free_ends[chains[e2[0]]])
        a.remove(node)
        b.remove(node)
        if a[0] == b[0]:  # the joined street would be a closed loop
            continue
        chains.merge(e1[0], e2[0])
        free_ends[chains[e1[0]]] = [a[0], b[0]]
        partner[e1], partner[e2] = e2, e1
    if not partner:
        return net, 0
    merged = [_join(net, group, partner) for group in _chain_groups(chains, len(streets))]
    return net.replace(streets=tuple(merged)), len(partner) // 2


Candidate = tuple[int, float, End, End]  # (same name, angle rounded to 1e-9 degrees, end, end)


def _candidates(net: StreetNetwork, groups: list[list[End]], opts: SimplifyOptions) -> list[list[Candidate]]:
    """Per group of ends meeting at a node, the pairs straighter than ``merge_angle``.

    Every pair's angle comes from one vectorised pass over all pairs
    (:func:`headings`, :func:`end_angles`), not one street walk per pair.
    """
    streets = net.streets
    pairs = [[(e1, e2) for e1, e2 in combinations(ends, 2)
              if e1[0] != e2[0] and streets[e1[0]].layer_key == streets[e2[0]].layer_key] for ends in groups]
    flat = [end for group in pairs for pair in group for end in pair]
    if not flat:
        return [[] for _ in groups]
    street = np.fromiter((k for k, _ in flat), dtype=np.intp, count=len(flat))
    first = np.fromiter((f for _, f in flat), dtype=bool, count=len(flat))
    heads = headings(net.xy, streets, street, first, opts.heading_reach)
    angles = end_angles(heads[0::2], heads[1::2]).tolist()
    out, i = [], 0
    for group in pairs:
        cands = []
        for e1, e2 in group:
            angle = angles[i]
            i += 1
            if angle > opts.merge_angle:
                a, b = streets[e1[0]], streets[e2[0]]
                same_name = bool(a.name) and a.name == b.name
                cands.append((int(same_name), round(angle, 9), e1, e2))
        out.append(cands)
    return out


def _best_pairs(cands: list[Candidate]) -> list[Candidate]:
    """Disjoint end pairs at one node, straightest (and same-named) first."""
    cands = sorted(cands, key=lambda c: (-c[0], -c[1], c[2], c[3]))
    used, out = set(), []
    for c in cands:
        if c[2] not in used and c[3] not in used:
            used |= {c[2], c[3]}
            out.append(c)
    return out


def _chain_groups(chains: UnionFind, n: int) -> list[list[int]]:
    groups: dict[int, list[int]] = {}
    for k in range(n):
        groups.setdefault(chains[k], []).append(k)
    return sorted(groups.values(), key=lambda g: g[0])


def _join(net: StreetNetwork, group: list[int], partner: dict[End, End]) -> Street:
    """Walk a chain from its free end and concatenate the streets in order."""
    if len(group) == 1:
        return net.streets[group[0]]
    start = next((k, first) for k in group for first in (True, False) if (k, first) not in partner)
    nodes: list[int] = []
    parts: list[Street] = []
    k, entry_first = start
    while True:
        s = net.streets[k]
        seq = s.nodes if entry_first else s.nodes[::-1]
        nodes.extend(seq if not nodes else seq[1:])
        parts.append(s)
        exit_end = (k, not entry_first)
        if exit_end not in partner:
            break
        k, entry_first = partner[exit_end]
    return combine(net.xy, parts, tuple(nodes))


def combine(xy: np.ndarray, parts: list[Street], nodes: tuple[int, ...]) -> Street:
    """One street from consecutive parts: every field of the longest part, the class with most length,
    the name of the longest named part, all OSM ids.

    The merged street is no longer one mapped way, so its OSM tags go (the
    typed fields carry what the stages need); a roundabout tag no longer holds.
    """
    lens = [lengths(xy, p.nodes) for p in parts]
    main = parts[int(np.argmax(lens))]
    named = [(ln, p.name) for ln, p in zip(lens, parts) if p.name]
    by_class: defaultdict[str, float] = defaultdict(float)
    for ln, p in zip(lens, parts):
        by_class[p.highway] += ln
    best_class = max(sorted(by_class), key=lambda h: (by_class[h], -rank(h)))
    ids = tuple(dict.fromkeys(i for p in parts for i in p.osm_ids))
    return replace(main, nodes=nodes, highway=best_class, name=max(named)[1] if named else None, junction=None,
                   osm_ids=ids, tags=() if len(parts) > 1 else main.tags)
